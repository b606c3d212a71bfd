/* world.c — models, materials and the envmap of a scene file. See world.h.
 *
 * Invariants:
 *  1. scenes[i] and materials[i] belong to scene-file model i;
 *  2. the nearest hit over models is found by shrinking the ray's tmax to
 *     the best hit so far, so each later model only reports nearer hits;
 *     models are visited in the order their boxes are entered, so the
 *     search stops at the first box that starts beyond the best hit.
 */
#include "render/world.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "math/v16.h"
#include "envmap/analytic.h"
#include "points/mesh_shapes.h"
#include "points/model_points.h"
#include "points/primitives.h"
#include "points/room.h"
#include "render/default_scene.h"
#include "render/world_int.h"


static sg_status load_model_points(const sg_scene_model *m, size_t index, sg_pointset *out,
                                   sg_model_points_report *report, sg_error *err)
{
    sg_status st;
    sg_model_points_desc md = m->points;
    md.report = report;
    switch (m->kind) {
    case SG_SCENE_MODEL_FILE:
        st = sg_model_points_load(m->path, &md, out, err);
        break;
    case SG_SCENE_MODEL_BUNNY: {
        char path[4096];
        snprintf(path, sizeof path, "%s/bunny.ply", SG_ASSET_DIR);
        st = sg_model_points_load(path, &md, out, err);
        break;
    }
    case SG_SCENE_MODEL_GROUND: {
        /* "points" asks for about that many: a jittered grid of
         * round(sqrt(points)) per side (at least 2); 0 = the default 300. */
        int side = 0;
        if (m->points.points > 0) {
            double r = floor(sqrt((double)m->points.points) + 0.5);
            side = r < 2.0 ? 2 : r > 20000.0 ? 20000 : (int)r;
        }
        sg_plane_points_desc d = {.side = side, .radius_k = m->points.radius_k,
                                  .radius_scale = m->points.radius_scale, .albedo = {1, 1, 1}};
        st = sg_points_make_plane(&d, out, err);
        break;
    }
    case SG_SCENE_MODEL_SPHERE: {
        sg_sphere_points_desc d = {.count = m->points.points, .radius_k = m->points.radius_k,
                                   .radius_scale = m->points.radius_scale, .albedo = {1, 1, 1}};
        st = sg_points_make_sphere(&d, out, err);
        break;
    }
    case SG_SCENE_MODEL_ROOM: {
        /* Sampled like any mesh: area-weighted, exact face normals. */
        sg_mesh mesh = {0};
        if ((st = sg_room_mesh(NULL, &mesh, err)) == SG_OK)
            st = sg_model_points_from_mesh(&mesh, "builtin room", &m->points, out, err);
        sg_mesh_free(&mesh);
        break;
    }
    default:
        st = sg_error_set(err, SG_ERR_INVALID_ARG, "$.models[%zu]: unknown model kind %d", index, (int)m->kind);
    }
    return st;
}

/* SG_SURFACE_HYBRID: the model as triangles. Files and the bunny as
 * read; the builtins with about `points` light sites, as many as splats:
 * "ground" a 30 x 30 square with sites side x side cells apart (side =
 * round(sqrt(points)), default 128), "sphere" the unit sphere with
 * rings = round(sqrt(points / 2)) bands (default 224: 100k triangles),
 * "room" as points/room.h builds it in cells of sqrt(162 m^2 / points)
 * (default 250k: 0.025). The ground and the room are 2 triangles a
 * rectangle whose light sites are lattices at their grid's spacing
 * (hybrid.h site_spacing; *spacing is set): a ray crosses a few
 * triangles, not a hierarchy of a grid's tens of thousands, and the light
 * has the grid's resolution (the ground's frame the same to 1e-7; the
 * room's bake within the spread of its sample sets, docs/hybrid.md). A
 * negative hybrid_site_spacing in the surface desc asks for the gridded
 * meshes of before (*spacing stays 0): the A/B of docs/hybrid.md. */
