/* test_corner_aa.c — corner supersampling (render/corner_aa.h) on images
 * whose exact pixel values are known.
 *
 *  1. corner_aa::edge_coverage      half-planes at 200 angles and offsets:
 *                                    every pixel's coverage within
 *                                    1/(2N) + 1/(4N^2) of its exact area
 *                                    (corner_aa.c derives it), colour the
 *                                    same mix; pixels the edge misses exact.
 *  2. corner_aa::affine_is_centre    an affine colour field: no pixel cut,
 *                                    (w+1)(h+1) samples, every pixel its
 *                                    centre's value; cut everywhere (negative
 *                                    threshold), the same.
 *  3. corner_aa::threads_identical   1 and 2 threads: same bits, same counts.
 *  4. corner_aa::depth_zero_is_ye    depth 0: the four corners' mean, Ye's
 *                                    scheme, one sample a corner.
 *  5. corner_aa::bad_desc            each bad field: INVALID_ARG naming it.
 */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "render/corner_aa.h"

typedef struct half_plane {
    double a, b, c; /* covered where a x + b y < c */
} half_plane;

static const float FG[3] = {0.8f, 0.5f, 0.2f}, BG[3] = {0.1f, 0.2f, 0.9f};

static void sample_half_plane(void *ctx, float x, float y, float rgb[3], float *coverage)
{
    const half_plane *h = ctx;
    int in = h->a * x + h->b * y < h->c;
    memcpy(rgb, in ? FG : BG, sizeof FG);
    *coverage = (float)in;
}

/* Area of the unit square at (i, j) where a x + b y < c. */
static double exact_area(const half_plane *h, int i, int j) { return sg_test_half_plane_area(h->a, h->b, h->c, i, j); }

static void test_edge_coverage(void **state)
{
    (void)state;
    const int W = 24, H = 20;
    uint64_t rng = 7;
    for (int depth = 2; depth <= 3; ++depth) {
        const double N = (double)(1 << depth), bound = 1.0 / (2.0 * N) + 1.0 / (4.0 * N * N);
        double worst = 0.0, sum = 0.0, sum_plain = 0.0;
        long crossed = 0;
        for (int e = 0; e < 100; ++e) {
            /* A line through a random point of the image at a random angle. */
            double ang = 2.0 * 3.14159265358979 * sg_test_rand01(&rng);
            double x0 = 2.0 + (W - 4) * sg_test_rand01(&rng), y0 = 2.0 + (H - 4) * sg_test_rand01(&rng);
            half_plane hp = {cos(ang), sin(ang), 0.0};
            hp.c = hp.a * x0 + hp.b * y0;
            sg_corner_aa_desc d = {.width = W, .height = H, .max_depth = depth, .threads = 2};
            sg_image img = {0};
            sg_error err = {0};
            assert_int_equal(sg_corner_aa_render(&d, sample_half_plane, &hp, &img, NULL, &err), SG_OK);
            for (int j = 0; j < H; ++j)
                for (int i = 0; i < W; ++i) {
                    const size_t at = (size_t)j * W + (size_t)i;
                    const double area = exact_area(&hp, i, j), cov = img.alpha[at];
                    if (area == 0.0 || area == 1.0) {
                        if (cov != area)
                            fail_msg("depth %d line %d: pixel (%d, %d) off the edge: coverage %.9g, area %g", depth,
                                     e, i, j, cov, area);
                    } else {
                        crossed++;
                        double c = hp.a * (i + 0.5) + hp.b * (j + 0.5) < hp.c; /* one ray at the centre */
                        sum_plain += fabs(c - area);
                        sum += fabs(cov - area);
                        worst = fabs(cov - area) > worst ? fabs(cov - area) : worst;
                        /* + 1e-6: the float sums of at most 25 samples */
                        if (fabs(cov - area) > bound + 1e-6)
                            fail_msg("depth %d line %d (%.6f x + %.6f y < %.6f): pixel (%d, %d): coverage %.6f, exact "
                                     "area %.6f, off by %.6f > bound %.6f",
                                     depth, e, hp.a, hp.b, hp.c, i, j, cov, area, fabs(cov - area), bound);
                    }
                    /* The colour is the same mix of the two colours. */
                    for (int k = 0; k < 3; ++k) {
                        double want = BG[k] + (FG[k] - BG[k]) * cov;
                        if (fabs(img.data[3 * at + (size_t)k] - want) > 1e-6)
                            fail_msg("depth %d line %d pixel (%d, %d) channel %d: %.9g, coverage says %.9g", depth, e,
                                     i, j, k, img.data[3 * at + (size_t)k], want);
                    }
                }
            sg_image_free(&img);
        }
        print_message("depth %d: %ld edge pixels, coverage error mean %.4f worst %.4f (bound %.4f); one ray at the "
                      "centre: mean %.4f\n",
                      depth, crossed, sum / (double)crossed, worst, bound, sum_plain / (double)crossed);
        assert_true(crossed > 1000);
        /* The mean is well inside the bound and far below one ray's. */
        assert_true(sum / (double)crossed < 0.5 * bound && sum < 0.25 * sum_plain);
    }
}

