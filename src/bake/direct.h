/* direct.h — direct irradiance from the envmap at every splat, by Monte
 * Carlo with shadow rays (the part of the bake the photon density estimate
 * does worst: direct light has the sharpest shadows and the brightest
 * values, and a kNN photon estimate turns them into blotches).
 *
 * Estimator at splat centre x with normal n, S samples, two strategies
 * combined by the power heuristic (Veach 1997):
 *   envmap sampling:   w ~ p_env,          pdf p_l = sg_envmap_pdf
 *   cosine sampling:   w ~ cos / pi,       pdf p_c = cos / pi
 *   E = 1/S sum [ L(w_l) V cos_l  w_l / p_l  +  L(w_c) V cos_c  w_c / p_c ]
 * with w_x = p_x^2 / (p_l^2 + p_c^2) and V the shadow-ray visibility
 * (sg_world_spawn_ray from the splat, so the splat's own surface does not
 * shadow it). Unbiased for E = int L V cos dw over the hemisphere.
 * Random numbers: sg_rng_float(seed, splat index over all models, 0, dim):
 * the same for a splat whether it is computed alone or with all others;
 * the result ignores the thread count.
 */
#ifndef SG_BAKE_DIRECT_H
#define SG_BAKE_DIRECT_H

#include <stdint.h>

#include "core/error.h"
#include "render/world.h"

/* The direct irradiance at n splats of model m: out[3 j .. 3 j + 2] (RGB)
 * for splat splats[j] (splats NULL: every splat, j = splat index; n is
 * then ignored). The random stream of splat i is keyed by key_base + i,
 * key_base = the number of splats of models before m, so a splat's value
 * does not depend on which other splats are computed. samples >= 1.
 * sigma (NULL: not wanted): per listed splat, the standard error of the
 * estimate's luminance (0.2126 R + 0.7152 G + 0.0722 B), from the spread
 * of the per-sample terms: what the refinement of the sample points
 * (samples.h) tells apart from a real change of the light.
 * unshadowed (NULL: not wanted): per listed splat, RGB, the same estimator
 * over the same samples with the visibility left out, so that out /
 * unshadowed is a ratio estimate of how much of the light arriving at
 * the splat gets through (1 exactly where nothing blocks it, whatever the
 * map's noise). With unshadowed given, sigma is the standard error of that
 * ratio's luminance (delta method) instead of the estimate's. */
sg_status sg_direct_irradiance_at(const sg_world *w, uint32_t m, const uint32_t *splats, size_t n,
                                  uint64_t key_base, int samples, uint64_t seed, int threads, float *out,
                                  float *unshadowed, float *sigma, sg_error *err);

#endif
