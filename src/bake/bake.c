/* bake.c — photon pass + gather, and the lookup (see bake.h).
 *
 * States of a bake and the function behind each step:
 *   world LOADED (sg_world_create) -> photons TRACED (sg_photons_trace or
 *   sg_photons_trace_more per chunk, checkpointable: bake_io.h) ->
 *   GATHERED (sg_bake_create_from_photons; sg_bake_create does both) ->
 *   WRITTEN (sg_bake_save) -> LOADED again (sg_bake_load) -> lookups.
 *
 * Gathering, per model m, in this order (sg_bake_create_from_photons):
 *   indirect E at every splat (irradiance.h) -> sample points at the
 *   material's spacing (samples.h) -> direct light at them (direct.h) ->
 *   REFINE_LEVELS refinements where it changes fast, each computed ->
 *   interpolation to every splat, added to E; then, once E is final for
 *   every model, the glossy bins of glossy models (glossy.h: their rays
 *   read E where they hit).
 *
 * Invariants:
 *  1. E[m] holds 3 floats per splat of model m, in the order of
 *     sg_scene_points(sg_world_scene(w, m)), finite and >= 0;
 *  2. the lookup's interpolation weights sum to 1 (sg_scene_hit_weights),
 *     so a constant E is reproduced exactly: no seams between splats; the
 *     glossy blend uses the same weights, summed per sample point;
 *  3. gres[m] > 0 exactly when model m has bins; then gnear[m][i] <
 *     gcount[m] for every splat i and gsplat[m][j] < the splat count.
 */
#include "bake/bake.h"

#include <assert.h>
#include <math.h>
#include <omp.h>
#include <string.h>

#include "bake/direct.h"
#include "bake/glossy.h"
#include "bake/samples.h"
#include "core/alloc.h"
#include "envmap/irradiance_table.h"

static const float INV_PI = 0.318309886183791f;

enum { LOOKUP_SPLATS = 32, TILE = 16 };

/* Refinement of the direct light's sample points (samples.h): levels at
 * s/2 and s/4, where neighbouring samples differ by more than half the
 * larger value (a shadow edge differs by a factor 2 or more) and by more
 * than three standard errors of the difference (noise alone, which at
 * 4 + 4 rays often exceeds 50%, then refines almost nowhere). Interpolation support: twice a
 * sample's spacing (a splat then sees about 4 pi samples, which averages
 * their noise without reaching past the next ring). */
enum { REFINE_LEVELS = 2 };
static const float REFINE_THRESHOLD = 0.5f;
static const float SUPPORT = 2.0f;

struct sg_bake {
    size_t models;
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
    if (d.direct_samples == 0) d.direct_samples = 32;
    if (d.direct_samples < 0) d.direct_samples = -1;
    if (d.sample_spacing < 0.0f || isnan(d.sample_spacing)) d.sample_spacing = -1.0f;
    if (d.glossy_rays <= 0) d.glossy_rays = SG_GLOSSY_DEFAULT_RAYS;
    if (d.glossy_res < 0) d.glossy_res = 0;
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
    s->irradiance_bytes = s->splats * 3 * sizeof(float);
    s->memory_bytes = s->irradiance_bytes + s->sample_bytes + s->glossy_bytes;
}

