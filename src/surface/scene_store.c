/* scene_store.c — a built scene as flat arrays and back. See scene_store.h.
 *
 * Invariants:
 *  1. one function, scalars(), walks the scalar fields in one order for
 *     both directions, so saving and loading cannot disagree on a slot;
 *  2. a scene from sg_scene_from_store has borrowed = 1 (so has its ISO or
 *     hybrid): its points, tree, soa, octree and sphere-tree arrays are the
 *     caller's, read-only; every derived pointer (sites, mls) is set as
 *     sg_scene_create (sg_scene_create_mesh) sets it;
 *  3. nothing read from the store reaches an assert or an index before the
 *     check that bounds it (checks run in the order the data is used).
 */
#include "surface/scene_store.h"

#include <assert.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "surface/hybrid_int.h"
#include "surface/iso_int.h"
#include "surface/scene_int.h"

static const sg_scene_array_spec SPECS[SG_SA_COUNT] = {
    [SG_SA_PX] = {"PX", SG_STORE_F32, 1},          [SG_SA_PY] = {"PY", SG_STORE_F32, 1},
    [SG_SA_PZ] = {"PZ", SG_STORE_F32, 1},          [SG_SA_NX] = {"NX", SG_STORE_F32, 1},
    [SG_SA_NY] = {"NY", SG_STORE_F32, 1},          [SG_SA_NZ] = {"NZ", SG_STORE_F32, 1},
    [SG_SA_RADIUS] = {"PR", SG_STORE_F32, 1},      [SG_SA_AR] = {"CR", SG_STORE_F32, 1},
    [SG_SA_AG] = {"CG", SG_STORE_F32, 1},          [SG_SA_AB] = {"CB", SG_STORE_F32, 1},
    [SG_SA_KD_NODES] = {"KN", SG_STORE_U32, 2},    [SG_SA_KD_LEAF_FIRST] = {"KF", SG_STORE_U32, 1},
    [SG_SA_KD_REFS] = {"KR", SG_STORE_U32, 1},     [SG_SA_KD_LEAF_BOUNDS] = {"KB", SG_STORE_F32, 6},
    [SG_SA_SOA_PX] = {"SX", SG_STORE_F32, 1},      [SG_SA_SOA_PY] = {"SY", SG_STORE_F32, 1},
    [SG_SA_SOA_PZ] = {"SZ", SG_STORE_F32, 1},      [SG_SA_SOA_NX] = {"SU", SG_STORE_F32, 1},
    [SG_SA_SOA_NY] = {"SV", SG_STORE_F32, 1},      [SG_SA_SOA_NZ] = {"SW", SG_STORE_F32, 1},
    [SG_SA_SOA_R] = {"SR", SG_STORE_F32, 1},       [SG_SA_SOA_INV_R] = {"SI", SG_STORE_F32, 1},
    [SG_SA_SOA_ID] = {"SD", SG_STORE_U32, 1},      [SG_SA_SOA_KEY] = {"SK", SG_STORE_U32, 1},
    [SG_SA_ISO_NODES] = {"ON", SG_STORE_U32, 9},   [SG_SA_ISO_LEAVES] = {"OL", SG_STORE_U32, 9},
    [SG_SA_ISO_CF] = {"OF", SG_STORE_U16, 1},      [SG_SA_ISO_CN] = {"OC", SG_STORE_U32, 1},
    [SG_SA_HY_BUNDLES] = {"YB", SG_STORE_U32, sizeof(sg_stree_bundle) / 4},
    [SG_SA_HY_NODE_COLOR] = {"YC", SG_STORE_F32, 3},
    [SG_SA_HY_TRI] = {"YT", SG_STORE_U32, 3},      [SG_SA_HY_TRI_ID] = {"YI", SG_STORE_U32, 1},
    [SG_SA_HY_POS] = {"YP", SG_STORE_F32, 3},      [SG_SA_HY_NORMAL] = {"YN", SG_STORE_U32, 1},
    [SG_SA_HY_COLOR] = {"YV", SG_STORE_F32, 3},    [SG_SA_HY_LATTICE] = {"YL", SG_STORE_U32, 2},
};

/* The stored structs are these many elements, with no padding the
 * checksums or the file would carry as garbage. */
_Static_assert(sizeof(sg_kd_node) == 8, "sg_kd_node: 2 x u32");
_Static_assert(sizeof(sg_aabb) == 24, "sg_aabb: 6 x f32");
_Static_assert(sizeof(iso_node) == 36, "iso_node: 9 x u32 (with its iso_lod)");
_Static_assert(sizeof(iso_lod) == 24, "iso_lod: 6 x u32");
_Static_assert(sizeof(iso_leaf) == 36, "iso_leaf: 9 x u32");
/* A bundle has padding after its int8 fields (216 of 256 bytes at width
 * 8): sphere_tree.c's bundle_clear zeroes it, so the file and the
 * checksums see zeros, never garbage. */
_Static_assert(sizeof(sg_stree_bundle) % 4 == 0, "sg_stree_bundle: whole u32 words");

const sg_scene_array_spec *sg_scene_array_spec_of(sg_scene_array_id id)
{
    assert((unsigned)id < SG_SA_COUNT);
    return &SPECS[id];
}

uint32_t sg_store_elem_size(sg_store_elem e) { return e == SG_STORE_U16 ? 2u : 4u; }

/* ---- scalars (invariant 1) ---------------------------------------------- */

typedef struct codec {
    uint64_t *slot; /* the store's scalars                  */
    int n;          /* next slot                            */
    int load;       /* 1: slots -> fields, 0: fields -> slots */
} codec;

