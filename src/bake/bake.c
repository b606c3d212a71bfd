/* bake.c — the bake's pipeline and the lookup (see bake.h).
 *
 * States of a bake and the function behind each step:
 *   world LOADED (sg_world_create) -> [photon estimator: photons TRACED
 *   (sg_photons_trace or sg_photons_trace_more per chunk, checkpointable:
 *   bake_io.h)] -> GATHERED (bake_pipeline, from sg_bake_create or
 *   sg_bake_create_from_photons) -> WRITTEN (sg_bake_save) -> LOADED again
 *   (sg_bake_load) -> lookups.
 *
 * The pipeline, in this order:
 *   [photon estimator: E per side at every splat from the photon map]
 *   -> sample points per model at the material's spacing (samples.h)
 *   -> the rays of their sites, both sides (transport.h)
 *   -> REFINE levels: samples marked where the direct light jumps between
 *      neighbours or where nearby surfaces fill the sites' view (Ward's
 *      harmonic mean distance below the spacing), thinned at half the
 *      spacing, their sites' rays traced
 *   -> [transport estimator: the indirect light of every site, solved]
 *   -> interpolation of each site's visibility ratio and indirect light to
 *      every splat, E += E0(n) * ratio + indirect per side
 *   -> once E is final for every model, the glossy bins of glossy models
 *      (glossy.h: their rays read E where they hit).
 *
 * Invariants:
 *  1. E[m] holds SG_BAKE_SPLAT_FLOATS floats per light site of model m
 *     (sites.h: a splat of an MLS or disk surface) (per side,
 *     front then back: the visibility ratio RGB, then the indirect
 *     irradiance RGB), in the order of sg_scene_sites(sg_world_scene(w,
 *     m)), finite and >= 0; e0 is the table of the world's envmap;
 *  2. the lookup's interpolation weights sum to 1 (sg_scene_hit_sites),
 *     so a constant E is reproduced exactly: no seams between splats; the
 *     glossy blend uses the same weights, summed per sample point;
 *  3. gres[m] > 0 exactly when model m has bins; then gnear[m][i] <
 *     gcount[m] for every splat i and gsplat[m][j] < the splat count.
 */
#include "bake/bake.h"

#include <assert.h>
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <string.h>

#include "bake/bake_job_int.h"
#include "bake/glossy.h"
#include "bake/transport.h"
#include "core/alloc.h"
#include "envmap/irradiance_table.h"

static const float INV_PI = 0.318309886183791f;

enum { LOOKUP_SPLATS = 32, TILE = 16 };
_Static_assert(LOOKUP_SPLATS <= 32, "keep_facing marks a lookup's sites in one 32-bit word");

struct sg_bake {
    size_t models;
    sg_irradiance_table *e0; /* unshadowed irradiance of the envmap by normal */
    size_t *count;    /* splats per model                                */
    float **E;        /* irradiance per splat (invariant 1)              */
    size_t *samples;  /* sample points per model                         */
    int *gres;        /* glossy bins per side; 0: none (invariant 3)     */
    size_t *gcount;   /* glossy sample points per model                  */
    uint32_t **gsplat;/* splat of each glossy sample point               */
    uint32_t **gnear; /* per splat: its glossy sample point              */
    uint16_t **gbins; /* 3 res^2 halves per glossy sample point          */
    sg_bake_desc desc;   /* resolved; threads/progress cleared */
    sg_bake_stats stats;
};

