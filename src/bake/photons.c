/* photons.c — light tracing from the envmap (see photons.h).
 *
 * Random dimensions per photon i and interaction b:
 *   b = 0: 0, 1 envmap direction; 2, 3 point on the emitting disk;
 *   b >= 1: 0, 1, 2 BSDF sample; 3 Russian roulette.
 *
 * Invariants:
 *  1. a record's flux is finite and >= 0 per channel;
 *  2. record order = (block, photon in block, interaction): a function of
 *     the input only (thread-count independence).
 */
#include "bake/photons.h"

#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/alloc.h"
#include "math/rng.h"

static const float PI_F = 3.14159265358979f;

typedef struct rec {
    float p[3], n[3], w[3], f[3];
    uint32_t model;
} rec;

typedef struct block {
    rec *r;
    size_t n, cap;
    sg_ray_stats rays;
    int failed;
} block;

static int push(block *b, const rec *r)
{
    if (b->n == b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 4096;
        void *p = b->r;
        if (!sg_realloc_array(&p, b->n, cap, sizeof *b->r))
            return 0;
        b->r = p;
        b->cap = cap;
    }
    b->r[b->n++] = *r;
    return 1;
}

static float max3(sg_vec3 v) { return fmaxf(v.x, fmaxf(v.y, v.z)); }

static void trace_photon(const sg_world *w, const sg_photon_desc *d, uint64_t i, sg_vec3 centre, float radius,
                         float share, block *b)
{
    const sg_envmap *env = sg_world_envmap(w);
    float pdf;
    sg_vec3 dir_env = sg_envmap_sample(env, sg_rng_float(d->seed, i, 0, 0), sg_rng_float(d->seed, i, 0, 1), &pdf);
    if (!(pdf > 0.0f))
        return;
    sg_vec3 Le = sg_envmap_eval(env, dir_env);
    /* Uniform point of the disk of radius R across dir_env, outside the
     * bounding sphere; the photon travels towards the scene. */
    sg_vec3 t1, t2;
    sg_v3_basis(dir_env, &t1, &t2);
    float r = radius * sqrtf(sg_rng_float(d->seed, i, 0, 2)), phi = 2.0f * PI_F * sg_rng_float(d->seed, i, 0, 3);
    sg_vec3 o = sg_v3_add(centre, sg_v3_scale(dir_env, 1.01f * radius));
    o = sg_v3_madd(sg_v3_madd(o, t1, r * cosf(phi)), t2, r * sinf(phi));
    sg_vec3 flux = sg_v3_scale(Le, PI_F * radius * radius * share / pdf);
    sg_ray ray = {.org = o, .dir = sg_v3_scale(dir_env, -1.0f), .tmin = 0.0f, .tmax = INFINITY};
    for (int depth = 0; depth < d->max_depth; ++depth) {
        sg_world_hit h;
        if (!sg_world_intersect(w, &ray, &h, &b->rays))
            return;
        sg_vec3 wi = sg_v3_scale(ray.dir, -1.0f);
        sg_vec3 n = sg_v3_dot(h.hit.n, wi) < 0.0f ? sg_v3_scale(h.hit.n, -1.0f) : h.hit.n;
        rec r = {{h.hit.p.x, h.hit.p.y, h.hit.p.z}, {n.x, n.y, n.z}, {wi.x, wi.y, wi.z}, {flux.x, flux.y, flux.z},
                 h.model};
        if (!push(b, &r)) {
            b->failed = 1;
            return;
        }
        uint32_t bn = (uint32_t)depth + 1;
        const sg_material *m = sg_world_material(w, h.model);
        sg_vec3 albedo = sg_world_albedo(w, &h);
        sg_vec3 wo, weight;
        float pdf_b;
        /* Scattering a photon: wi (where it came from) plays the role of
         * the view direction; the BSDF is reciprocal. */
        if (!sg_bsdf_sample(m, albedo, n, wi, sg_rng_float(d->seed, i, bn, 0), sg_rng_float(d->seed, i, bn, 1),
                            sg_rng_float(d->seed, i, bn, 2), &wo, &pdf_b, &weight))
            return;
        flux = sg_v3_mul(flux, weight);
        if (depth + 1 >= d->rr_depth) {
            float q = fminf(0.95f, max3(weight));
            if (!(q > 0.0f) || sg_rng_float(d->seed, i, bn, 3) >= q)
                return;
            flux = sg_v3_scale(flux, 1.0f / q);
        }
        ray = sg_world_spawn_ray(w, &h, wo, INFINITY);
    }
}

