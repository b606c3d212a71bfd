/* triangle.h — watertight ray/triangle intersection (Woop, Benthin & Wald
 * 2013, "Watertight Ray/Triangle Intersection", JCGT 2(1)), as plain inline
 * functions.
 *
 * Why this test: it decides which side of each edge the ray passes on from
 * 2D edge functions U, V, W computed in a ray-aligned, sheared frame that
 * depends on the ray only. Two triangles sharing an edge compute that
 * edge's function from the same (translated, sheared) vertex values, so a
 * ray through the edge can never see both as missed: no cracks on shared
 * edges or vertices. When a function comes out exactly 0.0 in float (the
 * ray grazes an edge or passes a vertex), all three are recomputed in
 * double, where the products of floats are exact, so the sign is right.
 * Edges and vertices are part of the triangle (a ray through a vertex may
 * hit every triangle of the fan; the caller keeps the nearest, ties broken
 * by its own order).
 *
 * Use:
 *     sg_tri_ray tr = sg_tri_ray_prepare(org, dir);   once per ray
 *     sg_tri_hit th;
 *     if (sg_tri_intersect(&tr, v0, v1, v2, tmin, tmax, &th)) ... th.t, th.b1, th.b2, th.front
 *
 * Space: world space, any units; dir need not be unit (t is in units of
 * |dir|). Barycentrics: the point is b0 v0 + b1 v1 + b2 v2, b0 = 1 - b1 - b2,
 * each in [0, 1] up to rounding. Facing: `front` is 1 when the ray meets the
 * side the counter-clockwise normal (v1 - v0) x (v2 - v0) points to, i.e.
 * dot(dir, n) < 0, decided from the sign of the same determinant that found
 * the hit (never contradicts it).
 */
#ifndef SG_MATH_TRIANGLE_H
#define SG_MATH_TRIANGLE_H

#include <math.h>
#include <stdint.h>

#include "math/v16.h"
#include "math/vec3.h"

typedef struct sg_tri_ray {
    float org[3];  /* ray origin                                    */
    int kx, ky, kz; /* axis permutation: kz the largest |dir| axis   */
    float sx, sy, sz; /* shear: dir[kx]/dir[kz], dir[ky]/dir[kz], 1/dir[kz] */
} sg_tri_ray;

typedef struct sg_tri_hit {
    float t;      /* distance along the ray, in units of |dir| */
    float b1, b2; /* barycentric weights of v1 and v2          */
    int front;    /* 1: ray meets the counter-clockwise side    */
} sg_tri_hit;

/* Per-ray set-up. dir must be finite and non-zero. */
static inline sg_tri_ray sg_tri_ray_prepare(sg_vec3 org, sg_vec3 dir)
{
    sg_tri_ray r;
    const float d[3] = {dir.x, dir.y, dir.z};
    float ax = fabsf(dir.x), ay = fabsf(dir.y), az = fabsf(dir.z);
    int kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    /* Swapping kx and ky when dir[kz] < 0 keeps the winding, so the sign
     * of the determinant means the same side for every ray. */
    if (d[kz] < 0.0f) {
        int s = kx;
        kx = ky;
        ky = s;
    }
    r.org[0] = org.x;
    r.org[1] = org.y;
    r.org[2] = org.z;
    r.kx = kx;
    r.ky = ky;
    r.kz = kz;
    r.sx = d[kx] / d[kz];
    r.sy = d[ky] / d[kz];
    r.sz = 1.0f / d[kz];
    return r;
}

/* 1 and *out when the ray crosses the closed triangle (v0, v1, v2) at t in
 * [tmin, tmax]; 0 otherwise (also for a triangle seen exactly edge-on,
 * whose determinant is 0). */
