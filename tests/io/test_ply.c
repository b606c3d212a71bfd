/* test_ply.c — the PLY loader (src/io/ply.c) and the model dispatch
 * (src/io/mesh.c).
 *
 * 1. One model written as ascii (CRLF), binary little endian (CRLF header)
 *    and binary big endian reads back exactly: doubles, short and list
 *    properties of unusual types that must be skipped, uchar and float
 *    colours under both naming schemes, radii, a quad that is fanned and a
 *    2-index face that is dropped, and an unknown element after the faces.
 * 2. Unusable normals become (0,0,0) without failing the load.
 * 3. Every malformed fixture gives the exact status, a message naming the
 *    file and the element, and leaves *out untouched.
 * 4. Every truncation of a binary fixture is SG_ERR_CORRUPT; every
 *    truncation of an ascii fixture is SG_OK or SG_ERR_CORRUPT.
 * 5. The real files of ../shared/data load with the counts of MANIFEST.md.
 */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/mesh.h"
#include "io/ply.h"

/* ---- fixture writer ---------------------------------------------------- */

typedef struct bytes {
    unsigned char d[16384]; /* fixture bytes      */
    size_t n;               /* bytes used         */
    bool be;                /* binary byte order  */
} bytes;

static void put_raw(bytes *b, uint64_t v, unsigned size)
{
    assert_true(b->n + size <= sizeof b->d);
    for (unsigned i = 0; i < size; i++) {
        unsigned shift = 8 * (b->be ? size - 1 - i : i);
        b->d[b->n++] = (unsigned char)(v >> shift);
    }
}
static void put_u8(bytes *b, unsigned v) { put_raw(b, v, 1); }
static void put_i8(bytes *b, int v) { put_raw(b, (uint8_t)(int8_t)v, 1); }
static void put_i16(bytes *b, int v) { put_raw(b, (uint16_t)(int16_t)v, 2); }
static void put_u16(bytes *b, unsigned v) { put_raw(b, (uint16_t)v, 2); }
static void put_i32(bytes *b, int32_t v) { put_raw(b, (uint32_t)v, 4); }
static void put_u32(bytes *b, uint32_t v) { put_raw(b, v, 4); }
static void put_f32(bytes *b, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_raw(b, u, 4);
}
static void put_f64(bytes *b, double f)
{
    uint64_t u;
    memcpy(&u, &f, 8);
    put_raw(b, u, 8);
}
static void put_str(bytes *b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf((char *)b->d + b->n, sizeof b->d - b->n, fmt, ap);
    va_end(ap);
    assert_true(n >= 0 && b->n + (size_t)n < sizeof b->d);
    b->n += (size_t)n;
}

static const char *write_bytes(const char *name, const bytes *b) { return sg_test_write_file(name, b->d, b->n); }
static const char *write_text(const char *name, const char *text)
{
    return sg_test_write_file(name, text, strlen(text));
}

/* ---- the round-trip model ---------------------------------------------- */

typedef enum fixture_format { FX_ASCII, FX_LE, FX_BE } fixture_format;

static const double VPOS[4][3] = {{0.5, -1.25, 2.0}, {0.1, 3.0, -7.0}, {-100.25, 0.0, 1e-5}, {12345.5, -0.001, 42.0}};
static const float VNRM[4][3] = {{0, 0, 2}, {3, 4, 0}, {0, -1, 0}, {0, 0, 0}};
static const float WANT_NRM[4][3] = {{0, 0, 1}, {0.6f, 0.8f, 0}, {0, -1, 0}, {0, 0, 0}};
static const unsigned VCOL8[4][3] = {{255, 0, 128}, {10, 20, 30}, {0, 0, 0}, {255, 255, 255}};
static const float VCOLF[4][3] = {{1.5f, -0.2f, 0.25f}, {0.5f, 0.5f, 0.5f}, {0, 0, 0}, {1, 1, 1}};
static const float WANT_COLF[4][3] = {{1, 0, 0.25f}, {0.5f, 0.5f, 0.5f}, {0, 0, 0}, {1, 1, 1}};
static const float VRAD[4] = {0.01f, 0.02f, 0.5f, 1.0f};
static const int VFLAGS[4] = {-3, 7, 0, 32767};
static const unsigned VEXTRA_LEN[4] = {0, 2, 1, 3};
static const unsigned FACE_LEN[3] = {3, 4, 3};
static const unsigned FACE_IDX[3][4] = {{0, 1, 2}, {0, 2, 3, 1}, {1, 3, 2}};
static const uint32_t WANT_TRI[4][3] = {{0, 1, 2}, {0, 2, 3}, {0, 3, 1}, {1, 3, 2}};

/* Independent of the loader's table: IEC 61966-2-1 decode. */
static double srgb_decode(double c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }

/* ascii: uchar red/green/blue, list uchar int vertex_indices, CRLF lines.
 * LE: float diffuse_*, list uint int vertex_indices, CRLF header.
 * BE: uchar diffuse_*, list ushort uint vertex_index, LF header. */
