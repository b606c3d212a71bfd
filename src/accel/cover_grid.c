/* cover_grid.c — the uniform grid of scaled supports (cover_grid.h).
 *
 * Two passes over the splats: the first finds the cells each support box
 * overlaps and counts their splats, the second fills the lists in
 * increasing splat order. The cell edge is 2 x scale x the mean radius, at
 * least 1 / 2,000,000 of the box's longest side (cell indices are 21-bit
 * fields of the hash keys).
 */
#include "accel/cover_grid.h"

#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/key_slots.h"

static const float GRID_RADII = 2.0f; /* cell edge in scaled mean radii */
static const float MAX_CELLS = 2000000.0f; /* per axis, below 2^21 */

/* Index of the cell with key k, added if new; UINT32_MAX when out of
 * memory. */
static uint32_t add_cell(sg_cover_grid *g, uint64_t k)
{
    if (!sg_key_slots_reserve(&g->slot, &g->slot_cap, g->key, g->cell_count, 4096))
        return UINT32_MAX;
    size_t j;
    uint32_t c = sg_key_slots_find(g->slot, g->slot_cap, g->key, k, &j);
    if (c != UINT32_MAX)
        return c;
    if (g->cell_count + 1 > g->key_cap) {
        size_t nc = g->key_cap ? g->key_cap * 2 : 4096;
        if (!sg_realloc_array((void **)&g->key, g->key_cap, nc, sizeof *g->key))
            return UINT32_MAX;
        g->key_cap = nc;
    }
    g->key[g->cell_count] = k;
    g->slot[j] = (uint32_t)g->cell_count + 1;
    return (uint32_t)g->cell_count++;
}

/* What a pass does with one (cell key, splat) pair; 0 stops the pass (out
 * of memory). */
typedef int (*cell_visit)(sg_cover_grid *g, uint64_t key, uint32_t splat, void *user);

/* Calls visit for every cell that splat i's scaled support box overlaps,
 * in a fixed order; 0 if a visit stopped it. */
static int for_cells(sg_cover_grid *g, const sg_pointset *p, size_t i, float scale, cell_visit visit, void *user)
{
    float r = scale * p->radius[i], x[3] = {p->px[i], p->py[i], p->pz[i]};
    uint32_t c0[3], c1[3];
    for (int a = 0; a < 3; ++a) {
        c0[a] = (uint32_t)((x[a] - r - g->lo[a]) * g->inv_h);
        c1[a] = (uint32_t)((x[a] + r - g->lo[a]) * g->inv_h);
    }
    for (uint32_t z = c0[2]; z <= c1[2]; ++z)
        for (uint32_t y = c0[1]; y <= c1[1]; ++y)
            for (uint32_t xx = c0[0]; xx <= c1[0]; ++xx)
                if (!visit(g, sg_key_grid3(xx, y, z), (uint32_t)i, user))
                    return 0;
    return 1;
}

/* Pass 1: the cells, and their counts in fill (grown with the cells). */
typedef struct count_pass {
    uint32_t *fill;
    size_t fcap, items;
} count_pass;

static int count_visit(sg_cover_grid *g, uint64_t key, uint32_t splat, void *user)
{
    (void)splat;
    count_pass *cp = user;
    uint32_t c = add_cell(g, key);
    if (c == UINT32_MAX)
        return 0;
    if (c >= cp->fcap) {
        size_t nc = cp->fcap ? cp->fcap * 2 : 4096;
        if (!sg_realloc_array((void **)&cp->fill, cp->fcap, nc, sizeof *cp->fill))
            return 0;
        memset(cp->fill + cp->fcap, 0, (nc - cp->fcap) * sizeof *cp->fill);
        cp->fcap = nc;
    }
    ++cp->fill[c];
    ++cp->items;
    return 1;
}

/* Pass 2: splat into its cells' lists (fill: each list's next slot). */
static int fill_visit(sg_cover_grid *g, uint64_t key, uint32_t splat, void *user)
{
    uint32_t *fill = user;
    size_t j;
    uint32_t c = sg_key_slots_find(g->slot, g->slot_cap, g->key, key, &j);
    g->items[fill[c]++] = splat;
    return 1;
}

sg_status sg_cover_grid_build(const sg_pointset *p, float scale, sg_cover_grid *out, sg_error *err)
{
    memset(out, 0, sizeof *out);
    const size_t n = p->count;
    double rsum = 0.0;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; ++i) {
        float r = scale * p->radius[i], x[3] = {p->px[i], p->py[i], p->pz[i]};
        rsum += r;
        for (int a = 0; a < 3; ++a) {
            lo[a] = fminf(lo[a], x[a] - r);
            hi[a] = fmaxf(hi[a], x[a] + r);
        }
    }
    float h = n ? GRID_RADII * (float)(rsum / (double)n) : 1.0f;
    for (int a = 0; a < 3; ++a)
        h = fmaxf(h, (hi[a] - lo[a]) / MAX_CELLS);
    sg_cover_grid g = {.lo = {n ? lo[0] : 0.0f, n ? lo[1] : 0.0f, n ? lo[2] : 0.0f}, .inv_h = 1.0f / h};
    count_pass cp = {0};
    for (size_t i = 0; i < n; ++i)
        if (!for_cells(&g, p, i, scale, count_visit, &cp) || cp.items >= UINT32_MAX) /* 32-bit offsets */
            goto nomem;
    g.first = sg_alloc_array(g.cell_count + 1, sizeof *g.first);
    g.items = sg_alloc_array(cp.items ? cp.items : 1, sizeof *g.items);
    if (!g.first || !g.items)
        goto nomem;
    uint32_t run = 0;
    for (size_t c = 0; c < g.cell_count; ++c) {
        g.first[c] = run;
        run += cp.fill[c];
        cp.fill[c] = g.first[c];
    }
    g.first[g.cell_count] = run;
    for (size_t i = 0; i < n; ++i) /* in increasing splat order */
        (void)for_cells(&g, p, i, scale, fill_visit, cp.fill);
    sg_free(cp.fill);
    *out = g;
    return SG_OK;
nomem:
    sg_free(cp.fill);
    sg_cover_grid_free(&g);
    return sg_error_set(err, SG_ERR_NOMEM, "cover grid: out of memory for the grid of %zu splats", n);
}

const uint32_t *sg_cover_grid_at(const sg_cover_grid *g, sg_vec3 x, size_t *count)
{
    *count = 0;
    if (!g->cell_count)
        return NULL;
    const float v[3] = {x.x, x.y, x.z};
    uint32_t c[3];
    for (int a = 0; a < 3; ++a) {
        float f = (v[a] - g->lo[a]) * g->inv_h;
        if (!(f >= 0.0f && f < MAX_CELLS)) /* outside every support box (NaN too) */
            return NULL;
        c[a] = (uint32_t)f;
    }
    size_t j;
    uint32_t cell = sg_key_slots_find(g->slot, g->slot_cap, g->key, sg_key_grid3(c[0], c[1], c[2]), &j);
    if (cell == UINT32_MAX)
        return NULL;
    *count = g->first[cell + 1] - g->first[cell];
    return g->items + g->first[cell];
}

void sg_cover_grid_free(sg_cover_grid *g)
{
    sg_free(g->key);
    sg_free(g->slot);
    sg_free(g->first);
    sg_free(g->items);
    memset(g, 0, sizeof *g);
}
