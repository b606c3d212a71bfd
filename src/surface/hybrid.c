/* hybrid.c — creating the hybrid point/triangle surface (Ye 2005, PPRT
 * §3.1) from a mesh, and what a hit gives a renderer or a bake: light
 * sites and weights, colour, spawned rays. The traversal is in
 * hybrid_trace.c. See hybrid.h for the contract, hybrid_int.h for the
 * invariants.
 *
 * States: CHECKED (the mesh validated; degenerate triangles set aside) ->
 * NORMALS (vertex normals given or computed) -> BUILT (sphere tree over
 * the traced triangles) -> PACKED (triangles in leaf order, vertices
 * copied) -> queryable. sg_hybrid_create runs them all or fails whole and
 * frees what it took.
 *
 * Degenerate triangles. A triangle whose edge vectors have a zero cross
 * product in double (exact for the float coordinates of any mesh whose
 * extent spans fewer than 2^29 of its smallest coordinate steps) has no
 * area and no normal: it is left out of the hierarchy, where it could only
 * ever be hit edge-on, and counted. Keeping the traced set free of them
 * is what lets every node have a normal cone (sphere_tree.c).
 */
#include "surface/hybrid_int.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "math/oct.h"

enum { W = SG_STREE_WIDTH };

/* Vertex normal of a vertex that no traced triangle uses. */
#define NO_NORMAL 0x80008000u

static const char *mesh_name(const sg_hybrid_desc *d) { return d && d->name ? d->name : "mesh"; }

static int finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

/* (v1 - v0) x (v2 - v0) in double. */
static void cross_d(const float *a, const float *b, const float *c, double n[3])
{
    double e1[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
    double e2[3] = {(double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2]};
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

void sg_hybrid_destroy(sg_hybrid *h)
{
    if (!h)
        return;
    if (h->borrowed) { /* the arrays are a world file's (hybrid_int.h) */
        sg_free(h);
        return;
    }
    sg_stree_free(&h->tree);
    sg_free(h->tri);
    sg_free(h->tri_id);
    sg_free(h->pos);
    sg_free(h->vnormal);
    sg_free(h->vcolor);
    sg_free(h->lattice);
    sg_free(h);
}

/* Validates the mesh; fills the traced triangles (input indices) and
 * counts the degenerate ones. */
static sg_status check_mesh(const sg_hybrid_desc *d, const sg_mesh *m, uint32_t **traced, size_t *count,
                            sg_error *err)
{
    const char *name = mesh_name(d);
    if (m->triangle_count == 0 || !m->triangles)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: the mesh has no triangles", name);
    if (m->triangle_count > SG_STREE_MAX_TRIANGLES)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: %zu triangles exceed the limit of %u", name,
                            m->triangle_count, SG_STREE_MAX_TRIANGLES);
    if (m->vertex_count == 0 || !m->positions)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: the mesh has no vertex positions", name);
    if (m->vertex_count >= SG_INVALID_ID)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: %zu vertices exceed 32-bit ids", name, m->vertex_count);
    for (size_t v = 0; v < m->vertex_count; ++v) {
        if (!finite3(m->positions + 3 * v))
            return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: vertex %zu: position is not finite", name, v);
        if (m->normals && !(d->flags & SG_HYBRID_FLAT_SHADING)) {
            const float *n = m->normals + 3 * v;
            if (!finite3(n) || n[0] * n[0] + n[1] * n[1] + n[2] * n[2] < 1e-20f)
                return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: vertex %zu: normal is not finite or zero", name,
                                    v);
        }
        if (m->colors && !finite3(m->colors + 3 * v))
            return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: vertex %zu: colour is not finite", name, v);
    }
    uint32_t *ids = sg_alloc_array(m->triangle_count, sizeof *ids);
    if (!ids)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu triangles", name, m->triangle_count);
    size_t n = 0;
    for (size_t t = 0; t < m->triangle_count; ++t) {
        const uint32_t *v = m->triangles + 3 * t;
        for (int k = 0; k < 3; ++k)
            if (v[k] >= m->vertex_count) {
                sg_free(ids);
                return sg_error_set(err, SG_ERR_INVALID_ARG,
                                    "%s: triangle %zu: vertex index %u is out of range (%zu vertices)", name, t,
                                    v[k], m->vertex_count);
            }
        double c[3];
        cross_d(m->positions + 3 * (size_t)v[0], m->positions + 3 * (size_t)v[1], m->positions + 3 * (size_t)v[2],
                c);
        if (c[0] != 0.0 || c[1] != 0.0 || c[2] != 0.0)
            ids[n++] = (uint32_t)t;
    }
    if (n == 0) {
        sg_free(ids);
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: all %zu triangles have zero area", name,
                            m->triangle_count);
    }
    *traced = ids;
    *count = n;
    return SG_OK;
}

