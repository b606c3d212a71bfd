/* mls.c — ray intersection with the implicit MLS surface (Wald & Seidel
 * 2005, §3.2), and the cell-shrinking hook of their kd-tree (§3.4.1).
 *
 * Three departures from the paper. Two to sample where the surface can be:
 *  - F is only defined where some splat's support covers the ray, so the
 *    samples are spread over [ta, tb], the part of the cell's ray interval
 *    covered by at least one support sphere, not over the whole cell. The
 *    tighter the interval, the finer the sampling for the same k.
 *  - The sample count grows when the spacing would exceed `max_spacing`
 *    times the smallest radius in play, so a thin part between two samples
 *    is not skipped; k stays the minimum (the paper's fixed k is kept by
 *    max_spacing <= 0).
 * And one so that opposed layers (thin walls, folds) do not cancel: where
 * splats carry layer keys (scene.c), the field is taken per group of
 * splats facing the ray the same way ("groups of splats" below; issue 12).
 * Distances are evaluated from per-splat constants of the ray: with
 * q = p - o, tc = q.d and perp2 = |q|^2 - tc^2, |x(t) - p|^2 =
 * (t - tc)^2 + perp2, one fused multiply-add per sample and splat.
 *
 * Invariants:
 *  1. a returned hit lies in [t0, t1] and its crossing is accepted by the
 *     ray's face flags (entering = the front group's F goes from > 0 to
 *     <= 0, leaving = the back group's from < 0 to >= 0);
 *  2. samples with W below W_EPS neither make nor break a crossing: across a
 *     gap in the supports the sign of F carries no information. A gap no
 *     longer than the sample spacing (max_spacing x rmin) is bridged by
 *     the covered samples on either side, so that the surface does not
 *     depend on whether a sample landed in it; a longer gap ends the bracket;
 *  3. the SIMD and the scalar evaluation agree to rounding (tested);
 *  4. a hit's normal lies on its crossing's side: dot(dir, n) < 0 for an
 *     entry, > 0 for an exit (refine_crossing; tests/surface/test_leaks.c);
 *  5. where no splat on the ray has a layer key, the hits are the paper's
 *     single field's, crossing for crossing;
 *  6. a front-group crossing in the overhang of a convex keyed edge is
 *     passed (past_back_layer);
 *  7. a camera ray (SG_RAY_PRIMARY) whose first covered front-group sample
 *     after an uncovered stretch already lies behind the splats facing it
 *     (F < 0, their normal sum towards the ray) enters there: it grazed the
 *     rim of a closed part, where the zero set leaves the covered region,
 *     and without the rule it saw the part's inside (a dark pixel on a
 *     silhouette, 0.36 in a white furnace). The hit's point is that
 *     sample moved onto the front surface (its distance F / (W |N|) along
 *     the normal), so that it is seen from the front side and not from
 *     the part's inside (a thin sheet's rim read its inside). Other rays
 *     keep invariant 2, so the bake's rays and the openings they escape
 *     through are as before; the reference's camera rays carry the flag
 *     too, so the reference and the lookup frame see one surface.
 */
#include "surface/mls.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "math/rng.h"

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#define SG_MLS_AVX2 1
#endif

enum {
    MAX_ACTIVE = 256,   /* splats whose support meets the ray in one leaf   */
    SHRINK_SLICES = 8,  /* §3.4.1 uses 7-13 slices                          */
    SHRINK_GRID = 5,    /* samples per slice: GRID x GRID x SHRINK_LAYERS   */
    SHRINK_LAYERS = 2
};

/* Weight below which a sample is treated as uncovered (invariant 2). A
 * single splat reaches this only in the outer 0.01% of its radius. */
static const float W_EPS = 1e-4f;

/* past_back_layer: a back layer counts only where the ray starts behind
 * its splats' planes by more than BACK_LAYER_BEHIND radii (not the surface
 * the ray leaves: a ray from a floor to the wall beside it), and passes a
 * crossing only more than BACK_LAYER_GAP x the smallest radius in front of
 * it (a wall of zero thickness has its two layers in one plane; 0.015
 * lets a ray of tests/surface/test_leaks.c meet such a wall from behind,
 * 0.03 passes), between layers that meet at more than acos(EDGE_COS). */
static const float BACK_LAYER_BEHIND = 0.5f;
static const float BACK_LAYER_GAP = 0.05f;
static const float BACK_LAYER_EDGE_COS = 0.5f;

static const float GAUSS_E4 = 0.018315638888734f; /* exp(-4) */

/* |cos| between the ray and a hit normal turned to the crossing's side
 * (refine_crossing): 1e-3, about 0.06 degrees past edge-on. */
static const float SIDE_COS = 1e-3f;

float sg_mls_kernel(sg_kernel kernel, float s)
{
    if (!(s < 1.0f))
        return 0.0f;
    if (kernel == SG_KERNEL_GAUSSIAN)
        return (expf(-4.0f * s * s) - GAUSS_E4) * (1.0f / (1.0f - GAUSS_E4));
    return 1.0f - s;
}

/* Kernel from the squared distance ratio s2 = (d / r)^2. */
static inline float kernel_sq(sg_kernel kernel, float s2)
{
    if (!(s2 < 1.0f))
        return 0.0f;
    if (kernel == SG_KERNEL_GAUSSIAN)
        return (expf(-4.0f * s2) - GAUSS_E4) * (1.0f / (1.0f - GAUSS_E4));
    return 1.0f - sqrtf(s2);
}

/* The running sums of the MLS field at x (sg_mls_field): W, P = sum w (x -
 * p), N, and the splat of largest weight. */
typedef struct field_acc {
    float W, wmax;
    sg_vec3 P, N;
    uint32_t best;
} field_acc;

static inline void field_add(field_acc *a, const sg_splat_soa *s, size_t i, sg_kernel kernel, sg_vec3 x)
{
    float dx = x.x - s->px[i], dy = x.y - s->py[i], dz = x.z - s->pz[i];
    float w = kernel_sq(kernel, (dx * dx + dy * dy + dz * dz) * s->inv_r[i] * s->inv_r[i]);
    if (w <= 0.0f)
        return;
    a->W += w;
    /* Accumulate w (x - p) rather than w p: same F, no cancellation
     * between W x and sum w p far from the origin. */
    a->P = sg_v3_add(a->P, sg_v3(w * dx, w * dy, w * dz));
    a->N = sg_v3_add(a->N, sg_v3(w * s->nx[i], w * s->ny[i], w * s->nz[i]));
    if (w > a->wmax) {
        a->wmax = w;
        a->best = s->id[i];
    }
}

float sg_mls_field(const sg_splat_soa *s, size_t first, size_t count, sg_kernel kernel, sg_vec3 x,
                   float *wsum, sg_vec3 *nsum, uint32_t *argmax)
{
    field_acc a = {.best = SG_INVALID_ID};
    for (size_t i = first; i < first + count; ++i)
        field_add(&a, s, i, kernel, x);
    if (wsum) *wsum = a.W;
    if (nsum) *nsum = a.N;
    if (argmax) *argmax = a.best;
    return sg_v3_dot(a.P, a.N);
}

float sg_mls_field_indexed(const sg_pointset *ps, const uint32_t *idx, size_t count, sg_kernel kernel,
                           sg_vec3 x, float *wsum, sg_vec3 *nsum)
{
    float W = 0;
    sg_vec3 P = {0, 0, 0}, N = {0, 0, 0};
    for (size_t k = 0; k < count; ++k) {
        uint32_t i = idx[k];
        float dx = x.x - ps->px[i], dy = x.y - ps->py[i], dz = x.z - ps->pz[i];
        float ir = 1.0f / ps->radius[i];
        float w = kernel_sq(kernel, (dx * dx + dy * dy + dz * dz) * ir * ir);
        if (w <= 0.0f)
            continue;
        W += w;
        P = sg_v3_add(P, sg_v3(w * dx, w * dy, w * dz));
        N = sg_v3_add(N, sg_v3(w * ps->nx[i], w * ps->ny[i], w * ps->nz[i]));
    }
    if (wsum) *wsum = W;
    if (nsum) *nsum = N;
    return sg_v3_dot(P, N);
}

/* The splats of a leaf whose support meets the ray, with the per-ray
 * constants the sampling loop needs. */
/* ACTIVE_CAP: 8 entries of slack, for the 8-lane stores of the packed
 * survivors at the end of the list (gather_actives). */
enum { ACTIVE_CAP = MAX_ACTIVE + 8 };
typedef struct actives {
    int n;
    float qx[ACTIVE_CAP], qy[ACTIVE_CAP], qz[ACTIVE_CAP]; /* p - o          */
    float tc[ACTIVE_CAP];                                 /* q . d          */
    float perp2[ACTIVE_CAP];                              /* |q|^2 - tc^2   */
    float inv_r2[ACTIVE_CAP];                             /* 1 / r^2        */
    float nx[ACTIVE_CAP], ny[ACTIVE_CAP], nz[ACTIVE_CAP];
    uint32_t id[ACTIVE_CAP];
    float kd[ACTIVE_CAP];   /* layer key . d (scene.c): < 0 the splat is
                               in the front group only, > 0 in the back
                               group only, 0 in both                    */
} actives;

#ifdef SG_MLS_AVX2
/* COMPRESS_LUT[m]: the lanes set in the 8-bit mask m, in increasing order,
 * one byte each (unused bytes 0): the permutation that packs a vector's
 * selected lanes to its front (AVX2 has no compress instruction). */
