/* knn.c — exact k-nearest-neighbour search with a balanced kd-tree.
 *
 * Job: answer kNN and radius queries for point-set preparation (radii,
 * normals) and the surface models. Friedman, Bentley & Finkel 1977 for the
 * tree; Arya & Mount 1993 for the incremental per-axis distance bound.
 *
 * The idea in five lines: the points are copied into one array and sorted
 * into a perfectly balanced implicit tree: node n splits its range
 * [lo,hi) at mid = lo + (hi-lo)/2 on the widest axis of its points, with
 * nth-element selection, children 2n+1 / 2n+2; all leaves sit at the same
 * depth and hold at most leaf_size points. A query descends to the near
 * child first and visits the far child only when the box bound can still
 * beat the current k-th candidate.
 *
 * Invariants:
 *  1. for internal node n with split s on axis a, every point in its left
 *     range has p[a] <= s and every point in its right range has p[a] >= s
 *     (s is the coordinate of the element at mid);
 *  2. a leaf range holds at most leaf_size points, and depth is the least
 *     that achieves it: ceil(count / 2^depth) <= leaf_size;
 *  3. the lower bound used for pruning is computed from float offsets
 *     off[a] = q[a] - s with the same formula as point distances; float
 *     subtraction and squaring are monotone, so the bound never exceeds
 *     the computed distance of a point in the pruned cell. Pruning only
 *     when bound > worst (strictly) therefore keeps the result exact,
 *     including ties, which are broken by index: the answer is the unique
 *     first k in (d2, index) order whatever the tree shape or thread count.
 */
#include "points/knn.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "core/alloc.h"

/* Default leaf capacity: 8 keeps the tree shallow enough that node visits
 * and leaf scans cost about the same for k = 8..16. */
enum { DEFAULT_LEAF_SIZE = 8 };
/* Ranges above this size are built as separate OpenMP tasks; below it the
 * task overhead outweighs the work. */
enum { TASK_CUTOFF = 32768 };
/* Selection ranges at or below this size finish by insertion sort. */
enum { SELECT_SMALL = 16 };

struct sg_knn {
    size_t count;       /* number of points                                  */
    unsigned depth;     /* internal levels; leaves are at this depth         */
    float *split;       /* 2^depth - 1 split coordinates (invariant 1)       */
    uint8_t *axis;      /* 2^depth - 1 split axes (0,1,2)                    */
    float *px, *py, *pz;/* coordinates in tree order                         */
    uint32_t *id;       /* tree slot -> caller's point index                 */
};

/* ---- build ---------------------------------------------------------- */

typedef struct item {
    float p[3];  /* coordinates          */
    uint32_t id; /* caller's point index */
} item;

/* (coordinate on axis, index) is a strict total order: ids are unique. */
static inline int item_less(const item *a, const item *b, int axis)
{
    return a->p[axis] < b->p[axis] || (a->p[axis] == b->p[axis] && a->id < b->id);
}

static int cmp_axis(const item *a, const item *b, int axis)
{
    return item_less(a, b, axis) ? -1 : (item_less(b, a, axis) ? 1 : 0);
}
static int cmp_x(const void *a, const void *b) { return cmp_axis(a, b, 0); }
static int cmp_y(const void *a, const void *b) { return cmp_axis(a, b, 1); }
static int cmp_z(const void *a, const void *b) { return cmp_axis(a, b, 2); }

static inline void item_swap(item *a, item *b)
{
    item t = *a;
    *a = *b;
    *b = t;
}

static void insertion_sort(item *a, size_t n, int axis)
{
    for (size_t i = 1; i < n; ++i) {
        item v = a[i];
        size_t j = i;
        while (j > 0 && item_less(&v, &a[j - 1], axis)) {
            a[j] = a[j - 1];
            --j;
        }
        a[j] = v;
    }
}

/* Rearranges a[0..n) so that a[nth] is the element of rank nth in
 * (p[axis], id) order, smaller ones before it and larger ones after.
 * Quickselect with median-of-three and Hoare partition; after a budget of
 * 2 log2(n) + 16 rounds it sorts the rest, so the worst case stays
 * O(n log n) on adversarial orders. */
