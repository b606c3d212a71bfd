/* radius.c — splat radius from the distance to the k-th nearest neighbour.
 *
 * Job: one batch kNN pass (points/knn.h) gives every point the squared
 * distance to its k-th nearest other point; radius = scale * sqrt of it.
 * The k-th-neighbour rule is the common spacing estimate for splat models
 * (e.g. Kashyap 2010, ch. 3: radii large enough for neighbouring disks to
 * overlap into a hole-free surface).
 *
 * Invariants:
 *  1. on SG_OK every radius is finite and > 0 (the pointset's invariant 2);
 *  2. the result is a pure function of positions, k, scale (and with
 *     desc.layers normals):
 *     kNN results are unique (ties by index), the duplicate pass runs
 *     sequentially in sorted-position order and the same-layer pass writes
 *     each point's own entry only, so the thread count does not matter;
 *  3. ps->radius is written only after every fallible step succeeded.
 * Duplicate clusters (k-th distance 0) are grouped by exact position and
 * resolved with one larger query per cluster, so a cluster of m points
 * costs O(m log N) once, not m times.
 *  4. no radius exceeds cap x the median radius (radius.h, stray points);
 *     the median is the exact middle order statistic (the lower of the two
 *     middle values for an even count), found by quickselect on a copy.
 */
#include "points/radius.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"

enum { DEFAULT_K = 8 };
/* Fallback radius for a cluster with no point at positive distance, as a
 * fraction of the bounding-box diagonal (DESIGN.md: epsilons relative to
 * the scene size). Reached only through float underflow of distances. */
#define FALLBACK_DIAG_FRACTION 1e-3f

typedef struct dup_point {
    float p[3];  /* position    */
    uint32_t id; /* point index */
} dup_point;

static int dup_cmp(const void *va, const void *vb)
{
    const dup_point *a = va, *b = vb;
    for (int c = 0; c < 3; ++c) {
        if (a->p[c] < b->p[c])
            return -1;
        if (a->p[c] > b->p[c])
            return 1;
    }
    return (a->id > b->id) - (a->id < b->id);
}

static int same_position(const dup_point *a, const dup_point *b)
{
    return a->p[0] == b->p[0] && a->p[1] == b->p[1] && a->p[2] == b->p[2];
}

/* The k-th smallest of v[0..n) (0-based), reordering v: quickselect with
 * a three-way partition, so runs of equal radii (grids) cannot make it
 * quadratic. The values are finite (checked before). */
static float select_kth(float *v, size_t n, size_t k)
{
    size_t lo = 0, hi = n; /* the answer lies in v[lo, hi) */
    while (hi - lo > 1) {
        float pivot = v[lo + (hi - lo) / 2];
        size_t lt = lo, i = lo, gt = hi;
        while (i < gt) {
            float x = v[i];
            if (x < pivot) {
                v[i++] = v[lt];
                v[lt++] = x;
            } else if (x > pivot) {
                v[i] = v[--gt];
                v[gt] = x;
            } else {
                ++i;
            }
        }
        if (k < lt)
            hi = lt;
        else if (k >= gt)
            lo = gt;
        else
            return pivot;
    }
    return v[k];
}

/* The k-th distance within the point's own layer (issue 12). On a thin
 * wall or part sampled on both sides, the k nearest points of a splat
 * include the other side's (normals opposed, more than 90 degrees from its
 * own): counted, they shrink the radius below the spacing of the splat's
 * own layer, which then has holes that let rays through the wall (the
 * stability map's thin_wall room: walls 0.77 r thick, where r would be
 * the kNN radius without this, kept gaps 1.6 spacings wide). So where at
 * least a third of the k nearest have opposed normals, more than 120
 * degrees from its own, and at least a third do not (on a wall about
 * half do, at 180 degrees; noisy normals n + 0.4 N(0, I) must not count:
 * with 90 degrees, one opposed neighbour enough, and outliers, whose
 * neighbours all look opposed, included, their radii grew uneven and the
 * noisy sphere's flipped pixels rose from 0.15% to 1.2%), d2k is the k-th
 * distance among the
 * points whose normals lie within 120 degrees of the splat's own (from the
 * 3k nearest; when fewer than k of them are there, the 3k-th distance).
 * Points without a normal, and the k nearest of every other point, are as
 * before: on smooth surfaces nothing changes. Only raises d2k. */
