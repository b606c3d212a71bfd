/* test_normals.c — PCA normals and their orientation.
 *
 *  1. normals::eigen_random        the 3x3 solver on random rotations of
 *                                  known spectra (distinct, repeated, zero):
 *                                  residual, orthonormality, eigenvalues.
 *  2. normals::sphere_accuracy     Fibonacci sphere: every normal within the
 *                                  curvature bound of the radial direction
 *                                  (derivation below) and pointing outward.
 *  3. normals::sphere_random       uniformly random sphere points: outward.
 *  4. normals::two_spheres         two disconnected kNN components: both
 *                                  outward, each from its own root.
 *  5. normals::torus_outward       torus (a non-convex, genus-1 surface).
 *  6. normals::box_outward         box: exact face normals away from the
 *                                  edges, outward everywhere.
 *  7. normals::plane               horizontal plane: exactly +y; a vertical
 *                                  plane: exactly +-x, one sign for all.
 *  8. normals::only_missing        half the normals known: known ones kept
 *                                  bit-exact, missing ones follow them (also
 *                                  when the known ones point inward).
 *  9. normals::threads_identical   1 and 2 threads: same bits.
 * 10. normals::errors              too few points, NaN position (named).
 */
#include "test_support.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "points/knn.h"
#include "points/normals.h"
#include "points/pointset.h"

#define PI_F 3.14159265f

static sg_pointset alloc_ps(size_t n)
{
    sg_pointset ps;
    sg_error err;
    assert_int_equal(sg_pointset_alloc(&ps, n, &err), SG_OK);
    for (size_t i = 0; i < n; ++i) {
        ps.nx[i] = ps.ny[i] = ps.nz[i] = 0.0f;
        ps.radius[i] = 1.0f;
    }
    return ps;
}

static void estimate(sg_pointset *ps, unsigned k, unsigned flags)
{
    sg_normals_desc d = {.k = k, .flags = flags};
    sg_error err;
    sg_status s = sg_points_estimate_normals(ps, &d, &err);
    if (s != SG_OK)
        fail_msg("estimate_normals(%zu points): %s: %s", ps->count, sg_status_name(s), err.message);
}

/* Fibonacci lattice on the sphere |p - c| = r, points [first, first+n). */
static void fibonacci_sphere(sg_pointset *ps, size_t first, size_t n, sg_vec3 c, float r)
{
    const float golden = 2.39996323f; /* pi (3 - sqrt 5) */
    for (size_t i = 0; i < n; ++i) {
        float y = 1.0f - 2.0f * ((float)i + 0.5f) / (float)n;
        float s = sqrtf(1.0f - y * y), phi = golden * (float)i;
        ps->px[first + i] = c.x + r * s * cosf(phi);
        ps->py[first + i] = c.y + r * y;
        ps->pz[first + i] = c.z + r * s * sinf(phi);
    }
}

/* "Outward" at point i means away from centre(ps, i, ctx). */
static sg_vec3 sphere_centre(const sg_pointset *ps, size_t i, const void *ctx)
{
    (void)ps;
    (void)i;
    return *(const sg_vec3 *)ctx;
}

typedef sg_vec3 (*centre_fn)(const sg_pointset *ps, size_t i, const void *ctx);

static void expect_outward(const sg_pointset *ps, centre_fn centre, const void *ctx, const char *what)
{
    for (size_t i = 0; i < ps->count; ++i) {
        sg_vec3 p = sg_pointset_position(ps, i), n = sg_pointset_normal(ps, i);
        sg_vec3 out = sg_v3_sub(p, centre(ps, i, ctx));
        if (!(sg_v3_dot(n, out) > 0.0f))
            fail_msg("%s: point %zu at (%g,%g,%g): normal (%g,%g,%g) is not outward (dir %g,%g,%g)",
                     what, i, (double)p.x, (double)p.y, (double)p.z, (double)n.x, (double)n.y,
                     (double)n.z, (double)out.x, (double)out.y, (double)out.z);
        float len = sg_v3_length(n);
        if (fabsf(len - 1.0f) > 1e-5f)
            fail_msg("%s: point %zu: |n| = %g", what, i, (double)len);
    }
}

/* ---- 1 ---------------------------------------------------------------- */