static inline int sg_tri_intersect(const sg_tri_ray *r, const float *v0, const float *v1, const float *v2,
                                   float tmin, float tmax, sg_tri_hit *out)
{
    const int kx = r->kx, ky = r->ky, kz = r->kz;
    const float ax = v0[kx] - r->org[kx], ay = v0[ky] - r->org[ky], az = v0[kz] - r->org[kz];
    const float bx = v1[kx] - r->org[kx], by = v1[ky] - r->org[ky], bz = v1[kz] - r->org[kz];
    const float cx = v2[kx] - r->org[kx], cy = v2[ky] - r->org[ky], cz = v2[kz] - r->org[kz];
    const float Ax = ax - r->sx * az, Ay = ay - r->sy * az;
    const float Bx = bx - r->sx * bz, By = by - r->sy * bz;
    const float Cx = cx - r->sx * cz, Cy = cy - r->sy * cz;
    float U = Cx * By - Cy * Bx;
    float V = Ax * Cy - Ay * Cx;
    float W = Bx * Ay - By * Ax;
    if (U == 0.0f || V == 0.0f || W == 0.0f) {
        /* Products of floats are exact in double: the sign is exact. */
        U = (float)((double)Cx * (double)By - (double)Cy * (double)Bx);
        V = (float)((double)Ax * (double)Cy - (double)Ay * (double)Cx);
        W = (float)((double)Bx * (double)Ay - (double)By * (double)Ax);
    }
    if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f))
        return 0;
    const float det = U + V + W;
    if (det == 0.0f)
        return 0;
    const float T = U * (r->sz * az) + V * (r->sz * bz) + W * (r->sz * cz);
    const float inv = 1.0f / det;
    const float t = T * inv;
    /* Written so that a NaN t fails. */
    if (!(t >= tmin && t <= tmax))
        return 0;
    out->t = t;
    out->b1 = V * inv;
    out->b2 = W * inv;
    /* det = -(n_z in the sheared frame), whose z axis is the ray's. */
    out->front = det > 0.0f;
    return 1;
}

/* Four triangles at once: their vertices' coordinates in the ray's
 * permuted axes, gathered by the caller (sg_tri4_gather). Lanes outside
 * `valid` are ignored. Returns the mask of lanes that sg_tri_intersect
 * would report as hit, with its t, b1, b2 and front, bit for bit: the same
 * operations in the same order (no fused multiply-adds), and lanes whose
 * edge function comes out exactly 0.0 are redone by sg_tri_intersect
 * itself (its double fallback). */
typedef struct sg_tri4 {
    float a[3][4], b[3][4], c[3][4]; /* [kx, ky, kz component][lane], origin-relative */
    const float *v[4][3];            /* the lanes' vertex pointers (for the fallback)  */
} sg_tri4;

/* Lane l of a gather of `width` lanes (sg_tri4, sg_tri8): rows a, b, c
 * ([kx, ky, kz component][lane]) from the triangle (v0, v1, v2), and its
 * vertex pointers in v[l]. */
static inline void sg_tri__gather(float *a, float *b, float *c, int width, const float *v[][3], int l,
                                  const sg_tri_ray *r, const float *v0, const float *v1, const float *v2)
{
    const int k[3] = {r->kx, r->ky, r->kz};
    for (int i = 0; i < 3; ++i) {
        a[i * width + l] = v0[k[i]] - r->org[k[i]];
        b[i * width + l] = v1[k[i]] - r->org[k[i]];
        c[i * width + l] = v2[k[i]] - r->org[k[i]];
    }
    v[l][0] = v0;
    v[l][1] = v1;
    v[l][2] = v2;
}

/* sg_tri_intersect on the lanes of `lanes` (vertex pointers v): each hit
 * lane's t, b1, b2 and front bit written; returns their mask. The scalar
 * references, and the SIMD kernels' double fallback. */
static inline unsigned sg_tri__lanes(const sg_tri_ray *r, const float *const v[][3], unsigned lanes, float tmin,
                                     float tmax, float *t, float *b1, float *b2, unsigned *front)
{
    unsigned mask = 0;
    for (unsigned m = lanes; m; m &= m - 1) {
        const int l = __builtin_ctz(m);
        sg_tri_hit h;
        if (!sg_tri_intersect(r, v[l][0], v[l][1], v[l][2], tmin, tmax, &h))
            continue;
        mask |= 1u << l;
        t[l] = h.t;
        b1[l] = h.b1;
        b2[l] = h.b2;
        *front |= (unsigned)h.front << l;
    }
    return mask;
}