static void select_nth(item *a, size_t n, size_t nth, int axis)
{
    size_t lo = 0, hi = n;  /* the element of rank nth lies in [lo,hi) */
    unsigned budget = 16;
    for (size_t m = n; m > 1; m >>= 1)
        budget += 2;
    while (hi - lo > SELECT_SMALL) {
        if (budget-- == 0) {
            static int (*const cmp[3])(const void *, const void *) = {cmp_x, cmp_y, cmp_z};
            qsort(a + lo, hi - lo, sizeof(item), cmp[axis]);
            return;
        }
        size_t mid = lo + (hi - lo) / 2;
        if (item_less(&a[mid], &a[lo], axis))
            item_swap(&a[mid], &a[lo]);
        if (item_less(&a[hi - 1], &a[lo], axis))
            item_swap(&a[hi - 1], &a[lo]);
        if (item_less(&a[hi - 1], &a[mid], axis))
            item_swap(&a[hi - 1], &a[mid]);
        item pivot = a[mid];
        /* Hoare: a[lo] <= pivot <= a[hi-1] act as sentinels. */
        size_t i = lo, j = hi - 1;
        for (;;) {
            while (item_less(&a[i], &pivot, axis))
                ++i;
            while (item_less(&pivot, &a[j], axis))
                --j;
            if (i >= j)
                break;
            item_swap(&a[i], &a[j]);
            ++i;
            --j;
        }
        /* Now [lo, j] <= pivot <= [j+1, hi). The three samples are distinct
         * items, so a[lo] < pivot < a[hi-1] strictly: j stops below hi-1 and
         * never below lo, and the range shrinks every round. */
        if (nth <= j)
            hi = j + 1;
        else
            lo = j + 1;
    }
    insertion_sort(a + lo, hi - lo, axis);
}

static void build(sg_knn *t, item *a, size_t node, size_t lo, size_t hi, unsigned level)
{
    if (level == t->depth)
        return;
    float lo3[3] = {INFINITY, INFINITY, INFINITY}, hi3[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = lo; i < hi; ++i)
        for (int c = 0; c < 3; ++c) {
            float v = a[i].p[c];
            lo3[c] = v < lo3[c] ? v : lo3[c];
            hi3[c] = v > hi3[c] ? v : hi3[c];
        }
    int axis = 0;
    for (int c = 1; c < 3; ++c)
        if (hi3[c] - lo3[c] > hi3[axis] - lo3[axis])
            axis = c;
    size_t mid = lo + (hi - lo) / 2;
    select_nth(a + lo, hi - lo, mid - lo, axis);
    t->split[node] = a[mid].p[axis];
    t->axis[node] = (uint8_t)axis;
    if (hi - lo > TASK_CUTOFF) {
#pragma omp task default(none) firstprivate(t, a, node, lo, mid, level)
        build(t, a, 2 * node + 1, lo, mid, level + 1);
        build(t, a, 2 * node + 2, mid, hi, level + 1);
#pragma omp taskwait
    } else {
        build(t, a, 2 * node + 1, lo, mid, level + 1);
        build(t, a, 2 * node + 2, mid, hi, level + 1);
    }
}

void sg_knn_destroy(sg_knn *t)
{
    if (!t)
        return;
    sg_free(t->split);
    sg_free(t->axis);
    sg_free(t->px);
    sg_free(t->py);
    sg_free(t->pz);
    sg_free(t->id);
    sg_free(t);
}

