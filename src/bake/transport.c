/* transport.c — rays from the sample sites and the transport solve (see
 * transport.h).
 *
 * Random streams per sample (key = global splat index): stream 2 + side,
 * dims 0, 1 the shift of the envmap strategy's lattice, 2, 3 the cosine
 * strategy's.
 *
 * Invariants:
 *  1. sd->first has 2 sd->count + 1 entries, non-decreasing, first[0] = 0,
 *     first[2 sd->count] = sd->hits; hits are stored in site order;
 *  2. ratio, unshadowed, sigma and dist hold values for the 2 sd->count
 *     sites, finite (dist may be INFINITY), ratio and unshadowed >= 0;
 *  3. every hit names a model of the world, a splat of it and k > 0 finite;
 *  4. the solve's iterate stays finite and >= 0: C >= 0, T >= 0, and a
 *     sweep only adds non-negative terms.
 */
#include "bake/transport.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"
#include "math/rng.h"
#include "sample/warp.h"

static const float INV_PI = 0.318309886183791f;

/* The R2 sequence's generators (Roberts 2018): the 2D rank-1 lattice with
 * the most even gaps for any count. */
static const double R2_A1 = 0.7548776662466927, R2_A2 = 0.5698402909980532;

enum {
    BLOCK = 16,          /* sample points per task                            */
    TOLERANCE_PPM = 10,  /* solve: stop when the iterate's remaining error,
                            predicted from its changes, is at most this many
                            millionths of the largest value ("Stopping")     */
    FLOOR_PPM = 1        /* ... or when no value changes by more than this
                            (a few float ulps more than rounding's churn)    */
};

static float lum3(const double *v) { return (float)(0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]); }

sg_transport_desc sg_transport_desc_resolve(const sg_transport_desc *desc)
{
    sg_transport_desc d = desc ? *desc : (sg_transport_desc){0};
    if (d.env_rays <= 0) d.env_rays = 32;
    if (d.cos_rays <= 0) d.cos_rays = 64;
    if (d.seed == 0) d.seed = 1;
    return d;
}

void sg_site_data_free(sg_site_data *sd)
{
    if (!sd)
        return;
    sg_free(sd->ratio);
    sg_free(sd->unshadowed);
    sg_free(sd->sigma);
    sg_free(sd->dist);
    sg_free(sd->first);
    sg_free(sd->hit_splat);
    sg_free(sd->hit_model);
    sg_free(sd->hit_k);
    memset(sd, 0, sizeof *sd);
}

/* Room for `samples` sample points' sites. */
static int reserve_sites(sg_site_data *sd, size_t samples)
{
    if (samples <= sd->capacity && sd->first)
        return 1;
    size_t cap = sg_grown_capacity(sd->capacity, samples);
    size_t old = sd->capacity;
    void *p;
    p = sd->ratio;
    if (!sg_realloc_array(&p, 6 * old, 6 * cap, sizeof(float)))
        return 0;
    sd->ratio = p;
    p = sd->unshadowed;
    if (!sg_realloc_array(&p, 6 * old, 6 * cap, sizeof(float)))
        return 0;
    sd->unshadowed = p;
    p = sd->sigma;
    if (!sg_realloc_array(&p, 2 * old, 2 * cap, sizeof(float)))
        return 0;
    sd->sigma = p;
    p = sd->dist;
    if (!sg_realloc_array(&p, 2 * old, 2 * cap, sizeof(float)))
        return 0;
    sd->dist = p;
    p = sd->first;
    if (!(p ? sg_realloc_array(&p, 2 * old + 1, 2 * cap + 1, sizeof(size_t))
            : !!(p = sg_calloc_array(2 * cap + 1, sizeof(size_t)))))
        return 0;
    sd->first = p;
    sd->capacity = cap;
    return 1;
}

static int reserve_hits(sg_site_data *sd, size_t need)
{
    if (need <= sd->hit_capacity && sd->hit_k)
        return 1;
    size_t cap = sg_grown_capacity(sd->hit_capacity, need);
    size_t old = sd->hits;
    void *p = sd->hit_splat;
    if (!sg_realloc_array(&p, old, cap, sizeof(uint32_t)))
        return 0;
    sd->hit_splat = p;
    p = sd->hit_model;
    if (!sg_realloc_array(&p, old, cap, sizeof(uint32_t)))
        return 0;
    sd->hit_model = p;
    p = sd->hit_k;
    if (!sg_realloc_array(&p, old, cap, sizeof(float)))
        return 0;
    sd->hit_k = p;
    sd->hit_capacity = cap;
    return 1;
}