/* Fills lane l of t from the triangle (v0, v1, v2). */
static inline void sg_tri4_gather(sg_tri4 *t, int l, const sg_tri_ray *r, const float *v0, const float *v1,
                                  const float *v2)
{
    sg_tri__gather(t->a[0], t->b[0], t->c[0], 4, t->v, l, r, v0, v1, v2);
}

typedef struct sg_tri4_hit {
    float t[4], b1[4], b2[4];
    unsigned front; /* bit l: lane l met the counter-clockwise side */
} sg_tri4_hit;

/* Scalar reference of sg_tri_intersect4 over the gathered lanes. */
static inline unsigned sg_tri_intersect4_scalar(const sg_tri_ray *r, const sg_tri4 *t, unsigned valid, float tmin,
                                                float tmax, sg_tri4_hit *out)
{
    out->front = 0;
    return sg_tri__lanes(r, t->v, valid & 15u, tmin, tmax, out->t, out->b1, out->b2, &out->front);
}

#if defined(__SSE2__)
#include <emmintrin.h>

/* Always inlined: with two callers in one file (the hybrid's single-ray
 * and packet leaves) GCC otherwise calls it, and the single ray's leaf
 * loop lost the inlining it had. */
__attribute__((always_inline)) static inline unsigned sg_tri_intersect4(const sg_tri_ray *r, const sg_tri4 *t,
                                                                        unsigned valid, float tmin, float tmax,
                                                                        sg_tri4_hit *out)
{
    const __m128 sx = _mm_set1_ps(r->sx), sy = _mm_set1_ps(r->sy), sz = _mm_set1_ps(r->sz);
    const __m128 zero = _mm_setzero_ps();
    const __m128 ax = _mm_loadu_ps(t->a[0]), ay = _mm_loadu_ps(t->a[1]), az = _mm_loadu_ps(t->a[2]);
    const __m128 bx = _mm_loadu_ps(t->b[0]), by = _mm_loadu_ps(t->b[1]), bz = _mm_loadu_ps(t->b[2]);
    const __m128 cx = _mm_loadu_ps(t->c[0]), cy = _mm_loadu_ps(t->c[1]), cz = _mm_loadu_ps(t->c[2]);
    const __m128 Ax = _mm_sub_ps(ax, _mm_mul_ps(sx, az)), Ay = _mm_sub_ps(ay, _mm_mul_ps(sy, az));
    const __m128 Bx = _mm_sub_ps(bx, _mm_mul_ps(sx, bz)), By = _mm_sub_ps(by, _mm_mul_ps(sy, bz));
    const __m128 Cx = _mm_sub_ps(cx, _mm_mul_ps(sx, cz)), Cy = _mm_sub_ps(cy, _mm_mul_ps(sy, cz));
    const __m128 U = _mm_sub_ps(_mm_mul_ps(Cx, By), _mm_mul_ps(Cy, Bx));
    const __m128 V = _mm_sub_ps(_mm_mul_ps(Ax, Cy), _mm_mul_ps(Ay, Cx));
    const __m128 Wf = _mm_sub_ps(_mm_mul_ps(Bx, Ay), _mm_mul_ps(By, Ax));
    const unsigned exact0 =
        (unsigned)_mm_movemask_ps(_mm_or_ps(_mm_or_ps(_mm_cmpeq_ps(U, zero), _mm_cmpeq_ps(V, zero)),
                                            _mm_cmpeq_ps(Wf, zero))) & valid;
    const __m128 anyneg = _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(U, zero), _mm_cmplt_ps(V, zero)), _mm_cmplt_ps(Wf, zero));
    const __m128 anypos = _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(U, zero), _mm_cmpgt_ps(V, zero)), _mm_cmpgt_ps(Wf, zero));
    const __m128 det = _mm_add_ps(_mm_add_ps(U, V), Wf);
    const __m128 T = _mm_add_ps(_mm_add_ps(_mm_mul_ps(U, _mm_mul_ps(sz, az)), _mm_mul_ps(V, _mm_mul_ps(sz, bz))),
                                _mm_mul_ps(Wf, _mm_mul_ps(sz, cz)));
    const __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), det);
    const __m128 tt = _mm_mul_ps(T, inv);
    __m128 ok = _mm_andnot_ps(_mm_and_ps(anyneg, anypos), _mm_cmpneq_ps(det, zero));
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmpge_ps(tt, _mm_set1_ps(tmin)), _mm_cmple_ps(tt, _mm_set1_ps(tmax))));
    unsigned mask = (unsigned)_mm_movemask_ps(ok) & valid & ~exact0;
    _mm_storeu_ps(out->t, tt);
    _mm_storeu_ps(out->b1, _mm_mul_ps(V, inv));
    _mm_storeu_ps(out->b2, _mm_mul_ps(Wf, inv));
    out->front = (unsigned)_mm_movemask_ps(_mm_cmpgt_ps(det, zero)) & mask;
    return mask | sg_tri__lanes(r, t->v, exact0, tmin, tmax, out->t, out->b1, out->b2, &out->front);
}
#else
static inline unsigned sg_tri_intersect4(const sg_tri_ray *r, const sg_tri4 *t, unsigned valid, float tmin,
                                         float tmax, sg_tri4_hit *out)
{
    return sg_tri_intersect4_scalar(r, t, valid, tmin, tmax, out);
}
#endif

