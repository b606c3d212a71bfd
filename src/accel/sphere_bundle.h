/* sphere_bundle.h — a ray against the SG_STREE_WIDTH nodes of a bundle
 * (sphere_tree.h): which it enters, where, and which are small enough to
 * be points. A scalar reference and an SSE4.1 (width 4) / AVX2 (width 8)
 * kernel that compute the same operations in the same order without fused
 * multiply-adds, so both give the same bits (tested on random bundles).
 *
 * The bound of a node is its sphere cut by its slab along the quantised
 * normal u (a flat patch's sphere is mostly empty above and below it).
 * Per lane, for a unit direction d and a = centre - origin:
 *     b   = a . d                      distance to the centre's projection
 *     p^2 = |a x d|^2                  squared distance of centre to line
 *     m   = 8 FLT_EPSILON (|a|_1 + R)  rounding margin
 *     h^2 = (R + m)^2 - p^2            sphere: [b - h - m, b + h + m]
 *     slab: (x - c) . u in [lo - m, hi + m] along x = o + t d gives
 *           t du in [lo - m + a.u, hi + m + a.u], du = d . u
 *     tin = the later entry, tout = the earlier exit
 *     hit = h^2 >= 0, tin <= tout, tout >= tmin, tin <= tfar
 *     lod = 2 R < lod0 + lod1 b        small enough to be a point
 * Why m bounds the rounding: each component of a x d is off by at most
 * 2 FLT_EPSILON |a|_1 (a product pair and a difference, each term at most
 * |a|_1 for unit d), so the computed distance is off by less than
 * 2 sqrt(3) FLT_EPSILON |a|_1 < m; b and a.u are off by less than
 * 3 FLT_EPSILON |a|_1, and the slab quotient's own rounding (relative
 * 2 FLT_EPSILON of t <= |a| + R) is below m / |du|. So a node the exact
 * ray enters is never missed and tin never exceeds the exact entry.
 * Division by du = 0 (a ray parallel to the slab) gives infinities of the
 * right signs: m > 0 keeps both numerators non-zero for a ray inside the
 * slab, so it is never cut; a ray outside may get NaN, which the
 * comparisons below treat as no cut (conservative). An empty lane (R =
 * NaN) makes h^2 NaN and fails every comparison.
 */
#ifndef SG_ACCEL_SPHERE_BUNDLE_H
#define SG_ACCEL_SPHERE_BUNDLE_H

#include <float.h>
#include <math.h>
#include <string.h>

#include "accel/sphere_tree.h"
#include "math/v16.h"

#if defined(__AVX2__) && SG_STREE_WIDTH == 8
#include <immintrin.h>
#define SG_BUNDLE_SIMD 8
#elif defined(__SSE4_1__) && SG_STREE_WIDTH == 4
#include <smmintrin.h>
#define SG_BUNDLE_SIMD 4
#else
#define SG_BUNDLE_SIMD 0
#endif

#define SG_BUNDLE_MARGIN (8.0f * FLT_EPSILON)

/* A ray prepared for bundle tests. */
typedef struct sg_bundle_ray {
    float o[3], d[3];  /* origin, unit direction                 */
    float tmin;
    float lod0, lod1;  /* point test 2R < lod0 + lod1 b; 0, 0: never */
} sg_bundle_ray;

/* Scalar reference. Returns the mask of lanes entered in [tmin, tfar];
 * tin[l] for every lane; *lod the mask of point-sized lanes. min and max
 * are written as the SIMD instructions compute them (the second operand
 * when a comparison fails), so NaN gives the same lane results. */
/* Lane l of B against one ray: 1 when it enters it in [tmin, tfar];
 * *tin its entry, *lod 1 when it is point-sized. The scalar formula, shared
 * by both scalar references. */