/* Vertex normals (invariant 2): the mesh's own, or the area-weighted mean
 * of the traced triangles' normals, summed in input order (deterministic). */
static sg_status make_normals(sg_hybrid *h, const sg_mesh *m, const uint32_t *traced, size_t count,
                              const char *name, sg_error *err)
{
    const size_t nv = m->vertex_count;
    h->vnormal = sg_alloc_array(nv, sizeof *h->vnormal);
    if (!h->vnormal)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu vertex normals", name, nv);
    if (m->normals) {
        for (size_t v = 0; v < nv; ++v) {
            const float *n = m->normals + 3 * v;
            h->vnormal[v] = sg_oct_encode(sg_v3_normalize(sg_v3(n[0], n[1], n[2])));
        }
        return SG_OK;
    }
    float *sum = sg_calloc_array(nv, 3 * sizeof(float));
    uint8_t *used = sg_calloc_array(nv, 1);
    if (!sum || !used) {
        sg_free(sum);
        sg_free(used);
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu vertex normals", name, nv);
    }
    for (size_t i = 0; i < count; ++i) {
        const uint32_t *v = m->triangles + 3 * (size_t)traced[i];
        double c[3];
        cross_d(m->positions + 3 * (size_t)v[0], m->positions + 3 * (size_t)v[1], m->positions + 3 * (size_t)v[2],
                c);
        for (int k = 0; k < 3; ++k) {
            float *s = sum + 3 * (size_t)v[k];
            s[0] += (float)c[0];
            s[1] += (float)c[1];
            s[2] += (float)c[2];
            used[v[k]] = 1;
        }
    }
    /* A vertex whose triangles' normals cancel (a fin of a non-manifold
     * edge) takes the normal of its first triangle. */
    for (size_t i = 0; i < count; ++i) {
        const uint32_t *v = m->triangles + 3 * (size_t)traced[i];
        for (int k = 0; k < 3; ++k) {
            float *s = sum + 3 * (size_t)v[k];
            if (s[0] == 0.0f && s[1] == 0.0f && s[2] == 0.0f) {
                double c[3];
                cross_d(m->positions + 3 * (size_t)v[0], m->positions + 3 * (size_t)v[1],
                        m->positions + 3 * (size_t)v[2], c);
                s[0] = (float)c[0];
                s[1] = (float)c[1];
                s[2] = (float)c[2];
            }
        }
    }
    for (size_t v = 0; v < nv; ++v) {
        const float *s = sum + 3 * v;
        h->vnormal[v] = used[v] ? sg_oct_encode(sg_v3_normalize(sg_v3(s[0], s[1], s[2]))) : NO_NORMAL;
    }
    sg_free(sum);
    sg_free(used);
    return SG_OK;
}


/* Invariant 5: the vertices numbered by first use in leaf order (those no
 * traced triangle uses after them, in mesh order), so that a leaf's
 * vertices lie in a few consecutive cache lines instead of wherever the
 * mesh file put them (the dragon: 4.0 lines a leaf instead of 5.8). Copies
 * the positions and colours into h in that order, permutes h->vnormal and
 * renames the vertex ids of h->tri. */
