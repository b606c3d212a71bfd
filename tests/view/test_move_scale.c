/* test_move_scale.c — the resolution scale the viewer picks while the
 * camera moves (sg_view_move_scale, view/frame.h).
 *   1. no usable measurement: scale 2
 *   2. the smallest scale whose predicted frame fits the budget, from the
 *      last frame's time per traced pixel and the pixels each scale traces
 *   3. nothing fits: 8
 *   4. going finer than the scale in use needs 0.8 x the budget
 *   5. a measurement at any scale predicts the others (cost per pixel)
 *   6. odd sizes count the rounded-up pixels
 */
#include "test_support.h"

#include <math.h>

#include "view/frame.h"

static const double BUDGET = 1.0 / 30.0;

/* 1 */
static void test_no_measurement(void **state)
{
    (void)state;
    assert_int_equal(sg_view_move_scale(1, 0.0, 1000, 512, 512, BUDGET), 2);
    assert_int_equal(sg_view_move_scale(1, 0.1, 0, 512, 512, BUDGET), 2);
    assert_int_equal(sg_view_move_scale(4, NAN, 1000, 512, 512, BUDGET), 2);
    assert_int_equal(sg_view_move_scale(4, INFINITY, 1000, 512, 512, BUDGET), 2);
    assert_int_equal(sg_view_move_scale(4, -1.0, 1000, 512, 512, BUDGET), 2);
}

/* 2, 3: a full 512 x 512 frame (262144 pixels) taking t seconds predicts
 * t / 4 at scale 2, t / 16 at 4, t / 64 at 8. */
static void test_smallest_scale_that_fits(void **state)
{
    (void)state;
    const size_t full = 512 * 512;
    assert_int_equal(sg_view_move_scale(1, 0.100, full, 512, 512, BUDGET), 2);  /* 25 ms */
    assert_int_equal(sg_view_move_scale(1, 0.133, full, 512, 512, BUDGET), 2);  /* 33.25 ms */
    assert_int_equal(sg_view_move_scale(1, 0.134, full, 512, 512, BUDGET), 4);  /* 33.5 ms at 2 */
    assert_int_equal(sg_view_move_scale(1, 0.500, full, 512, 512, BUDGET), 4);  /* 31 ms at 4 */
    assert_int_equal(sg_view_move_scale(1, 0.600, full, 512, 512, BUDGET), 8);  /* 37.5 ms at 4 */
    assert_int_equal(sg_view_move_scale(1, 10.0, full, 512, 512, BUDGET), 8);   /* nothing fits */
}

/* 4: at scale 4, scale 2 is taken only below 0.8 x budget. */
static void test_hysteresis_going_finer(void **state)
{
    (void)state;
    const size_t full = 512 * 512;
    /* 0.120 s full = 30 ms at scale 2: fits the budget, not 0.8 of it */
    assert_int_equal(sg_view_move_scale(1, 0.120, full, 512, 512, BUDGET), 2);
    assert_int_equal(sg_view_move_scale(2, 0.120, full, 512, 512, BUDGET), 2);
    assert_int_equal(sg_view_move_scale(4, 0.120, full, 512, 512, BUDGET), 4);
    /* 0.100 s full = 25 ms at 2 < 26.7 ms: finer again */
    assert_int_equal(sg_view_move_scale(4, 0.100, full, 512, 512, BUDGET), 2);
    /* going coarser needs no margin */
    assert_int_equal(sg_view_move_scale(2, 0.134, full, 512, 512, BUDGET), 4);
}

/* 5: the same cost per pixel measured on a scale-4 frame. */
static void test_measured_at_another_scale(void **state)
{
    (void)state;
    const size_t quarter = 128 * 128;
    double per_pixel = 0.100 / (512.0 * 512.0);
    assert_int_equal(sg_view_move_scale(4, per_pixel * (double)quarter, quarter, 512, 512, BUDGET), 2);
    per_pixel = 0.500 / (512.0 * 512.0);
    assert_int_equal(sg_view_move_scale(4, per_pixel * (double)quarter, quarter, 512, 512, BUDGET), 4);
}

/* 6: 3 x 3 at scale 2 traces 2 x 2 pixels, not 1.5 x 1.5. */
static void test_odd_sizes_round_up(void **state)
{
    (void)state;
    /* one pixel costs 0.01 s: 4 pixels = 0.04 s > 0.035 (2.25 pixels would
     * fit), 1 pixel at scale 4 fits */
    assert_int_equal(sg_view_move_scale(1, 0.09, 9, 3, 3, 0.035), 4);
    assert_int_equal(sg_view_move_scale(1, 0.09, 9, 3, 3, 0.041), 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_measurement),
        cmocka_unit_test(test_smallest_scale_that_fits),
        cmocka_unit_test(test_hysteresis_going_finer),
        cmocka_unit_test(test_measured_at_another_scale),
        cmocka_unit_test(test_odd_sizes_round_up),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
