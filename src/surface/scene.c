/* scene.c — the kd-tree over splats and its traversal for both surface
 * models (Wald & Seidel 2005 §3.2-3.4; Kashyap 2010 §3.3-3.6). See scene.h.
 *
 * States: CREATED (arrays copied) -> BUILT (kd-tree) -> PACKED (per-leaf
 * splat arrays) -> queryable; sg_scene_create runs all three or fails whole.
 *
 * Invariants:
 *  1. soa entries [leaf_first[l], leaf_first[l+1]) are the splats of leaf l,
 *     in the kd-tree's reference order;
 *  2. traversal visits leaves in increasing t, so the first accepted MLS
 *     crossing is the nearest; for disks the blend window may continue into
 *     later leaves and ends when the next leaf starts beyond it;
 *  3. queries never write to the scene (thread-safe).
 */
#include "surface/scene.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <omp.h>
#include <string.h>

#include "accel/kdtree.h"
#include "core/alloc.h"
#include "io/mesh.h"
#include "surface/disk.h"
#include "surface/hybrid.h"
#include "surface/hybrid_scene.h"
#include "surface/iso.h"
#include "surface/iso_sites.h"
#include "surface/layers.h"
#include "surface/mls.h"
#include "surface/scene_int.h"

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif
#if defined(__SSE4_1__)
#include <smmintrin.h>
#define SG_SCENE_TRAVERSE4 1 /* the quad traversal; else rays one by one */
#endif

enum { STACK_SIZE = 128 };


static sg_scene_desc with_defaults(const sg_scene_desc *d)
{
    sg_scene_desc r = d ? *d : (sg_scene_desc){0};
    if (r.samples_per_cell <= 0) r.samples_per_cell = 8;
    if (r.max_sample_spacing == 0.0f) r.max_sample_spacing = 0.5f;
    if (r.max_depth <= 0) r.max_depth = 48;
    if (r.blend_depth <= 0.0f) r.blend_depth = 0.5f;
    if (r.hybrid_lod == 0.0f) r.hybrid_lod = SG_HYBRID_LOD_DEFAULT;
    return r;
}

static void free_soa(sg_splat_soa *s)
{
    sg_free(s->px); sg_free(s->py); sg_free(s->pz);
    sg_free(s->nx); sg_free(s->ny); sg_free(s->nz);
    sg_free(s->key);
    sg_free(s->r); sg_free(s->inv_r); sg_free(s->id);
    memset(s, 0, sizeof *s);
}

static sg_status pack_leaves(sg_scene *sc, sg_error *err)
{
    size_t n = sc->tree.ref_count ? sc->tree.ref_count : 1;
    sg_splat_soa *s = &sc->soa;
    s->px = sg_alloc_array(n, sizeof(float)); s->py = sg_alloc_array(n, sizeof(float));
    s->pz = sg_alloc_array(n, sizeof(float)); s->nx = sg_alloc_array(n, sizeof(float));
    s->ny = sg_alloc_array(n, sizeof(float)); s->nz = sg_alloc_array(n, sizeof(float));
    s->r = sg_alloc_array(n, sizeof(float)); s->inv_r = sg_alloc_array(n, sizeof(float));
    s->id = sg_alloc_array(n, sizeof(uint32_t));
    if (!s->px || !s->py || !s->pz || !s->nx || !s->ny || !s->nz || !s->r || !s->inv_r || !s->id) {
        free_soa(s);
        return sg_error_set(err, SG_ERR_NOMEM, "scene: out of memory for %zu splat references", n);
    }
    const sg_pointset *p = &sc->points;
    for (size_t k = 0; k < sc->tree.ref_count; ++k) {
        uint32_t i = sc->tree.refs[k];
        s->px[k] = p->px[i]; s->py[k] = p->py[i]; s->pz[k] = p->pz[i];
        s->nx[k] = p->nx[i]; s->ny[k] = p->ny[i]; s->nz[k] = p->nz[i];
        s->r[k] = p->radius[i];
        s->inv_r[k] = 1.0f / p->radius[i];
        s->id[k] = i;
    }
    return SG_OK;
}

/* The leaf whose cell holds point x (descent by the split planes). */
static uint32_t leaf_at(const sg_kdtree *t, const float x[3])
{
    sg_kd_node n = t->nodes[0];
    while (!sg_kd_node_is_leaf(n)) {
        uint32_t child = sg_kd_node_index(n);
        n = t->nodes[x[sg_kd_node_axis(n)] < n.split ? child : child + 1];
    }
    return sg_kd_node_index(n);
}

/* Layer keys (MLS; mls.c "groups of splats"; the steps in layers.c). The
 * splats that may cover p_i are those of the kd-tree leaf holding p_i
 * (every splat whose support box holds it), in the leaf's reference order;
 * each splat's key goes to every reference of it. */
typedef struct leaf_cover {
    const sg_kdtree *t;
    const uint32_t *leaf; /* leaf holding p_i, per splat */
} leaf_cover;

static const uint32_t *kd_leaf_cover(const void *user, size_t i, size_t *count)
{
    const leaf_cover *c = user;
    uint32_t l = c->leaf[i];
    *count = c->t->leaf_first[l + 1] - c->t->leaf_first[l];
    return c->t->refs + c->t->leaf_first[l];
}

static sg_status layer_keys(sg_scene *sc, sg_error *err)
{
    const sg_pointset *p = &sc->points;
    const sg_kdtree *t = &sc->tree;
    sg_splat_soa *s = &sc->soa;
    size_t n = p->count, refs = t->ref_count ? t->ref_count : 1;
    uint32_t *leaf = sg_alloc_array(n, sizeof(uint32_t)), *key = sg_alloc_array(n, sizeof(uint32_t));
    s->key = sg_alloc_array(refs, sizeof(uint32_t));
    if (!leaf || !key || !s->key) {
        sg_free(leaf);
        sg_free(key);
        return sg_error_set(err, SG_ERR_NOMEM, "scene: out of memory for %zu layer keys", n);
    }
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
        const float x[3] = {p->px[i], p->py[i], p->pz[i]};
        leaf[i] = leaf_at(t, x);
    }
    leaf_cover cover = {t, leaf};
    size_t keyed_count = 0;
    sg_status st = sg_layer_keys(p, sc->desc.kernel, kd_leaf_cover, &cover, key, &keyed_count, err);
    if (st == SG_OK) {
#pragma omp parallel for schedule(static)
        for (size_t k = 0; k < t->ref_count; ++k)
            s->key[k] = key[s->id[k]];
        sc->info.keyed_count = keyed_count;
    }
    sg_free(leaf);
    sg_free(key);
    return st;
}

