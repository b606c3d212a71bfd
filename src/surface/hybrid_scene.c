/* hybrid_scene.c — the hybrid hierarchy's hits and light sites in the
 * terms of scene.h (Ye 2005 as a surface model). See hybrid_scene.h.
 *
 * Invariants:
 *  1. every site has a finite position, a unit normal and a reach > 0
 *     (stand-ins copy the first real vertex site);
 *  2. a triangle hit's sg_hit.leaf < triangle_count and names the triangle
 *     in leaf order; a node hit's splat >= vertex_count;
 *  3. queries read the hierarchy and the sites only (thread-safe).
 */
/* madvise(MADV_HUGEPAGE) is outside POSIX: glibc declares it with this. */
#define _DEFAULT_SOURCE
#include "surface/hybrid_scene.h"

#include <assert.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <omp.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "core/alloc.h"
#include "surface/hybrid_int.h"

enum { CHANNELS = 10 }; /* px py pz nx ny nz radius ar ag ab */

void sg_hybrid_sites_free(sg_hybrid_sites *s)
{
    if (!s)
        return;
    sg_free(s->data);
    memset(s, 0, sizeof *s);
}

size_t sg_hybrid_sites_memory(const sg_hybrid_sites *s) { return s->view.count * CHANNELS * sizeof(float); }

static int usable_normal(sg_vec3 n)
{
    float l = n.x * n.x + n.y * n.y + n.z * n.z;
    return isfinite(l) && fabsf(l - 1.0f) < 1e-3f;
}

/* Asks for transparent huge pages over the whole 2 MiB pages inside
 * [p, p + bytes), before anything is written there. The sites' arrays are
 * fresh memory written once; under the virtual machines we measure on, a
 * 4 KiB page fault costs ~10 us, and the dragon's 32 MiB of sites took
 * 145-220 ms of page faults against 55-75 ms with huge pages (one
 * thread; docs/hybrid.md). Advice only: where it is refused or absent,
 * nothing changes but the time. */
static void advise_huge_pages(void *p, size_t bytes)
{
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    const uintptr_t huge = (uintptr_t)2 << 20;
    const uintptr_t a0 = ((uintptr_t)p + huge - 1) & ~(huge - 1), a1 = ((uintptr_t)p + bytes) & ~(huge - 1);
    if (a1 > a0)
        (void)madvise((void *)a0, (size_t)(a1 - a0), MADV_HUGEPAGE);
#else
    (void)p;
    (void)bytes;
#endif
}

/* Sites are independent of one another, so the passes run in parallel
 * (OpenMP) and every site is computed exactly as the serial loop would
 * (bit for bit on any thread count: test_hybrid sites_threads_identical).
 * At a world file's load this was half the time (the dragon's 805k sites,
 * 0.2 s), nearly all of it page faults on the fresh sites array: hence
 * huge pages, and the faults shared between the threads. */
