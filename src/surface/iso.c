/* iso.c — ray casting the Implicit Surface Octree (Kashyap 2010, §4.5),
 * the corner codec (§4.4), and the ISO's accessors. Built in iso_build.c.
 *
 * Traversal: an explicit stack of cells with their ray intervals; the
 * children of a cell are pushed in the reverse of the order (k ^ octant),
 * octant bit a set where the ray runs towards -a, which is front to back
 * for the children a ray meets (it only ever moves into children whose
 * flipped index is a superset of the current one's). Each cell's slab
 * interval comes from its parent's three planes and the shared middle
 * planes, computed from integer grid coordinates (iso_int.h), so two
 * cells sharing a face see the ray cross it at the same t.
 *
 * In a leaf, the ray x(t) = o + t d, t = t0 + σ (t1 - t0), σ in [0,1],
 * puts the trilinear patch at a cubic g(σ) (the patch is multilinear and
 * each local coordinate is linear in σ). Its critical points split [0,1]
 * into monotone pieces; a piece whose ends change sign holds exactly one
 * root, found by Newton's method kept inside the shrinking bracket
 * (bisection when Newton leaves it) to SG_ISO_ROOT_EPS. The paper marched
 * samples and interpolated (§4.5), which §4.5.2 then has to paper over
 * with seamless ray tracing; the exact root needs neither.
 *
 * Invariants:
 *  1. a returned hit lies in [ray->tmin, ray->tmax], inside the leaf's ray
 *     interval, and its crossing is accepted by the ray's flags;
 *  2. its normal lies on its crossing's side: dot(dir, n) < 0 for an
 *     entry, > 0 for an exit (turned by SIDE_COS where the interpolated
 *     normal disagrees, as mls.c does);
 *  3. leaves are visited in increasing t, so the first accepted root is
 *     the nearest.
 */
#include "surface/iso.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <string.h>

#ifdef __AVX2__
#include <immintrin.h>
#endif

#include "core/alloc.h"
#include "math/v16.h"
#include "surface/iso_int.h"

/* |cos| between the ray and a normal turned to its crossing's side. */
static const float SIDE_COS = 1e-3f;

/* A sign change across the shared face of two consecutive leaves counts
 * when their ray intervals meet within this fraction of the leaf edge. */
static const float CARRY_EPS = 1e-5f;

enum { STACK_MAX = 8 * ISO_MAX_DEPTH + 8 };

/* min/max that keep the first argument when the second is NaN, and compile
 * to one instruction (fminf/fmaxf are library calls under -std=c11). */
static inline float max2(float a, float b) { return b > a ? b : a; }
static inline float min2(float a, float b) { return b < a ? b : a; }

void sg_iso_destroy(sg_iso *iso)
{
    if (!iso)
        return;
    if (iso->borrowed) {
        sg_free(iso);
        return;
    }
    sg_free(iso->nodes);
    sg_free(iso->leaves);
    sg_free(iso->cf);
    sg_free(iso->cn);
    sg_free(iso);
}

void sg_iso_set_lod(sg_iso *iso, float lod_px)
{
    assert(iso && lod_px >= 0.0f && isfinite(lod_px));
    iso->lod_px = lod_px;
}

void sg_iso_get_info(const sg_iso *iso, sg_iso_info *info)
{
    assert(iso && info);
    *info = iso->info;
}

/* ---- normal codec (Cigolle et al. 2014, oct32P: the rounding nearest in
 * angle among the four neighbours) ---------------------------------------- */

static inline float sign_nz(float v) { return v >= 0.0f ? 1.0f : -1.0f; }

static sg_vec3 oct_decode(float u, float v)
{
    sg_vec3 n = sg_v3(u, v, 1.0f - fabsf(u) - fabsf(v));
    if (n.z < 0.0f) {
        float x = n.x;
        n.x = (1.0f - fabsf(n.y)) * sign_nz(x);
        n.y = (1.0f - fabsf(x)) * sign_nz(n.y);
    }
    return sg_v3_normalize(n);
}

static inline int16_t q16(float v) { return (int16_t)fmaxf(-32767.0f, fminf(32767.0f, v)); }

static inline uint32_t pack(int16_t a, int16_t b) { return (uint32_t)(uint16_t)a | ((uint32_t)(uint16_t)b << 16); }

uint32_t sg_iso_encode_normal(sg_vec3 n)
{
    float l1 = fabsf(n.x) + fabsf(n.y) + fabsf(n.z);
    if (!(l1 > 0.0f))
        return pack(0, 0); /* decodes to +z; only invalid corners have none */
    float u = n.x / l1, v = n.y / l1;
    if (n.z < 0.0f) {
        float x = u;
        u = (1.0f - fabsf(v)) * sign_nz(x);
        v = (1.0f - fabsf(x)) * sign_nz(v);
    }
    float fu = floorf(u * 32767.0f), fv = floorf(v * 32767.0f);
    /* judged by the squared distance: a float dot product near 1 cannot
     * tell angles below ~3e-4 apart */
    sg_vec3 un = sg_v3_normalize(n);
    uint32_t best = 0;
    float best_d2 = INFINITY;
    for (int k = 0; k < 4; ++k) {
        int16_t a = q16(fu + (float)(k & 1)), b = q16(fv + (float)(k >> 1));
        sg_vec3 e = sg_v3_sub(oct_decode((float)a / 32767.0f, (float)b / 32767.0f), un);
        float d2 = sg_v3_dot(e, e);
        if (d2 < best_d2) {
            best_d2 = d2;
            best = pack(a, b);
        }
    }
    return best;
}

sg_vec3 sg_iso_decode_normal(uint32_t code)
{
    int16_t a = (int16_t)(uint16_t)(code & 0xFFFFu), b = (int16_t)(uint16_t)(code >> 16);
    return oct_decode((float)a / 32767.0f, (float)b / 32767.0f);
}

void sg_iso_leaf_corners(const sg_iso *iso, uint32_t leaf, float f[8], sg_vec3 n[8])
{
    assert(leaf < iso->leaf_count);
    const iso_leaf *L = &iso->leaves[leaf];
    for (int k = 0; k < 8; ++k) {
        f[k] = (float)iso->cf[L->corner[k]] * iso->f_scale;
        n[k] = sg_iso_decode_normal(iso->cn[L->corner[k]]);
    }
}

/* The trilinear interpolation of leaf L's 8 corner normals at local
 * coordinates uvw, normalised (iso.h: smooth across leaves, the corners
 * shared): the reference, corner by corner. */
static sg_vec3 leaf_normal_scalar(const sg_iso *iso, const iso_leaf *L, sg_vec3 uvw)
{
    sg_vec3 n = sg_v3(0, 0, 0);
    for (int k = 0; k < 8; ++k) {
        float w = (k & 1 ? uvw.x : 1.0f - uvw.x) * (k & 2 ? uvw.y : 1.0f - uvw.y) * (k & 4 ? uvw.z : 1.0f - uvw.z);
        n = sg_v3_madd(n, sg_iso_decode_normal(iso->cn[L->corner[k]]), w);
    }
    return sg_v3_normalize(n);
}

#ifdef __AVX2__
/* leaf_normal_scalar with the 8 decodes and weights in the 8 lanes of AVX
 * vectors: every lane evaluates oct_decode's and the weight's expressions
 * in their order (IEEE division and square root, no contraction), and the
 * weighted sum is then taken corner by corner in the scalar order, so
 * the result is the reference's bit for bit (tested through
 * sg_iso_leaf_normal_reference). */
