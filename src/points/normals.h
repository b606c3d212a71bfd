/* normals.h — splat normals from the point positions (PCA + orientation).
 *
 * What it does, for each point whose normal is to be estimated:
 *  1. PCA: the covariance of the point and its k nearest neighbours; the
 *     normal is the eigenvector of the smallest eigenvalue (the direction
 *     in which the neighbourhood is thinnest). Hoppe et al. 1992, §3.2.
 *  2. Orientation: PCA gives ±n. Signs are made consistent by propagation
 *     along a minimum spanning tree of the symmetric kNN graph with edge
 *     weight 1 - |n_i . n_j| (Hoppe et al. 1992, §3.3): nearly parallel
 *     neighbours are visited first, and each newly reached normal is
 *     flipped to agree (n_i . n_j >= 0) with the one it was reached from.
 *     Each connected component starts at its point of largest y (ties: the
 *     smallest index), whose normal is turned to +y — the outward normal at
 *     the top of a closed smooth surface is +y. When that normal is nearly
 *     horizontal (|n_y| < 0.5: a crease, a rim, a vertical sheet) it is
 *     instead turned away from the component's centroid.
 *
 * SG_NORMALS_ONLY_MISSING: only normals that are missing — the zero vector
 * (how the loaders mark an unknown normal) or non-finite — are estimated;
 * the others are kept as given and trusted as oriented. Orientation then
 * grows one spanning forest from all known normals at once (every missing
 * normal reached from a known neighbour agrees with the known side), and
 * components without any known normal fall back to the rule above.
 *
 * Degenerate neighbourhoods: coincident points give a zero covariance and
 * the normal (1,0,0) before orientation; collinear ones any normal
 * perpendicular to their line. Both are deterministic.
 *
 * Use:
 *     sg_normals_desc d = { .flags = SG_NORMALS_ONLY_MISSING };  zero = k 12
 *     if (sg_points_estimate_normals(&ps, &d, &err) != SG_OK) ...
 *
 * Errors: SG_ERR_INVALID_ARG (fewer than 3 points, non-finite position
 * naming the point, a shared tree of the wrong size), SG_ERR_NOMEM.
 * Only normals are written, and only on SG_OK. Parallel (OpenMP) PCA; the
 * orientation pass is sequential; results are identical for any thread
 * count. Memory: about (12k + 56) bytes per point.
 */
#ifndef SG_POINTS_NORMALS_H
#define SG_POINTS_NORMALS_H

#include "core/error.h"
#include "points/knn.h"
#include "points/pointset.h"

enum {
    SG_NORMALS_ONLY_MISSING = 1u << 0 /* keep non-zero finite normals */
};

typedef struct sg_normals_desc {
    unsigned k;        /* neighbours for PCA and the orientation graph; 0 = 12 */
    unsigned flags;    /* SG_NORMALS_* bits; 0 = estimate every normal         */
    const sg_knn *knn; /* optional, shared for the call: a tree built over
                          exactly this pointset's positions; NULL = build one  */
} sg_normals_desc;

/* d may be NULL (all defaults). An empty pointset is a no-op. */
sg_status sg_points_estimate_normals(sg_pointset *ps, const sg_normals_desc *d, sg_error *err);

/* Eigen-decomposition of the symmetric 3x3 matrix
 *     | a[0] a[1] a[2] |
 *     | a[1] a[3] a[4] |
 *     | a[2] a[4] a[5] |
 * by cyclic Jacobi rotations (Golub & Van Loan §8.5), in double precision.
 * Eigenvalues ascending into w[0..2]; the unit eigenvector of w[m] into
 * v[3m .. 3m+2]; the vectors are orthonormal. Total for any finite input. */
void sg_sym3_eigen(const double a[6], double w[3], double v[9]);

#endif