static sg_status load_model_mesh(const sg_scene_model *m, size_t index, sg_mesh *out, float *spacing, sg_error *err)
{
    const int gridded = m->surface.hybrid_site_spacing < 0.0f;
    const float own = m->surface.hybrid_site_spacing; /* > 0: the file's */
    *spacing = 0.0f;
    switch (m->kind) {
    case SG_SCENE_MODEL_FILE:
        return sg_mesh_read(m->path, out, err);
    case SG_SCENE_MODEL_BUNNY: {
        char path[4096];
        snprintf(path, sizeof path, "%s/bunny.ply", SG_ASSET_DIR);
        return sg_mesh_read(path, out, err);
    }
    case SG_SCENE_MODEL_GROUND: {
        int side = m->points.points > 0 ? (int)fmin(4096.0, fmax(1.0, floor(sqrt((double)m->points.points) + 0.5))) : 128;
        if (gridded)
            return sg_mesh_make_plane(side, 15.0f, out, err);
        *spacing = own > 0.0f ? own : (float)(30.0 / side); /* 30 / 128 = 0.234375 exactly */
        return sg_mesh_make_plane(1, 15.0f, out, err);
    }
    case SG_SCENE_MODEL_SPHERE: {
        int rings = m->points.points > 0 ? (int)fmin(4096.0, fmax(2.0, floor(sqrt(m->points.points / 2.0) + 0.5)))
                                         : 224;
        return sg_mesh_make_sphere(rings, 2 * rings, sg_v3(0, 0, 0), 1.0f, out, err);
    }
    case SG_SCENE_MODEL_ROOM: {
        /* about `points` vertices over the walls' ~162 m^2 (inside 72,
         * outside 90) */
        double n = m->points.points > 0 ? (double)m->points.points : 250000.0;
        const float cell = (float)fmax(0.005, sqrt(162.0 / n));
        if (gridded) {
            sg_room_desc rd = {.cell = cell};
            return sg_room_mesh(&rd, out, err);
        }
        *spacing = own > 0.0f ? own : cell;
        return sg_room_mesh(NULL, out, err); /* two triangles a rectangle */
    }
    default:
        return sg_error_set(err, SG_ERR_INVALID_ARG, "$.models[%zu]: unknown model kind %d", index, (int)m->kind);
    }
}

/* The largest factor by which t stretches a length: a builtin's site
 * spacing in the world (so a uniformly scaled ground keeps its lattice). */
static float scale_of(const sg_scene_transform *t)
{
    return fmaxf(t->scale.x, fmaxf(t->scale.y, t->scale.z));
}

static void transform_mesh(const sg_scene_transform *t, sg_mesh *mesh)
{
    for (size_t i = 0; i < mesh->vertex_count; ++i) {
        float *p = mesh->positions + 3 * i;
        sg_vec3 q = sg_scene_transform_point(t, sg_v3(p[0], p[1], p[2]));
        p[0] = q.x, p[1] = q.y, p[2] = q.z;
        if (mesh->normals) {
            float *n = mesh->normals + 3 * i;
            sg_vec3 r = sg_scene_transform_normal(t, sg_v3(n[0], n[1], n[2]));
            n[0] = r.x, n[1] = r.y, n[2] = r.z;
        }
    }
}

/* Model i's surface: the hybrid hierarchy over its triangles, or splats
 * under one of the point models. */
static sg_status make_model_scene(const sg_scene_file *sf, size_t i, const sg_world_desc *d, sg_scene **out,
                                  sg_error *err);

static void transform_points(const sg_scene_transform *t, sg_pointset *ps)
{
    for (size_t i = 0; i < ps->count; ++i) {
        sg_vec3 p = sg_scene_transform_point(t, sg_pointset_position(ps, i));
        sg_vec3 n = sg_scene_transform_normal(t, sg_pointset_normal(ps, i));
        ps->px[i] = p.x; ps->py[i] = p.y; ps->pz[i] = p.z;
        ps->nx[i] = n.x; ps->ny[i] = n.y; ps->nz[i] = n.z;
        ps->radius[i] = sg_scene_transform_radius(t, ps->radius[i]);
    }
}

