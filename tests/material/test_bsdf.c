/* test_bsdf.c — materials: Lambert + GGX glossy mixture (material/bsdf.h).
 *
 *  1. bsdf::reciprocity          f(wo, wi) = f(wi, wo) for random materials
 *                                and direction pairs on either side.
 *  2. bsdf::two_sided            flipping n changes nothing; wi on the other
 *                                side of wo gives f = 0 and pdf = 0.
 *  3. bsdf::lambert_albedo       int f cos dwi = rho (QMC) and every sample
 *                                weight equals rho.
 *  4. bsdf::energy_bound         glossy lobe: directional albedo <= 1 for
 *                                7 roughnesses x 6 view angles (QMC, 4
 *                                standard errors); near 1 where it must be;
 *                                the mixture is (1 - k) Lambert + k glossy.
 *  5. bsdf::sample_consistent    sample's pdf = sg_bsdf_pdf, weight =
 *                                f cos / pdf <= 1, wi unit on wo's side;
 *                                int pdf over the hemisphere (QMC) = the
 *                                fraction of successful samples.
 *  6. bsdf::estimator_vs_qmc     the sampling estimator of int f cos agrees
 *                                with the QMC integral within 4 sigma.
 *  7. bsdf::chi2                 sampled wi against the integrated pdf,
 *                                7 (material, wo) configurations, alpha =
 *                                0.01 Sidak-corrected, cells pooled to >= 5.
 *  8. material::validate_albedo  field checks; per-point albedo rule.
 *
 * The QMC integrals do not use the code under test's sampling: they mix
 * cosine-hemisphere and classic D(h) cos(h) half-vector sampling (Walter et
 * al. 2007, eq. 35, written again here) with the balance heuristic, using
 * sg_bsdf_eval / sg_bsdf_pdf only as integrands.
 */
#include "test_support.h"
#include "test_stats.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "material/bsdf.h"
#include "math/rng.h"
#include "sample/warp.h"

#define PI_D 3.14159265358979323846
#define SEED 0xB5DFull


/* ---- frames and materials --------------------------------------------- */

/* A shading normal off every axis, so the frame code is exercised. */
typedef struct frame {
    sg_vec3 t, b, n;
} frame;

static frame test_frame(void)
{
    frame f;
    f.n = sg_v3_normalize(sg_v3(0.3f, 0.8f, -0.5f));
    sg_v3_basis(f.n, &f.t, &f.b);
    return f;
}

static sg_vec3 to_world(const frame *f, sg_vec3 l)
{
    return sg_v3_add(sg_v3_add(sg_v3_scale(f->t, l.x), sg_v3_scale(f->b, l.y)), sg_v3_scale(f->n, l.z));
}

static sg_vec3 to_local(const frame *f, sg_vec3 w)
{
    return sg_v3(sg_v3_dot(f->t, w), sg_v3_dot(f->b, w), sg_v3_dot(f->n, w));
}

/* wo in the local xz-plane at cosine c. */
static sg_vec3 wo_local(double c) { return sg_v3((float)sqrt(fmax(0.0, 1.0 - c * c)), 0.0f, (float)c); }

static sg_material mat_ggx(float roughness, float k)
{
    sg_material m = sg_material_default();
    m.type = SG_MATERIAL_GGX;
    m.roughness = roughness;
    m.specular = k;
    return m;
}

static float channel(sg_vec3 v, int c) { return c == 0 ? v.x : (c == 1 ? v.y : v.z); }

/* ---- an independent reference: classic half-vector sampling ------------ */

static double ref_alpha(const sg_material *m)
{
    double a = (double)m->roughness * m->roughness;
    return a > SG_BSDF_MIN_ALPHA ? a : SG_BSDF_MIN_ALPHA;
}

/* GGX D(h) (Walter et al. 2007, eq. 33), from cos of h's angle to n. */
static double ref_d(double alpha, double cos_h)
{
    double a2 = alpha * alpha, c2 = cos_h * cos_h, t = c2 * (a2 - 1.0) + 1.0;
    return a2 / (PI_D * t * t);
}