sg_bake_desc sg_bake_desc_resolve(const sg_bake_desc *desc)
{
    sg_bake_desc d = desc ? *desc : (sg_bake_desc){0};
    d.photons = sg_photon_desc_resolve(&d.photons);
    /* irradiance.h's defaults, spelt out so the parameter hash sees them */
    if (d.gather.k == 0) d.gather.k = 64;
    if (d.gather.normal_cos == 0.0f) d.gather.normal_cos = 0.7f;
    /* 32 + 32 rays per sample point: with about 1/7 to 1/40 of the splats
     * as points this costs less than 16 + 16 at every splat did, and the
     * points' noise, which interpolation spreads over several splats, is
     * what limits the error (docs/bake.md). */
    if (d.indirect != SG_BAKE_INDIRECT_PHOTONS) d.indirect = SG_BAKE_INDIRECT_TRANSPORT;
    if (d.direct_samples == 0) d.direct_samples = 32;
    if (d.direct_samples < 0) d.direct_samples = d.indirect == SG_BAKE_INDIRECT_PHOTONS ? -1 : 32;
    /* Cosine rays carry the indirect light of the transport estimator:
     * twice the envmap samples by default (docs/bake.md measures them). */
    if (d.gather_rays <= 0) d.gather_rays = d.indirect == SG_BAKE_INDIRECT_PHOTONS ? 32 : 64;
    if (d.refine_levels == 0) d.refine_levels = 2;
    if (d.refine_levels < 0) d.refine_levels = -1;
    if (d.refine_levels > SG_SAMPLES_MAX_LEVEL - 1) d.refine_levels = SG_SAMPLES_MAX_LEVEL - 1;
    if (d.sample_spacing < 0.0f || isnan(d.sample_spacing)) d.sample_spacing = -1.0f;
    if (d.glossy_rays <= 0) d.glossy_rays = SG_GLOSSY_DEFAULT_RAYS;
    if (d.glossy_res < 0) d.glossy_res = 0;
    if (d.ray_cone == 0.0f) d.ray_cone = SG_BAKE_RAY_CONE_DEFAULT;
    if (!(d.ray_cone > 0.0f) || !isfinite(d.ray_cone)) d.ray_cone = -1.0f;
    if (d.ray_cone > SG_BAKE_RAY_CONE_MAX) d.ray_cone = SG_BAKE_RAY_CONE_MAX;
    /* With direct light computed by shadow rays, photons record only what
     * arrives after a bounce: direct light is not counted twice. */
    if (d.direct_samples > 0)
        d.photons.flags |= SG_PHOTONS_INDIRECT_ONLY;
    else
        d.photons.flags &= ~(uint32_t)SG_PHOTONS_INDIRECT_ONLY;
    return d;
}

static void fnv_u64(uint64_t *h, uint64_t v)
{
    for (int i = 0; i < 8; ++i) {
        *h ^= (v >> (8 * i)) & 0xffu;
        *h *= 0x100000001b3ull;
    }
}

uint64_t sg_bake_param_hash(const sg_bake_desc *desc)
{
    sg_bake_desc d = sg_bake_desc_resolve(desc);
    uint32_t cos_bits;
    memcpy(&cos_bits, &d.gather.normal_cos, sizeof cos_bits);
    uint64_t h = 0xcbf29ce484222325ull;
    fnv_u64(&h, d.photons.count);
    fnv_u64(&h, d.photons.seed);
    fnv_u64(&h, (uint64_t)d.photons.max_depth);
    fnv_u64(&h, (uint64_t)d.photons.rr_depth);
    fnv_u64(&h, d.gather.k);
    fnv_u64(&h, cos_bits);
    fnv_u64(&h, SG_PHOTON_BLOCK);
    fnv_u64(&h, (uint64_t)(int64_t)d.direct_samples);
    uint32_t sp_bits;
    memcpy(&sp_bits, &d.sample_spacing, sizeof sp_bits);
    fnv_u64(&h, sp_bits);
    fnv_u64(&h, (uint64_t)(int64_t)d.glossy_res);
    fnv_u64(&h, (uint64_t)(int64_t)d.glossy_rays);
    fnv_u64(&h, (uint64_t)d.indirect);
    fnv_u64(&h, (uint64_t)(int64_t)d.gather_rays);
    fnv_u64(&h, (uint64_t)(int64_t)d.refine_levels);
    if (d.ray_cone > 0.0f) { /* off: the key of a bake made before the option */
        uint32_t rc_bits;
        memcpy(&rc_bits, &d.ray_cone, sizeof rc_bits);
        fnv_u64(&h, 0x52434f4e45ull); /* "RCONE": apart from the fields before */
        fnv_u64(&h, rc_bits);
    }
    fnv_u64(&h, SG_BAKE_ALGORITHM); /* same parameters, other estimator: other values */
    return h ? h : 1; /* 0 means "do not check" to bake_file.h */
}

