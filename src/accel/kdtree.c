/* kdtree.c — SAH kd-tree builder (Wald & Seidel 2005, §3.4).
 *
 * The build runs top-down. A node with many primitives chooses its plane by
 * binned SAH (32 bins per axis); a node with few tests every primitive
 * boundary exactly, because near the leaves the planes must hug the surface.
 * Primitives straddling the plane go to both children. When the SAH prefers
 * a leaf, the optional shrink hook tightens the cell (§3.4.1). The paper
 * inserts the planes that cut the empty slabs off as inner nodes with an
 * empty child; we keep the shrunk box on the leaf instead and clip the ray
 * against it there: the same empty space is skipped without the extra
 * node steps.
 *
 * Refinements (see kdtree.h flags):
 *   E(n) = min(1, (95 + 5n) / 200) lowers the estimated cost of small
 *   children only (§3.4.2), so the SAH keeps splitting where the boxes of
 *   large splats overestimate the surface; post-collapse (§3.4.3) merges
 *   splits whose two children both ended up empty.
 *
 * Invariants (numbers refer to kdtree.h):
 *   (1),(2) hold by construction in flatten(); (3) because a primitive is
 *   dropped from a child only when its box does not reach that side of the
 *   plane, and from a shrunk leaf only when its box misses the shrunk cell;
 *   (4) because each subtree is a pure function of (primitives, cell, depth)
 *   and flatten() walks the finished tree depth-first in one thread.
 *
 * Build-time memory. The shrink hook empties most of the small cells the
 * SAH creates (on scanned models about 19 build nodes per splat, 2 of which
 * survive the collapse), so a split whose two children both ended up empty
 * is collapsed as soon as both are built, not after the whole tree: the live
 * build tree stays near the size of the final one. Build nodes and leaf id
 * lists come from per-thread arenas (bump allocation in large blocks, freed
 * together), and small partitions live on the stack, so the build makes a
 * few hundred allocations instead of several per splat. The tree is then
 * flattened into the compact arrays and the arenas are freed.
 */
#include "accel/kdtree.h"

#include <assert.h>
#include <float.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "core/alloc.h"
#include "core/arena.h"

enum {
    BIN_COUNT = 32,          /* bins per axis for the binned SAH                 */
    EXACT_SAH_MAX = 128,     /* at or below this many primitives, test every edge */
    TASK_MIN_PRIMS = 4096,   /* spawn an OpenMP task for subtrees this large     */
    STACK_PRIMS = 256,       /* partitions of up to this many ids stay on the stack */
    DEFAULT_MAX_DEPTH = 48
};

/* Wald's empty-space bonus: a split that cuts off an empty slab is worth a
 * little more than its SAH cost says, because empty space is free to skip. */
static const float EMPTY_BONUS = 0.8f;

/* A node of the temporary build tree (40 bytes). */
typedef struct bnode {
    union {
        struct {
            struct bnode *child[2]; /* left (below the plane), right       */
            float split;            /* plane position                       */
        } inner;                    /* axis 0..2                            */
        struct {
            uint32_t *prims;        /* ids in an arena, NULL when empty     */
            sg_aabb bounds;         /* the (shrunk) box holding its surface */
        } leaf;                     /* axis 3                               */
    } u;
    uint32_t count;                 /* leaf: number of ids                  */
    uint8_t axis;
} bnode;

typedef struct build_ctx {
    const sg_kdtree_desc *d;
    float cost_trav, cost_isec;
    int max_depth;
    sg_arena_set *arena;  /* one arena per thread of the build's region   */
    bnode **free_nodes;   /* per thread: collapsed nodes, linked through
                             u.inner.child[0]; only that thread touches
                             its list (tasks are tied)                    */
    int failed;    /* set (never cleared) when an allocation fails */
} build_ctx;

static void set_failed(build_ctx *c)
{
#pragma omp atomic write
    c->failed = 1;
}

/* `bytes` from the calling thread's arena; NULL (and the build marked
 * failed) when out of memory. */
static void *arena_alloc(build_ctx *c, size_t bytes)
{
    void *p = sg_arena_alloc(c->arena, bytes);
    if (!p)
        set_failed(c);
    return p;
}

/* A fresh leaf node (empty, zero box). */
static bnode *node_alloc(build_ctx *c)
{
    bnode **list = &c->free_nodes[omp_get_thread_num()];
    bnode *b = *list;
    if (b)
        *list = b->u.inner.child[0];
    else if (!(b = arena_alloc(c, sizeof *b)))
        return NULL;
    memset(b, 0, sizeof *b);
    b->axis = 3;
    return b;
}