static sg_status renumber_vertices(sg_hybrid *h, const sg_mesh *mesh, const char *name, sg_error *err)
{
    const size_t nv = mesh->vertex_count, nt = h->info.triangle_count;
    uint32_t *to = sg_alloc_array(nv, sizeof *to);
    uint32_t *vn = h->vnormal ? sg_alloc_array(nv, sizeof *vn) : NULL;
    if (!to || (h->vnormal && !vn)) {
        sg_free(to);
        sg_free(vn);
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu vertices", name, nv);
    }
    memset(to, 0xFF, nv * sizeof *to);
    uint32_t next = 0;
    for (size_t i = 0; i < 3 * nt; ++i)
        if (to[h->tri[i]] == UINT32_MAX)
            to[h->tri[i]] = next++;
    for (size_t v = 0; v < nv; ++v)
        if (to[v] == UINT32_MAX)
            to[v] = next++;
    assert(next == nv);
    for (size_t i = 0; i < 3 * nt; ++i)
        h->tri[i] = to[h->tri[i]];
    for (size_t v = 0; v < nv; ++v) {
        memcpy(h->pos + 3 * (size_t)to[v], mesh->positions + 3 * v, 3 * sizeof *h->pos);
        if (h->vcolor)
            memcpy(h->vcolor + 3 * (size_t)to[v], mesh->colors + 3 * v, 3 * sizeof *h->vcolor);
        if (vn)
            vn[to[v]] = h->vnormal[v];
    }
    if (vn) {
        sg_free(h->vnormal);
        h->vnormal = vn;
    }
    sg_free(to);
    return SG_OK;
}

/* How far lattice sites sit inside their triangle, in cells (make_lattice). */
#define SHRINK 3e-3

/* The lattices of desc.site_spacing (hybrid_int.h invariant 4): for each
 * traced triangle in leaf order whose second-longest edge e exceeds the
 * spacing,
 * n = ceil(e / spacing) subdivisions and (n + 1)(n + 2) / 2 new vertices
 * appended after the mesh's, their positions, normals and colours the
 * triangle's vertices' interpolated in double. Triangles own disjoint
 * ranges, so the fill runs in parallel and gives the same bits on any
 * thread count. */
