/* samples.c — sample points: greedy thinning, refinement, interpolation
 * (see samples.h).
 *
 * Invariants:
 *  1. no two samples facing the same way (normal dot >= normal_cos) lie
 *     closer than the spacing of the finer of the two;
 *  2. every splat that was a candidate of a thinning at spacing s has a
 *     same-facing sample within s (it was accepted, or rejected because of
 *     one);
 *  3. the set, the interpolated values and the nearest indices depend on
 *     the inputs only: decisions run sequentially in a fixed order, and the
 *     parallel loops give each splat a sum in the grid's fixed item order.
 *
 * The grid is a hash of integer cell coordinates (open addressing, linear
 * probing) to a singly linked list of items; its cell size equals the
 * largest query radius, so a query reads the 27 cells around a point.
 */
#include "bake/samples.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"
#include "points/knn.h"

static const uint32_t NONE = UINT32_MAX;

typedef struct grid {
    float inv;           /* 1 / cell size                                */
    size_t mask;         /* slots - 1 (slots a power of two)             */
    int32_t *key;        /* 3 cell coordinates per slot                  */
    uint32_t *head;      /* first item of the slot's cell; NONE: empty   */
    uint32_t *next;      /* per item: next item of its cell; NONE: last  */
} grid;

static void grid_free(grid *g)
{
    sg_free(g->key);
    sg_free(g->head);
    sg_free(g->next);
    memset(g, 0, sizeof *g);
}

static int grid_init(grid *g, float cell, size_t max_items)
{
    memset(g, 0, sizeof *g);
    size_t slots = 64;
    while (slots < 2 * max_items + 16)
        slots *= 2;
    g->inv = 1.0f / cell;
    g->mask = slots - 1;
    g->key = sg_alloc_array(slots, 3 * sizeof(int32_t));
    g->head = sg_alloc_array(slots, sizeof(uint32_t));
    g->next = sg_alloc_array(max_items ? max_items : 1, sizeof(uint32_t));
    if (!g->key || !g->head || !g->next) {
        grid_free(g);
        return 0;
    }
    for (size_t i = 0; i < slots; ++i)
        g->head[i] = NONE;
    return 1;
}

static int32_t cell_coord(float x, float inv)
{
    float c = floorf(x * inv);
    /* Clamped so that far-away or non-finite input cannot overflow. */
    if (!(c > -1e9f)) c = -1e9f;
    if (c > 1e9f) c = 1e9f;
    return (int32_t)c;
}

static size_t slot_of(const grid *g, int32_t x, int32_t y, int32_t z)
{
    uint64_t h = (uint64_t)(uint32_t)x * 0x9E3779B97F4A7C15ull ^ (uint64_t)(uint32_t)y * 0xC2B2AE3D27D4EB4Full ^
                 (uint64_t)(uint32_t)z * 0x165667B19E3779F9ull;
    h ^= h >> 29;
    size_t s = (size_t)h & g->mask;
    while (g->head[s] != NONE && !(g->key[3 * s] == x && g->key[3 * s + 1] == y && g->key[3 * s + 2] == z))
        s = (s + 1) & g->mask;
    return s;
}

static void grid_insert(grid *g, uint32_t item, sg_vec3 p)
{
    int32_t x = cell_coord(p.x, g->inv), y = cell_coord(p.y, g->inv), z = cell_coord(p.z, g->inv);
    size_t s = slot_of(g, x, y, z);
    if (g->head[s] == NONE) {
        g->key[3 * s] = x;
        g->key[3 * s + 1] = y;
        g->key[3 * s + 2] = z;
    }
    g->next[item] = g->head[s];
    g->head[s] = item;
}

/* The 27 cells around p: heads[] gets each cell's first item (NONE when
 * empty), in a fixed order. */
static void grid_around(const grid *g, sg_vec3 p, uint32_t heads[27])
{
    int32_t x = cell_coord(p.x, g->inv), y = cell_coord(p.y, g->inv), z = cell_coord(p.z, g->inv);
    int k = 0;
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx)
                heads[k++] = g->head[slot_of(g, x + dx, y + dy, z + dz)];
}