/* One task's output: BLOCK samples' sites, their hits in site order. */
typedef struct hit_rec {
    uint32_t splat, model;
    float k;
} hit_rec;

typedef struct task {
    float ratio[BLOCK * 6], unsh[BLOCK * 6], sigma[BLOCK * 2], dist[BLOCK * 2];
    size_t count[BLOCK * 2]; /* hits per site                              */
    hit_rec *hits;
    size_t n, cap;
    int failed;
} task;

static int push_hit(task *t, uint32_t splat, uint32_t model, float k)
{
    if (t->n == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 1024;
        void *p = t->hits;
        if (!sg_realloc_array(&p, t->n, cap, sizeof *t->hits))
            return 0;
        t->hits = p;
        t->cap = cap;
    }
    t->hits[t->n++] = (hit_rec){splat, model, k};
    return 1;
}

static float power_weight(float own, float other)
{
    float a = own * own, b = other * other;
    return a + b > 0.0f ? a / (a + b) : 0.0f;
}

/* Crossings a site's way down to its surface passes over (steep ones, of
 * a wall at a concave edge) before it takes one. */
enum { PROJECT_TRIES = 4 };

/* The surface a site names: the first crossing facing its way (normal
 * within 60 degrees of n) that a ray down the site's normal from one
 * reach above it meets within a reach of the site, passing over crossings
 * of surfaces facing elsewhere (the rounding of a wall where it meets a
 * floor). flags: the faces the ray takes. Returns 0 when there is none,
 * and when a crossing it meets first is an exit (flags 0 only): then the
 * way down begins inside the model. */
static int site_surface(const sg_scene *sc, uint32_t site, uint32_t flags, sg_hit *out)
{
    const sg_sites *ps = sg_scene_sites(sc);
    sg_vec3 p = sg_sites_position(ps, site), n = sg_sites_normal(ps, site);
    float r = ps->radius[site];
    sg_ray down = {.org = sg_v3_madd(p, n, r), .dir = sg_v3_scale(n, -1.0f), .tmin = 0.0f, .tmax = 2.0f * r,
                   .flags = flags};
    for (int k = 0; k < PROJECT_TRIES; ++k) {
        sg_hit h;
        if (!sg_scene_intersect(sc, &down, &h, NULL))
            return 0;
        float c = sg_v3_dot(h.n, n);
        if (c < 0.0f) /* an exit (either face): begun inside */
            return 0;
        if (c > 0.5f) {
            if (!(fabsf(h.t - r) < r))
                return 0;
            *out = h;
            return 1;
        }
        down.tmin = nextafterf(h.t, INFINITY);
    }
    return 0;
}

/* Where the rays of a splat's sites start: the point of the model's
 * surface over the splat's centre and the surface's normal there
 * (site_surface, front faces). A splat's centre lies off the surface it
 * makes (below it in a concave fold, where the smooth surface bridges the
 * fold): rays from the centre would see the fold's walls from too deep
 * and darken it, where the reference and the viewer shade the surface
 * itself. Where there is none, the splat's own centre and normal. The ray
 * leaves from the surface it names (ray.h): its outward normal decides the
 * front/back expectation and the self test, whatever the side. */
static sg_world_hit site_on_surface(const sg_world *w, uint32_t m, uint32_t splat)
{
    const sg_scene *sc = sg_world_scene(w, m);
    sg_world_hit self = {.hit = sg_scene_site_hit(sc, splat), .model = m};
    sg_hit h;
    if (site_surface(sc, splat, SG_RAY_FRONT_ONLY, &h)) {
        self.hit.p = h.p;
        self.hit.n = h.n;
    }
    return self;
}

/* Whether a site names no surface it can light from outside, so that it
 * must not be a sample point (sites.h unsampled). Either its way down
 * (site_surface, here accepting either face) begins inside the model --
 * the site lies on a stretch of surface walled in by another, as an
 * octree's corners beyond a concave edge do, where the smooth surface of
 * a floor runs on under the wall's rounding, a pocket a few hundredths
 * deep -- or it finds no surface facing the site's way within a reach,
 * and the site's rays would leave from the site itself, off the surface:
 * an octree corner under a floor at the foot of a wall, inside the wall,
 * or a splat on a sharp edge. Rays spawned inside pass walls from behind,
 * which spawned rays do not see, and read the sky (room bake on the ISO:
 * floor corners at a wall's foot 10-25 times too bright). */
static int site_off_surface(const sg_world *w, uint32_t m, uint32_t site)
{
    sg_hit h;
    return !site_surface(sg_world_scene(w, m), site, 0, &h);
}