static void sample_affine(void *ctx, float x, float y, float rgb[3], float *coverage)
{
    (void)ctx;
    rgb[0] = 0.3f + 0.01f * x;
    rgb[1] = 0.5f + 0.003f * y;
    rgb[2] = 0.2f + 0.001f * (x + y);
    *coverage = 1.0f;
}

static void test_affine_is_centre(void **state)
{
    (void)state;
    const int W = 33, H = 17;
    for (int cut = 0; cut <= 1; ++cut) {
        sg_corner_aa_desc d = {.width = W, .height = H, .threshold = cut ? -1.0f : 0.0f, .threads = 2};
        sg_image img = {0};
        sg_corner_aa_stats st;
        sg_error err = {0};
        assert_int_equal(sg_corner_aa_render(&d, sample_affine, NULL, &img, &st, &err), SG_OK);
        /* Default depth 2: a cut pixel has 25 samples, 4 of them corners. */
        uint64_t corners = (uint64_t)(W + 1) * (H + 1), want = corners + (cut ? 21u * W * H : 0u);
        if (st.samples != want || st.refined != (cut ? (uint64_t)W * H : 0u))
            fail_msg("cut %d: %llu samples, %llu refined; want %llu samples", cut, (unsigned long long)st.samples,
                     (unsigned long long)st.refined, (unsigned long long)want);
        for (int j = 0; j < H; ++j)
            for (int i = 0; i < W; ++i) {
                float c[3], cov;
                sample_affine(NULL, (float)i + 0.5f, (float)j + 0.5f, c, &cov);
                const float *p = img.data + 3 * ((size_t)j * W + (size_t)i);
                /* The mean of samples of an affine field is its value at
                 * their centroid; float sums of <= 25 values of size < 1
                 * round by a few ulp: 1e-6 relative is 8 ulp. */
                for (int k = 0; k < 3; ++k)
                    if (fabsf(p[k] - c[k]) > 1e-6f * c[k])
                        fail_msg("cut %d pixel (%d, %d) channel %d: %.9g, centre %.9g", cut, i, j, k, p[k], c[k]);
                assert_true(img.alpha[(size_t)j * W + (size_t)i] == 1.0f);
            }
        sg_image_free(&img);
    }
}

/* A disc and a ramp: curved edges and smooth shading, so that pixels are
 * cut to every depth. */
static void sample_disc(void *ctx, float x, float y, float rgb[3], float *coverage)
{
    (void)ctx;
    float dx = x - 20.3f, dy = y - 14.7f;
    int in = dx * dx + dy * dy < 121.0f;
    rgb[0] = in ? 0.9f : 0.05f * x;
    rgb[1] = in ? 0.02f * y : 0.3f;
    rgb[2] = in ? 0.4f + 0.3f * sinf(x) : 0.7f;
    *coverage = (float)in;
}

