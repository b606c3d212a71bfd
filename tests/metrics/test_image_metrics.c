/* test_image_metrics.c — image comparison against closed forms.
 *
 * Images with a constant reference b = v make every figure a closed form:
 * epsilon = 1e-2 v^2, so (a - b)^2 / (b^2 + epsilon) = (a - b)^2 / (1.01 v^2).
 * Tolerances are relative 1e-12 where a and b are exact in float, else
 * a few float ulps of the inputs (noted per case). */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "metrics/image_metrics.h"

static sg_image make_image(int w, int h)
{
    sg_image img = {0};
    sg_error err = {0};
    if (sg_image_alloc(&img, w, h, &err) != SG_OK)
        fail_msg("alloc %dx%d: %s", w, h, err.message);
    return img;
}

static sg_image constant_image(int w, int h, float v)
{
    sg_image img = make_image(w, h);
    for (size_t i = 0; i < 3 * (size_t)w * (size_t)h; ++i)
        img.data[i] = v;
    return img;
}

/* A reference with varied positive values (a rendered image's spread). */
static sg_image varied_image(int w, int h, uint64_t seed)
{
    sg_image img = make_image(w, h);
    for (size_t i = 0; i < 3 * (size_t)w * (size_t)h; ++i)
        img.data[i] = 0.05f + 3.0f * sg_test_rand01(&seed);
    return img;
}

static sg_image_metrics compare_ok(const sg_image *a, const sg_image *b, sg_image *diff)
{
    sg_image_metrics m;
    sg_error err = {0};
    if (sg_image_compare(a, b, &m, diff, &err) != SG_OK)
        fail_msg("compare: %s", err.message);
    return m;
}

static void expect_close(const char *what, double got, double want, double rel_tol)
{
    if (!(fabs(got - want) <= rel_tol * fabs(want)))
        fail_msg("%s: got %.17g, want %.17g (relative tolerance %g)", what, got, want, rel_tol);
}

/* 1. a = b: every error exactly 0, every ratio exactly 1. */
static void test_metrics_identical_images_exact(void **state)
{
    (void)state;
    sg_image b = varied_image(37, 23, 1);
    sg_image a = make_image(37, 23);
    memcpy(a.data, b.data, sizeof(float) * 3 * 37 * 23);
    sg_image diff = {0};
    sg_image_metrics m = compare_ok(&a, &b, &diff);
    assert_true(m.rel_mse == 0.0 && m.rel_mse_global == 0.0 && m.mse == 0.0);
    for (int c = 0; c < 3; ++c) {
        assert_true(m.rel_mse_channel[c] == 0.0);
        if (m.energy_ratio[c] != 1.0)
            fail_msg("channel %d energy ratio %.17g, want exactly 1", c, m.energy_ratio[c]);
    }
    assert_true(m.energy_ratio_lum == 1.0);
    assert_true(m.p99_rel_error == 0.0 && m.max_rel_error == 0.0 && m.max_abs_error == 0.0);
    assert_true(m.nan_pixels == 0 && m.inf_pixels == 0 && m.ref_nonfinite_pixels == 0);
    assert_int_equal(m.pixels_used, 37 * 23);
    for (size_t i = 0; i < 3 * 37 * 23; ++i)
        assert_true(diff.data[i] == 0.0f);
    sg_image_free(&a);
    sg_image_free(&b);
    sg_image_free(&diff);
}

/* 2. a = 1.1 b. Constant b = v: rel_mse = 0.01 / 1.01, p99 = max =
 * sqrt(0.01 / 1.01). Varied b: rel_mse_global = 0.01, energy ratios 1.1.
 * 1.1f * b carries one float rounding: tolerance 1e-6. */
