/* test_bake.c — energy of the bake + lookup: the white furnace (diffuse,
 * and glossy with the bins), agreement with the reference path tracer
 * (diffuse with sparse sample points; glossy, where the diffuse-only
 * lookup must fail), and determinism across thread counts. */
#include "test_support.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake/bake.h"
#include "bake/glossy.h"
#include "math/rng.h"
#include "ref/pathtrace.h"
#include "render/camera.h"
#include "render/world.h"
#include "surface/scene.h"

static sg_bake *bake(const sg_world *w, size_t photons, int depth, unsigned k)
{
    sg_bake_desc d = {.photons = {.count = photons, .max_depth = depth, .seed = 5}, .gather = {.k = k}};
    sg_bake *b = NULL;
    sg_error err = {0};
    if (sg_bake_create(w, &d, &b, &err) != SG_OK)
        fail_msg("bake: %s", err.message);
    return b;
}

static sg_camera camera(sg_vec3 eye, sg_vec3 look, float fov)
{
    sg_camera c;
    if (sg_camera_look_at(eye, look, sg_v3(0, 1, 0), fov, 1.0f, &c, NULL) != SG_OK)
        fail_msg("camera");
    return c;
}

/* White furnace: albedo-1 surfaces in a uniform environment L have
 * irradiance pi L everywhere, so every looked-up pixel must be L. This
 * catches irradiance stored without its 1/pi (pixels = pi L), envmap
 * energy counted twice, and bounces adding or losing energy.
 *
 * Tolerance: a splat's estimate from k = 128 photons scatters by about
 * 14% (measured on a bare plane: 1/sqrt(k) = 8.8% for the count, more for
 * the Epanechnikov weights and the random k-th-neighbour radius); the
 * frame sees ~100 independent kernels' worth of splats, so its mean has a
 * standard error near 1.5%, and 5% is over 3 of those. A pi error moves
 * the mean by 214%, a double-counted envmap by ~100%. Per-pixel noise is a
 * matter for the benchmark (error against photon count), not this test;
 * here every pixel must only be finite and positive. The view avoids the
 * ground's rim, where a kernel reaching past the edge underestimates. */
static void test_bake_white_furnace(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(
        "{\"models\":[{\"builtin\":\"sphere\",\"points\":30000,\"transform\":{\"translate\":[0,1,0]},"
        "\"material\":{\"albedo\":[1,1,1],\"use_point_colors\":false}},"
        "{\"builtin\":\"ground\",\"material\":{\"albedo\":[1,1,1],\"use_point_colors\":false}}],"
        "\"envmap\":{\"builtin\":\"uniform\",\"radiance\":[0.7,0.7,0.7]}}");
    sg_bake *b = bake(w, 800000, 64, 128);
    sg_bake_frame_desc fd = {.camera = camera(sg_v3(0, 4.0f, 4.0f), sg_v3(0, 0.5f, 0), 40.0f), .width = 48,
                             .height = 48};
    sg_image img;
    assert_int_equal(sg_bake_render(b, w, &fd, &img, NULL, NULL), SG_OK);
    double sum = 0;
    size_t n = (size_t)48 * 48;
    for (size_t i = 0; i < n; ++i) {
        float v = img.data[3 * i + 1];
        if (!(v > 0.0f && isfinite(v)))
            fail_msg("pixel %zu: %g is not a positive radiance", i, v);
        sum += v;
    }
    double mean = sum / (double)n;
    if (!(fabs(mean - 0.7) <= 0.05 * 0.7))
        fail_msg("furnace frame mean %.4f, expected 0.7 within 5%%", mean);
    sg_image_free(&img);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* Bake + lookup against the reference path tracer: a diffuse sphere on a
 * plane under the sky map (direct light, the sphere's shadow, light
 * bouncing between them). The reference's per-pixel mean at 256 paths has
 * a standard error well under 1% on average, so its mean energy is known
 * to better than 0.5%.
 * Bounds, measured (docs/bake.md) and kept with margin: mean-energy ratio
 * within 2%, relative MSE (sum (a - b)^2 / sum b^2) below 0.01. */
static void test_bake_matches_reference(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":30000,"
                                  "\"transform\":{\"translate\":[0,1,0]},\"material\":{\"albedo\":[0.7,0.7,0.7],"
                                  "\"use_point_colors\":false}},{\"builtin\":\"ground\",\"material\":"
                                  "{\"albedo\":[0.5,0.5,0.5],\"use_point_colors\":false}}],"
                                  "\"envmap\":{\"builtin\":\"sky\"}}");
    sg_camera cam = camera(sg_v3(0, 4.0f, 4.0f), sg_v3(0, 0.5f, 0), 40.0f);
    sg_bake *b = bake(w, 1600000, 8, 256);
    sg_bake_frame_desc fd = {.camera = cam, .width = 32, .height = 32};
    sg_image img;
    assert_int_equal(sg_bake_render(b, w, &fd, &img, NULL, NULL), SG_OK);
    /* The reference at pixel centres, like the bake frame: no pixel jitter
     * (sg_ref_path at x + 0.5), so both see the same point per pixel. */
    sg_ref_desc rd = {.camera = cam, .width = 32, .height = 32, .spp = 256, .max_depth = 8, .seed = 11};
    double num = 0, den = 0, sa = 0, sb = 0;
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
            double ref = 0;
            for (int s = 0; s < 256; ++s) {
                sg_vec3 L = sg_ref_path(w, &rd, (float)x + 0.5f, (float)y + 0.5f,
                                        ((uint64_t)(y * 32 + x) << 20) + (uint64_t)s, NULL);
                ref += L.y;
            }
            ref /= 256.0;
            double v = img.data[3 * (y * 32 + x) + 1];
            num += (v - ref) * (v - ref);
            den += ref * ref;
            sa += v;
            sb += ref;
        }
    double ratio = sa / sb, rel_mse = num / den;
    fprintf(stderr, "bake vs reference: mean-energy ratio %.4f, relative MSE %.5f\n", ratio, rel_mse);
    if (!(fabs(ratio - 1.0) <= 0.02) || !(rel_mse <= 0.01))
        fail_msg("mean-energy ratio %.4f (bound 1 +- 0.02), relative MSE %.5f (bound 0.01)", ratio, rel_mse);
    sg_image_free(&img);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* The same scene under a real HDR map (../shared/data's courtyard.exr, a
 * bright sky over a courtyard; skipped when the data is absent), at the
 * issue's bound: mean-energy ratio within 1%. The reference's own noise
 * enters the ratio: its frame sum over 1024 pixels x 256 paths has a
 * relative standard error s, printed and measured here from the per-pixel
 * sample variances (about 0.2%), so the bound is 1% + 3 s: a bake that is
 * 1% off is still caught whenever the reference is that precise.
 * relMSE bound as above (0.01). */
