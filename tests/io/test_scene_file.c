/* test_scene_file.c — JSON scene files (io/scene_file.h).
 *
 *  1. scene_file::full_roundtrip   a file setting every field, read from a
 *                                  temp folder: each field lands in the struct.
 *  2. scene_file::defaults         a minimal file: every documented default.
 *  3. scene_file::bad_values       35 bad files (wrong type, out of range,
 *                                  unknown or repeated key, missing required
 *                                  key, contradictions): SG_ERR_CORRUPT, the
 *                                  exact JSON path and expectation in the
 *                                  message, output untouched.
 *  4. scene_file::malformed_json   syntax errors give file:line:column.
 *  5. scene_file::path_resolution  relative paths join the scene's folder;
 *                                  absolute ones are kept; no folder given.
 *  6. scene_file::hash             invariant under key order, whitespace and
 *                                  spelt-out defaults; each part changes its
 *                                  own hash only; threads change nothing.
 *  7. scene_file::transform        XYZ Euler order, inverse-transpose normals,
 *                                  radius scale.
 *  8. scene_file::examples         examples/<name>.json parse (the real-mesh one
 *                                  only where ../shared/data is present).
 *  9. scene_file::io_error         a missing file is SG_ERR_IO naming it.
 *
 * JSON in this file is written with ' for " (see json()), for legibility.
 */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "io/scene_file.h"

/* Copy of s with every ' turned into ". Static storage: a ring of four,
 * so up to four results are valid at once. */
static const char *json(const char *s)
{
    static char ring[4][8192];
    static int next;
    char *buf = ring[next++ & 3];
    size_t n = strlen(s);
    assert_true(n < sizeof ring[0]);
    for (size_t i = 0; i <= n; ++i)
        buf[i] = s[i] == '\'' ? '"' : s[i];
    return buf;
}

static sg_status parse(const char *text, sg_scene_file *out, sg_error *err)
{
    return sg_scene_file_parse(text, strlen(text), "scene.json", "/scenes", out, err);
}

static sg_scene_file parse_ok(const char *text)
{
    sg_scene_file sf;
    sg_error err;
    sg_status st = parse(text, &sf, &err);
    if (st != SG_OK)
        fail_msg("parse failed: %s: %s\n  input: %s", sg_status_name(st), err.message, text);
    return sf;
}

static void assert_v3(const char *what, sg_vec3 v, float x, float y, float z)
{
    if (v.x != x || v.y != y || v.z != z)
        fail_msg("%s = (%g, %g, %g), expected (%g, %g, %g)", what, v.x, v.y, v.z, x, y, z);
}

/* ---- 1 ---------------------------------------------------------------- */

static const char *FULL =
    "{ 'models': [\n"
    "    { 'path': 'meshes/bunny.ply', 'points': 1000, 'radius_k': 12, 'radius_scale': 1.5,\n"
    "      'radius_cap': 20, 'drop_outliers': true,\n"
    "      'transform': {'up': 'z', 'translate': [1, 2, 3], 'rotate_deg': [10, 20, 30], 'scale': [2, 3, 4]},\n"
    "      'material': {'type': 'ggx', 'albedo': [0.1, 0.2, 0.3], 'roughness': 0.6, 'specular': 0.25,\n"
    "                   'emission': [4, 5, 6], 'use_point_colors': false},\n"
    "      'surface': {'model': 'disk', 'kernel': 'gaussian', 'samples_per_cell': 16,\n"
    "                  'refinements': {'shrink': false, 'encourage': true, 'collapse': false}} },\n"
    "    { 'builtin': 'ground', 'radius_cap': 0, 'transform': {'scale': 5, 'up': '-X'} } ],\n"
    "  'envmap': {'path': '/abs/sky.EXR', 'rotation_deg': 90, 'intensity': 2.5},\n"
    "  'cameras': [ {'name': 'main', 'eye': [0, 1, 5], 'look': [0, 1, 0], 'up': [1, 0, 0], 'fov_deg': 35},\n"
    "               {'eye': [5, 5, 5], 'look': [0, 0, 0]} ],\n"
    "  'render': {'width': 640, 'height': 480, 'spp': 16, 'max_depth': 3, 'seed': 42, 'threads': 2} }\n";