static int alloc_model_arrays(sg_bake *b)
{
    size_t n = b->models;
    b->count = sg_calloc_array(n, sizeof *b->count);
    b->E = sg_calloc_array(n, sizeof *b->E);
    b->samples = sg_calloc_array(n, sizeof *b->samples);
    b->gres = sg_calloc_array(n, sizeof *b->gres);
    b->gcount = sg_calloc_array(n, sizeof *b->gcount);
    b->gsplat = sg_calloc_array(n, sizeof *b->gsplat);
    b->gnear = sg_calloc_array(n, sizeof *b->gnear);
    b->gbins = sg_calloc_array(n, sizeof *b->gbins);
    return b->count && b->E && b->samples && b->gres && b->gcount && b->gsplat && b->gnear && b->gbins;
}

static void update_memory_stats(sg_bake *b)
{
    sg_bake_stats *s = &b->stats;
    s->splats = s->sample_points = s->glossy_points = 0;
    s->sample_bytes = s->glossy_bytes = 0;
    for (size_t m = 0; m < b->models; ++m) {
        s->splats += b->count[m];
        s->sample_points += b->samples[m];
        if (b->gres[m] > 0) {
            s->glossy_points += b->gcount[m];
            s->sample_bytes += (b->gcount[m] + b->count[m]) * sizeof(uint32_t);
            s->glossy_bytes += b->gcount[m] * 3 * (size_t)b->gres[m] * (size_t)b->gres[m] * sizeof(uint16_t);
        }
    }
    s->irradiance_bytes = s->splats * SG_BAKE_SPLAT_FLOATS * sizeof(float);
    s->memory_bytes = s->irradiance_bytes + s->sample_bytes + s->glossy_bytes;
}

sg_status sg_bake__new(const sg_envmap *env, size_t models, const size_t *counts, const sg_bake_desc *desc,
                       const sg_bake_stats *stats, sg_bake **out, sg_error *err)
{
    sg_bake *b = sg_calloc_array(1, sizeof *b);
    if (!b)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
    sg_irradiance_table_desc td = {.threads = desc ? desc->gather.threads : 0};
    sg_status st = sg_irradiance_table_create(env, &td, &b->e0, err);
    if (st != SG_OK) {
        sg_free(b);
        return st;
    }
    b->models = models;
    b->desc = sg_bake_desc_resolve(desc);
    b->desc.photons.threads = b->desc.gather.threads = 0;
    b->desc.photons.progress = NULL;
    b->desc.photons.progress_user = NULL;
    if (stats)
        b->stats = *stats;
    b->stats.models = models;
    b->stats.splats = 0;
    if (!alloc_model_arrays(b))
        goto nomem;
    for (size_t m = 0; m < models; ++m) {
        size_t nf;
        if (!sg_mul_size(counts[m], SG_BAKE_SPLAT_FLOATS, &nf) || !(b->E[m] = sg_calloc_array(nf, sizeof(float))))
            goto nomem;
        b->count[m] = counts[m];
        b->stats.splats += counts[m];
    }
    update_memory_stats(b);
    *out = b;
    return SG_OK;
nomem:
    sg_bake_destroy(b);
    return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for the irradiance of %zu models", models);
}

const sg_irradiance_table *sg_bake__table(const sg_bake *b) { return b->e0; }

sg_bake_stats *sg_bake__stats(sg_bake *b) { return &b->stats; }

void sg_bake__update_memory(sg_bake *b) { update_memory_stats(b); }

/* sg_bake_create's adapter: the photon desc's progress callback sees the
 * photon stage only. */
static int photon_progress(void *user, const sg_bake_progress *p)
{
    const sg_photon_desc *pd = user;
    return p->stage == SG_BAKE_STAGE_PHOTONS ? pd->progress(pd->progress_user, p->done, p->total) : 0;
}

float *sg_bake__light(sg_bake *b, uint32_t m)
{
    assert(m < b->models);
    return b->E[m];
}

void sg_bake__set_samples(sg_bake *b, uint32_t m, size_t samples)
{
    assert(m < b->models);
    b->samples[m] = samples;
    update_memory_stats(b);
}