static void test_metrics_scaled_image_closed_form(void **state)
{
    (void)state;
    const float k = 1.1f;
    sg_image b = constant_image(16, 8, 0.8f), a = constant_image(16, 8, 0.8f * k);
    sg_image_metrics m = compare_ok(&a, &b, NULL);
    double e = (double)(0.8f * k) - 0.8; /* the difference as stored */
    double want = e * e / (1.01 * 0.64);
    expect_close("constant b: rel_mse", m.rel_mse, want, 1e-6);
    expect_close("constant b: rel_mse ~ 0.01/1.01", m.rel_mse, 0.01 / 1.01, 1e-5);
    expect_close("constant b: p99", m.p99_rel_error, sqrt(want), 1e-6);
    expect_close("constant b: max rel", m.max_rel_error, sqrt(want), 1e-6);
    expect_close("constant b: epsilon", m.epsilon, 0.01 * (double)0.8f * (double)0.8f, 1e-12);
    sg_image_free(&a);
    sg_image_free(&b);

    b = varied_image(40, 30, 2);
    a = make_image(40, 30);
    for (size_t i = 0; i < 3 * 40 * 30; ++i)
        a.data[i] = k * b.data[i];
    m = compare_ok(&a, &b, NULL);
    expect_close("varied b: rel_mse_global", m.rel_mse_global, 0.01, 1e-5);
    for (int c = 0; c < 3; ++c)
        expect_close("varied b: energy ratio", m.energy_ratio[c], 1.1, 1e-6);
    expect_close("varied b: luminance energy ratio", m.energy_ratio_lum, 1.1, 1e-6);
    /* relMSE is scale-free: scaling both images by 4 (exact) changes nothing. */
    sg_image a4 = make_image(40, 30), b4 = make_image(40, 30);
    for (size_t i = 0; i < 3 * 40 * 30; ++i) {
        a4.data[i] = 4.0f * a.data[i];
        b4.data[i] = 4.0f * b.data[i];
    }
    sg_image_metrics m4 = compare_ok(&a4, &b4, NULL);
    expect_close("rel_mse under a common scale", m4.rel_mse, m.rel_mse, 1e-12);
    expect_close("p99 under a common scale", m4.p99_rel_error, m.p99_rel_error, 1e-12);
    expect_close("mse scales by 16", m4.mse, 16.0 * m.mse, 1e-12);
    sg_image_free(&a);
    sg_image_free(&b);
    sg_image_free(&a4);
    sg_image_free(&b4);
}

/* 3. a = b + c with b = v = 2, c = 0.5 (exact in float): rel_mse =
 * c^2 / (1.01 v^2), rel_mse_global = c^2 / v^2, mse = c^2, energy ratio
 * (v + c) / v, max_abs = c; the signed difference image holds +c. */
static void test_metrics_offset_image_closed_form(void **state)
{
    (void)state;
    const double v = 2.0, c = 0.5;
    sg_image b = constant_image(9, 7, (float)v), a = constant_image(9, 7, (float)(v + c));
    sg_image diff = {0};
    sg_image_metrics m = compare_ok(&a, &b, &diff);
    expect_close("rel_mse", m.rel_mse, c * c / (1.01 * v * v), 1e-12);
    for (int ch = 0; ch < 3; ++ch)
        expect_close("rel_mse per channel", m.rel_mse_channel[ch], c * c / (1.01 * v * v), 1e-12);
    expect_close("rel_mse_global", m.rel_mse_global, c * c / (v * v), 1e-12);
    expect_close("mse", m.mse, c * c, 1e-12);
    expect_close("energy ratio", m.energy_ratio_lum, (v + c) / v, 1e-12);
    expect_close("max_abs", m.max_abs_error, c, 1e-12);
    expect_close("p99", m.p99_rel_error, c / (v * sqrt(1.01)), 1e-12);
    for (size_t i = 0; i < 3 * 9 * 7; ++i)
        assert_true(diff.data[i] == (float)c);
    sg_image_free(&a);
    sg_image_free(&b);
    sg_image_free(&diff);
}

/* 4. One pixel's red channel raised by d in a constant b = v:
 * r = d^2 / (3 * 1.01 v^2) at that pixel, 0 elsewhere. Of 100 pixels the
 * 99th percentile (rank 99) is 0 and the maximum sqrt(r); of 50 pixels
 * rank ceil(49.5) = 50 is the changed pixel itself. */
static void test_metrics_one_pixel_changed(void **state)
{
    (void)state;
    const double v = 1.0, d = 3.0;
    const double r = d * d / (3.0 * 1.01 * v * v);
    int sizes[2][2] = {{10, 10}, {10, 5}};
    for (int s = 0; s < 2; ++s) {
        int w = sizes[s][0], h = sizes[s][1], n = w * h;
        sg_image b = constant_image(w, h, (float)v), a = constant_image(w, h, (float)v);
        a.data[3 * 37] = (float)(v + d);
        sg_image_metrics m = compare_ok(&a, &b, NULL);
        expect_close("rel_mse", m.rel_mse, r / n, 1e-12);
        expect_close("rel_mse red", m.rel_mse_channel[0], 3.0 * r / n, 1e-12);
        assert_true(m.rel_mse_channel[1] == 0.0 && m.rel_mse_channel[2] == 0.0);
        expect_close("max_rel", m.max_rel_error, sqrt(r), 1e-12);
        expect_close("max_abs", m.max_abs_error, d, 1e-12);
        expect_close("red energy ratio", m.energy_ratio[0], (n * v + d) / (n * v), 1e-12);
        assert_true(m.energy_ratio[1] == 1.0 && m.energy_ratio[2] == 1.0);
        if (n == 100) {
            if (m.p99_rel_error != 0.0)
                fail_msg("100 pixels, one changed: p99 %.17g, want 0", m.p99_rel_error);
        } else {
            expect_close("50 pixels, one changed: p99", m.p99_rel_error, sqrt(r), 1e-12);
        }
        sg_image_free(&a);
        sg_image_free(&b);
    }
}

