/* test_pathtrace.c — energy tests of the reference path tracer: furnaces,
 * a convex sphere, an emitting room, a real HDR map against numerical
 * integration, determinism and the 1/N variance law.
 *
 * Statistical tolerances. An image mean over P pixels, each the mean of N
 * independent paths, has standard error sqrt(sum_i se_i^2) / P with se_i the
 * per-pixel standard error the renderer reports (pixels are independent).
 * A test passes when |mean - expected| <= 4 such errors: a false failure
 * has probability below 1e-4 (normal tail); expected values are exact
 * except where noted. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ref/pathtrace.h"
#include "render/world.h"

static const float PI = 3.14159265358979f;

static sg_ref_desc desc_look(sg_vec3 eye, sg_vec3 look, float fov, int size, int spp, int max_depth)
{
    sg_ref_desc d = {.width = size, .height = size, .spp = spp, .max_depth = max_depth, .seed = 7};
    if (sg_camera_look_at(eye, look, sg_v3(0, 1, 0), fov, 1.0f, &d.camera, NULL) != SG_OK)
        fail_msg("camera");
    return d;
}

/* Image mean of channel c and its standard error (header comment). */
static void image_mean(const sg_ref_result *r, int c, double *mean, double *se)
{
    size_t n = (size_t)r->mean.width * (size_t)r->mean.height;
    double s = 0, v = 0;
    for (size_t i = 0; i < n; ++i) {
        s += r->mean.data[3 * i + c];
        v += (double)r->std_error.data[3 * i + c] * r->std_error.data[3 * i + c];
    }
    *mean = s / (double)n;
    *se = sqrt(v) / (double)n;
}

static void expect_image_mean(const sg_ref_result *r, double expected, const char *what)
{
    for (int c = 0; c < 3; ++c) {
        double m, se;
        image_mean(r, c, &m, &se);
        if (!(fabs(m - expected) <= 4.0 * se + 1e-6 * expected))
            fail_msg("%s: channel %d mean %.6f, expected %.6f (4 standard errors = %.2g)", what, c, m, expected,
                     4.0 * se);
    }
}

/* White furnace: surfaces of albedo 1 in a uniform environment L neither
 * absorb nor emit, so every pixel sees L — through any number of bounces,
 * for a convex sphere and for the sphere standing on a plane alike. */
static void check_furnace(const char *model)
{
    char json[2048];
    snprintf(json, sizeof json,
             "{\"models\":[{\"builtin\":\"sphere\",\"points\":40000,\"transform\":{\"translate\":[0,1,0]},"
             "\"material\":{\"albedo\":[1,1,1],\"use_point_colors\":false},\"surface\":{\"model\":\"%s\"}},"
             "{\"builtin\":\"ground\",\"material\":{\"albedo\":[1,1,1],\"use_point_colors\":false},"
             "\"surface\":{\"model\":\"%s\"}}],"
             "\"envmap\":{\"builtin\":\"uniform\",\"radiance\":[0.7,0.7,0.7]}}",
             model, model);
    sg_world *w = sg_test_world_from_json(json);
    sg_ref_desc d = desc_look(sg_v3(0, 2.0f, 4.0f), sg_v3(0, 0.8f, 0), 40.0f, 24, 16, 1024);
    sg_ref_result r;
    assert_int_equal(sg_ref_render(w, &d, &r, NULL), SG_OK);
    expect_image_mean(&r, 0.7, model);
    sg_ref_result_free(&r);
    sg_world_destroy(w);
}
static void test_ref_white_furnace_mls(void **state) { (void)state; check_furnace("mls"); }
static void test_ref_white_furnace_disk(void **state) { (void)state; check_furnace("disk"); }

/* A convex sphere of albedo rho in a uniform environment L: every ray that
 * leaves it reaches the environment, so it renders rho L. The camera is
 * close enough that the sphere fills the frame. */
static void test_ref_convex_sphere_albedo(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":40000,"
                                  "\"material\":{\"albedo\":[0.5,0.25,0.8],\"use_point_colors\":false}}],"
                                  "\"envmap\":{\"builtin\":\"uniform\",\"radiance\":[2,2,2]}}");
    sg_ref_desc d = desc_look(sg_v3(0, 0, 3.0f), sg_v3(0, 0, 0), 12.0f, 16, 16, 8);
    sg_ref_result r;
    assert_int_equal(sg_ref_render(w, &d, &r, NULL), SG_OK);
    const double expected[3] = {1.0, 0.5, 1.6};
    for (int c = 0; c < 3; ++c) {
        double m, se;
        image_mean(&r, c, &m, &se);
        if (!(fabs(m - expected[c]) <= 4.0 * se + 1e-6))
            fail_msg("channel %d: mean %.6f, expected rho L = %.6f (4 se = %.2g)", c, m, expected[c], 4.0 * se);
    }
    sg_ref_result_free(&r);
    sg_world_destroy(w);
}