sg_status sg_hybrid_sites_create(const sg_hybrid *h, sg_hybrid_sites *out, sg_error *err)
{
    memset(out, 0, sizeof *out);
    const size_t nv = h->vertex_count, n = sg_hybrid_site_count(h);
    const ptrdiff_t nt = (ptrdiff_t)h->info.triangle_count, ns = (ptrdiff_t)n, nvv = (ptrdiff_t)nv;
    float *d = sg_alloc_array(n, CHANNELS * sizeof(float));
    float *reach = sg_alloc_array(nv, sizeof *reach);
    if (!d || (nv && !reach)) {
        sg_free(d);
        sg_free(reach);
        return sg_error_set(err, SG_ERR_NOMEM, "hybrid: out of memory for %zu light sites", n);
    }
    advise_huge_pages(d, n * CHANNELS * sizeof(float));
    float *px = d, *py = d + n, *pz = d + 2 * n, *nx = d + 3 * n, *ny = d + 4 * n, *nz = d + 5 * n;
    float *rad = d + 6 * n, *ar = d + 7 * n, *ag = d + 8 * n, *ab = d + 9 * n;
    /* A vertex's reach: its longest traced edge, so its light spans the
     * triangles it is interpolated over. Each thread owns a range of
     * vertices and reads every triangle, updating only its own: no two
     * threads write one slot, and a maximum does not depend on the order
     * it is taken in, so the result is the serial loop's on any thread
     * count (an atomic max instead took twice the serial time on one
     * thread: test_hybrid sites_threads_identical, docs/hybrid.md). */
#pragma omp parallel
    {
        const size_t nth = (size_t)omp_get_num_threads(), me = (size_t)omp_get_thread_num();
        const size_t lo = nv / nth * me + (me < nv % nth ? me : nv % nth);
        const size_t span = nv / nth + (me < nv % nth ? 1 : 0);
        for (size_t i = lo; i < lo + span; ++i)
            reach[i] = 0.0f;
        for (ptrdiff_t i = 0; i < nt; ++i) {
            const uint32_t *v = h->tri + 3 * (size_t)i;
            if (h->lattice && h->lattice[2 * i + 1]) /* its lattice sites carry its light */
                continue;
            for (int k = 0; k < 3; ++k) {
                const size_t va = v[k], vb = v[(k + 1) % 3];
                const int mine_a = va - lo < span, mine_b = vb - lo < span; /* unsigned: va >= lo too */
                if (!mine_a && !mine_b)
                    continue;
                const float *a = h->pos + 3 * va, *b = h->pos + 3 * vb;
                float e = sqrtf((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                                (a[2] - b[2]) * (a[2] - b[2]));
                if (mine_a)
                    reach[va] = e > reach[va] ? e : reach[va]; /* fmaxf: a NaN e is ignored */
                if (mine_b)
                    reach[vb] = e > reach[vb] ? e : reach[vb];
            }
        }
    }
    /* A lattice site's reach: its triangle's longest edge over n, the
     * longest edge of the small triangles it is interpolated over. Each
     * triangle's sites are its own (hybrid_int.h invariant 4). */
    if (h->lattice) {
#pragma omp parallel for schedule(dynamic, 16)
        for (ptrdiff_t i = 0; i < nt; ++i) {
            const uint32_t n = h->lattice[2 * i + 1], first = h->lattice[2 * i];
            if (n == 0)
                continue;
            const uint32_t *v = h->tri + 3 * (size_t)i;
            float e = 0.0f;
            for (int k = 0; k < 3; ++k) {
                const float *a = h->pos + 3 * (size_t)v[k], *b = h->pos + 3 * (size_t)v[(k + 1) % 3];
                float l = sqrtf((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                                (a[2] - b[2]) * (a[2] - b[2]));
                e = l > e ? l : e;
            }
            const uint32_t count = (n + 1) * (n + 2) / 2;
            for (uint32_t q = 0; q < count; ++q)
                reach[first + q] = e / (float)n;
        }
    }
    ptrdiff_t first_real = PTRDIFF_MAX;
#pragma omp parallel for schedule(static) reduction(min : first_real)
    for (ptrdiff_t i = 0; i < ns; ++i) {
        sg_vec3 p, nn;
        float r = 0.0f;
        int ok = sg_hybrid_site(h, (uint32_t)i, &p, &nn) && usable_normal(nn) && sg_v3_isfinite(p);
        if (ok && i < nvv) {
            r = reach[i];
        } else if (ok) {
            const uint32_t k = (uint32_t)((size_t)i - nv);
            const sg_stree_bundle *B = &h->tree.bundles[k / SG_STREE_WIDTH];
            r = sg_hybrid_node_radius(h, k);
            ok = B->sin_cone[k % SG_STREE_WIDTH] != 255; /* never hit as a point */
        }
        ok = ok && r > 0.0f && isfinite(r);
        sg_vec3 c = sg_v3(1.0f, 1.0f, 1.0f);
        if (ok && h->vcolor) {
            const float *col = i < nvv ? h->vcolor + 3 * i : h->tree.colors + 3 * ((size_t)i - nv);
            c = sg_v3(col[0], col[1], col[2]);
        }
        if (!ok) {
            rad[i] = -1.0f; /* stand-in, filled below */
            continue;
        }
        if (i < first_real)
            first_real = i;
        px[i] = p.x, py[i] = p.y, pz[i] = p.z;
        nx[i] = nn.x, ny[i] = nn.y, nz[i] = nn.z;
        rad[i] = r;
        ar[i] = c.x, ag[i] = c.y, ab[i] = c.z;
    }
    sg_free(reach);
    /* create() keeps at least one triangle of non-zero area, and its
     * vertices have normals: there is a real site. */
    if (first_real == PTRDIFF_MAX) {
        sg_free(d);
        return sg_error_set(err, SG_ERR_INVALID_ARG, "hybrid: no vertex has a usable normal");
    }
    const size_t j = (size_t)first_real;
#pragma omp parallel for schedule(static)
    for (ptrdiff_t i = 0; i < ns; ++i)
        if (rad[i] < 0.0f) {
            px[i] = px[j], py[i] = py[j], pz[i] = pz[j];
            nx[i] = nx[j], ny[i] = ny[j], nz[i] = nz[j];
            rad[i] = rad[j];
            ar[i] = ar[j], ag[i] = ag[j], ab[i] = ab[j];
        }
    out->data = d;
    out->vertex_count = nv;
    out->view = (sg_sites){.count = n, .px = px, .py = py, .pz = pz, .nx = nx, .ny = ny, .nz = nz,
                           .radius = rad, .ar = ar, .ag = ag, .ab = ab, .white = !h->vcolor};
    return SG_OK;
}

static sg_footprint footprint(float lod, const sg_ray *ray)
{
    return (sg_footprint){0.0f, ray->spread, lod};
}

/* The geometric normal of the triangle at leaf-order position i. */
static sg_vec3 tri_normal(const sg_hybrid *h, uint32_t i)
{
    const uint32_t *v = h->tri + 3 * (size_t)i;
    const float *a = h->pos + 3 * (size_t)v[0], *b = h->pos + 3 * (size_t)v[1], *c = h->pos + 3 * (size_t)v[2];
    return sg_v3_normalize(sg_v3_cross(sg_v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]),
                                       sg_v3(c[0] - a[0], c[1] - a[1], c[2] - a[2])));
}