static void c_u64(codec *c, uint64_t *v)
{
    assert(c->n < SG_SCENE_SCALARS);
    if (c->load)
        *v = c->slot[c->n];
    else
        c->slot[c->n] = *v;
    c->n++;
}
static void c_size(codec *c, size_t *v)
{
    uint64_t u = *v;
    c_u64(c, &u);
    *v = (size_t)u; /* a value past SIZE_MAX cannot match any array count */
}
static void c_int(codec *c, int *v)
{
    uint64_t u = (uint64_t)(int64_t)*v;
    c_u64(c, &u);
    *v = (int)(int64_t)u;
}
static void c_f32(codec *c, float *v)
{
    uint32_t b;
    memcpy(&b, v, 4);
    uint64_t u = b;
    c_u64(c, &u);
    b = (uint32_t)u;
    memcpy(v, &b, 4);
}
static void c_f64(codec *c, double *v)
{
    uint64_t u;
    memcpy(&u, v, 8);
    c_u64(c, &u);
    memcpy(v, &u, 8);
}
static void c_vec3(codec *c, sg_vec3 *v)
{
    c_f32(c, &v->x);
    c_f32(c, &v->y);
    c_f32(c, &v->z);
}
static void c_box(codec *c, sg_aabb *b)
{
    c_vec3(c, &b->lo);
    c_vec3(c, &b->hi);
}

/* Every scalar of the scene, of its ISO and of its hybrid hierarchy (the
 * two zeroed when the scene has none: their slots are always there, so
 * the hybrid's do not move with the surface). The enum fields go through
 * int, whatever their storage. 109 slots. */
static void scalars(codec *c, sg_scene *sc, sg_iso *iso, sg_hybrid *hy)
{
    sg_scene_desc *d = &sc->desc;
    int e = (int)d->model;
    c_int(c, &e);
    d->model = (sg_surface_model)e;
    e = (int)d->kernel;
    c_int(c, &e);
    d->kernel = (sg_kernel)e;
    uint64_t u = d->kd_disable;
    c_u64(c, &u);
    d->kd_disable = (uint32_t)u;
    c_int(c, &d->samples_per_cell);
    c_f32(c, &d->max_sample_spacing);
    c_int(c, &d->max_depth);
    c_f32(c, &d->blend_depth);
    c_int(c, &d->threads);
    c_f32(c, &d->iso_tolerance);
    c_int(c, &d->iso_max_depth);
    c_f32(c, &d->iso_leaf_radii);
    c_f32(c, &d->iso_lod); /* a query setting: a load takes the scene's */
    c_size(c, &sc->points.count);

    sg_kdtree *t = &sc->tree;
    c_size(c, &t->node_count);
    c_size(c, &t->leaf_count);
    c_size(c, &t->empty_leaf_count);
    c_size(c, &t->ref_count);
    c_box(c, &t->bounds);
    c_int(c, &t->depth);

    sg_scene_info *in = &sc->info;
    c_size(c, &in->splat_count);
    c_size(c, &in->node_count);
    c_size(c, &in->leaf_count);
    c_size(c, &in->empty_leaf_count);
    c_size(c, &in->splat_refs);
    c_size(c, &in->keyed_count);
    c_size(c, &in->memory_bytes);
    c_int(c, &in->depth);
    c_f64(c, &in->build_seconds);
    c_box(c, &in->bounds);
    c_f32(c, &in->diagonal);
    c_vec3(c, &iso->lo);
    c_f32(c, &iso->edge);
    c_f32(c, &iso->unit);
    c_int(c, &iso->max_depth);
    c_f32(c, &iso->f_scale);
    c_size(c, &iso->node_count);
    c_size(c, &iso->leaf_count);
    c_size(c, &iso->corner_count);
    sg_iso_info *ii = &iso->info;
    c_size(c, &ii->point_count);
    c_size(c, &ii->node_count);
    c_size(c, &ii->leaf_count);
    c_size(c, &ii->corner_count);
    c_size(c, &ii->memory_bytes);
    c_f64(c, &ii->bytes_per_leaf);
    c_f64(c, &ii->bytes_per_point);
    c_int(c, &ii->depth);
    c_f64(c, &ii->build_seconds);
    c_box(c, &ii->bounds);
    c_f32(c, &ii->f_scale);
    c_f32(c, &ii->r_min);
    c_f32(c, &ii->r_max);

    c_f32(c, &d->hybrid_lod); /* a query setting, as iso_lod */
    sg_hybrid_desc *hd = &hy->desc;
    u = hd->flags;
    c_u64(c, &u);
    hd->flags = (uint32_t)u;
    e = (int)hd->traversal;
    c_int(c, &e);
    hd->traversal = (sg_hybrid_traversal)e;
    c_int(c, &hd->leaf_max);
    c_int(c, &hd->threads);
    c_f32(c, &hd->site_spacing);
    c_size(c, &hy->vertex_count);
    c_f32(c, &hy->self_eps);
    sg_stree *st = &hy->tree;
    c_size(c, &st->bundle_count);
    c_size(c, &st->triangle_count);
    c_size(c, &st->node_count);
    c_size(c, &st->leaf_count);
    c_int(c, &st->depth);
    sg_hybrid_info *hi = &hy->info;
    c_size(c, &hi->input_triangles);
    c_size(c, &hi->triangle_count);
    c_size(c, &hi->degenerate_count);
    c_size(c, &hi->vertex_count);
    c_size(c, &hi->lattice_triangles);
    c_size(c, &hi->lattice_sites);
    c_size(c, &hi->memory_lattice);
    c_size(c, &hi->node_count);
    c_size(c, &hi->leaf_count);
    c_size(c, &hi->node_slots);
    c_int(c, &hi->width);
    c_int(c, &hi->leaf_max);
    c_int(c, &hi->depth);
    c_size(c, &hi->memory_bytes);
    c_size(c, &hi->memory_nodes);
    c_size(c, &hi->memory_triangles);
    c_size(c, &hi->memory_vertices);
    c_size(c, &hi->memory_normals);
    c_size(c, &hi->memory_colors);
    c_f64(c, &hi->bytes_per_triangle);
    c_f64(c, &hi->build_seconds);
    c_box(c, &hi->bounds);
    c_f32(c, &hi->diagonal);
}

/* ---- save ------------------------------------------------------------------ */

static void put(sg_scene_store *o, sg_scene_array_id id, const void *data, size_t items)
{
    o->data[id] = data;
    o->items[id] = items;
}

