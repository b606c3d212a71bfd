/* iso_lod.c — the coarse patch of every inner node of an ISO, for level of
 * detail (iso.h "Levels of detail"; Kashyap 2010 §4.6 stops camera rays
 * at the octree depth whose cells project below a pixel).
 *
 * A node's coarse patch is the plane fitted to the surface its leaves
 * hold. Each stored leaf contributes one surface point and normal: its
 * centre moved along the patch normal by the patch value there (the
 * corners hold f, the signed distance to the local MLS plane, so this is
 * the centre's foot on the surface), weighted by the leaf's face area
 * (edge^2, the surface a leaf holds scales with it). Per node, the sums of
 * weights, points, outer products of points and normals give the
 * weighted centroid c, the mean normal n and the spread of the points
 * about the plane through c normal to n, bottom-up in one walk.
 *
 * A plane is stored only where it stands for the surface: the normals
 * agree (|mean n| >= LOD_NORMAL_AGREE: no thin wall, fold or opposite
 * sides of a part inside the cell, which a plane would merge) and the
 * points lie near it (RMS distance <= LOD_FLATNESS x the node's edge). A
 * node without a plane is always descended. The node's light and
 * material come from its representative leaf: among its children, the
 * one whose centroid lies nearest the node's, recursively (a leaf is its
 * own), so an LOD hit reads baked light from a leaf of the same patch of
 * surface within the cell, as a full-detail ray through that pixel would.
 *
 * The same normal bounds the node's surface slab: the extent along it of
 * every stored leaf box below (a second walk, each node over its whole
 * subtree: leaves x depth box projections), which lets a ray skip a node
 * whose path stays off it.
 *
 * Deterministic: sequential walks in the laid-out order (the same arrays
 * for any build thread count).
 */
#include <assert.h>
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "surface/iso_int.h"

/* |sum w n| / sum w below this: the cell's normals disagree by more than
 * about 25 degrees on average (a fold, a thin part's two sides). */
#define LOD_NORMAL_AGREE 0.9

/* RMS distance of the leaves' surface points from the fitted plane, in
 * units of the node's edge, above which the plane is not stored. A node is
 * hit as a plane only when it is below the level-of-detail width (about a
 * pixel), so an eighth of that is below what the pixel resolves. */
#define LOD_FLATNESS 0.125

/* Sums over the surface points of a subtree (positions relative to the
 * root cube's corner, in doubles: a cell is down to 2^-20 of the root). */
typedef struct lod_sum {
    double w, p[3], pp[6], n[3]; /* pp: xx, yy, zz, xy, xz, yz */
    uint32_t rep;                /* representative leaf        */
    double c[3];                 /* centroid, p / w            */
} lod_sum;

static void sum_point(lod_sum *s, double w, const double p[3], const double n[3])
{
    s->w += w;
    for (int a = 0; a < 3; ++a) {
        s->p[a] += w * p[a];
        s->n[a] += w * n[a];
    }
    s->pp[0] += w * p[0] * p[0];
    s->pp[1] += w * p[1] * p[1];
    s->pp[2] += w * p[2] * p[2];
    s->pp[3] += w * p[0] * p[1];
    s->pp[4] += w * p[0] * p[2];
    s->pp[5] += w * p[1] * p[2];
}

static void sum_add(lod_sum *s, const lod_sum *t)
{
    s->w += t->w;
    for (int a = 0; a < 3; ++a) {
        s->p[a] += t->p[a];
        s->n[a] += t->n[a];
    }
    for (int k = 0; k < 6; ++k)
        s->pp[k] += t->pp[k];
}

static double dist2(const double a[3], const double b[3])
{
    double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return x * x + y * y + z * z;
}

