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
 *     triangles (tree.order is released once tri/tri_id are made);
 *  4. a triangle with lattice {first, n}, n >= 1, owns the vertex ids
 *     first .. first + (n + 1)(n + 2) / 2 - 1, above every mesh vertex
 *     and no other triangle's: its lattice sites, the points of
 *     barycentric (i / n, j / n), i + j <= n, weights of v[1] and v[2],
 *     row i first (sg_hybrid__lattice_id). They are vertices to every
 *     site query (position, normal, colour interpolated over the
 *     triangle) but no traced triangle names them;
 *  5. the mesh's vertices are numbered by first use in leaf order (walking
 *     tri from its start), those no traced triangle uses after them in the
 *     mesh's order: a leaf's vertices lie in a few consecutive cache lines
 *     (hybrid.c renumber_vertices); pos, vnormal and vcolor follow that
 *     numbering.
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
    uint32_t *lattice;     /* 2 per traced triangle, leaf order: its first
                              lattice site and its subdivisions n (0: its
                              own vertices are its sites); NULL when no
                              triangle has a lattice (invariant 4)          */
    size_t vertex_count;   /* the mesh's vertices, then the lattice sites    */
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

/* Most rows a lattice may have (hybrid.c refuses a spacing that needs
 * more; a world file's lattices are checked against it). */
#define SG_HYBRID_LATTICE_MAX_N 8192u

/* Vertex id of lattice point (i, j) of a triangle whose lattice begins at
 * `first` with n subdivisions (invariant 4): rows i = 0..n hold
 * n + 1 - i points each. */
static inline uint32_t sg_hybrid__lattice_id(uint32_t first, uint32_t n, uint32_t i, uint32_t j)
{
    return first + i * (n + 1) - i * (i - 1) / 2 + j;
}

/* The triangle whose vertices carry the light at barycentrics (b1, b2) of
 * the traced triangle at leaf slot `slot` with vertices v: the triangle
 * itself, or, where it has a lattice, the lattice's small triangle holding
 * the point, with the point's barycentrics in it. Each lattice cell
 * (i, j) is split along the line i + j = const, as sg_mesh_make_plane
 * splits a grid's cells: "up" (i, j), (i + 1, j), (i, j + 1) where the
 * fractions sum to 1 or less, "down" (i + 1, j + 1), (i, j + 1),
 * (i + 1, j) above. Points outside the triangle (rounding) are clamped
 * into its edge cells; sg_hybrid__triangle_sites clamps the weights. */
static inline void sg_hybrid__light_triangle(const struct sg_hybrid *h, uint32_t slot, const uint32_t v[3], float b1,
                                             float b2, uint32_t out[3], float *ob1, float *ob2)
{
    const uint32_t n = h->lattice ? h->lattice[2 * (size_t)slot + 1] : 0u;
    if (n == 0) {
        out[0] = v[0], out[1] = v[1], out[2] = v[2];
        *ob1 = b1, *ob2 = b2;
        return;
    }
    const uint32_t first = h->lattice[2 * (size_t)slot];
    const float fn = (float)n;
    float B1 = b1 * fn, B2 = b2 * fn;
    B1 = B1 > 0.0f ? (B1 < fn ? B1 : fn) : 0.0f; /* NaN -> 0 */
    B2 = B2 > 0.0f ? (B2 < fn ? B2 : fn) : 0.0f;
    uint32_t i = (uint32_t)B1, j = (uint32_t)B2;
    i = i < n ? i : n - 1;
    j = j < n - i ? j : n - 1 - i;
    const float f1 = B1 - (float)i, f2 = B2 - (float)j;
    /* Up or down by selects: on a plane seen from afar the two alternate
     * from pixel to pixel, and a branch mispredicted half the time
     * (docs/hybrid.md, "Few triangles, light at lattice sites"). */
    const uint32_t down = (uint32_t)(f1 + f2 > 1.0f) & (uint32_t)(i + j + 2 <= n);
    const uint32_t p = sg_hybrid__lattice_id(first, n, i + 1, j), q = sg_hybrid__lattice_id(first, n, i, j + 1);
    out[0] = sg_hybrid__lattice_id(first, n, i + down, j + down);
    out[1] = down ? q : p;
    out[2] = down ? p : q;
    const float d1 = 1.0f - f1, d2 = 1.0f - f2;
    *ob1 = down ? d1 : f1;
    *ob2 = down ? d2 : f2;
}

#endif
