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

#include "accel/cover_grid.h"
#include "core/alloc.h"
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
 * The cell holding p_i lists every j with |p_i - p_j| < r_j (cover_grid.h,
 * scale 1), in increasing index order. */

typedef struct grid_user {
    const sg_pointset *p;
    const sg_cover_grid *g;
} grid_user;

static const uint32_t *grid_cover(const void *user, size_t i, size_t *count)
{
    const grid_user *u = user;
    return sg_cover_grid_at(u->g, sg_pointset_position(u->p, i), count);
}

sg_status sg_layer_keys_grid(const sg_pointset *p, sg_kernel kernel, uint32_t *key, size_t *keyed_count,
                             sg_error *err)
{
    sg_cover_grid g;
    sg_status st = sg_cover_grid_build(p, 1.0f, &g, err);
    if (st != SG_OK)
        return st;
    grid_user u = {p, &g};
    st = sg_layer_keys(p, kernel, grid_cover, &u, key, keyed_count, err);
    sg_cover_grid_free(&g);
    return st;
}
