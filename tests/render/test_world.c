/* test_world.c — what the world makes of a scene file's models: albedo
 * means what the material says (no tint the file does not have), the up
 * axis turns a Z-up model, progress and notes reach the caller; and the
 * models' box entries of sixteen rays at once (the 4x4 blocks' model
 * order) are the single ray's, bit for bit. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "io/image.h"
#include "io/scene_file.h"
#include "render/world.h"
#include "render/world_int.h"

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

typedef struct events {
    int stages, notes;
    char text[4096]; /* all messages, one a line */
} events;

static void on_event(void *user, sg_world_event kind, const char *message)
{
    events *e = user;
    if (kind == SG_WORLD_STAGE)
        e->stages++;
    else
        e->notes++;
    size_t n = strlen(e->text);
    snprintf(e->text + n, sizeof e->text - n, "%s %s\n", kind == SG_WORLD_STAGE ? "stage" : "note", message);
}

/* A scan with stray points, Z-up, under a map with NaN texels: the world
 * says what it is doing (a stage per model step and the map) and what it
 * changed (capped radii, zeroed texels) with counts; the Z-up grid lies
 * flat. */
static void test_world_progress_notes_and_up_axis(void **state)
{
    (void)state;
    char xyz[64 * 1024];
    size_t n = 0;
    for (int i = 0; i < 40; ++i) /* a 40 x 40 grid in the XY plane: the floor of a Z-up scan */
        for (int j = 0; j < 40; ++j)
            n += (size_t)snprintf(xyz + n, sizeof xyz - n, "%g %g 0\n", 0.05 * i, 0.05 * j);
    n += (size_t)snprintf(xyz + n, sizeof xyz - n, "30 30 0\n-30 5 0\n");
    const char *scan = sg_test_write_file("floor.xyz", xyz, n);
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, 8, 4, NULL), SG_OK);
    for (int t = 0; t < 3 * 32; ++t)
        img.data[t] = 1.0f;
    img.data[0] = NAN;
    img.data[10] = INFINITY;
    char map[700];
    snprintf(map, sizeof map, "%s/nan_texels.exr", sg_test_tmpdir());
    sg_error err = {0};
    assert_int_equal(sg_image_write_exr(&img, map, &err), SG_OK);
    sg_image_free(&img);
    char json[2048];
    snprintf(json, sizeof json,
             "{\"models\": [{\"path\": \"%s\", \"transform\": {\"up\": \"z\"}}], \"envmap\": {\"path\": \"%s\"}}",
             scan, map);
    sg_scene_file sf;
    assert_int_equal(sg_scene_file_parse(json, strlen(json), "t.json", NULL, &sf, &err), SG_OK);
    events ev = {0};
    sg_world_desc d = {.on_event = on_event, .user = &ev};
    sg_world *w = NULL;
    if (sg_world_create_desc(&sf, &d, &w, &err) != SG_OK)
        fail_msg("%s", err.message);
    print_message("%s", ev.text);
    assert_int_equal(ev.stages, 3);
    assert_int_equal(ev.notes, 2);
    assert_non_null(strstr(ev.text, "stage model 1 of 1 (floor.xyz): making splats"));
    assert_non_null(strstr(ev.text, "stage model 1 of 1 (floor.xyz): building the MLS surface of 1602 splats"));
    assert_non_null(strstr(ev.text, "note $.models[0] (floor.xyz): 2 of 1602 splat radii were over 8 x the median"));
    assert_non_null(strstr(ev.text, "nan_texels.exr: 2 of 8 x 4 texels held NaN or infinite values and were set to 0"));
    sg_world_destroy(w);
    /* drop_outliers: the two strays go, and the note says so. */
    sf.models[0].points.drop_outliers = true;
    memset(&ev, 0, sizeof ev);
    assert_int_equal(sg_world_create_desc(&sf, &d, &w, &err), SG_OK);
    assert_non_null(strstr(ev.text, "dropped 2 stray points"));
    assert_non_null(strstr(ev.text, "of 1600 splats"));
    /* The floor of the Z-up scan lies flat (bounds include splat radii). */
    sg_aabb b = sg_world_bounds(w);
    if (!(b.hi.y - b.lo.y < 0.3f) || !(b.hi.z - b.lo.z > 1.9f) || !(b.hi.z <= 0.2f))
        fail_msg("Z-up floor should lie flat in y = 0, z <= 0: bounds y [%g, %g], z [%g, %g]", (double)b.lo.y,
                 (double)b.hi.y, (double)b.lo.z, (double)b.hi.z);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
}

/* sg_world__box_entry16 against sg_world__box_entry, lane by lane, bit
 * for bit: random boxes and rays (from inside and outside, finite and
 * infinite tmax), rays parallel to an axis (a direction component exactly
 * 0 or -0, the origin inside or outside that slab), flat boxes (the
 * ground's), and partial masks whose other lanes must stay unwritten. */
