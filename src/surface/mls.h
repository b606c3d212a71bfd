/* mls.h — the implicit MLS surface of Adamson & Alexa as ray traced by Wald &
 * Seidel 2005 (§3.1-3.2):
 *
 *     F(x) = (W(x) x - sum_i w_i(x) p_i) . sum_i w_i(x) n_i,
 *     w_i(x) = K(|x - p_i| / r_i),   W(x) = sum_i w_i(x),
 *
 * which has the roots and signs of f(x) = (x - p̄(x)) . n̄(x) wherever W > 0.
 * F > 0 on the side the normals point to. A ray crossing from F > 0 to F < 0
 * enters the surface: a front-face hit. Near folds and thin walls (splats
 * with a layer key, scene.c) the sums run over the splats that face the
 * ray and over those that face away separately, so that opposed layers do
 * not cancel (mls.c, "groups of splats").
 *
 * The leaf intersector takes samples along the part of the ray interval that
 * lies inside some splat's support, evaluates F at all of them at once
 * (AVX2: 8 samples per vector), finds the first accepted sign change,
 * interpolates linearly and polishes the root with two regula-falsi steps.
 */
#ifndef SG_SURFACE_MLS_H
#define SG_SURFACE_MLS_H

#include <stddef.h>
#include <stdint.h>

#include "math/ray.h"
#include "surface/scene.h"
#include "surface/splat_soa.h"

/* Samples per leaf interval beyond which a leaf stops adding more. */
#define SG_MLS_MAX_SAMPLES 64

/* Splats whose layer normals differ by more than acos(SG_MLS_FOLD_COS) =
 * 26 degrees within one support (folds, creases, thin walls and parts;
 * curvature radii below about 2.3 splat radii) take their field per group
 * of splats facing a ray the same way (mls.c "groups of splats", scene.c
 * layer_keys); elsewhere the paper's field is used unchanged. The layer
 * normals are smoothed, so normal noise alone keys few splats (5% of a
 * sphere with normals n + 0.4 N(0, I)); Lucy sampled to 250k points has
 * 35% keyed. */
#define SG_MLS_FOLD_COS 0.9f


typedef struct sg_mls_params {
    sg_kernel kernel;
    int samples;          /* minimum samples per interval (>= 2)                 */
    float max_spacing;    /* max sample spacing in units of the smallest active
                             radius; <= 0: exactly `samples` samples             */
} sg_mls_params;

/* Value of the kernel K(s) for s = distance / radius (0 outside [0,1)). */
float sg_mls_kernel(sg_kernel kernel, float s);

/* Scalar reference evaluation of F at x over splats [first, first+count).
 * Optional outputs: *wsum = W(x), *nsum = sum w_i n_i, *argmax = id of the
 * splat with the largest weight (SG_INVALID_ID when W == 0). */
float sg_mls_field(const sg_splat_soa *s, size_t first, size_t count, sg_kernel kernel, sg_vec3 x,
                   float *wsum, sg_vec3 *nsum, uint32_t *argmax);

/* Same field over splats given by pointset indices (used during the build,
 * before the per-leaf arrays exist). */
float sg_mls_field_indexed(const sg_pointset *ps, const uint32_t *idx, size_t count, sg_kernel kernel,
                           sg_vec3 x, float *wsum, sg_vec3 *nsum);

/* The last sample of the previous leaf, handed to the next one. Two leaves
 * evaluate F at their shared face from different splat lists, so the two
 * values can differ in sign by rounding when the surface passes through
 * the face: comparing across the face catches that crossing. One sample
 * per group of splats (the group facing the ray, the group facing away:
 * sg_mls_intersect_leaf). */
typedef struct sg_mls_carry {
    int valid;      /* bit g: group g's last covered sample (W >= W_EPS), at
                       t_last[g], may still bracket a crossing: it lies at
                       the leaf's end t, or before a gap in the supports
                       short enough to bridge (sg_mls_intersect_leaf)     */
    int outside;    /* the ray's last sample of the group facing it, in any
                       leaf so far, had F > 0 (rays accepting either face) */
    float t;        /* the end of the leaf it comes from                  */
    float t_last[2];
    float F[2];
    float N[2][3];
} sg_mls_carry;

/* Nearest accepted crossing of F along ray within [t0, t1] using the leaf's
 * splats [first, first+count). Returns 1 and fills hit (t, p, n, splat).
 * carry (may be NULL) comes from the previous leaf on the ray and is
 * updated for the next one. */
int sg_mls_intersect_leaf(const sg_splat_soa *s, size_t first, size_t count, const sg_mls_params *mp,
                          const sg_ray *ray, float t0, float t1, sg_hit *hit, sg_mls_carry *carry);

/* Evaluates F and W at 8 ray parameters t[0..7] with the SIMD kernel
 * (scalar loop in the portable build) over the leaf's splats. Exposed so a
 * test can hold it against sg_mls_field. */
void sg_mls_eval8(const sg_splat_soa *s, size_t first, size_t count, sg_kernel kernel, const sg_ray *ray,
                  const float t[8], float F[8], float W[8]);

/* Shrink hook for the kd-tree build (§3.4.1): slices the cell along the
 * dominant axis of the splats' mean normal, samples F in each slice and
 * tightens the cell to the slices that may contain the surface. `user` is an
 * sg_mls_shrink_ctx. */
typedef struct sg_mls_shrink_ctx {
    const sg_pointset *points;
    sg_kernel kernel;
} sg_mls_shrink_ctx;
int sg_mls_shrink_cell(void *user, const uint32_t *prims, size_t count, sg_aabb *cell);

#endif
