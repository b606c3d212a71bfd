/* test_alloc_faults.c — every allocation of a call, failed in turn.
 *
 * For n = 0, 1, 2, ... the n-th allocation through core/alloc fails
 * (sg_alloc__fail_after(n)). The call must answer SG_OK (when it needs
 * fewer than n + 1 allocations) or a clean SG_ERR_NOMEM with a message,
 * must not crash, and must free everything it took (sg_alloc__live back to
 * where it was). The loop ends at the first n that succeeds: from there on
 * no allocation is failed any more.
 */
#include "test_support.h"

#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "bake/bake.h"
#include "bake/bake_io.h"
#include "io/mesh.h"
#include "io/scene_file.h"
#include "render/world.h"

typedef sg_status (*faulty_call)(void *ctx, sg_error *err);

/* One run with the n-th allocation (and all after it) failing. */
static sg_status run_failing_at(const char *what, faulty_call call, void *ctx, long n)
{
    long live = sg_alloc__live();
    sg_error err = {0};
    sg_alloc__fail_after(n);
    sg_status st = call(ctx, &err);
    sg_alloc__fail_after(-1);
    if (st != SG_OK && st != SG_ERR_NOMEM)
        fail_msg("%s: allocation %ld failed: status %d instead of SG_ERR_NOMEM (%s)", what, n, (int)st, err.message);
    if (st == SG_ERR_NOMEM && err.message[0] == '\0')
        fail_msg("%s: allocation %ld failed: SG_ERR_NOMEM without a message", what, n);
    if (sg_alloc__live() != live)
        fail_msg("%s: allocation %ld failed (status %d): %ld blocks leaked", what, n, (int)st, sg_alloc__live() - live);
    return st;
}

enum { EVERY_UP_TO = 400, SPREAD = 400 };

/* Fails each allocation of call in turn and returns how many allocations a
 * successful run makes. A call that makes more than EVERY_UP_TO + SPREAD
 * allocations (a tree build allocates per node) has its first EVERY_UP_TO
 * failed one by one and SPREAD more spread evenly over the rest, with
 * odd offsets so that neither every left nor every right child is skipped:
 * the run is quadratic in the count otherwise. */
static long fail_each_allocation(const char *what, faulty_call call, void *ctx)
{
    sg_error err = {0};
    long live = sg_alloc__live();
    sg_alloc__fail_after(1000000000L);
    sg_status st = call(ctx, &err);
    long used = 1000000000L - sg_alloc__fail_after(-1);
    if (st != SG_OK)
        fail_msg("%s: fails with no fault injected: %s", what, err.message);
    assert_int_equal(sg_alloc__live(), live);
    for (long n = 0; n < used && n < EVERY_UP_TO; ++n)
        assert_int_equal(run_failing_at(what, call, ctx, n), SG_ERR_NOMEM);
    if (used > EVERY_UP_TO)
        for (long j = 0; j < SPREAD; ++j) {
            long n = EVERY_UP_TO + (used - EVERY_UP_TO) * j / SPREAD + (j % 3);
            if (n < used)
                assert_int_equal(run_failing_at(what, call, ctx, n), SG_ERR_NOMEM);
        }
    /* Failing past the last allocation changes nothing. */
    assert_int_equal(run_failing_at(what, call, ctx, used), SG_OK);
    return used;
}

static sg_status read_mesh(void *path, sg_error *err)
{
    sg_mesh m = {0};
    sg_status st = sg_mesh_read(path, &m, err);
    if (st == SG_OK)
        sg_mesh_free(&m);
    return st;
}

static const char PLY[] = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                          "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
                          "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                          "0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 9 9 9\n3 0 1 2\n4 0 2 3 1\n";