static float dist2(sg_vec3 a, sg_vec3 b)
{
    sg_vec3 d = sg_v3_sub(a, b);
    return sg_v3_dot(d, d);
}

static float luminance(const float *v) { return 0.2126f * v[0] + 0.7152f * v[1] + 0.0722f * v[2]; }

void sg_sample_set_free(sg_sample_set *set)
{
    if (!set)
        return;
    sg_free(set->splat);
    sg_free(set->level);
    memset(set, 0, sizeof *set);
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

sg_status sg_samples_median_radius(const sg_sites *ps, float *out, sg_error *err)
{
    *out = 0.0f;
    if (ps->count == 0)
        return SG_OK;
    float *r = sg_alloc_array(ps->count, sizeof *r);
    if (!r)
        return sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for %zu radii", ps->count);
    size_t n = 0;
    for (size_t i = 0; i < ps->count; ++i)
        if (!(ps->unsampled && ps->unsampled[i]))
            r[n++] = ps->radius[i];
    if (n) {
        qsort(r, n, sizeof *r, cmp_float);
        *out = r[n / 2];
    }
    sg_free(r);
    return SG_OK;
}

float sg_samples_default_spacing(const sg_material *m)
{
    if (m->type != SG_MATERIAL_GGX || !(m->specular > 0.0f))
        return 4.0f;
    float r = m->roughness < 0.0f ? 0.0f : (m->roughness > 1.0f ? 1.0f : m->roughness);
    return 2.0f + 2.0f * r;
}

static int set_reserve(sg_sample_set *set, size_t n)
{
    if (n <= set->capacity)
        return 1;
    size_t cap = set->capacity ? set->capacity : 1024;
    while (cap < n)
        cap *= 2;
    void *s = set->splat, *l = set->level;
    int ok = sg_realloc_array(&s, set->capacity, cap, sizeof *set->splat);
    set->splat = s;
    ok = ok && sg_realloc_array(&l, set->capacity, cap, sizeof *set->level);
    set->level = l;
    if (!ok)
        return 0;
    set->capacity = cap;
    return 1;
}

sg_status sg_samples_thin(const sg_sites *ps, float spacing, float normal_cos, const uint32_t *candidates,
                          size_t ncand, uint8_t level, sg_sample_set *set, sg_error *err)
{
    if (!(spacing > 0.0f) || !isfinite(spacing))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "samples: spacing %g is not positive and finite",
                            (double)spacing);
    if (!candidates)
        ncand = ps->count;
    grid g;
    if (!grid_init(&g, spacing, set->count + ncand) || !set_reserve(set, set->count + ncand)) {
        grid_free(&g);
        return sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for %zu candidates", ncand);
    }
    for (size_t j = 0; j < set->count; ++j)
        grid_insert(&g, (uint32_t)j, sg_sites_position(ps, set->splat[j]));
    float s2 = spacing * spacing;
    for (size_t c = 0; c < ncand; ++c) {
        uint32_t i = candidates ? candidates[c] : (uint32_t)c;
        if (ps->unsampled && ps->unsampled[i])
            continue;
        sg_vec3 p = sg_sites_position(ps, i), n = sg_sites_normal(ps, i);
        uint32_t heads[27];
        grid_around(&g, p, heads);
        int near = 0;
        for (int k = 0; k < 27 && !near; ++k)
            for (uint32_t j = heads[k]; j != NONE && !near; j = g.next[j]) {
                uint32_t sj = set->splat[j];
                near = dist2(p, sg_sites_position(ps, sj)) < s2 &&
                       sg_v3_dot(n, sg_sites_normal(ps, sj)) >= normal_cos;
            }
        if (near)
            continue;
        size_t id = set->count++;
        set->splat[id] = i;
        set->level[id] = level;
        grid_insert(&g, (uint32_t)id, p);
    }
    grid_free(&g);
    return SG_OK;
}

static float level_spacing(float s0, uint8_t level) { return ldexpf(s0, -(int)level); }