/* 5. NaN and Inf in the test image are counted by kind and excluded from
 * every figure (so a = b elsewhere still gives 0 and 1), and NaN in the
 * difference image; a non-finite reference pixel is counted apart. */
static void test_metrics_nonfinite_counted_and_excluded(void **state)
{
    (void)state;
    sg_image b = varied_image(20, 10, 3);
    sg_image a = make_image(20, 10);
    memcpy(a.data, b.data, sizeof(float) * 3 * 200);
    a.data[3 * 5 + 0] = NAN;
    a.data[3 * 6 + 2] = NAN;
    a.data[3 * 7 + 1] = NAN;
    a.data[3 * 7 + 2] = INFINITY; /* NaN and Inf: counted as NaN */
    a.data[3 * 8 + 0] = INFINITY;
    a.data[3 * 9 + 1] = -INFINITY;
    b.data[3 * 150 + 1] = NAN;
    b.data[3 * 8 + 1] = NAN; /* both non-finite: counted in both, excluded once */
    sg_image diff = {0};
    sg_image_metrics m = compare_ok(&a, &b, &diff);
    assert_int_equal(m.nan_pixels, 3);
    assert_int_equal(m.inf_pixels, 2);
    assert_int_equal(m.ref_nonfinite_pixels, 2);
    assert_int_equal(m.pixels_used, 200 - 6);
    assert_true(m.rel_mse == 0.0 && m.rel_mse_global == 0.0 && m.max_abs_error == 0.0);
    assert_true(m.energy_ratio[0] == 1.0 && m.energy_ratio[1] == 1.0 && m.energy_ratio[2] == 1.0);
    assert_true(isfinite(m.mean_a[0]) && isfinite(m.mean_b[1]));
    int excluded[6] = {5, 6, 7, 8, 9, 150};
    for (int i = 0; i < 6; ++i)
        assert_true(isnan(diff.data[3 * excluded[i]]));
    assert_true(diff.data[3 * 10] == 0.0f);
    sg_image_free(&diff);

    /* A perturbation elsewhere is still measured exactly. */
    a.data[3 * 100] = b.data[3 * 100] + 1.0f;
    m = compare_ok(&a, &b, NULL);
    assert_true(m.rel_mse > 0.0 && isfinite(m.rel_mse) && isfinite(m.p99_rel_error));
    assert_int_equal(m.nan_pixels, 3);
    sg_image_free(&a);
    sg_image_free(&b);
}

