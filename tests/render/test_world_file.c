/* test_world_file.c — the .sgworld file (render/world_file.h,
 * surface/scene_store.h): a loaded world answers every query with the bits
 * of the built one (all three surfaces); truncated, damaged, newer,
 * other-scene, bake-instead-of-world and stale-input files are refused
 * with the right code and a message naming the fault; arrays with NaN or
 * broken links are refused before use; a failed save leaves nothing;
 * every allocation failure on load is clean. */
#include "test_support.h"

#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "accel/kdtree.h"
#include "accel/sphere_tree.h"
#include "bake/bake.h"
#include "bake/bake_file.h"
#include "bake/bake_io.h"
#include "core/alloc.h"
#include "io/scene_file.h"
#include "render/camera.h"
#include "render/render.h"
#include "render/world.h"
#include "render/world_file.h"
#include "surface/scene_int.h"
#include "surface/scene_store.h"

/* One model of each surface: MLS sphere, disk ground, ISO sphere. */
static const char SCENE_A[] =
    "{\"models\": [{\"builtin\": \"sphere\", \"points\": 3000, \"material\": {\"albedo\": [0.7, 0.6, 0.5]}},"
    " {\"builtin\": \"ground\", \"points\": 400, \"transform\": {\"translate\": [0, -1, 0]},"
    "  \"surface\": {\"model\": \"disk\"}, \"material\": {\"type\": \"ggx\", \"roughness\": 0.4}},"
    " {\"builtin\": \"sphere\", \"points\": 2000, \"transform\": {\"translate\": [2.5, 0, 0]},"
    "  \"surface\": {\"model\": \"iso\"}}]}";

/* Same but 2999 points on the first sphere: another scene. */
static const char SCENE_B[] =
    "{\"models\": [{\"builtin\": \"sphere\", \"points\": 2999, \"material\": {\"albedo\": [0.7, 0.6, 0.5]}},"
    " {\"builtin\": \"ground\", \"points\": 400, \"transform\": {\"translate\": [0, -1, 0]},"
    "  \"surface\": {\"model\": \"disk\"}, \"material\": {\"type\": \"ggx\", \"roughness\": 0.4}},"
    " {\"builtin\": \"sphere\", \"points\": 2000, \"transform\": {\"translate\": [2.5, 0, 0]},"
    "  \"surface\": {\"model\": \"iso\"}}]}";

static void parse(const char *json, sg_scene_file *sf)
{
    sg_error err = {0};
    if (sg_scene_file_parse(json, strlen(json), "test", NULL, sf, &err) != SG_OK)
        fail_msg("parse: %s", err.message);
}

/* The world of SCENE_A, built once and saved to its path once. */
static sg_scene_file scene_a;
static sg_world *built;
static char world_path[4096];