sg_status sg_samples_mark_jumps(const sg_sites *ps, float s0, float normal_cos, const float *values,
                                const float *sigma, float threshold, uint8_t level, const sg_sample_set *set,
                                uint8_t *mark, sg_error *err)
{
    if (level >= SG_SAMPLES_MAX_LEVEL || set->count == 0)
        return SG_OK;
    double mean = 0.0;
    for (size_t j = 0; j < set->count; ++j)
        mean += luminance(values + 3 * j);
    mean /= (double)set->count;
    if (!(mean > 0.0))
        return SG_OK;
    float floor_y = (float)(0.05 * mean), sl = level_spacing(s0, level), r2 = 4.0f * sl * sl;
    grid g = {0};
    if (!grid_init(&g, 2.0f * sl, set->count))
        return sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for refinement");
    for (size_t j = 0; j < set->count; ++j)
        grid_insert(&g, (uint32_t)j, sg_sites_position(ps, set->splat[j]));
    for (size_t j = 0; j < set->count; ++j) {
        if (set->level[j] != level || mark[j])
            continue;
        sg_vec3 p = sg_sites_position(ps, set->splat[j]), n = sg_sites_normal(ps, set->splat[j]);
        float yj = fmaxf(luminance(values + 3 * j), floor_y);
        uint32_t heads[27];
        grid_around(&g, p, heads);
        int differs = 0;
        for (int k = 0; k < 27 && !differs; ++k)
            for (uint32_t i = heads[k]; i != NONE && !differs; i = g.next[i]) {
                uint32_t si = set->splat[i];
                if (i == j || dist2(p, sg_sites_position(ps, si)) > r2 ||
                    sg_v3_dot(n, sg_sites_normal(ps, si)) < normal_cos)
                    continue;
                float yi = fmaxf(luminance(values + 3 * (size_t)i), floor_y), dy = fabsf(yi - yj);
                differs = dy > threshold * fmaxf(yi, yj) &&
                          (!sigma || dy > 3.0f * sqrtf(sigma[i] * sigma[i] + sigma[j] * sigma[j]));
            }
        mark[j] = (uint8_t)differs;
    }
    grid_free(&g);
    return SG_OK;
}

sg_status sg_samples_refine_marked(const sg_sites *ps, float s0, float normal_cos, const uint8_t *mark,
                                   uint8_t level, sg_sample_set *set, size_t *added, sg_error *err)
{
    *added = 0;
    if (level >= SG_SAMPLES_MAX_LEVEL || set->count == 0)
        return SG_OK;
    float sl = level_spacing(s0, level);
    grid gm = {0};
    uint32_t *marked = NULL, *cands = NULL;
    size_t nmarked = 0, ncand = 0;
    sg_status st = SG_OK;
    if (!(marked = sg_alloc_array(set->count, sizeof *marked))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for refinement");
        goto done;
    }
    for (size_t j = 0; j < set->count; ++j)
        if (mark[j] && set->level[j] == level)
            marked[nmarked++] = (uint32_t)j;
    if (nmarked == 0)
        goto done;
    if (!grid_init(&gm, sl, nmarked) || !(cands = sg_alloc_array(ps->count, sizeof *cands))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for refinement");
        goto done;
    }
    for (size_t k = 0; k < nmarked; ++k)
        grid_insert(&gm, (uint32_t)k, sg_sites_position(ps, set->splat[marked[k]]));
    float sl2 = sl * sl;
    for (size_t i = 0; i < ps->count; ++i) {
        sg_vec3 p = sg_sites_position(ps, i), n = sg_sites_normal(ps, i);
        uint32_t heads[27];
        grid_around(&gm, p, heads);
        int near = 0;
        for (int k = 0; k < 27 && !near; ++k)
            for (uint32_t m = heads[k]; m != NONE && !near; m = gm.next[m]) {
                uint32_t sm = set->splat[marked[m]];
                near = dist2(p, sg_sites_position(ps, sm)) <= sl2 &&
                       sg_v3_dot(n, sg_sites_normal(ps, sm)) >= normal_cos;
            }
        if (near)
            cands[ncand++] = (uint32_t)i;
    }
    size_t before = set->count;
    st = sg_samples_thin(ps, 0.5f * sl, normal_cos, cands, ncand, (uint8_t)(level + 1), set, err);
    if (st == SG_OK)
        *added = set->count - before;
done:
    grid_free(&gm);
    sg_free(marked);
    sg_free(cands);
    return st;
}

