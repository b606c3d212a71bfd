/* test_knn.c — exact kNN and radius search against brute force.
 *
 *  1. knn::random_vs_brute      uniform points, queries inside and outside
 *                               the box, k = 1, 8, 33, leaf sizes 1, 8, 64:
 *                               same indices and bit-identical d2.
 *  2. knn::duplicates_vs_brute  3000 points on 40 distinct positions: the
 *                               many equal distances are broken by index.
 *  3. knn::clustered_vs_brute   tight Gaussian clusters, a flat sheet and a
 *                               line (zero-extent axes).
 *  4. knn::batch_matches_single query_all / kth_all equal per-point queries
 *                               with the point itself excluded.
 *  5. knn::threads_identical    query_all on 1 and 2 threads: same bits.
 *  6. knn::few_points           k above the available count fills NONE/INF;
 *                               empty and single-point trees.
 *  7. knn::radius_vs_brute      radius search: count, sorted order, cap.
 *  8. knn::rejects_nan          a NaN coordinate is SG_ERR_INVALID_ARG
 *                               naming the point.
 * Distances are compared exactly: the tree promises the formula
 * dx*dx + dy*dy + dz*dz on d = q - p in float (knn.h), which the brute
 * force below repeats.
 */
#include "test_support.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"
#include "points/knn.h"

typedef struct cloud {
    size_t n;
    float *x, *y, *z;
} cloud;

static cloud cloud_new(size_t n)
{
    cloud c = {n, malloc(n * sizeof(float)), malloc(n * sizeof(float)), malloc(n * sizeof(float))};
    assert_non_null(c.x);
    assert_non_null(c.y);
    assert_non_null(c.z);
    return c;
}

static void cloud_free(cloud *c)
{
    free(c->x);
    free(c->y);
    free(c->z);
}

static sg_knn *tree_of(const cloud *c, unsigned leaf)
{
    sg_knn_desc d = {.count = c->n, .px = c->x, .py = c->y, .pz = c->z, .leaf_size = leaf};
    sg_knn *t = NULL;
    sg_error err;
    sg_status s = sg_knn_create(&d, &t, &err);
    if (s != SG_OK)
        fail_msg("sg_knn_create(%zu points): %s: %s", c->n, sg_status_name(s), err.message);
    return t;
}

typedef struct cand {
    float d2;
    uint32_t id;
} cand;

static int cand_cmp(const void *va, const void *vb)
{
    const cand *a = va, *b = vb;
    if (a->d2 != b->d2)
        return a->d2 < b->d2 ? -1 : 1;
    return (a->id > b->id) - (a->id < b->id);
}

/* All points except `exclude`, sorted by (d2, index); returns how many. */
static size_t brute_sorted(const cloud *c, sg_vec3 q, uint32_t exclude, cand *out)
{
    size_t m = 0;
    for (size_t i = 0; i < c->n; ++i) {
        if (i == exclude)
            continue;
        float dx = q.x - c->x[i], dy = q.y - c->y[i], dz = q.z - c->z[i];
        out[m++] = (cand){dx * dx + dy * dy + dz * dz, (uint32_t)i};
    }
    qsort(out, m, sizeof(cand), cand_cmp);
    return m;
}

/* One query checked against brute force; prints inputs on failure. */
static void check_query(const sg_knn *t, const cloud *c, sg_vec3 q, size_t k, uint32_t exclude,
                        const char *what)
{
    cand *all = malloc(c->n * sizeof(cand));
    uint32_t *idx = malloc(k * sizeof(uint32_t));
    float *d2 = malloc(k * sizeof(float));
    assert_non_null(all);
    assert_non_null(idx);
    assert_non_null(d2);
    size_t m = brute_sorted(c, q, exclude, all);
    size_t want = k < m ? k : m;
    size_t got = sg_knn_query(t, q, k, exclude, idx, d2);
    if (got != want)
        fail_msg("%s: q=(%g,%g,%g) k=%zu: found %zu, want %zu", what, (double)q.x, (double)q.y,
                 (double)q.z, k, got, want);
    for (size_t r = 0; r < want; ++r)
        if (idx[r] != all[r].id || d2[r] != all[r].d2)
            fail_msg("%s: q=(%g,%g,%g) k=%zu exclude=%u rank %zu: got (%u, %.9g), want (%u, %.9g)",
                     what, (double)q.x, (double)q.y, (double)q.z, k, exclude, r, idx[r],
                     (double)d2[r], all[r].id, (double)all[r].d2);
    free(all);
    free(idx);
    free(d2);
}

