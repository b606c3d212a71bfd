/* normals.c — PCA normals and their consistent orientation.
 *
 * Job: Hoppe, DeRose, Duchamp, McDonald & Stuetzle 1992, "Surface
 * reconstruction from unorganized points", §3.2 (tangent plane by PCA over
 * the k nearest neighbours) and §3.3 (orientation by propagation along a
 * minimum spanning tree of the Riemannian graph, weight 1 - |n_i . n_j|).
 * We use the symmetric kNN graph as the Riemannian graph (Hoppe adds the
 * Euclidean MST to guarantee connectivity; disconnected kNN components are
 * instead each started at their own extreme point).
 *
 * Stages, each the function named:
 *   positions --knn_pca()--> kNN lists + unoriented normals (parallel)
 *             --build_graph()--> symmetric kNN graph, CSR over rows
 *             --orient()--> Prim's MST grown from all known normals at once,
 *                           then from each remaining component's root
 *             --copy out--> ps normals (only on SG_OK)
 *
 * Invariants:
 *  1. "rows" are the points being estimated, in the kNN tree's order (so
 *     the graph walk is spatially coherent); row_of[i] is point i's row or
 *     NONE (a known normal, read but never changed);
 *  2. the Prim heap is ordered by (weight, point index) and a key is
 *     replaced only by a strictly smaller (weight, from-point index): every
 *     choice is a function of the data alone, not of the order in which
 *     edges are listed, nor of the thread count that found them;
 *  3. weights use |n_i . n_j|, which flipping either normal leaves
 *     bit-identical, so orienting never changes a weight already offered.
 */
#include "points/normals.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include <omp.h>

#include "core/alloc.h"

enum { DEFAULT_K = 12 };
#define NONE UINT32_MAX
/* A root normal decides by the sign of its y only when |n_y| reaches this
 * (30 degrees or more from horizontal); flatter ones say little about up
 * and down, so the direction away from the centroid decides instead. */
#define ROOT_MIN_VERTICAL 0.5f
/* Jacobi stops when the off-diagonal mass is below eps^2 of the total. */
enum { JACOBI_MAX_SWEEPS = 50 };

/* ---- symmetric 3x3 eigen-solver ---------------------------------------- */

void sg_sym3_eigen(const double a[6], double w[3], double v[9])
{
    double A[3][3] = {{a[0], a[1], a[2]}, {a[1], a[3], a[4]}, {a[2], a[4], a[5]}};
    double V[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int sweep = 0; sweep < JACOBI_MAX_SWEEPS; ++sweep) {
        double off = A[0][1] * A[0][1] + A[0][2] * A[0][2] + A[1][2] * A[1][2];
        double diag = A[0][0] * A[0][0] + A[1][1] * A[1][1] + A[2][2] * A[2][2];
        if (!(off > DBL_EPSILON * DBL_EPSILON * (diag + 2.0 * off)))
            break;
        static const int P[3] = {0, 0, 1}, Q[3] = {1, 2, 2};
        for (int r = 0; r < 3; ++r) {
            int p = P[r], q = Q[r];
            double apq = A[p][q];
            if (apq == 0.0)
                continue;
            /* Rotation that zeroes A[p][q] (Numerical Recipes §11.1 form,
             * the smaller of the two angles for stability). */
            double theta = (A[q][q] - A[p][p]) / (2.0 * apq);
            double t = fabs(theta) > 1e150 ? 0.5 / theta
                                           : (theta >= 0.0 ? 1.0 : -1.0) /
                                                 (fabs(theta) + sqrt(theta * theta + 1.0));
            double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
            for (int k = 0; k < 3; ++k) {
                double akp = A[k][p], akq = A[k][q];
                A[k][p] = c * akp - s * akq;
                A[k][q] = s * akp + c * akq;
            }
            for (int k = 0; k < 3; ++k) {
                double apk = A[p][k], aqk = A[q][k];
                A[p][k] = c * apk - s * aqk;
                A[q][k] = s * apk + c * aqk;
            }
            A[p][q] = A[q][p] = 0.0;
            for (int k = 0; k < 3; ++k) {
                double vkp = V[k][p], vkq = V[k][q];
                V[k][p] = c * vkp - s * vkq;
                V[k][q] = s * vkp + c * vkq;
            }
        }
    }
    int order[3] = {0, 1, 2};
    for (int i = 1; i < 3; ++i)
        for (int j = i; j > 0 && A[order[j]][order[j]] < A[order[j - 1]][order[j - 1]]; --j) {
            int tmp = order[j];
            order[j] = order[j - 1];
            order[j - 1] = tmp;
        }
    for (int m = 0; m < 3; ++m) {
        int c = order[m];
        w[m] = A[c][c];
        double len = sqrt(V[0][c] * V[0][c] + V[1][c] * V[1][c] + V[2][c] * V[2][c]);
        for (int k = 0; k < 3; ++k)
            v[3 * m + k] = V[k][c] / len;
    }
}

