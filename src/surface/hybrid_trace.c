/* hybrid_trace.c — nearest-first traversal of the hybrid hierarchy with
 * level of detail (Ye 2005, PPRT §3.2-3.4, §4.4). See hybrid.h.
 *
 * Nearest first. Ye keeps the spheres a ray has entered in a heap ordered
 * by entry distance and stops at the first hit (§3.2-3.3). That first hit
 * is not always the nearest (a triangle in a sphere entered early may lie
 * behind one in a sphere entered later), so here a traversal stops only
 * when the next sphere starts beyond the best hit so far. Two orders are
 * implemented: Ye's binary heap (SG_HYBRID_TRAVERSE_HEAP) and an ordered
 * stack (children pushed farthest first, so the nearest is popped next;
 * SG_HYBRID_TRAVERSE_STACK). Both give the same hit, bit for bit: the
 * accepted crossings do not depend on the order (a node is hit as a point
 * or opened by a rule of the node and the ray alone), pruning only drops
 * spheres that begin beyond the best hit, and ties at equal t go to the
 * lower key (triangles by leaf order, then nodes), so the minimum is
 * unique (invariant 2).
 *
 * Order. Pruning needs every accepted crossing of a subtree to lie at or
 * beyond the entry of each bound on the way down to it. A triangle does
 * (it lies in all of them; the entries are rounded down). A disk is
 * clipped by its own sphere only, and a node's sphere is not inside its
 * parent's, nor its disk exactly inside its quantised slab: a disk can
 * start a rounding (or more) before an ancestor's entry, and was then
 * found in one order and pruned in the other (stack and heap frames
 * differed in a pixel at lod 2, test_hybrid lod_orders_agree). So an
 * entry carries its floor, the latest entry of the bounds from the root
 * down to it (max of the parent's floor and its own entry: still a lower
 * bound of every crossing in it), and a disk met before its node's floor
 * is taken at the floor (a shift along the ray below the node's diameter,
 * which is below the footprint). And whether a node is a point or opened
 * depends on the node and the ray only, never on the best hit so far: a
 * disk the ray meets makes the node a point, and if the disk is not
 * nearer than the best, the node is done (before, it was opened, so its
 * triangles could win in one order and not in another).
 *
 * Level of detail (§3.4). Ye compares the projected diameter d/z 2R with a
 * threshold; with a footprint of width w(t) = width + spread t per pixel
 * that is 2R < lod w(b), b the distance to the centre along the ray. Ye
 * then returns the node's centre as the hit. Here the node is hit as a
 * disk through its area-weighted centroid with its mean normal, clipped by
 * its sphere, and only when two further conditions hold; otherwise the
 * node is opened as if it were large:
 *   - its triangles all face the same way along the ray (|d.n| > sin of
 *     the normal cone's half-angle): no silhouette crosses the node, so
 *     a disk neither widens nor trims the outline;
 *   - the ray meets the disk: a ray through the sphere beside the disk
 *     goes on to whatever is really there, so disks never leave holes.
 * A node whose triangles all face away from what the ray accepts (a
 * FRONT_ONLY ray and an all-back-facing node) is skipped whole.
 *
 * Sphere tests: accel/sphere_bundle.h (a rounding margin keeps them
 * conservative, and entry distances are lowered by it, so pruning never
 * drops a sphere that holds the best crossing).
 *
 * Invariants:
 *  1. queries read the hierarchy only (thread-safe);
 *  2. the result is the minimum of (t, key) over the accepted crossings
 *     of the nodes the ray reaches, whatever the order;
 *  3. the stack never holds more than (W - 1) * SG_STREE_MAX_DEPTH + 1
 *     entries (sphere_tree.h invariant 3); the heap holds at most
 *     HEAP_CAP and a ray that would need more is traced again with the
 *     stack (counted in heap_overflows; same hit by invariant 2);
 *  4. each ray of a packet (sg_hybrid_intersect16 and its first four
 *     lanes sg_hybrid_intersect4, "Packets" below) gets its single-ray hit
 *     bit for bit (by invariant 2; test_hybrid intersect4_matches_single,
 *     intersect16_matches_single).
 */
#include <float.h>
#include <math.h>
#include <string.h>

#include "accel/sphere_bundle.h"
#include "math/oct.h"
#include "math/triangle.h"
#include "surface/hybrid_int.h"

enum {
    W = SG_STREE_WIDTH,
    STACK_CAP = (W - 1) * SG_STREE_MAX_DEPTH + 2,
    HEAP_CAP = 1024
};

#define LOD_BIT 0x80000000u
/* Facing tests against a normal cone leave this much room (|d.n| units)
 * for the rounding of the stored sine and of the triangle test's
 * determinant sign. */
#define CONE_MARGIN 1e-4f

typedef struct entry {
    float t;      /* floor: latest entry of the bounds from the root to the
                     node (each lowered by its margin m); "Order" above */
    uint32_t id;  /* node id | LOD_BIT when it may be hit as a point    */
} entry;

typedef struct tray {
    float tmin;
    sg_bundle_ray br;  /* the ray for sphere tests (origin o, direction d),
                          with the LOD test                               */
    sg_tri_ray tr;
    int accept_front, accept_back;
    int cull;          /* skip nodes that face the wrong way             */
    const sg_ray *ray;
} tray;

typedef struct best {
    float t;
    uint64_t key;      /* triangle: leaf-order index; node: 2^32 + id   */
    float b1, b2;
    int front;
} best;

typedef struct counters {
    uint64_t pops, spheres, triangles, lod_tests, culled;
} counters;

static int setup(const sg_hybrid *h, const sg_ray *ray, const sg_footprint *fp, tray *r)
{
    if (!sg_v3_isfinite(ray->org) || !sg_v3_isfinite(ray->dir) || !(ray->tmax >= ray->tmin) || isnan(ray->tmin))
        return 0;
    if (ray->dir.x == 0.0f && ray->dir.y == 0.0f && ray->dir.z == 0.0f)
        return 0;
    r->tmin = ray->tmin;
    r->tr = sg_tri_ray_prepare(ray->org, ray->dir);
    /* From the ray, not copied from fields just stored: an 8-byte load of
     * two 4-byte stores stalled on store forwarding (a third of setup's
     * samples when the tray kept its own copy of o and d). */
    sg_bundle_ray *br = &r->br;
    br->o[0] = ray->org.x;
    br->o[1] = ray->org.y;
    br->o[2] = ray->org.z;
    br->d[0] = ray->dir.x;
    br->d[1] = ray->dir.y;
    br->d[2] = ray->dir.z;
    br->tmin = ray->tmin;
    br->lod0 = br->lod1 = 0.0f;
    if (fp && fp->lod > 0.0f && isfinite(fp->lod) && fp->width >= 0.0f && isfinite(fp->width) &&
        fp->spread >= 0.0f && isfinite(fp->spread)) {
        br->lod0 = fp->lod * fp->width;
        br->lod1 = fp->lod * fp->spread;
    }
    uint32_t flags = ray->flags;
    if ((h->desc.flags & SG_HYBRID_CULL_BACKFACES) && !(flags & (SG_RAY_FRONT_ONLY | SG_RAY_BACK_ONLY)))
        flags = SG_RAY_FRONT_ONLY;
    r->accept_front = !(flags & SG_RAY_BACK_ONLY);
    r->accept_back = !(flags & SG_RAY_FRONT_ONLY);
    r->cull = !r->accept_front || !r->accept_back;
    r->ray = ray;
    return 1;
}

static inline int better(float t, uint64_t key, const best *b)
{
    return t < b->t || (t == b->t && key < b->key);
}

