/* test_preflight.c — the checks before the long work: the memory
 * estimate (from point counts and headers, without loading) and its
 * refusal naming the figures, output folders and free space, and the bake
 * cache's verdicts from a bake file's header and age. */
#include "test_support.h"

#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "app/bake_cache.h"
#include "app/preflight.h"
#include "bake/bake.h"
#include "bake/bake_file.h"
#include "bake/bake_io.h"
#include "io/scene_file.h"
#include "render/world.h"

static sg_scene_file parse(const char *json)
{
    sg_scene_file sf;
    sg_error err = {0};
    if (sg_scene_file_parse(json, strlen(json), "t.json", NULL, &sf, &err) != SG_OK)
        fail_msg("%s", err.message);
    return sf;
}

/* "points": 1e9 used to start allocating (8.6 GB in 21 s) with no word. */
static void test_preflight_refuses_a_billion_points(void **state)
{
    (void)state;
    sg_scene_file sf = parse("{\"models\": [{\"builtin\": \"bunny\", \"points\": 1000000000}]}");
    sg_memory_estimate e;
    sg_error err = {0};
    assert_int_equal(sg_preflight_estimate(&sf, 0, &e, &err), SG_OK);
    assert_int_equal(e.points, 1000000000u);
    assert_true(e.bytes >= 1000000000ull * SG_PREFLIGHT_BYTES_PER_POINT);
    if (e.available == 0)
        skip(); /* no /proc/meminfo nor sysconf figures: nothing to compare */
    assert_true(e.available <= e.total);
    assert_int_equal(sg_preflight_memory("big.json", &e, &err), SG_ERR_NOMEM);
    assert_non_null(strstr(err.message, "big.json: the scene needs about 651.9 GiB (1000000000 splats x ~700 B"));
    assert_non_null(strstr(err.message, "GiB available"));
    assert_non_null(strstr(err.message, "\"points\""));
    sg_scene_file_free(&sf);
    /* The default scene fits anywhere this suite runs. */
    sf = parse("{\"models\": [{\"builtin\": \"bunny\"}, {\"builtin\": \"ground\"}]}");
    assert_int_equal(sg_preflight_estimate(&sf, 0, &e, &err), SG_OK);
    assert_int_equal(e.points, 250000 + 90000);
    assert_int_equal(sg_preflight_memory("small.json", &e, &err), SG_OK);
    sg_scene_file_free(&sf);
}