sg_status sg_bake__new(size_t models, const size_t *counts, const sg_bake_desc *desc, const sg_bake_stats *stats,
                       sg_bake **out, sg_error *err)
{
    sg_bake *b = sg_calloc_array(1, sizeof *b);
    if (!b)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
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
        size_t n3;
        if (!sg_mul_size(counts[m], 3, &n3) || !(b->E[m] = sg_calloc_array(n3, sizeof(float))))
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

float *sg_bake__irradiance(sg_bake *b, uint32_t m)
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

/* Sample points of model m and the direct light interpolated from them,
 * added to E; *set keeps the points (every splat when s0 <= 0). */
/* Direct light at sample points as a visibility ratio: rho = E / E_u per
 * channel, E_u the unshadowed estimate over the same samples
 * (sg_direct_irradiance_at), so rho is exactly 1 wherever nothing blocks
 * the light, however noisy E itself is under a real map. Each splat then
 * gets the interpolated rho times the unshadowed irradiance at its own
 * normal from the table (irradiance_table.h): the normal's cosine is
 * applied exactly, not averaged across a curved surface. A channel with no
 * sampled light takes the luminance ratio, and a sample with none at all
 * rho = 1 (the table says how little light there is). Samples [from, to). */
static void direct_to_ratio(size_t from, size_t to, const float *unshadowed, float *vals)
{
    for (size_t j = from; j < to; ++j) {
        const float *u = unshadowed + 3 * j;
        float *v = vals + 3 * j;
        float lu = 0.2126f * u[0] + 0.7152f * u[1] + 0.0722f * u[2];
        float lv = 0.2126f * v[0] + 0.7152f * v[1] + 0.0722f * v[2];
        float fallback = lu > 0.0f ? lv / lu : 1.0f;
        for (int c = 0; c < 3; ++c)
            v[c] = u[c] > 0.0f ? v[c] / u[c] : fallback;
    }
}

static sg_status direct_at_samples(const sg_world *w, const sg_bake_desc *d, const sg_irradiance_table *e0,
                                   uint32_t m, uint64_t key_base, float s0, float *E, sg_sample_set *set,
                                   sg_error *err)
{
    const sg_pointset *ps = sg_scene_points(sg_world_scene(w, m));
    int direct = d->direct_samples > 0;
    uint64_t seed = d->photons.seed ^ 0xD1EC7ull;
    float *vals = NULL, *sig = NULL, *unsh = NULL, *D = NULL;
    sg_status st = SG_OK;
    if (!(s0 > 0.0f)) { /* every splat a sample point: no interpolation */
        if (!(set->splat = sg_alloc_array(ps->count, sizeof *set->splat)) ||
            !(set->level = sg_calloc_array(ps->count, sizeof *set->level)))
            return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu sample points", ps->count);
        for (size_t i = 0; i < ps->count; ++i)
            set->splat[i] = (uint32_t)i;
        set->count = set->capacity = ps->count;
        if (!direct)
            return SG_OK;
        if (!(D = sg_alloc_array(3 * ps->count, sizeof *D)))
            return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for the direct light");
        st = sg_direct_irradiance_at(w, m, NULL, 0, key_base, d->direct_samples, seed, d->gather.threads, D, NULL, NULL,
                                     err);
        if (st == SG_OK)
            for (size_t i = 0; i < 3 * ps->count; ++i)
                E[i] += D[i];
        sg_free(D);
        return st;
    }
    float cosn = d->gather.normal_cos;
    if ((st = sg_samples_thin(ps, s0, cosn, NULL, 0, 0, set, err)) != SG_OK || !direct)
        return st;
    size_t done = 0;
    for (int level = 0;; ++level) {
        void *grown = vals, *grown_sig = sig, *grown_unsh = unsh;
        int ok = sg_realloc_array(&grown, 3 * done, 3 * set->count, sizeof *vals);
        vals = grown;
        ok = ok && sg_realloc_array(&grown_sig, done, set->count, sizeof *sig);
        sig = grown_sig;
        ok = ok && sg_realloc_array(&grown_unsh, 3 * done, 3 * set->count, sizeof *unsh);
        unsh = grown_unsh;
        if (!ok) {
            st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for the direct light");
            goto done;
        }
        if ((st = sg_direct_irradiance_at(w, m, set->splat + done, set->count - done, key_base, d->direct_samples,
                                          seed, d->gather.threads, vals + 3 * done, unsh + 3 * done, sig + done,
                                          err)) != SG_OK)
            goto done;
        direct_to_ratio(done, set->count, unsh, vals);
        done = set->count;
        size_t added = 0;
        if (level >= REFINE_LEVELS ||
            (st = sg_samples_refine(ps, s0, cosn, vals, sig, REFINE_THRESHOLD, (uint8_t)level, set, &added, err)) !=
                SG_OK ||
            added == 0)
            break;
    }
    if (st != SG_OK)
        goto done;
    if (!(D = sg_alloc_array(3 * ps->count, sizeof *D))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for the direct light");
        goto done;
    }
    st = sg_samples_interpolate(ps, set, s0, SUPPORT, cosn, vals, d->gather.threads, D, err);
    if (st == SG_OK)
        for (size_t i = 0; i < ps->count; ++i) {
            sg_vec3 e = sg_irradiance_table_eval(e0, sg_pointset_normal(ps, i));
            E[3 * i] += D[3 * i] * e.x;
            E[3 * i + 1] += D[3 * i + 1] * e.y;
            E[3 * i + 2] += D[3 * i + 2] * e.z;
        }
done:
    sg_free(vals);
    sg_free(sig);
    sg_free(unsh);
    sg_free(D);
    return st;
}

sg_status sg_bake_create_from_photons(const sg_world *w, const sg_bake_desc *desc, const sg_photon_map *pm,
                                      sg_bake **out, sg_error *err)
{
    sg_bake_desc d = sg_bake_desc_resolve(desc);
    size_t nblocks = sg_photon_block_count(&d.photons);
    if (pm->blocks != nblocks)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake: the photon map holds %zu of the pass's %zu blocks",
                            pm->blocks, nblocks);
    if (d.glossy_res != 0 && (d.glossy_res < SG_GLOSSY_MIN_RES || d.glossy_res > SG_GLOSSY_MAX_RES))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake: glossy resolution %d is not in %d..%d", d.glossy_res,
                            SG_GLOSSY_MIN_RES, SG_GLOSSY_MAX_RES);
    sg_bake *b = sg_calloc_array(1, sizeof *b);
    if (!b)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
    b->models = sg_world_model_count(w);
    b->desc = d;
    b->desc.photons.threads = b->desc.gather.threads = 0;
    b->desc.photons.progress = NULL;
    b->desc.photons.progress_user = NULL;
    sg_sample_set *sets = NULL;
    sg_irradiance_table *e0 = NULL; /* unshadowed irradiance, sparse direct light only */
    sg_status st = SG_OK;
    float **E = NULL;
    if (!alloc_model_arrays(b) || !(sets = sg_calloc_array(b->models, sizeof *sets))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
        goto fail;
    }
    for (size_t m = 0; m < b->models; ++m)
        b->count[m] = sg_scene_points(sg_world_scene(w, (uint32_t)m))->count;
    double t0 = omp_get_wtime();
    if ((st = sg_irradiance_gather(w, pm, &d.gather, &E, err)) != SG_OK)
        goto fail;
    for (size_t m = 0; m < b->models; ++m)
        b->E[m] = E[m];
    sg_free(E);
    double t1 = omp_get_wtime();
    if (d.direct_samples > 0 && d.sample_spacing >= 0.0f) {
        sg_irradiance_table_desc td = {.threads = d.gather.threads};
        if ((st = sg_irradiance_table_create(sg_world_envmap(w), &td, &e0, err)) != SG_OK)
            goto fail;
    }
    uint64_t key_base = 0; /* splats of the models before m: random streams */
    for (size_t m = 0; m < b->models; ++m) {
        const sg_pointset *ps = sg_scene_points(sg_world_scene(w, (uint32_t)m));
        const sg_material *mat = sg_world_material(w, (uint32_t)m);
        if (!(d.direct_samples > 0) && !sg_glossy_material(mat)) { /* nothing to sample */
            key_base += ps->count;
            continue;
        }
        float s0 = -1.0f;
        if (d.sample_spacing >= 0.0f) {
            float med;
            if ((st = sg_samples_median_radius(ps, &med, err)) != SG_OK)
                goto fail;
            s0 = (d.sample_spacing > 0.0f ? d.sample_spacing : sg_samples_default_spacing(mat)) * med;
        }
        if ((st = direct_at_samples(w, &d, e0, (uint32_t)m, key_base, s0, b->E[m], &sets[m], err)) != SG_OK)
            goto fail;
        b->samples[m] = sets[m].count;
        int res = sg_glossy_material(mat) ? (d.glossy_res ? d.glossy_res : sg_glossy_default_res(mat)) : 0;
        if (res && sets[m].count) {
            if ((st = sg_bake__alloc_glossy(b, (uint32_t)m, res, sets[m].count, err)) != SG_OK)
                goto fail;
            memcpy(b->gsplat[m], sets[m].splat, sets[m].count * sizeof(uint32_t));
            if (s0 > 0.0f)
                st = sg_samples_nearest(ps, &sets[m], s0, d.gather.normal_cos, d.gather.threads, b->gnear[m], err);
            else
                for (size_t i = 0; i < ps->count; ++i)
                    b->gnear[m][i] = (uint32_t)i;
            if (st != SG_OK)
                goto fail;
        }
        sg_sample_set_free(&sets[m]);
        key_base += ps->count;
    }
    double t2 = omp_get_wtime();
    /* Glossy bins last: their rays read the finished E of every model. */
    key_base = 0;
    for (size_t m = 0; m < b->models; ++m) {
        if (b->gres[m] > 0 &&
            (st = sg_glossy_bake(w, b, (uint32_t)m, b->gsplat[m], b->gcount[m], key_base, b->gres[m], d.glossy_rays,
                                 d.photons.seed ^ 0x6105ull, d.gather.threads, b->gbins[m], err)) != SG_OK)
            goto fail;
        key_base += b->count[m];
    }
    b->stats.direct_seconds = t2 - t1;
    b->stats.glossy_seconds = omp_get_wtime() - t2;
    b->stats.gather_seconds = omp_get_wtime() - t0;
    b->stats.trace_seconds = pm->seconds;
    b->stats.photons_shot = pm->shot;
    b->stats.photon_records = pm->count;
    b->stats.rays = pm->rays;
    b->stats.photon_memory_bytes = sg_photon_map_bytes(pm->count);
    b->stats.models = b->models;
    update_memory_stats(b);
    sg_free(sets);
    sg_irradiance_table_destroy(e0);
    *out = b;
    return SG_OK;