static inline unsigned sg_bundle__lane(const sg_stree_bundle *B, int l, const float o[3], const float d[3], float tmin,
                                       float lod0, float lod1, float tfar, float *tin, unsigned *lod)
{
    float ax = B->cx[l] - o[0], ay = B->cy[l] - o[1], az = B->cz[l] - o[2];
    float b = ax * d[0] + ay * d[1] + az * d[2];
    float qx = ay * d[2] - az * d[1];
    float qy = az * d[0] - ax * d[2];
    float qz = ax * d[1] - ay * d[0];
    float p2 = qx * qx + qy * qy + qz * qz;
    float R = B->r[l];
    float m = SG_BUNDLE_MARGIN * (fabsf(ax) + fabsf(ay) + fabsf(az) + R);
    float Rm = R + m;
    float h2 = Rm * Rm - p2;
    float hh = sqrtf(h2 > 0.0f ? h2 : 0.0f);
    float t0 = b - hh - m, t1 = b + hh + m;
    const float ns = 1.0f / SG_STREE_NORMAL_SCALE, ss = 1.0f / SG_STREE_SLAB_SCALE;
    float ux = (float)B->nx[l] * ns, uy = (float)B->ny[l] * ns, uz = (float)B->nz[l] * ns;
    float au = ax * ux + ay * uy + az * uz;
    float du = d[0] * ux + d[1] * uy + d[2] * uz;
    float rs = R * ss;
    float inv = 1.0f / du;
    float n0 = ((float)B->slo[l] * rs - m + au) * inv;
    float n1 = ((float)B->shi[l] * rs + m + au) * inv;
    float tn = n0 < n1 ? n0 : n1, tf = n0 > n1 ? n0 : n1;
    t0 = tn > t0 ? tn : t0;
    t1 = tf < t1 ? tf : t1;
    *tin = t0;
    *lod = (unsigned)(2.0f * R < lod0 + lod1 * b);
    return (unsigned)(h2 >= 0.0f && t0 <= t1 && t1 >= tmin && t0 <= tfar);
}

/* Scalar reference. Returns the mask of lanes entered in [tmin, tfar];
 * tin[l] for every lane; *lod the mask of point-sized lanes. min and max
 * are written as the SIMD instructions compute them (the second operand
 * when a comparison fails), so NaN gives the same lane results. */
static inline unsigned sg_bundle_test_scalar(const sg_stree_bundle *B, const sg_bundle_ray *r, float tfar,
                                             float tin[SG_STREE_WIDTH], unsigned *lod)
{
    unsigned mask = 0, lm = 0;
    for (int l = 0; l < SG_STREE_WIDTH; ++l) {
        unsigned pl;
        mask |= sg_bundle__lane(B, l, r->o, r->d, r->tmin, r->lod0, r->lod1, tfar, &tin[l], &pl) << l;
        lm |= pl << l;
    }
    *lod = lm;
    return mask;
}