/* Point counts come from headers and sizes, not from loading. */
static void test_preflight_counts_from_headers(void **state)
{
    (void)state;
    static const char cloud_text[] = "ply\nformat binary_little_endian 1.0\nelement vertex 123456789\n"
                                     "property float x\nproperty float y\nproperty float z\nend_header\n";
    static const char mesh_text[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty "
                                    "float y\nproperty float z\nelement face 1\nproperty list uchar int "
                                    "vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    static const char pcd_text[] = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 77\nDATA ascii\n";
    char cloud[700], mesh[700], pcd[700];
    snprintf(cloud, sizeof cloud, "%s", sg_test_write_file("cloud.ply", cloud_text, sizeof cloud_text - 1));
    snprintf(mesh, sizeof mesh, "%s", sg_test_write_file("mesh.ply", mesh_text, sizeof mesh_text - 1));
    snprintf(pcd, sizeof pcd, "%s", sg_test_write_file("c.pcd", pcd_text, sizeof pcd_text - 1));
    char xyz[1000] = "# header\n";
    for (int i = 0; i < 40; i++)
        strcat(xyz, "1.5 2.5 3.5\n"); /* 12 bytes a line */
    const char *text = sg_test_write_file("c.xyz", xyz, strlen(xyz));
    char json[4096];
    snprintf(json, sizeof json,
             "{\"models\": [{\"path\": \"%s\"}, {\"path\": \"%s\", \"points\": 5000}, {\"path\": \"%s\"},"
             " {\"path\": \"%s\"}]}", cloud, mesh, pcd, text);
    sg_scene_file sf = parse(json);
    sg_memory_estimate e;
    sg_error err = {0};
    assert_int_equal(sg_preflight_estimate(&sf, 0, &e, &err), SG_OK);
    uint64_t want = 123456789u + 5000u + 77u + (9u + 40u * 12u) / 12u + 1u;
    if (e.points != want)
        fail_msg("points %llu, want %llu", (unsigned long long)e.points, (unsigned long long)want);
    sg_scene_file_free(&sf);
    snprintf(json, sizeof json, "{\"models\": [{\"path\": \"%s/absent.ply\"}]}", sg_test_tmpdir());
    sf = parse(json);
    assert_int_equal(sg_preflight_estimate(&sf, 0, &e, &err), SG_ERR_IO);
    assert_non_null(strstr(err.message, "absent.ply"));
    sg_scene_file_free(&sf);
}

static void test_preflight_output(void **state)
{
    (void)state;
    sg_error err = {0};
    char path[700];
    snprintf(path, sizeof path, "%s/out.sgbake", sg_test_tmpdir());
    assert_int_equal(sg_preflight_output(path, 1000, &err), SG_OK);
    struct stat st;
    assert_true(stat(path, &st) != 0); /* nothing left behind */
    snprintf(path, sizeof path, "%s/no/such/folder/out.png", sg_test_tmpdir());
    assert_int_equal(sg_preflight_output(path, 0, &err), SG_ERR_IO);
    assert_non_null(strstr(err.message, "cannot write in"));
    assert_non_null(strstr(err.message, "no/such/folder"));
    /* More than any disk has. */
    snprintf(path, sizeof path, "%s/huge.sgbake", sg_test_tmpdir());
    assert_int_equal(sg_preflight_output(path, 1ull << 62, &err), SG_ERR_IO);
    assert_non_null(strstr(err.message, "huge.sgbake: needs at least 4398046511104.0 MiB"));
    assert_true(sg_preflight_bake_bytes(1000, 10) == 12000 + 40 + 4096);
}

static void test_bake_cache(void **state)
{
    (void)state;
    sg_error err = {0};
    char buf[256];
    assert_int_equal(sg_bake_cache_path("scans/scan.v2.ply", NULL, buf, sizeof buf, &err), SG_OK);
    assert_string_equal(buf, "out/scan.v2.sgbake");
    assert_int_equal(sg_bake_cache_path("examples/bunny_sky.json", "renders/f.png", buf, sizeof buf, &err), SG_OK);
    assert_string_equal(buf, "renders/bunny_sky.sgbake");
    assert_int_equal(sg_bake_cache_path("scan", "f.png", buf, sizeof buf, &err), SG_OK);
    assert_string_equal(buf, "./scan.sgbake");
    assert_int_equal(sg_bake_cache_path("scan.ply", "/f.png", buf, sizeof buf, &err), SG_OK);
    assert_string_equal(buf, "//scan.sgbake");
    assert_int_equal(sg_bake_cache_path("a.json", "x/y.png", buf, 8, &err), SG_ERR_INVALID_ARG);

    /* A small real bake of a scene whose model is a file. */
    static const char cloud[] = "0 0 0\n1 0 0\n0 1 0\n1 1 0\n0.5 0.5 0.1\n0.2 0.7 0\n0.7 0.2 0\n0.3 0.3 0\n"
                                "0.9 0.6 0\n0.6 0.9 0\n0.1 0.4 0\n0.4 0.1 0\n";
    const char *model = sg_test_write_file("sheet.xyz", cloud, sizeof cloud - 1);
    char json[1024], path[700], why[600];
    snprintf(json, sizeof json, "{\"models\": [{\"path\": \"%s\"}, {\"builtin\": \"sphere\", \"points\": 500}]}",
             model);
    sg_scene_file sf = parse(json);
    snprintf(path, sizeof path, "%s/sheet.sgbake", sg_test_tmpdir());
    assert_int_equal(sg_bake_cache_fresh(path, &sf, why, sizeof why), 0);
    assert_string_equal(why, "no bake yet");
    sg_world *w = NULL;
    assert_int_equal(sg_world_create(&sf, &w, &err), SG_OK);
    sg_bake_desc d = {.photons = {.count = 4096}, .glossy_rays = 4, .direct_samples = 2};
    sg_bake *b = NULL;
    if (sg_bake_create(w, &d, &b, &err) != SG_OK)
        fail_msg("%s", err.message);
    /* Make the model file older than the bake for certain. */
    struct timespec old[2] = {{.tv_sec = time(NULL) - 100}, {.tv_sec = time(NULL) - 100}};
    assert_int_equal(utimensat(AT_FDCWD, model, old, 0), 0);
    assert_int_equal(sg_bake_save(b, path, sg_scene_file_hash(&sf, SG_SCENE_HASH_BAKE), &err), SG_OK);
    if (!sg_bake_cache_fresh(path, &sf, why, sizeof why))
        fail_msg("a bake just made is not fresh: %s", why);
    /* Another scene: the header says so, naming both hashes. */
    sg_scene_file other = parse("{\"models\": [{\"builtin\": \"sphere\"}]}");
    assert_int_equal(sg_bake_cache_fresh(path, &other, why, sizeof why), 0);
    assert_non_null(strstr(why, "sheet.sgbake"));
    sg_scene_file_free(&other);
    /* The model edited after the bake. */
    assert_int_equal(utimensat(AT_FDCWD, model, NULL, 0), 0);
    struct timespec older[2] = {{.tv_sec = time(NULL) - 50}, {.tv_sec = time(NULL) - 50}};
    assert_int_equal(utimensat(AT_FDCWD, path, older, 0), 0);
    assert_int_equal(sg_bake_cache_fresh(path, &sf, why, sizeof why), 0);
    assert_string_equal(why, "older than sheet.xyz");
    /* A damaged file. */
    assert_int_equal(truncate(path, 100), 0);
    assert_int_equal(sg_bake_cache_fresh(path, &sf, why, sizeof why), 0);
    assert_non_null(strstr(why, "sheet.sgbake"));
    /* A bake whose META does not hash to its header's parameter hash: made
     * by an older build whose estimators differed (SG_BAKE_ALGORITHM). */
    sg_bake_writer *wr = NULL;
    sg_bake_writer_desc wd = {.path = path, .scene_hash = sg_scene_file_hash(&sf, SG_SCENE_HASH_BAKE),
                              .param_hash = sg_bake_param_hash(&d) ^ 1};
    uint64_t meta[SG_BAKE_META_COUNT] = {3, 4096, 1, 8, 2, 64, 0, SG_PHOTON_BLOCK};
    assert_int_equal(sg_bake_writer_create(&wd, &wr, &err), SG_OK);
    assert_int_equal(sg_bake_writer_add_section(wr, "META", SG_BAKE_TYPE_U64, SG_BAKE_META_COUNT, meta, &err), SG_OK);
    assert_int_equal(sg_bake_writer_commit(wr, &err), SG_OK);
    sg_bake_writer_destroy(wr);
    assert_int_equal(utimensat(AT_FDCWD, model, old, 0), 0);
    assert_int_equal(sg_bake_cache_fresh(path, &sf, why, sizeof why), 0);
    assert_string_equal(why, "made by an older splatgi (its estimators have changed since)");
    sg_bake_destroy(b);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_preflight_refuses_a_billion_points),
        cmocka_unit_test(test_preflight_counts_from_headers),
        cmocka_unit_test(test_preflight_output),
        cmocka_unit_test(test_bake_cache),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
