/* bench_leaks — where and why rays slip through closed splat surfaces
 * (issue 12). A diagnostic, not a speed benchmark.
 *
 * It samples a closed scanned mesh to splats (sg_model_points_load, the
 * scene files' path), optionally on the builtin ground, and traces the
 * reference renderer's paths through a close portrait camera: camera rays
 * through jittered pixel points, cosine-sampled bounces from the shading
 * normal turned to the arriving ray, one cosine-sampled shadow ray per
 * vertex, sg_world_spawn_ray for every secondary ray (pathtrace.c's
 * geometry; no radiance is computed). Every ray is checked against the
 * mesh the splats came from (Embree triangles; the ground as a one-sided
 * rectangle):
 *
 *   back hit   the splat surface is met from behind, dot(dir, n) > 0, by a
 *              ray that expected a front face: a camera ray (the camera is
 *              outside every model) or a ray spawned outwards
 *              (SG_RAY_FRONT_ONLY). On a closed model seen from outside
 *              each one follows a leak, and the path, whose shading normal
 *              is turned to the arriving ray, continues as if inside.
 *   tunnel     the ray crosses a front face of the mesh (entering it)
 *              more than one splat radius after its origin and more than
 *              one radius before its splat hit (or anywhere, when it
 *              misses), through material at least SLAB_MIN = 0.25 radii
 *              thick (the chord to the mesh's next crossing times |cos|
 *              at the entry: a slab's thickness): it went through a real
 *              surface without stopping, which leaks light whether or not
 *              a back hit follows. Shadow rays are counted the same way
 *              (unoccluded, yet the mesh blocks them). Thinner crossings
 *              are "slivers": a ray clipping a rounded edge or a grazing
 *              ray a few hundredths of a radius off the mesh, below what
 *              splats of radius r resolve; they are counted apart.
 *
 * Each event's ray is then traced again with one thing changed, to name
 * its cause: the seamless self test off (self_r = 0); the kd-tree built
 * without §3.4.1 cell shrinking; 64 samples per leaf interval and a
 * spacing of at most 0.05 radii; the ray accepting any face. A variant
 * "fixes" a tunnel when it stops within one radius of the mesh crossing;
 * a back hit, when it returns a front-facing hit no farther than the
 * original one. The mesh then says, for the events no variant fixes,
 * whether a real surface lies near the hit (within 2 radii) and which way
 * it faces.
 *
 * Output: counts and shares on stdout. Deterministic for any thread count
 * (per-path random numbers; events sorted by path before the retrace).
 */
#include <embree3/rtcore.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bench_common.h"
#include "core/alloc.h"
#include "core/cli.h"
#include "io/image.h"
#include "io/mesh.h"
#include "io/scene_file.h"
#include "math/rng.h"
#include "render/camera.h"
#include "render/render.h"
#include "render/world.h"

#define MODEL_LENGTH 10.0f /* longest side of the placed model, world units */
#define MAX_EVENTS 200000

static const char usage[] =
    "usage: bench_leaks --mesh PATH [options]\n"
    "  --points N        samples on the mesh (default 250000)\n"
    "  --ground          stand the model on the builtin ground\n"
    "  --surface S       mls | disk (default mls)\n"
    "  --size N          image side (default 64)\n"
    "  --spp N           paths per pixel (default 8)\n"
    "  --depth N         bounces per path (default 8)\n"
    "  --frame y0,y1     frame this height range, fractions of the model (default 0.62,0.92)\n"
    "  --box x0,y0,z0,x1,y1,z1  frame this box instead, fractions of the model's bounds\n"
    "  --view x,y,z      view direction (default 0,-0.15,-1)\n"
    "  --png FILE        write the view (normals) as PNG\n"
    "  --no-variants     skip the retrace of the events\n"
    "  --dump N          print the field of the splats facing / facing away along N events of each\n"
    "                    kind that no variant explains (--dump-all: any N events)\n"
    "  --threads N\n";

typedef struct options {
    const char *mesh, *surface, *png;
    size_t points;
    int ground, size, spp, depth, threads, variants, dump, dump_all;
    float y0, y1;
    float box[6];    /* --box; box[3] < 0: unset */
    sg_vec3 view;
} options;

/* ---- truth: the mesh (and ground rectangle) in Embree ------------------- */

typedef struct truth {
    RTCDevice dev;
    RTCScene scn;
    float *v;        /* placed vertices, 3 per vertex      */
    uint32_t *tri;   /* 3 per triangle                     */
    size_t tri_count;
    size_t ground_first; /* triangles from here are the ground's */
} truth;

/* First crossing with the truth in (t0, t1): 1 and *t, *entering, and
 * |cos| of the angle between the ray and the triangle's normal. */
static int truth_cross(const truth *tr, sg_vec3 o, sg_vec3 d, float t0, float t1, float *t, int *entering,
                       float *cosv)
{
    struct RTCRayHit rh;
    memset(&rh, 0, sizeof rh);
    rh.ray.org_x = o.x, rh.ray.org_y = o.y, rh.ray.org_z = o.z;
    rh.ray.dir_x = d.x, rh.ray.dir_y = d.y, rh.ray.dir_z = d.z;
    rh.ray.tnear = t0;
    rh.ray.tfar = t1;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    rtcIntersect1(tr->scn, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return 0;
    const uint32_t *f = tr->tri + 3 * (size_t)rh.hit.primID;
    const float *a = tr->v + 3 * f[0], *b = tr->v + 3 * f[1], *c = tr->v + 3 * f[2];
    sg_vec3 e1 = sg_v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]), e2 = sg_v3(c[0] - a[0], c[1] - a[1], c[2] - a[2]);
    sg_vec3 n = sg_v3_cross(e1, e2); /* counter-clockwise: outward (mesh.h) */
    *t = rh.ray.tfar;
    *entering = sg_v3_dot(n, d) < 0.0f;
    float nl = sg_v3_length(n);
    *cosv = nl > 0.0f ? fabsf(sg_v3_dot(n, d)) / nl : 0.0f;
    return 1;
}