static void node_release(build_ctx *c, bnode *b)
{
    bnode **list = &c->free_nodes[omp_get_thread_num()];
    b->u.inner.child[0] = *list;
    *list = b;
}

static float clampf(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }

static float half_area(sg_aabb b)
{
    float dx = b.hi.x - b.lo.x, dy = b.hi.y - b.lo.y, dz = b.hi.z - b.lo.z;
    return dx * dy + dy * dz + dz * dx;
}

/* E(n) for a child with n of the parent's n_parent primitives. Only a child
 * that actually separates primitives (n < n_parent) is encouraged: lowering
 * the cost of a child that keeps them all would make cutting off ever
 * thinner empty slabs look profitable forever; shrinking handles empty
 * space instead. */
static float encourage(const build_ctx *c, size_t n, size_t n_parent)
{
    if (!(c->d->flags & SG_KD_BUILD_ENCOURAGE) || n >= n_parent)
        return 1.0f;
    float e = (95.0f + 5.0f * (float)n) / 200.0f;
    return e < 1.0f ? e : 1.0f;
}

static float axis_lo(sg_aabb b, int a) { return sg_v3_get(b.lo, a); }
static float axis_hi(sg_aabb b, int a) { return sg_v3_get(b.hi, a); }

static void set_axis(sg_vec3 *v, int a, float x)
{
    if (a == 0) v->x = x;
    else if (a == 1) v->y = x;
    else v->z = x;
}

/* SAH cost of splitting `cell` at `pos` on `axis` with nl / nr primitives. */
static float split_cost(const build_ctx *c, sg_aabb cell, int axis, float pos, size_t nl, size_t nr, size_t n)
{
    sg_aabb l = cell, r = cell;
    set_axis(&l.hi, axis, pos);
    set_axis(&r.lo, axis, pos);
    float inv = 1.0f / (half_area(cell) + FLT_MIN);
    float cost = c->cost_isec * (half_area(l) * inv * (float)nl * encourage(c, nl, n) +
                                 half_area(r) * inv * (float)nr * encourage(c, nr, n));
    if (nl == 0 || nr == 0)
        cost *= EMPTY_BONUS;
    return c->cost_trav + cost;
}

typedef struct split_choice {
    int axis;   /* -1: no split better than a leaf */
    float pos;
    float cost;
} split_choice;

/* A primitive goes left when its box reaches below the plane, right when it
 * reaches above; a box flat on the plane goes left so that none is lost. */
static int goes_left(float lo, float hi, float pos) { return lo < pos || (lo == pos && hi == pos); }
static int goes_right(float lo, float hi, float pos) { (void)lo; return hi > pos; }

static split_choice find_split_binned(const build_ctx *c, const uint32_t *prims, size_t n, sg_aabb cell)
{
    split_choice best = {-1, 0.0f, FLT_MAX};
    for (int a = 0; a < 3; ++a) {
        float clo = axis_lo(cell, a), chi = axis_hi(cell, a);
        if (!(chi > clo))
            continue;
        uint32_t start[BIN_COUNT] = {0}, end[BIN_COUNT] = {0};
        float scale = (float)BIN_COUNT / (chi - clo);
        const float *plo = c->d->lo[a], *phi = c->d->hi[a];
        for (size_t i = 0; i < n; ++i) {
            uint32_t p = prims[i];
            int b0 = (int)clampf((plo[p] - clo) * scale, 0.0f, BIN_COUNT - 1);
            int b1 = (int)clampf((phi[p] - clo) * scale, 0.0f, BIN_COUNT - 1);
            start[b0]++;
            end[b1]++;
        }
        size_t nl = 0, nr = n;
        for (int k = 1; k < BIN_COUNT; ++k) {
            nl += start[k - 1];
            nr -= end[k - 1];
            float pos = clo + (chi - clo) * (float)k / BIN_COUNT;
            float cost = split_cost(c, cell, a, pos, nl, nr, n);
            if (cost < best.cost) {
                best.axis = a;
                best.pos = pos;
                best.cost = cost;
            }
        }
    }
    return best;
}