static void build_model(fixture_format fx, bytes *b)
{
    static const char *const FMT[3] = {"ascii", "binary_little_endian", "binary_big_endian"};
    static const char *const COLOR_DECL[3] = {"uchar red", "float diffuse_red", "uchar diffuse_red"};
    const char *eol = fx == FX_BE ? "\n" : "\r\n";
    const bool float_color = fx == FX_LE;
    memset(b, 0, sizeof *b);
    b->be = fx == FX_BE;
    put_str(b, "ply%sformat %s 1.0%scomment written by test_ply%sobj_info any text%s", eol, FMT[fx], eol, eol, eol);
    put_str(b, "element vertex 4%sproperty double x%sproperty float64 y%sproperty double z%s", eol, eol, eol, eol);
    put_str(b, "property short flags%sproperty float nx%sproperty float ny%sproperty float32 nz%s", eol, eol, eol, eol);
    put_str(b, "property list uint int extra%s", eol);
    const char *cbase = COLOR_DECL[fx];
    const char *cname = strchr(cbase, ' ') + 1;
    const char *ctype = float_color ? "float" : "uchar";
    const char *prefix = strncmp(cname, "diffuse_", 8) == 0 ? "diffuse_" : "";
    put_str(b, "property %s %sred%sproperty %s %sgreen%sproperty %s %sblue%s", ctype, prefix, eol, ctype, prefix,
            eol, ctype, prefix, eol);
    put_str(b, "property float radius%s", eol);
    put_str(b, "element face 3%s", eol);
    if (fx == FX_ASCII)
        put_str(b, "property list uchar int vertex_indices%s", eol);
    else if (fx == FX_LE)
        put_str(b, "property list uint int vertex_indices%s", eol);
    else
        put_str(b, "property list ushort uint vertex_index%s", eol);
    put_str(b, "property int flags%selement edge 2%sproperty int vertex1%sproperty int vertex2%s", eol, eol, eol,
            eol);
    put_str(b, "property list char uchar labels%send_header%s", eol, eol);

    for (int i = 0; i < 4; i++) {
        if (fx == FX_ASCII) {
            put_str(b, "%.17g %.17g %.17g %d %.9g %.9g %.9g %u", VPOS[i][0], VPOS[i][1], VPOS[i][2], VFLAGS[i],
                    VNRM[i][0], VNRM[i][1], VNRM[i][2], VEXTRA_LEN[i]);
            for (unsigned j = 0; j < VEXTRA_LEN[i]; j++)
                put_str(b, " %d", -1000 * (int)j - 5);
            put_str(b, " %u %u %u %.9g%s", VCOL8[i][0], VCOL8[i][1], VCOL8[i][2], VRAD[i], eol);
            continue;
        }
        for (int a = 0; a < 3; a++)
            put_f64(b, VPOS[i][a]);
        put_i16(b, VFLAGS[i]);
        for (int a = 0; a < 3; a++)
            put_f32(b, VNRM[i][a]);
        put_u32(b, VEXTRA_LEN[i]);
        for (unsigned j = 0; j < VEXTRA_LEN[i]; j++)
            put_i32(b, -1000 * (int)j - 5);
        for (int a = 0; a < 3; a++) {
            if (float_color)
                put_f32(b, VCOLF[i][a]);
            else
                put_u8(b, VCOL8[i][a]);
        }
        put_f32(b, VRAD[i]);
    }
    for (int f = 0; f < 3; f++) {
        if (fx == FX_ASCII) {
            put_str(b, "%u", FACE_LEN[f]);
            for (unsigned j = 0; j < FACE_LEN[f]; j++)
                put_str(b, " %u", FACE_IDX[f][j]);
            put_str(b, " %d%s", 100 + f, eol);
            continue;
        }
        if (fx == FX_LE)
            put_u32(b, FACE_LEN[f]);
        else
            put_u16(b, FACE_LEN[f]);
        for (unsigned j = 0; j < FACE_LEN[f]; j++)
            put_u32(b, FACE_IDX[f][j]); /* int and uint share the bytes */
        put_i32(b, 100 + f);
    }
    /* edge 0: labels []; edge 1: labels [1 2 3] */
    if (fx == FX_ASCII) {
        put_str(b, "0 1 0%s2 3 3 1 2 3%s", eol, eol);
    } else {
        put_i32(b, 0);
        put_i32(b, 1);
        put_i8(b, 0);
        put_i32(b, 2);
        put_i32(b, 3);
        put_i8(b, 3);
        put_u8(b, 1);
        put_u8(b, 2);
        put_u8(b, 3);
    }
}

static void expect_near(float got, double want, double tol, const char *what, int i, int a)
{
    if (!(fabs((double)got - want) <= tol))
        fail_msg("%s[%d][%d]: got %.9g, want %.9g (tol %g)", what, i, a, (double)got, want, tol);
}

static void check_model(fixture_format fx, const sg_mesh *m)
{
    assert_int_equal(m->vertex_count, 4);
    assert_non_null(m->normals);
    assert_non_null(m->colors);
    assert_non_null(m->radii);
    for (int i = 0; i < 4; i++) {
        for (int a = 0; a < 3; a++) {
            expect_near(m->positions[3 * i + a], (float)VPOS[i][a], 0.0, "position", i, a);
            expect_near(m->normals[3 * i + a], WANT_NRM[i][a], 1e-7, "normal", i, a);
            double want = fx == FX_LE ? WANT_COLF[i][a] : srgb_decode(VCOL8[i][a] / 255.0);
            expect_near(m->colors[3 * i + a], want, 1e-6, "color", i, a);
        }
        expect_near(m->radii[i], VRAD[i], 0.0, "radius", i, 0);
    }
    assert_int_equal(m->triangle_count, 4);
    assert_non_null(m->triangles);
    for (int t = 0; t < 4; t++) {
        for (int a = 0; a < 3; a++) {
            if (m->triangles[3 * t + a] != WANT_TRI[t][a])
                fail_msg("triangle %d corner %d: got %u, want %u", t, a, m->triangles[3 * t + a], WANT_TRI[t][a]);
        }
    }
}

