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

/* The light sites of a triangle hit (hybrid.h sg_hybrid_hit_sites): the
 * vertices v[0..2] weighted by the barycentrics (1 - b1 - b2, b1, b2),
 * each clamped to [0, 1]. With max >= 3 all three in vertex order; with
 * fewer, the largest first (ties keep vertex order). The weights written
 * are over their sum (1 / n each where it is 0). Returns how many (max
 * >= 1). sg_hybrid_hit_sites and the scene's hits (hybrid_scene.c) both
 * come here, so their sites are the same bits. */
static inline int sg_hybrid__triangle_sites(const uint32_t v[3], float b1, float b2, uint32_t *ids, float *weights,
                                            int max)
{
    float w[3] = {1.0f - b1 - b2, b1, b2};
    for (int k = 0; k < 3; ++k)
        w[k] = w[k] < 0.0f ? 0.0f : (w[k] > 1.0f ? 1.0f : w[k]);
    int order[3] = {0, 1, 2};
    if (max < 3)
        for (int i = 1; i < 3; ++i)
            for (int j = i; j > 0 && w[order[j]] > w[order[j - 1]]; --j) {
                int t = order[j];
                order[j] = order[j - 1];
                order[j - 1] = t;
            }
    int n = max < 3 ? max : 3;
    float sum = 0.0f;
    for (int i = 0; i < n; ++i)
        sum += w[order[i]];
    for (int i = 0; i < n; ++i) {
        ids[i] = v[order[i]];
        weights[i] = sum > 0.0f ? w[order[i]] / sum : 1.0f / (float)n;
    }
    return n;
}

/* The id sg_hybrid__triangle_sites puts first with max 1 (the vertex of
 * the largest clamped weight, ties to the earlier vertex; the insertion
 * sort's comparisons, NaN included), with selects instead of the sort's
 * branches: a hit's dominant site (hybrid_scene.c), where the branches
 * mispredicted. */
static inline uint32_t sg_hybrid__dominant_site(const uint32_t v[3], float b1, float b2)
{
    float w[3] = {1.0f - b1 - b2, b1, b2};
    for (int k = 0; k < 3; ++k)
        w[k] = w[k] < 0.0f ? 0.0f : (w[k] > 1.0f ? 1.0f : w[k]);
    const int a = w[1] > w[0];          /* the first after two vertices */
    const float wa = a ? w[1] : w[0], wb = a ? w[0] : w[1];
    return v[w[2] > wb && w[2] > wa ? 2 : a];
}

#endif
