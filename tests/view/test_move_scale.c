/* test_move_scale.c — the resolution scale the viewer picks while the
 * camera moves (sg_view_move_scale, view/frame.h).
 *   1. no usable measurement: scale 2
 *   2. the smallest scale whose predicted frame fits the budget; the
 *      prediction is last_seconds x (P / last_pixels)^0.75
 *   3. nothing fits: 8
 *   4. going finer than the scale in use needs 0.8 x the budget
 *   5. a measurement at any scale predicts the others
 *   6. odd sizes count the rounded-up pixels
 */
#include "test_support.h"

#include <math.h>

#include "view/frame.h"

static const double BUDGET = 1.0 / 30.0;

/* The fraction of a full frame's time that scale s is predicted to take:
 * (1 / s^2)^0.75, i.e. 0.354 at 2, 0.125 at 4, 0.0442 at 8. */

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

/* 2, 3: from a full 512 x 512 frame of t seconds. */
static void test_smallest_scale_that_fits(void **state)
{
    (void)state;
    const size_t full = 512 * 512;
    assert_int_equal(sg_view_move_scale(1, 0.0900, full, 512, 512, BUDGET), 2); /* 31.8 ms at 2 */
    assert_int_equal(sg_view_move_scale(1, 0.0940, full, 512, 512, BUDGET), 2); /* 33.2 ms at 2 */
    assert_int_equal(sg_view_move_scale(1, 0.0945, full, 512, 512, BUDGET), 4); /* 33.4 ms at 2 */
    assert_int_equal(sg_view_move_scale(1, 0.2660, full, 512, 512, BUDGET), 4); /* 33.25 ms at 4 */
    assert_int_equal(sg_view_move_scale(1, 0.2680, full, 512, 512, BUDGET), 8); /* 33.5 ms at 4 */
    assert_int_equal(sg_view_move_scale(1, 10.0, full, 512, 512, BUDGET), 8);   /* nothing fits */
}

/* 4: at scale 4, scale 2 is taken only below 0.8 x budget (26.7 ms). */
static void test_hysteresis_going_finer(void **state)
{
    (void)state;
    const size_t full = 512 * 512;
    /* 0.085 s full: 30.1 ms at scale 2, within the budget, not 0.8 of it */
    assert_int_equal(sg_view_move_scale(1, 0.085, full, 512, 512, BUDGET), 2);
    assert_int_equal(sg_view_move_scale(2, 0.085, full, 512, 512, BUDGET), 2);
    assert_int_equal(sg_view_move_scale(4, 0.085, full, 512, 512, BUDGET), 4);
    /* 0.070 s full: 24.7 ms at scale 2: finer again */
    assert_int_equal(sg_view_move_scale(4, 0.070, full, 512, 512, BUDGET), 2);
    /* going coarser needs no margin */
    assert_int_equal(sg_view_move_scale(2, 0.0945, full, 512, 512, BUDGET), 4);
}

/* 5: measured on a scale-4 frame (16384 pixels): scale 2 is predicted at
 * 4^0.75 = 2.83 times that frame's time. */
static void test_measured_at_another_scale(void **state)
{
    (void)state;
    const size_t quarter = 128 * 128;
    assert_int_equal(sg_view_move_scale(4, 0.009, quarter, 512, 512, BUDGET), 2); /* 25.5 ms at 2 */
    assert_int_equal(sg_view_move_scale(4, 0.010, quarter, 512, 512, BUDGET), 4); /* 28.3 ms at 2 */
    assert_int_equal(sg_view_move_scale(4, 0.030, quarter, 512, 512, BUDGET), 4); /* 30 ms at 4 */
    assert_int_equal(sg_view_move_scale(4, 0.040, quarter, 512, 512, BUDGET), 8); /* 40 ms at 4 */
    /* and from a scale-8 frame (4096 pixels) back to 4: 4^0.75 x 0.0093 = 26.3 ms */
    assert_int_equal(sg_view_move_scale(8, 0.0093, 64 * 64, 512, 512, BUDGET), 4);
}

/* 6: 3 x 3 at scale 2 traces 2 x 2 pixels, not 1.5 x 1.5: 0.09 s for 9
 * pixels predicts 0.09 (4/9)^0.75 = 49.0 ms (2.25 pixels would give
 * 31.8 ms), and 17.3 ms for the 1 pixel of scale 4. */
static void test_odd_sizes_round_up(void **state)
{
    (void)state;
    assert_int_equal(sg_view_move_scale(1, 0.09, 9, 3, 3, 0.040), 4);
    assert_int_equal(sg_view_move_scale(1, 0.09, 9, 3, 3, 0.050), 2);
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