sg_status sg_knn_create(const sg_knn_desc *d, sg_knn **out, sg_error *err)
{
    if (!d || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_knn_create: NULL desc or out");
    size_t n = d->count;
    if (n >= UINT32_MAX)
        return sg_error_set(err, SG_ERR_UNSUPPORTED,
                            "knn: %zu points; at most %u are supported", n, UINT32_MAX - 1u);
    if (n > 0 && (!d->px || !d->py || !d->pz))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "knn: %zu points but a coordinate array is NULL", n);
    for (size_t i = 0; i < n; ++i)
        if (!isfinite(d->px[i]) || !isfinite(d->py[i]) || !isfinite(d->pz[i]))
            return sg_error_set(err, SG_ERR_INVALID_ARG,
                                "knn: point %zu: position (%g, %g, %g) is not finite", i,
                                (double)d->px[i], (double)d->py[i], (double)d->pz[i]);
    size_t leaf = d->leaf_size ? d->leaf_size : DEFAULT_LEAF_SIZE;
    unsigned depth = 0;
    while (((n + ((size_t)1 << depth) - 1) >> depth) > leaf)
        ++depth;
    size_t nodes = ((size_t)1 << depth) - 1;

    sg_status st = SG_OK;
    item *items = NULL;
    sg_knn *t = sg_calloc_array(1, sizeof *t);
    if (!t)
        goto nomem;
    t->count = n;
    t->depth = depth;
    t->split = sg_alloc_array(nodes, sizeof(float));
    t->axis = sg_alloc_array(nodes, sizeof(uint8_t));
    t->px = sg_alloc_array(n, sizeof(float));
    t->py = sg_alloc_array(n, sizeof(float));
    t->pz = sg_alloc_array(n, sizeof(float));
    t->id = sg_alloc_array(n, sizeof(uint32_t));
    items = sg_alloc_array(n, sizeof(item));
    if (!t->split || !t->axis || !t->px || !t->py || !t->pz || !t->id || !items)
        goto nomem;

#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
        items[i].p[0] = d->px[i];
        items[i].p[1] = d->py[i];
        items[i].p[2] = d->pz[i];
        items[i].id = (uint32_t)i;
    }
#pragma omp parallel
#pragma omp single
    build(t, items, 0, 0, n, 0);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
        t->px[i] = items[i].p[0];
        t->py[i] = items[i].p[1];
        t->pz[i] = items[i].p[2];
        t->id[i] = items[i].id;
    }
    sg_free(items);
    *out = t;
    return SG_OK;

nomem:
    st = sg_error_set(err, SG_ERR_NOMEM, "knn: cannot allocate a tree over %zu points", n);
    sg_free(items);
    sg_knn_destroy(t);
    return st;
}

size_t sg_knn_count(const sg_knn *t) { return t ? t->count : 0; }

const uint32_t *sg_knn_order(const sg_knn *t) { return t->id; }

/* ---- queries -------------------------------------------------------- */

/* The one distance formula (invariant 3). */
static inline float dist2(float dx, float dy, float dz) { return dx * dx + dy * dy + dz * dz; }

typedef struct knn_query {
    float q[3];       /* query position                                   */
    uint32_t exclude; /* index to skip, or SG_KNN_NONE                     */
    size_t k, n;      /* wanted, found so far                              */
    uint32_t *idx;    /* n candidates sorted by (d2, index)                */
    float *d2;
    float worst;      /* d2[k-1] once n == k, else INFINITY                */
} knn_query;

static inline void knn_insert(knn_query *s, uint32_t id, float d)
{
    size_t pos;
    if (s->n == s->k) {
        if (!(d < s->worst || (d == s->worst && id < s->idx[s->k - 1])))
            return;
        pos = s->k - 1;
    } else {
        pos = s->n++;
    }
    while (pos > 0 && (s->d2[pos - 1] > d || (s->d2[pos - 1] == d && s->idx[pos - 1] > id))) {
        s->d2[pos] = s->d2[pos - 1];
        s->idx[pos] = s->idx[pos - 1];
        --pos;
    }
    s->d2[pos] = d;
    s->idx[pos] = id;
    if (s->n == s->k)
        s->worst = s->d2[s->k - 1];
}