void sg_scene_store_of(const sg_scene *sc, sg_scene_store *out)
{
    assert(sc && out);
    memset(out, 0, sizeof *out);
    sg_scene copy = *sc; /* shallow: scalars() reads fields only when saving */
    sg_iso iso_copy;
    sg_hybrid hy_copy;
    memset(&iso_copy, 0, sizeof iso_copy);
    memset(&hy_copy, 0, sizeof hy_copy);
    if (sc->iso)
        iso_copy = *sc->iso;
    if (sc->hybrid)
        hy_copy = *sc->hybrid;
    /* The only value that differs between two builds of one scene: left
     * out, so a world file is a function of its scene (DESIGN.md
     * "Determinism"); a loaded scene says 0 s (it was not built). */
    copy.info.build_seconds = 0.0;
    iso_copy.info.build_seconds = 0.0;
    hy_copy.info.build_seconds = 0.0;
    codec c = {.slot = out->scalars};
    scalars(&c, &copy, &iso_copy, &hy_copy);
    assert(c.n <= SG_SCENE_SCALARS);

    if (sc->hybrid) { /* no point set, no kd-tree */
        const sg_hybrid *h = sc->hybrid;
        put(out, SG_SA_HY_BUNDLES, h->tree.bundles, h->tree.bundle_count);
        if (h->tree.colors)
            put(out, SG_SA_HY_NODE_COLOR, h->tree.colors, h->info.node_slots);
        put(out, SG_SA_HY_TRI, h->tri, h->info.triangle_count);
        put(out, SG_SA_HY_TRI_ID, h->tri_id, h->info.triangle_count);
        put(out, SG_SA_HY_POS, h->pos, h->vertex_count);
        if (h->vnormal)
            put(out, SG_SA_HY_NORMAL, h->vnormal, h->vertex_count);
        if (h->vcolor)
            put(out, SG_SA_HY_COLOR, h->vcolor, h->vertex_count);
        if (h->lattice)
            put(out, SG_SA_HY_LATTICE, h->lattice, h->info.triangle_count);
        return;
    }

    const sg_pointset *p = &sc->points;
    size_t n = p->count;
    put(out, SG_SA_PX, p->px, n), put(out, SG_SA_PY, p->py, n), put(out, SG_SA_PZ, p->pz, n);
    put(out, SG_SA_NX, p->nx, n), put(out, SG_SA_NY, p->ny, n), put(out, SG_SA_NZ, p->nz, n);
    put(out, SG_SA_RADIUS, p->radius, n);
    put(out, SG_SA_AR, p->ar, n), put(out, SG_SA_AG, p->ag, n), put(out, SG_SA_AB, p->ab, n);
    if (sc->iso) {
        const sg_iso *o = sc->iso;
        put(out, SG_SA_ISO_NODES, o->nodes, o->node_count);
        put(out, SG_SA_ISO_LEAVES, o->leaves, o->leaf_count);
        put(out, SG_SA_ISO_CF, o->cf, o->corner_count);
        put(out, SG_SA_ISO_CN, o->cn, o->corner_count);
        return;
    }
    const sg_kdtree *t = &sc->tree;
    put(out, SG_SA_KD_NODES, t->nodes, t->node_count);
    put(out, SG_SA_KD_LEAF_FIRST, t->leaf_first, t->leaf_count + 1);
    put(out, SG_SA_KD_REFS, t->refs, t->ref_count);
    put(out, SG_SA_KD_LEAF_BOUNDS, t->leaf_bounds, t->leaf_count);
    const sg_splat_soa *s = &sc->soa;
    size_t r = t->ref_count;
    put(out, SG_SA_SOA_PX, s->px, r), put(out, SG_SA_SOA_PY, s->py, r), put(out, SG_SA_SOA_PZ, s->pz, r);
    put(out, SG_SA_SOA_NX, s->nx, r), put(out, SG_SA_SOA_NY, s->ny, r), put(out, SG_SA_SOA_NZ, s->nz, r);
    put(out, SG_SA_SOA_R, s->r, r), put(out, SG_SA_SOA_INV_R, s->inv_r, r), put(out, SG_SA_SOA_ID, s->id, r);
    if (s->key)
        put(out, SG_SA_SOA_KEY, s->key, r);
}

/* ---- load: checks (invariant 3) ------------------------------------------ */

/* Array id must be present with exactly want items. */
static sg_status need(const sg_scene_store *in, sg_scene_array_id id, uint64_t want, const char *label,
                      sg_error *err)
{
    if (!in->data[id])
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: array %s is missing", label, SPECS[id].code);
    if (in->items[id] != want)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: array %s holds %" PRIu64 " items, expected %" PRIu64, label,
                            SPECS[id].code, in->items[id], want);
    assert((uintptr_t)in->data[id] % 64 == 0);
    return SG_OK;
}

static sg_status check_desc(const sg_scene *sc, const char *label, sg_error *err)
{
    const sg_scene_desc *d = &sc->desc;
    if (d->model != SG_SURFACE_MLS && d->model != SG_SURFACE_DISK && d->model != SG_SURFACE_ISO &&
        d->model != SG_SURFACE_HYBRID)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: unknown surface model %d", label, (int)d->model);
    if (d->kernel != SG_KERNEL_HAT && d->kernel != SG_KERNEL_GAUSSIAN)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: unknown kernel %d", label, (int)d->kernel);
    if (d->samples_per_cell <= 0 || d->max_depth <= 0 || !(d->blend_depth > 0.0f) ||
        !isfinite(d->max_sample_spacing) || !isfinite(d->blend_depth))
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: surface options out of range (samples %d, spacing %g, depth %d, blend %g)", label,
                            d->samples_per_cell, (double)d->max_sample_spacing, d->max_depth,
                            (double)d->blend_depth);
    if (d->model == SG_SURFACE_HYBRID) {
        if (sc->points.count != 0)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: %zu splats on a hybrid surface (expected none)", label,
                                sc->points.count);
        return SG_OK;
    }
    if (sc->points.count == 0 || sc->points.count > UINT32_MAX - 1)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: %zu splats (expected 1 .. 2^32 - 2)", label, sc->points.count);
    return SG_OK;
}

/* The same float bits (a NaN equals itself, -0 differs from 0). */
static int same_bits(float a, float b)
{
    uint32_t x, y;
    memcpy(&x, &a, 4);
    memcpy(&y, &b, 4);
    return x == y;
}