/* First entering crossing in (t0, t1), skipping exits; *exited: an exit
 * came first (the ray was inside the mesh). */
static int truth_first_entry(const truth *tr, sg_vec3 o, sg_vec3 d, float t0, float t1, float *t, float *cosv,
                             int *exited)
{
    *exited = 0;
    for (int k = 0; k < 64; ++k) {
        int ent;
        if (!truth_cross(tr, o, d, t0, t1, t, &ent, cosv))
            return 0;
        if (ent)
            return 1;
        *exited = 1;
        t0 = nextafterf(*t, INFINITY);
    }
    return 0;
}

static sg_status truth_create(const sg_mesh *m, const sg_scene_transform *xf, int ground, truth *tr, sg_error *err)
{
    memset(tr, 0, sizeof *tr);
    size_t nv = m->vertex_count + (ground ? 4 : 0), nt = m->triangle_count + (ground ? 2 : 0);
    tr->v = malloc(nv * 3 * sizeof(float));
    tr->tri = malloc(nt * 3 * sizeof(uint32_t));
    if (!tr->v || !tr->tri)
        return sg_error_set(err, SG_ERR_NOMEM, "truth: out of memory");
    for (size_t i = 0; i < m->vertex_count; ++i) {
        sg_vec3 p = sg_scene_transform_point(xf, sg_v3(m->positions[3 * i], m->positions[3 * i + 1],
                                                       m->positions[3 * i + 2]));
        tr->v[3 * i] = p.x, tr->v[3 * i + 1] = p.y, tr->v[3 * i + 2] = p.z;
    }
    memcpy(tr->tri, m->triangles, m->triangle_count * 3 * sizeof(uint32_t));
    tr->ground_first = m->triangle_count;
    if (ground) {
        /* The builtin ground: y = 0, x and z in [-15, 15], facing +y. */
        size_t b = m->vertex_count;
        const float q[4][2] = {{-15, -15}, {15, -15}, {15, 15}, {-15, 15}};
        for (int k = 0; k < 4; ++k)
            tr->v[3 * (b + k)] = q[k][0], tr->v[3 * (b + k) + 1] = 0, tr->v[3 * (b + k) + 2] = q[k][1];
        uint32_t *t = tr->tri + 3 * m->triangle_count;
        /* counter-clockwise seen from +y */
        t[0] = (uint32_t)b, t[1] = (uint32_t)b + 3, t[2] = (uint32_t)b + 1;
        t[3] = (uint32_t)b + 1, t[4] = (uint32_t)b + 3, t[5] = (uint32_t)b + 2;
    }
    tr->tri_count = nt;
    tr->dev = rtcNewDevice(NULL);
    if (!tr->dev)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "truth: no Embree device");
    tr->scn = rtcNewScene(tr->dev);
    RTCGeometry g = rtcNewGeometry(tr->dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, tr->v, 0, 3 * sizeof(float), nv);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, tr->tri, 0, 3 * sizeof(uint32_t), nt);
    rtcCommitGeometry(g);
    rtcAttachGeometry(tr->scn, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(tr->scn);
    return SG_OK;
}

static void truth_free(truth *tr)
{
    if (tr->scn)
        rtcReleaseScene(tr->scn);
    if (tr->dev)
        rtcReleaseDevice(tr->dev);
    free(tr->v);
    free(tr->tri);
}

static int u64_cmp(const void *x, const void *y)
{
    uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return a < b ? -1 : a > b;
}