static void test_world_box_entry16_matches_single(void **state)
{
    (void)state;
    uint64_t rng = 17;
    size_t differ = 0, entered = 0, parallel = 0, boundary = 0;
    for (int n = 0; n < 4000; ++n) {
        sg_vec3 lo = sg_v3(4.0f * sg_test_rand01(&rng) - 2.0f, 4.0f * sg_test_rand01(&rng) - 2.0f,
                           4.0f * sg_test_rand01(&rng) - 2.0f);
        sg_vec3 size = sg_v3(3.0f * sg_test_rand01(&rng), n % 5 == 0 ? 0.0f : 3.0f * sg_test_rand01(&rng),
                             3.0f * sg_test_rand01(&rng));
        sg_aabb b = {lo, sg_v3_add(lo, size)};
        sg_ray rays[16];
        sg_vec3 eye = sg_v3(8.0f * sg_test_rand01(&rng) - 4.0f, 8.0f * sg_test_rand01(&rng) - 4.0f,
                            8.0f * sg_test_rand01(&rng) - 4.0f);
        for (int i = 0; i < 16; ++i) {
            sg_vec3 o = n % 2 ? eye : sg_v3(8.0f * sg_test_rand01(&rng) - 4.0f, 8.0f * sg_test_rand01(&rng) - 4.0f,
                                           8.0f * sg_test_rand01(&rng) - 4.0f);
            sg_vec3 at = sg_v3(lo.x + size.x * sg_test_rand01(&rng), lo.y + size.y * sg_test_rand01(&rng),
                               lo.z + size.z * sg_test_rand01(&rng)); /* half the rays aim into the box */
            sg_vec3 d = i % 2 ? sg_test_random_dir(&rng) : sg_v3_normalize(sg_v3_sub(at, o));
            if (n % 3 == 0 && i % 4 == 1) /* parallel to an axis; the origin in or out of its slab */
                d = i % 8 == 1 ? sg_v3(0.0f, d.y, d.z) : sg_v3(d.x, -0.0f, d.z);
            if (n % 3 == 0 && i % 8 == 5) { /* and on its boundary: 0 * inf is NaN there */
                d = sg_v3(i == 5 ? -0.0f : 0.0f, d.y, d.z);
                o.x = n % 2 ? b.lo.x : b.hi.x;
            }
            rays[i] = (sg_ray){.org = o, .dir = d, .tmin = i % 7 == 3 ? 0.5f : 0.0f,
                               .tmax = i % 5 == 2 ? 6.0f * sg_test_rand01(&rng) : INFINITY};
        }
        unsigned mask = n % 4 == 3 ? 1u + (unsigned)(65534.0f * sg_test_rand01(&rng)) : 0xFFFFu;
        float out[1][16];
        for (int i = 0; i < 16; ++i)
            out[0][i] = -7.0f; /* must stay for lanes outside mask */
        sg_world__box_entry16(&b, 1, rays, mask, out);
        for (int i = 0; i < 16; ++i) {
            if (!(mask >> i & 1u)) {
                differ += out[0][i] != -7.0f;
                continue;
            }
            const float one = sg_world__box_entry(&b, &rays[i]);
            entered += one < INFINITY;
            parallel += rays[i].dir.x == 0.0f || rays[i].dir.y == 0.0f;
            boundary += rays[i].dir.x == 0.0f && (rays[i].org.x == b.lo.x || rays[i].org.x == b.hi.x) &&
                        one < INFINITY;
            if (memcmp(&one, &out[0][i], sizeof one) != 0) {
                if (!differ)
                    print_message("box %d ray %d: org (%g, %g, %g) dir (%g, %g, %g): alone %.9g, in sixteen %.9g\n",
                                  n, i, (double)rays[i].org.x, (double)rays[i].org.y, (double)rays[i].org.z,
                                  (double)rays[i].dir.x, (double)rays[i].dir.y, (double)rays[i].dir.z, (double)one,
                                  (double)out[0][i]);
                ++differ;
            }
        }
    }
    print_message("box entries: %zu entered, %zu parallel to an axis, %zu of those on a slab's boundary entered\n",
                  entered, parallel, boundary);
    if (differ)
        fail_msg("%zu box entries differ between sixteen rays and one", differ);
    assert_true(entered > 5000 && parallel > 3000 && boundary > 50);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_world_albedo_of_mesh_without_colours),
        cmocka_unit_test(test_world_albedo_of_builtins),
        cmocka_unit_test(test_world_progress_notes_and_up_axis),
        cmocka_unit_test(test_world_box_entry16_matches_single),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
