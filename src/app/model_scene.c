/* model_scene.c — see model_scene.h.
 *
 * Invariants:
 *  1. Every field of the scene is set as scene_file.c would set it for a
 *     file that spells the same values out (defaults included), so
 *     writing it and loading it back gives the same hashes.
 *  2. The placement uses the box of the model's vertices after the up
 *     turn; the up turn is a quarter or half turn, so that box is the turn
 *     of the original box's corners, exactly.
 */
#define _XOPEN_SOURCE 700 /* realpath */
#include "app/model_scene.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "core/alloc.h"
#include "core/cli.h"
#include "io/mesh.h"
#include "render/camera.h"

/* The builtin ground is a 30 x 30 square (world.h). */
#define GROUND_SIDE 30.0f
/* Ground side over the model's largest extent: room for its shadow and
 * the light it bounces. */
#define GROUND_OVER_MODEL 4.0f

static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), m = strlen(ext);
    return n > m && strcasecmp(path + n - m, ext) == 0;
}

static int is_env(const char *path) { return has_ext(path, ".exr") || has_ext(path, ".hdr"); }

int sg_model_scene_is_model(const char *path)
{
    static const char *const exts[] = {".ply", ".obj", ".xyz", ".txt", ".pcd"};
    for (size_t i = 0; path && i < sizeof exts / sizeof exts[0]; i++)
        if (has_ext(path, exts[i]))
            return 1;
    return 0;
}

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *r = sg_alloc_array(n, 1);
    if (r)
        memcpy(r, s, n);
    return r;
}

/* The scene_file.c defaults of a model (invariant 1). */
static void model_defaults(sg_scene_model *m)
{
    m->points = (sg_model_points_desc){.radius_k = 8, .radius_scale = 1.0f, .radius_cap = SG_RADIUS_CAP_DEFAULT};
    m->transform = (sg_scene_transform){.scale = {1, 1, 1}, .up = SG_SCENE_UP_POS_Y};
    m->material = sg_material_default();
    m->surface = (sg_scene_desc){.model = SG_SURFACE_MLS, .kernel = SG_KERNEL_HAT, .samples_per_cell = 8};
}

sg_status sg_model_scene_make(const sg_model_scene_desc *d, sg_scene_file *out, sg_error *err)
{
    if (!d || !d->model || !d->model[0] || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "model scene: no model file");
    sg_scene_file sf = {0};
    sg_mesh mesh = {0};
    sg_status st = sg_mesh_read(d->model, &mesh, err);
    if (st != SG_OK)
        return st;
    /* Invariant 2: the box after the up turn. */
    sg_aabb raw = sg_mesh_bounds(&mesh), box = sg_aabb_empty();
    for (int c = 0; c < 8; c++) {
        sg_vec3 p = sg_v3(c & 1 ? raw.hi.x : raw.lo.x, c & 2 ? raw.hi.y : raw.lo.y, c & 4 ? raw.hi.z : raw.lo.z);
        box = sg_aabb_grow(box, sg_scene_up_apply(d->up, p));
    }
    const int has_colors = mesh.colors != NULL;
    /* The model's splats: mesh samples, or a cloud's own points. */
    const size_t splats = mesh.triangle_count ? (d->points ? d->points : 250000) : mesh.vertex_count;
    sg_mesh_free(&mesh);
    sg_vec3 ext = sg_v3_sub(box.hi, box.lo);
    float size = fmaxf(ext.x, fmaxf(ext.y, ext.z));
    if (!(size > 0.0f) || !isfinite(size))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: the model's points all coincide: nothing to frame",
                            d->model);

    sf.models = sg_calloc_array(2, sizeof *sf.models);
    sf.cameras = sg_calloc_array(1, sizeof *sf.cameras);
    char *abs = realpath(d->model, NULL);
    if (!sf.models || !sf.cameras)
        goto nomem;
    sf.model_count = 2;
    sf.camera_count = 1;

    sg_scene_model *m = &sf.models[0];
    model_defaults(m);
    m->kind = SG_SCENE_MODEL_FILE;
    if (!(m->path = dup_str(abs ? abs : d->model)))
        goto nomem;
    m->points.points = d->points;
    m->points.radius_cap = d->radius_cap == 0.0f ? SG_RADIUS_CAP_DEFAULT : d->radius_cap < 0.0f ? -1.0f
                                                                                             : d->radius_cap;
    m->points.drop_outliers = d->drop_outliers;
    m->transform.up = d->up;
    sg_vec3 t = sg_v3(-0.5f * (box.lo.x + box.hi.x), -box.lo.y, -0.5f * (box.lo.z + box.hi.z));
    m->transform.translate = t;
    m->material.albedo = has_colors ? sg_v3(1, 1, 1) : sg_v3(0.8f, 0.8f, 0.8f);

    sg_scene_model *g = &sf.models[1];
    model_defaults(g);
    g->kind = SG_SCENE_MODEL_GROUND;
    /* As dense as the model, roughly: the default scene's ratio (90k
     * ground points to 250k bunny samples), within [1e4, 3.6e5]. */
    double gp = 0.36 * (double)splats;
    g->points.points = gp < 1e4 ? 10000 : gp > 3.6e5 ? 360000 : (size_t)gp;
    float s = GROUND_OVER_MODEL * size / GROUND_SIDE;
    g->transform.scale = sg_v3(s, s, s);
    g->material.albedo = sg_v3(0.5f, 0.5f, 0.5f);
    g->material.use_point_colors = false;

    sf.env = (sg_scene_env){.kind = SG_SCENE_ENV_SKY, .intensity = 1.0f, .radiance = {1, 1, 1}};
    if (d->envmap) {
        char *env = realpath(d->envmap, NULL);
        sf.env.kind = SG_SCENE_ENV_FILE;
        sf.env.path = dup_str(env ? env : d->envmap);
        free(env);
        if (!sf.env.path)
            goto nomem;
    }

    sf.render = (sg_scene_render){.width = d->width > 0 ? d->width : 800, .height = d->height > 0 ? d->height : 600,
                                  .spp = 64, .max_depth = 8, .seed = 1};
    sf.bake = (sg_scene_bake){.ray_cone = -1.0f}; /* not given: the bake's default */
    sg_aabb placed = {sg_v3_add(box.lo, t), sg_v3_add(box.hi, t)};
    sg_camera cam;
    const float fov = 40.0f;
    st = sg_camera_frame(placed, sg_v3(-0.6f, -0.35f, -1.0f), sg_v3(0, 1, 0), fov,
                         (float)sf.render.width / (float)sf.render.height, 0.0f, &cam, err);
    if (st != SG_OK)
        goto fail;
    sg_scene_camera *c = &sf.cameras[0];
    snprintf(c->name, sizeof c->name, "main");
    c->eye = cam.eye;
    c->look = sg_v3_scale(sg_v3_add(placed.lo, placed.hi), 0.5f);
    c->up = sg_v3(0, 1, 0);
    c->fov_deg = fov;
    free(abs);
    *out = sf;
    return SG_OK;