static const uint64_t COMPRESS_LUT[256] = {
    0x0000000000000000ull, 0x0000000000000000ull, 0x0000000000000001ull, 0x0000000000000100ull,
    0x0000000000000002ull, 0x0000000000000200ull, 0x0000000000000201ull, 0x0000000000020100ull,
    0x0000000000000003ull, 0x0000000000000300ull, 0x0000000000000301ull, 0x0000000000030100ull,
    0x0000000000000302ull, 0x0000000000030200ull, 0x0000000000030201ull, 0x0000000003020100ull,
    0x0000000000000004ull, 0x0000000000000400ull, 0x0000000000000401ull, 0x0000000000040100ull,
    0x0000000000000402ull, 0x0000000000040200ull, 0x0000000000040201ull, 0x0000000004020100ull,
    0x0000000000000403ull, 0x0000000000040300ull, 0x0000000000040301ull, 0x0000000004030100ull,
    0x0000000000040302ull, 0x0000000004030200ull, 0x0000000004030201ull, 0x0000000403020100ull,
    0x0000000000000005ull, 0x0000000000000500ull, 0x0000000000000501ull, 0x0000000000050100ull,
    0x0000000000000502ull, 0x0000000000050200ull, 0x0000000000050201ull, 0x0000000005020100ull,
    0x0000000000000503ull, 0x0000000000050300ull, 0x0000000000050301ull, 0x0000000005030100ull,
    0x0000000000050302ull, 0x0000000005030200ull, 0x0000000005030201ull, 0x0000000503020100ull,
    0x0000000000000504ull, 0x0000000000050400ull, 0x0000000000050401ull, 0x0000000005040100ull,
    0x0000000000050402ull, 0x0000000005040200ull, 0x0000000005040201ull, 0x0000000504020100ull,
    0x0000000000050403ull, 0x0000000005040300ull, 0x0000000005040301ull, 0x0000000504030100ull,
    0x0000000005040302ull, 0x0000000504030200ull, 0x0000000504030201ull, 0x0000050403020100ull,
    0x0000000000000006ull, 0x0000000000000600ull, 0x0000000000000601ull, 0x0000000000060100ull,
    0x0000000000000602ull, 0x0000000000060200ull, 0x0000000000060201ull, 0x0000000006020100ull,
    0x0000000000000603ull, 0x0000000000060300ull, 0x0000000000060301ull, 0x0000000006030100ull,
    0x0000000000060302ull, 0x0000000006030200ull, 0x0000000006030201ull, 0x0000000603020100ull,
    0x0000000000000604ull, 0x0000000000060400ull, 0x0000000000060401ull, 0x0000000006040100ull,
    0x0000000000060402ull, 0x0000000006040200ull, 0x0000000006040201ull, 0x0000000604020100ull,
    0x0000000000060403ull, 0x0000000006040300ull, 0x0000000006040301ull, 0x0000000604030100ull,
    0x0000000006040302ull, 0x0000000604030200ull, 0x0000000604030201ull, 0x0000060403020100ull,
    0x0000000000000605ull, 0x0000000000060500ull, 0x0000000000060501ull, 0x0000000006050100ull,
    0x0000000000060502ull, 0x0000000006050200ull, 0x0000000006050201ull, 0x0000000605020100ull,
    0x0000000000060503ull, 0x0000000006050300ull, 0x0000000006050301ull, 0x0000000605030100ull,
    0x0000000006050302ull, 0x0000000605030200ull, 0x0000000605030201ull, 0x0000060503020100ull,
    0x0000000000060504ull, 0x0000000006050400ull, 0x0000000006050401ull, 0x0000000605040100ull,
    0x0000000006050402ull, 0x0000000605040200ull, 0x0000000605040201ull, 0x0000060504020100ull,
    0x0000000006050403ull, 0x0000000605040300ull, 0x0000000605040301ull, 0x0000060504030100ull,
    0x0000000605040302ull, 0x0000060504030200ull, 0x0000060504030201ull, 0x0006050403020100ull,
    0x0000000000000007ull, 0x0000000000000700ull, 0x0000000000000701ull, 0x0000000000070100ull,
    0x0000000000000702ull, 0x0000000000070200ull, 0x0000000000070201ull, 0x0000000007020100ull,
    0x0000000000000703ull, 0x0000000000070300ull, 0x0000000000070301ull, 0x0000000007030100ull,
    0x0000000000070302ull, 0x0000000007030200ull, 0x0000000007030201ull, 0x0000000703020100ull,
    0x0000000000000704ull, 0x0000000000070400ull, 0x0000000000070401ull, 0x0000000007040100ull,
    0x0000000000070402ull, 0x0000000007040200ull, 0x0000000007040201ull, 0x0000000704020100ull,
    0x0000000000070403ull, 0x0000000007040300ull, 0x0000000007040301ull, 0x0000000704030100ull,
    0x0000000007040302ull, 0x0000000704030200ull, 0x0000000704030201ull, 0x0000070403020100ull,
    0x0000000000000705ull, 0x0000000000070500ull, 0x0000000000070501ull, 0x0000000007050100ull,
    0x0000000000070502ull, 0x0000000007050200ull, 0x0000000007050201ull, 0x0000000705020100ull,
    0x0000000000070503ull, 0x0000000007050300ull, 0x0000000007050301ull, 0x0000000705030100ull,
    0x0000000007050302ull, 0x0000000705030200ull, 0x0000000705030201ull, 0x0000070503020100ull,
    0x0000000000070504ull, 0x0000000007050400ull, 0x0000000007050401ull, 0x0000000705040100ull,
    0x0000000007050402ull, 0x0000000705040200ull, 0x0000000705040201ull, 0x0000070504020100ull,
    0x0000000007050403ull, 0x0000000705040300ull, 0x0000000705040301ull, 0x0000070504030100ull,
    0x0000000705040302ull, 0x0000070504030200ull, 0x0000070504030201ull, 0x0007050403020100ull,
    0x0000000000000706ull, 0x0000000000070600ull, 0x0000000000070601ull, 0x0000000007060100ull,
    0x0000000000070602ull, 0x0000000007060200ull, 0x0000000007060201ull, 0x0000000706020100ull,
    0x0000000000070603ull, 0x0000000007060300ull, 0x0000000007060301ull, 0x0000000706030100ull,
    0x0000000007060302ull, 0x0000000706030200ull, 0x0000000706030201ull, 0x0000070603020100ull,
    0x0000000000070604ull, 0x0000000007060400ull, 0x0000000007060401ull, 0x0000000706040100ull,
    0x0000000007060402ull, 0x0000000706040200ull, 0x0000000706040201ull, 0x0000070604020100ull,
    0x0000000007060403ull, 0x0000000706040300ull, 0x0000000706040301ull, 0x0000070604030100ull,
    0x0000000706040302ull, 0x0000070604030200ull, 0x0000070604030201ull, 0x0007060403020100ull,
    0x0000000000070605ull, 0x0000000007060500ull, 0x0000000007060501ull, 0x0000000706050100ull,
    0x0000000007060502ull, 0x0000000706050200ull, 0x0000000706050201ull, 0x0000070605020100ull,
    0x0000000007060503ull, 0x0000000706050300ull, 0x0000000706050301ull, 0x0000070605030100ull,
    0x0000000706050302ull, 0x0000070605030200ull, 0x0000070605030201ull, 0x0007060503020100ull,
    0x0000000007060504ull, 0x0000000706050400ull, 0x0000000706050401ull, 0x0000070605040100ull,
    0x0000000706050402ull, 0x0000070605040200ull, 0x0000070605040201ull, 0x0007060504020100ull,
    0x0000000706050403ull, 0x0000070605040300ull, 0x0000070605040301ull, 0x0007060504030100ull,
    0x0000070605040302ull, 0x0007060504030200ull, 0x0007060504030201ull, 0x0706050403020100ull,
};

/* exp(x) for x in [-4, 0] to ~1e-6 relative: 2^(x log2 e) split into an
 * integer power (exponent bits) and a degree-5 polynomial on [0,1). */
static inline __m256 exp_m4_0(__m256 x)
{
    __m256 y = _mm256_mul_ps(x, _mm256_set1_ps(1.44269504089f));
    __m256 fl = _mm256_floor_ps(y);
    __m256 f = _mm256_sub_ps(y, fl);
    __m256 p = _mm256_set1_ps(1.8775767e-3f);
    p = _mm256_fmadd_ps(p, f, _mm256_set1_ps(8.9893397e-3f));
    p = _mm256_fmadd_ps(p, f, _mm256_set1_ps(5.5826318e-2f));
    p = _mm256_fmadd_ps(p, f, _mm256_set1_ps(2.4015361e-1f));
    p = _mm256_fmadd_ps(p, f, _mm256_set1_ps(6.9315308e-1f));
    p = _mm256_fmadd_ps(p, f, _mm256_set1_ps(9.9999994e-1f));
    __m256i e = _mm256_slli_epi32(_mm256_cvtps_epi32(fl), 23);
    return _mm256_castsi256_ps(_mm256_add_epi32(_mm256_castps_si256(p), e));
}

/* The kernel for 8 squared distance ratios s2 = (d / r)^2 (kernel_sq). */
static inline __m256 kernel8(sg_kernel kernel, __m256 s2)
{
    const __m256 zero = _mm256_setzero_ps();
    if (kernel == SG_KERNEL_GAUSSIAN) {
        __m256 g = exp_m4_0(_mm256_max_ps(_mm256_mul_ps(s2, _mm256_set1_ps(-4.0f)), _mm256_set1_ps(-4.0f)));
        return _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(g, _mm256_set1_ps(GAUSS_E4)),
                                           _mm256_set1_ps(1.0f / (1.0f - GAUSS_E4))),
                             zero);
    }
    return _mm256_max_ps(_mm256_sub_ps(_mm256_set1_ps(1.0f), _mm256_sqrt_ps(s2)), zero);
}
#endif

/* F, W and the normal sum N at 8 parameters over the active splats (SIMD
 * kernel). N may be NULL. */
