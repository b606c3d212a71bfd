/* render.c — the viewer's still frame (render.h).
 *
 * Invariants:
 *  1. pixel (x, y) is a pure function of (bake, world, camera, x, y): the
 *     value sg_bake_render gives it, whatever the tiling or threads,
 *     because sg_world_intersect16 gives each ray sg_world_intersect's hit.
 */
#include "view/render.h"

#include <omp.h>

#include "core/alloc.h"

/* Tiles are the unit of work per thread (dynamic schedule), as in
 * sg_bake_render; 4 x 4 blocks are traced within them. */
enum { TILE = 16 };

sg_status sg_view_render(const sg_bake *b, const sg_world *w, const sg_bake_frame_desc *desc, sg_image *out,
                         double *seconds, sg_error *err)
{
    if (!b || !w || !desc || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_view_render: NULL argument");
    if (sg_bake_model_count(b) != sg_world_model_count(w))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_view_render: the bake has %zu models, the world %zu",
                            sg_bake_model_count(b), sg_world_model_count(w));
    sg_bake_frame_desc d = *desc;
    if (d.width <= 0) d.width = 512;
    if (d.height <= 0) d.height = 512;
    sg_image img = {0};
    sg_status st = sg_image_alloc(&img, d.width, d.height, err);
    if (st != SG_OK)
        return st;
    /* Coverage for the EXR outputs (screenshots, headless frames): which
     * camera ray hit, as sg_coverage_render with one ray a pixel. */
    if (!(img.alpha = sg_alloc_array((size_t)d.width * (size_t)d.height, sizeof(float)))) {
        sg_image_free(&img);
        return sg_error_set(err, SG_ERR_NOMEM, "sg_view_render: out of memory for %dx%d", d.width, d.height);
    }
    const sg_envmap *env = sg_world_envmap(w);
    int tiles_x = (d.width + TILE - 1) / TILE, tiles = tiles_x * ((d.height + TILE - 1) / TILE);
    int threads = d.threads > 0 ? d.threads : omp_get_max_threads();
    double t0 = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (int t = 0; t < tiles; ++t) {
        int x0 = (t % tiles_x) * TILE, y0 = (t / tiles_x) * TILE;
        /* 4 x 4 blocks: sixteen camera rays from one eye, traced together
         * (the hybrid walks its tree once for them, sg_hybrid_intersect16). */
        for (int y = y0; y < y0 + TILE && y < d.height; y += 4)
            for (int x = x0; x < x0 + TILE && x < d.width; x += 4) {
                sg_ray rays[16];
                sg_world_hit h[16];
                unsigned mask = sg_camera_block16(&d.camera, x, y, d.width, d.height, rays);
                unsigned hit = sg_world_intersect16(w, rays, mask, h, NULL);
                sg_vec3 wo[16], Lh[16];
                for (unsigned m = hit; m; m &= m - 1)
                    wo[__builtin_ctz(m)] = sg_v3_scale(rays[__builtin_ctz(m)].dir, -1.0f);
                sg_bake_lookup16(b, w, h, wo, hit, Lh);
                for (unsigned m = mask; m; m &= m - 1) {
                    int q = __builtin_ctz(m);
                    sg_vec3 L = hit >> q & 1u ? Lh[q] : sg_envmap_eval(env, rays[q].dir);
                    size_t at = (size_t)(y + (q >> 2)) * (size_t)d.width + (size_t)(x + (q & 3));
                    float *px = img.data + 3 * at;
                    img.alpha[at] = (float)(hit >> q & 1u);
                    px[0] = L.x;
                    px[1] = L.y;
                    px[2] = L.z;
                }
            }
    }
    if (seconds)
        *seconds = omp_get_wtime() - t0;
    *out = img;
    return SG_OK;
}

typedef struct aa_ctx {
    const sg_bake *b;
    const sg_world *w;
    const sg_envmap *env;
    const sg_bake_frame_desc *d;
} aa_ctx;

/* One sample of the anti-aliased frame: sg_bake_render's pixel, at any
 * image-plane point. */
static void aa_sample(void *ctx, float x, float y, float rgb[3], float *coverage)
{
    const aa_ctx *c = ctx;
    sg_ray ray = sg_camera_ray(&c->d->camera, x, y, c->d->width, c->d->height);
    sg_world_hit h;
    int hit = sg_world_intersect(c->w, &ray, &h, NULL);
    sg_vec3 L = hit ? sg_bake_lookup(c->b, c->w, &h, sg_v3_scale(ray.dir, -1.0f)) : sg_envmap_eval(c->env, ray.dir);
    rgb[0] = L.x;
    rgb[1] = L.y;
    rgb[2] = L.z;
    *coverage = (float)hit;
}

sg_status sg_view_render_aa(const sg_bake *b, const sg_world *w, const sg_bake_frame_desc *desc, const sg_view_aa *aa,
                            sg_image *out, sg_corner_aa_stats *stats, sg_error *err)
{
    if (aa && aa->mode != SG_VIEW_AA_NONE && aa->mode != SG_VIEW_AA_CORNER)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "anti-aliasing mode %d is not none (0) or corner (1)",
                            (int)aa->mode);
    if (!aa || aa->mode == SG_VIEW_AA_NONE) {
        double sec = 0.0;
        sg_status st = sg_view_render(b, w, desc, out, &sec, err);
        if (st == SG_OK && stats) {
            sg_bake_frame_desc d = *desc;
            *stats = (sg_corner_aa_stats){.samples = (uint64_t)(d.width > 0 ? d.width : 512) *
                                                     (uint64_t)(d.height > 0 ? d.height : 512),
                                          .seconds = sec};
        }
        return st;
    }
    if (!b || !w || !desc || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_view_render_aa: NULL argument");
    if (sg_bake_model_count(b) != sg_world_model_count(w))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_view_render_aa: the bake has %zu models, the world %zu",
                            sg_bake_model_count(b), sg_world_model_count(w));
    sg_bake_frame_desc d = *desc;
    if (d.width <= 0) d.width = 512;
    if (d.height <= 0) d.height = 512;
    aa_ctx c = {b, w, sg_world_envmap(w), &d};
    sg_corner_aa_desc cd = {.width = d.width, .height = d.height, .threshold = aa->threshold,
                            .max_depth = aa->max_depth, .threads = d.threads};
    return sg_corner_aa_render(&cd, aa_sample, &c, out, stats, err);
}
