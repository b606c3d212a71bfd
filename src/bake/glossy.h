/* glossy.h — directional bins of a glossy material's filtered incident
 * radiance at the bake's sample points, and their lookup.
 *
 * What it stores: the GGX material (material/bsdf.h) reflects
 *     L_o(wo) = emission + (1 - k) rho/pi E + k S(wo),
 *     S(wo) = int L_in(wi) f_ggx(wo, wi) cos(wi) dwi
 * with f_ggx the white lobe (F = 1, alpha = roughness^2). E is the diffuse
 * bake; S, an RGB function of the outgoing direction, is stored per sample
 * point in R x R bins over the hemisphere around the sample's normal,
 * indexed by the hemi-octahedral map of wo (below), as IEEE half floats
 * (6 R^2 bytes per sample; values clamped to 65504).
 *
 * Estimator (one shared set of M rays per sample for all R^2 bins): ray j
 * draws wi from a mixture of envmap importance sampling, cosine sampling
 * and the GGX lobe (visible normals) of a uniformly drawn bin direction,
 * the strategies in fixed shares n_env, n_cos, n_ggx of M (M/3 each, the
 * rest to GGX); each ray is weighted by the balance heuristic over the
 * whole mixture,
 *     p_mix(wi) = c_env p_env(wi) + c_cos cos/pi + c_ggx mean_b p_ggx(wi | wo_b),
 *     S(wo_b) ~ 1/M sum_j L(wi_j) f_ggx(wo_b, wi_j) cos_j / p_mix(wi_j),
 * c_x = n_x / M: unbiased for every bin at once. L(wi) is the envmap where
 * the ray from the sample escapes, else the DIFFUSE baked radiance of the
 * surface it hits (emission + (1 - k) rho/pi E, a final gather: E must be complete
 * for every model first). Random numbers: sg_rng_float(seed, global splat
 * index of the sample, 1, dim): independent of the thread count.
 *
 * Hemi-octahedral map (local frame t, b, n of sg_v3_basis(n)): a local
 * direction v (v.z >= 0) maps to p = (v.x, v.y) / (|v.x| + |v.y| + v.z), then
 * (u, w) = (p.x + p.y, p.x - p.y) in [-1,1]^2; bin (i, j) covers
 * u in [-1 + 2i/R, -1 + 2(i+1)/R) and w likewise; bins[3 (j R + i) + c].
 * The frame is continuous in n except across n.z = 0 where sg_v3_basis
 * switches sign branch (Duff et al. 2017) and is singular nowhere; each
 * sample's map is read in that sample's own frame, so a frame jump between
 * neighbouring samples rotates nothing that is looked up.
 *
 * Lookup (sg_glossy_eval): S at a hit with normal n_h seen from wo, read
 * from a sample with normal n_s, is the sample's map at wo' = the
 * reflection of r = reflect(wo, n_h) about n_s: the direction whose mirror
 * direction about n_s is the hit's mirror direction, so a highlight moves
 * with the normal between samples instead of being smeared across them.
 * Bilinear between bin centres, clamped at the map's rim (the horizon).
 *
 * What it does not do: glossy-to-glossy paths (a ray hitting a glossy
 * surface sees its diffuse part only), the back side of a sample (wo below
 * the sample's hemisphere reads the rim), Fresnel, anisotropy.
 */
#ifndef SG_BAKE_GLOSSY_H
#define SG_BAKE_GLOSSY_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "material/bsdf.h"
#include "math/vec3.h"

typedef struct sg_bake sg_bake;
typedef struct sg_world sg_world;

#define SG_GLOSSY_MIN_RES 4
#define SG_GLOSSY_MAX_RES 32
#define SG_GLOSSY_DEFAULT_RAYS 128

/* Bins per side for a material: R = clamp(ceil(2.4 / alpha), 4, 32), so a
 * bin spans about half the highlight's width (the lobe's half-maximum
 * width in wi is about 2.6 alpha radians, a bin about pi / R); 0 when the
 * material has no glossy lobe (Lambert or specular 0). Measured
 * (docs/bake.md): roughness 0.3 under a sun, R = 16 (a bin about as wide
 * as the highlight) gives 5x the relMSE of R = 24 or 32. */
int sg_glossy_default_res(const sg_material *m);

/* Whether model materials need bins. */
int sg_glossy_material(const sg_material *m);

/* S for the n sample points splats[0..n) of model m, res x res bins each,
 * into bins (3 res^2 halves per sample). b's diffuse irradiance must be
 * final for every model. key_base: splats of models before m. */
sg_status sg_glossy_bake(const sg_world *w, const sg_bake *b, uint32_t m, const uint32_t *splats, size_t n,
                         uint64_t key_base, int res, int rays, uint64_t seed, int threads, uint16_t *bins,
                         sg_error *err);

/* S(wo) from one sample's bins (res x res x 3 halves) whose normal is n_s,
 * at a hit with normal n_h (both unit), viewer direction wo (unit, away
 * from the surface). */
sg_vec3 sg_glossy_eval(const uint16_t *bins, int res, sg_vec3 n_s, sg_vec3 n_h, sg_vec3 wo);

/* The hemi-octahedral map (above): local unit v (v.z >= 0) -> (u, w). */
void sg_glossy_encode(sg_vec3 v, float *u, float *w);
sg_vec3 sg_glossy_decode(float u, float w);

/* IEEE 754 binary16 conversion, round to nearest even; finite values
 * above 65504 become 65504 (S is never negative). */
uint16_t sg_half_from_float(float f);
float sg_half_to_float(uint16_t h);

#endif