/* ---- One ray against a leaf of up to eight triangles ----------------------
 *
 * sg_tri_intersect4 eight lanes wide (AVX): one call tests a whole leaf
 * (SG_STREE_MAX_LEAF triangles) against one ray, with the same operations
 * in the same order per lane, so each lane reported hit has
 * sg_tri_intersect's t, b1, b2 and front, bit for bit; lanes whose edge
 * function comes out exactly 0.0 are redone by sg_tri_intersect. */
typedef struct sg_tri8 {
    float a[3][8], b[3][8], c[3][8]; /* [kx, ky, kz component][lane], origin-relative */
    const float *v[8][3];            /* the lanes' vertex pointers (for the fallback)  */
} sg_tri8;

typedef struct sg_tri8_hit {
    float t[8], b1[8], b2[8];
    unsigned front; /* bit l: lane l met the counter-clockwise side */
} sg_tri8_hit;

/* Fills lane l of t from the triangle (v0, v1, v2), as sg_tri4_gather. */
static inline void sg_tri8_gather(sg_tri8 *t, int l, const sg_tri_ray *r, const float *v0, const float *v1,
                                  const float *v2)
{
    sg_tri__gather(t->a[0], t->b[0], t->c[0], 8, t->v, l, r, v0, v1, v2);
}

/* Scalar reference of sg_tri_intersect8 over the gathered lanes. */
static inline unsigned sg_tri_intersect8_scalar(const sg_tri_ray *r, const sg_tri8 *t, unsigned valid, float tmin,
                                                float tmax, sg_tri8_hit *out)
{
    out->front = 0;
    return sg_tri__lanes(r, t->v, valid & 255u, tmin, tmax, out->t, out->b1, out->b2, &out->front);
}