static sg_vec3 leaf_normal(const sg_iso *iso, const iso_leaf *L, sg_vec3 uvw)
{
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
    const __m256 absmask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
    uint32_t code[8];
    for (int k = 0; k < 8; ++k)
        code[k] = iso->cn[L->corner[k]];
    __m256i c = _mm256_loadu_si256((const __m256i *)code);
    __m256 q = _mm256_set1_ps(32767.0f);
    __m256 u = _mm256_div_ps(_mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(c, 16), 16)), q);
    __m256 v = _mm256_div_ps(_mm256_cvtepi32_ps(_mm256_srai_epi32(c, 16)), q);
    __m256 au = _mm256_and_ps(u, absmask), av = _mm256_and_ps(v, absmask);
    __m256 z = _mm256_sub_ps(_mm256_sub_ps(one, au), av);
    /* z < 0: x = (1 - |v|) sign_nz(u), y = (1 - |u|) sign_nz(v), sign_nz(a) = a >= 0 ? 1 : -1 */
    __m256 su = _mm256_blendv_ps(_mm256_set1_ps(-1.0f), one, _mm256_cmp_ps(u, zero, _CMP_GE_OQ));
    __m256 sv = _mm256_blendv_ps(_mm256_set1_ps(-1.0f), one, _mm256_cmp_ps(v, zero, _CMP_GE_OQ));
    __m256 fold = _mm256_cmp_ps(z, zero, _CMP_LT_OQ);
    __m256 x = _mm256_blendv_ps(u, _mm256_mul_ps(_mm256_sub_ps(one, av), su), fold);
    __m256 y = _mm256_blendv_ps(v, _mm256_mul_ps(_mm256_sub_ps(one, au), sv), fold);
    /* sg_v3_normalize: l2 > 1e-30 ? a * (1 / sqrt(l2)) : 0 */
    __m256 l2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y)), _mm256_mul_ps(z, z));
    __m256 inv = _mm256_div_ps(one, _mm256_sqrt_ps(l2));
    __m256 ok = _mm256_cmp_ps(l2, _mm256_set1_ps(1e-30f), _CMP_GT_OQ);
    x = _mm256_and_ps(_mm256_mul_ps(x, inv), ok);
    y = _mm256_and_ps(_mm256_mul_ps(y, inv), ok);
    z = _mm256_and_ps(_mm256_mul_ps(z, inv), ok);
    /* weights: lane k takes u or 1 - u by bit 0, w by bit 1, z by bit 2 */
    __m256 wu = _mm256_blend_ps(_mm256_set1_ps(1.0f - uvw.x), _mm256_set1_ps(uvw.x), 0xAA);
    __m256 wv = _mm256_blend_ps(_mm256_set1_ps(1.0f - uvw.y), _mm256_set1_ps(uvw.y), 0xCC);
    __m256 wz = _mm256_blend_ps(_mm256_set1_ps(1.0f - uvw.z), _mm256_set1_ps(uvw.z), 0xF0);
    __m256 w = _mm256_mul_ps(_mm256_mul_ps(wu, wv), wz);
    float px[8], py[8], pz[8];
    _mm256_storeu_ps(px, _mm256_mul_ps(x, w));
    _mm256_storeu_ps(py, _mm256_mul_ps(y, w));
    _mm256_storeu_ps(pz, _mm256_mul_ps(z, w));
    sg_vec3 n = sg_v3(0, 0, 0);
    for (int k = 0; k < 8; ++k)
        n = sg_v3(n.x + px[k], n.y + py[k], n.z + pz[k]);
    return sg_v3_normalize(n);
}
#else
static sg_vec3 leaf_normal(const sg_iso *iso, const iso_leaf *L, sg_vec3 uvw) { return leaf_normal_scalar(iso, L, uvw); }
#endif

sg_vec3 sg_iso_leaf_normal(const sg_iso *iso, uint32_t leaf, sg_vec3 uvw)
{
    assert(iso && leaf < iso->leaf_count);
    return leaf_normal(iso, &iso->leaves[leaf], uvw);
}

sg_vec3 sg_iso_leaf_normal_reference(const sg_iso *iso, uint32_t leaf, sg_vec3 uvw)
{
    assert(iso && leaf < iso->leaf_count);
    return leaf_normal_scalar(iso, &iso->leaves[leaf], uvw);
}

static inline int popcount8(unsigned v) { return __builtin_popcount(v & 0xFFu); }

static inline sg_aabb cell_box(const sg_iso *iso, uint32_t x, uint32_t y, uint32_t z, uint32_t size)
{
    sg_aabb b = {sg_v3(iso_coord(iso->lo.x, iso->unit, x), iso_coord(iso->lo.y, iso->unit, y),
                       iso_coord(iso->lo.z, iso->unit, z)),
                 sg_v3(iso_coord(iso->lo.x, iso->unit, x + size), iso_coord(iso->lo.y, iso->unit, y + size),
                       iso_coord(iso->lo.z, iso->unit, z + size))};
    return b;
}

static void boxes_rec(const sg_iso *iso, uint32_t node, uint32_t x, uint32_t y, uint32_t z, int level,
                      sg_aabb *boxes)
{
    const iso_node *N = &iso->nodes[node];
    uint32_t hs = 1u << (iso->max_depth - level - 1);
    for (unsigned k = 0; k < 8; ++k) {
        if (!(N->child_mask >> k & 1u))
            continue;
        uint32_t cx = x + (k & 1 ? hs : 0), cy = y + (k & 2 ? hs : 0), cz = z + (k & 4 ? hs : 0);
        unsigned below = (1u << k) - 1u;
        if (N->leaf_mask >> k & 1u)
            boxes[N->leaf_base + popcount8(N->leaf_mask & below)] = cell_box(iso, cx, cy, cz, hs);
        else
            boxes_rec(iso, N->inner_base + (uint32_t)popcount8(N->child_mask & ~N->leaf_mask & below), cx, cy, cz,
                      level + 1, boxes);
    }
}

void sg_iso_leaf_boxes(const sg_iso *iso, sg_aabb *boxes)
{
    if (iso->node_count)
        boxes_rec(iso, 0, 0, 0, 0, 0, boxes);
}