/* ---- working state -------------------------------------------------------- */

/* Everything the three stages share. Rows (invariant 1) index the points
 * being estimated; everything hot is stored by row so that the graph walk
 * touches memory in tree (spatial) order. */
typedef struct work {
    const sg_pointset *ps;  /* input positions; known normals               */
    const sg_knn *tree;     /* kNN index over ps                            */
    size_t n, rows, k;      /* points, estimated points, neighbours         */
    uint32_t *row_pt;       /* row -> point index                           */
    uint32_t *row_of;       /* point -> row, or NONE for a known normal     */
    uint32_t *nbr;          /* rows x k neighbour point indices (NONE pad)  */
    float *wx, *wy, *wz;    /* per-row working normals                      */
    size_t *adj_at;         /* CSR offsets, rows + 1                        */
    uint32_t *adj;          /* CSR neighbour rows (estimated points only)   */
    uint32_t *scratch;      /* rows entries: degrees, later the BFS queue   */
    float *key_w;           /* Prim: best weight offered to each row        */
    uint32_t *key_from;     /* Prim: point that offered it                  */
    uint8_t *state;         /* Prim: UNSEEN, IN_HEAP, DONE, LABELLED        */
    uint32_t *heap;         /* Prim: rows, min-heap by (key_w, point index) */
    uint32_t *hpos;         /* Prim: row -> slot in heap                    */
    size_t hn;              /* Prim: heap size                              */
} work;

enum { UNSEEN = 0, IN_HEAP = 1, DONE = 2, LABELLED = 3 };

/* ---- stage 1: knn_pca ------------------------------------------------------ */

/* Normal of the plane through point i and its m neighbours nb[0..m). */
static sg_vec3 pca_normal(const sg_pointset *ps, size_t i, const uint32_t *nb, size_t m)
{
    double cx = ps->px[i], cy = ps->py[i], cz = ps->pz[i];
    for (size_t j = 0; j < m; ++j) {
        cx += ps->px[nb[j]];
        cy += ps->py[nb[j]];
        cz += ps->pz[nb[j]];
    }
    double inv = 1.0 / (double)(m + 1);
    cx *= inv;
    cy *= inv;
    cz *= inv;
    double c[6] = {0, 0, 0, 0, 0, 0};
    for (size_t j = 0; j <= m; ++j) {
        size_t p = j < m ? nb[j] : i;
        double dx = ps->px[p] - cx, dy = ps->py[p] - cy, dz = ps->pz[p] - cz;
        c[0] += dx * dx;
        c[1] += dx * dy;
        c[2] += dx * dz;
        c[3] += dy * dy;
        c[4] += dy * dz;
        c[5] += dz * dz;
    }
    double w[3], v[9];
    sg_sym3_eigen(c, w, v);
    return sg_v3((float)v[0], (float)v[1], (float)v[2]);
}

/* kNN lists and unoriented normals of every row; each row is written by
 * exactly one iteration, so the schedule cannot matter. */
static sg_status knn_pca(work *g, sg_error *err)
{
    int threads = omp_get_max_threads();
    float *d2 = sg_alloc_array((size_t)threads * g->k, sizeof(float)); /* per-thread */
    if (!d2)
        return sg_error_set(err, SG_ERR_NOMEM, "normals: cannot allocate query scratch");
#pragma omp parallel num_threads(threads)
    {
        float *sd2 = d2 + (size_t)omp_get_thread_num() * g->k;
#pragma omp for schedule(dynamic, 256)
        for (size_t r = 0; r < g->rows; ++r) {
            uint32_t i = g->row_pt[r];
            uint32_t *nb = g->nbr + r * g->k;
            size_t found = sg_knn_query(g->tree, sg_pointset_position(g->ps, i), g->k, i, nb, sd2);
            for (size_t m = found; m < g->k; ++m)
                nb[m] = NONE;
            sg_vec3 nv = pca_normal(g->ps, i, nb, found);
            g->wx[r] = nv.x;
            g->wy[r] = nv.y;
            g->wz[r] = nv.z;
        }
    }
    sg_free(d2);
    return SG_OK;
}

