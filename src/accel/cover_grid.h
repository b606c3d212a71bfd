/* cover_grid.h — which splats' supports may cover a point: a uniform grid.
 *
 * What it does: lists each splat i of a point set in every cell of a
 * uniform grid that the box of its scaled support, p_i +- scale r_i,
 * overlaps (cells of edge 2 x scale x the mean radius: about 8 cells a
 * splat at the mean radius). The cell holding a point x then lists every
 * splat with |x - p_i| < scale r_i, and others (a superset), in increasing
 * index order: a caller summing over the list gets the same bits on every
 * run and thread count. Cell indices are floor((x - lo) / h), monotone in
 * x in float, so the cell holding x lies inside the range of any box that
 * holds x. The cells are kept in a hash on their packed indices (a model
 * is a surface: most of its box's cells are empty).
 *
 * Users: the layer keys (layers.c, scale 1: the splats covering p_i).
 * Stop 32's gap bridge for the ISO queried widened supports (scale 2) at
 * arbitrary points through it (reverted; docs/iso.md).
 *
 * Ownership: build allocates, sg_cover_grid_free releases; the point set
 * is read during the build only. Queries are read-only: any number of
 * threads may query one grid at once.
 */
#ifndef SG_ACCEL_COVER_GRID_H
#define SG_ACCEL_COVER_GRID_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "math/vec3.h"
#include "points/pointset.h"

typedef struct sg_cover_grid {
    float lo[3];        /* the grid's corner                              */
    float inv_h;        /* 1 / cell edge                                  */
    uint64_t *key;      /* packed cell indices, by cell (sg_key_grid3)    */
    size_t cell_count, key_cap;
    uint32_t *slot;     /* open addressing over key: cell + 1, 0 = empty  */
    size_t slot_cap;
    uint32_t *first;    /* cell c lists items[first[c] .. first[c + 1])   */
    uint32_t *items;    /* splat indices, increasing within a cell        */
} sg_cover_grid;

/* Builds the grid of p's supports scaled by `scale` (> 0). SG_ERR_NOMEM
 * (with *out zeroed) only. An empty point set gives an empty grid. */
sg_status sg_cover_grid_build(const sg_pointset *p, float scale, sg_cover_grid *out, sg_error *err);

/* The splats whose scaled support may cover x (a superset of every i with
 * |x - p_i| < scale r_i), *count of them; an empty list (and *count 0)
 * where x lies in no listed cell. */
const uint32_t *sg_cover_grid_at(const sg_cover_grid *g, sg_vec3 x, size_t *count);

void sg_cover_grid_free(sg_cover_grid *g);

#endif