static uint64_t fnv(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; ++i) {
        h ^= b[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

uint64_t sg_iso_checksum(const sg_iso *iso)
{
    uint64_t h = 0xcbf29ce484222325ull;
    h = fnv(h, &iso->lo, sizeof iso->lo);
    h = fnv(h, &iso->edge, sizeof iso->edge);
    h = fnv(h, &iso->f_scale, sizeof iso->f_scale);
    h = fnv(h, iso->nodes, iso->node_count * sizeof *iso->nodes);
    h = fnv(h, iso->leaves, iso->leaf_count * sizeof *iso->leaves);
    h = fnv(h, iso->cf, iso->corner_count * sizeof *iso->cf);
    h = fnv(h, iso->cn, iso->corner_count * sizeof *iso->cn);
    return h;
}

/* ---- ray casting ------------------------------------------------------------ */

/* What a ray carries from leaf to leaf. */
typedef struct ray_state {
    const sg_ray *ray;
    int want_front, want_back, either;
    int outside;        /* either: some patch on the ray so far was > 0      */
    int carry;          /* the last leaf's exit value is known ...          */
    float carry_t;      /* ... at this t ...                                 */
    float carry_g;      /* ... and is this                                   */
    uint64_t isects, roots;
} ray_state;

typedef struct cubic {
    float a0, a1, a2, a3;
} cubic;

static inline float cubic_at(const cubic *c, float s) { return ((c->a3 * s + c->a2) * s + c->a1) * s + c->a0; }
static inline float cubic_d(const cubic *c, float s) { return (3.0f * c->a3 * s + 2.0f * c->a2) * s + c->a1; }

/* The root of c in the monotone piece [lo, hi] where c(lo) is of class
 * (> 0) == pos and c(hi) is not. */
static float solve_piece(const cubic *c, float lo, float hi, float glo, float ghi, int pos)
{
    float s = lo + (hi - lo) * (glo / (glo - ghi)); /* secant start */
    if (!(s > lo && s < hi))
        s = 0.5f * (lo + hi);
    for (int it = 0; it < 40; ++it) {
        float g = cubic_at(c, s);
        if (g == 0.0f)
            return s;
        if ((g > 0.0f) == pos)
            lo = s;
        else
            hi = s;
        if (hi - lo <= SG_ISO_ROOT_EPS)
            break;
        float d = cubic_d(c, s), sn = s - g / d;
        if (!(sn > lo && sn < hi))
            sn = 0.5f * (lo + hi);
        if (fabsf(sn - s) <= 0.25f * SG_ISO_ROOT_EPS) {
            s = sn;
            break;
        }
        s = sn;
    }
    return s;
}

/* Roots of 3 a3 s^2 + 2 a2 s + a1 in (0, 1), ascending; returns the count. */
static int critical_points(const cubic *c, float out[2])
{
    float A = 3.0f * c->a3, B = 2.0f * c->a2, C = c->a1;
    float r[2];
    int n = 0;
    float scale = fabsf(A) + fabsf(B) + fabsf(C);
    if (!(scale > 0.0f))
        return 0;
    if (fabsf(A) <= 1e-7f * scale) {
        if (fabsf(B) > 0.0f)
            r[n++] = -C / B;
    } else {
        float disc = B * B - 4.0f * A * C;
        if (disc >= 0.0f) {
            /* the stable pair (no cancellation between -B and the root) */
            float q = -0.5f * (B + copysignf(sqrtf(disc), B));
            r[n++] = q / A;
            if (q != 0.0f)
                r[n++] = C / q;
        }
    }
    int m = 0;
    for (int i = 0; i < n; ++i)
        if (r[i] > 0.0f && r[i] < 1.0f)
            out[m++] = r[i];
    if (m == 2 && out[0] > out[1]) {
        float t = out[0];
        out[0] = out[1];
        out[1] = t;
    }
    return m;
}

/* The patch a ray meets in a cell: the trilinear interpolation of v[8] at
 * the corners of the cell's box (corner c at bit 0: +x, 1: +y, 2: +z). */
typedef struct patch {
    float v[8];
    float k[8];        /* v in the monomial basis (patch_coeffs): k[0] = v[0] */
    const iso_leaf *L; /* a leaf: its corner normals are interpolated; NULL: */
    sg_vec3 n;         /* a coarse patch (iso_lod.c), of this normal          */
    uint32_t leaf;     /* the leaf a hit names (a coarse patch: its leaf)     */
} patch;

/* Accepts or rejects a crossing at t (local coordinates uvw) of patch P;
 * fills hit on accept. */
static int accept(const sg_iso *iso, const patch *P, ray_state *rs, float t, sg_vec3 uvw, int entry, sg_hit *hit)
{
    const sg_ray *ray = rs->ray;
    if (entry ? !rs->want_front : (!rs->want_back || (rs->either && rs->outside)))
        return 0;
    if (!(t >= ray->tmin && t <= ray->tmax))
        return 0;
    sg_vec3 n = P->n;
    if (P->L) /* trilinear normal (iso.h: smooth across leaves, the corners shared) */
        n = leaf_normal(iso, P->L, uvw);
    /* The self test reads the surface's own normal, as mls.c's does, not
     * the one turned for invariant 2: a spawned ray leaves its site on the
     * surface, and where the origin's f lies within root precision of 0 a
     * crossing at t ~ 0 is its own patch seen from the wrong side (a
     * projected site on a leaf face: the carried sign change below). Turned
     * to graze the ray, that normal left the self cone, and 22% of the room
     * bake's sample points lost their light to their own surface. */
    if (sg_ray_is_self(ray, t, n))
        return 0;
    float side = entry ? -1.0f : 1.0f;
    float dn = sg_v3_dot(ray->dir, n);
    if (!(dn * side > SIDE_COS)) /* invariant 2 */
        n = sg_v3_normalize(sg_v3_madd(n, ray->dir, side * SIDE_COS - dn));
    hit->t = t;
    hit->p = sg_v3_madd(ray->org, ray->dir, t);
    hit->n = n;
    hit->splat = iso->leaves[P->leaf].splat;
    hit->leaf = P->leaf;
    return 1;
}

/* The patch as k0 + k1 u + k2 w + k3 z + k4 u w + k5 w z + k6 u z + k7 u w z
 * over local coordinates (u, w, z) in [0,1]^3; once per patch, whatever
 * number of rays meets it. */
static void patch_coeffs(patch *P)
{
    const float *v = P->v;
    P->k[0] = v[0];
    P->k[1] = v[1] - v[0], P->k[2] = v[2] - v[0], P->k[3] = v[4] - v[0];
    P->k[4] = v[3] - v[1] - v[2] + v[0], P->k[5] = v[6] - v[2] - v[4] + v[0], P->k[6] = v[5] - v[1] - v[4] + v[0];
    P->k[7] = v[7] - v[3] - v[5] - v[6] + v[1] + v[2] + v[4] - v[0];
}

/* A ray's way through a patch's box over [t0, t1]: its local coordinates
 * at t0, their change over the interval, and the cubic g(σ). */
typedef struct patch_ray {
    float u, w, z;    /* local coordinates at t0              */
    float bu, bw, bz; /* their change from t0 to t1           */
    cubic c;
} patch_ray;

/* The ray's patch_ray for patch P (box b, coefficients set) over [t0, t1];
 * trace16 evaluates the same expressions in the same order for its lanes
 * (packet16_patch_ray). */
static inline void patch_ray_of(const patch *P, sg_aabb b, const sg_ray *ray, float t0, float t1, patch_ray *pr)
{
    const float *v = P->v;
    float k1 = P->k[1], k2 = P->k[2], k3 = P->k[3], k4 = P->k[4], k5 = P->k[5], k6 = P->k[6], k7 = P->k[7];
    sg_vec3 h = sg_v3_sub(b.hi, b.lo);
    float S = t1 - t0;
    sg_vec3 e = sg_v3_madd(ray->org, ray->dir, t0);
    float u = (e.x - b.lo.x) / h.x, w = (e.y - b.lo.y) / h.y, z = (e.z - b.lo.z) / h.z;
    float bu = ray->dir.x * S / h.x, bw = ray->dir.y * S / h.y, bz = ray->dir.z * S / h.z;
    cubic *c = &pr->c;
    c->a0 = v[0] + k1 * u + k2 * w + k3 * z + k4 * u * w + k5 * w * z + k6 * u * z + k7 * u * w * z;
    c->a1 = k1 * bu + k2 * bw + k3 * bz + k4 * (u * bw + w * bu) + k5 * (w * bz + z * bw) + k6 * (u * bz + z * bu) +
            k7 * (bu * w * z + u * bw * z + u * w * bz);
    c->a2 = k4 * bu * bw + k5 * bw * bz + k6 * bu * bz + k7 * (bu * bw * z + bu * w * bz + u * bw * bz);
    c->a3 = k7 * bu * bw * bz;
    pr->u = u, pr->w = w, pr->z = z, pr->bu = bu, pr->bw = bw, pr->bz = bz;
}

/* The first accepted crossing of patch P (box b) over [t0, t1], the
 * ray's way through it given (pr). */
static int patch_solve(const sg_iso *iso, const patch *P, sg_aabb b, float t0, float t1, const patch_ray *pr,
                       ray_state *rs, sg_hit *hit)
{
    float u = pr->u, w = pr->w, z = pr->z, bu = pr->bu, bw = pr->bw, bz = pr->bz;
    cubic c = pr->c;
    float S = t1 - t0;
    rs->isects++;
    float edge = b.hi.x - b.lo.x;
    /* a sign change across the face shared with the previous leaf */
    if (rs->carry && fabsf(t0 - rs->carry_t) <= CARRY_EPS * edge) {
        int was_pos = rs->carry_g > 0.0f, is_pos = c.a0 > 0.0f;
        if (was_pos != is_pos) {
            rs->roots++;
            if (accept(iso, P, rs, t0, sg_v3(u, w, z), was_pos, hit))
                return 1;
        }
    }
    float cut[4] = {0.0f, 0.0f, 0.0f, 1.0f};
    int m = critical_points(&c, cut + 1);
    cut[m + 1] = 1.0f;
    float ga = c.a0;
    int crossed = 0;
    for (int p = 0; p <= m; ++p) {
        float pa = cut[p], pb = cut[p + 1];
        float gb = p == m ? cubic_at(&c, 1.0f) : cubic_at(&c, pb);
        if (rs->either && ga > 0.0f)
            rs->outside = 1;
        int entry = ga > 0.0f && gb <= 0.0f, exit = ga <= 0.0f && gb > 0.0f;
        if (entry || exit) {
            crossed = 1;
            rs->roots++;
            float s = solve_piece(&c, pa, pb, ga, gb, entry);
            float t = t0 + s * S;
            sg_vec3 q = sg_v3(u + bu * s, w + bw * s, z + bz * s);
            if (accept(iso, P, rs, t, q, entry, hit))
                return 1;
        }
        if (rs->either && gb > 0.0f)
            rs->outside = 1;
        ga = gb;
    }
    /* A jump at the next face counts only after a leaf without a crossing
     * of its own: after one, a jump back is the two patches covering the
     * same stretch of surface twice (leaves of different sizes), and would
     * be a second, spurious crossing. */
    rs->carry = !crossed;
    rs->carry_t = t1;
    rs->carry_g = ga;
    return 0;
}

/* The first accepted crossing of patch P (box b, coefficients set) over
 * [t0, t1]. */
static int patch_hit(const sg_iso *iso, const patch *P, sg_aabb b, float t0, float t1, ray_state *rs, sg_hit *hit)
{
    patch_ray pr;
    patch_ray_of(P, b, rs->ray, t0, t1, &pr);
    return patch_solve(iso, P, b, t0, t1, &pr, rs, hit);
}

/* Leaf `leaf`'s patch. */
static void leaf_patch(const sg_iso *iso, uint32_t leaf, patch *P)
{
    P->L = &iso->leaves[leaf];
    P->leaf = leaf;
    for (int k = 0; k < 8; ++k)
        P->v[k] = (float)iso->cf[P->L->corner[k]] * iso->f_scale;
    patch_coeffs(P);
}

/* slab_skips' decision for a ray whose path stays off the slab (above:
 * on the side its normal faces), shared with packet_slab_skips. */
static inline int slab_off_skips(const iso_lod *D, ray_state *rs, int above)
{
    if (!rs->either || rs->outside)
        return 1;
    if (above && D->leaf != ISO_NO_LOD) {
        rs->outside = 1;
        rs->carry = 0;
        return 1;
    }
    return 0;
}

/* Whether ray state rs may skip node `node` (cell interval [t0, t1],
 * normal n decoded from D) without meeting any leaf of it: its path
 * through the cell stays off the slab holding every leaf below
 * (iso_int.h), by more than the float rounding of n . x (a few ulps of
 * |n . o| + t1). Positive cells there would tell a ray accepting either
 * face that it is outside (iso_int.h pos_mask); one that does not know it
 * yet skips only a node whose leaves form one sheet (their normals agree:
 * a coarse patch exists) that it passes on the side its normal faces —
 * outside, so it now knows — and otherwise descends. */
static inline int slab_skips(const iso_lod *D, sg_vec3 n, ray_state *rs, float t0, float t1)
{
    const sg_ray *ray = rs->ray;
    float s0 = sg_v3_dot(n, ray->org), sd = sg_v3_dot(n, ray->dir);
    float a = s0 + sd * t0, b = s0 + sd * t1;
    float m = 8.0f * FLT_EPSILON * (fabsf(n.x * ray->org.x) + fabsf(n.y * ray->org.y) + fabsf(n.z * ray->org.z) + t1);
    int above = min2(a, b) > D->s_hi + m, below = max2(a, b) < D->s_lo - m;
    if (!above && !below)
        return 0;
    return slab_off_skips(D, rs, above);
}

/* Whether a ray whose footprint is lod_w wide per unit distance takes the
 * cell of `size` grid units that it enters at t0 as its node's coarse
 * patch (iso.h, "Levels of detail"). */
static inline int lod_takes(const sg_iso *iso, uint32_t node, uint32_t size, float lod_w, float t0)
{
    return lod_w > 0.0f && iso->nodes[node].lod.leaf != ISO_NO_LOD && (float)size * iso->unit <= lod_w * t0;
}

/* The first accepted crossing of node `node`'s coarse patch (box b) over
 * [t0, t1]. Without one, the ray's state is left as it was (the ray then
 * descends into the node as if it had not looked: no hole, no spurious
 * jump at the next face); only its counters keep the work done. */
static int lod_hit(const sg_iso *iso, uint32_t node, sg_aabb b, float t0, float t1, ray_state *rs, sg_hit *hit)
{
    const iso_lod *D = &iso->nodes[node].lod;
    patch P;
    P.L = NULL;
    sg_vec3 qn = iso_lod_normal(D);
    P.n = sg_v3_normalize(qn);
    P.leaf = D->leaf;
    for (int k = 0; k < 8; ++k) {
        sg_vec3 c = sg_v3(k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y, k & 4 ? b.hi.z : b.lo.z);
        P.v[k] = sg_v3_dot(qn, c) - D->d;
    }
    patch_coeffs(&P);
    ray_state before = *rs;
    if (patch_hit(iso, &P, b, t0, t1, rs, hit)) {
        hit->leaf = (uint32_t)iso->leaf_count + node; /* names the node (iso.h): its filtered light */
        return 1;
    }
    uint64_t isects = rs->isects, roots = rs->roots;
    *rs = before;
    rs->isects = isects;
    rs->roots = roots;
    return 0;
}

/* Bit j of the result is bit j ^ octant of mask (octant < 8): the three
 * index bits flipped by swapping bits, pairs and nibbles. */
static inline unsigned xor_permute(unsigned mask, unsigned octant)
{
    if (octant & 1u)
        mask = (mask & 0x55u) << 1 | (mask & 0xAAu) >> 1;
    if (octant & 2u)
        mask = (mask & 0x33u) << 2 | (mask & 0xCCu) >> 2;
    if (octant & 4u)
        mask = (mask & 0x0Fu) << 4 | (mask & 0xF0u) >> 4;
    return mask;
}

/* The ray's interval [c0[k], c1[k]] in each of a cell's 8 children (child
 * k: the low or high half per axis, bit a of k) from the halves' per-axis
 * intervals, clipped to the cell's [t0, t1]; returns the mask of children
 * with c0 <= c1. The AVX path computes the same maxima and minima as the
 * scalar one (max and min are exact), all 8 at once, without branches. */
static inline unsigned children_crossed(const float ilo[3][2], const float ihi[3][2], float t0, float t1,
                                        float c0[8], float c1[8])
{
#ifdef __AVX2__
    /* lanes k: x half k & 1, y half (k >> 1) & 1, z half k >> 2 */
    __m256 lx = _mm256_blend_ps(_mm256_set1_ps(ilo[0][0]), _mm256_set1_ps(ilo[0][1]), 0xAA);
    __m256 ly = _mm256_blend_ps(_mm256_set1_ps(ilo[1][0]), _mm256_set1_ps(ilo[1][1]), 0xCC);
    __m256 lz = _mm256_blend_ps(_mm256_set1_ps(ilo[2][0]), _mm256_set1_ps(ilo[2][1]), 0xF0);
    __m256 hx = _mm256_blend_ps(_mm256_set1_ps(ihi[0][0]), _mm256_set1_ps(ihi[0][1]), 0xAA);
    __m256 hy = _mm256_blend_ps(_mm256_set1_ps(ihi[1][0]), _mm256_set1_ps(ihi[1][1]), 0xCC);
    __m256 hz = _mm256_blend_ps(_mm256_set1_ps(ihi[2][0]), _mm256_set1_ps(ihi[2][1]), 0xF0);
    __m256 a = _mm256_max_ps(_mm256_max_ps(_mm256_set1_ps(t0), lx), _mm256_max_ps(ly, lz));
    __m256 b = _mm256_min_ps(_mm256_min_ps(_mm256_set1_ps(t1), hx), _mm256_min_ps(hy, hz));
    _mm256_storeu_ps(c0, a);
    _mm256_storeu_ps(c1, b);
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OQ));
#else
    unsigned mask = 0;
    for (int k = 0; k < 8; ++k) {
        int bx = k & 1, by = (k >> 1) & 1, bz = k >> 2;
        c0[k] = max2(max2(t0, ilo[0][bx]), max2(ilo[1][by], ilo[2][bz]));
        c1[k] = min2(min2(t1, ihi[0][bx]), min2(ihi[1][by], ihi[2][bz]));
        mask |= (unsigned)(c0[k] <= c1[k]) << k;
    }
    return mask;
#endif
}