static const char OBJ[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -1 -2 -3\n";

static void test_alloc_faults_mesh_readers(void **state)
{
    (void)state;
    long ply = fail_each_allocation("ply", read_mesh, (void *)sg_test_write_file("quad.ply", PLY, strlen(PLY)));
    long obj = fail_each_allocation("obj", read_mesh, (void *)sg_test_write_file("quad.obj", OBJ, strlen(OBJ)));
    /* The loop really injected faults: both readers allocate. */
    assert_true(ply > 0);
    assert_true(obj > 0);
}

static const char SCENE[] = "{\"models\":[{\"builtin\":\"sphere\",\"points\":400,\"material\":{\"albedo\":[0.5,0.5,0.5]}},"
                            "{\"builtin\":\"sphere\",\"points\":300,\"surface\":{\"model\":\"disk\"},\"transform\":{\"translate\":[3,0,0]}}],"
                            "\"envmap\":{\"builtin\":\"sky\"}}";

static sg_status build_world(void *text, sg_error *err)
{
    sg_scene_file sf = {0};
    sg_status st = sg_scene_file_parse(text, strlen(text), "faults.json", NULL, &sf, err);
    if (st != SG_OK)
        return st;
    sg_world *w = NULL;
    st = sg_world_create(&sf, &w, err);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
    return st;
}

static void test_alloc_faults_world_from_scene_file(void **state)
{
    (void)state;
    long n = fail_each_allocation("world", build_world, (void *)SCENE);
    assert_true(n > 10); /* points, kNN, normals, tree, envmap tables... */
}

/* The bake: a glossy and a diffuse model, so that sample points, glossy
 * bins and their file sections are all allocated. The world is built once,
 * outside the faults. */
typedef struct bake_ctx {
    const sg_world *w;
    const char *path;
} bake_ctx;

static sg_bake_desc small_bake(void)
{
    return (sg_bake_desc){.photons = {.count = 4096, .seed = 3, .threads = 1},
                          .gather = {.k = 16, .threads = 1},
                          .direct_samples = 2,
                          .glossy_rays = 8};
}

static sg_status bake_and_save(void *p, sg_error *err)
{
    const bake_ctx *c = p;
    sg_bake_desc d = small_bake();
    sg_bake *b = NULL;
    sg_status st = sg_bake_create(c->w, &d, &b, err);
    if (st == SG_OK)
        st = sg_bake_save(b, c->path, 77, err);
    sg_bake_destroy(b);
    return st;
}

static sg_status load_bake(void *p, sg_error *err)
{
    const bake_ctx *c = p;
    sg_bake *b = NULL;
    sg_status st = sg_bake_load(c->path, c->w, 77, &b, err);
    sg_bake_destroy(b);
    return st;
}

static const char GLOSSY_SCENE[] =
    "{\"models\":[{\"builtin\":\"sphere\",\"points\":500,"
    "\"material\":{\"type\":\"ggx\",\"roughness\":0.5,\"specular\":0.3}},"
    "{\"builtin\":\"sphere\",\"points\":300,\"transform\":{\"translate\":[2.5,0,0]}}],"
    "\"envmap\":{\"builtin\":\"sky\"}}";

static void test_alloc_faults_bake_save_load(void **state)
{
    (void)state;
    sg_scene_file sf = {0};
    sg_error err = {0};
    assert_int_equal(sg_scene_file_parse(GLOSSY_SCENE, strlen(GLOSSY_SCENE), "g.json", NULL, &sf, &err), SG_OK);
    sg_world *w = NULL;
    assert_int_equal(sg_world_create(&sf, &w, &err), SG_OK);
    char path[1024];
    snprintf(path, sizeof path, "%s/faults.sgbake", sg_test_tmpdir());
    bake_ctx c = {w, path};
    assert_true(fail_each_allocation("bake", bake_and_save, &c) > 0);
    assert_true(fail_each_allocation("bake load", load_bake, &c) > 0);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_alloc_faults_mesh_readers),
        cmocka_unit_test(test_alloc_faults_world_from_scene_file),
        cmocka_unit_test(test_alloc_faults_bake_save_load),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