static sg_status make_lattice(sg_hybrid *h, float spacing, const char *name, sg_error *err)
{
    const size_t nt = h->info.triangle_count, nv = h->vertex_count;
    size_t total = 0, with = 0;
    uint32_t *lat = sg_alloc_array(nt, 2 * sizeof *lat);
    if (!lat)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu lattices", name, nt);
    for (size_t i = 0; i < nt; ++i) {
        const uint32_t *v = h->tri + 3 * i;
        double l[3];
        for (int k = 0; k < 3; ++k) {
            const float *a = h->pos + 3 * (size_t)v[k], *b = h->pos + 3 * (size_t)v[(k + 1) % 3];
            double d2 = 0.0;
            for (int q = 0; q < 3; ++q)
                d2 += ((double)b[q] - a[q]) * ((double)b[q] - a[q]);
            l[k] = sqrt(d2);
        }
        /* the second-longest edge: a gridded rectangle's cell side for its
         * right triangles; the longest small edge is then below 2 spacings
         * (triangle inequality) */
        const double e = fmax(fmin(l[0], l[1]), fmin(fmax(l[0], l[1]), l[2]));
        /* e / spacing within a few float roundings of an integer k (a
         * scaled ground's side over its cell) gives k, not k + 1 */
        double n = e > (double)spacing ? ceil(e / (double)spacing * (1.0 - 1e-6)) : 0.0;
        n = n >= 2.0 ? n : 0.0; /* one row: the triangle's own vertices */
        if (n > (double)SG_HYBRID_LATTICE_MAX_N) {
            sg_free(lat);
            return sg_error_set(err, SG_ERR_INVALID_ARG,
                                "%s: site spacing %g splits triangle %u (edge %g) into %.0f lattice rows, "
                                "more than %u",
                                name, (double)spacing, h->tri_id[i], e, n, SG_HYBRID_LATTICE_MAX_N);
        }
        const size_t sites = n > 0.0 ? ((size_t)n + 1) * ((size_t)n + 2) / 2 : 0;
        if (nv + total + sites >= SG_INVALID_ID) {
            sg_free(lat);
            return sg_error_set(err, SG_ERR_INVALID_ARG,
                                "%s: site spacing %g makes more than %u vertices and lattice sites", name,
                                (double)spacing, SG_INVALID_ID - 1u);
        }
        lat[2 * i] = (uint32_t)(nv + total);
        lat[2 * i + 1] = (uint32_t)n;
        total += sites;
        with += sites > 0;
    }
    if (total == 0) {
        sg_free(lat);
        return SG_OK;
    }
    const size_t all = nv + total;
    if (!sg_realloc_array((void **)&h->pos, nv, all, 3 * sizeof *h->pos) ||
        (h->vnormal && !sg_realloc_array((void **)&h->vnormal, nv, all, sizeof *h->vnormal)) ||
        (h->vcolor && !sg_realloc_array((void **)&h->vcolor, nv, all, 3 * sizeof *h->vcolor))) {
        sg_free(lat);
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu lattice sites", name, total);
    }
    const ptrdiff_t nti = (ptrdiff_t)nt;
#pragma omp parallel for schedule(dynamic, 16)
    for (ptrdiff_t t = 0; t < nti; ++t) {
        const uint32_t n = lat[2 * t + 1], first = lat[2 * t];
        if (n == 0)
            continue;
        const uint32_t *v = h->tri + 3 * (size_t)t;
        const float *p[3] = {h->pos + 3 * (size_t)v[0], h->pos + 3 * (size_t)v[1], h->pos + 3 * (size_t)v[2]};
        sg_vec3 nn[3] = {sg_v3(0, 0, 0), sg_v3(0, 0, 0), sg_v3(0, 0, 0)};
        if (h->vnormal)
            for (int k = 0; k < 3; ++k)
                nn[k] = sg_oct_decode(h->vnormal[v[k]]);
        for (uint32_t i = 0; i <= n; ++i)
            for (uint32_t j = 0; i + j <= n; ++j) {
                const double w1 = (double)i / n, w2 = (double)j / n, w0 = 1.0 - w1 - w2;
                const size_t id = sg_hybrid__lattice_id(first, n, i, j);
                /* The position SHRINK (3/1000) of a cell inside the triangle
                 * (towards its centroid): a site on its edge, where a room's wall
                 * meets the floor, would start the bake's rays on the other
                 * wall's plane, and a crossing of a triangle metres wide at
                 * t ~ 0 rounds either way: 5.7% of those rays went through
                 * the wall (docs/hybrid.md). The lookup reads the lattice by
                 * barycentrics, not positions. */
                const double k = SHRINK / n, u0 = (1.0 - k) * w0 + k / 3.0, u1 = (1.0 - k) * w1 + k / 3.0,
                             u2 = (1.0 - k) * w2 + k / 3.0;
                for (int q = 0; q < 3; ++q)
                    h->pos[3 * id + (size_t)q] = (float)(u0 * p[0][q] + u1 * p[1][q] + u2 * p[2][q]);
                if (h->vnormal) {
                    double m[3] = {w0 * nn[0].x + w1 * nn[1].x + w2 * nn[2].x,
                                   w0 * nn[0].y + w1 * nn[1].y + w2 * nn[2].y,
                                   w0 * nn[0].z + w1 * nn[1].z + w2 * nn[2].z};
                    double l = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
                    /* opposite vertex normals cancel only on a fin (check_mesh's
                     * non-manifold case): then the first vertex's */
                    h->vnormal[id] = l > 0.0 ? sg_oct_encode(sg_v3((float)(m[0] / l), (float)(m[1] / l),
                                                                   (float)(m[2] / l)))
                                             : h->vnormal[v[0]];
                }
                if (h->vcolor)
                    for (int q = 0; q < 3; ++q)
                        h->vcolor[3 * id + (size_t)q] =
                            (float)(w0 * h->vcolor[3 * (size_t)v[0] + (size_t)q] +
                                    w1 * h->vcolor[3 * (size_t)v[1] + (size_t)q] +
                                    w2 * h->vcolor[3 * (size_t)v[2] + (size_t)q]);
            }
    }
    h->lattice = lat;
    h->vertex_count = all;
    h->info.lattice_triangles = with;
    h->info.lattice_sites = total;
    return SG_OK;
}

