/* iso_sites.c — the corners of an ISO as light sites (iso_sites.h).
 *
 * Invariants:
 *  1. every corner is used by some stored leaf (iso_build.c creates corners
 *     for stored leaves only), so every site gets a position, a reach and a
 *     colour from the leaves;
 *  2. a leaf's corner 0 and corner 7 are its box's low and high corners, at
 *     the same floats as sg_iso_leaf_boxes (both come from iso_coord);
 *  3. node_site[q] is SG_INVALID_ID exactly where nodes[q].lod.leaf is
 *     ISO_NO_LOD; the node sites are corner_sites .. view.count - 1, each
 *     named by one node, unsampled, with the representative leaf's splat.
 */
#include "surface/iso_sites.h"

#include <assert.h>
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "surface/iso_int.h"

enum { SITE_ARRAYS = 10 };

/* What the depth-first walk over the inner nodes writes (node sites). */
typedef struct node_walk {
    const sg_iso *iso;
    const sg_pointset *points;
    float *a[SITE_ARRAYS];
    uint32_t *splat, *node_site;
    uint32_t next; /* the next node site's id */
} node_walk;

/* Node q's site (if it has a coarse patch) and its inner children's; its
 * cell at grid coordinates x, y, z, `size` units a side. */
static void node_sites(node_walk *w, uint32_t q, uint32_t x, uint32_t y, uint32_t z, uint32_t size)
{
    const sg_iso *iso = w->iso;
    const iso_node *N = &iso->nodes[q];
    const uint32_t hs = size >> 1;
    w->node_site[q] = SG_INVALID_ID;
    if (N->lod.leaf != ISO_NO_LOD) {
        const uint32_t id = w->next++, sp = iso->leaves[N->lod.leaf].splat;
        /* the cell's centre moved along the stored normal onto the plane
         * n . p = d, clamped into the cell (an oblique plane may pass the
         * centre far off: the site names where the node's surface is, no
         * ray starts from it) */
        const float u = iso->unit;
        const sg_vec3 lo = sg_v3(iso_coord(iso->lo.x, u, x), iso_coord(iso->lo.y, u, y), iso_coord(iso->lo.z, u, z));
        const sg_vec3 hi = sg_v3(iso_coord(iso->lo.x, u, x + size), iso_coord(iso->lo.y, u, y + size),
                                 iso_coord(iso->lo.z, u, z + size));
        const sg_vec3 c = sg_v3(iso_coord(iso->lo.x, u, x + hs), iso_coord(iso->lo.y, u, y + hs),
                                iso_coord(iso->lo.z, u, z + hs));
        const sg_vec3 qn = iso_lod_normal(&N->lod), n = sg_v3_normalize(qn);
        const sg_vec3 on = sg_v3_madd(c, qn, (N->lod.d - sg_v3_dot(qn, c)) / sg_v3_dot(qn, qn));
        const sg_vec3 p = sg_v3_min(sg_v3_max(on, lo), hi);
        float **a = w->a;
        a[0][id] = p.x, a[1][id] = p.y, a[2][id] = p.z;
        a[3][id] = n.x, a[4][id] = n.y, a[5][id] = n.z;
        a[6][id] = w->points->radius[sp];
        a[7][id] = w->points->ar[sp], a[8][id] = w->points->ag[sp], a[9][id] = w->points->ab[sp];
        w->splat[id] = sp;
        w->node_site[q] = id;
    }
    unsigned inner = 0;
    for (unsigned k = 0; k < 8; ++k)
        if ((N->child_mask >> k & 1u) && !(N->leaf_mask >> k & 1u))
            node_sites(w, N->inner_base + inner++, x + (k & 1 ? hs : 0), y + (k & 2 ? hs : 0), z + (k & 4 ? hs : 0),
                       hs);
}