static void test_scene_file_full_roundtrip(void **state)
{
    (void)state;
    char dir[1024], file[1100];
    snprintf(dir, sizeof dir, "%s/full", sg_test_tmpdir());
    mkdir(dir, 0777);
    snprintf(file, sizeof file, "%s/scene.json", dir);
    const char *text = json(FULL);
    FILE *f = fopen(file, "wb");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);

    sg_scene_file sf;
    sg_error err;
    sg_status st = sg_scene_file_load(file, &sf, &err);
    if (st != SG_OK)
        fail_msg("load %s: %s", file, err.message);
    assert_int_equal(sf.model_count, 2);
    const sg_scene_model *m = &sf.models[0];
    char want[1200];
    snprintf(want, sizeof want, "%s/meshes/bunny.ply", dir);
    assert_int_equal(m->kind, SG_SCENE_MODEL_FILE);
    assert_string_equal(m->path, want);
    assert_int_equal(m->points.points, 1000);
    assert_int_equal(m->points.radius_k, 12);
    assert_true(m->points.radius_scale == 1.5f);
    assert_true(m->points.radius_cap == 20.0f);
    assert_true(m->points.drop_outliers);
    assert_int_equal(m->transform.up, SG_SCENE_UP_POS_Z);
    assert_v3("translate", m->transform.translate, 1, 2, 3);
    assert_v3("rotate_deg", m->transform.rotate_deg, 10, 20, 30);
    assert_v3("scale", m->transform.scale, 2, 3, 4);
    assert_int_equal(m->material.type, SG_MATERIAL_GGX);
    assert_v3("albedo", m->material.albedo, 0.1f, 0.2f, 0.3f);
    assert_true(m->material.roughness == 0.6f && m->material.specular == 0.25f);
    assert_v3("emission", m->material.emission, 4, 5, 6);
    assert_false(m->material.use_point_colors);
    assert_int_equal(m->surface.model, SG_SURFACE_DISK);
    assert_int_equal(m->surface.kernel, SG_KERNEL_GAUSSIAN);
    assert_int_equal(m->surface.samples_per_cell, 16);
    assert_int_equal(m->surface.kd_disable, SG_KD_NO_SHRINK | SG_KD_NO_COLLAPSE);

    m = &sf.models[1];
    assert_int_equal(m->kind, SG_SCENE_MODEL_GROUND);
    assert_null(m->path);
    assert_v3("uniform scale", m->transform.scale, 5, 5, 5);
    assert_int_equal(m->transform.up, SG_SCENE_UP_NEG_X);
    assert_true(m->points.radius_cap < 0.0f); /* 0 in the file: no cap */
    assert_false(m->points.drop_outliers);

    assert_int_equal(sf.env.kind, SG_SCENE_ENV_FILE);
    assert_string_equal(sf.env.path, "/abs/sky.EXR");
    assert_true(sf.env.rotation_deg == 90.0f && sf.env.intensity == 2.5f);

    assert_int_equal(sf.camera_count, 2);
    assert_string_equal(sf.cameras[0].name, "main");
    assert_v3("eye", sf.cameras[0].eye, 0, 1, 5);
    assert_v3("look", sf.cameras[0].look, 0, 1, 0);
    assert_v3("up", sf.cameras[0].up, 1, 0, 0);
    assert_true(sf.cameras[0].fov_deg == 35.0f);
    assert_string_equal(sf.cameras[1].name, "camera1");
    assert_ptr_equal(sg_scene_file_find_camera(&sf, "camera1"), &sf.cameras[1]);
    assert_null(sg_scene_file_find_camera(&sf, "nope"));

    assert_int_equal(sf.render.width, 640);
    assert_int_equal(sf.render.height, 480);
    assert_int_equal(sf.render.spp, 16);
    assert_int_equal(sf.render.max_depth, 3);
    assert_int_equal(sf.render.seed, 42);
    assert_int_equal(sf.render.threads, 2);
    sg_scene_file_free(&sf);
    assert_null(sf.models);
    sg_scene_file_free(&sf); /* zeroed: a no-op */
    sg_scene_file_free(NULL);
}

/* ---- 2 ---------------------------------------------------------------- */

static void test_scene_file_defaults(void **state)
{
    (void)state;
    sg_scene_file sf = parse_ok(json("{'models': [{'builtin': 'bunny'}]}"));
    assert_int_equal(sf.model_count, 1);
    const sg_scene_model *m = &sf.models[0];
    assert_int_equal(m->kind, SG_SCENE_MODEL_BUNNY);
    assert_null(m->path);
    assert_int_equal(m->points.points, 0);
    assert_int_equal(m->points.radius_k, 8);
    assert_true(m->points.radius_scale == 1.0f);
    assert_true(m->points.radius_cap == SG_RADIUS_CAP_DEFAULT);
    assert_false(m->points.drop_outliers);
    assert_int_equal(m->transform.up, SG_SCENE_UP_POS_Y);
    assert_v3("translate", m->transform.translate, 0, 0, 0);
    assert_v3("rotate_deg", m->transform.rotate_deg, 0, 0, 0);
    assert_v3("scale", m->transform.scale, 1, 1, 1);
    sg_material d = sg_material_default();
    assert_int_equal(m->material.type, d.type);
    assert_v3("albedo", m->material.albedo, 1, 1, 1);
    assert_true(m->material.roughness == d.roughness && m->material.specular == d.specular);
    assert_v3("emission", m->material.emission, 0, 0, 0);
    assert_true(m->material.use_point_colors);
    assert_int_equal(m->surface.model, SG_SURFACE_MLS);
    assert_int_equal(m->surface.kernel, SG_KERNEL_HAT);
    assert_int_equal(m->surface.kd_disable, 0);
    assert_int_equal(m->surface.samples_per_cell, 8);
    assert_int_equal(sf.env.kind, SG_SCENE_ENV_UNIFORM);
    assert_null(sf.env.path);
    assert_true(sf.env.rotation_deg == 0.0f && sf.env.intensity == 1.0f);
    assert_v3("radiance", sf.env.radiance, 1, 1, 1);
    assert_int_equal(sf.camera_count, 0);
    assert_null(sf.cameras);
    assert_int_equal(sf.render.width, 512);
    assert_int_equal(sf.render.height, 512);
    assert_int_equal(sf.render.spp, 64);
    assert_int_equal(sf.render.max_depth, 8);
    assert_int_equal(sf.render.seed, 1);
    assert_int_equal(sf.render.threads, 0);
    sg_scene_file_free(&sf);

    /* Empty sub-objects are the same as absent ones; a camera's defaults. */
    sf = parse_ok(json("{'models': [{'builtin': 'sphere', 'material': {}, 'surface': {'refinements': {}}}],"
                       " 'envmap': {}, 'render': {}, 'cameras': [{'eye': [0,0,1], 'look': [0,0,0]}]}"));
    assert_int_equal(sf.models[0].surface.kd_disable, 0);
    assert_int_equal(sf.env.kind, SG_SCENE_ENV_UNIFORM);
    assert_string_equal(sf.cameras[0].name, "camera0");
    assert_v3("up", sf.cameras[0].up, 0, 1, 0);
    assert_true(sf.cameras[0].fov_deg == 40.0f);
    sg_scene_file_free(&sf);

    /* The built-in room (points/room.h) is a builtin like the others. */
    sf = parse_ok(json("{'models': [{'builtin': 'room', 'points': 20000}]}"));
    assert_int_equal(sf.models[0].kind, SG_SCENE_MODEL_ROOM);
    assert_null(sf.models[0].path);
    assert_int_equal(sf.models[0].points.points, 20000);
    sg_scene_file_free(&sf);
}