/* What a popped node's point attributes decide. */
enum { NODE_OPEN = 0, NODE_SKIP = 1, NODE_HIT = 2 };

/* For a node that faces one way along the ray: skip it when that side is
 * not accepted; when it is a level-of-detail candidate, hit its disk. */
static int node_point(const sg_hybrid *h, uint32_t k, const tray *r, best *bst, int lod, float floor, counters *c)
{
    const sg_stree_bundle *B = &h->tree.bundles[k / W];
    const int l = (int)(k % W);
    if (B->sin_cone[l] == 255)
        return NODE_OPEN;
    sg_vec3 n = sg_stree_normal(B, l);
    const float *o = r->br.o, *d = r->br.d;
    float dn = n.x * d[0] + n.y * d[1] + n.z * d[2];
    if (!(fabsf(dn) > (float)B->sin_cone[l] * (1.0f / 255.0f) + CONE_MARGIN))
        return NODE_OPEN; /* a silhouette may cross it */
    const int front = dn < 0.0f;
    if (front ? !r->accept_front : !r->accept_back) {
        c->culled++;
        return NODE_SKIP;
    }
    if (!lod)
        return NODE_OPEN;
    c->lod_tests++;
    const float R = B->r[l];
    const float cx = B->cx[l], cy = B->cy[l], cz = B->cz[l];
    const float off = (float)B->offset[l] * (1.0f / 127.0f) * R;
    /* Plane through centre + off n: t = ((c + off n - o) . n) / (d . n). */
    float num = (cx - o[0]) * n.x + (cy - o[1]) * n.y + (cz - o[2]) * n.z + off;
    float t = num / dn;
    if (!(t >= r->tmin))
        return NODE_OPEN;
    float px = o[0] + t * d[0] - cx, py = o[1] + t * d[1] - cy, pz = o[2] + t * d[2] - cz;
    if (!(px * px + py * py + pz * pz <= R * R))
        return NODE_OPEN; /* beside the disk: look at what is really there */
    if (sg_ray_is_self(r->ray, t, n))
        return NODE_OPEN;
    /* The node is a point for this ray whatever else it meets ("Order"):
     * its crossing is taken no nearer than its floor, and when that is
     * not the best so far the node is done, never opened. */
    t = t < floor ? floor : t;
    if (!better(t, ((uint64_t)1 << 32) | k, bst))
        return NODE_SKIP;
    bst->t = t;
    bst->key = ((uint64_t)1 << 32) | k;
    bst->b1 = bst->b2 = 0.0f;
    bst->front = front;
    return NODE_HIT;
}

/* Unit geometric normal of leaf-order triangle i. */
static sg_vec3 tri_normal(const sg_hybrid *h, uint32_t i)
{
    const uint32_t *v = h->tri + 3 * (size_t)i;
    const float *a = h->pos + 3 * (size_t)v[0], *b = h->pos + 3 * (size_t)v[1], *c = h->pos + 3 * (size_t)v[2];
    sg_vec3 e1 = sg_v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    sg_vec3 e2 = sg_v3(c[0] - a[0], c[1] - a[1], c[2] - a[2]);
    return sg_v3_normalize(sg_v3_cross(e1, e2));
}

/* Takes the crossings of mask (lanes of th: triangles g + lane, leaf
 * order) that the ray accepts and that beat *b, in lane order so ties
 * resolve as one at a time would; returns 1 when one became the best.
 * Shared by the single-ray and the packet leaf tests (always inlined:
 * the single-ray loop compiles as it did before packets). */
static inline __attribute__((always_inline)) int take_hit(const sg_hybrid *h, const tray *r, float t, float b1,
                                                          float b2, int front, uint32_t i, best *b)
{
    if (front ? !r->accept_front : !r->accept_back)
        return 0;
    if (!better(t, i, b))
        return 0;
    if (r->ray->self_r > 0.0f && t < r->ray->self_r && sg_ray_is_self(r->ray, t, tri_normal(h, i)))
        return 0;
    b->t = t;
    b->key = i;
    b->b1 = b1;
    b->b2 = b2;
    b->front = front;
    return 1;
}

/* t, b1, b2, front: a triangle kernel's lanes (sg_tri4_hit, sg_tri8_hit). */
static inline __attribute__((always_inline)) int take_hits(const sg_hybrid *h, const tray *r, const float *t,
                                                           const float *b1, const float *b2, unsigned front,
                                                           unsigned mask, uint32_t g, best *b)
{
    int found = 0;
    for (uint32_t l = 0; mask; ++l, mask >>= 1)
        if (mask & 1u)
            found |= take_hit(h, r, t[l], b1[l], b2[l], (int)(front >> l & 1u), g + l, b);
    return found;
}

/* Tests the triangles of a leaf word, four at a time; returns 1 when one
 * became the best (any-hit callers stop there). Lanes are taken in leaf
 * order, so ties resolve as one at a time would. */
static int test_leaf(const sg_hybrid *h, uint32_t word, const tray *r, best *bst, counters *c)
{
    const uint32_t first = sg_stree_leaf_first(word), count = sg_stree_leaf_count(word);
    int found = 0;
    c->triangles += count;
    for (uint32_t g = first; g < first + count; g += 4) {
        const uint32_t n = first + count - g < 4 ? first + count - g : 4;
        sg_tri4 t4;
        for (uint32_t l = 0; l < 4; ++l) {
            const uint32_t *v = h->tri + 3 * (size_t)(g + (l < n ? l : 0));
            sg_tri4_gather(&t4, (int)l, &r->tr, h->pos + 3 * (size_t)v[0], h->pos + 3 * (size_t)v[1],
                           h->pos + 3 * (size_t)v[2]);
        }
        sg_tri4_hit th;
#ifdef EXPERIMENT_SCALAR_TRI
        unsigned mask = sg_tri_intersect4_scalar(&r->tr, &t4, (1u << n) - 1u, r->tmin, bst->t, &th);
#else
        unsigned mask = sg_tri_intersect4(&r->tr, &t4, (1u << n) - 1u, r->tmin, bst->t, &th);
#endif
        found |= take_hits(h, r, th.t, th.b1, th.b2, th.front, mask, g, bst);
    }
    return found;
}

/* Prefetches what a pushed child's visit will read: its children's bundle
 * (four cache lines), or its triangles' vertex ids (word: the child's
 * slot). Issued when the child is pushed, the loads of all the children
 * overlap instead of each waiting on memory when popped (the
 * 21.8M-triangle tree is 0.8 GB). SG_HYBRID_NO_PREFETCH: none (measuring). */
static inline void prefetch_visit(const sg_hybrid *h, uint32_t word)
{
#ifndef SG_HYBRID_NO_PREFETCH
    if (sg_stree_is_leaf(word)) {
        /* up to 8 triangles' ids, 96 bytes: their first and last lines */
        const uint32_t first = sg_stree_leaf_first(word), count = sg_stree_leaf_count(word);
        __builtin_prefetch(h->tri + 3 * (size_t)first);
        __builtin_prefetch(h->tri + 3 * (size_t)(first + count) - 1);
    } else {
        const char *nb = (const char *)&h->tree.bundles[word];
        for (size_t o = 0; o < sizeof(sg_stree_bundle); o += 64)
            __builtin_prefetch(nb + o);
    }
#else
    (void)h;
    (void)word;
#endif
}

/* Prefetches the vertex positions of a leaf word's triangles (their ids
 * are read, so they should be in cache: prefetch_visit). */
