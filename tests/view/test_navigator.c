/* test_navigator.c — the viewer's camera controller (view/navigator.h),
 * driven headless with synthetic input.
 *   1. walking forward for 1 s at speed v moves the eye by v along the view
 *   2. diagonal key combinations move speed * dt, not more
 *   3. speed scales with the scene's bounds
 *   4. mouse look changes yaw and pitch; pitch is clamped
 *   5. orbit keeps the distance to the centre and looks at it
 *   6. reset restores the first view exactly (and its camera)
 *   7. no input, no change
 */
#include "test_support.h"

#include <math.h>
#include <string.h>

#include "view/navigator.h"

static const sg_nav_view home = {{0.0f, 2.0f, 10.0f}, {0.0f, 1.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 45.0f};

static sg_aabb box(float half)
{
    sg_aabb b = {{-half, 0.0f, -half}, {half, half, half}};
    return b;
}

static float dist(sg_vec3 a, sg_vec3 b) { return sg_v3_length(sg_v3_sub(a, b)); }

/* 1 */
static void test_forward_one_second(void **state)
{
    (void)state;
    sg_navigator n;
    sg_nav_init(&n, &home, box(5.0f));
    float v = n.speed;
    assert_true(v > 0.0f);
    sg_vec3 f = sg_nav_forward(n.yaw, n.pitch);
    sg_vec3 want_dir = sg_v3_normalize(sg_v3_sub(home.look, home.eye));
    assert_true(dist(f, want_dir) < 1e-6f);
    sg_vec3 e0 = n.eye;
    sg_nav_input in = {.forward = 1};
    for (int i = 0; i < 100; i++)
        assert_int_equal(sg_nav_update(&n, &in, 0.01f), 1);
    sg_vec3 want = sg_v3_madd(e0, want_dir, v);
    assert_true(dist(n.eye, want) < 1e-4f * v);
    /* backwards for 1 s returns */
    sg_nav_input back = {.back = 1};
    assert_int_equal(sg_nav_update(&n, &back, 1.0f), 1);
    assert_true(dist(n.eye, e0) < 1e-4f * v);
    /* fast: SG_NAV_FAST_FACTOR times as far */
    sg_nav_input fast = {.forward = 1, .fast = 1};
    sg_nav_update(&n, &fast, 0.5f);
    assert_true(fabsf(dist(n.eye, e0) - 0.5f * v * SG_NAV_FAST_FACTOR) < 1e-3f * v);
}

/* 2 */
static void test_diagonal_normalised(void **state)
{
    (void)state;
    sg_navigator n;
    sg_nav_init(&n, &home, box(5.0f));
    sg_vec3 e0 = n.eye;
    sg_nav_input in = {.forward = 1, .right = 1, .up = 1};
    sg_nav_update(&n, &in, 1.0f);
    assert_true(fabsf(dist(n.eye, e0) - n.speed) < 1e-4f * n.speed);
    assert_true(n.eye.x > e0.x); /* right of a view along -Z is +X */
    /* opposite keys cancel */
    sg_nav_input none = {.forward = 1, .back = 1, .left = 1, .right = 1};
    sg_vec3 e1 = n.eye;
    assert_int_equal(sg_nav_update(&n, &none, 1.0f), 0);
    assert_true(dist(n.eye, e1) == 0.0f);
}

/* 3 */
static void test_speed_scales_with_bounds(void **state)
{
    (void)state;
    sg_navigator a, b;
    sg_nav_init(&a, &home, box(5.0f));
    sg_nav_init(&b, &home, box(50.0f));
    assert_true(fabsf(b.speed / a.speed - 10.0f) < 1e-4f);
    assert_true(fabsf(a.speed - SG_NAV_SPEED_FRACTION * sg_aabb_diagonal(box(5.0f))) < 1e-5f);
}

/* 4 */
static void test_mouse_look(void **state)
{
    (void)state;
    sg_navigator n;
    sg_nav_init(&n, &home, box(5.0f));
    float y0 = n.yaw, p0 = n.pitch;
    sg_nav_input in = {.look_dx = 100.0f, .look_dy = 50.0f};
    assert_int_equal(sg_nav_update(&n, &in, 0.016f), 1);
    assert_true(fabsf(n.yaw - (y0 + 100.0f * SG_NAV_LOOK_RATE)) < 1e-5f);
    assert_true(fabsf(n.pitch - (p0 - 50.0f * SG_NAV_LOOK_RATE)) < 1e-5f); /* mouse down looks down */
    sg_vec3 e = n.eye;
    assert_true(dist(e, home.eye) == 0.0f); /* looking does not move the eye */
    float pmax = SG_NAV_PITCH_MAX_DEG * 3.14159265f / 180.0f;
    sg_nav_input up = {.look_dy = -1e6f};
    sg_nav_update(&n, &up, 0.016f);
    assert_true(fabsf(n.pitch - pmax) < 1e-6f);
    sg_nav_input down = {.look_dy = 1e7f};
    sg_nav_update(&n, &down, 0.016f);
    assert_true(fabsf(n.pitch + pmax) < 1e-6f);
    /* still a valid camera at the clamp */
    sg_camera cam;
    sg_error err;
    assert_int_equal(sg_nav_camera(&n, 1.5f, &cam, &err), SG_OK);
    assert_true(cam.forward.y < -0.99f);
}

/* 5 */
static void test_orbit_keeps_distance(void **state)
{
    (void)state;
    sg_navigator n;
    sg_nav_init(&n, &home, box(5.0f));
    sg_nav_set_mode(&n, SG_NAV_ORBIT);
    assert_int_equal(n.mode, SG_NAV_ORBIT);
    float d0 = dist(n.eye, n.centre);
    assert_true(fabsf(d0 - dist(home.eye, n.centre)) < 1e-4f); /* the eye does not jump */
    uint64_t rng = 7;
    for (int i = 0; i < 200; i++) {
        sg_nav_input in = {.look_dx = 200.0f * (sg_test_rand01(&rng) - 0.5f),
                           .look_dy = 200.0f * (sg_test_rand01(&rng) - 0.5f),
                           .left = sg_test_rand01(&rng) < 0.3f, .right = sg_test_rand01(&rng) < 0.3f,
                           .up = sg_test_rand01(&rng) < 0.2f};
        sg_nav_update(&n, &in, 0.02f);
        assert_true(fabsf(dist(n.eye, n.centre) - d0) < 1e-4f * d0);
        sg_nav_view v = sg_nav_get_view(&n);
        sg_vec3 to_c = sg_v3_normalize(sg_v3_sub(n.centre, v.eye));
        assert_true(sg_v3_dot(to_c, sg_v3_normalize(sg_v3_sub(v.look, v.eye))) > 0.99999f);
    }
    /* W zooms in, never below the minimum */
    sg_nav_input zoom = {.forward = 1};
    sg_nav_update(&n, &zoom, 0.1f);
    assert_true(dist(n.eye, n.centre) < d0);
    sg_nav_update(&n, &zoom, 1000.0f);
    assert_true(fabsf(dist(n.eye, n.centre) - n.min_distance) < 1e-4f);
    /* back to walk keeps the view */
    sg_nav_view before = sg_nav_get_view(&n);
    sg_nav_set_mode(&n, SG_NAV_WALK);
    sg_nav_view after = sg_nav_get_view(&n);
    assert_true(dist(before.eye, after.eye) == 0.0f);
    assert_true(sg_v3_dot(sg_v3_normalize(sg_v3_sub(before.look, before.eye)),
                          sg_v3_normalize(sg_v3_sub(after.look, after.eye))) > 0.99999f);
}

/* 6 */
static void test_reset(void **state)
{
    (void)state;
    sg_nav_view h = {{1.0f, 3.0f, 7.0f}, {0.5f, 0.25f, -1.0f}, {0.1f, 1.0f, 0.0f}, 33.0f};
    sg_navigator n;
    sg_nav_init(&n, &h, box(5.0f));
    sg_nav_view v0 = sg_nav_get_view(&n);
    assert_memory_equal(&v0, &h, sizeof h);
    sg_nav_input in = {.forward = 1, .left = 1, .look_dx = 30.0f, .look_dy = -20.0f};
    sg_nav_update(&n, &in, 0.5f);
    sg_nav_set_mode(&n, SG_NAV_ORBIT);
    sg_nav_update(&n, &in, 0.5f);
    sg_nav_view moved = sg_nav_get_view(&n);
    assert_true(dist(moved.eye, h.eye) > 0.1f);
    sg_nav_reset(&n);
    assert_int_equal(n.mode, SG_NAV_WALK);
    sg_nav_view v1 = sg_nav_get_view(&n);
    assert_memory_equal(&v1, &h, sizeof h);
    sg_camera a, b;
    sg_error err;
    assert_int_equal(sg_nav_camera(&n, 1.25f, &a, &err), SG_OK);
    assert_int_equal(sg_camera_look_at(h.eye, h.look, h.up, h.fov_deg, 1.25f, &b, &err), SG_OK);
    assert_memory_equal(&a, &b, sizeof a);
}

/* 7 */
static void test_no_input(void **state)
{
    (void)state;
    sg_navigator n;
    sg_nav_init(&n, &home, box(5.0f));
    sg_nav_input in = {0};
    assert_int_equal(sg_nav_update(&n, &in, 0.5f), 0);
    assert_int_equal(n.at_home, 1);
    sg_nav_set_mode(&n, SG_NAV_ORBIT);
    assert_int_equal(sg_nav_update(&n, &in, 0.5f), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forward_one_second), cmocka_unit_test(test_diagonal_normalised),
        cmocka_unit_test(test_speed_scales_with_bounds), cmocka_unit_test(test_mouse_look),
        cmocka_unit_test(test_orbit_keeps_distance), cmocka_unit_test(test_reset),
        cmocka_unit_test(test_no_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