/* Inside a closed sphere whose surface has albedo rho and emits Le, the
 * radiance is the whole series Le (1 + rho + rho^2 + ...) = Le / (1 - rho):
 * the test fails if bounces are cut, double-counted or lose energy. */
static void test_ref_emitting_room(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":40000,"
                                  "\"material\":{\"albedo\":[0.5,0.5,0.5],\"use_point_colors\":false,"
                                  "\"emission\":[1,1,1]}}],"
                                  "\"envmap\":{\"builtin\":\"uniform\",\"radiance\":[0,0,0]}}");
    sg_ref_desc d = desc_look(sg_v3(0.1f, -0.2f, 0.3f), sg_v3(1, 0, 0), 60.0f, 16, 32, 1024);
    sg_ref_result r;
    assert_int_equal(sg_ref_render(w, &d, &r, NULL), SG_OK);
    expect_image_mean(&r, 2.0, "emitting room, rho 0.5, Le 1");
    sg_ref_result_free(&r);
    sg_world_destroy(w);
}

/* A diffuse convex sphere under a real HDR map: the radiance at a point of
 * normal n is rho / pi * E(n), E the map's irradiance integrated
 * numerically (sg_envmap_irradiance). Paths through one fixed image point
 * (no pixel jitter), mean of N against that within 4 sigma / sqrt(N),
 * sigma from the same paths. */
static void test_ref_diffuse_sphere_under_hdr_map(void **state)
{
    (void)state;
    const char *map = sg_test_shared_data("envmaps/blender_studiolights/courtyard.exr");
    if (!map)
        skip();
    char json[1024];
    snprintf(json, sizeof json,
             "{\"models\":[{\"builtin\":\"sphere\",\"points\":60000,"
             "\"material\":{\"albedo\":[0.6,0.6,0.6],\"use_point_colors\":false}}],"
             "\"envmap\":{\"path\":\"%s\",\"rotation_deg\":30}}",
             map);
    sg_world *w = sg_test_world_from_json(json);
    sg_ref_desc d = desc_look(sg_v3(0, 0, 3.0f), sg_v3(0, 0, 0), 40.0f, 64, 1, 8);
    d.seed = 3;
    const float pts[3][2] = {{32.0f, 32.0f}, {22.0f, 26.0f}, {40.0f, 41.0f}};
    for (int k = 0; k < 3; ++k) {
        sg_ray ray = sg_camera_ray(&d.camera, pts[k][0], pts[k][1], d.width, d.height);
        sg_world_hit h;
        assert_true(sg_world_intersect(w, &ray, &h, NULL));
        sg_vec3 E = sg_envmap_irradiance(sg_world_envmap(w), h.hit.n);
        const int N = 4000;
        double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
        for (int i = 0; i < N; ++i) {
            sg_vec3 L = sg_ref_path(w, &d, pts[k][0], pts[k][1], (uint64_t)i, NULL);
            double v[3] = {L.x, L.y, L.z};
            for (int c = 0; c < 3; ++c) {
                s[c] += v[c];
                s2[c] += v[c] * v[c];
            }
        }
        double e[3] = {E.x, E.y, E.z};
        for (int c = 0; c < 3; ++c) {
            double mean = s[c] / N, sigma = sqrt(fmax(0.0, s2[c] / N - mean * mean));
            double expected = 0.6 / PI * e[c];
            /* + 1e-3 relative: the quadrature error bound of
             * sg_envmap_irradiance; the hit normal of the sampled sphere
             * is within ~1e-3 rad of the true one. */
            if (!(fabs(mean - expected) <= 4.0 * sigma / sqrt((double)N) + 2e-3 * expected))
                fail_msg("point %d channel %d: path mean %.5f, rho/pi E(n) = %.5f (4 sigma/sqrt(N) = %.2g)", k, c,
                         mean, expected, 4.0 * sigma / sqrt((double)N));
        }
    }
    sg_world_destroy(w);
}

/* pixel_centres: each pixel is exactly the mean of its spp paths through
 * the pixel's centre (same path indices), which the jittered render is not. */