/* SG_SURFACE_ISO: the octree over the scene's own points, its corners as
 * the light sites, and the scene's info from the octree's. */
static sg_status create_iso(sg_scene *sc, sg_error *err)
{
    const sg_scene_desc *d = &sc->desc;
    sg_iso_desc id = {.kernel = d->kernel, .max_depth = d->iso_max_depth, .tolerance = d->iso_tolerance,
                      .threads = d->threads, .lod = d->iso_lod, .leaf_radii = d->iso_leaf_radii};
    sg_status st = sg_iso_create(&id, &sc->points, &sc->iso, err);
    if (st == SG_OK)
        st = sg_iso_sites_create(sc->iso, &sc->points, &sc->iso_sites, err);
    if (st != SG_OK)
        return st;
    sc->sites = sc->iso_sites.view;
    sg_iso_info ii;
    sg_iso_get_info(sc->iso, &ii);
    sg_scene_info *in = &sc->info;
    in->splat_count = sc->points.count;
    in->node_count = ii.node_count + ii.leaf_count;
    in->leaf_count = ii.leaf_count;
    in->depth = ii.depth;
    /* The splats' supports, as for the other models (the ISO's root cube
     * is larger). */
    sg_aabb b = sg_aabb_empty();
    const sg_pointset *p = &sc->points;
    for (size_t i = 0; i < p->count; ++i) {
        float r = p->radius[i];
        b = sg_aabb_union(b, (sg_aabb){{p->px[i] - r, p->py[i] - r, p->pz[i] - r},
                                       {p->px[i] + r, p->py[i] + r, p->pz[i] + r}});
    }
    in->bounds = b;
    in->diagonal = sg_aabb_diagonal(b);
    in->memory_bytes = sizeof *sc + ii.memory_bytes + sg_iso_sites_memory(&sc->iso_sites) +
                       p->count * 10 * sizeof(float);
    return SG_OK;
}

sg_status sg_scene_create(const sg_scene_desc *desc, const sg_pointset *points, sg_scene **out, sg_error *err)
{
    double t_start = omp_get_wtime();
    if (!points || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "scene: NULL points or out");
    if (points->count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "scene: the point set is empty");
    sg_status st = sg_pointset_validate(points, err);
    if (st != SG_OK)
        return st;
    sg_scene_desc d = with_defaults(desc);
    if (d.model == SG_SURFACE_HYBRID)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "scene: the hybrid surface needs a triangle mesh, not points (sg_scene_create_mesh)");
    if (d.model != SG_SURFACE_MLS && d.model != SG_SURFACE_DISK && d.model != SG_SURFACE_ISO)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "scene: unknown surface model %d", (int)d.model);
    if (d.kernel != SG_KERNEL_HAT && d.kernel != SG_KERNEL_GAUSSIAN)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "scene: unknown kernel %d", (int)d.kernel);

    sg_scene *sc = sg_calloc_array(1, sizeof *sc);
    float *box[6] = {0};
    if (!sc)
        return sg_error_set(err, SG_ERR_NOMEM, "scene: out of memory");
    sc->desc = d;
    if ((st = sg_pointset_append(&sc->points, points, err)) != SG_OK)
        goto fail;
    sc->sites = sg_sites_of_pointset(&sc->points);
    if (d.model == SG_SURFACE_ISO) {
        if ((st = create_iso(sc, err)) != SG_OK)
            goto fail;
        sc->info.build_seconds = omp_get_wtime() - t_start;
        *out = sc;
        return SG_OK;
    }
    size_t n = points->count;
    for (int k = 0; k < 6; ++k)
        if (!(box[k] = sg_alloc_array(n, sizeof(float)))) {
            st = sg_error_set(err, SG_ERR_NOMEM, "scene: out of memory for %zu splat boxes", n);
            goto fail;
        }
    const sg_pointset *p = &sc->points;
    for (size_t i = 0; i < n; ++i) {
        float r = p->radius[i];
        float e[3] = {r, r, r};
        if (d.model == SG_SURFACE_DISK) {
            /* A disk's extent along axis a is r * sqrt(1 - n_a^2); pad by a
             * hair so that a disk flat on a plane still has a box. */
            float nn[3] = {p->nx[i], p->ny[i], p->nz[i]};
            for (int a = 0; a < 3; ++a)
                e[a] = r * sqrtf(fmaxf(0.0f, 1.0f - nn[a] * nn[a])) + 1e-4f * r;
        }
        box[0][i] = p->px[i] - e[0]; box[3][i] = p->px[i] + e[0];
        box[1][i] = p->py[i] - e[1]; box[4][i] = p->py[i] + e[1];
        box[2][i] = p->pz[i] - e[2]; box[5][i] = p->pz[i] + e[2];
    }
    sg_mls_shrink_ctx shrink = {.points = p, .kernel = d.kernel};
    const int shrinks = d.model == SG_SURFACE_MLS && !(d.kd_disable & SG_KD_NO_SHRINK);
    sg_kdtree_desc kd = {
        .count = n,
        .lo = {box[0], box[1], box[2]},
        .hi = {box[3], box[4], box[5]},
        .max_depth = d.max_depth,
        /* E(n) lowers the cost of small cells because they will be
         * shrunk or culled later (§3.4.2); without shrinking (disks, or
         * SG_KD_NO_SHRINK) it only drives the build to the depth limit,
         * duplicating every splat ~100 times (measured), so it needs it. */
        .flags = (shrinks && !(d.kd_disable & SG_KD_NO_ENCOURAGE) ? SG_KD_BUILD_ENCOURAGE : 0u) |
                 (d.kd_disable & SG_KD_NO_COLLAPSE ? 0u : SG_KD_BUILD_COLLAPSE),
        .shrink = shrinks ? sg_mls_shrink_cell : NULL,
        .shrink_user = &shrink,
        /* SAH cost of one splat relative to one traversal step. An MLS
         * splat costs a gather plus a term in every sample; a disk test is
         * a handful of flops. Measured on the default scene (340k splats):
         * disks with 1.5 duplicated each splat 37 times (523 MiB, 2.5
         * Mrays/s), with 0.4 9 times (138 MiB, 2.9 Mrays/s); MLS is flat
         * between 1.5 and 6. */
        .cost_intersect = d.model == SG_SURFACE_DISK ? 0.4f : 1.5f,
    };
    int saved_threads = omp_get_max_threads();
    if (d.threads > 0)
        omp_set_num_threads(d.threads);
    st = sg_kdtree_build(&kd, &sc->tree, err);
    if (d.threads > 0)
        omp_set_num_threads(saved_threads);
    if (st != SG_OK)
        goto fail;
    if ((st = pack_leaves(sc, err)) != SG_OK)
        goto fail;
    if (d.model == SG_SURFACE_MLS && (st = layer_keys(sc, err)) != SG_OK)
        goto fail;
    for (int k = 0; k < 6; ++k)
        sg_free(box[k]);

    sc->mls = (sg_mls_params){.kernel = d.kernel, .samples = d.samples_per_cell,
                              .max_spacing = d.max_sample_spacing};
    sg_scene_info *in = &sc->info;
    in->splat_count = n;
    in->node_count = sc->tree.node_count;
    in->leaf_count = sc->tree.leaf_count;
    in->empty_leaf_count = sc->tree.empty_leaf_count;
    in->splat_refs = sc->tree.ref_count;
    in->depth = sc->tree.depth;
    in->bounds = sc->tree.bounds;
    in->diagonal = sg_aabb_diagonal(sc->tree.bounds);
    in->memory_bytes = sizeof *sc + sg_kdtree_memory(&sc->tree) + sc->tree.ref_count * 9 * sizeof(float) +
                       (sc->soa.key ? sc->tree.ref_count * sizeof(uint32_t) : 0) +
                       n * 10 * sizeof(float);
    in->build_seconds = omp_get_wtime() - t_start;
    *out = sc;
    return SG_OK;