typedef struct stack_entry {
    uint32_t index;  /* node or leaf                                   */
    uint32_t x, y, z;
    float t0, t1;
    uint8_t level;
    uint8_t is_leaf; /* CELL_NODE, CELL_LEAF or CELL_POSITIVE */
} stack_entry;

enum { CELL_NODE = 0, CELL_LEAF = 1, CELL_POSITIVE = 2 };

/* A ray's traversal constants. */
typedef struct ray_geom {
    float od[3], inv[3];
    int par[3];       /* the ray is parallel to axis a's planes */
    unsigned octant;  /* bit a: the ray runs towards -a          */
} ray_geom;

/* The ray's constants and its interval in the root cube, clipped to
 * [tmin, tmax]; 0 when it misses the cube. */
static int ray_enter(const sg_iso *iso, const sg_ray *ray, ray_geom *g, float *t0, float *t1)
{
    float dd[3] = {ray->dir.x, ray->dir.y, ray->dir.z}, lo[3] = {iso->lo.x, iso->lo.y, iso->lo.z};
    g->od[0] = ray->org.x, g->od[1] = ray->org.y, g->od[2] = ray->org.z;
    g->octant = 0;
    for (int a = 0; a < 3; ++a) {
        g->par[a] = dd[a] == 0.0f;
        g->inv[a] = g->par[a] ? 0.0f : 1.0f / dd[a];
        if (dd[a] < 0.0f)
            g->octant |= 1u << a;
    }
    float a0 = ray->tmin, a1 = ray->tmax;
    uint32_t full = 1u << iso->max_depth;
    for (int a = 0; a < 3; ++a) {
        float p0 = iso_coord(lo[a], iso->unit, 0), p1 = iso_coord(lo[a], iso->unit, full);
        if (g->par[a]) {
            if (!(g->od[a] >= p0 && g->od[a] <= p1))
                return 0;
            continue;
        }
        float ta = (p0 - g->od[a]) * g->inv[a], tb = (p1 - g->od[a]) * g->inv[a];
        a0 = max2(a0, min2(ta, tb));
        a1 = min2(a1, max2(ta, tb));
    }
    *t0 = a0;
    *t1 = a1;
    return a0 <= a1;
}

