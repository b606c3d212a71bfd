/* iso_build.c — building the Implicit Surface Octree (Kashyap 2010, §4.3,
 * §4.3.1, §4.4; rules a-c and the corner field in iso.h).
 *
 * The build is a recursion over cells, each with the list of splats whose
 * support ball touches its closed box (filtered from its parent's list).
 * Every point where f is evaluated lies on the box of the cell that asks,
 * so that list holds every splat of non-zero weight there; the lists keep
 * increasing splat order and sg_mls_field_indexed skips zero weights, so f
 * at a grid point is the same bits whichever cell computes it.
 *
 * Parallelism: the first TOP_LEVELS levels are split serially; each kept
 * cell at that level is a task that builds its subtree ("part") into its
 * own arrays (OpenMP dynamic schedule). The parts are then laid out
 * serially depth first from the root (Morton order): inner children of a node
 * contiguous, leaf children contiguous, corners numbered in order of first
 * use. Nothing in the result depends on which thread built what.
 *
 * Invariants:
 *  1. a stored leaf's 8 corners are valid and their f values change sign
 *     (min < 0 < max, or a zero beside a non-zero);
 *  2. a corner key (integer coordinates at max_depth) names one stored
 *     corner; leaves sharing a grid point share its index;
 *  3. nodes[0] is the root; every stored inner node has a child or a
 *     positive cell (child_mask | pos_mask non-zero), leaf_mask is a subset
 *     of child_mask and pos_mask is disjoint from it.
 */
#include <assert.h>
#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/alloc.h"
#include "core/key_slots.h"
#include "surface/iso_int.h"
#include "surface/layers.h"
#include "surface/mls.h"

enum { TOP_LEVELS = 3 }; /* serial split into up to 512 tasks */

/* The smallest leaf edge rules b and c may ask for, in units of
 * leaf_radii x r_min: two levels below rule a's bound. */
static const float FINE_EDGE = 0.25f;
/* ... and at a cell with a layered corner (corner_field): one level finer,
 * so that a sharp edge is cut off by at most 0.42 of a leaf of this size */
static const float EDGE_FINE_EDGE = 0.125f;

/* A cell whose corners all have one sign and |f| above this many of its
 * diagonals is dropped without the rule c test (f grows about as fast as
 * the distance to the surface; 1.5 leaves margin for curvature). */
static const float DROP_DIAGONALS = 1.5f;

#define REF_EMPTY 0xFFFFFFFFu
/* A cell without a surface whose corners are all valid and positive (in
 * front of the surface): not stored, but its bit in the parent's pos_mask
 * tells a ray accepting either face that it is outside (iso_int.h). */
#define REF_POSITIVE 0xFFFFFFFEu
#define REF_LEAF 0x80000000u

/* Slack of the ball-touches-box test: a splat whose kernel is non-zero at a
 * point of the box (|x - p|^2 / r^2 < 1 in float) must pass it. */
static const float TOUCH_SLACK = 1.0001f;

typedef struct build_ctx {
    const sg_pointset *ps;
    const uint32_t *key; /* layer keys per splat (layers.h); NULL: none keyed */
    sg_kernel kernel;
    int max_depth;
    float tol, leaf_radii;
    sg_vec3 lo;
    float unit;
} build_ctx;

/* A subdivided cell while its subtree is being built: its children's refs
 * (REF_EMPTY, REF_LEAF | leaf, or an inner node of the same part). */
typedef struct tnode {
    uint32_t child[8];
} tnode;

typedef struct tleaf {
    uint32_t corner[8]; /* slots in the part's point table */
    uint32_t splat;
} tleaf;

/* One task's subtree: its nodes, leaves, the points where f was evaluated
 * (a hash on their keys), and the stack of splat lists. */
typedef struct part {
    uint32_t ix, iy, iz;     /* the task cell (level TOP_LEVELS)         */
    size_t list_n;           /* its splats, at scratch[0..list_n)        */
    tnode *nodes; size_t nn, ncap;
    tleaf *leaves; size_t nl, lcap;
    uint64_t *pkey; float *pf; sg_vec3 *pn; uint8_t *pl; size_t np, pcap; /* evaluated points (pl: layered) */
    uint32_t *hash; size_t hcap; /* open addressing: slot + 1, 0 = empty   */
    uint32_t *scratch; size_t sn, scap;
    uint32_t root;           /* ref of the task cell                     */
    int depth;               /* deepest stored leaf                      */
    int nomem;
} part;

/* Grows an array of elements of `size` bytes to hold at least `need`. */
static int grow(void **p, size_t *cap, size_t need, size_t size)
{
    if (need <= *cap)
        return 1;
    size_t nc = *cap ? *cap : 64;
    while (nc < need)
        nc *= 2;
    if (!sg_realloc_array(p, *cap, nc, size))
        return 0;
    *cap = nc;
    return 1;
}

/* Squared distance from p to the box [a, b]. */
static inline float dist2_box(sg_vec3 p, sg_vec3 a, sg_vec3 b)
{
    /* ternaries: fmaxf is a library call under -std=c11 */
    float dx = a.x - p.x > p.x - b.x ? a.x - p.x : p.x - b.x;
    float dy = a.y - p.y > p.y - b.y ? a.y - p.y : p.y - b.y;
    float dz = a.z - p.z > p.z - b.z ? a.z - p.z : p.z - b.z;
    dx = dx > 0.0f ? dx : 0.0f;
    dy = dy > 0.0f ? dy : 0.0f;
    dz = dz > 0.0f ? dz : 0.0f;
    return dx * dx + dy * dy + dz * dz;
}

