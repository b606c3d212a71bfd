/* test_kdtree.c — invariants of the SAH kd-tree (kdtree.h 1-4), its
 * refinements' mechanics and bad input. */
#include "test_support.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "accel/kdtree.h"
#include "core/alloc.h"

enum { N = 3000 };

typedef struct boxes {
    float lo[3][N], hi[3][N];
} boxes;

/* Small random boxes clustered on a wavy sheet (like splats on a surface). */
static void make_boxes(boxes *b, uint64_t seed)
{
    for (int i = 0; i < N; ++i) {
        float x = sg_test_rand01(&seed), z = sg_test_rand01(&seed);
        float y = 0.5f + 0.2f * sinf(6.0f * x) * cosf(5.0f * z);
        float r = 0.01f + 0.03f * sg_test_rand01(&seed);
        float c[3] = {x, y, z};
        for (int a = 0; a < 3; ++a) {
            b->lo[a][i] = c[a] - r;
            b->hi[a][i] = c[a] + r;
        }
    }
}

static sg_kdtree_desc desc_for(const boxes *b, uint32_t flags)
{
    sg_kdtree_desc d = {.count = N, .flags = flags};
    for (int a = 0; a < 3; ++a) {
        d.lo[a] = b->lo[a];
        d.hi[a] = b->hi[a];
    }
    return d;
}

/* Walks the tree, checking that each leaf holds exactly the boxes that
 * overlap its cell with positive volume (plus boxes merely touching it). */
static void check_leaf(const sg_kdtree *t, const boxes *b, uint32_t leaf, sg_aabb cell, size_t *seen_leaves)
{
    ++*seen_leaves;
    uint32_t first = t->leaf_first[leaf], last = t->leaf_first[leaf + 1];
    assert_true(first <= last && last <= t->ref_count);
    static unsigned char in_leaf[N];
    memset(in_leaf, 0, sizeof in_leaf);
    for (uint32_t k = first; k < last; ++k) {
        uint32_t p = t->refs[k];
        assert_true(p < N);
        in_leaf[p] = 1;
        /* no spurious reference: the box reaches the cell */
        assert_true(b->lo[0][p] <= cell.hi.x && b->hi[0][p] >= cell.lo.x);
        assert_true(b->lo[1][p] <= cell.hi.y && b->hi[1][p] >= cell.lo.y);
        assert_true(b->lo[2][p] <= cell.hi.z && b->hi[2][p] >= cell.lo.z);
    }
    for (int p = 0; p < N; ++p) {
        int overlaps = b->lo[0][p] < cell.hi.x && b->hi[0][p] > cell.lo.x && b->lo[1][p] < cell.hi.y &&
                       b->hi[1][p] > cell.lo.y && b->lo[2][p] < cell.hi.z && b->hi[2][p] > cell.lo.z;
        if (overlaps && !in_leaf[p])
            fail_msg("box %d overlaps leaf %u's cell [%g %g %g]-[%g %g %g] but is not in it", p, leaf, cell.lo.x,
                     cell.lo.y, cell.lo.z, cell.hi.x, cell.hi.y, cell.hi.z);
    }
}

static void walk(const sg_kdtree *t, const boxes *b, uint32_t ni, sg_aabb cell, size_t *leaves)
{
    sg_kd_node n = t->nodes[ni];
    if (sg_kd_node_is_leaf(n)) {
        check_leaf(t, b, sg_kd_node_index(n), cell, leaves);
        return;
    }
    int a = sg_kd_node_axis(n);
    uint32_t c = sg_kd_node_index(n);
    assert_true(c > ni && c + 1 < t->node_count); /* invariant 1 */
    float lo = sg_v3_get(cell.lo, a), hi = sg_v3_get(cell.hi, a);
    assert_true(n.split >= lo && n.split <= hi);
    sg_aabb l = cell, r = cell;
    if (a == 0) { l.hi.x = n.split; r.lo.x = n.split; }
    else if (a == 1) { l.hi.y = n.split; r.lo.y = n.split; }
    else { l.hi.z = n.split; r.lo.z = n.split; }
    walk(t, b, c, l, leaves);
    walk(t, b, c + 1, r, leaves);
}

static void check_tree(uint32_t flags)
{
    static boxes b;
    make_boxes(&b, 42);
    sg_kdtree_desc d = desc_for(&b, flags);
    sg_kdtree t;
    sg_error err;
    assert_int_equal(sg_kdtree_build(&d, &t, &err), SG_OK);
    assert_int_equal(t.leaf_first[t.leaf_count], t.ref_count); /* invariant 2 */
    size_t leaves = 0;
    walk(&t, &b, 0, t.bounds, &leaves);
    assert_int_equal(leaves, t.leaf_count);
    assert_true(t.leaf_count > 50); /* 3000 small boxes: the SAH must split */
    sg_kdtree_free(&t);
}

static void test_kdtree_leaves_hold_overlapping_boxes(void **state)
{
    (void)state;
    check_tree(0);
    check_tree(SG_KD_BUILD_ENCOURAGE);
    check_tree(SG_KD_BUILD_COLLAPSE);
    check_tree(SG_KD_BUILD_ENCOURAGE | SG_KD_BUILD_COLLAPSE);
}

