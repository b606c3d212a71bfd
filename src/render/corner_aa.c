/* corner_aa.c — corner supersampling with adaptive refinement (corner_aa.h;
 * Ye 2005, PPRT §4.3: rays through the four corners of a pixel, averaged,
 * the corners kept for the neighbours; refined where they disagree, the
 * "adaptive supersampling" Ye's §4.3 and §6 leave for later).
 *
 * Two passes, each shared out by rows: first every pixel corner of the
 * image, then every pixel from its four corners, refined in a local grid
 * of (N + 1) x (N + 1) points (N = 2^max_depth) of which only the points
 * a refinement reaches are sampled.
 *
 * Error of the coverage at a straight edge (the bound corner_aa.h quotes).
 * A square whose four corners lie on one side of a line lies wholly on it
 * (a half-plane is convex), so a square is left uncut exactly when it is
 * uniform, and a pixel's estimate equals the uniform trapezoidal rule on
 * its N x N grid: weights 1/(4N^2) at the pixel's corners, 1/(2N^2) on its
 * sides, 1/N^2 inside. Take the edge as y = f(x), f affine, |f'| <= 1 (else
 * swap the axes), covered below. On each grid column x_i the 1-D
 * trapezoidal rule in y of the step [y < f(x_i)] is off only in the one
 * interval the step falls in, by |phi - 1/2| / N <= 1/(2N) (phi: where in
 * that interval). Over the columns the 2-D estimate is the trapezoidal
 * rule in x of these column estimates, so it is off from the trapezoidal
 * rule of the exact column integrals g(x) = clamp(f(x), 0, 1) by at most
 * 1/(2N) (the weights sum to 1); and that rule is off from the area
 * integral of g only in the intervals where g has a kink (g is piecewise
 * affine with at most two kinks, slope changes <= 1), by at most
 * (1/N)^2 / 8 per kink. Total: |coverage - area| <= 1/(2N) + 1/(4N^2):
 * 0.1406 at the default depth 2, 0.0664 at depth 3.
 *
 * Invariants:
 *  1. corner (i, j) of the image is sampled once, at (i, j) exactly, and
 *     read by the up to four pixels around it;
 *  2. a pixel's value depends on its samples only (a fixed summation
 *     order), and a sample on its position only: images do not depend on
 *     the thread count;
 *  3. the local grid's point (a, b) is sampled at most once per pixel
 *     (the `have` flags), at (x + a / N, y + b / N).
 */
#include "render/corner_aa.h"

#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/alloc.h"

enum { CH = 4, /* r, g, b, coverage */
       GRID_MAX = (1 << SG_CORNER_AA_MAX_DEPTH) + 1 };

typedef struct pixel_ctx {
    sg_corner_aa_sample_fn fn;
    void *ctx;
    float x0, y0;      /* the pixel's top-left corner                  */
    int n;             /* grid squares a side (2^max_depth)            */
    float threshold;
    float *grid;       /* (n + 1)^2 * CH, row-major in b               */
    unsigned char *have; /* (n + 1)^2 flags: sampled                   */
    uint64_t samples;
} pixel_ctx;

/* 1 when the four samples differ by more than the threshold: per colour
 * channel the contrast (hi - lo) / (hi + lo), and the coverage's
 * difference. NaN compares false: never a reason to cut. */
static int disagree(const float *c0, const float *c1, const float *c2, const float *c3, float t)
{
    for (int k = 0; k < CH; ++k) {
        float lo = c0[k], hi = c0[k];
        const float v[3] = {c1[k], c2[k], c3[k]};
        for (int i = 0; i < 3; ++i) {
            lo = v[i] < lo ? v[i] : lo;
            hi = v[i] > hi ? v[i] : hi;
        }
        if (k < 3 ? hi - lo > t * (hi + lo) : hi - lo > t)
            return 1;
    }
    return 0;
}

static float *grid_at(pixel_ctx *p, int a, int b) { return p->grid + ((size_t)b * (size_t)(p->n + 1) + (size_t)a) * CH; }

static void grid_sample(pixel_ctx *p, int a, int b)
{
    unsigned char *h = p->have + (size_t)b * (size_t)(p->n + 1) + (size_t)a;
    if (*h)
        return;
    const float inv = 1.0f / (float)p->n; /* a power of two: a * inv is exact */
    float *c = grid_at(p, a, b);
    p->fn(p->ctx, p->x0 + (float)a * inv, p->y0 + (float)b * inv, c, c + 3);
    p->samples++;
    *h = 1;
}

/* The square of side s grid units at (a, b), its corners sampled: its
 * value into out[CH]. */
static void square(pixel_ctx *p, int a, int b, int s, float *out)
{
    const float *c00 = grid_at(p, a, b), *c10 = grid_at(p, a + s, b);
    const float *c01 = grid_at(p, a, b + s), *c11 = grid_at(p, a + s, b + s);
    if (s == 1 || !disagree(c00, c10, c01, c11, p->threshold)) {
        for (int k = 0; k < CH; ++k)
            out[k] = 0.25f * ((c00[k] + c10[k]) + (c01[k] + c11[k]));
        return;
    }
    const int h = s / 2;
    grid_sample(p, a + h, b);
    grid_sample(p, a, b + h);
    grid_sample(p, a + h, b + h);
    grid_sample(p, a + s, b + h);
    grid_sample(p, a + h, b + s);
    float q[4][CH];
    square(p, a, b, h, q[0]);
    square(p, a + h, b, h, q[1]);
    square(p, a, b + h, h, q[2]);
    square(p, a + h, b + h, h, q[3]);
    for (int k = 0; k < CH; ++k)
        out[k] = 0.25f * ((q[0][k] + q[1][k]) + (q[2][k] + q[3][k]));
}