static inline void prefetch_vertices(const sg_hybrid *h, uint32_t word)
{
    const uint32_t first = sg_stree_leaf_first(word), count = sg_stree_leaf_count(word);
    for (uint32_t j = 3 * first; j < 3 * (first + count); ++j)
        __builtin_prefetch(h->pos + 3 * (size_t)h->tri[j]);
}

/* Children of bundle cb hit by the ray, nearest last (stack order).
 * A child small enough to be a point is decided here, while its bundle is
 * in cache, rather than pushed and decided when popped: its disk is hit
 * (bst updated, *found set, nothing pushed), it is skipped, or it is
 * pushed to be opened. Measured on the 21.8M-triangle dragon at lod 1:
 * 7% fewer pops (6.0 -> 5.6 a ray), 3% more frames a second. The hit is
 * the one a pop-time decision gives, as any order's is ("Order" above).
 * With SG_HYBRID_LOD_AT_POP (measuring) points are decided when popped. */
static int push_children(const sg_hybrid *h, uint32_t cb, const tray *r, best *bst, float floor, entry *out,
                         int *found, counters *c)
{
    float tin[W];
    unsigned lod;
    unsigned mask = sg_bundle_test(&h->tree.bundles[cb], &r->br, bst->t, tin, &lod);
    c->spheres += W;
    int n = 0;
    for (int l = 0; l < W; ++l) {
        if (!(mask >> l & 1u))
            continue;
        const uint32_t k = cb * (uint32_t)W + (uint32_t)l;
        const float ft = tin[l] > floor ? tin[l] : floor; /* the child's floor */
#ifndef SG_HYBRID_LOD_AT_POP
        if (lod >> l & 1u) {
            if (!(ft <= bst->t))
                continue; /* a disk found in this bundle is nearer */
            const int what = node_point(h, k, r, bst, 1, ft, c);
            if (what == NODE_HIT)
                *found = 1;
            if (what != NODE_OPEN)
                continue;
            lod &= ~(1u << l); /* opened: never tested as a point again */
        }
#else
        (void)found;
#endif
        prefetch_visit(h, h->tree.bundles[cb].child[l]);
        entry e = {ft, k | ((lod >> l & 1u) ? LOD_BIT : 0u)};
        /* Insertion by descending t; equal t keeps lane order reversed, so
         * the lower lane is popped first (deterministic either way). */
        int j = n++;
        while (j > 0 && out[j - 1].t < e.t) {
            out[j] = out[j - 1];
            --j;
        }
        out[j] = e;
    }
    return n;
}

/* Processes a popped node: returns 1 if the ray found a new best (any-hit
 * callers stop there), and appends the children to visit to kids[]. */
static int visit(const sg_hybrid *h, entry e, const tray *r, best *bst, entry *kids, int *nkids, counters *c)
{
    const uint32_t k = e.id & ~LOD_BIT;
    *nkids = 0;
    c->pops++;
    if ((e.id & LOD_BIT) || r->cull) {
        int what = node_point(h, k, r, bst, (e.id & LOD_BIT) != 0, e.t, c);
        if (what == NODE_SKIP)
            return 0;
        if (what == NODE_HIT)
            return 1;
    }
    const uint32_t word = h->tree.bundles[k / W].child[k % W];
    if (sg_stree_is_leaf(word))
        return test_leaf(h, word, r, bst, c);
    int found = 0;
    *nkids = push_children(h, word, r, bst, e.t, kids, &found, c);
    return found;
}

static void trace_stack(const sg_hybrid *h, const tray *r, best *bst, counters *c)
{
    entry stack[STACK_CAP];
    int found = 0;
    int sp = push_children(h, 0, r, bst, -INFINITY, stack, &found, c);
    while (sp > 0) {
        entry e = stack[--sp];
        if (e.t > bst->t)
            continue;
        int n;
        visit(h, e, r, bst, stack + sp, &n, c);
        sp += n;
    }
}

/* Min-heap on (t, id). */
static int heap_less(entry a, entry b) { return a.t < b.t || (a.t == b.t && a.id < b.id); }

static void heap_push(entry *hp, int *n, entry e)
{
    int i = (*n)++;
    while (i > 0) {
        int p = (i - 1) / 2;
        if (!heap_less(e, hp[p]))
            break;
        hp[i] = hp[p];
        i = p;
    }
    hp[i] = e;
}

static entry heap_pop(entry *hp, int *n)
{
    entry top = hp[0], last = hp[--*n];
    int i = 0;
    for (;;) {
        int l = 2 * i + 1;
        if (l >= *n)
            break;
        int m = l + 1 < *n && heap_less(hp[l + 1], hp[l]) ? l + 1 : l;
        if (!heap_less(hp[m], last))
            break;
        hp[i] = hp[m];
        i = m;
    }
    if (*n > 0)
        hp[i] = last;
    return top;
}

/* Returns 0 when the heap would overflow (the caller traces again with the
 * stack). */
static int trace_heap(const sg_hybrid *h, const tray *r, best *bst, counters *c)
{
    entry heap[HEAP_CAP], kids[W];
    int n = 0;
    int found = 0;
    int nk = push_children(h, 0, r, bst, -INFINITY, kids, &found, c);
    for (int i = 0; i < nk; ++i)
        heap_push(heap, &n, kids[i]);
    while (n > 0) {
        entry e = heap_pop(heap, &n);
        if (e.t > bst->t)
            break; /* every other sphere starts even later */
        visit(h, e, r, bst, kids, &nk, c);
        if (n + nk > HEAP_CAP)
            return 0;
        for (int i = 0; i < nk; ++i)
            heap_push(heap, &n, kids[i]);
    }
    return 1;
}

static void miss(sg_hybrid_hit *hit)
{
    memset(hit, 0, sizeof *hit);
    hit->t = INFINITY;
    hit->triangle = hit->node = hit->slot = SG_INVALID_ID;
    hit->vertex[0] = hit->vertex[1] = hit->vertex[2] = SG_INVALID_ID;
}

static void add_stats(sg_hybrid_stats *s, const counters *c, int hit, int lod_hit, int overflow)
{
    if (!s)
        return;
    s->rays++;
    s->pops += c->pops;
    s->spheres += c->spheres;
    s->triangles += c->triangles;
    s->lod_tests += c->lod_tests;
    s->culled += c->culled;
    s->hits += (uint64_t)hit;
    s->lod_hits += (uint64_t)lod_hit;
    s->heap_overflows += (uint64_t)overflow;
}

/* Fills *hit from the ray's best crossing; 0 when there is none (hit
 * stays a miss). */