/* Per axis, the ray's t interval in the low and the high half of the cell
 * whose planes are p0 < pm < p1 (p[a][0..2]). */
static inline void half_intervals(const ray_geom *g, const float p[3][3], float ilo[3][2], float ihi[3][2])
{
    for (int a = 0; a < 3; ++a) {
        float p0 = p[a][0], pm = p[a][1], p1 = p[a][2], o = g->od[a];
        if (g->par[a]) {
            ilo[a][0] = o <= pm ? -INFINITY : INFINITY;
            ihi[a][0] = o <= pm ? INFINITY : -INFINITY;
            ilo[a][1] = o >= pm ? -INFINITY : INFINITY;
            ihi[a][1] = o >= pm ? INFINITY : -INFINITY;
            continue;
        }
        float ta = (p0 - o) * g->inv[a], tm = (pm - o) * g->inv[a], tb = (p1 - o) * g->inv[a];
        ilo[a][0] = min2(ta, tm);
        ihi[a][0] = max2(ta, tm);
        ilo[a][1] = min2(tm, tb);
        ihi[a][1] = max2(tm, tb);
    }
}

/* The planes of a cell at base[] of edge size (grid units): p[a] = the low
 * plane, the middle one and the high one on axis a. */
static inline void cell_planes(const sg_iso *iso, const uint32_t base[3], uint32_t size, float p[3][3])
{
    const float lo[3] = {iso->lo.x, iso->lo.y, iso->lo.z};
    for (int a = 0; a < 3; ++a) {
        p[a][0] = iso_coord(lo[a], iso->unit, base[a]);
        p[a][1] = iso_coord(lo[a], iso->unit, base[a] + (size >> 1));
        p[a][2] = iso_coord(lo[a], iso->unit, base[a] + size);
    }
}

/* The child k entry of node N (cell at base[], edge size) for the stack,
 * without its interval. */
