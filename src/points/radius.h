/* radius.h — splat radii from the local point spacing.
 *
 * What it does: sets radius[i] = scale * (distance from point i to its k-th
 * nearest other point), the usual spacing estimate for splats (k = 8 gives
 * disks that overlap their ring of neighbours on a surface sampled evenly).
 * With desc.layers, where a third or more of the k nearest of point i
 * have a normal more than 120 degrees from its own (the other side of a
 * thin wall or part), only the points of its own layer (normals within 120
 * degrees) count: otherwise the other side halves the estimate and each
 * side is left with holes (issue 12). Elsewhere the rule is unchanged.
 *
 * Duplicates: a point with at least k coincident copies has a k-th
 * neighbour distance of 0. Such a cluster is treated as one sample: each of
 * its points gets scale * (distance to the k-th nearest point at a
 * different position); when fewer than k such points exist, the farthest of
 * those found. Only when no point at a positive distance is found at all
 * (which needs float underflow of distances) does the cluster fall back to
 * 1e-3 * the bounding-box diagonal of the set.
 * Fewer than k+1 points: k is lowered to count-1.
 *
 * Use:
 *     sg_radius_desc d = {0};                       zero = k 8, scale 1
 *     if (sg_points_estimate_radii(&ps, &d, &err) != SG_OK) ...
 *
 * Errors: SG_ERR_INVALID_ARG (non-finite position naming the point, a
 * single point, all points coincident, scale not finite and > 0, a shared
 * tree of the wrong size), SG_ERR_NOMEM. Positions, normals and albedo are
 * not touched (normals are read only with desc.layers); radius is written
 * only on SG_OK. Parallel (OpenMP), same
 * result for any thread count.
 */
#ifndef SG_POINTS_RADIUS_H
#define SG_POINTS_RADIUS_H

#include "core/error.h"
#include "points/knn.h"
#include "points/pointset.h"

typedef struct sg_radius_desc {
    unsigned k;        /* neighbour rank; 0 = 8                               */
    float scale;       /* multiplier of the k-th distance; 0 = 1.0            */
    int layers;        /* 1: the pointset's normals are set (unit, or 0 for
                          unknown) and a point's k-th neighbour is sought in
                          its own layer where an opposed normal is among its
                          k nearest (header note); 0 (default): normals are
                          not read                                        */
    const sg_knn *knn; /* optional, shared for the call: a tree built over
                          exactly this pointset's positions; NULL = build one */
} sg_radius_desc;

/* d may be NULL (all defaults). An empty pointset is a no-op. */
sg_status sg_points_estimate_radii(sg_pointset *ps, const sg_radius_desc *d, sg_error *err);

#endif