/* Invariant 4: the same layout, bit for bit, whatever the thread count. */
static void test_kdtree_deterministic_across_threads(void **state)
{
    (void)state;
    static boxes b;
    make_boxes(&b, 7);
    sg_kdtree_desc d = desc_for(&b, SG_KD_BUILD_ENCOURAGE | SG_KD_BUILD_COLLAPSE);
    sg_kdtree t1, t2;
    int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    assert_int_equal(sg_kdtree_build(&d, &t1, NULL), SG_OK);
    omp_set_num_threads(4);
    assert_int_equal(sg_kdtree_build(&d, &t2, NULL), SG_OK);
    omp_set_num_threads(saved);
    assert_int_equal(t1.node_count, t2.node_count);
    assert_int_equal(t1.ref_count, t2.ref_count);
    assert_memory_equal(t1.nodes, t2.nodes, t1.node_count * sizeof *t1.nodes);
    assert_memory_equal(t1.refs, t2.refs, t1.ref_count * sizeof *t1.refs);
    sg_kdtree_free(&t1);
    sg_kdtree_free(&t2);
}

/* A shrink hook that knows the surface lies in the slab y in [0.45, 0.55]. */
static int shrink_to_slab(void *user, const uint32_t *prims, size_t count, sg_aabb *cell)
{
    (void)user;
    (void)prims;
    (void)count;
    if (cell->hi.y < 0.45f || cell->lo.y > 0.55f)
        return 0;
    cell->lo.y = fmaxf(cell->lo.y, 0.45f);
    cell->hi.y = fminf(cell->hi.y, 0.55f);
    return 1;
}

static int shrink_to_nothing(void *user, const uint32_t *prims, size_t count, sg_aabb *cell)
{
    (void)user; (void)prims; (void)count; (void)cell;
    return 0;
}

/* Leaves outside the slab end up empty; every non-empty leaf keeps a box
 * (leaf_bounds) that lies in the slab and inside its cell. */
static void check_slab(const sg_kdtree *t, uint32_t ni, sg_aabb cell, size_t *nonempty)
{
    sg_kd_node n = t->nodes[ni];
    if (sg_kd_node_is_leaf(n)) {
        uint32_t l = sg_kd_node_index(n);
        if (t->leaf_first[l + 1] > t->leaf_first[l]) {
            ++*nonempty;
            sg_aabb b = t->leaf_bounds[l];
            assert_true(b.lo.y >= 0.45f - 1e-6f && b.hi.y <= 0.55f + 1e-6f);
            assert_true(b.lo.x >= cell.lo.x && b.hi.x <= cell.hi.x && b.lo.z >= cell.lo.z && b.hi.z <= cell.hi.z);
        }
        return;
    }
    int a = sg_kd_node_axis(n);
    uint32_t c = sg_kd_node_index(n);
    sg_aabb l = cell, r = cell;
    if (a == 0) { l.hi.x = n.split; r.lo.x = n.split; }
    else if (a == 1) { l.hi.y = n.split; r.lo.y = n.split; }
    else { l.hi.z = n.split; r.lo.z = n.split; }
    check_slab(t, c, l, nonempty);
    check_slab(t, c + 1, r, nonempty);
}

static void test_kdtree_shrink_hook_cuts_empty_space(void **state)
{
    (void)state;
    static boxes b;
    make_boxes(&b, 9);
    sg_kdtree_desc d = desc_for(&b, 0);
    d.shrink = shrink_to_slab;
    sg_kdtree t;
    assert_int_equal(sg_kdtree_build(&d, &t, NULL), SG_OK);
    size_t nonempty = 0;
    check_slab(&t, 0, t.bounds, &nonempty);
    assert_true(nonempty > 0);
    assert_true(t.empty_leaf_count > 0); /* the cells wholly outside the slab */
    sg_kdtree_free(&t);
}

/* §3.4.3: when every leaf comes out empty, post-collapse folds the whole
 * tree into one empty leaf; without it the empty splits remain. */
static void test_kdtree_collapse_merges_empty_siblings(void **state)
{
    (void)state;
    static boxes b;
    make_boxes(&b, 11);
    sg_kdtree_desc d = desc_for(&b, SG_KD_BUILD_COLLAPSE);
    d.shrink = shrink_to_nothing;
    sg_kdtree t;
    assert_int_equal(sg_kdtree_build(&d, &t, NULL), SG_OK);
    assert_int_equal(t.node_count, 1);
    assert_int_equal(t.ref_count, 0);
    sg_kdtree_free(&t);
    d.flags = 0;
    assert_int_equal(sg_kdtree_build(&d, &t, NULL), SG_OK);
    assert_true(t.node_count > 1);
    assert_int_equal(t.empty_leaf_count, t.leaf_count);
    sg_kdtree_free(&t);
}