/* 6. Sizes differ: SG_ERR_INVALID_ARG naming both sizes; out untouched. */
static void test_metrics_size_mismatch_rejected(void **state)
{
    (void)state;
    sg_image a = constant_image(4, 3, 1.0f), b = constant_image(3, 4, 1.0f);
    sg_image_metrics m;
    memset(&m, 0xAB, sizeof m);
    sg_image_metrics before = m;
    sg_image diff = {0};
    sg_error err = {0};
    assert_int_equal(sg_image_compare(&a, &b, &m, &diff, &err), SG_ERR_INVALID_ARG);
    if (!strstr(err.message, "4x3") || !strstr(err.message, "3x4"))
        fail_msg("message does not name both sizes: %s", err.message);
    assert_memory_equal(&m, &before, sizeof m);
    assert_null(diff.data);
    sg_image empty = {0};
    assert_int_equal(sg_image_compare(&a, &empty, &m, NULL, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_image_compare(NULL, &b, &m, NULL, &err), SG_ERR_INVALID_ARG);
    sg_image_free(&a);
    sg_image_free(&b);
}

/* 7. No pixel finite in both: an error, not a 0/0 figure. */
static void test_metrics_all_nonfinite_rejected(void **state)
{
    (void)state;
    sg_image a = constant_image(3, 2, NAN), b = constant_image(3, 2, 1.0f);
    sg_image_metrics m;
    sg_error err = {0};
    assert_int_equal(sg_image_compare(&a, &b, &m, NULL, &err), SG_ERR_INVALID_ARG);
    if (!strstr(err.message, "6 NaN"))
        fail_msg("message: %s", err.message);
    sg_image_free(&a);
    sg_image_free(&b);
}

/* 8. Black reference: epsilon falls back to 1e-2, ratios follow the header. */
static void test_metrics_black_reference(void **state)
{
    (void)state;
    sg_image a = constant_image(2, 2, 0.0f), b = constant_image(2, 2, 0.0f);
    sg_image_metrics m = compare_ok(&a, &b, NULL);
    assert_true(m.rel_mse == 0.0 && m.rel_mse_global == 0.0 && m.energy_ratio_lum == 1.0);
    expect_close("epsilon", m.epsilon, 1e-2, 1e-12);
    a.data[0] = 0.1f;
    m = compare_ok(&a, &b, NULL);
    assert_true(isinf(m.rel_mse_global) && isinf(m.energy_ratio[0]) && m.energy_ratio[1] == 1.0);
    expect_close("rel_mse", m.rel_mse, (double)0.1f * 0.1f / 1e-2 / 12.0, 1e-12);
    sg_image_free(&a);
    sg_image_free(&b);
}

/* 9. The reference's noise term: constant b = v, se = s gives
 * s^2 / (1.01 v^2); with an explicit epsilon e, s^2 / (v^2 + e). */
static void test_metrics_noise_rel_mse_closed_form(void **state)
{
    (void)state;
    const double v = 0.5, s = 0.125;
    sg_image b = constant_image(6, 5, (float)v), se = constant_image(6, 5, (float)s);
    double got;
    sg_error err = {0};
    assert_int_equal(sg_image_noise_rel_mse(&b, &se, 0.0, &got, &err), SG_OK);
    expect_close("noise, own epsilon", got, s * s / (1.01 * v * v), 1e-12);
    assert_int_equal(sg_image_noise_rel_mse(&b, &se, 0.25, &got, &err), SG_OK);
    expect_close("noise, given epsilon", got, s * s / (v * v + 0.25), 1e-12);
    sg_image small = constant_image(5, 6, 0.1f);
    assert_int_equal(sg_image_noise_rel_mse(&b, &small, 0.0, &got, &err), SG_ERR_INVALID_ARG);
    sg_image_free(&small);
    sg_image_free(&b);
    sg_image_free(&se);
}

/* 10. False colour: 0 white, positive red, negative blue, NaN green. */
static void test_metrics_false_colour(void **state)
{
    (void)state;
    sg_image d = constant_image(4, 1, 0.0f);
    for (int c = 0; c < 3; ++c) {
        d.data[3 + c] = 2.0f;   /* +1 after scale 2: full red   */
        d.data[6 + c] = -1.0f;  /* -0.5: half towards blue      */
    }
    d.data[9 + 1] = NAN;
    sg_image o = {0};
    sg_error err = {0};
    assert_int_equal(sg_image_false_colour(&d, 2.0, &o, &err), SG_OK);
    const float want[12] = {1, 1, 1, 1, 0, 0, 0.5f, 0.5f, 1, 0, 1, 0};
    for (int i = 0; i < 12; ++i)
        if (fabsf(o.data[i] - want[i]) > 1e-6f)
            fail_msg("value %d: got %g, want %g", i, (double)o.data[i], (double)want[i]);
    sg_image o2 = {0};
    assert_int_equal(sg_image_false_colour(&d, 0.0, &o2, &err), SG_ERR_INVALID_ARG);
    assert_null(o2.data);
    sg_image_free(&o);
    sg_image_free(&d);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_metrics_identical_images_exact),
        cmocka_unit_test(test_metrics_scaled_image_closed_form),
        cmocka_unit_test(test_metrics_offset_image_closed_form),
        cmocka_unit_test(test_metrics_one_pixel_changed),
        cmocka_unit_test(test_metrics_nonfinite_counted_and_excluded),
        cmocka_unit_test(test_metrics_size_mismatch_rejected),
        cmocka_unit_test(test_metrics_all_nonfinite_rejected),
        cmocka_unit_test(test_metrics_black_reference),
        cmocka_unit_test(test_metrics_noise_rel_mse_closed_form),
        cmocka_unit_test(test_metrics_false_colour),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