fail:
    for (int k = 0; k < 6; ++k)
        sg_free(box[k]);
    sg_scene_destroy(sc);
    return st;
}

sg_status sg_scene_create_mesh(const sg_scene_desc *desc, const sg_mesh *mesh, const char *name, sg_scene **out,
                               sg_error *err)
{
    double t_start = omp_get_wtime();
    const char *label = name ? name : "mesh";
    if (!mesh || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "scene: NULL mesh or out");
    sg_scene_desc d = with_defaults(desc);
    if (d.model != SG_SURFACE_HYBRID)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: surface model %d does not take a mesh (sample it to "
                            "points first)", label, (int)d.model);
    if (!isfinite(d.hybrid_lod))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: hybrid lod %g is not finite", label,
                            (double)d.hybrid_lod);
    if (!isfinite(d.hybrid_site_spacing))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: hybrid site spacing %g is not finite", label,
                            (double)d.hybrid_site_spacing);
    sg_scene *sc = sg_calloc_array(1, sizeof *sc);
    if (!sc)
        return sg_error_set(err, SG_ERR_NOMEM, "scene: out of memory");
    sc->desc = d;
    sg_hybrid_desc hd = {.threads = d.threads, .name = label,
                         .site_spacing = d.hybrid_site_spacing > 0.0f ? d.hybrid_site_spacing : 0.0f};
    sg_status st = sg_hybrid_create(&hd, mesh, &sc->hybrid, err);
    if (st == SG_OK)
        st = sg_hybrid_sites_create(sc->hybrid, &sc->hybrid_sites, err);
    if (st != SG_OK) {
        sg_scene_destroy(sc);
        return st;
    }
    sc->sites = sc->hybrid_sites.view;
    sg_hybrid_info hi;
    sg_hybrid_get_info(sc->hybrid, &hi);
    sg_scene_info *in = &sc->info;
    in->splat_count = hi.vertex_count;
    in->node_count = hi.node_count;
    in->leaf_count = hi.leaf_count;
    in->depth = hi.depth;
    in->bounds = hi.bounds;
    in->diagonal = hi.diagonal;
    in->memory_bytes = sizeof *sc + hi.memory_bytes + sg_hybrid_sites_memory(&sc->hybrid_sites);
    in->build_seconds = omp_get_wtime() - t_start;
    *out = sc;
    return SG_OK;
}

void sg_scene_destroy(sg_scene *sc)
{
    if (!sc)
        return;
    sg_hybrid_sites_free(&sc->hybrid_sites);
    sg_hybrid_destroy(sc->hybrid);
    if (sc->borrowed) { /* the arrays belong to a world file's map */
        sg_iso_sites_free(&sc->iso_sites);
        sg_iso_destroy(sc->iso);
        sg_free(sc);
        return;
    }
    sg_pointset_free(&sc->points);
    sg_iso_sites_free(&sc->iso_sites);
    sg_iso_destroy(sc->iso);
    sg_kdtree_free(&sc->tree);
    free_soa(&sc->soa);
    sg_free(sc);
}

/* Adds splat reference i to the weights kept so far (the exact
 * arithmetic of the lookup: every caller gets the same bits). */
