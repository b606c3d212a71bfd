/* pointset.h — the splats every surface representation is built from.
 *
 * Structure of arrays, because the intersection kernels stream positions,
 * normals and radii. Splat i is the disk/sphere of influence centred at
 * (px[i],py[i],pz[i]) with unit normal (nx[i],ny[i],nz[i]) and radius
 * radius[i] > 0; albedo (ar,ag,ab) is linear RGB in [0,1].
 *
 * Invariants of a valid pointset (sg_pointset_validate checks them):
 *  1. every array has `count` elements (64-byte aligned, sg_alloc_array);
 *  2. positions and radii are finite, radius > 0;
 *  3. normals are unit length (|n| within 1e-3 of 1).
 * Plain struct: the caller owns it and frees it with sg_pointset_free.
 */
#ifndef SG_POINTS_POINTSET_H
#define SG_POINTS_POINTSET_H

#include <stddef.h>

#include "core/error.h"
#include "io/mesh.h"
#include "math/vec3.h"

typedef struct sg_pointset {
    size_t count;            /* number of splats                        */
    float *px, *py, *pz;     /* centres, world space                    */
    float *nx, *ny, *nz;     /* unit normals                            */
    float *radius;           /* radius of influence / disk radius       */
    float *ar, *ag, *ab;     /* albedo, linear RGB                      */
} sg_pointset;

/* Allocates all arrays for `count` splats (contents uninitialised except
 * albedo, which is set to 0.8 grey). On failure *ps is untouched. */
sg_status sg_pointset_alloc(sg_pointset *ps, size_t count, sg_error *err);

void sg_pointset_free(sg_pointset *ps);

/* Checks invariants 1-3; names the first offending splat. */
sg_status sg_pointset_validate(const sg_pointset *ps, sg_error *err);

/* Bounding box of the splat centres (not their extents). */
sg_aabb sg_pointset_bounds(const sg_pointset *ps);

/* Appends all splats of src to *dst (dst may be empty/zeroed). */
sg_status sg_pointset_append(sg_pointset *dst, const sg_pointset *src, sg_error *err);

static inline sg_vec3 sg_pointset_position(const sg_pointset *ps, size_t i)
{
    return sg_v3(ps->px[i], ps->py[i], ps->pz[i]);
}
static inline sg_vec3 sg_pointset_normal(const sg_pointset *ps, size_t i)
{
    return sg_v3(ps->nx[i], ps->ny[i], ps->nz[i]);
}

#endif