sg_status sg_world__make_envmap(const sg_scene_env *e, sg_envmap **out, sg_error *err)
{
    sg_envmap_desc d = {.rotation_deg = e->rotation_deg, .intensity = e->intensity};
    sg_image img = {0};
    sg_status st = SG_OK;
    if (e->kind == SG_SCENE_ENV_FILE) {
        d.path = e->path;
    } else {
        sg_analytic_desc a = {.radiance = e->radiance};
        switch (e->kind) {
        case SG_SCENE_ENV_UNIFORM: a.type = SG_ANALYTIC_UNIFORM; a.width = 8; a.height = 4; break;
        case SG_SCENE_ENV_SKY: a.type = SG_ANALYTIC_SKY; break;
        case SG_SCENE_ENV_SUNSKY: a.type = SG_ANALYTIC_SUNSKY; break;
        case SG_SCENE_ENV_STUDIO: a.type = SG_ANALYTIC_STUDIO; break;
        default: return sg_error_set(err, SG_ERR_INVALID_ARG, "$.envmap: unknown kind %d", (int)e->kind);
        }
        if ((st = sg_analytic_make(&a, &img, err)) != SG_OK)
            return st;
        d.image = &img;
    }
    /* A zero intensity in the desc means 1; the scene file's 0 means dark. */
    if (e->intensity == 0.0f)
        d.intensity = 1e-30f;
    st = sg_envmap_create(&d, out, err);
    sg_image_free(&img);
    return st;
}

/* ---- progress and notes (sg_world_desc) --------------------------------- */

