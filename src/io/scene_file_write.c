/* scene_file_write.c — sg_scene_file_write (see scene_file.h): the parsed
 * struct back to JSON, every key explicit.
 *
 * Invariants:
 *  1. Every field that sg_scene_file_hash covers is written, with the
 *     spelling scene_file.c parses, so load(write(sf)) hashes like sf;
 *     floats are written with 9 significant digits (exact for float).
 *  2. The file appears under its name only complete (temporary + rename).
 */
#define _XOPEN_SOURCE 700 /* realpath */
#include "io/scene_file.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/file_mode.h"

/* A float as the shortest JSON number that reads back to the same float
 * (0.8, not 0.800000012). */
static cJSON *num(float f)
{
    char buf[32];
    for (int digits = 6; digits <= 9; ++digits) {
        snprintf(buf, sizeof buf, "%.*g", digits, (double)f);
        if ((float)strtod(buf, NULL) == f)
            break;
    }
    return cJSON_CreateRaw(buf);
}

static cJSON *vec(sg_vec3 v)
{
    cJSON *a = cJSON_CreateArray();
    cJSON_AddItemToArray(a, num(v.x));
    cJSON_AddItemToArray(a, num(v.y));
    cJSON_AddItemToArray(a, num(v.z));
    return a;
}

/* path made absolute when it names an existing file. */
static cJSON *path_string(const char *path)
{
    char *abs = realpath(path, NULL);
    cJSON *s = cJSON_CreateString(abs ? abs : path);
    free(abs);
    return s;
}

static cJSON *model_json(const sg_scene_model *m)
{
    static const char *const builtins[] = {"", "bunny", "ground", "sphere"};
    cJSON *o = cJSON_CreateObject();
    if (m->kind == SG_SCENE_MODEL_FILE)
        cJSON_AddItemToObject(o, "path", path_string(m->path));
    else
        cJSON_AddStringToObject(o, "builtin", (size_t)m->kind < 4 ? builtins[m->kind] : "?");
    if (m->points.points)
        cJSON_AddNumberToObject(o, "points", (double)m->points.points);
    cJSON_AddNumberToObject(o, "radius_k", m->points.radius_k);
    cJSON_AddItemToObject(o, "radius_scale", num(m->points.radius_scale));
    cJSON_AddItemToObject(o, "radius_cap", num(m->points.radius_cap < 0.0f ? 0.0f : m->points.radius_cap));
    cJSON_AddBoolToObject(o, "drop_outliers", m->points.drop_outliers);
    cJSON *t = cJSON_AddObjectToObject(o, "transform");
    cJSON_AddStringToObject(t, "up", sg_scene_up_name(m->transform.up));
    cJSON_AddItemToObject(t, "translate", vec(m->transform.translate));
    cJSON_AddItemToObject(t, "rotate_deg", vec(m->transform.rotate_deg));
    cJSON_AddItemToObject(t, "scale", vec(m->transform.scale));
    cJSON *mat = cJSON_AddObjectToObject(o, "material");
    cJSON_AddStringToObject(mat, "type", m->material.type == SG_MATERIAL_GGX ? "ggx" : "lambert");
    cJSON_AddItemToObject(mat, "albedo", vec(m->material.albedo));
    cJSON_AddItemToObject(mat, "roughness", num(m->material.roughness));
    cJSON_AddItemToObject(mat, "specular", num(m->material.specular));
    cJSON_AddItemToObject(mat, "emission", vec(m->material.emission));
    cJSON_AddBoolToObject(mat, "use_point_colors", m->material.use_point_colors);
    cJSON *sur = cJSON_AddObjectToObject(o, "surface");
    static const char *const model_names[] = {"mls", "disk", "iso", "hybrid"};
    cJSON_AddStringToObject(sur, "model", (size_t)m->surface.model < 4 ? model_names[m->surface.model] : "?");
    cJSON_AddStringToObject(sur, "kernel", m->surface.kernel == SG_KERNEL_GAUSSIAN ? "gaussian" : "hat");
    cJSON_AddNumberToObject(sur, "samples_per_cell", m->surface.samples_per_cell);
    if (m->surface.iso_tolerance > 0.0f)
        cJSON_AddItemToObject(sur, "iso_tolerance", num(m->surface.iso_tolerance));
    if (m->surface.iso_max_depth > 0)
        cJSON_AddNumberToObject(sur, "iso_max_depth", m->surface.iso_max_depth);
    if (m->surface.iso_leaf_radii > 0.0f)
        cJSON_AddItemToObject(sur, "iso_leaf_radii", num(m->surface.iso_leaf_radii));
    if (m->surface.iso_lod != 0.0f)
        cJSON_AddItemToObject(sur, "iso_lod", num(m->surface.iso_lod > 0.0f ? m->surface.iso_lod : 0.0f));
    if (m->surface.hybrid_lod != 0.0f) /* the file's 0 is full detail, the desc's negative */
        cJSON_AddItemToObject(sur, "hybrid_lod", num(m->surface.hybrid_lod > 0.0f ? m->surface.hybrid_lod : 0.0f));
    if (m->surface.hybrid_site_spacing != 0.0f) /* the file's 0 is vertices only, the desc's negative */
        cJSON_AddItemToObject(sur, "hybrid_site_spacing",
                              num(m->surface.hybrid_site_spacing > 0.0f ? m->surface.hybrid_site_spacing : 0.0f));
    cJSON *r = cJSON_AddObjectToObject(sur, "refinements");
    cJSON_AddBoolToObject(r, "shrink", !(m->surface.kd_disable & SG_KD_NO_SHRINK));
    cJSON_AddBoolToObject(r, "encourage", !(m->surface.kd_disable & SG_KD_NO_ENCOURAGE));
    cJSON_AddBoolToObject(r, "collapse", !(m->surface.kd_disable & SG_KD_NO_COLLAPSE));
    return o;
}