static void to_ray_stats(sg_ray_stats *s, const sg_hybrid_stats *hs)
{
    if (!s)
        return;
    s->rays += hs->rays;
    s->nodes += hs->pops;
    s->isects += hs->lod_tests;
    s->splats += hs->triangles;
    s->hits += hs->hits;
}

/* The sg_hit of a hierarchy hit (found) or miss. */
/* hh is read field by field, not copied: it was just written field by
 * field (write_hit), and a copy's wide loads of those narrow stores stall
 * on store forwarding. */
static int scene_hit(const sg_hybrid *h, const sg_hybrid_sites *s, const sg_ray *ray, const sg_hybrid_hit *hh,
                     int found, sg_hit *hit)
{
    if (!found) {
        hit->splat = SG_INVALID_ID;
        return 0;
    }
    hit->t = hh->t;
    hit->p = hh->p;
    if (hh->node != SG_INVALID_ID) {
        hit->n = hh->ns;
        hit->splat = (uint32_t)(s->vertex_count + hh->node);
        hit->leaf = SG_INVALID_ID;
        hit->b1 = hit->b2 = 0.0f;
        return 1;
    }
    /* The side the ray met is the geometric normal's; a shading normal
     * that says otherwise (a grazing ray) gives way to it. */
    float dg = sg_v3_dot(ray->dir, hh->ng), ds = sg_v3_dot(ray->dir, hh->ns);
    hit->n = (dg < 0.0f) == (ds < 0.0f) && ds != 0.0f ? hh->ns : hh->ng;
    hit->leaf = hh->slot;
    hit->b1 = hh->b1;
    hit->b2 = hh->b2;
    uint32_t v[3];
    float b1, b2;
    sg_hybrid__light_triangle(h, hh->slot, hh->vertex, hh->b1, hh->b2, v, &b1, &b2);
    hit->splat = sg_hybrid__dominant_site(v, b1, b2); /* the largest weight */
    return 1;
}

