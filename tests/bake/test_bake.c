/* test_bake.c — energy of the bake + lookup: the white furnace, agreement
 * with the reference path tracer, and determinism. */
#include "test_support.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "bake/bake.h"
#include "ref/pathtrace.h"
#include "render/world.h"

static sg_world *world_from_json(const char *json)
{
    sg_scene_file sf;
    sg_error err = {0};
    if (sg_scene_file_parse(json, strlen(json), "test.json", NULL, &sf, &err) != SG_OK)
        fail_msg("scene: %s", err.message);
    sg_world *w = NULL;
    if (sg_world_create(&sf, &w, &err) != SG_OK)
        fail_msg("world: %s", err.message);
    sg_scene_file_free(&sf);
    return w;
}

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
    sg_world *w = world_from_json(
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
    sg_world *w = world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":30000,"
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

/* The bake is bit-identical for 1 and 2 threads. */
static void test_bake_deterministic_across_threads(void **state)
{
    (void)state;
    sg_world *w = world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":10000,"
                                  "\"transform\":{\"translate\":[0,1,0]}},{\"builtin\":\"ground\"}],"
                                  "\"envmap\":{\"builtin\":\"sky\"}}");
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
    sg_image_free(&a);
    sg_image_free(&c);
    sg_bake_destroy(b1);
    sg_bake_destroy(b2);
    sg_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bake_white_furnace),
        cmocka_unit_test(test_bake_matches_reference),
        cmocka_unit_test(test_bake_deterministic_across_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
