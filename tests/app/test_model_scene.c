/* test_model_scene.c — the scene made for a model file: placement on the
 * ground (up axis turned first), ground sized to the model, materials by
 * whether the file has colours, a camera that frames the model, the
 * write/load round trip, and the shared command-line options. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "app/model_scene.h"
#include "io/scene_file.h"
#include "render/camera.h"
#include "render/world.h"

/* A 0.15-unit Z-up box, like a real scan in metres: x in [1, 1.1],
 * y in [2, 2.05], z (up) in [3, 3.15]; no colours. */
static const char BOX_OBJ[] = "v 1 2 3\nv 1.1 2 3\nv 1.1 2.05 3\nv 1 2.05 3\n"
                              "v 1 2 3.15\nv 1.1 2 3.15\nv 1.1 2.05 3.15\nv 1 2.05 3.15\n"
                              "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

static void expect_near(const char *what, float got, float want, float tol)
{
    if (!(fabsf(got - want) <= tol))
        fail_msg("%s: %.7g, want %.7g", what, (double)got, (double)want);
}

static void test_model_scene_places_frames_and_tints(void **state)
{
    (void)state;
    const char *obj = sg_test_write_file("zup_box.obj", BOX_OBJ, sizeof BOX_OBJ - 1);
    sg_model_scene_desc d = {.model = obj, .up = SG_SCENE_UP_POS_Z, .points = 20000};
    sg_scene_file sf;
    sg_error err = {0};
    if (sg_model_scene_make(&d, &sf, &err) != SG_OK)
        fail_msg("%s", err.message);
    assert_int_equal(sf.model_count, 2);
    const sg_scene_model *m = &sf.models[0], *g = &sf.models[1];
    assert_int_equal(m->kind, SG_SCENE_MODEL_FILE);
    assert_true(m->path[0] == '/'); /* absolute */
    assert_int_equal(m->transform.up, SG_SCENE_UP_POS_Z);
    assert_int_equal(m->points.points, 20000);
    /* Z-up: the box's z (up) becomes y; after the turn y' = z in [3, 3.15],
     * z' = -y in [-2.05, -2]: translate puts y' on 0 and centres x', z'. */
    sg_vec3 lo = sg_scene_transform_point(&m->transform, sg_v3(1, 2.05f, 3));
    sg_vec3 hi = sg_scene_transform_point(&m->transform, sg_v3(1.1f, 2, 3.15f));
    expect_near("bottom", lo.y, 0.0f, 1e-6f);
    expect_near("top", hi.y, 0.15f, 1e-6f);
    expect_near("centre x", 0.5f * (lo.x + hi.x), 0.0f, 1e-6f);
    expect_near("centre z", 0.5f * (lo.z + hi.z), 0.0f, 1e-6f);
    /* No colours in the file: an albedo that means 0.8. */
    assert_true(m->material.albedo.x == 0.8f && m->material.type == SG_MATERIAL_LAMBERT);
    /* The ground: 4 x the largest extent (0.15) = 0.6 on a side. */
    assert_int_equal(g->kind, SG_SCENE_MODEL_GROUND);
    expect_near("ground scale", g->transform.scale.x, 0.6f / 30.0f, 1e-7f);
    assert_true(g->transform.scale.y == g->transform.scale.x);
    assert_int_equal(sf.env.kind, SG_SCENE_ENV_SKY);
    assert_int_equal(sf.camera_count, 1);
    assert_string_equal(sf.cameras[0].name, "main");
    assert_int_equal(sf.render.width, 800);

    /* The camera frames the model: its centre ray hits the model, and the
     * box's corners project inside the image. */
    sg_world *w = NULL;
    if (sg_world_create(&sf, &w, &err) != SG_OK)
        fail_msg("%s", err.message);
    const sg_scene_camera *c = &sf.cameras[0];
    sg_camera cam;
    assert_int_equal(sg_camera_look_at(c->eye, c->look, c->up, c->fov_deg, 800.0f / 600.0f, &cam, &err), SG_OK);
    sg_ray r = sg_camera_ray(&cam, 400.0f, 300.0f, 800, 600);
    sg_world_hit h;
    assert_true(sg_world_intersect(w, &r, &h, NULL));
    assert_int_equal(h.model, 0);
    float dist = sg_v3_length(sg_v3_sub(c->eye, c->look));
    if (!(dist > 0.15f && dist < 1.5f))
        fail_msg("camera %g from a 0.15 model: a speck or inside it", (double)dist);
    sg_world_destroy(w);

    /* Written and loaded back: the same scene, hash for hash. */
    char path[700];
    snprintf(path, sizeof path, "%s/scene_of_box.json", sg_test_tmpdir());
    assert_int_equal(sg_scene_file_write(&sf, path, &err), SG_OK);
    sg_scene_file back;
    if (sg_scene_file_load(path, &back, &err) != SG_OK)
        fail_msg("%s", err.message);
    assert_true(sg_scene_file_hash(&back, SG_SCENE_HASH_ALL) == sg_scene_file_hash(&sf, SG_SCENE_HASH_ALL));
    sg_scene_file_free(&back);
    sg_scene_file_free(&sf);

    /* A point cloud with colours: albedo 1 x its colours. */
    const char *cloud = "0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n1 1 0 10 20 30\n0.5 0.5 1 1 2 3\n";
    const char *xyz = sg_test_write_file("coloured.xyz", cloud, strlen(cloud));
    d = (sg_model_scene_desc){.model = xyz, .envmap = "/abs/sky.exr"};
    if (sg_model_scene_make(&d, &sf, &err) != SG_OK)
        fail_msg("%s", err.message);
    assert_true(sf.models[0].material.albedo.x == 1.0f && sf.models[0].material.use_point_colors);
    assert_int_equal(sf.env.kind, SG_SCENE_ENV_FILE);
    assert_string_equal(sf.env.path, "/abs/sky.exr");
    sg_scene_file_free(&sf);

    /* Errors name the file. */
    d = (sg_model_scene_desc){.model = sg_test_write_file("bad.ply", "ply\nformat ascii 1.0\n", 21)};
    assert_int_equal(sg_model_scene_make(&d, &sf, &err), SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "bad.ply"));
    d.model = sg_test_write_file("dot.xyz", "1 1 1\n1 1 1\n", 12);
    assert_int_equal(sg_model_scene_make(&d, &sf, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "dot.xyz: the model's points all coincide"));
}