typedef double (*integrand)(const void *ctx, sg_vec3 wi_world);

typedef struct qmc_setup {
    const frame *f;
    sg_vec3 wo; /* local */
    double alpha;
    integrand g;
    const void *ctx;
} qmc_setup;

/* g(wi) / (p_cos(wi) + p_half(wi)): the balance heuristic with one sample of
 * each strategy (Veach 1997, §9.2.2), so the sum of both terms over the two
 * samples is unbiased for int g over the upper hemisphere. */
static double mis_term(const qmc_setup *q, sg_vec3 wi)
{
    double hx = (double)q->wo.x + wi.x, hy = (double)q->wo.y + wi.y, hz = (double)q->wo.z + wi.z;
    double hl = sqrt(hx * hx + hy * hy + hz * hz);
    hx /= hl, hy /= hl, hz /= hl;
    double oh = q->wo.x * hx + q->wo.y * hy + q->wo.z * hz;
    double p_cos = wi.z / PI_D, p_half = ref_d(q->alpha, hz) * hz / (4.0 * oh);
    return q->g(q->ctx, to_world(q->f, wi)) / (p_cos + p_half);
}

/* Randomised QMC (R shifted Fibonacci lattices) of int g dwi over the
 * hemisphere around n; *mean and its standard error *se from the spread of
 * the R independent estimates. */
static void qmc_hemisphere(const qmc_setup *q, uint64_t stream, double *mean, double *se)
{
    const int R = 16;
    double sum = 0.0, sum2 = 0.0;
    for (int j = 0; j < R; ++j) {
        double s0 = sg_rng_float(SEED, stream, (uint32_t)j, 0), s1 = sg_rng_float(SEED, stream, (uint32_t)j, 1);
        double acc = 0.0;
        for (size_t i = 0; i < SG_TEST_LATTICE_N; ++i) {
            double u0, u1;
            sg_test_lattice(i, s0, s1, &u0, &u1);
            sg_vec3 d = sg_warp_cosine_hemisphere_sample((float)u0, (float)u1);
            if (d.z > 0.0f)
                acc += mis_term(q, d);
            /* Walter et al. 2007, eq. 35: tan^2 theta_h = alpha^2 u / (1 - u). */
            double tan2 = q->alpha * q->alpha * u0 / (1.0 - u0), ch = 1.0 / sqrt(1.0 + tan2);
            double sh = sqrt(fmax(0.0, 1.0 - ch * ch)), phi = 2.0 * PI_D * u1;
            double hx = sh * cos(phi), hy = sh * sin(phi);
            double oh = q->wo.x * hx + q->wo.y * hy + q->wo.z * ch;
            double wx = 2.0 * oh * hx - q->wo.x, wy = 2.0 * oh * hy - q->wo.y, wz = 2.0 * oh * ch - q->wo.z;
            if (wz > 0.0 && oh > 0.0) {
                double l = sqrt(wx * wx + wy * wy + wz * wz);
                acc += mis_term(q, sg_v3((float)(wx / l), (float)(wy / l), (float)(wz / l)));
            }
        }
        double est = acc / SG_TEST_LATTICE_N;
        sum += est;
        sum2 += est * est;
    }
    *mean = sum / R;
    *se = sqrt(fmax(0.0, (sum2 - sum * sum / R) / (R - 1)) / R);
}

typedef struct eval_ctx {
    const sg_material *m;
    sg_vec3 albedo, n, wo; /* world */
    int channel;
} eval_ctx;

static double g_fcos(const void *ctx, sg_vec3 wi)
{
    const eval_ctx *e = ctx;
    return channel(sg_bsdf_eval(e->m, e->albedo, e->n, e->wo, wi), e->channel) * fabs(sg_v3_dot(e->n, wi));
}

static double g_pdf(const void *ctx, sg_vec3 wi)
{
    const eval_ctx *e = ctx;
    return sg_bsdf_pdf(e->m, e->n, e->wo, wi);
}

