/* test_render.c — the viewer's frame (view/render.h) against the bake's
 * (sg_bake_render), and the quad query it traces with
 * (sg_world_intersect4) against sg_world_intersect. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bake/bake.h"
#include "render/world.h"
#include "view/render.h"

/* Two models (a sphere with point colours in GGX, the ground in Lambert)
 * so that the nearest-model logic and the per-model bakes both count. */
static const char SCENE[] =
    "{\"models\":[{\"builtin\":\"sphere\",\"points\":20000,\"transform\":{\"translate\":[0,1,0]},"
    "\"material\":{\"type\":\"ggx\",\"albedo\":[0.8,0.6,0.4],\"roughness\":0.3,\"specular\":0.04}},"
    "{\"builtin\":\"ground\",\"material\":{\"albedo\":[0.5,0.5,0.5],\"use_point_colors\":false}}],"
    "\"envmap\":{\"builtin\":\"sky\"}}";

static sg_camera camera(sg_vec3 eye, sg_vec3 look, float aspect)
{
    sg_camera c;
    if (sg_camera_look_at(eye, look, sg_v3(0, 1, 0), 45.0f, aspect, &c, NULL) != SG_OK)
        fail_msg("camera");
    return c;
}

/* sg_view_render gives sg_bake_render's image bit for bit, on 1 and 2
 * threads, for views from far, close and grazing. */
static void test_view_render_matches_bake_render(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(SCENE);
    sg_bake_desc bd = {.photons = {.count = 20000, .seed = 3}, .direct_samples = 2};
    sg_bake *b = NULL;
    sg_error err = {0};
    if (sg_bake_create(w, &bd, &b, &err) != SG_OK)
        fail_msg("bake: %s", err.message);
    const sg_vec3 eyes[3] = {sg_v3(0, 3, 6), sg_v3(0.8f, 1.4f, 1.6f), sg_v3(-5, 0.2f, 3)};
    const int W = 67, H = 45; /* not multiples of the tile size */
    for (int v = 0; v < 3; ++v)
        for (int threads = 1; threads <= 2; ++threads) {
            sg_bake_frame_desc fd = {.camera = camera(eyes[v], sg_v3(0, 0.8f, 0), (float)W / (float)H), .width = W,
                                     .height = H, .threads = threads};
            sg_image ref = {0}, img = {0};
            assert_int_equal(sg_bake_render(b, w, &fd, &ref, NULL, &err), SG_OK);
            double sec = -1.0;
            assert_int_equal(sg_view_render(b, w, &fd, &img, &sec, &err), SG_OK);
            assert_true(sec >= 0.0);
            assert_int_equal(img.width, W);
            assert_int_equal(img.height, H);
            size_t n = (size_t)W * H * 3;
            for (size_t i = 0; i < n; ++i)
                if (memcmp(&ref.data[i], &img.data[i], sizeof(float)) != 0)
                    fail_msg("view %d threads %d: pixel (%zu, %zu) channel %zu: bake %.9g, view %.9g", v, threads,
                             i / 3 % W, i / 3 / W, i % 3, ref.data[i], img.data[i]);
            sg_image_free(&ref);
            sg_image_free(&img);
        }
    /* A bake of another world is refused. */
    sg_world *other = sg_test_world_from_json("{\"models\":[{\"builtin\":\"ground\"}],\"envmap\":{\"builtin\":\"sky\"}}");
    sg_bake_frame_desc fd = {.camera = camera(eyes[0], sg_v3(0, 0.8f, 0), 1.0f), .width = 8, .height = 8};
    sg_image img = {0};
    assert_int_equal(sg_view_render(b, other, &fd, &img, NULL, &err), SG_ERR_INVALID_ARG);
    assert_null(img.data);
    sg_world_destroy(other);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* sg_world_intersect4: each ray of a quad gets sg_world_intersect's hit
 * and model, bit for bit, whether the quad's rays share the models'
 * order (most quads) or not (quads across the sphere's silhouette
 * against the ground, wide quads), with partial masks. */
static void test_world_intersect4_matches_single(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(SCENE);
    uint64_t rng = 11;
    int hits[2] = {0, 0};
    for (int i = 0; i < 3000; ++i) {
        sg_vec3 eye = sg_v3(8.0f * sg_test_rand01(&rng) - 4.0f, 0.2f + 4.0f * sg_test_rand01(&rng),
                            8.0f * sg_test_rand01(&rng) - 4.0f);
        sg_vec3 to = sg_v3(2.0f * sg_test_rand01(&rng) - 1.0f, 2.5f * sg_test_rand01(&rng) - 0.5f,
                           2.0f * sg_test_rand01(&rng) - 1.0f);
        sg_camera cam = camera(eye, to, 1.0f);
        int res = i % 4 == 0 ? 16 : 400; /* coarse quads span more */
        int px = (int)(sg_test_rand01(&rng) * (float)(res - 1)), py = (int)(sg_test_rand01(&rng) * (float)(res - 1));
        sg_ray rays[4];
        for (int q = 0; q < 4; ++q)
            rays[q] = sg_camera_ray(&cam, (float)(px + (q & 1)) + 0.5f, (float)(py + (q >> 1)) + 0.5f, res, res);
        unsigned mask = i % 3 ? 15u : (unsigned)(1 + i % 15);
        sg_world_hit h4[4], h1;
        unsigned got = sg_world_intersect4(w, rays, mask, h4, NULL);
        for (int q = 0; q < 4; ++q) {
            if (!(mask >> q & 1u))
                continue;
            int f = sg_world_intersect(w, &rays[q], &h1, NULL);
            assert_int_equal(f, (int)(got >> q & 1u));
            if (!f) {
                assert_int_equal(h4[q].hit.splat, SG_INVALID_ID);
                continue;
            }
            hits[h1.model]++;
            if (h1.model != h4[q].model || memcmp(&h1.hit.t, &h4[q].hit.t, sizeof h1.hit.t) ||
                memcmp(&h1.hit.n, &h4[q].hit.n, sizeof h1.hit.n) || h1.hit.splat != h4[q].hit.splat ||
                h1.hit.leaf != h4[q].hit.leaf)
                fail_msg("quad %d ray %d: model %u / %u, t %.9g / %.9g", i, q, h1.model, h4[q].model, h1.hit.t,
                         h4[q].hit.t);
        }
    }
    print_message("hits: sphere %d, ground %d\n", hits[0], hits[1]);
    assert_true(hits[0] > 100 && hits[1] > 100);
    sg_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_view_render_matches_bake_render),
        cmocka_unit_test(test_world_intersect4_matches_single),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