/* Keeps weight w > 0 of splat reference i among the largest max. */
static inline void hit_weights_keep(const sg_splat_soa *s, size_t i, float w, uint32_t *ids, float *weights, int max,
                                    int *n, float *total)
{
    *total += w;
    if (*n < max) {
        ids[*n] = s->id[i];
        weights[(*n)++] = w;
        return;
    }
    /* Full: replace the smallest weight kept. */
    int k = 0;
    for (int j = 1; j < *n; ++j)
        if (weights[j] < weights[k])
            k = j;
    if (w > weights[k]) {
        ids[k] = s->id[i];
        weights[k] = w;
    }
}

/* Adds splat reference i to the weights kept so far (the exact
 * arithmetic of the lookup: every caller gets the same bits). */
static inline void hit_weights_add(const sg_scene *sc, const sg_hit *hit, size_t i, uint32_t *ids, float *weights,
                                   int max, int *n, float *total)
{
    const sg_splat_soa *s = &sc->soa;
    float dx = hit->p.x - s->px[i], dy = hit->p.y - s->py[i], dz = hit->p.z - s->pz[i];
    float w = sg_mls_kernel(sc->desc.kernel, sqrtf(dx * dx + dy * dy + dz * dz) * s->inv_r[i]);
    if (w > 0.0f)
        hit_weights_keep(s, i, w, ids, weights, max, n, total);
}

/* A splat passes the pre-filter when (d / r)^2 < HIT_WEIGHTS_SLACK: the
 * kernel is zero from d / r >= 1 on (sg_mls_kernel), and the filter's
 * squared ratio (no sqrt, maybe fused) is within a few ulps of the exact
 * one, so 1e-4 of slack keeps every splat the exact test would keep. */
static const float HIT_WEIGHTS_SLACK = 1.0001f;

/* prefilter 0: the scalar reference, every splat of the leaf weighed. */
static int hit_weights(const sg_scene *sc, const sg_hit *hit, uint32_t *ids, float *weights, int max, int prefilter)
{
    if (max <= 0 || hit->splat == SG_INVALID_ID)
        return 0;
    int n = 0;
    float total = 0.0f;
    if (hit->leaf < sc->tree.leaf_count) {
        const sg_splat_soa *s = &sc->soa;
        size_t i = sc->tree.leaf_first[hit->leaf], end = sc->tree.leaf_first[hit->leaf + 1];
        /* Most of a leaf's splats do not reach the hit: find the ones that
         * may with a cheap test on 8 at a time (squared distances, no sqrt
         * or kernel), then weigh those exactly, in leaf order as before. */
#if defined(__AVX2__) && defined(__FMA__)
        const __m256 hx = _mm256_set1_ps(hit->p.x), hy = _mm256_set1_ps(hit->p.y), hz = _mm256_set1_ps(hit->p.z);
        const __m256 slack = _mm256_set1_ps(HIT_WEIGHTS_SLACK);
        for (; prefilter && i + 8 <= end; i += 8) {
            __m256 dx = _mm256_sub_ps(hx, _mm256_loadu_ps(s->px + i));
            __m256 dy = _mm256_sub_ps(hy, _mm256_loadu_ps(s->py + i));
            __m256 dz = _mm256_sub_ps(hz, _mm256_loadu_ps(s->pz + i));
            __m256 ir = _mm256_loadu_ps(s->inv_r + i);
            if (sc->desc.kernel == SG_KERNEL_HAT) {
                /* The exact weights 8 at a time: the scalar expression's
                 * operations in its order (no fused steps), so the same
                 * bits; w = 1 - s inside the support, else 0. */
                __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                          _mm256_mul_ps(dz, dz));
                __m256 sr = _mm256_mul_ps(_mm256_sqrt_ps(d2), ir);
                __m256 inside = _mm256_cmp_ps(sr, _mm256_set1_ps(1.0f), _CMP_LT_OQ);
                __m256 w = _mm256_and_ps(inside, _mm256_sub_ps(_mm256_set1_ps(1.0f), sr));
                unsigned bits = (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(w, _mm256_setzero_ps(), _CMP_GT_OQ));
                if (!bits)
                    continue;
                float wl[8];
                _mm256_storeu_ps(wl, w);
                while (bits) {
                    int l = __builtin_ctz(bits);
                    bits &= bits - 1;
                    hit_weights_keep(s, i + (size_t)l, wl[l], ids, weights, max, &n, &total);
                }
                continue;
            }
            __m256 d2 = _mm256_fmadd_ps(dx, dx, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dz, dz)));
            __m256 s2 = _mm256_mul_ps(_mm256_mul_ps(d2, ir), ir);
            unsigned bits = (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(s2, slack, _CMP_LT_OQ));
            while (bits) {
                int l = __builtin_ctz(bits);
                bits &= bits - 1;
                hit_weights_add(sc, hit, i + (size_t)l, ids, weights, max, &n, &total);
            }
        }
#endif
        for (; i < end; ++i) {
            float dx = hit->p.x - s->px[i], dy = hit->p.y - s->py[i], dz = hit->p.z - s->pz[i];
            if (!prefilter || (dx * dx + dy * dy + dz * dz) * s->inv_r[i] * s->inv_r[i] < HIT_WEIGHTS_SLACK)
                hit_weights_add(sc, hit, i, ids, weights, max, &n, &total);
        }
    }
    if (n == 0 || !(total > 0.0f)) {
        ids[0] = hit->splat;
        weights[0] = 1.0f;
        return 1;
    }
    float kept = 0.0f;
    for (int j = 0; j < n; ++j)
        kept += weights[j];
    for (int j = 0; j < n; ++j)
        weights[j] /= kept;
    return n;
}

int sg_scene_hit_sites(const sg_scene *sc, const sg_hit *hit, uint32_t *ids, float *weights, int max)
{
    if (sc->hybrid)
        return sg_hybrid_scene_hit_sites(sc->hybrid, &sc->hybrid_sites, hit, ids, weights, max);
    if (sc->iso)
        return sg_iso_hit_sites(sc->iso, &sc->iso_sites, hit, ids, weights, max);
    return hit_weights(sc, hit, ids, weights, max, 1);
}

