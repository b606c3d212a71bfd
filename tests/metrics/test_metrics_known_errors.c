/* test_metrics_known_errors.c — known perturbations give known errors, for
 * the figures the verifier reports (relMSE, energy ratio, p99), beyond the
 * constant-image closed forms of test_image_metrics.c.
 *
 * Definitions (image_metrics.h): m = sum b / 3n, epsilon = 1e-2 m^2,
 * r_i = (1/3) sum_c (a_ic - b_ic)^2 / (b_ic^2 + epsilon), relMSE = mean r_i,
 * p99 = sqrt(r_(ceil(0.99 n))) over r sorted ascending, energy ratio per
 * channel = sum a / sum b, and its luminance form with Rec.709 weights. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "metrics/image_metrics.h"

static sg_image alloc_image(int w, int h)
{
    sg_image img = {0};
    sg_error err = {0};
    if (sg_image_alloc(&img, w, h, &err) != SG_OK)
        fail_msg("alloc: %s", err.message);
    return img;
}

static sg_image_metrics compare(const sg_image *a, const sg_image *b)
{
    sg_image_metrics m;
    sg_error err = {0};
    if (sg_image_compare(a, b, &m, NULL, &err) != SG_OK)
        fail_msg("compare: %s", err.message);
    return m;
}

/* 1. a = (1 + e) b, e = 1e-3, on a varied b: energy ratios 1 + e; relMSE
 * equals the definition evaluated here on the stored floats, and is close
 * to e^2 mean(b^2 / (b^2 + epsilon)) (exact but for a's float rounding). */
static void test_metrics_scale_by_one_plus_e(void **state)
{
    (void)state;
    const int w = 31, h = 17, n = w * h;
    const double e = 1e-3;
    sg_image a = alloc_image(w, h), b = alloc_image(w, h);
    uint64_t seed = 42;
    for (int i = 0; i < 3 * n; i++) {
        b.data[i] = 0.01f + 5.0f * sg_test_rand01(&seed);
        a.data[i] = (float)((1.0 + e) * b.data[i]);
    }
    double sb = 0;
    for (int i = 0; i < 3 * n; i++)
        sb += b.data[i];
    double mean = sb / (3.0 * n), eps = 1e-2 * mean * mean;
    double by_hand = 0, closed = 0, sa[3] = {0, 0, 0}, sbc[3] = {0, 0, 0};
    for (int i = 0; i < 3 * n; i++) {
        double d = (double)a.data[i] - b.data[i], bb = (double)b.data[i] * b.data[i];
        by_hand += d * d / (bb + eps);
        closed += e * e * bb / (bb + eps);
        sa[i % 3] += a.data[i];
        sbc[i % 3] += b.data[i];
    }
    by_hand /= 3.0 * n;
    closed /= 3.0 * n;
    sg_image_metrics m = compare(&a, &b);
    if (fabs(m.rel_mse - by_hand) > 1e-9 * by_hand)
        fail_msg("relMSE %.17g, by hand %.17g", m.rel_mse, by_hand);
    if (fabs(m.rel_mse - closed) > 1e-3 * closed)
        fail_msg("relMSE %.17g, e^2 mean(b^2/(b^2+eps)) %.17g", m.rel_mse, closed);
    for (int c = 0; c < 3; c++) {
        if (fabs(m.energy_ratio[c] - sa[c] / sbc[c]) > 1e-12)
            fail_msg("channel %d energy ratio %.17g, sums give %.17g", c, m.energy_ratio[c], sa[c] / sbc[c]);
        if (fabs(m.energy_ratio[c] - (1.0 + e)) > 1e-6)
            fail_msg("channel %d energy ratio %.17g, want 1 + %g", c, m.energy_ratio[c], e);
    }
    if (fabs(m.energy_ratio_lum - (1.0 + e)) > 1e-6)
        fail_msg("luminance energy ratio %.17g, want 1 + %g", m.energy_ratio_lum, e);
    sg_image_free(&a);
    sg_image_free(&b);
}