nomem:
    st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the scene", d->model);
fail:
    free(abs);
    sg_scene_file_free(&sf);
    return st;
}

/* ---- options ------------------------------------------------------------ */

int sg_model_scene_option(int argc, char **argv, int *i, sg_model_scene_desc *d, const char **write_scene,
                          sg_error *err)
{
    const char *a = argv[*i], *v = *i + 1 < argc ? argv[*i + 1] : NULL;
    if (!strcmp(a, "--drop-outliers")) {
        d->drop_outliers = true;
        return 1;
    }
    static const char *const with_value[] = {"--envmap", "--up", "--points", "--radius-cap", "--write-scene"};
    size_t k = 0;
    while (k < sizeof with_value / sizeof with_value[0] && strcmp(a, with_value[k]))
        k++;
    if (k == sizeof with_value / sizeof with_value[0])
        return 0;
    if (!v) {
        sg_error_set(err, SG_ERR_INVALID_ARG, "%s needs a value", a);
        return -1;
    }
    switch (k) {
    case 0:
        if (!is_env(v)) {
            sg_error_set(err, SG_ERR_INVALID_ARG, "--envmap: '%s' is not an .exr or .hdr file", v);
            return -1;
        }
        d->envmap = v;
        break;
    case 1:
        if (sg_scene_up_parse(v, &d->up) != SG_OK)
            return 0; /* not an axis: the program's own --up, if it has one */
        break;
    case 2: {
        long n;
        if (sg_cli_long(a, v, 1, 1000000000L, &n, err) != SG_OK)
            return -1;
        d->points = (size_t)n;
        break;
    }
    case 3: {
        char *end;
        errno = 0;
        double x = strtod(v, &end);
        if (errno || end == v || *end || !(x == 0.0 || (x >= 1.0 && x <= 1e6))) {
            sg_error_set(err, SG_ERR_INVALID_ARG, "--radius-cap: '%s' is not 0 (no cap) or a number in [1, 1e6]", v);
            return -1;
        }
        d->radius_cap = x == 0.0 ? -1.0f : (float)x;
        break;
    }
    default:
        *write_scene = v;
        break;
    }
    ++*i;
    return 1;
}