static inline stack_entry child_entry(const iso_node *N, const uint32_t base[3], uint32_t size, uint8_t level,
                                      unsigned k)
{
    uint32_t hs = size >> 1;
    unsigned below = (1u << k) - 1u;
    stack_entry ce = {0, base[0] + (k & 1 ? hs : 0), base[1] + (k & 2 ? hs : 0), base[2] + (k & 4 ? hs : 0),
                      0.0f, 0.0f, (uint8_t)(level + 1), CELL_NODE};
    if (!(N->child_mask >> k & 1u)) {
        ce.is_leaf = CELL_POSITIVE;
    } else if (N->leaf_mask >> k & 1u) {
        ce.index = N->leaf_base + (uint32_t)popcount8(N->leaf_mask & below);
        ce.is_leaf = CELL_LEAF;
    } else {
        ce.index = N->inner_base + (uint32_t)popcount8(N->child_mask & ~N->leaf_mask & below);
    }
    return ce;
}

/* Asks for the record of a cell about to be pushed: it is read when the
 * cell is popped, and on a large octree that load was the traversal's
 * hottest instruction (a cache miss; perf, 1M-point dragon). */
static inline void prefetch_cell(const sg_iso *iso, const stack_entry *ce)
{
    /* both ends: half of the 36-byte records straddle two cache lines */
    if (ce->is_leaf == CELL_LEAF) {
        const char *p = (const char *)&iso->leaves[ce->index];
        __builtin_prefetch(p);
        __builtin_prefetch(p + sizeof(iso_leaf) - 1);
    } else if (ce->is_leaf == CELL_NODE) {
        const char *p = (const char *)&iso->nodes[ce->index];
        __builtin_prefetch(p);
        __builtin_prefetch(p + sizeof(iso_node) - 1);
    }
}

static void ray_state_init(ray_state *rs, const sg_ray *ray)
{
    *rs = (ray_state){.ray = ray};
    rs->want_front = !(ray->flags & SG_RAY_BACK_ONLY);
    rs->want_back = !(ray->flags & SG_RAY_FRONT_ONLY);
    rs->either = rs->want_front && rs->want_back;
}

/* One ray's counters into stats (may be NULL); for the ISO, isects are
 * the leaves whose cubic was examined and splats the roots solved (iso.h). */
static void count_ray(sg_ray_stats *stats, const ray_state *rs, uint64_t nodes, uint64_t leaves, int found)
{
    if (!stats)
        return;
    stats->rays++;
    stats->nodes += nodes;
    stats->leaves += leaves;
    stats->isects += rs->isects;
    stats->splats += rs->roots;
    stats->hits += (uint64_t)found;
}

/* Front-to-back traversal; the first accepted crossing (see file note). */
static int trace(const sg_iso *iso, const sg_ray *ray, sg_hit *hit, sg_ray_stats *stats)
{
    ray_state rs;
    ray_state_init(&rs, ray);
    uint64_t nodes = 0, leaves = 0;
    int found = 0;
    ray_geom g;
    float t0, t1, lod_w = iso->lod_px * ray->spread;
    if (!iso->node_count || !ray_enter(iso, ray, &g, &t0, &t1))
        goto out;
    stack_entry st[STACK_MAX];
    int sp = 0;
    st[sp++] = (stack_entry){0, 0, 0, 0, t0, t1, 0, CELL_NODE};
    while (sp > 0) {
        stack_entry e = st[--sp];
        nodes++;
        uint32_t size = 1u << (iso->max_depth - e.level);
        if (e.is_leaf == CELL_POSITIVE) { /* in front of the surface (iso_int.h pos_mask) */
            rs.outside = 1;
            rs.carry = 0;
            continue;
        }
        if (e.is_leaf) {
            leaves++;
            patch P;
            leaf_patch(iso, e.index, &P);
            if (patch_hit(iso, &P, cell_box(iso, e.x, e.y, e.z, size), e.t0, e.t1, &rs, hit)) {
                found = 1;
                break;
            }
            continue;
        }
        const iso_lod *D = &iso->nodes[e.index].lod;
        if (slab_skips(D, iso_lod_normal(D), &rs, e.t0, e.t1))
            continue;
        if (lod_takes(iso, e.index, size, lod_w, e.t0) &&
            lod_hit(iso, e.index, cell_box(iso, e.x, e.y, e.z, size), e.t0, e.t1, &rs, hit)) {
            found = 1;
            break;
        }
        const iso_node *N = &iso->nodes[e.index];
        uint32_t base[3] = {e.x, e.y, e.z};
        float p[3][3], ilo[3][2], ihi[3][2];
        cell_planes(iso, base, size, p);
        half_intervals(&g, p, ilo, ihi);
        /* positive cells matter only to rays accepting either face */
        unsigned visit = N->child_mask | (rs.either ? N->pos_mask : 0u);
        float c0s[8], c1s[8];
        visit &= children_crossed(ilo, ihi, e.t0, e.t1, c0s, c1s);
        /* front to back is j = 0..7 with k = j ^ octant: push j = 7 first */
        for (unsigned m = xor_permute(visit, g.octant); m; m &= ~(1u << (31 - __builtin_clz(m)))) {
            unsigned k = (31u - (unsigned)__builtin_clz(m)) ^ g.octant;
            stack_entry ce = child_entry(N, base, size, e.level, k);
            prefetch_cell(iso, &ce);
            ce.t0 = c0s[k];
            ce.t1 = c1s[k];
            assert(sp < STACK_MAX);
            st[sp++] = ce;
        }
    }
out:
    if (!found)
        hit->splat = SG_INVALID_ID;
    count_ray(stats, &rs, nodes, leaves, found);
    return found;
}

/* ---- packets of sixteen ------------------------------------------------------ */

/* Up to sixteen rays with the same direction signs (a 4 x 4 block of
 * camera rays) down one traversal: each keeps its own interval per cell
 * and its own state, so it meets the same leaves in the same order with
 * the same intervals as alone and gets the same hit, bit for bit; a cell
 * is visited while any ray still looking for a hit crosses it. One node's
 * record, fetched once, serves every such ray (the records are cache
 * misses: docs/iso.md, "Where it falls short"). Every interval is the
 * single-ray expression lane by lane with the sg_v16 operations (math/v16.h:
 * the scalar rounding); half_intervals' min2(a, b) is sg_v16_min(b, a) and
 * max2(a, b) sg_v16_max(b, a) (both return their second operand unless the
 * first is strictly smaller / larger), and the children's clipping is
 * children_crossed's expression with the operands in its order. Rays
 * parallel to an axis's planes are left to the single-ray path (their half
 * intervals need a per-lane select; camera rays almost never have a zero
 * component). */
#if SG_V16_SIMD
typedef struct packet16_entry {
    sg_v16 t0, t1;
    uint32_t index, x, y, z;
    uint16_t active; /* rays crossing the cell */
    uint8_t level, kind;
} packet16_entry;

/* The per-axis constants of sixteen rays, lane r = rays[r]; the lanes of
 * rays not traced are zero (their values are computed and never read). */
typedef struct packet16_geom {
    sg_v16 od[3], inv[3], dir[3];
} packet16_geom;

