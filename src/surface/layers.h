/* layers.h — layer keys: which splats lie near an opposed or folded layer,
 * and the normal of the layer each belongs to (mls.c "groups of splats",
 * iso_build.c "layered corners").
 *
 * What it does: for every splat i of a point set, a layer normal l_i (its
 * normal averaged over its own layer, three passes of a kernel-weighted
 * mean over the neighbours within 90 degrees) and a key: l_i rounded to
 * int8 per component (x in bits 0-7, y 8-15, z 16-23; only directions are
 * read, so 1/127 is ample) for every splat near a fold (some splat whose
 * support covers it, or covers a splat covering it, has a layer normal
 * more than acos(SG_MLS_FOLD_COS) = 26 degrees from its own), 0 for all
 * others. Steps and measurements: layers.c.
 *
 * What it does not do: find neighbours. The caller says, for each splat i,
 * which splats may cover p_i (sg_layer_cover); the MLS scene gives the
 * kd-tree leaf holding p_i, the ISO a uniform grid (sg_layer_keys_grid).
 * The keys depend on the order of each list only through the rounding of
 * sums, so a caller that wants the same bits on every run gives the same
 * lists in the same order.
 *
 * Ownership: key[] (point count entries) is the caller's; nothing is kept.
 * Thread-safety: runs OpenMP loops over the splats; the cover callback is
 * called from several threads at once and must not write shared state.
 */
#ifndef SG_SURFACE_LAYERS_H
#define SG_SURFACE_LAYERS_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "points/pointset.h"
#include "surface/scene.h"

/* The splats that may cover point p_i: a superset of every j with
 * |p_i - p_j| < r_j, as point indices, *count of them. The list must stay
 * valid until sg_layer_keys returns. */
typedef const uint32_t *(*sg_layer_cover_fn)(const void *user, size_t i, size_t *count);

/* Layer keys of the splats of p into key[0..p->count), the number of
 * non-zero keys into *keyed_count (may be NULL). SG_ERR_NOMEM only. */
sg_status sg_layer_keys(const sg_pointset *p, sg_kernel kernel, sg_layer_cover_fn cover, const void *user,
                        uint32_t *key, size_t *keyed_count, sg_error *err);

/* The same, with the covering splats found in a uniform grid of cells
 * (each splat listed in every cell its support's box overlaps; lists in
 * increasing index order, so the keys are the same bits for any thread
 * count). SG_ERR_NOMEM only. */
sg_status sg_layer_keys_grid(const sg_pointset *p, sg_kernel kernel, uint32_t *key, size_t *keyed_count,
                             sg_error *err);

/* A key's direction (about 127 x the layer normal; 0 for no key). */
static inline void sg_layer_key_decode(uint32_t key, float out[3])
{
    out[0] = (float)(int8_t)(uint8_t)(key & 0xFFu);
    out[1] = (float)(int8_t)(uint8_t)((key >> 8) & 0xFFu);
    out[2] = (float)(int8_t)(uint8_t)((key >> 16) & 0xFFu);
}

#endif