static split_choice find_split_exact(const build_ctx *c, const uint32_t *prims, size_t n, sg_aabb cell)
{
    split_choice best = {-1, 0.0f, FLT_MAX};
    for (int a = 0; a < 3; ++a) {
        float clo = axis_lo(cell, a), chi = axis_hi(cell, a);
        const float *plo = c->d->lo[a], *phi = c->d->hi[a];
        for (size_t e = 0; e < 2 * n; ++e) {
            uint32_t pe = prims[e >> 1];
            float pos = (e & 1) ? phi[pe] : plo[pe];
            if (!(pos > clo && pos < chi))
                continue;
            size_t nl = 0, nr = 0;
            for (size_t i = 0; i < n; ++i) {
                uint32_t p = prims[i];
                nl += (size_t)goes_left(plo[p], phi[p], pos);
                nr += (size_t)goes_right(plo[p], phi[p], pos);
            }
            float cost = split_cost(c, cell, a, pos, nl, nr, n);
            /* Ties go to the lower (axis, edge) pair: deterministic. */
            if (cost < best.cost) {
                best.axis = a;
                best.pos = pos;
                best.cost = cost;
            }
        }
    }
    return best;
}

static int box_overlaps_cell(const sg_kdtree_desc *d, uint32_t p, sg_aabb cell)
{
    return d->lo[0][p] <= cell.hi.x && d->hi[0][p] >= cell.lo.x &&
           d->lo[1][p] <= cell.hi.y && d->hi[1][p] >= cell.lo.y &&
           d->lo[2][p] <= cell.hi.z && d->hi[2][p] >= cell.lo.z;
}

/* Turns `node` into a leaf holding the ids prims[0..n) (copied into the
 * arena; prims is freed when `owned`), shrinking the cell first when a hook
 * is given: the leaf keeps the shrunk box, which traversal clips the ray
 * against (no extra planes, no empty siblings), and drops the primitives
 * that no longer reach it. */
static void make_leaf(build_ctx *c, bnode *node, uint32_t *prims, size_t n, int owned, sg_aabb cell)
{
    node->axis = 3;
    node->u.leaf.prims = NULL;
    node->u.leaf.bounds = cell;
    node->count = 0;
    size_t kept = n;
    if (n && c->d->shrink) {
        sg_aabb s = cell;
        if (!c->d->shrink(c->d->shrink_user, prims, n, &s)) {
            kept = 0;
        } else {
            /* Keep the shrunk cell inside the original one. */
            s.lo = sg_v3_max(s.lo, cell.lo);
            s.hi = sg_v3_min(s.hi, cell.hi);
            kept = 0;
            for (size_t i = 0; i < n; ++i)
                if (box_overlaps_cell(c->d, prims[i], s))
                    prims[kept++] = prims[i];
            node->u.leaf.bounds = s;
        }
    }
    if (kept) {
        uint32_t *ids = arena_alloc(c, kept * sizeof *ids);
        if (ids) {
            memcpy(ids, prims, kept * sizeof *ids);
            node->u.leaf.prims = ids;
            node->count = (uint32_t)kept;
        }
    }
    if (owned)
        sg_free(prims);
}

static int is_empty_leaf(const bnode *b) { return b->axis == 3 && b->count == 0; }

/* Builds the subtree of `node` over prims[0..n) in `cell`. The ids are
 * freed here when `owned` (heap arrays); otherwise they live in the
 * caller's stack frame, which outlasts this call. */