static inline int ball_touches(const sg_pointset *ps, uint32_t i, sg_vec3 a, sg_vec3 b)
{
    float r = ps->radius[i] * TOUCH_SLACK;
    return dist2_box(sg_pointset_position(ps, i), a, b) <= r * r;
}

/* The splat's disk thickened by SG_ISO_SLAB radii (a slab through the
 * ball) meets the box: the ball touches it and the box's extent along n
 * reaches the slab. Conservative (the ball and slab may meet the box in
 * different places), which only keeps a few more cells. */
static inline int disk_touches(const sg_pointset *ps, uint32_t i, sg_vec3 a, sg_vec3 b)
{
    if (!ball_touches(ps, i, a, b))
        return 0;
    sg_vec3 n = sg_pointset_normal(ps, i);
    sg_vec3 c = sg_v3_scale(sg_v3_add(a, b), 0.5f), e = sg_v3_scale(sg_v3_sub(b, a), 0.5f);
    float reach = e.x * fabsf(n.x) + e.y * fabsf(n.y) + e.z * fabsf(n.z);
    float d = sg_v3_dot(n, sg_v3_sub(c, sg_pointset_position(ps, i)));
    return fabsf(d) <= reach + SG_ISO_SLAB * ps->radius[i];
}

float sg_iso_field(const sg_pointset *ps, const uint32_t *idx, size_t count, sg_kernel kernel, sg_vec3 x,
                   sg_vec3 *n)
{
    float W;
    sg_vec3 N;
    float F = sg_mls_field_indexed(ps, idx, count, kernel, x, &W, &N);
    float ln = sg_v3_length(N);
    /* Opposed normals that cancel leave no plane to measure against. */
    if (!(W > 0.0f) || !(ln > 1e-6f * W)) {
        if (n)
            *n = sg_v3(0, 0, 0);
        return NAN;
    }
    if (n)
        *n = sg_v3_scale(N, 1.0f / ln);
    return F / (W * ln);
}

/* ---- layered corners -------------------------------------------------------
 *
 * The single field blends the normals of two faces that meet at a sharp
 * edge and cuts the edge off (a window's opening grows), cancels between
 * the two sides of a thin wall (holes) and bridges a narrow fold. Where
 * the splats covering a corner carry layer keys (layers.h) of two or more
 * layers (their keys more than acos(LAYER_EDGE_COS) = 60 degrees apart),
 * each layer's own plane distance f_L = (x - p̄_L) . n̄_L is taken over its
 * splats (a keyless splat joins the layer its normal is nearest) and the
 * layers are combined as solids:
 *  - convex pair (each layer's mean point lies behind the other's plane:
 *    a convex edge, the two sides of a thin wall): the solid is the
 *    intersection of the two half-spaces, f = max(f_A, f_B);
 *  - concave pair (each in front of the other: an inner corner, the two
 *    walls of a fold): their union, f = min(f_A, f_B), so the air between
 *    the walls stays positive;
 *  - three layers where one is paired alike with both others and those
 *    two the other way (a window's corner: the wall face convex with both
 *    reveals, the reveals concave to each other): f = max(f_X, min(f_Y,
 *    f_Z)), or the converse;
 *  - anything else (mixed pairs, more layers): the single field.
 * "Behind" and "in front" are judged with the tolerance of mls.c
 * past_back_layer (half its gap, BACK_LAYER_GAP = 0.05 smallest radii), and
 * the normal stored is the normal of the layer whose value won. A corner
 * without keyed splats, or with one layer, keeps the single field bit for
 * bit (smooth models are unchanged). Trilinear patches of such values keep
 * an edge sharp to within a leaf (a patch of max(f_A, f_B) cuts a
 * right-angled edge back by at most 0.42 of its edge, and never bulges
 * out: it interpolates a convex function from above), and rule c refines
 * there (the patch misses the kink of max or min at the test points) one
 * level further than elsewhere (EDGE_FINE_EDGE). */
enum { MAX_LAYERS = 4 };
static const float LAYER_EDGE_COS = 0.5f;
static const float LAYER_TOL = 0.025f; /* x r_min: half of mls.c BACK_LAYER_GAP */

typedef struct layer_acc {
    float ref[3];  /* the first key of the layer, as decoded              */
    float W;       /* sum of weights                                      */
    sg_vec3 P, N;  /* sum w (x - p), sum w n                              */
    float f;       /* plane distance (x - p̄) . n̄                          */
    sg_vec3 n;     /* unit normal                                         */
} layer_acc;

/* The layer whose key direction is nearest to v (largest cosine), and
 * that cosine. */