static void test_knn_random_vs_brute(void **state)
{
    (void)state;
    uint64_t rng = 1;
    cloud c = cloud_new(4000);
    for (size_t i = 0; i < c.n; ++i) {
        c.x[i] = sg_test_rand01(&rng);
        c.y[i] = sg_test_rand01(&rng);
        c.z[i] = sg_test_rand01(&rng);
    }
    static const unsigned leaves[3] = {1, 0, 64};
    static const size_t ks[3] = {1, 8, 33};
    for (int l = 0; l < 3; ++l) {
        sg_knn *t = tree_of(&c, leaves[l]);
        assert_int_equal(sg_knn_count(t), c.n);
        for (int qi = 0; qi < 150; ++qi) {
            /* [-0.5, 1.5)^3: a third of the queries lie outside the box. */
            sg_vec3 q = sg_v3(2.0f * sg_test_rand01(&rng) - 0.5f, 2.0f * sg_test_rand01(&rng) - 0.5f,
                              2.0f * sg_test_rand01(&rng) - 0.5f);
            for (int ki = 0; ki < 3; ++ki)
                check_query(t, &c, q, ks[ki], SG_KNN_NONE, "random");
            uint32_t self = (uint32_t)(qi * 7 % c.n);
            check_query(t, &c, sg_v3(c.x[self], c.y[self], c.z[self]), 8, self, "random self");
        }
        sg_knn_destroy(t);
    }
    cloud_free(&c);
}

static void test_knn_duplicates_vs_brute(void **state)
{
    (void)state;
    uint64_t rng = 2;
    float pos[40][3];
    for (int p = 0; p < 40; ++p)
        for (int a = 0; a < 3; ++a)
            pos[p][a] = (float)(int)(sg_test_rand01(&rng) * 4.0f) * 0.25f; /* a coarse lattice */
    cloud c = cloud_new(3000);
    for (size_t i = 0; i < c.n; ++i) {
        int p = (int)(sg_test_rand01(&rng) * 40.0f);
        c.x[i] = pos[p][0];
        c.y[i] = pos[p][1];
        c.z[i] = pos[p][2];
    }
    sg_knn *t = tree_of(&c, 0);
    for (size_t i = 0; i < c.n; i += 37) {
        sg_vec3 q = sg_v3(c.x[i], c.y[i], c.z[i]);
        check_query(t, &c, q, 8, (uint32_t)i, "duplicates self");
        check_query(t, &c, q, 150, SG_KNN_NONE, "duplicates k=150");
    }
    check_query(t, &c, sg_v3(0.125f, 0.125f, 0.125f), 100, SG_KNN_NONE, "duplicates between");
    sg_knn_destroy(t);
    cloud_free(&c);
}

static void test_knn_clustered_vs_brute(void **state)
{
    (void)state;
    uint64_t rng = 3;
    cloud c = cloud_new(5000);
    for (size_t i = 0; i < c.n; ++i) {
        float u = sg_test_rand01(&rng), v = sg_test_rand01(&rng), w = sg_test_rand01(&rng);
        if (i < 3000) { /* 30 clusters of sigma ~1e-4 around random centres */
            uint64_t cs = 1000 + i % 30;
            float cx = sg_test_rand01(&cs), cy = sg_test_rand01(&cs), cz = sg_test_rand01(&cs);
            c.x[i] = cx + 1e-4f * (u - 0.5f);
            c.y[i] = cy + 1e-4f * (v - 0.5f);
            c.z[i] = cz + 1e-4f * (w - 0.5f);
        } else if (i < 4500) { /* a sheet z = 0.5 */
            c.x[i] = u;
            c.y[i] = v;
            c.z[i] = 0.5f;
        } else { /* a line along y */
            c.x[i] = 0.25f;
            c.y[i] = u;
            c.z[i] = 0.75f;
        }
    }
    sg_knn *t = tree_of(&c, 0);
    for (size_t i = 0; i < c.n; i += 23) {
        check_query(t, &c, sg_v3(c.x[i], c.y[i], c.z[i]), 12, (uint32_t)i, "clustered self");
        sg_vec3 q = sg_v3(sg_test_rand01(&rng), sg_test_rand01(&rng), sg_test_rand01(&rng));
        check_query(t, &c, q, 5, SG_KNN_NONE, "clustered random");
    }
    sg_knn_destroy(t);
    cloud_free(&c);
}

