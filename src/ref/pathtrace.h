/* pathtrace.h — the Monte Carlo reference: an unbiased path tracer over the
 * same surfaces, materials and envmap as the bake and the viewer.
 *
 * Estimator, per pixel: the mean of spp independent paths. Each path starts
 * at a uniformly jittered point of the pixel (or at its centre, with
 * pixel_centres); at every surface vertex it
 * adds the emission, samples the envmap (importance-sampled, shadow ray)
 * and the BSDF, and weights the two strategies by the power heuristic
 * (Veach 1997); a BSDF-sampled ray that escapes adds the envmap with the
 * matching weight. Russian roulette from rr_depth on, on paths whose
 * throughput has fallen below 1, with survival probability equal to the
 * largest throughput channel and the throughput divided by it, so no path
 * ever carries more than it started with: no clamping anywhere, so the
 * estimate is unbiased except for the max_depth cut (set it high to make
 * that bias negligible: the furnace tests use 1024), and the per-pixel
 * standard errors are honest (no heavy tail of rare paths whose
 * throughput grew).
 *
 * Surfaces: the exact ones. Camera rays carry no footprint (sg_ray.spread
 * 0), so the ISO and hybrid surfaces trace them to full depth: their
 * levels of detail are what the viewer and a bake's lookup frame choose,
 * and the reference is what those choices are measured against.
 *
 * Determinism: every random number is sg_rng_float(seed, path, bounce,
 * dim) with path = pixel * SG_REF_MAX_SPP + sample index, so the image is
 * bit-identical whatever the thread count, and passes with disjoint sample
 * ranges (first_sample) combine into the image of their union.
 *
 * Outputs: the mean radiance image (scene-linear RGB) and the per-pixel
 * standard error of that mean, sqrt(s^2 / N) with s^2 the unbiased sample
 * variance of the N path values, per channel.
 */
#ifndef SG_REF_PATHTRACE_H
#define SG_REF_PATHTRACE_H

#include <stdint.h>

#include "core/error.h"
#include "io/image.h"
#include "math/ray.h"
#include "render/camera.h"
#include "render/world.h"

#define SG_REF_MAX_SPP (1u << 24)

typedef struct sg_ref_desc {
    sg_camera camera;     /* required                                      */
    int width, height;    /* default 512 x 512                             */
    int spp;              /* paths per pixel; default 64                   */
    uint32_t first_sample;/* index of the first path (progressive passes)  */
    int max_depth;        /* scattering events per path; default 8         */
    int rr_depth;         /* Russian roulette from this bounce; default 3  */
    uint64_t seed;        /* default 1                                     */
    int threads;          /* OpenMP threads; 0 = default                   */
    int pixel_centres;    /* 1: every path through its pixel's centre, the
                             point the bake's lookup frame and the direct
                             renderers sample (no jitter: the estimate of
                             the radiance they try to show, not of the
                             pixel's average)                              */
} sg_ref_desc;

/* Hits from behind (issue 12). A path vertex is a "back hit" when its ray
 * meets the surface from behind, dot(dir, n) > 0, although the ray expected
 * a front face: a camera ray (the camera is taken to be outside every
 * model) or a ray that left its vertex towards the side the surface's
 * normal points to (SG_RAY_FRONT_ONLY: every bounce of a path that arrived
 * from the front). On closed models seen from outside every back hit
 * follows a ray that went through a surface, and the path then goes on as
 * if inside the model; a camera inside a closed model (the stability
 * map's camera_inside) makes every camera hit a back hit. Rays leaving a
 * surface inwards (SG_RAY_BACK_ONLY: the path is inside by its own
 * account) expect back faces and are not counted. Shadow rays make no
 * vertices and are not counted either. */
typedef struct sg_ref_counts {
    uint64_t surface_hits;      /* path vertices: camera and bounce rays that hit */
    uint64_t back_hits;         /* of them, back hits (above)                */
    uint64_t camera_back_hits;  /* of the back hits, by camera rays          */
    uint64_t back_paths;        /* paths with at least one back hit          */
} sg_ref_counts;

static inline void sg_ref_counts_add(sg_ref_counts *a, const sg_ref_counts *b)
{
    a->surface_hits += b->surface_hits;
    a->back_hits += b->back_hits;
    a->camera_back_hits += b->camera_back_hits;
    a->back_paths += b->back_paths;
}

typedef struct sg_ref_result {
    sg_image mean;        /* per-pixel mean radiance                       */
    sg_image std_error;   /* per-pixel standard error of the mean          */
    double mean_radiance[3]; /* image average of `mean`, per channel       */
    double seconds;       /* wall time                                     */
    uint64_t paths;       /* paths traced                                  */
    sg_ray_stats rays;    /* every ray: camera, shadow and bounce          */
    sg_ref_counts counts; /* surface hits, and those met from behind       */
} sg_ref_result;

/* Renders; on failure *out is untouched. */
sg_status sg_ref_render(const sg_world *w, const sg_ref_desc *d, sg_ref_result *out, sg_error *err);

void sg_ref_result_free(sg_ref_result *r);

/* Progressive rendering: folds result b (nb paths per pixel, a sample range
 * disjoint from a's) into a (na paths per pixel), so that a becomes the
 * result of all na + nb paths: exact pooled means and standard errors
 * (sums and sums of squares are recovered from mean and standard error).
 * Both must have the same size. */
sg_status sg_ref_result_merge(sg_ref_result *a, int na, const sg_ref_result *b, int nb, sg_error *err);

/* One path's radiance through image point (x, y) in pixels, path index
 * `path` (exposed for tests of the estimator). */
sg_vec3 sg_ref_path(const sg_world *w, const sg_ref_desc *d, float x, float y, uint64_t path, sg_ray_stats *st);

/* The same path, adding its hits to *counts (may be NULL). */
sg_vec3 sg_ref_path_counted(const sg_world *w, const sg_ref_desc *d, float x, float y, uint64_t path,
                            sg_ray_stats *st, sg_ref_counts *counts);

#endif