size_t sg_transport_off_surface_sites(const sg_world *w, uint32_t m, int threads, uint8_t *out)
{
    const sg_sites *ps = sg_scene_sites(sg_world_scene(w, m));
    int nt = threads > 0 ? threads : omp_get_max_threads();
    size_t off = 0;
#pragma omp parallel for schedule(dynamic, 1024) reduction(+ : off) num_threads(nt)
    for (size_t i = 0; i < ps->count; ++i) {
        if (ps->unsampled && ps->unsampled[i]) {
            out[i] = 1;
            continue;
        }
        out[i] = (uint8_t)site_off_surface(w, m, (uint32_t)i);
        off += out[i];
    }
    return off;
}

/* One traced ray of a site. */
typedef struct ray_rec {
    float pe, pc, cosi;  /* the two strategies' densities, cos to the side  */
    float L[3];          /* the envmap's radiance in its direction          */
    float t;             /* hit distance; 0: escaped                        */
    uint32_t splat, model; /* what it hit: splat, model << 1 | side          */
    uint8_t is_env;      /* drawn by the envmap strategy                    */
} ray_rec;

/* The cone of a site's ray (transport.h, "Level of detail").
 *
 * The site's N = ne + nc rays draw directions from the mixture density
 * q(w) = ne p_e(w) + nc p_c(w) rays per steradian, so a ray at w stands
 * for the solid angle 1/q(w) around it (the mean area of its cell among
 * the others). A camera pixel of angular width a covers a^2 sr and
 * sg_camera_ray gives it spread a; a ray standing for Omega sr is such a
 * pixel of width sqrt(Omega). Its share is capped at the even share of the
 * hemisphere, Omega <= 2 pi / N (N = 96: spread <= 0.256): where q is low
 * (cosine rays near the horizon, p_c -> 0) a ray's cell is a thin sliver
 * along the horizon, not a wide cone, and a grazing ray must not take
 * coarse nodes of the surface it leaves. A uniform sky (p_e = 1/4pi) with
 * 32 + 64 rays: q = 2.5 + 20.4 cos, spread 0.21 at the zenith, the cap
 * beyond 51 degrees from it; a ray towards the sun (p_e ~ 1000) has
 * spread 0.006 and the sun's shadow stays sharp.
 *
 * A surface takes a node of size s at distance t when s < lod spread t
 * (hybrid.h, iso.h; lod: the scene's hybrid_lod / iso_lod, 1 pixel). */
float sg_transport_ray_spread(const sg_transport_desc *d, float pe, float pc)
{
    if (!(d->ray_cone > 0.0f) || !isfinite(d->ray_cone))
        return 0.0f;
    float n = (float)(d->env_rays + d->cos_rays);
    float q = (float)d->env_rays * pe + (float)d->cos_rays * pc;
    float share = 6.28318530718f / n;
    float omega = q > 1.0f / share ? 1.0f / q : share;
    return d->ray_cone * sqrtf(omega);
}

/* Draws and traces ray jj of a strategy; 0 when the direction falls below
 * the side's horizon or has no density (no ray: it adds 0). */
static int trace_ray(const sg_world *w, const sg_transport_desc *d, const sg_world_hit *self, sg_vec3 ns, sg_vec3 tb,
                     sg_vec3 bb, const double sh[2], int is_env, int jj, ray_rec *r)
{
    const sg_envmap *env = sg_world_envmap(w);
    double u1 = sh[0] + R2_A1 * (double)jj, u2 = sh[1] + R2_A2 * (double)jj;
    u1 -= floor(u1);
    u2 -= floor(u2);
    sg_vec3 wi;
    if (is_env) {
        wi = sg_envmap_sample(env, (float)u1, (float)u2, &r->pe);
        r->cosi = sg_v3_dot(wi, ns);
        if (!(r->pe > 0.0f) || !(r->cosi > 0.0f))
            return 0;
    } else {
        sg_vec3 l = sg_warp_cosine_hemisphere_sample((float)u1, (float)u2);
        if (!(l.z > 0.0f))
            return 0;
        wi = sg_v3_normalize(sg_v3_add(sg_v3_add(sg_v3_scale(tb, l.x), sg_v3_scale(bb, l.y)), sg_v3_scale(ns, l.z)));
        r->cosi = l.z;
        r->pe = sg_envmap_pdf(env, wi);
    }
    r->pc = r->cosi * INV_PI;
    r->is_env = (uint8_t)is_env;
    sg_vec3 L = sg_envmap_eval(env, wi);
    r->L[0] = L.x, r->L[1] = L.y, r->L[2] = L.z;
    sg_ray ray = sg_world_spawn_ray(w, self, wi, INFINITY);
    ray.spread = sg_transport_ray_spread(d, r->pe, r->pc);
    sg_world_hit h;
    r->t = 0.0f;
    if (sg_world_intersect(w, &ray, &h, NULL)) {
        r->t = h.hit.t > 0.0f ? h.hit.t : FLT_MIN;
        r->splat = sg_scene_hit_site(sg_world_scene(w, h.model), &h.hit);
        r->model = h.model << 1 | (uint32_t)(sg_v3_dot(wi, h.hit.n) > 0.0f); /* y's back side */
    }
    return 1;
}

