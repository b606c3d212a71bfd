/* test_cli.c — option value parsing and its messages. */
#include "test_support.h"

#include <string.h>

#include "core/cli.h"

static void test_cli_long_accepts_range_and_names_errors(void **state)
{
    (void)state;
    long v = -7;
    sg_error err = {0};
    assert_int_equal(sg_cli_long("--width", "512", 1, 65536, &v, &err), SG_OK);
    assert_int_equal(v, 512);
    const char *bad[] = {"abc", "", "12x", "0", "65537", "99999999999999999999", NULL};
    for (int i = 0; bad[i]; ++i) {
        v = -7;
        assert_int_equal(sg_cli_long("--width", bad[i], 1, 65536, &v, &err), SG_ERR_INVALID_ARG);
        assert_int_equal(v, -7); /* untouched */
        assert_non_null(strstr(err.message, "--width: '"));
        assert_non_null(strstr(err.message, "is not an integer in [1, 65536]"));
    }
    assert_int_equal(sg_cli_long("--width", NULL, 1, 2, &v, &err), SG_ERR_INVALID_ARG);
}

static void test_cli_float_above(void **state)
{
    (void)state;
    float f = 0;
    sg_error err = {0};
    assert_int_equal(sg_cli_float_above("--fov", "40.5", 0.0f, &f, &err), SG_OK);
    assert_true(f == 40.5f);
    assert_int_equal(sg_cli_float_above("--fov", "0", 0.0f, &f, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_cli_float_above("--fov", "nan", 0.0f, &f, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_cli_float_above("--fov", "inf", 0.0f, &f, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "--fov: 'inf' is not a number > 0"));
}

static void test_cli_vec3(void **state)
{
    (void)state;
    sg_vec3 v = {0, 0, 0};
    sg_error err = {0};
    assert_int_equal(sg_cli_vec3("--eye", "1,-2.5,3e1", &v, &err), SG_OK);
    assert_true(v.x == 1.0f && v.y == -2.5f && v.z == 30.0f);
    const char *bad[] = {"1,2", "1,2,3,4", "1;2;3", "a,b,c", "1,2,nan", "", NULL};
    for (int i = 0; bad[i]; ++i) {
        assert_int_equal(sg_cli_vec3("--eye", bad[i], &v, &err), SG_ERR_INVALID_ARG);
        assert_non_null(strstr(err.message, "--eye: '"));
    }
    assert_true(v.x == 1.0f && v.y == -2.5f && v.z == 30.0f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cli_long_accepts_range_and_names_errors),
        cmocka_unit_test(test_cli_float_above),
        cmocka_unit_test(test_cli_vec3),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