static void build_rec(build_ctx *c, bnode *node, uint32_t *prims, size_t n, int owned, sg_aabb cell, int depth)
{
    int failed;
#pragma omp atomic read
    failed = c->failed;
    if (n == 0 || depth >= c->max_depth || failed) {
        make_leaf(c, node, prims, n, owned, cell);
        return;
    }
    split_choice s = n > EXACT_SAH_MAX ? find_split_binned(c, prims, n, cell)
                                       : find_split_exact(c, prims, n, cell);
    float leaf_cost = c->cost_isec * (float)n;
    if (s.axis < 0 || s.cost >= leaf_cost) {
        make_leaf(c, node, prims, n, owned, cell);
        return;
    }
    const float *plo = c->d->lo[s.axis], *phi = c->d->hi[s.axis];
    size_t nl = 0, nr = 0;
    for (size_t i = 0; i < n; ++i) {
        nl += (size_t)goes_left(plo[prims[i]], phi[prims[i]], s.pos);
        nr += (size_t)goes_right(plo[prims[i]], phi[prims[i]], s.pos);
    }
    if (nl == n && nr == n) { /* the plane separates nothing */
        make_leaf(c, node, prims, n, owned, cell);
        return;
    }
    /* Subtrees run as tasks only above TASK_MIN_PRIMS, so a stack buffer
     * is only ever read by this thread, while this frame is alive. */
    uint32_t stack_ids[2 * STACK_PRIMS];
    const int heap = nl + nr > 2 * STACK_PRIMS;
    uint32_t *left = heap ? sg_alloc_array(nl ? nl : 1, sizeof *left) : stack_ids;
    uint32_t *right = heap ? sg_alloc_array(nr ? nr : 1, sizeof *right) : stack_ids + nl;
    bnode *cl = node_alloc(c), *cr = node_alloc(c);
    if (!left || !right || !cl || !cr) {
        set_failed(c);
        if (heap) {
            sg_free(left);
            sg_free(right);
        }
        make_leaf(c, node, prims, n, owned, cell);
        return;
    }
    size_t il = 0, ir = 0;
    for (size_t i = 0; i < n; ++i) {
        uint32_t p = prims[i];
        if (goes_left(plo[p], phi[p], s.pos))
            left[il++] = p;
        if (goes_right(plo[p], phi[p], s.pos))
            right[ir++] = p;
    }
    assert(il == nl && ir == nr);
    if (owned)
        sg_free(prims);
    node->axis = (uint8_t)s.axis;
    node->u.inner.split = s.pos;
    node->u.inner.child[0] = cl;
    node->u.inner.child[1] = cr;
    sg_aabb lcell = cell, rcell = cell;
    set_axis(&lcell.hi, s.axis, s.pos);
    set_axis(&rcell.lo, s.axis, s.pos);
    if (n >= TASK_MIN_PRIMS) {
        assert(heap);
#pragma omp task default(shared) firstprivate(cl, left, nl, lcell, depth)
        build_rec(c, cl, left, nl, 1, lcell, depth + 1);
#pragma omp task default(shared) firstprivate(cr, right, nr, rcell, depth)
        build_rec(c, cr, right, nr, 1, rcell, depth + 1);
#pragma omp taskwait
    } else {
        build_rec(c, cl, left, nl, heap, lcell, depth + 1);
        build_rec(c, cr, right, nr, heap, rcell, depth + 1);
    }
    /* §3.4.3, bottom-up as the recursion returns: a split whose two
     * children are both empty becomes an empty leaf. */
    if ((c->d->flags & SG_KD_BUILD_COLLAPSE) && is_empty_leaf(cl) && is_empty_leaf(cr)) {
        node_release(c, cl);
        node_release(c, cr);
        node->axis = 3;
        node->u.leaf.prims = NULL;
        node->u.leaf.bounds = cell;
        node->count = 0;
    }
}

static void count_tree(const bnode *b, int depth, size_t *nodes, size_t *leaves, size_t *refs, int *max_depth)
{
    ++*nodes;
    if (depth > *max_depth)
        *max_depth = depth;
    if (b->axis == 3) {
        ++*leaves;
        *refs += b->count;
        return;
    }
    count_tree(b->u.inner.child[0], depth + 1, nodes, leaves, refs, max_depth);
    count_tree(b->u.inner.child[1], depth + 1, nodes, leaves, refs, max_depth);
}

typedef struct flat_ctx {
    sg_kdtree *t;
    size_t next_node, next_leaf, next_ref;
} flat_ctx;

static void flatten(flat_ctx *f, const bnode *b, size_t at)
{
    sg_kdtree *t = f->t;
    if (b->axis == 3) {
        size_t l = f->next_leaf++;
        t->leaf_first[l] = (uint32_t)f->next_ref;
        if (b->count)
            memcpy(t->refs + f->next_ref, b->u.leaf.prims, b->count * sizeof *b->u.leaf.prims);
        else
            t->empty_leaf_count++;
        f->next_ref += b->count;
        t->nodes[at].word = ((uint32_t)l << 2) | 3u;
        t->nodes[at].split = 0.0f;
        t->leaf_bounds[l] = b->u.leaf.bounds;
        return;
    }
    size_t child = f->next_node;
    f->next_node += 2;
    t->nodes[at].word = ((uint32_t)child << 2) | (uint32_t)b->axis;
    t->nodes[at].split = b->u.inner.split;
    flatten(f, b->u.inner.child[0], child);
    flatten(f, b->u.inner.child[1], child + 1);
}