int sg_scene_hit_sites_reference(const sg_scene *sc, const sg_hit *hit, uint32_t *ids, float *weights, int max)
{
    if (sc->hybrid)
        return sg_hybrid_scene_hit_sites(sc->hybrid, &sc->hybrid_sites, hit, ids, weights, max);
    if (sc->iso)
        return sg_iso_hit_sites(sc->iso, &sc->iso_sites, hit, ids, weights, max);
    return hit_weights(sc, hit, ids, weights, max, 0);
}

void sg_scene_filter_sites(const sg_scene *sc, float *values, size_t stride)
{
    if (sc->hybrid)
        sg_hybrid_sites_filter(sc->hybrid, &sc->hybrid_sites, values, stride);
    else if (sc->iso)
        sg_iso_sites_filter(sc->iso, &sc->iso_sites, values, stride);
}

const sg_pointset *sg_scene_points(const sg_scene *sc) { return &sc->points; }

const sg_sites *sg_scene_sites(const sg_scene *sc) { return &sc->sites; }

uint32_t sg_scene_hit_site(const sg_scene *sc, const sg_hit *hit)
{
    if (sc->iso)
        return sg_iso_hit_site(sc->iso, &sc->iso_sites, hit);
    return hit->splat;
}

sg_hit sg_scene_site_hit(const sg_scene *sc, uint32_t site)
{
    const sg_sites *s = &sc->sites;
    assert(site < s->count);
    uint32_t splat = sc->iso ? sc->iso_sites.splat[site] : site;
    return (sg_hit){.t = 0.0f, .p = sg_sites_position(s, site), .n = sg_sites_normal(s, site), .splat = splat,
                    .leaf = UINT32_MAX};
}

sg_vec3 sg_scene_hit_albedo(const sg_scene *sc, const sg_hit *hit)
{
    if (sc->hybrid)
        return sg_hybrid_scene_hit_albedo(sc->hybrid, &sc->hybrid_sites, hit);
    const sg_pointset *p = &sc->points;
    uint32_t i = hit->splat;
    return i < p->count ? sg_v3(p->ar[i], p->ag[i], p->ab[i]) : sg_v3(1.0f, 1.0f, 1.0f);
}

sg_vec3 sg_scene_hit_albedo_sites(const sg_scene *sc, const sg_hit *hit, const uint32_t *ids, const float *weights,
                                  int n)
{
    if (sc->hybrid)
        return sg_hybrid_scene_sites_albedo(sc->hybrid, &sc->hybrid_sites, ids, weights, n);
    return sg_scene_hit_albedo(sc, hit); /* a point's own colour: the sites are not read */
}

void sg_scene_get_info(const sg_scene *sc, sg_scene_info *info) { *info = sc->info; }

sg_ray sg_scene_spawn_ray(const sg_scene *sc, const sg_hit *h, sg_vec3 dir, float tmax)
{
    if (sc->hybrid)
        return sg_hybrid_scene_spawn_ray(sc->hybrid, &sc->hybrid_sites, h, dir, tmax);
    sg_ray r = {.org = h->p, .dir = dir, .tmin = 0.0f, .tmax = tmax};
    r.flags = sg_v3_dot(dir, h->n) >= 0.0f ? SG_RAY_FRONT_ONLY : SG_RAY_BACK_ONLY;
    if (h->splat < sc->points.count) {
        r.self_n = h->n;
        r.self_r = sc->points.radius[h->splat];
    }
    return r;
}

/* Slab test against the root cell; NaN-safe: a NaN from 0 * inf loses every
 * min/max because the comparisons are written so that NaN fails them. */
static int clip_root(const sg_aabb *b, const sg_ray *ray, const float inv[3], float *t0, float *t1)
{
    float lo = ray->tmin, hi = ray->tmax;
    const float o[3] = {ray->org.x, ray->org.y, ray->org.z};
    const float bl[3] = {b->lo.x, b->lo.y, b->lo.z}, bh[3] = {b->hi.x, b->hi.y, b->hi.z};
    for (int a = 0; a < 3; ++a) {
        float ta = (bl[a] - o[a]) * inv[a], tb = (bh[a] - o[a]) * inv[a];
        float tn = ta < tb ? ta : tb, tf = ta < tb ? tb : ta;
        if (tn > lo) lo = tn;
        if (tf < hi) hi = tf;
    }
    *t0 = lo;
    *t1 = hi;
    return lo <= hi;
}

/* Clips [*t0, *t1] to box b; 0 when nothing is left. An axis the ray runs
 * parallel to (inv = +-inf) only tests that the origin lies in the slab:
 * (b - o) * inf would be NaN when the origin sits on the face. */
static inline int clip_box(const sg_aabb *b, const float org[3], const float inv[3], float *t0, float *t1)
{
    const float bl[3] = {b->lo.x, b->lo.y, b->lo.z}, bh[3] = {b->hi.x, b->hi.y, b->hi.z};
    float lo = *t0, hi = *t1;
    for (int a = 0; a < 3; ++a) {
        if (isinf(inv[a])) {
            if (org[a] < bl[a] || org[a] > bh[a])
                return 0;
            continue;
        }
        float ta = (bl[a] - org[a]) * inv[a], tb = (bh[a] - org[a]) * inv[a];
        float tn = ta < tb ? ta : tb, tf = ta < tb ? tb : ta;
        if (tn > lo) lo = tn;
        if (tf < hi) hi = tf;
    }
    *t0 = lo;
    *t1 = hi;
    return lo <= hi;
}

typedef struct stack_entry {
    uint32_t node;
    float t0, t1;
} stack_entry;

enum query { QUERY_NEAREST, QUERY_ANY };