#if SG_BUNDLE_SIMD == 4
static inline unsigned sg_bundle_test(const sg_stree_bundle *B, const sg_bundle_ray *r, float tfar,
                                      float tin[SG_STREE_WIDTH], unsigned *lod)
{
    const __m128 sign = _mm_set1_ps(-0.0f), zero = _mm_setzero_ps();
    const __m128 dx = _mm_set1_ps(r->d[0]), dy = _mm_set1_ps(r->d[1]), dz = _mm_set1_ps(r->d[2]);
    const __m128 ax = _mm_sub_ps(_mm_load_ps(B->cx), _mm_set1_ps(r->o[0]));
    const __m128 ay = _mm_sub_ps(_mm_load_ps(B->cy), _mm_set1_ps(r->o[1]));
    const __m128 az = _mm_sub_ps(_mm_load_ps(B->cz), _mm_set1_ps(r->o[2]));
    const __m128 b = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ax, dx), _mm_mul_ps(ay, dy)), _mm_mul_ps(az, dz));
    const __m128 qx = _mm_sub_ps(_mm_mul_ps(ay, dz), _mm_mul_ps(az, dy));
    const __m128 qy = _mm_sub_ps(_mm_mul_ps(az, dx), _mm_mul_ps(ax, dz));
    const __m128 qz = _mm_sub_ps(_mm_mul_ps(ax, dy), _mm_mul_ps(ay, dx));
    const __m128 p2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(qx, qx), _mm_mul_ps(qy, qy)), _mm_mul_ps(qz, qz));
    const __m128 R = _mm_load_ps(B->r);
    const __m128 l1 = _mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_andnot_ps(sign, ax), _mm_andnot_ps(sign, ay)),
                                            _mm_andnot_ps(sign, az)),
                                 R);
    const __m128 m = _mm_mul_ps(_mm_set1_ps(SG_BUNDLE_MARGIN), l1);
    const __m128 Rm = _mm_add_ps(R, m);
    const __m128 h2 = _mm_sub_ps(_mm_mul_ps(Rm, Rm), p2);
    /* h2 > 0 ? h2 : 0, NaN giving 0 as the scalar's ternary does. */
    const __m128 hh = _mm_sqrt_ps(_mm_and_ps(_mm_cmpgt_ps(h2, zero), h2));
    __m128 t0 = _mm_sub_ps(_mm_sub_ps(b, hh), m);
    __m128 t1 = _mm_add_ps(_mm_add_ps(b, hh), m);
    int32_t raw[5];
    memcpy(&raw[0], B->nx, 4);
    memcpy(&raw[1], B->ny, 4);
    memcpy(&raw[2], B->nz, 4);
    memcpy(&raw[3], B->slo, 4);
    memcpy(&raw[4], B->shi, 4);
    const __m128 ns = _mm_set1_ps(1.0f / SG_STREE_NORMAL_SCALE);
    const __m128 ux = _mm_mul_ps(_mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(raw[0]))), ns);
    const __m128 uy = _mm_mul_ps(_mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(raw[1]))), ns);
    const __m128 uz = _mm_mul_ps(_mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(raw[2]))), ns);
    const __m128 slo = _mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(raw[3])));
    const __m128 shi = _mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(raw[4])));
    const __m128 au = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ax, ux), _mm_mul_ps(ay, uy)), _mm_mul_ps(az, uz));
    const __m128 du = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, ux), _mm_mul_ps(dy, uy)), _mm_mul_ps(dz, uz));
    const __m128 rs = _mm_mul_ps(R, _mm_set1_ps(1.0f / SG_STREE_SLAB_SCALE));
    const __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), du);
    const __m128 n0 = _mm_mul_ps(_mm_add_ps(_mm_sub_ps(_mm_mul_ps(slo, rs), m), au), inv);
    const __m128 n1 = _mm_mul_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(shi, rs), m), au), inv);
    const __m128 tn = _mm_min_ps(n0, n1), tf = _mm_max_ps(n0, n1);
    t0 = _mm_max_ps(tn, t0);
    t1 = _mm_min_ps(tf, t1);
    _mm_storeu_ps(tin, t0);
    __m128 hit = _mm_and_ps(_mm_cmpge_ps(h2, zero), _mm_cmple_ps(t0, t1));
    hit = _mm_and_ps(hit, _mm_cmpge_ps(t1, _mm_set1_ps(r->tmin)));
    hit = _mm_and_ps(hit, _mm_cmple_ps(t0, _mm_set1_ps(tfar)));
    const __m128 small = _mm_cmplt_ps(_mm_add_ps(R, R),
                                      _mm_add_ps(_mm_set1_ps(r->lod0), _mm_mul_ps(_mm_set1_ps(r->lod1), b)));
    *lod = (unsigned)_mm_movemask_ps(small);
    return (unsigned)_mm_movemask_ps(hit);
}
#elif SG_BUNDLE_SIMD == 8
static inline __m256 sg_bundle__i8(const int8_t *p)
{
    int64_t raw;
    memcpy(&raw, p, sizeof raw);
    return _mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(_mm_cvtsi64_si128(raw)));
}