sg_status sg_samples_refine(const sg_sites *ps, float s0, float normal_cos, const float *values,
                            const float *sigma, float threshold, uint8_t level, sg_sample_set *set, size_t *added,
                            sg_error *err)
{
    *added = 0;
    uint8_t *mark = sg_calloc_array(set->count ? set->count : 1, sizeof *mark);
    if (!mark)
        return sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for refinement");
    sg_status st = sg_samples_mark_jumps(ps, s0, normal_cos, values, sigma, threshold, level, set, mark, err);
    if (st == SG_OK)
        st = sg_samples_refine_marked(ps, s0, normal_cos, mark, level, set, added, err);
    sg_free(mark);
    return st;
}

/* Wendland C2 on [0,1]: smooth, compactly supported, positive. */
static float wendland(float q)
{
    float a = 1.0f - q;
    return a * a * a * a * (4.0f * q + 1.0f);
}

static int grid_of_samples(grid *g, const sg_sites *ps, const sg_sample_set *set, float cell)
{
    if (!grid_init(g, cell, set->count))
        return 0;
    for (size_t j = 0; j < set->count; ++j)
        grid_insert(g, (uint32_t)j, sg_sites_position(ps, set->splat[j]));
    return 1;
}

/* Nearest sample to splat i among the 27 cells: same-facing preferred.
 * NONE when the cells hold no sample. */
static uint32_t nearest_in_cells(const grid *g, const sg_sites *ps, const sg_sample_set *set, size_t i,
                                 float normal_cos)
{
    sg_vec3 p = sg_sites_position(ps, i), n = sg_sites_normal(ps, i);
    uint32_t heads[27], best_f = NONE, best_a = NONE;
    float d_f = INFINITY, d_a = INFINITY;
    grid_around(g, p, heads);
    for (int k = 0; k < 27; ++k)
        for (uint32_t j = heads[k]; j != NONE; j = g->next[j]) {
            uint32_t sj = set->splat[j];
            float d = dist2(p, sg_sites_position(ps, sj));
            /* ties: the lower sample index, whatever the cell order */
            if (d < d_a || (d == d_a && j < best_a)) {
                d_a = d;
                best_a = j;
            }
            if (sg_v3_dot(n, sg_sites_normal(ps, sj)) >= normal_cos && (d < d_f || (d == d_f && j < best_f))) {
                d_f = d;
                best_f = j;
            }
        }
    return best_f != NONE ? best_f : best_a;
}

/* A kd-tree over the samples' positions, for the nearest sample of all
 * (a site far from every sample: thinning over all splats never leaves
 * one, but an octree's corners off the surface are such sites, and a
 * linear scan per corner took 64% of an ISO bake's time, measured). Its
 * answer is the linear scan's: the smallest squared distance, ties to the
 * lower sample index (knn.h). Built by the first thread that needs it, so
 * a bake whose sites are all covered (MLS, disks) never builds one. */
typedef struct lazy_tree {
    sg_knn *tree;
    int failed; /* out of memory building it */
} lazy_tree;

static sg_knn *samples_tree(const sg_sites *ps, const sg_sample_set *set)
{
    float *xyz = sg_alloc_array(3 * set->count, sizeof *xyz);
    if (!xyz)
        return NULL;
    for (size_t j = 0; j < set->count; ++j) {
        sg_vec3 q = sg_sites_position(ps, set->splat[j]);
        xyz[j] = q.x, xyz[set->count + j] = q.y, xyz[2 * set->count + j] = q.z;
    }
    sg_knn_desc d = {.count = set->count, .px = xyz, .py = xyz + set->count, .pz = xyz + 2 * set->count};
    sg_knn *t = NULL;
    sg_status st = sg_knn_create(&d, &t, NULL);
    sg_free(xyz);
    return st == SG_OK ? t : NULL;
}

