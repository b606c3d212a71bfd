/* test_sample.c — mesh sampling, vertex splats and kNN radii.
 *
 *  1. sample::deterministic        same seed: same bits; 1 and 2 threads:
 *                                  same bits; another seed: other points.
 *  2. sample::area_weighted        triangles of area 1 : 0 : 3 get counts
 *                                  within the binomial 4-sigma bound and the
 *                                  stratified +-2 bound; zero area gets none.
 *  3. sample::stratified_many      100 triangles of random area: every count
 *                                  within +-2 of its share.
 *  4. sample::on_triangles         random 3D triangles: every point on one
 *                                  of them, every normal unit.
 *  5. sample::smooth_normals       icosahedron: interpolated normals lie in
 *                                  the cone of the face's vertex normals;
 *                                  file and area-weighted vertex normals
 *                                  agree; colours interpolate.
 *  6. sample::analytic_radius      the documented formula.
 *  7. sample::errors               no triangles, zero area only, bad index,
 *                                  count 0: INVALID_ARG naming the cause,
 *                                  output untouched.
 *  8. sample::from_vertices        copies normals/colours/radii; area-weighted
 *                                  normals from faces; zeros for a cloud,
 *                                  which then validates after estimation.
 *  9. radius::grid                 regular 2D and 3D grids: interior radii
 *                                  equal the k-th neighbour distance; scale.
 * 10. radius::duplicates           a 12-fold point is treated as one sample;
 *                                  few points lower k; all coincident and
 *                                  single point are errors.
 */
#include "test_support.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"
#include "io/mesh.h"
#include "points/model_points.h"
#include "points/normals.h"
#include "points/radius.h"
#include "points/sample.h"

#define PI_D 3.14159265358979323846

static sg_mesh mesh_new(size_t nv, size_t nt)
{
    sg_mesh m = {0};
    m.vertex_count = nv;
    m.positions = sg_alloc_array(nv, 3 * sizeof(float));
    m.triangle_count = nt;
    m.triangles = nt ? sg_alloc_array(nt, 3 * sizeof(uint32_t)) : NULL;
    assert_non_null(m.positions);
    return m;
}

static void set_v(sg_mesh *m, size_t v, float x, float y, float z)
{
    m->positions[3 * v] = x;
    m->positions[3 * v + 1] = y;
    m->positions[3 * v + 2] = z;
}

static void set_t(sg_mesh *m, size_t t, uint32_t a, uint32_t b, uint32_t c)
{
    m->triangles[3 * t] = a;
    m->triangles[3 * t + 1] = b;
    m->triangles[3 * t + 2] = c;
}

static sg_pointset sample(const sg_mesh *m, size_t n, uint64_t seed)
{
    sg_sample_desc d = {.count = n, .seed = seed};
    sg_pointset ps;
    sg_error err;
    sg_status s = sg_points_sample_mesh(m, &d, &ps, &err);
    if (s != SG_OK)
        fail_msg("sample_mesh(%zu): %s: %s", n, sg_status_name(s), err.message);
    assert_int_equal(ps.count, n);
    return ps;
}

static int same_bits(const sg_pointset *a, const sg_pointset *b)
{
    if (a->count != b->count)
        return 0;
    size_t bytes = a->count * sizeof(float);
    const float *fa[10] = {a->px, a->py, a->pz, a->nx, a->ny, a->nz, a->radius, a->ar, a->ag, a->ab};
    const float *fb[10] = {b->px, b->py, b->pz, b->nx, b->ny, b->nz, b->radius, b->ar, b->ag, b->ab};
    for (int i = 0; i < 10; ++i)
        if (memcmp(fa[i], fb[i], bytes) != 0)
            return 0;
    return 1;
}