static inline unsigned sg_bundle_test(const sg_stree_bundle *B, const sg_bundle_ray *r, float tfar,
                                      float tin[SG_STREE_WIDTH], unsigned *lod)
{
    const __m256 sign = _mm256_set1_ps(-0.0f), zero = _mm256_setzero_ps();
    const __m256 dx = _mm256_set1_ps(r->d[0]), dy = _mm256_set1_ps(r->d[1]), dz = _mm256_set1_ps(r->d[2]);
    const __m256 ax = _mm256_sub_ps(_mm256_load_ps(B->cx), _mm256_set1_ps(r->o[0]));
    const __m256 ay = _mm256_sub_ps(_mm256_load_ps(B->cy), _mm256_set1_ps(r->o[1]));
    const __m256 az = _mm256_sub_ps(_mm256_load_ps(B->cz), _mm256_set1_ps(r->o[2]));
    const __m256 b =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ax, dx), _mm256_mul_ps(ay, dy)), _mm256_mul_ps(az, dz));
    const __m256 qx = _mm256_sub_ps(_mm256_mul_ps(ay, dz), _mm256_mul_ps(az, dy));
    const __m256 qy = _mm256_sub_ps(_mm256_mul_ps(az, dx), _mm256_mul_ps(ax, dz));
    const __m256 qz = _mm256_sub_ps(_mm256_mul_ps(ax, dy), _mm256_mul_ps(ay, dx));
    const __m256 p2 =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(qx, qx), _mm256_mul_ps(qy, qy)), _mm256_mul_ps(qz, qz));
    const __m256 R = _mm256_load_ps(B->r);
    const __m256 l1 = _mm256_add_ps(
        _mm256_add_ps(_mm256_add_ps(_mm256_andnot_ps(sign, ax), _mm256_andnot_ps(sign, ay)), _mm256_andnot_ps(sign, az)),
        R);
    const __m256 m = _mm256_mul_ps(_mm256_set1_ps(SG_BUNDLE_MARGIN), l1);
    const __m256 Rm = _mm256_add_ps(R, m);
    const __m256 h2 = _mm256_sub_ps(_mm256_mul_ps(Rm, Rm), p2);
    const __m256 hh = _mm256_sqrt_ps(_mm256_and_ps(_mm256_cmp_ps(h2, zero, _CMP_GT_OQ), h2));
    __m256 t0 = _mm256_sub_ps(_mm256_sub_ps(b, hh), m);
    __m256 t1 = _mm256_add_ps(_mm256_add_ps(b, hh), m);
    const __m256 ns = _mm256_set1_ps(1.0f / SG_STREE_NORMAL_SCALE);
    const __m256 ux = _mm256_mul_ps(sg_bundle__i8(B->nx), ns);
    const __m256 uy = _mm256_mul_ps(sg_bundle__i8(B->ny), ns);
    const __m256 uz = _mm256_mul_ps(sg_bundle__i8(B->nz), ns);
    const __m256 slo = sg_bundle__i8(B->slo), shi = sg_bundle__i8(B->shi);
    const __m256 au =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ax, ux), _mm256_mul_ps(ay, uy)), _mm256_mul_ps(az, uz));
    const __m256 du =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, ux), _mm256_mul_ps(dy, uy)), _mm256_mul_ps(dz, uz));
    const __m256 rs = _mm256_mul_ps(R, _mm256_set1_ps(1.0f / SG_STREE_SLAB_SCALE));
    const __m256 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), du);
    const __m256 n0 = _mm256_mul_ps(_mm256_add_ps(_mm256_sub_ps(_mm256_mul_ps(slo, rs), m), au), inv);
    const __m256 n1 = _mm256_mul_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(shi, rs), m), au), inv);
    const __m256 tn = _mm256_min_ps(n0, n1), tf = _mm256_max_ps(n0, n1);
    t0 = _mm256_max_ps(tn, t0);
    t1 = _mm256_min_ps(tf, t1);
    _mm256_storeu_ps(tin, t0);
    __m256 hit = _mm256_and_ps(_mm256_cmp_ps(h2, zero, _CMP_GE_OQ), _mm256_cmp_ps(t0, t1, _CMP_LE_OQ));
    hit = _mm256_and_ps(hit, _mm256_cmp_ps(t1, _mm256_set1_ps(r->tmin), _CMP_GE_OQ));
    hit = _mm256_and_ps(hit, _mm256_cmp_ps(t0, _mm256_set1_ps(tfar), _CMP_LE_OQ));
    const __m256 small = _mm256_cmp_ps(
        _mm256_add_ps(R, R), _mm256_add_ps(_mm256_set1_ps(r->lod0), _mm256_mul_ps(_mm256_set1_ps(r->lod1), b)),
        _CMP_LT_OQ);
    *lod = (unsigned)_mm256_movemask_ps(small);
    return (unsigned)_mm256_movemask_ps(hit);
}
#else
static inline unsigned sg_bundle_test(const sg_stree_bundle *B, const sg_bundle_ray *r, float tfar,
                                      float tin[SG_STREE_WIDTH], unsigned *lod)
{
    return sg_bundle_test_scalar(B, r, tfar, tin, lod);
}
#endif