sg_status sg_hybrid_create(const sg_hybrid_desc *desc, const sg_mesh *mesh, sg_hybrid **out, sg_error *err)
{
    double t_start = omp_get_wtime();
    const char *name = mesh_name(desc);
    if (!mesh || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: NULL mesh or out", name);
    sg_hybrid_desc d = desc ? *desc : (sg_hybrid_desc){0};
    if (d.flags & ~(uint32_t)(SG_HYBRID_CULL_BACKFACES | SG_HYBRID_FLAT_SHADING))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: unknown flags 0x%x", name, d.flags);
    if (d.traversal != SG_HYBRID_TRAVERSE_STACK && d.traversal != SG_HYBRID_TRAVERSE_HEAP)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: unknown traversal %d", name, (int)d.traversal);
    if (d.leaf_max == 0)
        d.leaf_max = 8; /* 4 traced 2.5% faster for 33% more memory (docs/hybrid.md) */
    if (d.leaf_max < 1 || d.leaf_max > SG_STREE_MAX_LEAF)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: leaf_max %d is outside 1..%d", name, d.leaf_max,
                            SG_STREE_MAX_LEAF);
    if (d.threads < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: threads %d is negative", name, d.threads);
    if (!(d.site_spacing >= 0.0f) || !isfinite(d.site_spacing))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: site spacing %g is not a finite length >= 0", name,
                            (double)d.site_spacing);
    uint32_t *traced = NULL, *ctri = NULL;
    size_t count = 0;
    sg_status st = check_mesh(&d, mesh, &traced, &count, err); /* messages name d.name */
    if (st != SG_OK)
        return st;
    d.name = NULL; /* not kept: the caller's string may not outlive the call */
    sg_hybrid *h = sg_calloc_array(1, sizeof *h);
    if (!h) {
        sg_free(traced);
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", name);
    }
    h->desc = d;
    h->vertex_count = mesh->vertex_count;
    const size_t nv = mesh->vertex_count;

    if (!(d.flags & SG_HYBRID_FLAT_SHADING) && (st = make_normals(h, mesh, traced, count, name, err)) != SG_OK)
        goto fail;

    /* The traced triangles, compacted, for the tree. */
    ctri = sg_alloc_array(count, 3 * sizeof *ctri);
    if (!ctri) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu triangles", name, count);
        goto fail;
    }
    sg_aabb bounds = sg_aabb_empty();
    for (size_t i = 0; i < count; ++i)
        for (int k = 0; k < 3; ++k) {
            uint32_t v = mesh->triangles[3 * (size_t)traced[i] + (size_t)k];
            ctri[3 * i + (size_t)k] = v;
            const float *p = mesh->positions + 3 * (size_t)v;
            bounds = sg_aabb_grow(bounds, sg_v3(p[0], p[1], p[2]));
        }

    sg_stree_desc sd = {.vertex_count = nv, .positions = mesh->positions, .triangle_count = count,
                        .triangles = ctri, .colors = mesh->colors, .leaf_max = d.leaf_max, .threads = d.threads};
    if ((st = sg_stree_build(&sd, &h->tree, err)) != SG_OK) {
        char inner[SG_ERROR_MESSAGE_MAX];
        snprintf(inner, sizeof inner, "%s", err ? err->message : "");
        st = sg_error_set(err, st, "%s: %s", name, inner);
        goto fail;
    }

    /* Invariant 1: triangles in leaf order. */
    h->tri = sg_alloc_array(count, 3 * sizeof *h->tri);
    h->tri_id = sg_alloc_array(count, sizeof *h->tri_id);
    h->pos = sg_alloc_array(nv, 3 * sizeof *h->pos);
    if (mesh->colors)
        h->vcolor = sg_alloc_array(nv, 3 * sizeof *h->vcolor);
    if (!h->tri || !h->tri_id || !h->pos || (mesh->colors && !h->vcolor)) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu triangles and %zu vertices", name, count,
                          nv);
        goto fail;
    }
    for (size_t i = 0; i < count; ++i) {
        uint32_t c = h->tree.order[i];
        memcpy(h->tri + 3 * i, ctri + 3 * (size_t)c, 3 * sizeof *h->tri);
        h->tri_id[i] = traced[c];
    }
    sg_free(h->tree.order); /* invariant 3 */
    h->tree.order = NULL;
    sg_free(ctri);
    ctri = NULL;
    h->info.triangle_count = count; /* renumber_vertices and make_lattice read it */
    if ((st = renumber_vertices(h, mesh, name, err)) != SG_OK)
        goto fail;
    if (d.site_spacing > 0.0f && (st = make_lattice(h, d.site_spacing, name, err)) != SG_OK)
        goto fail;

    float extent = fmaxf(fmaxf(fabsf(bounds.lo.x), fabsf(bounds.hi.x)),
                         fmaxf(fmaxf(fabsf(bounds.lo.y), fabsf(bounds.hi.y)),
                               fmaxf(fabsf(bounds.lo.z), fabsf(bounds.hi.z))));
    sg_hybrid_info *in = &h->info;
    in->diagonal = sg_aabb_diagonal(bounds);
    /* A hit point is a barycentric sum of float vertices: off its triangle
     * by a few units in the last place of the largest coordinate. */
    h->self_eps = 8.0f * FLT_EPSILON * (extent + in->diagonal);
    in->input_triangles = mesh->triangle_count;
    in->triangle_count = count;
    in->degenerate_count = mesh->triangle_count - count;
    in->vertex_count = h->vertex_count; /* lattice sites included */
    in->node_count = h->tree.node_count;
    in->leaf_count = h->tree.leaf_count;
    in->node_slots = h->tree.bundle_count * W;
    in->width = W;
    in->leaf_max = d.leaf_max;
    in->depth = h->tree.depth;
    in->memory_nodes = h->tree.bundle_count * sizeof(sg_stree_bundle);
    in->memory_triangles = count * (3 * sizeof *h->tri + sizeof *h->tri_id);
    in->memory_vertices = h->vertex_count * 3 * sizeof *h->pos;
    in->memory_normals = h->vnormal ? h->vertex_count * sizeof *h->vnormal : 0;
    in->memory_lattice = h->lattice ? count * 2 * sizeof *h->lattice : 0;
    in->memory_colors = (h->vcolor ? h->vertex_count * 3 * sizeof(float) : 0) +
                        (h->tree.colors ? in->node_slots * 3 * sizeof(float) : 0);
    in->memory_bytes = sizeof *h + in->memory_nodes + in->memory_triangles + in->memory_vertices +
                       in->memory_normals + in->memory_colors + in->memory_lattice;
    in->bytes_per_triangle = (double)in->memory_bytes / (double)count;
    in->bounds = bounds;
    sg_free(traced);
    in->build_seconds = omp_get_wtime() - t_start;
    *out = h;
    return SG_OK;

