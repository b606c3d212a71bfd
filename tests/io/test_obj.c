/* test_obj.c — the OBJ loader (src/io/obj.c).
 *
 * 1. Geometry round trip: v with extra w / colour columns, every corner
 *    form, negative indices, fan triangulation, ignored statements, CRLF.
 * 2. Per-corner normals become normalised per-vertex sums; they stay NULL
 *    when some corner or vertex has none; a faceless file pairs v and vn.
 * 3. Each malformed fixture gives SG_ERR_CORRUPT, a message naming the
 *    file and the line, and leaves *out untouched.
 * 4. The real armadillo loads with the counts of MANIFEST.md.
 */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "io/mesh.h"
#include "io/obj.h"

static const char *write_text(const char *name, const char *text)
{
    return sg_test_write_file(name, text, strlen(text));
}

static sg_mesh read_ok(const char *name, const char *text)
{
    const char *path = write_text(name, text);
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_obj_read(path, &m, &err);
    if (st != SG_OK)
        fail_msg("%s: %s: %s\n--- input ---\n%s", name, sg_status_name(st), err.message, text);
    return m;
}

static void expect_tris(const sg_mesh *m, size_t n, const uint32_t *want, const char *text)
{
    if (m->triangle_count != n)
        fail_msg("%zu triangles, want %zu\n--- input ---\n%s", m->triangle_count, n, text);
    for (size_t i = 0; i < 3 * n; i++) {
        if (m->triangles[i] != want[i])
            fail_msg("triangle %zu corner %zu: got %u, want %u\n--- input ---\n%s", i / 3, i % 3, m->triangles[i],
                     want[i], text);
    }
}

static void expect_vec(const float *got, float x, float y, float z, double tol, const char *what, size_t i)
{
    const float want[3] = {x, y, z};
    for (int a = 0; a < 3; a++) {
        if (!(fabs((double)got[a] - want[a]) <= tol))
            fail_msg("%s %zu: got (%.9g, %.9g, %.9g), want (%.9g, %.9g, %.9g)", what, i, (double)got[0],
                     (double)got[1], (double)got[2], (double)x, (double)y, (double)z);
    }
}

static void test_obj_geometry_roundtrip(void **state)
{
    const char *good = "# a comment\r\n"
                       "mtllib scene.mtl\r\n"
                       "o thing\r\n"
                       "g group\r\n"
                       "v 0 0 0\r\n"
                       "v 1.5 0 0 1.0\r\n"
                       "v 1.5 2.25e0 0 0.1 0.2 0.3\r\n"
                       "v -0 2.25 -3E-1\r\n"
                       "vt 0 0\r\nvt 1 0\r\nvt 1 1\r\n"
                       "vn 0 0 1\r\n"
                       "s off\r\n"
                       "usemtl red\r\n"
                       "f 1 2/1 3/2 4/3\r\n"   /* quad: (0,1,2) (0,2,3) */
                       "f -4//1 -3/1/1 -1\t# trailing comment\r\n"
                       "l 1 2\r\n";
    sg_mesh m = read_ok("geometry.obj", good);
    assert_int_equal(m.vertex_count, 4);
    expect_vec(&m.positions[0], 0, 0, 0, 0, "position", 0);
    expect_vec(&m.positions[3], 1.5f, 0, 0, 0, "position", 1);
    expect_vec(&m.positions[6], 1.5f, 2.25f, 0, 0, "position", 2);
    expect_vec(&m.positions[9], -0.0f, 2.25f, -0.3f, 0, "position", 3);
    const uint32_t want[] = {0, 1, 2, 0, 2, 3, 0, 1, 3};
    expect_tris(&m, 3, want, good);
    /* Some corners have no normal: per-vertex normals are unknowable. */
    assert_null(m.normals);
    assert_null(m.colors);
    assert_null(m.radii);
    sg_mesh_free(&m);
}

static void test_obj_corner_normals_summed_per_vertex(void **state)
{
    /* Two triangles sharing the edge 1-3: at vertices 1 and 3 the corners
     * name vn 1 and vn 2, so they get the normalised sum; vertices 2 and 4
     * only see vn 1 (the second face reaches it as -1). vn 2 is defined
     * after the face that names it: positive indices may point forward. */
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                       "vn 0 0 3\n"
                       "f 1//1 2//1 3//1\n"
                       "f 1/1/2 3//2 4//-1\n"
                       "vn 3 0 0\n";
    sg_mesh m = read_ok("normals.obj", text);
    assert_non_null(m.normals);
    const float s = (float)(1.0 / sqrt(2.0));
    expect_vec(&m.normals[0], s, 0, s, 1e-7, "normal", 0);
    expect_vec(&m.normals[3], 0, 0, 1, 1e-7, "normal", 1);
    expect_vec(&m.normals[6], s, 0, s, 1e-7, "normal", 2);
    expect_vec(&m.normals[9], 0, 0, 1, 1e-7, "normal", 3);
    sg_mesh_free(&m);
}