static cJSON *scene_json(const sg_scene_file *sf)
{
    static const char *const envs[] = {"", "uniform", "sky", "sunsky", "studio"};
    cJSON *root = cJSON_CreateObject();
    cJSON *models = cJSON_AddArrayToObject(root, "models");
    for (size_t i = 0; i < sf->model_count; ++i)
        cJSON_AddItemToArray(models, model_json(&sf->models[i]));
    cJSON *env = cJSON_AddObjectToObject(root, "envmap");
    if (sf->env.kind == SG_SCENE_ENV_FILE)
        cJSON_AddItemToObject(env, "path", path_string(sf->env.path));
    else
        cJSON_AddStringToObject(env, "builtin", (size_t)sf->env.kind < 5 ? envs[sf->env.kind] : "?");
    cJSON_AddItemToObject(env, "rotation_deg", num(sf->env.rotation_deg));
    cJSON_AddItemToObject(env, "intensity", num(sf->env.intensity));
    if (sf->env.kind == SG_SCENE_ENV_UNIFORM)
        cJSON_AddItemToObject(env, "radiance", vec(sf->env.radiance));
    cJSON *cams = cJSON_AddArrayToObject(root, "cameras");
    for (size_t i = 0; i < sf->camera_count; ++i) {
        const sg_scene_camera *c = &sf->cameras[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", c->name);
        cJSON_AddItemToObject(o, "eye", vec(c->eye));
        cJSON_AddItemToObject(o, "look", vec(c->look));
        cJSON_AddItemToObject(o, "up", vec(c->up));
        cJSON_AddItemToObject(o, "fov_deg", num(c->fov_deg));
        cJSON_AddItemToArray(cams, o);
    }
    cJSON *r = cJSON_AddObjectToObject(root, "render");
    cJSON_AddNumberToObject(r, "width", sf->render.width);
    cJSON_AddNumberToObject(r, "height", sf->render.height);
    cJSON_AddNumberToObject(r, "spp", sf->render.spp);
    cJSON_AddNumberToObject(r, "max_depth", sf->render.max_depth);
    cJSON_AddNumberToObject(r, "seed", (double)sf->render.seed);
    cJSON_AddNumberToObject(r, "threads", sf->render.threads);
    if (sf->bake.ray_cone >= 0.0f) { /* given: kept; absent stays absent */
        cJSON *b = cJSON_AddObjectToObject(root, "bake");
        cJSON_AddItemToObject(b, "ray_cone", num(sf->bake.ray_cone));
    }
    return root;
}

sg_status sg_scene_file_write(const sg_scene_file *sf, const char *path, sg_error *err)
{
    if (!sf || !path || !path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "scene file write: no scene or no path");
    cJSON *root = scene_json(sf);
    char *text = root ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!text)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the scene text", path);
    sg_status st = SG_OK;
    size_t n = strlen(path);
    char *tmp = malloc(n + 8);
    int fd = -1;
    if (!tmp) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    memcpy(tmp, path, n);
    memcpy(tmp + n, ".XXXXXX", 8);
    if ((fd = mkstemp(tmp)) < 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: cannot create a file beside it: %s", path, strerror(errno));
        goto done;
    }
    FILE *f = fdopen(fd, "w");
    if (!f) {
        close(fd);
        st = sg_error_set(err, SG_ERR_IO, "%s: %s", path, strerror(errno));
        goto remove_tmp;
    }
    int ok = fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (fclose(f) != 0 || !ok) {
        st = sg_error_set(err, SG_ERR_IO, "%s: write failed: %s", path, strerror(errno));
        goto remove_tmp;
    }
    if (chmod(tmp, sg_output_file_mode(path)) != 0 || rename(tmp, path) != 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: cannot move the finished file into place: %s", path,
                          strerror(errno));
        goto remove_tmp;
    }
    goto done;
remove_tmp:
    remove(tmp);
done:
    free(tmp);
    cJSON_free(text);
    return st;
}
