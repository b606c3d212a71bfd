/* test_render.c — the viewer's frame (view/render.h) against the bake's
 * (sg_bake_render), the quad and 4x4 block queries it traces with
 * (sg_world_intersect4, sg_world_intersect16)
 * against sg_world_intersect, and its anti-aliased still frame
 * (sg_view_render_aa: off is sg_view_render; corner supersampling gives a
 * plane's silhouette its exact coverage within the derived bound, flat
 * pixels their value, 1 and 2 threads the same bits). */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bake/bake.h"
#include "render/corner_aa.h"
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

/* A bake of w with desc bd, or the test fails with its message. */
static sg_bake *bake_of(const sg_world *w, const sg_bake_desc *bd)
{
    sg_bake *b = NULL;
    sg_error err = {0};
    if (sg_bake_create(w, bd, &b, &err) != SG_OK)
        fail_msg("bake: %s", err.message);
    return b;
}

/* sg_view_render gives sg_bake_render's image bit for bit, on 1 and 2
 * threads, for views from far, close and grazing. */
static void test_view_render_matches_bake_render(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(SCENE);
    sg_bake_desc bd = {.photons = {.count = 20000, .seed = 3}, .direct_samples = 2};
    sg_bake *b = bake_of(w, &bd);
    sg_error err = {0};
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

/* sg_world_intersect16: each ray of a 4 x 4 block gets
 * sg_world_intersect's hit and model, bit for bit, whether the block's
 * rays share the models' order or split into groups (blocks across the
 * sphere's silhouette against the ground, wide blocks), with partial
 * masks; rays outside the mask are not written. */
static void test_world_intersect16_matches_single(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(SCENE);
    uint64_t rng = 13;
    int hits[2] = {0, 0}, split = 0;
    for (int i = 0; i < 1500; ++i) {
        sg_vec3 eye = sg_v3(8.0f * sg_test_rand01(&rng) - 4.0f, 0.2f + 4.0f * sg_test_rand01(&rng),
                            8.0f * sg_test_rand01(&rng) - 4.0f);
        sg_vec3 to = sg_v3(2.0f * sg_test_rand01(&rng) - 1.0f, 2.5f * sg_test_rand01(&rng) - 0.5f,
                           2.0f * sg_test_rand01(&rng) - 1.0f);
        sg_camera cam = camera(eye, to, 1.0f);
        int res = i % 4 == 0 ? 16 : 400; /* coarse blocks span more */
        int px = (int)(sg_test_rand01(&rng) * (float)(res - 3)), py = (int)(sg_test_rand01(&rng) * (float)(res - 3));
        sg_ray rays[16];
        for (int q = 0; q < 16; ++q)
            rays[q] = sg_camera_ray(&cam, (float)(px + (q & 3)) + 0.5f, (float)(py + (q >> 2)) + 0.5f, res, res);
        unsigned mask = i % 3 ? 0xFFFFu : 1u + (unsigned)(65534.0f * sg_test_rand01(&rng));
        sg_world_hit h16[16], h1;
        for (int q = 0; q < 16; ++q)
            h16[q].model = 77u; /* must stay for rays outside mask */
        unsigned got = sg_world_intersect16(w, rays, mask, h16, NULL);
        int models = 0;
        for (int q = 0; q < 16; ++q) {
            if (!(mask >> q & 1u)) {
                assert_int_equal(h16[q].model, 77u);
                assert_false(got >> q & 1u);
                continue;
            }
            int f = sg_world_intersect(w, &rays[q], &h1, NULL);
            assert_int_equal(f, (int)(got >> q & 1u));
            if (!f) {
                assert_int_equal(h16[q].hit.splat, SG_INVALID_ID);
                continue;
            }
            hits[h1.model]++;
            models |= 1 << h1.model;
            if (h1.model != h16[q].model || memcmp(&h1.hit.t, &h16[q].hit.t, sizeof h1.hit.t) ||
                memcmp(&h1.hit.n, &h16[q].hit.n, sizeof h1.hit.n) || h1.hit.splat != h16[q].hit.splat ||
                h1.hit.leaf != h16[q].hit.leaf)
                fail_msg("block %d ray %d: model %u / %u, t %.9g / %.9g", i, q, h1.model, h16[q].model, h1.hit.t,
                         h16[q].hit.t);
        }
        split += models == 3;
    }
    print_message("hits: sphere %d, ground %d; %d blocks hit both\n", hits[0], hits[1], split);
    assert_true(hits[0] > 100 && hits[1] > 100 && split > 20);
    sg_world_destroy(w);
}

/* Anti-aliasing off (NULL, or mode none) is sg_view_render bit for bit,
 * alpha included; a bad mode is refused. */
static void test_view_render_aa_off_is_plain(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(SCENE);
    sg_bake_desc bd = {.photons = {.count = 20000, .seed = 3}, .direct_samples = 2};
    sg_bake *b = bake_of(w, &bd);
    sg_error err = {0};
    const int W = 37, H = 29;
    sg_bake_frame_desc fd = {.camera = camera(sg_v3(0.8f, 1.4f, 1.6f), sg_v3(0, 0.8f, 0), (float)W / (float)H),
                             .width = W, .height = H, .threads = 2};
    sg_image ref = {0};
    assert_int_equal(sg_view_render(b, w, &fd, &ref, NULL, &err), SG_OK);
    const sg_view_aa none = {.mode = SG_VIEW_AA_NONE, .threshold = 0.3f, .max_depth = 3};
    for (int k = 0; k < 2; ++k) {
        sg_image img = {0};
        sg_corner_aa_stats st;
        assert_int_equal(sg_view_render_aa(b, w, &fd, k ? &none : NULL, &img, &st, &err), SG_OK);
        assert_memory_equal(ref.data, img.data, sizeof(float) * 3 * W * H);
        assert_memory_equal(ref.alpha, img.alpha, sizeof(float) * W * H);
        assert_true(st.samples == (uint64_t)W * H);
        sg_image_free(&img);
    }
    sg_view_aa bad = {.mode = (sg_view_aa_mode)7};
    sg_image img = {0};
    assert_int_equal(sg_view_render_aa(b, w, &fd, &bad, &img, NULL, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "mode 7"));
    assert_null(img.data);
    sg_image_free(&ref);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* Pixel coordinates (camera.h) of world point p. */
static void project(const sg_camera *c, int width, int height, sg_vec3 p, double *px, double *py)
{
    double dx = p.x - c->eye.x, dy = p.y - c->eye.y, dz = p.z - c->eye.z;
    double f = dx * c->forward.x + dy * c->forward.y + dz * c->forward.z;
    double r = dx * c->right.x + dy * c->right.y + dz * c->right.z;
    double u = dx * c->up.x + dy * c->up.y + dz * c->up.z;
    *px = (r / f / ((double)c->tan_half_fov * c->aspect) + 1.0) * 0.5 * width;
    *py = (1.0 - u / f / (double)c->tan_half_fov) * 0.5 * height;
}

/* The far edge of a hybrid ground (exact triangles, so a straight
 * silhouette) against a uniform sky, the camera rolled so the edge runs
 * slanted. Bounds:
 *  - coverage of each pixel the edge crosses within 1/(2N) + 1/(4N^2) of
 *    its exact area (corner_aa.c), N = 2^depth, plus 1e-3 for the float
 *    camera rays (their directions are rounded to ~1e-7 relative, which
 *    moves the edge by < 1e-4 pixel here);
 *  - the sky is a constant, so a sky pixel's corners are equal and its
 *    mean is the value bit for bit; a ground pixel away from the edge
 *    reads the bake's lookup, which in this furnace (a lone plane under
 *    a uniform sky) is albedo x sky within 1% at every pixel (the bound
 *    bake::test_transport asserts): an uncut pixel (the mean of 4
 *    lookups) and the plain pixel (one) differ by at most 2% of it;
 *  - 1 and 2 threads: the same bits. */
static void test_view_render_aa_edge(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(
        "{\"models\":[{\"builtin\":\"ground\",\"points\":400,\"material\":{\"albedo\":[0.5,0.5,0.5],"
        "\"use_point_colors\":false},\"surface\":{\"model\":\"hybrid\"}}],"
        "\"envmap\":{\"builtin\":\"uniform\",\"radiance\":[0.7,0.7,0.7]}}");
    sg_bake_desc bd = {.photons = {.seed = 5}};
    sg_bake *b = bake_of(w, &bd);
    sg_error err = {0};
    const sg_aabb box = sg_world_bounds(w);
    const int W = 64, H = 48;
    sg_camera cam;
    if (sg_camera_look_at(sg_v3(0, 4, 0.5f * box.hi.z), sg_v3(0, 0, box.lo.z), sg_v3(0.3f, 1, 0), 45.0f,
                          (float)W / (float)H, &cam, NULL) != SG_OK)
        fail_msg("camera");
    /* The edge z = lo.z, y = 0 as a line a x + b y = c in pixels; covered
     * on the side of the ground's centre. */
    double x0, y0, x1, y1, xc, yc;
    project(&cam, W, H, sg_v3(box.lo.x, 0, box.lo.z), &x0, &y0);
    project(&cam, W, H, sg_v3(box.hi.x, 0, box.lo.z), &x1, &y1);
    project(&cam, W, H, sg_v3(0, 0, 0.5f * (box.lo.z + box.hi.z)), &xc, &yc);
    double a = y1 - y0, bb = x0 - x1, c = a * x0 + bb * y0;
    if (a * xc + bb * yc > c) {
        a = -a, bb = -bb, c = -c;
    }
    sg_bake_frame_desc fd = {.camera = cam, .width = W, .height = H, .threads = 1};
    sg_image plain = {0}, aa1 = {0}, aa2 = {0};
    assert_int_equal(sg_view_render(b, w, &fd, &plain, NULL, &err), SG_OK);
    const sg_view_aa aa = {.mode = SG_VIEW_AA_CORNER};
    sg_corner_aa_stats s1, s2;
    assert_int_equal(sg_view_render_aa(b, w, &fd, &aa, &aa1, &s1, &err), SG_OK);
    fd.threads = 2;
    assert_int_equal(sg_view_render_aa(b, w, &fd, &aa, &aa2, &s2, &err), SG_OK);
    assert_memory_equal(aa1.data, aa2.data, sizeof(float) * 3 * W * H);
    assert_memory_equal(aa1.alpha, aa2.alpha, sizeof(float) * W * H);
    assert_true(s1.samples == s2.samples && s1.refined == s2.refined);
    const double N = 1 << SG_CORNER_AA_DEPTH, bound = 1.0 / (2.0 * N) + 1.0 / (4.0 * N * N) + 1e-3;
    const double ground = 0.35, flat = 0.02 * ground;
    int edge = 0, sky = 0, inside = 0;
    double worst = 0.0, worst_flat = 0.0, sum = 0.0, sum_plain = 0.0;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            const size_t at = (size_t)j * W + (size_t)i;
            const double area = sg_test_half_plane_area(a, bb, c, i, j), cov = aa1.alpha[at];
            const float *p = aa1.data + 3 * at, *q = plain.data + 3 * at;
            /* Signed distances of the corners from the edge, pixels:
             * within 1e-3 of the edge a sample may go either way. */
            double dmin = INFINITY, dmax = -INFINITY;
            for (int k = 0; k < 4; ++k) {
                double d = (a * (i + (k & 1)) + bb * (j + (k >> 1)) - c) / sqrt(a * a + bb * bb);
                dmin = fmin(dmin, d);
                dmax = fmax(dmax, d);
            }
            if (dmin < 1e-3 && dmax > -1e-3) {
                edge++;
                worst = fmax(worst, fabs(cov - area));
                sum += fabs(cov - area);
                sum_plain += fabs(plain.alpha[at] - area);
                if (fabs(cov - area) > bound)
                    fail_msg("edge pixel (%d, %d): coverage %.5f, exact area %.5f (bound %.4f)", i, j, cov, area,
                             bound);
                /* Its colour: the mix of ground and sky the coverage says. */
                double want = cov * ground + (1.0 - cov) * 0.7;
                if (fabs(p[1] - want) > flat)
                    fail_msg("edge pixel (%d, %d): %.5f, coverage %.4f says %.5f", i, j, p[1], cov, want);
            } else if (dmin >= 1e-3) {
                sky++;
                if (memcmp(p, q, 3 * sizeof(float)) || cov != 0.0)
                    fail_msg("sky pixel (%d, %d): %.9g, plain %.9g, coverage %g", i, j, p[1], q[1], cov);
            } else {
                inside++;
                worst_flat = fmax(worst_flat, fabs(p[1] - q[1]));
                if (cov != 1.0 || fabs(p[1] - q[1]) > flat)
                    fail_msg("ground pixel (%d, %d): %.6f, plain %.6f (bound %.4f), coverage %g", i, j, p[1], q[1],
                             flat, cov);
            }
        }
    print_message("edge: %d pixels, coverage error mean %.4f worst %.4f (bound %.4f; one ray: mean %.4f); %d sky, "
                  "%d ground pixels, ground vs plain worst %.2g; %llu samples for %d pixels, %llu refined\n",
                  edge, sum / edge, worst, bound, sum_plain / edge, sky, inside, worst_flat,
                  (unsigned long long)s1.samples, W * H, (unsigned long long)s1.refined);
    assert_true(edge >= W && sky > 200 && inside > 200);
    assert_true(sum < 0.25 * sum_plain);
    sg_image_free(&plain);
    sg_image_free(&aa1);
    sg_image_free(&aa2);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_view_render_matches_bake_render),
        cmocka_unit_test(test_world_intersect4_matches_single),
        cmocka_unit_test(test_world_intersect16_matches_single),
        cmocka_unit_test(test_view_render_aa_off_is_plain),
        cmocka_unit_test(test_view_render_aa_edge),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