static void eval_actives8(const actives *a, sg_kernel kernel, sg_vec3 d, const float t[8], float F[8],
                          float W[8], float (*N)[8])
{
#ifdef SG_MLS_AVX2
    const __m256 vt = _mm256_loadu_ps(t), zero = _mm256_setzero_ps();
    __m256 w_sum = zero, qx = zero, qy = zero, qz = zero, nx = zero, ny = zero, nz = zero;
    for (int j = 0; j < a->n; ++j) {
        __m256 dt = _mm256_sub_ps(vt, _mm256_set1_ps(a->tc[j]));
        __m256 s2 = _mm256_mul_ps(_mm256_fmadd_ps(dt, dt, _mm256_set1_ps(a->perp2[j])),
                                  _mm256_set1_ps(a->inv_r2[j]));
        __m256 w = kernel8(kernel, s2);
        w_sum = _mm256_add_ps(w_sum, w);
        qx = _mm256_fmadd_ps(w, _mm256_set1_ps(a->qx[j]), qx);
        qy = _mm256_fmadd_ps(w, _mm256_set1_ps(a->qy[j]), qy);
        qz = _mm256_fmadd_ps(w, _mm256_set1_ps(a->qz[j]), qz);
        nx = _mm256_fmadd_ps(w, _mm256_set1_ps(a->nx[j]), nx);
        ny = _mm256_fmadd_ps(w, _mm256_set1_ps(a->ny[j]), ny);
        nz = _mm256_fmadd_ps(w, _mm256_set1_ps(a->nz[j]), nz);
    }
    /* sum w (x - p) = t d W - sum w q */
    __m256 tw = _mm256_mul_ps(vt, w_sum);
    __m256 ex = _mm256_fmsub_ps(tw, _mm256_set1_ps(d.x), qx);
    __m256 ey = _mm256_fmsub_ps(tw, _mm256_set1_ps(d.y), qy);
    __m256 ez = _mm256_fmsub_ps(tw, _mm256_set1_ps(d.z), qz);
    __m256 f = _mm256_fmadd_ps(ex, nx, _mm256_fmadd_ps(ey, ny, _mm256_mul_ps(ez, nz)));
    _mm256_storeu_ps(F, f);
    _mm256_storeu_ps(W, w_sum);
    if (N) {
        _mm256_storeu_ps(N[0], nx);
        _mm256_storeu_ps(N[1], ny);
        _mm256_storeu_ps(N[2], nz);
    }
#else
    float ws[8] = {0}, qx[8] = {0}, qy[8] = {0}, qz[8] = {0}, nx[8] = {0}, ny[8] = {0}, nz[8] = {0};
    for (int j = 0; j < a->n; ++j) {
        for (int l = 0; l < 8; ++l) {
            float dt = t[l] - a->tc[j];
            float w = kernel_sq(kernel, (dt * dt + a->perp2[j]) * a->inv_r2[j]);
            ws[l] += w;
            qx[l] += w * a->qx[j];
            qy[l] += w * a->qy[j];
            qz[l] += w * a->qz[j];
            nx[l] += w * a->nx[j];
            ny[l] += w * a->ny[j];
            nz[l] += w * a->nz[j];
        }
    }
    for (int l = 0; l < 8; ++l) {
        float tw = t[l] * ws[l];
        F[l] = (tw * d.x - qx[l]) * nx[l] + (tw * d.y - qy[l]) * ny[l] + (tw * d.z - qz[l]) * nz[l];
        W[l] = ws[l];
        if (N) {
            N[0][l] = nx[l];
            N[1][l] = ny[l];
            N[2][l] = nz[l];
        }
    }
#endif
}

/* The splat with the largest weight at parameter t (SG_INVALID_ID if none
 * covers it): the hit's material comes from it. */
static uint32_t dominant_splat(const actives *a, sg_kernel kernel, float t)
{
    float wmax = 0.0f;
    uint32_t best = SG_INVALID_ID;
#ifdef SG_MLS_AVX2
    if (kernel == SG_KERNEL_HAT) {
        /* The hat weights 8 at a time, with the scalar loop's operations
         * (multiply, add, multiply, sqrt, subtract: no fused steps), so
         * the same values; then the same first-largest scan. A weight
         * outside the support is <= 0 (or NaN) and never beats wmax >= 0. */
        float w[ACTIVE_CAP];
        const __m256 vt = _mm256_set1_ps(t), one = _mm256_set1_ps(1.0f);
        for (int j = 0; j < a->n; j += 8) {
            __m256 dt = _mm256_sub_ps(vt, _mm256_loadu_ps(a->tc + j));
            __m256 s2 = _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(dt, dt), _mm256_loadu_ps(a->perp2 + j)),
                                      _mm256_loadu_ps(a->inv_r2 + j));
            _mm256_storeu_ps(w + j, _mm256_sub_ps(one, _mm256_sqrt_ps(s2)));
        }
        for (int j = 0; j < a->n; ++j)
            if (w[j] > wmax) {
                wmax = w[j];
                best = a->id[j];
            }
        return best;
    }
#endif
    for (int j = 0; j < a->n; ++j) {
        float dt = t - a->tc[j];
        float w = kernel_sq(kernel, (dt * dt + a->perp2[j]) * a->inv_r2[j]);
        if (w > wmax) {
            wmax = w;
            best = a->id[j];
        }
    }
    return best;
}

/* ---- groups of splats (issue 12) -------------------------------------------
 *
 * The paper's field F sums w_i n_i over every splat near x. Where two
 * layers with opposed normals lie within each other's support (a thin
 * wall's two sides, the facing walls of a fold, a thin part), the normals
 * cancel: F keeps one sign across the wall and rays pass through it, and
 * where the sum turns over inside a thin part F changes sign with a normal
 * that faces the wrong way (a hit "from behind" on a closed model). So the
 * splats near an opposed layer carry a layer key (scene.c: their normal
 * averaged over their own layer, free of the noise of single normals; 0
 * for every other splat), and a ray takes F over two groups apart: the
 * splats whose key faces it (key . d < 0) and those whose key faces away,
 * each with all the keyless splats. The front group's field is entered
 * (F falls through 0 along the ray), the back group's left (F rises).
 * Where no splat on the ray has a key, both groups are all the splats and
 * this is the paper's single field, crossing for crossing. */
enum { G_FRONT = 0, G_BACK = 1 };
enum { WANT_FRONT = 1u << G_FRONT, WANT_BACK = 1u << G_BACK };

/* The groups a ray's face expectation needs: a ray that accepts only
 * front faces looks only for the entry into the front group's field, one
 * that accepts only back faces for the exit from the back group's, any
 * other ray for the first of either. */
static unsigned ray_groups(uint32_t flags)
{
    if (flags & SG_RAY_FRONT_ONLY)
        return WANT_FRONT;
    if (flags & SG_RAY_BACK_ONLY)
        return WANT_BACK;
    return WANT_FRONT | WANT_BACK;
}

/* Which group a keyed splat joins for a ray, as a number whose sign says
 * it (< 0: front, > 0: back, NaN: neither; the key is the layer normal l
 * as three int8, splat_soa.h, so about 127 l). By direction, key . d: a
 * layer is entered from its front, moving against its normal, and left
 * from its back. But a ray whose origin lies behind the splat's plane and
 * moves away from its front (or in front, moving away from its back) never
 * crosses that plane: the splat joins neither group. Along a thin floor,
 * the floor's lower layer (facing down) is behind a ray rising from the
 * upper one: by direction alone it would join the front group and pull the
 * field of a wall ahead below zero, letting the ray through the corner
 * (the closed thin box of tests/ref/test_pathtrace.c: 0.7% of the path
 * segments inside escaped; 0.02% now). Sorting every splat the ray does
 * not cross within its support by the side the ray passes it on instead
 * did worse (Lucy: 1.7x the rays through folds; the box 20x the escapes).
 * With q = p - o, the origin's side of the plane is -q . k. */
static inline float key_side(uint32_t key, sg_vec3 d, float qx, float qy, float qz)
{
    int32_t k = (int32_t)key;
    float x = (float)((int32_t)((uint32_t)k << 24) >> 24), y = (float)((int32_t)((uint32_t)k << 16) >> 24),
          z = (float)((int32_t)((uint32_t)k << 8) >> 24);
    float kd = x * d.x + y * d.y + z * d.z, qk = x * qx + y * qy + z * qz;
    return (kd < 0.0f && qk > 0.0f) || (kd > 0.0f && qk < 0.0f) ? NAN : kd;
}

/* Whether a splat with key_side kd belongs to group gi (0: both, NaN:
 * neither). */
static inline int in_group(int gi, float kd) { return gi == G_FRONT ? kd <= 0.0f : kd >= 0.0f; }

/* A group's own crossing: the front group's field falls through zero
 * along the ray, the back group's rises through zero. */
static inline int group_crossing(int gi, float prevF, float F)
{
    return gi == G_FRONT ? prevF > 0.0f && F <= 0.0f : prevF < 0.0f && F >= 0.0f;
}

static inline int push_active(const sg_splat_soa *s, size_t i, float qx, float qy, float qz, float tc, float perp2,
                              float kd, actives *a)
{
    int n = a->n;
    if (n == MAX_ACTIVE)
        return 0;
    a->qx[n] = qx;
    a->qy[n] = qy;
    a->qz[n] = qz;
    a->tc[n] = tc;
    a->perp2[n] = perp2;
    a->inv_r2[n] = s->inv_r[i] * s->inv_r[i];
    a->nx[n] = s->nx[i];
    a->ny[n] = s->ny[i];
    a->nz[n] = s->nz[i];
    a->id[n] = s->id[i];
    a->kd[n] = kd;
    a->n = n + 1;
    return 1;
}

#ifdef SG_MLS_AVX2
/* Appends the lanes set in `bits` to the active list, in lane order (the
 * scalar loop's order): packs them to the front of each vector and stores
 * all 8 at the list's end; n only advances by the survivors. Returns 0 when
 * they do not fit (the caller falls back to the slow path). */
