/* render.c — one primary ray per pixel, shaded locally (see render.h).
 *
 * Frame: the image is cut into 16x16 tiles handed to OpenMP threads
 * dynamically (tiles on the model cost far more than tiles on the sky).
 *
 * Invariants:
 *  1. Pixel (x, y) is a pure function of the scene, the desc and (x, y):
 *     its primary ray goes through (x + 0.5, y + 0.5) and any shadow ray
 *     starts from that ray's hit. No random numbers, no shared state.
 *  2. Each tile writes only its own pixels and its own tile_stats slot;
 *     the slots are reduced after the parallel loop in tile order, so the
 *     counters, like the image, ignore the thread count and schedule.
 *  3. Scene counters reach sg_scene_* through per-tile sg_ray_stats only
 *     (scene.h: stats pointers must be per-thread).
 */
#include "render/render.h"

#include <assert.h>
#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/alloc.h"

/* Tile edge in pixels: small enough to balance load on a 512^2 frame over
 * 16+ threads (1024 tiles), big enough that scheduling costs nothing. */
#define TILE 16

typedef struct tile_stats {
    uint64_t primary_rays;  /* rays from the camera in this tile         */
    uint64_t shadow_rays;   /* shadow rays from this tile's hits         */
    sg_ray_stats primary;   /* scene counters over the primary rays      */
    sg_ray_stats shadow;    /* scene counters over the shadow rays       */
} tile_stats;

/* The desc with defaults filled in and the light normalised. */
typedef struct frame {
    const sg_scene *scene;
    sg_render_desc d;
} frame;

static sg_vec3 albedo_of(const frame *f, const sg_hit *h)
{
    return sg_scene_hit_albedo(f->scene, h);
}

/* Sky radiance along dir: the sky colour, lighter towards the horizon. */
static sg_vec3 sky(const frame *f, sg_vec3 dir)
{
    float t = dir.y > 0.0f ? dir.y : 0.0f;
    sg_vec3 horizon = sg_v3_scale(sg_v3_add(f->d.sky_color, sg_v3(1, 1, 1)), 0.5f);
    return sg_v3_add(sg_v3_scale(horizon, 1.0f - t), sg_v3_scale(f->d.sky_color, t));
}

static sg_vec3 shade_pixel(const frame *f, const sg_ray *ray, tile_stats *ts, int *covered)
{
    sg_hit hit;
    ts->primary_rays++;
    int found = sg_scene_intersect(f->scene, ray, &hit, &ts->primary);
    *covered = found;
    switch (f->d.shade) {
    case SG_SHADE_NORMALS:
        if (!found)
            return sg_v3(0, 0, 0);
        return sg_v3_add(sg_v3_scale(hit.n, 0.5f), sg_v3(0.5f, 0.5f, 0.5f));
    case SG_SHADE_SIMPLE: {
        if (!found)
            return sg_v3(0.1f, 0.1f, 0.12f);
        float c = fabsf(sg_v3_dot(hit.n, ray->dir));
        return sg_v3_scale(albedo_of(f, &hit), 0.15f + 0.85f * c);
    }
    case SG_SHADE_PHONG:
        break;
    }
    if (!found)
        return sky(f, ray->dir);
    sg_vec3 albedo = albedo_of(f, &hit);
    sg_vec3 v = sg_v3_scale(ray->dir, -1.0f);
    /* Shade the side the camera sees (the back of an open scan, say). */
    sg_vec3 n = sg_v3_dot(hit.n, v) < 0.0f ? sg_v3_scale(hit.n, -1.0f) : hit.n;
    sg_vec3 l = f->d.light_dir;
    sg_vec3 c = sg_v3_scale(sg_v3_mul(albedo, f->d.sky_color), f->d.ambient);
    float ndl = sg_v3_dot(n, l);
    if (ndl > 0.0f) {
        sg_ray shadow = sg_scene_spawn_ray(f->scene, &hit, l, INFINITY);
        ts->shadow_rays++;
        if (!sg_scene_occluded(f->scene, &shadow, &ts->shadow)) {
            /* r = reflect(-l, n); highlight from the angle between r and v. */
            sg_vec3 r = sg_v3_madd(sg_v3_scale(l, -1.0f), n, 2.0f * ndl);
            float rv = sg_v3_dot(r, v);
            float spec = rv > 0.0f ? f->d.specular * powf(rv, f->d.shininess) : 0.0f;
            sg_vec3 lit = sg_v3_add(sg_v3_scale(albedo, ndl), sg_v3(spec, spec, spec));
            c = sg_v3_add(c, sg_v3_mul(lit, f->d.light_color));
        }
    }
    return c;
}

static void render_tile(const frame *f, int tile, int tiles_x, sg_image *img, tile_stats *ts)
{
    int x0 = (tile % tiles_x) * TILE, y0 = (tile / tiles_x) * TILE;
    int x1 = x0 + TILE < img->width ? x0 + TILE : img->width;
    int y1 = y0 + TILE < img->height ? y0 + TILE : img->height;
    for (int y = y0; y < y1; y++) {
        for (int x = x0; x < x1; x++) {
            sg_ray ray = sg_camera_ray(&f->d.camera, (float)x + 0.5f, (float)y + 0.5f, img->width,
                                       img->height);
            int covered;
            sg_vec3 c = shade_pixel(f, &ray, ts, &covered);
            img->alpha[(size_t)y * (size_t)img->width + (size_t)x] = (float)covered;
            float *px = img->data + 3 * ((size_t)y * (size_t)img->width + (size_t)x);
            px[0] = c.x;
            px[1] = c.y;
            px[2] = c.z;
        }
    }
}