sg_status sg_bake__alloc_glossy(sg_bake *b, uint32_t m, int res, size_t count, sg_error *err)
{
    assert(m < b->models && res >= SG_GLOSSY_MIN_RES && res <= SG_GLOSSY_MAX_RES && !b->gres[m]);
    size_t nbins;
    if (!sg_mul_size(count, 3 * (size_t)res * (size_t)res, &nbins) ||
        !(b->gsplat[m] = sg_alloc_array(count, sizeof(uint32_t))) ||
        !(b->gnear[m] = sg_alloc_array(b->count[m], sizeof(uint32_t))) ||
        !(b->gbins[m] = sg_alloc_array(nbins, sizeof(uint16_t)))) {
        sg_free(b->gsplat[m]);
        sg_free(b->gnear[m]);
        b->gsplat[m] = b->gnear[m] = NULL;
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu glossy sample points of model %u", count,
                            m);
    }
    b->gres[m] = res;
    b->gcount[m] = count;
    update_memory_stats(b);
    return SG_OK;
}

void sg_bake__glossy(sg_bake *b, uint32_t m, uint32_t **splat, uint32_t **nearest, uint16_t **bins)
{
    assert(m < b->models && b->gres[m] > 0);
    *splat = b->gsplat[m];
    *nearest = b->gnear[m];
    *bins = b->gbins[m];
}

sg_status sg_bake_create_from_photons(const sg_world *w, const sg_bake_desc *desc, const sg_photon_map *pm,
                                      sg_bake **out, sg_error *err)
{
    sg_bake_desc d = sg_bake_desc_resolve(desc);
    if (d.indirect != SG_BAKE_INDIRECT_PHOTONS)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake: a photon map given to the transport estimator");
    size_t nblocks = sg_photon_block_count(&d.photons);
    if (pm->blocks != nblocks)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake: the photon map holds %zu of the pass's %zu blocks",
                            pm->blocks, nblocks);
    sg_bake_job *j = NULL;
    sg_status st = sg_bake_job_create(w, &d, &j, err);
    if (st != SG_OK)
        return st;
    sg_bake_job__borrow_photons(j, pm);
    if ((st = sg_bake_job_run(j, NULL, NULL, err)) == SG_OK)
        st = sg_bake_job_finish(j, out, err);
    sg_bake_job_destroy(j);
    return st;
}

sg_status sg_bake_create(const sg_world *w, const sg_bake_desc *desc, sg_bake **out, sg_error *err)
{
    sg_bake_desc d = sg_bake_desc_resolve(desc);
    sg_bake_job *j = NULL;
    sg_status st = sg_bake_job_create(w, &d, &j, err);
    if (st != SG_OK)
        return st;
    /* the photon pass's own progress callback and its cancel, as before */
    if ((st = sg_bake_job_run(j, d.photons.progress ? photon_progress : NULL, &d.photons, err)) == SG_OK)
        st = sg_bake_job_finish(j, out, err);
    sg_bake_job_destroy(j);
    return st;
}

void sg_bake_destroy(sg_bake *b)
{
    if (!b)
        return;
    for (size_t m = 0; m < b->models; ++m) {
        if (b->E)
            sg_free(b->E[m]);
        if (b->gsplat)
            sg_free(b->gsplat[m]);
        if (b->gnear)
            sg_free(b->gnear[m]);
        if (b->gbins)
            sg_free(b->gbins[m]);
    }
    sg_free(b->E);
    sg_irradiance_table_destroy(b->e0);
    sg_free(b->gsplat);
    sg_free(b->gnear);
    sg_free(b->gbins);
    sg_free(b->gres);
    sg_free(b->gcount);
    sg_free(b->samples);
    sg_free(b->count);
    sg_free(b);
}

void sg_bake_get_stats(const sg_bake *b, sg_bake_stats *stats) { *stats = b->stats; }

sg_bake_desc sg_bake_get_desc(const sg_bake *b) { return b->desc; }

size_t sg_bake_model_count(const sg_bake *b) { return b->models; }

