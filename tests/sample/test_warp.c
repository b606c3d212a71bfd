/* test_warp.c — the square-to-disk/sphere/hemisphere warps (sample/warp.h).
 *
 *  1. warp::invert_roundtrip   invert(sample(u)) = u for random u, all four
 *                              warps (azimuth compared on the circle).
 *  2. warp::support            samples are unit (disk: |p| <= 1) and inside
 *                              the support; pdf is 0 outside it.
 *  3. warp::pdf_integrates     the pdf integrates to 1 over its domain
 *                              (randomised rank-1 lattice QMC, 4 standard
 *                              errors from the shift-to-shift spread).
 *  4. warp::chi2               histograms of 10^6 samples against the
 *                              integrated pdf: chi-square at alpha = 0.01,
 *                              Sidak-corrected over the four warps, cells
 *                              pooled to >= 5 expected, fixed seed.
 *
 * The chi-square and lattice helpers are duplicated in
 * tests/material/test_bsdf.c (each suite is one self-contained file).
 */
#include "test_support.h"
#include "test_stats.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "math/rng.h"
#include "sample/warp.h"

#define PI_D 3.14159265358979323846
#define SEED 0x5157A8Bull


/* ---- warps under test, through one interface ----------------------------
 * Directions are parametrised by (z, phi) on [-1,1] x [0,2pi) (area element
 * dz dphi = solid angle); the disk by (r, phi) with area r dr dphi. */

typedef struct warp {
    const char *name;
    int is_disk;
} warp;

static const warp WARPS[] = {{"disk", 1}, {"sphere", 0}, {"hemisphere", 0}, {"cosine_hemisphere", 0}};
#define NWARPS 4

static sg_vec3 w_sample(int w, float u0, float u1)
{
    float p[2];
    switch (w) {
    case 0:
        sg_warp_disk_sample(u0, u1, p);
        return sg_v3(p[0], p[1], 0.0f);
    case 1:
        return sg_warp_sphere_sample(u0, u1);
    case 2:
        return sg_warp_hemisphere_sample(u0, u1);
    default:
        return sg_warp_cosine_hemisphere_sample(u0, u1);
    }
}

static float w_pdf(int w, sg_vec3 x)
{
    switch (w) {
    case 0:
        return sg_warp_disk_pdf(x.x, x.y);
    case 1:
        return sg_warp_sphere_pdf(x);
    case 2:
        return sg_warp_hemisphere_pdf(x);
    default:
        return sg_warp_cosine_hemisphere_pdf(x);
    }
}

static void w_invert(int w, sg_vec3 x, float u[2])
{
    switch (w) {
    case 0:
        sg_warp_disk_invert(x.x, x.y, u);
        return;
    case 1:
        sg_warp_sphere_invert(x, u);
        return;
    case 2:
        sg_warp_hemisphere_invert(x, u);
        return;
    default:
        sg_warp_cosine_hemisphere_invert(x, u);
        return;
    }
}

/* Point of the domain at parameters (a, b): disk (r, phi), sphere (z, phi). */
static sg_vec3 w_point(int w, double a, double phi)
{
    if (WARPS[w].is_disk)
        return sg_v3((float)(a * cos(phi)), (float)(a * sin(phi)), 0.0f);
    double r = sqrt(fmax(0.0, 1.0 - a * a));
    return sg_v3((float)(r * cos(phi)), (float)(r * sin(phi)), (float)a);
}

/* Range of the first parameter and the area element's factor. */
static double w_lo(int w) { return WARPS[w].is_disk ? 0.0 : -1.0; }
static double w_jac(int w, double a) { return WARPS[w].is_disk ? a : 1.0; }

/* ---- 1 ---------------------------------------------------------------- */

/* Tolerance: the round trip passes through float sqrt/atan2/cos/sin, each
 * within a few ulp (~1e-7 relative; the worst error seen is 2.4e-7). Near
 * the poles of the sphere warps the azimuth of a point at radius r is only
 * determined to ~1e-7 / r, so it is compared only where r > 1e-2, where
 * that bound is 1e-5; we allow 2e-5. A wrong mapping is off by O(0.1). */