void sg_world__say(const sg_world_desc *d, sg_world_event kind, const char *fmt, ...)
{
    if (!d || !d->on_event)
        return;
    char msg[SG_ERROR_MESSAGE_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    d->on_event(d->user, kind, msg);
}

/* "scan.ply" for a file model, "builtin bunny" otherwise. */
static const char *model_label(const sg_scene_model *m)
{
    static const char *const builtin[] = {"", "builtin bunny", "builtin ground", "builtin sphere", "builtin room"};
    if (m->kind == SG_SCENE_MODEL_FILE && m->path) {
        const char *slash = strrchr(m->path, '/');
        return slash ? slash + 1 : m->path;
    }
    return (size_t)m->kind < sizeof builtin / sizeof builtin[0] ? builtin[m->kind] : "builtin model";
}

static void note_points(const sg_world_desc *d, size_t i, const sg_scene_model *m, const sg_model_points_report *r,
                        size_t splats)
{
    if (r->faces_repeated || r->faces_turned)
        sg_world__say(d, SG_WORLD_NOTE,
            "$.models[%zu] (%s): of %zu triangles, %zu repeat an earlier one (left out) and %zu were wound against "
            "their neighbours (turned)", i, model_label(m), r->file_triangles, r->faces_repeated, r->faces_turned);
    if (r->dropped)
        sg_world__say(d, SG_WORLD_NOTE,
            "$.models[%zu] (%s): dropped %zu stray points whose radius was over %g x the median spacing",
            i, model_label(m), r->dropped, (double)m->points.radius_cap);
    if (r->capped)
        sg_world__say(d, SG_WORLD_NOTE,
            "$.models[%zu] (%s): %zu of %zu splat radii were over %g x the median (%.4g) and were capped to %.4g "
            "(stray points; \"drop_outliers\": true removes them)",
            i, model_label(m), r->capped, splats,
            (double)(m->points.radius_cap > 0.0f ? m->points.radius_cap : SG_RADIUS_CAP_DEFAULT),
            (double)r->median_radius, (double)r->cap_radius);
}

void sg_world__note_envmap(const sg_world_desc *d, const sg_scene_env *e, const sg_envmap *env)
{
    sg_envmap_info info;
    sg_envmap_get_info(env, &info);
    if (info.nonfinite_texels)
        sg_world__say(d, SG_WORLD_NOTE, "%s: %zu of %d x %d texels held NaN or infinite values and were set to 0",
            e->path ? e->path : "envmap", info.nonfinite_texels, info.width, info.height);
}

void sg_world__add_bounds(sg_world *w, size_t i)
{
    sg_scene_info info;
    sg_scene_get_info(w->scenes[i], &info);
    w->bounds = sg_aabb_union(w->bounds, info.bounds);
    w->model_bounds[i] = info.bounds;
}

sg_status sg_world_create(const sg_scene_file *sf, sg_world **out, sg_error *err)
{
    return sg_world_create_desc(sf, NULL, out, err);
}

sg_status sg_world_create_desc(const sg_scene_file *sf, const sg_world_desc *d, sg_world **out, sg_error *err)
{
    if (!sf || !out || sf->model_count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "world: no models");
    sg_world *w = sg_calloc_array(1, sizeof *w);
    if (!w)
        return sg_error_set(err, SG_ERR_NOMEM, "world: out of memory");
    sg_status st = SG_OK;
    w->scenes = sg_calloc_array(sf->model_count, sizeof *w->scenes);
    w->materials = sg_calloc_array(sf->model_count, sizeof *w->materials);
    w->model_bounds = sg_calloc_array(sf->model_count, sizeof *w->model_bounds);
    if (!w->scenes || !w->materials || !w->model_bounds) {
        st = sg_error_set(err, SG_ERR_NOMEM, "world: out of memory for %zu models", sf->model_count);
        goto fail;
    }
    w->count = sf->model_count;
    w->bounds = sg_aabb_empty();
    for (size_t i = 0; i < sf->model_count; ++i) {
        const sg_scene_model *m = &sf->models[i];
        if ((st = make_model_scene(sf, i, d, &w->scenes[i], err)) != SG_OK)
            goto fail;
        w->materials[i] = m->material;
        sg_world__add_bounds(w, i);
    }
    sg_world__say(d, SG_WORLD_STAGE, "environment map%s%s", sf->env.path ? " " : "", sf->env.path ? sf->env.path : "");
    if ((st = sg_world__make_envmap(&sf->env, &w->env, err)) != SG_OK)
        goto fail;
    sg_world__note_envmap(d, &sf->env, w->env);
    *out = w;
    return SG_OK;
fail:
    sg_world_destroy(w);
    return st;
}

static sg_status make_model_scene(const sg_scene_file *sf, size_t i, const sg_world_desc *d, sg_scene **out,
                                  sg_error *err)
{
    const sg_scene_model *m = &sf->models[i];
    sg_status st;
    if (m->surface.model == SG_SURFACE_HYBRID) {
        sg_mesh mesh = {0};
        float spacing = 0.0f;
        sg_world__say(d, SG_WORLD_STAGE, "model %zu of %zu (%s): reading triangles", i + 1, sf->model_count, model_label(m));
        if ((st = load_model_mesh(m, i, &mesh, &spacing, err)) != SG_OK)
            return st;
        transform_mesh(&m->transform, &mesh);
        sg_world__say(d, SG_WORLD_STAGE, "model %zu of %zu (%s): building the hybrid hierarchy of %zu triangles", i + 1,
            sf->model_count, model_label(m), mesh.triangle_count);
        sg_scene_desc sd = m->surface;
        if (spacing > 0.0f) /* a builtin's lattice spacing, in the model's frame */
            sd.hybrid_site_spacing = spacing * scale_of(&m->transform);
        st = sg_scene_create_mesh(&sd, &mesh, m->kind == SG_SCENE_MODEL_FILE ? m->path : model_label(m), out, err);
        sg_mesh_free(&mesh);
        return st;
    }
    sg_pointset ps = {0};
    sg_model_points_report rep = {0};
    sg_world__say(d, SG_WORLD_STAGE, "model %zu of %zu (%s): making splats", i + 1, sf->model_count, model_label(m));
    if ((st = load_model_points(m, i, &ps, &rep, err)) != SG_OK)
        return st;
    note_points(d, i, m, &rep, ps.count);
    transform_points(&m->transform, &ps);
    sg_world__say(d, SG_WORLD_STAGE, "model %zu of %zu (%s): building the %s surface of %zu splats", i + 1, sf->model_count,
        model_label(m),
        m->surface.model == SG_SURFACE_DISK ? "disk" : m->surface.model == SG_SURFACE_ISO ? "ISO" : "MLS", ps.count);
    st = sg_scene_create(&m->surface, &ps, out, err);
    sg_pointset_free(&ps);
    return st;
}

void sg_world_destroy(sg_world *w)
{
    if (!w)
        return;
    for (size_t i = 0; w->scenes && i < w->count; ++i)
        sg_scene_destroy(w->scenes[i]);
    sg_free(w->scenes);
    sg_free(w->materials);
    sg_free(w->model_bounds);
    sg_envmap_destroy(w->env);
    sg_bake_file_close(w->file); /* after the scenes that borrow its map */
    sg_free(w);
}

/* Per-model counters are summed, but a world query is one ray and at
 * most one hit, whatever the number of models it traverses. */
static void add_world_stats(sg_ray_stats *stats, sg_ray_stats *local, int found)
{
    if (!stats)
        return;
    local->rays = 1;
    local->hits = (uint64_t)found;
    sg_ray_stats_add(stats, local);
}

/* Where the ray enters box b, or INFINITY when it misses it within
 * [tmin, tmax]. Written so that a NaN from 0 * inf loses every comparison.
 * (world_int.h; sg_world__box_entry16 is its SIMD form.) */
float sg_world__box_entry(const sg_aabb *b, const sg_ray *r)
{
    const float o[3] = {r->org.x, r->org.y, r->org.z}, d[3] = {r->dir.x, r->dir.y, r->dir.z};
    const float lo[3] = {b->lo.x, b->lo.y, b->lo.z}, hi[3] = {b->hi.x, b->hi.y, b->hi.z};
    float t0 = r->tmin, t1 = r->tmax;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0f) {
            if (o[a] < lo[a] || o[a] > hi[a])
                return INFINITY;
            continue;
        }
        float inv = 1.0f / d[a], ta = (lo[a] - o[a]) * inv, tb = (hi[a] - o[a]) * inv;
        if (ta > tb) {
            float t = ta;
            ta = tb;
            tb = t;
        }
        if (ta > t0) t0 = ta;
        if (tb < t1) t1 = tb;
    }
    return t0 <= t1 ? t0 : INFINITY;
}

