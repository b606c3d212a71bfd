/* test_xyz.c — text point clouds (.xyz / .txt): each column layout,
 * normals told from colours, separators and comments, and every error
 * naming the file and the line. */
#include "test_support.h"

#include <math.h>
#include <string.h>

#include "io/mesh.h"
#include "io/xyz.h"

static const char *write_text(const char *name, const char *text)
{
    return sg_test_write_file(name, text, strlen(text));
}

static sg_mesh read_ok(const char *name, const char *text)
{
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_mesh_read(write_text(name, text), &m, &err); /* through the dispatch */
    if (st != SG_OK)
        fail_msg("%s: %s: %s", name, sg_status_name(st), err.message);
    return m;
}

static void expect3(const float *v, float x, float y, float z, float tol, const char *what)
{
    if (fabsf(v[0] - x) > tol || fabsf(v[1] - y) > tol || fabsf(v[2] - z) > tol)
        fail_msg("%s: (%g, %g, %g), want (%g, %g, %g)", what, v[0], v[1], v[2], x, y, z);
}

static float srgb(double c) { return (float)(c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4)); }

static void test_xyz_positions_only(void **state)
{
    (void)state;
    sg_mesh m = read_ok("plain.xyz", "# a comment\n//X Y Z\n\n1 2 3\r\n-4.5e1,0.25,6\n7\t8;9\n");
    assert_int_equal(m.vertex_count, 3);
    assert_int_equal(m.triangle_count, 0);
    assert_null(m.normals);
    assert_null(m.colors);
    assert_null(m.radii);
    expect3(&m.positions[0], 1, 2, 3, 0, "p0");
    expect3(&m.positions[3], -45, 0.25f, 6, 0, "p1");
    expect3(&m.positions[6], 7, 8, 9, 0, "p2");
    sg_mesh_free(&m);
}

static void test_xyz_six_columns_decided_by_file(void **state)
{
    (void)state;
    /* Unit triples on every line: normals. */
    sg_mesh m = read_ok("n6.txt", "0 0 0 0 0 1\n1 0 0 0.6 0.8 0\n2 0 0 0 0 0\n");
    assert_non_null(m.normals);
    assert_null(m.colors);
    expect3(&m.normals[3], 0.6f, 0.8f, 0, 1e-6f, "n1");
    expect3(&m.normals[6], 0, 0, 0, 0, "n2 unknown");
    sg_mesh_free(&m);
    /* One non-unit triple: the three columns are 8-bit colours. */
    m = read_ok("c6.xyz", "0 0 0 255 0 128\n1 0 0 0 0 1\n");
    assert_null(m.normals);
    assert_non_null(m.colors);
    expect3(&m.colors[0], 1.0f, 0.0f, srgb(128 / 255.0), 1e-6f, "c0");
    expect3(&m.colors[3], 0, 0, srgb(1 / 255.0), 1e-7f, "c1");
    sg_mesh_free(&m);
    /* Colours all within [0, 1]: a 0..1 scale. */
    m = read_ok("c01.xyz", "0 0 0 0.5 0.25 0.2\n1 0 0 1 0 0.1\n");
    assert_non_null(m.colors);
    expect3(&m.colors[0], srgb(0.5), srgb(0.25), srgb(0.2), 1e-6f, "c0 0..1");
    sg_mesh_free(&m);
}

static void test_xyz_seven_and_nine_columns(void **state)
{
    (void)state;
    sg_mesh m = read_ok("i7.txt", "1 2 3 0.87 255 255 0\n4 5 6 0.1 0 0 255\n");
    assert_null(m.normals);
    expect3(&m.positions[3], 4, 5, 6, 0, "p1");
    expect3(&m.colors[0], 1, 1, 0, 1e-6f, "c0");
    sg_mesh_free(&m);
    m = read_ok("n9.xyz", "1 2 3 0 1 0 10 20 30\n4 5 6 0 0 -3 0 0 0\n");
    expect3(&m.normals[0], 0, 1, 0, 0, "n0");
    expect3(&m.normals[3], 0, 0, -1, 0, "n1");
    expect3(&m.colors[0], srgb(10 / 255.0), srgb(20 / 255.0), srgb(30 / 255.0), 1e-6f, "c0");
    sg_mesh_free(&m);
    m = read_ok("i4.xyz", "1 2 3 100\n4 5 6 200\n");
    assert_null(m.colors);
    assert_null(m.normals);
    assert_int_equal(m.vertex_count, 2);
    sg_mesh_free(&m);
}

static void expect_fail(const char *name, const char *text, sg_status want, const char *frag)
{
    sg_mesh m;
    memset(&m, 0x5A, sizeof m);
    sg_mesh before = m;
    sg_error err = {0};
    sg_status st = sg_xyz_read(write_text(name, text), &m, &err);
    if (st != want || !strstr(err.message, name) || !strstr(err.message, frag))
        fail_msg("%s: got %s \"%s\"; want %s with \"%s\"", name, sg_status_name(st), err.message, sg_status_name(want),
                 frag);
    if (memcmp(&m, &before, sizeof m) != 0)
        fail_msg("%s: *out was modified on failure", name);
}

static void test_xyz_errors(void **state)
{
    (void)state;
    expect_fail("word.xyz", "1 2 3\n4 abc 6\n", SG_ERR_CORRUPT, "line 2: column 2: 'abc' is not a number");
    expect_fail("ragged.xyz", "1 2 3\n4 5 6 7 8 9\n", SG_ERR_CORRUPT, "line 2: 6 columns, but line 1 has 3");
    expect_fail("five.xyz", "# x y z a b\n1 2 3 4 5\n", SG_ERR_CORRUPT, "line 2: 5 columns; expected x y z");
    expect_fail("two.xyz", "1 2\n", SG_ERR_CORRUPT, "line 1: 2 columns");
    expect_fail("nan.xyz", "1 2 3\nnan 0 0\n", SG_ERR_CORRUPT, "line 2: x is NaN");
    expect_fail("inf.xyz", "1 2 3\n0 -inf 0\n", SG_ERR_CORRUPT, "line 2: y is infinite");
    expect_fail("big.xyz", "1 2 3\n0 0 1e300\n", SG_ERR_CORRUPT, "line 2: z is out of float range");
    expect_fail("col.xyz", "1 2 3 10 20 300\n", SG_ERR_CORRUPT, "line 1: colour b = 300 is outside [0, 255]");
    expect_fail("neg.xyz", "1 2 3 0 0 1 -5 20 30\n", SG_ERR_CORRUPT, "line 1: colour r = -5 is outside [0, 255]");
    expect_fail("empty.xyz", "# nothing\n\n", SG_ERR_CORRUPT, "no points");
    expect_fail("zero.xyz", "", SG_ERR_CORRUPT, "no points");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_xyz_positions_only),
        cmocka_unit_test(test_xyz_six_columns_decided_by_file),
        cmocka_unit_test(test_xyz_seven_and_nine_columns),
        cmocka_unit_test(test_xyz_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