/* The nearest sample of all to site i; NONE (and lt->failed) when the
 * tree cannot be built. Called inside a parallel loop: the critical section
 * builds the tree once and publishes it to every thread that passes it. */
static uint32_t nearest_anywhere(lazy_tree *lt, const sg_sites *ps, const sg_sample_set *set, size_t i)
{
    sg_knn *tree;
#pragma omp critical(sg_samples_lazy_tree)
    {
        if (!lt->tree && !lt->failed) {
            lt->tree = samples_tree(ps, set);
            lt->failed = !lt->tree;
        }
        tree = lt->tree;
    }
    uint32_t j = NONE;
    float d2;
    if (!tree || !sg_knn_query(tree, sg_sites_position(ps, i), 1, SG_KNN_NONE, &j, &d2))
        return NONE;
    return j;
}

/* Whether sample j's support reaches the site at p (normal n) and faces
 * its way; *dp gets the offset to the sample, *q its distance in units of
 * the sample's support radius (support x its level's spacing). */
static int reaches(const sg_sites *ps, const sg_sample_set *set, uint32_t j, sg_vec3 p, sg_vec3 n, float s0,
                   float support, float normal_cos, sg_vec3 *dp, float *q)
{
    uint32_t sj = set->splat[j];
    float r = support * level_spacing(s0, set->level[j]);
    *dp = sg_v3_sub(sg_sites_position(ps, sj), p);
    float d2 = sg_v3_dot(*dp, *dp);
    if (d2 >= r * r || sg_v3_dot(n, sg_sites_normal(ps, sj)) < normal_cos)
        return 0;
    *q = sqrtf(d2) / r;
    return 1;
}

/* How much a level's samples count at a site: the finest level whose
 * supports reach it counts fully, and each coarser level only where the
 * finer ones do not cover it, as the partition
 *     level_w[l] = prod over l' > l of (1 - min(1, cover(l') / FINE_COVER)),
 * cover(l) the sum of the level's kernel values at the site. Finer levels
 * were added where the light changes faster than the coarse samples
 * resolve (a shadow's edge, a concave fold); inside such a zone a coarse
 * sample, whose support is 2^level times wider, would carry the far side
 * of the edge into it: a ring of sunlight 2 coarse spacings wide around
 * the sun's patch through the built-in room's window, where the patch's
 * light is 10 times the floor's around it. (Weighting finer levels
 * 4^level more instead left that ring at 1/17 of a coarse sample's
 * value: the room's relMSE 10-19% higher on every surface, docs/verify.md
 * section 2b.) FINE_COVER: a fine sample at 0.4 of its support radius
 * alone (kernel 0.34) nearly hides the coarse ones; a zone's inside,
 * where the fine samples cover the plane at their spacing, has a cover
 * of about 2.2 and hides them fully; measured 0.25, 0.5 and 1 (0.5: the
 * rooms gain most, an open close-up of folds loses least). Partition of
 * unity over the levels, smooth in position: no seam where a zone ends. */
static const double FINE_COVER = 0.5;

static void levels_weights(const double cover[SG_SAMPLES_MAX_LEVEL + 1], double level_w[SG_SAMPLES_MAX_LEVEL + 1])
{
    double keep = 1.0;
    for (int l = SG_SAMPLES_MAX_LEVEL; l >= 0; --l) {
        level_w[l] = keep;
        double a = cover[l] / FINE_COVER;
        keep *= a >= 1.0 ? 0.0 : 1.0 - a;
    }
}

/* A site's fit: weighted least squares of f = c0 + c1 u + c2 v in the
 * site's tangent plane (u, v in units of the level-0 support), c0 the
 * value: exact for light that varies linearly over the surface, and on a
 * curved surface the normal (what the light depends on) does, to first
 * order. A weighted mean would pull every value towards its
 * neighbourhood's average (1.5% of the energy on a unit sphere at the
 * default spacing, measured). The sums, and each channel's range. */