/* ---- stage 2: build_graph -------------------------------------------------- */

/* Row r lists its estimated neighbours, then every row that lists r. Known
 * neighbours stay only in nbr (stage 3 seeds from them). */
static sg_status build_graph(work *g, sg_error *err)
{
    uint32_t *deg = g->scratch;
    memset(deg, 0, g->rows * sizeof(uint32_t));
    for (size_t r = 0; r < g->rows; ++r)
        for (size_t m = 0; m < g->k; ++m) {
            uint32_t q = g->nbr[r * g->k + m];
            if (q != NONE && g->row_of[q] != NONE) {
                deg[r]++;
                deg[g->row_of[q]]++;
            }
        }
    g->adj_at[0] = 0;
    for (size_t r = 0; r < g->rows; ++r)
        g->adj_at[r + 1] = g->adj_at[r] + deg[r];
    g->adj = sg_alloc_array(g->adj_at[g->rows], sizeof(uint32_t));
    if (!g->adj)
        return sg_error_set(err, SG_ERR_NOMEM, "normals: cannot allocate %zu graph edges",
                            g->adj_at[g->rows]);
    memset(deg, 0, g->rows * sizeof(uint32_t));
    for (size_t r = 0; r < g->rows; ++r)
        for (size_t m = 0; m < g->k; ++m) {
            uint32_t q = g->nbr[r * g->k + m];
            uint32_t rq = q == NONE ? NONE : g->row_of[q];
            if (rq == NONE)
                continue;
            g->adj[g->adj_at[r] + deg[r]++] = rq;
            g->adj[g->adj_at[rq] + deg[rq]++] = (uint32_t)r;
        }
    return SG_OK;
}

/* ---- stage 3: orient (Prim's algorithm with an indexed binary heap) -------- */

/* Weight ties are broken by point index (invariant 2). */
static inline int heap_less(const work *g, uint32_t a, uint32_t b)
{
    return g->key_w[a] < g->key_w[b] || (g->key_w[a] == g->key_w[b] && g->row_pt[a] < g->row_pt[b]);
}

static void heap_up(work *g, size_t at)
{
    uint32_t r = g->heap[at];
    while (at > 0) {
        size_t parent = (at - 1) / 2;
        if (!heap_less(g, r, g->heap[parent]))
            break;
        g->heap[at] = g->heap[parent];
        g->hpos[g->heap[at]] = (uint32_t)at;
        at = parent;
    }
    g->heap[at] = r;
    g->hpos[r] = (uint32_t)at;
}

static void heap_down(work *g, size_t at)
{
    uint32_t r = g->heap[at];
    for (;;) {
        size_t c = 2 * at + 1;
        if (c >= g->hn)
            break;
        if (c + 1 < g->hn && heap_less(g, g->heap[c + 1], g->heap[c]))
            ++c;
        if (!heap_less(g, g->heap[c], r))
            break;
        g->heap[at] = g->heap[c];
        g->hpos[g->heap[at]] = (uint32_t)at;
        at = c;
    }
    g->heap[at] = r;
    g->hpos[r] = (uint32_t)at;
}

/* 1 - |n_a . n_b| (invariant 3). */
static inline float weight_of(float ax, float ay, float az, float bx, float by, float bz)
{
    return 1.0f - fabsf(ax * bx + ay * by + az * bz);
}

/* Offers row r the edge from point `from` with weight w (invariant 2). */
static void offer(work *g, uint32_t r, float w, uint32_t from)
{
    uint8_t s = g->state[r];
    if (s == DONE)
        return;
    if (s != IN_HEAP) {
        g->key_w[r] = w;
        g->key_from[r] = from;
        g->state[r] = IN_HEAP;
        g->heap[g->hn] = r;
        heap_up(g, g->hn++);
        return;
    }
    if (w < g->key_w[r] || (w == g->key_w[r] && from < g->key_from[r])) {
        g->key_w[r] = w;
        g->key_from[r] = from;
        heap_up(g, g->hpos[r]);
    }
}