/* One stored leaf's surface point (relative to iso->lo) and normal. */
static void leaf_point(const sg_iso *iso, uint32_t leaf, const double lo[3], double edge, double p[3],
                       double n[3])
{
    const iso_leaf *L = &iso->leaves[leaf];
    double f = 0.0, m[3] = {0, 0, 0};
    for (int k = 0; k < 8; ++k) {
        f += (double)iso->cf[L->corner[k]] * (double)iso->f_scale;
        sg_vec3 c = sg_iso_decode_normal(iso->cn[L->corner[k]]);
        m[0] += c.x, m[1] += c.y, m[2] += c.z;
    }
    f /= 8.0; /* the trilinear patch at the centre */
    double len = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
    for (int a = 0; a < 3; ++a) {
        n[a] = len > 0.0 ? m[a] / len : 0.0;
        p[a] = lo[a] + 0.5 * edge - f * n[a];
    }
}

/* Node q's plane from its subtree's sums: always the normal (the slab's
 * direction) and the plane through the centroid; the representative leaf
 * (the coarse patch usable) only where the plane stands for the surface. */
static void fit(sg_iso *iso, uint32_t q, const lod_sum *s, double edge)
{
    iso_lod *out = &iso->nodes[q].lod;
    double nl = sqrt(s->n[0] * s->n[0] + s->n[1] * s->n[1] + s->n[2] * s->n[2]);
    double n[3] = {0.0, 0.0, 1.0}; /* no surface below, or normals that cancel: any direction bounds */
    if (nl > 0.0)
        n[0] = s->n[0] / nl, n[1] = s->n[1] / nl, n[2] = s->n[2] / nl;
    *out = (iso_lod){{(int16_t)lrint(n[0] * 32767.0), (int16_t)lrint(n[1] * 32767.0), (int16_t)lrint(n[2] * 32767.0)},
                     0, 0.0f, INFINITY, -INFINITY, ISO_NO_LOD};
    sg_vec3 qn = iso_lod_normal(out); /* the stored normal decides the offset */
    const double *c = s->c;
    double d = (double)qn.x * ((double)iso->lo.x + c[0]) + (double)qn.y * ((double)iso->lo.y + c[1]) +
               (double)qn.z * ((double)iso->lo.z + c[2]);
    out->d = (float)d;
    if (!(s->w > 0.0) || !(nl >= LOD_NORMAL_AGREE * s->w))
        return;
    /* variance along n: n^T (E[p p^T] - c c^T) n */
    double C[6];
    C[0] = s->pp[0] / s->w - c[0] * c[0];
    C[1] = s->pp[1] / s->w - c[1] * c[1];
    C[2] = s->pp[2] / s->w - c[2] * c[2];
    C[3] = s->pp[3] / s->w - c[0] * c[1];
    C[4] = s->pp[4] / s->w - c[0] * c[2];
    C[5] = s->pp[5] / s->w - c[1] * c[2];
    double var = n[0] * n[0] * C[0] + n[1] * n[1] * C[1] + n[2] * n[2] * C[2] +
                 2.0 * (n[0] * n[1] * C[3] + n[0] * n[2] * C[4] + n[1] * n[2] * C[5]);
    if (var <= LOD_FLATNESS * LOD_FLATNESS * edge * edge)
        out->leaf = s->rep;
}

/* The extent along n of every stored leaf box below node q (cell at x, y,
 * z of `size` grid units), grown into [*lo, *hi]. */
static void slab_rec(const sg_iso *iso, uint32_t q, uint32_t x, uint32_t y, uint32_t z, uint32_t size,
                     const double n[3], double *lo, double *hi)
{
    const iso_node *N = &iso->nodes[q];
    uint32_t hs = size >> 1;
    unsigned inner = 0;
    const double o[3] = {iso->lo.x, iso->lo.y, iso->lo.z}, unit = (double)iso->unit;
    for (unsigned k = 0; k < 8; ++k) {
        if (!(N->child_mask >> k & 1u))
            continue;
        uint32_t c[3] = {x + (k & 1 ? hs : 0), y + (k & 2 ? hs : 0), z + (k & 4 ? hs : 0)};
        if (!(N->leaf_mask >> k & 1u)) {
            slab_rec(iso, N->inner_base + inner++, c[0], c[1], c[2], hs, n, lo, hi);
            continue;
        }
        double a = 0.0, b = 0.0;
        for (int ax = 0; ax < 3; ++ax) {
            double p0 = o[ax] + c[ax] * unit, p1 = o[ax] + (c[ax] + hs) * unit;
            a += n[ax] * (n[ax] > 0.0 ? p0 : p1);
            b += n[ax] * (n[ax] > 0.0 ? p1 : p0);
        }
        *lo = a < *lo ? a : *lo;
        *hi = b > *hi ? b : *hi;
    }
}

