/* mesh_shapes.c — a latitude/longitude sphere and a gridded square as
 * triangle meshes. See mesh_shapes.h.
 *
 * Invariants: every vertex index < vertex_count; the sphere's vertices are
 * shared between neighbouring triangles (one per grid point, one per
 * pole), so every edge has exactly two triangles and shared edges use the
 * same two vertex ids (what a watertight test needs).
 */
#include "points/mesh_shapes.h"

#include <math.h>

#include "core/alloc.h"

enum { MAX_TRIANGLES = 1 << 28 };

static sg_status alloc_mesh(size_t nv, size_t nt, int normals, sg_mesh *m, sg_error *err)
{
    *m = (sg_mesh){.vertex_count = nv, .triangle_count = nt};
    m->positions = sg_alloc_array(nv, 3 * sizeof(float));
    m->normals = normals ? sg_alloc_array(nv, 3 * sizeof(float)) : NULL;
    m->triangles = sg_alloc_array(nt, 3 * sizeof(uint32_t));
    if (!m->positions || (normals && !m->normals) || !m->triangles) {
        sg_mesh_free(m);
        return sg_error_set(err, SG_ERR_NOMEM, "mesh shape: out of memory for %zu triangles", nt);
    }
    return SG_OK;
}

static void put_tri(uint32_t *t, size_t *k, uint32_t a, uint32_t b, uint32_t c)
{
    t[3 * *k] = a, t[3 * *k + 1] = b, t[3 * *k + 2] = c;
    ++*k;
}

sg_status sg_mesh_make_sphere(int rings, int segments, sg_vec3 centre, float radius, sg_mesh *out, sg_error *err)
{
    if (rings < 2 || segments < 3 || !(radius > 0.0f) || !isfinite(radius) || !sg_v3_isfinite(centre) ||
        (double)rings * segments * 2.0 > MAX_TRIANGLES)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "mesh sphere: need rings >= 2, segments >= 3, a finite radius > 0 (got %d, %d, %g)",
                            rings, segments, (double)radius);
    /* Vertex 0 the north pole, 1 the south pole, then rings - 1 bands of
     * `segments` vertices from north to south. */
    const size_t nv = 2 + (size_t)(rings - 1) * (size_t)segments;
    const size_t nt = 2 * (size_t)segments * (size_t)(rings - 1);
    sg_mesh m;
    sg_status st = alloc_mesh(nv, nt, 1, &m, err);
    if (st != SG_OK)
        return st;
    const double pi = 3.14159265358979323846;
    double dirs[2][3] = {{0, 1, 0}, {0, -1, 0}};
    for (int k = 0; k < 2; ++k)
        for (int a = 0; a < 3; ++a)
            m.normals[3 * k + a] = (float)dirs[k][a];
    for (int i = 1; i < rings; ++i) {
        double th = pi * i / rings;
        for (int j = 0; j < segments; ++j) {
            double ph = 2.0 * pi * j / segments;
            size_t v = 2 + (size_t)(i - 1) * segments + j;
            m.normals[3 * v] = (float)(sin(th) * cos(ph));
            m.normals[3 * v + 1] = (float)cos(th);
            m.normals[3 * v + 2] = (float)(-sin(th) * sin(ph)); /* so that the winding below faces out */
        }
    }
    const float c[3] = {centre.x, centre.y, centre.z};
    for (size_t v = 0; v < nv; ++v)
        for (int a = 0; a < 3; ++a)
            m.positions[3 * v + a] = c[a] + radius * m.normals[3 * v + a];
    size_t k = 0;
    for (int j = 0; j < segments; ++j) {
        uint32_t j1 = (uint32_t)((j + 1) % segments);
        uint32_t top = 2, bot = (uint32_t)(2 + (size_t)(rings - 2) * segments);
        put_tri(m.triangles, &k, 0, top + (uint32_t)j, top + j1);
        put_tri(m.triangles, &k, 1, bot + j1, bot + (uint32_t)j);
        for (int i = 1; i + 1 < rings; ++i) {
            uint32_t a = (uint32_t)(2 + (size_t)(i - 1) * segments), b = a + (uint32_t)segments;
            put_tri(m.triangles, &k, a + (uint32_t)j, b + (uint32_t)j, b + j1);
            put_tri(m.triangles, &k, a + (uint32_t)j, b + j1, a + j1);
        }
    }
    *out = m;
    return SG_OK;
}

sg_status sg_mesh_make_plane(int side, float half, sg_mesh *out, sg_error *err)
{
    if (side < 1 || side > 8192 || !(half > 0.0f) || !isfinite(half))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "mesh plane: need 1 <= side <= 8192 and a finite half > 0 "
                            "(got %d, %g)", side, (double)half);
    const size_t n = (size_t)side + 1;
    sg_mesh m;
    sg_status st = alloc_mesh(n * n, 2 * (size_t)side * side, 1, &m, err);
    if (st != SG_OK)
        return st;
    for (size_t i = 0; i < n; ++i)
        for (size_t j = 0; j < n; ++j) {
            size_t v = i * n + j;
            /* exact grid coordinates: -half + 2 half j / side */
            m.positions[3 * v] = (float)(-half + 2.0 * half * (double)j / side);
            m.positions[3 * v + 1] = 0.0f;
            m.positions[3 * v + 2] = (float)(-half + 2.0 * half * (double)i / side);
            m.normals[3 * v] = 0.0f, m.normals[3 * v + 1] = 1.0f, m.normals[3 * v + 2] = 0.0f;
        }
    size_t k = 0;
    for (size_t i = 0; i < (size_t)side; ++i)
        for (size_t j = 0; j < (size_t)side; ++j) {
            uint32_t a = (uint32_t)(i * n + j), b = a + 1, c = a + (uint32_t)n, d = c + 1;
            /* x along j, z along i: (c - a) x (b - a) = +Y, so a, c, b is counter-clockwise from +Y */
            put_tri(m.triangles, &k, a, c, b);
            put_tri(m.triangles, &k, b, c, d);
        }
    *out = m;
    return SG_OK;
}