static int nearest_layer(const layer_acc *L, int nl, const float v[3], float *cos_out)
{
    float lv = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    int best = 0;
    float bc = -INFINITY;
    for (int a = 0; a < nl; ++a) {
        const float *r = L[a].ref;
        float lr = sqrtf(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
        float cs = (r[0] * v[0] + r[1] * v[1] + r[2] * v[2]) / (lr * lv);
        if (cs > bc) {
            bc = cs;
            best = a;
        }
    }
    *cos_out = bc;
    return best;
}

/* Pairing of layers a and b: +1 convex (each behind the other's plane),
 * -1 concave (each in front), 0 neither. */
static int pairing(const layer_acc *A, const layer_acc *B, float tol)
{
    /* mean points relative to x: p̄ - x = -P / W */
    sg_vec3 ma = sg_v3_scale(A->P, -1.0f / A->W), mb = sg_v3_scale(B->P, -1.0f / B->W);
    sg_vec3 ab = sg_v3_sub(ma, mb);
    float a_front = sg_v3_dot(ab, B->n), b_front = -sg_v3_dot(ab, A->n);
    if (a_front < tol && b_front < tol)
        return 1;
    if (a_front > tol && b_front > tol)
        return -1;
    return 0;
}

/* f at x over the splats idx[0..count) with layered corners (above); NAN
 * and a zero normal where the single field is invalid and no layers
 * apply. */
static float corner_field(const build_ctx *c, const uint32_t *idx, size_t count, sg_vec3 x, sg_vec3 *n,
                         uint8_t *layered)
{
    *layered = 0;
    if (!c->key)
        return sg_iso_field(c->ps, idx, count, c->kernel, x, n);
    const sg_pointset *ps = c->ps;
    layer_acc L[MAX_LAYERS];
    int nl = 0;
    float rmin = INFINITY;
    for (size_t k = 0; k < count; ++k) {
        uint32_t i = idx[k];
        if (!c->key[i])
            continue;
        float dx = x.x - ps->px[i], dy = x.y - ps->py[i], dz = x.z - ps->pz[i];
        float ir = 1.0f / ps->radius[i];
        if (!((dx * dx + dy * dy + dz * dz) * ir * ir < 1.0f))
            continue;
        float v[3], cs;
        sg_layer_key_decode(c->key[i], v);
        if (nl > 0 && (nearest_layer(L, nl, v, &cs), cs > LAYER_EDGE_COS))
            continue;
        if (nl == MAX_LAYERS)
            return sg_iso_field(ps, idx, count, c->kernel, x, n); /* too many: the single field */
        memset(&L[nl], 0, sizeof L[nl]);
        memcpy(L[nl].ref, v, sizeof v);
        ++nl;
    }
    if (nl < 2)
        return sg_iso_field(ps, idx, count, c->kernel, x, n);
    for (size_t k = 0; k < count; ++k) {
        uint32_t i = idx[k];
        float dx = x.x - ps->px[i], dy = x.y - ps->py[i], dz = x.z - ps->pz[i];
        float ir = 1.0f / ps->radius[i];
        float w = sg_mls_kernel(c->kernel, sqrtf(dx * dx + dy * dy + dz * dz) * ir);
        if (!(w > 0.0f))
            continue;
        float v[3], cs;
        if (c->key[i])
            sg_layer_key_decode(c->key[i], v);
        else
            v[0] = ps->nx[i], v[1] = ps->ny[i], v[2] = ps->nz[i];
        layer_acc *A = &L[nearest_layer(L, nl, v, &cs)];
        A->W += w;
        A->P = sg_v3_add(A->P, sg_v3(w * dx, w * dy, w * dz));
        A->N = sg_v3_add(A->N, sg_v3(w * ps->nx[i], w * ps->ny[i], w * ps->nz[i]));
        rmin = fminf(rmin, ps->radius[i]);
    }
    for (int a = 0; a < nl; ++a) {
        float ln = sg_v3_length(L[a].N);
        /* a layer without a plane (its normals cancel, or no weight): no
         * layered value here */
        if (!(L[a].W > 0.0f) || !(ln > 1e-6f * L[a].W))
            return sg_iso_field(ps, idx, count, c->kernel, x, n);
        L[a].n = sg_v3_scale(L[a].N, 1.0f / ln);
        L[a].f = sg_v3_dot(L[a].P, L[a].N) / (L[a].W * ln);
    }
    const float tol = LAYER_TOL * rmin;
    int rel[MAX_LAYERS][MAX_LAYERS], all = 0;
    for (int a = 0; a < nl; ++a)
        for (int b = a + 1; b < nl; ++b) {
            if (sg_v3_dot(L[a].n, L[b].n) >= LAYER_EDGE_COS) /* the fitted planes agree: no edge */
                return sg_iso_field(ps, idx, count, c->kernel, x, n);
            rel[a][b] = rel[b][a] = pairing(&L[a], &L[b], tol);
            if (!rel[a][b])
                return sg_iso_field(ps, idx, count, c->kernel, x, n);
            all += rel[a][b];
        }
    int pairs = nl * (nl - 1) / 2, win = 0;
    if (all == pairs || all == -pairs) {
        /* one kind throughout: max (intersection) or min (union) */
        for (int a = 1; a < nl; ++a)
            if (all > 0 ? L[a].f > L[win].f : L[a].f < L[win].f)
                win = a;
    } else if (nl == 3) {
        /* the odd one out: paired alike with both others, which are paired
         * the other way */
        int X = -1;
        for (int a = 0; a < 3 && X < 0; ++a) {
            int b = (a + 1) % 3, d = (a + 2) % 3;
            if (rel[a][b] == rel[a][d] && rel[b][d] == -rel[a][b])
                X = a;
        }
        if (X < 0)
            return sg_iso_field(ps, idx, count, c->kernel, x, n);
        int Y = (X + 1) % 3, Z = (X + 2) % 3;
        int outer_max = rel[X][Y] > 0;
        /* inner: the opposite operation over Y and Z */
        int inner = outer_max ? (L[Y].f < L[Z].f ? Y : Z) : (L[Y].f > L[Z].f ? Y : Z);
        win = outer_max ? (L[X].f > L[inner].f ? X : inner) : (L[X].f < L[inner].f ? X : inner);
    } else
        return sg_iso_field(ps, idx, count, c->kernel, x, n);
    *layered = 1;
    if (n)
        *n = L[win].n;
    return L[win].f;
}

static inline sg_vec3 grid_point(const build_ctx *c, uint32_t x, uint32_t y, uint32_t z)
{
    return sg_v3(iso_coord(c->lo.x, c->unit, x), iso_coord(c->lo.y, c->unit, y), iso_coord(c->lo.z, c->unit, z));
}

/* Slot of grid point (x, y, z) in the part's point table, evaluating f
 * there from the list scratch[off..off+n) the first time. UINT32_MAX when
 * out of memory. */
static uint32_t point_slot(const build_ctx *c, part *P, size_t off, size_t n, uint32_t x, uint32_t y, uint32_t z)
{
    uint64_t key = sg_key_grid3(x, y, z);
    if (!sg_key_slots_reserve(&P->hash, &P->hcap, P->pkey, P->np, 1024))
        return UINT32_MAX;
    size_t j;
    uint32_t found = sg_key_slots_find(P->hash, P->hcap, P->pkey, key, &j);
    if (found != UINT32_MAX)
        return found;
    size_t need = P->np + 1;
    size_t cap = P->pcap;
    if (need > cap) {
        size_t c1 = cap, c2 = cap, c3 = cap, c4 = cap;
        if (!grow((void **)&P->pkey, &c1, need, sizeof *P->pkey) || !grow((void **)&P->pf, &c2, need, sizeof *P->pf) ||
            !grow((void **)&P->pn, &c3, need, sizeof *P->pn) || !grow((void **)&P->pl, &c4, need, sizeof *P->pl))
            return UINT32_MAX;
        /* Keep the four capacities equal: each grew from cap the same way. */
        assert(c1 == c2 && c2 == c3 && c3 == c4);
        P->pcap = c1;
    }
    uint32_t s = (uint32_t)P->np++;
    P->pkey[s] = key;
    P->pf[s] = corner_field(c, P->scratch + off, n, grid_point(c, x, y, z), &P->pn[s], &P->pl[s]);
    P->hash[j] = s + 1;
    return s;
}

/* Trilinear patch of corner values v at the 27 points of the 3x3x3
 * lattice of the cell (a, b, c in {0, 1, 2} = low, middle, high). */
static inline float patch_at(const float v[8], int a, int b, int cz)
{
    float u = 0.5f * (float)a, w = 0.5f * (float)b, s = 0.5f * (float)cz;
    float x00 = v[0] + (v[1] - v[0]) * u, x10 = v[2] + (v[3] - v[2]) * u;
    float x01 = v[4] + (v[5] - v[4]) * u, x11 = v[6] + (v[7] - v[6]) * u;
    float y0 = x00 + (x10 - x00) * w, y1 = x01 + (x11 - x01) * w;
    return y0 + (y1 - y0) * s;
}

/* Appends an inner node with children kids; its ref (REF_EMPTY and
 * *nomem set when out of memory). */
static uint32_t push_node(tnode **nodes, size_t *nn, size_t *ncap, const uint32_t kids[8], int *nomem)
{
    if (!grow((void **)nodes, ncap, *nn + 1, sizeof **nodes)) {
        *nomem = 1;
        return REF_EMPTY;
    }
    memcpy((*nodes)[*nn].child, kids, 8 * sizeof *kids);
    return (uint32_t)(*nn)++;
}

/* Builds the cell at (x, y, z), level `level`, whose splat list is
 * scratch[off..off+n); returns its ref. */
static uint32_t build_cell(const build_ctx *c, part *P, uint32_t x, uint32_t y, uint32_t z, int level, size_t off,
                           size_t n)
{
    const sg_pointset *ps = c->ps;
    uint32_t size = 1u << (c->max_depth - level);
    sg_vec3 a = grid_point(c, x, y, z), b = grid_point(c, x + size, y + size, z + size);
    float r_min = INFINITY;
    for (size_t k = 0; k < n; ++k) {
        uint32_t i = P->scratch[off + k];
        if (ps->radius[i] < r_min && disk_touches(ps, i, a, b))
            r_min = ps->radius[i];
    }
    if (r_min == INFINITY)
        return REF_EMPTY; /* no splat's thick disk meets the cell */
    float edge = b.x - a.x;
    int can_split = level < c->max_depth;
    int split = can_split && edge > c->leaf_radii * r_min; /* rule a */
    uint32_t cs[8];
    float fv[8];
    if (!split) {
        int valid = 0;
        for (int k = 0; k < 8; ++k) {
            cs[k] = point_slot(c, P, off, n, x + (k & 1 ? size : 0), y + (k & 2 ? size : 0), z + (k & 4 ? size : 0));
            if (cs[k] == UINT32_MAX) {
                P->nomem = 1;
                return REF_EMPTY;
            }
            fv[k] = P->pf[cs[k]];
            valid += !isnan(fv[k]);
        }
        /* rules b and c refine at most FINE_LEVELS levels below rule a's
         * size: f has kinks (the kernels' support edges, opposed normals
         * cancelling) that no patch fits, which would otherwise be chased
         * down to max_depth */
        int layered = 0;
        for (int k = 0; k < 8; ++k)
            layered |= P->pl[cs[k]];
        int fine = can_split && edge > (layered ? EDGE_FINE_EDGE : FINE_EDGE) * c->leaf_radii * r_min;
        if (valid == 8) {
            /* f is close to a distance (|grad f| ~ 1 near the surface):
             * corners of one sign all farther than the cell's diagonal
             * from it leave no zero inside; drop the cell unexamined */
            float near = INFINITY, lo = fv[0], hi = fv[0];
            for (int k = 0; k < 8; ++k) {
                near = fminf(near, fabsf(fv[k]));
                lo = fminf(lo, fv[k]);
                hi = fmaxf(hi, fv[k]);
            }
            if ((lo > 0.0f || hi < 0.0f) && near > DROP_DIAGONALS * 1.7320508f * edge)
                return lo > 0.0f ? REF_POSITIVE : REF_EMPTY;
        }
        if (valid < 8) {
            /* rule b: follow the surface towards the supports' edge */
            split = fine && valid > 0;
        } else if (fine) {
            /* at a layered cell, rule c also splits where two corners'
             * normals are more than 60 degrees apart (from two layers): f
             * can be near-linear across the kink of max or min (a thin
             * wall's middle just inside the cell) and pass the test below,
             * while the corners beyond the kink carry the other layer's
             * normal and the trilinear normal turns over between them
             * (measured on the stability map's thin_wall: 32% of the
             * pixels flipped before this split) */
            for (int k = 0; k < 8 && layered && !split; ++k)
                for (int q = k + 1; q < 8 && !split; ++q)
                    split = sg_v3_dot(P->pn[cs[k]], P->pn[cs[q]]) < LAYER_EDGE_COS;
            /* rule c over the 19 lattice points that are not corners */
            for (int q = 0; q < 27 && !split; ++q) {
                int ga = q % 3, gb = (q / 3) % 3, gc = q / 9;
                if ((ga != 1) + (gb != 1) + (gc != 1) == 3)
                    continue; /* a corner */
                uint32_t s = point_slot(c, P, off, n, x + (uint32_t)ga * (size / 2), y + (uint32_t)gb * (size / 2),
                                        z + (uint32_t)gc * (size / 2));
                if (s == UINT32_MAX) {
                    P->nomem = 1;
                    return REF_EMPTY;
                }
                float e = fabsf(P->pf[s] - patch_at(fv, ga, gb, gc));
                if (!(e <= c->tol * r_min)) /* NaN (invalid point) splits too */
                    split = 1;
            }
        }
        if (!split) {
            if (valid < 8)
                return REF_EMPTY; /* an invalid corner: never intersected (iso.h) */
            float lo = fv[0], hi = fv[0];
            for (int k = 1; k < 8; ++k) {
                lo = fminf(lo, fv[k]);
                hi = fmaxf(hi, fv[k]);
            }
            if (!(lo <= 0.0f && hi >= 0.0f && (lo < 0.0f || hi > 0.0f)))
                return lo > 0.0f ? REF_POSITIVE : REF_EMPTY; /* no zero in the patch (invariant 1) */
            if (!grow((void **)&P->leaves, &P->lcap, P->nl + 1, sizeof *P->leaves)) {
                P->nomem = 1;
                return REF_EMPTY;
            }
            tleaf *L = &P->leaves[P->nl];
            memcpy(L->corner, cs, sizeof cs);
            /* the splat nearest the centre (first of equals: lists ascend) */
            sg_vec3 m = sg_v3_scale(sg_v3_add(a, b), 0.5f);
            float best = INFINITY;
            L->splat = P->scratch[off];
            for (size_t k = 0; k < n; ++k) {
                uint32_t i = P->scratch[off + k];
                sg_vec3 d = sg_v3_sub(sg_pointset_position(ps, i), m);
                float d2 = sg_v3_dot(d, d);
                if (d2 < best) {
                    best = d2;
                    L->splat = i;
                }
            }
            if (level > P->depth)
                P->depth = level;
            return REF_LEAF | (uint32_t)P->nl++;
        }
    }
    /* subdivide: each child's list is filtered onto the top of the stack */
    uint32_t kids[8];
    int any = 0, positive = 0;
    uint32_t hs = size / 2;
    for (int k = 0; k < 8; ++k) {
        uint32_t cx = x + (k & 1 ? hs : 0), cy = y + (k & 2 ? hs : 0), cz = z + (k & 4 ? hs : 0);
        sg_vec3 ca = grid_point(c, cx, cy, cz), cb = grid_point(c, cx + hs, cy + hs, cz + hs);
        size_t top = P->sn;
        if (!grow((void **)&P->scratch, &P->scap, top + n, sizeof *P->scratch)) {
            P->nomem = 1;
            return REF_EMPTY;
        }
        size_t m = 0;
        for (size_t q = 0; q < n; ++q) {
            uint32_t i = P->scratch[off + q];
            if (ball_touches(ps, i, ca, cb))
                P->scratch[top + m++] = i;
        }
        P->sn = top + m;
        kids[k] = m ? build_cell(c, P, cx, cy, cz, level + 1, top, m) : REF_EMPTY;
        P->sn = top;
        if (P->nomem)
            return REF_EMPTY;
        any |= kids[k] != REF_EMPTY && kids[k] != REF_POSITIVE;
        positive |= kids[k] == REF_POSITIVE;
    }
    /* A cell of positive and empty children only is outside as a whole
     * (the empty ones meet no splat's disk). */
    if (!any)
        return positive ? REF_POSITIVE : REF_EMPTY;
    return push_node(&P->nodes, &P->nn, &P->ncap, kids, &P->nomem);
}

static void part_free(part *P)
{
    sg_free(P->nodes);
    sg_free(P->leaves);
    sg_free(P->pkey);
    sg_free(P->pf);
    sg_free(P->pn);
    sg_free(P->pl);
    sg_free(P->hash);
    sg_free(P->scratch);
}

/* ---- the serial top levels ------------------------------------------------ */

/* The top TOP_LEVELS levels as a small tree: child refs are top nodes, or
 * TASK | part index. */
#define REF_TASK 0x40000000u

typedef struct top {
    tnode *nodes; size_t nn, ncap;
    part *parts; size_t np, pcap;
    int nomem;
} top;

static uint32_t split_top(const build_ctx *c, top *T, uint32_t x, uint32_t y, uint32_t z, int level,
                          const uint32_t *list, size_t n, int levels)
{
    uint32_t size = 1u << (c->max_depth - level);
    sg_vec3 a = grid_point(c, x, y, z), b = grid_point(c, x + size, y + size, z + size);
    int kept = 0;
    for (size_t k = 0; k < n && !kept; ++k)
        kept = disk_touches(c->ps, list[k], a, b);
    if (!kept)
        return REF_EMPTY;
    if (level == levels) {
        if (!grow((void **)&T->parts, &T->pcap, T->np + 1, sizeof *T->parts)) {
            T->nomem = 1;
            return REF_EMPTY;
        }
        part *P = &T->parts[T->np];
        memset(P, 0, sizeof *P);
        P->ix = x; P->iy = y; P->iz = z;
        if (!grow((void **)&P->scratch, &P->scap, n, sizeof *P->scratch)) {
            T->nomem = 1;
            return REF_EMPTY;
        }
        memcpy(P->scratch, list, n * sizeof *list);
        P->sn = P->list_n = n;
        return REF_TASK | (uint32_t)T->np++;
    }
    uint32_t *sub = sg_alloc_array(n, sizeof *sub);
    if (!sub) {
        T->nomem = 1;
        return REF_EMPTY;
    }
    uint32_t kids[8];
    int any = 0;
    uint32_t hs = size / 2;
    for (int k = 0; k < 8; ++k) {
        uint32_t cx = x + (k & 1 ? hs : 0), cy = y + (k & 2 ? hs : 0), cz = z + (k & 4 ? hs : 0);
        sg_vec3 ca = grid_point(c, cx, cy, cz), cb = grid_point(c, cx + hs, cy + hs, cz + hs);
        size_t m = 0;
        for (size_t q = 0; q < n; ++q)
            if (ball_touches(c->ps, list[q], ca, cb))
                sub[m++] = list[q];
        kids[k] = m ? split_top(c, T, cx, cy, cz, level + 1, sub, m, levels) : REF_EMPTY;
        if (T->nomem)
            break;
        any |= kids[k] != REF_EMPTY;
    }
    sg_free(sub);
    if (T->nomem || !any)
        return REF_EMPTY;
    return push_node(&T->nodes, &T->nn, &T->ncap, kids, &T->nomem);
}

/* ---- layout ---------------------------------------------------------------- */

/* A node of the merged tree before layout: which part (T->np = the top
 * tree) and its ref there. */
typedef struct gref {
    uint32_t part, ref;
} gref;

/* Resolves a child ref of node `from` to the merged tree (a top child
 * naming a task becomes that part's root). */
static gref resolve(const top *T, uint32_t from_part, uint32_t ref)
{
    gref g = {from_part, ref};
    if (from_part == T->np && ref != REF_EMPTY && (ref & REF_TASK) && !(ref & REF_LEAF)) {
        g.part = ref & ~REF_TASK;
        g.ref = T->parts[g.part].root;
    }
    return g;
}

/* Global corner table during layout: key -> index, hash of index + 1. */
typedef struct corners {
    uint64_t *key; float *f; sg_vec3 *n; size_t count, cap;
    uint32_t *hash; size_t hcap;
} corners;

static uint32_t corner_index(corners *C, uint64_t key, float f, sg_vec3 n)
{
    assert(C->hcap >= 2 * (C->count + 1));
    size_t j;
    uint32_t found = sg_key_slots_find(C->hash, C->hcap, C->key, key, &j);
    if (found != UINT32_MAX)
        return found;
    assert(C->count < C->cap);
    uint32_t s = (uint32_t)C->count++;
    C->key[s] = key;
    C->f[s] = f;
    C->n[s] = n;
    C->hash[j] = s + 1;
    return s;
}

/* Layout of the merged tree into iso (breadth-first; see the file note). */
static sg_status lay_out(sg_iso *iso, const top *T, uint32_t root, sg_error *err)
{
    size_t inner = T->nn, leaves = 0;
    for (size_t p = 0; p < T->np; ++p) {
        inner += T->parts[p].nn;
        leaves += T->parts[p].nl;
    }
    if (leaves >= UINT32_MAX / 2 || inner >= UINT32_MAX / 2)
        return sg_error_set(err, SG_ERR_NOMEM, "iso: %zu leaves and %zu nodes exceed 32-bit indices", leaves, inner);
    sg_status st = SG_OK;
    gref *queue = sg_alloc_array(inner ? inner : 1, sizeof *queue);
    uint32_t *todo = sg_alloc_array(inner ? inner : 1, sizeof *todo); /* depth-first: nodes to lay out */
    iso->nodes = sg_calloc_array(inner ? inner : 1, sizeof *iso->nodes);
    iso->leaves = sg_alloc_array(leaves ? leaves : 1, sizeof *iso->leaves);
    corners C = {0};
    size_t evaluated = 0;
    for (size_t p = 0; p < T->np; ++p)
        evaluated += T->parts[p].np;
    size_t ccap = (leaves * 8 < evaluated ? leaves * 8 : evaluated) + 1, hcap = 1024;
    while (hcap < 2 * ccap)
        hcap *= 2;
    /* corners: at most 8 per leaf, and at most the points evaluated */
    C.key = sg_alloc_array(ccap, sizeof *C.key);
    C.f = sg_alloc_array(ccap, sizeof *C.f);
    C.n = sg_alloc_array(ccap, sizeof *C.n);
    C.hash = sg_calloc_array(hcap, sizeof *C.hash);
    C.cap = ccap;
    C.hcap = hcap;
    if (!queue || !todo || !iso->nodes || !iso->leaves || !C.key || !C.f || !C.n || !C.hash) {
        st = sg_error_set(err, SG_ERR_NOMEM, "iso: out of memory laying out %zu leaves", leaves);
        goto done;
    }
    /* Depth first: a node's inner children get consecutive indices when
     * the node is laid out (queue[] holds each index's tree node) and are
     * laid out before its siblings' subtrees, so the leaves, and the
     * corners numbered by first use, follow the octree's Morton order:
     * neighbouring cells lie near each other in memory (measured:
     * breadth-first order cost a cache miss per leaf and corner). */
    size_t qn = 0, ln = 0, tn_todo = 0;
    if (root != REF_EMPTY) {
        assert(!(root & REF_LEAF)); /* the top levels always split */
        queue[qn++] = (gref){(uint32_t)T->np, root};
        todo[tn_todo++] = 0;
    }
    while (tn_todo > 0) {
        size_t q = todo[--tn_todo];
        gref g = queue[q];
        const tnode *tn = g.part == T->np ? &T->nodes[g.ref] : &T->parts[g.part].nodes[g.ref];
        iso_node *out = &iso->nodes[q];
        out->inner_base = (uint32_t)qn;
        out->leaf_base = (uint32_t)ln;
        for (int k = 0; k < 8; ++k) {
            gref ch = resolve(T, g.part, tn->child[k]);
            if (ch.ref == REF_EMPTY)
                continue;
            if (ch.ref == REF_POSITIVE) {
                out->pos_mask |= (uint8_t)(1u << k);
                continue;
            }
            out->child_mask |= (uint8_t)(1u << k);
            if (ch.ref & REF_LEAF) {
                const part *P = &T->parts[ch.part];
                const tleaf *tl = &P->leaves[ch.ref & ~REF_LEAF];
                iso_leaf *L = &iso->leaves[ln++];
                out->leaf_mask |= (uint8_t)(1u << k);
                L->splat = tl->splat;
                for (int v = 0; v < 8; ++v) {
                    uint32_t s = tl->corner[v];
                    L->corner[v] = corner_index(&C, P->pkey[s], P->pf[s], P->pn[s]);
                }
            } else {
                assert(qn < inner);
                queue[qn++] = ch;
            }
        }
        assert((out->child_mask | out->pos_mask) != 0); /* invariant 3 */
        for (size_t c = qn; c-- > out->inner_base;) /* first child on top */
            todo[tn_todo++] = (uint32_t)c;
    }
    iso->node_count = qn;
    iso->leaf_count = ln;
    iso->corner_count = C.count;
    /* quantise (iso.h): one global step for f */
    float fmax = 0.0f;
    for (size_t s = 0; s < C.count; ++s)
        fmax = fmaxf(fmax, fabsf(C.f[s]));
    iso->f_scale = fmax > 0.0f ? fmax / 32767.0f : 1.0f;
    iso->cf = sg_alloc_array(C.count ? C.count : 1, sizeof *iso->cf);
    iso->cn = sg_alloc_array(C.count ? C.count : 1, sizeof *iso->cn);
    if (!iso->cf || !iso->cn) {
        st = sg_error_set(err, SG_ERR_NOMEM, "iso: out of memory for %zu corners", C.count);
        goto done;
    }
    float inv = 1.0f / iso->f_scale;
    for (size_t s = 0; s < C.count; ++s) {
        float q = rintf(C.f[s] * inv);
        iso->cf[s] = (int16_t)fmaxf(-32767.0f, fminf(32767.0f, q));
        iso->cn[s] = sg_iso_encode_normal(C.n[s]);
    }
done:
    sg_free(queue);
    sg_free(todo);
    sg_free(C.key);
    sg_free(C.f);
    sg_free(C.n);
    sg_free(C.hash);
    return st;
}

/* ---- create ------------------------------------------------------------------ */

sg_status sg_iso_create(const sg_iso_desc *desc, const sg_pointset *ps, sg_iso **out, sg_error *err)
{
    if (!ps || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_iso_create: NULL %s", ps ? "out" : "points");
    sg_iso_desc d = desc ? *desc : (sg_iso_desc){0};
    if (d.max_depth == 0) d.max_depth = 16;
    if (d.tolerance == 0.0f) d.tolerance = 0.05f;
    if (d.leaf_radii == 0.0f) d.leaf_radii = 2.0f; /* iso.h */
    if (d.lod == 0.0f) d.lod = SG_ISO_LOD_DEFAULT;
    else if (d.lod < 0.0f) d.lod = 0.0f; /* off */
    if (d.max_depth < 2 || d.max_depth > ISO_MAX_DEPTH)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_iso_create: max_depth %d outside 2..%d", d.max_depth,
                            ISO_MAX_DEPTH);
    if (!isfinite(d.lod))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_iso_create: lod %g must be finite", (double)d.lod);
    if (!(d.tolerance > 0.0f) || !isfinite(d.tolerance) || !(d.leaf_radii > 0.0f) || !isfinite(d.leaf_radii))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_iso_create: tolerance %g and leaf_radii %g must be finite and > 0",
                            (double)d.tolerance, (double)d.leaf_radii);
    if (ps->count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_iso_create: the pointset is empty");
    if (ps->count >= UINT32_MAX - 1)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_iso_create: %zu splats exceed 32-bit ids", ps->count);
    sg_status st = sg_pointset_validate(ps, err);
    if (st != SG_OK)
        return st;
    double t_start = omp_get_wtime();
    int threads = d.threads > 0 ? d.threads : omp_get_max_threads();

    /* The root cube: the supports' box, made cubic, a hair larger so that
     * no support touches its boundary. */
    sg_aabb box = sg_aabb_empty();
    float r_min = INFINITY, r_max = 0.0f;
    for (size_t i = 0; i < ps->count; ++i) {
        float r = ps->radius[i];
        sg_vec3 p = sg_pointset_position(ps, i);
        box = sg_aabb_grow(box, sg_v3_sub(p, sg_v3(r, r, r)));
        box = sg_aabb_grow(box, sg_v3_add(p, sg_v3(r, r, r)));
        r_min = fminf(r_min, r);
        r_max = fmaxf(r_max, r);
    }
    sg_vec3 ext = sg_v3_sub(box.hi, box.lo);
    float edge = fmaxf(ext.x, fmaxf(ext.y, ext.z)) * 1.001f;
    sg_vec3 mid = sg_v3_scale(sg_v3_add(box.lo, box.hi), 0.5f);
    build_ctx c = {.ps = ps, .kernel = d.kernel, .max_depth = d.max_depth, .tol = d.tolerance,
                   .leaf_radii = d.leaf_radii, .lo = sg_v3_sub(mid, sg_v3(0.5f * edge, 0.5f * edge, 0.5f * edge)),
                   .unit = edge / (float)(1u << d.max_depth)};

    sg_iso *iso = sg_calloc_array(1, sizeof *iso);
    uint32_t *all = sg_alloc_array(ps->count, sizeof *all);
    uint32_t *key = sg_alloc_array(ps->count, sizeof *key);
    top T = {0};
    if (!iso || !all || !key) {
        st = sg_error_set(err, SG_ERR_NOMEM, "sg_iso_create: out of memory for %zu splats", ps->count);
        goto fail;
    }
    /* layer keys for the layered corners (corner_field); none keyed: the
     * paper's field everywhere */
    size_t keyed = 0;
    int saved_threads = omp_get_max_threads();
    omp_set_num_threads(threads);
    st = sg_layer_keys_grid(ps, d.kernel, key, &keyed, err);
    omp_set_num_threads(saved_threads);
    if (st != SG_OK)
        goto fail;
    if (keyed == 0) {
        sg_free(key);
        key = NULL;
    }
    c.key = key;
    iso->lo = c.lo;
    iso->edge = edge;
    iso->unit = c.unit;
    iso->max_depth = d.max_depth;
    for (size_t i = 0; i < ps->count; ++i)
        all[i] = (uint32_t)i;
    int levels = d.max_depth - 1 < TOP_LEVELS ? d.max_depth - 1 : TOP_LEVELS;
    uint32_t root = split_top(&c, &T, 0, 0, 0, 0, all, ps->count, levels);
    sg_free(all);
    all = NULL;
    if (T.nomem) {
        st = sg_error_set(err, SG_ERR_NOMEM, "sg_iso_create: out of memory splitting the top levels");
        goto fail;
    }
    int nomem = 0;
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) reduction(| : nomem)
    for (size_t p = 0; p < T.np; ++p) {
        part *P = &T.parts[p];
        P->root = build_cell(&c, P, P->ix, P->iy, P->iz, levels, 0, P->list_n);
        nomem |= P->nomem;
    }
    if (nomem) {
        st = sg_error_set(err, SG_ERR_NOMEM, "sg_iso_create: out of memory building the octree");
        goto fail;
    }
    st = lay_out(iso, &T, root, err);
    if (st != SG_OK)
        goto fail;
    iso_lod_build(iso);
    iso->lod_px = d.lod;
    int depth = 0;
    for (size_t p = 0; p < T.np; ++p)
        depth = T.parts[p].depth > depth ? T.parts[p].depth : depth;
    for (size_t p = 0; p < T.np; ++p)
        part_free(&T.parts[p]);
    sg_free(T.parts);
    sg_free(T.nodes);
    sg_free(key);

    sg_iso_info *in = &iso->info;
    in->point_count = ps->count;
    in->node_count = iso->node_count;
    in->leaf_count = iso->leaf_count;
    in->corner_count = iso->corner_count;
    in->memory_bytes = sizeof *iso + iso->node_count * sizeof(iso_node) +
                       iso->leaf_count * sizeof(iso_leaf) +
                       iso->corner_count * (sizeof(int16_t) + sizeof(uint32_t));
    in->bytes_per_leaf = iso->leaf_count ? (double)in->memory_bytes / (double)iso->leaf_count : 0.0;
    in->bytes_per_point = (double)in->memory_bytes / (double)ps->count;
    in->depth = depth;
    in->bounds = (sg_aabb){c.lo, sg_v3_add(c.lo, sg_v3(edge, edge, edge))};
    in->f_scale = iso->f_scale;
    in->r_min = r_min;
    in->r_max = r_max;
    in->build_seconds = omp_get_wtime() - t_start;
    *out = iso;
    return SG_OK;

fail:
    for (size_t p = 0; p < T.np; ++p)
        part_free(&T.parts[p]);
    sg_free(T.parts);
    sg_free(T.nodes);
    sg_free(all);
    sg_free(key);
    sg_iso_destroy(iso);
    return st;
}