static void test_normals_eigen_random(void **state)
{
    (void)state;
    uint64_t rng = 11;
    static const double spectra[5][3] = {
        {1.0, 2.0, 3.0}, {0.0, 0.0, 5.0}, {2.0, 2.0, 2.0}, {1e-8, 1.0, 1.0}, {-3.0, 0.5, 1e6}};
    for (int trial = 0; trial < 500; ++trial) {
        const double *lam = spectra[trial % 5];
        /* Random rotation from a random unit quaternion. */
        double q[4], qn = 0.0;
        for (int c = 0; c < 4; ++c) {
            q[c] = 2.0 * sg_test_rand01(&rng) - 1.0;
            qn += q[c] * q[c];
        }
        qn = sqrt(qn);
        for (int c = 0; c < 4; ++c)
            q[c] /= qn;
        double w = q[0], x = q[1], y = q[2], z = q[3];
        double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
        double M[3][3];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                M[i][j] = 0.0;
                for (int m = 0; m < 3; ++m)
                    M[i][j] += R[i][m] * lam[m] * R[j][m];
            }
        double a[6] = {M[0][0], M[0][1], M[0][2], M[1][1], M[1][2], M[2][2]};
        double ev[3], vec[9];
        sg_sym3_eigen(a, ev, vec);
        double scale = fabs(lam[0]) + fabs(lam[1]) + fabs(lam[2]);
        double tol = 1e-12 * scale;
        for (int m = 0; m < 3; ++m) {
            if (fabs(ev[m] - lam[m]) > tol)
                fail_msg("trial %d: eigenvalue %d = %.17g, want %.17g", trial, m, ev[m], lam[m]);
            const double *v = vec + 3 * m;
            for (int i = 0; i < 3; ++i) {
                double av = M[i][0] * v[0] + M[i][1] * v[1] + M[i][2] * v[2];
                if (fabs(av - ev[m] * v[i]) > tol)
                    fail_msg("trial %d: (A v - w v)[%d] = %g for eigenvector %d", trial, i,
                             av - ev[m] * v[i], m);
            }
            for (int o = 0; o < 3; ++o) {
                const double *u = vec + 3 * o;
                double d = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
                if (fabs(d - (o == m ? 1.0 : 0.0)) > 1e-12)
                    fail_msg("trial %d: v%d . v%d = %.17g", trial, m, o, d);
            }
        }
    }
}

/* ---- 2-4 -------------------------------------------------------------- */

/* Accuracy bound for PCA on a sphere of radius R. The k+1 points of a
 * neighbourhood lie within rho (the k-th neighbour distance) of p, and a
 * sphere point at chord distance c from p lies c^2/(2R) below the tangent
 * plane at p: the neighbourhood sits in a slab of thickness h = rho^2/(2R)
 * around that plane. The fitted plane tilts by at most the coupling of the
 * normal and tangent directions over the spectral gap (Davis-Kahan):
 * sin(theta) <= sqrt(var_n var_t) / (var_t - var_n) with var_n <= (h/2)^2.
 * An even (Fibonacci) neighbourhood fills a disk of radius rho, var_t
 * ~ rho^2/4, so theta <~ (h/2)(rho/2)/(rho^2/4) = rho/(2R), the bound
 * checked per point (the ratio reached is printed; about 0.2 of it). */
static void test_normals_sphere_accuracy(void **state)
{
    (void)state;
    const size_t n = 20000;
    const unsigned k = 12;
    sg_pointset ps = alloc_ps(n);
    sg_vec3 c = sg_v3(0.5f, -1.0f, 2.0f);
    fibonacci_sphere(&ps, 0, n, c, 1.0f);
    estimate(&ps, k, 0);
    expect_outward(&ps, sphere_centre, &c, "fibonacci sphere");
    sg_knn_desc kd = {.count = n, .px = ps.px, .py = ps.py, .pz = ps.pz};
    sg_knn *t;
    sg_error err;
    assert_int_equal(sg_knn_create(&kd, &t, &err), SG_OK);
    float *kth = malloc(n * sizeof(float));
    assert_non_null(kth);
    assert_int_equal(sg_knn_kth_all(t, k, kth, &err), SG_OK);
    double worst_ratio = 0.0;
    for (size_t i = 0; i < n; ++i) {
        sg_vec3 truth = sg_v3_normalize(sg_v3_sub(sg_pointset_position(&ps, i), c));
        double d = sg_v3_dot(truth, sg_pointset_normal(&ps, i));
        double theta = acos(d > 1.0 ? 1.0 : d);
        double bound = sqrt((double)kth[i]) / (2.0 * 1.0); /* rho / (2R), R = 1 */
        if (theta / bound > worst_ratio)
            worst_ratio = theta / bound;
        if (!(theta <= bound))
            fail_msg("point %zu: normal off by %g rad, bound rho/(2R) = %g", i, theta, bound);
    }
    printf("sphere accuracy: worst theta / (rho/(2R)) = %.3f\n", worst_ratio);
    free(kth);
    sg_knn_destroy(t);
    sg_pointset_free(&ps);
}