static int box_has_nan(const sg_aabb *b)
{
    return isnan(b->lo.x) || isnan(b->lo.y) || isnan(b->lo.z) || isnan(b->hi.x) || isnan(b->hi.y) || isnan(b->hi.z);
}

/* Nodes: children after their parent and each reached once (so the tree
 * is a tree and traversal ends), depth bounded by the traversal's stack. */
static sg_status check_kdtree(const sg_kdtree *t, size_t splats, const char *label, sg_error *err)
{
    if (t->node_count == 0 || t->node_count > UINT32_MAX / 4 || t->leaf_count > UINT32_MAX / 4 ||
        t->ref_count > UINT32_MAX || t->empty_leaf_count > t->leaf_count || t->depth < 0 ||
        t->depth > SG_SCENE_MAX_KD_DEPTH || box_has_nan(&t->bounds))
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: kd-tree header out of range (%zu nodes, %zu leaves, %zu refs, depth %d)", label,
                            t->node_count, t->leaf_count, t->ref_count, t->depth);
    uint8_t *depth = sg_calloc_array(t->node_count, 1);
    if (!depth)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory checking %zu kd-tree nodes", label, t->node_count);
    sg_status st = SG_OK;
    depth[0] = 1; /* reached; level = depth - 1 */
    for (size_t i = 0; i < t->node_count && st == SG_OK; ++i) {
        sg_kd_node nd = t->nodes[i];
        uint32_t k = sg_kd_node_index(nd);
        if (depth[i] == 0) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree node %zu: no parent reaches it", label, i);
        } else if (sg_kd_node_is_leaf(nd)) {
            if (k >= t->leaf_count)
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree node %zu: leaf %" PRIu32 " of %zu", label, i, k,
                                  t->leaf_count);
        } else if (k <= i || (size_t)k + 1 >= t->node_count) {
            st = sg_error_set(err, SG_ERR_CORRUPT,
                              "%s: kd-tree node %zu: children %" PRIu32 ", %" PRIu32
                              " are not after it within %zu nodes",
                              label, i, k, k + 1, t->node_count);
        } else if (isnan(nd.split)) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree node %zu: split plane is NaN", label, i);
        } else if (depth[k] || depth[k + 1]) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree node %" PRIu32 ": reached twice", label,
                              depth[k] ? k : k + 1);
        } else if (depth[i] > t->depth) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree node %zu: deeper than the tree's depth %d", label, i,
                              t->depth);
        } else {
            depth[k] = depth[k + 1] = (uint8_t)(depth[i] + 1);
        }
    }
    sg_free(depth);
    if (st != SG_OK)
        return st;
    if (t->leaf_first[0] != 0 || t->leaf_first[t->leaf_count] != t->ref_count)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree leaf offsets run %" PRIu32 "..%" PRIu32 ", expected 0..%zu",
                            label, t->leaf_first[0], t->leaf_first[t->leaf_count], t->ref_count);
    for (size_t l = 0; l < t->leaf_count; ++l) {
        if (t->leaf_first[l + 1] < t->leaf_first[l])
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree leaf %zu: offsets decrease (%" PRIu32 " after %" PRIu32 ")",
                                label, l, t->leaf_first[l + 1], t->leaf_first[l]);
        if (box_has_nan(&t->leaf_bounds[l]))
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree leaf %zu: its box holds NaN", label, l);
    }
    for (size_t k = 0; k < t->ref_count; ++k)
        if (t->refs[k] >= splats)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree reference %zu: splat %" PRIu32 " of %zu", label, k,
                                t->refs[k], splats);
    return SG_OK;
}

/* The per-leaf arrays are the gather of the point set by the references
 * (pack_leaves in scene.c), bit for bit. */
static sg_status check_soa(const sg_scene *sc, const char *label, sg_error *err)
{
    const sg_splat_soa *s = &sc->soa;
    const sg_pointset *p = &sc->points;
    for (size_t k = 0; k < sc->tree.ref_count; ++k) {
        uint32_t i = sc->tree.refs[k];
        if (s->id[k] != i || !same_bits(s->px[k], p->px[i]) || !same_bits(s->py[k], p->py[i]) ||
            !same_bits(s->pz[k], p->pz[i]) || !same_bits(s->nx[k], p->nx[i]) || !same_bits(s->ny[k], p->ny[i]) ||
            !same_bits(s->nz[k], p->nz[i]) || !same_bits(s->r[k], p->radius[i]) ||
            !same_bits(s->inv_r[k], 1.0f / p->radius[i]))
            return sg_error_set(err, SG_ERR_CORRUPT,
                                "%s: splat reference %zu: its leaf copy differs from splat %" PRIu32, label, k, i);
    }
    return SG_OK;
}

