/* bsdf.c — Lambert + GGX glossy mixture (see bsdf.h for the model and the
 * energy argument).
 *
 * Sources: GGX / Trowbridge-Reitz D and Smith Lambda, Walter et al. 2007;
 * height-correlated G2, Heitz 2014 "Understanding the masking-shadowing
 * function", eq. 99; visible-normal sampling and its pdf
 * D_wo(h) = G1(wo) max(0, wo.h) D(h) / cos_o, Heitz 2018 "Sampling the GGX
 * distribution of visible normals" (JCGT 7(4)), listing 1; the reflection
 * Jacobian dh/dwi = 1 / (4 |wo.h|), Walter et al. 2007 eq. 14.
 *
 * Invariants:
 *  1. eval, pdf and sample see the same geometry: n flipped to wo's side,
 *     wi valid only on that side, the same clamped alpha.
 *  2. sample returns *pdf == sg_bsdf_pdf(m, n, wo, *wi) and
 *     *weight == eval * cos / pdf, computed by those functions, so the three
 *     cannot drift apart.
 *  3. Everything is symmetric in (wo, wi) except the pdf: f is reciprocal.
 */
#include "material/bsdf.h"

#include <assert.h>
#include <math.h>

#include "sample/warp.h"

#define PI_F 3.14159265358979323846f
#define INV_PI_F 0.31830988618379067154f

sg_material sg_material_default(void)
{
    sg_material m = {
        .type = SG_MATERIAL_LAMBERT,
        .albedo = {1.0f, 1.0f, 1.0f},
        .roughness = 0.3f,
        .specular = 0.04f,
        .emission = {0.0f, 0.0f, 0.0f},
        .use_point_colors = true,
    };
    return m;
}

static int in01(float x) { return x >= 0.0f && x <= 1.0f; } /* false for NaN */

sg_status sg_material_validate(const sg_material *m, sg_error *err)
{
    assert(m);
    if (m->type != SG_MATERIAL_LAMBERT && m->type != SG_MATERIAL_GGX)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "material: unknown type %d", (int)m->type);
    if (!in01(m->albedo.x) || !in01(m->albedo.y) || !in01(m->albedo.z))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "material: albedo (%g, %g, %g) is not in [0,1]",
                            m->albedo.x, m->albedo.y, m->albedo.z);
    if (!in01(m->roughness))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "material: roughness %g is not in [0,1]", m->roughness);
    if (!in01(m->specular))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "material: specular %g is not in [0,1]", m->specular);
    if (!sg_v3_isfinite(m->emission) || !(m->emission.x >= 0.0f && m->emission.y >= 0.0f && m->emission.z >= 0.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "material: emission (%g, %g, %g) is not finite and >= 0",
                            m->emission.x, m->emission.y, m->emission.z);
    return SG_OK;
}

sg_vec3 sg_material_albedo(const sg_material *m, sg_vec3 point_albedo)
{
    return m->use_point_colors ? sg_v3_mul(m->albedo, point_albedo) : m->albedo;
}

float sg_bsdf_ggx_average_albedo(float roughness)
{
    /* Entry i: roughness i / 32 (see bsdf.h for how it was integrated). */
    static const float table[33] = {
        1.00000f, 1.00000f, 0.99996f, 0.99955f, 0.99903f, 0.99780f, 0.99542f, 0.99230f, 0.98735f,
        0.98089f, 0.97257f, 0.96265f, 0.95061f, 0.93669f, 0.92062f, 0.90229f, 0.88148f, 0.85864f,
        0.83400f, 0.80751f, 0.77921f, 0.74968f, 0.71889f, 0.68725f, 0.65505f, 0.62250f, 0.58993f,
        0.55761f, 0.52579f, 0.49472f, 0.46453f, 0.43539f, 0.40743f};
    float x = (roughness > 0.0f ? (roughness < 1.0f ? roughness : 1.0f) : 0.0f) * 32.0f;
    int i = (int)x;
    if (i >= 32)
        return table[32];
    float t = x - (float)i;
    return table[i] + (table[i + 1] - table[i]) * t;
}