static void test_bake_matches_reference_real_map(void **state)
{
    (void)state;
    const char *map = sg_test_shared_data("envmaps/blender_studiolights/courtyard.exr");
    if (!map)
        skip();
    char json[2048];
    snprintf(json, sizeof json,
             "{\"models\":[{\"builtin\":\"sphere\",\"points\":30000,"
             "\"transform\":{\"translate\":[0,1,0]},\"material\":{\"albedo\":[0.7,0.7,0.7],"
             "\"use_point_colors\":false}},{\"builtin\":\"ground\",\"material\":"
             "{\"albedo\":[0.5,0.5,0.5],\"use_point_colors\":false}}],"
             "\"envmap\":{\"path\":\"%s\",\"rotation_deg\":30}}",
             map);
    sg_world *w = sg_test_world_from_json(json);
    sg_camera cam = camera(sg_v3(0, 4.0f, 4.0f), sg_v3(0, 0.5f, 0), 40.0f);
    sg_bake *b = bake(w, 1600000, 8, 256);
    sg_bake_frame_desc fd = {.camera = cam, .width = 32, .height = 32};
    sg_image img;
    assert_int_equal(sg_bake_render(b, w, &fd, &img, NULL, NULL), SG_OK);
    enum { N = 32, SPP = 256 };
    sg_ref_desc rd = {.camera = cam, .width = N, .height = N, .spp = SPP, .max_depth = 8, .seed = 11};
    double num = 0, den = 0, sa = 0, sb = 0, var_sum = 0;
    for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x) {
            double m1 = 0, m2 = 0;
            for (int s = 0; s < SPP; ++s) {
                double L = sg_ref_path(w, &rd, (float)x + 0.5f, (float)y + 0.5f,
                                       ((uint64_t)(y * N + x) << 20) + (uint64_t)s, NULL).y;
                m1 += L;
                m2 += L * L;
            }
            double ref = m1 / SPP;
            var_sum += (m2 / SPP - ref * ref) / (SPP - 1); /* variance of this pixel's mean */
            double v = img.data[3 * (y * N + x) + 1];
            num += (v - ref) * (v - ref);
            den += ref * ref;
            sa += v;
            sb += ref;
        }
    double ratio = sa / sb, rel_mse = num / den, ref_rel_se = sqrt(var_sum) / sb;
    fprintf(stderr, "real map: mean-energy ratio %.4f (reference's relative standard error %.4f), relative MSE %.5f\n",
            ratio, ref_rel_se, rel_mse);
    double bound = 0.01 + 3.0 * ref_rel_se;
    if (!(fabs(ratio - 1.0) <= bound) || !(rel_mse <= 0.01))
        fail_msg("mean-energy ratio %.4f (bound 1 +- %.4f), relative MSE %.5f (bound 0.01)", ratio, bound, rel_mse);
    sg_image_free(&img);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* The envmap's intensity and rotation reach the bake (two failures users
 * report of bakers). A sphere alone under the sun-and-sky map:
 *  - intensity 2 doubles every splat's irradiance: the map's texels are
 *    scaled at creation, its sampling pdf is not, so every photon flux,
 *    shadow-ray term and table entry doubles exactly (powers of two);
 *    1e-5 relative allows for nothing but float rounding of the sum;
 *  - rotation 180 degrees about +Y turns the light with it: the
 *    irradiance-weighted mean normal sum E_i n_i (pointing at the sun's
 *    side) has its x and z flipped. A bake that ignored the rotation would
 *    give the same vector twice (dot product > 0); the bound asks for the
 *    rotated vector to lie within 10 degrees of the flipped one, the
 *    photons' and shadow rays' noise on 4000 splats being far smaller. */
