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
 * Stray points: a point far from the rest (a raw, unaligned range scan,
 * a flying pixel at a depth edge) has a k-th neighbour distance of its
 * distance to the surface and would get a splat covering the frame. Every
 * radius is therefore capped at cap x the median radius of the set (cap
 * SG_RADIUS_CAP_DEFAULT = 8 unless the desc says otherwise): evenly sampled
 * surfaces vary by less than 2x, scans by a few times with the distance to
 * the scanner, stray points by 100x and more. stats says how many were
 * capped; capped[] (optional) marks them, for callers that drop them.
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

#define SG_RADIUS_CAP_DEFAULT 8.0f /* radii capped at 8 x the median */

/* What the cap did. */
typedef struct sg_radius_stats {
    size_t capped;     /* radii lowered to the cap                        */
    float median;      /* median radius before the cap                    */
    float cap_radius;  /* the cap: cap x median (INFINITY without a cap)  */
} sg_radius_stats;

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
    float cap;         /* radii above cap x the median are capped; 0 =
                          SG_RADIUS_CAP_DEFAULT, < 0 no cap, else >= 1       */
    sg_radius_stats *stats;  /* optional out: filled on SG_OK                */
    unsigned char *capped;   /* optional out: count bytes, 1 where capped    */
} sg_radius_desc;

/* d may be NULL (all defaults). An empty pointset is a no-op. */
sg_status sg_points_estimate_radii(sg_pointset *ps, const sg_radius_desc *d, sg_error *err);

#endif