fail:
    for (size_t m = 0; sets && m < b->models; ++m)
        sg_sample_set_free(&sets[m]);
    sg_free(sets);
    sg_irradiance_table_destroy(e0);
    sg_bake_destroy(b);
    return st;
}

sg_status sg_bake_create(const sg_world *w, const sg_bake_desc *desc, sg_bake **out, sg_error *err)
{
    sg_bake_desc d = sg_bake_desc_resolve(desc);
    sg_photon_map pm = {0};
    sg_status st = sg_photons_trace(w, &d.photons, &pm, err);
    if (st == SG_OK)
        st = sg_bake_create_from_photons(w, &d, &pm, out, err);
    sg_photon_map_free(&pm);
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

const float *sg_bake_irradiance_data(const sg_bake *b, uint32_t m, size_t *splats)
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

static sg_vec3 irradiance_of(const sg_bake *b, uint32_t model, const uint32_t *ids, const float *wts, int n)
{
    const float *E = b->E[model];
    sg_vec3 e = {0, 0, 0};
    for (int j = 0; j < n; ++j) {
        const float *v = E + 3 * (size_t)ids[j];
        e = sg_v3_add(e, sg_v3_scale(sg_v3(v[0], v[1], v[2]), wts[j]));
    }
    return e;
}

sg_vec3 sg_bake_irradiance(const sg_bake *b, const sg_world *w, const sg_world_hit *h)
{
    uint32_t ids[LOOKUP_SPLATS];
    float wts[LOOKUP_SPLATS];
    int n = sg_scene_hit_weights(sg_world_scene(w, h->model), &h->hit, ids, wts, LOOKUP_SPLATS);
    return irradiance_of(b, h->model, ids, wts, n);
}

sg_vec3 sg_bake_lookup(const sg_bake *b, const sg_world *w, const sg_world_hit *h, sg_vec3 wo)
{
    const sg_material *m = sg_world_material(w, h->model);
    sg_vec3 rho = sg_world_albedo(w, h);
    int res = b->gres[h->model];
    if (!res || !sg_glossy_material(m)) { /* the diffuse path, as fast as before bins */
        sg_vec3 E = sg_bake_irradiance(b, w, h);
        return sg_v3_add(m->emission, sg_v3_scale(sg_v3_mul(rho, E), INV_PI));
    }
    const sg_scene *sc = sg_world_scene(w, h->model);
    uint32_t ids[LOOKUP_SPLATS], sid[LOOKUP_SPLATS];
    float wts[LOOKUP_SPLATS], sw[LOOKUP_SPLATS];
    int n = sg_scene_hit_weights(sc, &h->hit, ids, wts, LOOKUP_SPLATS), ns = 0;
    sg_vec3 E = irradiance_of(b, h->model, ids, wts, n);
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
    const sg_pointset *ps = sg_scene_points(sc);
    size_t stride = 3 * (size_t)res * (size_t)res;
    sg_vec3 S = {0, 0, 0};
    for (int k = 0; k < ns; ++k) {
        sg_vec3 n_s = sg_pointset_normal(ps, b->gsplat[h->model][sid[k]]);
        S = sg_v3_add(S, sg_v3_scale(sg_glossy_eval(b->gbins[h->model] + sid[k] * stride, res, n_s, h->hit.n, wo),
                                     sw[k]));
    }
    float ks = m->specular > 1.0f ? 1.0f : m->specular;
    return sg_v3_add(sg_v3_add(m->emission, sg_v3_scale(sg_v3_mul(rho, E), (1.0f - ks) * INV_PI)),
                     sg_v3_scale(S, ks));
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