/* Marks row r done and offers its neighbours that are not done. */
static void expand(work *g, uint32_t r)
{
    g->state[r] = DONE;
    for (size_t e = g->adj_at[r]; e < g->adj_at[r + 1]; ++e) {
        uint32_t q = g->adj[e];
        if (g->state[q] != DONE)
            offer(g, q, weight_of(g->wx[r], g->wy[r], g->wz[r], g->wx[q], g->wy[q], g->wz[q]),
                  g->row_pt[r]);
    }
}

static void flip(work *g, uint32_t r)
{
    g->wx[r] = -g->wx[r];
    g->wy[r] = -g->wy[r];
    g->wz[r] = -g->wz[r];
}

/* Pops rows until the heap is empty, orienting each like the point it was
 * reached from (a known normal or an already oriented row). */
static void prim_run(work *g)
{
    while (g->hn > 0) {
        uint32_t r = g->heap[0];
        g->heap[0] = g->heap[--g->hn];
        if (g->hn > 0) {
            g->hpos[g->heap[0]] = 0;
            heap_down(g, 0);
        }
        uint32_t f = g->key_from[r], rf = g->row_of[f];
        float fx = rf == NONE ? g->ps->nx[f] : g->wx[rf];
        float fy = rf == NONE ? g->ps->ny[f] : g->wy[rf];
        float fz = rf == NONE ? g->ps->nz[f] : g->wz[rf];
        if (g->wx[r] * fx + g->wy[r] * fy + g->wz[r] * fz < 0.0f)
            flip(g, r);
        expand(g, r);
    }
}

/* Orients the component of row `start` (all its rows UNSEEN) from its
 * point of largest y, by the rule in normals.h. */
static void orient_component(work *g, uint32_t start)
{
    const sg_pointset *ps = g->ps;
    uint32_t *queue = g->scratch;
    size_t head = 0, tail = 0;
    queue[tail++] = start;
    g->state[start] = LABELLED;
    uint32_t root = start; /* row */
    double cx = 0.0, cy = 0.0, cz = 0.0;
    while (head < tail) {
        uint32_t r = queue[head++], p = g->row_pt[r], pr = g->row_pt[root];
        cx += ps->px[p];
        cy += ps->py[p];
        cz += ps->pz[p];
        if (ps->py[p] > ps->py[pr] || (ps->py[p] == ps->py[pr] && p < pr))
            root = r;
        for (size_t e = g->adj_at[r]; e < g->adj_at[r + 1]; ++e) {
            uint32_t q = g->adj[e];
            if (g->state[q] == UNSEEN) {
                g->state[q] = LABELLED;
                queue[tail++] = q;
            }
        }
    }
    double inv = 1.0 / (double)tail;
    uint32_t p = g->row_pt[root];
    float s = g->wy[root];
    if (fabsf(s) < ROOT_MIN_VERTICAL)
        s = (float)(g->wx[root] * (ps->px[p] - cx * inv) + g->wy[root] * (ps->py[p] - cy * inv) +
                    g->wz[root] * (ps->pz[p] - cz * inv));
    if (s < 0.0f)
        flip(g, root);
    expand(g, root);
    prim_run(g);
}

static sg_status orient(work *g, sg_error *err)
{
    g->key_w = sg_alloc_array(g->rows, sizeof(float));
    g->key_from = sg_alloc_array(g->rows, sizeof(uint32_t));
    g->heap = sg_alloc_array(g->rows, sizeof(uint32_t));
    g->hpos = sg_alloc_array(g->rows, sizeof(uint32_t));
    g->state = sg_calloc_array(g->rows, sizeof(uint8_t));
    if (!g->key_w || !g->key_from || !g->heap || !g->hpos || !g->state)
        return sg_error_set(err, SG_ERR_NOMEM, "normals: cannot allocate the spanning-tree heap");
    /* Every known normal is a root at once: the rows listing a known
     * neighbour are offered that edge. */
    const sg_pointset *ps = g->ps;
    for (size_t r = 0; r < g->rows; ++r)
        for (size_t m = 0; m < g->k; ++m) {
            uint32_t q = g->nbr[r * g->k + m];
            if (q != NONE && g->row_of[q] == NONE)
                offer(g, (uint32_t)r, weight_of(g->wx[r], g->wy[r], g->wz[r], ps->nx[q], ps->ny[q], ps->nz[q]), q);
        }
    prim_run(g);
    /* Components with no known normal, in order of their first row. */
    for (size_t r = 0; r < g->rows; ++r)
        if (g->state[r] == UNSEEN)
            orient_component(g, (uint32_t)r);
    return SG_OK;
}