__attribute__((always_inline)) static inline int write_hit(const sg_hybrid *h, const sg_ray *ray, const best *bst0,
                                                           sg_hybrid_hit *hit)
{
    const best bst = *bst0;
    if (bst.key == UINT64_MAX)
        return 0;
    hit->t = bst.t;
    hit->back = !bst.front;
    if (bst.key >> 32) {
        const uint32_t k = (uint32_t)bst.key;
        const sg_stree_bundle *B = &h->tree.bundles[k / W];
        sg_vec3 n = sg_stree_normal(B, (int)(k % W));
        hit->node = k;
        hit->p = sg_v3_madd(ray->org, ray->dir, bst.t);
        hit->ng = hit->ns = n;
        return 1;
    }
    const uint32_t i = (uint32_t)bst.key;
    const uint32_t *v = h->tri + 3 * (size_t)i;
    const float *a = h->pos + 3 * (size_t)v[0], *b = h->pos + 3 * (size_t)v[1], *cc = h->pos + 3 * (size_t)v[2];
    const float b0 = 1.0f - bst.b1 - bst.b2;
    hit->triangle = h->tri_id[i];
    hit->slot = i;
    hit->vertex[0] = v[0];
    hit->vertex[1] = v[1];
    hit->vertex[2] = v[2];
    hit->b1 = bst.b1;
    hit->b2 = bst.b2;
    hit->p = sg_v3(b0 * a[0] + bst.b1 * b[0] + bst.b2 * cc[0], b0 * a[1] + bst.b1 * b[1] + bst.b2 * cc[1],
                   b0 * a[2] + bst.b1 * b[2] + bst.b2 * cc[2]);
    hit->ng = tri_normal(h, i);
    if (h->vnormal) {
        sg_vec3 n0 = sg_oct_decode(h->vnormal[v[0]]), n1 = sg_oct_decode(h->vnormal[v[1]]);
        sg_vec3 n2 = sg_oct_decode(h->vnormal[v[2]]);
        sg_vec3 ns = sg_v3_normalize(sg_v3_add(sg_v3_add(sg_v3_scale(n0, b0), sg_v3_scale(n1, bst.b1)),
                                               sg_v3_scale(n2, bst.b2)));
        hit->ns = ns.x == 0.0f && ns.y == 0.0f && ns.z == 0.0f ? hit->ng : ns;
    } else {
        hit->ns = hit->ng;
    }
    return 1;
}

int sg_hybrid_intersect(const sg_hybrid *h, const sg_ray *ray, const sg_footprint *fp, sg_hybrid_hit *hit,
                        sg_hybrid_stats *stats)
{
    tray r;
    counters c = {0};
    miss(hit);
    if (!setup(h, ray, fp, &r)) {
        add_stats(stats, &c, 0, 0, 0);
        return 0;
    }
    best bst = {.t = ray->tmax, .key = UINT64_MAX};
    int overflow = 0;
    if (h->desc.traversal == SG_HYBRID_TRAVERSE_HEAP) {
        if (!trace_heap(h, &r, &bst, &c)) {
            overflow = 1;
            bst = (best){.t = ray->tmax, .key = UINT64_MAX};
            trace_stack(h, &r, &bst, &c);
        }
    } else {
        trace_stack(h, &r, &bst, &c);
    }
    const int got = write_hit(h, ray, &bst, hit);
    add_stats(stats, &c, got, got && hit->node != SG_INVALID_ID, overflow);
    return got;
}

/* ---- Packets: up to sixteen rays, one traversal ----------------------------
 *
 * sg_hybrid_intersect16 walks the tree once for up to sixteen rays (a 4x4
 * block of camera rays; sg_hybrid_intersect4 is its first four lanes). An entry carries, per ray, the node's floor (as a
 * single ray's entry does) and the mask of the rays that go on into it: a
 * ray is in it only when it entered the node's sphere and every ancestor's,
 * and each of those was opened for it, by the same per-ray rules
 * (node_point on the node, the ray and the ray's own floor). So each ray
 * reaches exactly the nodes it reaches alone, less what pruning drops, and
 * pruning (the ray's floor beyond its own best) drops only crossings that
 * cannot win: by invariant 2 each ray gets its single-ray hit, bit for bit,
 * whatever order the packet takes. The order is nearest first by the least
 * floor of the entry's rays. Sphere and triangle tests run on each ray's
 * own best with the single ray's operations: for a few rays, ray by ray
 * with the single-ray kernels; for more (SPARSE_LANES), node by node and
 * triangle by triangle across the rays (sg_bundle_test16,
 * sg_tri_intersect16), after a cone test that skips the children no ray
 * of a one-origin packet can enter. What the rays share is the walk itself
 * (one pop, one sort, one prefetch per node), the bundle's and the
 * triangles' cache lines, and, for rays with one origin and one axis
 * permutation (sg_tri_ray), the leaf's gathered vertices. */
enum { PW = 16 };

typedef struct pentry {
    float t[PW];    /* per ray: its floor ("Order"); valid for rays in lanes */
    float key;      /* the least floor of the rays in lanes: the order */
    uint32_t id;    /* node id                                          */
    uint32_t lanes; /* rays that go on into the node                    */
} pentry;

/* The packet's rays as SIMD lanes (sg_bundle_test16 tests one node against
 * all of them), and each ray's best t beside its best (kept in step). */
typedef struct psoa {
    sg_bundle_ray16 br;         /* lanes outside the packet: copies of one in it */
    _Alignas(64) float bt[PW];  /* bt[i] = bst[i].t                            */
    sg_tri_shear16 sh;          /* the rays' shears (sg_tri_ray sx, sy, sz)     */
    unsigned cull;              /* rays with r[i].cull                          */
    unsigned alike;             /* rays that gather like the packet's first ray
                                   (same_gather): camera rays, all of them    */
    int eye;                    /* 1: every lane of br leaves one origin        */
    int cone;                   /* 1: and its rays lie within cn                */
    sg_bundle_cone cn;          /* apex (the origin), axis, half-angle widened  */
} psoa;

#if SG_BUNDLE_SIMD16
/* The children of bundle B that some ray of the packet may enter: a
 * sphere that does not meet the packet's cone is entered by none of its
 * rays (sg_bundle_cone_test, all eight children in one go), so its 16-ray
 * test is skipped; it would have come out 0 for every ray. Any ray
 * order: all children. */
static unsigned cone_children(const sg_stree_bundle *B, const psoa *P)
{
    if (P->cone)
        return sg_bundle_cone_test(B, &P->cn);
    unsigned kids = 0;
    for (int l = 0; l < W && B->child[l] != SG_STREE_EMPTY; ++l)
        kids |= 1u << l;
    return kids;
}
#endif

/* The children of mask `any` in push order, farthest first (popped last);
 * equal keys: the lower lane popped first. Returns how many. */
static inline int order_children(const float key[W], unsigned any, int kids[W])
{
    int n = 0;
    for (unsigned ml = any; ml; ml &= ml - 1) {
        const int l = __builtin_ctz(ml);
        int j = n++;
        while (j > 0 && key[kids[j - 1]] < key[l]) {
            kids[j] = kids[j - 1];
            --j;
        }
        kids[j] = l;
    }
    return n;
}

/* Children of bundle cb that the rays in `lanes` enter, nearest (least
 * key) last; per ray, a point-sized child is decided here as push_children
 * decides it (disk hit, skipped, or opened). Returns how many were
 * written to out. floor may lie in out[0] (the popped entry's slot): it is
 * read in full before out is written, here and in push_children16. */
static int push_children4(const sg_hybrid *h, uint32_t cb, const tray *r, best *bst, psoa *P, const float *floor,
                          unsigned lanes, pentry *out, counters *c)
{
    const sg_stree_bundle *B = &h->tree.bundles[cb];
    float ft[PW][W];                        /* per ray: the children's floors */
    unsigned open[PW] = {0}, any = 0;       /* per ray: children it goes on into */
    for (unsigned m = lanes; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        float tin[W];
        unsigned lod;
        const unsigned mask = sg_bundle_test(B, &r[i].br, bst[i].t, tin, &lod);
        c->spheres += W;
        for (int l = 0; l < W; ++l)
            ft[i][l] = tin[l] > floor[i] ? tin[l] : floor[i];
        open[i] = mask & ~lod;
        for (unsigned ml = mask & lod; ml; ml &= ml - 1) {
            const int l = __builtin_ctz(ml);
            if (!(ft[i][l] <= bst[i].t))
                continue; /* a disk found in this bundle is nearer */
            if (node_point(h, cb * (uint32_t)W + (uint32_t)l, &r[i], &bst[i], 1, ft[i][l], c) == NODE_OPEN)
                open[i] |= 1u << l;
            P->bt[i] = bst[i].t;
        }
        any |= open[i];
    }
    if (!any)
        return 0;
    /* Per child: the rays that go on into it, and the least of their floors. */
    float key[W];
    unsigned go[W] = {0};
    for (int l = 0; l < W; ++l)
        key[l] = INFINITY;
    for (unsigned m = lanes; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        for (unsigned ml = open[i]; ml; ml &= ml - 1) {
            const int l = __builtin_ctz(ml);
            go[l] |= 1u << i;
            key[l] = ft[i][l] < key[l] ? ft[i][l] : key[l];
        }
    }
    int kids[W], n = order_children(key, any, kids);
    for (int j = 0; j < n; ++j) {
        const int l = kids[j];
        pentry *e = &out[j];
        for (unsigned m = go[l]; m; m &= m - 1)
            e->t[__builtin_ctz(m)] = ft[__builtin_ctz(m)][l];
        e->key = key[l];
        e->id = cb * (uint32_t)W + (uint32_t)l;
        e->lanes = go[l];
        prefetch_visit(h, B->child[l]);
    }
    return n;
}