enum { LAYER_QUERY = 3, MAX_K = 64 };
/* Normals more than 120 degrees apart belong to opposed layers. */
static const float OPPOSED_COS = -0.5f;
static sg_status same_layer_distances(const sg_pointset *ps, const sg_knn *tree, size_t k, float *d2k,
                                      sg_error *err)
{
    size_t n = ps->count;
    if (!ps->nx || k > MAX_K)
        return SG_OK;
    int any = 0;
    for (size_t i = 0; i < n && !any; ++i)
        any = ps->nx[i] != 0.0f || ps->ny[i] != 0.0f || ps->nz[i] != 0.0f;
    if (!any)
        return SG_OK;
    (void)err;
    const uint32_t *order = sg_knn_order(tree);
#pragma omp parallel for schedule(dynamic, 1024)
    for (size_t oi = 0; oi < n; ++oi) {
        uint32_t i = order[oi];
        uint32_t idx[LAYER_QUERY * MAX_K];
        float d2[LAYER_QUERY * MAX_K];
        const sg_vec3 p = sg_v3(ps->px[i], ps->py[i], ps->pz[i]);
        const float ni[3] = {ps->nx[i], ps->ny[i], ps->nz[i]};
        if (ni[0] == 0.0f && ni[1] == 0.0f && ni[2] == 0.0f)
            continue;
        size_t found = sg_knn_query(tree, p, k, i, idx, d2), opposed = 0;
        for (size_t j = 0; j < found; ++j)
            opposed += ps->nx[idx[j]] * ni[0] + ps->ny[idx[j]] * ni[1] + ps->nz[idx[j]] * ni[2] < OPPOSED_COS;
        /* A wall: both sides among the k nearest. A point whose own
         * normal is an outlier sees nearly all its neighbours "opposed"
         * and is not one (its layer would be itself alone). */
        if (3 * opposed < k || 3 * (found - opposed) < k)
            continue;
        found = sg_knn_query(tree, p, LAYER_QUERY * k, i, idx, d2);
        float r2 = found ? d2[found - 1] : d2k[i];
        for (size_t j = 0, same = 0; j < found; ++j)
            if (ps->nx[idx[j]] * ni[0] + ps->ny[idx[j]] * ni[1] + ps->nz[idx[j]] * ni[2] >= OPPOSED_COS && ++same == k) {
                r2 = d2[j];
                break;
            }
        if (r2 > d2k[i])
            d2k[i] = r2;
    }
    return SG_OK;
}