typedef struct fit_sums {
    double m[6];                             /* sums of w, wu, wv, wuu, wuv, wvv */
    double rhs[SG_SAMPLES_MAX_CHANNELS][3];  /* per channel: sums of wf, wfu, wfv */
    float lo[SG_SAMPLES_MAX_CHANNELS], hi[SG_SAMPLES_MAX_CHANNELS];
} fit_sums;

static void fit_init(fit_sums *s, size_t nc)
{
    memset(s->m, 0, sizeof s->m);
    memset(s->rhs, 0, sizeof s->rhs);
    for (size_t c = 0; c < nc; ++c) {
        s->lo[c] = INFINITY;
        s->hi[c] = -INFINITY;
    }
}

/* Adds sample j (values f, nc channels) at (u, v) with weight w. */
static void fit_add(fit_sums *s, double w, double u, double v, const float *f, size_t nc)
{
    s->m[0] += w;
    s->m[1] += w * u;
    s->m[2] += w * v;
    s->m[3] += w * u * u;
    s->m[4] += w * u * v;
    s->m[5] += w * v * v;
    for (size_t c = 0; c < nc; ++c) {
        s->rhs[c][0] += w * f[c];
        s->rhs[c][1] += w * f[c] * u;
        s->rhs[c][2] += w * f[c] * v;
        s->lo[c] = fminf(s->lo[c], f[c]);
        s->hi[c] = fmaxf(s->hi[c], f[c]);
    }
}

/* out (nc values): c0 of each channel's fit, s->m[0] > 0. By Cramer's
 * rule; the weighted mean where the points do not span the plane (a line
 * of samples, one sample, a rim). No new extrema: a fit across a shadow
 * edge cannot overshoot the values it was made from. */
static void fit_solve(const fit_sums *s, size_t nc, float *out)
{
    double a = s->m[0], b = s->m[1], c_ = s->m[2], d = s->m[3], e = s->m[4], f = s->m[5];
    double det = a * (d * f - e * e) - b * (b * f - e * c_) + c_ * (b * e - d * c_);
    int fit = det > 1e-4 * a * a * a;
    for (size_t c = 0; c < nc; ++c) {
        double v0 = s->rhs[c][0] / a;
        if (fit) {
            double r0 = s->rhs[c][0], r1 = s->rhs[c][1], r2 = s->rhs[c][2];
            v0 = (r0 * (d * f - e * e) - b * (r1 * f - e * r2) + c_ * (r1 * e - d * r2)) / det;
        }
        float vf = (float)v0;
        out[c] = vf < s->lo[c] ? s->lo[c] : (vf > s->hi[c] ? s->hi[c] : vf);
    }
}

/* The samples that reach a site, kept from the pass that sums the levels'
 * cover for the pass that fits: one walk over the grid. One per thread,
 * grown as needed (a site sees a few dozen samples). */
typedef struct near_list {
    size_t n, cap;
    uint32_t *j;
    float *q;
    sg_vec3 *dp;
} near_list;

static void near_free(near_list *l)
{
    sg_free(l->j);
    sg_free(l->q);
    sg_free(l->dp);
    memset(l, 0, sizeof *l);
}

/* Appends (j, q, dp); 0 when out of memory. */
static int near_push(near_list *l, uint32_t j, float q, sg_vec3 dp)
{
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 64;
        void *a = l->j, *b = l->q, *c = l->dp;
        int ok = sg_realloc_array(&a, l->cap, cap, sizeof *l->j);
        l->j = a;
        ok = ok && sg_realloc_array(&b, l->cap, cap, sizeof *l->q);
        l->q = b;
        ok = ok && sg_realloc_array(&c, l->cap, cap, sizeof *l->dp);
        l->dp = c;
        if (!ok)
            return 0;
        l->cap = cap;
    }
    l->j[l->n] = j;
    l->q[l->n] = q;
    l->dp[l->n] = dp;
    ++l->n;
    return 1;
}

sg_status sg_samples_interpolate(const sg_sites *ps, const sg_sample_set *set, float s0, float support,
                                 float normal_cos, const float *values, int threads, float *out, sg_error *err)
{
    return sg_samples_interpolate_n(ps, set, s0, support, normal_cos, values, 3, threads, out, err);
}

