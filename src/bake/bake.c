/* bake.c — photon pass + gather, and the lookup (see bake.h).
 *
 * Invariants:
 *  1. E[m] holds 3 floats per splat of model m, in the order of
 *     sg_scene_points(sg_world_scene(w, m)), finite and >= 0;
 *  2. the lookup's interpolation weights sum to 1 (sg_scene_hit_weights),
 *     so a constant E is reproduced exactly: no seams between splats.
 */
#include "bake/bake.h"

#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/alloc.h"

static const float INV_PI = 0.318309886183791f;

enum { LOOKUP_SPLATS = 32, TILE = 16 };

struct sg_bake {
    size_t models;
    size_t *count;  /* splats per model                 */
    float **E;      /* irradiance per splat (invariant 1) */
    sg_bake_info info;
};

sg_status sg_bake_create(const sg_world *w, const sg_bake_desc *desc, sg_bake **out, sg_error *err)
{
    sg_bake_desc d = desc ? *desc : (sg_bake_desc){0};
    sg_bake *b = sg_calloc_array(1, sizeof *b);
    if (!b)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
    b->models = sg_world_model_count(w);
    b->count = sg_calloc_array(b->models, sizeof *b->count);
    sg_photon_map pm = {0};
    sg_status st = SG_OK;
    if (!b->count) {
        st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
        goto fail;
    }
    if ((st = sg_photons_trace(w, &d.photons, &pm, err)) != SG_OK)
        goto fail;
    double t0 = omp_get_wtime();
    if ((st = sg_irradiance_gather(w, &pm, &d.gather, &b->E, err)) != SG_OK)
        goto fail;
    b->info.gather_seconds = omp_get_wtime() - t0;
    b->info.trace_seconds = pm.seconds;
    b->info.photons_shot = pm.shot;
    b->info.photon_records = pm.count;
    b->info.models = b->models;
    for (size_t m = 0; m < b->models; ++m) {
        b->count[m] = sg_scene_points(sg_world_scene(w, (uint32_t)m))->count;
        b->info.splats += b->count[m];
    }
    b->info.memory_bytes = b->info.splats * 3 * sizeof(float);
    sg_photon_map_free(&pm);
    *out = b;
    return SG_OK;
fail:
    sg_photon_map_free(&pm);
    sg_bake_destroy(b);
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

void sg_bake_get_info(const sg_bake *b, sg_bake_info *info) { *info = b->info; }

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