/* ---- 3 ---------------------------------------------------------------- */

typedef struct bad_case {
    const char *text;    /* JSON, ' for " */
    const char *message; /* the whole expected message, ' for " */
} bad_case;

#define M0 "{'models': [{'builtin': 'bunny', "
#define UNIT "a number in [0,1]"

static const bad_case BAD[] = {
    /* the example of the brief, verbatim */
    {"{'models': [{'builtin': 'bunny'}, {'builtin': 'bunny', 'material': {'roughness': 'high'}}]}",
     "scene.json: $.models[1].material.roughness: expected " UNIT ", got 'high'"},
    {M0 "'material': {'albedo': [0.5, 1.2, 0]}}]}",
     "scene.json: $.models[0].material.albedo[1]: expected " UNIT ", got 1.2"},
    {M0 "'material': {'albedo': [0.5, 0.5]}}]}",
     "scene.json: $.models[0].material.albedo: expected an array of 3 numbers in [0,1], got an array of 2"},
    {M0 "'material': {'emission': [0, -1, 0]}}]}",
     "scene.json: $.models[0].material.emission[1]: expected a number >= 0, got -1"},
    {M0 "'material': {'type': 'phong'}}]}",
     "scene.json: $.models[0].material.type: expected one of 'lambert', 'ggx', got 'phong'"},
    {M0 "'material': {'use_point_colors': 1}}]}",
     "scene.json: $.models[0].material.use_point_colors: expected true or false, got 1"},
    {M0 "'materal': {}}]}",
     "scene.json: $.models[0].materal: unknown key (expected one of: path, builtin, points, radius_k, "
     "radius_scale, radius_cap, drop_outliers, transform, material, surface)"},
    {M0 "'radius_cap': 0.5}]}",
     "scene.json: $.models[0].radius_cap: expected 0 (no cap) or a number in [1,1000000], got 0.5"},
    {M0 "'drop_outliers': 'yes'}]}",
     "scene.json: $.models[0].drop_outliers: expected true or false, got 'yes'"},
    {M0 "'transform': {'up': 'w'}}]}",
     "scene.json: $.models[0].transform.up: expected one of '+y', '-y', '+z', '-z', '+x', '-x' (the sign may be "
     "left out), got 'w'"},
    {M0 "'transform': {'up': '++z'}}]}",
     "scene.json: $.models[0].transform.up: expected one of '+y', '-y', '+z', '-z', '+x', '-x' (the sign may be "
     "left out), got '++z'"},
    {M0 "'points': 10, 'points': 20}]}", "scene.json: $.models[0].points: key appears more than once"},
    {M0 "'points': 12.5}]}", "scene.json: $.models[0].points: expected an integer in [1,1000000000], got 12.5"},
    {M0 "'radius_k': 0}]}", "scene.json: $.models[0].radius_k: expected an integer in [1,64], got 0"},
    {M0 "'radius_scale': 0}]}", "scene.json: $.models[0].radius_scale: expected a number in (0,100], got 0"},
    {M0 "'transform': {'scale': -1}}]}",
     "scene.json: $.models[0].transform.scale: expected a number in (0,1000000], got -1"},
    {M0 "'transform': {'scale': 'big'}}]}",
     "scene.json: $.models[0].transform.scale: expected a number in (0,1000000] or an array of 3 of them, got 'big'"},
    {M0 "'transform': {'rotate': [0, 90, 0]}}]}",
     "scene.json: $.models[0].transform.rotate: unknown key (expected one of: up, translate, rotate_deg, scale)"},
    {M0 "'surface': {'model': 'splat'}}]}",
     "scene.json: $.models[0].surface.model: expected one of 'mls', 'disk', 'iso', 'hybrid', got 'splat'"},
    {M0 "'surface': {'refinements': {'shrnk': false}}}]}",
     "scene.json: $.models[0].surface.refinements.shrnk: unknown key (expected one of: shrink, encourage, "
     "collapse)"},
    {M0 "'surface': {'iso_leaf_radii': 0}}]}",
     "scene.json: $.models[0].surface.iso_leaf_radii: expected a number in (0,16], got 0"},
    {M0 "'surface': {'iso_lod': 65}}]}",
     "scene.json: $.models[0].surface.iso_lod: expected a number in [0,64], got 65"},
    {M0 "'surface': {'samples_per_cell': 0}}]}",
     "scene.json: $.models[0].surface.samples_per_cell: expected an integer in [1,1024], got 0"},
    {"{'models': [{'builtin': 'dragon'}]}",
     "scene.json: $.models[0].builtin: expected one of 'bunny', 'ground', 'sphere', 'room', got 'dragon'"},
    {"{'models': [{'path': 'bunny.stl'}]}",
     "scene.json: $.models[0].path: expected a .ply, .obj, .xyz, .txt or .pcd file path, got 'bunny.stl'"},
    /* a long value keeps its end, where a path's extension is */
    {"{'models': [{'path': 'scans/2024-05-01/session_three/raw_export_bunny.stl'}]}",
     "scene.json: $.models[0].path: expected a .ply, .obj, .xyz, .txt or .pcd file path, got "
     "'scans/2024-05-01/ses..._export_bunny.stl'"},
    {"{'models': [{'points': 5}]}", "scene.json: $.models[0]: missing required key 'path' or 'builtin'"},
    {"{'models': [{'path': 'a.ply', 'builtin': 'bunny'}]}",
     "scene.json: $.models[0]: give either 'path' or 'builtin', not both"},
    {"{'render': {}}", "scene.json: $: missing required key 'models'"},
    {"{'models': []}", "scene.json: $.models: expected a non-empty array of models, got an array of 0"},
    {"[1, 2]", "scene.json: $: expected an object, got an array of 2"},
    {"{'models': [{'builtin': 'bunny'}], 'envmap': {'builtin': 'sky', 'radiance': [1,1,1]}}",
     "scene.json: $.envmap.radiance: only allowed with 'builtin': 'uniform'"},
    {"{'models': [{'builtin': 'bunny'}], 'envmap': {'path': 'sky.png'}}",
     "scene.json: $.envmap.path: expected a .exr or .hdr file path, got 'sky.png'"},
    {"{'models': [{'builtin': 'bunny'}], 'cameras': [{'look': [0,0,0]}]}",
     "scene.json: $.cameras[0]: missing required key 'eye'"},
    {"{'models': [{'builtin': 'bunny'}], 'cameras': [{'eye': [1,2,3], 'look': [1,2,3]}]}",
     "scene.json: $.cameras[0].look: expected a point other than eye"},
    {"{'models': [{'builtin': 'bunny'}], 'cameras': [{'eye': [0,5,0], 'look': [0,0,0]}]}",
     "scene.json: $.cameras[0].up: expected a direction not parallel to look - eye"},
    {"{'models': [{'builtin': 'bunny'}], 'cameras': [{'eye': [0,0,5], 'look': [0,0,0], 'fov_deg': 180}]}",
     "scene.json: $.cameras[0].fov_deg: expected a number in (0,180), got 180"},
    {"{'models': [{'builtin': 'bunny'}], 'cameras': [{'name': 'a', 'eye': [0,0,5], 'look': [0,0,0]},"
     " {'name': 'a', 'eye': [0,0,6], 'look': [0,0,0]}]}",
     "scene.json: $.cameras[1].name: 'a' is already the name of $.cameras[0]"},
    {"{'models': [{'builtin': 'bunny'}], 'render': {'width': 0}}",
     "scene.json: $.render.width: expected an integer in [1,16384], got 0"},
    {"{'models': [{'builtin': 'bunny'}], 'render': {'seed': -1}}",
     "scene.json: $.render.seed: expected an integer in [0,9007199254740992], got -1"},
    {"{'models': [{'builtin': 'bunny'}], 'render': {'threads': '4'}}",
     "scene.json: $.render.threads: expected an integer in [0,4096], got '4'"},
    {"{'models': [{'builtin': 'bunny'}], 'renderer': {}}",
     "scene.json: $.renderer: unknown key (expected one of: models, envmap, cameras, render, bake)"},
    {"{'models': [{'builtin': 'bunny'}], 'bake': {'ray_cone': 17}}",
     "scene.json: $.bake.ray_cone: expected a number in [0,16], got 17"},
    {"{'models': [{'builtin': 'bunny'}], 'bake': {'ray_cone': -1}}",
     "scene.json: $.bake.ray_cone: expected a number in [0,16], got -1"},
    {"{'models': [{'builtin': 'bunny'}], 'bake': {'rays': 1}}",
     "scene.json: $.bake.rays: unknown key (expected one of: ray_cone)"},
    {"{'models': [{'builtin': 'bunny'}], 'bake': 2}",
     "scene.json: $.bake: expected an object, got 2"},
};