static inline int append_survivors(actives *a, int bits, __m256 qx, __m256 qy, __m256 qz, __m256 tc, __m256 perp2,
                                   __m256 inv_r, __m256 nx, __m256 ny, __m256 nz, __m256i id, __m256 kd)
{
    int n = a->n, pc = __builtin_popcount((unsigned)bits);
    if (n + pc > MAX_ACTIVE)
        return 0;
    const __m256i perm = _mm256_cvtepu8_epi32(_mm_cvtsi64_si128((long long)COMPRESS_LUT[bits]));
    _mm256_storeu_ps(a->qx + n, _mm256_permutevar8x32_ps(qx, perm));
    _mm256_storeu_ps(a->qy + n, _mm256_permutevar8x32_ps(qy, perm));
    _mm256_storeu_ps(a->qz + n, _mm256_permutevar8x32_ps(qz, perm));
    _mm256_storeu_ps(a->tc + n, _mm256_permutevar8x32_ps(tc, perm));
    _mm256_storeu_ps(a->perp2 + n, _mm256_permutevar8x32_ps(perp2, perm));
    _mm256_storeu_ps(a->inv_r2 + n, _mm256_permutevar8x32_ps(_mm256_mul_ps(inv_r, inv_r), perm));
    _mm256_storeu_ps(a->nx + n, _mm256_permutevar8x32_ps(nx, perm));
    _mm256_storeu_ps(a->ny + n, _mm256_permutevar8x32_ps(ny, perm));
    _mm256_storeu_ps(a->nz + n, _mm256_permutevar8x32_ps(nz, perm));
    _mm256_storeu_si256((__m256i *)(void *)(a->id + n), _mm256_permutevar8x32_epi32(id, perm));
    _mm256_storeu_ps(a->kd + n, _mm256_permutevar8x32_ps(kd, perm));
    a->n = n + pc;
    return 1;
}

/* key_side of 8 packed keys (same products in the same order). */
static inline __m256 key_side8(__m256i key, __m256 dx, __m256 dy, __m256 dz, __m256 qx, __m256 qy, __m256 qz)
{
    const __m256 zero = _mm256_setzero_ps();
    __m256 x = _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(key, 24), 24));
    __m256 y = _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(key, 16), 24));
    __m256 z = _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(key, 8), 24));
    __m256 kd = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(x, dx), _mm256_mul_ps(y, dy)), _mm256_mul_ps(z, dz));
    __m256 qk = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(x, qx), _mm256_mul_ps(y, qy)), _mm256_mul_ps(z, qz));
    __m256 never = _mm256_or_ps(_mm256_and_ps(_mm256_cmp_ps(kd, zero, _CMP_LT_OQ), _mm256_cmp_ps(qk, zero, _CMP_GT_OQ)),
                                _mm256_and_ps(_mm256_cmp_ps(kd, zero, _CMP_GT_OQ), _mm256_cmp_ps(qk, zero, _CMP_LT_OQ)));
    return _mm256_blendv_ps(kd, _mm256_set1_ps(NAN), never);
}
#endif

/* Collects the leaf's splats whose support sphere meets the ray inside
 * [t0, t1], in leaf order, with the per-ray constants the sampling loop
 * needs and key . d. Returns 0 when none does, else 1 and the interval
 * [*ta, *tb] the supports cover; -1 when more than MAX_ACTIVE qualify.
 * *keyed: some splat has a key (the groups differ). The AVX2 path tests 8
 * splats per step and appends the survivors; the scalar loop is the
 * reference and the fallback. */
static int gather_actives(const sg_splat_soa *s, size_t first, size_t count, const sg_ray *ray, float t0,
                          float t1, actives *a, float *ta, float *tb, float *rmin, int *keyed)
{
    float lo_all = FLT_MAX, hi_all = -FLT_MAX, r2min = FLT_MAX;
    const sg_vec3 o = ray->org, d = ray->dir;
    size_t i = first, end = first + count;
    int any_key = 0;
    a->n = 0;
#ifdef SG_MLS_AVX2
    const __m256 ox = _mm256_set1_ps(o.x), oy = _mm256_set1_ps(o.y), oz = _mm256_set1_ps(o.z);
    const __m256 dx = _mm256_set1_ps(d.x), dy = _mm256_set1_ps(d.y), dz = _mm256_set1_ps(d.z);
    const __m256 vt0 = _mm256_set1_ps(t0), vt1 = _mm256_set1_ps(t1), zero = _mm256_setzero_ps();
    __m256 vlo = _mm256_set1_ps(FLT_MAX), vhi = _mm256_set1_ps(-FLT_MAX), vr2 = _mm256_set1_ps(FLT_MAX);
    for (; i + 8 <= end; i += 8) {
        __m256 qx = _mm256_sub_ps(_mm256_loadu_ps(s->px + i), ox);
        __m256 qy = _mm256_sub_ps(_mm256_loadu_ps(s->py + i), oy);
        __m256 qz = _mm256_sub_ps(_mm256_loadu_ps(s->pz + i), oz);
        __m256 tc = _mm256_fmadd_ps(qx, dx, _mm256_fmadd_ps(qy, dy, _mm256_mul_ps(qz, dz)));
        __m256 q2 = _mm256_fmadd_ps(qx, qx, _mm256_fmadd_ps(qy, qy, _mm256_mul_ps(qz, qz)));
        __m256 perp2 = _mm256_max_ps(_mm256_fnmadd_ps(tc, tc, q2), zero);
        __m256 r = _mm256_loadu_ps(s->r + i);
        __m256 r2 = _mm256_mul_ps(r, r);
        __m256 inside = _mm256_cmp_ps(perp2, r2, _CMP_LT_OQ);
        __m256 h = _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(r2, perp2), zero));
        __m256 lo = _mm256_sub_ps(tc, h), hi = _mm256_add_ps(tc, h);
        __m256 m = _mm256_and_ps(inside, _mm256_and_ps(_mm256_cmp_ps(hi, vt0, _CMP_GE_OQ),
                                                        _mm256_cmp_ps(lo, vt1, _CMP_LE_OQ)));
        int bits = _mm256_movemask_ps(m);
        if (!bits)
            continue;
        vlo = _mm256_min_ps(vlo, _mm256_blendv_ps(vlo, lo, m));
        vhi = _mm256_max_ps(vhi, _mm256_blendv_ps(vhi, hi, m));
        vr2 = _mm256_min_ps(vr2, _mm256_blendv_ps(vr2, r2, m));
        __m256 kd = zero;
        if (s->key) {
            __m256i key = _mm256_loadu_si256((const __m256i *)(const void *)(s->key + i));
            if (!_mm256_testz_si256(key, _mm256_castps_si256(m))) {
                kd = key_side8(key, dx, dy, dz, qx, qy, qz);
                any_key = 1;
            }
        }
        if (!append_survivors(a, bits, qx, qy, qz, tc, perp2, _mm256_loadu_ps(s->inv_r + i),
                              _mm256_loadu_ps(s->nx + i), _mm256_loadu_ps(s->ny + i), _mm256_loadu_ps(s->nz + i),
                              _mm256_loadu_si256((const __m256i *)(const void *)(s->id + i)), kd))
            return -1;
    }
    if (i < end) {
        /* The last 1..7 splats in one masked step (no load past the
         * arrays' end) with the scalar loop's operations in its order
         * (separate multiplies and adds, perp2 < 0 set to 0, the same
         * rejection tests), so each splat gets the values it would get
         * there, bit for bit. */
        const __m256i lane = _mm256_cmpgt_epi32(_mm256_set1_epi32((int)(end - i)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        __m256 qx = _mm256_sub_ps(_mm256_maskload_ps(s->px + i, lane), ox);
        __m256 qy = _mm256_sub_ps(_mm256_maskload_ps(s->py + i, lane), oy);
        __m256 qz = _mm256_sub_ps(_mm256_maskload_ps(s->pz + i, lane), oz);
        __m256 tc = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(qx, dx), _mm256_mul_ps(qy, dy)), _mm256_mul_ps(qz, dz));
        __m256 q2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(qx, qx), _mm256_mul_ps(qy, qy)), _mm256_mul_ps(qz, qz));
        __m256 perp2 = _mm256_sub_ps(q2, _mm256_mul_ps(tc, tc));
        perp2 = _mm256_blendv_ps(perp2, zero, _mm256_cmp_ps(perp2, zero, _CMP_LT_OQ));
        __m256 r = _mm256_maskload_ps(s->r + i, lane);
        __m256 r2 = _mm256_mul_ps(r, r);
        __m256 inside = _mm256_and_ps(_mm256_cmp_ps(perp2, r2, _CMP_LT_OQ), _mm256_castsi256_ps(lane));
        __m256 h = _mm256_sqrt_ps(_mm256_sub_ps(r2, perp2));
        __m256 lo = _mm256_sub_ps(tc, h), hi = _mm256_add_ps(tc, h);
        __m256 reject = _mm256_or_ps(_mm256_cmp_ps(hi, vt0, _CMP_LT_OQ), _mm256_cmp_ps(lo, vt1, _CMP_GT_OQ));
        __m256 m = _mm256_andnot_ps(reject, inside);
        int bits = _mm256_movemask_ps(m);
        if (bits) {
            vlo = _mm256_min_ps(vlo, _mm256_blendv_ps(vlo, lo, m));
            vhi = _mm256_max_ps(vhi, _mm256_blendv_ps(vhi, hi, m));
            vr2 = _mm256_min_ps(vr2, _mm256_blendv_ps(vr2, r2, m));
            __m256 kd = zero;
            if (s->key) {
                __m256i key = _mm256_maskload_epi32((const int *)(const void *)(s->key + i), lane);
                if (!_mm256_testz_si256(key, _mm256_castps_si256(m))) {
                    kd = key_side8(key, dx, dy, dz, qx, qy, qz);
                    any_key = 1;
                }
            }
            if (!append_survivors(a, bits, qx, qy, qz, tc, perp2, _mm256_maskload_ps(s->inv_r + i, lane),
                                  _mm256_maskload_ps(s->nx + i, lane), _mm256_maskload_ps(s->ny + i, lane),
                                  _mm256_maskload_ps(s->nz + i, lane),
                                  _mm256_maskload_epi32((const int *)(const void *)(s->id + i), lane), kd))
                return -1;
        }
        i = end;
    }
    {
        float tmp[8];
        _mm256_storeu_ps(tmp, vlo);
        for (int l = 0; l < 8; ++l) lo_all = tmp[l] < lo_all ? tmp[l] : lo_all;
        _mm256_storeu_ps(tmp, vhi);
        for (int l = 0; l < 8; ++l) hi_all = tmp[l] > hi_all ? tmp[l] : hi_all;
        _mm256_storeu_ps(tmp, vr2);
        for (int l = 0; l < 8; ++l) r2min = tmp[l] < r2min ? tmp[l] : r2min;
    }