static void roundtrip(fixture_format fx, const char *name)
{
    bytes b;
    build_model(fx, &b);
    const char *path = write_bytes(name, &b);
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_ply_read(path, &m, &err);
    if (st != SG_OK)
        fail_msg("%s: %s: %s", name, sg_status_name(st), err.message);
    check_model(fx, &m);
    sg_mesh_free(&m);
    assert_null(m.positions);
}

static void test_ply_ascii_roundtrip(void **state) { roundtrip(FX_ASCII, "model_ascii.ply"); }
static void test_ply_binary_le_roundtrip(void **state) { roundtrip(FX_LE, "model_le.ply"); }
static void test_ply_binary_be_roundtrip(void **state) { roundtrip(FX_BE, "model_be.ply"); }

/* ---- failure checks ---------------------------------------------------- */

/* Reads path expecting status `want` and a message holding the fixture's
 * file name and every fragment; *out must stay byte-for-byte untouched. */
static void expect_fail_with(sg_status (*reader)(const char *, sg_mesh *, sg_error *), const char *path,
                             sg_status want, const char *frag1, const char *frag2)
{
    sg_mesh m;
    unsigned char before[sizeof m];
    memset(&m, 0xA5, sizeof m);
    memcpy(before, &m, sizeof m);
    sg_error err = {0};
    sg_status st = reader(path, &m, &err);
    const char *name = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    if (st != want || !strstr(err.message, name) || (frag1 && !strstr(err.message, frag1)) ||
        (frag2 && !strstr(err.message, frag2)))
        fail_msg("%s: got %s \"%s\"; want %s with \"%s\" and \"%s\"", path, sg_status_name(st), err.message,
                 sg_status_name(want), frag1 ? frag1 : "", frag2 ? frag2 : "");
    if (memcmp(before, &m, sizeof m) != 0)
        fail_msg("%s: *out was modified on failure (%s)", path, err.message);
}

static void expect_fail(const char *path, sg_status want, const char *frag1, const char *frag2)
{
    expect_fail_with(sg_ply_read, path, want, frag1, frag2);
}

#define XYZ_HEADER "property float x\nproperty float y\nproperty float z\n"

static void test_ply_truncated_binary_body(void **state)
{
    bytes b;
    build_model(FX_LE, &b);
    /* Cut inside face 1's index list: the 4 vertices and face 0 are whole,
     * so the header's size check passes and the body read must notice. */
    const char *mark = "end_header\r\n";
    size_t body = 0;
    for (size_t i = 0; i + strlen(mark) <= b.n; i++) {
        if (memcmp(b.d + i, mark, strlen(mark)) == 0) {
            body = i + strlen(mark);
            break;
        }
    }
    assert_true(body > 0);
    size_t vertex_bytes = 0;
    for (int i = 0; i < 4; i++)
        vertex_bytes += 24 + 2 + 12 + 4 + 4 * VEXTRA_LEN[i] + 12 + 4;
    size_t face0 = 4 + 3 * 4 + 4;
    b.n = body + vertex_bytes + face0 + 4 + 8; /* face 1: count + 2 of 4 indices */
    expect_fail(write_bytes("trunc_bin.ply", &b), SG_ERR_CORRUPT, "face 1: ", "truncated");
}

static void test_ply_truncated_ascii_body(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 3\n" XYZ_HEADER
                       "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                       "0.000 0.000 0.000\n1.000 0.000 0.000\n0.000 1.000";
    expect_fail(write_text("trunc_ascii.ply", text), SG_ERR_CORRUPT, "vertex 2: ", "truncated");
}

