/* coverage.h — how much of each pixel shows a model rather than the sky:
 * the alpha channel of the images the programs write.
 *
 * What it does: for a camera and an image size, traces per pixel n x n
 * rays through the centres of an n x n grid of cells of the pixel (n = 1:
 * the pixel's centre, the one ray of the lookup frame and of the direct
 * renderers, so their alpha says exactly which pixels hit) and stores the
 * fraction that hit any model of the world. Deterministic whatever the
 * thread count (no random numbers; each pixel is its own).
 * What it does NOT do: transparency of surfaces (splats are opaque) or
 * premultiplication (the images keep their radiance as it is).
 *
 * Ownership: *alpha is allocated here (sg_alloc_array, width x height
 * floats, row 0 top); hand it to an sg_image (image.h), whose
 * sg_image_free frees it, or sg_free it.
 * Errors: SG_ERR_INVALID_ARG (size, samples), SG_ERR_NOMEM.
 */
#ifndef SG_RENDER_COVERAGE_H
#define SG_RENDER_COVERAGE_H

#include "core/error.h"
#include "render/camera.h"
#include "render/world.h"

typedef struct sg_coverage_desc {
    sg_camera camera;  /* REQUIRED                                     */
    int width, height; /* REQUIRED, 1..SG_IMAGE_MAX_DIM                */
    int per_side;      /* rays per pixel side, 1..16; 0 = 1 (centre)    */
    int threads;       /* 0 = OpenMP default                           */
} sg_coverage_desc;

sg_status sg_coverage_render(const sg_world *w, const sg_coverage_desc *d, float **alpha, sg_error *err);

#endif