static void test_obj_normals_cancel_to_unknown(void **state)
{
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 -1\n"
                       "f 1//1 2//1 3//1\nf 1//2 3//2 2//2\n";
    sg_mesh m = read_ok("cancel.obj", text);
    assert_non_null(m.normals);
    for (size_t i = 0; i < 3; i++)
        expect_vec(&m.normals[3 * i], 0, 0, 0, 0, "normal", i);
    sg_mesh_free(&m);
}

static void test_obj_normals_null_when_a_vertex_has_none(void **state)
{
    /* Vertex 4 is used by no face, so it has no normal. */
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nvn 0 0 1\nf 1//1 2//1 3//1\n";
    sg_mesh m = read_ok("lonely.obj", text);
    assert_null(m.normals);
    assert_int_equal(m.triangle_count, 1);
    sg_mesh_free(&m);
}

static void test_obj_point_cloud_pairs_normals(void **state)
{
    const char *text = "vn 0 3 0\nv 1 2 3\nvn 0 0 0\nv 4 5 6\n";
    sg_mesh m = read_ok("cloud.obj", text);
    assert_int_equal(m.vertex_count, 2);
    assert_int_equal(m.triangle_count, 0);
    assert_null(m.triangles);
    assert_non_null(m.normals);
    expect_vec(&m.normals[0], 0, 1, 0, 0, "normal", 0);
    expect_vec(&m.normals[3], 0, 0, 0, 0, "normal", 1);
    sg_mesh_free(&m);
}

static void test_obj_polygon_fan(void **state)
{
    const char *text = "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nf 1 2 3 4 5\n";
    sg_mesh m = read_ok("pentagon.obj", text);
    const uint32_t want[] = {0, 1, 2, 0, 2, 3, 0, 3, 4};
    expect_tris(&m, 3, want, text);
    sg_mesh_free(&m);
}

static void test_obj_relative_indices_count_vertices_so_far(void **state)
{
    /* -1 is the last vertex defined before the face (3), not the last of
     * the file (5). */
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 7 7 7\nv 8 8 8\nf -1 -2 -5\n";
    sg_mesh m = read_ok("relative.obj", text);
    const uint32_t want[] = {0, 1, 2, 4, 3, 0};
    expect_tris(&m, 2, want, text);
    sg_mesh_free(&m);
}

static void test_obj_read_through_mesh_dispatch(void **state)
{
    const char *path = write_text("upper.OBJ", "v 1 2 3\nv 4 5 6\nv 7 8 9\nf 3 2 1\n");
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_mesh_read(path, &m, &err);
    if (st != SG_OK)
        fail_msg("%s: %s: %s", path, sg_status_name(st), err.message);
    const uint32_t want[] = {2, 1, 0};
    expect_tris(&m, 1, want, "v 1 2 3\nv 4 5 6\nv 7 8 9\nf 3 2 1\n");
    sg_mesh_free(&m);
}

/* sg_mesh_read_bounds is the vertex box; sg_mesh_ground_placement scales
 * the longest side to the length, centres x and z, stands the box on y = 0,
 * and refuses a point-sized box. */