/* Rays per strategy of a site's pilot: if every pilot ray meets a surface
 * from behind, the site looks into a closed volume (the inside of a
 * model), which light reaches only through holes; its estimate then stands
 * on the pilot rays alone, a valid estimator with fewer samples. */
enum { PILOT = 4 };

/* The estimator weight of ray r for ne envmap and nc cosine samples. */
static float ray_weight(const ray_rec *r, int ne, int nc)
{
    float fe = (float)ne * r->pe, fc = (float)nc * r->pc;
    float k = r->is_env ? r->cosi * power_weight(fe, fc) / fe : r->cosi * power_weight(fc, fe) / fc;
    return k > 0.0f && isfinite(k) ? k : 0.0f;
}

/* The site's figures from its rays, estimator weights for ne envmap and nc
 * cosine samples (power heuristic). The hits' weights are scaled so that
 * all rays' weights sum to pi = int cos dw, the estimator's value for
 * L_in = 1: a ratio estimator (bias O(1/N)) with two purposes. A row of
 * the transport then sums to at most the largest reflectance times pi over
 * pi, so the solve cannot diverge on noise (the inside of a closed white
 * model reflects everything: a row summing above 1 by chance would
 * amplify every sweep); and under a uniform sky over a white surface the
 * site's E = E0 D + I is exactly E0, with no noise at all (the white
 * furnace). */
static int finish_site(const ray_rec *rays, int count, int ne, int nc, task *t, int slot)
{
    double ed[3] = {0, 0, 0}, eu[3] = {0, 0, 0};
    double y2 = 0, ya2 = 0, yya = 0, inv_dist = 0; /* per-ray luminance sums (sigma), 1/d */
    double ksum = 0.0;
    for (int j = 0; j < count; ++j)
        ksum += ray_weight(&rays[j], ne, nc);
    float scale = ksum > 0.0 ? (float)(3.14159265358979 / ksum) : 1.0f;
    size_t before = t->n;
    for (int j = 0; j < count; ++j) {
        const ray_rec *r = &rays[j];
        float k = ray_weight(r, ne, nc);
        if (!(k > 0.0f))
            continue;
        double a[3] = {r->L[0] * k, r->L[1] * k, r->L[2] * k};
        for (int c = 0; c < 3; ++c)
            eu[c] += a[c];
        double ya = lum3(a), y = 0;
        if (r->t == 0.0f) {
            for (int c = 0; c < 3; ++c)
                ed[c] += a[c];
            y = ya;
        } else {
            if (!push_hit(t, r->splat, r->model, k * scale))
                return 0;
            inv_dist += 1.0 / r->t;
        }
        y2 += y * y;
        ya2 += ya * ya;
        yya += y * ya;
    }
    /* Visibility ratio per channel; a channel without sampled light takes
     * the luminance ratio, a site without any 1 (the table says how little
     * light there is). Its standard error by the delta method for a ratio
     * of two sums over the same rays: Var(r) ~ sum (y - r y_a)^2 / E_u^2. */
    double lu = lum3(eu), ld = lum3(ed);
    double r = lu > 0.0 ? ld / lu : 1.0;
    for (int c = 0; c < 3; ++c) {
        double v = eu[c] > 0.0 ? ed[c] / eu[c] : r;
        t->ratio[3 * slot + c] = isfinite(v) && v > 0.0 ? (float)v : 0.0f;
        t->unsh[3 * slot + c] = isfinite(eu[c]) ? (float)eu[c] : 0.0f;
    }
    double ss = y2 - 2.0 * r * yya + r * r * ya2;
    double se = lu > 0.0 && ss > 0.0 ? sqrt(ss) / lu : 0.0;
    t->sigma[slot] = isfinite(se) ? (float)se : 0.0f;
    t->dist[slot] = inv_dist > 0.0 ? (float)((double)(ne + nc) / inv_dist) : INFINITY;
    t->count[slot] = t->n - before;
    return 1;
}

/* The rays of one site: sample i (splat) of model m, side `side`; rays is
 * the task's scratch for env_rays + cos_rays records. */