static void test_bake_envmap_intensity_and_rotation(void **state)
{
    (void)state;
    const char *fmt = "{\"models\":[{\"builtin\":\"sphere\",\"points\":4000,\"material\":{\"albedo\":[0.6,0.6,0.6],"
                      "\"use_point_colors\":false}}],\"envmap\":{\"builtin\":\"sunsky\",\"intensity\":%g,"
                      "\"rotation_deg\":%g}}";
    const double cfg[3][2] = {{1, 0}, {2, 0}, {1, 180}};
    double sum[3] = {0}, vx[3] = {0}, vz[3] = {0};
    for (int c = 0; c < 3; ++c) {
        char json[512];
        snprintf(json, sizeof json, fmt, cfg[c][0], cfg[c][1]);
        sg_world *w = sg_test_world_from_json(json);
        sg_bake *b = bake(w, 100000, 4, 32);
        size_t n;
        sg_bake_light_data(b, 0, &n);
        const sg_sites *ps = sg_scene_sites(sg_world_scene(w, 0));
        for (size_t i = 0; i < n; ++i) {
            sg_vec3 nrm = sg_sites_normal(ps, i);
            double e = sg_bake_splat_irradiance(b, w, 0, i, 0).y;
            sum[c] += e;
            vx[c] += e * nrm.x;
            vz[c] += e * nrm.z;
        }
        sg_bake_destroy(b);
        sg_world_destroy(w);
    }
    double ratio = sum[1] / sum[0];
    fprintf(stderr, "intensity 2 / 1: %.7f; mean normal (x, z): (%.4g, %.4g) turned 180 deg: (%.4g, %.4g)\n", ratio,
            vx[0], vz[0], vx[2], vz[2]);
    if (!(fabs(ratio - 2.0) <= 2e-5))
        fail_msg("intensity 2 scales the bake by %.7f, not 2", ratio);
    double len0 = hypot(vx[0], vz[0]), len2 = hypot(vx[2], vz[2]);
    assert_true(len0 > 0.0 && len2 > 0.0);
    double cosang = -(vx[0] * vx[2] + vz[0] * vz[2]) / (len0 * len2);
    if (!(cosang >= cos(10.0 * 3.14159265358979 / 180.0)))
        fail_msg("rotation 180: the lit side turned by acos(%.4f) from the expected direction", cosang);
}

/* relMSE and mean-energy ratio of a frame (green channel) against the
 * reference at the same pixel centres, 256 paths each. lookup: 1 the
 * bake's lookup, 0 the diffuse-only lookup the bake had before glossy
 * bins (rho / pi * E for every material). */
static void compare_with_reference(const sg_bake *b, const sg_world *w, const sg_camera *cam, int n, int lookup,
                                   double *ratio, double *rel_mse)
{
    sg_ref_desc rd = {.camera = *cam, .width = n, .height = n, .spp = 256, .max_depth = 8, .seed = 11};
    double num = 0, den = 0, sa = 0, sb = 0;
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            double ref = 0;
            for (int s = 0; s < 256; ++s)
                ref += sg_ref_path(w, &rd, (float)x + 0.5f, (float)y + 0.5f,
                                   ((uint64_t)(y * n + x) << 20) + (uint64_t)s, NULL).y;
            ref /= 256.0;
            sg_ray ray = sg_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, n, n);
            sg_world_hit h;
            double v;
            if (!sg_world_intersect(w, &ray, &h, NULL))
                v = sg_envmap_eval(sg_world_envmap(w), ray.dir).y;
            else if (lookup)
                v = sg_bake_lookup(b, w, &h, sg_v3_scale(ray.dir, -1.0f)).y;
            else
                v = sg_world_albedo(w, &h).y * sg_bake_irradiance(b, w, &h, sg_v3_scale(ray.dir, -1.0f)).y / 3.14159265358979;
            num += (v - ref) * (v - ref);
            den += ref * ref;
            sa += v;
            sb += ref;
        }
    *ratio = sa / sb;
    *rel_mse = num / den;
}