static void test_mesh_bounds_and_ground_placement(void **state)
{
    (void)state;
    const char *path = write_text("box.obj", "v -1 2 3\nv 3 4 4\nv 1 2.5 5\nf 1 2 3\n");
    sg_aabb b;
    sg_error err = {0};
    if (sg_mesh_read_bounds(path, &b, &err) != SG_OK)
        fail_msg("%s", err.message);
    expect_vec(&b.lo.x, -1.0f, 2.0f, 3.0f, 0.0, "lo", 0);
    expect_vec(&b.hi.x, 3.0f, 4.0f, 5.0f, 0.0, "hi", 0);
    sg_ground_placement p;
    assert_int_equal(sg_mesh_ground_placement(b, 10.0f, &p, &err), SG_OK);
    assert_true(p.scale == 2.5f); /* longest side 4 -> 10 */
    expect_vec(&p.placed.lo.x, -5.0f, 0.0f, -2.5f, 1e-6, "placed lo", 0);
    expect_vec(&p.placed.hi.x, 5.0f, 5.0f, 2.5f, 1e-6, "placed hi", 0);
    sg_vec3 moved = sg_v3_add(sg_v3_scale(b.hi, p.scale), p.translate);
    expect_vec(&moved.x, 5.0f, 5.0f, 2.5f, 1e-6, "translate + scale hi", 0);
    sg_aabb point = {sg_v3(1, 1, 1), sg_v3(1, 1, 1)};
    assert_int_equal(sg_mesh_ground_placement(point, 10.0f, &p, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "degenerate"));
    assert_int_equal(sg_mesh_ground_placement(sg_aabb_empty(), 10.0f, &p, NULL), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_mesh_read_bounds(write_text("none.obj", "v 1 2\n"), &b, &err), SG_ERR_CORRUPT);
}

/* ---- failures ------------------------------------------------------------ */

static void expect_fail(const char *name, const char *text, sg_status want, const char *frag)
{
    const char *path = write_text(name, text);
    sg_mesh m;
    unsigned char before[sizeof m];
    memset(&m, 0x5A, sizeof m);
    memcpy(before, &m, sizeof m);
    sg_error err = {0};
    sg_status st = sg_obj_read(path, &m, &err);
    if (st != want || !strstr(err.message, name) || !strstr(err.message, frag))
        fail_msg("%s: got %s \"%s\"; want %s with \"%s\"\n--- input ---\n%s", name, sg_status_name(st), err.message,
                 sg_status_name(want), frag, text);
    if (memcmp(before, &m, sizeof m) != 0)
        fail_msg("%s: *out was modified on failure", name);
}

static void test_obj_malformed_number(void **state)
{
    expect_fail("badnum.obj", "v 0 0 0\nv 1 0 0\nv 1 2 x\n", SG_ERR_CORRUPT, "line 3: vertex z: 'x' is not a number");
}

static void test_obj_number_with_trailing_junk(void **state)
{
    expect_fail("junk.obj", "v 0 0 0\nv 1.0.0 0 0\n", SG_ERR_CORRUPT, "line 2: vertex x: '1.0.0' is not a number");
}

static void test_obj_too_few_coordinates(void **state)
{
    expect_fail("short.obj", "v 0 0 0\nv 1 2\n", SG_ERR_CORRUPT, "line 2: vertex has 2 coordinates, needs 3");
}

static void test_obj_normal_too_few_coordinates(void **state)
{
    expect_fail("shortn.obj", "v 0 0 0\nvn 1\n", SG_ERR_CORRUPT, "line 2: normal has 1 coordinates, needs 3");
}

static void test_obj_nan_coordinate(void **state)
{
    expect_fail("nan.obj", "v 0 0 0\nv 0 nan 0\n", SG_ERR_CORRUPT, "line 2: vertex y is NaN");
}

static void test_obj_inf_coordinate(void **state)
{
    expect_fail("inf.obj", "v 0 0 1e39\n", SG_ERR_CORRUPT, "line 1: vertex z is out of float range");
}

static void test_obj_face_index_zero(void **state)
{
    expect_fail("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", SG_ERR_CORRUPT, "line 4: face index 0 is invalid");
}

static void test_obj_face_index_out_of_range(void **state)
{
    const char *text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 0\nv 1 0 1\nv 0 1 1\nv 1 1 1\n"
                       "#\n#\n#\n#\n#\n#\n#\n#\nf 1 2 9\n";
    expect_fail("m.obj", text, SG_ERR_CORRUPT, "line 17: face index 9 out of range (8 vertices)");
}

static void test_obj_face_negative_index_out_of_range(void **state)
{
    /* Relative indices count the vertices defined so far (2), not all 3. */
    expect_fail("neg.obj", "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n", SG_ERR_CORRUPT,
                "line 3: face index -3 out of range (2 vertices)");
}

static void test_obj_face_normal_index_out_of_range(void **state)
{
    expect_fail("nrange.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n", SG_ERR_CORRUPT,
                "line 5: face normal index 2 out of range (1 normals)");
}