#if defined(__AVX__)
#include <immintrin.h>
#define SG_TRI8_SIMD 1
static inline unsigned sg_tri_intersect8(const sg_tri_ray *r, const sg_tri8 *t, unsigned valid, float tmin,
                                         float tmax, sg_tri8_hit *out)
{
    const __m256 sx = _mm256_set1_ps(r->sx), sy = _mm256_set1_ps(r->sy), sz = _mm256_set1_ps(r->sz);
    const __m256 zero = _mm256_setzero_ps();
    const __m256 ax = _mm256_loadu_ps(t->a[0]), ay = _mm256_loadu_ps(t->a[1]), az = _mm256_loadu_ps(t->a[2]);
    const __m256 bx = _mm256_loadu_ps(t->b[0]), by = _mm256_loadu_ps(t->b[1]), bz = _mm256_loadu_ps(t->b[2]);
    const __m256 cx = _mm256_loadu_ps(t->c[0]), cy = _mm256_loadu_ps(t->c[1]), cz = _mm256_loadu_ps(t->c[2]);
    const __m256 Ax = _mm256_sub_ps(ax, _mm256_mul_ps(sx, az)), Ay = _mm256_sub_ps(ay, _mm256_mul_ps(sy, az));
    const __m256 Bx = _mm256_sub_ps(bx, _mm256_mul_ps(sx, bz)), By = _mm256_sub_ps(by, _mm256_mul_ps(sy, bz));
    const __m256 Cx = _mm256_sub_ps(cx, _mm256_mul_ps(sx, cz)), Cy = _mm256_sub_ps(cy, _mm256_mul_ps(sy, cz));
    const __m256 U = _mm256_sub_ps(_mm256_mul_ps(Cx, By), _mm256_mul_ps(Cy, Bx));
    const __m256 V = _mm256_sub_ps(_mm256_mul_ps(Ax, Cy), _mm256_mul_ps(Ay, Cx));
    const __m256 Wf = _mm256_sub_ps(_mm256_mul_ps(Bx, Ay), _mm256_mul_ps(By, Ax));
    const unsigned exact0 = (unsigned)_mm256_movemask_ps(_mm256_or_ps(
                                _mm256_or_ps(_mm256_cmp_ps(U, zero, _CMP_EQ_OQ), _mm256_cmp_ps(V, zero, _CMP_EQ_OQ)),
                                _mm256_cmp_ps(Wf, zero, _CMP_EQ_OQ))) &
                            valid;
    const __m256 anyneg = _mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps(U, zero, _CMP_LT_OQ), _mm256_cmp_ps(V, zero, _CMP_LT_OQ)),
        _mm256_cmp_ps(Wf, zero, _CMP_LT_OQ));
    const __m256 anypos = _mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps(U, zero, _CMP_GT_OQ), _mm256_cmp_ps(V, zero, _CMP_GT_OQ)),
        _mm256_cmp_ps(Wf, zero, _CMP_GT_OQ));
    const __m256 det = _mm256_add_ps(_mm256_add_ps(U, V), Wf);
    const __m256 T = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(U, _mm256_mul_ps(sz, az)), _mm256_mul_ps(V, _mm256_mul_ps(sz, bz))),
        _mm256_mul_ps(Wf, _mm256_mul_ps(sz, cz)));
    const __m256 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
    const __m256 tt = _mm256_mul_ps(T, inv);
    __m256 ok = _mm256_andnot_ps(_mm256_and_ps(anyneg, anypos), _mm256_cmp_ps(det, zero, _CMP_NEQ_UQ));
    ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(tt, _mm256_set1_ps(tmin), _CMP_GE_OQ),
                                         _mm256_cmp_ps(tt, _mm256_set1_ps(tmax), _CMP_LE_OQ)));
    unsigned mask = (unsigned)_mm256_movemask_ps(ok) & valid & ~exact0;
    _mm256_storeu_ps(out->t, tt);
    _mm256_storeu_ps(out->b1, _mm256_mul_ps(V, inv));
    _mm256_storeu_ps(out->b2, _mm256_mul_ps(Wf, inv));
    out->front = (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(det, zero, _CMP_GT_OQ)) & mask;
    return mask | sg_tri__lanes(r, t->v, exact0, tmin, tmax, out->t, out->b1, out->b2, &out->front);
}
#else
#define SG_TRI8_SIMD 0
static inline unsigned sg_tri_intersect8(const sg_tri_ray *r, const sg_tri8 *t, unsigned valid, float tmin,
                                         float tmax, sg_tri8_hit *out)
{
    return sg_tri_intersect8_scalar(r, t, valid, tmin, tmax, out);
}
#endif

/* ---- One triangle against sixteen rays ------------------------------------
 *
 * For a packet of rays with one origin and one axis permutation (kx, ky,
 * kz; camera rays of a 4x4 block), the triangle's vertices relative to the
 * origin in the permuted axes are the same for every ray (sg_tri4_gather's
 * values): sg_tri_intersect16 runs sg_tri_intersect's operations with those
 * as scalars and each ray's shear as a lane, so a lane that it reports hit
 * has sg_tri_intersect's t, b1, b2 and front, bit for bit. Lanes whose edge
 * function comes out exactly 0.0 are not decided here: they come back in
 * *exact0 for the caller to test with sg_tri_intersect (its double
 * fallback). */