/* ---- A bundle against a cone of rays (a packet's) ---------------------------
 *
 * Which nodes of a bundle some ray of a cone may enter: rays that leave
 * one apex o within half-angle a of the unit axis. A sphere (centre c,
 * radius r) meets the cone when its centre lies in the cone of centres
 * (the apex moved back along the axis by r / sin a) and is not behind
 * the apex beyond r (Eberly, "Intersection of a sphere and a cone"). The
 * radius is widened (r 1.001 + 1e-4 |c - o|_1) far beyond the rounding
 * of this test and of the rays' own sphere tests, so a node a ray of the
 * cone enters is never dropped. The slab is not used (the cone only
 * skips nodes; the rays' own tests cut by the slab). An empty lane (r
 * NaN) fails every comparison. A scalar reference and an AVX2 kernel
 * (width 8) with the same operations in the same order: the same mask. */
typedef struct sg_bundle_cone {
    float o[3];         /* apex: the rays' common origin          */
    float a[3];         /* unit axis                              */
    float sin, cos;     /* of the half-angle, widened; sin > 0    */
} sg_bundle_cone;

static inline unsigned sg_bundle_cone_test_scalar(const sg_stree_bundle *B, const sg_bundle_cone *C)
{
    const float s2 = C->sin * C->sin, c2 = C->cos * C->cos, back = 1.0f / C->sin;
    unsigned kids = 0;
    for (int l = 0; l < SG_STREE_WIDTH; ++l) {
        const float vx = B->cx[l] - C->o[0], vy = B->cy[l] - C->o[1], vz = B->cz[l] - C->o[2];
        const float r = B->r[l] * 1.001f + 1e-4f * (fabsf(vx) + fabsf(vy) + fabsf(vz));
        /* apex moved back along the axis by r / sin: the cone of centres */
        const float rb = r * back;
        const float ux = vx + rb * C->a[0], uy = vy + rb * C->a[1], uz = vz + rb * C->a[2];
        const float e = ux * C->a[0] + uy * C->a[1] + uz * C->a[2];
        const float u2 = ux * ux + uy * uy + uz * uz;
        const float f = -(vx * C->a[0] + vy * C->a[1] + vz * C->a[2]);
        const float v2 = vx * vx + vy * vy + vz * vz;
        /* in the cone of centres, and not behind the apex beyond r */
        const int in = e > 0.0f && e * e >= u2 * c2 && (!(f > 0.0f && f * f >= v2 * s2) || v2 <= r * r);
        kids |= (unsigned)in << l;
    }
    return kids;
}

#if SG_BUNDLE_SIMD == 8
static inline unsigned sg_bundle_cone_test(const sg_stree_bundle *B, const sg_bundle_cone *C)
{
    const float s2s = C->sin * C->sin, c2s = C->cos * C->cos, backs = 1.0f / C->sin;
    const __m256 sign = _mm256_set1_ps(-0.0f), zero = _mm256_setzero_ps();
    const __m256 ax = _mm256_set1_ps(C->a[0]), ay = _mm256_set1_ps(C->a[1]), az = _mm256_set1_ps(C->a[2]);
    const __m256 vx = _mm256_sub_ps(_mm256_load_ps(B->cx), _mm256_set1_ps(C->o[0]));
    const __m256 vy = _mm256_sub_ps(_mm256_load_ps(B->cy), _mm256_set1_ps(C->o[1]));
    const __m256 vz = _mm256_sub_ps(_mm256_load_ps(B->cz), _mm256_set1_ps(C->o[2]));
    const __m256 l1 = _mm256_add_ps(_mm256_add_ps(_mm256_andnot_ps(sign, vx), _mm256_andnot_ps(sign, vy)),
                                    _mm256_andnot_ps(sign, vz));
    const __m256 r = _mm256_add_ps(_mm256_mul_ps(_mm256_load_ps(B->r), _mm256_set1_ps(1.001f)),
                                   _mm256_mul_ps(_mm256_set1_ps(1e-4f), l1));
    const __m256 rb = _mm256_mul_ps(r, _mm256_set1_ps(backs));
    const __m256 ux = _mm256_add_ps(vx, _mm256_mul_ps(rb, ax));
    const __m256 uy = _mm256_add_ps(vy, _mm256_mul_ps(rb, ay));
    const __m256 uz = _mm256_add_ps(vz, _mm256_mul_ps(rb, az));
    const __m256 e = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ux, ax), _mm256_mul_ps(uy, ay)), _mm256_mul_ps(uz, az));
    const __m256 u2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ux, ux), _mm256_mul_ps(uy, uy)), _mm256_mul_ps(uz, uz));
    const __m256 f = _mm256_xor_ps(
        sign, _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(vx, ax), _mm256_mul_ps(vy, ay)), _mm256_mul_ps(vz, az)));
    const __m256 v2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(vx, vx), _mm256_mul_ps(vy, vy)), _mm256_mul_ps(vz, vz));
    const __m256 front = _mm256_and_ps(_mm256_cmp_ps(e, zero, _CMP_GT_OQ),
                                       _mm256_cmp_ps(_mm256_mul_ps(e, e), _mm256_mul_ps(u2, _mm256_set1_ps(c2s)),
                                                     _CMP_GE_OQ));
    const __m256 behind = _mm256_and_ps(_mm256_cmp_ps(f, zero, _CMP_GT_OQ),
                                        _mm256_cmp_ps(_mm256_mul_ps(f, f), _mm256_mul_ps(v2, _mm256_set1_ps(s2s)),
                                                      _CMP_GE_OQ));
    const __m256 near = _mm256_cmp_ps(v2, _mm256_mul_ps(r, r), _CMP_LE_OQ);
    /* front && (!behind || near) */
    const __m256 in = _mm256_and_ps(front, _mm256_or_ps(_mm256_andnot_ps(behind, _mm256_castsi256_ps(
                                                                                      _mm256_set1_epi32(-1))),
                                                        near));
    return (unsigned)_mm256_movemask_ps(in);
}
#else
static inline unsigned sg_bundle_cone_test(const sg_stree_bundle *B, const sg_bundle_cone *C)
{
    return sg_bundle_cone_test_scalar(B, C);
}
#endif

