/* image_metrics.h — how far a test image is from a reference image.
 *
 * What it does: compares a test image a (a bake's frame, a short render)
 * with a reference b of the same size (DESIGN.md "Measuring": relative MSE,
 * mean-energy ratio, a difference image) and fills one plain struct with
 * every figure the verifier and the benchmarks report. It also gives the
 * relMSE a reference owes to its own Monte Carlo noise, and a false-colour
 * view of a difference image.
 * What it does NOT do: alignment, resampling, tone mapping, perceptual
 * metrics (SSIM, FLIP), colour management. Values are scene-linear RGB.
 *
 * Definitions. P is the set of pixels where every channel of a and of b is
 * finite (the others are counted and excluded from every figure, so one NaN
 * cannot poison a mean); n = |P|; sums run over i in P and channels
 * c in {R, G, B}; lum = 0.2126 R + 0.7152 G + 0.0722 B (Rec.709).
 *
 *   m        = sum b / (3 n)                       mean of the reference
 *   epsilon  = 1e-2 m^2    (if m == 0: 1e-2)       keeps dark pixels from
 *                                                  dominating; scales with
 *                                                  the image, so every ratio
 *                                                  below is invariant under
 *                                                  a -> k a, b -> k b
 *   r_i      = (1/3) sum_c (a_ic - b_ic)^2 / (b_ic^2 + epsilon)
 *                                                  pixel i's relative squared
 *                                                  error
 *   rel_mse  = (1/n) sum_i r_i                     PRIMARY metric, "relMSE"
 *                                                  everywhere in splatgi
 *   rel_mse_channel[c] = (1/n) sum_i (a_ic - b_ic)^2 / (b_ic^2 + epsilon)
 *   rel_mse_global = sum (a - b)^2 / sum b^2       ratio of totals (0 when
 *                                                  both sums are 0, INFINITY
 *                                                  when only sum b^2 is)
 *   mse      = sum (a - b)^2 / (3 n)               absolute, radiance^2
 *   energy_ratio[c] = mean_a[c] / mean_b[c],  mean_x[c] = sum_i x_ic / n;
 *   energy_ratio_lum = lum(mean_a) / lum(mean_b)   (1 when both means are 0,
 *                                                  INFINITY when only the
 *                                                  reference's is)
 *   p99_rel_error = sqrt(r_(k)), k = ceil(0.99 n) (nearest rank, 1-based,
 *                  over r sorted ascending): 99 % of pixels have an RMS
 *                  relative error at most this
 *   max_rel_error = sqrt(max_i r_i)
 *   max_abs_error = max |a_ic - b_ic|
 *
 * Closed forms the tests check: a = b gives 0 errors and ratios 1; a = k b
 * gives rel_mse_global = (k-1)^2, energy ratios k, and for a constant b = v,
 * rel_mse = (k-1)^2 v^2 / (v^2 + 1e-2 v^2) = (k-1)^2 / 1.01.
 *
 * The difference image (optional) is a - b, signed, per channel; excluded
 * pixels are NaN there, so sg_image_false_colour marks them.
 *
 * Errors: SG_ERR_INVALID_ARG (NULL or unallocated images, sizes differ:
 * the message names both sizes; no pixel with finite values in both),
 * SG_ERR_NOMEM. Out-parameters are written only on SG_OK.
 * Ownership: the caller owns a and b; a diff or colour image is allocated
 * here and freed with sg_image_free. Thread-safety: pure functions.
 *
 * Use:
 *     sg_image_metrics m;
 *     sg_image diff = {0};
 *     if (sg_image_compare(&test, &ref, &m, &diff, &err) != SG_OK) report(err.message);
 *     printf("relMSE %.4g, energy %.4f\n", m.rel_mse, m.energy_ratio_lum);
 *     sg_image_free(&diff);
 */
#ifndef SG_METRICS_IMAGE_METRICS_H
#define SG_METRICS_IMAGE_METRICS_H

#include <stddef.h>

#include "core/error.h"
#include "io/image.h"

/* epsilon = SG_REL_MSE_EPS_FACTOR * (mean of the reference)^2 */
#define SG_REL_MSE_EPS_FACTOR 1e-2

typedef struct sg_image_metrics {
    double rel_mse;            /* primary: mean over pixels, channels of
                                  (a-b)^2 / (b^2 + epsilon)                */
    double rel_mse_channel[3]; /* the same per channel                     */
    double rel_mse_global;     /* sum (a-b)^2 / sum b^2                    */
    double mse;                /* mean (a-b)^2, absolute                   */
    double epsilon;            /* the epsilon used (header)                */
    double mean_a[3], mean_b[3];  /* per-channel means over used pixels    */
    double energy_ratio[3];    /* mean_a / mean_b per channel              */
    double energy_ratio_lum;   /* lum(mean_a) / lum(mean_b)                */
    double p99_rel_error;      /* 99th-percentile per-pixel RMS relative error */
    double max_rel_error;      /* largest per-pixel RMS relative error     */
    double max_abs_error;      /* largest |a - b| over pixels and channels  */
    size_t nan_pixels;         /* pixels of a with a NaN channel           */
    size_t inf_pixels;         /* pixels of a with an infinite channel and
                                  no NaN                                   */
    size_t ref_nonfinite_pixels; /* pixels of b with a NaN or infinite
                                  channel (also excluded)                  */
    size_t pixels_used;        /* n: pixels finite in both                 */
} sg_image_metrics;

/* Compares test image a with reference b (header for every figure). diff,
 * if non-NULL, receives a - b (allocated here; its previous contents are not
 * freed). */
sg_status sg_image_compare(const sg_image *a, const sg_image *b, sg_image_metrics *out, sg_image *diff,
                           sg_error *err);

/* The relMSE a Monte Carlo reference owes to its own noise: with se its
 * per-pixel standard error (pathtrace.h), an independent unbiased image
 * compared with b has expected rel_mse = (its own noise) + this, where
 *     noise = (1/3n) sum_ic se_ic^2 / (b_ic^2 + epsilon)
 * over the pixels where b and se are finite. epsilon <= 0 means the one
 * sg_image_compare would use for reference b (from b's finite pixels).
 * Errors as sg_image_compare (se must match b's size). */
sg_status sg_image_noise_rel_mse(const sg_image *b, const sg_image *se, double epsilon, double *out,
                                 sg_error *err);

/* A diverging false-colour view of a difference image (e.g. a - b from
 * sg_image_compare): t = lum(diff) / scale clamped to [-1, 1] gives white
 * at 0, towards red (1, 1-t, 1-t) for t > 0 (test too bright) and towards
 * blue (1+t, 1+t, 1) for t < 0; pixels with a non-finite channel are green
 * (0, 1, 0). Values are in [0, 1]: write with sg_image_write_png at
 * exposure 1. scale must be finite and > 0. */
sg_status sg_image_false_colour(const sg_image *diff, double scale, sg_image *out, sg_error *err);

#endif