static sg_status check_iso(const sg_iso *o, size_t splats, const char *label, sg_error *err)
{
    if (o->max_depth < 2 || o->max_depth > ISO_MAX_DEPTH || !isfinite(o->lo.x) || !isfinite(o->lo.y) ||
        !isfinite(o->lo.z) || !(o->edge > 0.0f) || !isfinite(o->edge) ||
        !same_bits(o->unit, o->edge / (float)(1u << o->max_depth)) || !isfinite(o->f_scale) || o->f_scale < 0.0f ||
        o->node_count > UINT32_MAX || o->leaf_count > UINT32_MAX || o->corner_count > UINT32_MAX ||
        o->leaf_count + o->node_count >= SG_INVALID_ID) /* LOD hits name leaf_count + node (iso.h) */
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: octree header out of range (max depth %d, edge %g, unit %g, f scale %g)", label,
                            o->max_depth, (double)o->edge, (double)o->unit, (double)o->f_scale);
    uint8_t *level = sg_calloc_array(o->node_count ? o->node_count : 1, 1);
    if (!level)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory checking %zu octree nodes", label, o->node_count);
    sg_status st = SG_OK;
    if (o->node_count)
        level[0] = 1; /* reached; level = value - 1 */
    for (size_t i = 0; i < o->node_count && st == SG_OK; ++i) {
        const iso_node *N = &o->nodes[i];
        unsigned inner = (unsigned)__builtin_popcount((unsigned)(N->child_mask & ~N->leaf_mask) & 0xFFu);
        unsigned leaves = (unsigned)__builtin_popcount(N->leaf_mask);
        if (level[i] == 0)
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: octree node %zu: no parent reaches it", label, i);
        else if (N->pad != 0 || (N->leaf_mask & ~N->child_mask) || (N->pos_mask & N->child_mask))
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: octree node %zu: inconsistent masks (%02x %02x %02x %02x)",
                              label, i, N->child_mask, N->leaf_mask, N->pos_mask, N->pad);
        else if (inner && (N->inner_base <= i || (uint64_t)N->inner_base + inner > o->node_count))
            st = sg_error_set(err, SG_ERR_CORRUPT,
                              "%s: octree node %zu: inner children from %" PRIu32 " are not after it within %zu nodes",
                              label, i, N->inner_base, o->node_count);
        else if (leaves && (uint64_t)N->leaf_base + leaves > o->leaf_count)
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: octree node %zu: leaf children from %" PRIu32 " past %zu leaves",
                              label, i, N->leaf_base, o->leaf_count);
        else if ((inner || leaves) && level[i] > o->max_depth)
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: octree node %zu: children below max depth %d", label, i,
                              o->max_depth);
        else if (N->lod.pad != 0 || (N->lod.leaf != ISO_NO_LOD && N->lod.leaf >= o->leaf_count) ||
                 isnan(N->lod.d) || isnan(N->lod.s_lo) || isnan(N->lod.s_hi))
            st = sg_error_set(err, SG_ERR_CORRUPT,
                              "%s: octree node %zu: coarse patch out of range (leaf %" PRIu32 " of %zu, d %g, slab "
                              "%g..%g)",
                              label, i, N->lod.leaf, o->leaf_count, (double)N->lod.d, (double)N->lod.s_lo,
                              (double)N->lod.s_hi);
        for (unsigned k = 0; k < inner && st == SG_OK; ++k) {
            size_t c = N->inner_base + k;
            if (level[c])
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: octree node %zu: reached twice", label, c);
            level[c] = (uint8_t)(level[i] + 1);
        }
    }
    sg_free(level);
    if (st != SG_OK)
        return st;
    for (size_t l = 0; l < o->leaf_count; ++l) {
        const iso_leaf *L = &o->leaves[l];
        if (L->splat >= splats)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: octree leaf %zu: splat %" PRIu32 " of %zu", label, l, L->splat,
                                splats);
        for (int c = 0; c < 8; ++c)
            if (L->corner[c] >= o->corner_count)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: octree leaf %zu: corner %" PRIu32 " of %zu", label, l,
                                    L->corner[c], o->corner_count);
    }
    return SG_OK;
}

static sg_status check_colours(const sg_pointset *p, const char *label, sg_error *err)
{
    for (size_t i = 0; i < p->count; ++i)
        if (!isfinite(p->ar[i]) || !isfinite(p->ag[i]) || !isfinite(p->ab[i]))
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: splat %zu: colour is not finite", label, i);
    return SG_OK;
}

/* ---- load: the hybrid hierarchy --------------------------------------------- */

/* The hierarchy's scalars against each other and this build. */
static sg_status check_hybrid_header(const sg_hybrid *h, const char *label, sg_error *err)
{
    const sg_hybrid_info *in = &h->info;
    const sg_stree *t = &h->tree;
    if (in->width != SG_STREE_WIDTH)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: sphere tree of %d children per node; this build traces %d (SG_HYBRID_WIDTH)", label,
                            in->width, SG_STREE_WIDTH);
    if ((h->desc.flags & ~(uint32_t)(SG_HYBRID_CULL_BACKFACES | SG_HYBRID_FLAT_SHADING)) ||
        (h->desc.traversal != SG_HYBRID_TRAVERSE_STACK && h->desc.traversal != SG_HYBRID_TRAVERSE_HEAP) ||
        h->desc.leaf_max < 1 || h->desc.leaf_max > SG_STREE_MAX_LEAF || h->desc.leaf_max != in->leaf_max ||
        h->desc.threads < 0)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: hybrid options out of range (flags 0x%x, traversal %d, leaf max %d)",
                            label, h->desc.flags, (int)h->desc.traversal, h->desc.leaf_max);
    if (h->vertex_count == 0 || h->vertex_count >= SG_INVALID_ID || in->vertex_count != h->vertex_count ||
        t->triangle_count == 0 || t->triangle_count > SG_STREE_MAX_TRIANGLES ||
        in->triangle_count != t->triangle_count || in->input_triangles < in->triangle_count ||
        in->input_triangles > UINT32_MAX || in->degenerate_count != in->input_triangles - in->triangle_count)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: hybrid counts out of range (%zu vertices, %zu of %zu triangles traced, %zu degenerate)",
                            label, h->vertex_count, t->triangle_count, in->input_triangles, in->degenerate_count);
    if (t->bundle_count == 0 || t->bundle_count > SG_STREE_LEAF / SG_STREE_WIDTH ||
        in->node_slots != t->bundle_count * SG_STREE_WIDTH || in->node_count != t->node_count ||
        in->leaf_count != t->leaf_count || in->depth != t->depth || t->depth < 1 || t->depth > SG_STREE_MAX_DEPTH)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: sphere tree header out of range (%zu bundles, %zu node slots, %zu nodes, depth %d)",
                            label, t->bundle_count, in->node_slots, t->node_count, t->depth);
    if (!(h->self_eps > 0.0f) || !isfinite(h->self_eps) || !isfinite(in->diagonal) || box_has_nan(&in->bounds))
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: hybrid scalars not finite (self epsilon %g, diagonal %g)", label,
                            (double)h->self_eps, (double)in->diagonal);
    return SG_OK;
}

/* Every bundle: reached once from an earlier one within the depth limit,
 * lanes empty or finite with a child word in range; the counts of nodes,
 * leaves and the depth as stored. What the traversal indexes with. */