/* ---- driver ------------------------------------------------------------------ */

static int normal_missing(const sg_pointset *ps, size_t i)
{
    float x = ps->nx[i], y = ps->ny[i], z = ps->nz[i];
    if (!isfinite(x) || !isfinite(y) || !isfinite(z))
        return 1;
    return x * x + y * y + z * z < 1e-12f;
}

sg_status sg_points_estimate_normals(sg_pointset *ps, const sg_normals_desc *d, sg_error *err)
{
    if (!ps)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "normals: pointset is NULL");
    sg_normals_desc desc = d ? *d : (sg_normals_desc){0};
    size_t k = desc.k ? desc.k : DEFAULT_K;
    size_t n = ps->count;
    if (n == 0)
        return SG_OK;
    if (n < 3)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "normals: %zu points; a tangent plane needs at least 3", n);
    if (n >= UINT32_MAX)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "normals: %zu points is too many", n);
    if (desc.knn && sg_knn_count(desc.knn) != n)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "normals: shared kNN tree has %zu points, pointset has %zu",
                            sg_knn_count(desc.knn), n);
    if (k > n - 1)
        k = n - 1;
    int only_missing = (desc.flags & SG_NORMALS_ONLY_MISSING) != 0;
    size_t rows = 0;
    for (size_t i = 0; i < n; ++i)
        rows += !only_missing || normal_missing(ps, i);
    if (rows == 0)
        return SG_OK;

    sg_status st = SG_OK;
    sg_knn *own = NULL;
    work g = {.ps = ps, .tree = desc.knn, .n = n, .rows = rows, .k = k};
    size_t nbr_count;
    if (!sg_mul_size(rows, k, &nbr_count)) {
        st = sg_error_set(err, SG_ERR_NOMEM, "normals: %zu points x %zu neighbours overflows", rows, k);
        goto done;
    }
    if (!g.tree) {
        sg_knn_desc kd = {.count = n, .px = ps->px, .py = ps->py, .pz = ps->pz};
        st = sg_knn_create(&kd, &own, err);
        if (st != SG_OK)
            goto done;
        g.tree = own;
    }
    g.row_pt = sg_alloc_array(rows, sizeof(uint32_t));
    g.row_of = sg_alloc_array(n, sizeof(uint32_t));
    g.nbr = sg_alloc_array(nbr_count, sizeof(uint32_t));
    g.wx = sg_alloc_array(rows, sizeof(float));
    g.wy = sg_alloc_array(rows, sizeof(float));
    g.wz = sg_alloc_array(rows, sizeof(float));
    g.adj_at = sg_alloc_array(rows + 1, sizeof(size_t));
    g.scratch = sg_alloc_array(rows, sizeof(uint32_t));
    if (!g.row_pt || !g.row_of || !g.nbr || !g.wx || !g.wy || !g.wz || !g.adj_at || !g.scratch) {
        st = sg_error_set(err, SG_ERR_NOMEM, "normals: cannot allocate for %zu points", n);
        goto done;
    }
    /* Invariant 1: rows in tree order. */
    const uint32_t *order = sg_knn_order(g.tree);
    for (size_t j = 0, r = 0; j < n; ++j) {
        uint32_t i = order[j];
        int est = !only_missing || normal_missing(ps, i);
        g.row_of[i] = est ? (uint32_t)r : NONE;
        if (est)
            g.row_pt[r++] = i;
    }
    st = knn_pca(&g, err);
    if (st == SG_OK)
        st = build_graph(&g, err);
    if (st == SG_OK)
        st = orient(&g, err);
    if (st != SG_OK)
        goto done;
    for (size_t r = 0; r < rows; ++r) {
        uint32_t i = g.row_pt[r];
        ps->nx[i] = g.wx[r];
        ps->ny[i] = g.wy[r];
        ps->nz[i] = g.wz[r];
    }

done:
    sg_free(g.state);
    sg_free(g.hpos);
    sg_free(g.heap);
    sg_free(g.key_from);
    sg_free(g.key_w);
    sg_free(g.scratch);
    sg_free(g.adj);
    sg_free(g.adj_at);
    sg_free(g.wz);
    sg_free(g.wy);
    sg_free(g.wx);
    sg_free(g.nbr);
    sg_free(g.row_of);
    sg_free(g.row_pt);
    sg_knn_destroy(own);
    return st;
}