/* A glossy sphere (GGX, roughness 0.3, specular 0.3) on the plane under
 * the sun-and-sky map: the sun's highlight is some 15 times brighter than
 * the diffuse light around it, so a lookup without it is far off.
 * Measured (docs/bake.md), photon seeds 5, 6, 7, 8 (which also seed the
 * shadow rays and the bins): mean-energy ratio 0.998, 1.000, 0.997,
 * 0.984, relMSE 0.0059, 0.0090, 0.0067, 0.0060 with the bins (R = 27, 128
 * rays per point); the diffuse-only lookup: relMSE 0.33 (it keeps the
 * energy, ratio 0.99, by counting the whole albedo as diffuse, but puts
 * it in the wrong place). Bounds: energy within 2% as the diffuse test
 * (2.7 times the spread over seeds, sd 0.75%); relMSE 0.02, twice the
 * worst seed and 16 times below the diffuse-only lookup. */
static void test_bake_glossy_matches_reference(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(
        "{\"models\":[{\"builtin\":\"sphere\",\"points\":30000,\"transform\":{\"translate\":[0,1,0]},"
        "\"material\":{\"type\":\"ggx\",\"roughness\":0.3,\"specular\":0.3,\"albedo\":[0.7,0.7,0.7],"
        "\"use_point_colors\":false}},{\"builtin\":\"ground\",\"material\":{\"albedo\":[0.5,0.5,0.5],"
        "\"use_point_colors\":false}}],\"envmap\":{\"builtin\":\"sunsky\"}}");
    sg_camera cam = camera(sg_v3(0, 4.0f, 4.0f), sg_v3(0, 0.5f, 0), 40.0f);
    sg_bake *b = bake(w, 1600000, 8, 256);
    sg_bake_stats st;
    sg_bake_get_stats(b, &st);
    assert_true(st.glossy_points > 0 && st.glossy_points == sg_bake_sample_count(b, 0));
    double ratio, rel_mse, ratio_d, rel_mse_d;
    compare_with_reference(b, w, &cam, 32, 1, &ratio, &rel_mse);
    compare_with_reference(b, w, &cam, 32, 0, &ratio_d, &rel_mse_d);
    fprintf(stderr, "glossy bake vs reference (%zu glossy points, R = %d): ratio %.4f, relMSE %.5f; diffuse-only "
                    "lookup: ratio %.4f, relMSE %.5f\n",
            st.glossy_points, sg_glossy_default_res(sg_world_material(w, 0)), ratio, rel_mse, ratio_d, rel_mse_d);
    if (!(fabs(ratio - 1.0) <= 0.02) || !(rel_mse <= 0.02))
        fail_msg("glossy: mean-energy ratio %.4f (bound 1 +- 0.02), relative MSE %.5f (bound 0.02)", ratio, rel_mse);
    /* The test detects lost highlights: the old lookup must fail it. */
    if (rel_mse_d <= 0.02)
        fail_msg("the diffuse-only lookup passes the glossy bound (relMSE %.5f): the test sees no highlight", rel_mse_d);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* The lobe's directional albedo E_ggx(cos_o) = int f_ggx cos dwi, by
 * visible-normal sampling (bsdf.h: weight G2/G1 <= 1, failures count 0):
 * with n = 16384 samples its standard error is under 0.1%. */
static double ggx_albedo(const sg_material *lobe, float cos_o)
{
    sg_vec3 nrm = sg_v3(0, 0, 1), wo = sg_v3(sqrtf(fmaxf(0.0f, 1.0f - cos_o * cos_o)), 0.0f, cos_o);
    double sum = 0;
    const int n = 16384;
    for (int i = 0; i < n; ++i) {
        sg_vec3 wi, wt;
        float pdf;
        if (sg_bsdf_sample(lobe, lobe->albedo, nrm, wo, 0.0f, sg_rng_float(3, (uint64_t)i, 0, 0),
                           sg_rng_float(3, (uint64_t)i, 0, 1), &wi, &pdf, &wt))
            sum += wt.y;
    }
    return sum / n;
}

/* Glossy white furnace: a sphere whose material is the GGX lobe alone
 * (specular 1) under a uniform L = 0.7 (the convex sphere sees only the
 * sky) reflects S(wo) = L E_ggx(wo).
 * 1. The bins: every sample point's bin b estimates the same value
 *    L E_ggx(wo_b), independently (own random streams), so over the n
 *    points the mean of bin b lies within 5 sigma_b / sqrt(n) of it (sigma_b
 *    the same bins' standard deviation; 5 sigma: a false alarm per bin of
 *    6e-7, below 1e-3 over all R^2 bins), plus 2e-3 relative for the
 *    half-float rounding (2^-11) and the albedo's own sampling error.
 *    (sigma_b is large, near 1 relative at roughness 0.3: 128 rays over
 *    the hemisphere put about one ray in a lobe of this width; a sun is
 *    found by the envmap strategy, a uniform sky is not; docs/bake.md.)
 * 2. The lookup, given exact bins (each set to L E_ggx(wo_b), so no
 *    estimator noise): at pixel centres with cos_o > 0.2 it must give
 *    L E_ggx(cos_o) within 3%: what remains is the bilinear interpolation
 *    of E_ggx between bin centres and the re-parametrisation by the sample
 *    point's normal (up to ~6 degrees from the hit's here), measured at
 *    most 1.7%; the frame's mean within 1% (measured 0.05%). A wrong frame,
 *    an unnormalised blend or a swapped bin index moves pixels by 10% or
 *    more.
 * 3. The lookup of a lobe around a mirror direction (below). */
static void test_bake_glossy_white_furnace_and_lookup(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(
        "{\"models\":[{\"builtin\":\"sphere\",\"points\":20000,\"material\":{\"type\":\"ggx\","
        "\"roughness\":0.3,\"specular\":1,\"albedo\":[1,1,1],\"use_point_colors\":false}}],"
        "\"envmap\":{\"builtin\":\"uniform\",\"radiance\":[0.7,0.7,0.7]}}");
    const float L = 0.7f;
    sg_bake *b = bake(w, 20000, 4, 64);
    const sg_material *mat = sg_world_material(w, 0);
    sg_material lobe = *mat;
    lobe.albedo = sg_v3(0, 0, 0);
    int res;
    size_t n = 0;
    const uint32_t *splat, *nearest;
    const uint16_t *bins;
    sg_bake_glossy_data(b, 0, &res, &n, &splat, &nearest, &bins);
    assert_int_equal(res, sg_glossy_default_res(mat));
    assert_true(n > 100);
    size_t nb = (size_t)res * (size_t)res;
    double *want = malloc(nb * sizeof *want), max_rel_sigma = 0;
    assert_non_null(want);
    for (int j = 0; j < res; ++j)
        for (int i = 0; i < res; ++i) {
            size_t k = (size_t)j * (size_t)res + (size_t)i;
            sg_vec3 wo = sg_glossy_decode(-1.0f + (2.0f * (float)i + 1.0f) / (float)res,
                                          -1.0f + (2.0f * (float)j + 1.0f) / (float)res);
            want[k] = L * ggx_albedo(&lobe, wo.z);
            double s1 = 0, s2 = 0;
            for (size_t p = 0; p < n; ++p) {
                double v = sg_half_to_float(bins[(p * nb + k) * 3 + 1]);
                s1 += v;
                s2 += v * v;
            }
            double mean = s1 / (double)n, sd = sqrt(fmax(0.0, s2 / (double)n - mean * mean));
            if (!(fabs(mean - want[k]) <= 5.0 * sd / sqrt((double)n) + 2e-3 * want[k]))
                fail_msg("bin (%d, %d), cos_o %.3f: mean %.5f over %zu points (sd %.4f), expected L E_ggx = %.5f", i, j,
                         (double)wo.z, mean, n, sd, want[k]);
            if (wo.z > 0.2f && sd / want[k] > max_rel_sigma)
                max_rel_sigma = sd / want[k];
        }
    /* 2: exact bins, then the lookup. */
    uint32_t *ws, *wn;
    uint16_t *wb;
    sg_bake__glossy(b, 0, &ws, &wn, &wb);
    for (size_t p = 0; p < n; ++p)
        for (size_t k = 0; k < nb; ++k)
            for (int c = 0; c < 3; ++c)
                wb[(p * nb + k) * 3 + (size_t)c] = sg_half_from_float((float)want[k]);
    sg_camera cam = camera(sg_v3(0, 0.5f, 4.0f), sg_v3(0, 0, 0), 35.0f);
    double table[65];
    for (int t = 0; t <= 64; ++t)
        table[t] = L * ggx_albedo(&lobe, fmaxf(1e-3f, (float)t / 64.0f));
    double worst = 0, sum = 0;
    int count = 0;
    const int N = 40;
    for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x) {
            sg_ray ray = sg_camera_ray(&cam, (float)x + 0.5f, (float)y + 0.5f, N, N);
            sg_world_hit h;
            if (!sg_world_intersect(w, &ray, &h, NULL))
                continue;
            sg_vec3 wo = sg_v3_scale(ray.dir, -1.0f);
            float c = sg_v3_dot(wo, h.hit.n);
            if (c <= 0.2f)
                continue;
            float ft = c * 64.0f;
            int t0 = (int)ft < 64 ? (int)ft : 63;
            double e = table[t0] + (table[t0 + 1] - table[t0]) * (ft - (float)t0);
            double got = sg_bake_lookup(b, w, &h, wo).y, r = got / e;
            sum += r;
            ++count;
            if (fabs(r - 1.0) > worst)
                worst = fabs(r - 1.0);
            if (!(fabs(r - 1.0) <= 0.03))
                fail_msg("pixel (%d, %d), cos_o %.3f: S = %.5f, L E_ggx = %.5f (ratio %.4f, bound 1 +- 0.03)", x, y,
                         (double)c, got, e, r);
        }
    fprintf(stderr, "glossy furnace: %zu points, R = %d, largest relative bin sigma %.3f; exact bins, lookup over %d "
                    "pixels: mean ratio %.4f, worst deviation %.4f\n",
            n, res, max_rel_sigma, count, sum / count, worst);
    assert_true(count > 200);
    if (!(fabs(sum / count - 1.0) <= 0.01))
        fail_msg("mean lookup ratio %.4f, expected 1 within 1%%", sum / count);
    /* 3. A highlight moves with the normal: every point's bins hold the
     * same smooth lobe around the mirror direction of a fixed light l,
     * g(reflect(wo_b, n_p) . l) = exp((c - 1) / 0.05) (about 13 degrees
     * wide, two bins), so at a hit the lookup must give g(reflect(wo, n_hit)
     * . l) although no point has the hit's normal. Deterministic; bound
     * 0.005 on the relMSE over the pixels, measured 0.0008 (the bilinear
     * interpolation of the lobe and the half floats); reading each point's
     * map at wo itself instead of the reflection-preserving wo' shifts the
     * lobe by up to twice the normals' difference: 0.023. */
    const sg_sites *ps = sg_scene_sites(sg_world_scene(w, 0));
    sg_vec3 l = sg_v3_normalize(sg_v3(0.3f, 0.8f, 0.5f));
    for (size_t p = 0; p < n; ++p) {
        sg_vec3 np = sg_sites_normal(ps, splat[p]), t, bt;
        sg_v3_basis(np, &t, &bt);
        for (int j = 0; j < res; ++j)
            for (int i = 0; i < res; ++i) {
                sg_vec3 v = sg_glossy_decode(-1.0f + (2.0f * (float)i + 1.0f) / (float)res,
                                             -1.0f + (2.0f * (float)j + 1.0f) / (float)res);
                sg_vec3 wo = sg_v3_add(sg_v3_add(sg_v3_scale(t, v.x), sg_v3_scale(bt, v.y)), sg_v3_scale(np, v.z));
                sg_vec3 r = sg_v3_sub(sg_v3_scale(np, 2.0f * sg_v3_dot(wo, np)), wo);
                float g = expf((sg_v3_dot(r, l) - 1.0f) / 0.05f);
                for (int c = 0; c < 3; ++c)
                    wb[(p * nb + (size_t)j * (size_t)res + (size_t)i) * 3 + (size_t)c] = sg_half_from_float(g);
            }
    }
    double num = 0, den = 0;
    for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x) {
            sg_ray ray = sg_camera_ray(&cam, (float)x + 0.5f, (float)y + 0.5f, N, N);
            sg_world_hit h;
            if (!sg_world_intersect(w, &ray, &h, NULL))
                continue;
            sg_vec3 wo = sg_v3_scale(ray.dir, -1.0f);
            if (sg_v3_dot(wo, h.hit.n) <= 0.2f)
                continue;
            sg_vec3 r = sg_v3_sub(sg_v3_scale(h.hit.n, 2.0f * sg_v3_dot(wo, h.hit.n)), wo);
            double e = expf((sg_v3_dot(r, l) - 1.0f) / 0.05f), got = sg_bake_lookup(b, w, &h, wo).y;
            num += (got - e) * (got - e);
            den += e * e;
        }
    fprintf(stderr, "glossy highlight moving with the normal: relMSE %.5f over the sphere's pixels\n", num / den);
    if (!(num / den <= 0.005))
        fail_msg("a lobe around the mirror direction is looked up with relMSE %.5f (bound 0.005)", num / den);
    free(want);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* The bake is bit-identical for 1 and 2 threads (surface model `model`
 * for both models). */