#if SG_V16_SIMD
/* Sixteen rays as lanes: origins, 1 / direction, and the axes each is
 * parallel to (a direction component exactly 0). */
typedef struct rays16 {
    sg_v16 o[3], inv[3], tmin, tmax;
    unsigned parallel[3];
} rays16;

/* sg_world__box_entry's operations on the lanes of R: the swap as min and
 * max (v16.h: the scalar ternaries, so a NaN goes the same way); an axis
 * a ray is parallel to leaves its t0 and t1 as they were, or misses the
 * box when the origin is outside that slab. */
static sg_v16 box_entry_lanes(const sg_aabb *b, const rays16 *R)
{
    const float lo[3] = {b->lo.x, b->lo.y, b->lo.z}, hi[3] = {b->hi.x, b->hi.y, b->hi.z};
    sg_v16 t0 = R->tmin, t1 = R->tmax;
    unsigned out_of_slab = 0;
    for (int a = 0; a < 3; ++a) {
        const sg_v16 l = sg_v16_set1(lo[a]), h = sg_v16_set1(hi[a]);
        out_of_slab |= R->parallel[a] & (sg_v16_lt(R->o[a], l) | sg_v16_gt(R->o[a], h));
        const sg_v16 ta = sg_v16_mul(sg_v16_sub(l, R->o[a]), R->inv[a]);
        const sg_v16 tb = sg_v16_mul(sg_v16_sub(h, R->o[a]), R->inv[a]);
        const sg_v16 near = sg_v16_min(tb, ta), far = sg_v16_max(ta, tb); /* ta > tb: swapped */
        t0 = sg_v16_select(R->parallel[a], t0, sg_v16_max(near, t0));
        t1 = sg_v16_select(R->parallel[a], t1, sg_v16_min(far, t1));
    }
    return sg_v16_select(sg_v16_le(t0, t1) & ~out_of_slab, t0, sg_v16_set1(INFINITY));
}
#endif

void sg_world__box_entry16(const sg_aabb *boxes, size_t n, const sg_ray *rays, unsigned mask, float (*out)[16])
{
    if (!mask)
        return;
#if SG_V16_SIMD
    _Alignas(64) float v[8][16]; /* the rays' origins, directions, tmin, tmax */
    const int f = __builtin_ctz(mask);
    for (int i = 0; i < 16; ++i) {
        const sg_ray *r = &rays[mask >> i & 1u ? i : f]; /* outside mask: a copy, never written out */
        v[0][i] = r->org.x, v[1][i] = r->org.y, v[2][i] = r->org.z;
        v[3][i] = r->dir.x, v[4][i] = r->dir.y, v[5][i] = r->dir.z;
        v[6][i] = r->tmin, v[7][i] = r->tmax;
    }
    rays16 R = {.tmin = sg_v16_load(v[6]), .tmax = sg_v16_load(v[7])};
    for (int a = 0; a < 3; ++a) {
        const sg_v16 d = sg_v16_load(v[3 + a]);
        R.o[a] = sg_v16_load(v[a]);
        R.inv[a] = sg_v16_div(sg_v16_set1(1.0f), d);
        R.parallel[a] = sg_v16_eq(d, sg_v16_set1(0.0f));
    }
    for (size_t k = 0; k < n; ++k) {
        _Alignas(64) float e[16];
        sg_v16_store(e, box_entry_lanes(&boxes[k], &R));
        for (unsigned m = mask; m; m &= m - 1)
            out[k][__builtin_ctz(m)] = e[__builtin_ctz(m)];
    }
#else
    for (size_t k = 0; k < n; ++k)
        for (unsigned m = mask; m; m &= m - 1)
            out[k][__builtin_ctz(m)] = sg_world__box_entry(&boxes[k], &rays[__builtin_ctz(m)]);
#endif
}