sg_status sg_photons_trace(const sg_world *w, const sg_photon_desc *desc, sg_photon_map *out, sg_error *err)
{
    sg_photon_desc d = desc ? *desc : (sg_photon_desc){0};
    if (d.count == 0) d.count = 1000000;
    if (d.seed == 0) d.seed = 1;
    if (d.max_depth <= 0) d.max_depth = 8;
    if (d.rr_depth <= 0) d.rr_depth = 2;
    if (d.count > ((size_t)1 << 34))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "photons: %zu photons is too many", d.count);
    sg_aabb bb = sg_world_bounds(w);
    sg_vec3 centre = sg_v3_scale(sg_v3_add(bb.lo, bb.hi), 0.5f);
    float radius = 0.5f * sg_aabb_diagonal(bb);
    if (!(radius > 0.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "photons: the scene has no extent");
    size_t nblocks = (d.count + SG_PHOTON_BLOCK - 1) / SG_PHOTON_BLOCK;
    block *blocks = sg_calloc_array(nblocks, sizeof *blocks);
    if (!blocks)
        return sg_error_set(err, SG_ERR_NOMEM, "photons: out of memory");
    double t0 = omp_get_wtime();
    int threads = d.threads > 0 ? d.threads : omp_get_max_threads();
    float share = 1.0f / (float)d.count;
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (size_t bi = 0; bi < nblocks; ++bi) {
        size_t end = (bi + 1) * SG_PHOTON_BLOCK < d.count ? (bi + 1) * SG_PHOTON_BLOCK : d.count;
        for (size_t i = bi * SG_PHOTON_BLOCK; i < end && !blocks[bi].failed; ++i)
            trace_photon(w, &d, i, centre, radius, share, &blocks[bi]);
    }
    sg_status st = SG_OK;
    sg_photon_map m = {0};
    size_t total = 0;
    for (size_t bi = 0; bi < nblocks; ++bi) {
        if (blocks[bi].failed)
            st = sg_error_set(err, SG_ERR_NOMEM, "photons: out of memory for photon records");
        total += blocks[bi].n;
        sg_ray_stats_add(&m.rays, &blocks[bi].rays);
    }
    float **arrays[12] = {&m.px, &m.py, &m.pz, &m.nx, &m.ny, &m.nz, &m.wx, &m.wy, &m.wz, &m.fr, &m.fg, &m.fb};
    if (st == SG_OK) {
        for (int a = 0; a < 12; ++a)
            if (!(*arrays[a] = sg_alloc_array(total ? total : 1, sizeof(float))))
                st = sg_error_set(err, SG_ERR_NOMEM, "photons: out of memory for %zu records", total);
        if (!(m.model = sg_alloc_array(total ? total : 1, sizeof(uint32_t))))
            st = sg_error_set(err, SG_ERR_NOMEM, "photons: out of memory for %zu records", total);
    }
    if (st == SG_OK) {
        size_t k = 0; /* invariant 2: block order */
        for (size_t bi = 0; bi < nblocks; ++bi)
            for (size_t j = 0; j < blocks[bi].n; ++j, ++k) {
                const rec *r = &blocks[bi].r[j];
                m.px[k] = r->p[0]; m.py[k] = r->p[1]; m.pz[k] = r->p[2];
                m.nx[k] = r->n[0]; m.ny[k] = r->n[1]; m.nz[k] = r->n[2];
                m.wx[k] = r->w[0]; m.wy[k] = r->w[1]; m.wz[k] = r->w[2];
                m.fr[k] = r->f[0]; m.fg[k] = r->f[1]; m.fb[k] = r->f[2];
                m.model[k] = r->model;
            }
        m.count = total;
        m.shot = d.count;
        m.seconds = omp_get_wtime() - t0;
    }
    for (size_t bi = 0; bi < nblocks; ++bi)
        sg_free(blocks[bi].r);
    sg_free(blocks);
    if (st != SG_OK) {
        sg_photon_map_free(&m);
        return st;
    }
    *out = m;
    return SG_OK;
}

void sg_photon_map_free(sg_photon_map *m)
{
    if (!m)
        return;
    float *arrays[12] = {m->px, m->py, m->pz, m->nx, m->ny, m->nz, m->wx, m->wy, m->wz, m->fr, m->fg, m->fb};
    for (int a = 0; a < 12; ++a)
        sg_free(arrays[a]);
    sg_free(m->model);
    memset(m, 0, sizeof *m);
}