sg_status sg_corner_aa_render(const sg_corner_aa_desc *desc, sg_corner_aa_sample_fn fn, void *ctx, sg_image *out,
                              sg_corner_aa_stats *stats, sg_error *err)
{
    if (!desc || !fn || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_corner_aa_render: NULL argument");
    const int w = desc->width, h = desc->height;
    if (w < 1 || h < 1 || w > SG_IMAGE_MAX_DIM || h > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "anti-aliasing: image size %d x %d is not in [1, %d]", w, h,
                            SG_IMAGE_MAX_DIM);
    int depth = desc->max_depth == 0 ? SG_CORNER_AA_DEPTH : desc->max_depth == -1 ? 0 : desc->max_depth;
    if (depth < 0 || depth > SG_CORNER_AA_MAX_DEPTH)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "anti-aliasing: depth %d is not in [0, %d] (-1 means 0)",
                            desc->max_depth, SG_CORNER_AA_MAX_DEPTH);
    if (isnan(desc->threshold))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "anti-aliasing: the threshold is NaN");
    if (desc->threads < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "anti-aliasing: threads %d is negative", desc->threads);
    const float threshold = desc->threshold == 0.0f ? SG_CORNER_AA_THRESHOLD : desc->threshold;
    const int n = 1 << depth;
    const size_t cw = (size_t)w + 1;
    size_t ncorner;
    if (!sg_mul_size(cw, (size_t)h + 1, &ncorner))
        return sg_error_set(err, SG_ERR_NOMEM, "anti-aliasing: %d x %d corners overflow", w + 1, h + 1);
    sg_image img = {0};
    sg_status st = sg_image_alloc(&img, w, h, err);
    if (st != SG_OK)
        return st;
    float *corner = sg_alloc_array(ncorner, CH * sizeof(float));
    img.alpha = sg_alloc_array((size_t)w * (size_t)h, sizeof(float));
    if (!corner || !img.alpha) {
        sg_free(corner);
        sg_image_free(&img);
        return sg_error_set(err, SG_ERR_NOMEM, "anti-aliasing: out of memory for %d x %d", w, h);
    }
    const int threads = desc->threads > 0 ? desc->threads : omp_get_max_threads();
    uint64_t samples = (uint64_t)ncorner, refined = 0;
    int nomem = 0;
    double t0 = omp_get_wtime();
    /* Pass 1: the corners (invariant 1). */
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (int j = 0; j <= h; ++j)
        for (int i = 0; i <= w; ++i) {
            float *c = corner + ((size_t)j * cw + (size_t)i) * CH;
            fn(ctx, (float)i, (float)j, c, c + 3);
        }
    /* Pass 2: the pixels. */
#pragma omp parallel num_threads(threads) reduction(+ : samples, refined) reduction(| : nomem)
    {
        pixel_ctx p = {.fn = fn, .ctx = ctx, .n = n, .threshold = threshold};
        const size_t g = (size_t)(n + 1) * (size_t)(n + 1);
        p.grid = depth > 0 ? sg_alloc_array(g, CH * sizeof(float)) : NULL;
        p.have = depth > 0 ? sg_alloc_array(g, 1) : NULL;
        nomem = depth > 0 && (!p.grid || !p.have);
#pragma omp for schedule(dynamic, 1)
        for (int j = 0; j < h; ++j) {
            if (nomem)
                continue;
            for (int i = 0; i < w; ++i) {
                const float *c00 = corner + ((size_t)j * cw + (size_t)i) * CH, *c10 = c00 + CH;
                const float *c01 = c00 + cw * CH, *c11 = c01 + CH;
                float v[CH];
                if (depth == 0 || !disagree(c00, c10, c01, c11, threshold)) {
                    for (int k = 0; k < CH; ++k)
                        v[k] = 0.25f * ((c00[k] + c10[k]) + (c01[k] + c11[k]));
                } else {
                    memset(p.have, 0, g);
                    memcpy(grid_at(&p, 0, 0), c00, CH * sizeof(float));
                    memcpy(grid_at(&p, n, 0), c10, CH * sizeof(float));
                    memcpy(grid_at(&p, 0, n), c01, CH * sizeof(float));
                    memcpy(grid_at(&p, n, n), c11, CH * sizeof(float));
                    p.have[0] = p.have[n] = p.have[(size_t)n * (size_t)(n + 1)] = 1;
                    p.have[(size_t)n * (size_t)(n + 1) + (size_t)n] = 1;
                    p.x0 = (float)i;
                    p.y0 = (float)j;
                    square(&p, 0, 0, n, v);
                    refined++;
                }
                const size_t at = (size_t)j * (size_t)w + (size_t)i;
                memcpy(img.data + 3 * at, v, 3 * sizeof(float));
                img.alpha[at] = v[3];
            }
        }
        samples += p.samples;
        sg_free(p.grid);
        sg_free(p.have);
    }
    const double seconds = omp_get_wtime() - t0;
    sg_free(corner);
    if (nomem) {
        sg_image_free(&img);
        return sg_error_set(err, SG_ERR_NOMEM, "anti-aliasing: out of memory for a pixel's grid");
    }
    if (stats)
        *stats = (sg_corner_aa_stats){.samples = samples, .refined = refined, .seconds = seconds};
    *out = img;
    return SG_OK;
}