static int traverse(const sg_scene *sc, const sg_ray *ray, sg_hit *hit, sg_ray_stats *stats, enum query q)
{
    sg_ray_stats st = {.rays = 1};
    const float inv[3] = {1.0f / ray->dir.x, 1.0f / ray->dir.y, 1.0f / ray->dir.z};
    const float org[3] = {ray->org.x, ray->org.y, ray->org.z};
    const sg_kd_node *nodes = sc->tree.nodes;
    const uint32_t *leaf_first = sc->tree.leaf_first;
    const int disk = sc->desc.model == SG_SURFACE_DISK;
    sg_disk_blend blend;
    sg_disk_blend_init(&blend, sc->desc.blend_depth);
    sg_mls_carry carry = {0};
    uint32_t disk_leaf = 0;
    stack_entry stack[STACK_SIZE];
    int sp = 0, found = 0;
    float t0, t1;
    if (!clip_root(&sc->tree.bounds, ray, inv, &t0, &t1))
        goto done;
    uint32_t ni = 0;
    for (;;) {
        sg_kd_node n = nodes[ni];
        st.nodes++;
        while (!sg_kd_node_is_leaf(n)) {
            int a = sg_kd_node_axis(n);
            uint32_t child = sg_kd_node_index(n);
            float ts = (n.split - org[a]) * inv[a];
            int below = org[a] < n.split || (org[a] == n.split && inv[a] <= 0.0f);
            uint32_t first = below ? child : child + 1, second = below ? child + 1 : child;
            if (!(ts == ts) || ts > t1 || ts <= 0.0f) {
                ni = first;
            } else if (ts < t0) {
                ni = second;
            } else {
                assert(sp < STACK_SIZE);
                stack[sp++] = (stack_entry){second, ts, t1};
                ni = first;
                t1 = ts;
            }
            n = nodes[ni];
            st.nodes++;
        }
        uint32_t l = sg_kd_node_index(n);
        size_t lf = leaf_first[l], lc = leaf_first[l + 1] - lf;
        st.leaves++;
        float c0 = t0, c1 = t1;
        if (lc && !clip_box(&sc->tree.leaf_bounds[l], org, inv, &c0, &c1))
            lc = 0; /* the ray passes the leaf's empty part only */
        if (lc) {
            st.isects++;
            st.splats += lc;
            if (!disk) {
                sg_hit h;
                if (sg_mls_intersect_leaf(&sc->soa, lf, lc, &sc->mls, ray, c0, c1, &h, &carry)) {
                    h.leaf = l;
                    if (hit)
                        *hit = h;
                    found = 1;
                    goto done;
                }
            } else if (q == QUERY_ANY) {
                if (sg_disk_leaf_any(&sc->soa, lf, lc, ray, c0, c1)) {
                    found = 1;
                    goto done;
                }
            } else {
                int had = !isinf(blend.t_near);
                sg_disk_leaf(&sc->soa, lf, lc, ray, c0, c1, &blend);
                if (!had && !isinf(blend.t_near))
                    disk_leaf = l; /* the nearest disk's leaf */
                if (blend.t_end <= t1)
                    break;
            }
        }
        else
            carry.valid = 0; /* an empty leaf: the supports have a gap here */
        if (sp == 0)
            break;
        --sp;
        ni = stack[sp].node;
        t0 = stack[sp].t0;
        t1 = stack[sp].t1;
        if (disk && t0 > blend.t_end)
            break;
    }
    if (disk && q == QUERY_NEAREST) {
        sg_hit h;
        if (sg_disk_blend_finish(&blend, ray, &h)) {
            h.leaf = disk_leaf;
            if (hit)
                *hit = h;
            found = 1;
        }
    }
done:
    if (!found && hit)
        hit->splat = SG_INVALID_ID;
    st.hits = (uint64_t)found;
    if (stats)
        sg_ray_stats_add(stats, &st);
    return found;
}

/* The nearest hit, with the disks' side rule. A ray that accepts either
 * face (a camera ray) takes the nearest disk whichever way it faces, but a
 * disk overhanging a silhouette or a thin part's rim faces away from a ray
 * that never entered the model: the camera would see the model's inside
 * there (bench_leaks: 1.3% of the camera hits on Lucy, 143 in 32k paths).
 * So when the nearest disk faces away, the disks that face the ray and lie
 * within two radii of the hit point (in the leaves around it) are asked
 * where it lies:
 * in front of any of their planes, the point is outside the model, and the
 * ray is traced again accepting front faces only. (Within one radius
 * missed the rims where the nearest facing disks sit 1 to 2 radii away.) With none there (the inside of a
 * closed model seen from within, or through a gap in its near side) the
 * back face stands. MLS needs no such rule: its groups (mls.c) decide
 * the side along the ray. */
static int nearest(const sg_scene *sc, const sg_ray *ray, sg_hit *hit, sg_ray_stats *stats)
{
    int found = traverse(sc, ray, hit, stats, QUERY_NEAREST);
    if (!found || sc->desc.model != SG_SURFACE_DISK || (ray->flags & (SG_RAY_FRONT_ONLY | SG_RAY_BACK_ONLY)) ||
        !(sg_v3_dot(hit->n, ray->dir) > 0.0f) || hit->leaf >= sc->tree.leaf_count)
        return found;
    const sg_splat_soa *s = &sc->soa;
    /* Ask the disks in every leaf whose cell meets the box of half-side 2r
     * around the hit point (a disk flat in a plane is referenced only by
     * the leaves its thin box meets: those of a convex edge's other face
     * are often not the hit's leaf). Fixed-size stack, at most MAX_ASKED
     * leaves (a cap, never reached at scene scale). */
    enum { MAX_ASKED = 64 };
    float rr = hit->splat < sc->points.count ? 2.0f * sc->points.radius[hit->splat] : 0.0f;
    const float lo[3] = {hit->p.x - rr, hit->p.y - rr, hit->p.z - rr}, hi[3] = {hit->p.x + rr, hit->p.y + rr, hit->p.z + rr};
    uint32_t stack[STACK_SIZE];
    int sp = 0, asked = 0, outside = 0;
    stack[sp++] = 0;
    while (sp > 0 && !outside && asked < MAX_ASKED) {
        sg_kd_node n = sc->tree.nodes[stack[--sp]];
        if (!sg_kd_node_is_leaf(n)) {
            int a = sg_kd_node_axis(n);
            uint32_t child = sg_kd_node_index(n);
            if (lo[a] < n.split && sp < STACK_SIZE)
                stack[sp++] = child;
            if (hi[a] >= n.split && sp < STACK_SIZE)
                stack[sp++] = child + 1;
            continue;
        }
        uint32_t l = sg_kd_node_index(n);
        ++asked;
        for (size_t k = sc->tree.leaf_first[l]; k < sc->tree.leaf_first[l + 1] && !outside; ++k) {
            float ex = hit->p.x - s->px[k], ey = hit->p.y - s->py[k], ez = hit->p.z - s->pz[k];
            outside = s->nx[k] * ray->dir.x + s->ny[k] * ray->dir.y + s->nz[k] * ray->dir.z < 0.0f &&
                      ex * ex + ey * ey + ez * ez < 4.0f * s->r[k] * s->r[k] &&
                      ex * s->nx[k] + ey * s->ny[k] + ez * s->nz[k] > 0.0f;
        }
    }
    if (!outside)
        return found;
    /* The second traversal counts its steps, not as a ray or a hit. */
    sg_ray_stats extra = {0};
    sg_ray front = *ray;
    front.flags = SG_RAY_FRONT_ONLY;
    found = traverse(sc, &front, hit, &extra, QUERY_NEAREST);
    if (stats) {
        stats->hits -= 1u - (uint64_t)found; /* the first traversal counted the back face */
        extra.rays = extra.hits = 0;
        sg_ray_stats_add(stats, &extra);
    }
    return found;
}