sg_status sg_iso_sites_create(const sg_iso *iso, const sg_pointset *points, sg_iso_sites *out, sg_error *err)
{
    assert(iso && points && out);
    memset(out, 0, sizeof *out);
    size_t nodes = 0;
    for (size_t q = 0; q < iso->node_count; ++q)
        nodes += iso->nodes[q].lod.leaf != ISO_NO_LOD;
    const size_t corners = iso->corner_count, n = corners + nodes, leaves = iso->leaf_count;
    if (n >= SG_INVALID_ID)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "iso: %zu light sites (%zu corners, %zu nodes) exceed 32-bit ids",
                            n, corners, nodes);
    float *data = sg_alloc_array(SITE_ARRAYS * (n ? n : 1), sizeof(float));
    uint32_t *splat = sg_alloc_array(n ? n : 1, sizeof *splat);
    uint32_t *node_site = sg_alloc_array(iso->node_count ? iso->node_count : 1, sizeof *node_site);
    uint8_t *unsampled = sg_alloc_array(n ? n : 1, 1);
    sg_aabb *box = sg_alloc_array(leaves ? leaves : 1, sizeof *box);
    if (!data || !splat || !node_site || !unsampled || !box) {
        sg_free(data);
        sg_free(splat);
        sg_free(node_site);
        sg_free(unsampled);
        sg_free(box);
        return sg_error_set(err, SG_ERR_NOMEM, "iso: out of memory for %zu light sites", n);
    }
    float *a[SITE_ARRAYS];
    for (int k = 0; k < SITE_ARRAYS; ++k)
        a[k] = data + (size_t)k * n;
    float *px = a[0], *py = a[1], *pz = a[2], *radius = a[6], *ar = a[7], *ag = a[8], *ab = a[9];
    for (size_t c = 0; c < corners; ++c) {
        sg_vec3 nrm = sg_iso_decode_normal(iso->cn[c]);
        a[3][c] = nrm.x, a[4][c] = nrm.y, a[5][c] = nrm.z;
        radius[c] = 0.0f; /* no leaf yet (invariant 1 fills it) */
    }
    sg_iso_leaf_boxes(iso, box);
    for (size_t l = 0; l < leaves; ++l) {
        const iso_leaf *L = &iso->leaves[l];
        uint32_t sp = L->splat;
        assert(sp < points->count);
        for (int c = 0; c < 8; ++c) {
            uint32_t id = L->corner[c];
            assert(id < corners);
            if (radius[id] == 0.0f) { /* first leaf to use it: position, reach and colour */
                px[id] = c & 1 ? box[l].hi.x : box[l].lo.x;
                py[id] = c & 2 ? box[l].hi.y : box[l].lo.y;
                pz[id] = c & 4 ? box[l].hi.z : box[l].lo.z;
                ar[id] = points->ar[sp], ag[id] = points->ag[sp], ab[id] = points->ab[sp];
                splat[id] = sp;
                radius[id] = points->radius[sp];
            }
        }
    }
    sg_free(box);
    memset(unsampled, 0, corners);
    memset(unsampled + corners, 1, nodes);
    if (iso->node_count) {
        node_walk w = {.iso = iso, .points = points, .splat = splat, .node_site = node_site,
                       .next = (uint32_t)corners};
        memcpy(w.a, a, sizeof a);
        node_sites(&w, 0, 0, 0, 0, 1u << iso->max_depth);
        assert(w.next == n); /* invariant 3 */
    }
    out->data = data;
    out->splat = splat;
    out->node_site = node_site;
    out->unsampled = unsampled;
    out->corner_sites = corners;
    out->node_count = iso->node_count;
    out->view = (sg_sites){.count = n, .px = px, .py = py, .pz = pz, .nx = a[3], .ny = a[4], .nz = a[5],
                           .radius = radius, .ar = ar, .ag = ag, .ab = ab, .unsampled = unsampled};
    return SG_OK;
}

void sg_iso_sites_free(sg_iso_sites *s)
{
    if (!s)
        return;
    sg_free(s->data);
    sg_free(s->splat);
    sg_free(s->node_site);
    sg_free(s->unsampled);
    memset(s, 0, sizeof *s);
}

size_t sg_iso_sites_memory(const sg_iso_sites *s)
{
    return s->view.count * (SITE_ARRAYS * sizeof(float) + sizeof *s->splat + sizeof *s->unsampled) +
           s->node_count * sizeof *s->node_site;
}

/* The trilinear weights of the hit's leaf, corner c at bit 0 +x, 1 +y, 2 +z. */
static int trilinear(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit, float w[8])
{
    if (hit->leaf >= iso->leaf_count)
        return 0;
    const iso_leaf *L = &iso->leaves[hit->leaf];
    const sg_sites *v = &s->view;
    uint32_t lo = L->corner[0], hi = L->corner[7]; /* invariant 2 */
    float p[3] = {hit->p.x, hit->p.y, hit->p.z};
    float l3[3] = {v->px[lo], v->py[lo], v->pz[lo]}, h3[3] = {v->px[hi], v->py[hi], v->pz[hi]};
    float u[3];
    for (int a = 0; a < 3; ++a) {
        float t = (p[a] - l3[a]) / (h3[a] - l3[a]);
        u[a] = t > 0.0f ? (t < 1.0f ? t : 1.0f) : 0.0f; /* NaN -> 0 */
    }
    for (int c = 0; c < 8; ++c)
        w[c] = (c & 1 ? u[0] : 1.0f - u[0]) * (c & 2 ? u[1] : 1.0f - u[1]) * (c & 4 ? u[2] : 1.0f - u[2]);
    return 1;
}

