/* kdtree.h — SAH kd-tree over axis-aligned primitive boxes (Wald & Seidel
 * 2005, §3.4), with the paper's three refinements as options.
 *
 * The tree stores, in each leaf, every primitive whose box overlaps the
 * leaf's cell (primitives straddling a plane go to both sides). It knows
 * nothing of splats: the caller supplies boxes, and optionally a shrink hook
 * that tightens a leaf cell to where the surface actually is (§3.4.1); the
 * leaf keeps that box (leaf_bounds) for traversal to clip against, and the
 * builder drops the primitives that no longer overlap it.
 *
 * Layout of the built tree (what traversal reads):
 *   nodes[0] is the root. An inner node has split axis 0..2, the split
 *   position, and children at nodes[child] (left, below the plane) and
 *   nodes[child + 1] (right). A leaf (axis == 3) has a leaf index;
 *   leaf_first[l] .. leaf_first[l+1] index into refs[], the primitive ids.
 *
 * Invariants after sg_kdtree_build:
 *  1. every inner node's children are a pair in nodes[], after the parent;
 *  2. leaf_first has leaf_count + 1 entries, non-decreasing, last = ref_count;
 *  3. every primitive overlapping a non-empty leaf's box (leaf_bounds) is in it, so
 *     a function supported on the primitives' boxes can be evaluated exactly
 *     inside a cell from the leaf's primitives alone;
 *  4. the layout is a function of the input only, never of thread count.
 */
#ifndef SG_ACCEL_KDTREE_H
#define SG_ACCEL_KDTREE_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "math/vec3.h"

/* 8-byte node: word = (index << 2) | axis, axis 3 = leaf. For an inner node
 * index is the left child; for a leaf it is the leaf number. */
typedef struct sg_kd_node {
    uint32_t word;
    float split;
} sg_kd_node;

static inline int sg_kd_node_axis(sg_kd_node n) { return (int)(n.word & 3u); }
static inline int sg_kd_node_is_leaf(sg_kd_node n) { return (n.word & 3u) == 3u; }
static inline uint32_t sg_kd_node_index(sg_kd_node n) { return n.word >> 2; }

/* Shrink hook: given the primitives of a leaf-to-be and its cell, tighten
 * *cell to the part that may contain the surface. Return 0 when the cell
 * contains no surface at all (the leaf becomes empty), 1 otherwise. Must be
 * a pure function of its inputs (thread-safe, deterministic). */
typedef int (*sg_kd_shrink_fn)(void *user, const uint32_t *prims, size_t count, sg_aabb *cell);

enum sg_kd_build_flags {
    SG_KD_BUILD_ENCOURAGE = 1u << 0, /* §3.4.2 E(n) in the child cost        */
    SG_KD_BUILD_COLLAPSE = 1u << 1   /* §3.4.3 merge splits of two empties    */
};

typedef struct sg_kdtree_desc {
    size_t count;           /* number of primitives                            */
    const float *lo[3];     /* lo[axis][i]: box minimum of primitive i (shared, read during build only) */
    const float *hi[3];     /* hi[axis][i]: box maximum                        */
    uint32_t flags;         /* sg_kd_build_flags                               */
    int max_depth;          /* default 48                                      */
    float cost_traversal;   /* SAH C_trav; default 1                           */
    float cost_intersect;   /* SAH C_isec; default 1.5                         */
    sg_kd_shrink_fn shrink; /* optional, §3.4.1                                */
    void *shrink_user;
} sg_kdtree_desc;

typedef struct sg_kdtree {
    sg_kd_node *nodes;      /* node_count nodes, root first                    */
    size_t node_count;
    uint32_t *leaf_first;   /* leaf_count + 1 offsets into refs                */
    size_t leaf_count;
    size_t empty_leaf_count;
    uint32_t *refs;         /* primitive ids, grouped by leaf                  */
    size_t ref_count;
    sg_aabb *leaf_bounds;   /* per leaf: the box that holds its surface — the
                               shrunk cell, or the cell (traversal clips the
                               ray against it)                              */
    sg_aabb bounds;         /* root cell                                        */
    int depth;              /* deepest leaf                                     */
} sg_kdtree;

/* Builds the tree. On failure *out is untouched. Parallel (OpenMP tasks) and
 * deterministic. */
sg_status sg_kdtree_build(const sg_kdtree_desc *desc, sg_kdtree *out, sg_error *err);

void sg_kdtree_free(sg_kdtree *tree);

/* Bytes held by the tree's arrays. */
size_t sg_kdtree_memory(const sg_kdtree *tree);

#endif