static int camera_ok(const sg_camera *c)
{
    float fl = sg_v3_length(c->forward), rl = sg_v3_length(c->right), ul = sg_v3_length(c->up);
    return sg_v3_isfinite(c->eye) && fabsf(fl - 1.0f) < 1e-3f && fabsf(rl - 1.0f) < 1e-3f &&
           fabsf(ul - 1.0f) < 1e-3f && c->tan_half_fov > 0.0f && isfinite(c->tan_half_fov) &&
           c->aspect > 0.0f && isfinite(c->aspect);
}

static sg_status fill_defaults(const sg_render_desc *in, sg_render_desc *d, sg_error *err)
{
    *d = *in;
    if (d->width == 0)
        d->width = 512;
    if (d->height == 0)
        d->height = 512;
    if (d->width < 0 || d->height < 0 || d->width > SG_IMAGE_MAX_DIM || d->height > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "render: image size %dx%d is out of range",
                            d->width, d->height);
    if (d->shade != SG_SHADE_SIMPLE && d->shade != SG_SHADE_PHONG && d->shade != SG_SHADE_NORMALS)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "render: unknown shade mode %d", (int)d->shade);
    if (d->threads < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "render: threads %d must be >= 0", d->threads);
    if (!camera_ok(&d->camera))
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "render: camera is not set (build it with sg_camera_look_at)");
    sg_vec3 zero = {0, 0, 0};
    if (memcmp(&d->light_dir, &zero, sizeof zero) == 0)
        d->light_dir = sg_v3(-0.5f, 0.8f, 0.45f);
    if (!sg_v3_isfinite(d->light_dir) || sg_v3_length(d->light_dir) == 0.0f)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "render: light direction must be finite and non-zero");
    d->light_dir = sg_v3_normalize(d->light_dir);
    if (memcmp(&d->light_color, &zero, sizeof zero) == 0)
        d->light_color = sg_v3(1.5f, 1.45f, 1.35f);
    if (memcmp(&d->sky_color, &zero, sizeof zero) == 0)
        d->sky_color = sg_v3(0.60f, 0.72f, 0.90f);
    if (d->ambient == 0.0f)
        d->ambient = 0.3f;
    if (d->ambient < 0.0f)
        d->ambient = 0.0f;
    if (d->specular == 0.0f)
        d->specular = 0.15f;
    if (d->shininess == 0.0f)
        d->shininess = 32.0f;
    if (!sg_v3_isfinite(d->light_color) || !sg_v3_isfinite(d->sky_color) || !isfinite(d->ambient) ||
        !isfinite(d->specular) || !isfinite(d->shininess))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "render: light, sky and material values must be finite");
    return SG_OK;
}

sg_status sg_render_frame(const sg_scene *scene, const sg_render_desc *desc, sg_image *out,
                          sg_render_stats *stats, sg_error *err)
{
    if (!scene || !desc || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "render: scene, desc and image are required");
    frame f = {.scene = scene};
    sg_status st = fill_defaults(desc, &f.d, err);
    if (st != SG_OK)
        return st;

    sg_image img = {0};
    st = sg_image_alloc(&img, f.d.width, f.d.height, err);
    if (st != SG_OK)
        return st;
    /* Coverage (which camera ray hit), the alpha of EXR outputs. */
    if (!(img.alpha = sg_alloc_array((size_t)f.d.width * (size_t)f.d.height, sizeof(float)))) {
        sg_image_free(&img);
        return sg_error_set(err, SG_ERR_NOMEM, "render: out of memory for %dx%d", f.d.width, f.d.height);
    }
    int tiles_x = (img.width + TILE - 1) / TILE, tiles_y = (img.height + TILE - 1) / TILE;
    int tiles = tiles_x * tiles_y; /* <= 4096^2: fits an int */
    tile_stats *ts = sg_calloc_array((size_t)tiles, sizeof *ts);
    if (!ts) {
        sg_image_free(&img);
        return sg_error_set(err, SG_ERR_NOMEM, "render: out of memory for %d tiles", tiles);
    }

    int threads = f.d.threads > 0 ? f.d.threads : omp_get_max_threads();
    double t0 = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (int t = 0; t < tiles; t++)
        render_tile(&f, t, tiles_x, &img, &ts[t]);
    double seconds = omp_get_wtime() - t0;

    sg_render_stats s = {0};
    for (int t = 0; t < tiles; t++) { /* invariant 2: tile order */
        s.primary_rays += ts[t].primary_rays;
        s.shadow_rays += ts[t].shadow_rays;
        sg_ray_stats_add(&s.primary, &ts[t].primary);
        sg_ray_stats_add(&s.shadow, &ts[t].shadow);
    }
    s.rays = s.primary_rays + s.shadow_rays;
    s.seconds = seconds;
    s.mrays_per_s = seconds > 0.0 ? (double)s.rays / seconds * 1e-6 : 0.0;
    sg_free(ts);
    *out = img;
    if (stats)
        *stats = s;
    return SG_OK;
}