int sg_iso_hit_sites(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit, uint32_t *ids, float *weights,
                     int max)
{
    float w[8];
    if (max <= 0)
        return 0;
    if (hit->leaf >= iso->leaf_count) { /* an LOD hit names its node (iso.h) */
        const uint64_t q = (uint64_t)hit->leaf - iso->leaf_count;
        if (q >= s->node_count || s->node_site[q] == SG_INVALID_ID)
            return 0;
        ids[0] = s->node_site[q];
        weights[0] = 1.0f;
        return 1;
    }
    if (!trilinear(iso, s, hit, w))
        return 0;
    const iso_leaf *L = &iso->leaves[hit->leaf];
    if (max >= 8) {
        for (int c = 0; c < 8; ++c)
            ids[c] = L->corner[c], weights[c] = w[c];
        return 8;
    }
    /* Keep the max largest (selection: at most 8 x 8 steps) and renormalise. */
    int used = 0;
    float kept = 0.0f;
    unsigned taken = 0;
    for (; used < max; ++used) {
        int best = -1;
        for (int c = 0; c < 8; ++c)
            if (!(taken >> c & 1u) && (best < 0 || w[c] > w[best]))
                best = c;
        taken |= 1u << best;
        ids[used] = L->corner[best];
        weights[used] = w[best];
        kept += w[best];
    }
    for (int j = 0; j < used; ++j)
        weights[j] = kept > 0.0f ? weights[j] / kept : 1.0f / (float)used;
    return used;
}

uint32_t sg_iso_hit_site(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit)
{
    uint32_t id;
    float w;
    return sg_iso_hit_sites(iso, s, hit, &id, &w, 1) ? id : SG_INVALID_ID;
}

/* The filter's walk: adds node q's leaves (cell `size` units a side) to
 * sum (stride doubles, each leaf the mean of its corners times its
 * weight), sets q's site from its own sums, and returns q's weight. scratch
 * holds stride doubles for each level below. */
static double filter_node(const sg_iso *iso, const sg_iso_sites *s, uint32_t q, uint32_t size, float *values,
                          size_t stride, double *sum, double *scratch)
{
    const iso_node *N = &iso->nodes[q];
    double *own = scratch, weight = 0.0;
    memset(own, 0, stride * sizeof *own);
    const uint32_t hs = size >> 1;
    /* a leaf's face area in grid units (exact in double up to 2^26 a side) */
    const double area = (double)hs * (double)hs;
    unsigned inner = 0, leaf = 0;
    for (unsigned k = 0; k < 8; ++k) {
        if (!(N->child_mask >> k & 1u))
            continue;
        if (N->leaf_mask >> k & 1u) {
            const iso_leaf *L = &iso->leaves[N->leaf_base + leaf++];
            for (int c = 0; c < 8; ++c) {
                const float *v = values + stride * (size_t)L->corner[c];
                for (size_t j = 0; j < stride; ++j)
                    own[j] += 0.125 * area * (double)v[j];
            }
            weight += area;
        } else {
            weight += filter_node(iso, s, N->inner_base + inner++, hs, values, stride, own, scratch + stride);
        }
    }
    const uint32_t id = s->node_site[q];
    if (id != SG_INVALID_ID && weight > 0.0) {
        float *o = values + stride * (size_t)id;
        for (size_t j = 0; j < stride; ++j)
            o[j] = (float)(own[j] / weight);
    }
    for (size_t j = 0; j < stride; ++j)
        sum[j] += own[j];
    return weight;
}

void sg_iso_sites_filter(const sg_iso *iso, const sg_iso_sites *s, float *values, size_t stride)
{
    assert(iso && s && values && stride > 0 && stride <= SG_ISO_FILTER_STRIDE_MAX);
    assert(iso->max_depth <= ISO_MAX_DEPTH);
    if (!iso->node_count || s->view.count == s->corner_sites)
        return;
    /* a row of stride doubles for the root's sum and one per level */
    double scratch[(ISO_MAX_DEPTH + 2) * SG_ISO_FILTER_STRIDE_MAX] = {0};
    filter_node(iso, s, 0, 1u << iso->max_depth, values, stride, scratch, scratch + stride);
}
