/* truth.c — exact ray casts against the shapes the stability cases were
 * sampled from, and the per-view comparison with the splat surface.
 *
 * Invariants:
 *  1. A part's normal is its outward normal whatever side the ray comes
 *     from (seen from inside a sphere it points away from the camera), so a
 *     splat normal oriented the wrong way scores 180 deg.
 *  2. Intersections are computed in double precision, so scenes at 1e-3
 *     and 1e4 units are traced as accurately as unit ones.
 */
#include "verify/truth.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"

static sg_status add_part(sg_truth *t, sg_truth_part p, sg_error *err)
{
    if (t->count >= SG_TRUTH_MAX_PARTS)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "truth: more than %d parts", SG_TRUTH_MAX_PARTS);
    t->parts[t->count++] = p;
    return SG_OK;
}

sg_status sg_truth_add_sphere(sg_truth *t, sg_vec3 centre, float radius, sg_error *err)
{
    return add_part(t, (sg_truth_part){.kind = SG_TRUTH_SPHERE, .a = centre, .r = radius}, err);
}

sg_status sg_truth_add_box(sg_truth *t, sg_vec3 lo, sg_vec3 hi, sg_error *err)
{
    return add_part(t, (sg_truth_part){.kind = SG_TRUTH_BOX, .a = lo, .b = hi}, err);
}

sg_status sg_truth_add_rect(sg_truth *t, float y, float x0, float x1, float z0, float z1, sg_error *err)
{
    return add_part(t, (sg_truth_part){.kind = SG_TRUTH_RECT, .a = sg_v3(x0, y, z0), .b = sg_v3(x1, y, z1)}, err);
}

sg_status sg_truth_add_mesh(sg_truth *t, const sg_mesh *m, sg_vec3 translate, float scale, sg_error *err)
{
    if (m->triangle_count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "truth: mesh has no triangles");
    if (m->triangle_count > SIZE_MAX / (9 * sizeof(float)))
        return sg_error_set(err, SG_ERR_NOMEM, "truth: mesh too large");
    float *tri = malloc(m->triangle_count * 9 * sizeof(float));
    if (!tri)
        return sg_error_set(err, SG_ERR_NOMEM, "truth: out of memory for %zu triangles", m->triangle_count);
    for (size_t i = 0; i < m->triangle_count; i++)
        for (int v = 0; v < 3; v++) {
            const float *p = m->positions + 3 * (size_t)m->triangles[3 * i + v];
            tri[9 * i + 3 * v + 0] = translate.x + scale * p[0];
            tri[9 * i + 3 * v + 1] = translate.y + scale * p[1];
            tri[9 * i + 3 * v + 2] = translate.z + scale * p[2];
        }
    sg_status st = add_part(t, (sg_truth_part){.kind = SG_TRUTH_MESH, .tri = tri, .tri_count = m->triangle_count},
                            err);
    if (st != SG_OK)
        free(tri);
    return st;
}

void sg_truth_free(sg_truth *t)
{
    if (!t)
        return;
    for (int i = 0; i < t->count; i++)
        free(t->parts[i].tri);
    memset(t, 0, sizeof *t);
}

typedef struct dray {
    double o[3], d[3], tmin, tmax;
} dray;

/* Nearest root of |o + t d - c|^2 = r^2 in (tmin, tmax]. */
static int hit_sphere(const sg_truth_part *p, const dray *r, double *t, double n[3])
{
    double oc[3] = {r->o[0] - p->a.x, r->o[1] - p->a.y, r->o[2] - p->a.z};
    double b = oc[0] * r->d[0] + oc[1] * r->d[1] + oc[2] * r->d[2];
    double c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - (double)p->r * p->r;
    double disc = b * b - c;
    if (disc < 0)
        return 0;
    double s = sqrt(disc), roots[2] = {-b - s, -b + s};
    for (int i = 0; i < 2; i++)
        if (roots[i] > r->tmin && roots[i] <= r->tmax) {
            *t = roots[i];
            for (int k = 0; k < 3; k++)
                n[k] = (oc[k] + roots[i] * r->d[k]) / p->r;
            return 1;
        }
    return 0;
}

