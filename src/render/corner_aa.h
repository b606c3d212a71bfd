/* corner_aa.h — anti-aliasing of a still frame by rays through pixel
 * corners, refined where the corners disagree (Ye 2005, PPRT §4.3, made
 * adaptive as its §4.3 and §6 suggest).
 *
 * What it does: samples the image at the (width + 1) x (height + 1) pixel
 * corners, each corner once and shared by the four pixels around it (Ye's
 * "keep the four corner intensities for the neighbouring pixel"); a pixel
 * whose four corners agree (contrast below the threshold, same coverage)
 * is their average; a pixel whose corners differ is cut into four squares,
 * each sampled at its own corners (five new samples: edge midpoints and
 * centre), and each square is judged the same way, down to max_depth
 * levels (a 2^depth x 2^depth grid of squares at most). A square's value
 * is the average of its four corners, a pixel's the average of its
 * squares: the 2-D trapezoidal rule, so a straight edge gives a coverage
 * within 1/(2N) + 1/(4N^2) of its exact area, N = 2^max_depth
 * (corner_aa.c derives it); a colour field that is affine within a pixel
 * gives the value at the pixel's centre.
 * What it does NOT do: trace or shade (the caller's sample function
 * does), filters wider than a pixel, temporal accumulation, jitter.
 *
 * Use:
 *     sg_corner_aa_desc d = {.width = w, .height = h};   zero = defaults
 *     sg_corner_aa_stats st;
 *     sg_corner_aa_render(&d, my_sample, my_ctx, &img, &st, &err);
 *
 * Coordinates: image-plane points (x, y) in [0, width] x [0, height],
 * (0, 0) the top-left corner of the top-left pixel, as sg_camera_ray's
 * (px, py) (render/camera.h): pixel (i, j) covers [i, i + 1] x [j, j + 1].
 * Sample positions are dyadic fractions of a pixel (exact in float for
 * images up to 2^16 pixels a side), so a point shared by two pixels is
 * the same float pair in both.
 *
 * Determinism: a pixel is a pure function of its samples and the sample
 * function is called with positions only, so the image is bit-identical
 * whatever the thread count (rows are shared out dynamically) as long as
 * the sample function is itself a pure function of (x, y).
 * Thread-safety: reentrant; fn is called from several threads at once
 * (desc.threads) and must be safe so.
 */
#ifndef SG_RENDER_CORNER_AA_H
#define SG_RENDER_CORNER_AA_H

#include <stdint.h>

#include "core/error.h"
#include "io/image.h"

/* Defaults: contrast threshold (Mitchell 1987's |a - b| / (a + b) per
 * channel) and refinement depth. 0.1 is a step of about 20% between
 * corners; depth 2 is at most 25 samples in a pixel (a 4 x 4 grid),
 * enough for edge coverage within 0.14 (corner_aa.c). */
#define SG_CORNER_AA_THRESHOLD 0.1f
#define SG_CORNER_AA_DEPTH 2
#define SG_CORNER_AA_MAX_DEPTH 6

/* Radiance (3 floats, scene-linear, finite, >= 0 for the contrast to mean
 * anything) and coverage in [0, 1] (1 where the ray hit a surface) at
 * image-plane point (x, y). */
typedef void (*sg_corner_aa_sample_fn)(void *ctx, float x, float y, float rgb[3], float *coverage);

/* Options; zero means the documented default. */
typedef struct sg_corner_aa_desc {
    int width, height; /* image size in pixels, each in [1, SG_IMAGE_MAX_DIM]; required */
    float threshold;   /* contrast above which a square is cut (per channel;
                          coverage counts as a channel too); default
                          SG_CORNER_AA_THRESHOLD; negative: always cut (to
                          max_depth: a uniform grid)                     */
    int max_depth;     /* levels of cutting, 0..SG_CORNER_AA_MAX_DEPTH; 0 is
                          Ye's plain four-corner average; default
                          SG_CORNER_AA_DEPTH (-1 in the desc means 0)    */
    int threads;       /* OpenMP threads; 0 = OpenMP default            */
} sg_corner_aa_desc;

typedef struct sg_corner_aa_stats {
    uint64_t samples;  /* calls of the sample function (rays)           */
    uint64_t refined;  /* pixels cut at least once                      */
    double seconds;    /* wall time                                     */
} sg_corner_aa_stats;

/* Fills *out (allocated here, width x height, with alpha = the coverage
 * averaged like the colour; free with sg_image_free). stats may be NULL.
 * Errors: SG_ERR_INVALID_ARG (NULL fn or out, size out of range, depth
 * out of range, threshold NaN, negative threads), SG_ERR_NOMEM. *out and
 * *stats are written only on SG_OK. */
sg_status sg_corner_aa_render(const sg_corner_aa_desc *desc, sg_corner_aa_sample_fn fn, void *ctx, sg_image *out,
                              sg_corner_aa_stats *stats, sg_error *err);

#endif
