/* bsdf.h — surface materials: a Lambert base and an optional GGX glossy
 * lobe, with evaluation, importance sampling and the matching pdf.
 *
 * What it does: one reflective, two-sided material model,
 *
 *     f(wo, wi) = (1 - k) * rho / pi  +  k * D(h) G2(wo, wi) / (4 |n.wo| |n.wi|)
 *
 * with rho the diffuse albedo (per colour channel), k = `specular` in [0,1]
 * (the share of the glossy lobe), D the GGX (Trowbridge-Reitz) normal
 * distribution with alpha = roughness^2, G2 Smith's height-correlated
 * masking-shadowing (Heitz 2014, eq. 99) and h = normalize(wo + wi). The
 * glossy lobe is white (uncoloured, like the highlight of a varnish or
 * plastic) and has no Fresnel factor (F = 1).
 *   SG_MATERIAL_LAMBERT  k is taken as 0 (roughness and specular ignored).
 *   SG_MATERIAL_GGX      the mixture above.
 *
 * Energy (why k is a mixing weight and not a Fresnel F0): the directional
 * albedo of the glossy lobe is E(wo) = int D G2 / (4 cos_o) dwi
 * = int_{h.wo>0} D(h) G2 (h.wo) / cos_o dh <= int D(h) G1(wo) (h.wo)/cos_o dh
 * = 1, because G2 <= G1(wo) and the last integral is the normalisation of
 * the distribution of visible normals (Heitz 2014, eq. 38). Hence the
 * material's albedo (1 - k) rho + k E(wo) <= 1 whenever rho <= 1: energy
 * conservation is a theorem, not a fitted approximation. A Schlick-Fresnel
 * layer with a Lambert base cannot be bounded this way without tabulating
 * E, so it is not offered. `specular` = 0.04 gives roughly the normal-
 * incidence reflectance of a dielectric, without its grazing rise.
 *
 * What it does not do: transmission, anisotropy, multiple scattering inside
 * the microsurface (rough lobes lose up to ~1 - E(wo) of their energy),
 * delta (mirror) lobes: alpha is clamped below at SG_BSDF_MIN_ALPHA.
 *
 * Conventions (pbrt's):
 *  - Directions are world-space unit vectors pointing AWAY from the surface:
 *    wo towards the viewer (or the previous vertex), wi towards the light.
 *  - n is the unit shading normal. Surfaces are two-sided: n is flipped to
 *    the side of wo, and wi must lie on that same side, else f = 0, pdf = 0
 *    and sampling fails. wo exactly in the tangent plane gives 0.
 *  - sg_bsdf_eval returns f alone; the caller multiplies by |n.wi|.
 *  - Albedo and emission are linear Rec.709 RGB carried in sg_vec3 as
 *    (x, y, z) = (r, g, b).
 *  - Per-point albedo: sg_material_albedo gives the albedo to pass to the
 *    functions below: material albedo times the point's albedo when
 *    use_point_colors is set (a tint, like glTF's baseColorFactor times the
 *    texture), the material albedo alone otherwise.
 *  - Emission is radiance L_e leaving the surface, the same in every
 *    direction and on both sides; the integrator adds it, the BSDF ignores it.
 *
 * Use:
 *     sg_material m = sg_material_default();    Lambert, white, no emission
 *     m.type = SG_MATERIAL_GGX; m.roughness = 0.3f; m.specular = 0.2f;
 *     sg_vec3 rho = sg_material_albedo(&m, point_albedo);
 *     sg_vec3 wi, w; float pdf;
 *     if (sg_bsdf_sample(&m, rho, n, wo, u0, u1, u2, &wi, &pdf, &w))
 *         throughput = sg_v3_mul(throughput, w);   w = f |n.wi| / pdf
 *
 * Thread-safety: pure functions of their arguments. Debug builds assert
 * that n and wo are unit vectors.
 */
#ifndef SG_MATERIAL_BSDF_H
#define SG_MATERIAL_BSDF_H

#include <stdbool.h>

#include "core/error.h"
#include "math/vec3.h"

