/* layers.c — layer keys (layers.h): shared by the MLS scene (scene.c, its
 * kd-tree leaves as the covering lists) and the ISO build (iso_build.c, a
 * uniform grid).
 *
 * Three steps, each a pass over the splats that reads, for splat i, the
 * list of splats that may cover p_i:
 *  1. layer normals: l_i starts as n_i; each of LAYER_PASSES passes
 *     replaces it by the kernel-weighted mean, at p_i, of the layer
 *     normals within 90 degrees of it. Each pass reaches about one radius
 *     further, so the noise of single normals averages out (with k = 8
 *     neighbours in reach one pass only halves it), while the other side
 *     of a thin wall, whose normals are opposed, never enters the mean;
 *  2. folded: some splat covering p_i has a layer normal more than
 *     acos(SG_MLS_FOLD_COS) = 26 degrees from l_i (the two sides of a thin
 *     wall or part, the walls of a fold, a crease);
 *  3. keyed: i or some splat covering p_i is folded, so the key reaches
 *     every splat whose support can share a point with a folded one.
 * Keyed splats get key = l_i rounded to int8 per component, all others 0:
 * there the field is the paper's, unchanged. Measured on Lucy sampled to
 * 250k points: 35% of the splats are keyed; a single field over all of
 * them (SG_MLS_FOLD_COS = -1) lets 4x as many rays slip through the scan's
 * thin parts, one over only the opposed ones (0) 3x as many (bench_leaks,
 * docs/surfaces.md).
 *
 * Invariant: a splat j outside the list of i, or with |p_i - p_j| >= r_j,
 * changes nothing of i (its kernel weight is 0 and it is not tested in
 * steps 2 and 3), so two callers whose lists are supersets of the true
 * covering sets, in the same order, get the same bits.
 */
#include "surface/layers.h"

#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/key_slots.h"
#include "surface/mls.h"

enum { LAYER_PASSES = 3 };

sg_status sg_layer_keys(const sg_pointset *p, sg_kernel kernel, sg_layer_cover_fn cover, const void *user,
                        uint32_t *key, size_t *keyed_count, sg_error *err)
{
    size_t n = p->count;
    float *l = sg_alloc_array(n ? n : 1, 3 * sizeof(float)), *next = sg_alloc_array(n ? n : 1, 3 * sizeof(float));
    uint8_t *folded = sg_alloc_array(n ? n : 1, 1);
    if (!l || !next || !folded) {
        sg_free(l);
        sg_free(next);
        sg_free(folded);
        return sg_error_set(err, SG_ERR_NOMEM, "layer keys: out of memory for %zu splats", n);
    }
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i)
        l[3 * i] = p->nx[i], l[3 * i + 1] = p->ny[i], l[3 * i + 2] = p->nz[i];
    for (int pass = 0; pass < LAYER_PASSES; ++pass) {
#pragma omp parallel for schedule(dynamic, 1024)
        for (size_t i = 0; i < n; ++i) {
            const float *li = l + 3 * i;
            size_t m;
            const uint32_t *list = cover(user, i, &m);
            double a[3] = {0, 0, 0};
            for (size_t k = 0; k < m; ++k) {
                uint32_t j = list[k];
                const float *lj = l + 3 * (size_t)j;
                if (lj[0] * li[0] + lj[1] * li[1] + lj[2] * li[2] <= 0.0f)
                    continue;
                float dx = p->px[i] - p->px[j], dy = p->py[i] - p->py[j], dz = p->pz[i] - p->pz[j];
                const float inv_r = 1.0f / p->radius[j];
                float w = sg_mls_kernel(kernel, sqrtf(dx * dx + dy * dy + dz * dz) * inv_r);
                a[0] += w * lj[0], a[1] += w * lj[1], a[2] += w * lj[2];
            }
            double len = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
            for (int c = 0; c < 3; ++c) /* nothing in reach (i covers itself, so only w == 0 at the rim): keep */
                next[3 * i + c] = len > 0.0 ? (float)(a[c] / len) : li[c];
        }
        float *tmp = l;
        l = next;
        next = tmp;
    }