#if SG_BUNDLE_SIMD16
/* push_children4 with the sphere tests across the rays: per child, one
 * sg_bundle_test16 gives the rays that enter it, their floors and which of
 * them see it point-sized, so the child's lanes and key come straight from
 * the masks. Each ray's point decisions are node_point's, made for its
 * children in lane order as alone; a disk hit lowers the ray's far limit
 * for the later children's tests, which then drop only children that
 * begin beyond its best (pruned at their pop otherwise): the same hits. */
static int push_children16(const sg_hybrid *h, uint32_t cb, const tray *r, best *bst, psoa *P, const float *floor,
                           unsigned lanes, pentry *out, counters *c)
{
    const sg_stree_bundle *B = &h->tree.bundles[cb];
    _Alignas(64) float ft[W][PW]; /* per child, per ray: its floor */
    float key[W];
    unsigned go[W], any = 0;
    const sg_v16 fl = sg_v16_load(floor);
    c->spheres += (uint64_t)W * (uint64_t)__builtin_popcount(lanes);
    for (unsigned kids = cone_children(B, P); kids; kids &= kids - 1) {
        const int l = __builtin_ctz(kids);
        _Alignas(64) float tin[PW];
        unsigned lod;
        const unsigned mask = (P->eye ? sg_bundle_test16_eye(B, l, &P->br, P->bt, tin, &lod)
                                      : sg_bundle_test16(B, l, &P->br, P->bt, tin, &lod)) &
                              lanes;
        if (!mask)
            continue;
        const sg_v16 f = sg_v16_max(sg_v16_load(tin), fl); /* tin > floor ? tin : floor */
        sg_v16_store(ft[l], f);
        unsigned open = mask & ~lod;
        for (unsigned ml = mask & lod; ml; ml &= ml - 1) {
            const int i = __builtin_ctz(ml);
            if (!(ft[l][i] <= bst[i].t))
                continue; /* a disk found in this bundle is nearer */
            if (node_point(h, cb * (uint32_t)W + (uint32_t)l, &r[i], &bst[i], 1, ft[l][i], c) == NODE_OPEN)
                open |= 1u << i;
            P->bt[i] = bst[i].t;
        }
        if (!open)
            continue;
        go[l] = open;
        key[l] = sg_v16_min_lanes(f, open);
        any |= 1u << l;
    }
    int kids[W], n = order_children(key, any, kids);
    for (int j = 0; j < n; ++j) {
        const int l = kids[j];
        pentry *e = &out[j];
        memcpy(e->t, ft[l], sizeof e->t);
        e->key = key[l];
        e->id = cb * (uint32_t)W + (uint32_t)l;
        e->lanes = go[l];
        prefetch_visit(h, B->child[l]);
    }
    return n;
}
#endif

/* Packets of a few rays test a bundle ray by ray (8 nodes a test) and a
 * leaf ray by ray (4 triangles a test), fuller ones node by node and
 * triangle by triangle across the rays (16 rays a test, whatever how many
 * are in). Across costs about 8 rays' worth per bundle or leaf: measured
 * (1 thread, best of 3, paired) 8 gave 0.92x the frame time of 4, and 12
 * the same as 8. */
enum { SPARSE_LANES = 8 };

static inline int push_packet(const sg_hybrid *h, uint32_t cb, const tray *r, best *bst, psoa *P, const float *floor,
                              unsigned lanes, pentry *out, counters *c)
{
#if SG_BUNDLE_SIMD16
    if (__builtin_popcount(lanes) > SPARSE_LANES)
        return push_children16(h, cb, r, bst, P, floor, lanes, out, c);
#endif
    return push_children4(h, cb, r, bst, P, floor, lanes, out, c);
}

/* 1 when rays a and b gather a triangle's vertices alike (sg_tri4_gather
 * reads the origin and the axis permutation only). */
static int same_gather(const sg_tri_ray *a, const sg_tri_ray *b)
{
    return a->kx == b->kx && a->ky == b->ky && a->kz == b->kz && memcmp(a->org, b->org, sizeof a->org) == 0;
}

/* test_leaf for the rays in `lanes`: each ray tests the leaf's triangles
 * in test_leaf's order against its own best, with the same kernel; a
 * gather is shared by the rays that gather alike. */
static void test_leaf4(const sg_hybrid *h, uint32_t word, const tray *r, best *bst, unsigned lanes, counters *c)
{
    const uint32_t first = sg_stree_leaf_first(word), count = sg_stree_leaf_count(word);
    c->triangles += count * (uint64_t)__builtin_popcount(lanes);
    for (uint32_t g = first; g < first + count; g += 4) {
        const uint32_t n = first + count - g < 4 ? first + count - g : 4;
        sg_tri4 t4;
        int gathered = -1; /* the ray whose gather t4 holds */
        for (unsigned m = lanes; m; m &= m - 1) {
            const int i = __builtin_ctz(m);
            const tray *ri = &r[i];
            if (gathered < 0 || !same_gather(&r[gathered].tr, &ri->tr)) {
                for (uint32_t l = 0; l < 4; ++l) {
                    const uint32_t *v = h->tri + 3 * (size_t)(g + (l < n ? l : 0));
                    sg_tri4_gather(&t4, (int)l, &ri->tr, h->pos + 3 * (size_t)v[0], h->pos + 3 * (size_t)v[1],
                                   h->pos + 3 * (size_t)v[2]);
                }
                gathered = i;
            }
            sg_tri4_hit th;
            unsigned hm = sg_tri_intersect4(&ri->tr, &t4, (1u << n) - 1u, ri->tmin, bst[i].t, &th);
            take_hits(h, ri, th.t, th.b1, th.b2, th.front, hm, g, &bst[i]);
        }
    }
}

#if SG_V16_SIMD
/* test_leaf4 for rays that all gather alike (same_gather): the leaf's
 * triangles are gathered once and each ray tests all of them in one
 * sg_tri_intersect8 against its own best, taking the crossings in leaf
 * order. The kernel's far limit is the ray's best before the leaf, where
 * test_leaf4's second four see the best after the first four: a crossing
 * between the two is then dropped by take_hit (better()) instead of by
 * the kernel, so the same crossings are taken, in the same order. */