/* int f cos dwi (one channel) or int pdf dwi for material m at view cos_o. */
static void integrate(const sg_material *m, sg_vec3 albedo, double cos_o, int chan, integrand g, uint64_t stream,
                      double *mean, double *se)
{
    frame f = test_frame();
    sg_vec3 wo = wo_local(cos_o);
    eval_ctx e = {m, albedo, f.n, sg_v3_normalize(to_world(&f, wo)), chan};
    qmc_setup q = {&f, wo, ref_alpha(m), g, &e};
    qmc_hemisphere(&q, stream, mean, se);
}

/* ---- 1 ---------------------------------------------------------------- */

static sg_vec3 random_dir(uint64_t i, uint32_t dim)
{
    return sg_warp_sphere_sample(sg_rng_float(SEED, i, 1, dim), sg_rng_float(SEED, i, 1, dim + 1));
}

static void test_bsdf_reciprocity(void **state)
{
    (void)state;
    int checked = 0;
    for (uint64_t i = 0; i < 200000; ++i) {
        sg_material m = mat_ggx(sg_rng_float(SEED, i, 0, 0), sg_rng_float(SEED, i, 0, 1));
        if (i % 4 == 0)
            m.type = SG_MATERIAL_LAMBERT;
        sg_vec3 rho = sg_v3(0.9f, 0.5f, 0.2f);
        sg_vec3 n = random_dir(i, 0), wo = random_dir(i, 2), wi = random_dir(i, 4);
        sg_vec3 a = sg_bsdf_eval(&m, rho, n, wo, wi), b = sg_bsdf_eval(&m, rho, n, wi, wo);
        for (int c = 0; c < 3; ++c) {
            double x = channel(a, c), y = channel(b, c);
            /* Both orders evaluate the same symmetric expressions, so only
             * float reassociation could separate them. */
            if (!(fabs(x - y) <= 1e-6 * fmax(fabs(x), fabs(y))))
                fail_msg("roughness %g specular %g n (%g,%g,%g) wo (%g,%g,%g) wi (%g,%g,%g): f(wo,wi)[%d] = %.9g, "
                         "f(wi,wo) = %.9g",
                         m.roughness, m.specular, n.x, n.y, n.z, wo.x, wo.y, wo.z, wi.x, wi.y, wi.z, c, x, y);
        }
        checked += a.x > 0.0f;
    }
    printf("reciprocity: %d of 200000 pairs on one side, all symmetric\n", checked);
    assert_true(checked > 50000); /* half the pairs share a side */
}

/* ---- 2 ---------------------------------------------------------------- */

static void test_bsdf_two_sided(void **state)
{
    (void)state;
    sg_material m = mat_ggx(0.4f, 0.5f);
    sg_vec3 rho = sg_v3(0.7f, 0.7f, 0.7f);
    for (uint64_t i = 0; i < 20000; ++i) {
        sg_vec3 n = random_dir(i, 10), wo = random_dir(i, 12), wi = random_dir(i, 14);
        sg_vec3 neg = sg_v3_scale(n, -1.0f);
        sg_vec3 a = sg_bsdf_eval(&m, rho, n, wo, wi), b = sg_bsdf_eval(&m, rho, neg, wo, wi);
        float pa = sg_bsdf_pdf(&m, n, wo, wi), pb = sg_bsdf_pdf(&m, neg, wo, wi);
        if (a.x != b.x || pa != pb)
            fail_msg("n (%g,%g,%g): f %g vs %g with -n; pdf %g vs %g", n.x, n.y, n.z, a.x, b.x, pa, pb);
        int same_side = sg_v3_dot(n, wo) * sg_v3_dot(n, wi) > 0.0f;
        if (!same_side && (a.x != 0.0f || pa != 0.0f))
            fail_msg("wo, wi on opposite sides of n (%g,%g,%g): f = %g, pdf = %g, expected 0", n.x, n.y, n.z, a.x,
                     pa);
        if (same_side && !(a.x > 0.0f && pa > 0.0f))
            fail_msg("wo, wi on one side: f = %g, pdf = %g, expected > 0", a.x, pa);
        sg_vec3 w, wt;
        float p;
        if (sg_bsdf_sample(&m, rho, n, wo, sg_rng_float(SEED, i, 2, 0), sg_rng_float(SEED, i, 2, 1),
                           sg_rng_float(SEED, i, 2, 2), &w, &p, &wt) &&
            !(sg_v3_dot(n, wo) * sg_v3_dot(n, w) > 0.0f))
            fail_msg("sampled wi (%g,%g,%g) is not on the side of wo (%g,%g,%g) for n (%g,%g,%g)", w.x, w.y, w.z,
                     wo.x, wo.y, wo.z, n.x, n.y, n.z);
    }
    /* Tangent wo: nothing to reflect. */
    sg_vec3 n = sg_v3(0, 0, 1), wo = sg_v3(1, 0, 0), wi = sg_v3(0, 0, 1), w = sg_v3(9, 9, 9), wt = w;
    float p = 9.0f;
    assert_true(sg_bsdf_eval(&m, rho, n, wo, wi).x == 0.0f);
    assert_int_equal(sg_bsdf_sample(&m, rho, n, wo, 0.5f, 0.5f, 0.5f, &w, &p, &wt), 0);
    assert_true(p == 9.0f && w.x == 9.0f); /* outputs untouched on failure */
}

