/* sphere_tree.c — build of the bounding-sphere hierarchy of Ye 2005 (PPRT,
 * §3.1) over triangles. See sphere_tree.h for the layout and invariants.
 *
 * Build. Top-down, like QSplat and Ye (§3.1.2), but with the split chosen
 * by cost rather than at the midpoint: a node of more than leaf_max
 * triangles is cut in two, then its largest part in two again, until it
 * has SG_STREE_WIDTH parts or none is larger than leaf_max (the wide node
 * of a binary tree collapsed on the fly: open the part with the largest
 * bound first). Each cut minimises n_L |box_L|^2 + n_R |box_R|^2 over 16
 * centroid bins per axis (every position when the part has <= 32
 * triangles): a ray meets a sphere with probability proportional to its
 * cross-section pi R^2, and the tight sphere of a box has R = |box| / 2 at
 * most, so this is the surface-area heuristic with spheres in place of
 * boxes. Below depth SG_STREE_MAX_DEPTH - 32 parts are cut at the median
 * of their largest centroid extent instead, which halves them, so no path
 * grows past SG_STREE_MAX_DEPTH bundles (invariant 3: 2^28 triangles need
 * at most 28 halvings).
 *
 * Spheres (§3.1.3). Ye computes a parent's sphere from its children's
 * spheres, which grow looser at every level. Here every node's sphere is
 * computed from its own triangles: the centre is the middle of their
 * vertices' box and the radius the largest distance to one of those
 * vertices, in double, rounded up to float and padded (invariant 1). The
 * node's point attributes come from the same passes: the area-weighted
 * mean of the triangles' geometric normals (quantised to int8; the cone,
 * the slab and the offset are measured against the quantised normal, so
 * invariants 1 and 2 hold for what is stored), the slab of the vertices
 * along it (a flat patch's sphere is mostly empty above and below the
 * patch; the slab cuts that off for a traversal), and the area-weighted
 * centroid as an offset along it, which puts a level-of-detail disk on
 * the surface rather than at the sphere's centre. Cost: two passes over a
 * node's triangles per level, O(n log n) in all.
 *
 * Parallelism and determinism (invariant 4). Parts of at least 8192
 * triangles are built as OpenMP tasks; each part only reorders its own
 * slice of the order array, and every choice is a function of that slice
 * (ties go to the lower axis, bin or position), so the same tree comes out
 * whatever the thread count. Build nodes come from per-thread arenas; the
 * finished tree is flattened depth-first by one thread.
 */
#include "accel/sphere_tree.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/alloc.h"
#include "core/arena.h"

enum {
    W = SG_STREE_WIDTH,
    BIN_COUNT = 16,         /* centroid bins per axis                         */
    EXACT_MAX = 32,         /* at or below, try every centroid position       */
    TASK_MIN = 8192,        /* parts this large are built as OpenMP tasks     */
    MEDIAN_DEPTH = SG_STREE_MAX_DEPTH - 32, /* from here on, median cuts (invariant 3) */
    TIGHT_MAX = 32,         /* nodes this small get the iterated centre        */
    TIGHT_ITERATIONS = 16,
    DEFAULT_LEAF_MAX = 8
};

_Static_assert(W == 2 || W == 4 || W == 8, "SG_STREE_WIDTH must be 2, 4 or 8");
_Static_assert(sizeof(sg_stree_bundle) % 64 == 0, "bundles fill whole cache lines");

/* A node of the temporary build tree. */
typedef struct bnode {
    struct bnode *child[W];
    uint32_t begin, end;   /* its triangles: order[begin, end)             */
    float c[3], r;         /* sphere                                       */
    int8_t q[3];           /* mean normal * 127                            */
    int8_t slo, shi, offset;
    uint8_t sin_cone;
    float col[3];          /* mean colour (when the mesh has colours)      */
    uint8_t nchild;        /* 0: leaf                                      */
} bnode;

typedef struct build_ctx {
    const sg_stree_desc *d;
    float *cen;            /* 3 per triangle: centroid (input order)       */
    uint32_t *order;       /* the leaf order being built                   */
    int leaf_max;
    sg_arena_set *arena;
    int failed;            /* set (never cleared) when an allocation fails */
} build_ctx;