fail:
    sg_free(traced);
    sg_free(ctri);
    sg_hybrid_destroy(h);
    return st;
}

void sg_hybrid_get_info(const sg_hybrid *h, sg_hybrid_info *info) { *info = h->info; }

size_t sg_hybrid_site_count(const sg_hybrid *h) { return h->vertex_count + h->info.node_slots; }

/* Node k's radius, centre, mean normal and disk centre. */
static int node_geometry(const sg_hybrid *h, uint32_t k, float *r, sg_vec3 *c, sg_vec3 *n, sg_vec3 *disk)
{
    if ((size_t)k >= h->info.node_slots)
        return 0;
    const sg_stree_bundle *B = &h->tree.bundles[k / W];
    const int l = (int)(k % W);
    if (!(B->r[l] > 0.0f))
        return 0; /* empty lane (NaN) */
    *r = B->r[l];
    *c = sg_v3(B->cx[l], B->cy[l], B->cz[l]);
    *n = sg_stree_normal(B, l);
    *disk = sg_v3_madd(*c, *n, (float)B->offset[l] / 127.0f * B->r[l]);
    return 1;
}

int sg_hybrid_site(const sg_hybrid *h, uint32_t id, sg_vec3 *pos, sg_vec3 *normal)
{
    if ((size_t)id < h->vertex_count) {
        const float *p = h->pos + 3 * (size_t)id;
        *pos = sg_v3(p[0], p[1], p[2]);
        *normal = h->vnormal && h->vnormal[id] != NO_NORMAL ? sg_oct_decode(h->vnormal[id]) : sg_v3(0, 0, 0);
        return 1;
    }
    float r;
    sg_vec3 c, n, disk;
    if ((size_t)id - h->vertex_count >= h->info.node_slots ||
        !node_geometry(h, (uint32_t)((size_t)id - h->vertex_count), &r, &c, &n, &disk))
        return 0;
    *pos = disk;
    *normal = n;
    return 1;
}

float sg_hybrid_node_radius(const sg_hybrid *h, uint32_t node)
{
    float r;
    sg_vec3 c, n, disk;
    return node_geometry(h, node, &r, &c, &n, &disk) ? r : 0.0f;
}