static int setup(void **state)
{
    (void)state;
    sg_error err = {0};
    parse(SCENE_A, &scene_a);
    if (sg_world_create(&scene_a, &built, &err) != SG_OK) {
        fprintf(stderr, "world: %s\n", err.message);
        return -1;
    }
    snprintf(world_path, sizeof world_path, "%s/a.sgworld", sg_test_tmpdir());
    if (sg_world_save(built, &scene_a, world_path, &err) != SG_OK) {
        fprintf(stderr, "save: %s\n", err.message);
        return -1;
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    sg_world_destroy(built);
    sg_scene_file_free(&scene_a);
    return 0;
}

static uint8_t *read_all(const char *path, size_t *size) { return sg_test_read_file(path, size); }

/* Loads path for scene_a: the status, and the message in msg. */
static sg_status try_load(const char *path, char *msg, size_t msg_size)
{
    sg_error err = {0};
    sg_world *w = NULL;
    sg_status st = sg_world_load(path, &scene_a, NULL, &w, &err);
    if (st == SG_OK)
        assert_non_null(w);
    else
        assert_null(w);
    sg_world_destroy(w);
    snprintf(msg, msg_size, "%s", st == SG_OK ? "" : err.message);
    return st;
}

static void expect_load(const char *path, sg_status want, const char *needle)
{
    char msg[SG_ERROR_MESSAGE_MAX];
    sg_status st = try_load(path, msg, sizeof msg);
    if (st != want || !strstr(msg, needle))
        fail_msg("%s: status %d, want %d; message \"%s\" lacks \"%s\"", path, (int)st, (int)want, msg, needle);
}

/* The build facts of a loaded scene (and of its ISO or hybrid) are the
 * built one's but for the build time, stored as 0 (field by field: the
 * structs have padding). */
/* The fields of two materials, bit for bit (not the struct's bytes: its
 * padding after use_point_colors is whatever the copy left there, and a
 * memcmp of it failed now and then once the build used AVX-512 stores). */
static void same_material(const sg_material *x, const sg_material *y)
{
    assert_int_equal(x->type, y->type);
    assert_memory_equal(&x->albedo, &y->albedo, sizeof x->albedo);
    assert_memory_equal(&x->roughness, &y->roughness, sizeof x->roughness);
    assert_memory_equal(&x->specular, &y->specular, sizeof x->specular);
    assert_memory_equal(&x->emission, &y->emission, sizeof x->emission);
    assert_int_equal(x->use_point_colors, y->use_point_colors);
}

static void compare_infos(const sg_scene *a, const sg_scene *b)
{
    sg_scene_info ia, ib;
    sg_scene_get_info(a, &ia);
    sg_scene_get_info(b, &ib);
    assert_true(ia.splat_count == ib.splat_count && ia.node_count == ib.node_count &&
                ia.leaf_count == ib.leaf_count && ia.memory_bytes == ib.memory_bytes && ia.depth == ib.depth);
    assert_memory_equal(&ia.bounds, &ib.bounds, sizeof ia.bounds);
    assert_true((a->iso != NULL) == (b->iso != NULL) && (a->hybrid != NULL) == (b->hybrid != NULL));
    if (a->iso) {
        sg_iso_info oa, ob;
        sg_iso_get_info(a->iso, &oa);
        sg_iso_get_info(b->iso, &ob);
        float fa[3] = {oa.f_scale, oa.r_min, oa.r_max}, fb[3] = {ob.f_scale, ob.r_min, ob.r_max};
        if (memcmp(fa, fb, sizeof fa) != 0 || memcmp(&oa.bounds, &ob.bounds, sizeof oa.bounds) != 0 ||
            oa.leaf_count != ob.leaf_count || oa.memory_bytes != ob.memory_bytes)
            fail_msg("ISO info differs: f_scale %g / %g, r_min %g / %g, r_max %g / %g, bounds hi.z %g / %g",
                     (double)fa[0], (double)fb[0], (double)fa[1], (double)fb[1], (double)fa[2], (double)fb[2],
                     (double)oa.bounds.hi.z, (double)ob.bounds.hi.z);
    }
    if (a->hybrid) {
        sg_hybrid_info ha, hb;
        sg_hybrid_get_info(a->hybrid, &ha);
        sg_hybrid_get_info(b->hybrid, &hb);
        assert_true(ha.triangle_count == hb.triangle_count && ha.node_slots == hb.node_slots &&
                    ha.memory_bytes == hb.memory_bytes && ha.depth == hb.depth && ha.width == hb.width);
        assert_memory_equal(&ha.bounds, &hb.bounds, sizeof ha.bounds);
        assert_int_equal(sg_hybrid_layout_hash(a->hybrid), sg_hybrid_layout_hash(b->hybrid));
    }
}

static void compare_worlds(const sg_world *a, const sg_world *b)
{
    assert_int_equal(sg_world_model_count(a), sg_world_model_count(b));
    sg_aabb ba = sg_world_bounds(a), bb = sg_world_bounds(b);
    assert_memory_equal(&ba, &bb, sizeof ba);
    uint64_t rng = 7;
    int hits = 0;
    for (int k = 0; k < 4000; ++k) {
        /* rays from a sphere of radius 8 towards points near the models */
        float u = sg_test_rand01(&rng), v = sg_test_rand01(&rng);
        float th = 6.2831853f * u, ph = acosf(1.0f - 2.0f * v);
        sg_vec3 o = sg_v3(8.0f * sinf(ph) * cosf(th), 8.0f * cosf(ph), 8.0f * sinf(ph) * sinf(th));
        sg_vec3 t = sg_v3(3.0f * sg_test_rand01(&rng) - 0.5f, 2.0f * sg_test_rand01(&rng) - 1.0f,
                          2.0f * sg_test_rand01(&rng) - 1.0f);
        sg_ray r = {.org = o, .dir = sg_v3_normalize(sg_v3_sub(t, o)), .tmin = 0.0f, .tmax = INFINITY};
        sg_world_hit ha, hb;
        int fa = sg_world_intersect(a, &r, &ha, NULL), fb = sg_world_intersect(b, &r, &hb, NULL);
        assert_int_equal(fa, fb);
        if (!fa)
            continue;
        hits++;
        if (memcmp(&ha, &hb, sizeof ha) != 0)
            fail_msg("ray %d: built hit t %.9g model %u splat %u, loaded t %.9g model %u splat %u", k, (double)ha.hit.t,
                     ha.model, ha.hit.splat, (double)hb.hit.t, hb.model, hb.hit.splat);
        const sg_scene *sa = sg_world_scene(a, ha.model), *sb = sg_world_scene(b, hb.model);
        uint32_t ia[8], ib[8];
        float wa[8], wb[8];
        int na = sg_scene_hit_sites(sa, &ha.hit, ia, wa, 8), nb = sg_scene_hit_sites(sb, &hb.hit, ib, wb, 8);
        assert_int_equal(na, nb);
        assert_memory_equal(ia, ib, (size_t)na * sizeof ia[0]);
        assert_memory_equal(wa, wb, (size_t)na * sizeof wa[0]);
        sg_vec3 aa = sg_world_albedo(a, &ha), ab = sg_world_albedo(b, &hb);
        assert_memory_equal(&aa, &ab, sizeof aa);
        sg_ray sr = sg_world_spawn_ray(a, &ha, sg_v3(0, 1, 0), INFINITY);
        assert_int_equal(sg_world_occluded(a, &sr, NULL), sg_world_occluded(b, &sr, NULL));
    }
    if (hits < 1000)
        fail_msg("only %d of 4000 rays hit: the comparison proves little", hits);
    for (uint32_t m = 0; m < sg_world_model_count(a); ++m) {
        const sg_sites *sa = sg_scene_sites(sg_world_scene(a, m)), *sb = sg_scene_sites(sg_world_scene(b, m));
        assert_int_equal(sa->count, sb->count);
        assert_memory_equal(sa->px, sb->px, sa->count * sizeof(float));
        assert_memory_equal(sa->nz, sb->nz, sa->count * sizeof(float));
        assert_memory_equal(sa->radius, sb->radius, sa->count * sizeof(float));
        assert_memory_equal(sa->ab, sb->ab, sa->count * sizeof(float));
        same_material(sg_world_material(a, m), sg_world_material(b, m));
        compare_infos(sg_world_scene(a, m), sg_world_scene(b, m));
        /* a frame of the model alone, pixel for pixel */
        sg_render_desc rd = {.width = 48, .height = 40, .shade = SG_SHADE_PHONG, .threads = 1};
        sg_error err = {0};
        assert_int_equal(sg_camera_look_at(sg_v3(4, 3, 6), sg_v3(1, 0, 0), sg_v3(0, 1, 0), 50.0f, 48.0f / 40.0f,
                                           &rd.camera, &err),
                         SG_OK);
        sg_image ia = {0}, ib = {0};
        assert_int_equal(sg_render_frame(sg_world_scene(a, m), &rd, &ia, NULL, &err), SG_OK);
        assert_int_equal(sg_render_frame(sg_world_scene(b, m), &rd, &ib, NULL, &err), SG_OK);
        assert_memory_equal(ia.data, ib.data, 3u * 48u * 40u * sizeof(float));
        sg_image_free(&ia);
        sg_image_free(&ib);
    }
}

/* 1. MLS, disk and ISO models come back with the bits of the build. */
static void test_world_file_roundtrip_same_bits(void **state)
{
    (void)state;
    sg_error err = {0};
    sg_world *loaded = NULL;
    if (sg_world_load(world_path, &scene_a, NULL, &loaded, &err) != SG_OK)
        fail_msg("load: %s", err.message);
    compare_worlds(built, loaded);
    /* the file a loaded world saves is the file it came from */
    char again[4200];
    snprintf(again, sizeof again, "%s/again.sgworld", sg_test_tmpdir());
    assert_int_equal(sg_world_save(loaded, &scene_a, again, &err), SG_OK);
    sg_world_destroy(loaded);
    size_t n1, n2;
    uint8_t *b1 = read_all(world_path, &n1), *b2 = read_all(again, &n2);
    assert_int_equal(n1, n2);
    /* INPT holds no file here (builtins only), so the files are equal */
    assert_memory_equal(b1, b2, n1);
    free(b1);
    free(b2);
    char why[512];
    assert_true(sg_world_file_fresh(world_path, &scene_a, why, sizeof why));
}

/* 2. Every cut of the file is refused as corrupt, never loaded. */
static void test_world_file_truncated(void **state)
{
    (void)state;
    size_t n;
    uint8_t *buf = read_all(world_path, &n);
    const size_t cuts[] = {0, 5, 47, 48, 200, 4096, n / 3, n / 2, n - 64, n - 1};
    for (size_t k = 0; k < sizeof cuts / sizeof cuts[0]; ++k) {
        const char *p = sg_test_write_file("cut.sgworld", buf, cuts[k]);
        char msg[SG_ERROR_MESSAGE_MAX];
        sg_status st = try_load(p, msg, sizeof msg);
        if (st != SG_ERR_CORRUPT || !strstr(msg, "cut.sgworld"))
            fail_msg("cut at %zu of %zu: status %d, message \"%s\"", cuts[k], n, (int)st, msg);
    }
    free(buf);
}

/* 3. One flipped byte anywhere (header, table, each payload) is caught. */
static void test_world_file_flipped_byte(void **state)
{
    (void)state;
    size_t n;
    uint8_t *buf = read_all(world_path, &n);
    uint64_t rng = 11;
    for (int k = 0; k < 40; ++k) {
        size_t at = k == 0 ? 20 : k == 1 ? 100 : (size_t)(sg_test_rand01(&rng) * (float)n) % n;
        buf[at] ^= 0x10;
        const char *p = sg_test_write_file("flip.sgworld", buf, n);
        char msg[SG_ERROR_MESSAGE_MAX];
        sg_status st = try_load(p, msg, sizeof msg);
        /* byte 16..23 is the scene hash, covered by the header CRC first */
        if (st != SG_ERR_CORRUPT || !(strstr(msg, "checksum mismatch") || strstr(msg, "padding")))
            fail_msg("flip at byte %zu of %zu: status %d, message \"%s\"", at, n, (int)st, msg);
        buf[at] ^= 0x10;
    }
    free(buf);
}

static void put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

/* 4. A newer format version is unsupported, not corrupt. */
static void test_world_file_newer_version(void **state)
{
    (void)state;
    size_t n;
    uint8_t *buf = read_all(world_path, &n);
    put_u32(buf + 8, SG_BAKE_FORMAT_VERSION + 1);
    put_u32(buf + 44, (uint32_t)crc32(0, buf, 44));
    const char *p = sg_test_write_file("newer.sgworld", buf, n);
    expect_load(p, SG_ERR_UNSUPPORTED, "newer than this build reads");
    free(buf);
}

/* 5. A world of another scene, and a bake file, are refused by name. */
static void test_world_file_other_scene_and_bake(void **state)
{
    (void)state;
    sg_scene_file sb = {0};
    parse(SCENE_B, &sb);
    sg_error err = {0};
    sg_world *w = NULL;
    sg_status st = sg_world_load(world_path, &sb, NULL, &w, &err);
    if (st != SG_ERR_INVALID_ARG || !strstr(err.message, "made for another scene"))
        fail_msg("other scene: status %d, \"%s\"", (int)st, err.message);
    assert_null(w);
    char why[512];
    assert_false(sg_world_file_fresh(world_path, &sb, why, sizeof why));
    assert_non_null(strstr(why, "another scene"));
    sg_scene_file_free(&sb);

    char bake[4200];
    snprintf(bake, sizeof bake, "%s/x.sgbake", sg_test_tmpdir());
    sg_bake_writer *wr = NULL;
    sg_bake_writer_desc d = {.path = bake};
    assert_int_equal(sg_bake_writer_create(&d, &wr, &err), SG_OK);
    assert_int_equal(sg_bake_writer_commit(wr, &err), SG_OK);
    sg_bake_writer_destroy(wr);
    expect_load(bake, SG_ERR_INVALID_ARG, "a splatgi bake file, not a world file");
    /* and a world is never written over it */
    assert_int_equal(sg_world_file_replaceable(bake, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_world_file_replaceable(world_path, &err), SG_OK);
}

static const char CUBE_OBJ[] =
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/* 6. A model file changed after the build makes the world stale. */
static void test_world_file_changed_input(void **state)
{
    (void)state;
    const char *obj = sg_test_write_file("cube.obj", CUBE_OBJ, sizeof CUBE_OBJ - 1);
    char json[4400], path[4200];
    snprintf(json, sizeof json, "{\"models\": [{\"path\": \"%s\", \"points\": 2000}]}", obj);
    snprintf(path, sizeof path, "%s/cube.sgworld", sg_test_tmpdir());
    sg_scene_file sf = {0};
    parse(json, &sf);
    sg_error err = {0};
    sg_world *w = NULL;
    assert_int_equal(sg_world_create(&sf, &w, &err), SG_OK);
    assert_int_equal(sg_world_save(w, &sf, path, &err), SG_OK);
    sg_world_destroy(w);
    w = NULL;
    char why[SG_ERROR_MESSAGE_MAX];
    assert_true(sg_world_file_fresh(path, &sf, why, sizeof why));
    /* same bytes, a new modification time */
    struct timespec ts[2] = {{.tv_sec = 1000000000, .tv_nsec = 0}, {.tv_sec = 1000000000, .tv_nsec = 0}};
    assert_int_equal(utimensat(AT_FDCWD, obj, ts, 0), 0);
    assert_false(sg_world_file_fresh(path, &sf, why, sizeof why));
    assert_non_null(strstr(why, "an input changed"));
    sg_status st = sg_world_load(path, &sf, NULL, &w, &err);
    if (st != SG_ERR_INVALID_ARG || !strstr(err.message, "cube.obj"))
        fail_msg("changed input: status %d, \"%s\"", (int)st, err.message);
    sg_scene_file_free(&sf);
}

/* 7. A save that cannot be made leaves nothing behind, and a good file
 * already at a path survives a failed save over it. */
static void test_world_file_failed_save(void **state)
{
    (void)state;
    char path[4200];
    snprintf(path, sizeof path, "%s/no/such/folder/w.sgworld", sg_test_tmpdir());
    sg_error err = {0};
    assert_int_equal(sg_world_save(built, &scene_a, path, &err), SG_ERR_IO);
    struct stat sb;
    assert_int_not_equal(stat(path, &sb), 0);
    /* a scene of another model count: refused before anything is written */
    sg_scene_file other = {0};
    parse("{\"models\": [{\"builtin\": \"sphere\", \"points\": 500}]}", &other);
    size_t n1, n2;
    uint8_t *before = read_all(world_path, &n1);
    assert_int_equal(sg_world_save(built, &other, world_path, &err), SG_ERR_INVALID_ARG);
    uint8_t *after = read_all(world_path, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(before, after, n1);
    free(before);
    free(after);
    sg_scene_file_free(&other);
}

/* ---- hybrid models (surface/hybrid.h) ------------------------------------ */

/* A cube of 8 coloured vertices (so the vertex and node colour arrays are
 * stored too): ASCII PLY, 12 triangles. */
static const char CUBE_PLY[] =
    "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
    "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 12\n"
    "property list uchar int vertex_indices\nend_header\n"
    "-1 -1 -1 255 0 0\n1 -1 -1 0 255 0\n1 1 -1 0 0 255\n-1 1 -1 255 255 0\n"
    "-1 -1 1 255 0 255\n1 -1 1 0 255 255\n1 1 1 255 255 255\n-1 1 1 40 40 40\n"
    "3 0 3 2\n3 0 2 1\n3 4 5 6\n3 4 6 7\n3 0 1 5\n3 0 5 4\n"
    "3 3 7 6\n3 3 6 2\n3 0 4 7\n3 0 7 3\n3 1 2 6\n3 1 6 5\n";

/* The mixed scene: an MLS sphere, a hybrid ground, a hybrid sphere (4096
 * triangles, fine enough for level-of-detail hits) and a hybrid coloured
 * cube from a file; in *sf, its world built in *w and saved to path. */
static void hybrid_world(sg_scene_file *sf, sg_world **w, char *path, size_t path_size)
{
    const char *ply = sg_test_write_file("cube.ply", CUBE_PLY, sizeof CUBE_PLY - 1);
    char json[4800];
    snprintf(json, sizeof json,
             "{\"models\": [{\"builtin\": \"sphere\", \"points\": 3000, \"material\": {\"albedo\": [0.7, 0.6, 0.5]}},"
             " {\"builtin\": \"ground\", \"points\": 400, \"transform\": {\"translate\": [0, -1, 0]},"
             "  \"surface\": {\"model\": \"hybrid\"}, \"material\": {\"type\": \"ggx\", \"roughness\": 0.4}},"
             " {\"builtin\": \"sphere\", \"points\": 2000, \"transform\": {\"translate\": [2.5, 0, 0]},"
             "  \"surface\": {\"model\": \"hybrid\"}},"
             " {\"path\": \"%s\", \"transform\": {\"translate\": [1.2, 0.4, -0.9], \"scale\": 0.35},"
             "  \"surface\": {\"model\": \"hybrid\"}}],"
             " \"envmap\": {\"builtin\": \"sky\"}}",
             ply);
    parse(json, sf);
    sg_error err = {0};
    if (sg_world_create(sf, w, &err) != SG_OK)
        fail_msg("hybrid world: %s", err.message);
    snprintf(path, path_size, "%s/hybrid.sgworld", sg_test_tmpdir());
    if (sg_world_save(*w, sf, path, &err) != SG_OK)
        fail_msg("hybrid save: %s", err.message);
}

/* Rays with a footprint (sg_ray.spread) at the hybrid sphere: the same
 * hits, bit for bit; returns how many were level-of-detail (node) hits. */
static int compare_lod_hits(const sg_world *a, const sg_world *b)
{
    uint64_t rng = 3;
    int lod = 0;
    for (int k = 0; k < 3000; ++k) {
        float u = sg_test_rand01(&rng), v = sg_test_rand01(&rng);
        float th = 6.2831853f * u, ph = acosf(1.0f - 2.0f * v);
        sg_vec3 o = sg_v3(2.5f + 6.0f * sinf(ph) * cosf(th), 6.0f * cosf(ph), 6.0f * sinf(ph) * sinf(th));
        sg_vec3 t = sg_v3(2.5f + 1.6f * sg_test_rand01(&rng) - 0.8f, 1.6f * sg_test_rand01(&rng) - 0.8f,
                          1.6f * sg_test_rand01(&rng) - 0.8f);
        sg_ray r = {.org = o, .dir = sg_v3_normalize(sg_v3_sub(t, o)), .tmin = 0.0f, .tmax = INFINITY,
                    .spread = 0.005f + 0.1f * sg_test_rand01(&rng)};
        sg_world_hit ha, hb;
        int fa = sg_world_intersect(a, &r, &ha, NULL), fb = sg_world_intersect(b, &r, &hb, NULL);
        assert_int_equal(fa, fb);
        if (!fa)
            continue;
        if (memcmp(&ha, &hb, sizeof ha) != 0)
            fail_msg("ray %d (spread %g): built hit t %.9g model %u site %u leaf %u, loaded t %.9g model %u site %u "
                     "leaf %u",
                     k, (double)r.spread, (double)ha.hit.t, ha.model, ha.hit.splat, ha.hit.leaf, (double)hb.hit.t,
                     hb.model, hb.hit.splat, hb.hit.leaf);
        lod += ha.model >= 1 && ha.hit.leaf == SG_INVALID_ID;
        sg_ray sr = sg_world_spawn_ray(a, &ha, sg_v3(0, 1, 0), INFINITY);
        sr.spread = r.spread;
        assert_int_equal(sg_world_occluded(a, &sr, NULL), sg_world_occluded(b, &sr, NULL));
    }
    return lod;
}

/* A small bake of w saved to name; the file's bytes in *size. */
static uint8_t *bake_bytes(const sg_world *w, const sg_scene_file *sf, const char *name, size_t *size,
                           float **frame)
{
    sg_bake_desc d = {.photons = {.count = 20000, .max_depth = 4, .seed = 9}, .gather = {.k = 16}};
    sg_bake *b = NULL;
    sg_error err = {0};
    if (sg_bake_create(w, &d, &b, &err) != SG_OK)
        fail_msg("bake: %s", err.message);
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", sg_test_tmpdir(), name);
    if (sg_bake_save(b, path, sg_world_file_scene_hash(sf), &err) != SG_OK)
        fail_msg("bake save: %s", err.message);
    /* the lookup frame: camera rays carry a footprint, so nodes are hit */
    sg_bake_frame_desc fd = {.width = 64, .height = 48};
    assert_int_equal(sg_camera_look_at(sg_v3(6, 3, 7), sg_v3(1.5f, -0.3f, 0), sg_v3(0, 1, 0), 45.0f, 64.0f / 48.0f,
                                       &fd.camera, &err),
                     SG_OK);
    sg_image img = {0};
    if (sg_bake_render(b, w, &fd, &img, NULL, &err) != SG_OK)
        fail_msg("bake render: %s", err.message);
    *frame = malloc(sizeof(float) * 3 * 64 * 48);
    assert_non_null(*frame);
    memcpy(*frame, img.data, sizeof(float) * 3 * 64 * 48);
    sg_image_free(&img);
    sg_bake_destroy(b);
    return read_all(path, size);
}

/* 7b. A scene with hybrid models (ground, sphere, a coloured mesh from a
 * file) beside an MLS model comes back with the bits of the build: hits
 * of rays without and with a footprint (level-of-detail node hits among
 * them), light sites, albedo, frames, a bake file and its lookup frame;
 * and a loaded world saves the file it came from. */
static void test_world_file_hybrid_roundtrip(void **state)
{
    (void)state;
    sg_scene_file sf = {0};
    sg_world *w = NULL, *loaded = NULL;
    char path[4200];
    hybrid_world(&sf, &w, path, sizeof path);
    sg_error err = {0};
    if (sg_world_load(path, &sf, NULL, &loaded, &err) != SG_OK)
        fail_msg("hybrid load: %s", err.message);
    compare_worlds(w, loaded);
    int lod = compare_lod_hits(w, loaded);
    if (lod < 100)
        fail_msg("only %d level-of-detail hits: the footprint rays prove little", lod);
    size_t n1, n2;
    float *f1, *f2;
    uint8_t *b1 = bake_bytes(w, &sf, "hb.sgbake", &n1, &f1), *b2 = bake_bytes(loaded, &sf, "hl.sgbake", &n2, &f2);
    assert_int_equal(n1, n2);
    assert_memory_equal(b1, b2, n1);
    assert_memory_equal(f1, f2, sizeof(float) * 3 * 64 * 48);
    free(b1), free(b2), free(f1), free(f2);
    char again[4200];
    snprintf(again, sizeof again, "%s/hybrid-again.sgworld", sg_test_tmpdir());
    assert_int_equal(sg_world_save(loaded, &sf, again, &err), SG_OK);
    b1 = read_all(path, &n1);
    b2 = read_all(again, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(b1, b2, n1);
    free(b1), free(b2);
    sg_world_destroy(loaded);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
}

/* 7c. Damage in a hybrid section: a flipped byte in each hybrid array is
 * a checksum mismatch naming the section; a file cut inside the node
 * bundles is truncated, naming the section; both SG_ERR_CORRUPT. Every
 * allocation failing in turn on a hybrid load is clean. */
static void test_world_file_hybrid_damaged(void **state)
{
    (void)state;
    sg_scene_file sf = {0};
    sg_world *w = NULL;
    char path[4200];
    hybrid_world(&sf, &w, path, sizeof path);
    sg_world_destroy(w);
    sg_bake_open_desc od = {.kind = SG_BAKE_KIND_WORLD};
    sg_bake_file *f = NULL;
    sg_error err = {0};
    assert_int_equal(sg_bake_file_open_desc(path, &od, &f, &err), SG_OK);
    static const char *const tags[] = {"YB02", "YT02", "YI02", "YP02", "YN02", "YB03", "YC03", "YV03"};
    uint64_t off[8], size[8];
    for (int k = 0; k < 8; ++k) {
        const sg_bake_section *sec = sg_bake_file_find(f, tags[k]);
        if (!sec)
            fail_msg("no section %s in the hybrid world", tags[k]);
        off[k] = sec->offset, size[k] = sec->size;
    }
    sg_bake_file_close(f);
    size_t n;
    uint8_t *buf = read_all(path, &n);
    for (int k = 0; k < 8; ++k) {
        size_t at = (size_t)(off[k] + size[k] / 2);
        buf[at] ^= 0x04;
        const char *p = sg_test_write_file("hflip.sgworld", buf, n);
        sg_world *lw = NULL;
        sg_status st = sg_world_load(p, &sf, NULL, &lw, &err);
        if (st != SG_ERR_CORRUPT || !strstr(err.message, tags[k]) || !strstr(err.message, "checksum mismatch"))
            fail_msg("%s flipped at byte %zu: status %d, \"%s\"", tags[k], at, (int)st, st ? err.message : "");
        assert_null(lw);
        buf[at] ^= 0x04;
    }
    const char *p = sg_test_write_file("hcut.sgworld", buf, (size_t)(off[0] + size[0] / 2));
    sg_world *lw = NULL;
    sg_status st = sg_world_load(p, &sf, NULL, &lw, &err);
    if (st != SG_ERR_CORRUPT || !strstr(err.message, "hcut.sgworld") || !strstr(err.message, "YB02: truncated"))
        fail_msg("cut in YB02: status %d, \"%s\"", (int)st, st ? err.message : "");
    free(buf);

    for (long k = 0;; ++k) {
        long live = sg_alloc__live();
        lw = NULL;
        sg_alloc__fail_after(k);
        st = sg_world_load(path, &sf, NULL, &lw, &err);
        sg_alloc__fail_after(-1);
        if (st == SG_OK) {
            sg_world_destroy(lw);
            assert_int_equal(sg_alloc__live(), live);
            assert_true(k > 3);
            break;
        }
        if (st != SG_ERR_NOMEM)
            fail_msg("hybrid load, allocation %ld failing: status %d, \"%s\"", k, (int)st, err.message);
        assert_null(lw);
        assert_int_equal(sg_alloc__live(), live);
    }
    sg_scene_file_free(&sf);
}

/* 7d. The hybrid level of detail steers queries, not the build, and is no
 * part of the scene hash: a world saved with the default loads for a
 * scene asking "hybrid_lod": 0 (full detail) and traces as a world built
 * so: the same hits, and no node hits, where the default has many. */
static void test_world_file_hybrid_lod_from_scene(void **state)
{
    (void)state;
    sg_scene_file sf = {0};
    sg_world *w = NULL, *full = NULL, *loaded = NULL;
    char path[4200];
    hybrid_world(&sf, &w, path, sizeof path);
    int lod_default = compare_lod_hits(w, w);
    for (size_t m = 1; m < sf.model_count; ++m)
        sf.models[m].surface.hybrid_lod = -1.0f; /* as the parser makes "hybrid_lod": 0 */
    sg_error err = {0};
    assert_int_equal(sg_world_create(&sf, &full, &err), SG_OK);
    if (sg_world_load(path, &sf, NULL, &loaded, &err) != SG_OK)
        fail_msg("load with hybrid_lod 0: %s", err.message);
    int lod = compare_lod_hits(full, loaded);
    if (lod != 0 || lod_default < 100)
        fail_msg("%d node hits with hybrid_lod 0 (want 0), %d with the default (want 100 or more)", lod, lod_default);
    sg_world_destroy(loaded);
    sg_world_destroy(full);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
}

/* 8. Every allocation failing in turn: SG_OK or a clean SG_ERR_NOMEM. */
static void test_world_file_load_nomem(void **state)
{
    (void)state;
    for (long k = 0;; ++k) {
        long live = sg_alloc__live();
        sg_error err = {0};
        sg_world *w = NULL;
        sg_alloc__fail_after(k);
        sg_status st = sg_world_load(world_path, &scene_a, NULL, &w, &err);
        sg_alloc__fail_after(-1);
        if (st == SG_OK) {
            sg_world_destroy(w);
            assert_int_equal(sg_alloc__live(), live);
            assert_true(k > 3);
            return;
        }
        if (st != SG_ERR_NOMEM)
            fail_msg("allocation %ld failing: status %d, \"%s\"", k, (int)st, err.message);
        assert_null(w);
        assert_int_equal(sg_alloc__live(), live);
    }
}

/* A 96 x 80 frame of model m (camera rays carry a footprint, so the
 * ISO's level of detail applies) into a malloc'd RGB array. */
static float *frame_of(const sg_world *w, uint32_t m)
{
    sg_render_desc rd = {.width = 96, .height = 80, .shade = SG_SHADE_SIMPLE, .threads = 1};
    sg_error err = {0};
    assert_int_equal(sg_camera_look_at(sg_v3(9, 5, 14), sg_v3(2.5f, 0, 0), sg_v3(0, 1, 0), 30.0f, 96.0f / 80.0f,
                                       &rd.camera, &err),
                     SG_OK);
    sg_image img = {0};
    assert_int_equal(sg_render_frame(sg_world_scene(w, m), &rd, &img, NULL, &err), SG_OK);
    float *px = malloc(sizeof(float) * 3 * 96 * 80);
    assert_non_null(px);
    memcpy(px, img.data, sizeof(float) * 3 * 96 * 80);
    sg_image_free(&img);
    return px;
}

/* 9. The ISO's level of detail steers queries, not the build, and is no
 * part of the scene hash: a world saved with the default loads for a
 * scene asking "iso_lod": 16 and traces as a world built with 16 (and
 * not as the default, or this would prove nothing). */
static void test_world_file_iso_lod_from_scene(void **state)
{
    (void)state;
    char json[sizeof SCENE_A + 64];
    const char *iso = strstr(SCENE_A, "\"model\": \"iso\"");
    assert_non_null(iso);
    int at = (int)(iso - SCENE_A);
    snprintf(json, sizeof json, "%.*s\"model\": \"iso\", \"iso_lod\": 16%s", at, SCENE_A,
             iso + strlen("\"model\": \"iso\""));
    sg_scene_file s16 = {0};
    parse(json, &s16);
    sg_error err = {0};
    sg_world *built16 = NULL, *loaded16 = NULL;
    assert_int_equal(sg_world_create(&s16, &built16, &err), SG_OK);
    if (sg_world_load(world_path, &s16, NULL, &loaded16, &err) != SG_OK)
        fail_msg("load with iso_lod 16: %s", err.message);
    float *a = frame_of(built16, 2), *b = frame_of(loaded16, 2), *c = frame_of(built, 2);
    assert_memory_equal(a, b, sizeof(float) * 3 * 96 * 80);
    if (memcmp(a, c, sizeof(float) * 3 * 96 * 80) == 0)
        fail_msg("iso_lod 16 renders as the default: the test cannot tell the two apart");
    free(a);
    free(b);
    free(c);
    sg_world_destroy(loaded16);
    sg_world_destroy(built16);
    sg_scene_file_free(&s16);
}

/* ---- the arrays behind a file: checks before use (scene_store.h) ----- */

typedef struct copied {
    sg_scene_store store;
    void *owned[SG_SA_COUNT];
} copied;

/* A store of model m of world w with every array copied, so a test may
 * damage it. */
static void copy_store_of(const sg_world *w, uint32_t m, copied *c)
{
    memset(c, 0, sizeof *c);
    sg_scene_store_of(sg_world_scene(w, m), &c->store);
    for (int a = 0; a < SG_SA_COUNT; ++a) {
        if (!c->store.data[a])
            continue;
        const sg_scene_array_spec *sp = sg_scene_array_spec_of((sg_scene_array_id)a);
        size_t bytes = (size_t)c->store.items[a] * sp->per * sg_store_elem_size(sp->elem);
        c->owned[a] = sg_alloc_array(bytes ? bytes : 1, 1);
        assert_non_null(c->owned[a]);
        memcpy(c->owned[a], c->store.data[a], bytes);
        c->store.data[a] = c->owned[a];
    }
}

static void copy_store(uint32_t m, copied *c) { copy_store_of(built, m, c); }

static void free_copy(copied *c)
{
    for (int a = 0; a < SG_SA_COUNT; ++a)
        sg_free(c->owned[a]);
}

static void expect_store(const copied *c, sg_status want, const char *needle)
{
    sg_error err = {0};
    sg_scene *sc = NULL;
    sg_status st = sg_scene_from_store(&c->store, "m", NULL, &sc, &err);
    sg_scene_destroy(sc);
    if (st != want || (needle && !strstr(err.message, needle)))
        fail_msg("status %d (want %d), message \"%s\" (want \"%s\")", (int)st, (int)want,
                 st == SG_OK ? "" : err.message, needle ? needle : "");
}

/* 10. An untouched copy loads; NaN in positions, radii, normals, colours,
 * split planes or the leaf copies does not. */
static void test_scene_store_nan(void **state)
{
    (void)state;
    for (uint32_t m = 0; m < 3; ++m) {
        copied c;
        copy_store(m, &c);
        expect_store(&c, SG_OK, NULL);
        const sg_scene_array_id ids[] = {SG_SA_PX, SG_SA_NY, SG_SA_RADIUS, SG_SA_AG, SG_SA_SOA_PZ, SG_SA_SOA_INV_R};
        for (size_t k = 0; k < sizeof ids / sizeof ids[0]; ++k) {
            float *f = (float *)c.owned[ids[k]];
            if (!f)
                continue; /* the ISO has no leaf copies */
            float keep = f[17];
            f[17] = NAN;
            expect_store(&c, SG_ERR_CORRUPT, k < 4 ? "17" : "reference 17");
            f[17] = keep;
        }
        if (c.owned[SG_SA_KD_NODES]) {
            sg_kd_node *nd = c.owned[SG_SA_KD_NODES];
            float keep = nd[0].split;
            nd[0].split = NAN;
            expect_store(&c, SG_ERR_CORRUPT, "split plane is NaN");
            nd[0].split = keep;
        }
        expect_store(&c, SG_OK, NULL); /* every damage was undone */
        free_copy(&c);
    }
}

/* 11. Broken links: child indices, leaf numbers, references, offsets,
 * octree corners, and arrays of the wrong length or missing. */
static void test_scene_store_links(void **state)
{
    (void)state;
    copied c;
    copy_store(0, &c); /* MLS */
    sg_kd_node *nd = c.owned[SG_SA_KD_NODES];
    uint32_t keep = nd[0].word;
    nd[0].word = (0u << 2) | 0u; /* root's own child */
    expect_store(&c, SG_ERR_CORRUPT, "not after it");
    nd[0].word = ((uint32_t)c.store.items[SG_SA_KD_NODES] << 2) | 1u;
    expect_store(&c, SG_ERR_CORRUPT, "not after it");
    nd[0].word = keep;
    uint32_t *refs = c.owned[SG_SA_KD_REFS];
    uint32_t r = refs[5];
    refs[5] = 1u << 30;
    expect_store(&c, SG_ERR_CORRUPT, "reference 5");
    refs[5] = r;
    uint32_t *first = c.owned[SG_SA_KD_LEAF_FIRST];
    size_t leaves = c.store.items[SG_SA_KD_LEAF_BOUNDS];
    uint32_t f = first[leaves];
    first[leaves] = f + 1;
    expect_store(&c, SG_ERR_CORRUPT, "leaf offsets");
    first[leaves] = f;
    c.store.items[SG_SA_SOA_ID]--;
    expect_store(&c, SG_ERR_CORRUPT, "array SD holds");
    c.store.items[SG_SA_SOA_ID]++;
    const void *key = c.store.data[SG_SA_SOA_KEY];
    c.store.data[SG_SA_SOA_KEY] = NULL;
    expect_store(&c, SG_ERR_CORRUPT, "array SK is missing");
    c.store.data[SG_SA_SOA_KEY] = key;
    c.store.scalars[0] = 7; /* surface model */
    expect_store(&c, SG_ERR_CORRUPT, "unknown surface model 7");
    c.store.scalars[0] = SG_SURFACE_MLS;
    expect_store(&c, SG_OK, NULL);
    free_copy(&c);

    copy_store(2, &c); /* ISO */
    uint32_t *leaf = c.owned[SG_SA_ISO_LEAVES];
    uint32_t corner = leaf[3];
    leaf[3] = (uint32_t)c.store.items[SG_SA_ISO_CF];
    expect_store(&c, SG_ERR_CORRUPT, "octree leaf 0: corner");
    leaf[3] = corner;
    uint8_t *node = c.owned[SG_SA_ISO_NODES];
    uint8_t pad = node[11];
    node[11] = 1;
    expect_store(&c, SG_ERR_CORRUPT, "octree node 0: inconsistent masks");
    node[11] = pad;
    uint32_t base = ((uint32_t *)node)[0];
    ((uint32_t *)node)[0] = 0; /* inner children at the root itself */
    expect_store(&c, SG_ERR_CORRUPT, "not after it");
    ((uint32_t *)node)[0] = base;
    expect_store(&c, SG_OK, NULL);
    free_copy(&c);
}

/* 12. The hybrid hierarchy's arrays: child words (a bundle not after its
 * parent, past the end, reached twice), leaf ranges past the triangles,
 * lanes that are neither empty nor a sphere, vertex ids out of range, a
 * zero-area triangle, an input index out of range, NaN positions and
 * colours, wrong lengths, missing or extra arrays, another branching
 * factor: each refused naming the array and element; the untouched copy
 * loads. */
static void test_scene_store_hybrid(void **state)
{
    (void)state;
    sg_scene_file sf = {0};
    sg_world *w = NULL;
    char path[4200];
    hybrid_world(&sf, &w, path, sizeof path);
    copied c;
    copy_store_of(w, 2, &c); /* the hybrid sphere */
    expect_store(&c, SG_OK, NULL);
    sg_stree_bundle *B = c.owned[SG_SA_HY_BUNDLES];
    const size_t bundles = c.store.items[SG_SA_HY_BUNDLES];
    assert_true(bundles > 4 && !sg_stree_is_leaf(B[0].child[0]));
    uint32_t keep = B[0].child[0];
    B[0].child[0] = 0; /* the root's children in its own bundle */
    expect_store(&c, SG_ERR_CORRUPT, "sphere-tree node 0: children bundle 0 is not after it");
    B[0].child[0] = (uint32_t)bundles;
    expect_store(&c, SG_ERR_CORRUPT, "is not after it within");
    B[0].child[0] = keep;
    /* two inner lanes of the root's children with the same children */
    assert_true(!sg_stree_is_leaf(B[1].child[0]) && !sg_stree_is_leaf(B[1].child[1]));
    uint32_t k1 = B[1].child[1];
    B[1].child[1] = B[1].child[0];
    expect_store(&c, SG_ERR_CORRUPT, "reached twice");
    B[1].child[1] = k1;
    /* a leaf whose triangles run past the end */
    size_t lb = 0;
    int ll = -1;
    for (size_t b = 0; b < bundles && ll < 0; ++b)
        for (int l = 0; l < SG_STREE_WIDTH; ++l)
            if (sg_stree_is_leaf(B[b].child[l])) {
                lb = b, ll = l;
                break;
            }
    assert_true(ll >= 0);
    keep = B[lb].child[ll];
    B[lb].child[ll] = SG_STREE_LEAF | (7u << SG_STREE_COUNT_SHIFT) | (uint32_t)c.store.items[SG_SA_HY_TRI];
    expect_store(&c, SG_ERR_CORRUPT, "past");
    B[lb].child[ll] = keep;
    /* the root bundle's lane 1 made a sphere; a node's radius NaN */
    B[0].r[1] = 1.0f;
    expect_store(&c, SG_ERR_CORRUPT, "sphere-tree node 1: an empty lane");
    B[0].r[1] = NAN;
    float r0 = B[0].r[0];
    B[0].r[0] = NAN;
    expect_store(&c, SG_ERR_CORRUPT, "sphere-tree node 0: sphere");
    B[0].r[0] = r0;
    uint32_t *tri = c.owned[SG_SA_HY_TRI];
    uint32_t t4 = tri[4];
    tri[4] = (uint32_t)c.store.items[SG_SA_HY_POS];
    expect_store(&c, SG_ERR_CORRUPT, "hybrid triangle 1: vertices");
    tri[4] = tri[3]; /* a repeated vertex: zero area */
    expect_store(&c, SG_ERR_CORRUPT, "hybrid triangle 1: zero area");
    tri[4] = t4;
    uint32_t *tid = c.owned[SG_SA_HY_TRI_ID];
    uint32_t i5 = tid[5];
    tid[5] = 1u << 30;
    expect_store(&c, SG_ERR_CORRUPT, "hybrid triangle 5: input index");
    tid[5] = i5;
    float *pos = c.owned[SG_SA_HY_POS];
    float p = pos[3 * 17 + 1];
    pos[3 * 17 + 1] = NAN;
    expect_store(&c, SG_ERR_CORRUPT, "hybrid vertex 17 is not finite");
    pos[3 * 17 + 1] = p;
    c.store.items[SG_SA_HY_TRI_ID]--;
    expect_store(&c, SG_ERR_CORRUPT, "array YI holds");
    c.store.items[SG_SA_HY_TRI_ID]++;
    const void *nrm = c.store.data[SG_SA_HY_NORMAL];
    c.store.data[SG_SA_HY_NORMAL] = NULL;
    expect_store(&c, SG_ERR_CORRUPT, "array YN is missing");
    c.store.data[SG_SA_HY_NORMAL] = nrm;
    c.store.data[SG_SA_HY_NODE_COLOR] = c.store.data[SG_SA_HY_POS]; /* this mesh has no colours */
    expect_store(&c, SG_ERR_CORRUPT, "array YC on a hybrid surface that has none");
    c.store.data[SG_SA_HY_NODE_COLOR] = NULL;
    /* slot 91 holds the branching factor (scene_store.c scalars()) */
    assert_int_equal(c.store.scalars[91], SG_STREE_WIDTH);
    c.store.scalars[91] = SG_STREE_WIDTH == 8 ? 4 : 8;
    expect_store(&c, SG_ERR_CORRUPT, "children per node");
    c.store.scalars[91] = SG_STREE_WIDTH;
    expect_store(&c, SG_OK, NULL); /* every damage was undone */
    free_copy(&c);

    copy_store_of(w, 3, &c); /* the coloured cube */
    expect_store(&c, SG_OK, NULL);
    float *vc = c.owned[SG_SA_HY_COLOR], *nc = c.owned[SG_SA_HY_NODE_COLOR];
    vc[3 * 5 + 2] = INFINITY;
    expect_store(&c, SG_ERR_CORRUPT, "hybrid vertex colour 5 is not finite");
    vc[3 * 5 + 2] = 0.5f;
    nc[0] = NAN;
    expect_store(&c, SG_ERR_CORRUPT, "sphere-tree node colour 0 is not finite");
    free_copy(&c);

    /* The ground: two triangles with lattices of light sites (20 rows:
     * 231 sites each, after the mesh's 4 vertices; hybrid_int.h
     * invariant 4). A lattice that overlaps another, runs past the
     * vertices, or disagrees with the header's count is refused. */
    copy_store_of(w, 1, &c);
    expect_store(&c, SG_OK, NULL);
    assert_int_equal(c.store.items[SG_SA_HY_LATTICE], 2);
    assert_int_equal(c.store.items[SG_SA_HY_POS], 4 + 2 * 231);
    uint32_t *lat = c.owned[SG_SA_HY_LATTICE];
    assert_int_equal(lat[1], 20);
    assert_int_equal(lat[3], 20);
    assert_int_equal(lat[0], 4);
    assert_int_equal(lat[2], 4 + 231);
    lat[2] = 4 + 230; /* overlaps the first */
    expect_store(&c, SG_ERR_CORRUPT, "hybrid triangle 1: lattice of 20 rows at vertex 234 (expected at 235");
    lat[2] = 4 + 231;
    lat[3] = 21; /* runs past the vertices */
    expect_store(&c, SG_ERR_CORRUPT, "hybrid triangle 1: lattice of 21 rows");
    lat[3] = 19; /* too few sites for the header */
    expect_store(&c, SG_ERR_CORRUPT, "hybrid lattices hold 441 sites on 2 triangles; the header says 462 on 2");
    lat[3] = 0;
    expect_store(&c, SG_ERR_CORRUPT, "hybrid lattices hold 231 sites on 1 triangles");
    lat[3] = 20;
    const void *keep_lat = c.store.data[SG_SA_HY_LATTICE];
    c.store.data[SG_SA_HY_LATTICE] = NULL;
    expect_store(&c, SG_ERR_CORRUPT, "array YL is missing");
    c.store.data[SG_SA_HY_LATTICE] = keep_lat;
    expect_store(&c, SG_OK, NULL); /* every damage was undone */
    free_copy(&c);
    copy_store_of(w, 2, &c); /* the sphere: no lattice */
    c.store.data[SG_SA_HY_LATTICE] = c.store.data[SG_SA_HY_TRI_ID];
    c.store.items[SG_SA_HY_LATTICE] = c.store.items[SG_SA_HY_TRI_ID];
    expect_store(&c, SG_ERR_CORRUPT, "array YL on a hybrid surface that has none");
    free_copy(&c);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_world_file_roundtrip_same_bits),
        cmocka_unit_test(test_world_file_truncated),
        cmocka_unit_test(test_world_file_flipped_byte),
        cmocka_unit_test(test_world_file_newer_version),
        cmocka_unit_test(test_world_file_other_scene_and_bake),
        cmocka_unit_test(test_world_file_changed_input),
        cmocka_unit_test(test_world_file_failed_save),
        cmocka_unit_test(test_world_file_hybrid_roundtrip),
        cmocka_unit_test(test_world_file_hybrid_damaged),
        cmocka_unit_test(test_world_file_hybrid_lod_from_scene),
        cmocka_unit_test(test_world_file_load_nomem),
        cmocka_unit_test(test_world_file_iso_lod_from_scene),
        cmocka_unit_test(test_scene_store_nan),
        cmocka_unit_test(test_scene_store_links),
        cmocka_unit_test(test_scene_store_hybrid),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