const float *sg_bake_light_data(const sg_bake *b, uint32_t m, size_t *splats)
{
    assert(m < b->models);
    if (splats)
        *splats = b->count[m];
    return b->E[m];
}

size_t sg_bake_sample_count(const sg_bake *b, uint32_t m)
{
    assert(m < b->models);
    return b->samples[m];
}

void sg_bake_glossy_data(const sg_bake *b, uint32_t m, int *res, size_t *count, const uint32_t **splat,
                         const uint32_t **nearest, const uint16_t **bins)
{
    assert(m < b->models);
    *res = b->gres[m];
    if (!b->gres[m])
        return;
    *count = b->gcount[m];
    *splat = b->gsplat[m];
    *nearest = b->gnear[m];
    *bins = b->gbins[m];
}

/* The lookup's splats: the n MLS weights at the hit (invariant 2; from
 * sg_scene_hit_sites), keeping only splats that face the way the surface at the hit does. A thin wall
 * made of two layers of opposite normals within each other's support puts
 * both layers' splats in the weights; each layer's light belongs to its
 * own outer side, so the other layer's splats are dropped and the rest
 * renormalised. Returns the count; side gets the side of the hit that
 * faces wo (0 front, 1 back). */
static int keep_facing(const sg_world *w, const sg_world_hit *h, sg_vec3 wo, uint32_t *ids, float *wts, int n,
                       int *side)
{
    const sg_scene *sc = sg_world_scene(w, h->model);
    *side = sg_v3_dot(wo, h->hit.n) < 0.0f;
    const sg_sites *ps = sg_scene_sites(sc);
    float kept = 0.0f;
    int k = 0;
    uint32_t away = 0; /* bit j: site j faces away (LOOKUP_SPLATS <= 32) */
    for (int j = 0; j < n; ++j) {
        uint32_t i = ids[j];
        if (ps->nx[i] * h->hit.n.x + ps->ny[i] * h->hit.n.y + ps->nz[i] * h->hit.n.z < 0.0f) {
            away |= 1u << j;
            continue;
        }
        ++k;
        kept += wts[j];
    }
    /* All same-facing (the usual case), or none with weight: the list as
     * it is. (Compacting before this test left a list of the kept sites'
     * zero weights and a stale tail: black specks where the only weighted
     * site faced away, 3 channels of 8 ISO frames at 128 x 128.) */
    if (k == n || !(kept > 0.0f))
        return n;
    k = 0;
    for (int j = 0; j < n; ++j)
        if (!(away >> j & 1u)) {
            ids[k] = ids[j];
            wts[k++] = wts[j] / kept;
        }
    return k;
}

static int lookup_weights(const sg_world *w, const sg_world_hit *h, sg_vec3 wo, uint32_t *ids, float *wts,
                          int *side)
{
    int n = sg_scene_hit_sites(sg_world_scene(w, h->model), &h->hit, ids, wts, LOOKUP_SPLATS);
    return keep_facing(w, h, wo, ids, wts, n, side);
}

/* E = E0(n) * ratio + indirect, the ratio and the indirect light blended
 * with the lookup's weights, E0 at the hit's own normal n on the side seen
 * (interpolating E itself would average the cosines of the splats'
 * normals: on a scanned statue their weighted mean is 2% shorter than a
 * unit normal and E0 0.5% lower, measured). */
static sg_vec3 irradiance_of(const sg_bake *b, uint32_t model, const uint32_t *ids, const float *wts, int n,
                             int side, sg_vec3 normal)
{
    const float *E = b->E[model] + 6 * side;
    float r[3] = {0, 0, 0}, ind[3] = {0, 0, 0};
    for (int j = 0; j < n; ++j) {
        const float *v = E + SG_BAKE_SPLAT_FLOATS * (size_t)ids[j];
        for (int c = 0; c < 3; ++c) {
            r[c] += wts[j] * v[c];
            ind[c] += wts[j] * v[3 + c];
        }
    }
    sg_vec3 e0 = sg_irradiance_table_eval_fast(b->e0, side ? sg_v3_scale(normal, -1.0f) : normal);
    return sg_v3(e0.x * r[0] + ind[0], e0.y * r[1] + ind[1], e0.z * r[2] + ind[2]);
}