/* Number of inner nodes whose two children are both empty leaves. */
static size_t empty_pairs(const sg_kdtree *t, uint32_t ni)
{
    sg_kd_node n = t->nodes[ni];
    if (sg_kd_node_is_leaf(n))
        return 0;
    uint32_t c = sg_kd_node_index(n);
    size_t pairs = 0;
    sg_kd_node l = t->nodes[c], r = t->nodes[c + 1];
    if (sg_kd_node_is_leaf(l) && sg_kd_node_is_leaf(r)) {
        uint32_t a = sg_kd_node_index(l), b = sg_kd_node_index(r);
        pairs += t->leaf_first[a] == t->leaf_first[a + 1] && t->leaf_first[b] == t->leaf_first[b + 1];
    }
    return pairs + empty_pairs(t, c) + empty_pairs(t, c + 1);
}

/* The collapse runs bottom-up during the build: with a shrink hook that
 * empties part of the cells, no split is left with two empty children (and
 * without the flag some are: the check can fail), and the same boxes
 * overlap every leaf either way. */
static void test_kdtree_collapse_leaves_no_empty_pair(void **state)
{
    (void)state;
    static boxes b;
    make_boxes(&b, 13);
    sg_kdtree_desc d = desc_for(&b, SG_KD_BUILD_ENCOURAGE);
    d.shrink = shrink_to_slab;
    sg_kdtree plain, collapsed;
    assert_int_equal(sg_kdtree_build(&d, &plain, NULL), SG_OK);
    d.flags |= SG_KD_BUILD_COLLAPSE;
    assert_int_equal(sg_kdtree_build(&d, &collapsed, NULL), SG_OK);
    assert_true(empty_pairs(&plain, 0) > 0);
    assert_int_equal(empty_pairs(&collapsed, 0), 0);
    assert_true(collapsed.node_count < plain.node_count);
    /* Collapsing only removes empty leaves: the references are the same. */
    assert_int_equal(collapsed.ref_count, plain.ref_count);
    assert_int_equal(collapsed.leaf_count - collapsed.empty_leaf_count, plain.leaf_count - plain.empty_leaf_count);
    sg_kdtree_free(&plain);
    sg_kdtree_free(&collapsed);
}

/* Every allocation of the build fails in turn (arena blocks, partitions,
 * the final arrays): the build returns SG_ERR_NOMEM with *out untouched and
 * nothing leaked, or succeeds with the same tree as without faults. */
static void test_kdtree_allocation_failures(void **state)
{
    (void)state;
    static boxes b;
    make_boxes(&b, 21);
    sg_kdtree_desc d = desc_for(&b, SG_KD_BUILD_ENCOURAGE | SG_KD_BUILD_COLLAPSE);
    d.shrink = shrink_to_slab;
    sg_kdtree good;
    assert_int_equal(sg_kdtree_build(&d, &good, NULL), SG_OK);
    int failures = 0;
    for (long k = 0;; ++k) {
        long live = sg_alloc__live();
        sg_kdtree t;
        memset(&t, 0xAB, sizeof t);
        sg_kdtree before = t;
        sg_error err;
        sg_alloc__fail_after(k);
        sg_status st = sg_kdtree_build(&d, &t, &err);
        long left = sg_alloc__fail_after(-1);
        if (st == SG_OK) {
            assert_int_equal(t.node_count, good.node_count);
            assert_memory_equal(t.nodes, good.nodes, t.node_count * sizeof *t.nodes);
            assert_memory_equal(t.refs, good.refs, t.ref_count * sizeof *t.refs);
            sg_kdtree_free(&t);
            if (left > 0)
                break; /* no fault was reached: every allocation has been failed once */
            continue;
        }
        ++failures;
        assert_int_equal(st, SG_ERR_NOMEM);
        assert_non_null(strstr(err.message, "out of memory"));
        assert_memory_equal(&t, &before, sizeof t);
        assert_int_equal(sg_alloc__live(), live);
    }
    assert_true(failures > 3);
    sg_kdtree_free(&good);
}

static void test_kdtree_rejects_bad_input(void **state)
{
    (void)state;
    static boxes b;
    make_boxes(&b, 1);
    sg_kdtree t;
    memset(&t, 0xAB, sizeof t);
    sg_kdtree before = t;
    sg_error err;
    sg_kdtree_desc d = desc_for(&b, 0);
    d.count = 0;
    assert_int_equal(sg_kdtree_build(&d, &t, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "no primitives"));
    d = desc_for(&b, 0);
    b.hi[1][17] = NAN;
    b.lo[2][5] = INFINITY;
    assert_int_equal(sg_kdtree_build(&d, &t, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "primitive 5: box is not finite"));
    assert_memory_equal(&t, &before, sizeof t); /* untouched on failure */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kdtree_leaves_hold_overlapping_boxes),
        cmocka_unit_test(test_kdtree_deterministic_across_threads),
        cmocka_unit_test(test_kdtree_shrink_hook_cuts_empty_space),
        cmocka_unit_test(test_kdtree_collapse_merges_empty_siblings),
        cmocka_unit_test(test_kdtree_collapse_leaves_no_empty_pair),
        cmocka_unit_test(test_kdtree_allocation_failures),
        cmocka_unit_test(test_kdtree_rejects_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