#pragma omp parallel for schedule(dynamic, 1024)
    for (size_t i = 0; i < n; ++i) {
        const float *li = l + 3 * i;
        size_t m;
        const uint32_t *list = cover(user, i, &m);
        uint8_t o = 0;
        for (size_t k = 0; k < m && !o; ++k) {
            uint32_t j = list[k];
            const float *lj = l + 3 * (size_t)j;
            float dx = p->px[i] - p->px[j], dy = p->py[i] - p->py[j], dz = p->pz[i] - p->pz[j];
            const float inv_r = 1.0f / p->radius[j];
            o = lj[0] * li[0] + lj[1] * li[1] + lj[2] * li[2] < SG_MLS_FOLD_COS &&
                (dx * dx + dy * dy + dz * dz) * inv_r * inv_r < 1.0f;
        }
        folded[i] = o;
    }
    /* keyed, into next[3 i] as 0 / 1 (next is free now) */
#pragma omp parallel for schedule(dynamic, 1024)
    for (size_t i = 0; i < n; ++i) {
        size_t m;
        const uint32_t *list = cover(user, i, &m);
        int keyed = folded[i];
        for (size_t k = 0; k < m && !keyed; ++k) {
            uint32_t j = list[k];
            float dx = p->px[i] - p->px[j], dy = p->py[i] - p->py[j], dz = p->pz[i] - p->pz[j];
            const float inv_r = 1.0f / p->radius[j];
            keyed = folded[j] && (dx * dx + dy * dy + dz * dz) * inv_r * inv_r < 1.0f;
        }
        next[3 * i] = (float)keyed;
    }
    size_t count = 0;
    for (size_t i = 0; i < n; ++i) {
        uint32_t k = 0;
        if (next[3 * i] != 0.0f) {
            for (int c = 0; c < 3; ++c)
                k |= (uint32_t)(uint8_t)(int8_t)lrintf(127.0f * l[3 * i + c]) << (8 * c);
            ++count;
        }
        key[i] = k;
    }
    if (keyed_count)
        *keyed_count = count;
    sg_free(l);
    sg_free(next);
    sg_free(folded);
    return SG_OK;
}

/* ---- the uniform grid ------------------------------------------------------
 *
 * Cells of edge GRID_RADII x the mean radius; each splat is listed in
 * every cell its support's box [p - r, p + r] overlaps (about 8 at the
 * mean radius), so the cell holding p_i lists every j with |p_i - p_j| <
 * r_j (cell indices are floor((x - lo) / h), monotone in x in float, so
 * p_i's cell lies in the range of any box that holds p_i). The cells are
 * kept in a hash on their packed indices (a model is a surface: most of
 * its box's cells are empty). */
static const float GRID_RADII = 2.0f;

typedef struct cover_grid {
    uint32_t *cell_of;  /* cell of p_i, per splat                        */
    uint32_t *first;    /* cell c lists items[first[c] .. first[c + 1])  */
    uint32_t *items;    /* splat indices, increasing within a cell       */
} cover_grid;

static const uint32_t *grid_cover(const void *user, size_t i, size_t *count)
{
    const cover_grid *g = user;
    uint32_t c = g->cell_of[i];
    *count = g->first[c + 1] - g->first[c];
    return g->items + g->first[c];
}

typedef struct cell_hash {
    uint64_t *key; size_t count, cap; /* cell keys by cell index          */
    uint32_t *slot; size_t scap;      /* open addressing: index + 1       */
} cell_hash;

/* Index of the cell with key k, added if new; UINT32_MAX when out of
 * memory. */
static uint32_t cell_index(cell_hash *H, uint64_t k)
{
    if (!sg_key_slots_reserve(&H->slot, &H->scap, H->key, H->count, 4096))
        return UINT32_MAX;
    size_t j;
    uint32_t c = sg_key_slots_find(H->slot, H->scap, H->key, k, &j);
    if (c != UINT32_MAX)
        return c;
    if (H->count + 1 > H->cap) {
        size_t nc = H->cap ? H->cap * 2 : 4096;
        if (!sg_realloc_array((void **)&H->key, H->cap, nc, sizeof *H->key))
            return UINT32_MAX;
        H->cap = nc;
    }
    H->key[H->count] = k;
    H->slot[j] = (uint32_t)H->count + 1;
    return (uint32_t)H->count++;
}

/* The grid cells [c0, c1] (per axis, inclusive) that splat i's support
 * box overlaps. */
static void cell_range(const sg_pointset *p, size_t i, const float lo[3], float inv_h, uint32_t c0[3], uint32_t c1[3])
{
    float r = p->radius[i], x[3] = {p->px[i], p->py[i], p->pz[i]};
    for (int a = 0; a < 3; ++a) {
        c0[a] = (uint32_t)((x[a] - r - lo[a]) * inv_h);
        c1[a] = (uint32_t)((x[a] + r - lo[a]) * inv_h);
    }
}