sg_status sg_kdtree_build(const sg_kdtree_desc *d, sg_kdtree *out, sg_error *err)
{
    assert(d && out);
    if (d->count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "kd-tree: no primitives");
    if (d->count > (size_t)UINT32_MAX / 4)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "kd-tree: %zu primitives exceed the 2^30 limit", d->count);

    build_ctx c = {.d = d,
                   .cost_trav = d->cost_traversal > 0 ? d->cost_traversal : 1.0f,
                   .cost_isec = d->cost_intersect > 0 ? d->cost_intersect : 1.5f,
                   .max_depth = d->max_depth > 0 ? d->max_depth : DEFAULT_MAX_DEPTH};
    sg_status st = SG_OK;
    sg_kdtree t = {0};

    sg_aabb bounds = sg_aabb_empty();
    for (size_t i = 0; i < d->count; ++i) {
        sg_vec3 lo = sg_v3(d->lo[0][i], d->lo[1][i], d->lo[2][i]), hi = sg_v3(d->hi[0][i], d->hi[1][i], d->hi[2][i]);
        if (!sg_v3_isfinite(lo) || !sg_v3_isfinite(hi) || lo.x > hi.x || lo.y > hi.y || lo.z > hi.z)
            return sg_error_set(err, SG_ERR_INVALID_ARG, "kd-tree: primitive %zu: box is not finite or inverted", i);
        bounds = sg_aabb_grow(bounds, lo);
        bounds = sg_aabb_grow(bounds, hi);
    }

    /* The parallel region below has at most omp_get_max_threads() threads. */
    const int threads = omp_get_max_threads();
    c.arena = sg_arena_set_create(threads);
    c.free_nodes = sg_calloc_array((size_t)threads, sizeof *c.free_nodes);
    uint32_t *all = sg_alloc_array(d->count, sizeof *all);
    if (!all || !c.arena || !c.free_nodes) {
        sg_free(all);
        sg_arena_set_destroy(c.arena);
        sg_free(c.free_nodes);
        return sg_error_set(err, SG_ERR_NOMEM, "kd-tree: out of memory for %zu primitives", d->count);
    }
    for (size_t i = 0; i < d->count; ++i)
        all[i] = (uint32_t)i;

    /* Every arena access, the root's included, happens inside the region,
     * where thread numbers are below `threads`. */
    bnode *root = NULL;
#pragma omp parallel num_threads(threads)
#pragma omp single
    {
        root = node_alloc(&c);
        if (root)
            build_rec(&c, root, all, d->count, 1, bounds, 0);
        else
            sg_free(all);
    }

    if (c.failed) {
        st = sg_error_set(err, SG_ERR_NOMEM, "kd-tree: out of memory during build (%zu primitives)", d->count);
        goto cleanup;
    }

    size_t nodes = 0, leaves = 0, refs = 0;
    int depth = 0;
    count_tree(root, 0, &nodes, &leaves, &refs, &depth);
    if (refs > UINT32_MAX || nodes > UINT32_MAX / 4) {
        st = sg_error_set(err, SG_ERR_UNSUPPORTED, "kd-tree: %zu references exceed 32-bit indices", refs);
        goto cleanup;
    }
    t.nodes = sg_alloc_array(nodes, sizeof *t.nodes);
    t.leaf_first = sg_alloc_array(leaves + 1, sizeof *t.leaf_first);
    t.refs = sg_alloc_array(refs ? refs : 1, sizeof *t.refs);
    t.leaf_bounds = sg_alloc_array(leaves, sizeof *t.leaf_bounds);
    if (!t.nodes || !t.leaf_first || !t.refs || !t.leaf_bounds) {
        sg_kdtree_free(&t);
        st = sg_error_set(err, SG_ERR_NOMEM, "kd-tree: out of memory for %zu nodes", nodes);
        goto cleanup;
    }
    t.node_count = nodes;
    t.leaf_count = leaves;
    t.ref_count = refs;
    t.bounds = bounds;
    t.depth = depth;
    flat_ctx f = {.t = &t, .next_node = 1};
    flatten(&f, root, 0);
    t.leaf_first[leaves] = (uint32_t)refs;
    assert(f.next_node == nodes && f.next_leaf == leaves && f.next_ref == refs);
    *out = t;

cleanup:
    sg_arena_set_destroy(c.arena);
    sg_free(c.free_nodes);
    return st;
}

void sg_kdtree_free(sg_kdtree *t)
{
    if (!t)
        return;
    sg_free(t->nodes);
    sg_free(t->leaf_first);
    sg_free(t->refs);
    sg_free(t->leaf_bounds);
    memset(t, 0, sizeof *t);
}

size_t sg_kdtree_memory(const sg_kdtree *t)
{
    return t->node_count * sizeof *t->nodes + (t->leaf_count + 1) * sizeof *t->leaf_first +
           t->ref_count * sizeof *t->refs + t->leaf_count * sizeof *t->leaf_bounds;
}
