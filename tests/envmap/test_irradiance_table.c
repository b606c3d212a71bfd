/* test_irradiance_table.c — the tabulated unshadowed irradiance against
 * sg_envmap_irradiance (the midpoint rule over every texel, error < 1e-3).
 *
 * Bounds: the table quantises each direction of the map to a cell of
 * 180/128 = 1.4 degrees and interpolates between normals h = 2.8 degrees
 * apart. E0 is the map convolved with a clamped cosine, so a smooth map
 * gives errors of about 1e-4. A sun would not be smooth: in a cell its
 * direction moves by up to sin(0.99 deg) = 1.7%, and interpolation across
 * the kink of its clamped cosine errs by up to h/4 = 1.2%, each of the
 * sun's irradiance; that is why texels holding more than 1e-4 of the
 * map's power are summed exactly instead. What stays in the cells holds
 * less than 1e-4 of the power per texel, so 0.5% of the largest E0 bounds
 * every map here, the sun maps included (measured: 1e-4). Without the
 * exact bright texels the 45-degree sun gives 0.009 and fails.
 * (sg_envmap_irradiance itself is exact only for maps of 64 rows or more:
 * the one-texel map is compared with pi L instead.) */
#include "test_support.h"

#include <math.h>
#include <stdio.h>

#include "envmap/analytic.h"
#include "envmap/envmap.h"
#include "envmap/irradiance_table.h"

static sg_envmap *make_map(sg_analytic_type type, int width, float rotation, sg_vec3 sun)
{
    sg_analytic_desc ad = {.type = type, .width = width, .radiance = {0.7f, 0.7f, 0.7f},
                           .sun_dir = sun};
    sg_image img;
    sg_error err = {0};
    if (sg_analytic_make(&ad, &img, &err) != SG_OK)
        fail_msg("%s", err.message);
    sg_envmap_desc d = {.image = &img, .rotation_deg = rotation};
    sg_envmap *m = NULL;
    if (sg_envmap_create(&d, &m, &err) != SG_OK)
        fail_msg("%s", err.message);
    sg_image_free(&img);
    return m;
}

/* Largest error over 200 normals spread over the sphere, relative to the
 * largest E0 seen. */
static double worst_error(const sg_envmap *m, const sg_irradiance_table *t)
{
    double worst = 0.0, top = 0.0;
    double err[200];
    for (int k = 0; k < 200; ++k) {
        /* Fibonacci sphere: even coverage, no normal on the table's grid;
         * and the poles (a ground plane's normal) exactly, k < 2. */
        double y = 1.0 - (k + 0.5) / 100.0, r = sqrt(fmax(0.0, 1.0 - y * y)), phi = k * 2.399963229728653;
        sg_vec3 n = sg_v3((float)(r * cos(phi)), (float)y, (float)(r * sin(phi)));
        if (k < 2)
            n = sg_v3(0.0f, k == 0 ? 1.0f : -1.0f, 0.0f);
        sg_vec3 a = sg_irradiance_table_eval(t, n), b = sg_envmap_irradiance(m, n);
        assert_true(isfinite(a.x) && a.x >= 0.0f && isfinite(a.y) && isfinite(a.z));
        err[k] = fmax(fabs(a.x - b.x), fmax(fabs(a.y - b.y), fabs(a.z - b.z)));
        top = fmax(top, fmax(b.x, fmax(b.y, b.z)));
    }
    for (int k = 0; k < 200; ++k)
        worst = fmax(worst, err[k] / top);
    return worst;
}

static void check(sg_analytic_type type, int width, float rotation, sg_vec3 sun, double bound, const char *what)
{
    sg_envmap *m = make_map(type, width, rotation, sun);
    sg_irradiance_table *t = NULL;
    sg_error err = {0};
    assert_int_equal(sg_irradiance_table_create(m, NULL, &t, &err), SG_OK);
    double e = 0.0;
    if (type == SG_ANALYTIC_UNIFORM) {
        const double pi_L = 3.14159265358979 * 0.7;
        for (int k = 0; k < 200; ++k) {
            sg_vec3 n = sg_v3(sinf(0.7f * k), cosf(0.3f * k), sinf(1.3f * k + 0.2f));
            sg_vec3 a = sg_irradiance_table_eval(t, n);
            e = fmax(e, fmax(fabs(a.x - pi_L), fmax(fabs(a.y - pi_L), fabs(a.z - pi_L))) / pi_L);
        }
    } else {
        e = worst_error(m, t);
    }
    fprintf(stderr, "%s: worst error %.5f of the largest irradiance (bound %.3f)\n", what, e, bound);
    if (!(e <= bound))
        fail_msg("%s: worst relative error %.5f above %.3f", what, e, bound);
    sg_irradiance_table_destroy(t);
    sg_envmap_destroy(m);
}

static void test_irradiance_table_uniform_one_texel(void **state)
{
    (void)state;
    /* A map of 2 x 1 texels: coarser than the table's cells. E0 = pi L. */
    check(SG_ANALYTIC_UNIFORM, 2, 0.0f, sg_v3(0, 1, 0), 0.005, "uniform 2x1");
}

static void test_irradiance_table_sky_rotated(void **state)
{
    (void)state;
    check(SG_ANALYTIC_SKY, 256, 73.0f, sg_v3(0, 1, 0), 0.005, "sky 256x128 rotated 73 deg");
}

