/* iso_int.h — the ISO's stored layout, shared by iso_build.c (writes it)
 * and iso.c (traverses it). Not a public header.
 *
 * The root cube is [lo, lo + edge]^3. Cells are addressed by integer
 * coordinates in units of unit = edge / 2^max_depth; a cell of level l has
 * edge 2^(max_depth - l) units. Grid coordinate i maps to world
 * lo + i * unit through iso_coord, the one expression both the build and
 * the traversal use, so a face shared by two cells is the same float.
 *
 * Arrays (each 64-byte aligned, sg_alloc_array):
 *   nodes[node_count]     inner nodes; nodes[0] is the root (level 0)
 *   leaves[leaf_count]    stored leaves
 *   cf[corner_count]      corner f, int16, f = cf * f_scale
 *   cn[corner_count]      corner normal, oct-encoded 2 x int16 (x low half)
 * Child c of a cell (bit 0: +x half, bit 1: +y, bit 2: +z) exists iff bit c
 * of child_mask; it is a leaf iff bit c of leaf_mask too. The inner
 * children of a node are nodes[inner_base + k], the leaf children
 * leaves[leaf_base + k], k = the rank of c among them (popcount).
 */
#ifndef SG_SURFACE_ISO_INT_H
#define SG_SURFACE_ISO_INT_H

#include <stdint.h>

#include "surface/iso.h"

#define ISO_MAX_DEPTH 20 /* coordinates up to 2^20 inclusive fit 21 bits of a key */

/* An inner node's coarse patch for level of detail and its surface slab
 * (iso_lod.c). The plane dot(n, x) = d, fitted to the surface in the
 * node's cell, is hit in place of the node's subtree by a ray whose
 * footprint is wider than the cell; the hit reads its light and material
 * from `leaf`, the stored leaf nearest the plane's centre; leaf =
 * ISO_NO_LOD where no plane fits. Every stored leaf below the node lies
 * in the slab s_lo <= dot(n, x) <= s_hi (boxes, not only their patches),
 * so a ray whose path through the cell stays off the slab meets no leaf
 * there (iso.c skips the node). */
typedef struct iso_lod {
    int16_t n[3];        /* normal x 32767, rounded (iso_lod_normal): one
                            multiply per axis to decode, as every ray
                            meeting the node tests its slab              */
    uint16_t pad;        /* zero (the checksum reads it)                    */
    float d;             /* plane offset                                    */
    float s_lo, s_hi;    /* the slab of the leaves below (empty: lo > hi)   */
    uint32_t leaf;       /* the leaf an LOD hit reads, or ISO_NO_LOD        */
} iso_lod;

#define ISO_NO_LOD UINT32_MAX

/* The stored normal of a node's plane and slab, as stored (within 2e-5 of
 * unit length; the plane and slab were computed with this vector). */
static inline sg_vec3 iso_lod_normal(const iso_lod *D)
{
    const float s = 1.0f / 32767.0f;
    return sg_v3((float)D->n[0] * s, (float)D->n[1] * s, (float)D->n[2] * s);
}

typedef struct iso_node {
    uint32_t inner_base; /* first inner child in nodes[]                  */
    uint32_t leaf_base;  /* first leaf child in leaves[]                  */
    uint8_t child_mask;  /* children that exist                           */
    uint8_t leaf_mask;   /* of those, the leaves                          */
    uint8_t pos_mask;    /* children not stored whose corners are all valid
                            and positive: in front of the surface. A ray
                            accepting either face that crosses one is
                            outside, so an exit crossing after it is not
                            taken as a back face (iso.c)                  */
    uint8_t pad;         /* zero (the checksum reads it)                  */
    iso_lod lod;         /* in the node, not an array beside it: every ray
                            meeting the node reads its slab (one cache
                            line instead of two; measured)                */
} iso_node;

typedef struct iso_leaf {
    uint32_t corner[8]; /* corner c at (bit 0: +x, bit 1: +y, bit 2: +z)    */
    uint32_t splat;     /* representative splat: nearest to the centre      */
} iso_leaf;

struct sg_iso {
    sg_vec3 lo;          /* root cube corner                                 */
    float edge;          /* root cube edge                                   */
    float unit;          /* edge / 2^max_depth                               */
    int max_depth;
    float f_scale;       /* f = cf * f_scale                                 */
    size_t node_count, leaf_count, corner_count;
    iso_node *nodes;
    iso_leaf *leaves;
    int16_t *cf;
    uint32_t *cn;
    float lod_px;        /* level-of-detail threshold in pixels; 0: off      */
    sg_iso_info info;    /* filled at the end of the build                   */
    int borrowed;        /* 1: nodes, leaves, cf, cn belong to a world file's
                            map (scene_store.c); destroy frees the struct only */
};

static inline float iso_coord(float lo, float unit, uint32_t i) { return lo + (float)i * unit; }

/* Fits every inner node's coarse patch and slab (nodes[].lod) once the
 * octree is laid out. */
void iso_lod_build(sg_iso *iso);

#endif