sg_vec3 sg_bake_splat_irradiance(const sg_bake *b, const sg_world *w, uint32_t m, size_t splat, int side)
{
    assert(m < b->models && splat < b->count[m] && (side == 0 || side == 1));
    uint32_t id = (uint32_t)splat;
    float one = 1.0f;
    return irradiance_of(b, m, &id, &one, 1, side, sg_sites_normal(sg_scene_sites(sg_world_scene(w, m)), splat));
}

sg_vec3 sg_bake_irradiance(const sg_bake *b, const sg_world *w, const sg_world_hit *h, sg_vec3 wo)
{
    uint32_t ids[LOOKUP_SPLATS];
    float wts[LOOKUP_SPLATS];
    int side;
    int n = lookup_weights(w, h, wo, ids, wts, &side);
    return irradiance_of(b, h->model, ids, wts, n, side, h->hit.n);
}

/* sg_bake_lookup from the hit's sites (n of them in ids, wts; rewritten). */
static sg_vec3 lookup_sites(const sg_bake *b, const sg_world *w, const sg_world_hit *h, sg_vec3 wo, uint32_t *ids,
                            float *wts, int n)
{
    const sg_material *m = sg_world_material(w, h->model);
    uint32_t sid[LOOKUP_SPLATS];
    float sw[LOOKUP_SPLATS];
    int side, ns = 0;
    sg_vec3 rho = sg_world_albedo_sites(w, h, ids, wts, n);
    n = keep_facing(w, h, wo, ids, wts, n, &side);
    sg_vec3 E = irradiance_of(b, h->model, ids, wts, n, side, h->hit.n);
    int res = b->gres[h->model];
    if (!res || !sg_glossy_material(m)) /* the diffuse path, as fast as before bins */
        return sg_v3_add(m->emission, sg_v3_scale(sg_v3_mul(rho, E), INV_PI));
    if (side) /* no bins behind a glossy surface: it reflects as in the transport */
        return sg_v3_add(m->emission, sg_v3_mul(sg_transport_reflectance(m, rho), E));
    /* The splats' weights, summed per glossy sample point (invariant 2). */
    const uint32_t *near = b->gnear[h->model];
    for (int j = 0; j < n; ++j) {
        uint32_t s = near[ids[j]];
        int k = 0;
        while (k < ns && sid[k] != s)
            ++k;
        if (k == ns) {
            sid[ns] = s;
            sw[ns++] = 0.0f;
        }
        sw[k] += wts[j];
    }
    const sg_sites *ps = sg_scene_sites(sg_world_scene(w, h->model));
    size_t stride = 3 * (size_t)res * (size_t)res;
    sg_vec3 S = {0, 0, 0};
    for (int k = 0; k < ns; ++k) {
        sg_vec3 n_s = sg_sites_normal(ps, b->gsplat[h->model][sid[k]]);
        S = sg_v3_add(S, sg_v3_scale(sg_glossy_eval(b->gbins[h->model] + sid[k] * stride, res, n_s, h->hit.n, wo),
                                     sw[k]));
    }
    float ks = m->specular > 1.0f ? 1.0f : m->specular;
    return sg_v3_add(sg_v3_add(m->emission, sg_v3_scale(sg_v3_mul(rho, E), (1.0f - ks) * INV_PI)),
                     sg_v3_scale(S, ks));
}

sg_vec3 sg_bake_lookup(const sg_bake *b, const sg_world *w, const sg_world_hit *h, sg_vec3 wo)
{
    uint32_t ids[LOOKUP_SPLATS];
    float wts[LOOKUP_SPLATS];
    /* The hit's sites once, for the albedo (a hybrid hit's is their
     * blend) and, kept facing, for the light. */
    int n = sg_scene_hit_sites(sg_world_scene(w, h->model), &h->hit, ids, wts, LOOKUP_SPLATS);
    return lookup_sites(b, w, h, wo, ids, wts, n);
}

