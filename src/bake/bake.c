/* bake.c — photon pass + gather, and the lookup (see bake.h).
 *
 * States of a bake and the function behind each step:
 *   world LOADED (sg_world_create) -> photons TRACED (sg_photons_trace or
 *   sg_photons_trace_more per chunk, checkpointable: bake_io.h) ->
 *   GATHERED (sg_bake_create_from_photons; sg_bake_create does both) ->
 *   WRITTEN (sg_bake_save) -> LOADED again (sg_bake_load) -> lookups.
 *
 * Invariants:
 *  1. E[m] holds 3 floats per splat of model m, in the order of
 *     sg_scene_points(sg_world_scene(w, m)), finite and >= 0;
 *  2. the lookup's interpolation weights sum to 1 (sg_scene_hit_weights),
 *     so a constant E is reproduced exactly: no seams between splats.
 */
#include "bake/bake.h"

#include <assert.h>
#include <math.h>
#include <omp.h>
#include <string.h>

#include "bake/direct.h"
#include "core/alloc.h"

static const float INV_PI = 0.318309886183791f;

enum { LOOKUP_SPLATS = 32, TILE = 16 };

struct sg_bake {
    size_t models;
    size_t *count;  /* splats per model                   */
    float **E;      /* irradiance per splat (invariant 1) */
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
    if (d.direct_samples == 0) d.direct_samples = 16;
    if (d.direct_samples < 0) d.direct_samples = -1;
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
    return h ? h : 1; /* 0 means "do not check" to bake_file.h */
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
    b->count = sg_calloc_array(models, sizeof *b->count);
    b->E = sg_calloc_array(models, sizeof *b->E);
    if (!b->count || !b->E)
        goto nomem;
    for (size_t m = 0; m < models; ++m) {
        size_t n3;
        if (!sg_mul_size(counts[m], 3, &n3) || !(b->E[m] = sg_calloc_array(n3, sizeof(float))))
            goto nomem;
        b->count[m] = counts[m];
        b->stats.splats += counts[m];
    }
    b->stats.memory_bytes = b->stats.splats * 3 * sizeof(float);
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

sg_status sg_bake_create_from_photons(const sg_world *w, const sg_bake_desc *desc, const sg_photon_map *pm,
                                      sg_bake **out, sg_error *err)
{
    sg_bake_desc d = sg_bake_desc_resolve(desc);
    size_t nblocks = sg_photon_block_count(&d.photons);
    if (pm->blocks != nblocks)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake: the photon map holds %zu of the pass's %zu blocks",
                            pm->blocks, nblocks);
    sg_bake *b = sg_calloc_array(1, sizeof *b);
    if (!b)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
    b->models = sg_world_model_count(w);
    b->desc = d;
    b->desc.photons.threads = b->desc.gather.threads = 0;
    b->desc.photons.progress = NULL;
    b->desc.photons.progress_user = NULL;
    b->count = sg_calloc_array(b->models, sizeof *b->count);
    sg_status st = SG_OK;
    if (!b->count) {
        st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
        goto fail;
    }
    double t0 = omp_get_wtime();
    if ((st = sg_irradiance_gather(w, pm, &d.gather, &b->E, err)) != SG_OK)
        goto fail;
    double t1 = omp_get_wtime();
    if (d.direct_samples > 0 &&
        (st = sg_direct_irradiance_add(w, d.direct_samples, d.photons.seed ^ 0xD1EC7ull, d.gather.threads, b->E,
                                       err)) != SG_OK)
        goto fail;
    b->stats.direct_seconds = omp_get_wtime() - t1;
    b->stats.gather_seconds = omp_get_wtime() - t0;
    b->stats.trace_seconds = pm->seconds;
    b->stats.photons_shot = pm->shot;
    b->stats.photon_records = pm->count;
    b->stats.rays = pm->rays;
    b->stats.photon_memory_bytes = sg_photon_map_bytes(pm->count);
    b->stats.models = b->models;
    for (size_t m = 0; m < b->models; ++m) {
        b->count[m] = sg_scene_points(sg_world_scene(w, (uint32_t)m))->count;
        b->stats.splats += b->count[m];
    }
    b->stats.memory_bytes = b->stats.splats * 3 * sizeof(float);
    *out = b;
    return SG_OK;
fail:
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
    for (size_t m = 0; b->E && m < b->models; ++m)
        sg_free(b->E[m]);
    sg_free(b->E);
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

sg_vec3 sg_bake_irradiance(const sg_bake *b, const sg_world *w, const sg_world_hit *h)
{
    uint32_t ids[LOOKUP_SPLATS];
    float wts[LOOKUP_SPLATS];
    int n = sg_scene_hit_weights(sg_world_scene(w, h->model), &h->hit, ids, wts, LOOKUP_SPLATS);
    const float *E = b->E[h->model];
    sg_vec3 e = {0, 0, 0};
    for (int j = 0; j < n; ++j) {
        const float *v = E + 3 * (size_t)ids[j];
        e = sg_v3_add(e, sg_v3_scale(sg_v3(v[0], v[1], v[2]), wts[j]));
    }
    return e;
}

sg_vec3 sg_bake_lookup(const sg_bake *b, const sg_world *w, const sg_world_hit *h, sg_vec3 wo)
{
    (void)wo; /* diffuse only for now: see bake.h */
    const sg_material *m = sg_world_material(w, h->model);
    sg_vec3 rho = sg_world_albedo(w, h);
    sg_vec3 E = sg_bake_irradiance(b, w, h);
    return sg_v3_add(m->emission, sg_v3_scale(sg_v3_mul(rho, E), INV_PI));
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