static void deterministic_across_threads(const char *model)
{
    /* A glossy sphere, so that the sample points, their refinement and the
     * glossy bins are all covered. */
    char json[512];
    snprintf(json, sizeof json,
             "{\"models\":[{\"builtin\":\"sphere\",\"points\":10000,\"surface\":{\"model\":\"%s\"},"
             "\"transform\":{\"translate\":[0,1,0]},\"material\":{\"type\":\"ggx\","
             "\"roughness\":0.4,\"specular\":0.3}},{\"builtin\":\"ground\",\"surface\":{\"model\":\"%s\"}}],"
             "\"envmap\":{\"builtin\":\"sunsky\"}}",
             model, model);
    sg_world *w = sg_test_world_from_json(json);
    sg_image a, c;
    sg_bake_frame_desc fd = {.camera = camera(sg_v3(0, 2.5f, 4.0f), sg_v3(0, 0.8f, 0), 40.0f), .width = 32,
                             .height = 32, .threads = 2};
    int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    sg_bake *b1 = bake(w, 50000, 8, 64);
    omp_set_num_threads(2);
    sg_bake *b2 = bake(w, 50000, 8, 64);
    omp_set_num_threads(saved);
    assert_int_equal(sg_bake_render(b1, w, &fd, &a, NULL, NULL), SG_OK);
    assert_int_equal(sg_bake_render(b2, w, &fd, &c, NULL, NULL), SG_OK);
    assert_memory_equal(a.data, c.data, sizeof(float) * 3 * 32 * 32);
    for (uint32_t m = 0; m < 2; ++m) {
        size_t n1, n2;
        const float *e1 = sg_bake_light_data(b1, m, &n1), *e2 = sg_bake_light_data(b2, m, &n2);
        assert_int_equal(n1, n2);
        assert_memory_equal(e1, e2, SG_BAKE_SPLAT_FLOATS * n1 * sizeof(float));
        assert_int_equal(sg_bake_sample_count(b1, m), sg_bake_sample_count(b2, m));
        int r1, r2;
        size_t c1 = 0, c2 = 0;
        const uint32_t *s1, *s2, *q1, *q2;
        const uint16_t *g1, *g2;
        sg_bake_glossy_data(b1, m, &r1, &c1, &s1, &q1, &g1);
        sg_bake_glossy_data(b2, m, &r2, &c2, &s2, &q2, &g2);
        assert_int_equal(r1, r2);
        assert_int_equal(r1 > 0, m == 0);
        if (r1) {
            assert_int_equal(c1, c2);
            assert_memory_equal(s1, s2, c1 * sizeof *s1);
            assert_memory_equal(q1, q2, n1 * sizeof *q1);
            assert_memory_equal(g1, g2, c1 * 3 * (size_t)r1 * (size_t)r1 * sizeof *g1);
        }
    }
    sg_image_free(&a);
    sg_image_free(&c);
    sg_bake_destroy(b1);
    sg_bake_destroy(b2);
    sg_world_destroy(w);
}