static void test_irradiance_table_sun(void **state)
{
    (void)state;
    check(SG_ANALYTIC_SUNSKY, 1024, -20.0f, sg_v3(0.4f, 0.5f, -0.3f), 0.005, "sun at 45 deg, 1024x512");
    /* A low sun (10 degrees up): E0 changes fastest near the +Y pole,
     * where a ground plane's normal looks. */
    check(SG_ANALYTIC_SUNSKY, 1024, 140.0f, sg_v3(0.9f, 0.16f, 0.3f), 0.005, "sun at 10 deg, rotated 140 deg");
}

/* The fast table (octahedral grid of 128 x 128 cells, bilinear) against
 * the exact eval over 20000 Fibonacci normals. Between vertices a smooth
 * E0 errs by about 1e-4 of its largest value (cells of 1.4 degrees, as the
 * main table); across a sun's terminator the bilinear blend of a clamped
 * cosine errs by up to a quarter of the cell's angle, 0.0245 / 4 = 0.6%,
 * of the sun's irradiance: so 1% of the largest E0 bounds every normal,
 * and the mean error stays below 1e-3 of the mean E0 (the terminator's
 * band is 1.4 degrees wide). +Y and -Y are grid vertices, exact to
 * rounding (a ground plane's normal). */
static void check_fast(sg_analytic_type type, float rotation, sg_vec3 sun, const char *what)
{
    sg_envmap *m = make_map(type, 1024, rotation, sun);
    sg_irradiance_table *t = NULL;
    assert_int_equal(sg_irradiance_table_create(m, NULL, &t, NULL), SG_OK);
    double worst = 0.0, top = 0.0, sum_err = 0.0, sum = 0.0;
    enum { N = 20000 };
    for (int k = 0; k < N; ++k) {
        double y = 1.0 - (k + 0.5) / (N / 2.0), r = sqrt(fmax(0.0, 1.0 - y * y)), phi = k * 2.399963229728653;
        sg_vec3 n = sg_v3((float)(r * cos(phi)), (float)y, (float)(r * sin(phi)));
        sg_vec3 a = sg_irradiance_table_eval_fast(t, n), b = sg_irradiance_table_eval(t, n);
        assert_true(isfinite(a.x) && a.x >= 0.0f && isfinite(a.y) && a.y >= 0.0f && isfinite(a.z) && a.z >= 0.0f);
        double e = fmax(fabs(a.x - b.x), fmax(fabs(a.y - b.y), fabs(a.z - b.z)));
        worst = fmax(worst, e);
        top = fmax(top, fmax(b.x, fmax(b.y, b.z)));
        sum_err += fabs(a.y - b.y);
        sum += b.y;
    }
    double pole = 0.0;
    for (int k = 0; k < 2; ++k) {
        sg_vec3 n = sg_v3(0.0f, k ? -1.0f : 1.0f, 0.0f);
        sg_vec3 a = sg_irradiance_table_eval_fast(t, n), b = sg_irradiance_table_eval(t, n);
        pole = fmax(pole, fabs(a.y - b.y) / fmax(b.y, 1e-30));
    }
    fprintf(stderr, "%s, fast table: worst %.5f of the largest E0, mean %.2e of the mean, poles %.1e\n", what,
            worst / top, sum_err / sum, pole);
    if (!(worst <= 0.01 * top) || !(sum_err <= 1e-3 * sum) || !(pole <= 1e-5))
        fail_msg("%s: fast table errs by %.5f of the largest E0 (1%%), %.2e of the mean (1e-3), %.1e at a pole",
                 what, worst / top, sum_err / sum, pole);
    sg_irradiance_table_destroy(t);
    sg_envmap_destroy(m);
}

static void test_irradiance_table_fast(void **state)
{
    (void)state;
    check_fast(SG_ANALYTIC_SKY, 73.0f, sg_v3(0, 1, 0), "sky rotated 73 deg");
    check_fast(SG_ANALYTIC_SUNSKY, -20.0f, sg_v3(0.4f, 0.5f, -0.3f), "sun at 45 deg");
    check_fast(SG_ANALYTIC_SUNSKY, 140.0f, sg_v3(0.9f, 0.16f, 0.3f), "sun at 10 deg");
}

static void test_irradiance_table_bad_sizes(void **state)
{
    (void)state;
    sg_envmap *m = make_map(SG_ANALYTIC_UNIFORM, 8, 0.0f, sg_v3(0, 1, 0));
    sg_irradiance_table *t = NULL;
    sg_error err = {0};
    sg_irradiance_table_desc d = {.rows = 2};
    assert_int_equal(sg_irradiance_table_create(m, &d, &t, &err), SG_ERR_INVALID_ARG);
    assert_null(t);
    d = (sg_irradiance_table_desc){.cell_rows = 5000};
    assert_int_equal(sg_irradiance_table_create(m, &d, &t, &err), SG_ERR_INVALID_ARG);
    sg_envmap_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_irradiance_table_uniform_one_texel),
        cmocka_unit_test(test_irradiance_table_sky_rotated),
        cmocka_unit_test(test_irradiance_table_sun),
        cmocka_unit_test(test_irradiance_table_fast),
        cmocka_unit_test(test_irradiance_table_bad_sizes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