static void gather_site(const sg_world *w, uint32_t m, uint32_t splat, int side, uint64_t key,
                        const sg_transport_desc *d, task *t, int slot, ray_rec *rays)
{
    sg_world_hit self = site_on_surface(w, m, splat);
    sg_vec3 n = self.hit.n;                               /* the surface's outward normal */
    sg_vec3 ns = side ? sg_v3_scale(n, -1.0f) : n;        /* the site's side               */
    sg_vec3 tb, bb;
    sg_v3_basis(ns, &tb, &bb);
    uint32_t stream = 2u + (uint32_t)side;
    double sh[4];
    for (uint32_t k = 0; k < 4; ++k)
        sh[k] = sg_rng_float(d->seed, key, stream, k);
    int pe = d->env_rays < PILOT ? d->env_rays : PILOT, pc = d->cos_rays < PILOT ? d->cos_rays : PILOT;
    int count = 0, inside = 1;
    for (int j = 0; j < pe + pc; ++j) {
        ray_rec *r = &rays[count];
        if (!trace_ray(w, d, &self, ns, tb, bb, j < pe ? sh : sh + 2, j < pe, j < pe ? j : j - pe, r))
            continue;
        inside &= r->t > 0.0f && (r->model & 1u);
        ++count;
    }
    if (inside && count >= PILOT) {
        if (!finish_site(rays, count, pe, pc, t, slot))
            t->failed = 1;
        return;
    }
    for (int j = pe; j < d->env_rays; ++j)
        count += trace_ray(w, d, &self, ns, tb, bb, sh, 1, j, &rays[count]);
    for (int j = pc; j < d->cos_rays; ++j)
        count += trace_ray(w, d, &self, ns, tb, bb, sh + 2, 0, j, &rays[count]);
    if (!finish_site(rays, count, d->env_rays, d->cos_rays, t, slot))
        t->failed = 1;
}

sg_status sg_transport_gather(const sg_world *w, uint32_t m, const sg_sample_set *set, uint64_t key_base,
                              const sg_transport_desc *desc, sg_site_data *sd, sg_error *err)
{
    sg_transport_desc d = sg_transport_desc_resolve(desc);
    assert(sd->count <= set->count);
    size_t first = sd->count, n = set->count - first;
    if (n == 0)
        return SG_OK;
    if (!reserve_sites(sd, set->count))
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu sample points' light", set->count);
    size_t ntasks = (n + BLOCK - 1) / BLOCK;
    int threads = d.threads > 0 ? d.threads : omp_get_max_threads();
    sg_status st = SG_OK;
    /* Tasks run in rounds of a few per thread, so that a cancel is seen
     * soon and each round's hits are appended in site order. */
    size_t round = (size_t)threads * 8;
    task *tasks = sg_calloc_array(round, sizeof *tasks);
    if (!tasks)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
    for (size_t t0 = 0; t0 < ntasks && st == SG_OK; t0 += round) {
        size_t nt = ntasks - t0 < round ? ntasks - t0 : round;
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
        for (size_t ti = 0; ti < nt; ++ti) {
            task *t = &tasks[ti];
            t->n = 0;
            t->failed = 0;
            ray_rec *rays = sg_alloc_array((size_t)d.env_rays + (size_t)d.cos_rays, sizeof *rays);
            if (!rays) {
                t->failed = 1;
                continue;
            }
            size_t s0 = first + (t0 + ti) * BLOCK, s1 = s0 + BLOCK < set->count ? s0 + BLOCK : set->count;
            for (size_t s = s0; s < s1 && !t->failed; ++s)
                for (int side = 0; side < SG_SIDES && !t->failed; ++side)
                    gather_site(w, m, set->splat[s], side, key_base + set->splat[s], &d, t,
                                (int)(2 * (s - s0)) + side, rays);
            sg_free(rays);
        }
        /* Append the round in task order (invariant 1). */
        size_t add = 0;
        for (size_t ti = 0; ti < nt; ++ti) {
            if (tasks[ti].failed)
                st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for the sample points' rays");
            add += tasks[ti].n;
        }
        if (st == SG_OK && !reserve_hits(sd, sd->hits + add))
            st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu ray hits", sd->hits + add);
        for (size_t ti = 0; ti < nt && st == SG_OK; ++ti) {
            task *t = &tasks[ti];
            size_t s0 = first + (t0 + ti) * BLOCK, s1 = s0 + BLOCK < set->count ? s0 + BLOCK : set->count;
            size_t ns = s1 - s0;
            memcpy(sd->ratio + 6 * s0, t->ratio, 6 * ns * sizeof(float));
            memcpy(sd->unshadowed + 6 * s0, t->unsh, 6 * ns * sizeof(float));
            memcpy(sd->sigma + 2 * s0, t->sigma, 2 * ns * sizeof(float));
            memcpy(sd->dist + 2 * s0, t->dist, 2 * ns * sizeof(float));
            for (size_t r = 0; r < t->n; ++r) {
                sd->hit_splat[sd->hits + r] = t->hits[r].splat;
                sd->hit_model[sd->hits + r] = t->hits[r].model;
                sd->hit_k[sd->hits + r] = t->hits[r].k;
            }
            for (size_t i = 0; i < 2 * ns; ++i)
                sd->first[2 * s0 + i + 1] = sd->first[2 * s0 + i] + t->count[i];
            sd->hits += t->n;
            sd->count = s1;
        }
        if (st == SG_OK && d.progress && d.progress(d.progress_user, sd->count - first, n))
            st = sg_error_set(err, SG_ERR_CANCELLED, "bake: cancelled after %zu of %zu sample points", sd->count,
                              set->count);
    }
    for (size_t ti = 0; ti < round; ++ti)
        sg_free(tasks[ti].hits);
    sg_free(tasks);
    return st;
}