/* Slab test; the entry face (or, from inside, the exit face) gives the normal. */
static int hit_box(const sg_truth_part *p, const dray *r, double *t, double n[3])
{
    double lo[3] = {p->a.x, p->a.y, p->a.z}, hi[3] = {p->b.x, p->b.y, p->b.z};
    double t0 = -INFINITY, t1 = INFINITY;
    int a0 = -1, a1 = -1, s0 = 0, s1 = 0;
    for (int k = 0; k < 3; k++) {
        if (r->d[k] == 0.0) {
            if (r->o[k] < lo[k] || r->o[k] > hi[k])
                return 0;
            continue;
        }
        double ta = (lo[k] - r->o[k]) / r->d[k], tb = (hi[k] - r->o[k]) / r->d[k];
        int sa = -1, sb = 1;
        if (ta > tb) {
            double x = ta;
            ta = tb;
            tb = x;
            sa = 1;
            sb = -1;
        }
        if (ta > t0) {
            t0 = ta;
            a0 = k;
            s0 = sa;
        }
        if (tb < t1) {
            t1 = tb;
            a1 = k;
            s1 = sb;
        }
    }
    if (t0 > t1)
        return 0;
    n[0] = n[1] = n[2] = 0;
    if (t0 > r->tmin && t0 <= r->tmax && a0 >= 0) {
        *t = t0;
        n[a0] = s0;
        return 1;
    }
    if (t1 > r->tmin && t1 <= r->tmax && a1 >= 0) {
        *t = t1;
        n[a1] = s1;
        return 1;
    }
    return 0;
}

static int hit_rect(const sg_truth_part *p, const dray *r, double *t, double n[3])
{
    if (r->d[1] == 0.0)
        return 0;
    double tt = (p->a.y - r->o[1]) / r->d[1];
    if (!(tt > r->tmin && tt <= r->tmax))
        return 0;
    double x = r->o[0] + tt * r->d[0], z = r->o[2] + tt * r->d[2];
    if (x < p->a.x || x > p->b.x || z < p->a.z || z > p->b.z)
        return 0;
    *t = tt;
    n[0] = n[2] = 0;
    n[1] = 1;
    return 1;
}

/* Moller-Trumbore, double precision; nearest over all triangles. */
static int hit_mesh(const sg_truth_part *p, const dray *r, double *t, double n[3])
{
    double best = r->tmax;
    int found = 0;
    for (size_t i = 0; i < p->tri_count; i++) {
        const float *v = p->tri + 9 * i;
        double e1[3], e2[3], pv[3], tv[3], qv[3];
        for (int k = 0; k < 3; k++) {
            e1[k] = (double)v[3 + k] - v[k];
            e2[k] = (double)v[6 + k] - v[k];
        }
        pv[0] = r->d[1] * e2[2] - r->d[2] * e2[1];
        pv[1] = r->d[2] * e2[0] - r->d[0] * e2[2];
        pv[2] = r->d[0] * e2[1] - r->d[1] * e2[0];
        double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
        if (det == 0.0)
            continue;
        double inv = 1.0 / det;
        for (int k = 0; k < 3; k++)
            tv[k] = r->o[k] - v[k];
        double u = (tv[0] * pv[0] + tv[1] * pv[1] + tv[2] * pv[2]) * inv;
        if (u < 0.0 || u > 1.0)
            continue;
        qv[0] = tv[1] * e1[2] - tv[2] * e1[1];
        qv[1] = tv[2] * e1[0] - tv[0] * e1[2];
        qv[2] = tv[0] * e1[1] - tv[1] * e1[0];
        double w = (r->d[0] * qv[0] + r->d[1] * qv[1] + r->d[2] * qv[2]) * inv;
        if (w < 0.0 || u + w > 1.0)
            continue;
        double tt = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) * inv;
        if (tt > r->tmin && tt <= best) {
            best = tt;
            found = 1;
            double c[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                           e1[0] * e2[1] - e1[1] * e2[0]};
            double l = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
            for (int k = 0; k < 3; k++)
                n[k] = l > 0 ? c[k] / l : 0;
        }
    }
    if (found)
        *t = best;
    return found;
}