static void test_knn_batch_matches_single(void **state)
{
    (void)state;
    uint64_t rng = 4;
    cloud c = cloud_new(3000);
    for (size_t i = 0; i < c.n; ++i) { /* points on a sphere, some doubled */
        float z = 2.0f * sg_test_rand01(&rng) - 1.0f, phi = 6.2831853f * sg_test_rand01(&rng);
        float r = sqrtf(1.0f - z * z);
        size_t src = i % 10 == 9 ? i - 1 : i;
        c.x[i] = src == i ? r * cosf(phi) : c.x[src];
        c.y[i] = src == i ? r * sinf(phi) : c.y[src];
        c.z[i] = src == i ? z : c.z[src];
    }
    sg_knn *t = tree_of(&c, 0);
    const size_t k = 10;
    uint32_t *idx = malloc(c.n * k * sizeof(uint32_t));
    float *d2 = malloc(c.n * k * sizeof(float)), *kth = malloc(c.n * sizeof(float));
    assert_non_null(idx);
    assert_non_null(d2);
    assert_non_null(kth);
    sg_error err;
    assert_int_equal(sg_knn_query_all(t, k, idx, d2, &err), SG_OK);
    assert_int_equal(sg_knn_kth_all(t, k, kth, &err), SG_OK);
    for (size_t i = 0; i < c.n; ++i) {
        uint32_t si[10];
        float sd[10];
        size_t got = sg_knn_query(t, sg_v3(c.x[i], c.y[i], c.z[i]), k, (uint32_t)i, si, sd);
        assert_int_equal(got, k);
        for (size_t r = 0; r < k; ++r)
            if (si[r] != idx[i * k + r] || sd[r] != d2[i * k + r])
                fail_msg("point %zu rank %zu: batch (%u, %g), single (%u, %g)", i, r, idx[i * k + r],
                         (double)d2[i * k + r], si[r], (double)sd[r]);
        if (kth[i] != sd[k - 1])
            fail_msg("point %zu: kth_all %g, single query %g", i, (double)kth[i], (double)sd[k - 1]);
    }
    free(idx);
    free(d2);
    free(kth);
    sg_knn_destroy(t);
    cloud_free(&c);
}

static void test_knn_threads_identical(void **state)
{
    (void)state;
    uint64_t rng = 5;
    cloud c = cloud_new(60000); /* above the task cutoff, so the build forks */
    for (size_t i = 0; i < c.n; ++i) {
        c.x[i] = sg_test_rand01(&rng);
        c.y[i] = 0.01f * sg_test_rand01(&rng);
        c.z[i] = sg_test_rand01(&rng);
    }
    const size_t k = 8;
    uint32_t *idx[2];
    float *d2[2];
    int saved = omp_get_max_threads();
    for (int run = 0; run < 2; ++run) {
        omp_set_num_threads(run + 1);
        sg_knn *t = tree_of(&c, 0);
        idx[run] = malloc(c.n * k * sizeof(uint32_t));
        d2[run] = malloc(c.n * k * sizeof(float));
        assert_non_null(idx[run]);
        assert_non_null(d2[run]);
        sg_error err;
        assert_int_equal(sg_knn_query_all(t, k, idx[run], d2[run], &err), SG_OK);
        sg_knn_destroy(t);
    }
    omp_set_num_threads(saved);
    for (size_t i = 0; i < c.n * k; ++i)
        if (idx[0][i] != idx[1][i] || memcmp(&d2[0][i], &d2[1][i], sizeof(float)) != 0)
            fail_msg("slot %zu (point %zu): 1 thread (%u, %g), 2 threads (%u, %g)", i, i / k,
                     idx[0][i], (double)d2[0][i], idx[1][i], (double)d2[1][i]);
    for (int run = 0; run < 2; ++run) {
        free(idx[run]);
        free(d2[run]);
    }
    cloud_free(&c);
}

static void test_knn_few_points(void **state)
{
    (void)state;
    sg_error err;
    cloud c = cloud_new(5);
    for (size_t i = 0; i < 5; ++i) {
        c.x[i] = (float)i;
        c.y[i] = 0.0f;
        c.z[i] = 0.0f;
    }
    sg_knn *t = tree_of(&c, 0);
    uint32_t idx[5 * 8];
    float d2[5 * 8], kth[5];
    assert_int_equal(sg_knn_query_all(t, 8, idx, d2, &err), SG_OK);
    for (size_t i = 0; i < 5; ++i)
        for (size_t r = 0; r < 8; ++r) {
            int filled = r < 4;
            if (filled != (idx[i * 8 + r] != SG_KNN_NONE) || filled != isfinite(d2[i * 8 + r]))
                fail_msg("point %zu rank %zu: (%u, %g); ranks >= 4 must be NONE/INF", i, r,
                         idx[i * 8 + r], (double)d2[i * 8 + r]);
        }
    /* Point 0 at x=0: neighbours 1,2,3,4 at distances 1,2,3,4. */
    assert_int_equal(idx[0], 1);
    assert_int_equal(idx[3], 4);
    assert_true(d2[3] == 16.0f);
    assert_int_equal(sg_knn_kth_all(t, 8, kth, &err), SG_OK);
    assert_true(isinf(kth[2]));
    assert_int_equal(sg_knn_kth_all(t, 4, kth, &err), SG_OK);
    assert_true(kth[2] == 4.0f); /* x=2: neighbours at 1,1,2,2 */
    sg_knn_destroy(t);

    c.n = 1;
    t = tree_of(&c, 0);
    assert_int_equal(sg_knn_query(t, sg_v3(0, 0, 0), 3, 0, idx, d2), 0);
    assert_int_equal(sg_knn_query(t, sg_v3(9, 0, 0), 3, SG_KNN_NONE, idx, d2), 1);
    sg_knn_destroy(t);
    c.n = 0;
    t = tree_of(&c, 0);
    assert_int_equal(sg_knn_query(t, sg_v3(0, 0, 0), 3, SG_KNN_NONE, idx, d2), 0);
    assert_int_equal(sg_knn_query_all(t, 3, idx, d2, &err), SG_OK);
    sg_knn_destroy(t);
    sg_knn_destroy(NULL);
    c.n = 5;
    cloud_free(&c);
}

