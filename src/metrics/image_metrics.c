/* image_metrics.c — relative MSE, energy ratio, percentiles and difference
 * images (definitions in image_metrics.h).
 *
 * relMSE with a scale-relative epsilon follows the denoising literature
 * (Rousselle et al. 2011, "Adaptive sampling and reconstruction using
 * greedy error minimization"; there epsilon is absolute, 1e-2 for images of
 * mean ~1): tying it to the reference's mean makes the figure independent
 * of exposure and of the envmap's intensity.
 *
 * Invariants:
 *  1. a pixel enters a figure only if all six of its values (a and b) are
 *     finite: every sum and maximum is over the same pixel set P;
 *  2. sums are accumulated in double, per channel, in pixel order, so the
 *     result is deterministic and a = b gives exactly 0 and ratios exactly 1;
 *  3. out and the images are written only after every check and
 *     allocation has succeeded.
 */
#include "metrics/image_metrics.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>

#include "core/alloc.h"

static const double LUM[3] = {0.2126, 0.7152, 0.0722};

static sg_status check_images(const sg_image *a, const sg_image *b, const char *what_a, const char *what_b,
                              sg_error *err)
{
    if (!a || !b || !a->data || !b->data || a->width <= 0 || a->height <= 0 || b->width <= 0 || b->height <= 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "image compare: %s or %s is NULL or not allocated", what_a,
                            what_b);
    if (a->width != b->width || a->height != b->height)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "image compare: %s is %dx%d but %s is %dx%d", what_a, a->width,
                            a->height, what_b, b->width, b->height);
    return SG_OK;
}

static int finite3(const float *p) { return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]); }

static int has_nan3(const float *p) { return isnan(p[0]) || isnan(p[1]) || isnan(p[2]); }

/* x / y with the header's conventions for y == 0. */
static double ratio(double x, double y)
{
    if (y != 0.0)
        return x / y;
    return x == 0.0 ? 1.0 : INFINITY;
}

static double epsilon_of_mean(double m)
{
    return m != 0.0 ? SG_REL_MSE_EPS_FACTOR * m * m : SG_REL_MSE_EPS_FACTOR;
}