static void test_threads_identical(void **state)
{
    (void)state;
    sg_image a = {0}, b = {0};
    sg_corner_aa_stats sa, sb;
    sg_error err = {0};
    sg_corner_aa_desc d = {.width = 41, .height = 29, .max_depth = 3, .threads = 1};
    assert_int_equal(sg_corner_aa_render(&d, sample_disc, NULL, &a, &sa, &err), SG_OK);
    d.threads = 2;
    assert_int_equal(sg_corner_aa_render(&d, sample_disc, NULL, &b, &sb, &err), SG_OK);
    print_message("disc: %llu samples, %llu of %d pixels refined\n", (unsigned long long)sa.samples,
                  (unsigned long long)sa.refined, 41 * 29);
    assert_true(sa.refined > 50);
    assert_true(sa.samples == sb.samples && sa.refined == sb.refined);
    assert_memory_equal(a.data, b.data, sizeof(float) * 3 * 41 * 29);
    assert_memory_equal(a.alpha, b.alpha, sizeof(float) * 41 * 29);
    sg_image_free(&a);
    sg_image_free(&b);
}

static void test_depth_zero_is_ye(void **state)
{
    (void)state;
    const int W = 12, H = 9;
    half_plane hp = {0.6, 0.8, 7.3};
    sg_corner_aa_desc d = {.width = W, .height = H, .max_depth = -1, .threads = 2};
    sg_image img = {0};
    sg_corner_aa_stats st;
    sg_error err = {0};
    assert_int_equal(sg_corner_aa_render(&d, sample_half_plane, &hp, &img, &st, &err), SG_OK);
    assert_true(st.samples == (uint64_t)(W + 1) * (H + 1) && st.refined == 0);
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            int k = 0;
            for (int q = 0; q < 4; ++q)
                k += hp.a * (i + (q & 1)) + hp.b * (j + (q >> 1)) < hp.c;
            if (img.alpha[(size_t)j * W + (size_t)i] != 0.25f * (float)k)
                fail_msg("pixel (%d, %d): coverage %g, corners inside %d", i, j, img.alpha[(size_t)j * W + (size_t)i],
                         k);
        }
    sg_image_free(&img);
}

static void test_bad_desc(void **state)
{
    (void)state;
    struct {
        sg_corner_aa_desc d;
        const char *says;
    } cases[] = {
        {{.width = 0, .height = 4}, "image size 0 x 4"},
        {{.width = 4, .height = SG_IMAGE_MAX_DIM + 1}, "is not in [1, 65536]"},
        {{.width = 4, .height = 4, .max_depth = 7}, "depth 7"},
        {{.width = 4, .height = 4, .max_depth = -2}, "depth -2"},
        {{.width = 4, .height = 4, .threshold = NAN}, "threshold is NaN"},
        {{.width = 4, .height = 4, .threads = -1}, "threads -1"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        sg_image img = {0};
        sg_error err = {0};
        assert_int_equal(sg_corner_aa_render(&cases[i].d, sample_affine, NULL, &img, NULL, &err), SG_ERR_INVALID_ARG);
        if (!strstr(err.message, cases[i].says))
            fail_msg("case %zu: message '%s' does not say '%s'", i, err.message, cases[i].says);
        assert_null(img.data);
    }
    sg_corner_aa_desc d = {.width = 4, .height = 4};
    sg_image img = {0};
    sg_error err = {0};
    assert_int_equal(sg_corner_aa_render(&d, NULL, NULL, &img, NULL, &err), SG_ERR_INVALID_ARG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_edge_coverage),    cmocka_unit_test(test_affine_is_centre),
        cmocka_unit_test(test_threads_identical), cmocka_unit_test(test_depth_zero_is_ye),
        cmocka_unit_test(test_bad_desc),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