int sg_hybrid_scene_intersect(const sg_hybrid *h, const sg_hybrid_sites *s, float lod, const sg_ray *ray,
                              sg_hit *hit, sg_ray_stats *stats)
{
    sg_footprint fp = footprint(lod, ray);
    sg_hybrid_hit hh;
    sg_hybrid_stats hs = {0};
    int found = sg_hybrid_intersect(h, ray, lod > 0.0f ? &fp : NULL, &hh, stats ? &hs : NULL);
    to_ray_stats(stats, &hs);
    return scene_hit(h, s, ray, &hh, found, hit);
}

unsigned sg_hybrid_scene_intersect4(const sg_hybrid *h, const sg_hybrid_sites *s, float lod, const sg_ray rays[4],
                                    unsigned mask, sg_hit hits[4], sg_ray_stats *stats)
{
    return sg_hybrid_scene_intersect16(h, s, lod, rays, mask & 15u, hits, stats);
}

unsigned sg_hybrid_scene_intersect16(const sg_hybrid *h, const sg_hybrid_sites *s, float lod, const sg_ray *rays,
                                     unsigned mask, sg_hit *hits, sg_ray_stats *stats)
{
    sg_footprint fp[16];
    sg_hybrid_hit hh[16];
    sg_hybrid_stats hs = {0};
    mask &= 0xFFFFu;
    for (unsigned m = mask; m; m &= m - 1)
        fp[__builtin_ctz(m)] = footprint(lod, &rays[__builtin_ctz(m)]);
    unsigned found = sg_hybrid_intersect16(h, rays, mask, lod > 0.0f ? fp : NULL, hh, stats ? &hs : NULL);
    to_ray_stats(stats, &hs);
    for (unsigned m = mask; m; m &= m - 1) {
        const int r = __builtin_ctz(m);
        scene_hit(h, s, &rays[r], &hh[r], (int)(found >> r & 1u), &hits[r]);
    }
    return found;
}

int sg_hybrid_scene_occluded(const sg_hybrid *h, float lod, const sg_ray *ray, sg_ray_stats *stats)
{
    sg_footprint fp = footprint(lod, ray);
    sg_hybrid_stats hs = {0};
    int found = sg_hybrid_occluded(h, ray, lod > 0.0f ? &fp : NULL, stats ? &hs : NULL);
    to_ray_stats(stats, &hs);
    return found;
}

/* The triangle hit behind an sg_hit (invariant 2): vertices, the
 * barycentrics the triangle test found (the hit carries them) and the
 * geometric normal. */
static sg_hybrid_hit triangle_hit(const sg_hybrid *h, const sg_hit *hit)
{
    sg_hybrid_hit hh = {.t = hit->t, .p = hit->p, .node = SG_INVALID_ID, .slot = hit->leaf};
    const uint32_t *v = h->tri + 3 * (size_t)hit->leaf;
    hh.triangle = h->tri_id[hit->leaf];
    memcpy(hh.vertex, v, sizeof hh.vertex);
    hh.b1 = hit->b1;
    hh.b2 = hit->b2;
    hh.ng = tri_normal(h, hit->leaf);
    hh.ns = hit->n;
    return hh;
}

int sg_hybrid_scene_hit_sites(const sg_hybrid *h, const sg_hybrid_sites *s, const sg_hit *hit, uint32_t *ids,
                              float *weights, int max)
{
    if (max <= 0 || hit->splat == SG_INVALID_ID)
        return 0;
    if (hit->leaf < h->info.triangle_count) { /* the lookup's case, every pixel: no sg_hybrid_hit built */
        uint32_t v[3];
        float b1, b2;
        sg_hybrid__light_triangle(h, hit->leaf, h->tri + 3 * (size_t)hit->leaf, hit->b1, hit->b2, v, &b1, &b2);
        return sg_hybrid__triangle_sites(v, b1, b2, ids, weights, max);
    }
    if (hit->splat >= s->view.count)
        return 0;
    ids[0] = hit->splat;
    weights[0] = 1.0f;
    return 1;
}