#endif
    for (; i < end; ++i) {
        float qx = s->px[i] - o.x, qy = s->py[i] - o.y, qz = s->pz[i] - o.z;
        float tc = qx * d.x + qy * d.y + qz * d.z;
        float perp2 = qx * qx + qy * qy + qz * qz - tc * tc;
        if (perp2 < 0.0f)
            perp2 = 0.0f;
        float r2 = s->r[i] * s->r[i];
        if (!(perp2 < r2))
            continue;
        float h = sqrtf(r2 - perp2);
        float lo = tc - h, hi = tc + h;
        if (hi < t0 || lo > t1)
            continue;
        float kd = 0.0f;
        if (s->key && s->key[i]) {
            kd = key_side(s->key[i], d, qx, qy, qz);
            any_key = 1;
        }
        if (!push_active(s, i, qx, qy, qz, tc, perp2, kd, a))
            return -1;
        lo_all = lo < lo_all ? lo : lo_all;
        hi_all = hi > hi_all ? hi : hi_all;
        r2min = r2 < r2min ? r2 : r2min;
    }
    if (!a->n)
        return 0;
    *keyed = any_key;
    *ta = lo_all > t0 ? lo_all : t0;
    *tb = hi_all < t1 ? hi_all : t1;
    *rmin = sqrtf(r2min);
    return *tb >= *ta;
}

static inline void copy_active(const actives *a, int j, actives *g, int n)
{
    g->qx[n] = a->qx[j], g->qy[n] = a->qy[j], g->qz[n] = a->qz[j];
    g->tc[n] = a->tc[j], g->perp2[n] = a->perp2[j], g->inv_r2[n] = a->inv_r2[j];
    g->nx[n] = a->nx[j], g->ny[n] = a->ny[j], g->nz[n] = a->nz[j];
    g->id[n] = a->id[j], g->kd[n] = a->kd[j];
}

/* Group gi of the actives in a, in a's order. */
static void group_of(const actives *a, int gi, actives *g)
{
    int n = 0;
    for (int j = 0; j < a->n; ++j) {
        if (in_group(gi, a->kd[j]))
            copy_active(a, j, g, n++);
    }
    g->n = n;
}

static int sample_count(const sg_mls_params *mp, float len, float rmin)
{
    int k = mp->samples < 2 ? 2 : mp->samples;
    if (mp->max_spacing > 0.0f && rmin > 0.0f) {
        float need = ceilf(len / (mp->max_spacing * rmin)) + 1.0f;
        if (need > (float)k)
            k = need > SG_MLS_MAX_SAMPLES ? SG_MLS_MAX_SAMPLES : (int)need;
    }
    return k > SG_MLS_MAX_SAMPLES ? SG_MLS_MAX_SAMPLES : k;
}

/* F, W, N and the dominant splat of group gi's field at x, straight from
 * the leaf arrays (the slow path's field). */
static float field_group(const sg_splat_soa *s, size_t first, size_t count, sg_kernel kernel, sg_vec3 x, sg_vec3 o,
                         sg_vec3 d, int gi, float *wsum, sg_vec3 *nsum, uint32_t *argmax)
{
    field_acc a = {.best = SG_INVALID_ID};
    for (size_t i = first; i < first + count; ++i) {
        if (s->key && s->key[i]) {
            float qx = s->px[i] - o.x, qy = s->py[i] - o.y, qz = s->pz[i] - o.z;
            if (!in_group(gi, key_side(s->key[i], d, qx, qy, qz)))
                continue;
        }
        field_add(&a, s, i, kernel, x);
    }
    *wsum = a.W;
    *nsum = a.N;
    *argmax = a.best;
    return sg_v3_dot(a.P, a.N);
}

/* Invariant 7's hit point and normal: the sample x, behind the front
 * surface (F < 0, inside the part), moved onto it along the normal sum's
 * direction by its distance F / (W |N|), so that what is seen from there
 * (the bake's light sites, the reference's paths) is the front side's and
 * not the part's inside (a thin sheet's rim read its inside). */
static sg_vec3 onto_front(sg_vec3 x, sg_vec3 nsum, float F, float W, sg_vec3 *n)
{
    const float len = sg_v3_length(nsum);
    *n = sg_v3_scale(nsum, 1.0f / len);
    return sg_v3_madd(x, *n, -F / (W * len));
}

/* Slow path for a leaf with more than MAX_ACTIVE splats on the ray (rare:
 * degenerate inputs such as thousands of duplicate points): each group's
 * field from the leaf arrays directly, sample by sample, with the crossing
 * rules of sg_mls_intersect_leaf. */
static int intersect_leaf_slow(const sg_splat_soa *s, size_t first, size_t count, const sg_mls_params *mp,
                               const sg_ray *ray, float t0, float t1, sg_hit *hit)
{
    int k = mp->samples < 2 ? 2 : mp->samples;
    if (k < SG_MLS_MAX_SAMPLES)
        k = SG_MLS_MAX_SAMPLES;
    const unsigned want = ray_groups(ray->flags);
    float prevF[2] = {0, 0}, prevT[2] = {t0, t0};
    int prev_ok[2] = {0, 0}, front_out = 0;
    for (int j = 0; j < k; ++j) {
        float t = t0 + (t1 - t0) * (float)j / (float)(k - 1);
        sg_vec3 x = sg_v3_madd(ray->org, ray->dir, t);
        float F[2] = {0, 0}, W[2] = {0, 0}, best_t = INFINITY;
        int found = 0;
        for (int gi = 0; gi < 2; ++gi) {
            if (!(want & (1u << gi)))
                continue;
            sg_vec3 N;
            uint32_t id;
            F[gi] = field_group(s, first, count, mp->kernel, x, ray->org, ray->dir, gi, &W[gi], &N, &id);
            if (gi == G_FRONT && (ray->flags & SG_RAY_PRIMARY) && W[gi] >= W_EPS && !prev_ok[gi] && F[gi] < 0.0f &&
                sg_v3_dot(N, ray->dir) < 0.0f && j > 0) {
                /* invariant 7; not at j = 0: this path carries nothing in
                 * from the previous leaf, so its first sample has no
                 * predecessor whatever the ray met before */
                sg_vec3 n;
                const sg_vec3 p = onto_front(x, N, F[gi], W[gi], &n);
                *hit = (sg_hit){.t = t, .p = p, .n = n, .splat = id};
                return 1;
            }
            if (W[gi] < W_EPS || !prev_ok[gi] || !group_crossing(gi, prevF[gi], F[gi]) ||
                (gi == G_BACK && front_out))
                continue;
            float th = prevT[gi] + (t - prevT[gi]) * prevF[gi] / (prevF[gi] - F[gi]), Wh;
            sg_vec3 p = sg_v3_madd(ray->org, ray->dir, th);
            field_group(s, first, count, mp->kernel, p, ray->org, ray->dir, gi, &Wh, &N, &id);
            sg_vec3 n = sg_v3_normalize(N);
            if (Wh > 0.0f && th < best_t && !sg_ray_is_self(ray, th, n)) {
                best_t = th;
                *hit = (sg_hit){.t = th, .p = p, .n = n, .splat = id};
                found = 1;
            }
        }
        if (found)
            return 1;
        if (want == (WANT_FRONT | WANT_BACK) && W[G_FRONT] >= W_EPS)
            front_out = F[G_FRONT] > 0.0f;
        for (int gi = 0; gi < 2; ++gi) {
            prev_ok[gi] = W[gi] >= W_EPS;
            prevF[gi] = F[gi];
            prevT[gi] = t;
        }
    }
    return 0;
}

void sg_mls_eval8(const sg_splat_soa *s, size_t first, size_t count, sg_kernel kernel, const sg_ray *ray,
                  const float t[8], float F[8], float W[8])
{
    actives a;
    float ta, tb, rmin;
    int keyed;
    /* Everything on the infinite line, so every splat near the ray counts:
     * the field over all splats. */
    if (gather_actives(s, first, count, ray, -FLT_MAX, FLT_MAX, &a, &ta, &tb, &rmin, &keyed) < 0) {
        for (int l = 0; l < 8; ++l)
            F[l] = sg_mls_field(s, first, count, kernel, sg_v3_madd(ray->org, ray->dir, t[l]), &W[l], NULL, NULL);
        return;
    }
    eval_actives8(&a, kernel, ray->dir, t, F, W, NULL);
}

/* One group's running state along the ray: its last usable sample. */
typedef struct field_prev {
    int ok;          /* a crossing may be bracketed from this sample      */
    int gap;         /* an uncovered stretch (W < W_EPS) has followed it  */
    float t, F;
    float N[3];
} field_prev;

/* The crossing in [pv->t, hi] of the field over a. The paper interpolates
 * linearly between the two samples; we first resample the bracket with 8
 * interior samples in one SIMD pass (spacing / 9), then interpolate F and
 * the normal sum linearly in the sub-bracket holding the sign change:
 * position error shrinks ~81-fold for one pass. */