static void test_ply_truncated_vertex_section_caught_by_header(void **state)
{
    bytes b = {.be = false};
    put_str(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 3\n" XYZ_HEADER "end_header\n");
    for (int i = 0; i < 8; i++) /* 8 of the 9 floats */
        put_f32(&b, (float)i);
    expect_fail(write_bytes("short_vertices.ply", &b), SG_ERR_CORRUPT,
                "header: vertex count 3 exceeds what the file can hold (32 bytes)", NULL);
}

static void test_ply_missing_end_header(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_HEADER;
    expect_fail(write_text("no_end.ply", text), SG_ERR_CORRUPT, "header: missing end_header", NULL);
}

static void test_ply_data_before_end_header(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_HEADER "0 0 0\nend_header\n0 0 0\n";
    expect_fail(write_text("no_end_data.ply", text), SG_ERR_CORRUPT, "header: line 7: data before end_header",
                NULL);
}

static void test_ply_count_exceeds_file(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 4000000000\n" XYZ_HEADER "end_header\n0 0 0\n";
    expect_fail(write_text("huge_count.ply", text), SG_ERR_CORRUPT,
                "header: vertex count 4000000000 exceeds what the file can hold (6 bytes)", NULL);
}

static void test_ply_face_count_exceeds_file(void **state)
{
    bytes b = {.be = true};
    put_str(&b, "ply\nformat binary_big_endian 1.0\nelement vertex 1\n" XYZ_HEADER
                "element face 1000\nproperty list uchar int vertex_indices\nend_header\n");
    put_f32(&b, 1);
    put_f32(&b, 2);
    put_f32(&b, 3);
    put_u8(&b, 0);
    expect_fail(write_bytes("huge_faces.ply", &b), SG_ERR_CORRUPT, "header: face count 1000 exceeds", NULL);
}

static void test_ply_count_overflows_size(void **state)
{
    const char *text = "ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\n" XYZ_HEADER
                       "end_header\n";
    expect_fail(write_text("overflow.ply", text), SG_ERR_NOMEM, "header: vertex count 18446744073709551615",
                "overflows");
}

static void test_ply_count_overflows_64_bits(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\n" XYZ_HEADER "end_header\n";
    expect_fail(write_text("overflow64.ply", text), SG_ERR_NOMEM, "header: vertex count 99999999999999999999999",
                "overflows");
}

static void test_ply_count_sum_overflows(void **state)
{
    /* Each product fits; their sum does not. */
    const char *text = "ply\nformat binary_little_endian 1.0\nelement vertex 1537228672809129301\n" XYZ_HEADER
                       "element junk 1537228672809129301\nproperty double a\nend_header\n";
    expect_fail(write_text("overflow_sum.ply", text), SG_ERR_NOMEM, "header: junk count", "overflows");
}

static void test_ply_bad_count_text(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex -4\n" XYZ_HEADER "end_header\n";
    expect_fail(write_text("neg_count.ply", text), SG_ERR_CORRUPT, "header: line 3: vertex count '-4'", NULL);
}

static void test_ply_nan_coordinate_ascii(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 2\n" XYZ_HEADER "end_header\n0 0 0\nnan 1 2\n";
    expect_fail(write_text("nan.ply", text), SG_ERR_CORRUPT, "vertex 1: x is NaN", NULL);
}

static void test_ply_inf_coordinate_binary(void **state)
{
    bytes b = {.be = false};
    put_str(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 1\n" XYZ_HEADER "end_header\n");
    put_f32(&b, 1);
    put_f32(&b, INFINITY);
    put_f32(&b, 3);
    expect_fail(write_bytes("inf.ply", &b), SG_ERR_CORRUPT, "vertex 0: y is infinite", NULL);
}

static void test_ply_double_out_of_float_range(void **state)
{
    bytes b = {.be = false};
    put_str(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\nproperty double y\n"
                "property double z\nend_header\n");
    put_f64(&b, 1);
    put_f64(&b, 2);
    put_f64(&b, -1e300);
    expect_fail(write_bytes("far.ply", &b), SG_ERR_CORRUPT, "vertex 0: z -1e+300 is out of float range", NULL);
}

static void test_ply_unusable_normals_become_unknown(void **state)
{
    bytes b = {.be = false};
    put_str(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 4\n" XYZ_HEADER
                "property double nx\nproperty double ny\nproperty double nz\nend_header\n");
    const double n[4][3] = {{0, 0, 0}, {NAN, 0, 1}, {0, INFINITY, 0}, {0, 0, -0.5}};
    const float want[4][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, -1}};
    for (int i = 0; i < 4; i++) {
        for (int a = 0; a < 3; a++)
            put_f32(&b, (float)i);
        for (int a = 0; a < 3; a++)
            put_f64(&b, n[i][a]);
    }
    const char *path = write_bytes("bad_normals.ply", &b);
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_ply_read(path, &m, &err);
    if (st != SG_OK)
        fail_msg("%s: %s", sg_status_name(st), err.message);
    assert_non_null(m.normals);
    for (int i = 0; i < 4; i++) {
        for (int a = 0; a < 3; a++)
            expect_near(m.normals[3 * i + a], want[i][a], 0.0, "normal", i, a);
    }
    sg_mesh_free(&m);
}

static void test_ply_radius_nan(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 2\n" XYZ_HEADER
                       "property float radius\nend_header\n0 0 0 1\n1 1 1 NaN\n";
    expect_fail(write_text("radius_nan.ply", text), SG_ERR_CORRUPT, "vertex 1: radius is NaN", NULL);
}

static void test_ply_radius_negative(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_HEADER
                       "property float radius\nend_header\n0 0 0 -0.5\n";
    expect_fail(write_text("radius_neg.ply", text), SG_ERR_CORRUPT, "vertex 0: radius -0.5 is not positive", NULL);
}

static void test_ply_color_nan(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_HEADER
                       "property float red\nproperty float green\nproperty float blue\nend_header\n0 0 0 1 nan 0\n";
    expect_fail(write_text("color_nan.ply", text), SG_ERR_CORRUPT, "vertex 0: green is NaN", NULL);
}

static void test_ply_color_int_unsupported(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_HEADER
                       "property int red\nproperty int green\nproperty int blue\nend_header\n0 0 0 1 2 3\n";
    expect_fail(write_text("color_int.ply", text), SG_ERR_UNSUPPORTED, "header: vertex: colour red has type int",
                NULL);
}

/* A face of fewer than 3 indices is no polygon (it used to be dropped
 * quietly, leaving a point cloud when every face was like it). */
static void test_ply_face_with_fewer_than_3_indices(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 3\n" XYZ_HEADER
                       "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                       "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n2 0 1\n";
    expect_fail(write_text("two_index_face.ply", text), SG_ERR_CORRUPT,
                "face 1: 2 vertex indices; a face needs at least 3", NULL);
}

/* Triangle strips (element tristrips, -1 ends a strip): strip triangle k
 * is (v_k, v_k+1, v_k+2), the first two swapped for odd k so that every
 * triangle keeps the strip's winding; triangles with a repeated vertex
 * (stitching) are dropped. Faces and strips in one file both count. */
static void test_ply_tristrips(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 8\n" XYZ_HEADER
                       "element tristrips 2\nproperty list int int vertex_indices\n"
                       "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                       "0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 0 0\n2 1 0\n3 0 0\n3 1 0\n"
                       "8 0 1 2 3 -1 3 4 5\n"
                       "5 4 5 5 6 7\n"
                       "3 0 2 1\n";
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_ply_read(write_text("strips.ply", text), &m, &err);
    if (st != SG_OK)
        fail_msg("%s", err.message);
    /* strip 1 = 4 5 5 6 7: k0 (4,5,5) and k1 (5,5,6) have a repeated
     * vertex; k2 is even again: (5,6,7), as OpenGL draws it. */
    static const uint32_t expect[][3] = {{0, 1, 2}, {2, 1, 3}, {3, 4, 5}, {5, 6, 7}, {0, 2, 1}};
    size_t n = sizeof expect / sizeof expect[0];
    if (m.triangle_count != n)
        fail_msg("%zu triangles, want %zu", m.triangle_count, n);
    /* Strips first (file order: the tristrips element comes first). */
    for (size_t t = 0; t < n; ++t)
        for (int a = 0; a < 3; ++a)
            if (m.triangles[3 * t + a] != expect[t][a])
                fail_msg("triangle %zu corner %d: %u, want %u", t, a, m.triangles[3 * t + a], expect[t][a]);
    sg_mesh_free(&m);

    /* Binary big-endian strip, uint indices with 0xFFFFFFFF as the end. */
    bytes b;
    memset(&b, 0, sizeof b);
    b.be = true;
    put_str(&b, "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                "property float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n");
    for (int v = 0; v < 4; ++v) {
        put_f32(&b, (float)(v & 1));
        put_f32(&b, (float)(v >> 1));
        put_f32(&b, 0.0f);
    }
    put_i32(&b, 5);
    put_i32(&b, 0);
    put_i32(&b, 1);
    put_i32(&b, 2);
    put_i32(&b, 3);
    put_i32(&b, -1);
    st = sg_ply_read(write_bytes("strips_be.ply", &b), &m, &err);
    if (st != SG_OK)
        fail_msg("%s", err.message);
    assert_int_equal(m.triangle_count, 2);
    assert_true(m.triangles[3] == 2 && m.triangles[4] == 1 && m.triangles[5] == 3);
    sg_mesh_free(&m);

    /* Bad strips: an index out of range, a negative index other than -1. */
    text = "ply\nformat ascii 1.0\nelement vertex 3\n" XYZ_HEADER
           "element tristrips 1\nproperty list int int vertex_indices\nend_header\n"
           "0 0 0\n1 0 0\n0 1 0\n4 0 1 2 7\n";
    expect_fail(write_text("strip_range.ply", text), SG_ERR_CORRUPT,
                "tristrips 0: vertex index 7 out of range (3 vertices)", NULL);
    text = "ply\nformat ascii 1.0\nelement vertex 3\n" XYZ_HEADER
           "element tristrips 1\nproperty list int int vertex_indices\nend_header\n"
           "0 0 0\n1 0 0\n0 1 0\n4 0 1 2 -2\n";
    expect_fail(write_text("strip_neg.ply", text), SG_ERR_CORRUPT,
                "tristrips 0: negative vertex index -2 (only -1 may end a strip)", NULL);
}

static void test_ply_face_index_out_of_range(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 3\n" XYZ_HEADER
                       "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                       "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 9 2\n";
    expect_fail(write_text("index_range.ply", text), SG_ERR_CORRUPT, "face 1: vertex index 9 out of range (3 vertices)",
                NULL);
}

static void test_ply_face_negative_index(void **state)
{
    bytes b = {.be = false};
    put_str(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 3\n" XYZ_HEADER
                "element face 1\nproperty list uchar int vertex_indices\nend_header\n");
    for (int i = 0; i < 9; i++)
        put_f32(&b, (float)i);
    put_u8(&b, 3);
    put_i32(&b, 0);
    put_i32(&b, -1);
    put_i32(&b, 2);
    expect_fail(write_bytes("index_neg.ply", &b), SG_ERR_CORRUPT, "face 0: negative vertex index -1", NULL);
}

static void test_ply_list_count_runs_past_file(void **state)
{
    bytes b = {.be = false};
    put_str(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 3\n" XYZ_HEADER
                "element face 1\nproperty list uchar int vertex_indices\nend_header\n");
    for (int i = 0; i < 9; i++)
        put_f32(&b, (float)i);
    put_u8(&b, 255);
    put_i32(&b, 0);
    put_i32(&b, 1);
    expect_fail(write_bytes("list255.ply", &b), SG_ERR_CORRUPT,
                "face 0: list vertex_indices of 255 items runs past the end of the file (truncated)", NULL);
}

static void test_ply_list_negative_length(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 3\n" XYZ_HEADER
                       "element face 1\nproperty list int int vertex_indices\nend_header\n"
                       "0 0 0\n1 0 0\n0 1 0\n-1 0 1 2\n";
    expect_fail(write_text("list_neg.ply", text), SG_ERR_CORRUPT, "face 0: list vertex_indices has negative length",
                NULL);
}

static void test_ply_ascii_list_count_out_of_type_range(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 3\n" XYZ_HEADER
                       "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                       "0 0 0\n1 0 0\n0 1 0\n2.5 0 1 2\n";
    expect_fail(write_text("list_frac.ply", text), SG_ERR_CORRUPT, "face 0: vertex_indices: '2.5' is not a valid uchar",
                NULL);
}

static void test_ply_ascii_malformed_number(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 2\n" XYZ_HEADER "end_header\n0 0 0\n1 0.5abc 0\n";
    expect_fail(write_text("malformed.ply", text), SG_ERR_CORRUPT, "vertex 1: y: '0.5abc' is not a number", NULL);
}

static void test_ply_empty_file(void **state)
{
    expect_fail(sg_test_write_file("empty.ply", "", 0), SG_ERR_CORRUPT, "header: empty file", NULL);
}

static void test_ply_not_a_ply(void **state)
{
    expect_fail(write_text("notply.ply", "solid cube\nendsolid\n"), SG_ERR_CORRUPT, "header: not a PLY file", NULL);
}

static void test_ply_wrong_type_name(void **state)
{
    bytes b = {.be = false};
    put_str(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty flot x\nproperty float y\n"
                "property float z\nend_header\n");
    put_f32(&b, 1);
    put_f32(&b, 2);
    put_f32(&b, 3);
    expect_fail(write_bytes("badtype.ply", &b), SG_ERR_CORRUPT, "header: line 4: vertex x: unknown property type 'flot'",
                NULL);
}

static void test_ply_float_list_count_type(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_HEADER
                       "element face 0\nproperty list float int vertex_indices\nend_header\n0 0 0\n";
    expect_fail(write_text("float_count.ply", text), SG_ERR_CORRUPT, "face vertex_indices: list count type float",
                NULL);
}

static void test_ply_float_index_type(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_HEADER
                       "element face 0\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n";
    expect_fail(write_text("float_index.ply", text), SG_ERR_CORRUPT, "face: vertex_indices index type float", NULL);
}

static void test_ply_unknown_format(void **state)
{
    const char *text = "ply\nformat binary_middle_endian 1.0\nelement vertex 1\n" XYZ_HEADER "end_header\n";
    expect_fail(write_text("middle.ply", text), SG_ERR_UNSUPPORTED, "unknown format 'binary_middle_endian'", NULL);
}

static void test_ply_missing_format(void **state)
{
    const char *text = "ply\nelement vertex 1\n" XYZ_HEADER "end_header\n0 0 0\n";
    expect_fail(write_text("noformat.ply", text), SG_ERR_CORRUPT, "header: missing format line", NULL);
}

static void test_ply_unknown_keyword(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelemnt vertex 1\n" XYZ_HEADER "end_header\n0 0 0\n";
    expect_fail(write_text("keyword.ply", text), SG_ERR_CORRUPT, "header: line 3: unknown keyword 'elemnt'", NULL);
}

static void test_ply_property_before_element(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nproperty float x\nend_header\n";
    expect_fail(write_text("orphan.ply", text), SG_ERR_CORRUPT, "header: line 3: property before any element", NULL);
}

static void test_ply_duplicate_element(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_HEADER "element vertex 1\n" XYZ_HEADER
                       "end_header\n0 0 0\n0 0 0\n";
    expect_fail(write_text("twice.ply", text), SG_ERR_CORRUPT, "element vertex declared twice", NULL);
}

static void test_ply_missing_xyz(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                       "property float w\nend_header\n0 0 0\n";
    expect_fail(write_text("noxyz.ply", text), SG_ERR_UNSUPPORTED, "vertex: no x,y,z vertex properties", NULL);
}

static void test_ply_zero_vertices(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 0\n" XYZ_HEADER "end_header\n";
    expect_fail(write_text("novertex.ply", text), SG_ERR_CORRUPT, "no vertices", NULL);
}

static void test_ply_no_vertex_element(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement point 1\n" XYZ_HEADER "end_header\n0 0 0\n";
    expect_fail(write_text("novertex_elem.ply", text), SG_ERR_CORRUPT, "header: no vertices", NULL);
}

static void test_ply_face_without_index_list(void **state)
{
    const char *text = "ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_HEADER
                       "element face 1\nproperty list uchar int corners\nend_header\n0 0 0\n0\n";
    expect_fail(write_text("face_nolist.ply", text), SG_ERR_UNSUPPORTED, "face: no vertex_indices", NULL);
}

static void test_ply_missing_file(void **state)
{
    char path[1100];
    snprintf(path, sizeof path, "%s/does_not_exist.ply", sg_test_tmpdir());
    expect_fail(path, SG_ERR_IO, "cannot open", NULL);
}

static void test_ply_directory_is_io_error(void **state)
{
    char path[1100];
    snprintf(path, sizeof path, "%s/folder.ply", sg_test_tmpdir());
    assert_int_equal(mkdir(path, 0777), 0);
    expect_fail(path, SG_ERR_IO, "not a regular file", NULL);
}

/* Invariant 2/3 of ply.c from outside: no cut of a valid file crashes,
 * hangs or half-succeeds. Binary bodies use every byte, so every cut must
 * fail; an ascii cut may still parse (e.g. "42" cut to "4"). */
static void truncation_sweep(fixture_format fx, const char *name)
{
    bytes full;
    build_model(fx, &full);
    char path[1100];
    snprintf(path, sizeof path, "%s", write_bytes(name, &full));
    /* Shortening one file in place is far cheaper than writing ~1000. */
    for (size_t n = full.n; n-- > 0;) {
        assert_int_equal(truncate(path, (off_t)n), 0);
        sg_mesh m = {0};
        sg_error err = {0};
        sg_status st = sg_ply_read(path, &m, &err);
        bool ok = fx == FX_ASCII ? (st == SG_OK || st == SG_ERR_CORRUPT) : st == SG_ERR_CORRUPT;
        if (!ok || (st != SG_OK && !strstr(err.message, name)))
            fail_msg("%s cut to %zu of %zu bytes: %s \"%s\"", name, n, full.n, sg_status_name(st), err.message);
        sg_mesh_free(&m);
    }
}

static void test_ply_every_truncation_fails_cleanly_binary(void **state)
{
    truncation_sweep(FX_LE, "sweep_le.ply");
    truncation_sweep(FX_BE, "sweep_be.ply");
}

static void test_ply_every_truncation_fails_cleanly_ascii(void **state) { truncation_sweep(FX_ASCII, "sweep.ply"); }

/* ---- dispatch ------------------------------------------------------------ */

static void test_mesh_read_dispatches_case_insensitive(void **state)
{
    bytes b;
    build_model(FX_BE, &b);
    const char *path = write_bytes("UPPER.PlY", &b);
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_mesh_read(path, &m, &err);
    if (st != SG_OK)
        fail_msg("%s: %s: %s", path, sg_status_name(st), err.message);
    check_model(FX_BE, &m);
    sg_mesh_free(&m);
}

static void test_mesh_read_unknown_extension(void **state)
{
    bytes b;
    build_model(FX_ASCII, &b);
    expect_fail_with(sg_mesh_read, write_bytes("model.stl", &b), SG_ERR_UNSUPPORTED, "unsupported model format",
                     NULL);
    char path[1100];
    snprintf(path, sizeof path, "%s/dir.ply/model", sg_test_tmpdir());
    expect_fail_with(sg_mesh_read, path, SG_ERR_UNSUPPORTED, "unsupported model format", NULL);
}

/* ---- real files ---------------------------------------------------------- */

typedef struct real_case {
    const char *rel;       /* path under ../shared/data               */
    size_t vertices;       /* from MANIFEST.md                        */
    size_t triangles;      /* from MANIFEST.md (all are triangles)    */
    bool normals, colors;  /* what the file carries                   */
    bool zero_normals;     /* some normals are zero-length in the file */
} real_case;

static void check_real(const real_case *c)
{
    const char *path = sg_test_shared_data(c->rel);
    if (!path)
        skip();
    sg_mesh m = {0};
    sg_error err = {0};
    sg_status st = sg_mesh_read(path, &m, &err);
    if (st != SG_OK)
        fail_msg("%s: %s: %s", c->rel, sg_status_name(st), err.message);
    if (m.vertex_count != c->vertices || m.triangle_count != c->triangles)
        fail_msg("%s: %zu vertices, %zu triangles; MANIFEST.md says %zu, %zu", c->rel, m.vertex_count,
                 m.triangle_count, c->vertices, c->triangles);
    if ((m.normals != NULL) != c->normals || (m.colors != NULL) != c->colors)
        fail_msg("%s: normals %s, colours %s", c->rel, m.normals ? "yes" : "no", m.colors ? "yes" : "no");
    for (size_t i = 0; i < 3 * m.vertex_count; i++) {
        if (!isfinite(m.positions[i]))
            fail_msg("%s: position component %zu is %g", c->rel, i, (double)m.positions[i]);
    }
    for (size_t i = 0; i < 3 * m.triangle_count; i++) {
        if (m.triangles[i] >= m.vertex_count)
            fail_msg("%s: triangle index %zu is %u", c->rel, i, m.triangles[i]);
    }
    size_t zero = 0;
    for (size_t i = 0; m.normals && i < m.vertex_count; i++) {
        const float *n = &m.normals[3 * i];
        double len = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2]);
        if (len == 0.0)
            zero++;
        else if (fabs(len - 1.0) > 1e-5)
            fail_msg("%s: normal %zu has length %.9g", c->rel, i, len);
    }
    if ((zero > 0) != c->zero_normals)
        fail_msg("%s: %zu zero-length normals", c->rel, zero);
    for (size_t i = 0; m.colors && i < 3 * m.vertex_count; i++) {
        if (!(m.colors[i] >= 0.0f && m.colors[i] <= 1.0f))
            fail_msg("%s: colour component %zu is %g", c->rel, i, (double)m.colors[i]);
    }
    sg_mesh_free(&m);
}

