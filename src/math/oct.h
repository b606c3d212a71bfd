/* oct.h — unit vectors in 32 bits by the octahedral map (Cigolle et al.
 * 2014, "A Survey of Efficient Representations for Independent Unit
 * Vectors", JCGT 3(2)): the sphere is folded onto the octahedron |x| + |y|
 * + |z| = 1, its lower half unfolded into the corners of the square, and
 * the square stored as two 16-bit signed-normalised numbers.
 *
 * Precision: the largest angle between a unit vector and its decoded
 * encoding is below SG_OCT_MAX_ERROR (2^-14 rad, about 0.0035 degrees:
 * one step of 2 / 65534 on the square maps to at most 2x that on the
 * sphere, and rounding takes half a step); tested on random vectors.
 * A zero vector encodes as (0, 0, 1).
 *
 * Layout: bits 0..15 the x coordinate, 16..31 the y coordinate on the
 * square, each round(v * 32767) as int16.
 */
#ifndef SG_MATH_OCT_H
#define SG_MATH_OCT_H

#include <math.h>
#include <stdint.h>

#include "math/v16.h"
#include "math/vec3.h"

#define SG_OCT_MAX_ERROR 6.103515625e-05f /* 2^-14 radians */

static inline float sg_oct__sign(float v) { return v < 0.0f ? -1.0f : 1.0f; }

static inline uint32_t sg_oct_encode(sg_vec3 n)
{
    float l1 = fabsf(n.x) + fabsf(n.y) + fabsf(n.z);
    if (!(l1 > 0.0f))
        return 0u; /* (0, 0) on the square: +z */
    float x = n.x / l1, y = n.y / l1;
    if (n.z < 0.0f) {
        float fx = (1.0f - fabsf(y)) * sg_oct__sign(x);
        float fy = (1.0f - fabsf(x)) * sg_oct__sign(y);
        x = fx;
        y = fy;
    }
    int32_t qx = (int32_t)lrintf(fminf(fmaxf(x, -1.0f), 1.0f) * 32767.0f);
    int32_t qy = (int32_t)lrintf(fminf(fmaxf(y, -1.0f), 1.0f) * 32767.0f);
    return (uint32_t)(uint16_t)(int16_t)qx | ((uint32_t)(uint16_t)(int16_t)qy << 16);
}

static inline sg_vec3 sg_oct_decode(uint32_t e)
{
    float x = (float)(int16_t)(uint16_t)(e & 0xFFFFu) * (1.0f / 32767.0f);
    float y = (float)(int16_t)(uint16_t)(e >> 16) * (1.0f / 32767.0f);
    float z = 1.0f - fabsf(x) - fabsf(y);
    if (z < 0.0f) {
        float fx = (1.0f - fabsf(y)) * sg_oct__sign(x);
        float fy = (1.0f - fabsf(x)) * sg_oct__sign(y);
        x = fx;
        y = fy;
    }
    float inv = 1.0f / sqrtf(x * x + y * y + z * z);
    return sg_v3(x * inv, y * inv, z * inv);
}

#if SG_V16_SIMD
/* sg_oct_decode of sixteen codes across the lanes of sg_v16 (v16.h: the
 * same IEEE operations in the same order, no fused multiply-adds), so lane
 * i is sg_oct_decode(code[i]) bit for bit (test_hybrid kernels_agree). The
 * halves go to float one by one (sg_v16 has no integer lanes); the rest,
 * its divisions and square roots, runs across the lanes. */
static inline void sg_oct_decode16(const uint32_t code[16], sg_v16 *x, sg_v16 *y, sg_v16 *z)
{
    _Alignas(64) float qx[16], qy[16];
    for (int i = 0; i < 16; ++i) {
        qx[i] = (float)(int16_t)(uint16_t)(code[i] & 0xFFFFu);
        qy[i] = (float)(int16_t)(uint16_t)(code[i] >> 16);
    }
    const sg_v16 one = sg_v16_set1(1.0f), zero = sg_v16_set1(0.0f), minus = sg_v16_set1(-1.0f);
    const sg_v16 k = sg_v16_set1(1.0f / 32767.0f);
    sg_v16 a = sg_v16_mul(sg_v16_load(qx), k), b = sg_v16_mul(sg_v16_load(qy), k);
    const sg_v16 c = sg_v16_sub(sg_v16_sub(one, sg_v16_abs(a)), sg_v16_abs(b));
    const unsigned fold = sg_v16_lt(c, zero);
    const sg_v16 fa = sg_v16_mul(sg_v16_sub(one, sg_v16_abs(b)), sg_v16_select(sg_v16_lt(a, zero), minus, one));
    const sg_v16 fb = sg_v16_mul(sg_v16_sub(one, sg_v16_abs(a)), sg_v16_select(sg_v16_lt(b, zero), minus, one));
    a = sg_v16_select(fold, fa, a);
    b = sg_v16_select(fold, fb, b);
    const sg_v16 inv = sg_v16_div(one, sg_v16_sqrt(sg_v16_add(sg_v16_add(sg_v16_mul(a, a), sg_v16_mul(b, b)),
                                                             sg_v16_mul(c, c))));
    *x = sg_v16_mul(a, inv);
    *y = sg_v16_mul(b, inv);
    *z = sg_v16_mul(c, inv);
}
#endif

#endif