sg_status sg_points_estimate_radii(sg_pointset *ps, const sg_radius_desc *d, sg_error *err)
{
    if (!ps)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "radii: pointset is NULL");
    sg_radius_desc desc = d ? *d : (sg_radius_desc){0};
    size_t k = desc.k ? desc.k : DEFAULT_K;
    float scale = desc.scale != 0.0f ? desc.scale : 1.0f;
    if (!isfinite(scale) || !(scale > 0.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "radii: scale %g is not finite and positive",
                            (double)scale);
    size_t n = ps->count;
    if (n == 0)
        return SG_OK;
    if (n == 1)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "radii: a single point has no neighbour to set its radius from");
    if (desc.knn && sg_knn_count(desc.knn) != n)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "radii: shared kNN tree has %zu points, pointset has %zu",
                            sg_knn_count(desc.knn), n);
    if (k > n - 1)
        k = n - 1;
    float cap = desc.cap == 0.0f ? SG_RADIUS_CAP_DEFAULT : desc.cap;
    if (!(cap < 0.0f) && !(cap >= 1.0f && isfinite(cap)))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "radii: cap %g is not >= 1 (or < 0 for none)", (double)cap);

    sg_status st = SG_OK;
    sg_knn *own = NULL;      /* tree built here when none is shared       */
    float *d2k = NULL;       /* squared k-th distance per point           */
    dup_point *dups = NULL;  /* points whose k-th distance is 0, sorted   */
    uint32_t *qidx = NULL;   /* query scratch for one duplicate cluster   */
    float *qd2 = NULL;
    float *sorted = NULL;    /* copy of the radii for the median          */
    const sg_knn *tree = desc.knn;
    if (!tree) {
        sg_knn_desc kd = {.count = n, .px = ps->px, .py = ps->py, .pz = ps->pz};
        st = sg_knn_create(&kd, &own, err);
        if (st != SG_OK)
            goto done;
        tree = own;
    }
    d2k = sg_alloc_array(n, sizeof(float));
    if (!d2k) {
        st = sg_error_set(err, SG_ERR_NOMEM, "radii: cannot allocate %zu distances", n);
        goto done;
    }
    st = sg_knn_kth_all(tree, k, d2k, err);
    if (st != SG_OK)
        goto done;

    size_t ndup = 0;
    for (size_t i = 0; i < n; ++i)
        ndup += d2k[i] == 0.0f;
    if (ndup > 0) {
        sg_aabb box = sg_pointset_bounds(ps);
        float diag = sg_aabb_diagonal(box);
        if (!(diag > 0.0f)) {
            st = sg_error_set(err, SG_ERR_INVALID_ARG,
                              "radii: all %zu points coincide; no spacing to set radii from", n);
            goto done;
        }
        dups = sg_alloc_array(ndup, sizeof(dup_point));
        if (!dups) {
            st = sg_error_set(err, SG_ERR_NOMEM, "radii: cannot allocate %zu duplicates", ndup);
            goto done;
        }
        size_t m = 0;
        for (size_t i = 0; i < n; ++i)
            if (d2k[i] == 0.0f)
                dups[m++] = (dup_point){{ps->px[i], ps->py[i], ps->pz[i]}, (uint32_t)i};
        qsort(dups, ndup, sizeof(dup_point), dup_cmp);
        size_t maxg = 0; /* largest cluster */
        for (size_t a = 0, b; a < ndup; a = b) {
            for (b = a + 1; b < ndup && same_position(&dups[a], &dups[b]); ++b) {
            }
            maxg = b - a > maxg ? b - a : maxg;
        }
        size_t cap = maxg + k < n ? maxg + k : n;
        qidx = sg_alloc_array(cap, sizeof(uint32_t));
        qd2 = sg_alloc_array(cap, sizeof(float));
        if (!qidx || !qd2) {
            st = sg_error_set(err, SG_ERR_NOMEM, "radii: cannot allocate %zu query slots", cap);
            goto done;
        }
        for (size_t a = 0, b; a < ndup; a = b) {
            for (b = a + 1; b < ndup && same_position(&dups[a], &dups[b]); ++b) {
            }
            size_t want = (b - a) + k < n ? (b - a) + k : n;
            sg_vec3 q = sg_v3(dups[a].p[0], dups[a].p[1], dups[a].p[2]);
            size_t found = sg_knn_query(tree, q, want, SG_KNN_NONE, qidx, qd2);
            float r2 = 0.0f;       /* k-th positive distance, or the last one */
            size_t positive = 0;
            for (size_t j = 0; j < found && positive < k; ++j)
                if (qd2[j] > 0.0f) {
                    r2 = qd2[j];
                    ++positive;
                }
            float fallback = FALLBACK_DIAG_FRACTION * diag / scale;
            for (size_t j = a; j < b; ++j)
                d2k[dups[j].id] = positive > 0 ? r2 : fallback * fallback;
        }
    }
    if (desc.layers && (st = same_layer_distances(ps, tree, k, d2k, err)) != SG_OK)
        goto done;
    for (size_t i = 0; i < n; ++i) {
        float r = scale * sqrtf(d2k[i]);
        if (!isfinite(r) || !(r > 0.0f)) {
            st = sg_error_set(err, SG_ERR_INVALID_ARG,
                              "radii: point %zu: radius %g (scale %g) is not finite and positive",
                              i, (double)r, (double)scale);
            goto done;
        }
        d2k[i] = r;
    }
    /* Invariant 4: the cap. */
    sg_radius_stats rs = {.cap_radius = INFINITY};
    sorted = sg_alloc_array(n, sizeof(float));
    if (!sorted) {
        st = sg_error_set(err, SG_ERR_NOMEM, "radii: cannot allocate %zu radii for the median", n);
        goto done;
    }
    memcpy(sorted, d2k, n * sizeof(float));
    rs.median = select_kth(sorted, n, (n - 1) / 2);
    if (cap > 0.0f)
        rs.cap_radius = cap * rs.median;
    for (size_t i = 0; i < n; ++i) {
        int over = d2k[i] > rs.cap_radius;
        if (over) {
            d2k[i] = rs.cap_radius;
            ++rs.capped;
        }
        if (desc.capped)
            desc.capped[i] = (unsigned char)over;
    }
    memcpy(ps->radius, d2k, n * sizeof(float));
    if (desc.stats)
        *desc.stats = rs;

done:
    sg_free(sorted);
    sg_free(qd2);
    sg_free(qidx);
    sg_free(dups);
    sg_free(d2k);
    sg_knn_destroy(own);
    return st;
}
