/* room.c — the closed room with a window (room.h).
 *
 * Invariants:
 *  1. every rectangle is a grid of cells (one cell unless desc.cell asks
 *     for more) of two triangles each, counter-clockwise seen from the
 *     side its normal points to (mesh.h), with vertices of its own
 *     carrying that normal; its corners are the exact corner coordinates;
 *  2. the rectangles tile the walls' boundary without gaps or overlaps:
 *     inner box, outer box, and the window's hole in both joined by its
 *     four reveals, so the wall material is closed.
 */
#include "points/room.h"

#include <math.h>
#include <string.h>

#include "core/alloc.h"

typedef struct builder {
    sg_mesh *m;   /* NULL: only count vertices and triangles */
    float cell;   /* grid cell size; 0: one cell per rectangle */
    size_t nv, nt;
} builder;

/* Cells along a side of length len. */
static int cells(const builder *b, float len)
{
    if (!(b->cell > 0.0f))
        return 1;
    double n = ceil((double)len / b->cell);
    return n < 1.0 ? 1 : n > 1024.0 ? 1024 : (int)n;
}

/* The rectangle with normal along axis a (sign +-1) at coordinate c, over
 * [u0, u1] on axis (a + 1) % 3 and [v0, v1] on axis (a + 2) % 3, as a grid
 * of cells of two triangles sharing its vertices. */
static void rect(builder *b, int a, float c, float sign, float u0, float u1, float v0, float v1)
{
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    const int nu = cells(b, u1 - u0), nv = cells(b, v1 - v0);
    const uint32_t base = (uint32_t)b->nv;
    if (!b->m) {
        b->nv += (size_t)(nu + 1) * (size_t)(nv + 1);
        b->nt += 2 * (size_t)nu * (size_t)nv;
        return;
    }
    for (int j = 0; j <= nv; ++j)
        for (int i = 0; i <= nu; ++i) {
            float *p = b->m->positions + 3 * b->nv, *n = b->m->normals + 3 * b->nv;
            /* the rectangle's corners exactly (i = 0 or nu: u0 or u1) */
            p[a] = c;
            p[u] = i == nu ? u1 : (float)(u0 + (double)(u1 - u0) * i / nu);
            p[v] = j == nv ? v1 : (float)(v0 + (double)(v1 - v0) * j / nv);
            n[0] = n[1] = n[2] = 0.0f;
            n[a] = sign;
            b->nv++;
        }
    /* e_u x e_v = e_a: (0, 1, 2) is counter-clockwise seen from +a. */
    static const uint32_t pos[6] = {0, 1, 2, 0, 2, 3}, neg[6] = {0, 2, 1, 0, 3, 2};
    const uint32_t *order = sign > 0.0f ? pos : neg;
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            const uint32_t q[4] = {base + (uint32_t)(j * (nu + 1) + i), base + (uint32_t)(j * (nu + 1) + i + 1),
                                   base + (uint32_t)((j + 1) * (nu + 1) + i + 1),
                                   base + (uint32_t)((j + 1) * (nu + 1) + i)};
            for (int k = 0; k < 6; ++k)
                b->m->triangles[3 * b->nt + (size_t)k] = q[order[k]];
            b->nt += 2;
        }
}

/* A wall rectangle of the +X side (axis x, u = y, v = z) minus the window
 * opening, as four rectangles around it. */
static void window_wall(builder *b, float x, float sign, float y0, float y1, float z0, float z1)
{
    const float wz = SG_ROOM_WINDOW_Z, wy0 = SG_ROOM_WINDOW_Y0, wy1 = SG_ROOM_WINDOW_Y1;
    rect(b, 0, x, sign, y0, y1, z0, -wz);
    rect(b, 0, x, sign, y0, y1, wz, z1);
    rect(b, 0, x, sign, y0, wy0, -wz, wz);
    rect(b, 0, x, sign, wy1, y1, -wz, wz);
}

/* Every rectangle of the room (invariant 2), walls w thick and the window
 * wall wx. */
static void add_rects(builder *b, float w, float wx)
{
    const float H = SG_ROOM_HALF, T = SG_ROOM_HEIGHT, O = H + w, Ox = H + wx, yb = -w, yt = T + w;
    /* inside, normals into the room: axes x (u = y, v = z), y (u = z,
     * v = x), z (u = x, v = y) */
    rect(b, 1, 0.0f, 1.0f, -H, H, -H, H);  /* floor   */
    rect(b, 1, T, -1.0f, -H, H, -H, H);    /* ceiling */
    rect(b, 0, -H, 1.0f, 0.0f, T, -H, H);  /* -X wall */
    window_wall(b, H, -1.0f, 0.0f, T, -H, H);
    rect(b, 2, -H, 1.0f, -H, H, 0.0f, T);  /* -Z wall */
    rect(b, 2, H, -1.0f, -H, H, 0.0f, T);  /* +Z wall */
    /* outside, normals out */
    rect(b, 1, yb, -1.0f, -O, O, -O, Ox);
    rect(b, 1, yt, 1.0f, -O, O, -O, Ox);
    rect(b, 0, -O, -1.0f, yb, yt, -O, O);
    window_wall(b, Ox, 1.0f, yb, yt, -O, O);
    rect(b, 2, -O, -1.0f, -O, Ox, yb, yt);
    rect(b, 2, O, 1.0f, -O, Ox, yb, yt);
    /* the window's reveals, x in [H, Ox], normals into the opening */
    const float wz = SG_ROOM_WINDOW_Z, wy0 = SG_ROOM_WINDOW_Y0, wy1 = SG_ROOM_WINDOW_Y1;
    rect(b, 1, wy0, 1.0f, -wz, wz, H, Ox);   /* sill  */
    rect(b, 1, wy1, -1.0f, -wz, wz, H, Ox);  /* head  */
    rect(b, 2, -wz, 1.0f, H, Ox, wy0, wy1);  /* jambs */
    rect(b, 2, wz, -1.0f, H, Ox, wy0, wy1);
}

sg_status sg_room_mesh(const sg_room_desc *d, sg_mesh *out, sg_error *err)
{
    float w = d && d->wall != 0.0f ? d->wall : SG_ROOM_WALL;
    float wx = d && d->window_wall != 0.0f ? d->window_wall : w;
    if (!(w > 0.0f && w <= 1.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "room: wall thickness %g is not in (0, 1]", (double)w);
    if (!(wx > 0.0f && wx <= 1.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "room: window wall thickness %g is not in (0, 1]", (double)wx);
    float cell = d ? d->cell : 0.0f;
    if (!(cell >= 0.0f) || !isfinite(cell))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "room: cell size %g is not finite and >= 0", (double)cell);
    /* Two passes: count, then fill. */
    sg_mesh m = {0};
    builder b = {.m = NULL, .cell = cell};
    for (int pass = 0; pass < 2; ++pass) {
        if (pass == 1) {
            m.positions = sg_alloc_array(b.nv, 3 * sizeof(float));
            m.normals = sg_alloc_array(b.nv, 3 * sizeof(float));
            m.triangles = sg_alloc_array(b.nt, 3 * sizeof(uint32_t));
            if (!m.positions || !m.normals || !m.triangles) {
                sg_mesh_free(&m);
                return sg_error_set(err, SG_ERR_NOMEM, "room: out of memory for %zu triangles", b.nt);
            }
            b = (builder){.m = &m, .cell = cell};
        }
        add_rects(&b, w, wx);
    }
    m.vertex_count = b.nv;
    m.triangle_count = b.nt;
    *out = m;
    return SG_OK;
}