static int float_cmp(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

/* Boundary edges of the mesh (edges with one triangle): 0 for a closed one. */
static size_t open_edges(const sg_mesh *m)
{
    size_t ne = 3 * m->triangle_count;
    uint64_t *e = malloc(ne * sizeof *e);
    if (!e)
        return (size_t)-1;
    for (size_t i = 0; i < m->triangle_count; ++i)
        for (int k = 0; k < 3; ++k) {
            uint64_t a = m->triangles[3 * i + k], b = m->triangles[3 * i + (k + 1) % 3];
            e[3 * i + k] = a < b ? a << 32 | b : b << 32 | a;
        }
    qsort(e, ne, sizeof *e, u64_cmp);
    size_t open = 0;
    for (size_t i = 0; i < ne;) {
        size_t j = i;
        while (j < ne && e[j] == e[i])
            ++j;
        open += j - i == 1;
        i = j;
    }
    free(e);
    return open;
}

/* ---- paths ----------------------------------------------------------------- */

enum { K_CAMERA, K_FRONT, K_BACK, K_SHADOW, K_KINDS };
static const char *const kind_name[K_KINDS] = {"camera", "front-only", "back-only", "shadow"};

enum { EV_BACKHIT, EV_TUNNEL };

typedef struct event {
    uint64_t path;
    int depth, type, kind;
    sg_ray ray;
    float t_hit;     /* splat hit (INFINITY: none)            */
    float t_true;    /* the mesh crossing tunnelled through    */
    float r;         /* splat radius at the hit or the origin  */
    float slab;      /* tunnels: thickness crossed, in r       */
    float cos_hit;   /* back hits: dot(dir, n) at the hit      */
    int started_inside;
} event;

typedef struct counts {
    uint64_t paths, paths_back, paths_tunnel;
    uint64_t rays[K_KINDS], hits[K_KINDS], back[K_KINDS], tunnels[K_KINDS], slivers[K_KINDS], inside_start[K_KINDS];
    uint64_t hits_model, hits_ground, back_model, back_ground;
} counts;

typedef struct ctx {
    const sg_world *w;
    const truth *tr;
    const options *o;
    sg_camera cam;
    float r_med;
} ctx;

static sg_vec3 cosine_dir(sg_vec3 n, float u0, float u1)
{
    float r = sqrtf(u0), phi = 6.2831853f * u1;
    float x = r * cosf(phi), y = r * sinf(phi), z = sqrtf(fmaxf(0.0f, 1.0f - u0));
    sg_vec3 t = fabsf(n.x) > 0.5f ? sg_v3(0, 1, 0) : sg_v3(1, 0, 0);
    sg_vec3 b1 = sg_v3_normalize(sg_v3_cross(t, n)), b2 = sg_v3_cross(n, b1);
    return sg_v3_normalize(sg_v3_add(sg_v3_add(sg_v3_scale(b1, x), sg_v3_scale(b2, y)), sg_v3_scale(n, z)));
}

static float radius_of(const sg_world *w, const sg_world_hit *h)
{
    const sg_pointset *ps = sg_scene_points(sg_world_scene(w, h->model));
    return h->hit.splat < ps->count ? ps->radius[h->hit.splat] : 0.0f;
}

static int ray_kind(const sg_ray *r, int depth)
{
    if (depth == 0)
        return K_CAMERA;
    return r->flags & SG_RAY_BACK_ONLY ? K_BACK : K_FRONT;
}

/* The tunnel test of one ray segment: a mesh entry in (t_self, t_end),
 * and the thickness of the material the ray crosses there, measured
 * across the surface: the chord to the next crossing times |cos| at the
 * entry (a slab's thickness), in units of r. Returns 0 (none), 1 (a
 * tunnel) or 2 (a sliver: thinner than SLAB_MIN radii). */
#define SLAB_MIN 0.25f
static int tunnel_test(const ctx *c, const sg_ray *r, float t_self, float t_end, float rr, float *t_true,
                       float *slab, int *inside)
{
    float cos_in, t_out, cos_out;
    int ent;
    if (!(t_end > t_self) || !truth_first_entry(c->tr, r->org, r->dir, t_self, t_end, t_true, &cos_in, inside))
        return 0;
    *slab = truth_cross(c->tr, r->org, r->dir, nextafterf(*t_true, INFINITY), INFINITY, &t_out, &ent, &cos_out)
                ? (t_out - *t_true) * cos_in / rr
                : INFINITY;
    return *slab >= SLAB_MIN ? 1 : 2;
}

static void trace_path(const ctx *c, uint64_t path, float px, float py, counts *k, event *ev, size_t *nev,
                       size_t cap)
{
    const options *o = c->o;
    sg_ray ray = sg_camera_ray(&c->cam, px, py, o->size, o->size);
    int had_back = 0, had_tunnel = 0;
    float r_org = 0.0f;
    for (int depth = 0; depth <= o->depth; ++depth) {
        int kind = ray_kind(&ray, depth);
        sg_world_hit h;
        int hit = sg_world_intersect(c->w, &ray, &h, NULL);
        k->rays[kind]++;
        float t_self = depth == 0 ? 0.0f : r_org;
        float r_hit = hit ? radius_of(c->w, &h) : 0.0f;
        float t_end = hit ? h.hit.t - r_hit : INFINITY;
        float t_true, slab, rr = fmaxf(fmaxf(r_org, r_hit), c->r_med);
        int inside, tun = kind == K_BACK ? 0 : tunnel_test(c, &ray, t_self, t_end, rr, &t_true, &slab, &inside);
        /* Tunnels: only for rays that expect front faces (a back-only ray
         * is, by the path's own account, inside something). */
        k->slivers[kind] += (uint64_t)(tun == 2);
        if (tun == 1) {
            k->tunnels[kind]++;
            k->inside_start[kind] += (uint64_t)inside;
            had_tunnel = 1;
            if (*nev < cap)
                ev[(*nev)++] = (event){.path = path, .depth = depth, .type = EV_TUNNEL, .kind = kind, .ray = ray,
                                       .t_hit = hit ? h.hit.t : INFINITY, .t_true = t_true, .r = rr,
                                       .slab = slab, .started_inside = inside};
        }
        if (!hit)
            break;
        k->hits[kind]++;
        int is_model = h.model == 0;
        k->hits_model += (uint64_t)is_model;
        k->hits_ground += (uint64_t)!is_model;
        if (sg_v3_dot(ray.dir, h.hit.n) > 0.0f) {
            k->back[kind]++;
            k->back_model += (uint64_t)is_model;
            k->back_ground += (uint64_t)!is_model;
            if (kind != K_BACK) {
                had_back = 1;
                if (*nev < cap)
                    ev[(*nev)++] = (event){.path = path, .depth = depth, .type = EV_BACKHIT, .kind = kind,
                                           .ray = ray, .t_hit = h.hit.t, .t_true = NAN, .r = r_hit,
                                           .cos_hit = sg_v3_dot(ray.dir, h.hit.n)};
            }
        }
        if (depth == o->depth)
            break;
        uint32_t b = (uint32_t)depth + 1;
        sg_vec3 wo = sg_v3_scale(ray.dir, -1.0f);
        sg_vec3 n = sg_v3_dot(h.hit.n, wo) < 0.0f ? sg_v3_scale(h.hit.n, -1.0f) : h.hit.n;
        /* A shadow ray, cosine distributed (where an envmap sample may go). */
        sg_vec3 wl = cosine_dir(n, sg_rng_float(7, path, b, 0), sg_rng_float(7, path, b, 1));
        sg_ray sh = sg_world_spawn_ray(c->w, &h, wl, INFINITY);
        k->rays[K_SHADOW]++;
        if (!sg_world_occluded(c->w, &sh, NULL)) {
            rr = fmaxf(r_hit, c->r_med);
            tun = tunnel_test(c, &sh, r_hit, INFINITY, rr, &t_true, &slab, &inside);
            k->slivers[K_SHADOW] += (uint64_t)(tun == 2);
            if (tun == 1) {
                k->tunnels[K_SHADOW]++;
                k->inside_start[K_SHADOW] += (uint64_t)inside;
                if (*nev < cap)
                    ev[(*nev)++] = (event){.path = path, .depth = depth, .type = EV_TUNNEL, .kind = K_SHADOW,
                                           .ray = sh, .t_hit = INFINITY, .t_true = t_true, .r = rr,
                                           .slab = slab, .started_inside = inside};
            }
        } else
            k->hits[K_SHADOW]++;
        sg_vec3 wi = cosine_dir(n, sg_rng_float(7, path, b, 2), sg_rng_float(7, path, b, 3));
        ray = sg_world_spawn_ray(c->w, &h, wi, INFINITY);
        r_org = r_hit;
    }
    k->paths++;
    k->paths_back += (uint64_t)had_back;
    k->paths_tunnel += (uint64_t)had_tunnel;
}

static int event_cmp(const void *a, const void *b)
{
    const event *x = a, *y = b;
    if (x->path != y->path)
        return x->path < y->path ? -1 : 1;
    if (x->depth != y->depth)
        return x->depth < y->depth ? -1 : 1;
    return x->kind - y->kind;
}

/* The field of the splats of group sign sg (-1: facing the ray, n . d < 0;
 * +1: facing away) at x, over every splat of the model: W, the distance to
 * the local plane F / (W |N|), and the cosine of N with d. */
static void brute_field(const sg_pointset *ps, sg_vec3 x, sg_vec3 d, int sg, float *W, float *dist, float *cosn)
{
    double w_sum = 0, P[3] = {0, 0, 0}, N[3] = {0, 0, 0};
    for (size_t i = 0; i < ps->count; ++i) {
        float dn = ps->nx[i] * d.x + ps->ny[i] * d.y + ps->nz[i] * d.z;
        if (sg < 0 ? !(dn < 0.0f) : !(dn > 0.0f))
            continue;
        float dx = x.x - ps->px[i], dy = x.y - ps->py[i], dz = x.z - ps->pz[i];
        float q = sqrtf(dx * dx + dy * dy + dz * dz) / ps->radius[i];
        if (q >= 1.0f)
            continue;
        float w = 1.0f - q;
        w_sum += w;
        P[0] += w * dx, P[1] += w * dy, P[2] += w * dz;
        N[0] += w * ps->nx[i], N[1] += w * ps->ny[i], N[2] += w * ps->nz[i];
    }
    double nl = sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2]);
    *W = (float)w_sum;
    *dist = w_sum > 0 && nl > 0 ? (float)((P[0] * N[0] + P[1] * N[1] + P[2] * N[2]) / (w_sum * nl)) : NAN;
    *cosn = nl > 0 ? (float)((N[0] * d.x + N[1] * d.y + N[2] * d.z) / nl) : NAN;
}

