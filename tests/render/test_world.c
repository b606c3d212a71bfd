/* test_world.c — what the world makes of a scene file's models: albedo
 * means what the material says (no tint the file does not have), the up
 * axis turns a Z-up model, progress and notes reach the caller. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "io/scene_file.h"
#include "render/world.h"

/* A closed cube [-1,1]^3 as OBJ text, no colours. */
static const char CUBE_OBJ[] =
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/* The albedo the world reports where a ray from +Z (x, y offset) hits. */
static sg_vec3 albedo_from_front(const sg_world *w, float x, float y)
{
    sg_ray r = {.org = sg_v3(x, y, 10.0f), .dir = sg_v3(0, 0, -1), .tmin = 0.0f, .tmax = INFINITY};
    sg_world_hit h;
    if (!sg_world_intersect(w, &r, &h, NULL))
        fail_msg("ray at (%g, %g) missed", (double)x, (double)y);
    return sg_world_albedo(w, &h);
}

static void assert_albedo(const char *what, sg_vec3 a, float want)
{
    if (fabsf(a.x - want) > 1e-6f || fabsf(a.y - want) > 1e-6f || fabsf(a.z - want) > 1e-6f)
        fail_msg("%s: albedo (%g, %g, %g), want %g", what, (double)a.x, (double)a.y, (double)a.z, (double)want);
}

/* "albedo": [0.6, 0.6, 0.6] on a mesh without colours is 0.6, with the
 * default use_point_colors (true): the file has no colours to tint by. */
static void test_world_albedo_of_mesh_without_colours(void **state)
{
    (void)state;
    const char *obj = sg_test_write_file("cube.obj", CUBE_OBJ, sizeof CUBE_OBJ - 1);
    char json[1024];
    snprintf(json, sizeof json,
             "{\"models\": [{\"path\": \"%s\", \"points\": 3000, \"material\": {\"albedo\": [0.6, 0.6, 0.6]}}]}",
             obj);
    sg_world *w = sg_test_world_from_json(json);
    assert_albedo("mesh without colours", albedo_from_front(w, 0.1f, 0.2f), 0.6f);
    sg_world_destroy(w);
}

/* The builtin ground and sphere have no colours either. */
static void test_world_albedo_of_builtins(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json(
        "{\"models\": [{\"builtin\": \"sphere\", \"points\": 4000, \"material\": {\"albedo\": [0.6, 0.6, 0.6]}},"
        " {\"builtin\": \"ground\", \"points\": 400, \"transform\": {\"translate\": [0, -1, 0]},"
        "  \"material\": {\"albedo\": [0.3, 0.3, 0.3]}}]}");
    assert_albedo("sphere", albedo_from_front(w, 0.0f, 0.0f), 0.6f);
    sg_ray down = {.org = sg_v3(5.0f, 5.0f, 5.0f), .dir = sg_v3(0, -1, 0), .tmin = 0.0f, .tmax = INFINITY};
    sg_world_hit h;
    assert_true(sg_world_intersect(w, &down, &h, NULL));
    assert_int_equal(h.model, 1);
    assert_albedo("ground", sg_world_albedo(w, &h), 0.3f);
    sg_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_world_albedo_of_mesh_without_colours),
        cmocka_unit_test(test_world_albedo_of_builtins),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
