/* disk.c — ray / disk-splat intersection and deep blending (Kashyap 2010,
 * §3.3 eq. 3.1, §3.5, §3.6). See disk.h.
 *
 * Invariants:
 *  1. a hit counts in exactly one leaf: the one whose half-open interval
 *     [t0, t1) holds its t (a disk is referenced by every leaf it overlaps);
 *  2. only crossings the ray's face flags accept are found or blended
 *     (front face: dot(dir, n) < 0), so a secondary ray ignores the disks of
 *     the surface it leaves without any distance epsilon (§3.6);
 *  3. the blend window is fixed by the nearest hit and never moves after;
 *  4. only hits that face the ray the way the nearest one does are blended:
 *     the back of a two-sided sheet thinner than the window is not mixed in.
 */
#include "surface/disk.h"

#include <math.h>

void sg_disk_blend_init(sg_disk_blend *b, float window)
{
    b->t_near = INFINITY;
    b->t_end = INFINITY;
    b->window = window;
    b->facing = 0.0f;
    b->wsum = 0.0f;
    b->psum = sg_v3(0, 0, 0);
    b->nsum = sg_v3(0, 0, 0);
    b->wmax = 0.0f;
    b->best = SG_INVALID_ID;
}

/* Ray parameter of the hit with disk i, or NAN when there is none or the
 * face is not accepted; *w gets the blend weight 1 - dist / r and *dn_out
 * the cosine dir . n. */
static inline float disk_hit(const sg_splat_soa *s, size_t i, const sg_ray *ray, float *w, float *dn_out)
{
    float dn = ray->dir.x * s->nx[i] + ray->dir.y * s->ny[i] + ray->dir.z * s->nz[i];
    *dn_out = dn;
    if ((ray->flags & SG_RAY_FRONT_ONLY) && !(dn < 0.0f))
        return NAN;
    if ((ray->flags & SG_RAY_BACK_ONLY) && !(dn > 0.0f))
        return NAN;
    if (dn == 0.0f)
        return NAN;
    float qx = s->px[i] - ray->org.x, qy = s->py[i] - ray->org.y, qz = s->pz[i] - ray->org.z;
    float t = (qx * s->nx[i] + qy * s->ny[i] + qz * s->nz[i]) / dn;
    float ex = t * ray->dir.x - qx, ey = t * ray->dir.y - qy, ez = t * ray->dir.z - qz;
    float d2 = ex * ex + ey * ey + ez * ez, r2 = s->r[i] * s->r[i];
    if (!(d2 < r2))
        return NAN;
    if (sg_ray_is_self(ray, t, sg_v3(s->nx[i], s->ny[i], s->nz[i])))
        return NAN;
    *w = 1.0f - sqrtf(d2) * s->inv_r[i];
    return t;
}

void sg_disk_leaf(const sg_splat_soa *s, size_t first, size_t count, const sg_ray *ray, float t0, float t1,
                  sg_disk_blend *b)
{
    size_t end = first + count;
    if (isinf(b->t_near)) {
        size_t nearest = end;
        float facing = 0.0f;
        for (size_t i = first; i < end; ++i) {
            float w, dn, t = disk_hit(s, i, ray, &w, &dn);
            if (t >= t0 && t < t1 && t < b->t_near) {
                b->t_near = t;
                nearest = i;
                facing = dn;
            }
        }
        if (nearest == end)
            return;
        b->facing = facing < 0.0f ? -1.0f : 1.0f;
        b->t_end = b->t_near + b->window * s->r[nearest];
    }
    float lo = t0 > b->t_near ? t0 : b->t_near;
    float hi = t1;
    for (size_t i = first; i < end; ++i) {
        float w, dn, t = disk_hit(s, i, ray, &w, &dn);
        if (!(t >= lo && t < hi && t <= b->t_end) || !(dn * b->facing > 0.0f))
            continue;
        b->wsum += w;
        b->psum = sg_v3_madd(b->psum, sg_v3_madd(ray->org, ray->dir, t), w);
        b->nsum = sg_v3_madd(b->nsum, sg_v3(s->nx[i], s->ny[i], s->nz[i]), w);
        if (w > b->wmax) {
            b->wmax = w;
            b->best = s->id[i];
        }
    }
}

int sg_disk_leaf_any(const sg_splat_soa *s, size_t first, size_t count, const sg_ray *ray, float t0, float t1)
{
    for (size_t i = first; i < first + count; ++i) {
        float w, dn, t = disk_hit(s, i, ray, &w, &dn);
        if (t >= t0 && t <= t1)
            return 1;
    }
    return 0;
}

int sg_disk_blend_finish(const sg_disk_blend *b, const sg_ray *ray, sg_hit *hit)
{
    if (isinf(b->t_near) || !(b->wsum > 0.0f))
        return 0;
    sg_vec3 p = sg_v3_scale(b->psum, 1.0f / b->wsum);
    /* Report t of the blended point projected on the ray, so t and p agree. */
    hit->t = sg_v3_dot(sg_v3_sub(p, ray->org), ray->dir);
    hit->p = p;
    hit->n = sg_v3_normalize(b->nsum);
    hit->splat = b->best;
    return 1;
}