static void test_normals_sphere_random(void **state)
{
    (void)state;
    const size_t n = 20000;
    sg_pointset ps = alloc_ps(n);
    uint64_t rng = 12;
    for (size_t i = 0; i < n; ++i) {
        float z = 2.0f * sg_test_rand01(&rng) - 1.0f, phi = 2.0f * PI_F * sg_test_rand01(&rng);
        float s = sqrtf(1.0f - z * z);
        ps.px[i] = s * cosf(phi);
        ps.py[i] = s * sinf(phi);
        ps.pz[i] = z;
    }
    estimate(&ps, 0, 0);
    sg_vec3 c = sg_v3(0, 0, 0);
    expect_outward(&ps, sphere_centre, &c, "random sphere");
    sg_pointset_free(&ps);
}

static sg_vec3 two_centres(const sg_pointset *ps, size_t i, const void *ctx)
{
    (void)ps;
    const sg_vec3 *c = ctx;
    return i < 5000 ? c[0] : c[1];
}

static void test_normals_two_spheres(void **state)
{
    (void)state;
    sg_pointset ps = alloc_ps(10000);
    sg_vec3 c[2] = {sg_v3(0, 0, 0), sg_v3(5, 1, 0)};
    fibonacci_sphere(&ps, 0, 5000, c[0], 1.0f);
    fibonacci_sphere(&ps, 5000, 5000, c[1], 0.5f);
    estimate(&ps, 0, 0);
    expect_outward(&ps, two_centres, c, "two spheres");
    sg_pointset_free(&ps);
}

/* ---- 5-7 -------------------------------------------------------------- */

#define TORUS_R 1.0f
#define TORUS_r 0.35f

/* Nearest point of the tube's centre circle (torus around +y). */
static sg_vec3 torus_centre(const sg_pointset *ps, size_t i, const void *ctx)
{
    (void)ctx;
    float x = ps->px[i], z = ps->pz[i], l = sqrtf(x * x + z * z);
    return sg_v3(TORUS_R * x / l, 0.0f, TORUS_R * z / l);
}

static void test_normals_torus_outward(void **state)
{
    (void)state;
    /* A jittered (u,v) grid; about even on the surface away from the hole. */
    const size_t nu = 300, nv = 110, n = nu * nv;
    sg_pointset ps = alloc_ps(n);
    uint64_t rng = 13;
    for (size_t a = 0; a < nu; ++a)
        for (size_t b = 0; b < nv; ++b) {
            float u = 2.0f * PI_F * ((float)a + sg_test_rand01(&rng)) / (float)nu;
            float v = 2.0f * PI_F * ((float)b + sg_test_rand01(&rng)) / (float)nv;
            size_t i = a * nv + b;
            ps.px[i] = (TORUS_R + TORUS_r * cosf(v)) * cosf(u);
            ps.py[i] = TORUS_r * sinf(v);
            ps.pz[i] = (TORUS_R + TORUS_r * cosf(v)) * sinf(u);
        }
    estimate(&ps, 0, 0);
    expect_outward(&ps, torus_centre, NULL, "torus");
    sg_pointset_free(&ps);
}

static sg_vec3 box_centre(const sg_pointset *ps, size_t i, const void *ctx)
{
    (void)ps;
    (void)i;
    (void)ctx;
    return sg_v3(0, 0, 0);
}