static void test_bake_deterministic_across_threads(void **state)
{
    (void)state;
    deterministic_across_threads("mls");
}

/* The hybrid hierarchy (issue 15): its build, traversal, sites and bake. */
static void test_bake_deterministic_across_threads_hybrid(void **state)
{
    (void)state;
    deterministic_across_threads("hybrid");
}


/* The lookup's choice of sites (bake.c keep_facing) in its three cases:
 * every site facing the hit's normal; some away, the rest renormalised;
 * the only weighted sites away, the list taken as it is. The last was a
 * black speck before (the list was compacted before it was judged, which
 * left the kept sites' zero weights and a stale tail): on the sphere's
 * front, which the sky and the ground light everywhere, such a lookup
 * must not be black. To reach the cases on every surface model (a Lambert
 * sphere with emission, a GGX ground with bins, both sides) two hits in
 * three get a normal near their tangent plane, and a third of the
 * hybrid's triangle hits among them one vertex's weight alone (b1 = 1 or
 * b2 = 1). sg_bake_lookup16 gives each of them sg_bake_lookup's bits. */
static void test_bake_lookup_keep_facing(void **state)
{
    (void)state;
    const char *models[4] = {"mls", "disk", "iso", "hybrid"};
    for (int mi = 0; mi < 4; ++mi) {
        char json[640];
        snprintf(json, sizeof json,
                 "{\"models\":[{\"builtin\":\"sphere\",\"points\":3000,\"surface\":{\"model\":\"%s\"},"
                 "\"transform\":{\"translate\":[0,1,0]},\"material\":{\"albedo\":[0.8,0.6,0.4],"
                 "\"emission\":[0.01,0.02,0.03]}},{\"builtin\":\"ground\",\"points\":2000,"
                 "\"surface\":{\"model\":\"%s\"},\"material\":{\"type\":\"ggx\",\"roughness\":0.4,"
                 "\"specular\":0.3}}],\"envmap\":{\"builtin\":\"sky\"}}",
                 models[mi], models[mi]);
        sg_world *w = sg_test_world_from_json(json);
        sg_bake_desc bd = {.photons = {.count = 20000, .seed = 3}, .direct_samples = 2, .glossy_res = 4, .glossy_rays = 16};
        sg_bake *b = NULL;
        sg_error err = {0};
        if (sg_bake_create(w, &bd, &b, &err) != SG_OK)
            fail_msg("%s: bake: %s", models[mi], err.message);
        uint64_t rng = 99;
        size_t lanes = 0, glossy = 0, facing = 0, renorm = 0, as_is = 0;
        const sg_vec3 eyes[3] = {sg_v3(0, 3, 5), sg_v3(1.2f, 1.6f, 1.4f), sg_v3(-4, 0.3f, 2)};
        const int W = 40, H = 40;
        for (int v = 0; v < 3; ++v) {
            sg_camera cam = camera(eyes[v], sg_v3(0, 0.8f, 0), 50.0f);
            for (int y = 0; y < H; y += 4)
                for (int x = 0; x < W; x += 4) {
                    sg_ray rays[16];
                    sg_world_hit h[16];
                    const unsigned mask = sg_camera_block16(&cam, x, y, W, H, rays);
                    const unsigned hit = sg_world_intersect16(w, rays, mask, h, NULL);
                    sg_vec3 wo[16], got[16];
                    for (unsigned m = hit; m; m &= m - 1) {
                        const int r = __builtin_ctz(m);
                        wo[r] = sg_v3_scale(rays[r].dir, -1.0f);
                        const uint64_t u = (uint64_t)(sg_test_rand01(&rng) * 1048576.0f);
                        if (u % 3 != 2) {
                            /* a normal near the surface's tangent plane, so
                             * that its sites straddle it */
                            const sg_vec3 n = h[r].hit.n, d = sg_test_random_dir(&rng);
                            const sg_vec3 t = sg_v3_sub(d, sg_v3_scale(n, sg_v3_dot(d, n)));
                            const float tilt = 0.1f * sg_test_rand01(&rng) - 0.05f;
                            const sg_vec3 m2 = sg_v3_normalize(sg_v3_add(sg_v3_normalize(t), sg_v3_scale(n, tilt)));
                            if (m2.x != 0.0f || m2.y != 0.0f || m2.z != 0.0f)
                                h[r].hit.n = m2;
                        }
                        if (mi == 3 && u % 3 == 1 && h[r].hit.leaf != SG_INVALID_ID) {
                            h[r].hit.b1 = (u >> 8 & 1u) ? 1.0f : 0.0f;
                            h[r].hit.b2 = 1.0f - h[r].hit.b1;
                        }
                    }
                    sg_bake_lookup16(b, w, h, wo, hit, got);
                    for (unsigned m = hit; m; m &= m - 1) {
                        const int r = __builtin_ctz(m);
                        const sg_vec3 want = sg_bake_lookup(b, w, &h[r], wo[r]);
                        if (memcmp(&want, &got[r], sizeof want) != 0)
                            fail_msg("%s, view %d, block (%d, %d), ray %d (model %u): lookup %.9g %.9g %.9g, "
                                     "lookup16 %.9g %.9g %.9g",
                                     models[mi], v, x, y, r, h[r].model, (double)want.x, (double)want.y,
                                     (double)want.z, (double)got[r].x, (double)got[r].y, (double)got[r].z);
                        ++lanes;
                        glossy += h[r].model == 1;
                        /* which of keep_facing's cases this was */
                        const sg_scene *sc = sg_world_scene(w, h[r].model);
                        const sg_sites *ps = sg_scene_sites(sc);
                        uint32_t ids[32];
                        float wts[32];
                        const int n = sg_scene_hit_sites(sc, &h[r].hit, ids, wts, 32);
                        float kept = 0.0f;
                        int away = 0;
                        for (int j = 0; j < n; ++j) {
                            const sg_vec3 sn = sg_v3(ps->nx[ids[j]], ps->ny[ids[j]], ps->nz[ids[j]]);
                            if (sg_v3_dot(sn, h[r].hit.n) < 0.0f)
                                ++away;
                            else
                                kept += wts[j];
                        }
                        if (!away) {
                            ++facing;
                        } else if (kept > 0.0f) {
                            ++renorm;
                        } else if (away < n) {
                            ++as_is;
                            /* 0.1: above the sphere's emission alone
                             * (0.01 + 0.02 + 0.03), which is what the old
                             * rule's zero weights returned */
                            if (h[r].model == 0 && sg_v3_dot(wo[r], h[r].hit.n) >= 0.0f &&
                                !(got[r].x + got[r].y + got[r].z > 0.1f))
                                fail_msg("%s, view %d, block (%d, %d), ray %d: the only weighted sites face away "
                                         "and the lookup is black (%.9g %.9g %.9g)",
                                         models[mi], v, x, y, r, (double)got[r].x, (double)got[r].y,
                                         (double)got[r].z);
                        }
                    }
                }
        }
        print_message("%s: %zu lookups (%zu glossy): all facing %zu, renormalised %zu, taken as they are %zu\n",
                      models[mi], lanes, glossy, facing, renorm, as_is);
        assert_true(glossy > 100 && lanes - glossy > 100 && facing > 100 && renorm > 100);
        if (mi == 3) /* zero weights: a vertex's alone */
            assert_true(as_is > 5);
        sg_bake_destroy(b);
        sg_world_destroy(w);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bake_white_furnace),
        cmocka_unit_test(test_bake_matches_reference),
        cmocka_unit_test(test_bake_matches_reference_real_map),
        cmocka_unit_test(test_bake_envmap_intensity_and_rotation),
        cmocka_unit_test(test_bake_glossy_matches_reference),
        cmocka_unit_test(test_bake_glossy_white_furnace_and_lookup),
        cmocka_unit_test(test_bake_deterministic_across_threads),
        cmocka_unit_test(test_bake_deterministic_across_threads_hybrid),
        cmocka_unit_test(test_bake_lookup_keep_facing),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