static int cmp_double(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

sg_status sg_image_compare(const sg_image *a, const sg_image *b, sg_image_metrics *out, sg_image *diff,
                           sg_error *err)
{
    assert(out);
    sg_status st = check_images(a, b, "test image", "reference", err);
    if (st != SG_OK)
        return st;
    size_t npix = (size_t)a->width * (size_t)a->height;

    sg_image_metrics m = {0};
    double sum_a[3] = {0, 0, 0}, sum_b[3] = {0, 0, 0}; /* over P (invariant 1) */
    for (size_t i = 0; i < npix; ++i) {
        const float *pa = a->data + 3 * i, *pb = b->data + 3 * i;
        int fa = finite3(pa), fb = finite3(pb);
        if (!fa) {
            if (has_nan3(pa))
                m.nan_pixels++;
            else
                m.inf_pixels++;
        }
        if (!fb)
            m.ref_nonfinite_pixels++;
        if (!fa || !fb)
            continue;
        m.pixels_used++;
        for (int c = 0; c < 3; ++c) {
            sum_a[c] += pa[c];
            sum_b[c] += pb[c];
        }
    }
    if (m.pixels_used == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "image compare: no pixel is finite in both images (%zu NaN, %zu infinite in the test "
                            "image, %zu non-finite in the reference, of %zu)",
                            m.nan_pixels, m.inf_pixels, m.ref_nonfinite_pixels, npix);

    double *r = sg_alloc_array(m.pixels_used, sizeof *r); /* r_i of the pixels of P, in order */
    sg_image d = {0};
    if (!r)
        return sg_error_set(err, SG_ERR_NOMEM, "image compare: out of memory for %zu pixels", m.pixels_used);
    if (diff && (st = sg_image_alloc(&d, a->width, a->height, err)) != SG_OK)
        goto fail_r;

    double n = (double)m.pixels_used;
    m.epsilon = epsilon_of_mean((sum_b[0] + sum_b[1] + sum_b[2]) / (3.0 * n));
    double sq[3] = {0, 0, 0};      /* sum (a-b)^2 per channel            */
    double rel[3] = {0, 0, 0};     /* sum (a-b)^2 / (b^2 + eps) per channel */
    double sq_b = 0.0;             /* sum b^2                            */
    double max_r = 0.0, max_abs = 0.0;
    size_t k = 0;
    for (size_t i = 0; i < npix; ++i) {
        const float *pa = a->data + 3 * i, *pb = b->data + 3 * i;
        if (!finite3(pa) || !finite3(pb)) {
            if (diff)
                d.data[3 * i] = d.data[3 * i + 1] = d.data[3 * i + 2] = NAN;
            continue;
        }
        double ri = 0.0;
        for (int c = 0; c < 3; ++c) {
            double e = (double)pa[c] - (double)pb[c], bb = (double)pb[c] * pb[c];
            double q = e * e / (bb + m.epsilon);
            sq[c] += e * e;
            rel[c] += q;
            sq_b += bb;
            ri += q;
            max_abs = fmax(max_abs, fabs(e));
            if (diff)
                d.data[3 * i + c] = (float)e;
        }
        ri /= 3.0;
        max_r = fmax(max_r, ri);
        r[k++] = ri;
    }
    assert(k == m.pixels_used);

    double sq_all = sq[0] + sq[1] + sq[2];
    for (int c = 0; c < 3; ++c) {
        m.rel_mse_channel[c] = rel[c] / n;
        m.mean_a[c] = sum_a[c] / n;
        m.mean_b[c] = sum_b[c] / n;
        m.energy_ratio[c] = ratio(m.mean_a[c], m.mean_b[c]);
    }
    m.rel_mse = (rel[0] + rel[1] + rel[2]) / (3.0 * n);
    m.rel_mse_global = ratio(sq_all, sq_b);
    if (sq_all == 0.0)
        m.rel_mse_global = 0.0;
    m.mse = sq_all / (3.0 * n);
    m.energy_ratio_lum = ratio(LUM[0] * m.mean_a[0] + LUM[1] * m.mean_a[1] + LUM[2] * m.mean_a[2],
                               LUM[0] * m.mean_b[0] + LUM[1] * m.mean_b[1] + LUM[2] * m.mean_b[2]);
    /* Nearest rank: the ceil(0.99 n)-th smallest, 1-based. The integer form
     * avoids 0.99 * n rounding up past an exact multiple. */
    qsort(r, k, sizeof *r, cmp_double);
    size_t rank = (99 * k + 99) / 100; /* = ceil(0.99 k) for k >= 1 */
    m.p99_rel_error = sqrt(r[rank - 1]);
    m.max_rel_error = sqrt(max_r);
    m.max_abs_error = max_abs;

    sg_free(r);
    *out = m;
    if (diff)
        *diff = d;
    return SG_OK;

fail_r:
    sg_free(r);
    return st;
}

sg_status sg_image_noise_rel_mse(const sg_image *b, const sg_image *se, double epsilon, double *out,
                                 sg_error *err)
{
    assert(out);
    sg_status st = check_images(se, b, "standard-error image", "reference", err);
    if (st != SG_OK)
        return st;
    size_t npix = (size_t)b->width * (size_t)b->height;
    if (!(epsilon > 0.0)) {
        double s = 0.0;
        size_t n = 0;
        for (size_t i = 0; i < npix; ++i) {
            const float *pb = b->data + 3 * i;
            if (!finite3(pb))
                continue;
            s += (double)pb[0] + pb[1] + pb[2];
            n++;
        }
        if (n == 0)
            return sg_error_set(err, SG_ERR_INVALID_ARG, "noise relMSE: the reference has no finite pixel");
        epsilon = epsilon_of_mean(s / (3.0 * (double)n));
    }
    double sum = 0.0;
    size_t n = 0;
    for (size_t i = 0; i < npix; ++i) {
        const float *pb = b->data + 3 * i, *ps = se->data + 3 * i;
        if (!finite3(pb) || !finite3(ps))
            continue;
        for (int c = 0; c < 3; ++c)
            sum += (double)ps[c] * ps[c] / ((double)pb[c] * pb[c] + epsilon);
        n++;
    }
    if (n == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "noise relMSE: no pixel is finite in both the reference and its standard error");
    *out = sum / (3.0 * (double)n);
    return SG_OK;
}

sg_status sg_image_false_colour(const sg_image *diff, double scale, sg_image *out, sg_error *err)
{
    assert(out);
    if (!diff || !diff->data || diff->width <= 0 || diff->height <= 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "false colour: image is NULL or not allocated");
    if (!(scale > 0.0) || !isfinite(scale))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "false colour: scale %g is not finite and > 0", scale);
    sg_image o = {0};
    sg_status st = sg_image_alloc(&o, diff->width, diff->height, err);
    if (st != SG_OK)
        return st;
    size_t npix = (size_t)diff->width * (size_t)diff->height;
    for (size_t i = 0; i < npix; ++i) {
        const float *p = diff->data + 3 * i;
        float *q = o.data + 3 * i;
        if (!finite3(p)) {
            q[0] = 0.0f, q[1] = 1.0f, q[2] = 0.0f;
            continue;
        }
        double t = (LUM[0] * p[0] + LUM[1] * p[1] + LUM[2] * p[2]) / scale;
        t = t > 1.0 ? 1.0 : t < -1.0 ? -1.0 : t;
        if (t >= 0.0)
            q[0] = 1.0f, q[1] = q[2] = (float)(1.0 - t);
        else
            q[0] = q[1] = (float)(1.0 + t), q[2] = 1.0f;
    }
    *out = o;
    return SG_OK;
}