static void test_normals_box_outward(void **state)
{
    (void)state;
    /* Box [-1,1] x [-0.5,0.5] x [-0.75,0.75], each face a jittered grid of
     * spacing ~0.02. */
    const float half[3] = {1.0f, 0.5f, 0.75f}, h = 0.02f;
    size_t n = 0;
    for (int ax = 0; ax < 3; ++ax) {
        int u = (ax + 1) % 3, v = (ax + 2) % 3;
        n += 2 * (size_t)(2.0f * half[u] / h) * (size_t)(2.0f * half[v] / h);
    }
    sg_pointset ps = alloc_ps(n);
    uint64_t rng = 14;
    size_t i = 0;
    for (int ax = 0; ax < 3; ++ax)
        for (int side = -1; side <= 1; side += 2) {
            int u = (ax + 1) % 3, v = (ax + 2) % 3;
            size_t nu = (size_t)(2.0f * half[u] / h), nv = (size_t)(2.0f * half[v] / h);
            for (size_t a = 0; a < nu; ++a)
                for (size_t b = 0; b < nv; ++b, ++i) {
                    float p[3];
                    p[ax] = (float)side * half[ax];
                    p[u] = -half[u] + h * ((float)a + 0.1f + 0.8f * sg_test_rand01(&rng));
                    p[v] = -half[v] + h * ((float)b + 0.1f + 0.8f * sg_test_rand01(&rng));
                    ps.px[i] = p[0];
                    ps.py[i] = p[1];
                    ps.pz[i] = p[2];
                }
        }
    assert_int_equal(i, n);
    estimate(&ps, 0, 0);
    expect_outward(&ps, box_centre, NULL, "box");
    /* Away from edges (4h: beyond any 12-neighbourhood's reach) all
     * neighbours are coplanar, so the normal is the face normal to float
     * precision. */
    for (size_t j = 0; j < n; ++j) {
        float p[3] = {ps.px[j], ps.py[j], ps.pz[j]}, nn[3] = {ps.nx[j], ps.ny[j], ps.nz[j]};
        int face = -1, near_edge = 0;
        for (int ax = 0; ax < 3; ++ax) {
            if (fabsf(fabsf(p[ax]) - half[ax]) == 0.0f)
                face = ax;
            else if (half[ax] - fabsf(p[ax]) < 4.0f * h)
                near_edge = 1;
        }
        assert_true(face >= 0);
        if (near_edge)
            continue;
        for (int ax = 0; ax < 3; ++ax) {
            float want = ax == face ? (p[ax] > 0.0f ? 1.0f : -1.0f) : 0.0f;
            if (fabsf(nn[ax] - want) > 1e-5f)
                fail_msg("box point %zu (%g,%g,%g): normal (%g,%g,%g), want face %d", j,
                         (double)p[0], (double)p[1], (double)p[2], (double)nn[0], (double)nn[1],
                         (double)nn[2], face);
        }
    }
    sg_pointset_free(&ps);
}

static void test_normals_plane(void **state)
{
    (void)state;
    const size_t side = 60, n = side * side;
    sg_pointset ps = alloc_ps(n);
    uint64_t rng = 15;
    for (int vertical = 0; vertical < 2; ++vertical) {
        for (size_t i = 0; i < n; ++i) {
            float a = (float)(i / side) + 0.9f * sg_test_rand01(&rng), b = (float)(i % side);
            ps.px[i] = vertical ? 2.0f : a;
            ps.py[i] = vertical ? a : 2.0f;
            ps.pz[i] = b;
            ps.nx[i] = ps.ny[i] = ps.nz[i] = 0.0f;
        }
        estimate(&ps, 0, 0);
        float sign = vertical ? ps.nx[0] : 1.0f;
        assert_true(fabsf(sign) == 1.0f);
        for (size_t i = 0; i < n; ++i) {
            float want[3] = {vertical ? sign : 0.0f, vertical ? 0.0f : 1.0f, 0.0f};
            float got[3] = {ps.nx[i], ps.ny[i], ps.nz[i]};
            for (int c = 0; c < 3; ++c)
                if (fabsf(got[c] - want[c]) > 1e-6f)
                    fail_msg("%s plane point %zu: normal (%g,%g,%g), want (%g,%g,%g)",
                             vertical ? "vertical" : "horizontal", i, (double)got[0],
                             (double)got[1], (double)got[2], (double)want[0], (double)want[1],
                             (double)want[2]);
        }
    }
    sg_pointset_free(&ps);
}

/* ---- 8-10 ------------------------------------------------------------- */