static sg_status check_stree(const sg_stree *t, const char *label, sg_error *err)
{
    uint8_t *level = sg_calloc_array(t->bundle_count, 1);
    if (!level)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory checking %zu sphere-tree bundles", label,
                            t->bundle_count);
    sg_status st = SG_OK;
    size_t nodes = 0, leaves = 0;
    int depth = 0;
    level[0] = 1; /* the root bundle; level = bundles from it */
    for (size_t b = 0; b < t->bundle_count && st == SG_OK; ++b) {
        const sg_stree_bundle *B = &t->bundles[b];
        if (level[b] == 0) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: sphere-tree bundle %zu: no inner node reaches it", label, b);
            break;
        }
        for (int l = 0; l < SG_STREE_WIDTH && st == SG_OK; ++l) {
            const size_t k = b * SG_STREE_WIDTH + (size_t)l;
            const uint32_t word = B->child[l];
            const float r = B->r[l];
            if (word == SG_STREE_EMPTY || (b == 0 && l > 0)) {
                /* an empty lane misses every sphere test only with NaN */
                if (word != SG_STREE_EMPTY || !isnan(r))
                    st = sg_error_set(err, SG_ERR_CORRUPT,
                                      "%s: sphere-tree node %zu: an empty lane with child 0x%08" PRIx32 " radius %g",
                                      label, k, word, (double)r);
                continue;
            }
            if (!(r > 0.0f) || !isfinite(r) || !isfinite(B->cx[l]) || !isfinite(B->cy[l]) || !isfinite(B->cz[l])) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: sphere-tree node %zu: sphere (%g %g %g) radius %g", label, k,
                                  (double)B->cx[l], (double)B->cy[l], (double)B->cz[l], (double)r);
                continue;
            }
            nodes++;
            if (sg_stree_is_leaf(word)) {
                uint64_t first = sg_stree_leaf_first(word), count = sg_stree_leaf_count(word);
                if (first + count > t->triangle_count)
                    st = sg_error_set(err, SG_ERR_CORRUPT,
                                      "%s: sphere-tree node %zu: leaf triangles %" PRIu64 "..%" PRIu64 " past %zu", label,
                                      k, first, first + count - 1, t->triangle_count);
                leaves++;
                depth = level[b] > depth ? level[b] : depth;
            } else if (word <= b || word >= t->bundle_count) {
                st = sg_error_set(err, SG_ERR_CORRUPT,
                                  "%s: sphere-tree node %zu: children bundle %" PRIu32 " is not after it within %zu "
                                  "bundles",
                                  label, k, word, t->bundle_count);
            } else if (level[word]) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: sphere-tree bundle %" PRIu32 ": reached twice", label,
                                  word);
            } else if (level[b] >= SG_STREE_MAX_DEPTH) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: sphere-tree node %zu: children deeper than %d bundles",
                                  label, k, SG_STREE_MAX_DEPTH);
            } else {
                level[word] = (uint8_t)(level[b] + 1);
            }
        }
    }
    sg_free(level);
    if (st != SG_OK)
        return st;
    if (nodes != t->node_count || leaves != t->leaf_count || depth != t->depth)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: sphere tree holds %zu nodes, %zu leaves, depth %d; its header says %zu, %zu, %d",
                            label, nodes, leaves, depth, t->node_count, t->leaf_count, t->depth);
    return SG_OK;
}

/* Floats all finite: "<label>: <what> <item> is not finite". */
static sg_status check_finite(const float *f, size_t items, size_t per, const char *what, const char *label,
                              sg_error *err)
{
    for (size_t i = 0; i < items * per; ++i)
        if (!isfinite(f[i]))
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: %s %zu is not finite", label, what, i / per);
    return SG_OK;
}

/* Triangles in leaf order: vertex ids in range, non-zero area in double
 * (hybrid_int.h invariant 1: a traced triangle has a normal), input
 * index in range. */
static sg_status check_triangles(const sg_hybrid *h, const char *label, sg_error *err)
{
    for (size_t i = 0; i < h->info.triangle_count; ++i) {
        const uint32_t *v = h->tri + 3 * i;
        if (v[0] >= h->vertex_count || v[1] >= h->vertex_count || v[2] >= h->vertex_count)
            return sg_error_set(err, SG_ERR_CORRUPT,
                                "%s: hybrid triangle %zu: vertices %" PRIu32 " %" PRIu32 " %" PRIu32 " of %zu", label, i,
                                v[0], v[1], v[2], h->vertex_count);
        if (h->tri_id[i] >= h->info.input_triangles)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: hybrid triangle %zu: input index %" PRIu32 " of %zu", label,
                                i, h->tri_id[i], h->info.input_triangles);
        const float *a = h->pos + 3 * (size_t)v[0], *b = h->pos + 3 * (size_t)v[1], *c = h->pos + 3 * (size_t)v[2];
        double e1[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
        double e2[3] = {(double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2]};
        if (e1[1] * e2[2] - e1[2] * e2[1] == 0.0 && e1[2] * e2[0] - e1[0] * e2[2] == 0.0 &&
            e1[0] * e2[1] - e1[1] * e2[0] == 0.0)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: hybrid triangle %zu: zero area", label, i);
    }
    return SG_OK;
}

/* Lattices (hybrid_int.h invariant 4): each a range of its own, in leaf
 * order, after the mesh's vertices and within vertex_count; their sizes
 * sum to the header's count. What a lookup indexes with. */
static sg_status check_lattice(const sg_hybrid *h, const char *label, sg_error *err)
{
    const sg_hybrid_info *in = &h->info;
    if (!h->lattice)
        return in->lattice_sites || in->lattice_triangles
                   ? sg_error_set(err, SG_ERR_CORRUPT, "%s: hybrid lattice counts without a lattice", label)
                   : SG_OK;
    if (in->lattice_sites >= h->vertex_count)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: %zu hybrid lattice sites of %zu vertices", label,
                            in->lattice_sites, h->vertex_count);
    uint64_t next = h->vertex_count - in->lattice_sites, with = 0;
    for (size_t i = 0; i < in->triangle_count; ++i) {
        const uint64_t first = h->lattice[2 * i], n = h->lattice[2 * i + 1];
        if (n == 0)
            continue;
        const uint64_t sites = (n + 1) * (n + 2) / 2;
        if (n > SG_HYBRID_LATTICE_MAX_N || first != next || first + sites > h->vertex_count)
            return sg_error_set(err, SG_ERR_CORRUPT,
                                "%s: hybrid triangle %zu: lattice of %" PRIu64 " rows at vertex %" PRIu64
                                " (expected at %" PRIu64 " of %zu)",
                                label, i, n, first, next, h->vertex_count);
        next += sites;
        with++;
    }
    if (next != h->vertex_count || with != in->lattice_triangles)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: hybrid lattices hold %" PRIu64 " sites on %" PRIu64 " triangles; the header says %zu "
                            "on %zu",
                            label, next - (h->vertex_count - in->lattice_sites), with, in->lattice_sites,
                            in->lattice_triangles);
    return SG_OK;
}