static int dump_event(const sg_world *w, const truth *tr, const event *e)
{
    const sg_pointset *ps = sg_scene_points(sg_world_scene(w, 0));
    (void)tr;
    float tc = e->type == EV_TUNNEL ? e->t_true : e->t_hit, thick = e->slab;
    printf("  event path %llu depth %d kind %s: t_true %.4g (%.2f r), t_hit %.4g, r %.4g, self_r %.4g, "
           "slab %.2f r, self_n.d %.3f\n",
           (unsigned long long)e->path, e->depth, kind_name[e->kind], (double)e->t_true,
           (double)(e->t_true / e->r), (double)e->t_hit, (double)e->r, (double)e->ray.self_r, (double)thick,
           (double)sg_v3_dot(e->ray.self_n, e->ray.dir));
    for (int k = -8; k <= 8; ++k) {
        float t = tc + 0.25f * (float)k * e->r;
        if (t < 0.0f)
            continue;
        sg_vec3 x = sg_v3_madd(e->ray.org, e->ray.dir, t);
        float Wf, df, cf, Wb, db, cb;
        brute_field(ps, x, e->ray.dir, -1, &Wf, &df, &cf);
        brute_field(ps, x, e->ray.dir, +1, &Wb, &db, &cb);
        printf("    t %+5.2f r: front W %6.3f dist %+7.3f r cos %+6.3f | back W %6.3f dist %+7.3f r cos %+6.3f\n",
               (double)((t - tc) / e->r), (double)Wf, (double)(df / e->r), (double)cf, (double)Wb,
               (double)(db / e->r), (double)cb);
    }
    return 1;
}

