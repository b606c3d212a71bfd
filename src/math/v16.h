/* v16.h — sixteen float lanes for packets of 4x4 rays (the hybrid's
 * camera-ray packets, surface/hybrid_trace.c): one AVX-512 register, or two
 * AVX2 halves. Only IEEE operations that round as the scalar ones do (no
 * fused multiply-add), so a kernel written with them gives each lane the
 * bits of its scalar reference. min and max are the scalar ternaries
 * a < b ? a : b and a > b ? a : b (the second operand when either is
 * NaN). Comparisons return a 16-bit mask (bit i: lane i). Without AVX2,
 * SG_V16_SIMD is 0 and nothing is defined: callers keep a scalar path.
 */
#ifndef SG_MATH_V16_H
#define SG_MATH_V16_H

#include <math.h>

#if defined(__AVX512F__) || defined(__AVX2__)
#include <immintrin.h>
#define SG_V16_SIMD 1
#else
#define SG_V16_SIMD 0
#endif

#if defined(__AVX512F__)
typedef __m512 sg_v16;
static inline sg_v16 sg_v16_load(const float *p) { return _mm512_loadu_ps(p); }
static inline void sg_v16_store(float *p, sg_v16 a) { _mm512_storeu_ps(p, a); }
static inline sg_v16 sg_v16_set1(float x) { return _mm512_set1_ps(x); }
static inline sg_v16 sg_v16_add(sg_v16 a, sg_v16 b) { return _mm512_add_ps(a, b); }
static inline sg_v16 sg_v16_sub(sg_v16 a, sg_v16 b) { return _mm512_sub_ps(a, b); }
static inline sg_v16 sg_v16_mul(sg_v16 a, sg_v16 b) { return _mm512_mul_ps(a, b); }
static inline sg_v16 sg_v16_div(sg_v16 a, sg_v16 b) { return _mm512_div_ps(a, b); }
static inline sg_v16 sg_v16_sqrt(sg_v16 a) { return _mm512_sqrt_ps(a); }
/* min and max as the scalar ternaries: a < b ? a : b, a > b ? a : b */
static inline sg_v16 sg_v16_min(sg_v16 a, sg_v16 b) { return _mm512_min_ps(a, b); }
static inline sg_v16 sg_v16_max(sg_v16 a, sg_v16 b) { return _mm512_max_ps(a, b); }
static inline sg_v16 sg_v16_abs(sg_v16 a) { return _mm512_abs_ps(a); }
/* a > 0 ? a : 0 (NaN: 0) */
static inline sg_v16 sg_v16_pos(sg_v16 a)
{
    return _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(a, _mm512_setzero_ps(), _CMP_GT_OQ), a);
}
static inline unsigned sg_v16_ge(sg_v16 a, sg_v16 b) { return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ); }
static inline unsigned sg_v16_le(sg_v16 a, sg_v16 b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
static inline unsigned sg_v16_lt(sg_v16 a, sg_v16 b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
static inline unsigned sg_v16_eq(sg_v16 a, sg_v16 b) { return _mm512_cmp_ps_mask(a, b, _CMP_EQ_OQ); }
/* a != b, NaN included (as the scalar !=) */
static inline unsigned sg_v16_neq(sg_v16 a, sg_v16 b) { return _mm512_cmp_ps_mask(a, b, _CMP_NEQ_UQ); }
static inline unsigned sg_v16_gt(sg_v16 a, sg_v16 b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
/* Lanes of mask from a, the others from b. */
static inline sg_v16 sg_v16_select(unsigned mask, sg_v16 a, sg_v16 b)
{
    return _mm512_mask_blend_ps((__mmask16)mask, b, a);
}
/* The least of the lanes of mask (INFINITY for none); NaN-free input. */
static inline float sg_v16_min_lanes(sg_v16 a, unsigned mask)
{
    return _mm512_mask_reduce_min_ps((__mmask16)mask, a);
}
#elif defined(__AVX2__)
typedef struct sg_v16 {
    __m256 lo, hi;
} sg_v16;
static inline sg_v16 sg_v16_load(const float *p) { return (sg_v16){_mm256_loadu_ps(p), _mm256_loadu_ps(p + 8)}; }
static inline void sg_v16_store(float *p, sg_v16 a)
{
    _mm256_storeu_ps(p, a.lo);
    _mm256_storeu_ps(p + 8, a.hi);
}
static inline sg_v16 sg_v16_set1(float x) { return (sg_v16){_mm256_set1_ps(x), _mm256_set1_ps(x)}; }
static inline sg_v16 sg_v16_add(sg_v16 a, sg_v16 b) { return (sg_v16){_mm256_add_ps(a.lo, b.lo), _mm256_add_ps(a.hi, b.hi)}; }
static inline sg_v16 sg_v16_sub(sg_v16 a, sg_v16 b) { return (sg_v16){_mm256_sub_ps(a.lo, b.lo), _mm256_sub_ps(a.hi, b.hi)}; }
static inline sg_v16 sg_v16_mul(sg_v16 a, sg_v16 b) { return (sg_v16){_mm256_mul_ps(a.lo, b.lo), _mm256_mul_ps(a.hi, b.hi)}; }
static inline sg_v16 sg_v16_div(sg_v16 a, sg_v16 b) { return (sg_v16){_mm256_div_ps(a.lo, b.lo), _mm256_div_ps(a.hi, b.hi)}; }
static inline sg_v16 sg_v16_sqrt(sg_v16 a) { return (sg_v16){_mm256_sqrt_ps(a.lo), _mm256_sqrt_ps(a.hi)}; }
static inline sg_v16 sg_v16_min(sg_v16 a, sg_v16 b) { return (sg_v16){_mm256_min_ps(a.lo, b.lo), _mm256_min_ps(a.hi, b.hi)}; }
static inline sg_v16 sg_v16_max(sg_v16 a, sg_v16 b) { return (sg_v16){_mm256_max_ps(a.lo, b.lo), _mm256_max_ps(a.hi, b.hi)}; }
static inline sg_v16 sg_v16_abs(sg_v16 a)
{
    const __m256 sign = _mm256_set1_ps(-0.0f);
    return (sg_v16){_mm256_andnot_ps(sign, a.lo), _mm256_andnot_ps(sign, a.hi)};
}
static inline sg_v16 sg_v16_pos(sg_v16 a)
{
    const __m256 z = _mm256_setzero_ps();
    return (sg_v16){_mm256_and_ps(_mm256_cmp_ps(a.lo, z, _CMP_GT_OQ), a.lo),
                    _mm256_and_ps(_mm256_cmp_ps(a.hi, z, _CMP_GT_OQ), a.hi)};
}
static inline unsigned sg_v16__bits(__m256 lo, __m256 hi)
{
    return (unsigned)_mm256_movemask_ps(lo) | (unsigned)_mm256_movemask_ps(hi) << 8;
}
static inline unsigned sg_v16_ge(sg_v16 a, sg_v16 b)
{
    return sg_v16__bits(_mm256_cmp_ps(a.lo, b.lo, _CMP_GE_OQ), _mm256_cmp_ps(a.hi, b.hi, _CMP_GE_OQ));
}
static inline unsigned sg_v16_le(sg_v16 a, sg_v16 b)
{
    return sg_v16__bits(_mm256_cmp_ps(a.lo, b.lo, _CMP_LE_OQ), _mm256_cmp_ps(a.hi, b.hi, _CMP_LE_OQ));
}
static inline unsigned sg_v16_lt(sg_v16 a, sg_v16 b)
{
    return sg_v16__bits(_mm256_cmp_ps(a.lo, b.lo, _CMP_LT_OQ), _mm256_cmp_ps(a.hi, b.hi, _CMP_LT_OQ));
}
static inline unsigned sg_v16_gt(sg_v16 a, sg_v16 b)
{
    return sg_v16__bits(_mm256_cmp_ps(a.lo, b.lo, _CMP_GT_OQ), _mm256_cmp_ps(a.hi, b.hi, _CMP_GT_OQ));
}
static inline unsigned sg_v16_eq(sg_v16 a, sg_v16 b)
{
    return sg_v16__bits(_mm256_cmp_ps(a.lo, b.lo, _CMP_EQ_OQ), _mm256_cmp_ps(a.hi, b.hi, _CMP_EQ_OQ));
}
/* a != b, NaN included (as the scalar !=) */
static inline unsigned sg_v16_neq(sg_v16 a, sg_v16 b)
{
    return sg_v16__bits(_mm256_cmp_ps(a.lo, b.lo, _CMP_NEQ_UQ), _mm256_cmp_ps(a.hi, b.hi, _CMP_NEQ_UQ));
}
/* Lanes of mask from a, the others from b. */
static inline sg_v16 sg_v16_select(unsigned mask, sg_v16 a, sg_v16 b)
{
    const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    const __m256i ml = _mm256_and_si256(_mm256_set1_epi32((int)(mask & 255u)), bit);
    const __m256i mh = _mm256_and_si256(_mm256_set1_epi32((int)(mask >> 8 & 255u)), bit);
    return (sg_v16){_mm256_blendv_ps(b.lo, a.lo, _mm256_castsi256_ps(_mm256_cmpeq_epi32(ml, bit))),
                    _mm256_blendv_ps(b.hi, a.hi, _mm256_castsi256_ps(_mm256_cmpeq_epi32(mh, bit)))};
}
/* The least of the lanes of mask (INFINITY for none); NaN-free input. */
static inline float sg_v16_min_lanes(sg_v16 a, unsigned mask)
{
    const sg_v16 m = sg_v16_select(mask, a, sg_v16_set1(INFINITY));
    __m256 v = _mm256_min_ps(m.lo, m.hi);
    __m128 x = _mm_min_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    x = _mm_min_ps(x, _mm_movehl_ps(x, x));
    x = _mm_min_ss(x, _mm_shuffle_ps(x, x, 1));
    return _mm_cvtss_f32(x);
}
#endif


#endif