/* ---- 3 ---------------------------------------------------------------- */

/* Tolerance of every QMC comparison: 4 standard errors of the randomised
 * lattice estimate (probability ~6e-5 of failing a correct integral, Gaussian
 * tail) plus 1e-5 for the float rounding of the integrand (relative 2^-23
 * per evaluation, averaged in double). */
#define QMC_TOL(se) (4.0 * (se) + 1e-5)

static void test_bsdf_lambert_albedo(void **state)
{
    (void)state;
    sg_material m = sg_material_default();
    sg_vec3 rho = sg_v3(0.9f, 0.5f, 0.2f);
    const double cosines[] = {1.0, 0.7, 0.3, 0.05};
    for (int k = 0; k < 4; ++k)
        for (int c = 0; c < 3; ++c) {
            double mean, se;
            integrate(&m, rho, cosines[k], c, g_fcos, 100 + (uint64_t)(k * 3 + c), &mean, &se);
            if (fabs(mean - channel(rho, c)) > QMC_TOL(se))
                fail_msg("Lambert, cos_o %g, channel %d: int f cos = %.7f +- %.2g, expected rho = %g", cosines[k], c,
                         mean, se, channel(rho, c));
        }
    frame f = test_frame();
    sg_vec3 wo = sg_v3_normalize(to_world(&f, wo_local(0.6)));
    for (uint64_t i = 0; i < 10000; ++i) {
        sg_vec3 w, wt;
        float p;
        if (!sg_bsdf_sample(&m, rho, f.n, wo, sg_rng_float(SEED, i, 3, 0), sg_rng_float(SEED, i, 3, 1),
                            sg_rng_float(SEED, i, 3, 2), &w, &p, &wt))
            continue;
        /* f cos / pdf = (rho/pi) cos / (cos/pi) = rho, up to float rounding. */
        if (fabsf(wt.x - rho.x) > 1e-5f || fabsf(wt.z - rho.z) > 1e-5f)
            fail_msg("Lambert sample %llu: weight (%g,%g,%g), expected rho (%g,%g,%g)", (unsigned long long)i, wt.x,
                     wt.y, wt.z, rho.x, rho.y, rho.z);
    }
}

/* ---- 4 ---------------------------------------------------------------- */

static const float ROUGH[] = {0.0f, 0.1f, 0.2f, 0.35f, 0.5f, 0.75f, 1.0f};
static const double COS_O[] = {1.0, 0.8, 0.5, 0.25, 0.1, 0.02};
#define NROUGH 7
#define NCOS 6