static void test_leaf8(const sg_hybrid *h, uint32_t word, const tray *r, best *bst, unsigned lanes, counters *c)
{
    const uint32_t first = sg_stree_leaf_first(word), count = sg_stree_leaf_count(word);
    const sg_tri_ray *t0 = &r[__builtin_ctz(lanes)].tr;
    c->triangles += count * (uint64_t)__builtin_popcount(lanes);
    sg_tri8 t8;
    for (uint32_t l = 0; l < 8; ++l) {
        const uint32_t *v = h->tri + 3 * (size_t)(first + (l < count ? l : 0));
        sg_tri8_gather(&t8, (int)l, t0, h->pos + 3 * (size_t)v[0], h->pos + 3 * (size_t)v[1],
                       h->pos + 3 * (size_t)v[2]);
    }
    for (unsigned m = lanes; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        sg_tri8_hit th;
        const unsigned hm = sg_tri_intersect8(&r[i].tr, &t8, (1u << count) - 1u, r[i].tmin, bst[i].t, &th);
        take_hits(h, &r[i], th.t, th.b1, th.b2, th.front, hm, first, &bst[i]);
    }
}

/* test_leaf4 across the rays: the rays that gather like the packet's first
 * (one origin and axis order: camera rays) test each triangle in one
 * sg_tri_intersect16, against their own bests, and take its crossings in
 * leaf order as test_leaf does (each ray's triangles in the same order,
 * each crossing kept or not by the same rule: the same hit). A ray that
 * gathers otherwise goes through test_leaf4. */
static void test_leaf16(const sg_hybrid *h, uint32_t word, const tray *r, best *bst, psoa *P, unsigned lanes,
                        counters *c)
{
    const int f = __builtin_ctz(lanes);
    unsigned cls = (lanes & P->alike) == lanes ? lanes : 0;
    for (unsigned m = cls ? 0 : lanes; m; m &= m - 1)
        if (same_gather(&r[f].tr, &r[__builtin_ctz(m)].tr))
            cls |= 1u << __builtin_ctz(m);
    const unsigned few = __builtin_popcount(cls) <= SPARSE_LANES ? cls : 0u;
    cls &= ~few;
    if (few)
        test_leaf8(h, word, r, bst, few, c);
    if (lanes & ~cls & ~few)
        test_leaf4(h, word, r, bst, lanes & ~cls & ~few, c);
    for (unsigned m = lanes & ~cls; m; m &= m - 1)
        P->bt[__builtin_ctz(m)] = bst[__builtin_ctz(m)].t;
    if (!cls)
        return;
    const uint32_t first = sg_stree_leaf_first(word), count = sg_stree_leaf_count(word);
    c->triangles += count * (uint64_t)__builtin_popcount(cls);
#ifndef SG_HYBRID_NO_PREFETCH
    /* every vertex of the leaf at once: their misses overlap instead of
     * each triangle's waiting on its own */
    prefetch_vertices(h, word);
#endif
    const sg_tri_ray *t0 = &r[f].tr;
    const int k[3] = {t0->kx, t0->ky, t0->kz};
    for (uint32_t j = first; j < first + count; ++j) {
        const uint32_t *v = h->tri + 3 * (size_t)j;
        const float *p0 = h->pos + 3 * (size_t)v[0], *p1 = h->pos + 3 * (size_t)v[1], *p2 = h->pos + 3 * (size_t)v[2];
        float a[3], b[3], cc[3]; /* as sg_tri4_gather */
        for (int q = 0; q < 3; ++q) {
            a[q] = p0[k[q]] - t0->org[k[q]];
            b[q] = p1[k[q]] - t0->org[k[q]];
            cc[q] = p2[k[q]] - t0->org[k[q]];
        }
        sg_tri16_hit th;
        unsigned e0;
        const unsigned hm = sg_tri_intersect16(&P->sh, a, b, cc, cls, P->br.tmin, P->bt, &th, &e0);
        for (unsigned m = hm | e0; m; m &= m - 1) {
            const int i = __builtin_ctz(m);
            if (e0 >> i & 1u) { /* an edge function exactly 0: the scalar test's double fallback */
                sg_tri_hit one;
                if (sg_tri_intersect(&r[i].tr, p0, p1, p2, r[i].tmin, bst[i].t, &one) &&
                    take_hit(h, &r[i], one.t, one.b1, one.b2, one.front, j, &bst[i]))
                    P->bt[i] = bst[i].t;
            } else if (take_hit(h, &r[i], th.t[i], th.b1[i], th.b2[i], (int)(th.front >> i & 1u), j, &bst[i])) {
                P->bt[i] = bst[i].t;
            }
        }
    }
}
#endif

static void trace_packet(const sg_hybrid *h, const tray *r, best *bst, psoa *P, unsigned lanes, counters *c)
{
    /* Each pop pushes at most W entries and the walk is depth first, so
     * the single ray's bound holds (invariant 3). */
    pentry stack[STACK_CAP];
    float root[PW];
    for (int i = 0; i < PW; ++i)
        root[i] = -INFINITY;
    int sp = push_packet(h, 0, r, bst, P, root, lanes, stack, c);
    while (sp > 0) {
        /* Read in place, not copied: a copy was stored in 16-byte pieces
         * and loaded back 32 bytes at a time, which stalls every pop on
         * store forwarding. The children are written over this slot, but
         * push_packet reads the floors (e->t) before it writes an entry. */
        const pentry *e = &stack[--sp];
        const uint32_t k = e->id;
        /* the rays whose floor is not beyond their best (e->t[i] > bst[i].t: pruned) */
        unsigned go = e->lanes;
#if SG_BUNDLE_SIMD16
        go &= ~sg_v16_gt(sg_v16_load(e->t), sg_v16_load(P->bt));
#else
        for (unsigned m = e->lanes; m; m &= m - 1)
            if (e->t[__builtin_ctz(m)] > bst[__builtin_ctz(m)].t)
                go &= ~(1u << __builtin_ctz(m));
#endif
        /* lod 0: only a cull (NODE_SKIP) or NODE_OPEN comes back */
        for (unsigned m = go & P->cull; m; m &= m - 1) {
            const int i = __builtin_ctz(m);
            if (node_point(h, k, &r[i], &bst[i], 0, e->t[i], c) == NODE_SKIP)
                go &= ~(1u << i);
        }
        if (!go)
            continue;
        c->pops++;
        const uint32_t word = h->tree.bundles[k / W].child[k % W];
        if (sg_stree_is_leaf(word)) {
#ifndef SG_HYBRID_NO_PREFETCH
            /* The next entry's vertices while this leaf is tested: their
             * ids came in when it was pushed, and the positions, which
             * need the ids, were asked for only as its test began. */
            if (sp > 0) {
                const uint32_t nk = stack[sp - 1].id, nword = h->tree.bundles[nk / W].child[nk % W];
                if (sg_stree_is_leaf(nword))
                    prefetch_vertices(h, nword);
            }
#endif
#if SG_V16_SIMD
            test_leaf16(h, word, r, bst, P, go, c);
#else
            test_leaf4(h, word, r, bst, go, c);
            for (unsigned m = go; m; m &= m - 1)
                P->bt[__builtin_ctz(m)] = bst[__builtin_ctz(m)].t;
#endif
        } else {
            sp += push_packet(h, word, r, bst, P, e->t, go, stack + sp, c);
        }
    }
}

/* The packet's cone (psoa), when its rays leave one origin: the axis is
 * their mean direction (the lanes of br, copies included: any axis
 * will do, the half-angle is measured against the one stored) and the
 * half-angle the widest ray's, widened by 1e-3 radians. In float, across
 * the lanes: the angle comes from its sine |a x d| / |d|, which float
 * gives within about 1e-6 radians even for parallel rays (a cosine near 1
 * would lose it), far below the widening. */