static void refine_crossing(const actives *a, sg_kernel kernel, const sg_ray *ray, const field_prev *pv, float hi,
                            float Fhi, const float Nhi[3], sg_hit *hit)
{
    const sg_vec3 d = ray->dir;
    float lo = pv->t, sub_t[10], sub_F[10], sub_W[10], sub_N[3][10];
    float N8[3][8];
    sub_t[0] = lo;
    sub_F[0] = pv->F;
    sub_t[9] = hi;
    sub_F[9] = Fhi;
    sub_W[0] = sub_W[9] = 1.0f; /* both ends are covered samples */
    for (int m = 1; m <= 8; ++m)
        sub_t[m] = lo + (hi - lo) * (float)m / 9.0f;
    eval_actives8(a, kernel, d, sub_t + 1, sub_F + 1, sub_W + 1, N8);
    for (int c = 0; c < 3; ++c) {
        sub_N[c][0] = pv->N[c];
        sub_N[c][9] = Nhi[c];
        for (int m = 0; m < 8; ++m)
            sub_N[c][m + 1] = N8[c][m];
    }
    int m = 1;
    for (; m < 9; ++m)
        if (sub_W[m] >= W_EPS && (sub_F[m] > 0.0f) != (sub_F[0] > 0.0f))
            break;
    /* First sample on the far side of zero is m; interpolate from the
     * last covered sample before it, c0 (m - 1 unless the bracket spans a
     * bridged gap in the supports, where F and N are 0 and say nothing). */
    int c0 = m - 1;
    while (c0 > 0 && sub_W[c0] < W_EPS)
        --c0;
    float fa = sub_F[c0], fb = sub_F[m];
    float u = (fa != fb) ? fa / (fa - fb) : 0.5f;
    if (!(u >= 0.0f && u <= 1.0f))
        u = 0.5f;
    float th = sub_t[c0] + (sub_t[m] - sub_t[c0]) * u;
    sg_vec3 N = sg_v3(sub_N[0][c0] + (sub_N[0][m] - sub_N[0][c0]) * u,
                      sub_N[1][c0] + (sub_N[1][m] - sub_N[1][c0]) * u,
                      sub_N[2][c0] + (sub_N[2][m] - sub_N[2][c0]) * u);
    /* The side of the hit is the crossing's: F falling along the ray is an
     * entry, so the normal must face the ray (and rising, face away). The
     * interpolated normal sum is not F's gradient, and at grazing incidence
     * the two can disagree on the side by a degree or two; a path tracer
     * trusting the normal would then carry on as if inside the model. So
     * such a normal is turned, in the plane of it and the ray, until it
     * lies just on the crossing's side (cosine SIDE_COS with the ray). */
    const float side = sub_F[0] > 0.0f ? -1.0f : 1.0f, nd = sg_v3_dot(N, d);
    if (!(nd * side > 0.0f)) {
        float len = sg_v3_length(N);
        sg_vec3 perp = sg_v3_sub(N, sg_v3_scale(d, nd));
        float pl = sg_v3_length(perp);
        N = pl > 0.0f && len > 0.0f ? sg_v3_add(sg_v3_scale(perp, sqrtf(1.0f - SIDE_COS * SIDE_COS) / pl),
                                               sg_v3_scale(d, side * SIDE_COS))
                                    : sg_v3_scale(d, side);
    }
    hit->t = th;
    hit->p = sg_v3_madd(ray->org, d, th);
    hit->n = sg_v3_normalize(N);
    hit->splat = dominant_splat(a, kernel, th);
    if (hit->splat == SG_INVALID_ID) /* th in a bridged gap; hi is covered */
        hit->splat = dominant_splat(a, kernel, hi);
    assert(hit->splat != SG_INVALID_ID);
}

/* The weighted mean of a's splat positions at o + t d, as q = p - o, and
 * the sum of their weighted normals; returns W (0 where no splat covers
 * that point). */
static float mean_point(const actives *a, sg_kernel kernel, float t, float qm[3], float nm[3])
{
    float W = 0.0f;
    qm[0] = qm[1] = qm[2] = 0.0f;
    nm[0] = nm[1] = nm[2] = 0.0f;
    for (int j = 0; j < a->n; ++j) {
        float dt = t - a->tc[j], w = kernel_sq(kernel, (dt * dt + a->perp2[j]) * a->inv_r2[j]);
        W += w;
        qm[0] += w * a->qx[j], qm[1] += w * a->qy[j], qm[2] += w * a->qz[j];
        nm[0] += w * a->nx[j], nm[1] += w * a->ny[j], nm[2] += w * a->nz[j];
    }
    if (W < W_EPS)
        return 0.0f;
    for (int c = 0; c < 3; ++c)
        qm[c] /= W;
    return W;
}

/* A ray enters a surface only from outside it (the mirror of the rule for
 * the back group in sg_mls_intersect_leaf). Where two keyed layers meet at
 * a convex edge (a window's reveal and the wall's face) and the ray passes
 * just outside it, the layer the ray enters (the front group) and the one
 * whose plane it rises through from behind (the back layer: keyed splats
 * facing away from the ray, with the ray's origin well behind their
 * planes) are taken apart, and each alone continues its plane past the
 * edge by up to a splat radius. The ray then meets that overhang: the
 * built-in room's window was 9% narrower than its mesh for the sun's rays
 * at 250k points, the room 4% dark against the exact triangles. A
 * front-group crossing at t is passed as overhang when
 *  - it lies in front of the back layer's MLS plane (on its open side) by
 *    more than BACK_LAYER_GAP x rmin,
 *  - the two layers meet at an edge (normals more than 60 degrees apart),
 *    not along a smooth convex bend, whose back splats' plane passes under
 *    the surface by its sagitta,
 *  - and the entered layer does not lie in front of the back one (behind
 *    it at a convex edge; in its plane, to half the gap, for samples on the
 *    edge itself).
 * Kept: a thin wall's near face (behind its far face); the far wall of a
 * narrow fold, entered past the near wall's rim (it lies in front of the
 * near wall); a corner's wall seen from the floor the ray leaves (its
 * origin is not behind the floor's splats); every crossing the back layer
 * does not cover. bench_leaks on Lucy: the same back hits and tunnels as
 * without the rule. The back layer is split off `a` when first needed.
 * (The slow path for leaves of more than MAX_ACTIVE splats on the ray does
 * not apply the rule.) */
static int past_back_layer(const actives *a, const actives *front, actives *split_back, const actives **back,
                           sg_kernel kernel, sg_vec3 d, float t, float rmin)
{
    if (!*back) {
        int n = 0;
        for (int j = 0; j < a->n; ++j) {
            float behind = a->qx[j] * a->nx[j] + a->qy[j] * a->ny[j] + a->qz[j] * a->nz[j];
            if (a->kd[j] > 0.0f && behind > BACK_LAYER_BEHIND * sqrtf(1.0f / a->inv_r2[j]))
                copy_active(a, j, split_back, n++);
        }
        split_back->n = n;
        *back = split_back;
    }
    if (!(*back)->n)
        return 0;
    /* Both layers' MLS planes at x = o + t d: mean points qb, qf (as
     * p - o) and normals nb, nf. */
    float qb[3], nb[3], qf[3], nf[3];
    if (mean_point(*back, kernel, t, qb, nb) == 0.0f || mean_point(front, kernel, t, qf, nf) == 0.0f)
        return 0;
    float lb = sqrtf(nb[0] * nb[0] + nb[1] * nb[1] + nb[2] * nb[2]);
    float lf = sqrtf(nf[0] * nf[0] + nf[1] * nf[1] + nf[2] * nf[2]);
    if (!(lb > 0.0f && lf > 0.0f))
        return 0;
    /* x lies in front of the back layer by more than the gap ... */
    float x_front = ((t * d.x - qb[0]) * nb[0] + (t * d.y - qb[1]) * nb[1] + (t * d.z - qb[2]) * nb[2]) / lb;
    /* ... the layers meet at an edge, not along a smooth convex bend (whose
     * back splats' plane passes under the surface by its sagitta) ... */
    float cos_layers = (nb[0] * nf[0] + nb[1] * nf[1] + nb[2] * nf[2]) / (lb * lf);
    /* ... and the entered layer does not lie in front of the back one
     * (behind it: a convex edge; in its plane to within half the gap: the
     * edge's own row of samples). The far wall of a narrow fold, entered
     * past the near wall's rim, lies in front of the near wall: kept. */
    float entered_front = ((qf[0] - qb[0]) * nb[0] + (qf[1] - qb[1]) * nb[1] + (qf[2] - qb[2]) * nb[2]) / lb;
    return x_front > BACK_LAYER_GAP * rmin && cos_layers < BACK_LAYER_EDGE_COS && entered_front < 0.5f * BACK_LAYER_GAP * rmin;
}

/* Invariant 7's entry: the hit at the covered sample t (lane l of the
 * front group's normal sums N, which face the ray). 0, hit untouched, if
 * no splat has a positive weight there after all. */
static int take_rim_entry(const actives *front, sg_kernel kernel, const sg_ray *ray, float t, float F, float W,
                          float N[3][8], int l, sg_hit *hit)
{
    const uint32_t splat = dominant_splat(front, kernel, t);
    if (splat == SG_INVALID_ID)
        return 0;
    sg_vec3 n;
    const sg_vec3 p = onto_front(sg_v3_madd(ray->org, ray->dir, t), sg_v3(N[0][l], N[1][l], N[2][l]), F, W, &n);
    *hit = (sg_hit){.t = t, .p = p, .n = n, .splat = splat};
    return 1;
}