/* ---- One node against sixteen rays (a 4x4 packet) --------------------------
 *
 * sg_bundle_test16 runs sg_bundle_test_scalar's operations for lane l of
 * a bundle against sixteen rays at once (SIMD across the rays, not the
 * nodes), so ray i gets the bits sg_bundle_test gives it for that lane:
 * the node's values (centre, radius, int8 normal and slab converted) are
 * scalars broadcast, the ray's are SoA lanes. A packet walk reads each
 * child's entry mask, floors and point mask straight from the result,
 * with no per-ray loop. AVX-512 (one register), AVX2 (two halves) or a
 * scalar loop, the same operations in the same order. */
typedef struct sg_bundle_ray16 {
    _Alignas(64) float ox[16]; /* origins (the alignment binds this one field) */
    float oy[16], oz[16];
    float dx[16], dy[16], dz[16]; /* unit directions */
    float tmin[16];
    float lod0[16], lod1[16];     /* as sg_bundle_ray's */
} sg_bundle_ray16;

/* Scalar reference: rays of lane i of r against node lane l of B. Returns
 * the mask of rays that enter it in [tmin, tfar[i]]; tin[i] for every ray;
 * *lod the mask of rays for which it is point-sized. */
static inline unsigned sg_bundle_test16_scalar(const sg_stree_bundle *B, int l, const sg_bundle_ray16 *r,
                                               const float tfar[16], float tin[16], unsigned *lod)
{
    unsigned mask = 0, lm = 0;
    for (int i = 0; i < 16; ++i) {
        const float o[3] = {r->ox[i], r->oy[i], r->oz[i]}, d[3] = {r->dx[i], r->dy[i], r->dz[i]};
        unsigned pl;
        mask |= sg_bundle__lane(B, l, o, d, r->tmin[i], r->lod0[i], r->lod1[i], tfar[i], &tin[i], &pl) << i;
        lm |= pl << i;
    }
    *lod = lm;
    return mask;
}

