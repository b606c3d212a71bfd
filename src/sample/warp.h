/* warp.h — maps from the unit square to directions and disk points, each a
 * trio in the pbrt manner: sample (u -> x), pdf (x) and invert (x -> u).
 *
 * What it does: the four warps every sampler in splatgi builds on:
 *   disk               uniform on the unit disk, Shirley-Chiu concentric
 *                      map (low distortion, so stratified u stays
 *                      stratified); pdf 1/pi per unit area.
 *   sphere             uniform on the unit sphere; pdf 1/(4 pi) per sr.
 *   hemisphere         uniform on the hemisphere z >= 0; pdf 1/(2 pi).
 *   cosine_hemisphere  density cos(theta)/pi about +Z (Malley's method:
 *                      a concentric disk point lifted to the hemisphere).
 * What it does not do: frames. Directions are in a local frame whose pole
 * is +Z; turn them into world space with sg_v3_basis (vec3.h).
 *
 * Conventions: u0, u1 in [0,1) (sg_rng_float never returns 1). Directions
 * are unit vectors. pdf is per steradian for directions, per unit area for
 * the disk, and is 0 outside the warp's support. invert returns u in
 * [0,1]^2 with invert(sample(u)) = u up to float rounding (u at the seams,
 * e.g. phi = 0 vs 2 pi, may come back as the other seam value).
 * Thread-safety: pure functions.
 *
 * Use:
 *     sg_vec3 d = sg_warp_cosine_hemisphere_sample(u0, u1);
 *     float pdf = sg_warp_cosine_hemisphere_pdf(d);      = d.z / pi
 *     float u[2]; sg_warp_cosine_hemisphere_invert(d, u);
 */
#ifndef SG_SAMPLE_WARP_H
#define SG_SAMPLE_WARP_H

#include "math/vec3.h"

/* Unit disk (concentric). p[0], p[1]: the point; |p| <= 1. */
void sg_warp_disk_sample(float u0, float u1, float p[2]);
float sg_warp_disk_pdf(float x, float y);
void sg_warp_disk_invert(float x, float y, float u[2]);

/* Uniform sphere: z = 1 - 2 u0, phi = 2 pi u1. */
sg_vec3 sg_warp_sphere_sample(float u0, float u1);
float sg_warp_sphere_pdf(sg_vec3 d);
void sg_warp_sphere_invert(sg_vec3 d, float u[2]);

/* Uniform hemisphere about +Z: z = u0, phi = 2 pi u1. pdf 0 for z < 0. */
sg_vec3 sg_warp_hemisphere_sample(float u0, float u1);
float sg_warp_hemisphere_pdf(sg_vec3 d);
void sg_warp_hemisphere_invert(sg_vec3 d, float u[2]);

/* Cosine-weighted hemisphere about +Z (Malley). pdf = max(z, 0) / pi;
 * invert needs z >= 0 (it uses only x and y). */
sg_vec3 sg_warp_cosine_hemisphere_sample(float u0, float u1);
float sg_warp_cosine_hemisphere_pdf(sg_vec3 d);
void sg_warp_cosine_hemisphere_invert(sg_vec3 d, float u[2]);

#endif