/* Worlds of up to this many models visit them in box-entry order. */
enum { SORTED_MAX = 16 };

/* Models 0..n-1 sorted by their box entries e[i * stride] (insertion
 * sort, stable): order[k] is the k-th model, entry[k] its box entry. */
static void sort_models(size_t n, const float *e, size_t stride, size_t *order, float *entry)
{
    for (size_t i = 0; i < n; ++i) {
        const float ei = e[i * stride];
        size_t j = i;
        for (; j > 0 && entry[j - 1] > ei; --j) {
            entry[j] = entry[j - 1];
            order[j] = order[j - 1];
        }
        entry[j] = ei;
        order[j] = i;
    }
}

/* The models in the order ray r enters their boxes (sort_models). */
static void model_order(const sg_world *w, const sg_ray *r, size_t n, size_t *order, float *entry)
{
    float e[SORTED_MAX];
    for (size_t i = 0; i < n; ++i)
        e[i] = sg_world__box_entry(&w->model_bounds[i], r);
    sort_models(n, e, 1, order, entry);
}

int sg_world_intersect(const sg_world *w, const sg_ray *ray, sg_world_hit *h, sg_ray_stats *stats)
{
    sg_ray r = *ray;
    sg_ray_stats local = {0};
    int found = 0;
    /* Visit the models in the order the ray enters their boxes, and stop
     * at the first whose box starts beyond the nearest hit so far: with a
     * large ground and a model on it, most rays traverse only one. */
    size_t order[SORTED_MAX];
    float entry[SORTED_MAX];
    size_t n = w->count <= SORTED_MAX ? w->count : 0;
    model_order(w, &r, n, order, entry);
    for (size_t k = 0; k < w->count; ++k) {
        size_t i = n ? order[k] : k;
        if (n && !(entry[k] <= r.tmax))
            break; /* sorted: every later box starts farther */
        sg_hit hit;
        if (sg_scene_intersect(w->scenes[i], &r, &hit, stats ? &local : NULL)) {
            h->hit = hit;
            h->model = (uint32_t)i;
            r.tmax = hit.t; /* invariant 2 */
            found = 1;
        }
    }
    if (!found) {
        h->hit.splat = SG_INVALID_ID;
        h->model = 0;
    }
    add_world_stats(stats, &local, found);
    return found;
}

/* world_nearest for the rays of group, which visit the models in one
 * order (ord, entry[r][k] ray r's entry into the k-th): each model traced
 * for the rays still searching in one call (sg_scene_intersect16). */
static unsigned world_group(const sg_world *w, const sg_ray *rays, unsigned group, const size_t *ord,
                            float (*entry)[SORTED_MAX], sg_world_hit *h, sg_ray_stats *stats)
{
    sg_ray rr[16];
    sg_ray_stats local = {0};
    for (unsigned m = group; m; m &= m - 1)
        rr[__builtin_ctz(m)] = rays[__builtin_ctz(m)];
    unsigned searching = group, found = 0;
    for (size_t k = 0; k < w->count && searching; ++k) {
        for (unsigned m = searching; m; m &= m - 1) {
            int r = __builtin_ctz(m);
            if (!(entry[r][k] <= rr[r].tmax))
                searching &= ~(1u << r); /* sorted: every later box starts farther */
        }
        if (!searching)
            break;
        size_t i = ord[k];
        sg_hit hit[16];
        unsigned got = sg_scene_intersect16(w->scenes[i], rr, searching, hit, stats ? &local : NULL);
        for (unsigned m = got; m; m &= m - 1) {
            int r = __builtin_ctz(m);
            h[r].hit = hit[r];
            h[r].model = (uint32_t)i;
            rr[r].tmax = hit[r].t; /* invariant 2 */
        }
        found |= got;
    }
    for (unsigned m = group & ~found; m; m &= m - 1) {
        int r = __builtin_ctz(m);
        h[r].hit.splat = SG_INVALID_ID;
        h[r].model = 0;
    }
    if (stats) {
        /* one ray and at most one hit per ray, as sg_world_intersect counts */
        local.rays = (uint64_t)__builtin_popcount(group);
        local.hits = (uint64_t)__builtin_popcount(found);
        sg_ray_stats_add(stats, &local);
    }
    return found;
}