sg_status sg_samples_interpolate_n(const sg_sites *ps, const sg_sample_set *set, float s0, float support,
                                   float normal_cos, const float *values, int channels, int threads, float *out,
                                   sg_error *err)
{
    if (channels < 1 || channels > SG_SAMPLES_MAX_CHANNELS)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "samples: %d channels (1..%d)", channels,
                            SG_SAMPLES_MAX_CHANNELS);
    const size_t nc = (size_t)channels;
    if (set->count == 0) {
        memset(out, 0, nc * ps->count * sizeof *out);
        return SG_OK;
    }
    grid g;
    if (!grid_of_samples(&g, ps, set, support * s0))
        return sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for the interpolation grid");
    lazy_tree lt = {0};
    int nt = threads > 0 ? threads : omp_get_max_threads(), nomem = 0;
#pragma omp parallel num_threads(nt) reduction(| : nomem)
    {
        near_list nl = {0};
#pragma omp for schedule(dynamic, 1024)
        for (size_t i = 0; i < ps->count; ++i) {
            sg_vec3 p = sg_sites_position(ps, i), n = sg_sites_normal(ps, i), t, bt;
            sg_v3_basis(n, &t, &bt);
            uint32_t heads[27];
            grid_around(&g, p, heads);
            fit_sums fs;
            fit_init(&fs, nc);
            float inv_r0 = 1.0f / (support * s0);
            double cover[SG_SAMPLES_MAX_LEVEL + 1] = {0}, level_w[SG_SAMPLES_MAX_LEVEL + 1];
            nl.n = 0;
            for (int k = 0; k < 27; ++k)
                for (uint32_t j = heads[k]; j != NONE; j = g.next[j]) {
                    sg_vec3 dp;
                    float q;
                    if (!reaches(ps, set, j, p, n, s0, support, normal_cos, &dp, &q))
                        continue;
                    cover[set->level[j]] += wendland(q);
                    nomem |= !near_push(&nl, j, q, dp);
                }
            levels_weights(cover, level_w);
            for (size_t k = 0; k < nl.n; ++k) {
                double w = (double)wendland(nl.q[k]) * level_w[set->level[nl.j[k]]];
                if (!(w > 0.0))
                    continue; /* a coarser level that finer samples cover */
                fit_add(&fs, w, sg_v3_dot(nl.dp[k], t) * inv_r0, sg_v3_dot(nl.dp[k], bt) * inv_r0,
                        values + nc * nl.j[k], nc);
            }
            if (fs.m[0] > 0.0) {
                fit_solve(&fs, nc, out + nc * i);
            } else {
                uint32_t j = nearest_in_cells(&g, ps, set, i, normal_cos);
                if (j == NONE)
                    j = nearest_anywhere(&lt, ps, set, i);
                if (j != NONE) /* else out of memory, reported below */
                    memcpy(out + nc * i, values + nc * (size_t)j, nc * sizeof *out);
            }
        }
        near_free(&nl);
    }
    sg_knn_destroy(lt.tree);
    grid_free(&g);
    if (lt.failed || nomem)
        return sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for the interpolation");
    return SG_OK;
}

sg_status sg_samples_nearest(const sg_sites *ps, const sg_sample_set *set, float s0, float normal_cos,
                             int threads, uint32_t *out, sg_error *err)
{
    if (set->count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "samples: no sample points");
    grid g;
    if (!grid_of_samples(&g, ps, set, 2.0f * s0))
        return sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for the nearest-sample grid");
    lazy_tree lt = {0};
    int nt = threads > 0 ? threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1024) num_threads(nt)
    for (size_t i = 0; i < ps->count; ++i) {
        uint32_t j = nearest_in_cells(&g, ps, set, i, normal_cos);
        out[i] = j != NONE ? j : nearest_anywhere(&lt, ps, set, i);
    }
    sg_knn_destroy(lt.tree);
    grid_free(&g);
    if (lt.failed)
        return sg_error_set(err, SG_ERR_NOMEM, "samples: out of memory for the samples' kd-tree");
    return SG_OK;
}