/* Every node's slab, top-down (each from its whole subtree). */
static void slabs(sg_iso *iso, uint32_t q, uint32_t x, uint32_t y, uint32_t z, uint32_t size)
{
    iso_lod *D = &iso->nodes[q].lod;
    sg_vec3 f = iso_lod_normal(D);
    double n[3] = {f.x, f.y, f.z}, lo = INFINITY, hi = -INFINITY;
    slab_rec(iso, q, x, y, z, size, n, &lo, &hi);
    /* rounded outward, and by the float rounding of a query's dot product
     * (iso.c slab_misses) */
    if (lo <= hi) {
        D->s_lo = nextafterf((float)lo, -INFINITY);
        D->s_hi = nextafterf((float)hi, INFINITY);
    }
    const iso_node *N = &iso->nodes[q];
    uint32_t hs = size >> 1;
    unsigned inner = 0;
    for (unsigned k = 0; k < 8; ++k)
        if ((N->child_mask >> k & 1u) && !(N->leaf_mask >> k & 1u))
            slabs(iso, N->inner_base + inner++, x + (k & 1 ? hs : 0), y + (k & 2 ? hs : 0), z + (k & 4 ? hs : 0),
                  hs);
}

/* Post-order walk: the sums of node q (cell at x, y, z of `size` grid
 * units), its plane decided on the way back. */
static lod_sum walk(sg_iso *iso, uint32_t q, uint32_t x, uint32_t y, uint32_t z, uint32_t size)
{
    const iso_node *N = &iso->nodes[q];
    lod_sum s = {0};
    s.rep = ISO_NO_LOD;
    lod_sum kids[8];
    int nk = 0;
    uint32_t hs = size >> 1;
    double unit = (double)iso->unit;
    unsigned inner = 0, leaf = 0;
    for (unsigned k = 0; k < 8; ++k) {
        if (!(N->child_mask >> k & 1u))
            continue;
        uint32_t cx = x + (k & 1 ? hs : 0), cy = y + (k & 2 ? hs : 0), cz = z + (k & 4 ? hs : 0);
        lod_sum *ks = &kids[nk++];
        if (N->leaf_mask >> k & 1u) {
            uint32_t l = N->leaf_base + leaf++;
            double lo[3] = {cx * unit, cy * unit, cz * unit}, p[3], n[3], edge = hs * unit;
            leaf_point(iso, l, lo, edge, p, n);
            *ks = (lod_sum){0};
            sum_point(ks, edge * edge, p, n);
            ks->rep = l;
        } else {
            *ks = walk(iso, N->inner_base + inner++, cx, cy, cz, hs);
        }
        for (int a = 0; a < 3; ++a)
            ks->c[a] = ks->w > 0.0 ? ks->p[a] / ks->w : 0.0;
        sum_add(&s, ks);
    }
    for (int a = 0; a < 3; ++a)
        s.c[a] = s.w > 0.0 ? s.p[a] / s.w : 0.0;
    double best = INFINITY;
    for (int i = 0; i < nk; ++i) {
        double d2 = dist2(kids[i].c, s.c);
        if (kids[i].rep != ISO_NO_LOD && d2 < best) {
            best = d2;
            s.rep = kids[i].rep;
        }
    }
    fit(iso, q, &s, size * unit);
    return s;
}

void iso_lod_build(sg_iso *iso)
{
    assert(iso);
    if (iso->node_count) {
        walk(iso, 0, 0, 0, 0, 1u << iso->max_depth);
        slabs(iso, 0, 0, 0, 0, 1u << iso->max_depth);
    }
}