static void test_obj_malformed_corner(void **state)
{
    expect_fail("corner.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2/a 3\n", SG_ERR_CORRUPT,
                "line 4: malformed face corner '2/a'");
    expect_fail("corner2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/1/\n", SG_ERR_CORRUPT,
                "line 4: malformed face corner '3/1/'");
    expect_fail("corner4.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2/ 3\n", SG_ERR_CORRUPT,
                "line 4: malformed face corner '2/'");
    expect_fail("corner3.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3//0\n", SG_ERR_CORRUPT,
                "line 4: malformed face corner '3//0'");
}

/* A face of fewer than 3 corners is no polygon: accepted, it used to turn
 * the model into a point cloud of its vertices (one splat filling the
 * frame); now the line and the reason. */
static void test_obj_face_with_fewer_than_3_indices(void **state)
{
    expect_fail("two.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", SG_ERR_CORRUPT,
                "two.obj: line 4: face has 2 vertex indices; a face needs at least 3");
    expect_fail("one.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 3\n", SG_ERR_CORRUPT,
                "one.obj: line 5: face has 1 vertex index; a face needs at least 3");
    expect_fail("none.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n", SG_ERR_CORRUPT,
                "none.obj: line 4: face has 0 vertex indices; a face needs at least 3");
}

static void test_obj_no_vertices(void **state)
{
    expect_fail("empty.obj", "", SG_ERR_CORRUPT, "no vertices");
    expect_fail("comments.obj", "# nothing\nvt 0 0\n", SG_ERR_CORRUPT, "no vertices");
}

static void test_obj_missing_file(void **state)
{
    char path[1100];
    snprintf(path, sizeof path, "%s/absent.obj", sg_test_tmpdir());
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_obj_read(path, &m, &err);
    if (st != SG_ERR_IO || !strstr(err.message, "absent.obj"))
        fail_msg("%s: got %s \"%s\"", path, sg_status_name(st), err.message);
    assert_null(m.positions);
}

/* ---- real file ---------------------------------------------------------- */

static void test_obj_real_armadillo(void **state)
{
    const char *path = sg_test_shared_data("meshes/armadillo/armadillo_50k.obj");
    if (!path)
        skip();
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_mesh_read(path, &m, &err);
    if (st != SG_OK)
        fail_msg("%s: %s: %s", path, sg_status_name(st), err.message);
    if (m.vertex_count != 49990 || m.triangle_count != 99976)
        fail_msg("%s: %zu vertices, %zu triangles; MANIFEST.md says 49990, 99976", path, m.vertex_count,
                 m.triangle_count);
    assert_null(m.normals);
    for (size_t i = 0; i < 3 * m.triangle_count; i++) {
        if (m.triangles[i] >= m.vertex_count)
            fail_msg("triangle index %zu is %u", i, m.triangles[i]);
    }
    /* First vertex of the file: "v 12.759519 -2.470218 19.806297". */
    expect_vec(m.positions, 12.759519f, -2.470218f, 19.806297f, 0, "position", 0);
    sg_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_obj_geometry_roundtrip),
        cmocka_unit_test(test_obj_corner_normals_summed_per_vertex),
        cmocka_unit_test(test_obj_normals_cancel_to_unknown),
        cmocka_unit_test(test_obj_normals_null_when_a_vertex_has_none),
        cmocka_unit_test(test_obj_point_cloud_pairs_normals),
        cmocka_unit_test(test_obj_polygon_fan),
        cmocka_unit_test(test_obj_relative_indices_count_vertices_so_far),
        cmocka_unit_test(test_obj_read_through_mesh_dispatch),
        cmocka_unit_test(test_mesh_bounds_and_ground_placement),
        cmocka_unit_test(test_obj_malformed_number),
        cmocka_unit_test(test_obj_number_with_trailing_junk),
        cmocka_unit_test(test_obj_too_few_coordinates),
        cmocka_unit_test(test_obj_normal_too_few_coordinates),
        cmocka_unit_test(test_obj_nan_coordinate),
        cmocka_unit_test(test_obj_inf_coordinate),
        cmocka_unit_test(test_obj_face_index_zero),
        cmocka_unit_test(test_obj_face_index_out_of_range),
        cmocka_unit_test(test_obj_face_negative_index_out_of_range),
        cmocka_unit_test(test_obj_face_normal_index_out_of_range),
        cmocka_unit_test(test_obj_malformed_corner),
        cmocka_unit_test(test_obj_face_with_fewer_than_3_indices),
        cmocka_unit_test(test_obj_no_vertices),
        cmocka_unit_test(test_obj_missing_file),
        cmocka_unit_test(test_obj_real_armadillo),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