sg_ray sg_hybrid_scene_spawn_ray(const sg_hybrid *h, const sg_hybrid_sites *s, const sg_hit *hit, sg_vec3 dir,
                                 float tmax)
{
    if (hit->leaf < h->info.triangle_count) {
        sg_hybrid_hit hh = triangle_hit(h, hit);
        /* The caller chose dir on one side of the shading normal; where the
         * triangle's plane puts it on the other (near the terminator of an
         * interpolated normal), it would pass through its own triangle: a
         * ray reflected off the inside of a closed mesh would leave it
         * (measured: the reference saw 3e-5 of the sky from inside a
         * closed sphere). Mirrored in the plane, it stays on its side. */
        float dn = sg_v3_dot(dir, hit->n), dg = sg_v3_dot(dir, hh.ng);
        if ((dn > 0.0f && dg < 0.0f) || (dn < 0.0f && dg > 0.0f))
            dir = sg_v3_normalize(sg_v3_madd(dir, hh.ng, -2.0f * dg));
        return sg_hybrid_spawn_ray(h, &hh, dir, tmax);
    }
    if (hit->splat >= s->vertex_count && hit->splat < s->view.count) {
        sg_hybrid_hit hh = {.t = hit->t, .p = hit->p, .ng = hit->n, .ns = hit->n, .triangle = SG_INVALID_ID,
                            .node = (uint32_t)(hit->splat - s->vertex_count), .slot = SG_INVALID_ID};
        return sg_hybrid_spawn_ray(h, &hh, dir, tmax);
    }
    /* A site hit at a vertex: its neighbours' triangles meet it at t ~ 0
     * within its reach; those within SG_SELF_COS of its normal are its own
     * surface (ray.h). */
    sg_ray r = {.org = hit->p, .dir = dir, .tmin = 0.0f, .tmax = tmax};
    r.flags = sg_v3_dot(dir, hit->n) >= 0.0f ? SG_RAY_FRONT_ONLY : SG_RAY_BACK_ONLY;
    if (hit->splat < s->view.count) {
        r.self_n = hit->n;
        r.self_r = s->view.radius[hit->splat];
    }
    return r;
}

enum { FILTER_MAX = 16 };

/* Adds area x the mean over a lattice's n^2 small triangles (all of one
 * area) of their vertex means to acc: a site on k of them counts k / 3
 * times. */
static void lattice_mean(uint32_t first, uint32_t n, const float *values, size_t stride, double area, double *acc)
{
    double sum[FILTER_MAX] = {0};
    for (uint32_t i = 0; i <= n; ++i)
        for (uint32_t j = 0; i + j <= n; ++j) {
            /* small triangles touching (i, j): up ones with it as corner
             * (i, j), (i - 1, j), (i, j - 1); down ones as (i - 1, j - 1)'s
             * d, and as the b / c of (i, j - 1) / (i - 1, j) */
            int k = 0;
            k += i + j < n;                                /* up (i, j)           */
            k += i >= 1 && i - 1 + j < n;                  /* up (i - 1, j)       */
            k += j >= 1 && i + j - 1 < n;                  /* up (i, j - 1)       */
            k += i >= 1 && j >= 1 && i + j <= n;           /* down (i - 1, j - 1) */
            k += j >= 1 && i + j + 1 <= n;                 /* down (i, j - 1)     */
            k += i >= 1 && i + j + 1 <= n;                 /* down (i - 1, j)     */
            const size_t id = sg_hybrid__lattice_id(first, n, i, j);
            for (size_t ch = 0; ch < stride; ++ch)
                sum[ch] += k * (double)values[id * stride + ch];
        }
    for (size_t ch = 0; ch < stride; ++ch)
        acc[ch] += area * sum[ch] / (3.0 * (double)n * (double)n);
}

/* Sums over node k's triangles of area x (vertex mean) into acc; writes
 * the node's mean; returns its area. Recursion depth: the tree's, <=
 * SG_STREE_MAX_DEPTH bundles (sphere_tree.h invariant 3). */
