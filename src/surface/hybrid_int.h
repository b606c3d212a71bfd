/* hybrid_int.h — the inside of sg_hybrid, shared by hybrid.c (create,
 * sites, spawn) and hybrid_trace.c (traversal). Not a public header.
 *
 * Invariants (hybrid.c establishes them, hybrid_trace.c relies on them):
 *  1. tri[3 i .. 3 i + 2] are the vertex ids of the i-th triangle in the
 *     tree's leaf order, tri_id[i] its input index, and every triangle
 *     there has non-zero area (computed in double);
 *  2. pos holds vertex_count finite positions; vnormal, when not NULL,
 *     vertex_count oct-encoded unit normals (oct.h);
 *  3. tree satisfies sphere_tree.h's invariants over exactly these
 *     triangles (tree.order is released once tri/tri_id are made).
 * A hierarchy loaded from a world file (scene_store.c) has been checked
 * for everything a traversal indexes with (child words, leaf ranges,
 * vertex ids, depth) and for NaN, not for invariant 1's tightness.
 */
#ifndef SG_SURFACE_HYBRID_INT_H
#define SG_SURFACE_HYBRID_INT_H

#include "accel/sphere_tree.h"
#include "surface/hybrid.h"

struct sg_hybrid {
    sg_hybrid_desc desc;   /* with defaults filled in (name not kept)        */
    sg_stree tree;         /* node bundles; order released (invariant 3)     */
    uint32_t *tri;         /* 3 per traced triangle, leaf order              */
    uint32_t *tri_id;      /* input index per traced triangle, leaf order    */
    float *pos;            /* 3 per vertex                                   */
    uint32_t *vnormal;     /* per vertex, oct.h; NULL with flat shading      */
    float *vcolor;         /* 3 per vertex; NULL when the mesh had none      */
    size_t vertex_count;
    float self_eps;        /* self_r of rays spawned at triangle hits        */
    sg_hybrid_info info;
    int borrowed;          /* 1: tree.bundles, tree.colors, tri, tri_id, pos,
                              vnormal, vcolor belong to a world file's map
                              (scene_store.c); destroy frees the struct only */
};

/* A triangle hit's three vertex weights from its barycentrics (b1, b2):
 * each clamped to [0, 1], in vertex order. sg_hybrid_hit_sites and the
 * scene's lookup path (hybrid_scene.c) both start here, so their weights
 * are the same bits. */
static inline void sg_hybrid__clamped_weights(float b1, float b2, float w[3])
{
    w[0] = 1.0f - b1 - b2;
    w[1] = b1;
    w[2] = b2;
    for (int k = 0; k < 3; ++k)
        w[k] = w[k] < 0.0f ? 0.0f : (w[k] > 1.0f ? 1.0f : w[k]);
}

#endif