/* ---- packing for the distributed bake --------------------------------------- */

/* Bytes per sample and per hit of a packed piece (transport.h). */
enum {
    PACK_HEAD = 2 * sizeof(uint64_t),
    PACK_PER_SAMPLE = (6 + 6 + 2 + 2) * sizeof(float) + 2 * sizeof(uint64_t),
    PACK_PER_HIT = 2 * sizeof(uint32_t) + sizeof(float)
};

static unsigned char *put(unsigned char *p, const void *src, size_t n)
{
    if (n)
        memcpy(p, src, n);
    return p + n;
}

sg_status sg_site_data_pack(const sg_site_data *sd, void **buf, size_t *bytes, sg_error *err)
{
    size_t c = sd->count, h = sd->hits, a, b, total;
    if (!sg_mul_size(c, PACK_PER_SAMPLE, &a) || !sg_mul_size(h, PACK_PER_HIT, &b) || a + b < a ||
        a + b > SIZE_MAX - PACK_HEAD)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: %zu sample points' sites are too many to send", c);
    total = PACK_HEAD + a + b;
    unsigned char *out = sg_alloc_array(total, 1), *p = out;
    if (!out)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu bytes of sites to send", total);
    uint64_t head[2] = {c, h};
    p = put(p, head, sizeof head);
    p = put(p, sd->ratio, 6 * c * sizeof(float));
    p = put(p, sd->unshadowed, 6 * c * sizeof(float));
    p = put(p, sd->sigma, 2 * c * sizeof(float));
    p = put(p, sd->dist, 2 * c * sizeof(float));
    for (size_t i = 0; i < 2 * c; ++i) {
        uint64_t n = sd->first[i + 1] - sd->first[i];
        p = put(p, &n, sizeof n);
    }
    p = put(p, sd->hit_splat, h * sizeof(uint32_t));
    p = put(p, sd->hit_model, h * sizeof(uint32_t));
    p = put(p, sd->hit_k, h * sizeof(float));
    assert((size_t)(p - out) == total);
    *buf = out;
    *bytes = total;
    return SG_OK;
}

