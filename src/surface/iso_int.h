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
    sg_iso_info info;    /* filled at the end of the build                   */
    int borrowed;        /* 1: nodes, leaves, cf, cn belong to a world file's
                            map (scene_store.c); destroy frees the struct only */
};

static inline float iso_coord(float lo, float unit, uint32_t i) { return lo + (float)i * unit; }

#endif