static void test_bsdf_energy_bound(void **state)
{
    (void)state;
    sg_vec3 white = sg_v3(1, 1, 1);
    printf("glossy directional albedo E(roughness, cos_o):\n  rough ");
    for (int k = 0; k < NCOS; ++k)
        printf("  %8.2f", COS_O[k]);
    printf("\n");
    for (int r = 0; r < NROUGH; ++r) {
        sg_material m = mat_ggx(ROUGH[r], 1.0f);
        printf("  %5.2f ", ROUGH[r]);
        for (int k = 0; k < NCOS; ++k) {
            double mean, se;
            integrate(&m, white, COS_O[k], 0, g_fcos, 200 + (uint64_t)(r * NCOS + k), &mean, &se);
            printf("  %8.5f", mean);
            if (mean > 1.0 + QMC_TOL(se))
                fail_msg("roughness %g, cos_o %g: directional albedo %.7f +- %.2g exceeds 1", ROUGH[r], COS_O[k],
                         mean, se);
            /* At alpha <= 0.04 and cos_o >= 0.5 masking is nearly absent
             * (Lambda(wo) <= 0.002), so E = int D G2 .. >= 1 - 2 Lambda
             * ~ 0.99; a lost constant (4, pi, 2) would show as <= 0.5. */
            if (ref_alpha(&m) <= 0.04 && COS_O[k] >= 0.5 && mean < 0.97)
                fail_msg("roughness %g, cos_o %g: directional albedo %.7f +- %.2g, expected about 1", ROUGH[r],
                         COS_O[k], mean, se);
        }
        printf("\n");
    }
    /* The mixture is exactly (1 - k) Lambert + k glossy, pointwise, so its
     * albedo is (1 - k) rho + k E <= 1 by the bound above. */
    sg_vec3 rho = sg_v3(0.9f, 0.5f, 0.2f);
    for (uint64_t i = 0; i < 20000; ++i) {
        float k = sg_rng_float(SEED, i, 4, 0), rough = sg_rng_float(SEED, i, 4, 1);
        sg_material mix = mat_ggx(rough, k), gl = mat_ggx(rough, 1.0f);
        sg_vec3 n = random_dir(i, 20), wo = random_dir(i, 22), wi = random_dir(i, 24);
        sg_vec3 fm = sg_bsdf_eval(&mix, rho, n, wo, wi), fg = sg_bsdf_eval(&gl, rho, n, wo, wi);
        if (fg.x == 0.0f)
            continue;
        double want = (1.0 - k) * rho.y / PI_D + k * fg.y;
        if (fabs(fm.y - want) > 1e-5 * want)
            fail_msg("k %g roughness %g: mixture f %.9g, expected (1-k) rho/pi + k f_glossy = %.9g", k, rough, fm.y,
                     want);
    }
}

/* ---- 5 ---------------------------------------------------------------- */

typedef struct config {
    const char *name;
    sg_material m;
    double cos_o;
} config;

static config make_config(const char *name, sg_material_type type, float rough, float k, double cos_o)
{
    config c = {name, mat_ggx(rough, k), cos_o};
    c.m.type = type;
    return c;
}

#define NCONF 7
static void configs(config out[NCONF])
{
    out[0] = make_config("ggx_r0.2_cos0.8", SG_MATERIAL_GGX, 0.2f, 1.0f, 0.8);
    out[1] = make_config("ggx_r0.5_cos0.3", SG_MATERIAL_GGX, 0.5f, 1.0f, 0.3);
    out[2] = make_config("ggx_r0.8_cos0.95", SG_MATERIAL_GGX, 0.8f, 1.0f, 0.95);
    out[3] = make_config("ggx_r0.35_cos0.1", SG_MATERIAL_GGX, 0.35f, 1.0f, 0.1);
    out[4] = make_config("mix_r0.4_k0.5_cos0.6", SG_MATERIAL_GGX, 0.4f, 0.5f, 0.6);
    out[5] = make_config("mix_r0.25_k0.04_cos0.5", SG_MATERIAL_GGX, 0.25f, 0.04f, 0.5);
    out[6] = make_config("lambert_cos0.5", SG_MATERIAL_LAMBERT, 0.3f, 0.0f, 0.5);
}