static void test_normals_only_missing(void **state)
{
    (void)state;
    const size_t n = 8000;
    sg_pointset ps = alloc_ps(n);
    sg_vec3 c = sg_v3(0, 0, 0);
    fibonacci_sphere(&ps, 0, n, c, 1.0f);
    for (int inward = 0; inward < 2; ++inward) {
        float s = inward ? -1.0f : 1.0f;
        /* Known: the true normal (times s) on every other latitude band of
         * ~50 points; the rest unknown. Bands make the unknown regions
         * reachable only through the graph. */
        for (size_t i = 0; i < n; ++i) {
            int known = (i / 50) % 2 == 0;
            ps.nx[i] = known ? s * ps.px[i] : 0.0f;
            ps.ny[i] = known ? s * ps.py[i] : 0.0f;
            ps.nz[i] = known ? s * ps.pz[i] : 0.0f;
        }
        if (inward)
            ps.nx[1] = NAN; /* a non-finite normal counts as missing too */
        float *before = malloc(3 * n * sizeof(float));
        assert_non_null(before);
        memcpy(before, ps.nx, n * sizeof(float));
        memcpy(before + n, ps.ny, n * sizeof(float));
        memcpy(before + 2 * n, ps.nz, n * sizeof(float));
        estimate(&ps, 0, SG_NORMALS_ONLY_MISSING);
        for (size_t i = 0; i < n; ++i) {
            int known = (i / 50) % 2 == 0 && !(inward && i == 1);
            if (known && (ps.nx[i] != before[i] || ps.ny[i] != before[n + i] || ps.nz[i] != before[2 * n + i]))
                fail_msg("known normal %zu changed", i);
            float d = s * sg_v3_dot(sg_pointset_normal(&ps, i), sg_pointset_position(&ps, i));
            if (!(d > 0.9f))
                fail_msg("%s: point %zu (%s): normal . radial = %g, want > 0.9 towards the known side",
                         inward ? "inward" : "outward", i, known ? "known" : "estimated", (double)(s * d));
        }
        free(before);
    }
    sg_pointset_free(&ps);
}

static void test_normals_threads_identical(void **state)
{
    (void)state;
    const size_t n = 40000;
    sg_pointset ps[2];
    int saved = omp_get_max_threads();
    for (int run = 0; run < 2; ++run) {
        ps[run] = alloc_ps(n);
        uint64_t rng = 16;
        for (size_t i = 0; i < n; ++i) { /* a wavy sheet */
            float x = sg_test_rand01(&rng), z = sg_test_rand01(&rng);
            ps[run].px[i] = x;
            ps[run].py[i] = 0.1f * sinf(6.0f * x) * cosf(4.0f * z);
            ps[run].pz[i] = z;
        }
        omp_set_num_threads(run + 1);
        estimate(&ps[run], 0, 0);
    }
    omp_set_num_threads(saved);
    for (size_t i = 0; i < n; ++i)
        if (memcmp(&ps[0].nx[i], &ps[1].nx[i], 4) || memcmp(&ps[0].ny[i], &ps[1].ny[i], 4) ||
            memcmp(&ps[0].nz[i], &ps[1].nz[i], 4))
            fail_msg("point %zu: 1 thread (%g,%g,%g), 2 threads (%g,%g,%g)", i, (double)ps[0].nx[i],
                     (double)ps[0].ny[i], (double)ps[0].nz[i], (double)ps[1].nx[i],
                     (double)ps[1].ny[i], (double)ps[1].nz[i]);
    sg_pointset_free(&ps[0]);
    sg_pointset_free(&ps[1]);
}

static void test_normals_errors(void **state)
{
    (void)state;
    sg_error err;
    sg_pointset ps = alloc_ps(2);
    ps.px[0] = 0.0f;
    ps.px[1] = 1.0f;
    ps.py[0] = ps.py[1] = ps.pz[0] = ps.pz[1] = 0.0f;
    assert_int_equal(sg_points_estimate_normals(&ps, NULL, &err), SG_ERR_INVALID_ARG);
    assert_true(ps.nx[0] == 0.0f && ps.ny[0] == 0.0f && ps.nz[0] == 0.0f);
    sg_pointset_free(&ps);

    ps = alloc_ps(100);
    fibonacci_sphere(&ps, 0, 100, sg_v3(0, 0, 0), 1.0f);
    ps.pz[42] = NAN;
    assert_int_equal(sg_points_estimate_normals(&ps, NULL, &err), SG_ERR_INVALID_ARG);
    if (!strstr(err.message, "point 42"))
        fail_msg("message \"%s\" does not name point 42", err.message);
    for (size_t i = 0; i < 100; ++i)
        assert_true(ps.nx[i] == 0.0f && ps.ny[i] == 0.0f && ps.nz[i] == 0.0f);
    sg_pointset_free(&ps);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_normals_eigen_random),
        cmocka_unit_test(test_normals_sphere_accuracy),
        cmocka_unit_test(test_normals_sphere_random),
        cmocka_unit_test(test_normals_two_spheres),
        cmocka_unit_test(test_normals_torus_outward),
        cmocka_unit_test(test_normals_box_outward),
        cmocka_unit_test(test_normals_plane),
        cmocka_unit_test(test_normals_only_missing),
        cmocka_unit_test(test_normals_threads_identical),
        cmocka_unit_test(test_normals_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
