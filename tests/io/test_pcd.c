/* test_pcd.c — PCL .pcd point clouds, ascii and binary: fields, packed rgb,
 * normals, radius, skipped fields, NaN points, and the header errors. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "io/mesh.h"
#include "io/pcd.h"

static float srgb8(unsigned c)
{
    double x = c / 255.0;
    return (float)(x <= 0.04045 ? x / 12.92 : pow((x + 0.055) / 1.055, 2.4));
}

static void expect3(const float *v, float x, float y, float z, float tol, const char *what)
{
    if (fabsf(v[0] - x) > tol || fabsf(v[1] - y) > tol || fabsf(v[2] - z) > tol)
        fail_msg("%s: (%g, %g, %g), want (%g, %g, %g)", what, v[0], v[1], v[2], x, y, z);
}

static sg_mesh read_ok(const char *path)
{
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_mesh_read(path, &m, &err);
    if (st != SG_OK)
        fail_msg("%s: %s", sg_status_name(st), err.message);
    return m;
}

/* The float whose bits are 0xAARRGGBB, as PCL stores rgb. */
static float packed_rgb(unsigned r, unsigned g, unsigned b)
{
    uint32_t u = 0xFF000000u | (r << 16) | (g << 8) | b;
    float f;
    memcpy(&f, &u, 4);
    return f;
}

static void test_pcd_ascii(void **state)
{
    (void)state;
    const char *text = "# .PCD v0.7 - Point Cloud Data file format\n"
                       "VERSION 0.7\nFIELDS x y z rgb normal_x normal_y normal_z curvature fpfh\n"
                       "SIZE 4 4 4 4 4 4 4 4 4\nTYPE F F F U F F F F F\nCOUNT 1 1 1 1 1 1 1 1 3\n"
                       "WIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n"
                       "1 2 3 16744448 0 0 2 0.5 1 2 3\n"
                       "nan nan nan 0 0 0 0 0 0 0 0\n"
                       "-1.5 0 4e-1 255 0.6 0.8 0 0.1 4 5 6\n";
    const char *path = sg_test_write_file("ascii.pcd", text, strlen(text));
    sg_mesh m = read_ok(path);
    assert_int_equal(m.vertex_count, 2); /* the NaN point is skipped */
    expect3(&m.positions[0], 1, 2, 3, 0, "p0");
    expect3(&m.positions[3], -1.5f, 0, 0.4f, 0, "p1");
    expect3(&m.normals[0], 0, 0, 1, 0, "n0");
    expect3(&m.normals[3], 0.6f, 0.8f, 0, 1e-7f, "n1");
    /* 16744448 = 0xFF8000: r 255, g 128, b 0 */
    expect3(&m.colors[0], 1.0f, srgb8(128), 0.0f, 1e-7f, "c0");
    expect3(&m.colors[3], 0, 0, 1.0f, 1e-7f, "c1");
    assert_null(m.radii);
    sg_mesh_free(&m);
}

/* Binary records with a double x, a packed float rgb, a uchar skipped field,
 * a radius and an int16 y; little-endian. */
static void test_pcd_binary(void **state)
{
    (void)state;
    unsigned char buf[1024];
    int n = snprintf((char *)buf, sizeof buf,
                     "VERSION .7\nFIELDS x flags y z rgb radius\nSIZE 8 1 2 4 4 4\nTYPE F U I F F F\n"
                     "COUNT 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA binary\n");
    size_t at = (size_t)n;
    const double xs[2] = {0.5, -2.25};
    const int16_t ys[2] = {-300, 7};
    const float zs[2] = {1.0f, 2.0f}, rad[2] = {0.01f, 0.02f};
    const float rgb[2] = {packed_rgb(10, 20, 30), packed_rgb(255, 255, 255)};
    for (int i = 0; i < 2; ++i) {
        memcpy(buf + at, &xs[i], 8), at += 8; /* little-endian host */
        buf[at++] = 0xEE;
        memcpy(buf + at, &ys[i], 2), at += 2;
        memcpy(buf + at, &zs[i], 4), at += 4;
        memcpy(buf + at, &rgb[i], 4), at += 4;
        memcpy(buf + at, &rad[i], 4), at += 4;
    }
    const char *path = sg_test_write_file("binary.pcd", buf, at);
    sg_mesh m = read_ok(path);
    assert_int_equal(m.vertex_count, 2);
    expect3(&m.positions[0], 0.5f, -300, 1, 0, "p0");
    expect3(&m.positions[3], -2.25f, 7, 2, 0, "p1");
    expect3(&m.colors[0], srgb8(10), srgb8(20), srgb8(30), 1e-7f, "c0");
    assert_null(m.normals);
    assert_true(m.radii[0] == 0.01f && m.radii[1] == 0.02f);
    sg_mesh_free(&m);

    /* One byte short: POINTS cannot fit. */
    path = sg_test_write_file("short.pcd", buf, at - 1);
    sg_error err = {0};
    assert_int_equal(sg_pcd_read(path, &m, &err), SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "short.pcd: header: POINTS 2 exceeds what the file can hold"));
}