/* 2. p99 picks the rank-ceil(0.99 n) pixel, on b = v with outliers
 * raising all three channels by d1 < d2 < d3 (r = d^2 / (1.01 v^2)).
 * n = 200 (rank 198): with three outliers ranks 198..200 hold them and
 * p99 = d1 / (v sqrt(1.01)); with two, rank 198 is unchanged: p99 = 0.
 * n = 150 (0.99 n = 148.5, rank 149, where rounding down would give 148):
 * with two outliers p99 = d2's, with one it is 0. The maximum is always
 * d3's, and relMSE the outliers' r summed over n. */
static void test_metrics_p99_rank_with_outliers(void **state)
{
    (void)state;
    const double v = 2.0, d[3] = {0.5, 1.0, 4.0};
    const int pix[3] = {7, 120, 149};
    const struct {
        int w, h, count;
        double want_d; /* 0: p99 is 0 */
    } cases[4] = {{20, 10, 3, 0.5}, {20, 10, 2, 0.0}, {15, 10, 2, 1.0}, {15, 10, 1, 0.0}};
    for (int q = 0; q < 4; q++) {
        int w = cases[q].w, h = cases[q].h, n = w * h, count = cases[q].count;
        sg_image a = alloc_image(w, h), b = alloc_image(w, h);
        for (int i = 0; i < 3 * n; i++)
            a.data[i] = b.data[i] = (float)v;
        for (int k = 3 - count; k < 3; k++)
            for (int c = 0; c < 3; c++)
                a.data[3 * pix[k] + c] = (float)(v + d[k]);
        sg_image_metrics m = compare(&a, &b);
        double want = cases[q].want_d / (v * sqrt(1.01));
        if (fabs(m.p99_rel_error - want) > 1e-12)
            fail_msg("%d pixels, %d outliers: p99 %.17g, want %.17g", n, count, m.p99_rel_error, want);
        double maxr = d[2] / (v * sqrt(1.01));
        if (fabs(m.max_rel_error - maxr) > 1e-12)
            fail_msg("%d pixels, %d outliers: max %.17g, want %.17g", n, count, m.max_rel_error, maxr);
        double sum = 0;
        for (int k = 3 - count; k < 3; k++)
            sum += d[k] * d[k] / (1.01 * v * v);
        if (fabs(m.rel_mse - sum / n) > 1e-12 * sum)
            fail_msg("%d pixels, %d outliers: relMSE %.17g, want %.17g", n, count, m.rel_mse, sum / n);
        sg_image_free(&a);
        sg_image_free(&b);
    }
}

/* 3. Only green scaled by k on a grey b: energy ratios (1, k, 1) and the
 * luminance ratio 0.2126 + 0.7152 k + 0.0722 (Rec.709 weights). */
static void test_metrics_luminance_ratio_weights(void **state)
{
    (void)state;
    const double k = 1.5;
    sg_image a = alloc_image(8, 8), b = alloc_image(8, 8);
    for (int i = 0; i < 3 * 64; i++)
        b.data[i] = a.data[i] = 0.25f;
    for (int i = 0; i < 64; i++)
        a.data[3 * i + 1] = (float)(0.25 * k);
    sg_image_metrics m = compare(&a, &b);
    assert_true(m.energy_ratio[0] == 1.0 && m.energy_ratio[2] == 1.0);
    if (fabs(m.energy_ratio[1] - k) > 1e-12)
        fail_msg("green energy ratio %.17g, want %g", m.energy_ratio[1], k);
    double want = 0.2126 + 0.7152 * k + 0.0722;
    if (fabs(m.energy_ratio_lum - want) > 1e-12)
        fail_msg("luminance energy ratio %.17g, want %.17g", m.energy_ratio_lum, want);
    sg_image_free(&a);
    sg_image_free(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_metrics_scale_by_one_plus_e),
        cmocka_unit_test(test_metrics_p99_rank_with_outliers),
        cmocka_unit_test(test_metrics_luminance_ratio_weights),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