int sg_mls_intersect_leaf(const sg_splat_soa *s, size_t first, size_t count, const sg_mls_params *mp,
                          const sg_ray *ray, float t0, float t1, sg_hit *hit, sg_mls_carry *carry)
{
    actives all, split[2], back_layer;
    float ta, tb, rmin;
    int keyed = 0;
    sg_mls_carry in = {0};
    if (carry) {
        in = *carry;
        carry->valid = 0;
    }
    int got = gather_actives(s, first, count, ray, t0, t1, &all, &ta, &tb, &rmin, &keyed);
    if (got == 0)
        return 0;
    if (got < 0)
        return intersect_leaf_slow(s, first, count, mp, ray, t0, t1, hit);

    /* The groups: all the splats for both where none has a key (then one
     * evaluation serves both), else the two subsets. */
    const unsigned want = ray_groups(ray->flags);
    const actives *g[2] = {NULL, NULL};
    for (int gi = 0; gi < 2; ++gi) {
        if (!(want & (1u << gi)))
            continue;
        if (keyed) {
            group_of(&all, gi, &split[gi]);
            g[gi] = split[gi].n ? &split[gi] : NULL;
        } else
            g[gi] = &all;
    }
    const int shared = g[0] && g[0] == g[1];
    const actives *back = NULL; /* past_back_layer's, split off when first needed */

    float ts[SG_MLS_MAX_SAMPLES + 8];
    int k = sample_count(mp, tb - ta, rmin);
    float step = k > 1 ? (tb - ta) / (float)(k - 1) : 0.0f;
    for (int j = 0; j < k; ++j)
        ts[j] = ta + step * (float)j;
    ts[k - 1] = tb;
    for (int j = k; j < ((k + 7) & ~7); ++j)
        ts[j] = tb;

    /* Gaps in the supports up to one sample spacing long are bridged: such
     * a gap is seen only where a sample happens to land in it (short
     * leaves sample densely), and where the samples fall must not decide
     * the surface. A ray tunnelled through the default bunny's flank where
     * the front's supports broke off 0.2 radii before the field's sign
     * changed. A longer gap ends the bracket (invariant 2). */
    const float bridge = mp->max_spacing > 0.0f ? mp->max_spacing * rmin : 0.0f;
    field_prev prev[2] = {{.t = ta}, {.t = ta}};
    for (int gi = 0; gi < 2; ++gi)
        if ((in.valid >> gi & 1) && (in.t == ta || in.t == t0)) { /* the previous leaf ended where this one starts */
            prev[gi].ok = ta - in.t_last[gi] <= bridge || in.t_last[gi] == ta;
            prev[gi].gap = in.t_last[gi] != ta;
            prev[gi].t = in.t_last[gi];
            prev[gi].F = in.F[gi];
            memcpy(prev[gi].N, in.N[gi], sizeof prev[gi].N);
        }
    /* The last front-group sample with W >= W_EPS on the ray, in this leaf
     * or an earlier one, had F > 0: as the splats facing the ray see it, a
     * ray accepting either face is still outside. */
    const int either = want == (WANT_FRONT | WANT_BACK);
    int front_out = either && in.outside;
    const int rim_entry = (ray->flags & SG_RAY_PRIMARY) && (want & WANT_FRONT) && g[G_FRONT];
    for (int b = 0; b < k; b += 8) {
        float F8[2][8], W8[2][8], N8[2][3][8];
        for (int gi = 0; gi < 2; ++gi) {
            if (gi == 1 && shared) {
                memcpy(F8[1], F8[0], sizeof F8[0]);
                memcpy(W8[1], W8[0], sizeof W8[0]);
                memcpy(N8[1], N8[0], sizeof N8[0]);
            } else if (g[gi])
                eval_actives8(g[gi], mp->kernel, ray->dir, ts + b, F8[gi], W8[gi], N8[gi]);
            else
                memset(W8[gi], 0, sizeof W8[gi]);
        }
        int end = b + 8 < k ? b + 8 : k;
        for (int j = b; j < end; ++j) {
            int l = j - b, best = -1;
            float best_t = INFINITY;
            if (rim_entry && !prev[G_FRONT].ok && W8[G_FRONT][l] >= W_EPS && F8[G_FRONT][l] < 0.0f &&
                N8[G_FRONT][0][l] * ray->dir.x + N8[G_FRONT][1][l] * ray->dir.y + N8[G_FRONT][2][l] * ray->dir.z <
                    0.0f && take_rim_entry(g[G_FRONT], mp->kernel, ray, ts[j], F8[G_FRONT][l], W8[G_FRONT][l],
                                                N8[G_FRONT], l, hit))
                return 1; /* invariant 7 */
            for (int gi = 0; gi < 2; ++gi) {
                const field_prev *pv = &prev[gi];
                float F = F8[gi][l];
                if (W8[gi][l] < W_EPS || !pv->ok || (pv->gap && ts[j] - pv->t > bridge) ||
                    !group_crossing(gi, pv->F, F))
                    continue;
                /* A ray that accepts either face leaves a surface only from
                 * inside it: while the splats facing the ray last placed it
                 * in front of them (outside; as of the bracket's start, so
                 * that an entry and an exit in one bracket, as at a thin
                 * part's rim, give the entry), the back group's crossing
                 * is the far layer's plane reaching past the rim, not an
                 * exit. (With one group for both, F cannot rise through 0
                 * from a positive start: no effect.) */
                if (gi == G_BACK && front_out)
                    continue;
                /* The linear root; on the ray's own surface (ray.h)? Judge
                 * by it and the interpolated normal sum. */
                float u = pv->F / (pv->F - F), tl = pv->t + (ts[j] - pv->t) * u;
                if (ray->self_r > 0.0f) {
                    sg_vec3 nn = sg_v3_normalize(sg_v3(pv->N[0] + (N8[gi][0][l] - pv->N[0]) * u,
                                                       pv->N[1] + (N8[gi][1][l] - pv->N[1]) * u,
                                                       pv->N[2] + (N8[gi][2][l] - pv->N[2]) * u));
                    if (sg_ray_is_self(ray, tl, nn))
                        continue;
                }
                if (gi == G_FRONT && keyed &&
                    past_back_layer(&all, g[G_FRONT], &back_layer, &back, mp->kernel, ray->dir, tl, rmin))
                    continue;
                if (tl < best_t) {
                    best = gi;
                    best_t = tl;
                }
            }
            if (best >= 0) {
                float N[3] = {N8[best][0][l], N8[best][1][l], N8[best][2][l]};
                refine_crossing(g[best], mp->kernel, ray, &prev[best], ts[j], F8[best][l], N, hit);
                return 1;
            }
            if (either && W8[G_FRONT][l] >= W_EPS)
                front_out = F8[G_FRONT][l] > 0.0f;
            for (int gi = 0; gi < 2; ++gi) {
                if (W8[gi][l] < W_EPS) { /* in a gap: bridged while short */
                    prev[gi].gap = 1;
                    prev[gi].ok = prev[gi].ok && ts[j] - prev[gi].t <= bridge;
                    continue;
                }
                prev[gi] = (field_prev){.ok = 1, .t = ts[j], .F = F8[gi][l],
                                        .N = {N8[gi][0][l], N8[gi][1][l], N8[gi][2][l]}};
            }
        }
    }
    if (carry) {
        carry->t = t1;
        carry->outside = front_out;
        for (int gi = 0; gi < 2; ++gi)
            if (prev[gi].ok && (prev[gi].t == t1 || t1 - prev[gi].t <= bridge)) {
                carry->valid |= 1 << gi;
                carry->t_last[gi] = prev[gi].t;
                carry->F[gi] = prev[gi].F;
                memcpy(carry->N[gi], prev[gi].N, sizeof prev[gi].N);
            }
    }
    return 0;
}

/* ---- §3.4.1 cell shrinking ------------------------------------------------ */

/* The splats of a leaf-to-be, gathered once for the many field samples of
 * the shrink test. */
typedef struct shrink_splats {
    size_t n;
    float *px, *py, *pz, *nx, *ny, *nz, *inv_r2;
} shrink_splats;

/* Signed distances to the local MLS plane, f = F / (W |N|), at 8 points
 * (SIMD over the points); ok[l] = 0 where W is too small to say. */
static void plane_distance8(const shrink_splats *sp, sg_kernel kernel, const float x[3][8], float f[8], int ok[8])
{
    float W[8], E[3][8], N[3][8];
#ifdef SG_MLS_AVX2
    const __m256 zero = _mm256_setzero_ps();
    const __m256 x0 = _mm256_loadu_ps(x[0]), x1 = _mm256_loadu_ps(x[1]), x2 = _mm256_loadu_ps(x[2]);
    __m256 ws = zero, ex = zero, ey = zero, ez = zero, nx = zero, ny = zero, nz = zero;
    for (size_t i = 0; i < sp->n; ++i) {
        __m256 dx = _mm256_sub_ps(x0, _mm256_set1_ps(sp->px[i]));
        __m256 dy = _mm256_sub_ps(x1, _mm256_set1_ps(sp->py[i]));
        __m256 dz = _mm256_sub_ps(x2, _mm256_set1_ps(sp->pz[i]));
        __m256 s2 = _mm256_mul_ps(_mm256_fmadd_ps(dx, dx, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dz, dz))),
                                  _mm256_set1_ps(sp->inv_r2[i]));
        __m256 w = kernel8(kernel, s2);
        ws = _mm256_add_ps(ws, w);
        ex = _mm256_fmadd_ps(w, dx, ex);
        ey = _mm256_fmadd_ps(w, dy, ey);
        ez = _mm256_fmadd_ps(w, dz, ez);
        nx = _mm256_fmadd_ps(w, _mm256_set1_ps(sp->nx[i]), nx);
        ny = _mm256_fmadd_ps(w, _mm256_set1_ps(sp->ny[i]), ny);
        nz = _mm256_fmadd_ps(w, _mm256_set1_ps(sp->nz[i]), nz);
    }
    _mm256_storeu_ps(W, ws);
    _mm256_storeu_ps(E[0], ex); _mm256_storeu_ps(E[1], ey); _mm256_storeu_ps(E[2], ez);
    _mm256_storeu_ps(N[0], nx); _mm256_storeu_ps(N[1], ny); _mm256_storeu_ps(N[2], nz);
#else
    memset(W, 0, sizeof W);
    memset(E, 0, sizeof E);
    memset(N, 0, sizeof N);
    for (size_t i = 0; i < sp->n; ++i)
        for (int l = 0; l < 8; ++l) {
            float dx = x[0][l] - sp->px[i], dy = x[1][l] - sp->py[i], dz = x[2][l] - sp->pz[i];
            float w = kernel_sq(kernel, (dx * dx + dy * dy + dz * dz) * sp->inv_r2[i]);
            W[l] += w;
            E[0][l] += w * dx; E[1][l] += w * dy; E[2][l] += w * dz;
            N[0][l] += w * sp->nx[i]; N[1][l] += w * sp->ny[i]; N[2][l] += w * sp->nz[i];
        }
#endif
    for (int l = 0; l < 8; ++l) {
        float nl = sqrtf(N[0][l] * N[0][l] + N[1][l] * N[1][l] + N[2][l] * N[2][l]);
        ok[l] = W[l] >= W_EPS && nl > 0.0f;
        f[l] = ok[l] ? (E[0][l] * N[0][l] + E[1][l] * N[1][l] + E[2][l] * N[2][l]) / (W[l] * nl) : 0.0f;
    }
}

/* Whether slice `sl` may hold the surface: F changes sign in it, or some
 * sample lies within eps of the local plane. Stops at the first batch of 8
 * samples that decides it. Samples: a jittered GRID x GRID x LAYERS lattice,
 * the jitter from one hash per slice plus a Kronecker (R3) sequence. */