/* Share of the glossy lobe, which is also its sampling probability: the
 * weight then stays a mean of rho and G2/G1, both <= 1 (bsdf.h). */
static float glossy_share(const sg_material *m)
{
    if (m->type != SG_MATERIAL_GGX)
        return 0.0f;
    return m->specular < 0.0f ? 0.0f : (m->specular > 1.0f ? 1.0f : m->specular);
}

static float ggx_alpha(const sg_material *m)
{
    float a = m->roughness * m->roughness;
    return a > SG_BSDF_MIN_ALPHA ? a : SG_BSDF_MIN_ALPHA;
}

/* GGX D(h) from cos and sin^2 of h's angle to n. sin^2 comes in separately
 * (from a cross product) because 1 - cos^2 cancels catastrophically near the
 * peak, where alpha^2 cos^2 is as small as 1e-6. */
static float ggx_d(float a2, float cos_h, float sin2_h)
{
    float t = sin2_h + a2 * cos_h * cos_h;
    return a2 * INV_PI_F / (t * t);
}

/* sqrt(cos^2 + alpha^2 sin^2) = cos * (1 + 2 Lambda): the Smith term in the
 * form that keeps both G1 and the height-correlated G2 free of division by
 * a tangent. */
static float smith_s(float a2, float c)
{
    float s2 = 1.0f - c * c;
    return sqrtf(c * c + a2 * (s2 > 0.0f ? s2 : 0.0f));
}

/* Geometry common to eval and pdf (invariant 1). Returns 0 when the pair is
 * not a valid reflection configuration. */
typedef struct pair_geom {
    float co, ci;  /* cosines of wo and wi with the flipped normal, > 0 */
    float hz;      /* cos of the half vector with that normal            */
    float h_sin2;  /* sin^2 of the same angle                            */
} pair_geom;

static int pair_setup(sg_vec3 n, sg_vec3 wo, sg_vec3 wi, pair_geom *g)
{
    assert(fabsf(sg_v3_dot(n, n) - 1.0f) < 1e-3f);
    assert(fabsf(sg_v3_dot(wo, wo) - 1.0f) < 1e-3f);
    float co = sg_v3_dot(n, wo);
    if (co < 0.0f) { /* two-sided: face wo */
        n = sg_v3_scale(n, -1.0f);
        co = -co;
    }
    float ci = sg_v3_dot(n, wi);
    if (!(co > 0.0f) || !(ci > 0.0f))
        return 0;
    sg_vec3 h = sg_v3_normalize(sg_v3_add(wo, wi));
    sg_vec3 c = sg_v3_cross(n, h);
    g->co = co;
    g->ci = ci;
    g->hz = sg_v3_dot(n, h);
    g->h_sin2 = sg_v3_dot(c, c);
    return g->hz > 0.0f;
}

sg_vec3 sg_bsdf_eval(const sg_material *m, sg_vec3 albedo, sg_vec3 n, sg_vec3 wo, sg_vec3 wi)
{
    pair_geom g;
    if (!pair_setup(n, wo, wi, &g))
        return sg_v3(0.0f, 0.0f, 0.0f);
    float k = glossy_share(m);
    sg_vec3 f = sg_v3_scale(albedo, (1.0f - k) * INV_PI_F);
    if (k > 0.0f) {
        float alpha = ggx_alpha(m), a2 = alpha * alpha;
        /* D G2 / (4 co ci) with G2 = 2 co ci / (co s_i + ci s_o):
         * symmetric in (co, ci), hence reciprocal. */
        float v = 0.5f / (g.co * smith_s(a2, g.ci) + g.ci * smith_s(a2, g.co));
        float spec = k * ggx_d(a2, g.hz, g.h_sin2) * v;
        f = sg_v3_add(f, sg_v3(spec, spec, spec));
    }
    return f;
}