sg_status sg_layer_keys_grid(const sg_pointset *p, sg_kernel kernel, uint32_t *key, size_t *keyed_count,
                             sg_error *err)
{
    size_t n = p->count;
    double rsum = 0.0;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; ++i) {
        float r = p->radius[i], x[3] = {p->px[i], p->py[i], p->pz[i]};
        rsum += r;
        for (int a = 0; a < 3; ++a) {
            lo[a] = fminf(lo[a], x[a] - r);
            hi[a] = fmaxf(hi[a], x[a] + r);
        }
    }
    /* 21 bits of cell index per axis */
    float h = n ? GRID_RADII * (float)(rsum / (double)n) : 1.0f;
    for (int a = 0; a < 3; ++a)
        h = fmaxf(h, (hi[a] - lo[a]) / 2000000.0f);
    const float inv_h = 1.0f / h;
    sg_status st = SG_OK;
    cell_hash H = {0};
    cover_grid g = {0};
    uint32_t *fill = NULL;
    g.cell_of = sg_alloc_array(n ? n : 1, sizeof *g.cell_of);
    if (!g.cell_of)
        goto nomem;
    /* pass 1: the cells and their counts (counts kept in fill, grown with
     * the cells) */
    size_t items = 0, fcap = 0;
    for (size_t i = 0; i < n; ++i) {
        uint32_t c0[3], c1[3];
        cell_range(p, i, lo, inv_h, c0, c1);
        for (uint32_t z = c0[2]; z <= c1[2]; ++z)
            for (uint32_t y = c0[1]; y <= c1[1]; ++y)
                for (uint32_t xx = c0[0]; xx <= c1[0]; ++xx) {
                    uint32_t c = cell_index(&H, sg_key_grid3(xx, y, z));
                    if (c == UINT32_MAX)
                        goto nomem;
                    if (c >= fcap) {
                        size_t nc = fcap ? fcap * 2 : 4096;
                        if (!sg_realloc_array((void **)&fill, fcap, nc, sizeof *fill))
                            goto nomem;
                        memset(fill + fcap, 0, (nc - fcap) * sizeof *fill);
                        fcap = nc;
                    }
                    ++fill[c];
                    ++items;
                }
        if (items >= UINT32_MAX)
            goto nomem; /* 32-bit offsets */
    }
    g.first = sg_alloc_array(H.count + 1, sizeof *g.first);
    g.items = sg_alloc_array(items ? items : 1, sizeof *g.items);
    if (!g.first || !g.items)
        goto nomem;
    uint32_t run = 0;
    for (size_t c = 0; c < H.count; ++c) {
        g.first[c] = run;
        run += fill[c];
        fill[c] = g.first[c];
    }
    g.first[H.count] = run;
    /* pass 2: fill in increasing splat order */
    for (size_t i = 0; i < n; ++i) {
        float x[3] = {p->px[i], p->py[i], p->pz[i]};
        uint32_t c0[3], c1[3];
        cell_range(p, i, lo, inv_h, c0, c1);
        for (uint32_t z = c0[2]; z <= c1[2]; ++z)
            for (uint32_t y = c0[1]; y <= c1[1]; ++y)
                for (uint32_t xx = c0[0]; xx <= c1[0]; ++xx) {
                    uint32_t c = cell_index(&H, sg_key_grid3(xx, y, z));
                    g.items[fill[c]++] = (uint32_t)i;
                }
        uint32_t cx = (uint32_t)((x[0] - lo[0]) * inv_h), cy = (uint32_t)((x[1] - lo[1]) * inv_h),
                 cz = (uint32_t)((x[2] - lo[2]) * inv_h);
        g.cell_of[i] = cell_index(&H, sg_key_grid3(cx, cy, cz));
    }
    st = sg_layer_keys(p, kernel, grid_cover, &g, key, keyed_count, err);
    goto done;
nomem:
    st = sg_error_set(err, SG_ERR_NOMEM, "layer keys: out of memory for the grid of %zu splats", n);
done:
    sg_free(H.key);
    sg_free(H.slot);
    sg_free(fill);
    sg_free(g.cell_of);
    sg_free(g.first);
    sg_free(g.items);
    return st;
}