static void test_bsdf_sample_consistent(void **state)
{
    (void)state;
    config cf[NCONF];
    configs(cf);
    frame f = test_frame();
    sg_vec3 rho = sg_v3(0.9f, 0.5f, 0.2f);
    const uint64_t N = 200000;
    for (int ci = 0; ci < NCONF; ++ci) {
        const sg_material *m = &cf[ci].m;
        sg_vec3 wo = sg_v3_normalize(to_world(&f, wo_local(cf[ci].cos_o)));
        uint64_t ok = 0;
        for (uint64_t i = 0; i < N; ++i) {
            float u0 = sg_rng_float(SEED, i, 5 + ci, 0), u1 = sg_rng_float(SEED, i, 5 + ci, 1),
                  u2 = sg_rng_float(SEED, i, 5 + ci, 2);
            sg_vec3 wi, wt;
            float pdf;
            if (!sg_bsdf_sample(m, rho, f.n, wo, u0, u1, u2, &wi, &pdf, &wt))
                continue;
            ++ok;
            float p2 = sg_bsdf_pdf(m, f.n, wo, wi), c = sg_v3_dot(f.n, wi);
            sg_vec3 fv = sg_bsdf_eval(m, rho, f.n, wo, wi);
            double want = fv.y * c / p2;
            if (!(fabsf(pdf - p2) <= 1e-5f * p2) || !(fabs(wt.y - want) <= 1e-5 * want) ||
                fabs(sg_v3_length(wi) - 1.0) > 1e-5 || !(c > 0.0f))
                fail_msg("%s u (%g,%g,%g): wi (%g,%g,%g) cos %g, pdf %g vs sg_bsdf_pdf %g, weight %g vs f cos/pdf %g",
                         cf[ci].name, u0, u1, u2, wi.x, wi.y, wi.z, c, pdf, p2, wt.y, want);
            if (wt.x > 1.0f + 1e-5f || wt.y > 1.0f + 1e-5f || wt.z > 1.0f + 1e-5f)
                fail_msg("%s u (%g,%g,%g): weight (%g,%g,%g) exceeds 1", cf[ci].name, u0, u1, u2, wt.x, wt.y, wt.z);
        }
        /* The pdf's mass over the hemisphere is the probability that a sample
         * succeeds: compare QMC with the binomial estimate. */
        double mean, se, frac = (double)ok / N, se_b = sqrt(frac * (1.0 - frac) / N);
        integrate(m, rho, cf[ci].cos_o, 0, g_pdf, 300 + (uint64_t)ci, &mean, &se);
        double tol = 4.0 * sqrt(se * se + se_b * se_b) + 1e-5;
        printf("%s: int pdf = %.6f +- %.2g, success fraction %.6f +- %.2g\n", cf[ci].name, mean, se, frac, se_b);
        if (fabs(mean - frac) > tol || mean > 1.0 + QMC_TOL(se))
            fail_msg("%s: int pdf dwi = %.6f +- %.2g but %.6f of samples succeed (tolerance %.2g)", cf[ci].name, mean,
                     se, frac, tol);
    }
}

/* ---- 6 ---------------------------------------------------------------- */

/* The sampling estimator Y = weight (0 on failure) has mean int f cos dwi.
 * Its variance sigma^2 is estimated from the same N samples; by the CLT the
 * sample mean is normal with standard deviation sigma/sqrt(N) (weights lie
 * in [0,1], so every moment is finite). The QMC value carries its own
 * standard error se; the difference of the two independent estimates has
 * standard deviation sqrt(sigma^2/N + se^2), and 4 of those bound it with
 * false-alarm probability ~6e-5 per comparison (21 comparisons here). */