static double filter_node(const sg_hybrid *h, uint32_t k, float *values, size_t stride, double *acc)
{
    const uint32_t word = h->tree.bundles[k / SG_STREE_WIDTH].child[k % SG_STREE_WIDTH];
    double area = 0.0;
    for (size_t c = 0; c < stride; ++c)
        acc[c] = 0.0;
    if (word == SG_STREE_EMPTY)
        return 0.0;
    if (sg_stree_is_leaf(word)) {
        const uint32_t first = sg_stree_leaf_first(word), count = sg_stree_leaf_count(word);
        for (uint32_t i = first; i < first + count; ++i) {
            const uint32_t *v = h->tri + 3 * (size_t)i;
            const uint32_t n = h->lattice ? h->lattice[2 * (size_t)i + 1] : 0u;
            const float *a = h->pos + 3 * (size_t)v[0], *b = h->pos + 3 * (size_t)v[1], *c = h->pos + 3 * (size_t)v[2];
            double e1[3], e2[3];
            for (int q = 0; q < 3; ++q) {
                e1[q] = (double)b[q] - a[q];
                e2[q] = (double)c[q] - a[q];
            }
            double nx = e1[1] * e2[2] - e1[2] * e2[1], ny = e1[2] * e2[0] - e1[0] * e2[2],
                   nz = e1[0] * e2[1] - e1[1] * e2[0];
            double ar = 0.5 * sqrt(nx * nx + ny * ny + nz * nz);
            if (n == 0) {
                for (size_t ch = 0; ch < stride; ++ch)
                    acc[ch] += ar * ((double)values[v[0] * stride + ch] + values[v[1] * stride + ch] +
                                     values[v[2] * stride + ch]) / 3.0;
            } else {
                lattice_mean(h->lattice[2 * (size_t)i], n, values, stride, ar, acc);
            }
            area += ar;
        }
    } else {
        double sub[FILTER_MAX];
        for (uint32_t l = 0; l < SG_STREE_WIDTH; ++l) {
            area += filter_node(h, word * SG_STREE_WIDTH + l, values, stride, sub);
            for (size_t c = 0; c < stride; ++c)
                acc[c] += sub[c];
        }
    }
    if (area > 0.0)
        for (size_t c = 0; c < stride; ++c)
            values[(h->vertex_count + k) * stride + c] = (float)(acc[c] / area);
    return area;
}

void sg_hybrid_sites_filter(const sg_hybrid *h, const sg_hybrid_sites *s, float *values, size_t stride)
{
    assert(stride >= 1 && stride <= FILTER_MAX && s->vertex_count == h->vertex_count);
    (void)s;
    double acc[FILTER_MAX];
    filter_node(h, 0, values, stride, acc); /* node 0: the root (bundle 0, lane 0) */
}

sg_vec3 sg_hybrid_scene_hit_albedo(const sg_hybrid *h, const sg_hybrid_sites *s, const sg_hit *hit)
{
    uint32_t ids[3];
    float w[3];
    return sg_hybrid_scene_sites_albedo(h, s, ids, w, sg_hybrid_scene_hit_sites(h, s, hit, ids, w, 3));
}

sg_vec3 sg_hybrid_scene_sites_albedo(const sg_hybrid *h, const sg_hybrid_sites *s, const uint32_t *ids,
                                     const float *w, int n)
{
    if (n == 0)
        return sg_v3(1.0f, 1.0f, 1.0f);
    sg_vec3 c = sg_v3(0.0f, 0.0f, 0.0f);
    if (!h->vcolor) {
        /* Every site is white (sg_hybrid_sites_create): c + 1 w = c + w
         * exactly, so the sum of the weights is the same bits without
         * reading three sites' colours (cache misses in 10 channels of
         * 40 bytes a site). */
        for (int i = 0; i < n; ++i)
            c.x += w[i];
        return sg_v3(c.x, c.x, c.x);
    }
    for (int i = 0; i < n; ++i)
        c = sg_v3_madd(c, sg_v3(s->view.ar[ids[i]], s->view.ag[ids[i]], s->view.ab[ids[i]]), w[i]);
    return c;
}