static void test_warp_invert_roundtrip(void **state)
{
    (void)state;
    for (int w = 0; w < NWARPS; ++w) {
        double worst = 0.0;
        for (uint64_t i = 0; i < 200000; ++i) {
            float u[2] = {sg_rng_float(SEED, i, 0, 0), sg_rng_float(SEED, i, 0, 1)}, v[2];
            sg_vec3 x = w_sample(w, u[0], u[1]);
            w_invert(w, x, v);
            double r = WARPS[w].is_disk || w == 3 ? sqrt(x.x * x.x + x.y * x.y) : sqrt(1.0 - x.z * x.z);
            for (int k = 0; k < 2; ++k) {
                double d = fabs((double)u[k] - v[k]);
                int azimuth = !WARPS[w].is_disk && w != 3 && k == 1;
                if (azimuth) {
                    d = fmin(d, 1.0 - d); /* 0 and 1 are the same azimuth */
                    if (r < 1e-2)
                        continue;
                }
                if (d > worst)
                    worst = d;
                if (d > 2e-5)
                    fail_msg("%s: u = (%.9g, %.9g) -> x = (%g, %g, %g) -> u' = (%.9g, %.9g): |du%d| = %g > 2e-5",
                             WARPS[w].name, u[0], u[1], x.x, x.y, x.z, v[0], v[1], k, d);
            }
        }
        printf("%s: worst round-trip error %.3g\n", WARPS[w].name, worst);
    }
}

/* ---- 2 ---------------------------------------------------------------- */

static void test_warp_support(void **state)
{
    (void)state;
    for (int w = 0; w < NWARPS; ++w)
        for (uint64_t i = 0; i < 100000; ++i) {
            float u0 = sg_rng_float(SEED, i, 1, 0), u1 = sg_rng_float(SEED, i, 1, 1);
            if (i == 0)
                u0 = u1 = 0.0f; /* the corner of the square */
            sg_vec3 x = w_sample(w, u0, u1);
            double len = sg_v3_length(x);
            if (!sg_v3_isfinite(x) || (WARPS[w].is_disk ? len > 1.0 + 1e-6 : fabs(len - 1.0) > 1e-5))
                fail_msg("%s: u = (%g, %g) gives (%g, %g, %g), length %g", WARPS[w].name, u0, u1, x.x, x.y, x.z,
                         len);
            if ((w == 2 || w == 3) && x.z < 0.0f)
                fail_msg("%s: u = (%g, %g) gives z = %g < 0", WARPS[w].name, u0, u1, x.z);
            if (!(w_pdf(w, x) > 0.0f) && !(w == 3 && x.z == 0.0f))
                fail_msg("%s: sample (%g, %g, %g) has pdf %g", WARPS[w].name, x.x, x.y, x.z, w_pdf(w, x));
        }
    assert_true(sg_warp_disk_pdf(0.8f, 0.8f) == 0.0f);
    assert_true(sg_warp_hemisphere_pdf(sg_v3(0, 0, -1)) == 0.0f);
    assert_true(sg_warp_cosine_hemisphere_pdf(sg_v3(0.6f, 0, -0.8f)) == 0.0f);
    assert_true(fabs(sg_warp_cosine_hemisphere_pdf(sg_v3(0.6f, 0, 0.8f)) - 0.8 / PI_D) < 1e-7);
}

/* ---- 3 ---------------------------------------------------------------- */

/* Estimate: R = 32 independently shifted lattices, each an unbiased
 * estimate I_j of the integral; mean +- sd/sqrt(R). The bound 4 standard
 * errors plus the float rounding of the pdf values (relative 2^-23 each,
 * summed in double) fails a correct warp with probability ~1e-4. */