#if SG_BUNDLE_SIMD16
static void packet_cone(unsigned lanes, psoa *P)
{
    const sg_bundle_ray16 *b = &P->br;
    const int f = __builtin_ctz(lanes);
    P->eye = P->cone = 0;
    /* lanes outside the packet are copies of ray f */
    if (sg_v16_neq(sg_v16_load(b->ox), sg_v16_set1(b->ox[f])) |
        sg_v16_neq(sg_v16_load(b->oy), sg_v16_set1(b->oy[f])) |
        sg_v16_neq(sg_v16_load(b->oz), sg_v16_set1(b->oz[f])))
        return;
    P->eye = 1;
    float a[3] = {0.0f, 0.0f, 0.0f};
    for (int i = 0; i < PW; ++i) {
        a[0] += b->dx[i];
        a[1] += b->dy[i];
        a[2] += b->dz[i];
    }
    const float len = sqrtf(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    if (!(len > 0.0f))
        return;
    for (int q = 0; q < 3; ++q)
        a[q] /= len;
    const sg_v16 dx = sg_v16_load(b->dx), dy = sg_v16_load(b->dy), dz = sg_v16_load(b->dz);
    const sg_v16 ax = sg_v16_set1(a[0]), ay = sg_v16_set1(a[1]), az = sg_v16_set1(a[2]);
    const sg_v16 dot = sg_v16_add(sg_v16_add(sg_v16_mul(ax, dx), sg_v16_mul(ay, dy)), sg_v16_mul(az, dz));
    if (sg_v16_gt(dot, sg_v16_set1(0.0f)) != 0xFFFFu)
        return; /* a ray at 90 degrees or more from the axis (or NaN) */
    const sg_v16 qx = sg_v16_sub(sg_v16_mul(ay, dz), sg_v16_mul(az, dy));
    const sg_v16 qy = sg_v16_sub(sg_v16_mul(az, dx), sg_v16_mul(ax, dz));
    const sg_v16 qz = sg_v16_sub(sg_v16_mul(ax, dy), sg_v16_mul(ay, dx));
    const sg_v16 q2 = sg_v16_add(sg_v16_add(sg_v16_mul(qx, qx), sg_v16_mul(qy, qy)), sg_v16_mul(qz, qz));
    const sg_v16 d2 = sg_v16_add(sg_v16_add(sg_v16_mul(dx, dx), sg_v16_mul(dy, dy)), sg_v16_mul(dz, dz));
    /* the widest ray's sin^2 (the largest: the least of its negation) */
    const float s2 = -sg_v16_min_lanes(sg_v16_sub(sg_v16_set1(0.0f), sg_v16_div(q2, d2)), 0xFFFFu);
    const float s0 = sqrtf(s2 < 1.0f ? s2 : 1.0f), c0 = sqrtf(1.0f - s0 * s0);
    /* the half-angle plus 1e-3 radians, by the angle-sum identities */
    const float cd = 0.9999995f, sd = 9.9999983e-4f; /* cos, sin of 1e-3 */
    const float cw = c0 * cd - s0 * sd, sw = s0 * cd + c0 * sd;
    if (!(cw > 0.55f)) /* wider than about 1 radian: the test would reject little */
        return;
    P->cn.o[0] = b->ox[f];
    P->cn.o[1] = b->oy[f];
    P->cn.o[2] = b->oz[f];
    memcpy(P->cn.a, a, sizeof a);
    P->cn.sin = sw;
    P->cn.cos = cw;
    P->cone = 1;
}
#endif

#if SG_V16_SIMD
/* Unit vectors of sixteen lanes: x, y, z scaled by 1 / sqrt(l2) where
 * l2 = x x + y y + z z > 1e-30, else zero (sg_v3_normalize, lane by
 * lane, with its operations in its order). */
static inline void normalize16(sg_v16 *x, sg_v16 *y, sg_v16 *z)
{
    const sg_v16 l2 = sg_v16_add(sg_v16_add(sg_v16_mul(*x, *x), sg_v16_mul(*y, *y)), sg_v16_mul(*z, *z));
    const unsigned big = sg_v16_gt(l2, sg_v16_set1(1e-30f));
    const sg_v16 s = sg_v16_div(sg_v16_set1(1.0f), sg_v16_sqrt(l2)), zero = sg_v16_set1(0.0f);
    *x = sg_v16_select(big, sg_v16_mul(*x, s), zero);
    *y = sg_v16_select(big, sg_v16_mul(*y, s), zero);
    *z = sg_v16_select(big, sg_v16_mul(*z, s), zero);
}

/* write_hit for the rays of `lanes` whose best is a triangle, across the
 * lanes: the hit point, the geometric normal and the interpolated shading
 * normal by write_hit's expressions in its order (v16.h: no fused
 * multiply-adds), so every lane gets write_hit's bits
 * (hybrid::intersect16_matches_single compares each field). One lane at a
 * time, the scalar divisions and square roots of the normals (five a hit)
 * were the largest part of a packet's own time outside the walk. Returns
 * the lanes written; the caller writes the others. */
static unsigned write_hits16(const sg_hybrid *h, const best *bst, unsigned lanes, sg_hybrid_hit *hits)
{
    unsigned tri = 0;
    for (unsigned m = lanes; m; m &= m - 1) {
        const int r = __builtin_ctz(m);
        tri |= (unsigned)(bst[r].key >> 32 == 0) << r;
    }
    if (!tri)
        return 0;
    /* the lanes' inputs, one array per quantity; a lane outside tri is a
     * copy of the first in it (computed, never read; no zero-fill, whose
     * string store cost more than the copies) */
    _Alignas(64) float P[9][16], B1[16], B2[16];
    uint32_t code[3][16]; /* the vertices' normals, oct.h */
    const uint32_t *vn = h->vnormal;
    const int f = __builtin_ctz(tri);
    for (int r = 0; r < 16; ++r) {
        const int src = tri >> r & 1u ? r : f;
        const uint32_t i = (uint32_t)bst[src].key;
        const uint32_t *v = h->tri + 3 * (size_t)i;
        for (int q = 0; q < 3; ++q) {
            const float *x = h->pos + 3 * (size_t)v[q];
            P[3 * q][r] = x[0];
            P[3 * q + 1][r] = x[1];
            P[3 * q + 2][r] = x[2];
            if (vn)
                code[q][r] = vn[v[q]];
        }
        B1[r] = bst[src].b1;
        B2[r] = bst[src].b2;
        if (src != r)
            continue;
        sg_hybrid_hit *hit = &hits[r];
        hit->t = bst[r].t;
        hit->back = !bst[r].front;
        hit->triangle = h->tri_id[i];
        hit->slot = i;
        memcpy(hit->vertex, v, sizeof hit->vertex);
        hit->b1 = bst[r].b1;
        hit->b2 = bst[r].b2;
    }
    const sg_v16 b1 = sg_v16_load(B1), b2 = sg_v16_load(B2);
    const sg_v16 b0 = sg_v16_sub(sg_v16_sub(sg_v16_set1(1.0f), b1), b2);
    sg_v16 a[3], b[3], c[3];
    for (int q = 0; q < 3; ++q) {
        a[q] = sg_v16_load(P[q]);
        b[q] = sg_v16_load(P[3 + q]);
        c[q] = sg_v16_load(P[6 + q]);
    }
    /* p = b0 a + b1 b + b2 c */
    _Alignas(64) float out[9][16];
    for (int q = 0; q < 3; ++q)
        sg_v16_store(out[q], sg_v16_add(sg_v16_add(sg_v16_mul(b0, a[q]), sg_v16_mul(b1, b[q])), sg_v16_mul(b2, c[q])));
    /* ng = normalize((b - a) x (c - a)), tri_normal */
    const sg_v16 e1x = sg_v16_sub(b[0], a[0]), e1y = sg_v16_sub(b[1], a[1]), e1z = sg_v16_sub(b[2], a[2]);
    const sg_v16 e2x = sg_v16_sub(c[0], a[0]), e2y = sg_v16_sub(c[1], a[1]), e2z = sg_v16_sub(c[2], a[2]);
    sg_v16 gx = sg_v16_sub(sg_v16_mul(e1y, e2z), sg_v16_mul(e1z, e2y));
    sg_v16 gy = sg_v16_sub(sg_v16_mul(e1z, e2x), sg_v16_mul(e1x, e2z));
    sg_v16 gz = sg_v16_sub(sg_v16_mul(e1x, e2y), sg_v16_mul(e1y, e2x));
    normalize16(&gx, &gy, &gz);
    sg_v16 sx = gx, sy = gy, sz = gz;
    if (vn) {
        /* ns = normalize(n0 b0 + n1 b1 + n2 b2), ng where that is zero */
        sg_v16 nx[3], ny[3], nz[3];
        for (int q = 0; q < 3; ++q)
            sg_oct_decode16(code[q], &nx[q], &ny[q], &nz[q]);
        sg_v16 x = sg_v16_add(sg_v16_add(sg_v16_mul(nx[0], b0), sg_v16_mul(nx[1], b1)), sg_v16_mul(nx[2], b2));
        sg_v16 y = sg_v16_add(sg_v16_add(sg_v16_mul(ny[0], b0), sg_v16_mul(ny[1], b1)), sg_v16_mul(ny[2], b2));
        sg_v16 z = sg_v16_add(sg_v16_add(sg_v16_mul(nz[0], b0), sg_v16_mul(nz[1], b1)), sg_v16_mul(nz[2], b2));
        normalize16(&x, &y, &z);
        const sg_v16 zero = sg_v16_set1(0.0f);
        const unsigned flat = sg_v16_eq(x, zero) & sg_v16_eq(y, zero) & sg_v16_eq(z, zero);
        sx = sg_v16_select(flat, gx, x);
        sy = sg_v16_select(flat, gy, y);
        sz = sg_v16_select(flat, gz, z);
    }
    sg_v16_store(out[3], gx), sg_v16_store(out[4], gy), sg_v16_store(out[5], gz);
    sg_v16_store(out[6], sx), sg_v16_store(out[7], sy), sg_v16_store(out[8], sz);
    for (unsigned m = tri; m; m &= m - 1) {
        const int r = __builtin_ctz(m);
        sg_hybrid_hit *hit = &hits[r];
        hit->p = sg_v3(out[0][r], out[1][r], out[2][r]);
        hit->ng = sg_v3(out[3][r], out[4][r], out[5][r]);
        hit->ns = sg_v3(out[6][r], out[7][r], out[8][r]);
    }
    return tri;
}
#endif

unsigned sg_hybrid_intersect16(const sg_hybrid *h, const sg_ray *rays, unsigned mask, const sg_footprint *fp,
                               sg_hybrid_hit *hits, sg_hybrid_stats *stats)
{
    tray r[PW];
    best bst[PW];
    counters c = {0};
    unsigned lanes = 0;
    mask &= 0xFFFFu;
    for (unsigned m = mask; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        miss(&hits[i]);
        if (!setup(h, &rays[i], fp ? &fp[i] : NULL, &r[i]))
            continue;
        bst[i] = (best){.t = rays[i].tmax, .key = UINT64_MAX};
        lanes |= 1u << i;
    }
    if (lanes) {
        psoa P;
        P.cull = P.alike = 0;
        P.eye = P.cone = 0;
        const int f = __builtin_ctz(lanes);
        for (int i = 0; i < PW; ++i) {
            const tray *ri = &r[lanes >> i & 1u ? i : f]; /* a ray outside: a copy, so lanes stay finite */
            P.br.ox[i] = ri->br.o[0];
            P.br.oy[i] = ri->br.o[1];
            P.br.oz[i] = ri->br.o[2];
            P.br.dx[i] = ri->br.d[0];
            P.br.dy[i] = ri->br.d[1];
            P.br.dz[i] = ri->br.d[2];
            P.br.tmin[i] = ri->br.tmin;
            P.br.lod0[i] = ri->br.lod0;
            P.br.lod1[i] = ri->br.lod1;
            P.bt[i] = bst[lanes >> i & 1u ? i : f].t;
            P.sh.sx[i] = ri->tr.sx;
            P.sh.sy[i] = ri->tr.sy;
            P.sh.sz[i] = ri->tr.sz;
            P.cull |= (unsigned)(lanes >> i & 1u && ri->cull) << i;
            P.alike |= (unsigned)(lanes >> i & 1u && same_gather(&r[f].tr, &ri->tr)) << i;
        }
#if SG_BUNDLE_SIMD16
        packet_cone(lanes, &P);
#endif
        trace_packet(h, r, bst, &P, lanes, &c);
    }
    unsigned found = 0, lod_hits = 0;
#ifndef SG_HYBRID_NO_PREFETCH
    /* The hits' vertex normals and ids (write_hit) are cold: ask for all
     * of them before the first is read. */
    for (unsigned m = lanes; m; m &= m - 1) {
        const best *b = &bst[__builtin_ctz(m)];
        if (b->key >> 32)
            continue; /* a miss (all ones) or a node */
        const uint32_t *v = h->tri + 3 * (size_t)b->key;
        __builtin_prefetch(&h->tri_id[b->key]);
        if (h->vnormal)
            for (int q = 0; q < 3; ++q)
                __builtin_prefetch(&h->vnormal[v[q]]);
    }
#endif
    unsigned rest = lanes;
#if SG_V16_SIMD
    const unsigned tri = write_hits16(h, bst, lanes, hits);
    found |= tri;
    rest &= ~tri;
#endif
    for (unsigned m = rest; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        if (write_hit(h, &rays[i], &bst[i], &hits[i])) {
            found |= 1u << i;
            lod_hits += hits[i].node != SG_INVALID_ID;
        }
    }
    if (stats) {
        stats->rays += (uint64_t)__builtin_popcount(mask);
        stats->pops += c.pops;
        stats->spheres += c.spheres;
        stats->triangles += c.triangles;
        stats->lod_tests += c.lod_tests;
        stats->culled += c.culled;
        stats->hits += (uint64_t)__builtin_popcount(found);
        stats->lod_hits += lod_hits;
    }
    return found;
}

unsigned sg_hybrid_intersect4(const sg_hybrid *h, const sg_ray rays[4], unsigned mask, const sg_footprint *fp,
                              sg_hybrid_hit hits[4], sg_hybrid_stats *stats)
{
    /* lanes outside mask are never read or written */
    return sg_hybrid_intersect16(h, rays, mask & 15u, fp, hits, stats);
}

int sg_hybrid_occluded(const sg_hybrid *h, const sg_ray *ray, const sg_footprint *fp, sg_hybrid_stats *stats)
{
    tray r;
    counters c = {0};
    if (!setup(h, ray, fp, &r)) {
        add_stats(stats, &c, 0, 0, 0);
        return 0;
    }
    best bst = {.t = ray->tmax, .key = UINT64_MAX};
    entry stack[STACK_CAP];
    int found = 0;
    int sp = push_children(h, 0, &r, &bst, -INFINITY, stack, &found, &c);
    while (sp > 0 && !found) {
        entry e = stack[--sp];
        int n;
        found = visit(h, e, &r, &bst, stack + sp, &n, &c);
        sp += n;
    }
    add_stats(stats, &c, found, 0, 0);
    return found;
}
