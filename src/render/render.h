/* render.h — one frame of primary rays over a built scene.
 *
 * What it does: traces one primary ray per pixel, through the pixel centre,
 * and shades the hit with a simple local model; reports rays, time and the
 * scene's per-ray traversal counters. It is the ray-casting front end of
 * Wald & Seidel 2005 (§4) and the speed benchmark's frame.
 * What it does NOT do: global illumination (that is the bake lookup and the
 * reference renderer), anti-aliasing, tone mapping or colour management (the
 * image is scene-linear; PNG output applies the sRGB OETF only).
 *
 * Use:
 *     sg_render_desc d = { .camera = cam, .width = 512, .height = 512,
 *                          .shade = SG_SHADE_PHONG };
 *     sg_image img; sg_render_stats st;
 *     if (sg_render_frame(scene, &d, &img, &st, &err) != SG_OK) ...
 *     sg_image_free(&img);
 *
 * Determinism: every pixel depends only on its own rays, so the image is
 * bit-identical whatever the thread count; the counters are summed per
 * 16x16 tile and then over tiles in tile order.
 * Thread-safety: reentrant; uses its own OpenMP team (desc.threads) and
 * never changes the process-wide OpenMP settings.
 */
#ifndef SG_RENDER_RENDER_H
#define SG_RENDER_RENDER_H

#include <stdint.h>

#include "core/error.h"
#include "io/image.h"
#include "math/ray.h"
#include "render/camera.h"
#include "surface/scene.h"

typedef enum sg_shade_mode {
    /* Albedo * (0.15 + 0.85 |n.v|), like an OpenGL headlight; no shadow
     * rays. One ray per pixel: the speed benchmark's mode. (default) */
    SG_SHADE_SIMPLE = 0,
    /* Albedo of the hit splat; ambient (sky colour * ambient) + Lambert
     * and a Phong highlight from one directional light, the light term
     * shadowed by a ray towards the light (sg_scene_occluded); misses show
     * the sky. Up to two rays per pixel. */
    SG_SHADE_PHONG = 1,
    /* Debug: 0.5 n + 0.5 as RGB; misses are black. */
    SG_SHADE_NORMALS = 2
} sg_shade_mode;

/* Frame options; zero means the documented default. */
typedef struct sg_render_desc {
    sg_camera camera;      /* required (sg_camera_look_at / _frame)          */
    int width, height;     /* image size in pixels; default 512 x 512        */
    sg_shade_mode shade;   /* default SG_SHADE_SIMPLE                        */
    sg_vec3 light_dir;     /* PHONG: direction towards the light, world
                              space (normalised here); default
                              (-0.5, 0.8, 0.45), upper left front            */
    sg_vec3 light_color;   /* PHONG: light radiance scale; default (1.5,1.45,1.35) */
    sg_vec3 sky_color;     /* PHONG: sky seen by misses and ambient; default
                              (0.60, 0.72, 0.90)                             */
    float ambient;         /* PHONG: ambient = albedo * sky * ambient;
                              default 0.3; negative = 0                     */
    float specular;        /* PHONG: Phong highlight weight; default 0.15    */
    float shininess;       /* PHONG: Phong exponent; default 32              */
    int threads;           /* OpenMP threads; 0 = OpenMP default             */
} sg_render_desc;

typedef struct sg_render_stats {
    uint64_t primary_rays;  /* one per pixel                               */
    uint64_t shadow_rays;   /* PHONG: lit hits that cast a shadow ray       */
    uint64_t rays;          /* primary + shadow                             */
    double seconds;         /* wall time of the tracing and shading         */
    double mrays_per_s;     /* rays / seconds / 1e6                         */
    sg_ray_stats primary;   /* scene counters summed over primary rays      */
    sg_ray_stats shadow;    /* scene counters summed over shadow rays       */
} sg_render_stats;

/* Renders one frame into *out (allocated here, width x height; free with
 * sg_image_free). stats may be NULL. Errors: SG_ERR_INVALID_ARG (NULL
 * scene, bad size, camera not set, bad shade mode, negative threads),
 * SG_ERR_NOMEM. *out and *stats are written only on SG_OK. */
sg_status sg_render_frame(const sg_scene *scene, const sg_render_desc *desc, sg_image *out,
                          sg_render_stats *stats, sg_error *err);

#endif