/* Smallest GGX alpha: below it the lobe is a near-delta that neither float
 * evaluation nor these pdfs represent well. roughness < sqrt(1e-3) ~ 0.032
 * therefore behaves as 0.032. */
#define SG_BSDF_MIN_ALPHA 1e-3f

typedef enum sg_material_type {
    SG_MATERIAL_LAMBERT = 0, /* diffuse only                                 */
    SG_MATERIAL_GGX = 1      /* (1 - specular) Lambert + specular GGX lobe    */
} sg_material_type;

/* Plain struct; sg_material_default() gives the documented defaults. */
typedef struct sg_material {
    sg_material_type type;  /* default SG_MATERIAL_LAMBERT                       */
    sg_vec3 albedo;         /* diffuse albedo rho, linear RGB in [0,1]; default 1 */
    float roughness;        /* [0,1], GGX alpha = roughness^2; default 0.3       */
    float specular;         /* glossy share k in [0,1]; default 0.04             */
    sg_vec3 emission;       /* emitted radiance, linear RGB >= 0; default 0      */
    bool use_point_colors;  /* albedo multiplies the point's albedo; default true */
} sg_material;

/* Lambert, albedo (1,1,1), roughness 0.3, specular 0.04, no emission,
 * use_point_colors true. */
sg_material sg_material_default(void);

/* SG_ERR_INVALID_ARG naming the field when albedo is outside [0,1],
 * roughness or specular outside [0,1], emission negative, anything NaN or
 * infinite, or type unknown. */
sg_status sg_material_validate(const sg_material *m, sg_error *err);

/* The diffuse albedo rho at a point whose own albedo is point_albedo
 * (sg_pointset ar/ag/ab): m->albedo * point_albedo per channel when
 * m->use_point_colors, m->albedo otherwise. */
sg_vec3 sg_material_albedo(const sg_material *m, sg_vec3 point_albedo);

/* f(wo, wi) per RGB channel, 1/sr, WITHOUT the cosine; 0 when wi and wo
 * lie on opposite sides of the surface (see conventions). Reciprocal:
 * f(wo, wi) = f(wi, wo). */
sg_vec3 sg_bsdf_eval(const sg_material *m, sg_vec3 albedo, sg_vec3 n, sg_vec3 wo, sg_vec3 wi);

/* Density (per steradian) with which sg_bsdf_sample returns wi. It does not
 * depend on albedo. It integrates to at most 1 over the sphere: the
 * missing mass is the probability that a glossy sample leaves below the
 * surface, where sampling fails. */
float sg_bsdf_pdf(const sg_material *m, sg_vec3 n, sg_vec3 wo, sg_vec3 wi);

/* The hemispherical albedo of the glossy lobe alone (white, k = 1):
 * (1/pi) int E(wo) cos(wo) dwo, E the directional albedo above, for the
 * material's roughness: 1 for a sharp lobe, 0.41 at roughness 1 (the
 * single-scattering lobe loses the rest). Tabulated at roughness steps of
 * 1/32 (64 x 64 cosine-distributed wo, 4096 lobe samples each) and
 * interpolated linearly; tests/material/test_bsdf.c checks the table
 * against the integral. Used where a glossy surface's light is treated
 * as diffuse (the bake's transport). */
float sg_bsdf_ggx_average_albedo(float roughness);

/* Draws wi from (1 - p) cosine-hemisphere + p visible-normal GGX
 * (Heitz 2018), p = k for SG_MATERIAL_GGX and 0 for Lambert; u0 picks the
 * lobe, (u1, u2) the direction; u* in [0,1). On success returns 1 and writes
 * *wi (unit), *pdf = sg_bsdf_pdf(m, n, wo, wi) > 0 and
 * *weight = f(wo, wi) |n.wi| / pdf, the factor a path's throughput takes
 * (each channel <= 1, since the weight is bounded by max(rho, G2/G1) <= 1).
 * Returns 0 (outputs untouched) when wo is tangent or the drawn direction
 * falls below the surface. */
int sg_bsdf_sample(const sg_material *m, sg_vec3 albedo, sg_vec3 n, sg_vec3 wo, float u0, float u1,
                   float u2, sg_vec3 *wi, float *pdf, sg_vec3 *weight);

#endif