#if SG_V16_SIMD
#define SG_BUNDLE_SIMD16 1
static inline unsigned sg_bundle_test16(const sg_stree_bundle *B, int l, const sg_bundle_ray16 *r,
                                        const float tfar[16], float tin[16], unsigned *lod)
{
    const float ns = 1.0f / SG_STREE_NORMAL_SCALE, ss = 1.0f / SG_STREE_SLAB_SCALE;
    const float Rs = B->r[l];
    const float uxs = (float)B->nx[l] * ns, uys = (float)B->ny[l] * ns, uzs = (float)B->nz[l] * ns;
    const float rss = Rs * ss;
    const sg_v16 dx = sg_v16_load(r->dx), dy = sg_v16_load(r->dy), dz = sg_v16_load(r->dz);
    const sg_v16 ax = sg_v16_sub(sg_v16_set1(B->cx[l]), sg_v16_load(r->ox));
    const sg_v16 ay = sg_v16_sub(sg_v16_set1(B->cy[l]), sg_v16_load(r->oy));
    const sg_v16 az = sg_v16_sub(sg_v16_set1(B->cz[l]), sg_v16_load(r->oz));
    const sg_v16 b = sg_v16_add(sg_v16_add(sg_v16_mul(ax, dx), sg_v16_mul(ay, dy)), sg_v16_mul(az, dz));
    const sg_v16 qx = sg_v16_sub(sg_v16_mul(ay, dz), sg_v16_mul(az, dy));
    const sg_v16 qy = sg_v16_sub(sg_v16_mul(az, dx), sg_v16_mul(ax, dz));
    const sg_v16 qz = sg_v16_sub(sg_v16_mul(ax, dy), sg_v16_mul(ay, dx));
    const sg_v16 p2 = sg_v16_add(sg_v16_add(sg_v16_mul(qx, qx), sg_v16_mul(qy, qy)), sg_v16_mul(qz, qz));
    const sg_v16 R = sg_v16_set1(Rs);
    const sg_v16 l1 = sg_v16_add(sg_v16_add(sg_v16_add(sg_v16_abs(ax), sg_v16_abs(ay)), sg_v16_abs(az)), R);
    const sg_v16 m = sg_v16_mul(sg_v16_set1(SG_BUNDLE_MARGIN), l1);
    const sg_v16 Rm = sg_v16_add(R, m);
    const sg_v16 h2 = sg_v16_sub(sg_v16_mul(Rm, Rm), p2);
    const sg_v16 hh = sg_v16_sqrt(sg_v16_pos(h2));
    sg_v16 t0 = sg_v16_sub(sg_v16_sub(b, hh), m);
    sg_v16 t1 = sg_v16_add(sg_v16_add(b, hh), m);
    const sg_v16 ux = sg_v16_set1(uxs), uy = sg_v16_set1(uys), uz = sg_v16_set1(uzs);
    const sg_v16 au = sg_v16_add(sg_v16_add(sg_v16_mul(ax, ux), sg_v16_mul(ay, uy)), sg_v16_mul(az, uz));
    const sg_v16 du = sg_v16_add(sg_v16_add(sg_v16_mul(dx, ux), sg_v16_mul(dy, uy)), sg_v16_mul(dz, uz));
    const sg_v16 inv = sg_v16_div(sg_v16_set1(1.0f), du);
    const sg_v16 n0 = sg_v16_mul(sg_v16_add(sg_v16_sub(sg_v16_set1((float)B->slo[l] * rss), m), au), inv);
    const sg_v16 n1 = sg_v16_mul(sg_v16_add(sg_v16_add(sg_v16_set1((float)B->shi[l] * rss), m), au), inv);
    const sg_v16 tn = sg_v16_min(n0, n1), tf = sg_v16_max(n0, n1);
    t0 = sg_v16_max(tn, t0);
    t1 = sg_v16_min(tf, t1);
    sg_v16_store(tin, t0);
    const unsigned hit = sg_v16_ge(h2, sg_v16_set1(0.0f)) & sg_v16_le(t0, t1) &
                         sg_v16_ge(t1, sg_v16_load(r->tmin)) & sg_v16_le(t0, sg_v16_load(tfar));
    *lod = sg_v16_lt(sg_v16_add(R, R), sg_v16_add(sg_v16_load(r->lod0), sg_v16_mul(sg_v16_load(r->lod1), b)));
    return hit;
}

/* sg_bundle_test16 for rays that all leave r->ox[0], r->oy[0], r->oz[0]
 * (camera rays): what depends on the node and the origin only (a = c - o,
 * the margin, a . u and the slab's numerators) is computed once, as a
 * scalar, with the same operations, so each ray gets the same bits. */