static void expect_fail(const char *name, const char *text, sg_status want, const char *frag)
{
    sg_mesh m;
    memset(&m, 0x5A, sizeof m);
    sg_mesh before = m;
    sg_error err = {0};
    sg_status st = sg_pcd_read(sg_test_write_file(name, text, strlen(text)), &m, &err);
    if (st != want || !strstr(err.message, name) || !strstr(err.message, frag))
        fail_msg("%s: got %s \"%s\"; want %s with \"%s\"", name, sg_status_name(st), err.message, sg_status_name(want),
                 frag);
    if (memcmp(&m, &before, sizeof m) != 0)
        fail_msg("%s: *out was modified on failure", name);
}

#define HDR(fields, size, type, pts, data)                                                                          \
    "VERSION 0.7\nFIELDS " fields "\nSIZE " size "\nTYPE " type "\nWIDTH " pts "\nHEIGHT 1\nPOINTS " pts            \
    "\nDATA " data "\n"

static void test_pcd_errors(void **state)
{
    (void)state;
    expect_fail("compressed.pcd", HDR("x y z", "4 4 4", "F F F", "1", "binary_compressed") "xxxxxxxxxxxx",
                SG_ERR_UNSUPPORTED, "DATA binary_compressed is not read");
    expect_fail("noz.pcd", HDR("x y", "4 4", "F F", "1", "ascii") "1 2\n", SG_ERR_UNSUPPORTED, "no x, y and z");
    expect_fail("wh.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\nPOINTS 3\nDATA ascii\n",
                SG_ERR_CORRUPT, "WIDTH 2 x HEIGHT 2 is not POINTS 3");
    expect_fail("sizes.pcd", "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 2 3\n", SG_ERR_CORRUPT,
                "line 2: SIZE has 2 entries for 3 FIELDS");
    expect_fail("type.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F Q F\nPOINTS 1\nDATA ascii\n1 2 3\n", SG_ERR_CORRUPT,
                "line 3: TYPE of field y: 'Q' is not I, U or F");
    expect_fail("order.pcd", "FIELDS x y z\nTYPE F F F\nSIZE 4 4 4\nPOINTS 1\nDATA ascii\n1 2 3\n", SG_ERR_CORRUPT,
                "line 2: TYPE out of order (expected SIZE)");
    expect_fail("key.pcd", "FIELDS x y z\nSIZES 4 4 4\n", SG_ERR_CORRUPT, "line 2: unknown keyword 'SIZES'");
    expect_fail("nodata.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\n", SG_ERR_CORRUPT, "no DATA line");
    expect_fail("value.pcd", HDR("x y z", "4 4 4", "F F F", "2", "ascii") "1 2 3\n4 five 6\n", SG_ERR_CORRUPT,
                "point 1: field y: 'five' is not a number");
    expect_fail("few.pcd", HDR("x y z", "4 4 4", "F F F", "2", "ascii") "1 2 3\n4 5\n", SG_ERR_CORRUPT,
                "point 1: 2 values, expected 3");
    expect_fail("many.pcd", HDR("x y z", "4 4 4", "F F F", "1", "ascii") "1 2 3 4\n", SG_ERR_CORRUPT,
                "point 0: more than the 3 values");
    expect_fail("trunc.pcd", HDR("x y z", "4 4 4", "F F F", "3", "ascii") "1 2 3\n4 5 6\n", SG_ERR_CORRUPT,
                "point 2: file ends (truncated; POINTS 3)");
    expect_fail("huge.pcd", HDR("x y z", "4 4 4", "F F F", "4000000", "ascii") "1 2 3\n", SG_ERR_CORRUPT,
                "POINTS 4000000 exceeds what the file can hold");
    expect_fail("inf.pcd", HDR("x y z", "4 4 4", "F F F", "1", "ascii") "1 inf 3\n", SG_ERR_CORRUPT,
                "point 0: y is infinite");
    expect_fail("allnan.pcd", HDR("x y z", "4 4 4", "F F F", "1", "ascii") "nan nan nan\n", SG_ERR_CORRUPT,
                "all 1 points are NaN");
    expect_fail("radius.pcd", HDR("x y z radius", "4 4 4 4", "F F F F", "1", "ascii") "1 2 3 0\n", SG_ERR_CORRUPT,
                "point 0: radius 0 is not positive and finite");
    expect_fail("size3.pcd", HDR("x y z", "4 3 4", "F F F", "1", "ascii") "1 2 3\n", SG_ERR_UNSUPPORTED,
                "SIZE of field y: '3' is not 1, 2, 4 or 8");
    expect_fail("empty.pcd", "", SG_ERR_CORRUPT, "no DATA line");
    /* Found by fuzz_pcd: a NaN in an integer rgb field was cast to an
     * integer (undefined behaviour). */
    expect_fail("rgb_nan.pcd", HDR("x y z rgb", "4 4 4 4", "F F F U", "1", "ascii") "1 2 3 nan\n", SG_ERR_CORRUPT,
                "point 0: field rgb: nan is not a packed colour (0 to 4294967295)");
    expect_fail("rgb_neg.pcd", HDR("x y z rgba", "4 4 4 4", "F F F I", "1", "ascii") "1 2 3 -5\n", SG_ERR_CORRUPT,
                "point 0: field rgba: -5 is not a packed colour");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pcd_ascii),
        cmocka_unit_test(test_pcd_binary),
        cmocka_unit_test(test_pcd_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