sg_status sg_site_data_append_packed(sg_site_data *sd, const void *buf, size_t bytes, size_t *used, sg_error *err)
{
    const unsigned char *p = buf;
    uint64_t head[2];
    if (bytes < PACK_HEAD)
        return sg_error_set(err, SG_ERR_CORRUPT, "bake: a piece of sites of %zu bytes is cut short", bytes);
    memcpy(head, p, sizeof head);
    p += PACK_HEAD;
    size_t c = (size_t)head[0], h = (size_t)head[1];
    if (c > (bytes - PACK_HEAD) / PACK_PER_SAMPLE || h > (bytes - PACK_HEAD - c * PACK_PER_SAMPLE) / PACK_PER_HIT)
        return sg_error_set(err, SG_ERR_CORRUPT, "bake: a piece of %zu bytes cannot hold %zu sites and %zu hits",
                            bytes, 2 * c, h);
    const unsigned char *counts = p + 16 * c * sizeof(float);
    uint64_t sum = 0;
    for (size_t i = 0; i < 2 * c; ++i) {
        uint64_t n;
        memcpy(&n, counts + i * sizeof n, sizeof n);
        sum += n > h ? h + 1 : n; /* no wrap: each term is at most h + 1 */
    }
    if (sum != h)
        return sg_error_set(err, SG_ERR_CORRUPT, "bake: a piece's sites name %llu hits, it holds %zu",
                            (unsigned long long)sum, h);
    if (!reserve_sites(sd, sd->count + c) || !reserve_hits(sd, sd->hits + h))
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu sample points' light", sd->count + c);
    size_t s0 = sd->count;
    memcpy(sd->ratio + 6 * s0, p, 6 * c * sizeof(float));
    p += 6 * c * sizeof(float);
    memcpy(sd->unshadowed + 6 * s0, p, 6 * c * sizeof(float));
    p += 6 * c * sizeof(float);
    memcpy(sd->sigma + 2 * s0, p, 2 * c * sizeof(float));
    p += 2 * c * sizeof(float);
    memcpy(sd->dist + 2 * s0, p, 2 * c * sizeof(float));
    p += 2 * c * sizeof(float);
    for (size_t i = 0; i < 2 * c; ++i, p += sizeof(uint64_t)) {
        uint64_t n;
        memcpy(&n, p, sizeof n);
        sd->first[2 * s0 + i + 1] = sd->first[2 * s0 + i] + (size_t)n; /* invariant 1 */
    }
    memcpy(sd->hit_splat + sd->hits, p, h * sizeof(uint32_t));
    p += h * sizeof(uint32_t);
    memcpy(sd->hit_model + sd->hits, p, h * sizeof(uint32_t));
    p += h * sizeof(uint32_t);
    memcpy(sd->hit_k + sd->hits, p, h * sizeof(float));
    p += h * sizeof(float);
    sd->hits += h;
    sd->count += c;
    *used = (size_t)(p - (const unsigned char *)buf);
    return SG_OK;
}

sg_vec3 sg_transport_reflectance(const sg_material *m, sg_vec3 rho)
{
    if (m->type != SG_MATERIAL_GGX || !(m->specular > 0.0f))
        return sg_v3_scale(rho, INV_PI);
    float k = m->specular > 1.0f ? 1.0f : m->specular;
    float a = sg_bsdf_ggx_average_albedo(m->roughness);
    return sg_v3_scale(sg_v3_add(sg_v3_scale(rho, 1.0f - k), sg_v3(k * a, k * a, k * a)), INV_PI);
}

/* One row entry of T: the target site (global index) and RGB weight. */
typedef struct entry {
    uint32_t site;
    float w[3];
} entry;

static int entry_cmp(const void *a, const void *b)
{
    uint32_t x = ((const entry *)a)->site, y = ((const entry *)b)->site;
    return (x > y) - (x < y);
}

