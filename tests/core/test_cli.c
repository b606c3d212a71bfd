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

static void test_cli_size_list(void **state)
{
    (void)state;
    size_t v[3] = {0};
    int n = -1;
    sg_error err = {0};
    assert_int_equal(sg_cli_size_list("--sizes", "2000,8000,24000000", 100, 100000000ull, v, 3, &n, &err), SG_OK);
    assert_int_equal(n, 3);
    assert_true(v[0] == 2000 && v[1] == 8000 && v[2] == 24000000);
    assert_int_equal(sg_cli_size_list("--sizes", "500", 100, 1000, v, 3, &n, &err), SG_OK);
    assert_int_equal(n, 1);
    /* out of range, too many, empty items, trailing comma, junk, nothing */
    const char *bad[] = {"99", "1001", "200,300,400,500", "200,,300", "200,", ",200", "200x", "", "-200", NULL};
    for (int i = 0; bad[i]; ++i) {
        n = -1;
        assert_int_equal(sg_cli_size_list("--sizes", bad[i], 100, 1000, v, 3, &n, &err), SG_ERR_INVALID_ARG);
        assert_int_equal(n, -1); /* untouched */
        assert_non_null(strstr(err.message, "--sizes: '"));
        assert_non_null(strstr(err.message, "at most 3 integers in [100, 1000]"));
    }
    assert_int_equal(sg_cli_size_list("--sizes", NULL, 1, 2, v, 3, &n, &err), SG_ERR_INVALID_ARG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cli_long_accepts_range_and_names_errors),
        cmocka_unit_test(test_cli_float_above),
        cmocka_unit_test(test_cli_vec3),
        cmocka_unit_test(test_cli_size_list),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
