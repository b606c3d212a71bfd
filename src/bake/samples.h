/* samples.h — sample points of the bake: a deterministic subset of a
 * model's light sites (surface/sites.h; the splats of MLS and disk
 * surfaces, so "splat" below means site) at which the expensive estimates
 * (direct light by shadow rays, glossy bins) are computed, and the
 * interpolation back to every site.
 *
 * What it does:
 *  - thinning (sg_samples_thin): visits candidate splats in a fixed order
 *    (index order) and accepts one when no accepted sample facing the same
 *    way (normal dot >= normal_cos) lies closer than the spacing s: a
 *    greedy Poisson-disk subset. Sites marked unsampled (sites.h) are
 *    never accepted. A uniform grid hash of cell size s finds
 *    the neighbours. Guarantees (tested): no two same-facing samples closer
 *    than s; every candidate not unsampled has a same-facing sample within s.
 *  - refinement (sg_samples_refine): where a sample's value (luminance)
 *    differs from a same-facing neighbour sample's by more than a relative
 *    threshold and beyond its noise (a shadow boundary, a contact shadow),
 *    the splats within the
 *    sample's spacing become candidates of a thinning at half the spacing
 *    (one level finer). Decisions run in sample order after all values are
 *    known, so the set ignores the thread count.
 *  - interpolation (sg_samples_interpolate): each splat takes the
 *    Wendland-C2 weighted linear fit of the same-facing samples whose
 *    support (support x their spacing) covers it; where the samples of a
 *    finer level cover the splat, the coarser levels drop out (a partition
 *    of unity over the levels, samples.c levels_weights), so a refined
 *    edge is not blurred by the coarse samples around it; the nearest
 *    sample when none covers it.
 *  - nearest (sg_samples_nearest): each splat's nearest same-facing sample
 *    (glossy bins are looked up per sample, bake/glossy.h).
 * What it does not do: choose the spacing (bake.c does, from the material:
 *    sg_samples_default_spacing) or compute any value.
 *
 * Spacing of a sample of level l: s / 2^l. Sets grow by appending, so the
 * indices of existing samples never change.
 *
 * Thread-safety: the functions are reentrant; interpolate and nearest run
 * OpenMP loops whose results do not depend on the thread count.
 */
#ifndef SG_BAKE_SAMPLES_H
#define SG_BAKE_SAMPLES_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "material/bsdf.h"
#include "surface/sites.h"

#define SG_SAMPLES_MAX_LEVEL 8
#define SG_SAMPLES_MAX_CHANNELS 12 /* values per sample of sg_samples_interpolate_n */

typedef struct sg_sample_set {
    size_t count;     /* sample points                                     */
    size_t capacity;  /* allocated entries of splat[] and level[]          */
    uint32_t *splat;  /* splat index of each sample, in acceptance order   */
    uint8_t *level;   /* refinement level: its spacing is s / 2^level      */
} sg_sample_set;

void sg_sample_set_free(sg_sample_set *set);

/* Median of ps->radius over the sites that may be sample points (not
 * unsampled; 0 when there are none). SG_ERR_NOMEM only. */
sg_status sg_samples_median_radius(const sg_sites *ps, float *out, sg_error *err);

/* Default spacing of a material's sample points, as a multiple of the
 * model's median splat radius: 4 for a diffuse (Lambert, or specular 0)
 * material; for a glossy one 2 + 2 roughness (a rough lobe is nearly
 * diffuse, a sharp one varies faster over the surface). */
float sg_samples_default_spacing(const sg_material *m);

/* Appends to set the candidates (splat indices, visited in the given
 * order; NULL: every splat in index order, ncand ignored) that keep every
 * pair of same-facing samples at least `spacing` apart, counting the
 * samples already in set. New samples get level `level`. spacing > 0. */
sg_status sg_samples_thin(const sg_sites *ps, float spacing, float normal_cos, const uint32_t *candidates,
                          size_t ncand, uint8_t level, sg_sample_set *set, sg_error *err);

/* One refinement step. values: 3 floats (RGB) per sample of set; sigma
 * (NULL: none) the standard error of each value's luminance. A sample of
 * level `level` is marked when some same-facing sample within twice its
 * spacing differs in luminance by more than threshold * max of the two
 * (values below 5% of the mean luminance count as that floor) AND by more
 * than 3 sqrt(sigma_a^2 + sigma_b^2), so that Monte Carlo noise alone
 * rarely refines. The splats within one spacing of a marked sample are
 * thinned at half its spacing (level + 1) into set; *added gets the
 * number of new samples (indices [old count, set->count)). s0: spacing of
 * level 0. */
sg_status sg_samples_refine(const sg_sites *ps, float s0, float normal_cos, const float *values,
                            const float *sigma, float threshold, uint8_t level, sg_sample_set *set, size_t *added,
                            sg_error *err);

/* The two halves of sg_samples_refine, for callers that mark samples by
 * several criteria: mark_jumps sets mark[j] = 1 for the samples of level
 * `level` that differ from a neighbour as sg_samples_refine describes
 * (marks already set stay set; mark has set->count entries); refine_marked
 * thins the splats within one spacing of the marked samples of level
 * `level` at half that spacing into set. */
sg_status sg_samples_mark_jumps(const sg_sites *ps, float s0, float normal_cos, const float *values,
                                const float *sigma, float threshold, uint8_t level, const sg_sample_set *set,
                                uint8_t *mark, sg_error *err);
sg_status sg_samples_refine_marked(const sg_sites *ps, float s0, float normal_cos, const uint8_t *mark,
                                   uint8_t level, sg_sample_set *set, size_t *added, sg_error *err);

/* out: 3 floats per splat, interpolated from values (3 floats per sample)
 * as described above (a constant is reproduced exactly, a linear
 * function of the tangent-plane position too where the samples span it); support: kernel radius as a multiple of a sample's
 * spacing (e.g. 2). Deterministic. */
sg_status sg_samples_interpolate(const sg_sites *ps, const sg_sample_set *set, float s0, float support,
                                 float normal_cos, const float *values, int threads, float *out, sg_error *err);

/* The same for `channels` values per sample (1..SG_SAMPLES_MAX_CHANNELS),
 * each interpolated on its own with the same weights: out gets channels
 * floats per splat. */
sg_status sg_samples_interpolate_n(const sg_sites *ps, const sg_sample_set *set, float s0, float support,
                                   float normal_cos, const float *values, int channels, int threads, float *out,
                                   sg_error *err);

/* out: per splat, the index into set of its nearest same-facing sample
 * (nearest of any facing when none faces its way within 2 s0). */
sg_status sg_samples_nearest(const sg_sites *ps, const sg_sample_set *set, float s0, float normal_cos,
                             int threads, uint32_t *out, sg_error *err);

#endif