static void test_ref_pixel_centres(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":20000,"
                                  "\"transform\":{\"translate\":[0,1,0]}},{\"builtin\":\"ground\"}],"
                                  "\"envmap\":{\"builtin\":\"sky\"}}");
    sg_ref_desc d = desc_look(sg_v3(0, 2.0f, 4.0f), sg_v3(0, 0.8f, 0), 40.0f, 16, 4, 6);
    d.rr_depth = 3; /* spelt out: sg_ref_path below takes d as it is */
    sg_ref_result jittered, centred;
    assert_int_equal(sg_ref_render(w, &d, &jittered, NULL), SG_OK);
    d.pixel_centres = 1;
    assert_int_equal(sg_ref_render(w, &d, &centred, NULL), SG_OK);
    int differ = 0;
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            uint64_t pixel = (uint64_t)y * 16 + (uint64_t)x;
            double sum = 0;
            for (int s = 0; s < 4; ++s)
                sum += sg_ref_path(w, &d, (float)x + 0.5f, (float)y + 0.5f, pixel * SG_REF_MAX_SPP + (uint64_t)s,
                                   NULL).y;
            if ((float)(sum / 4) != centred.mean.data[3 * pixel + 1])
                fail_msg("pixel (%d, %d): %.9g, the centre paths' mean %.9g", x, y,
                         (double)centred.mean.data[3 * pixel + 1], sum / 4);
            differ += jittered.mean.data[3 * pixel + 1] != centred.mean.data[3 * pixel + 1];
        }
    assert_true(differ > 128);
    sg_ref_result_free(&jittered);
    sg_ref_result_free(&centred);
    sg_world_destroy(w);
}

/* The same seed gives the same bits on 1 and 2 threads. */
static void test_ref_deterministic_across_threads(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":20000,"
                                  "\"transform\":{\"translate\":[0,1,0]}},{\"builtin\":\"ground\"}],"
                                  "\"envmap\":{\"builtin\":\"sky\"}}");
    sg_ref_desc d = desc_look(sg_v3(0, 2.0f, 4.0f), sg_v3(0, 0.8f, 0), 40.0f, 24, 4, 6);
    sg_ref_result a, b;
    d.threads = 1;
    assert_int_equal(sg_ref_render(w, &d, &a, NULL), SG_OK);
    d.threads = 2;
    assert_int_equal(sg_ref_render(w, &d, &b, NULL), SG_OK);
    assert_memory_equal(a.mean.data, b.mean.data, sizeof(float) * 3 * 24 * 24);
    assert_memory_equal(a.std_error.data, b.std_error.data, sizeof(float) * 3 * 24 * 24);
    sg_ref_result_free(&a);
    sg_ref_result_free(&b);
    sg_world_destroy(w);
}

/* The reference traces the exact surface: the level of detail that the
 * ISO and hybrid surfaces give camera rays (by their footprint) leaves its
 * image untouched, bit for bit, while the same camera rays traced alone
 * do meet coarse patches at that threshold (so the check can fail). */
static void test_ref_full_detail_whatever_lod(void **state)
{
    (void)state;
    const char *fmt = "{\"models\":[{\"builtin\":\"sphere\",\"points\":20000,\"transform\":{\"translate\":[0,1,0]},"
                      "\"surface\":{\"model\":\"iso\",\"iso_lod\":%d}},{\"builtin\":\"ground\","
                      "\"surface\":{\"model\":\"hybrid\",\"hybrid_lod\":%d}}],\"envmap\":{\"builtin\":\"sky\"}}";
    char ja[1024], jb[1024];
    snprintf(ja, sizeof ja, fmt, 16, 16);
    snprintf(jb, sizeof jb, fmt, 0, 0);
    sg_world *wa = sg_test_world_from_json(ja), *wb = sg_test_world_from_json(jb);
    sg_ref_desc d = desc_look(sg_v3(0, 2.0f, 4.0f), sg_v3(0, 0.8f, 0), 40.0f, 24, 4, 6);
    int coarse = 0;
    for (int y = 0; y < 24; ++y)
        for (int x = 0; x < 24; ++x) {
            sg_ray r = sg_camera_ray(&d.camera, (float)x + 0.5f, (float)y + 0.5f, 24, 24);
            sg_world_hit ha, hb;
            int a = sg_world_intersect(wa, &r, &ha, NULL), b = sg_world_intersect(wb, &r, &hb, NULL);
            coarse += a != b || (a && ha.hit.t != hb.hit.t);
        }
    if (coarse == 0)
        fail_msg("no camera ray met a coarse patch at lod 16: the test shows nothing");
    sg_ref_result a, b;
    assert_int_equal(sg_ref_render(wa, &d, &a, NULL), SG_OK);
    assert_int_equal(sg_ref_render(wb, &d, &b, NULL), SG_OK);
    assert_memory_equal(a.mean.data, b.mean.data, sizeof(float) * 3 * 24 * 24);
    sg_ref_result_free(&a);
    sg_ref_result_free(&b);
    sg_world_destroy(wa);
    sg_world_destroy(wb);
}