static void set_failed(build_ctx *c)
{
#pragma omp atomic write
    c->failed = 1;
}

static const float *vtx(const build_ctx *c, uint32_t t, int k)
{
    return c->d->positions + 3 * (size_t)c->d->triangles[3 * (size_t)t + (size_t)k];
}

typedef struct box {
    float lo[3], hi[3];
} box;

static box box_empty(void)
{
    box b = {{FLT_MAX, FLT_MAX, FLT_MAX}, {-FLT_MAX, -FLT_MAX, -FLT_MAX}};
    return b;
}

static void box_grow(box *b, const float *p)
{
    for (int a = 0; a < 3; ++a) {
        b->lo[a] = p[a] < b->lo[a] ? p[a] : b->lo[a];
        b->hi[a] = p[a] > b->hi[a] ? p[a] : b->hi[a];
    }
}

static void box_union(box *b, const box *o)
{
    for (int a = 0; a < 3; ++a) {
        b->lo[a] = o->lo[a] < b->lo[a] ? o->lo[a] : b->lo[a];
        b->hi[a] = o->hi[a] > b->hi[a] ? o->hi[a] : b->hi[a];
    }
}

/* |diagonal|^2: four times the squared radius of the box's sphere. */
static float box_metric(const box *b)
{
    if (b->hi[0] < b->lo[0])
        return 0.0f;
    float dx = b->hi[0] - b->lo[0], dy = b->hi[1] - b->lo[1], dz = b->hi[2] - b->lo[2];
    return dx * dx + dy * dy + dz * dz;
}

static box tri_box(const build_ctx *c, uint32_t t)
{
    box b = box_empty();
    box_grow(&b, vtx(c, t, 0));
    box_grow(&b, vtx(c, t, 1));
    box_grow(&b, vtx(c, t, 2));
    return b;
}