unsigned sg_world_intersect16(const sg_world *w, const sg_ray *rays, unsigned mask, sg_world_hit *h,
                              sg_ray_stats *stats)
{
    mask &= 0xFFFFu;
    size_t n = w->count <= SORTED_MAX ? w->count : 0;
    unsigned found = 0;
    if (!n) { /* too many models to sort per ray: one at a time */
        for (unsigned m = mask; m; m &= m - 1) {
            int r = __builtin_ctz(m);
            if (sg_world_intersect(w, &rays[r], &h[r], stats))
                found |= 1u << r;
        }
        return found;
    }
    size_t order[16][SORTED_MAX];
    float entry[16][SORTED_MAX], e[SORTED_MAX][16]; /* e[i][r]: ray r's entry into model i's box */
    sg_world__box_entry16(w->model_bounds, n, rays, mask, e);
    for (unsigned m = mask; m; m &= m - 1)
        sort_models(n, &e[0][__builtin_ctz(m)], 16, order[__builtin_ctz(m)], entry[__builtin_ctz(m)]);
    /* The order decides each model's tmax, and so the bits: rays are
     * traced together only with rays that visit the models in their order
     * (a block on the ground's edge splits into two groups). */
    for (unsigned pending = mask; pending;) {
        const int r0 = __builtin_ctz(pending);
        unsigned group = 0;
        for (unsigned m = pending; m; m &= m - 1) {
            int r = __builtin_ctz(m);
            if (memcmp(order[r], order[r0], n * sizeof order[r][0]) == 0)
                group |= 1u << r;
        }
        pending &= ~group;
        found |= world_group(w, rays, group, order[r0], entry, h, stats);
    }
    return found;
}

unsigned sg_world_intersect4(const sg_world *w, const sg_ray rays[4], unsigned mask, sg_world_hit h[4],
                             sg_ray_stats *stats)
{
    return sg_world_intersect16(w, rays, mask & 15u, h, stats);
}

int sg_world_occluded(const sg_world *w, const sg_ray *ray, sg_ray_stats *stats)
{
    sg_ray_stats local = {0};
    int found = 0;
    for (size_t i = 0; i < w->count && !found; ++i)
        found = sg_scene_occluded(w->scenes[i], ray, stats ? &local : NULL);
    add_world_stats(stats, &local, found);
    return found;
}

sg_ray sg_world_spawn_ray(const sg_world *w, const sg_world_hit *h, sg_vec3 dir, float tmax)
{
    return sg_scene_spawn_ray(w->scenes[h->model], &h->hit, dir, tmax);
}

const sg_material *sg_world_material(const sg_world *w, uint32_t model) { return &w->materials[model]; }

sg_vec3 sg_world_albedo(const sg_world *w, const sg_world_hit *h)
{
    return sg_material_albedo(&w->materials[h->model], sg_scene_hit_albedo(w->scenes[h->model], &h->hit));
}

sg_vec3 sg_world_albedo_sites(const sg_world *w, const sg_world_hit *h, const uint32_t *ids, const float *weights,
                              int n)
{
    return sg_material_albedo(&w->materials[h->model],
                              sg_scene_hit_albedo_sites(w->scenes[h->model], &h->hit, ids, weights, n));
}

sg_vec3 sg_world_site_albedo(const sg_world *w, uint32_t model, uint32_t site)
{
    const sg_sites *s = sg_scene_sites(w->scenes[model]);
    sg_vec3 point = site < s->count ? sg_v3(s->ar[site], s->ag[site], s->ab[site]) : sg_v3(1, 1, 1);
    return sg_material_albedo(&w->materials[model], point);
}

const sg_envmap *sg_world_envmap(const sg_world *w) { return w->env; }
size_t sg_world_model_count(const sg_world *w) { return w->count; }
const sg_scene *sg_world_scene(const sg_world *w, uint32_t model) { return w->scenes[model]; }
sg_aabb sg_world_bounds(const sg_world *w) { return w->bounds; }