int sg_hybrid_hit_sites(const sg_hybrid *h, const sg_hybrid_hit *hit, uint32_t *ids, float *weights, int max)
{
    if (max <= 0)
        return 0;
    if (hit->node != SG_INVALID_ID) {
        ids[0] = (uint32_t)(h->vertex_count + hit->node);
        weights[0] = 1.0f;
        return 1;
    }
    if (hit->triangle == SG_INVALID_ID)
        return 0;
    uint32_t v[3];
    float b1, b2;
    if (hit->slot < h->info.triangle_count)
        sg_hybrid__light_triangle(h, hit->slot, hit->vertex, hit->b1, hit->b2, v, &b1, &b2);
    else /* a hit made by hand, without its slot: a lattice can not be read */
        memcpy(v, hit->vertex, sizeof v), b1 = hit->b1, b2 = hit->b2;
    return sg_hybrid__triangle_sites(v, b1, b2, ids, weights, max);
}

int sg_hybrid_hit_color(const sg_hybrid *h, const sg_hybrid_hit *hit, sg_vec3 *rgb)
{
    if (!h->vcolor)
        return 0;
    if (hit->node != SG_INVALID_ID) {
        if ((size_t)hit->node >= h->info.node_slots)
            return 0;
        const float *c = h->tree.colors + 3 * (size_t)hit->node;
        *rgb = sg_v3(c[0], c[1], c[2]);
        return 1;
    }
    if (hit->triangle == SG_INVALID_ID)
        return 0;
    uint32_t ids[3];
    float w[3];
    int n = sg_hybrid_hit_sites(h, hit, ids, w, 3);
    sg_vec3 s = sg_v3(0, 0, 0);
    for (int i = 0; i < n; ++i) {
        const float *c = h->vcolor + 3 * (size_t)ids[i];
        s = sg_v3_madd(s, sg_v3(c[0], c[1], c[2]), w[i]);
    }
    *rgb = s;
    return 1;
}

sg_ray sg_hybrid_spawn_ray(const sg_hybrid *h, const sg_hybrid_hit *hit, sg_vec3 dir, float tmax)
{
    sg_ray r = {.org = hit->p, .dir = dir, .tmin = 0.0f, .tmax = tmax};
    r.flags = sg_v3_dot(dir, hit->ng) >= 0.0f ? SG_RAY_FRONT_ONLY : SG_RAY_BACK_ONLY;
    r.self_n = hit->ng;
    r.self_r = h->self_eps;
    float rad;
    sg_vec3 c, n, disk;
    if (hit->node != SG_INVALID_ID && node_geometry(h, hit->node, &rad, &c, &n, &disk))
        r.self_r = 2.0f * rad;
    return r;
}

sg_footprint sg_hybrid_spawn_footprint(const sg_footprint *fp, const sg_hybrid_hit *hit, float spread)
{
    sg_footprint f = {0.0f, 0.0f, 0.0f};
    if (!fp || !(fp->lod > 0.0f))
        return f;
    f.width = fp->width + fp->spread * hit->t;
    f.spread = spread;
    f.lod = fp->lod;
    return f;
}

static uint64_t fnv(uint64_t h, const void *data, size_t bytes)
{
    const unsigned char *p = data;
    for (size_t i = 0; p && i < bytes; ++i) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

uint64_t sg_hybrid_layout_hash(const sg_hybrid *h)
{
    uint64_t x = 0xcbf29ce484222325ull;
    x = fnv(x, h->tree.bundles, h->tree.bundle_count * sizeof *h->tree.bundles);
    if (h->tree.colors)
        x = fnv(x, h->tree.colors, h->info.node_slots * 3 * sizeof(float));
    x = fnv(x, h->tri, h->info.triangle_count * 3 * sizeof *h->tri);
    x = fnv(x, h->tri_id, h->info.triangle_count * sizeof *h->tri_id);
    x = fnv(x, h->pos, h->vertex_count * 3 * sizeof *h->pos);
    if (h->vnormal)
        x = fnv(x, h->vnormal, h->vertex_count * sizeof *h->vnormal);
    if (h->vcolor)
        x = fnv(x, h->vcolor, h->vertex_count * 3 * sizeof *h->vcolor);
    if (h->lattice)
        x = fnv(x, h->lattice, h->info.triangle_count * 2 * sizeof *h->lattice);
    return x;
}