int sg_truth_intersect(const sg_truth *t, const sg_ray *ray, float *t_out, sg_vec3 *n_out)
{
    dray r = {{ray->org.x, ray->org.y, ray->org.z}, {ray->dir.x, ray->dir.y, ray->dir.z}, ray->tmin, ray->tmax};
    int found = 0;
    double best = INFINITY, bn[3] = {0, 0, 0};
    for (int i = 0; i < t->count; i++) {
        const sg_truth_part *p = &t->parts[i];
        double tt, n[3];
        int h = 0;
        switch (p->kind) {
        case SG_TRUTH_SPHERE: h = hit_sphere(p, &r, &tt, n); break;
        case SG_TRUTH_BOX: h = hit_box(p, &r, &tt, n); break;
        case SG_TRUTH_RECT: h = hit_rect(p, &r, &tt, n); break;
        case SG_TRUTH_MESH: h = hit_mesh(p, &r, &tt, n); break;
        }
        if (h && tt < best) {
            best = tt;
            memcpy(bn, n, sizeof bn);
            found = 1;
            r.tmax = tt;
        }
    }
    if (found) {
        *t_out = (float)best;
        *n_out = sg_v3((float)bn[0], (float)bn[1], (float)bn[2]);
    }
    return found;
}

sg_status sg_truth_compare_view(const sg_truth *t, const sg_world *w, const sg_camera *cam, int width, int height,
                                sg_truth_view_stats *out, sg_error *err)
{
    if (width < 1 || height < 1 || width > SG_IMAGE_MAX_DIM || height > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "truth view: bad size %dx%d", width, height);
    size_t tp = 0, holes = 0, spills = 0, both = 0, flipped = 0, nonfinite = 0;
    double angle_sum = 0;
    long n = (long)width * height;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : tp, holes, spills, both, flipped, nonfinite, angle_sum)
    for (long i = 0; i < n; i++) {
        int x = (int)(i % width), y = (int)(i / width);
        sg_ray ray = sg_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, width, height);
        /* The exact surface, as the reference sees it (ref/pathtrace.c):
         * with the pixel's footprint the ISO's coarse node planes cover
         * holes its full-detail surface keeps, and the map measured the
         * viewer's picture instead of the surface's. */
        ray.spread = 0.0f;
        float tt;
        sg_vec3 nt;
        int ht = sg_truth_intersect(t, &ray, &tt, &nt);
        sg_world_hit wh;
        int hs = sg_world_intersect(w, &ray, &wh, NULL);
        if (ht)
            tp++;
        if (ht && !hs)
            holes++;
        if (!ht && hs)
            spills++;
        if (ht && hs) {
            if (!sg_v3_isfinite(wh.hit.n)) {
                nonfinite++;
                continue;
            }
            both++;
            double c = (double)sg_v3_dot(sg_v3_normalize(wh.hit.n), nt);
            c = c > 1 ? 1 : c < -1 ? -1 : c;
            angle_sum += acos(c) * (180.0 / 3.14159265358979323846);
            if (c < 0)
                flipped++;
        }
    }
    sg_truth_view_stats s = {.pixels = (size_t)n, .truth_pixels = tp, .holes = holes, .spills = spills,
                             .both = both, .flipped = flipped, .nonfinite_normals = nonfinite};
    s.hole_rate = tp ? (double)holes / (double)tp : 0.0;
    s.spill_rate = (size_t)n > tp ? (double)spills / (double)((size_t)n - tp) : 0.0;
    s.normal_error_deg = both ? angle_sum / (double)both : 0.0;
    s.flipped_rate = both ? (double)flipped / (double)both : 0.0;
    *out = s;
    return SG_OK;
}