/* ---- variants ---------------------------------------------------------- */

enum { V_NOSELF, V_NOSHRINK, V_DENSE, V_ANYFACE, V_COUNT };
static const char *const variant_name[V_COUNT] = {"self test off", "no cell shrinking", "dense samples",
                                                   "any face"};

/* Whether the variant's answer for event e would have been right. */
static int fixed_by(const sg_world *w, const event *e, const sg_ray *r)
{
    sg_world_hit h;
    if (e->kind == K_SHADOW && e->type == EV_TUNNEL) {
        sg_ray q = *r;
        q.tmax = e->t_true + 2.0f * e->r;
        return sg_world_occluded(w, &q, NULL);
    }
    if (!sg_world_intersect(w, r, &h, NULL))
        return 0;
    if (e->type == EV_TUNNEL)
        return h.hit.t < e->t_true + e->r && sg_v3_dot(r->dir, h.hit.n) < 0.0f;
    return sg_v3_dot(r->dir, h.hit.n) < 0.0f && h.hit.t <= e->t_hit + e->r;
}

static sg_status make_world(const options *o, const sg_ground_placement *pl, const char *surface_json,
                            sg_world **out, sg_error *err)
{
    char json[8192];
    int n = snprintf(json, sizeof json,
                     "{\"models\": [{\"path\": \"%s\", \"points\": %zu,"
                     " \"transform\": {\"translate\": [%.9g, %.9g, %.9g], \"scale\": %.9g},"
                     " \"material\": {\"type\": \"lambert\", \"albedo\": [0.7, 0.7, 0.7], \"use_point_colors\": false},"
                     " \"surface\": %s}%s], \"envmap\": {\"builtin\": \"sky\"}}",
                     o->mesh, o->points, (double)pl->translate.x, (double)pl->translate.y, (double)pl->translate.z,
                     (double)pl->scale, surface_json,
                     o->ground ? ", {\"builtin\": \"ground\", \"surface\": {\"model\": \"mls\"}}" : "");
    if (n < 0 || (size_t)n >= sizeof json)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "scene JSON too long");
    sg_scene_file sf;
    sg_status st = sg_scene_file_parse(json, (size_t)n, "bench_leaks", NULL, &sf, err);
    if (st != SG_OK)
        return st;
    st = sg_world_create(&sf, out, err);
    sg_scene_file_free(&sf);
    return st;
}

static int parse(int argc, char **argv, options *o)
{
    *o = (options){.surface = "mls", .points = 250000, .size = 64, .spp = 8, .depth = 8, .variants = 1,
                   .y0 = 0.62f, .y1 = 0.92f, .box = {0, 0, 0, -1, 0, 0}, .view = sg_v3(0, -0.15f, -1)};
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help")) {
            fputs(usage, stdout);
            return 0;
        } else if (!strcmp(a, "--ground")) {
            o->ground = 1;
        } else if (!strcmp(a, "--no-variants")) {
            o->variants = 0;
        } else if (!strcmp(a, "--dump-all")) {
            o->dump_all = 1;
        } else if (!v) {
            fprintf(stderr, "bench_leaks: %s needs a value\n", a);
            return 1;
        } else if (!strcmp(a, "--mesh")) {
            o->mesh = v, ++i;
        } else if (!strcmp(a, "--surface")) {
            o->surface = v, ++i;
        } else if (!strcmp(a, "--png")) {
            o->png = v, ++i;
        } else if (!strcmp(a, "--points")) {
            o->points = strtoul(v, NULL, 10), ++i;
        } else if (!strcmp(a, "--dump")) {
            o->dump = atoi(v), ++i;
        } else if (!strcmp(a, "--size")) {
            o->size = atoi(v), ++i;
        } else if (!strcmp(a, "--spp")) {
            o->spp = atoi(v), ++i;
        } else if (!strcmp(a, "--depth")) {
            o->depth = atoi(v), ++i;
        } else if (!strcmp(a, "--threads")) {
            o->threads = atoi(v), ++i;
        } else if (!strcmp(a, "--frame")) {
            if (sscanf(v, "%f,%f", &o->y0, &o->y1) != 2)
                return fprintf(stderr, "bench_leaks: --frame y0,y1\n"), 1;
            ++i;
        } else if (!strcmp(a, "--box")) {
            float *b = o->box;
            if (sscanf(v, "%f,%f,%f,%f,%f,%f", &b[0], &b[1], &b[2], &b[3], &b[4], &b[5]) != 6)
                return fprintf(stderr, "bench_leaks: --box x0,y0,z0,x1,y1,z1\n"), 1;
            ++i;
        } else if (!strcmp(a, "--view")) {
            if (sscanf(v, "%f,%f,%f", &o->view.x, &o->view.y, &o->view.z) != 3)
                return fprintf(stderr, "bench_leaks: --view x,y,z\n"), 1;
            ++i;
        } else {
            fprintf(stderr, "bench_leaks: unknown option %s\n%s", a, usage);
            return 1;
        }
    }
    if (!o->mesh) {
        fputs(usage, stderr);
        return 1;
    }
    return -1;
}