/* (v1 - v0) x (v2 - v0) in double: twice the area times the unit normal. */
static void tri_cross(const build_ctx *c, uint32_t t, double n[3])
{
    const float *a = vtx(c, t, 0), *b = vtx(c, t, 1), *d = vtx(c, t, 2);
    double e1[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
    double e2[3] = {(double)d[0] - a[0], (double)d[1] - a[1], (double)d[2] - a[2]};
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

/* Badoiu & Clarkson 2003: moving the centre a step 1/(i+2) towards the
 * farthest vertex converges to the smallest enclosing sphere; the best
 * centre seen is kept (starting from the box's, so never worse). Used for
 * small nodes only, where it pays: on the dragon it cut the triangle
 * tests per ray by 9% (docs/hybrid.md); at the top of the tree it would
 * cost a pass per iteration over millions of triangles. */
static void tighten_centre(const build_ctx *c, uint32_t begin, uint32_t end, double centre[3], float out[3])
{
    double cc[3] = {centre[0], centre[1], centre[2]}, best_r2 = INFINITY, bc[3] = {centre[0], centre[1], centre[2]};
    for (int it = 0; it < TIGHT_ITERATIONS; ++it) {
        double far2 = -1.0;
        const float *fv = NULL;
        for (uint32_t i = begin; i < end; ++i)
            for (int k = 0; k < 3; ++k) {
                const float *v = vtx(c, c->order[i], k);
                double dx = v[0] - cc[0], dy = v[1] - cc[1], dz = v[2] - cc[2], d2 = dx * dx + dy * dy + dz * dz;
                if (d2 > far2) {
                    far2 = d2;
                    fv = v;
                }
            }
        if (far2 < best_r2) {
            best_r2 = far2;
            memcpy(bc, cc, sizeof bc);
        }
        for (int a = 0; a < 3; ++a)
            cc[a] += (fv[a] - cc[a]) / (double)(it + 2);
    }
    for (int a = 0; a < 3; ++a) {
        out[a] = (float)bc[a];
        centre[a] = out[a]; /* the radius is measured from the stored float */
    }
}

/* Sphere and point attributes of the node holding order[begin, end). */
static void node_stats(const build_ctx *c, bnode *nd, uint32_t begin, uint32_t end)
{
    const float *col = c->d->colors;
    box b = box_empty();
    double ns[3] = {0, 0, 0}, cs[3] = {0, 0, 0}, cl[3] = {0, 0, 0}, area = 0.0;
    for (uint32_t i = begin; i < end; ++i) {
        uint32_t t = c->order[i];
        double n[3];
        tri_cross(c, t, n);
        double a = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int k = 0; k < 3; ++k) {
            const float *v = vtx(c, t, k);
            box_grow(&b, v);
            for (int ax = 0; ax < 3; ++ax)
                cs[ax] += a * v[ax] / 3.0;
            if (col) {
                const float *q = col + 3 * (size_t)c->d->triangles[3 * (size_t)t + (size_t)k];
                for (int ax = 0; ax < 3; ++ax)
                    cl[ax] += a * q[ax] / 3.0;
            }
        }
        for (int ax = 0; ax < 3; ++ax)
            ns[ax] += n[ax];
        area += a;
    }
    double centre[3];
    for (int ax = 0; ax < 3; ++ax) {
        nd->c[ax] = 0.5f * (b.lo[ax] + b.hi[ax]);
        centre[ax] = nd->c[ax];
    }
    double nl = sqrt(ns[0] * ns[0] + ns[1] * ns[1] + ns[2] * ns[2]);
    double mean[3] = {0.0, 0.0, 1.0};
    if (nl > 0.0)
        for (int ax = 0; ax < 3; ++ax)
            mean[ax] = ns[ax] / nl;
    /* The stored normal u = q / 127; every test below is against it, so the
     * invariants hold for what is stored. A unit vector has a component of
     * at least 1/sqrt(3), so q is never zero. */
    double u[3], ul = 0.0;
    for (int ax = 0; ax < 3; ++ax) {
        nd->q[ax] = (int8_t)lrint(mean[ax] * SG_STREE_NORMAL_SCALE);
        u[ax] = (double)((float)nd->q[ax] * (1.0f / SG_STREE_NORMAL_SCALE));
        ul += u[ax] * u[ax];
    }
    ul = sqrt(ul);

    if (end - begin <= TIGHT_MAX)
        tighten_centre(c, begin, end, centre, nd->c);
    double r2 = 0.0, cos_min = 1.0, smin = INFINITY, smax = -INFINITY;
    for (uint32_t i = begin; i < end; ++i) {
        uint32_t t = c->order[i];
        for (int k = 0; k < 3; ++k) {
            const float *v = vtx(c, t, k);
            double dx = v[0] - centre[0], dy = v[1] - centre[1], dz = v[2] - centre[2];
            double d2 = dx * dx + dy * dy + dz * dz;
            r2 = d2 > r2 ? d2 : r2;
            double s = dx * u[0] + dy * u[1] + dz * u[2];
            smin = s < smin ? s : smin;
            smax = s > smax ? s : smax;
        }
        double n[3];
        tri_cross(c, t, n);
        double a = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double cs_t = a > 0.0 ? (n[0] * u[0] + n[1] * u[1] + n[2] * u[2]) / (a * ul) : -1.0;
        cos_min = cs_t < cos_min ? cs_t : cos_min;
    }
    /* Invariant 1: the double radius rounded up to float, then padded. */
    float r = (float)sqrt(r2);
    if ((double)r < sqrt(r2))
        r = nextafterf(r, INFINITY);
    nd->r = r * (1.0f + SG_STREE_RADIUS_PAD) + FLT_MIN;
    /* ...and the slab, rounded outwards in steps of r / 120 (|s| <= r |u|
     * < 1.01 r, so the steps stay within int8). */
    double step = (double)nd->r / SG_STREE_SLAB_SCALE;
    double lo = floor(smin / step), hi = ceil(smax / step);
    nd->slo = (int8_t)(lo < -127.0 ? -127.0 : lo);
    nd->shi = (int8_t)(hi > 127.0 ? 127.0 : hi);

    /* Invariant 2: the half-angle, widened by 1e-6 rad for the rounding of
     * the cosine, as a sine rounded up to 1/255. */
    nd->sin_cone = 255;
    if (cos_min > 0.0) {
        double theta = acos(cos_min > 1.0 ? 1.0 : cos_min) + 1e-6;
        if (theta < 0.5 * 3.14159265358979323846) {
            double sq = ceil(255.0 * sin(theta));
            nd->sin_cone = (uint8_t)(sq < 255.0 ? sq : 255.0);
        }
    }
    double off = 0.0;
    if (area > 0.0)
        for (int ax = 0; ax < 3; ++ax)
            off += (cs[ax] / area - centre[ax]) * u[ax] / ul;
    off = off / (double)nd->r * 127.0;
    off = off > 127.0 ? 127.0 : (off < -127.0 ? -127.0 : off);
    nd->offset = (int8_t)lrint(off);
    for (int ax = 0; ax < 3; ++ax)
        nd->col[ax] = col && area > 0.0 ? (float)(cl[ax] / area) : 0.0f;
}

/* Deterministic quickselect: order[begin, end) rearranged so that the
 * element at `mid` has the centroid coordinate it would have sorted, with
 * nothing larger before it and nothing smaller after it. */
static void select_median(build_ctx *c, uint32_t begin, uint32_t end, uint32_t mid, int axis)
{
    uint32_t *o = c->order;
    const float *cen = c->cen;
#define KEY(i) cen[3 * (size_t)o[i] + (size_t)axis]
    int64_t lo = begin, hi = (int64_t)end - 1;
    while (lo < hi) {
        /* Median of three by position: a deterministic pivot that is one
         * of the slice's values, so both scans below stop inside it. */
        int64_t m = lo + (hi - lo) / 2;
        float a = KEY(lo), b = KEY(m), d = KEY(hi);
        float pivot = a < b ? (b < d ? b : (a < d ? d : a)) : (a < d ? a : (b < d ? d : b));
        int64_t i = lo, j = hi;
        while (i <= j) {
            while (KEY(i) < pivot)
                ++i;
            while (KEY(j) > pivot)
                --j;
            if (i <= j) {
                uint32_t s = o[i];
                o[i] = o[j];
                o[j] = s;
                ++i;
                --j;
            }
        }
        /* [lo, j] <= pivot <= [i, hi]; between them every key is the pivot. */
        if ((int64_t)mid <= j)
            hi = j;
        else if ((int64_t)mid >= i)
            lo = i;
        else
            break;
    }
#undef KEY
}

/* Cuts order[begin, end) (>= 2 triangles) in two non-empty parts and
 * returns the first index of the second. */
static uint32_t split_range(build_ctx *c, uint32_t begin, uint32_t end, int median)
{
    const uint32_t n = end - begin;
    const float *cen = c->cen;
    uint32_t *o = c->order;
    box cb = box_empty();
    for (uint32_t i = begin; i < end; ++i)
        box_grow(&cb, cen + 3 * (size_t)o[i]);
    float ext[3] = {cb.hi[0] - cb.lo[0], cb.hi[1] - cb.lo[1], cb.hi[2] - cb.lo[2]};
    int wide = ext[0] >= ext[1] ? (ext[0] >= ext[2] ? 0 : 2) : (ext[1] >= ext[2] ? 1 : 2);
    if (!(ext[wide] > 0.0f))
        return begin + n / 2; /* every centroid in one place: any cut is as good */
    if (median) {
        uint32_t mid = begin + n / 2;
        select_median(c, begin, end, mid, wide);
        return mid;
    }

    if (n <= EXACT_MAX) {
        /* Every position on every axis, from the centroids sorted by
         * insertion (ties keep their slice order: deterministic). */
        uint32_t sorted[3][EXACT_MAX];
        float best = FLT_MAX;
        int best_axis = -1;
        uint32_t best_k = 0;
        for (int a = 0; a < 3; ++a) {
            uint32_t *s = sorted[a];
            for (uint32_t i = 0; i < n; ++i) {
                uint32_t t = o[begin + i];
                float key = cen[3 * (size_t)t + (size_t)a];
                uint32_t j = i;
                while (j > 0 && cen[3 * (size_t)s[j - 1] + (size_t)a] > key) {
                    s[j] = s[j - 1];
                    --j;
                }
                s[j] = t;
            }
            float right[EXACT_MAX];
            box rb = box_empty();
            for (uint32_t k = n; k-- > 1;) {
                box tb = tri_box(c, s[k]);
                box_union(&rb, &tb);
                right[k] = box_metric(&rb);
            }
            box lb = box_empty();
            for (uint32_t k = 1; k < n; ++k) {
                box tb = tri_box(c, s[k - 1]);
                box_union(&lb, &tb);
                float cost = (float)k * box_metric(&lb) + (float)(n - k) * right[k];
                if (cost < best) {
                    best = cost;
                    best_axis = a;
                    best_k = k;
                }
            }
        }
        assert(best_axis >= 0);
        memcpy(o + begin, sorted[best_axis], n * sizeof *o);
        return begin + best_k;
    }

    /* Binned: one pass fills the bins of all three axes. */
    uint32_t count[3][BIN_COUNT];
    box bins[3][BIN_COUNT];
    float scale[3];
    for (int a = 0; a < 3; ++a) {
        scale[a] = ext[a] > 0.0f ? (float)BIN_COUNT * (1.0f - 1e-6f) / ext[a] : 0.0f;
        for (int k = 0; k < BIN_COUNT; ++k) {
            count[a][k] = 0;
            bins[a][k] = box_empty();
        }
    }
    for (uint32_t i = begin; i < end; ++i) {
        uint32_t t = o[i];
        box tb = tri_box(c, t);
        for (int a = 0; a < 3; ++a) {
            int k = (int)((cen[3 * (size_t)t + (size_t)a] - cb.lo[a]) * scale[a]);
            k = k < 0 ? 0 : (k >= BIN_COUNT ? BIN_COUNT - 1 : k);
            count[a][k]++;
            box_union(&bins[a][k], &tb);
        }
    }
    float best = FLT_MAX;
    int best_axis = -1, best_bin = 0;
    for (int a = 0; a < 3; ++a) {
        if (!(ext[a] > 0.0f))
            continue;
        float right[BIN_COUNT];
        uint32_t rn[BIN_COUNT];
        box rb = box_empty();
        uint32_t acc = 0;
        for (int k = BIN_COUNT; k-- > 1;) {
            box_union(&rb, &bins[a][k]);
            acc += count[a][k];
            right[k] = box_metric(&rb);
            rn[k] = acc;
        }
        box lb = box_empty();
        uint32_t ln = 0;
        for (int k = 1; k < BIN_COUNT; ++k) {
            box_union(&lb, &bins[a][k - 1]);
            ln += count[a][k - 1];
            if (ln == 0 || rn[k] == 0)
                continue;
            float cost = (float)ln * box_metric(&lb) + (float)rn[k] * right[k];
            if (cost < best) {
                best = cost;
                best_axis = a;
                best_bin = k;
            }
        }
    }
    if (best_axis < 0) { /* all in one bin on every axis: halve at the median */
        uint32_t mid = begin + n / 2;
        select_median(c, begin, end, mid, wide);
        return mid;
    }
    /* Partition: bins below best_bin first. */
    const int a = best_axis;
    uint32_t i = begin, j = end;
    while (i < j) {
        uint32_t t = o[i];
        int k = (int)((cen[3 * (size_t)t + (size_t)a] - cb.lo[a]) * scale[a]);
        k = k < 0 ? 0 : (k >= BIN_COUNT ? BIN_COUNT - 1 : k);
        if (k < best_bin) {
            ++i;
        } else {
            --j;
            o[i] = o[j];
            o[j] = t;
        }
    }
    assert(i > begin && i < end);
    return i;
}

typedef struct part {
    uint32_t begin, end;
    float metric;
} part;

static float part_metric(const build_ctx *c, uint32_t begin, uint32_t end)
{
    box b = box_empty();
    for (uint32_t i = begin; i < end; ++i) {
        box tb = tri_box(c, c->order[i]);
        box_union(&b, &tb);
    }
    return box_metric(&b);
}

static bnode *node_alloc(build_ctx *c)
{
    bnode *b = sg_arena_alloc(c->arena, sizeof *b);
    if (!b) {
        set_failed(c);
        return NULL;
    }
    memset(b, 0, sizeof *b);
    return b;
}

static void build_node(build_ctx *c, bnode *nd, uint32_t begin, uint32_t end, int depth)
{
    nd->begin = begin;
    nd->end = end;
    node_stats(c, nd, begin, end);
    int failed;
#pragma omp atomic read
    failed = c->failed;
    if (end - begin <= (uint32_t)c->leaf_max || failed)
        return;

    const int median = depth >= MEDIAN_DEPTH;
    part parts[W];
    int np = 1;
    parts[0] = (part){begin, end, FLT_MAX};
    while (np < W) {
        /* Open the largest part (by bound, or by count for median cuts). */
        /* Only parts too big for a leaf are cut. Cutting leaves smaller to
         * fill free lanes (they cost no memory) was measured: fewer
         * triangle tests, but more leaf visits, and slower. */
        int pick = -1;
        for (int i = 0; i < np; ++i) {
            if (parts[i].end - parts[i].begin <= (uint32_t)c->leaf_max)
                continue;
            float key = median ? (float)(parts[i].end - parts[i].begin) : parts[i].metric;
            if (pick < 0 || key > (median ? (float)(parts[pick].end - parts[pick].begin) : parts[pick].metric))
                pick = i;
        }
        if (pick < 0)
            break;
        part p = parts[pick];
        uint32_t mid = split_range(c, p.begin, p.end, median);
        assert(mid > p.begin && mid < p.end);
        memmove(parts + pick + 2, parts + pick + 1, (size_t)(np - pick - 1) * sizeof *parts);
        parts[pick] = (part){p.begin, mid, part_metric(c, p.begin, mid)};
        parts[pick + 1] = (part){mid, p.end, part_metric(c, mid, p.end)};
        ++np;
    }
    for (int i = 0; i < np; ++i)
        if (!(nd->child[i] = node_alloc(c)))
            return;
    nd->nchild = (uint8_t)np;
    for (int i = 0; i < np; ++i) {
        bnode *ch = nd->child[i];
        uint32_t b = parts[i].begin, e = parts[i].end;
        if (e - b >= TASK_MIN) {
#pragma omp task default(shared) firstprivate(ch, b, e, depth)
            build_node(c, ch, b, e, depth + 1);
        } else {
            build_node(c, ch, b, e, depth + 1);
        }
    }
#pragma omp taskwait
}

static void count_tree(const bnode *nd, int depth, size_t *inner, size_t *nodes, size_t *leaves, int *max_depth)
{
    ++*nodes;
    if (depth > *max_depth)
        *max_depth = depth;
    if (nd->nchild == 0) {
        ++*leaves;
        return;
    }
    ++*inner;
    for (int i = 0; i < nd->nchild; ++i)
        count_tree(nd->child[i], depth + 1, inner, nodes, leaves, max_depth);
}

typedef struct flat_ctx {
    sg_stree *t;
    size_t next_bundle;
} flat_ctx;

static void bundle_clear(sg_stree_bundle *b)
{
    memset(b, 0, sizeof *b);
    for (int l = 0; l < W; ++l) {
        b->r[l] = NAN;
        b->child[l] = SG_STREE_EMPTY;
    }
}

static void flatten(flat_ctx *f, const bnode *nd, size_t b, int lane)
{
    sg_stree_bundle *B = &f->t->bundles[b];
    B->cx[lane] = nd->c[0];
    B->cy[lane] = nd->c[1];
    B->cz[lane] = nd->c[2];
    B->r[lane] = nd->r;
    B->nx[lane] = nd->q[0];
    B->ny[lane] = nd->q[1];
    B->nz[lane] = nd->q[2];
    B->slo[lane] = nd->slo;
    B->shi[lane] = nd->shi;
    B->offset[lane] = nd->offset;
    B->sin_cone[lane] = nd->sin_cone;
    if (f->t->colors) {
        float *col = f->t->colors + 3 * (b * W + (size_t)lane);
        col[0] = nd->col[0];
        col[1] = nd->col[1];
        col[2] = nd->col[2];
    }
    if (nd->nchild == 0) {
        uint32_t count = nd->end - nd->begin;
        assert(count >= 1 && count <= SG_STREE_MAX_LEAF);
        B->child[lane] = SG_STREE_LEAF | ((count - 1u) << SG_STREE_COUNT_SHIFT) | nd->begin;
        return;
    }
    size_t cb = f->next_bundle++;
    B->child[lane] = (uint32_t)cb;
    bundle_clear(&f->t->bundles[cb]);
    for (int i = 0; i < nd->nchild; ++i)
        flatten(f, nd->child[i], cb, i);
}

sg_status sg_stree_build(const sg_stree_desc *d, sg_stree *out, sg_error *err)
{
    if (!d || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sphere tree: NULL desc or out");
    if (d->triangle_count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sphere tree: no triangles");
    if (d->triangle_count > SG_STREE_MAX_TRIANGLES)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "sphere tree: %zu triangles exceed the limit of %u",
                            d->triangle_count, SG_STREE_MAX_TRIANGLES);
    if (!d->positions || !d->triangles)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sphere tree: NULL positions or triangles");
    int leaf_max = d->leaf_max ? d->leaf_max : DEFAULT_LEAF_MAX;
    if (leaf_max < 1 || leaf_max > SG_STREE_MAX_LEAF)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sphere tree: leaf_max %d is outside 1..%d", d->leaf_max,
                            SG_STREE_MAX_LEAF);

    const size_t n = d->triangle_count;
    const int threads = d->threads > 0 ? d->threads : omp_get_max_threads();
    sg_status st = SG_OK;
    sg_stree t = {0};
    build_ctx c = {.d = d, .leaf_max = leaf_max};
    c.cen = sg_alloc_array(n, 3 * sizeof(float));
    c.order = sg_alloc_array(n, sizeof(uint32_t));
    c.arena = sg_arena_set_create(threads);
    if (!c.cen || !c.order || !c.arena) {
        st = sg_error_set(err, SG_ERR_NOMEM, "sphere tree: out of memory for %zu triangles", n);
        goto cleanup;
    }
#pragma omp parallel for schedule(static) num_threads(threads)
    for (size_t i = 0; i < n; ++i) {
        c.order[i] = (uint32_t)i;
        for (int a = 0; a < 3; ++a)
            c.cen[3 * i + (size_t)a] = (vtx(&c, (uint32_t)i, 0)[a] + vtx(&c, (uint32_t)i, 1)[a] +
                                        vtx(&c, (uint32_t)i, 2)[a]) / 3.0f;
    }

    bnode *root = NULL;
#pragma omp parallel num_threads(threads)
#pragma omp single
    {
        root = node_alloc(&c);
        if (root)
            build_node(&c, root, 0, (uint32_t)n, 1);
    }
    if (c.failed) {
        st = sg_error_set(err, SG_ERR_NOMEM, "sphere tree: out of memory during the build (%zu triangles)", n);
        goto cleanup;
    }

    size_t inner = 0, nodes = 0, leaves = 0;
    int depth = 0;
    count_tree(root, 1, &inner, &nodes, &leaves, &depth);
    assert(depth <= SG_STREE_MAX_DEPTH);
    t.bundle_count = inner + 1;
    t.bundles = sg_alloc_array(t.bundle_count, sizeof *t.bundles);
    if (d->colors)
        t.colors = sg_alloc_array(t.bundle_count * W, 3 * sizeof(float));
    if (!t.bundles || (d->colors && !t.colors)) {
        sg_stree_free(&t);
        st = sg_error_set(err, SG_ERR_NOMEM, "sphere tree: out of memory for %zu node bundles", inner + 1);
        goto cleanup;
    }
    if (t.colors)
        memset(t.colors, 0, t.bundle_count * W * 3 * sizeof(float));
    bundle_clear(&t.bundles[0]);
    flat_ctx f = {.t = &t, .next_bundle = 1};
    flatten(&f, root, 0, 0);
    assert(f.next_bundle == t.bundle_count);
    t.order = c.order;
    c.order = NULL;
    t.triangle_count = n;
    t.node_count = nodes;
    t.leaf_count = leaves;
    t.depth = depth;
    *out = t;

cleanup:
    sg_free(c.cen);
    sg_free(c.order);
    sg_arena_set_destroy(c.arena);
    return st;
}

void sg_stree_free(sg_stree *t)
{
    if (!t)
        return;
    sg_free(t->bundles);
    sg_free(t->colors);
    sg_free(t->order);
    memset(t, 0, sizeof *t);
}

size_t sg_stree_memory(const sg_stree *t)
{
    return t->bundle_count * sizeof *t->bundles + (t->colors ? t->bundle_count * W * 3 * sizeof(float) : 0) +
           t->triangle_count * sizeof *t->order;
}
