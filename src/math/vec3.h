/* vec3.h — 3-vectors and axis-aligned boxes as plain values.
 * World space, right-handed, +Y up (DESIGN.md). */
#ifndef SG_MATH_VEC3_H
#define SG_MATH_VEC3_H

#include <math.h>

typedef struct sg_vec3 {
    float x, y, z;
} sg_vec3;

static inline sg_vec3 sg_v3(float x, float y, float z) { sg_vec3 r = {x, y, z}; return r; }
static inline sg_vec3 sg_v3_add(sg_vec3 a, sg_vec3 b) { return sg_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline sg_vec3 sg_v3_sub(sg_vec3 a, sg_vec3 b) { return sg_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline sg_vec3 sg_v3_mul(sg_vec3 a, sg_vec3 b) { return sg_v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline sg_vec3 sg_v3_scale(sg_vec3 a, float s) { return sg_v3(a.x * s, a.y * s, a.z * s); }
static inline sg_vec3 sg_v3_madd(sg_vec3 a, sg_vec3 b, float s) { return sg_v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
static inline float sg_v3_dot(sg_vec3 a, sg_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline sg_vec3 sg_v3_cross(sg_vec3 a, sg_vec3 b)
{
    return sg_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float sg_v3_length(sg_vec3 a) { return sqrtf(sg_v3_dot(a, a)); }
/* Returns a unit vector, or the zero vector when a has (near) zero length. */
static inline sg_vec3 sg_v3_normalize(sg_vec3 a)
{
    float l2 = sg_v3_dot(a, a);
    return l2 > 1e-30f ? sg_v3_scale(a, 1.0f / sqrtf(l2)) : sg_v3(0, 0, 0);
}
static inline float sg_v3_get(sg_vec3 a, int axis) { return axis == 0 ? a.x : (axis == 1 ? a.y : a.z); }
static inline sg_vec3 sg_v3_min(sg_vec3 a, sg_vec3 b)
{
    return sg_v3(a.x < b.x ? a.x : b.x, a.y < b.y ? a.y : b.y, a.z < b.z ? a.z : b.z);
}
static inline sg_vec3 sg_v3_max(sg_vec3 a, sg_vec3 b)
{
    return sg_v3(a.x > b.x ? a.x : b.x, a.y > b.y ? a.y : b.y, a.z > b.z ? a.z : b.z);
}
static inline int sg_v3_isfinite(sg_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

/* Builds an orthonormal basis (t, b) around unit n (Duff et al. 2017). */
static inline void sg_v3_basis(sg_vec3 n, sg_vec3 *t, sg_vec3 *b)
{
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float c = n.x * n.y * a;
    *t = sg_v3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = sg_v3(c, sign + n.y * n.y * a, -n.y);
}

typedef struct sg_aabb {
    sg_vec3 lo, hi; /* empty box: lo > hi (see sg_aabb_empty) */
} sg_aabb;

static inline sg_aabb sg_aabb_empty(void)
{
    sg_aabb b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    return b;
}
static inline sg_aabb sg_aabb_grow(sg_aabb b, sg_vec3 p)
{
    b.lo = sg_v3_min(b.lo, p);
    b.hi = sg_v3_max(b.hi, p);
    return b;
}
static inline sg_aabb sg_aabb_union(sg_aabb a, sg_aabb b)
{
    a.lo = sg_v3_min(a.lo, b.lo);
    a.hi = sg_v3_max(a.hi, b.hi);
    return a;
}
static inline float sg_aabb_diagonal(sg_aabb b)
{
    return b.hi.x >= b.lo.x ? sg_v3_length(sg_v3_sub(b.hi, b.lo)) : 0.0f;
}

#endif