/* The estimator's variance falls as 1/N: the image-averaged squared
 * standard error at N = 4, 16, 64 paths per pixel lies on a log-log line
 * of slope -1 (least squares; +-0.15 covers the scatter of the variance
 * estimates themselves at these N over 576 pixels). */
static void test_ref_variance_falls_as_one_over_n(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":20000,"
                                  "\"transform\":{\"translate\":[0,1,0]}},{\"builtin\":\"ground\"}],"
                                  "\"envmap\":{\"builtin\":\"sky\"}}");
    const int ns[3] = {4, 16, 64};
    double x[3], y[3];
    for (int k = 0; k < 3; ++k) {
        sg_ref_desc d = desc_look(sg_v3(0, 2.0f, 4.0f), sg_v3(0, 0.8f, 0), 40.0f, 24, ns[k], 6);
        sg_ref_result r;
        assert_int_equal(sg_ref_render(w, &d, &r, NULL), SG_OK);
        double v = 0;
        size_t n = 24 * 24;
        for (size_t i = 0; i < 3 * n; ++i)
            v += (double)r.std_error.data[i] * r.std_error.data[i];
        x[k] = log((double)ns[k]);
        y[k] = log(v / (double)(3 * n));
        sg_ref_result_free(&r);
    }
    double mx = (x[0] + x[1] + x[2]) / 3, my = (y[0] + y[1] + y[2]) / 3, sxy = 0, sxx = 0;
    for (int k = 0; k < 3; ++k) {
        sxy += (x[k] - mx) * (y[k] - my);
        sxx += (x[k] - mx) * (x[k] - mx);
    }
    double slope = sxy / sxx;
    if (!(fabs(slope + 1.0) <= 0.15))
        fail_msg("log-log slope of variance against N is %.3f, expected -1", slope);
    sg_world_destroy(w);
}

/* Per-pixel test in the manner of Mitsuba 3's render tests: a short render
 * (64 paths) against an independent long one (1024 paths, another seed) of
 * the sphere on the ground under the sky map. Per pixel and channel
 * z = (a - b) / sqrt(se_a^2 + se_b^2); with 3 P tests at family level
 * alpha = 0.01, Sidak gives each alpha' = 1 - (1 - alpha)^(1 / 3P) and the
 * two-sided threshold z* = Phi^-1(1 - alpha' / 2). Pixels whose paths all
 * returned the same value (se = 0 in both) must agree exactly. Passes when
 * at least 99.75% of the tests pass (heavy-tailed pixels, e.g. a few
 * paths finding a bright spot, may fail the normal approximation). */