static inline unsigned sg_bundle_test16_eye(const sg_stree_bundle *B, int l, const sg_bundle_ray16 *r,
                                            const float tfar[16], float tin[16], unsigned *lod)
{
    const float ns = 1.0f / SG_STREE_NORMAL_SCALE, ss = 1.0f / SG_STREE_SLAB_SCALE;
    const float Rs = B->r[l];
    const float uxs = (float)B->nx[l] * ns, uys = (float)B->ny[l] * ns, uzs = (float)B->nz[l] * ns;
    const float rss = Rs * ss;
    const float axs = B->cx[l] - r->ox[0], ays = B->cy[l] - r->oy[0], azs = B->cz[l] - r->oz[0];
    const float ms = SG_BUNDLE_MARGIN * (fabsf(axs) + fabsf(ays) + fabsf(azs) + Rs);
    const float Rms = Rs + ms;
    const float aus = axs * uxs + ays * uys + azs * uzs;
    const sg_v16 dx = sg_v16_load(r->dx), dy = sg_v16_load(r->dy), dz = sg_v16_load(r->dz);
    const sg_v16 ax = sg_v16_set1(axs), ay = sg_v16_set1(ays), az = sg_v16_set1(azs);
    const sg_v16 b = sg_v16_add(sg_v16_add(sg_v16_mul(ax, dx), sg_v16_mul(ay, dy)), sg_v16_mul(az, dz));
    const sg_v16 qx = sg_v16_sub(sg_v16_mul(ay, dz), sg_v16_mul(az, dy));
    const sg_v16 qy = sg_v16_sub(sg_v16_mul(az, dx), sg_v16_mul(ax, dz));
    const sg_v16 qz = sg_v16_sub(sg_v16_mul(ax, dy), sg_v16_mul(ay, dx));
    const sg_v16 p2 = sg_v16_add(sg_v16_add(sg_v16_mul(qx, qx), sg_v16_mul(qy, qy)), sg_v16_mul(qz, qz));
    const sg_v16 m = sg_v16_set1(ms);
    const sg_v16 h2 = sg_v16_sub(sg_v16_set1(Rms * Rms), p2);
    const sg_v16 hh = sg_v16_sqrt(sg_v16_pos(h2));
    sg_v16 t0 = sg_v16_sub(sg_v16_sub(b, hh), m);
    sg_v16 t1 = sg_v16_add(sg_v16_add(b, hh), m);
    const sg_v16 du = sg_v16_add(sg_v16_add(sg_v16_mul(dx, sg_v16_set1(uxs)), sg_v16_mul(dy, sg_v16_set1(uys))),
                                 sg_v16_mul(dz, sg_v16_set1(uzs)));
    const sg_v16 inv = sg_v16_div(sg_v16_set1(1.0f), du);
    const sg_v16 n0 = sg_v16_mul(sg_v16_set1((float)B->slo[l] * rss - ms + aus), inv);
    const sg_v16 n1 = sg_v16_mul(sg_v16_set1((float)B->shi[l] * rss + ms + aus), inv);
    const sg_v16 tn = sg_v16_min(n0, n1), tf = sg_v16_max(n0, n1);
    t0 = sg_v16_max(tn, t0);
    t1 = sg_v16_min(tf, t1);
    sg_v16_store(tin, t0);
    const unsigned hit = sg_v16_ge(h2, sg_v16_set1(0.0f)) & sg_v16_le(t0, t1) &
                         sg_v16_ge(t1, sg_v16_load(r->tmin)) & sg_v16_le(t0, sg_v16_load(tfar));
    const sg_v16 R = sg_v16_set1(Rs);
    *lod = sg_v16_lt(sg_v16_add(R, R), sg_v16_add(sg_v16_load(r->lod0), sg_v16_mul(sg_v16_load(r->lod1), b)));
    return hit;
}
#else
#define SG_BUNDLE_SIMD16 0
static inline unsigned sg_bundle_test16(const sg_stree_bundle *B, int l, const sg_bundle_ray16 *r,
                                        const float tfar[16], float tin[16], unsigned *lod)
{
    return sg_bundle_test16_scalar(B, l, r, tfar, tin, lod);
}
static inline unsigned sg_bundle_test16_eye(const sg_stree_bundle *B, int l, const sg_bundle_ray16 *r,
                                            const float tfar[16], float tin[16], unsigned *lod)
{
    return sg_bundle_test16_scalar(B, l, r, tfar, tin, lod);
}
#endif

#endif