/* ---- four rays at once (primary-ray quads) ---------------------------------
 *
 * traverse4 walks the tree once for up to four rays that share the origin
 * and the sign of each direction component, so that every inner node has
 * one near child for all of them. Each ray keeps its own interval, decides
 * at each node exactly as traverse() does (same arithmetic, same tests)
 * whether it needs the near child, the far one or both, and is carried
 * into a child only when it needs it: each ray meets the same leaves, in
 * the same order, with the same intervals and carries as when traced
 * alone, so the hits are the same bits. What the rays share is the node
 * and leaf fetches, the stack and the control flow. MLS only: the disk
 * blend window is per ray and ends traversal per ray (traverse()). */

#ifdef SG_SCENE_TRAVERSE4
typedef struct stack_entry4 {
    __m128 t0, t1;   /* interval per ray (lane r: ray r)  */
    uint32_t node;
    unsigned mask;   /* rays that need this subtree      */
} stack_entry4;

static unsigned traverse4(const sg_scene *sc, const sg_ray *rays, unsigned mask, sg_hit *hits, sg_ray_stats *stats)
{
    sg_ray_stats st = {0};
    float inv[4][3], t0a[4] = {0, 0, 0, 0}, t1a[4] = {0, 0, 0, 0};
    sg_mls_carry carry[4];
    unsigned found = 0;
    /* the shared origin from a ray of mask: the others may be unset */
    const sg_ray *r0 = &rays[__builtin_ctz(mask)];
    const float org[3] = {r0->org.x, r0->org.y, r0->org.z};
    const sg_kd_node *nodes = sc->tree.nodes;
    const uint32_t *leaf_first = sc->tree.leaf_first;
    for (int r = 0; r < 4; ++r) {
        inv[r][0] = inv[r][1] = inv[r][2] = 1.0f; /* lanes of rays outside mask: unused */
        if (!(mask >> r & 1u))
            continue;
        st.rays++;
        inv[r][0] = 1.0f / rays[r].dir.x;
        inv[r][1] = 1.0f / rays[r].dir.y;
        inv[r][2] = 1.0f / rays[r].dir.z;
        carry[r] = (sg_mls_carry){0};
        if (!clip_root(&sc->tree.bounds, &rays[r], inv[r], &t0a[r], &t1a[r]))
            mask &= ~(1u << r);
    }
    /* Per node, each ray's decision of traverse() in one lane: first only
     * when ts is NaN, beyond t1 or <= 0; second only when ts < t0; else
     * both, the near child's interval ending and the far one's starting
     * at ts. Same operations per lane as traverse() per ray. */
    const __m128 inv_v[3] = {_mm_setr_ps(inv[0][0], inv[1][0], inv[2][0], inv[3][0]),
                             _mm_setr_ps(inv[0][1], inv[1][1], inv[2][1], inv[3][1]),
                             _mm_setr_ps(inv[0][2], inv[1][2], inv[2][2], inv[3][2])};
    const __m128 zero = _mm_setzero_ps();
    __m128 t0 = _mm_loadu_ps(t0a), t1 = _mm_loadu_ps(t1a);
    stack_entry4 stack[STACK_SIZE];
    int sp = 0;
    uint32_t ni = 0;
    while (mask) {
        sg_kd_node n = nodes[ni];
        st.nodes += (uint64_t)__builtin_popcount(mask);
        while (!sg_kd_node_is_leaf(n)) {
            int a = sg_kd_node_axis(n);
            uint32_t child = sg_kd_node_index(n);
            int r0 = __builtin_ctz(mask);
            /* Shared origin and direction signs: one near side for all. */
            int below = org[a] < n.split || (org[a] == n.split && inv[r0][a] <= 0.0f);
            uint32_t first = below ? child : child + 1, second = below ? child + 1 : child;
            __m128 ts = _mm_mul_ps(_mm_set1_ps(n.split - org[a]), inv_v[a]);
            __m128 first_only = _mm_or_ps(_mm_cmpunord_ps(ts, ts),
                                          _mm_or_ps(_mm_cmpgt_ps(ts, t1), _mm_cmple_ps(ts, zero)));
            __m128 second_only = _mm_andnot_ps(first_only, _mm_cmplt_ps(ts, t0));
            unsigned fo = (unsigned)_mm_movemask_ps(first_only), so = (unsigned)_mm_movemask_ps(second_only);
            unsigned need_first = mask & ~so, need_second = mask & ~fo;
            if (!need_first) {
                ni = second; /* every ray needs the far side alone: intervals stay */
                mask = need_second;
            } else {
                if (need_second) {
                    __m128 both = _mm_andnot_ps(_mm_or_ps(first_only, second_only), _mm_cmpeq_ps(zero, zero));
                    assert(sp < STACK_SIZE);
                    stack_entry4 *e = &stack[sp++];
                    e->node = second;
                    e->mask = need_second;
                    e->t0 = _mm_blendv_ps(t0, ts, both);
                    e->t1 = t1;
                    t1 = _mm_blendv_ps(t1, ts, both);
                }
                ni = first;
                mask = need_first;
            }
            n = nodes[ni];
            st.nodes += (uint64_t)__builtin_popcount(mask);
        }
        uint32_t l = sg_kd_node_index(n);
        size_t lf = leaf_first[l], lc_leaf = leaf_first[l + 1] - lf;
        _mm_storeu_ps(t0a, t0);
        _mm_storeu_ps(t1a, t1);
        for (unsigned m = mask; m; m &= m - 1) {
            int r = __builtin_ctz(m);
            size_t lc = lc_leaf;
            st.leaves++;
            float c0 = t0a[r], c1 = t1a[r];
            if (lc && !clip_box(&sc->tree.leaf_bounds[l], org, inv[r], &c0, &c1))
                lc = 0;
            if (!lc) {
                carry[r].valid = 0;
                continue;
            }
            st.isects++;
            st.splats += lc;
            sg_hit h;
            if (sg_mls_intersect_leaf(&sc->soa, lf, lc, &sc->mls, &rays[r], c0, c1, &h, &carry[r])) {
                h.leaf = l;
                hits[r] = h;
                found |= 1u << r;
            }
        }
        /* Pop the next subtree some unfinished ray needs. */
        mask = 0;
        while (sp > 0 && !mask) {
            --sp;
            mask = stack[sp].mask & ~found;
            ni = stack[sp].node;
            t0 = stack[sp].t0;
            t1 = stack[sp].t1;
        }
    }
    st.hits = (uint64_t)__builtin_popcount(found);
    if (stats)
        sg_ray_stats_add(stats, &st);
    return found;
}