static int slice_may_hold_surface(const shrink_splats *const *fields, int nf, sg_kernel kernel, const float lo[3],
                                  const float ext[3], int a, int sl, float eps, uint64_t key)
{
    int b = (a + 1) % 3, c = (a + 2) % 3;
    float slice = ext[a] / SHRINK_SLICES;
    float j0 = sg_rng_float(key, (uint64_t)sl, 0, 0), j1 = sg_rng_float(key, (uint64_t)sl, 0, 1),
          j2 = sg_rng_float(key, (uint64_t)sl, 0, 2);
    float fmin[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, fmax[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    enum { TOTAL = SHRINK_LAYERS * SHRINK_GRID * SHRINK_GRID };
    for (int base = 0; base < TOTAL; base += 8) {
        float x[3][8], f[8];
        int ok[8];
        for (int l = 0; l < 8; ++l) {
            int sample = base + l < TOTAL ? base + l : TOTAL - 1;
            int la = sample / (SHRINK_GRID * SHRINK_GRID), ib = (sample / SHRINK_GRID) % SHRINK_GRID,
                ic = sample % SHRINK_GRID;
            /* R3 sequence offsets (Roberts 2018), shifted per slice. */
            float u0 = j0 + 0.8191725f * (float)sample, u1 = j1 + 0.6710436f * (float)sample,
                  u2 = j2 + 0.5497005f * (float)sample;
            u0 -= floorf(u0); u1 -= floorf(u1); u2 -= floorf(u2);
            x[a][l] = lo[a] + slice * ((float)sl + ((float)la + u0) / SHRINK_LAYERS);
            x[b][l] = lo[b] + ext[b] / SHRINK_GRID * ((float)ib + u1);
            x[c][l] = lo[c] + ext[c] / SHRINK_GRID * ((float)ic + u2);
        }
        for (int fi = 0; fi < nf; ++fi) {
            if (!fields[fi]->n)
                continue;
            plane_distance8(fields[fi], kernel, x, f, ok);
            for (int l = 0; l < 8; ++l) {
                if (!ok[l])
                    continue;
                fmin[fi] = f[l] < fmin[fi] ? f[l] : fmin[fi];
                fmax[fi] = f[l] > fmax[fi] ? f[l] : fmax[fi];
            }
            if (fmin[fi] <= eps && fmax[fi] >= -eps)
                return 1;
        }
    }
    return 0;
}

int sg_mls_shrink_cell(void *user, const uint32_t *prims, size_t count, sg_aabb *cell)
{
    const sg_mls_shrink_ctx *ctx = user;
    const sg_pointset *ps = ctx->points;
    enum { LOCAL = 64 };
    float local[7][LOCAL];
    float *buf = NULL;
    shrink_splats sp = {.n = count};
    if (count <= LOCAL) {
        sp.px = local[0]; sp.py = local[1]; sp.pz = local[2];
        sp.nx = local[3]; sp.ny = local[4]; sp.nz = local[5]; sp.inv_r2 = local[6];
    } else {
        buf = sg_alloc_array(count, 7 * sizeof(float));
        if (!buf)
            return 1; /* cannot test: keep the cell as it is (always correct) */
        sp.px = buf; sp.py = buf + count; sp.pz = buf + 2 * count;
        sp.nx = buf + 3 * count; sp.ny = buf + 4 * count; sp.nz = buf + 5 * count; sp.inv_r2 = buf + 6 * count;
    }
    sg_vec3 mean = {0, 0, 0};
    for (size_t k = 0; k < count; ++k) {
        uint32_t i = prims[k];
        sp.px[k] = ps->px[i]; sp.py[k] = ps->py[i]; sp.pz[k] = ps->pz[i];
        sp.nx[k] = ps->nx[i]; sp.ny[k] = ps->ny[i]; sp.nz[k] = ps->nz[i];
        sp.inv_r2[k] = 1.0f / (ps->radius[i] * ps->radius[i]);
        mean = sg_v3_add(mean, sg_pointset_normal(ps, i));
    }
    /* Opposed layers in the cell (some normal more than 90 degrees from
     * the mean: the two sides of a thin wall, facing walls of a fold)? Their
     * normals cancel in F, which may then miss the surface of either layer
     * that the query's groups (mls.c "groups of splats") find: a culled
     * slice would hide it (measured: rays through a thin closed shell). */
    int mixed = 0;
    for (size_t k = 0; k < count && !mixed; ++k)
        mixed = sp.nx[k] * mean.x + sp.ny[k] * mean.y + sp.nz[k] * mean.z < 0.0f;
    /* Slice across the dominant axis of the mean normal: the surface runs
     * roughly along the slices' other two axes, so empty slabs show. With
     * opposed layers the mean cancels; their common axis is the one of the
     * largest sum of |n_a|. */
    int a = 0;
    float am[3] = {fabsf(mean.x), fabsf(mean.y), fabsf(mean.z)};
    if (mixed) {
        am[0] = am[1] = am[2] = 0.0f;
        for (size_t k = 0; k < count; ++k)
            am[0] += fabsf(sp.nx[k]), am[1] += fabsf(sp.ny[k]), am[2] += fabsf(sp.nz[k]);
    }
    if (am[1] > am[a]) a = 1;
    if (am[2] > am[a]) a = 2;
    /* The fields a slice is tested with: F over all splats, and with
     * opposed layers also F over the splats whose normal has n_a > 0 and
     * over those with n_a <= 0 (a copy, in cell order); a slice stays when
     * any of them may hold a surface there (more kept, never less). */
    shrink_splats part[2] = {{0}, {0}};
    float *pbuf = NULL;
    const shrink_splats *fields[3] = {&sp, &part[0], &part[1]};
    int nf = 1;
    if (mixed && (pbuf = sg_alloc_array(count, 14 * sizeof(float))) != NULL) {
        for (int g = 0; g < 2; ++g) {
            float *base = pbuf + (size_t)g * 7 * count;
            shrink_splats *q = &part[g];
            q->px = base; q->py = base + count; q->pz = base + 2 * count;
            q->nx = base + 3 * count; q->ny = base + 4 * count; q->nz = base + 5 * count;
            q->inv_r2 = base + 6 * count;
        }
        const float *na = a == 0 ? sp.nx : a == 1 ? sp.ny : sp.nz;
        for (size_t k = 0; k < count; ++k) {
            shrink_splats *q = &part[na[k] > 0.0f ? 0 : 1];
            size_t j = q->n++;
            q->px[j] = sp.px[k]; q->py[j] = sp.py[k]; q->pz[j] = sp.pz[k];
            q->nx[j] = sp.nx[k]; q->ny[j] = sp.ny[k]; q->nz[j] = sp.nz[k];
            q->inv_r2[j] = sp.inv_r2[k];
        }
        nf = 3;
    } else if (mixed) {
        sg_free(buf);
        return 1; /* cannot test the groups: keep the cell as it is (always correct) */
    }
    int b = (a + 1) % 3, c = (a + 2) % 3;
    float lo[3] = {cell->lo.x, cell->lo.y, cell->lo.z}, hi[3] = {cell->hi.x, cell->hi.y, cell->hi.z};
    float ext[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    /* f = F / (W|N|) is the signed distance to the local plane, so a surface
     * crossing the slice passes within half a lattice-cell diagonal of some
     * sample: eps is that, with a 1.5x margin for the plane's curvature. */
    float gb = ext[b] / SHRINK_GRID, gc = ext[c] / SHRINK_GRID, ga = ext[a] / SHRINK_SLICES / SHRINK_LAYERS;
    float eps = 1.5f * 0.5f * sqrtf(gb * gb + gc * gc + ga * ga);
    /* Jitter keyed by the cell's position: deterministic, thread-independent. */
    uint64_t key;
    {
        uint32_t bits[3];
        memcpy(bits, lo, sizeof bits);
        key = ((uint64_t)bits[0] << 32 | bits[1]) ^ ((uint64_t)bits[2] * 0x9E3779B97F4A7C15ull) ^ count;
    }
    /* Quick rejection first: f is the distance to the local plane, so where
     * the surface crosses the cell, |f| at any point of the cell is at most
     * the cell's diagonal (same local-planarity assumption as eps). If 8
     * points spread over the cell all see the plane farther than 1.5
     * diagonals, on the same side, no surface is inside. Most of the cells
     * that end up empty go here, for 8 evaluations instead of 8 slices. */
    {
        float diag = sqrtf(ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]);
        float x[3][8], f[8];
        int ok[8], far_pos = 0, far_neg = 0;
        for (int l = 0; l < 8; ++l) /* the cube's corners pulled in to 1/4 and 3/4 */
            for (int c3 = 0; c3 < 3; ++c3)
                x[c3][l] = lo[c3] + ext[c3] * ((l >> c3) & 1 ? 0.75f : 0.25f);
        plane_distance8(&sp, ctx->kernel, x, f, ok);
        for (int l = 0; l < 8; ++l) {
            far_pos += ok[l] && f[l] > 1.5f * diag;
            far_neg += ok[l] && f[l] < -1.5f * diag;
        }
        if (!mixed && (far_pos == 8 || far_neg == 8)) {
            sg_free(buf);
            return 0;
        }
    }
    /* Only the ends can be cut off, so search inwards from both sides. */
    int first = 0, last = SHRINK_SLICES - 1;
    while (first < SHRINK_SLICES && !slice_may_hold_surface(fields, nf, ctx->kernel, lo, ext, a, first, eps, key))
        ++first;
    if (first == SHRINK_SLICES) {
        sg_free(buf);
        sg_free(pbuf);
        return 0;
    }
    while (last > first && !slice_may_hold_surface(fields, nf, ctx->kernel, lo, ext, a, last, eps, key))
        --last;
    sg_free(buf);
    sg_free(pbuf);
    float slice = ext[a] / SHRINK_SLICES;
    float nlo = first == 0 ? lo[a] : lo[a] + slice * (float)first;
    float nhi = last == SHRINK_SLICES - 1 ? hi[a] : lo[a] + slice * (float)(last + 1);
    if (a == 0) { cell->lo.x = nlo; cell->hi.x = nhi; }
    else if (a == 1) { cell->lo.y = nlo; cell->hi.y = nhi; }
    else { cell->lo.z = nlo; cell->hi.z = nhi; }
    return 1;
}