/* Optional array id: present with want items when `has`, absent when not. */
static sg_status need_if(const sg_scene_store *in, sg_scene_array_id id, int has, uint64_t want, const char *label,
                         sg_error *err)
{
    if (has)
        return need(in, id, want, label, err);
    if (in->data[id])
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: array %s on a hybrid surface that has none", label,
                            SPECS[id].code);
    return SG_OK;
}

/* sc->hybrid over in's arrays, checked; then its light sites (made, as
 * sg_scene_create_mesh makes them). */
static sg_status load_hybrid(const sg_scene_store *in, sg_scene *sc, const char *label, sg_error *err)
{
    sg_hybrid *h = sc->hybrid;
    sg_status st = check_hybrid_header(h, label, err);
    if (st != SG_OK)
        return st;
    const int colours = in->data[SG_SA_HY_COLOR] != NULL;
    const size_t nv = h->vertex_count, nt = h->tree.triangle_count;
    if ((st = need(in, SG_SA_HY_BUNDLES, h->tree.bundle_count, label, err)) != SG_OK ||
        (st = need_if(in, SG_SA_HY_NODE_COLOR, colours, h->info.node_slots, label, err)) != SG_OK ||
        (st = need(in, SG_SA_HY_TRI, nt, label, err)) != SG_OK ||
        (st = need(in, SG_SA_HY_TRI_ID, nt, label, err)) != SG_OK ||
        (st = need(in, SG_SA_HY_POS, nv, label, err)) != SG_OK ||
        (st = need_if(in, SG_SA_HY_NORMAL, !(h->desc.flags & SG_HYBRID_FLAT_SHADING), nv, label, err)) != SG_OK ||
        (st = need_if(in, SG_SA_HY_COLOR, colours, nv, label, err)) != SG_OK ||
        (st = need_if(in, SG_SA_HY_LATTICE, h->info.lattice_sites > 0, nt, label, err)) != SG_OK)
        return st;
    h->tree.bundles = (sg_stree_bundle *)in->data[SG_SA_HY_BUNDLES];
    h->tree.colors = (float *)in->data[SG_SA_HY_NODE_COLOR];
    h->tri = (uint32_t *)in->data[SG_SA_HY_TRI];
    h->tri_id = (uint32_t *)in->data[SG_SA_HY_TRI_ID];
    h->pos = (float *)in->data[SG_SA_HY_POS];
    h->vnormal = (uint32_t *)in->data[SG_SA_HY_NORMAL]; /* any word decodes to a unit vector (oct.h) */
    h->vcolor = (float *)in->data[SG_SA_HY_COLOR];
    h->lattice = (uint32_t *)in->data[SG_SA_HY_LATTICE];
    if ((st = check_finite(h->pos, nv, 3, "hybrid vertex", label, err)) != SG_OK ||
        (colours && (st = check_finite(h->vcolor, nv, 3, "hybrid vertex colour", label, err)) != SG_OK) ||
        (colours &&
         (st = check_finite(h->tree.colors, h->info.node_slots, 3, "sphere-tree node colour", label, err)) !=
             SG_OK) ||
        (st = check_stree(&h->tree, label, err)) != SG_OK || (st = check_triangles(h, label, err)) != SG_OK ||
        (st = check_lattice(h, label, err)) != SG_OK)
        return st;
    float lod = sc->desc.hybrid_lod;
    if (!isfinite(lod))
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: hybrid level of detail %g is not finite", label, (double)lod);
    if ((st = sg_hybrid_sites_create(h, &sc->hybrid_sites, err)) != SG_OK) {
        if (st == SG_ERR_NOMEM)
            return st;
        char why[SG_ERROR_MESSAGE_MAX];
        snprintf(why, sizeof why, "%s", err ? err->message : "");
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: %s", label, why);
    }
    sc->sites = sc->hybrid_sites.view;
    return SG_OK;
}

/* ---- load ------------------------------------------------------------------ */