static void test_ply_real_bunny(void **state)
{
    check_real(&(real_case){"meshes/stanford_bunny/bun_zipper.ply", 35947, 69451, false, false, false});
}
static void test_ply_real_dragon_vcg_normals(void **state)
{
    check_real(&(real_case){"meshes/dragon_vcg50k_normals/dragon.ply", 50000, 100000, true, false, false});
}
static void test_ply_real_hippo1_doubles(void **state)
{
    check_real(&(real_case){"points/cgal/hippo1.ply", 6104, 0, true, false, false});
}
static void test_ply_real_hippo2_zero_normals(void **state)
{
    check_real(&(real_case){"points/cgal/hippo2.ply", 4387, 0, true, false, true});
}
static void test_ply_real_pond_colours(void **state)
{
    check_real(&(real_case){"points/assimp/pond.0.ply", 70051, 0, true, true, false});
}
static void test_ply_real_building(void **state)
{
    check_real(&(real_case){"points/cgal/building.ply", 100000, 0, true, false, false});
}
static void test_ply_real_lucy(void **state)
{
    check_real(&(real_case){"meshes/lucy/Lucy100k.ply", 50002, 100000, false, false, false});
}
static void test_ply_real_dragon_vrip(void **state)
{
    check_real(&(real_case){"meshes/stanford_dragon/dragon_vrip.ply", 437645, 871414, false, false, false});
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ply_ascii_roundtrip),
        cmocka_unit_test(test_ply_binary_le_roundtrip),
        cmocka_unit_test(test_ply_binary_be_roundtrip),
        cmocka_unit_test(test_ply_unusable_normals_become_unknown),
        cmocka_unit_test(test_ply_truncated_binary_body),
        cmocka_unit_test(test_ply_truncated_ascii_body),
        cmocka_unit_test(test_ply_truncated_vertex_section_caught_by_header),
        cmocka_unit_test(test_ply_missing_end_header),
        cmocka_unit_test(test_ply_data_before_end_header),
        cmocka_unit_test(test_ply_count_exceeds_file),
        cmocka_unit_test(test_ply_face_count_exceeds_file),
        cmocka_unit_test(test_ply_count_overflows_size),
        cmocka_unit_test(test_ply_count_overflows_64_bits),
        cmocka_unit_test(test_ply_count_sum_overflows),
        cmocka_unit_test(test_ply_bad_count_text),
        cmocka_unit_test(test_ply_nan_coordinate_ascii),
        cmocka_unit_test(test_ply_inf_coordinate_binary),
        cmocka_unit_test(test_ply_double_out_of_float_range),
        cmocka_unit_test(test_ply_radius_nan),
        cmocka_unit_test(test_ply_radius_negative),
        cmocka_unit_test(test_ply_color_nan),
        cmocka_unit_test(test_ply_color_int_unsupported),
        cmocka_unit_test(test_ply_face_index_out_of_range),
        cmocka_unit_test(test_ply_face_with_fewer_than_3_indices),
        cmocka_unit_test(test_ply_tristrips),
        cmocka_unit_test(test_ply_face_negative_index),
        cmocka_unit_test(test_ply_list_count_runs_past_file),
        cmocka_unit_test(test_ply_list_negative_length),
        cmocka_unit_test(test_ply_ascii_list_count_out_of_type_range),
        cmocka_unit_test(test_ply_ascii_malformed_number),
        cmocka_unit_test(test_ply_empty_file),
        cmocka_unit_test(test_ply_not_a_ply),
        cmocka_unit_test(test_ply_wrong_type_name),
        cmocka_unit_test(test_ply_float_list_count_type),
        cmocka_unit_test(test_ply_float_index_type),
        cmocka_unit_test(test_ply_unknown_format),
        cmocka_unit_test(test_ply_missing_format),
        cmocka_unit_test(test_ply_unknown_keyword),
        cmocka_unit_test(test_ply_property_before_element),
        cmocka_unit_test(test_ply_duplicate_element),
        cmocka_unit_test(test_ply_missing_xyz),
        cmocka_unit_test(test_ply_zero_vertices),
        cmocka_unit_test(test_ply_no_vertex_element),
        cmocka_unit_test(test_ply_face_without_index_list),
        cmocka_unit_test(test_ply_missing_file),
        cmocka_unit_test(test_ply_directory_is_io_error),
        cmocka_unit_test(test_ply_every_truncation_fails_cleanly_binary),
        cmocka_unit_test(test_ply_every_truncation_fails_cleanly_ascii),
        cmocka_unit_test(test_mesh_read_dispatches_case_insensitive),
        cmocka_unit_test(test_mesh_read_unknown_extension),
        cmocka_unit_test(test_ply_real_bunny),
        cmocka_unit_test(test_ply_real_dragon_vcg_normals),
        cmocka_unit_test(test_ply_real_hippo1_doubles),
        cmocka_unit_test(test_ply_real_hippo2_zero_normals),
        cmocka_unit_test(test_ply_real_pond_colours),
        cmocka_unit_test(test_ply_real_building),
        cmocka_unit_test(test_ply_real_lucy),
        cmocka_unit_test(test_ply_real_dragon_vrip),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