static void test_scene_file_bad_values(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof BAD / sizeof BAD[0]; ++i) {
        const char *text = json(BAD[i].text), *want = json(BAD[i].message);
        sg_scene_file sf;
        memset(&sf, 0xAB, sizeof sf);
        sg_scene_file before = sf;
        sg_error err;
        sg_status st = parse(text, &sf, &err);
        if (st != SG_ERR_CORRUPT || strcmp(err.message, want) != 0)
            fail_msg("case %zu: input %s\n  status %s, message:\n    %s\n  expected SG_ERR_CORRUPT and:\n    %s", i,
                     text, sg_status_name(st), st == SG_OK ? "(none)" : err.message, want);
        if (memcmp(&sf, &before, sizeof sf) != 0)
            fail_msg("case %zu: output written on failure", i);
    }
    printf("%zu bad files rejected with the expected messages\n", sizeof BAD / sizeof BAD[0]);
}

/* ---- 4 ---------------------------------------------------------------- */

static void test_scene_file_malformed_json(void **state)
{
    (void)state;
    struct {
        const char *text;
        const char *prefix; /* message start: file:line:column */
        const char *detail;
    } cases[] = {
        /* cJSON stops just past the '}' that follows the stray comma */
        {"{\n  'models': [\n    {'builtin': 'bunny',}\n  ]\n}", "scene.json:3:26: ",
         "invalid JSON near '{'builtin': 'bunny',}'"},
        {"{'models': [", "scene.json:1:13: ", "unexpected end of file after '{'models': ['"},
        {"{'models': [{'builtin': 'bunny'}]} trailing", "scene.json:1:36: ", "} trailing'"},
        {"", "scene.json:1:1: ", "invalid JSON: unexpected end of file"},
        {"{'models': [{'builtin': 'bunny'}]}\n\n  x", "scene.json:3:3: ", "invalid JSON near 'x'"},
        {"{'models': [{'builtin': 'bunny', 'points': 1e}]}", "scene.json:1:", "invalid JSON near"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        const char *text = json(cases[i].text), *detail = json(cases[i].detail);
        sg_scene_file sf;
        sg_error err;
        sg_status st = parse(text, &sf, &err);
        if (st != SG_ERR_CORRUPT || strncmp(err.message, cases[i].prefix, strlen(cases[i].prefix)) != 0 ||
            !strstr(err.message, detail))
            fail_msg("case %zu: input %s\n  status %s, message \"%s\"\n  expected prefix \"%s\" and \"%s\"", i, text,
                     sg_status_name(st), err.message, cases[i].prefix, detail);
    }
    /* A NUL byte inside the text: cJSON would stop there and accept it. */
    const char with_nul[] = "{\"models\": [{\"builtin\": \"bunny\"}]}\0junk";
    sg_scene_file sf;
    sg_error err;
    assert_int_equal(sg_scene_file_parse(with_nul, sizeof with_nul - 1, "scene.json", NULL, &sf, &err),
                     SG_ERR_CORRUPT);
    if (!strstr(err.message, "scene.json:1:35: ") || !strstr(err.message, "NUL"))
        fail_msg("NUL byte: message \"%s\"", err.message);
}

/* ---- 5 ---------------------------------------------------------------- */

static void test_scene_file_path_resolution(void **state)
{
    (void)state;
    const char *text = json("{'models': [{'path': 'meshes/a.ply'}, {'path': '../up/b.OBJ'}, {'path': '/abs/c.ply'}],"
                            " 'envmap': {'path': 'env/sky.hdr'}}");
    struct {
        const char *base;
        const char *want[4];
    } cases[] = {
        {"/data/scenes", {"/data/scenes/meshes/a.ply", "/data/scenes/../up/b.OBJ", "/abs/c.ply", "/data/scenes/env/sky.hdr"}},
        {"/data/scenes/", {"/data/scenes/meshes/a.ply", "/data/scenes/../up/b.OBJ", "/abs/c.ply", "/data/scenes/env/sky.hdr"}},
        {"rel", {"rel/meshes/a.ply", "rel/../up/b.OBJ", "/abs/c.ply", "rel/env/sky.hdr"}},
        {NULL, {"meshes/a.ply", "../up/b.OBJ", "/abs/c.ply", "env/sky.hdr"}},
        {"/", {"/meshes/a.ply", "/../up/b.OBJ", "/abs/c.ply", "/env/sky.hdr"}},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        sg_scene_file sf;
        sg_error err;
        if (sg_scene_file_parse(text, strlen(text), "s.json", cases[i].base, &sf, &err) != SG_OK)
            fail_msg("base %s: %s", cases[i].base ? cases[i].base : "NULL", err.message);
        const char *got[4] = {sf.models[0].path, sf.models[1].path, sf.models[2].path, sf.env.path};
        for (int k = 0; k < 4; ++k)
            if (strcmp(got[k], cases[i].want[k]) != 0)
                fail_msg("base %s, path %d: got \"%s\", expected \"%s\"", cases[i].base ? cases[i].base : "NULL", k,
                         got[k], cases[i].want[k]);
        sg_scene_file_free(&sf);
    }
    /* load() takes the folder from the scene's own path. */
    char dir[1024], file[1100];
    snprintf(dir, sizeof dir, "%s/nested", sg_test_tmpdir());
    mkdir(dir, 0777);
    snprintf(file, sizeof file, "%s/s.json", dir);
    FILE *f = fopen(file, "wb");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    sg_scene_file sf;
    sg_error err;
    assert_int_equal(sg_scene_file_load(file, &sf, &err), SG_OK);
    char want[1200];
    snprintf(want, sizeof want, "%s/meshes/a.ply", dir);
    assert_string_equal(sf.models[0].path, want);
    sg_scene_file_free(&sf);
}

/* ---- 6 ---------------------------------------------------------------- */

static uint64_t hash_of(const char *text, uint32_t parts)
{
    sg_scene_file sf = parse_ok(json(text));
    uint64_t h = sg_scene_file_hash(&sf, parts);
    sg_scene_file_free(&sf);
    return h;
}

static void test_scene_file_hash(void **state)
{
    (void)state;
    const char *base = "{'models': [{'path': 'a.ply', 'material': {'roughness': 0.5}}],"
                       " 'cameras': [{'name': 'c', 'eye': [0,0,5], 'look': [0,0,0]}], 'render': {'spp': 8}}";
    /* Same content: other key order, whitespace, defaults spelt out. */
    const char *same = "{\n 'render': {'spp': 8, 'threads': 7, 'width': 512},\n"
                       " 'cameras': [{'look': [0,0,0], 'eye': [0,0,5], 'name': 'c', 'up': [0,1,0]}],\n"
                       " 'envmap': {'builtin': 'uniform', 'radiance': [1,1,1]},\n"
                       " 'models': [{'material': {'roughness': 0.5, 'type': 'lambert'}, 'radius_k': 8, 'path': 'a.ply',"
                       " 'transform': {'scale': 1, 'rotate_deg': [0, -0, 0]}}]}";
    uint64_t h0 = hash_of(base, SG_SCENE_HASH_ALL);
    if (hash_of(same, SG_SCENE_HASH_ALL) != h0)
        fail_msg("equivalent files hash differently: %016llx vs %016llx", (unsigned long long)h0,
                 (unsigned long long)hash_of(same, SG_SCENE_HASH_ALL));
    /* Each change moves the hash of its own part, and only that part. */
    struct {
        const char *text;
        uint32_t part;
    } changes[] = {
        {"{'models': [{'path': 'b.ply', 'material': {'roughness': 0.5}}], 'cameras': [{'name': 'c', 'eye': [0,0,5],"
         " 'look': [0,0,0]}], 'render': {'spp': 8}}",
         SG_SCENE_HASH_MODELS},
        {"{'models': [{'path': 'a.ply', 'material': {'roughness': 0.51}}], 'cameras': [{'name': 'c', 'eye': [0,0,5],"
         " 'look': [0,0,0]}], 'render': {'spp': 8}}",
         SG_SCENE_HASH_MODELS},
        {"{'models': [{'path': 'a.ply', 'material': {'roughness': 0.5}}], 'envmap': {'intensity': 2}, 'cameras':"
         " [{'name': 'c', 'eye': [0,0,5], 'look': [0,0,0]}], 'render': {'spp': 8}}",
         SG_SCENE_HASH_ENV},
        {"{'models': [{'path': 'a.ply', 'material': {'roughness': 0.5}}], 'cameras': [{'name': 'c', 'eye': [0,0,6],"
         " 'look': [0,0,0]}], 'render': {'spp': 8}}",
         SG_SCENE_HASH_CAMERAS},
        {"{'models': [{'path': 'a.ply', 'material': {'roughness': 0.5}}], 'cameras': [{'name': 'c', 'eye': [0,0,5],"
         " 'look': [0,0,0]}], 'render': {'spp': 9}}",
         SG_SCENE_HASH_RENDER},
    };
    const uint32_t parts[] = {SG_SCENE_HASH_MODELS, SG_SCENE_HASH_ENV, SG_SCENE_HASH_CAMERAS, SG_SCENE_HASH_RENDER};
    for (size_t i = 0; i < sizeof changes / sizeof changes[0]; ++i)
        for (size_t p = 0; p < 4; ++p) {
            uint64_t a = hash_of(base, parts[p]), b = hash_of(changes[i].text, parts[p]);
            int should_differ = parts[p] == changes[i].part;
            if ((a != b) != should_differ)
                fail_msg("change %zu, part %u: hashes %016llx and %016llx should %s", i, parts[p],
                         (unsigned long long)a, (unsigned long long)b, should_differ ? "differ" : "agree");
        }
    /* The bake key ignores cameras and render settings. */
    assert_true(hash_of(base, SG_SCENE_HASH_BAKE) == hash_of(changes[4].text, SG_SCENE_HASH_BAKE));
    assert_true(hash_of(base, SG_SCENE_HASH_BAKE) != hash_of(base, SG_SCENE_HASH_ALL));
}

/* The ISO's leaf size and level-of-detail threshold. iso_lod: absent = the default (0 in the
 * desc), 0 = off (negative in the desc), a value in pixels; it steers
 * camera rays only, so a bake made before it changed stays valid (the
 * bake key ignores it, where iso_tolerance, which moves the octree's
 * corners and so the light sites, is part of it). */
static void test_scene_file_iso_lod(void **state)
{
    (void)state;
    const char *text[] = {"{'models': [{'path': 'a.ply', 'surface': {'model': 'iso'}}]}",
                          "{'models': [{'path': 'a.ply', 'surface': {'model': 'iso', 'iso_lod': 0}}]}",
                          "{'models': [{'path': 'a.ply', 'surface': {'model': 'iso', 'iso_lod': 2.5}}]}",
                          "{'models': [{'path': 'a.ply', 'surface': {'model': 'iso', 'iso_tolerance': 0.1}}]}",
                          "{'models': [{'path': 'a.ply', 'surface': {'model': 'iso', 'iso_leaf_radii': 1}}]}"};
    const float want[] = {0.0f, -1.0f, 2.5f, 0.0f};
    for (int i = 0; i < 3; ++i) {
        sg_scene_file sf = parse_ok(json(text[i]));
        if (sf.models[0].surface.iso_lod != want[i])
            fail_msg("%s: iso_lod %g, want %g", text[i], (double)sf.models[0].surface.iso_lod, (double)want[i]);
        sg_scene_file_free(&sf);
    }
    uint64_t h0 = hash_of(text[0], SG_SCENE_HASH_BAKE);
    assert_true(hash_of(text[1], SG_SCENE_HASH_BAKE) == h0);
    assert_true(hash_of(text[2], SG_SCENE_HASH_BAKE) == h0);
    assert_true(hash_of(text[3], SG_SCENE_HASH_BAKE) != h0);
    /* the leaf size moves the corners: part of the key */
    sg_scene_file sf = parse_ok(json(text[4]));
    assert_true(sf.models[0].surface.iso_leaf_radii == 1.0f);
    sg_scene_file_free(&sf);
    assert_true(hash_of(text[4], SG_SCENE_HASH_BAKE) != h0);
}

/* "bake": {"ray_cone": x}: absent = -1 (the bake's default), 0 = off, a
 * value kept as given; not in the scene hash (the bake's parameter hash
 * holds it), and written back by sg_scene_file_write only when given. */
static void test_scene_file_bake_ray_cone(void **state)
{
    (void)state;
    const char *text[] = {"{'models': [{'path': 'a.ply'}]}", "{'models': [{'path': 'a.ply'}], 'bake': {}}",
                          "{'models': [{'path': 'a.ply'}], 'bake': {'ray_cone': 0}}",
                          "{'models': [{'path': 'a.ply'}], 'bake': {'ray_cone': 2.5}}"};
    const float want[] = {-1.0f, -1.0f, 0.0f, 2.5f};
    uint64_t h0 = hash_of(text[0], SG_SCENE_HASH_BAKE);
    for (int i = 0; i < 4; ++i) {
        sg_scene_file sf = parse_ok(json(text[i]));
        if (sf.bake.ray_cone != want[i])
            fail_msg("%s: ray_cone %g, want %g", text[i], (double)sf.bake.ray_cone, (double)want[i]);
        const char *path = sg_test_tmp_path("cone.json");
        sg_error err = {0};
        if (sg_scene_file_write(&sf, path, &err) != SG_OK)
            fail_msg("write: %s", err.message);
        sg_scene_file back;
        if (sg_scene_file_load(path, &back, &err) != SG_OK)
            fail_msg("load: %s", err.message);
        assert_true(back.bake.ray_cone == want[i]);
        sg_scene_file_free(&back);
        sg_scene_file_free(&sf);
        assert_true(hash_of(text[i], SG_SCENE_HASH_BAKE) == h0);
    }
}

/* ---- 7 ---------------------------------------------------------------- */

static void assert_near3(const char *what, sg_vec3 v, float x, float y, float z)
{
    if (fabsf(v.x - x) > 1e-5f || fabsf(v.y - y) > 1e-5f || fabsf(v.z - z) > 1e-5f)
        fail_msg("%s = (%.7g, %.7g, %.7g), expected (%g, %g, %g)", what, v.x, v.y, v.z, x, y, z);
}

static void test_scene_file_transform(void **state)
{
    (void)state;
    sg_scene_transform t = {{0, 0, 0}, {0, 90, 0}, {1, 1, 1}, SG_SCENE_UP_POS_Y};
    /* Right-handed rotation about +Y by 90 degrees takes +X to -Z. */
    assert_near3("Ry(90) x", sg_scene_transform_point(&t, sg_v3(1, 0, 0)), 0, 0, -1);
    /* XYZ order: X first. Rx(90) takes +Y to +Z, then Ry(90) takes +Z to +X;
     * the other order would leave +Y on +Z. */
    t.rotate_deg = sg_v3(90, 90, 0);
    assert_near3("Ry(90) Rx(90) y", sg_scene_transform_point(&t, sg_v3(0, 1, 0)), 1, 0, 0);
    t.rotate_deg = sg_v3(0, 0, 90);
    assert_near3("Rz(90) x", sg_scene_transform_point(&t, sg_v3(1, 0, 0)), 0, 1, 0);
    /* Scale, then rotate, then translate. */
    t = (sg_scene_transform){{1, 2, 3}, {0, 0, 90}, {2, 3, 4}, SG_SCENE_UP_POS_Y};
    assert_near3("T R S p", sg_scene_transform_point(&t, sg_v3(1, 1, 1)), 1 - 3, 2 + 2, 3 + 4);
    /* Normals stay perpendicular to transformed tangents. */
    t = (sg_scene_transform){{5, 0, 0}, {30, 40, 50}, {1, 4, 0.5f}, SG_SCENE_UP_POS_Z};
    sg_vec3 n = sg_v3_normalize(sg_v3(1, 1, 1)), a = sg_v3(1, -1, 0), b = sg_v3(0, 1, -1);
    sg_vec3 tn = sg_scene_transform_normal(&t, n);
    sg_vec3 o = sg_scene_transform_point(&t, sg_v3(0, 0, 0));
    sg_vec3 ta = sg_v3_sub(sg_scene_transform_point(&t, a), o), tb = sg_v3_sub(sg_scene_transform_point(&t, b), o);
    if (fabsf(sg_v3_length(tn) - 1.0f) > 1e-6f || fabsf(sg_v3_dot(tn, ta)) > 1e-5f * sg_v3_length(ta) ||
        fabsf(sg_v3_dot(tn, tb)) > 1e-5f * sg_v3_length(tb))
        fail_msg("normal (%g,%g,%g): |n'| = %g, n'.a' = %g, n'.b' = %g", tn.x, tn.y, tn.z, sg_v3_length(tn),
                 sg_v3_dot(tn, ta), sg_v3_dot(tn, tb));
    assert_true(sg_scene_transform_radius(&t, 0.5f) == 2.0f);
}

/* The up axis: each choice takes its axis to +Y by a proper rotation
 * (x' cross y' = z', so a mesh keeps its winding), applied before scale,
 * rotation and translation; names parse with or without a sign. */
static void test_scene_file_up_axis(void **state)
{
    (void)state;
    static const struct {
        const char *name;
        sg_scene_up up;
        sg_vec3 axis; /* the model axis that must come out as +Y */
    } ups[] = {{"+y", SG_SCENE_UP_POS_Y, {0, 1, 0}},  {"-y", SG_SCENE_UP_NEG_Y, {0, -1, 0}},
               {"+z", SG_SCENE_UP_POS_Z, {0, 0, 1}},  {"-z", SG_SCENE_UP_NEG_Z, {0, 0, -1}},
               {"+x", SG_SCENE_UP_POS_X, {1, 0, 0}},  {"-x", SG_SCENE_UP_NEG_X, {-1, 0, 0}}};
    for (size_t i = 0; i < sizeof ups / sizeof ups[0]; ++i) {
        sg_scene_up u = (sg_scene_up)99;
        assert_int_equal(sg_scene_up_parse(ups[i].name, &u), SG_OK);
        assert_int_equal(u, ups[i].up);
        assert_string_equal(sg_scene_up_name(u), ups[i].name);
        assert_v3(ups[i].name, sg_scene_up_apply(u, ups[i].axis), 0, 1, 0);
        sg_vec3 x = sg_scene_up_apply(u, sg_v3(1, 0, 0)), y = sg_scene_up_apply(u, sg_v3(0, 1, 0)),
                z = sg_scene_up_apply(u, sg_v3(0, 0, 1));
        sg_vec3 c = sg_v3_cross(x, y);
        if (c.x != z.x || c.y != z.y || c.z != z.z)
            fail_msg("%s is not a rotation: x' cross y' = (%g,%g,%g), z' = (%g,%g,%g)", ups[i].name, c.x, c.y, c.z,
                     z.x, z.y, z.z);
    }
    sg_scene_up u = SG_SCENE_UP_POS_Y;
    assert_int_equal(sg_scene_up_parse("Z", &u), SG_OK);
    assert_int_equal(u, SG_SCENE_UP_POS_Z);
    assert_int_equal(sg_scene_up_parse("x", &u), SG_OK);
    assert_int_equal(u, SG_SCENE_UP_POS_X);
    const char *bad[] = {"", "+", "w", "zz", "+-z", "up", NULL};
    for (int i = 0; bad[i]; ++i)
        assert_int_equal(sg_scene_up_parse(bad[i], &u), SG_ERR_INVALID_ARG);
    assert_int_equal(u, SG_SCENE_UP_POS_X); /* untouched */
    /* Z-up then translate: a point 2 above the model's base lands 2 above
     * the translated origin. */
    sg_scene_transform t = {{10, 0, 0}, {0, 0, 0}, {1, 1, 1}, SG_SCENE_UP_POS_Z};
    assert_near3("Z-up point", sg_scene_transform_point(&t, sg_v3(0, 0, 2)), 10, 2, 0);
    assert_near3("Z-up normal", sg_scene_transform_normal(&t, sg_v3(0, 0, 1)), 0, 1, 0);
    /* The up axis is part of the bake's scene hash. */
    sg_scene_file a = parse_ok(json("{'models': [{'builtin': 'bunny'}]}"));
    sg_scene_file b = parse_ok(json("{'models': [{'builtin': 'bunny', 'transform': {'up': 'z'}}]}"));
    sg_scene_file c2 = parse_ok(json("{'models': [{'builtin': 'bunny', 'transform': {'up': '+y'}}]}"));
    assert_true(sg_scene_file_hash(&a, SG_SCENE_HASH_BAKE) != sg_scene_file_hash(&b, SG_SCENE_HASH_BAKE));
    assert_true(sg_scene_file_hash(&a, SG_SCENE_HASH_BAKE) == sg_scene_file_hash(&c2, SG_SCENE_HASH_BAKE));
    sg_scene_file_free(&a);
    sg_scene_file_free(&b);
    sg_scene_file_free(&c2);
}

/* ---- 8 ---------------------------------------------------------------- */

static void test_scene_file_examples(void **state)
{
    (void)state;
    sg_scene_file sf;
    sg_error err;
    const char *path = SG_SOURCE_DIR "/examples/bunny_sky.json";
    if (sg_scene_file_load(path, &sf, &err) != SG_OK)
        fail_msg("%s", err.message);
    assert_true(sf.model_count >= 1);
    assert_int_equal(sf.models[0].kind, SG_SCENE_MODEL_BUNNY);
    assert_int_equal(sf.env.kind, SG_SCENE_ENV_SKY);
    sg_scene_file_free(&sf);

    path = SG_SOURCE_DIR "/examples/dragon_courtyard.json";
    if (sg_scene_file_load(path, &sf, &err) != SG_OK)
        fail_msg("%s", err.message);
    /* Its paths point into ../shared/data; check they resolve to real files
     * where that folder is present. */
    const char *mesh = sg_test_shared_data("meshes/dragon_vcg50k_normals/dragon.ply");
    if (mesh) {
        FILE *f = fopen(sf.models[0].path, "rb");
        if (!f)
            fail_msg("model path %s does not open", sf.models[0].path);
        fclose(f);
        f = fopen(sf.env.path, "rb");
        if (!f)
            fail_msg("envmap path %s does not open", sf.env.path);
        fclose(f);
    }
    sg_scene_file_free(&sf);

    /* The hybrid dragon of the anti-aliasing figures (docs/hybrid.md). */
    path = SG_SOURCE_DIR "/examples/dragon_hybrid_courtyard.json";
    if (sg_scene_file_load(path, &sf, &err) != SG_OK)
        fail_msg("%s", err.message);
    assert_int_equal(sf.model_count, 2);
    if (sg_test_shared_data("meshes/stanford_dragon/dragon_vrip.ply")) {
        FILE *f = fopen(sf.models[0].path, "rb");
        if (!f)
            fail_msg("model path %s does not open", sf.models[0].path);
        fclose(f);
    }
    sg_scene_file_free(&sf);
}

/* ---- 9 ---------------------------------------------------------------- */

static void test_scene_file_io_error(void **state)
{
    (void)state;
    sg_scene_file sf;
    sg_error err;
    assert_int_equal(sg_scene_file_load("/nonexistent/dir/scene.json", &sf, &err), SG_ERR_IO);
    if (!strstr(err.message, "/nonexistent/dir/scene.json"))
        fail_msg("message \"%s\" does not name the file", err.message);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scene_file_full_roundtrip),  cmocka_unit_test(test_scene_file_defaults),
        cmocka_unit_test(test_scene_file_bad_values),      cmocka_unit_test(test_scene_file_malformed_json),
        cmocka_unit_test(test_scene_file_path_resolution), cmocka_unit_test(test_scene_file_hash),
        cmocka_unit_test(test_scene_file_transform),       cmocka_unit_test(test_scene_file_examples),
        cmocka_unit_test(test_scene_file_io_error),         cmocka_unit_test(test_scene_file_up_axis),
        cmocka_unit_test(test_scene_file_iso_lod),
        cmocka_unit_test(test_scene_file_bake_ray_cone),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