/* Unit icosahedron: 12 vertices, 20 faces, counter-clockwise from outside. */
static sg_mesh icosahedron(void)
{
    sg_mesh m = mesh_new(12, 20);
    const float t = 1.61803399f;
    const float v[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                            {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    const uint32_t f[20][3] = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11},
                               {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                               {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9},
                               {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
    float l = sqrtf(1.0f + t * t);
    for (size_t i = 0; i < 12; ++i)
        set_v(&m, i, v[i][0] / l, v[i][1] / l, v[i][2] / l);
    for (size_t i = 0; i < 20; ++i)
        set_t(&m, i, f[i][0], f[i][1], f[i][2]);
    return m;
}

/* ---- 1-3 -------------------------------------------------------------- */

static void test_sample_deterministic(void **state)
{
    (void)state;
    sg_mesh m = icosahedron();
    int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    sg_pointset a = sample(&m, 50000, 7);
    omp_set_num_threads(2);
    sg_pointset b = sample(&m, 50000, 7), c = sample(&m, 50000, 7), d = sample(&m, 50000, 8);
    omp_set_num_threads(saved);
    if (!same_bits(&a, &b))
        fail_msg("seed 7, 50000 points: 1 and 2 threads differ");
    if (!same_bits(&b, &c))
        fail_msg("seed 7, 50000 points: two runs differ");
    size_t moved = 0;
    for (size_t i = 0; i < d.count; ++i)
        moved += d.px[i] != b.px[i];
    if (moved < d.count / 2)
        fail_msg("seeds 7 and 8 share %zu of %zu x coordinates", d.count - moved, d.count);
    sg_pointset_free(&a);
    sg_pointset_free(&b);
    sg_pointset_free(&c);
    sg_pointset_free(&d);
    sg_mesh_free(&m);
}

/* Triangle A (area 1) in x in [0,2], a degenerate triangle, triangle B
 * (area 3) in x in [10,13]; all in the plane z = 0. */
static void test_sample_area_weighted(void **state)
{
    (void)state;
    sg_mesh m = mesh_new(9, 3);
    set_v(&m, 0, 0, 0, 0);
    set_v(&m, 1, 2, 0, 0);
    set_v(&m, 2, 0, 1, 0); /* area 1 */
    set_v(&m, 3, 5, 0, 0);
    set_v(&m, 4, 6, 0, 0);
    set_v(&m, 5, 7, 0, 0); /* collinear: area 0 */
    set_v(&m, 6, 10, 0, 0);
    set_v(&m, 7, 13, 0, 0);
    set_v(&m, 8, 10, 2, 0); /* area 3 */
    set_t(&m, 0, 0, 1, 2);
    set_t(&m, 1, 3, 4, 5);
    set_t(&m, 2, 6, 7, 8);
    const size_t n = 20000;
    for (uint64_t seed = 0; seed < 4; ++seed) {
        sg_pointset ps = sample(&m, n, seed);
        size_t count[3] = {0, 0, 0};
        for (size_t i = 0; i < n; ++i)
            count[ps.px[i] < 3.0f ? 0 : ps.px[i] < 8.0f ? 1 : 2]++;
        /* Binomial: were the N points independent, count_A ~ B(N, 1/4),
         * sigma = sqrt(N p (1-p)) = sqrt(20000 * 3/16) = 61.2, so 4 sigma
         * = 245 around N/4 = 5000. Stratification promises more: the
         * interval [0, N/4) of stratum space holds 5000 unit strata, each
         * placing its point inside itself, so at most the two strata
         * straddling the ends can move a point across: |count - 5000| <= 2. */
        double want = (double)n / 4.0, sigma = sqrt((double)n * 0.25 * 0.75);
        if (fabs((double)count[0] - want) > 4.0 * sigma || fabs((double)count[2] - 3.0 * want) > 4.0 * sigma)
            fail_msg("seed %llu: counts %zu / %zu, binomial 4-sigma bound %g around %g / %g",
                     (unsigned long long)seed, count[0], count[2], 4.0 * sigma, want, 3.0 * want);
        if (fabs((double)count[0] - want) > 2.0 || fabs((double)count[2] - 3.0 * want) > 2.0)
            fail_msg("seed %llu: counts %zu / %zu, stratified bound +-2 around %g / %g",
                     (unsigned long long)seed, count[0], count[2], want, 3.0 * want);
        if (count[1] != 0)
            fail_msg("seed %llu: %zu points on the zero-area triangle", (unsigned long long)seed, count[1]);
        sg_pointset_free(&ps);
    }
    sg_mesh_free(&m);
}

/* Triangle t lies in the plane z = t, so a point's z names its triangle. */
static void test_sample_stratified_many(void **state)
{
    (void)state;
    const size_t nt = 100, n = 10000;
    sg_mesh m = mesh_new(3 * nt, nt);
    uint64_t rng = 21;
    double area[100], total = 0.0;
    for (size_t t = 0; t < nt; ++t) {
        float a = 0.05f + sg_test_rand01(&rng), b = 0.05f + 2.0f * sg_test_rand01(&rng);
        set_v(&m, 3 * t, 0, 0, (float)t);
        set_v(&m, 3 * t + 1, a, 0, (float)t);
        set_v(&m, 3 * t + 2, 0, b, (float)t);
        set_t(&m, t, (uint32_t)(3 * t), (uint32_t)(3 * t + 1), (uint32_t)(3 * t + 2));
        area[t] = 0.5 * (double)a * (double)b;
        total += area[t];
    }
    sg_pointset ps = sample(&m, n, 99);
    size_t count[100] = {0};
    for (size_t i = 0; i < n; ++i) {
        float z = ps.pz[i];
        assert_true(z == floorf(z) && z >= 0.0f && z < (float)nt);
        count[(size_t)z]++;
    }
    for (size_t t = 0; t < nt; ++t) {
        double want = (double)n * area[t] / total;
        if (fabs((double)count[t] - want) > 2.0)
            fail_msg("triangle %zu (area %g of %g): %zu points, want %g +- 2", t, area[t], total,
                     count[t], want);
    }
    sg_pointset_free(&ps);
    sg_mesh_free(&m);
}

/* ---- 4-6 -------------------------------------------------------------- */

static void test_sample_on_triangles(void **state)
{
    (void)state;
    const size_t nt = 50, n = 4000;
    sg_mesh m = mesh_new(3 * nt, nt);
    uint64_t rng = 31;
    for (size_t v = 0; v < 3 * nt; ++v)
        set_v(&m, v, sg_test_rand01(&rng), sg_test_rand01(&rng), sg_test_rand01(&rng));
    for (size_t t = 0; t < nt; ++t)
        set_t(&m, t, (uint32_t)(3 * t), (uint32_t)(3 * t + 1), (uint32_t)(3 * t + 2));
    sg_pointset ps = sample(&m, n, 5);
    for (size_t i = 0; i < n; ++i) {
        sg_vec3 p = sg_pointset_position(&ps, i);
        double best = INFINITY; /* distance to the nearest triangle */
        for (size_t t = 0; t < nt; ++t) {
            const float *a = m.positions + 9 * t;
            sg_vec3 A = sg_v3(a[0], a[1], a[2]), B = sg_v3(a[3], a[4], a[5]), C = sg_v3(a[6], a[7], a[8]);
            sg_vec3 e1 = sg_v3_sub(B, A), e2 = sg_v3_sub(C, A), w = sg_v3_sub(p, A);
            sg_vec3 nn = sg_v3_cross(e1, e2);
            float nl = sg_v3_length(nn);
            double plane = fabs(sg_v3_dot(w, nn)) / nl;
            /* barycentrics of the projection */
            float d11 = sg_v3_dot(e1, e1), d12 = sg_v3_dot(e1, e2), d22 = sg_v3_dot(e2, e2);
            float dw1 = sg_v3_dot(w, e1), dw2 = sg_v3_dot(w, e2), den = d11 * d22 - d12 * d12;
            float s = (d22 * dw1 - d12 * dw2) / den, u = (d11 * dw2 - d12 * dw1) / den;
            if (s >= -1e-4f && u >= -1e-4f && s + u <= 1.0f + 1e-4f && plane < best)
                best = plane;
        }
        if (!(best < 1e-5))
            fail_msg("point %zu (%g,%g,%g) is %g from every triangle", i, (double)p.x, (double)p.y,
                     (double)p.z, best);
        float len = sg_v3_length(sg_pointset_normal(&ps, i));
        if (fabsf(len - 1.0f) > 1e-5f)
            fail_msg("point %zu: |n| = %g", i, (double)len);
    }
    sg_error err;
    assert_int_equal(sg_pointset_validate(&ps, &err), SG_OK);
    sg_pointset_free(&ps);
    sg_mesh_free(&m);
}

static void test_sample_smooth_normals(void **state)
{
    (void)state;
    sg_mesh m = icosahedron();
    /* Without file normals: area-weighted vertex normals. By symmetry each
     * is the vertex direction, so both runs must agree. */
    sg_pointset faces = sample(&m, 3000, 3);
    m.normals = sg_alloc_array(12, 3 * sizeof(float));
    m.colors = sg_alloc_array(12, 3 * sizeof(float));
    assert_non_null(m.normals);
    assert_non_null(m.colors);
    for (size_t v = 0; v < 12; ++v)
        for (int c = 0; c < 3; ++c) {
            m.normals[3 * v + c] = m.positions[3 * v + c]; /* unit already */
            m.colors[3 * v + c] = (float)v / 11.0f;
        }
    sg_pointset file = sample(&m, 3000, 3);
    /* The face normal of an icosahedron is 37.38 degrees from each vertex
     * direction; an interpolated normal stays inside that cone:
     * n . face_normal >= cos(37.38 deg) = 0.7947. */
    const float cone = 0.7946544f - 1e-5f;
    for (size_t i = 0; i < file.count; ++i) {
        sg_vec3 p = sg_pointset_position(&file, i), n = sg_pointset_normal(&file, i);
        /* p's face is the one whose normal is closest to p's direction. */
        float best = -2.0f;
        sg_vec3 face_n = sg_v3(0, 0, 0);
        for (size_t t = 0; t < 20; ++t) {
            const uint32_t *tri = m.triangles + 3 * t;
            sg_vec3 v[3];
            for (int c = 0; c < 3; ++c)
                v[c] = sg_v3(m.positions[3 * tri[c]], m.positions[3 * tri[c] + 1], m.positions[3 * tri[c] + 2]);
            sg_vec3 fn = sg_v3_normalize(sg_v3_cross(sg_v3_sub(v[1], v[0]), sg_v3_sub(v[2], v[0])));
            float dp = sg_v3_dot(fn, sg_v3_normalize(p));
            if (dp > best) {
                best = dp;
                face_n = fn;
            }
        }
        if (!(sg_v3_dot(face_n, n) >= cone))
            fail_msg("point %zu: normal . face normal = %g < cos 37.38 deg", i,
                     (double)sg_v3_dot(face_n, n));
        if (fabsf(sg_v3_length(n) - 1.0f) > 1e-5f)
            fail_msg("point %zu: |n| = %g", i, (double)sg_v3_length(n));
        sg_vec3 d = sg_v3_sub(n, sg_pointset_normal(&faces, i));
        if (sg_v3_length(d) > 1e-5f)
            fail_msg("point %zu: file-normal and area-weighted interpolation differ by %g", i,
                     (double)sg_v3_length(d));
        if (!(file.ar[i] >= 0.0f && file.ar[i] <= 1.0f) || file.ar[i] != file.ag[i])
            fail_msg("point %zu: albedo (%g,%g,%g) not an interpolated grey", i, (double)file.ar[i],
                     (double)file.ag[i], (double)file.ab[i]);
    }
    sg_pointset_free(&faces);
    sg_pointset_free(&file);
    sg_mesh_free(&m);
}

static void test_sample_analytic_radius(void **state)
{
    (void)state;
    sg_mesh m = mesh_new(4, 2); /* a 2 x 3 rectangle, area 6 */
    set_v(&m, 0, 0, 0, 0);
    set_v(&m, 1, 2, 0, 0);
    set_v(&m, 2, 2, 3, 0);
    set_v(&m, 3, 0, 3, 0);
    set_t(&m, 0, 0, 1, 2);
    set_t(&m, 1, 0, 2, 3);
    sg_sample_desc d = {.count = 5000, .radius_scale = 0.5f};
    sg_pointset ps;
    sg_error err;
    assert_int_equal(sg_points_sample_mesh(&m, &d, &ps, &err), SG_OK);
    float want = (float)(0.5 * sqrt(8.0 * 6.0 / (PI_D * 5000.0)));
    for (size_t i = 0; i < ps.count; ++i)
        if (fabsf(ps.radius[i] - want) > 1e-6f * want)
            fail_msg("point %zu: radius %g, want 0.5 sqrt(8 A / (pi N)) = %g", i, (double)ps.radius[i],
                     (double)want);
    sg_pointset_free(&ps);
    sg_mesh_free(&m);
}

/* ---- 7-8 -------------------------------------------------------------- */

static void expect_sample_error(const sg_mesh *m, size_t n, const char *word)
{
    sg_sample_desc d = {.count = n};
    sg_pointset ps = {.count = 12345};
    sg_error err;
    sg_status s = sg_points_sample_mesh(m, &d, &ps, &err);
    if (s != SG_ERR_INVALID_ARG)
        fail_msg("expecting \"%s\": status %s", word, sg_status_name(s));
    if (!strstr(err.message, word))
        fail_msg("message \"%s\" does not say \"%s\"", err.message, word);
    assert_int_equal(ps.count, 12345);
    assert_null(ps.px);
}

static void test_sample_errors(void **state)
{
    (void)state;
    sg_mesh cloud = mesh_new(3, 0);
    set_v(&cloud, 0, 0, 0, 0);
    set_v(&cloud, 1, 1, 0, 0);
    set_v(&cloud, 2, 0, 1, 0);
    expect_sample_error(&cloud, 100, "no triangles");
    sg_mesh flat = mesh_new(3, 2);
    set_v(&flat, 0, 0, 0, 0);
    set_v(&flat, 1, 1, 0, 0);
    set_v(&flat, 2, 2, 0, 0);
    set_t(&flat, 0, 0, 1, 2);
    set_t(&flat, 1, 1, 1, 1);
    expect_sample_error(&flat, 100, "positive area");
    set_t(&flat, 1, 0, 1, 3);
    expect_sample_error(&flat, 100, "triangle 1");
    set_v(&flat, 2, 0, 1, 0);
    set_t(&flat, 1, 0, 1, 2);
    expect_sample_error(&flat, 0, "count");
    sg_mesh_free(&cloud);
    sg_mesh_free(&flat);
}

static void test_sample_from_vertices(void **state)
{
    (void)state;
    sg_error err;
    /* (a) file normals, colours, radii are copied. */
    sg_mesh m = icosahedron();
    m.normals = sg_alloc_array(12, 3 * sizeof(float));
    m.colors = sg_alloc_array(12, 3 * sizeof(float));
    m.radii = sg_alloc_array(12, sizeof(float));
    for (size_t v = 0; v < 12; ++v) {
        for (int c = 0; c < 3; ++c) {
            m.normals[3 * v + c] = 2.0f * m.positions[3 * v + c]; /* renormalised */
            m.colors[3 * v + c] = 0.1f * (float)c;
        }
        m.radii[v] = 0.01f * (float)(v + 1);
    }
    sg_pointset ps;
    assert_int_equal(sg_points_from_vertices(&m, &ps, &err), SG_OK);
    assert_int_equal(ps.count, 12);
    for (size_t v = 0; v < 12; ++v) {
        sg_vec3 want = sg_v3(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]);
        if (sg_v3_length(sg_v3_sub(sg_pointset_normal(&ps, v), want)) > 1e-6f)
            fail_msg("vertex %zu: file normal not copied", v);
        assert_true(ps.px[v] == want.x && ps.radius[v] == m.radii[v]);
        assert_true(ps.ar[v] == 0.0f && ps.ag[v] == 0.1f && ps.ab[v] == 0.2f);
    }
    assert_int_equal(sg_pointset_validate(&ps, &err), SG_OK);
    sg_pointset_free(&ps);
    sg_mesh_free(&m);

    /* (b) no file normals: area-weighted from faces. Vertices 0 and 1 are
     * shared by a horizontal triangle of area 2 and a vertical one of area
     * 1; vertex 4 is in no triangle. */
    m = mesh_new(5, 2);
    set_v(&m, 0, 0, 0, 0);
    set_v(&m, 1, 2, 0, 0);
    set_v(&m, 2, 0, 0, -2);
    set_v(&m, 3, 0, 1, 0);
    set_v(&m, 4, 9, 9, 9);
    set_t(&m, 0, 0, 1, 2); /* (2,0,0) x (0,0,-2) = (0,4,0): area 2, +y */
    set_t(&m, 1, 0, 1, 3); /* (2,0,0) x (0,1,0) = (0,0,2): area 1, +z */
    assert_int_equal(sg_points_from_vertices(&m, &ps, &err), SG_OK);
    /* Vertices 0, 1: normalize((0,4,0) + (0,0,2)); vertex 2: +y; 3: +z. */
    const float s5 = 1.0f / sqrtf(5.0f);
    const float want[5][3] = {{0, 2 * s5, s5}, {0, 2 * s5, s5}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
    for (size_t v = 0; v < 5; ++v) {
        sg_vec3 got = sg_pointset_normal(&ps, v);
        if (fabsf(got.x - want[v][0]) > 1e-6f || fabsf(got.y - want[v][1]) > 1e-6f ||
            fabsf(got.z - want[v][2]) > 1e-6f)
            fail_msg("vertex %zu: normal (%g,%g,%g), want (%g,%g,%g)", v, (double)got.x,
                     (double)got.y, (double)got.z, (double)want[v][0], (double)want[v][1],
                     (double)want[v][2]);
        assert_true(ps.radius[v] == 0.0f && ps.ar[v] == 0.8f);
    }
    sg_pointset_free(&ps);
    sg_mesh_free(&m);

    /* (c) a point cloud: zero normals and radii, completed by estimation. */
    m = mesh_new(2000, 0);
    for (size_t v = 0; v < 2000; ++v) { /* Fibonacci sphere */
        float y = 1.0f - 2.0f * ((float)v + 0.5f) / 2000.0f, r = sqrtf(1.0f - y * y);
        set_v(&m, v, r * cosf(2.39996323f * (float)v), y, r * sinf(2.39996323f * (float)v));
    }
    assert_int_equal(sg_points_from_vertices(&m, &ps, &err), SG_OK);
    for (size_t v = 0; v < 2000; ++v)
        assert_true(ps.nx[v] == 0.0f && ps.ny[v] == 0.0f && ps.nz[v] == 0.0f && ps.radius[v] == 0.0f);
    assert_int_equal(sg_pointset_validate(&ps, &err), SG_ERR_INVALID_ARG);
    sg_normals_desc nd = {.flags = SG_NORMALS_ONLY_MISSING};
    assert_int_equal(sg_points_estimate_normals(&ps, &nd, &err), SG_OK);
    assert_int_equal(sg_points_estimate_radii(&ps, NULL, &err), SG_OK);
    sg_status s = sg_pointset_validate(&ps, &err);
    if (s != SG_OK)
        fail_msg("after estimation: %s", err.message);
    sg_pointset_free(&ps);
    sg_mesh_free(&m);
}

/* ---- 9-10: radii ------------------------------------------------------- */

static void estimate_radii(sg_pointset *ps, unsigned k, float scale)
{
    sg_radius_desc d = {.k = k, .scale = scale};
    sg_error err;
    sg_status s = sg_points_estimate_radii(ps, &d, &err);
    if (s != SG_OK)
        fail_msg("estimate_radii(k %u): %s: %s", k, sg_status_name(s), err.message);
}

static void test_radius_grid(void **state)
{
    (void)state;
    sg_error err;
    const float h = 0.125f; /* exact in binary: distances are exact */
    /* 2D grid 30 x 30 in the plane y = 1: an interior point has 4
     * neighbours at h and 4 at sqrt(2) h, then 4 at 2h. */
    sg_pointset ps;
    assert_int_equal(sg_pointset_alloc(&ps, 900, &err), SG_OK);
    for (size_t i = 0; i < 900; ++i) {
        ps.px[i] = h * (float)(i % 30);
        ps.py[i] = 1.0f;
        ps.pz[i] = h * (float)(i / 30);
    }
    static const struct { unsigned k; float scale, want; } cases2[4] = {
        {0, 0.0f, 0.17677669f /* sqrt(2) h, the default k = 8 */},
        {4, 1.0f, 0.125f},
        {8, 2.0f, 0.35355339f},
        {12, 1.0f, 0.25f}};
    for (int c = 0; c < 4; ++c) {
        estimate_radii(&ps, cases2[c].k, cases2[c].scale);
        for (size_t i = 0; i < 900; ++i) {
            size_t a = i % 30, b = i / 30;
            if (a < 2 || b < 2 || a > 27 || b > 27)
                continue; /* 2 rows from the border: the 12-ring is complete */
            if (fabsf(ps.radius[i] - cases2[c].want) > 1e-6f)
                fail_msg("2D grid k %u scale %g: point (%zu,%zu) radius %.9g, want %.9g", cases2[c].k,
                         (double)cases2[c].scale, a, b, (double)ps.radius[i], (double)cases2[c].want);
        }
    }
    sg_pointset_free(&ps);
    /* 3D grid 12^3: 6 neighbours at h, then 12 at sqrt(2) h. */
    assert_int_equal(sg_pointset_alloc(&ps, 1728, &err), SG_OK);
    for (size_t i = 0; i < 1728; ++i) {
        ps.px[i] = h * (float)(i % 12);
        ps.py[i] = h * (float)(i / 12 % 12);
        ps.pz[i] = h * (float)(i / 144);
    }
    static const struct { unsigned k; float want; } cases3[2] = {{6, 0.125f}, {8, 0.17677669f}};
    for (int c = 0; c < 2; ++c) {
        estimate_radii(&ps, cases3[c].k, 1.0f);
        for (size_t i = 0; i < 1728; ++i) {
            size_t a = i % 12, b = i / 12 % 12, cc = i / 144;
            if (a < 1 || b < 1 || cc < 1 || a > 10 || b > 10 || cc > 10)
                continue;
            if (fabsf(ps.radius[i] - cases3[c].want) > 1e-6f)
                fail_msg("3D grid k %u: point (%zu,%zu,%zu) radius %.9g, want %.9g", cases3[c].k, a, b,
                         cc, (double)ps.radius[i], (double)cases3[c].want);
        }
    }
    sg_pointset_free(&ps);
}

/* A thin wall: two 30 x 30 grids 0.3 h apart with opposed normals (the
 * two sides of a sheet). Each point's radius comes from its own layer, as
 * if the other were absent: sqrt(2) h for k = 8 (issue 12: counting the
 * other side gave 1.044 h, and each side kept holes). Two layers facing
 * the same way are one surface sampled twice and keep the plain rule. */
static void test_radius_two_layers(void **state)
{
    (void)state;
    sg_error err;
    const float h = 0.125f;
    for (int same = 0; same < 2; ++same) {
        sg_pointset ps;
        assert_int_equal(sg_pointset_alloc(&ps, 1800, &err), SG_OK);
        for (size_t i = 0; i < 1800; ++i) {
            size_t j = i % 900;
            int lower = i >= 900;
            ps.px[i] = h * (float)(j % 30);
            ps.py[i] = 1.0f - (lower ? 0.3f * h : 0.0f);
            ps.pz[i] = h * (float)(j / 30);
            ps.nx[i] = 0, ps.ny[i] = lower && !same ? -1.0f : 1.0f, ps.nz[i] = 0;
        }
        sg_radius_desc rd = {.k = 8, .layers = 1};
        assert_int_equal(sg_points_estimate_radii(&ps, &rd, &err), SG_OK);
        /* same: the point across at 0.3 h, 4 at h, then 4 across at
         * sqrt(1 + 0.09) h and 4 at sqrt(2) h: the 8th is the across one */
        float want = same ? 1.04403065f * h : 0.17677669f;
        for (size_t i = 0; i < 1800; ++i) {
            size_t a = i % 900 % 30, b = i % 900 / 30;
            if (a < 2 || b < 2 || a > 27 || b > 27)
                continue;
            if (fabsf(ps.radius[i] - want) > 1e-5f)
                fail_msg("two layers (%s normals): point %zu radius %.9g, want %.9g", same ? "same" : "opposed", i,
                         (double)ps.radius[i], (double)want);
        }
        sg_pointset_free(&ps);
    }
}

static void test_radius_duplicates(void **state)
{
    (void)state;
    sg_error err;
    const float h = 0.125f;
    /* 20 x 20 grid plus 11 extra copies of grid point (10,10) (index 210)
     * and 2 extra copies of (5,5) (index 105). */
    sg_pointset ps;
    assert_int_equal(sg_pointset_alloc(&ps, 400 + 11 + 2, &err), SG_OK);
    for (size_t i = 0; i < 400; ++i) {
        ps.px[i] = h * (float)(i % 20);
        ps.py[i] = h * (float)(i / 20);
        ps.pz[i] = 0.0f;
    }
    for (size_t j = 400; j < 413; ++j) {
        size_t src = j < 411 ? 210 : 105;
        ps.px[j] = ps.px[src];
        ps.py[j] = ps.py[src];
        ps.pz[j] = 0.0f;
    }
    estimate_radii(&ps, 8, 1.0f);
    /* The 12-fold point: its 8th neighbour is a copy (distance 0), so it is
     * treated as one sample: 8th nearest at another position = sqrt(2) h. */
    const float s2h = 0.17677669f;
    for (size_t j = 400; j < 411; ++j)
        if (fabsf(ps.radius[j] - s2h) > 1e-6f)
            fail_msg("copy %zu of the 12-fold point: radius %.9g, want sqrt(2) h = %.9g", j,
                     (double)ps.radius[j], (double)s2h);
    assert_true(fabsf(ps.radius[210] - s2h) <= 1e-6f);
    /* The 3-fold point counts its 2 copies: 2 at 0, 4 at h, 2 of 4 at
     * sqrt(2) h -> the 8th is sqrt(2) h as well; with k = 6: h. */
    assert_true(fabsf(ps.radius[105] - s2h) <= 1e-6f);
    estimate_radii(&ps, 6, 1.0f);
    if (fabsf(ps.radius[105] - h) > 1e-6f || fabsf(ps.radius[411] - h) > 1e-6f)
        fail_msg("3-fold point, k 6: radius %.9g, want h", (double)ps.radius[105]);
    sg_pointset_free(&ps);

    /* 5 points, k 8: k drops to 4 (the farthest other point). */
    assert_int_equal(sg_pointset_alloc(&ps, 5, &err), SG_OK);
    for (size_t i = 0; i < 5; ++i) {
        ps.px[i] = (float)i;
        ps.py[i] = ps.pz[i] = 0.0f;
    }
    estimate_radii(&ps, 0, 0.0f);
    assert_true(ps.radius[0] == 4.0f && ps.radius[2] == 2.0f);
    /* All coincident, or one point: an error, radii untouched. */
    for (size_t i = 0; i < 5; ++i) {
        ps.px[i] = 1.0f;
        ps.radius[i] = -1.0f;
    }
    assert_int_equal(sg_points_estimate_radii(&ps, NULL, &err), SG_ERR_INVALID_ARG);
    if (!strstr(err.message, "coincide"))
        fail_msg("message \"%s\" does not say the points coincide", err.message);
    assert_true(ps.radius[3] == -1.0f);
    ps.count = 1;
    assert_int_equal(sg_points_estimate_radii(&ps, NULL, &err), SG_ERR_INVALID_ARG);
    ps.count = 5;
    sg_pointset_free(&ps);
}


/* Stray points far from a scan (raw, unaligned range scans) would get
 * radii of their distance to the rest and cover the frame: the model
 * pipeline caps every radius at 8 x the median. 30 x 30 grid of spacing h,
 * plus three points 100 h away from it and from each other. */
static void test_radius_stray_points_capped(void **state)
{
    (void)state;
    const float h = 0.125f;
    sg_mesh m = mesh_new(903, 0);
    for (size_t v = 0; v < 900; ++v)
        set_v(&m, v, h * (float)(v % 30), 0.0f, h * (float)(v / 30));
    set_v(&m, 900, 100.0f * h, 50.0f * h, 0.0f);
    set_v(&m, 901, -100.0f * h, 60.0f * h, 0.0f);
    set_v(&m, 902, 0.0f, -80.0f * h, 100.0f * h);
    sg_pointset ps = {0};
    sg_error err;
    sg_model_points_desc d = {.radius_k = 8};
    sg_status s = sg_model_points_from_mesh(&m, "strays.xyz", &d, &ps, &err);
    if (s != SG_OK)
        fail_msg("%s", err.message);
    const float median = 0.17677669f; /* sqrt(2) h: interior points' 8th neighbour */
    float biggest = 0.0f;
    for (size_t i = 0; i < ps.count; ++i)
        biggest = ps.radius[i] > biggest ? ps.radius[i] : biggest;
    if (!(biggest <= 8.0f * median * 1.0001f))
        fail_msg("largest radius %.6g, want at most 8 x the median spacing %.6g", (double)biggest,
                 (double)(8.0f * median));
    assert_int_equal(ps.count, 903);
    sg_pointset_free(&ps);

    /* The report counts them; the cap is exactly 8 x the median. */
    sg_model_points_report rep;
    memset(&rep, 0xAB, sizeof rep);
    d.report = &rep;
    assert_int_equal(sg_model_points_from_mesh(&m, "strays.xyz", &d, &ps, &err), SG_OK);
    assert_int_equal(rep.capped, 3);
    assert_int_equal(rep.dropped, 0);
    assert_true(fabsf(rep.median_radius - median) < 1e-6f);
    assert_true(rep.cap_radius == 8.0f * rep.median_radius);
    assert_true(ps.radius[900] == rep.cap_radius && ps.radius[902] == rep.cap_radius);
    assert_false(rep.has_colors);
    assert_int_equal(rep.file_vertices, 903);
    sg_pointset_free(&ps);

    /* drop_outliers removes them: the grid alone, its radii untouched. */
    d.drop_outliers = true;
    assert_int_equal(sg_model_points_from_mesh(&m, "strays.xyz", &d, &ps, &err), SG_OK);
    assert_int_equal(ps.count, 900);
    assert_int_equal(rep.dropped, 3);
    assert_int_equal(rep.capped, 0);
    for (size_t i = 0; i < ps.count; ++i)
        assert_true(fabsf(ps.py[i]) == 0.0f && ps.radius[i] <= 0.36f); /* corners: sqrt(8) h */
    sg_pointset_free(&ps);

    /* A cap of 20 leaves these strays (~12.5 / 0.177 = 70x) capped; a
     * negative cap (none) keeps their full radii. */
    d.drop_outliers = false;
    d.radius_cap = -1.0f;
    assert_int_equal(sg_model_points_from_mesh(&m, "strays.xyz", &d, &ps, &err), SG_OK);
    assert_int_equal(rep.capped, 0);
    assert_true(isinf(rep.cap_radius));
    assert_true(ps.radius[900] > 10.0f);
    sg_pointset_free(&ps);
    d.radius_cap = 0.5f;
    assert_int_equal(sg_model_points_from_mesh(&m, "strays.xyz", &d, &ps, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "strays.xyz"));
    sg_mesh_free(&m);
}

/* The median is the exact middle order statistic, for the awkward cases
 * of the select: many equal values, sorted and reversed input. */
static void test_radius_cap_median_exact(void **state)
{
    (void)state;
    sg_error err;
    for (int pattern = 0; pattern < 3; ++pattern) {
        /* 101 points on a line with spacings chosen per pattern; k = 1: the
         * radius is the distance to the nearest neighbour. */
        sg_pointset ps;
        assert_int_equal(sg_pointset_alloc(&ps, 101, &err), SG_OK);
        float x = 0.0f;
        for (size_t i = 0; i < 101; ++i) {
            ps.px[i] = x;
            ps.py[i] = ps.pz[i] = 0.0f;
            float gap = pattern == 0 ? 1.0f : pattern == 1 ? 1.0f + (float)i * 0.01f : 2.0f - (float)i * 0.01f;
            x += gap;
        }
        sg_radius_stats rs;
        sg_radius_desc d = {.k = 1, .scale = 1.0f, .stats = &rs, .cap = 1000.0f};
        assert_int_equal(sg_points_estimate_radii(&ps, &d, &err), SG_OK);
        float sorted[101];
        memcpy(sorted, ps.radius, sizeof sorted);
        for (int a = 1; a < 101; ++a) /* insertion sort: the plain reference */
            for (int b = a; b > 0 && sorted[b - 1] > sorted[b]; --b) {
                float t = sorted[b];
                sorted[b] = sorted[b - 1];
                sorted[b - 1] = t;
            }
        if (rs.median != sorted[50] || rs.capped != 0)
            fail_msg("pattern %d: median %.9g, want %.9g; capped %zu", pattern, (double)rs.median,
                     (double)sorted[50], rs.capped);
        sg_pointset_free(&ps);
    }
}

/* Faces: a repeated triangle (same vertices, either winding) is left out,
 * and faces wound against their neighbours are turned; a closed piece
 * faces outward. Tetrahedron with face 2 reversed, face 0 repeated
 * reversed: 1 repeat, 1 turned; normals point away from the centre. */
static void test_sample_faces_oriented_and_deduplicated(void **state)
{
    (void)state;
    sg_mesh m = mesh_new(4, 5);
    set_v(&m, 0, 1, 1, 1);
    set_v(&m, 1, 1, -1, -1);
    set_v(&m, 2, -1, 1, -1);
    set_v(&m, 3, -1, -1, 1);
    set_t(&m, 0, 0, 1, 2); /* outward: (0,1,2) has normal along +(1,1,-1)... */
    set_t(&m, 1, 0, 3, 1);
    set_t(&m, 2, 0, 3, 2); /* wound the other way round than its neighbours */
    set_t(&m, 3, 1, 3, 2);
    set_t(&m, 4, 2, 1, 0); /* face 0 again, reversed */
    size_t turned = 99, repeated = 99;
    sg_sample_desc d = {.count = 4000, .faces_turned = &turned, .faces_repeated = &repeated};
    sg_pointset ps;
    sg_error err;
    if (sg_points_sample_mesh(&m, &d, &ps, &err) != SG_OK)
        fail_msg("%s", err.message);
    assert_int_equal(repeated, 1);
    assert_true(turned == 1 || turned == 3); /* the odd one, or the other three */
    size_t inward = 0;
    for (size_t i = 0; i < ps.count; ++i)
        inward += sg_v3_dot(sg_pointset_position(&ps, i), sg_pointset_normal(&ps, i)) <= 0.0f;
    if (inward)
        fail_msg("%zu of %zu samples have normals pointing into the tetrahedron", inward, ps.count);
    sg_pointset_free(&ps);
    sg_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sample_deterministic),
        cmocka_unit_test(test_sample_area_weighted),
        cmocka_unit_test(test_sample_stratified_many),
        cmocka_unit_test(test_sample_on_triangles),
        cmocka_unit_test(test_sample_smooth_normals),
        cmocka_unit_test(test_sample_analytic_radius),
        cmocka_unit_test(test_sample_errors),
        cmocka_unit_test(test_sample_from_vertices),
        cmocka_unit_test(test_radius_grid),
        cmocka_unit_test(test_radius_two_layers),
        cmocka_unit_test(test_radius_duplicates),
        cmocka_unit_test(test_sample_faces_oriented_and_deduplicated),
        cmocka_unit_test(test_radius_stray_points_capped),
        cmocka_unit_test(test_radius_cap_median_exact),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