static double inverse_normal_tail(double p) /* z with P(Z > z) = p, by bisection */
{
    double lo = 0.0, hi = 40.0;
    for (int i = 0; i < 200; ++i) {
        double mid = 0.5 * (lo + hi);
        if (0.5 * erfc(mid / sqrt(2.0)) > p)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

static void test_ref_per_pixel_z_test(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":20000,"
                                  "\"transform\":{\"translate\":[0,1,0]}},{\"builtin\":\"ground\"}],"
                                  "\"envmap\":{\"builtin\":\"sky\"}}");
    sg_ref_desc d = desc_look(sg_v3(0, 2.0f, 4.0f), sg_v3(0, 0.8f, 0), 40.0f, 24, 64, 8);
    sg_ref_result a, b;
    assert_int_equal(sg_ref_render(w, &d, &a, NULL), SG_OK);
    d.spp = 1024;
    d.seed = 99;
    assert_int_equal(sg_ref_render(w, &d, &b, NULL), SG_OK);
    size_t tests = (size_t)3 * 24 * 24, passed = 0;
    double alpha_each = 1.0 - pow(1.0 - 0.01, 1.0 / (double)tests);
    double zstar = inverse_normal_tail(alpha_each / 2.0);
    for (size_t i = 0; i < tests; ++i) {
        double sa = a.std_error.data[i], sb = b.std_error.data[i];
        double diff = (double)a.mean.data[i] - (double)b.mean.data[i];
        double s = sqrt(sa * sa + sb * sb);
        passed += s > 0.0 ? fabs(diff) / s <= zstar : diff == 0.0;
    }
    if ((double)passed < 0.9975 * (double)tests)
        fail_msg("%zu of %zu pixel-channel z-tests passed (z* = %.3f); need 99.75%%", passed, tests, zstar);
    sg_ref_result_free(&a);
    sg_ref_result_free(&b);
    sg_world_destroy(w);
}

/* Whether z[0..n) looks like n draws of a standard normal variable (the
 * z-score tests below): the Kolmogorov-Smirnov distance to the normal CDF
 * below its 1% critical value 1.628 / sqrt(n), the mean of z^2 within 4
 * standard errors (sqrt(2 / n) each) of 1, and at most max_tail values
 * beyond |z| = 3. Sorts z. Fails the test naming `what` otherwise. */
static void expect_standard_normal(const char *what, double *z, int n, int max_tail)
{
    double z2 = 0.0;
    int tail = 0;
    for (int i = 0; i < n; ++i) {
        z2 += z[i] * z[i];
        tail += fabs(z[i]) > 3.0;
    }
    for (int i = 1; i < n; ++i) /* insertion sort: a few hundred values */
        for (int j = i; j > 0 && z[j - 1] > z[j]; --j) {
            double t = z[j];
            z[j] = z[j - 1];
            z[j - 1] = t;
        }
    double ks = 0.0;
    for (int i = 0; i < n; ++i) {
        double phi = 0.5 * erfc(-z[i] / sqrt(2.0));
        ks = fmax(ks, fmax(phi - (double)i / n, (double)(i + 1) / n - phi));
    }
    double mz2 = z2 / n, crit = 1.628 / sqrt((double)n), band = 4.0 * sqrt(2.0 / n);
    fprintf(stderr, "%s: %d z-scores, KS distance %.4f (bound %.4f), mean z^2 %.3f, %d beyond 3\n", what, n, ks, crit,
            mz2, tail);
    if (!(ks <= crit) || !(fabs(mz2 - 1.0) <= band) || tail > max_tail)
        fail_msg("%s: z-scores are not standard normal: KS %.4f (bound %.4f), mean z^2 %.3f (1 +- %.3f), "
                 "%d beyond |z| = 3 (at most %d)",
                 what, ks, crit, mz2, band, tail, max_tail);
}

/* Honest error bars (issue 12): the built-in room, white (albedo 1) and lit
 * by a uniform sky L = 0.7 through its window, seen from inside. Nothing
 * absorbs, so every surface, inside and out, has radiance exactly 0.7 (a
 * furnace with an opening; paths end by leaving through the window, with
 * probability about 1.2 / 72 per bounce, window over inner area, so about
 * 60 bounces, and max_depth 1024 truncates a fraction e^-17 of them).
 * Two references with other seeds, 128 paths per pixel over 16 x 16
 * pixels (green channel; the sky is grey):
 *  - against the exact value, z = (mean - 0.7) / se per pixel and render
 *    (506 values: pixels that see the sky through the window have se 0);
 *  - against each other, z = (a - b) / sqrt(se_a^2 + se_b^2) (253 values).
 * With 128 paths the sample variances make each z a Student-t variable of
 * 127 or about 250 degrees of freedom, normal to 0.5% in its quantiles,
 * and with |z| > 3 of probability about 0.0035: at most 7 of 506 (Poisson
 * mean 1.8, P(X >= 8) < 1e-3) and 5 of 253 (mean 0.9, P(X >= 6) < 1e-3).
 * Russian roulette with a floor, q = min(0.95, max beta), divides a white
 * path's throughput by 0.95 at every bounce past the third, and the paths
 * that survive 150 bounces carry 2000 times the light: a tail of infinite
 * variance that 128 samples rarely see, so most pixels lie low with a
 * small standard error. Measured with that roulette: 134 of the 506
 * exact-value z-scores beyond 3 (all below -3), KS 0.44, mean z^2 10.0
 * (this test then fails),
 * while the two-reference z-scores still pass (KS 0.065, mean z^2 0.92):
 * both references miss the same tail, which is why the exact value is
 * checked too. */
static void test_ref_z_scores_are_standard_normal(void **state)
{
    (void)state;
    const double L = 0.7;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"room\",\"points\":40000,"
                                          "\"material\":{\"albedo\":[1,1,1],\"use_point_colors\":false}}],"
                                          "\"envmap\":{\"builtin\":\"uniform\",\"radiance\":[0.7,0.7,0.7]}}");
    sg_ref_desc d = desc_look(sg_v3(-1.5f, 1.2f, 1.5f), sg_v3(1.0f, 1.0f, -1.0f), 70.0f, 16, 128, 1024);
    sg_ref_result r[2];
    assert_int_equal(sg_ref_render(w, &d, &r[0], NULL), SG_OK);
    d.seed = 8;
    assert_int_equal(sg_ref_render(w, &d, &r[1], NULL), SG_OK);
    enum { N = 16 * 16 };
    double exact[2 * N], pair[N];
    int ne = 0, np = 0;
    for (int i = 0; i < N; ++i) {
        double m[2], se[2];
        for (int k = 0; k < 2; ++k) {
            m[k] = r[k].mean.data[3 * i + 1];
            se[k] = r[k].std_error.data[3 * i + 1];
            if (se[k] > 0.0)
                exact[ne++] = (m[k] - L) / se[k];
            else if (!(fabs(m[k] - L) < 1e-5)) /* the sky, seen through the window */
                fail_msg("pixel %d: %g with standard error 0, expected %g", i, m[k], L);
        }
        double s = sqrt(se[0] * se[0] + se[1] * se[1]);
        if (s > 0.0)
            pair[np++] = (m[0] - m[1]) / s;
    }
    assert_true(np > N / 2 && ne > N);
    expect_standard_normal("against the exact value", exact, ne, 7);
    expect_standard_normal("two references", pair, np, 5);
    sg_ref_result_free(&r[0]);
    sg_ref_result_free(&r[1]);
    sg_world_destroy(w);
}