sg_status sg_transport_solve(const sg_world *w, const sg_transport_model *models, int max_iterations, int threads,
                             float **indirect, sg_transport_stats *stats, sg_error *err)
{
    size_t nm = sg_world_model_count(w);
    int nt = threads > 0 ? threads : omp_get_max_threads();
    if (max_iterations <= 0)
        max_iterations = 10000;
    size_t *offset = sg_calloc_array(nm + 1, sizeof *offset);
    if (!offset)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
    size_t hits = 0;
    for (size_t m = 0; m < nm; ++m) {
        offset[m + 1] = offset[m] + 2 * models[m].sites->count;
        hits += models[m].sites->hits;
    }
    size_t sites = offset[nm];
    sg_status st = SG_OK;
    size_t *row = sg_calloc_array(sites + 1, sizeof *row);
    entry *T = sg_alloc_array(hits ? hits : 1, sizeof *T);
    float *C = sg_calloc_array(3 * (sites ? sites : 1), sizeof *C);
    float *I = sg_alloc_array(3 * (sites ? sites : 1), sizeof *I);
    float *J = sg_alloc_array(3 * (sites ? sites : 1), sizeof *J);
    if (!row || !T || !C || !I || !J) {
        st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for the light transport of %zu sites", sites);
        goto done;
    }
    /* Rows of T and C, site by site; a row's hits are sorted by target and
     * merged in place, so each row holds each target once. */
    for (size_t m = 0; m < nm; ++m)
        for (size_t s = 0; s < 2 * models[m].sites->count; ++s)
            row[offset[m] + s + 1] = models[m].sites->first[s + 1] - models[m].sites->first[s];
    for (size_t i = 0; i < sites; ++i)
        row[i + 1] += row[i];
#pragma omp parallel for schedule(dynamic, 64) num_threads(nt)
    for (size_t g = 0; g < sites; ++g) {
        size_t m = 0;
        while (offset[m + 1] <= g)
            ++m;
        const sg_site_data *sd = models[m].sites;
        size_t s = g - offset[m];
        entry *e = T + row[g];
        size_t ne = 0;
        double c[3] = {0, 0, 0};
        for (size_t h = sd->first[s]; h < sd->first[s + 1]; ++h) {
            uint32_t hm = sd->hit_model[h] >> 1, side = sd->hit_model[h] & 1u, splat = sd->hit_splat[h];
            float k = sd->hit_k[h];
            const sg_material *mat = sg_world_material(w, hm);
            sg_vec3 R = sg_transport_reflectance(mat, sg_world_site_albedo(w, hm, splat));
            const sg_transport_model *tm = &models[hm];
            uint32_t t = tm->nearest[splat];
            const float *D = tm->sites->ratio + 6 * (size_t)t + 3 * side;
            const float *e0 = tm->e0 + 6 * (size_t)splat + 3 * side;
            c[0] += k * (mat->emission.x + R.x * e0[0] * D[0]);
            c[1] += k * (mat->emission.y + R.y * e0[1] * D[1]);
            c[2] += k * (mat->emission.z + R.z * e0[2] * D[2]);
            e[ne++] = (entry){(uint32_t)(offset[hm] + 2 * t + side), {k * R.x, k * R.y, k * R.z}};
        }
        qsort(e, ne, sizeof *e, entry_cmp);
        size_t out = 0;
        for (size_t j = 0; j < ne; ++j) {
            if (out && e[out - 1].site == e[j].site) {
                for (int ch = 0; ch < 3; ++ch)
                    e[out - 1].w[ch] += e[j].w[ch];
            } else
                e[out++] = e[j];
        }
        for (size_t j = out; j < ne; ++j)
            e[j].site = UINT32_MAX; /* merged away: skipped by the sweeps */
        for (int ch = 0; ch < 3; ++ch)
            C[3 * g + ch] = (float)c[ch];
    }
    size_t entries = 0;
    for (size_t i = 0; i < hits; ++i)
        entries += T[i].site != UINT32_MAX;
    /* Jacobi sweeps from I = C (invariant 4).
     *
     * Stopping. The sweeps' largest changes shrink by about the transport's
     * spectral radius q a sweep (the share of light a bounce keeps), so the
     * iterate still lacks about change q / (1 - q). Stopping at a change of
     * 10 ppm, as before stop 31, is right for q <= 1/2 but left a white
     * room lit through its window (q ~ 0.98) 6e-4 dark in the furnace.
     * q is estimated from successive changes, the larger of the last two
     * ratios; q >= 1 (not yet contracting) never stops on the prediction. */
    memcpy(I, C, 3 * sites * sizeof *I);
    int it = 0;
    double residual = 0.0, last_change = 0.0, last_q = 1.0;
    for (it = 0; it < max_iterations && sites; ++it) {
        double change = 0.0, largest = 0.0;
#pragma omp parallel for schedule(static) num_threads(nt) reduction(max : change, largest)
        for (size_t g = 0; g < sites; ++g) {
            double v[3] = {C[3 * g], C[3 * g + 1], C[3 * g + 2]};
            for (size_t j = row[g]; j < row[g + 1]; ++j) {
                const entry *e = &T[j];
                if (e->site == UINT32_MAX)
                    break;
                const float *x = I + 3 * (size_t)e->site;
                v[0] += e->w[0] * x[0];
                v[1] += e->w[1] * x[1];
                v[2] += e->w[2] * x[2];
            }
            for (int ch = 0; ch < 3; ++ch) {
                float nv = isfinite(v[ch]) ? (float)v[ch] : 0.0f;
                double dch = fabs((double)nv - (double)I[3 * g + ch]);
                change = dch > change ? dch : change;
                largest = nv > largest ? nv : largest;
                J[3 * g + ch] = nv;
            }
        }
        float *tmp = I;
        I = J;
        J = tmp;
        residual = largest > 0.0 ? change / largest : 0.0;
        const double ratio = last_change > 0.0 ? change / last_change : 1.0, q = ratio > last_q ? ratio : last_q;
        last_change = change;
        last_q = ratio;
        if (residual <= FLOOR_PPM * 1e-6 || (q < 1.0 && residual * q <= TOLERANCE_PPM * 1e-6 * (1.0 - q)))
            break;
    }
    for (size_t m = 0; m < nm; ++m)
        memcpy(indirect[m], I + 3 * offset[m], 3 * (offset[m + 1] - offset[m]) * sizeof(float));
    if (stats)
        *stats = (sg_transport_stats){.sites = sites, .entries = entries, .iterations = it + (it < max_iterations),
                                      .residual = residual};
done:
    sg_free(offset);
    sg_free(row);
    sg_free(T);
    sg_free(C);
    sg_free(I);
    sg_free(J);
    return st;
}