float sg_bsdf_pdf(const sg_material *m, sg_vec3 n, sg_vec3 wo, sg_vec3 wi)
{
    pair_geom g;
    if (!pair_setup(n, wo, wi, &g))
        return 0.0f;
    float p = glossy_share(m);
    float pdf = (1.0f - p) * g.ci * INV_PI_F;
    if (p > 0.0f) {
        float alpha = ggx_alpha(m), a2 = alpha * alpha;
        /* VNDF pdf over h times the reflection Jacobian 1/(4 wo.h):
         * G1(wo) (wo.h) D / co / (4 wo.h) = G1 D / (4 co), and
         * G1(wo) = 2 co / (co + s_o). */
        float g1 = 2.0f * g.co / (g.co + smith_s(a2, g.co));
        pdf += p * g1 * ggx_d(a2, g.hz, g.h_sin2) / (4.0f * g.co);
    }
    return pdf;
}

/* Heitz 2018, listing 1: a visible normal for local view v (v.z > 0). */
static sg_vec3 ggx_sample_vndf(sg_vec3 v, float alpha, float u1, float u2)
{
    /* Stretch the view so the microsurface becomes the hemisphere (alpha 1). */
    sg_vec3 vh = sg_v3_normalize(sg_v3(alpha * v.x, alpha * v.y, v.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    sg_vec3 t1 = lensq > 0.0f ? sg_v3_scale(sg_v3(-vh.y, vh.x, 0.0f), 1.0f / sqrtf(lensq)) : sg_v3(1.0f, 0.0f, 0.0f);
    sg_vec3 t2 = sg_v3_cross(vh, t1);
    /* A disk point, squeezed onto the part of the disk the view sees. */
    float r = sqrtf(u1);
    float phi = 2.0f * PI_F * u2;
    float p1 = r * cosf(phi), p2 = r * sinf(phi);
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrtf(fmaxf(0.0f, 1.0f - p1 * p1)) + s * p2;
    float pz = sqrtf(fmaxf(0.0f, 1.0f - p1 * p1 - p2 * p2));
    sg_vec3 nh = sg_v3_add(sg_v3_add(sg_v3_scale(t1, p1), sg_v3_scale(t2, p2)), sg_v3_scale(vh, pz));
    /* Unstretch back to the ellipsoid's normal. */
    return sg_v3_normalize(sg_v3(alpha * nh.x, alpha * nh.y, fmaxf(0.0f, nh.z)));
}

int sg_bsdf_sample(const sg_material *m, sg_vec3 albedo, sg_vec3 n, sg_vec3 wo, float u0, float u1,
                   float u2, sg_vec3 *wi, float *pdf, sg_vec3 *weight)
{
    float co = sg_v3_dot(n, wo);
    if (co < 0.0f) {
        n = sg_v3_scale(n, -1.0f);
        co = -co;
    }
    if (!(co > 0.0f))
        return 0;
    sg_vec3 t, b;
    sg_v3_basis(n, &t, &b);
    sg_vec3 d;
    if (u0 < glossy_share(m)) {
        sg_vec3 wo_l = sg_v3(sg_v3_dot(t, wo), sg_v3_dot(b, wo), co);
        sg_vec3 h_l = ggx_sample_vndf(wo_l, ggx_alpha(m), u1, u2);
        float oh = sg_v3_dot(wo_l, h_l);
        d = sg_v3_sub(sg_v3_scale(h_l, 2.0f * oh), wo_l); /* mirror wo about h */
    } else {
        d = sg_warp_cosine_hemisphere_sample(u1, u2);
    }
    if (!(d.z > 0.0f))
        return 0;
    sg_vec3 w = sg_v3_normalize(sg_v3_add(sg_v3_add(sg_v3_scale(t, d.x), sg_v3_scale(b, d.y)), sg_v3_scale(n, d.z)));
    float p = sg_bsdf_pdf(m, n, wo, w);
    float ci = sg_v3_dot(n, w);
    if (!(p > 0.0f) || !(ci > 0.0f))
        return 0;
    sg_vec3 f = sg_bsdf_eval(m, albedo, n, wo, w);
    *wi = w;
    *pdf = p;
    *weight = sg_v3_scale(f, ci / p);
    return 1;
}