/* packet_slab_skips for sixteen lanes. */
static inline unsigned packet16_slab_skips(const packet16_geom *pg, const iso_lod *D, sg_vec3 n, ray_state *rs,
                                           unsigned act, sg_v16 t0, sg_v16 t1)
{
    const sg_v16 nx = sg_v16_set1(n.x), ny = sg_v16_set1(n.y), nz = sg_v16_set1(n.z);
    sg_v16 px = sg_v16_mul(nx, pg->od[0]), py = sg_v16_mul(ny, pg->od[1]), pz = sg_v16_mul(nz, pg->od[2]);
    sg_v16 s0 = sg_v16_add(sg_v16_add(px, py), pz);
    sg_v16 sd = sg_v16_add(sg_v16_add(sg_v16_mul(nx, pg->dir[0]), sg_v16_mul(ny, pg->dir[1])),
                           sg_v16_mul(nz, pg->dir[2]));
    sg_v16 a = sg_v16_add(s0, sg_v16_mul(sd, t0)), b = sg_v16_add(s0, sg_v16_mul(sd, t1));
    sg_v16 sum = sg_v16_add(sg_v16_add(sg_v16_add(sg_v16_abs(px), sg_v16_abs(py)), sg_v16_abs(pz)), t1);
    sg_v16 m = sg_v16_mul(sg_v16_set1(8.0f * FLT_EPSILON), sum);
    unsigned up = sg_v16_gt(sg_v16_min(b, a), sg_v16_add(sg_v16_set1(D->s_hi), m));
    unsigned off = (up | sg_v16_lt(sg_v16_max(b, a), sg_v16_sub(sg_v16_set1(D->s_lo), m))) & act;
    unsigned skip = 0;
    for (unsigned q = off; q; q &= q - 1) {
        int r = __builtin_ctz(q);
        if (slab_off_skips(D, &rs[r], (int)(up >> r & 1u)))
            skip |= 1u << r;
    }
    return skip;
}

/* packet_half_intervals for sixteen lanes, none parallel to a plane. */
static inline void packet16_half_intervals(const packet16_geom *pg, const float p[3][3], sg_v16 ilo[3][2],
                                           sg_v16 ihi[3][2])
{
    for (int a = 0; a < 3; ++a) {
        sg_v16 o = pg->od[a], inv = pg->inv[a];
        sg_v16 ta = sg_v16_mul(sg_v16_sub(sg_v16_set1(p[a][0]), o), inv);
        sg_v16 tm = sg_v16_mul(sg_v16_sub(sg_v16_set1(p[a][1]), o), inv);
        sg_v16 tb = sg_v16_mul(sg_v16_sub(sg_v16_set1(p[a][2]), o), inv);
        ilo[a][0] = sg_v16_min(tm, ta);
        ihi[a][0] = sg_v16_max(tm, ta);
        ilo[a][1] = sg_v16_min(tb, tm);
        ihi[a][1] = sg_v16_max(tb, tm);
    }
}

/* Short names for the cubic's long sums below (no contraction). */
static inline sg_v16 wmul(sg_v16 a, sg_v16 b) { return sg_v16_mul(a, b); }
static inline sg_v16 wadd(sg_v16 a, sg_v16 b) { return sg_v16_add(a, b); }

/* patch_ray_of for sixteen lanes; pr[r] is written for the lanes of act
 * only. */
static inline void packet16_patch_ray(const patch *P, sg_aabb b, const packet16_geom *pg, sg_v16 T0, sg_v16 T1,
                                      unsigned act, patch_ray pr[16])
{
    const float lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
    sg_v16 S = sg_v16_sub(T1, T0), loc[3], rate[3];
    for (int a = 0; a < 3; ++a) {
        sg_v16 h = sg_v16_set1(hi[a] - lo[a]);
        sg_v16 e = sg_v16_add(pg->od[a], sg_v16_mul(pg->dir[a], T0));
        loc[a] = sg_v16_div(sg_v16_sub(e, sg_v16_set1(lo[a])), h);
        rate[a] = sg_v16_div(sg_v16_mul(pg->dir[a], S), h);
    }
    sg_v16 u = loc[0], w = loc[1], z = loc[2], bu = rate[0], bw = rate[1], bz = rate[2];
    sg_v16 k1 = sg_v16_set1(P->k[1]), k2 = sg_v16_set1(P->k[2]), k3 = sg_v16_set1(P->k[3]);
    sg_v16 k4 = sg_v16_set1(P->k[4]), k5 = sg_v16_set1(P->k[5]), k6 = sg_v16_set1(P->k[6]);
    sg_v16 k7 = sg_v16_set1(P->k[7]);
    sg_v16 a0 = wadd(wadd(wadd(wadd(wadd(wadd(wadd(sg_v16_set1(P->v[0]), wmul(k1, u)), wmul(k2, w)), wmul(k3, z)), wmul(wmul(k4, u), w)), wmul(wmul(k5, w), z)),
                    wmul(wmul(k6, u), z)),
                  wmul(wmul(wmul(k7, u), w), z));
    sg_v16 a1 = wadd(wadd(wadd(wadd(wadd(wadd(wmul(k1, bu), wmul(k2, bw)), wmul(k3, bz)), wmul(k4, wadd(wmul(u, bw), wmul(w, bu)))), wmul(k5, wadd(wmul(w, bz), wmul(z, bw)))),
                    wmul(k6, wadd(wmul(u, bz), wmul(z, bu)))),
                  wmul(k7, wadd(wadd(wmul(wmul(bu, w), z), wmul(wmul(u, bw), z)), wmul(wmul(u, w), bz))));
    sg_v16 a2 = wadd(wadd(wadd(wmul(wmul(k4, bu), bw), wmul(wmul(k5, bw), bz)), wmul(wmul(k6, bu), bz)),
                  wmul(k7, wadd(wadd(wmul(wmul(bu, bw), z), wmul(wmul(bu, w), bz)), wmul(wmul(u, bw), bz))));
    sg_v16 a3 = wmul(wmul(wmul(k7, bu), bw), bz);
    float f[10][16];
    sg_v16_store(f[0], u), sg_v16_store(f[1], w), sg_v16_store(f[2], z);
    sg_v16_store(f[3], bu), sg_v16_store(f[4], bw), sg_v16_store(f[5], bz);
    sg_v16_store(f[6], a0), sg_v16_store(f[7], a1), sg_v16_store(f[8], a2), sg_v16_store(f[9], a3);
    for (unsigned m = act; m; m &= m - 1) {
        int r = __builtin_ctz(m);
        pr[r] = (patch_ray){f[0][r], f[1][r], f[2][r], f[3][r], f[4][r], f[5][r], {f[6][r], f[7][r], f[8][r], f[9][r]}};
    }
}

/* The rays of mask (bits 0-15) down one traversal: they share their
 * direction signs and none is parallel to an axis's planes. */