/* Progressive passes: 8 + 24 paths over disjoint sample ranges, merged,
 * equal the single 32-path render (same paths), to float rounding of the
 * recovered sums. */
static void test_ref_progressive_merge_equals_single_render(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":20000}],"
                                  "\"envmap\":{\"builtin\":\"sky\"}}");
    sg_ref_desc d = desc_look(sg_v3(0, 0.5f, 3.0f), sg_v3(0, 0, 0), 40.0f, 16, 32, 6);
    sg_ref_result whole, a, b;
    assert_int_equal(sg_ref_render(w, &d, &whole, NULL), SG_OK);
    d.spp = 8;
    assert_int_equal(sg_ref_render(w, &d, &a, NULL), SG_OK);
    d.first_sample = 8;
    d.spp = 24;
    assert_int_equal(sg_ref_render(w, &d, &b, NULL), SG_OK);
    assert_int_equal(sg_ref_result_merge(&a, 8, &b, 24, NULL), SG_OK);
    for (size_t i = 0; i < (size_t)3 * 16 * 16; ++i) {
        float m = whole.mean.data[i], e = whole.std_error.data[i];
        if (!(fabsf(a.mean.data[i] - m) <= 1e-4f * (fabsf(m) + 1e-3f)) ||
            !(fabsf(a.std_error.data[i] - e) <= 1e-3f * (e + 1e-3f)))
            fail_msg("value %zu: merged mean %g se %g, single render mean %g se %g", i, a.mean.data[i],
                     a.std_error.data[i], m, e);
    }
    sg_ref_result_free(&whole);
    sg_ref_result_free(&a);
    sg_ref_result_free(&b);
    sg_world_destroy(w);
}

/* A closed box around [-1, 1]^3 with walls of two layers `thick` apart
 * (the outer layer, facing out, on the box of half-side 1 + thick/2, the
 * inner one, facing in, on 1 - thick/2), g x g points per face and layer
 * at cell centres, as an ascii PLY under the test's temp folder; its
 * path. */
