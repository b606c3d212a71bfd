/* test_pointset.c — the splat container and its invariants.
 *
 *  1. pointset::alloc_defaults        every array present, albedo 0.8 grey,
 *                                     free zeroes the struct, free(NULL) ok.
 *  2. pointset::validate_good         a valid set passes; empty set passes.
 *  3. pointset::validate_nan_position names the splat and says "position".
 *  4. pointset::validate_radius       zero, negative and NaN radius.
 *  5. pointset::validate_normal       non-unit (0.9) and zero normal; a
 *                                     normal off by 5e-4 still passes.
 *  6. pointset::append                to an empty (zeroed) set, to a full
 *                                     one, an empty source; bounds follow.
 */
#include "test_support.h"

#include <math.h>
#include <string.h>

#include "points/pointset.h"

/* n splats on the x axis at x = i + offset, normal +y, radius 0.5. */
static void make_line(sg_pointset *ps, size_t n, float offset)
{
    sg_error err;
    assert_int_equal(sg_pointset_alloc(ps, n, &err), SG_OK);
    for (size_t i = 0; i < n; ++i) {
        ps->px[i] = (float)i + offset;
        ps->py[i] = 0.0f;
        ps->pz[i] = 0.0f;
        ps->nx[i] = 0.0f;
        ps->ny[i] = 1.0f;
        ps->nz[i] = 0.0f;
        ps->radius[i] = 0.5f;
    }
}

static void expect_invalid(const sg_pointset *ps, const char *splat, const char *word)
{
    sg_error err;
    sg_status s = sg_pointset_validate(ps, &err);
    if (s != SG_ERR_INVALID_ARG)
        fail_msg("validate: %s, want SG_ERR_INVALID_ARG (expecting \"%s\")", sg_status_name(s), splat);
    if (!strstr(err.message, splat) || !strstr(err.message, word))
        fail_msg("message \"%s\" does not name \"%s\" and \"%s\"", err.message, splat, word);
}

static void test_pointset_alloc_defaults(void **state)
{
    (void)state;
    sg_pointset ps;
    make_line(&ps, 100, 0.0f);
    assert_int_equal(ps.count, 100);
    for (size_t i = 0; i < 100; ++i)
        if (ps.ar[i] != 0.8f || ps.ag[i] != 0.8f || ps.ab[i] != 0.8f)
            fail_msg("splat %zu albedo (%g,%g,%g), want 0.8 grey", i, (double)ps.ar[i],
                     (double)ps.ag[i], (double)ps.ab[i]);
    assert_int_equal((uintptr_t)ps.px % 64, 0);
    assert_int_equal((uintptr_t)ps.radius % 64, 0);
    sg_pointset_free(&ps);
    assert_int_equal(ps.count, 0);
    assert_null(ps.px);
    assert_null(ps.ab);
    sg_pointset_free(&ps);
    sg_pointset_free(NULL);
}

static void test_pointset_validate_good(void **state)
{
    (void)state;
    sg_pointset ps, empty = {0};
    sg_error err;
    make_line(&ps, 10, 0.0f);
    assert_int_equal(sg_pointset_validate(&ps, &err), SG_OK);
    assert_int_equal(sg_pointset_validate(&empty, &err), SG_OK);
    sg_pointset_free(&ps);
}

static void test_pointset_validate_nan_position(void **state)
{
    (void)state;
    sg_pointset ps;
    make_line(&ps, 10, 0.0f);
    ps.pz[6] = NAN;
    expect_invalid(&ps, "splat 6", "position");
    ps.pz[6] = 0.0f;
    ps.px[2] = INFINITY;
    expect_invalid(&ps, "splat 2", "position");
    sg_pointset_free(&ps);
}

static void test_pointset_validate_radius(void **state)
{
    (void)state;
    sg_pointset ps;
    make_line(&ps, 10, 0.0f);
    ps.radius[4] = 0.0f;
    expect_invalid(&ps, "splat 4", "radius");
    ps.radius[4] = -1.0f;
    expect_invalid(&ps, "splat 4", "radius");
    ps.radius[4] = NAN;
    expect_invalid(&ps, "splat 4", "radius");
    sg_pointset_free(&ps);
}

static void test_pointset_validate_normal(void **state)
{
    (void)state;
    sg_pointset ps;
    sg_error err;
    make_line(&ps, 10, 0.0f);
    ps.ny[9] = 0.9f;
    expect_invalid(&ps, "splat 9", "normal");
    ps.ny[9] = 0.0f;
    expect_invalid(&ps, "splat 9", "normal");
    ps.ny[9] = 1.0f - 5e-4f; /* within the 1e-3 tolerance of invariant 3 */
    assert_int_equal(sg_pointset_validate(&ps, &err), SG_OK);
    sg_pointset_free(&ps);
}

static void test_pointset_append(void **state)
{
    (void)state;
    sg_pointset dst = {0}, a, b, none = {0};
    sg_error err;
    make_line(&a, 3, 0.0f);
    make_line(&b, 4, 100.0f);
    b.ar[1] = 0.25f;
    assert_int_equal(sg_pointset_append(&dst, &a, &err), SG_OK);
    assert_int_equal(dst.count, 3);
    assert_int_equal(sg_pointset_append(&dst, &b, &err), SG_OK);
    assert_int_equal(sg_pointset_append(&dst, &none, &err), SG_OK);
    assert_int_equal(dst.count, 7);
    static const float want_x[7] = {0, 1, 2, 100, 101, 102, 103};
    for (size_t i = 0; i < 7; ++i)
        if (dst.px[i] != want_x[i] || dst.ny[i] != 1.0f || dst.radius[i] != 0.5f)
            fail_msg("splat %zu: x %g ny %g r %g, want x %g ny 1 r 0.5", i, (double)dst.px[i],
                     (double)dst.ny[i], (double)dst.radius[i], (double)want_x[i]);
    assert_true(dst.ar[4] == 0.25f && dst.ar[3] == 0.8f);
    assert_int_equal(sg_pointset_validate(&dst, &err), SG_OK);
    sg_aabb box = sg_pointset_bounds(&dst);
    assert_true(box.lo.x == 0.0f && box.hi.x == 103.0f && box.lo.y == 0.0f && box.hi.y == 0.0f);
    sg_pointset_free(&a);
    sg_pointset_free(&b);
    sg_pointset_free(&dst);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pointset_alloc_defaults),
        cmocka_unit_test(test_pointset_validate_good),
        cmocka_unit_test(test_pointset_validate_nan_position),
        cmocka_unit_test(test_pointset_validate_radius),
        cmocka_unit_test(test_pointset_validate_normal),
        cmocka_unit_test(test_pointset_append),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
