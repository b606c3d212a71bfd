/* sphere_tree.h — the bounding-sphere hierarchy of Ye 2005 (PPRT, §3.1)
 * over a triangle mesh: leaves hold triangles, and every node, leaf or
 * inner, is also a point primitive (centre, radius, mean normal, normal
 * cone, plane offset, mean colour) that a traversal may hit in place of
 * its subtree when it looks small enough (level of detail).
 *
 * What it does: builds the tree top-down (each node split into up to
 * SG_STREE_WIDTH children by binned sphere-area splits, §"Build" in
 * sphere_tree.c), computes a tight sphere per node (the exact radius of its
 * triangles' vertices around the centre of their box), and stores it flat:
 * node bundles of SG_STREE_WIDTH lanes, 64-byte aligned, that a traversal
 * tests in one go. What it does not do: intersect rays (surface/hybrid.c),
 * validate the mesh (the caller passes finite vertices, indices in range
 * and no zero-area triangle), refit, instance.
 *
 * Layout (what traversal reads):
 *   node id k = bundle * SG_STREE_WIDTH + lane. Bundle 0 holds the root in
 *   lane 0; its other lanes are empty. An inner node's children fill the
 *   lanes of bundle child_bundle(k) (lanes from 0; unused lanes empty). An
 *   empty lane has radius NaN, so every sphere test written to fail on
 *   NaN misses it, and child word SG_STREE_EMPTY.
 *   child word of node k (bundles[b].child[lane]):
 *     inner: the bundle index of its children (< 2^31);
 *     leaf:  SG_STREE_LEAF | (count - 1) << SG_STREE_COUNT_SHIFT | first,
 *            the triangles [first, first + count) of the leaf order;
 *   order[i] is the input index of the i-th triangle in leaf order; every
 *   subtree's triangles are contiguous in that order.
 *   point attributes of node k (in its bundle, lane l): the area-weighted
 *   mean geometric normal, quantised to int8 (u = n / 127); the slab
 *   along u that holds the node's triangles (it tightens the sphere for a
 *   traversal: surface patches are thin); the sine of the normal cone's
 *   half-angle (every triangle's unit normal within that angle of u / |u|;
 *   quantised up, 255 = 90 degrees or more); and the offset of the
 *   area-weighted centroid from the centre along u / |u|, in units of the
 *   radius (int8 / 127).
 *
 * Invariants after sg_stree_build:
 *  1. every vertex of every triangle under node k lies within the stored
 *     radius of its stored centre, and within its slab, after rounding
 *     (the radius is rounded up in double and padded by
 *     SG_STREE_RADIUS_PAD relative; slab bounds are rounded outwards from
 *     exact (double) extents against the stored u);
 *  2. the normal cone holds every triangle's unit normal, measured against
 *     the stored (quantised) normal;
 *  3. depth (bundles from the root bundle to the deepest leaf) <=
 *     SG_STREE_MAX_DEPTH, so a traversal stack of
 *     (SG_STREE_WIDTH - 1) * SG_STREE_MAX_DEPTH + 2 entries never overflows;
 *  4. the layout is a function of the input only, never of thread count.
 *
 * Ownership: sg_stree_build allocates every array (sg_alloc_array);
 * sg_stree_free releases them. Inputs are read during the build only.
 */
#ifndef SG_ACCEL_SPHERE_TREE_H
#define SG_ACCEL_SPHERE_TREE_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "math/vec3.h"

/* Children per node (the branching factor): CMake's SG_HYBRID_WIDTH, 8
 * unless a build chooses 2 or 4 for measuring (8 traced 22% faster than 4
 * on the dragon, docs/hybrid.md). */
#ifndef SG_STREE_WIDTH
#define SG_STREE_WIDTH 8
#endif

#define SG_STREE_MAX_LEAF 8          /* triangles per leaf at most             */
#define SG_STREE_MAX_DEPTH 64        /* bundles from root to any leaf, at most */
#define SG_STREE_MAX_TRIANGLES (1u << 28) /* leaf words hold 28-bit offsets    */
#define SG_STREE_LEAF 0x80000000u
#define SG_STREE_COUNT_SHIFT 28
#define SG_STREE_FIRST_MASK 0x0FFFFFFFu
#define SG_STREE_EMPTY 0xFFFFFFFFu
#define SG_STREE_RADIUS_PAD 4.0e-7f  /* relative: radius *= 1 + pad, > 3 ulp   */

