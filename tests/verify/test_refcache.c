/* test_refcache.c — the verifier's converged reference and its disk cache.
 *
 * The cache must give back exactly what was rendered (float EXR), must be
 * used only for the same scene contents, camera, size and spp, and the
 * centred estimator must match sg_ref_path at pixel centres. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "ref/pathtrace.h"
#include "render/world.h"
#include "verify/cases.h"
#include "verify/refcache.h"

typedef struct fixture {
    sg_verify_case c;
    sg_world *w;
    char cache[4200];
} fixture;

static void setup(fixture *f, const char *name)
{
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/cases", sg_test_tmpdir());
    snprintf(f->cache, sizeof f->cache, "%s/cache_%s", sg_test_tmpdir(), name);
    sg_error err = {0};
    if (sg_verify_case_make(sg_verify_case_find("sphere_clean"), SG_SURFACE_MLS, 1, dir, &f->c, &err) != SG_OK)
        fail_msg("case: %s", err.message);
    if (sg_world_create(&f->c.scene, &f->w, &err) != SG_OK)
        fail_msg("world: %s", err.message);
}

static void teardown(fixture *f)
{
    sg_world_destroy(f->w);
    sg_verify_case_free(&f->c);
}

/* 1. First call renders and writes; second reads back the same bits. */
static void test_refcache_roundtrip_bit_exact(void **state)
{
    (void)state;
    fixture f;
    setup(&f, "roundtrip");
    sg_verify_ref_desc d = {.camera = f.c.camera, .width = 12, .height = 10, .spp = 4, .cache_dir = f.cache,
                            .scene_key = sg_verify_scene_key(&f.c.scene)};
    sg_ref_result a = {0}, b = {0};
    int cached = -1;
    char path[4200];
    sg_error err = {0};
    assert_int_equal(sg_verify_reference(f.w, &d, &a, &cached, path, sizeof path, &err), SG_OK);
    assert_int_equal(cached, 0);
    assert_int_equal(access(path, R_OK), 0);
    assert_int_equal(sg_verify_reference(f.w, &d, &b, &cached, NULL, 0, &err), SG_OK);
    assert_int_equal(cached, 1);
    assert_int_equal(b.mean.width, 12);
    assert_int_equal(b.mean.height, 10);
    assert_memory_equal(a.mean.data, b.mean.data, sizeof(float) * 3 * 12 * 10);
    assert_memory_equal(a.std_error.data, b.std_error.data, sizeof(float) * 3 * 12 * 10);
    assert_true(b.paths == (uint64_t)12 * 10 * 4);
    /* Pixel (5, 3) is the mean of its spp paths through the pixel centre. */
    sg_ref_desc rd = {.camera = f.c.camera, .width = 12, .height = 10, .spp = 4, .max_depth = 8, .rr_depth = 3,
                      .seed = 1};
    double sum = 0;
    uint64_t pixel = 3 * 12 + 5;
    for (int s = 0; s < 4; s++)
        sum += sg_ref_path(f.w, &rd, 5.5f, 3.5f, pixel * SG_REF_MAX_SPP + (uint64_t)s, NULL).y;
    if (fabs(sum / 4 - (double)a.mean.data[3 * pixel + 1]) > 1e-6 * fabs(sum / 4) + 1e-9)
        fail_msg("pixel (5,3) green: %.9g, sg_ref_path mean %.9g", (double)a.mean.data[3 * pixel + 1], sum / 4);
    sg_ref_result_free(&a);
    sg_ref_result_free(&b);
    teardown(&f);
}

/* 2. The key changes with every input that changes the image, and with
 * nothing else. */
static void test_refcache_key_covers_inputs(void **state)
{
    (void)state;
    fixture f;
    setup(&f, "key");
    sg_verify_ref_desc d = {.camera = f.c.camera, .width = 12, .height = 10, .spp = 4, .cache_dir = f.cache,
                            .scene_key = sg_verify_scene_key(&f.c.scene)};
    uint64_t k0 = sg_verify_ref_key(&d);
    sg_verify_ref_desc e = d;
    e.cache_dir = "elsewhere";
    assert_true(sg_verify_ref_key(&e) == k0);
    e = d, e.max_depth = 8, e.seed = 1; /* the defaults spelt out */
    assert_true(sg_verify_ref_key(&e) == k0);
    e = d, e.spp = 5;
    assert_true(sg_verify_ref_key(&e) != k0);
    e = d, e.width = 13;
    assert_true(sg_verify_ref_key(&e) != k0);
    e = d, e.height = 11;
    assert_true(sg_verify_ref_key(&e) != k0);
    e = d, e.seed = 2;
    assert_true(sg_verify_ref_key(&e) != k0);
    e = d, e.max_depth = 4;
    assert_true(sg_verify_ref_key(&e) != k0);
    e = d, e.camera.eye.x += 1e-3f;
    assert_true(sg_verify_ref_key(&e) != k0);
    e = d, e.scene_key ^= 1;
    assert_true(sg_verify_ref_key(&e) != k0);
    teardown(&f);
}

/* 3. The scene key covers the bytes of the model file, not only its name:
 * rewriting the PLY with one point moved changes it. */
static void test_refcache_scene_key_follows_file_contents(void **state)
{
    (void)state;
    char path[4200];
    snprintf(path, sizeof path, "%s/moved.ply", sg_test_tmpdir());
    float p[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    sg_error err = {0};
    assert_int_equal(sg_verify_write_ply(path, 4, p, NULL, &err), SG_OK);
    char json[4400];
    snprintf(json, sizeof json, "{\"models\": [{\"path\": \"%s\"}]}", path);
    sg_scene_file sf = {0};
    assert_int_equal(sg_scene_file_parse(json, strlen(json), "t", NULL, &sf, &err), SG_OK);
    uint64_t k0 = sg_verify_scene_key(&sf);
    assert_true(sg_verify_scene_key(&sf) == k0);
    p[4] = 0.5f;
    assert_int_equal(sg_verify_write_ply(path, 4, p, NULL, &err), SG_OK);
    assert_true(sg_verify_scene_key(&sf) != k0);
    sg_scene_file_free(&sf);
}

/* 4. A cache entry without its .txt (an interrupted write) is ignored. */
static void test_refcache_incomplete_entry_ignored(void **state)
{
    (void)state;
    fixture f;
    setup(&f, "incomplete");
    sg_verify_ref_desc d = {.camera = f.c.camera, .width = 8, .height = 8, .spp = 2, .cache_dir = f.cache,
                            .scene_key = sg_verify_scene_key(&f.c.scene)};
    sg_ref_result a = {0};
    int cached = -1;
    char path[4200], txt[4300];
    sg_error err = {0};
    assert_int_equal(sg_verify_reference(f.w, &d, &a, &cached, path, sizeof path, &err), SG_OK);
    sg_ref_result_free(&a);
    snprintf(txt, sizeof txt, "%.*s.txt", (int)(strlen(path) - 4), path);
    assert_int_equal(remove(txt), 0);
    assert_int_equal(sg_verify_reference(f.w, &d, &a, &cached, NULL, 0, &err), SG_OK);
    assert_int_equal(cached, 0);
    sg_ref_result_free(&a);
    teardown(&f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_refcache_roundtrip_bit_exact),
        cmocka_unit_test(test_refcache_key_covers_inputs),
        cmocka_unit_test(test_refcache_scene_key_follows_file_contents),
        cmocka_unit_test(test_refcache_incomplete_entry_ignored),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