void sg_bake_lookup16(const sg_bake *b, const sg_world *w, const sg_world_hit *h, const sg_vec3 *wo, unsigned mask,
                      sg_vec3 *out)
{
    uint32_t ids[16][LOOKUP_SPLATS];
    float wts[16][LOOKUP_SPLATS];
    int n[16];
    mask &= 0xFFFFu;
    /* Every hit's sites first, and what the lookup will read of each site
     * asked for: a block's sites are scattered over arrays far larger than
     * the cache, and one pixel at a time their misses came one by one. */
    for (unsigned m = mask; m; m &= m - 1) {
        const int r = __builtin_ctz(m);
        const sg_scene *sc = sg_world_scene(w, h[r].model);
        n[r] = sg_scene_hit_sites(sc, &h[r].hit, ids[r], wts[r], LOOKUP_SPLATS);
        const sg_sites *ps = sg_scene_sites(sc);
        const float *E = b->E[h[r].model];
        for (int j = 0; j < n[r]; ++j) {
            const uint32_t i = ids[r][j];
            /* Both ends where a 48-byte record straddles two lines (at one
             * offset in four), and only what the lookup reads: the misses
             * of a block, some 16 x 3 sites x 5 lines, outnumber what a core
             * keeps in flight, so a prefetch of a line already asked for,
             * or of colours a white mesh never reads, stalls the ones that
             * count (bench_view_split, hybrid: the colours' prefetches took
             * 4-7% of the view, docs/bench_view.md stop 29). */
            const float *rec = E + SG_BAKE_SPLAT_FLOATS * (size_t)i, *end = rec + (SG_BAKE_SPLAT_FLOATS - 1);
            __builtin_prefetch(rec);
            if (((uintptr_t)rec ^ (uintptr_t)end) >> 6)
                __builtin_prefetch(end);
            if (i >= ps->count)
                continue; /* not a site of the table (a point's own colour) */
            __builtin_prefetch(&ps->nx[i]);
            __builtin_prefetch(&ps->ny[i]);
            __builtin_prefetch(&ps->nz[i]);
            if (ps->ar && !ps->white) {
                __builtin_prefetch(&ps->ar[i]);
                __builtin_prefetch(&ps->ag[i]);
                __builtin_prefetch(&ps->ab[i]);
            }
        }
    }
    for (unsigned m = mask; m; m &= m - 1) {
        const int r = __builtin_ctz(m);
        out[r] = lookup_sites(b, w, &h[r], wo[r], ids[r], wts[r], n[r]);
    }
}

sg_status sg_bake_render(const sg_bake *b, const sg_world *w, const sg_bake_frame_desc *desc, sg_image *out,
                         double *seconds, sg_error *err)
{
    sg_bake_frame_desc d = *desc;
    if (d.width <= 0) d.width = 512;
    if (d.height <= 0) d.height = 512;
    sg_image img = {0};
    sg_status st = sg_image_alloc(&img, d.width, d.height, err);
    if (st != SG_OK)
        return st;
    const sg_envmap *env = sg_world_envmap(w);
    int tiles_x = (d.width + TILE - 1) / TILE, tiles = tiles_x * ((d.height + TILE - 1) / TILE);
    int threads = d.threads > 0 ? d.threads : omp_get_max_threads();
    double t0 = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (int t = 0; t < tiles; ++t) {
        int x0 = (t % tiles_x) * TILE, y0 = (t / tiles_x) * TILE;
        for (int y = y0; y < y0 + TILE && y < d.height; ++y)
            for (int x = x0; x < x0 + TILE && x < d.width; ++x) {
                sg_ray ray = sg_camera_ray(&d.camera, (float)x + 0.5f, (float)y + 0.5f, d.width, d.height);
                sg_world_hit h;
                sg_vec3 L = sg_world_intersect(w, &ray, &h, NULL)
                                ? sg_bake_lookup(b, w, &h, sg_v3_scale(ray.dir, -1.0f))
                                : sg_envmap_eval(env, ray.dir);
                float *px = img.data + 3 * ((size_t)y * (size_t)d.width + (size_t)x);
                px[0] = L.x;
                px[1] = L.y;
                px[2] = L.z;
            }
    }
    if (seconds)
        *seconds = omp_get_wtime() - t0;
    *out = img;
    return SG_OK;
}