static unsigned trace16(const sg_iso *iso, const sg_ray *rays, unsigned mask, sg_hit *hits, sg_ray_stats *stats)
{
    ray_state rs[16];
    float r0[16] = {0}, r1[16] = {0}, lod_w[16] = {0};
    float od[3][16] = {{0}}, inv[3][16] = {{0}}, dir[3][16] = {{0}};
    unsigned active = 0, found = 0, either = 0, octant = 0;
    uint64_t nodes[16] = {0}, leaves[16] = {0};
    int lod_any = 0;
    for (unsigned m = mask; m; m &= m - 1) {
        int r = __builtin_ctz(m);
        ray_geom g;
        ray_state_init(&rs[r], &rays[r]);
        lod_w[r] = iso->lod_px * rays[r].spread;
        lod_any |= lod_w[r] > 0.0f;
        if (rs[r].either)
            either |= 1u << r;
        if (!iso->node_count || !ray_enter(iso, &rays[r], &g, &r0[r], &r1[r]))
            continue;
        active |= 1u << r;
        octant = g.octant;
        const float d[3] = {rays[r].dir.x, rays[r].dir.y, rays[r].dir.z};
        for (int a = 0; a < 3; ++a)
            od[a][r] = g.od[a], inv[a][r] = g.inv[a], dir[a][r] = d[a];
    }
    packet16_geom pg;
    for (int a = 0; a < 3; ++a)
        pg.od[a] = sg_v16_load(od[a]), pg.inv[a] = sg_v16_load(inv[a]), pg.dir[a] = sg_v16_load(dir[a]);
    const sg_v16 lw = sg_v16_load(lod_w), zero = sg_v16_set1(0.0f);
    packet16_entry st[STACK_MAX];
    int sp = 0;
    if (active)
        st[sp++] = (packet16_entry){sg_v16_load(r0), sg_v16_load(r1), 0, 0, 0, 0, (uint16_t)active, 0, CELL_NODE};
    while (sp > 0) {
        const packet16_entry *e = &st[--sp];
        unsigned act = e->active & ~found;
        if (!act)
            continue;
        if (stats)
            for (unsigned m = act; m; m &= m - 1)
                nodes[__builtin_ctz(m)]++;
        if (e->kind == CELL_POSITIVE) {
            for (unsigned m = act; m; m &= m - 1) {
                rs[__builtin_ctz(m)].outside = 1;
                rs[__builtin_ctz(m)].carry = 0;
            }
            continue;
        }
        uint32_t size = 1u << (iso->max_depth - e->level);
        if (e->kind == CELL_LEAF) {
            sg_aabb box = cell_box(iso, e->x, e->y, e->z, size);
            float t0[16], t1[16];
            sg_v16_store(t0, e->t0);
            sg_v16_store(t1, e->t1);
            patch P; /* once for the rays meeting it */
            leaf_patch(iso, e->index, &P);
            patch_ray pr[16];
            packet16_patch_ray(&P, box, &pg, e->t0, e->t1, act, pr);
            for (unsigned m = act; m; m &= m - 1) {
                int r = __builtin_ctz(m);
                leaves[r]++;
                if (patch_solve(iso, &P, box, t0[r], t1[r], &pr[r], &rs[r], &hits[r]))
                    found |= 1u << r;
            }
            continue;
        }
        const iso_lod *D = &iso->nodes[e->index].lod;
        act &= ~packet16_slab_skips(&pg, D, iso_lod_normal(D), rs, act, e->t0, e->t1);
        if (!act)
            continue;
        if (lod_any && D->leaf != ISO_NO_LOD) {
            /* lod_takes lane by lane: lod_w > 0 and size * unit <= lod_w * t0 */
            unsigned takes = act & sg_v16_gt(lw, zero) &
                             sg_v16_le(sg_v16_set1((float)size * iso->unit), sg_v16_mul(lw, e->t0));
            if (takes) {
                sg_aabb box = cell_box(iso, e->x, e->y, e->z, size);
                float t0[16], t1[16];
                sg_v16_store(t0, e->t0);
                sg_v16_store(t1, e->t1);
                for (unsigned m = takes; m; m &= m - 1) {
                    int r = __builtin_ctz(m);
                    if (lod_hit(iso, e->index, box, t0[r], t1[r], &rs[r], &hits[r]))
                        found |= 1u << r;
                }
                act &= ~found;
                if (!act)
                    continue;
            }
        }
        const iso_node *N = &iso->nodes[e->index];
        uint32_t base[3] = {e->x, e->y, e->z};
        uint8_t level = e->level;
        sg_v16 T0 = e->t0, T1 = e->t1;
        float p[3][3];
        cell_planes(iso, base, size, p);
        sg_v16 ilo[3][2], ihi[3][2];
        packet16_half_intervals(&pg, p, ilo, ihi);
        unsigned pos_rays = act & either; /* positive cells matter only to rays accepting either face */
        /* farthest child first; e (a stack slot) is overwritten from here on */
        for (int j = 7; j >= 0; --j) {
            unsigned k = (unsigned)j ^ octant;
            unsigned exists = N->child_mask >> k & 1u, pos = N->pos_mask >> k & 1u;
            unsigned lanes = exists ? act : pos ? pos_rays : 0u;
            if (!lanes)
                continue;
            sg_v16 c0 = sg_v16_max(sg_v16_max(T0, ilo[0][k & 1]), sg_v16_max(ilo[1][k >> 1 & 1], ilo[2][k >> 2]));
            sg_v16 c1 = sg_v16_min(sg_v16_min(T1, ihi[0][k & 1]), sg_v16_min(ihi[1][k >> 1 & 1], ihi[2][k >> 2]));
            lanes &= sg_v16_le(c0, c1);
            if (!lanes)
                continue;
            stack_entry ce = child_entry(N, base, size, level, k);
            prefetch_cell(iso, &ce);
            assert(sp < STACK_MAX);
            st[sp++] = (packet16_entry){c0, c1, ce.index, ce.x, ce.y, ce.z, (uint16_t)lanes, ce.level, ce.is_leaf};
        }
    }
    for (unsigned m = mask; m; m &= m - 1) {
        int r = __builtin_ctz(m);
        if (!(found >> r & 1u))
            hits[r].splat = SG_INVALID_ID;
        count_ray(stats, &rs[r], nodes[r], leaves[r], (int)(found >> r & 1u));
    }
    return found;
}
#endif

unsigned sg_iso_intersect16(const sg_iso *iso, const sg_ray *rays, unsigned mask, sg_hit *hits, sg_ray_stats *stats)
{
    assert(iso && rays && hits);
    mask &= 0xFFFFu;
    unsigned found = 0;
#if SG_V16_SIMD
    /* one traversal per direction octant (front to back is the octant's
     * order: a block on an octant's border is two or four packets) */
    unsigned octant[16], left = 0;
    for (unsigned m = mask; m; m &= m - 1) {
        int r = __builtin_ctz(m);
        sg_vec3 d = rays[r].dir;
        if (d.x == 0.0f || d.y == 0.0f || d.z == 0.0f)
            continue; /* alone, below */
        octant[r] = (d.x < 0.0f) | (d.y < 0.0f) << 1 | (d.z < 0.0f) << 2;
        left |= 1u << r;
    }
    unsigned alone = mask & ~left;
    while (left) {
        unsigned o = octant[__builtin_ctz(left)], same = 0;
        for (unsigned m = left; m; m &= m - 1)
            if (octant[__builtin_ctz(m)] == o)
                same |= 1u << __builtin_ctz(m);
        found |= trace16(iso, rays, same, hits, stats);
        left &= ~same;
    }
#else
    unsigned alone = mask;
#endif
    for (unsigned m = alone; m; m &= m - 1) {
        int r = __builtin_ctz(m);
        if (trace(iso, &rays[r], &hits[r], stats))
            found |= 1u << r;
    }
    return found;
}

unsigned sg_iso_intersect4(const sg_iso *iso, const sg_ray rays[4], unsigned mask, sg_hit hits[4],
                           sg_ray_stats *stats)
{
    return sg_iso_intersect16(iso, rays, mask & 15u, hits, stats); /* a quad is a packet of four */
}

int sg_iso_intersect(const sg_iso *iso, const sg_ray *ray, sg_hit *hit, sg_ray_stats *stats)
{
    assert(iso && ray && hit);
    return trace(iso, ray, hit, stats);
}

int sg_iso_occluded(const sg_iso *iso, const sg_ray *ray, sg_ray_stats *stats)
{
    /* the nearest accepted crossing is the first one the traversal meets:
     * nothing cheaper to stop at earlier */
    sg_hit h;
    return trace(iso, ray, &h, stats);
}