/* SG_STREE_WIDTH nodes: spheres as structure-of-arrays (one aligned load
 * per coordinate), their child words, then per node the quantised mean
 * normal u = (nx, ny, nz) / 127, the slab {x : slo r / 120 <= (x - c) . u
 * <= shi r / 120} that holds its triangles, the offset of its
 * area-weighted centroid along u / |u| (offset r / 127), and the sine of
 * its normal cone's half-angle (sin_cone / 255, rounded up; 255: 90
 * degrees or more). Width 4: 128 bytes; 8: 256 bytes. */
typedef struct sg_stree_bundle {
    _Alignas(64) float cx[SG_STREE_WIDTH]; /* (the alignment binds this one field) */
    float cy[SG_STREE_WIDTH], cz[SG_STREE_WIDTH];
    float r[SG_STREE_WIDTH];              /* NaN: empty lane             */
    uint32_t child[SG_STREE_WIDTH];       /* child word (see header)     */
    int8_t nx[SG_STREE_WIDTH], ny[SG_STREE_WIDTH], nz[SG_STREE_WIDTH];
    int8_t slo[SG_STREE_WIDTH], shi[SG_STREE_WIDTH];
    int8_t offset[SG_STREE_WIDTH];
    uint8_t sin_cone[SG_STREE_WIDTH];
} sg_stree_bundle;

#define SG_STREE_NORMAL_SCALE 127.0f  /* u = (nx, ny, nz) / this        */
#define SG_STREE_SLAB_SCALE 120.0f    /* slab bounds in units of r / this; < 127
                                         because |u| may exceed 1 by rounding */

/* The unit mean normal of lane l (u / |u|). */
static inline sg_vec3 sg_stree_normal(const sg_stree_bundle *B, int l)
{
    return sg_v3_normalize(sg_v3((float)B->nx[l], (float)B->ny[l], (float)B->nz[l]));
}

typedef struct sg_stree_desc {
    size_t vertex_count;
    const float *positions;     /* 3 per vertex (shared, read during build) */
    size_t triangle_count;      /* >= 1, <= SG_STREE_MAX_TRIANGLES          */
    const uint32_t *triangles;  /* 3 vertex ids per triangle                */
    const float *colors;        /* 3 per vertex, or NULL                     */
    int leaf_max;               /* triangles per leaf, 1..SG_STREE_MAX_LEAF; default 8 */
    int threads;                /* build threads; 0 = OpenMP default         */
} sg_stree_desc;

typedef struct sg_stree {
    sg_stree_bundle *bundles;   /* bundle_count, 64-byte aligned              */
    size_t bundle_count;
    float *colors;              /* 3 per node id (bundle_count * WIDTH), area-weighted
                                   mean of the triangles' vertex colours; NULL
                                   when the desc had none                   */
    uint32_t *order;            /* triangle_count input indices, leaf order  */
    size_t triangle_count;
    size_t node_count;          /* non-empty lanes                            */
    size_t leaf_count;          /* nodes that hold triangles                  */
    int depth;                  /* bundles on the longest root-to-leaf path   */
} sg_stree;

/* Builds the tree (parallel, OpenMP tasks). Errors: SG_ERR_INVALID_ARG (no
 * triangles, NULL arrays, leaf_max out of range), SG_ERR_UNSUPPORTED
 * (more than SG_STREE_MAX_TRIANGLES), SG_ERR_NOMEM. *out is written only on
 * SG_OK. */
sg_status sg_stree_build(const sg_stree_desc *desc, sg_stree *out, sg_error *err);

void sg_stree_free(sg_stree *tree);

/* Bytes held by the tree's arrays. */
size_t sg_stree_memory(const sg_stree *tree);

static inline int sg_stree_is_leaf(uint32_t word) { return (word & SG_STREE_LEAF) != 0 && word != SG_STREE_EMPTY; }
static inline uint32_t sg_stree_leaf_first(uint32_t word) { return word & SG_STREE_FIRST_MASK; }
static inline uint32_t sg_stree_leaf_count(uint32_t word) { return ((word >> SG_STREE_COUNT_SHIFT) & 7u) + 1u; }

#endif