/* Whether the rays of mask can share traverse4: same origin bits, same
 * sign bit of each direction component. */
static int can_share(const sg_ray *rays, unsigned mask)
{
    int r0 = __builtin_ctz(mask);
    for (unsigned m = mask & (mask - 1); m; m &= m - 1) {
        int r = __builtin_ctz(m);
        if (memcmp(&rays[r].org, &rays[r0].org, sizeof rays[r0].org) != 0 ||
            signbit(rays[r].dir.x) != signbit(rays[r0].dir.x) || signbit(rays[r].dir.y) != signbit(rays[r0].dir.y) ||
            signbit(rays[r].dir.z) != signbit(rays[r0].dir.z))
            return 0;
    }
    return 1;
}

#endif

unsigned sg_scene_intersect4(const sg_scene *sc, const sg_ray rays[4], unsigned mask, sg_hit hits[4],
                             sg_ray_stats *stats)
{
    mask &= 15u;
    if (sc->iso)
        return sg_iso_intersect4(sc->iso, rays, mask, hits, stats);
    if (sc->hybrid) /* one walk for the four (sg_hybrid_intersect4) */
        return sg_hybrid_scene_intersect4(sc->hybrid, &sc->hybrid_sites, sc->desc.hybrid_lod, rays, mask, hits,
                                          stats);
    unsigned found = 0;
#ifdef SG_SCENE_TRAVERSE4
    if (mask && sc->desc.model == SG_SURFACE_MLS && can_share(rays, mask)) {
        found = traverse4(sc, rays, mask, hits, stats);
    } else
#endif
    {
        for (unsigned m = mask; m; m &= m - 1) {
            int r = __builtin_ctz(m);
            if (nearest(sc, &rays[r], &hits[r], stats))
                found |= 1u << r;
        }
    }
    for (unsigned m = mask & ~found; m; m &= m - 1)
        hits[__builtin_ctz(m)].splat = SG_INVALID_ID;
    return found;
}

unsigned sg_scene_intersect16(const sg_scene *sc, const sg_ray *rays, unsigned mask, sg_hit *hits,
                              sg_ray_stats *stats)
{
    mask &= 0xFFFFu;
    if (sc->hybrid) /* one walk for the sixteen (sg_hybrid_intersect16) */
        return sg_hybrid_scene_intersect16(sc->hybrid, &sc->hybrid_sites, sc->desc.hybrid_lod, rays, mask, hits,
                                           stats);
    if (sc->iso) /* one traversal per direction octant (sg_iso_intersect16) */
        return sg_iso_intersect16(sc->iso, rays, mask, hits, stats);
    /* The others in quads: each ray gets its own hit whatever the grouping. */
    unsigned found = 0;
    for (int q = 0; q < 16; q += 4)
        if (mask >> q & 15u)
            found |= sg_scene_intersect4(sc, rays + q, mask >> q & 15u, hits + q, stats) << q;
    return found;
}

int sg_scene_intersect(const sg_scene *sc, const sg_ray *ray, sg_hit *hit, sg_ray_stats *stats)
{
    if (sc->hybrid)
        return sg_hybrid_scene_intersect(sc->hybrid, &sc->hybrid_sites, sc->desc.hybrid_lod, ray, hit, stats);
    if (sc->iso)
        return sg_iso_intersect(sc->iso, ray, hit, stats);
    return nearest(sc, ray, hit, stats);
}

int sg_scene_occluded(const sg_scene *sc, const sg_ray *ray, sg_ray_stats *stats)
{
    if (sc->hybrid)
        return sg_hybrid_scene_occluded(sc->hybrid, sc->desc.hybrid_lod, ray, stats);
    if (sc->iso)
        return sg_iso_occluded(sc->iso, ray, stats);
    return traverse(sc, ray, NULL, stats, QUERY_ANY);
}