static void knn_search(const sg_knn *t, knn_query *s, size_t node, size_t lo, size_t hi,
                       unsigned level, float off[3])
{
    if (level == t->depth) {
        for (size_t j = lo; j < hi; ++j) {
            float d = dist2(s->q[0] - t->px[j], s->q[1] - t->py[j], s->q[2] - t->pz[j]);
            if (d <= s->worst && t->id[j] != s->exclude)
                knn_insert(s, t->id[j], d);
        }
        return;
    }
    int ax = t->axis[node];
    float diff = s->q[ax] - t->split[node];
    size_t mid = lo + (hi - lo) / 2;
    if (diff < 0.0f)
        knn_search(t, s, 2 * node + 1, lo, mid, level + 1, off);
    else
        knn_search(t, s, 2 * node + 2, mid, hi, level + 1, off);
    float old = off[ax];
    off[ax] = diff;
    if (dist2(off[0], off[1], off[2]) <= s->worst) {
        if (diff < 0.0f)
            knn_search(t, s, 2 * node + 2, mid, hi, level + 1, off);
        else
            knn_search(t, s, 2 * node + 1, lo, mid, level + 1, off);
    }
    off[ax] = old;
}

static size_t knn_run(const sg_knn *t, float qx, float qy, float qz, size_t k, uint32_t exclude,
                      uint32_t *idx, float *d2)
{
    if (k == 0 || t->count == 0)
        return 0;
    knn_query s = {{qx, qy, qz}, exclude, k, 0, idx, d2, INFINITY};
    float off[3] = {0.0f, 0.0f, 0.0f};
    knn_search(t, &s, 0, 0, t->count, 0, off);
    return s.n;
}

size_t sg_knn_query(const sg_knn *t, sg_vec3 q, size_t k, uint32_t exclude, uint32_t *idx, float *d2)
{
    assert(t && (k == 0 || (idx && d2)));
    return knn_run(t, q.x, q.y, q.z, k, exclude, idx, d2);
}

typedef struct radius_query {
    float q[3];       /* query position             */
    uint32_t exclude; /* index to skip              */
    float r2;         /* squared radius             */
    size_t total;     /* points found so far        */
    size_t cap;       /* room in idx/d2             */
    uint32_t *idx;
    float *d2;
} radius_query;

static void radius_search(const sg_knn *t, radius_query *s, size_t node, size_t lo, size_t hi,
                          unsigned level, float off[3])
{
    if (level == t->depth) {
        for (size_t j = lo; j < hi; ++j) {
            float d = dist2(s->q[0] - t->px[j], s->q[1] - t->py[j], s->q[2] - t->pz[j]);
            if (d <= s->r2 && t->id[j] != s->exclude) {
                if (s->total < s->cap) {
                    s->idx[s->total] = t->id[j];
                    s->d2[s->total] = d;
                }
                s->total++;
            }
        }
        return;
    }
    int ax = t->axis[node];
    float diff = s->q[ax] - t->split[node];
    size_t mid = lo + (hi - lo) / 2;
    if (diff < 0.0f)
        radius_search(t, s, 2 * node + 1, lo, mid, level + 1, off);
    else
        radius_search(t, s, 2 * node + 2, mid, hi, level + 1, off);
    float old = off[ax];
    off[ax] = diff;
    if (dist2(off[0], off[1], off[2]) <= s->r2) {
        if (diff < 0.0f)
            radius_search(t, s, 2 * node + 2, mid, hi, level + 1, off);
        else
            radius_search(t, s, 2 * node + 1, lo, mid, level + 1, off);
    }
    off[ax] = old;
}

static inline int pair_less(const float *d2, const uint32_t *idx, size_t a, size_t b)
{
    return d2[a] < d2[b] || (d2[a] == d2[b] && idx[a] < idx[b]);
}

static void pair_sift(float *d2, uint32_t *idx, size_t root, size_t n)
{
    for (;;) {
        size_t c = 2 * root + 1;
        if (c >= n)
            return;
        if (c + 1 < n && pair_less(d2, idx, c, c + 1))
            ++c;
        if (!pair_less(d2, idx, root, c))
            return;
        float td = d2[root]; d2[root] = d2[c]; d2[c] = td;
        uint32_t ti = idx[root]; idx[root] = idx[c]; idx[c] = ti;
        root = c;
    }
}