static void test_warp_pdf_integrates(void **state)
{
    (void)state;
    const int R = 32;
    for (int w = 0; w < NWARPS; ++w) {
        double lo = w_lo(w), span = 1.0 - lo, sum = 0.0, sum2 = 0.0;
        for (int j = 0; j < R; ++j) {
            double s0 = sg_rng_float(SEED, (uint64_t)j, 2, 0), s1 = sg_rng_float(SEED, (uint64_t)j, 2, 1), acc = 0.0;
            for (size_t i = 0; i < SG_TEST_LATTICE_N; ++i) {
                double a, b;
                sg_test_lattice(i, s0, s1, &a, &b);
                a = lo + span * a;
                b *= 2.0 * PI_D;
                acc += w_pdf(w, w_point(w, a, b)) * w_jac(w, a);
            }
            double est = acc / SG_TEST_LATTICE_N * span * 2.0 * PI_D;
            sum += est;
            sum2 += est * est;
        }
        double mean = sum / R, var = fmax(0.0, (sum2 - sum * sum / R) / (R - 1)), se = sqrt(var / R);
        double tol = 4.0 * se + 4.0 * FLT_EPSILON;
        printf("%s: integral of pdf = %.9f +- %.2g\n", WARPS[w].name, mean, se);
        if (fabs(mean - 1.0) > tol)
            fail_msg("%s: integral of pdf %.9f, expected 1 within %.3g (standard error %.3g)", WARPS[w].name, mean,
                     tol, se);
    }
}

/* ---- 4 ---------------------------------------------------------------- */

#define CHI_A 20  /* bins of the first parameter (z or r)  */
#define CHI_P 40  /* bins of the azimuth                   */
#define CHI_SUB 8 /* midpoint sub-samples per bin and axis */
#define CHI_N 1000000

static void test_warp_chi2(void **state)
{
    (void)state;
    const double alpha = sg_test_sidak(0.01, NWARPS);
    double *obs = calloc(CHI_A * CHI_P, sizeof *obs), *expd = calloc(CHI_A * CHI_P, sizeof *expd);
    assert_non_null(obs);
    assert_non_null(expd);
    for (int w = 0; w < NWARPS; ++w) {
        double lo = w_lo(w), da = (1.0 - lo) / CHI_A, dp = 2.0 * PI_D / CHI_P;
        memset(obs, 0, CHI_A * CHI_P * sizeof *obs);
        for (uint64_t i = 0; i < CHI_N; ++i) {
            sg_vec3 x = w_sample(w, sg_rng_float(SEED, i, 3 + w, 0), sg_rng_float(SEED, i, 3 + w, 1));
            double a = WARPS[w].is_disk ? sqrt((double)x.x * x.x + (double)x.y * x.y) : x.z;
            double phi = atan2(x.y, x.x);
            if (phi < 0.0)
                phi += 2.0 * PI_D;
            int ia = (int)((a - lo) / da), ip = (int)(phi / dp);
            ia = ia < 0 ? 0 : (ia >= CHI_A ? CHI_A - 1 : ia);
            ip = ip < 0 ? 0 : (ip >= CHI_P ? CHI_P - 1 : ip);
            obs[ia * CHI_P + ip] += 1.0;
        }
        /* Expected: N times the pdf integrated over the cell (midpoint rule
         * in (a, phi); every pdf here is at most linear in a per cell, and
         * the support edges lie on cell edges, so it is near exact). */
        for (int ia = 0; ia < CHI_A; ++ia)
            for (int ip = 0; ip < CHI_P; ++ip) {
                double acc = 0.0;
                for (int s = 0; s < CHI_SUB; ++s)
                    for (int t = 0; t < CHI_SUB; ++t) {
                        double a = lo + (ia + (s + 0.5) / CHI_SUB) * da, phi = (ip + (t + 0.5) / CHI_SUB) * dp;
                        acc += w_pdf(w, w_point(w, a, phi)) * w_jac(w, a);
                    }
                expd[ia * CHI_P + ip] = CHI_N * acc * da * dp / (CHI_SUB * CHI_SUB);
            }
        int dof;
        double chi2, p = sg_test_chi2(WARPS[w].name, obs, expd, CHI_A * CHI_P, &dof, &chi2);
        printf("%s: chi2 = %.1f, dof = %d, p = %.4f (reject below %.5f)\n", WARPS[w].name, chi2, dof, p, alpha);
        if (!(p >= alpha)) {
            sg_test_dump_table(WARPS[w].name, obs, expd, CHI_A * CHI_P, CHI_P);
            fail_msg("%s: chi-square %.1f with %d dof, p = %.3g < %.3g", WARPS[w].name, chi2, dof, p, alpha);
        }
    }
    free(obs);
    free(expd);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_warp_invert_roundtrip),
        cmocka_unit_test(test_warp_support),
        cmocka_unit_test(test_warp_pdf_integrates),
        cmocka_unit_test(test_warp_chi2),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