static const char *thin_box_ply(const char *name, int g, float thick)
{
    size_t n = (size_t)6 * 2 * g * g, cap = n * 80 + 256, len = 0;
    char *buf = malloc(cap);
    assert_non_null(buf);
    len += (size_t)snprintf(buf + len, cap - len,
                            "ply\nformat ascii 1.0\nelement vertex %zu\nproperty float x\nproperty float y\n"
                            "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                            "end_header\n",
                            n);
    for (int axis = 0; axis < 3; ++axis)
        for (int sgn = -1; sgn <= 1; sgn += 2)
            for (int layer = 0; layer < 2; ++layer) /* 0 outer, 1 inner */
                for (int i = 0; i < g; ++i)
                    for (int j = 0; j < g; ++j) {
                        /* each layer spans its own box, so the layers close at the edges */
                        float p[3], nn[3] = {0, 0, 0}, half = 1.0f + (layer ? -0.5f : 0.5f) * thick;
                        p[axis] = (float)sgn * half;
                        p[(axis + 1) % 3] = half * (-1.0f + 2.0f * ((float)i + 0.5f) / (float)g);
                        p[(axis + 2) % 3] = half * (-1.0f + 2.0f * ((float)j + 0.5f) / (float)g);
                        nn[axis] = layer ? -(float)sgn : (float)sgn;
                        len += (size_t)snprintf(buf + len, cap - len, "%g %g %g %g %g %g\n", p[0], p[1], p[2], nn[0],
                                                nn[1], nn[2]);
                    }
    const char *path = sg_test_write_file(name, buf, len);
    free(buf);
    return path;
}

/* The spacing of thin_box_ply's points is 2 / g and the kNN radius of the
 * scene file (k = 8) about 1.6 spacings: walls 0.2 spacings thick are an
 * eighth of a splat radius. */
static sg_world *thin_box_world(const char *model, float thick_in_spacings)
{
    const int g = 40;
    char name[64];
    snprintf(name, sizeof name, "thin_box_%s.ply", model);
    const char *ply = thin_box_ply(name, g, thick_in_spacings * 2.0f / (float)g);
    char json[4600];
    snprintf(json, sizeof json,
             "{\"models\":[{\"path\":\"%s\",\"material\":{\"albedo\":[0.8,0.8,0.8],"
             "\"use_point_colors\":false},\"surface\":{\"model\":\"%s\"}}],\"envmap\":{\"builtin\":\"sunsky\"}}",
             ply, model);
    return sg_test_world_from_json(json);
}

/* Light does not pass thin walls: inside a closed box whose walls are an
 * eighth of a splat radius thick, under a sun and sky, paths (camera,
 * bounces, shadow rays to the envmap) stay inside and find (almost) no
 * light. Before issue 12 the MLS walls vanished (the two layers' normals
 * cancelled) and the inside had 0.2 of the outside's mean luminance.
 * What can still get out is not the walls' thinness: a ray leaving an
 * inner wall within 6 degrees of its tangent plane (the seamless self
 * test, SG_SELF_RISE, cannot tell a concave wall from its own bumps there)
 * and, for disks, rays skimming the box's inner edges (as many escape with
 * walls one radius thick). Measured: the inside's mean luminance is 3.5e-5
 * (MLS) and 9e-4 (disks; 7e-4 before issue 12) of the box's mean seen
 * from outside. The bound, 1e-2,
 * tells a thin wall that stops light from one that does not; it is not
 * statistical. */
static void check_thin_box_dark(const char *model)
{
    sg_world *w = thin_box_world(model, 0.2f);
    sg_ref_desc d = desc_look(sg_v3(0.1f, 0.2f, -0.3f), sg_v3(1, 0.3f, 0.5f), 80.0f, 16, 16, 8);
    sg_ref_result in, out;
    assert_int_equal(sg_ref_render(w, &d, &in, NULL), SG_OK);
    /* inside: every camera ray meets the walls from the front */
    assert_true(in.counts.surface_hits >= (uint64_t)16 * 16 * 16);
    assert_int_equal(in.counts.camera_back_hits, 0);
    d = desc_look(sg_v3(2.5f, 1.8f, 3.2f), sg_v3(0, 0, 0), 30.0f, 16, 16, 8);
    assert_int_equal(sg_ref_render(w, &d, &out, NULL), SG_OK);
    double lum_in = 0.2126 * in.mean_radiance[0] + 0.7152 * in.mean_radiance[1] + 0.0722 * in.mean_radiance[2];
    double lum_out = 0.2126 * out.mean_radiance[0] + 0.7152 * out.mean_radiance[1] + 0.0722 * out.mean_radiance[2];
    print_message("%s: closed thin box: mean luminance inside %.3g, outside %.3g (ratio %.2g)\n", model, lum_in,
                  lum_out, lum_in / lum_out);
    if (!(lum_out > 0.0) || !(lum_in <= 1e-2 * lum_out))
        fail_msg("%s: inside a closed thin-walled box the mean luminance is %.3g, outside %.3g", model, lum_in,
                 lum_out);
    sg_ref_result_free(&in);
    sg_ref_result_free(&out);
    sg_world_destroy(w);
}
static void test_ref_thin_box_is_dark_inside_mls(void **state) { (void)state; check_thin_box_dark("mls"); }
static void test_ref_thin_box_is_dark_inside_disk(void **state) { (void)state; check_thin_box_dark("disk"); }