static void test_bsdf_estimator_vs_qmc(void **state)
{
    (void)state;
    config cf[NCONF];
    configs(cf);
    frame f = test_frame();
    sg_vec3 rho = sg_v3(0.9f, 0.5f, 0.2f);
    const uint64_t N = 1u << 17;
    for (int ci = 0; ci < NCONF; ++ci) {
        const sg_material *m = &cf[ci].m;
        sg_vec3 wo = sg_v3_normalize(to_world(&f, wo_local(cf[ci].cos_o)));
        double s[3] = {0}, s2[3] = {0};
        for (uint64_t i = 0; i < N; ++i) {
            sg_vec3 wi, wt = sg_v3(0, 0, 0);
            float pdf;
            sg_bsdf_sample(m, rho, f.n, wo, sg_rng_float(SEED, i, 20 + ci, 0), sg_rng_float(SEED, i, 20 + ci, 1),
                           sg_rng_float(SEED, i, 20 + ci, 2), &wi, &pdf, &wt);
            for (int c = 0; c < 3; ++c) {
                s[c] += channel(wt, c);
                s2[c] += (double)channel(wt, c) * channel(wt, c);
            }
        }
        for (int c = 0; c < 3; ++c) {
            double mean = s[c] / N, var = fmax(0.0, (s2[c] - s[c] * s[c] / N) / (N - 1));
            double q, se;
            integrate(m, rho, cf[ci].cos_o, c, g_fcos, 400 + (uint64_t)(ci * 3 + c), &q, &se);
            double tol = 4.0 * sqrt(var / N + se * se) + 1e-5;
            if (c == 1)
                printf("%s: sampled %.6f +- %.2g, QMC %.6f +- %.2g\n", cf[ci].name, mean, sqrt(var / N), q, se);
            if (fabs(mean - q) > tol)
                fail_msg("%s channel %d: sampling estimate %.6f (sigma %.3g, N %llu) vs QMC %.6f +- %.2g: "
                         "difference %.3g > %.3g",
                         cf[ci].name, c, mean, sqrt(var), (unsigned long long)N, q, se, fabs(mean - q), tol);
        }
    }
}

/* ---- 7 ---------------------------------------------------------------- */

#define CT 18       /* theta bins over [0, pi/2]                    */
#define CP 36       /* phi bins over [0, 2 pi)                      */
#define SUBDIV 16    /* Gauss-Legendre sub-intervals per cell and axis */
#define CHI_N 1000000

/* Expected counts: N times the pdf integrated over each (theta, phi) cell
 * with the sin(theta) area element, by composite 2-point Gauss-Legendre
 * (16 sub-intervals, 32 nodes per axis; the narrowest lobe here, alpha =
 * 0.04, spans ~30 nodes 0.0027 rad apart; 3x finer changes no chi2 by
 * more than 0.1). An open rule, because the pdf
 * jumps to 0 at the horizon (theta = pi/2), which a closed rule such as
 * Simpson's would sample and smear into the last row. */
static void expected_counts(const config *c, const frame *f, sg_vec3 wo, double *expd)
{
    const double dt = 0.5 * PI_D / CT, dp = 2.0 * PI_D / CP, g = 0.5 / sqrt(3.0);
    for (int it = 0; it < CT; ++it)
        for (int ip = 0; ip < CP; ++ip) {
            double acc = 0.0;
            for (int a = 0; a < 2 * SUBDIV; ++a)
                for (int b = 0; b < 2 * SUBDIV; ++b) {
                    /* node at the sub-interval centre -+ h / (2 sqrt 3) */
                    double ta = (a / 2 + 0.5 + (a % 2 ? g : -g)) / SUBDIV;
                    double tb = (b / 2 + 0.5 + (b % 2 ? g : -g)) / SUBDIV;
                    double th = (it + ta) * dt, ph = (ip + tb) * dp;
                    sg_vec3 l = sg_v3((float)(sin(th) * cos(ph)), (float)(sin(th) * sin(ph)), (float)cos(th));
                    acc += sg_bsdf_pdf(&c->m, f->n, wo, to_world(f, l)) * sin(th);
                }
            expd[it * CP + ip] = CHI_N * acc * dt * dp / (4.0 * SUBDIV * SUBDIV);
        }
}