typedef struct sg_tri_shear16 {
    float sx[16], sy[16], sz[16]; /* each ray's sg_tri_ray sx, sy, sz */
} sg_tri_shear16;

typedef struct sg_tri16_hit {
    float t[16], b1[16], b2[16];
    unsigned front; /* bit i: ray i met the counter-clockwise side */
} sg_tri16_hit;

#if SG_V16_SIMD
/* a, b, c: the vertices minus the origin, in the order kx, ky, kz. Lanes
 * outside valid are ignored; tmin and tmax per ray. */
static inline unsigned sg_tri_intersect16(const sg_tri_shear16 *r, const float a[3], const float b[3],
                                          const float c[3], unsigned valid, const float tmin[16],
                                          const float tmax[16], sg_tri16_hit *out, unsigned *exact0)
{
    const sg_v16 sx = sg_v16_load(r->sx), sy = sg_v16_load(r->sy), sz = sg_v16_load(r->sz);
    const sg_v16 zero = sg_v16_set1(0.0f);
    const sg_v16 ax = sg_v16_set1(a[0]), ay = sg_v16_set1(a[1]), az = sg_v16_set1(a[2]);
    const sg_v16 bx = sg_v16_set1(b[0]), by = sg_v16_set1(b[1]), bz = sg_v16_set1(b[2]);
    const sg_v16 cx = sg_v16_set1(c[0]), cy = sg_v16_set1(c[1]), cz = sg_v16_set1(c[2]);
    const sg_v16 Ax = sg_v16_sub(ax, sg_v16_mul(sx, az)), Ay = sg_v16_sub(ay, sg_v16_mul(sy, az));
    const sg_v16 Bx = sg_v16_sub(bx, sg_v16_mul(sx, bz)), By = sg_v16_sub(by, sg_v16_mul(sy, bz));
    const sg_v16 Cx = sg_v16_sub(cx, sg_v16_mul(sx, cz)), Cy = sg_v16_sub(cy, sg_v16_mul(sy, cz));
    const sg_v16 U = sg_v16_sub(sg_v16_mul(Cx, By), sg_v16_mul(Cy, Bx));
    const sg_v16 V = sg_v16_sub(sg_v16_mul(Ax, Cy), sg_v16_mul(Ay, Cx));
    const sg_v16 W = sg_v16_sub(sg_v16_mul(Bx, Ay), sg_v16_mul(By, Ax));
    const unsigned e0 = (sg_v16_eq(U, zero) | sg_v16_eq(V, zero) | sg_v16_eq(W, zero)) & valid;
    const unsigned anyneg = sg_v16_lt(U, zero) | sg_v16_lt(V, zero) | sg_v16_lt(W, zero);
    const unsigned anypos = sg_v16_gt(U, zero) | sg_v16_gt(V, zero) | sg_v16_gt(W, zero);
    unsigned mask = valid & ~e0 & ~(anyneg & anypos);
    *exact0 = e0;
    out->front = 0;
    if (!mask)
        return 0;
    const sg_v16 det = sg_v16_add(sg_v16_add(U, V), W);
    const sg_v16 T = sg_v16_add(sg_v16_add(sg_v16_mul(U, sg_v16_mul(sz, az)), sg_v16_mul(V, sg_v16_mul(sz, bz))),
                                sg_v16_mul(W, sg_v16_mul(sz, cz)));
    const sg_v16 inv = sg_v16_div(sg_v16_set1(1.0f), det);
    const sg_v16 t = sg_v16_mul(T, inv);
    mask &= sg_v16_neq(det, zero) & sg_v16_ge(t, sg_v16_load(tmin)) & sg_v16_le(t, sg_v16_load(tmax));
    if (!mask)
        return 0;
    sg_v16_store(out->t, t);
    sg_v16_store(out->b1, sg_v16_mul(V, inv));
    sg_v16_store(out->b2, sg_v16_mul(W, inv));
    out->front = sg_v16_gt(det, zero) & mask;
    return mask;
}
#endif

#endif