/* The hit counts (pathtrace.h sg_ref_counts): the same box seen from
 * outside, lit by the sky, has no back hit with MLS (before issue 12: 432
 * of 767 hits, rays went through the near walls and met the far walls'
 * inner layer from behind); a camera inside a closed sphere meets it from
 * behind with every camera ray, and those are counted as camera back hits.
 * (Disks: 3 of 908 hits, camera rays that slip between the two faces'
 * disks exactly at the box's convex edges and meet the inner corner;
 * printed, not asserted: a coverage limit of flat disks at sharp edges,
 * not a thin-wall leak.) */
static void test_ref_counts_hits_from_behind(void **state)
{
    (void)state;
    for (int m = 0; m < 2; ++m) {
        sg_world *w = thin_box_world(m ? "disk" : "mls", 0.2f);
        sg_ref_desc d = desc_look(sg_v3(2.5f, 1.8f, 3.2f), sg_v3(0, 0, 0), 50.0f, 16, 8, 8);
        sg_ref_result r;
        assert_int_equal(sg_ref_render(w, &d, &r, NULL), SG_OK);
        print_message("%s: thin box from outside: %llu back hits of %llu surface hits\n", m ? "disk" : "mls",
                      (unsigned long long)r.counts.back_hits, (unsigned long long)r.counts.surface_hits);
        if ((m == 0 && r.counts.back_hits != 0) || r.counts.surface_hits < 16 * 16 * 8 / 4)
            fail_msg("%s: thin box from outside: %llu back hits of %llu surface hits (%llu paths)", m ? "disk" : "mls",
                     (unsigned long long)r.counts.back_hits, (unsigned long long)r.counts.surface_hits,
                     (unsigned long long)r.counts.back_paths);
        sg_ref_result_free(&r);
        sg_world_destroy(w);
    }
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":20000}],"
                                          "\"envmap\":{\"builtin\":\"sky\"}}");
    sg_ref_desc d = desc_look(sg_v3(0.1f, 0, 0), sg_v3(1, 0.2f, 0.3f), 60.0f, 8, 4, 4);
    sg_ref_result r;
    assert_int_equal(sg_ref_render(w, &d, &r, NULL), SG_OK);
    assert_int_equal(r.counts.camera_back_hits, 8 * 8 * 4);
    assert_true(r.counts.back_hits >= r.counts.camera_back_hits);
    assert_int_equal(r.counts.back_paths, 8 * 8 * 4);
    assert_true(r.counts.surface_hits > r.counts.back_hits); /* bounces inside go inwards: not counted */
    /* merged passes add up */
    sg_ref_result b;
    d.first_sample = 4;
    assert_int_equal(sg_ref_render(w, &d, &b, NULL), SG_OK);
    uint64_t hits = r.counts.surface_hits + b.counts.surface_hits;
    assert_int_equal(sg_ref_result_merge(&r, 4, &b, 4, NULL), SG_OK);
    assert_int_equal(r.counts.surface_hits, hits);
    assert_int_equal(r.counts.camera_back_hits, 2 * 8 * 8 * 4);
    sg_ref_result_free(&r);
    sg_ref_result_free(&b);
    sg_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ref_white_furnace_mls),
        cmocka_unit_test(test_ref_white_furnace_disk),
        cmocka_unit_test(test_ref_convex_sphere_albedo),
        cmocka_unit_test(test_ref_emitting_room),
        cmocka_unit_test(test_ref_diffuse_sphere_under_hdr_map),
        cmocka_unit_test(test_ref_pixel_centres),
        cmocka_unit_test(test_ref_deterministic_across_threads),
        cmocka_unit_test(test_ref_full_detail_whatever_lod),
        cmocka_unit_test(test_ref_variance_falls_as_one_over_n),
        cmocka_unit_test(test_ref_per_pixel_z_test),
        cmocka_unit_test(test_ref_z_scores_are_standard_normal),
        cmocka_unit_test(test_ref_progressive_merge_equals_single_render),
        cmocka_unit_test(test_ref_thin_box_is_dark_inside_mls),
        cmocka_unit_test(test_ref_thin_box_is_dark_inside_disk),
        cmocka_unit_test(test_ref_counts_hits_from_behind),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