static void test_model_scene_options(void **state)
{
    (void)state;
    char *argv[] = {"prog", "--envmap", "map.exr", "--up", "-z", "--points", "5000", "--radius-cap", "0",
                    "--drop-outliers", "--write-scene", "s.json", "--up", "0,0,1", "--other"};
    int argc = (int)(sizeof argv / sizeof argv[0]);
    sg_model_scene_desc d = {0};
    const char *ws = NULL;
    sg_error err = {0};
    int i = 1;
    for (int k = 0; k < 6; k++, i++)
        assert_int_equal(sg_model_scene_option(argc, argv, &i, &d, &ws, &err), 1);
    assert_string_equal(d.envmap, "map.exr");
    assert_int_equal(d.up, SG_SCENE_UP_NEG_Z);
    assert_int_equal(d.points, 5000);
    assert_true(d.radius_cap < 0.0f);
    assert_true(d.drop_outliers);
    assert_string_equal(ws, "s.json");
    assert_int_equal(i, 12);
    /* "--up 0,0,1" is no axis: the program's own option. */
    assert_int_equal(sg_model_scene_option(argc, argv, &i, &d, &ws, &err), 0);
    assert_int_equal(i, 12);
    i = 14;
    assert_int_equal(sg_model_scene_option(argc, argv, &i, &d, &ws, &err), 0);
    char *bad1[] = {"prog", "--envmap", "map.png"};
    i = 1;
    assert_int_equal(sg_model_scene_option(3, bad1, &i, &d, &ws, &err), -1);
    assert_non_null(strstr(err.message, "--envmap: 'map.png' is not an .exr or .hdr file"));
    char *bad2[] = {"prog", "--radius-cap", "0.5"};
    i = 1;
    assert_int_equal(sg_model_scene_option(3, bad2, &i, &d, &ws, &err), -1);
    char *bad3[] = {"prog", "--points"};
    i = 1;
    assert_int_equal(sg_model_scene_option(2, bad3, &i, &d, &ws, &err), -1);
    assert_non_null(strstr(err.message, "--points needs a value"));
    assert_true(sg_model_scene_is_model("a/b/SCAN.PLY") && sg_model_scene_is_model("x.pcd") &&
                sg_model_scene_is_model("x.txt") && !sg_model_scene_is_model("scene.json") &&
                !sg_model_scene_is_model("ply"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_model_scene_places_frames_and_tints),
        cmocka_unit_test(test_model_scene_options),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