static void test_bsdf_chi2(void **state)
{
    (void)state;
    config cf[NCONF];
    configs(cf);
    frame f = test_frame();
    const double alpha = sg_test_sidak(0.01, NCONF);
    double *obs = calloc(CT * CP, sizeof *obs), *expd = calloc(CT * CP, sizeof *expd);
    assert_non_null(obs);
    assert_non_null(expd);
    for (int ci = 0; ci < NCONF; ++ci) {
        sg_vec3 wo = sg_v3_normalize(to_world(&f, wo_local(cf[ci].cos_o)));
        memset(obs, 0, CT * CP * sizeof *obs);
        for (uint64_t i = 0; i < CHI_N; ++i) {
            sg_vec3 wi, wt;
            float pdf;
            if (!sg_bsdf_sample(&cf[ci].m, sg_v3(1, 1, 1), f.n, wo, sg_rng_float(SEED, i, 40 + ci, 0),
                                sg_rng_float(SEED, i, 40 + ci, 1), sg_rng_float(SEED, i, 40 + ci, 2), &wi, &pdf, &wt))
                continue;
            sg_vec3 l = to_local(&f, wi);
            double th = acos(fmin(1.0, fmax(-1.0, l.z))), ph = atan2(l.y, l.x);
            if (ph < 0.0)
                ph += 2.0 * PI_D;
            int it = (int)(th / (0.5 * PI_D / CT)), ip = (int)(ph / (2.0 * PI_D / CP));
            it = it >= CT ? CT - 1 : it;
            ip = ip >= CP ? CP - 1 : ip;
            obs[it * CP + ip] += 1.0;
        }
        expected_counts(&cf[ci], &f, wo, expd);
        int dof;
        double chi2, p = sg_test_chi2(cf[ci].name, obs, expd, CT * CP, &dof, &chi2);
        printf("%s: chi2 = %.1f, dof = %d, p = %.4f (reject below %.5f)\n", cf[ci].name, chi2, dof, p, alpha);
        if (!(p >= alpha)) {
            sg_test_dump_table(cf[ci].name, obs, expd, CT * CP, CP);
            fail_msg("%s: chi-square %.1f with %d dof, p = %.3g < %.3g", cf[ci].name, chi2, dof, p, alpha);
        }
    }
    free(obs);
    free(expd);
}

/* ---- 8 ---------------------------------------------------------------- */

static void test_material_validate_albedo(void **state)
{
    (void)state;
    sg_error err;
    sg_material m = sg_material_default();
    assert_int_equal(sg_material_validate(&m, &err), SG_OK);
    assert_int_equal(m.type, SG_MATERIAL_LAMBERT);
    assert_true(m.albedo.x == 1.0f && m.emission.y == 0.0f && m.use_point_colors);
    struct {
        const char *field;
        sg_material m;
    } bad[5];
    for (int i = 0; i < 5; ++i)
        bad[i].m = sg_material_default();
    bad[0].field = "albedo", bad[0].m.albedo.y = 1.5f;
    bad[1].field = "roughness", bad[1].m.roughness = NAN;
    bad[2].field = "specular", bad[2].m.specular = -0.1f;
    bad[3].field = "emission", bad[3].m.emission.z = -1.0f;
    bad[4].field = "type", bad[4].m.type = (sg_material_type)7;
    for (int i = 0; i < 5; ++i) {
        sg_status st = sg_material_validate(&bad[i].m, &err);
        if (st != SG_ERR_INVALID_ARG || !strstr(err.message, bad[i].field))
            fail_msg("bad %s: status %s, message \"%s\"", bad[i].field, sg_status_name(st), err.message);
    }
    sg_vec3 pt = sg_v3(0.5f, 0.25f, 1.0f);
    m.albedo = sg_v3(0.8f, 0.8f, 0.4f);
    sg_vec3 a = sg_material_albedo(&m, pt);
    assert_true(a.x == 0.4f && a.y == 0.2f && a.z == 0.4f);
    m.use_point_colors = false;
    a = sg_material_albedo(&m, pt);
    assert_true(a.x == 0.8f && a.y == 0.8f && a.z == 0.4f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bsdf_reciprocity),       cmocka_unit_test(test_bsdf_two_sided),
        cmocka_unit_test(test_bsdf_lambert_albedo),    cmocka_unit_test(test_bsdf_energy_bound),
        cmocka_unit_test(test_bsdf_sample_consistent), cmocka_unit_test(test_bsdf_estimator_vs_qmc),
        cmocka_unit_test(test_bsdf_chi2),              cmocka_unit_test(test_material_validate_albedo),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