/* Heapsort of the parallel arrays by (d2, idx): in place, O(n log n). */
static void pair_sort(float *d2, uint32_t *idx, size_t n)
{
    for (size_t i = n / 2; i-- > 0;)
        pair_sift(d2, idx, i, n);
    for (size_t end = n; end-- > 1;) {
        float td = d2[0]; d2[0] = d2[end]; d2[end] = td;
        uint32_t ti = idx[0]; idx[0] = idx[end]; idx[end] = ti;
        pair_sift(d2, idx, 0, end);
    }
}

size_t sg_knn_radius(const sg_knn *t, sg_vec3 q, float r, uint32_t exclude, uint32_t *idx,
                     float *d2, size_t cap)
{
    assert(t && (cap == 0 || (idx && d2)));
    if (t->count == 0 || !(r >= 0.0f))
        return 0;
    radius_query s = {{q.x, q.y, q.z}, exclude, r * r, 0, cap, idx, d2};
    float off[3] = {0.0f, 0.0f, 0.0f};
    radius_search(t, &s, 0, 0, t->count, 0, off);
    if (s.total <= cap)
        pair_sort(d2, idx, s.total);
    return s.total;
}

/* ---- batch ---------------------------------------------------------- */

/* For every tree slot (spatially coherent order) query its k nearest,
 * excluding itself; write the row of its caller index into idx/d2 (each
 * may be NULL, then per-thread scratch holds it) and/or the k-th distance
 * into d2k. */
static sg_status knn_batch(const sg_knn *t, size_t k, uint32_t *idx, float *d2, float *d2k,
                           sg_error *err)
{
    size_t n = t->count;
    if (n == 0 || k == 0) {
        if (d2k)
            for (size_t i = 0; i < n; ++i)
                d2k[i] = k == 0 ? 0.0f : INFINITY;
        return SG_OK;
    }
    size_t rows;
    if (!sg_mul_size(n, k, &rows))
        return sg_error_set(err, SG_ERR_NOMEM, "knn: %zu points x %zu neighbours overflows", n, k);
    int threads = omp_get_max_threads();
    size_t scratch_n; /* per-thread rows of scratch */
    if (!sg_mul_size((size_t)threads, k, &scratch_n))
        return sg_error_set(err, SG_ERR_NOMEM, "knn: scratch size overflows");
    uint32_t *sidx = idx ? NULL : sg_alloc_array(scratch_n, sizeof(uint32_t));
    float *sd2 = d2 ? NULL : sg_alloc_array(scratch_n, sizeof(float));
    if ((!idx && !sidx) || (!d2 && !sd2)) {
        sg_free(sidx);
        sg_free(sd2);
        return sg_error_set(err, SG_ERR_NOMEM, "knn: cannot allocate query scratch (%zu)", scratch_n);
    }
#pragma omp parallel num_threads(threads)
    {
        size_t tid = (size_t)omp_get_thread_num();
#pragma omp for schedule(dynamic, 512)
        for (size_t j = 0; j < n; ++j) {
            size_t row = t->id[j];
            uint32_t *ri = idx ? idx + row * k : sidx + tid * k;
            float *rd = d2 ? d2 + row * k : sd2 + tid * k;
            size_t found = knn_run(t, t->px[j], t->py[j], t->pz[j], k, t->id[j], ri, rd);
            for (size_t m = found; m < k; ++m) {
                ri[m] = SG_KNN_NONE;
                rd[m] = INFINITY;
            }
            if (d2k)
                d2k[row] = rd[k - 1];
        }
    }
    sg_free(sidx);
    sg_free(sd2);
    return SG_OK;
}

sg_status sg_knn_query_all(const sg_knn *t, size_t k, uint32_t *idx, float *d2, sg_error *err)
{
    if (!t || (!idx && k > 0 && t->count > 0))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_knn_query_all: NULL tree or idx");
    return knn_batch(t, k, idx, d2, NULL, err);
}

sg_status sg_knn_kth_all(const sg_knn *t, size_t k, float *d2k, sg_error *err)
{
    if (!t || (!d2k && t->count > 0))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_knn_kth_all: NULL tree or output");
    return knn_batch(t, k, NULL, NULL, d2k, err);
}
