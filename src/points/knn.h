/* knn.h — k-nearest-neighbour and radius queries over 3D points.
 *
 * What it does: builds a balanced kd-tree (median split on the widest axis
 * of each node's points, leaves of at most `leaf_size` points) over a copy
 * of N points, and answers
 *   - the k nearest neighbours of a query position,
 *   - all points within a radius of a query position,
 *   - batch: the k nearest neighbours (or only the k-th distance) of every
 *     point of the set itself, in parallel (OpenMP).
 * What it does NOT do: approximate search, insertion/removal after create,
 * other metrics than Euclidean.
 *
 * Use:
 *     sg_knn_desc d = { .count = n, .px = x, .py = y, .pz = z };
 *     sg_knn *t; if (sg_knn_create(&d, &t, &err) != SG_OK) ...
 *     uint32_t idx[8]; float d2[8];
 *     size_t found = sg_knn_query(t, q, 8, SG_KNN_NONE, idx, d2);
 *     sg_knn_destroy(t);
 *
 * Results are exact and unique: neighbours are ordered by (squared distance,
 * point index) ascending, so equal distances are broken by the smaller
 * index, and the answer depends neither on the tree's shape nor on the
 * thread count. Squared distances are computed in float as
 * dx*dx + dy*dy + dz*dz with d = q - p.
 *
 * Ownership: create copies the coordinates; the caller's arrays may be
 * freed afterwards. Thread-safety: queries take a const tree and may run
 * concurrently. Indices are the positions in the caller's arrays (uint32).
 */
#ifndef SG_POINTS_KNN_H
#define SG_POINTS_KNN_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "math/vec3.h"

typedef struct sg_knn sg_knn; /* opaque */

/* "No point": as `exclude`, excludes nothing; in results, an empty slot. */
#define SG_KNN_NONE UINT32_MAX

typedef struct sg_knn_desc {
    size_t count;               /* required: number of points (< UINT32_MAX)  */
    const float *px, *py, *pz;  /* required when count > 0: finite coords,
                                   world space; read during create only      */
    unsigned leaf_size;         /* max points per leaf; 0 = 8                 */
} sg_knn_desc;

/* Builds the tree in O(N log N), parallel with OpenMP tasks.
 * Errors: SG_ERR_INVALID_ARG (NULL arrays, a non-finite coordinate: names
 * the point), SG_ERR_UNSUPPORTED (count >= UINT32_MAX), SG_ERR_NOMEM. */
sg_status sg_knn_create(const sg_knn_desc *d, sg_knn **out, sg_error *err);

/* NULL is a no-op. */
void sg_knn_destroy(sg_knn *t);

size_t sg_knn_count(const sg_knn *t);

/* The point indices in tree order (spatially coherent): iterating batch
 * work in this order keeps queries cache-friendly. count entries, owned by
 * the tree. */
const uint32_t *sg_knn_order(const sg_knn *t);

/* The k nearest points to q, skipping the point with index `exclude`
 * (SG_KNN_NONE skips none; coincident points with other indices are not
 * skipped). Writes idx[0..found) and d2[0..found) (both required, room for
 * k) sorted by (d2, index); returns found = min(k, points available). */
size_t sg_knn_query(const sg_knn *t, sg_vec3 q, size_t k, uint32_t exclude,
                    uint32_t *idx, float *d2);

/* Every point p (except `exclude`) with |q - p|^2 <= r*r. Returns how many
 * there are; writes the first min(that, cap) to idx/d2 (may be NULL when
 * cap == 0). When all fit they are sorted by (d2, index); when they do not,
 * which ones are written is unspecified (but deterministic) — call again
 * with a larger cap. */
size_t sg_knn_radius(const sg_knn *t, sg_vec3 q, float r, uint32_t exclude,
                     uint32_t *idx, float *d2, size_t cap);

/* For every point i of the set: its k nearest other points (itself
 * excluded by index), row i at idx[i*k .. i*k+k), d2 likewise (d2 may be
 * NULL). When fewer than k others exist the tail of a row is SG_KNN_NONE /
 * INFINITY. Parallel (OpenMP); identical results for any thread count.
 * Errors: SG_ERR_NOMEM (count*k overflows or scratch). */
sg_status sg_knn_query_all(const sg_knn *t, size_t k, uint32_t *idx, float *d2, sg_error *err);

/* For every point i: the squared distance to its k-th nearest other point
 * (INFINITY when fewer than k others exist), into d2k[i]. Same threading
 * and errors as sg_knn_query_all, but O(N) output. */
sg_status sg_knn_kth_all(const sg_knn *t, size_t k, float *d2k, sg_error *err);

#endif