static double pct(uint64_t a, uint64_t b) { return b ? 100.0 * (double)a / (double)b : 0.0; }

int main(int argc, char **argv)
{
    options o;
    int rc = parse(argc, argv, &o);
    if (rc >= 0)
        return rc;
    if (access(o.mesh, R_OK) != 0) {
        printf("bench_leaks: skipped: %s not found\n", o.mesh);
        return 0;
    }
    if (o.threads > 0)
        omp_set_num_threads(o.threads);
    sg_error err = {0};
    sg_ground_placement pl;
    if (bench_place_mesh(o.mesh, MODEL_LENGTH, &pl, &err) != SG_OK)
        return bench_fail("bench_leaks", "%s", err.message);
    sg_mesh mesh = {0};
    if (sg_mesh_read(o.mesh, &mesh, &err) != SG_OK)
        return bench_fail("bench_leaks", "%s", err.message);
    sg_scene_transform xf = {.translate = pl.translate, .scale = sg_v3(pl.scale, pl.scale, pl.scale)};
    truth tr;
    if (truth_create(&mesh, &xf, o.ground, &tr, &err) != SG_OK)
        return bench_fail("bench_leaks", "%s", err.message);
    printf("bench_leaks: %s: %zu vertices, %zu triangles, %zu open edges; %zu points, %s%s\n", o.mesh,
           mesh.vertex_count, mesh.triangle_count, open_edges(&mesh), o.points, o.surface,
           o.ground ? ", on the ground" : "");

    char surf[256];
    snprintf(surf, sizeof surf, "{\"model\": \"%s\"}", o.surface);
    sg_world *w = NULL;
    double t0 = omp_get_wtime();
    if (make_world(&o, &pl, surf, &w, &err) != SG_OK)
        return bench_fail("bench_leaks", "%s", err.message);
    {
        sg_scene_info si;
        sg_scene_get_info(sg_world_scene(w, 0), &si);
        printf("bench_leaks: world built in %.1f s; model: %zu splats, %zu keyed (%.1f%%: near an opposed layer)\n",
               omp_get_wtime() - t0, si.splat_count, si.keyed_count,
               100.0 * (double)si.keyed_count / (double)si.splat_count);
    }
    const sg_pointset *ps = sg_scene_points(sg_world_scene(w, 0));
    float *rs = malloc(ps->count * sizeof(float));
    memcpy(rs, ps->radius, ps->count * sizeof(float));
    qsort(rs, ps->count, sizeof(float), float_cmp);
    ctx c = {.w = w, .tr = &tr, .o = &o, .r_med = rs[ps->count / 2]};
    free(rs);

    /* The portrait: the model's y range [y0, y1] framed from view. */
    sg_aabb box = pl.placed;
    float h = box.hi.y - box.lo.y;
    float ylo = box.lo.y + o.y0 * h, yhi = box.lo.y + o.y1 * h;
    box.lo.y = ylo, box.hi.y = yhi;
    /* Narrow the box in x and z to the middle so the head fills the frame. */
    float cx = 0.5f * (box.lo.x + box.hi.x), cz = 0.5f * (box.lo.z + box.hi.z), half = 0.5f * (yhi - ylo);
    box.lo.x = fmaxf(box.lo.x, cx - half), box.hi.x = fminf(box.hi.x, cx + half);
    box.lo.z = fmaxf(box.lo.z, cz - half), box.hi.z = fminf(box.hi.z, cz + half);
    if (o.box[3] >= 0.0f) {
        sg_aabb b = pl.placed;
        sg_vec3 e = sg_v3_sub(b.hi, b.lo);
        box.lo = sg_v3(b.lo.x + o.box[0] * e.x, b.lo.y + o.box[1] * e.y, b.lo.z + o.box[2] * e.z);
        box.hi = sg_v3(b.lo.x + o.box[3] * e.x, b.lo.y + o.box[4] * e.y, b.lo.z + o.box[5] * e.z);
    }
    if (sg_camera_frame(box, o.view, sg_v3(0, 1, 0), 40.0f, 1.0f, 1.0f, &c.cam, &err) != SG_OK)
        return bench_fail("bench_leaks", "%s", err.message);
    printf("bench_leaks: median radius %.4g, camera eye (%.3g %.3g %.3g), %dx%d, %d spp, depth %d\n",
           (double)c.r_med, (double)c.cam.eye.x, (double)c.cam.eye.y, (double)c.cam.eye.z, o.size, o.size, o.spp,
           o.depth);
    if (o.png) {
        sg_render_desc rd = {.camera = c.cam, .width = 256, .height = 256, .shade = SG_SHADE_NORMALS};
        sg_image img;
        if (sg_render_frame(sg_world_scene(w, 0), &rd, &img, NULL, &err) == SG_OK) {
            sg_image_write_png(&img, o.png, 1.0f, &err);
            sg_image_free(&img);
        }
    }

    int nth = omp_get_max_threads();
    counts *kc = calloc((size_t)nth, sizeof *kc);
    event **evs = calloc((size_t)nth, sizeof *evs);
    size_t *nev = calloc((size_t)nth, sizeof *nev), cap = MAX_EVENTS / (size_t)nth;
    for (int i = 0; i < nth; ++i)
        evs[i] = malloc(cap * sizeof(event));
    t0 = omp_get_wtime();
    int npix = o.size * o.size;
#pragma omp parallel for schedule(dynamic, 16)
    for (int p = 0; p < npix; ++p) {
        int th = omp_get_thread_num();
        for (int s = 0; s < o.spp; ++s) {
            uint64_t path = (uint64_t)p * 65536u + (uint64_t)s;
            float px = (float)(p % o.size) + sg_rng_float(7, path, 0, 0);
            float py = (float)(p / o.size) + sg_rng_float(7, path, 0, 1);
            trace_path(&c, path, px, py, &kc[th], evs[th], &nev[th], cap);
        }
    }
    counts k = {0};
    size_t total_ev = 0;
    for (int i = 0; i < nth; ++i) {
        k.paths += kc[i].paths, k.paths_back += kc[i].paths_back, k.paths_tunnel += kc[i].paths_tunnel;
        k.hits_model += kc[i].hits_model, k.hits_ground += kc[i].hits_ground;
        k.back_model += kc[i].back_model, k.back_ground += kc[i].back_ground;
        for (int j = 0; j < K_KINDS; ++j) {
            k.rays[j] += kc[i].rays[j], k.hits[j] += kc[i].hits[j], k.back[j] += kc[i].back[j];
            k.tunnels[j] += kc[i].tunnels[j], k.inside_start[j] += kc[i].inside_start[j];
            k.slivers[j] += kc[i].slivers[j];
        }
        total_ev += nev[i];
    }
    event *all = malloc((total_ev ? total_ev : 1) * sizeof *all);
    size_t m = 0;
    for (int i = 0; i < nth; ++i) {
        memcpy(all + m, evs[i], nev[i] * sizeof(event));
        m += nev[i];
    }
    qsort(all, total_ev, sizeof *all, event_cmp);
    printf("bench_leaks: %llu paths traced in %.1f s\n", (unsigned long long)k.paths, omp_get_wtime() - t0);

    uint64_t hits = k.hits[K_CAMERA] + k.hits[K_FRONT] + k.hits[K_BACK];
    uint64_t back = k.back[K_CAMERA] + k.back[K_FRONT] + k.back[K_BACK];
    printf("\npaths with a back hit (unexpected): %llu of %llu (%.3f%%); paths with a tunnel: %llu (%.3f%%)\n",
           (unsigned long long)k.paths_back, (unsigned long long)k.paths, pct(k.paths_back, k.paths),
           (unsigned long long)k.paths_tunnel, pct(k.paths_tunnel, k.paths));
    printf("surface hits of path rays: %llu, from behind: %llu (%.3f%%); model %llu / %llu, ground %llu / %llu\n",
           (unsigned long long)hits, (unsigned long long)back, pct(back, hits), (unsigned long long)k.back_model,
           (unsigned long long)k.hits_model, (unsigned long long)k.back_ground, (unsigned long long)k.hits_ground);
    printf("%-11s %10s %10s %10s %8s %10s %8s %12s %8s\n", "ray", "rays", "hits", "back hits", "%hits", "tunnels",
           "%rays", "start inside", "slivers");
    for (int j = 0; j < K_KINDS; ++j)
        printf("%-11s %10llu %10llu %10llu %8.3f %10llu %8.4f %12llu %8llu\n", kind_name[j],
               (unsigned long long)k.rays[j], (unsigned long long)k.hits[j], (unsigned long long)k.back[j],
               pct(k.back[j], k.hits[j]), (unsigned long long)k.tunnels[j], pct(k.tunnels[j], k.rays[j]),
               (unsigned long long)k.inside_start[j], (unsigned long long)k.slivers[j]);

    if (o.variants && total_ev) {
        sg_world *vw[V_COUNT] = {0};
        char js[256];
        snprintf(js, sizeof js, "{\"model\": \"%s\", \"refinements\": {\"shrink\": false}}", o.surface);
        if (make_world(&o, &pl, js, &vw[V_NOSHRINK], &err) != SG_OK)
            return bench_fail("bench_leaks", "%s", err.message);
        snprintf(js, sizeof js, "{\"model\": \"%s\", \"samples_per_cell\": 64}", o.surface);
        if (make_world(&o, &pl, js, &vw[V_DENSE], &err) != SG_OK)
            return bench_fail("bench_leaks", "%s", err.message);
        /* Events in the order: (type, kind) groups; per group, how many each
         * variant fixes, and how many none does, split by what the mesh
         * shows near the hit. */
        for (int type = 0; type < 2; ++type)
            for (int kind = 0; kind < K_KINDS; ++kind) {
                uint64_t n = 0, fix[V_COUNT] = {0}, only[V_COUNT] = {0}, none = 0, none_near_front = 0,
                         none_near_back = 0, none_far = 0, first_in_path = 0, inside = 0;
                uint64_t last_path = UINT64_MAX, thick[6] = {0}, graze[3] = {0};
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : n, none, none_near_front, none_near_back, none_far, \
                                                                 first_in_path, inside, thick[:6], graze[:3])
                for (size_t i = 0; i < total_ev; ++i) {
                    const event *e = &all[i];
                    if (e->type != type || e->kind != kind)
                        continue;
                    ++n;
                    inside += (uint64_t)e->started_inside;
                    if (type == EV_BACKHIT)
                        graze[e->cos_hit < 0.05f ? 0 : e->cos_hit < 0.2f ? 1 : 2]++;
                    (void)last_path;
                    int f[V_COUNT];
                    sg_ray r = e->ray;
                    r.self_r = 0.0f;
                    f[V_NOSELF] = fixed_by(w, e, &r);
                    f[V_NOSHRINK] = fixed_by(vw[V_NOSHRINK], e, &e->ray);
                    f[V_DENSE] = fixed_by(vw[V_DENSE], e, &e->ray);
                    r = e->ray;
                    r.flags = SG_RAY_ANY_FACE;
                    f[V_ANYFACE] = fixed_by(w, e, &r);
                    int nf = 0;
                    for (int v = 0; v < V_COUNT; ++v)
                        nf += f[v];
                    for (int v = 0; v < V_COUNT; ++v) {
                        if (f[v]) {
#pragma omp atomic
                            fix[v]++;
                        }
                        if (f[v] && nf == 1) {
#pragma omp atomic
                            only[v]++;
                        }
                    }
                    {
                        /* The mesh's thickness where the ray meets it: from the
                         * crossing (tunnel) or the mesh entry nearest the hit
                         * to the next crossing, in splat radii. */
                        float ta = type == EV_TUNNEL ? e->t_true : NAN, tb, ca, cb, th = e->slab;
                        int ent;
                        if (type == EV_BACKHIT) {
                            th = NAN;
                            if (truth_cross(&tr, e->ray.org, e->ray.dir, fmaxf(0.0f, e->t_hit - 4.0f * e->r),
                                            e->t_hit + 4.0f * e->r, &ta, &ent, &ca) &&
                                truth_cross(&tr, e->ray.org, e->ray.dir, nextafterf(ta, INFINITY), INFINITY, &tb,
                                            &ent, &cb))
                                th = (tb - ta) * ca / e->r;
                        }
                        int bin = !(th == th) ? 5 : th < 0.1f ? 0 : th < 0.5f ? 1 : th < 1.0f ? 2 : th < 2.0f ? 3 : 4;
                        thick[bin]++;
                    }
                    if (nf == 0) {
                        ++none;
                        /* What the mesh has near the splat hit (back hits) or
                         * the tunnelled crossing. */
                        float tc = type == EV_BACKHIT ? e->t_hit : e->t_true, tt, cc;
                        int ent;
                        if (truth_cross(&tr, e->ray.org, e->ray.dir, fmaxf(0.0f, tc - 2.0f * e->r), tc + 2.0f * e->r,
                                        &tt, &ent, &cc))
                            ent ? ++none_near_front : ++none_near_back;
                        else
                            ++none_far;
                    }
                }
                for (size_t i = 0; i < total_ev; ++i) {
                    const event *e = &all[i];
                    if (e->type != type || e->kind != kind)
                        continue;
                    if (e->path != last_path)
                        ++first_in_path;
                    last_path = e->path;
                }
                if (!n)
                    continue;
                int dumped = 0;
                for (size_t i = 0; i < total_ev && dumped < o.dump; ++i) {
                    const event *e = &all[i];
                    if (e->type != type || e->kind != kind)
                        continue;
                    sg_ray r = e->ray;
                    r.self_r = 0.0f;
                    if (!o.dump_all && (fixed_by(w, e, &r) || fixed_by(vw[V_DENSE], e, &e->ray)))
                        continue;
                    dumped += dump_event(w, &tr, e);
                }
                printf("\n%s events of %s rays: %llu (%llu paths; %llu started inside the mesh)\n",
                       type == EV_BACKHIT ? "back-hit" : "tunnel", kind_name[kind], (unsigned long long)n,
                       (unsigned long long)first_in_path, (unsigned long long)inside);
                for (int v = 0; v < V_COUNT; ++v)
                    printf("  fixed by %-18s %8llu (%5.1f%%), by it alone %8llu (%5.1f%%)\n", variant_name[v],
                           (unsigned long long)fix[v], pct(fix[v], n), (unsigned long long)only[v], pct(only[v], n));
                if (type == EV_BACKHIT)
                    printf("  dot(dir, n) at the hit: < 0.05 %llu, 0.05-0.2 %llu, > 0.2 %llu\n",
                           (unsigned long long)graze[0], (unsigned long long)graze[1], (unsigned long long)graze[2]);
                printf("  mesh thickness there (chord x cos), radii: <0.1 %llu, 0.1-0.5 %llu, 0.5-1 %llu, 1-2 %llu, >2 %llu, unknown %llu\n",
                       (unsigned long long)thick[0], (unsigned long long)thick[1], (unsigned long long)thick[2],
                       (unsigned long long)thick[3], (unsigned long long)thick[4], (unsigned long long)thick[5]);
                printf("  fixed by none: %llu (%.1f%%): mesh near it faces the ray %llu, faces away %llu, no mesh %llu\n",
                       (unsigned long long)none, pct(none, n), (unsigned long long)none_near_front,
                       (unsigned long long)none_near_back, (unsigned long long)none_far);
            }
        for (int v = 0; v < V_COUNT; ++v)
            sg_world_destroy(vw[v]);
    }
    free(all);
    for (int i = 0; i < nth; ++i)
        free(evs[i]);
    free(evs);
    free(nev);
    free(kc);
    sg_world_destroy(w);
    truth_free(&tr);
    sg_mesh_free(&mesh);
    return 0;
}