sg_status sg_scene_from_store(const sg_scene_store *in, const char *label, const sg_scene_desc *query,
                              sg_scene **out, sg_error *err)
{
    assert(in && label && out);
    sg_status st = SG_OK;
    sg_scene *sc = sg_calloc_array(1, sizeof *sc);
    sg_iso *iso = sg_calloc_array(1, sizeof *iso);
    sg_hybrid *hy = sg_calloc_array(1, sizeof *hy);
    if (!sc || !iso || !hy) {
        sg_free(sc);
        sg_free(iso);
        sg_free(hy);
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", label);
    }
    sc->borrowed = 1; /* invariant 2: from here on destroy frees no array */
    iso->borrowed = 1;
    hy->borrowed = 1;
    codec c = {.slot = (uint64_t *)in->scalars, .load = 1};
    scalars(&c, sc, iso, hy);
    if (sc->desc.model == SG_SURFACE_ISO)
        sc->iso = iso;
    else
        sg_free(iso);
    iso = NULL;
    if (sc->desc.model == SG_SURFACE_HYBRID)
        sc->hybrid = hy;
    else
        sg_free(hy);
    hy = NULL;
    if (query) {
        sc->desc.iso_lod = query->iso_lod;
        /* with the default filled in as sg_scene_create* does for every
         * model, so a saved world stays a function of its scene */
        sc->desc.hybrid_lod = query->hybrid_lod == 0.0f ? SG_HYBRID_LOD_DEFAULT : query->hybrid_lod;
    }
    if ((st = check_desc(sc, label, err)) != SG_OK)
        goto fail;
    if (sc->hybrid) {
        if ((st = load_hybrid(in, sc, label, err)) != SG_OK)
            goto fail;
        *out = sc;
        return SG_OK;
    }

    size_t n = sc->points.count;
    for (int a = SG_SA_PX; a <= SG_SA_AB; ++a)
        if ((st = need(in, (sg_scene_array_id)a, n, label, err)) != SG_OK)
            goto fail;
    sg_pointset *p = &sc->points;
    p->px = (float *)in->data[SG_SA_PX], p->py = (float *)in->data[SG_SA_PY], p->pz = (float *)in->data[SG_SA_PZ];
    p->nx = (float *)in->data[SG_SA_NX], p->ny = (float *)in->data[SG_SA_NY], p->nz = (float *)in->data[SG_SA_NZ];
    p->radius = (float *)in->data[SG_SA_RADIUS];
    p->ar = (float *)in->data[SG_SA_AR], p->ag = (float *)in->data[SG_SA_AG], p->ab = (float *)in->data[SG_SA_AB];
    if ((st = sg_pointset_validate(p, err)) != SG_OK) {
        char why[SG_ERROR_MESSAGE_MAX];
        snprintf(why, sizeof why, "%s", err->message);
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: %s", label, why);
        goto fail;
    }
    if ((st = check_colours(p, label, err)) != SG_OK)
        goto fail;
    sc->sites = sg_sites_of_pointset(p);

    if (sc->iso) {
        sg_iso *o = sc->iso;
        if ((st = need(in, SG_SA_ISO_NODES, o->node_count, label, err)) != SG_OK ||
            (st = need(in, SG_SA_ISO_LEAVES, o->leaf_count, label, err)) != SG_OK ||
            (st = need(in, SG_SA_ISO_CF, o->corner_count, label, err)) != SG_OK ||
            (st = need(in, SG_SA_ISO_CN, o->corner_count, label, err)) != SG_OK)
            goto fail;
        o->nodes = (iso_node *)in->data[SG_SA_ISO_NODES];
        o->leaves = (iso_leaf *)in->data[SG_SA_ISO_LEAVES];
        o->cf = (int16_t *)in->data[SG_SA_ISO_CF];
        o->cn = (uint32_t *)in->data[SG_SA_ISO_CN];
        if ((st = check_iso(o, n, label, err)) != SG_OK)
            goto fail;
        /* as sg_iso_create maps its desc's lod (iso.h): 0 the default,
         * negative off */
        float lod = sc->desc.iso_lod;
        if (!isfinite(lod)) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: level of detail %g is not finite", label, (double)lod);
            goto fail;
        }
        sg_iso_set_lod(o, lod == 0.0f ? SG_ISO_LOD_DEFAULT : lod < 0.0f ? 0.0f : lod);
        if ((st = sg_iso_sites_create(o, p, &sc->iso_sites, err)) != SG_OK)
            goto fail;
        sc->sites = sc->iso_sites.view;
        *out = sc;
        return SG_OK;
    }

    sg_kdtree *t = &sc->tree;
    if (t->leaf_count > UINT32_MAX / 4 || t->ref_count > UINT32_MAX) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: kd-tree of %zu leaves and %zu refs", label, t->leaf_count,
                          t->ref_count);
        goto fail;
    }
    if ((st = need(in, SG_SA_KD_NODES, t->node_count, label, err)) != SG_OK ||
        (st = need(in, SG_SA_KD_LEAF_FIRST, (uint64_t)t->leaf_count + 1, label, err)) != SG_OK ||
        (st = need(in, SG_SA_KD_REFS, t->ref_count, label, err)) != SG_OK ||
        (st = need(in, SG_SA_KD_LEAF_BOUNDS, t->leaf_count, label, err)) != SG_OK)
        goto fail;
    t->nodes = (sg_kd_node *)in->data[SG_SA_KD_NODES];
    t->leaf_first = (uint32_t *)in->data[SG_SA_KD_LEAF_FIRST];
    t->refs = (uint32_t *)in->data[SG_SA_KD_REFS];
    t->leaf_bounds = (sg_aabb *)in->data[SG_SA_KD_LEAF_BOUNDS];
    if ((st = check_kdtree(t, n, label, err)) != SG_OK)
        goto fail;
    for (int a = SG_SA_SOA_PX; a <= SG_SA_SOA_ID; ++a)
        if ((st = need(in, (sg_scene_array_id)a, t->ref_count, label, err)) != SG_OK)
            goto fail;
    int keyed = sc->desc.model == SG_SURFACE_MLS;
    if (keyed && (st = need(in, SG_SA_SOA_KEY, t->ref_count, label, err)) != SG_OK)
        goto fail;
    if (!keyed && in->data[SG_SA_SOA_KEY]) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: layer keys on a disk surface", label);
        goto fail;
    }
    sg_splat_soa *s = &sc->soa;
    s->px = (float *)in->data[SG_SA_SOA_PX], s->py = (float *)in->data[SG_SA_SOA_PY];
    s->pz = (float *)in->data[SG_SA_SOA_PZ], s->nx = (float *)in->data[SG_SA_SOA_NX];
    s->ny = (float *)in->data[SG_SA_SOA_NY], s->nz = (float *)in->data[SG_SA_SOA_NZ];
    s->r = (float *)in->data[SG_SA_SOA_R], s->inv_r = (float *)in->data[SG_SA_SOA_INV_R];
    s->id = (uint32_t *)in->data[SG_SA_SOA_ID];
    s->key = keyed ? (uint32_t *)in->data[SG_SA_SOA_KEY] : NULL;
    if ((st = check_soa(sc, label, err)) != SG_OK)
        goto fail;
    /* as sg_scene_create sets it */
    sc->mls = (sg_mls_params){.kernel = sc->desc.kernel, .samples = sc->desc.samples_per_cell,
                              .max_spacing = sc->desc.max_sample_spacing};
    *out = sc;
    return SG_OK;

fail:
    sg_scene_destroy(sc);
    return st;
}