static void test_knn_radius_vs_brute(void **state)
{
    (void)state;
    uint64_t rng = 6;
    cloud c = cloud_new(4000);
    for (size_t i = 0; i < c.n; ++i) {
        c.x[i] = sg_test_rand01(&rng);
        c.y[i] = sg_test_rand01(&rng);
        c.z[i] = i % 4 == 0 ? 0.5f : sg_test_rand01(&rng);
    }
    sg_knn *t = tree_of(&c, 0);
    cand *all = malloc(c.n * sizeof(cand));
    uint32_t *idx = malloc(c.n * sizeof(uint32_t));
    float *d2 = malloc(c.n * sizeof(float));
    assert_non_null(all);
    assert_non_null(idx);
    assert_non_null(d2);
    for (int qi = 0; qi < 100; ++qi) {
        sg_vec3 q = sg_v3(sg_test_rand01(&rng), sg_test_rand01(&rng), sg_test_rand01(&rng));
        float r = 0.3f * sg_test_rand01(&rng);
        uint32_t ex = qi % 2 ? (uint32_t)qi : SG_KNN_NONE;
        size_t m = brute_sorted(&c, q, ex, all), want = 0;
        while (want < m && all[want].d2 <= r * r)
            ++want;
        size_t got = sg_knn_radius(t, q, r, ex, idx, d2, c.n);
        if (got != want)
            fail_msg("q=(%g,%g,%g) r=%g: %zu points, want %zu", (double)q.x, (double)q.y,
                     (double)q.z, (double)r, got, want);
        for (size_t j = 0; j < want; ++j)
            if (idx[j] != all[j].id || d2[j] != all[j].d2)
                fail_msg("r=%g rank %zu: got (%u, %g), want (%u, %g)", (double)r, j, idx[j],
                         (double)d2[j], all[j].id, (double)all[j].d2);
        /* A too-small cap still counts them all. */
        assert_int_equal(sg_knn_radius(t, q, r, ex, idx, d2, want / 2), want);
        assert_int_equal(sg_knn_radius(t, q, r, ex, NULL, NULL, 0), want);
    }
    free(all);
    free(idx);
    free(d2);
    sg_knn_destroy(t);
    cloud_free(&c);
}

static void test_knn_rejects_nan(void **state)
{
    (void)state;
    cloud c = cloud_new(10);
    for (size_t i = 0; i < 10; ++i)
        c.x[i] = c.y[i] = c.z[i] = (float)i;
    c.y[7] = NAN;
    sg_knn_desc d = {.count = c.n, .px = c.x, .py = c.y, .pz = c.z};
    sg_knn *t = (sg_knn *)&d; /* must stay untouched */
    sg_error err;
    assert_int_equal(sg_knn_create(&d, &t, &err), SG_ERR_INVALID_ARG);
    assert_ptr_equal(t, (sg_knn *)&d);
    if (!strstr(err.message, "point 7"))
        fail_msg("message \"%s\" does not name point 7", err.message);
    cloud_free(&c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_knn_random_vs_brute),
        cmocka_unit_test(test_knn_duplicates_vs_brute),
        cmocka_unit_test(test_knn_clustered_vs_brute),
        cmocka_unit_test(test_knn_batch_matches_single),
        cmocka_unit_test(test_knn_threads_identical),
        cmocka_unit_test(test_knn_few_points),
        cmocka_unit_test(test_knn_radius_vs_brute),
        cmocka_unit_test(test_knn_rejects_nan),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
