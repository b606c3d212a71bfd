/* test_bake_io.c — bakes and checkpoints in files (bake/bake_io.h), and the
 * photon pass in block ranges with progress and cancel (bake/photons.h):
 *  1. save/load round trip: same irradiance bits, same frame, same figures;
 *  2. a bake for another scene, a truncated or corrupted file, a model or
 *     splat count that differs from the world, a NaN irradiance, a
 *     checkpoint given as a bake: each a clean error naming the file;
 *  3. resume: photon blocks traced in parts equal one pass bit for bit;
 *     a bake job stopped anywhere (every stage, each estimator), saved,
 *     loaded and finished on another thread count writes the same bytes as
 *     one run straight through;
 *  4. the progress callback is called, counts up to the total, and a
 *     nonzero return cancels with the completed prefix kept;
 *  5. glossy bakes: bins, sample points and the new parameters round trip;
 *     damaged glossy sections and the old META layout are named. */
#include "test_support.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake/bake.h"
#include "bake/bake_file.h"
#include "bake/bake_io.h"
#include "bake/bake_job.h"
#include "core/alloc.h"
#include "render/world.h"

static const uint64_t SCENE_HASH = 0x5ce9e0000000001ull;

/* A sphere of `sphere_points` splats over a ground of 3000. */
static sg_world *small_world(int sphere_points)
{
    char json[512];
    snprintf(json, sizeof json,
             "{\"models\":[{\"builtin\":\"sphere\",\"points\":%d,\"transform\":{\"translate\":[0,1,0]}},"
             "{\"builtin\":\"ground\",\"points\":3000}],\"envmap\":{\"builtin\":\"sky\"}}",
             sphere_points);
    return sg_test_world_from_json(json);
}

static sg_bake_desc bake_desc(size_t photons)
{
    /* Resolved: a bake's photon pass is traced with the resolved desc (its
     * flags say whether photons record direct light). */
    sg_bake_desc d = {.indirect = SG_BAKE_INDIRECT_PHOTONS, .photons = {.count = photons, .seed = 7, .max_depth = 6},
                      .gather = {.k = 32}};
    return sg_bake_desc_resolve(&d);
}

static sg_bake *make_bake(const sg_world *w, size_t photons)
{
    sg_bake_desc d = bake_desc(photons);
    sg_bake *b = NULL;
    sg_error err = {0};
    if (sg_bake_create(w, &d, &b, &err) != SG_OK)
        fail_msg("bake: %s", err.message);
    return b;
}

static void render(const sg_bake *b, const sg_world *w, sg_image *img)
{
    sg_bake_frame_desc fd = {.width = 24, .height = 24};
    if (sg_camera_look_at(sg_v3(0, 2.5f, 4.0f), sg_v3(0, 0.8f, 0), sg_v3(0, 1, 0), 40.0f, 1.0f, &fd.camera, NULL) !=
        SG_OK)
        fail_msg("camera");
    assert_int_equal(sg_bake_render(b, w, &fd, img, NULL, NULL), SG_OK);
}

static unsigned char *read_all(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        fail_msg("cannot open %s", path);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *size = (size_t)n;
    return buf;
}

/* Saves b under sg_test_tmp_path(name) and checks the file is the same bytes as
 * the file at `expected`. */
static void assert_saves_as(const sg_bake *b, const char *name, const char *expected)
{
    sg_error err = {0};
    const char *path = sg_test_tmp_path(name);
    if (sg_bake_save(b, path, SCENE_HASH, &err) != SG_OK)
        fail_msg("save %s: %s", path, err.message);
    size_t n1, n2;
    unsigned char *f1 = read_all(expected, &n1), *f2 = read_all(path, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(f1, f2, n1);
    free(f1);
    free(f2);
}

static void write_all(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, size, f), size);
    assert_int_equal(fclose(f), 0);
}

static void expect_load_fails(const char *path, const sg_world *w, uint64_t hash, sg_status want, const char *what)
{
    sg_bake *b = (sg_bake *)(uintptr_t)1; /* must stay untouched */
    sg_error err = {0};
    sg_status st = sg_bake_load(path, w, hash, &b, &err);
    if (st != want || !strstr(err.message, path) || (what && !strstr(err.message, what)))
        fail_msg("load %s: got %s \"%s\", expected %s with \"%s\" and the path", path, sg_status_name(st),
                 err.message, sg_status_name(want), what ? what : "");
    assert_ptr_equal(b, (sg_bake *)(uintptr_t)1);
}

static void assert_maps_equal(const sg_photon_map *a, const sg_photon_map *b)
{
    if (a->count != b->count || a->blocks != b->blocks || a->shot != b->shot)
        fail_msg("maps differ: %zu/%zu records, %zu/%zu blocks, %zu/%zu shot", a->count, b->count, a->blocks,
                 b->blocks, a->shot, b->shot);
    const float *fa[12] = {a->px, a->py, a->pz, a->nx, a->ny, a->nz, a->wx, a->wy, a->wz, a->fr, a->fg, a->fb};
    const float *fb[12] = {b->px, b->py, b->pz, b->nx, b->ny, b->nz, b->wx, b->wy, b->wz, b->fr, b->fg, b->fb};
    for (int k = 0; k < 12; ++k)
        if (memcmp(fa[k], fb[k], a->count * sizeof(float)) != 0)
            fail_msg("photon array %d differs", k);
    assert_memory_equal(a->model, b->model, a->count * sizeof(uint32_t));
    assert_memory_equal(&a->rays, &b->rays, sizeof a->rays);
}

/* 1. Save, load: the same irradiance bits, frame, parameters and figures. */
static void test_bake_io_roundtrip(void **state)
{
    (void)state;
    sg_world *w = small_world(4000);
    sg_bake *b = make_bake(w, 40000);
    const char *path = sg_test_tmp_path("round.sgbake");
    sg_error err = {0};
    assert_int_equal(sg_bake_save(b, path, SCENE_HASH, &err), SG_OK);
    sg_bake *c = NULL;
    if (sg_bake_load(path, w, SCENE_HASH, &c, &err) != SG_OK)
        fail_msg("load: %s", err.message);
    assert_int_equal(sg_bake_model_count(c), sg_world_model_count(w));
    for (uint32_t m = 0; m < sg_bake_model_count(b); ++m) {
        size_t nb, nc;
        const float *eb = sg_bake_light_data(b, m, &nb), *ec = sg_bake_light_data(c, m, &nc);
        assert_int_equal(nb, nc);
        assert_memory_equal(eb, ec, SG_BAKE_SPLAT_FLOATS * nb * sizeof(float));
    }
    sg_image ib, ic;
    render(b, w, &ib);
    render(c, w, &ic);
    assert_memory_equal(ib.data, ic.data, sizeof(float) * 3 * 24 * 24);
    sg_bake_stats sb, sc;
    sg_bake_get_stats(b, &sb);
    sg_bake_get_stats(c, &sc);
    assert_int_equal(sb.photons_shot, sc.photons_shot);
    assert_int_equal(sb.photon_records, sc.photon_records);
    assert_int_equal(sb.splats, sc.splats);
    assert_memory_equal(&sb.rays, &sc.rays, sizeof sb.rays);
    sg_bake_desc db = sg_bake_get_desc(b), dc = sg_bake_get_desc(c);
    assert_int_equal(sg_bake_param_hash(&db), sg_bake_param_hash(&dc));
    assert_int_equal(dc.photons.count, 40000);
    assert_int_equal(dc.photons.seed, 7);
    assert_int_equal(dc.gather.k, 32);
    /* Saving the loaded bake gives the same bytes (invariant 1). */
    assert_saves_as(c, "round2.sgbake", path);
    sg_image_free(&ib);
    sg_image_free(&ic);
    sg_bake_destroy(b);
    sg_bake_destroy(c);
    sg_world_destroy(w);
}

/* Defaults spelt out hash like defaults left 0; threads and progress do
 * not count; every value parameter does. */
static void test_bake_io_param_hash(void **state)
{
    (void)state;
    sg_bake_desc zero = {0};
    sg_bake_desc spelt = {.photons = {.count = 1000000, .seed = 1, .max_depth = 8, .rr_depth = 2, .threads = 3},
                          .gather = {.k = 64, .normal_cos = 0.7f, .threads = 5}};
    assert_int_equal(sg_bake_param_hash(&zero), sg_bake_param_hash(&spelt));
    assert_int_equal(sg_bake_param_hash(NULL), sg_bake_param_hash(&spelt));
    sg_bake_desc v[9];
    for (int i = 0; i < 9; ++i)
        v[i] = spelt;
    v[0].photons.count = 1000001;
    v[1].photons.seed = 2;
    v[2].photons.max_depth = 9;
    v[3].photons.rr_depth = 3;
    v[4].gather.k = 65;
    v[5].gather.normal_cos = 0.71f;
    v[6].sample_spacing = 3.0f;
    v[7].glossy_res = 12;
    v[8].glossy_rays = 64;
    /* 0 means "from the material" and < 0 "every splat": both differ from
     * an explicit spacing; glossy rays 128 is the default spelt out. */
    sg_bake_desc every = spelt, rays = spelt;
    every.sample_spacing = -5.0f;
    rays.glossy_rays = 128;
    assert_int_equal(sg_bake_param_hash(&rays), sg_bake_param_hash(&spelt));
    assert_true(sg_bake_param_hash(&every) != sg_bake_param_hash(&spelt));
    for (int i = 0; i < 9; ++i)
        if (sg_bake_param_hash(&v[i]) == sg_bake_param_hash(&spelt))
            fail_msg("changing parameter %d leaves the hash", i);
}

/* The ray cone (issues 13, 15): off (0 = the default while
 * SG_BAKE_RAY_CONE_DEFAULT is 0, or < 0) keeps the key every bake had
 * before the option: the defaults' key and a photon bake's are the values
 * the build without the option gives (main e5d2cfb's keys were
 * 0x63938bff59e2a7d4 and 0xede08c9fb5db8bb5; SG_BAKE_ALGORITHM 6, 7 and 8,
 * raised since, move both; sg_bake_param_hash is integer arithmetic
 * over the resolved fields: the same on every machine). On, each value is its own
 * key, and a bake saved with it loads with it (META element 27), while
 * one without it writes 0 there, as before. */
static void test_bake_io_ray_cone_key(void **state)
{
    (void)state;
    sg_bake_desc zero = {0}, off = {.ray_cone = -1.0f}, nan_cone = {.ray_cone = NAN};
    sg_bake_desc photons = {.indirect = SG_BAKE_INDIRECT_PHOTONS, .sample_spacing = 3.0f};
    const uint64_t main_default = 0xfe796f2c908f1a79ull, main_photons = 0x4ad0e1bad6a96a18ull;
    if (SG_BAKE_RAY_CONE_DEFAULT <= 0.0f && sg_bake_param_hash(&zero) != main_default)
        fail_msg("default key %016llx, main's %016llx", (unsigned long long)sg_bake_param_hash(&zero),
                 (unsigned long long)main_default);
    assert_true(sg_bake_param_hash(&off) == main_default);
    assert_true(sg_bake_param_hash(&nan_cone) == main_default);
    if (sg_bake_param_hash(&photons) != main_photons)
        fail_msg("photon key %016llx, main's %016llx", (unsigned long long)sg_bake_param_hash(&photons),
                 (unsigned long long)main_photons);
    sg_bake_desc one = {.ray_cone = 1.0f}, two = {.ray_cone = 2.0f};
    assert_true(sg_bake_param_hash(&one) != main_default);
    assert_true(sg_bake_param_hash(&two) != main_default);
    assert_true(sg_bake_param_hash(&one) != sg_bake_param_hash(&two));
    assert_true(sg_bake_desc_resolve(&off).ray_cone == -1.0f);
    assert_true(sg_bake_desc_resolve(&two).ray_cone == 2.0f);

    sg_world *w = small_world(2000);
    sg_bake_desc d = bake_desc(8192);
    d.ray_cone = 2.0f;
    sg_bake *b = NULL;
    sg_error err = {0};
    if (sg_bake_create(w, &d, &b, &err) != SG_OK)
        fail_msg("bake: %s", err.message);
    const char *path = sg_test_tmp_path("cone.sgbake");
    assert_int_equal(sg_bake_save(b, path, SCENE_HASH, &err), SG_OK);
    sg_bake *c = NULL;
    if (sg_bake_load(path, w, SCENE_HASH, &c, &err) != SG_OK)
        fail_msg("load: %s", err.message);
    sg_bake_desc dc = sg_bake_get_desc(c);
    assert_true(dc.ray_cone == 2.0f);
    assert_true(sg_bake_param_hash(&dc) == sg_bake_param_hash(&d));
    sg_bake_destroy(c);
    sg_bake_destroy(b);
    d.ray_cone = -1.0f;
    if (sg_bake_create(w, &d, &b, &err) != SG_OK)
        fail_msg("bake: %s", err.message);
    assert_int_equal(sg_bake_save(b, path, SCENE_HASH, &err), SG_OK);
    if (sg_bake_load(path, w, SCENE_HASH, &c, &err) != SG_OK)
        fail_msg("load: %s", err.message);
    assert_true(sg_bake_get_desc(c).ray_cone == -1.0f);
    sg_bake_file *f = NULL;
    assert_int_equal(sg_bake_file_open(path, SCENE_HASH, 0, &f, &err), SG_OK);
    uint64_t meta[SG_BAKE_META_COUNT];
    assert_int_equal(sg_bake_file_read(f, "META", meta, sizeof meta, &err), SG_OK);
    assert_true(meta[27] == 0);
    sg_bake_file_close(f);
    sg_bake_destroy(c);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* 2. Another scene: bake_file's message, naming the file. */
static void test_bake_io_other_scene(void **state)
{
    (void)state;
    sg_world *w = small_world(2000);
    sg_bake *b = make_bake(w, 8192);
    const char *path = sg_test_tmp_path("scene.sgbake");
    assert_int_equal(sg_bake_save(b, path, SCENE_HASH, NULL), SG_OK);
    expect_load_fails(path, w, SCENE_HASH + 1, SG_ERR_INVALID_ARG, "made for another scene");
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* 2. Truncated at every structural boundary and mid-payload, one byte
 * flipped in a payload, a missing file: clean errors naming the file. */
static void test_bake_io_truncated_or_corrupt(void **state)
{
    (void)state;
    sg_world *w = small_world(2000);
    sg_bake *b = make_bake(w, 8192);
    const char *path = sg_test_tmp_path("good.sgbake");
    assert_int_equal(sg_bake_save(b, path, SCENE_HASH, NULL), SG_OK);
    size_t n;
    unsigned char *bytes = read_all(path, &n);
    const size_t cuts[] = {0, 10, 47, 48, 100, n / 2, n - 1};
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; ++i) {
        const char *cut = sg_test_tmp_path("cut.sgbake");
        write_all(cut, bytes, cuts[i]);
        expect_load_fails(cut, w, SCENE_HASH, SG_ERR_CORRUPT, NULL);
    }
    const char *flipped = sg_test_tmp_path("flip.sgbake");
    bytes[n - 5] ^= 0x40; /* inside the last irradiance section */
    write_all(flipped, bytes, n);
    expect_load_fails(flipped, w, SCENE_HASH, SG_ERR_CORRUPT, "checksum mismatch");
    expect_load_fails(sg_test_tmp_path("missing.sgbake"), w, SCENE_HASH, SG_ERR_IO, NULL);
    free(bytes);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* 2. A bake loaded into a world whose models have other splat counts, or
 * another number of models (same scene hash given: the counts are the
 * check of last resort). */
static void test_bake_io_splat_count_mismatch(void **state)
{
    (void)state;
    sg_world *w = small_world(2000), *w2 = small_world(2100);
    size_t have = sg_scene_sites(sg_world_scene(w, 0))->count, want = sg_scene_sites(sg_world_scene(w2, 0))->count;
    assert_true(have != want);
    sg_bake *b = make_bake(w, 8192);
    const char *path = sg_test_tmp_path("count.sgbake");
    assert_int_equal(sg_bake_save(b, path, SCENE_HASH, NULL), SG_OK);
    char msg[256];
    snprintf(msg, sizeof msg, "%s: model 0 has %zu light sites in the bake, %zu in the scene", path, have, want);
    expect_load_fails(path, w2, SCENE_HASH, SG_ERR_INVALID_ARG, msg);
    sg_world *one = sg_test_world_from_json("{\"models\":[{\"builtin\":\"ground\",\"points\":3000}]}");
    snprintf(msg, sizeof msg, "%s: 2 models in the bake, 1 in the scene", path);
    expect_load_fails(path, one, SCENE_HASH, SG_ERR_INVALID_ARG, msg);
    sg_world_destroy(one);
    sg_bake_destroy(b);
    sg_world_destroy(w);
    sg_world_destroy(w2);
}

/* Copies the file at src to dst section by section (fresh CRCs), with
 * value v written over float element `elem` of section `tag`, and the
 * header flags given. */
static void rewrite(const char *src, const char *dst, const char *tag, size_t elem, float v, uint32_t flags)
{
    sg_bake_file *f = NULL;
    sg_error err = {0};
    if (sg_bake_file_open(src, 0, 0, &f, &err) != SG_OK)
        fail_msg("%s", err.message);
    const sg_bake_info *info = sg_bake_file_info(f);
    sg_bake_writer *wr = NULL;
    sg_bake_writer_desc wd = {.path = dst, .scene_hash = info->scene_hash, .param_hash = info->param_hash,
                              .flags = flags, .max_sections = info->section_count};
    assert_int_equal(sg_bake_writer_create(&wd, &wr, &err), SG_OK);
    for (uint32_t i = 0; i < info->section_count; ++i) {
        const sg_bake_section *s = sg_bake_file_section(f, i);
        unsigned char *buf = malloc(s->size + 1);
        assert_int_equal(sg_bake_file_read(f, s->tag, buf, s->size, &err), SG_OK);
        if (!strcmp(s->tag, tag))
            memcpy(buf + 4 * elem, &v, 4);
        assert_int_equal(sg_bake_writer_add_section(wr, s->tag, s->type, s->count, buf, &err), SG_OK);
        free(buf);
    }
    assert_int_equal(sg_bake_writer_commit(wr, &err), SG_OK);
    sg_bake_writer_destroy(wr);
    sg_bake_file_close(f);
}

/* 2. Values the checksums cannot catch (a writer's bug): NaN or negative
 * irradiance, named by model and splat; a checkpoint given as a bake. */
static void test_bake_io_bad_values(void **state)
{
    (void)state;
    sg_world *w = small_world(2000);
    sg_bake *b = make_bake(w, 8192);
    const char *path = sg_test_tmp_path("values.sgbake"), *bad = sg_test_tmp_path("bad.sgbake");
    assert_int_equal(sg_bake_save(b, path, SCENE_HASH, NULL), SG_OK);
    char msg[256];
    rewrite(path, bad, "E001", SG_BAKE_SPLAT_FLOATS * 17 + 1, NAN, 0);
    snprintf(msg, sizeof msg, "%s: model 1, splat 17: front visibility ratio is NaN", bad);
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_CORRUPT, msg);
    rewrite(path, bad, "E000", SG_BAKE_SPLAT_FLOATS * 5 + 10, -1.0f, 0);
    snprintf(msg, sizeof msg, "%s: model 0, splat 5: back indirect irradiance is negative", bad);
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_CORRUPT, msg);
    rewrite(path, bad, "E000", 3, INFINITY, 0);
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_CORRUPT, "model 0, splat 0: front indirect irradiance is infinite");
    rewrite(path, bad, "none", 0, 0.0f, SG_BAKE_FLAG_CHECKPOINT);
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_INVALID_ARG, "a checkpoint of an unfinished bake");
    /* META that contradicts the header's parameter hash */
    rewrite(path, bad, "META", 2 * 2, 1.0f, 0); /* low half of the seed */
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_CORRUPT, "section META hashes to");
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* A GGX sphere over a ground: the glossy sections are written. */
static sg_world *glossy_world(void)
{
    return sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":3000,\"transform\":{\"translate\":"
                           "[0,1,0]},\"material\":{\"type\":\"ggx\",\"roughness\":0.3,\"specular\":0.3}},"
                           "{\"builtin\":\"ground\",\"points\":3000}],\"envmap\":{\"builtin\":\"sunsky\"}}");
}

static sg_bake *make_glossy_bake(const sg_world *w)
{
    sg_bake_desc d = bake_desc(8192);
    d.sample_spacing = 3.0f;
    d.glossy_res = 8;
    d.glossy_rays = 48;
    sg_bake *b = NULL;
    sg_error err = {0};
    if (sg_bake_create(w, &d, &b, &err) != SG_OK)
        fail_msg("bake: %s", err.message);
    return b;
}

/* 1. Glossy bake: sample counts, bins, sample splats and per-splat sample
 * indices, the new parameters, and the frame survive save and load. */
static void test_bake_io_glossy_roundtrip(void **state)
{
    (void)state;
    sg_world *w = glossy_world();
    sg_bake *b = make_glossy_bake(w);
    const char *path = sg_test_tmp_path("glossy.sgbake");
    sg_error err = {0};
    assert_int_equal(sg_bake_save(b, path, SCENE_HASH, &err), SG_OK);
    sg_bake *c = NULL;
    if (sg_bake_load(path, w, SCENE_HASH, &c, &err) != SG_OK)
        fail_msg("load: %s", err.message);
    for (uint32_t m = 0; m < 2; ++m) {
        assert_int_equal(sg_bake_sample_count(b, m), sg_bake_sample_count(c, m));
        assert_true(sg_bake_sample_count(b, m) > 0);
        int rb, rc;
        size_t nb = 0, nc = 0, splats;
        const uint32_t *sb, *sc, *qb, *qc;
        const uint16_t *gb, *gc;
        sg_bake_light_data(b, m, &splats);
        sg_bake_glossy_data(b, m, &rb, &nb, &sb, &qb, &gb);
        sg_bake_glossy_data(c, m, &rc, &nc, &sc, &qc, &gc);
        assert_int_equal(rb, rc);
        assert_int_equal(rb, m == 0 ? 8 : 0);
        if (!rb)
            continue;
        assert_int_equal(nb, nc);
        assert_memory_equal(sb, sc, nb * sizeof *sb);
        assert_memory_equal(qb, qc, splats * sizeof *qb);
        assert_memory_equal(gb, gc, nb * 3 * 64 * sizeof *gb);
    }
    sg_bake_stats sb, sc;
    sg_bake_get_stats(b, &sb);
    sg_bake_get_stats(c, &sc);
    assert_int_equal(sb.sample_points, sc.sample_points);
    assert_int_equal(sb.glossy_points, sc.glossy_points);
    assert_int_equal(sb.memory_bytes, sc.memory_bytes);
    assert_int_equal(sb.glossy_bytes, sb.glossy_points * 3 * 64 * 2);
    sg_bake_desc dc = sg_bake_get_desc(c);
    assert_true(dc.sample_spacing == 3.0f);
    assert_int_equal(dc.glossy_res, 8);
    assert_int_equal(dc.glossy_rays, 48);
    sg_image ib, ic;
    render(b, w, &ib);
    render(c, w, &ic);
    assert_memory_equal(ib.data, ic.data, sizeof(float) * 3 * 24 * 24);
    assert_saves_as(c, "glossy2.sgbake", path);
    sg_image_free(&ib);
    sg_image_free(&ic);
    sg_bake_destroy(b);
    sg_bake_destroy(c);
    sg_world_destroy(w);
}

static float float_of_bits(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* 2. A damaged glossy section is named: a flipped byte (checksum), a
 * non-finite bin, a splat pointing past the sample points; a file of
 * META layout 2 (before sample points) is refused with a message. */
static void test_bake_io_glossy_corrupt(void **state)
{
    (void)state;
    sg_world *w = glossy_world();
    sg_bake *b = make_glossy_bake(w);
    const char *path = sg_test_tmp_path("gbad.sgbake"), *bad = sg_test_tmp_path("gbad2.sgbake");
    assert_int_equal(sg_bake_save(b, path, SCENE_HASH, NULL), SG_OK);
    sg_bake_file *f = NULL;
    assert_int_equal(sg_bake_file_open(path, 0, 0, &f, NULL), SG_OK);
    const sg_bake_section *gs = sg_bake_file_find(f, "G000");
    assert_non_null(gs);
    uint64_t off = gs->offset + gs->size / 2;
    sg_bake_file_close(f);
    size_t n;
    unsigned char *bytes = read_all(path, &n);
    bytes[off] ^= 0x10;
    write_all(bad, bytes, n);
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_CORRUPT, "section G000: checksum mismatch");
    free(bytes);
    char msg[300];
    rewrite(path, bad, "G000", 0, float_of_bits(0x7fc00000u), 0); /* halves 0x0000, 0x7fc0 */
    snprintf(msg, sizeof msg, "%s: section G000: sample point 0, bin 0: value is not finite", bad);
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_CORRUPT, msg);
    rewrite(path, bad, "N000", 17, float_of_bits(0xffffffffu), 0);
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_CORRUPT, "section N000: splat 17 names sample point 4294967295");
    rewrite(path, bad, "P000", 0, float_of_bits(3000000u), 0);
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_CORRUPT, "section P000: sample point 0 names splat 3000000");
    rewrite(path, bad, "META", 0, float_of_bits(2u), 0);
    expect_load_fails(bad, w, SCENE_HASH, SG_ERR_UNSUPPORTED,
                      "section META: layout 2, this build reads 4 (made before light per side and the transport solve; "
                      "bake again)");
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* 3a. Photon blocks [0, n/2) on 1 thread and then [n/2, n) on 2 threads
 * equal the one-pass map bit for bit, and make the same bake file. */
static void test_bake_io_photons_in_parts_equal_one_pass(void **state)
{
    (void)state;
    sg_world *w = small_world(4000);
    sg_bake_desc d = bake_desc(100000);
    size_t nb = sg_photon_block_count(&d.photons);
    assert_int_equal(nb, 25);
    sg_error err = {0};
    sg_photon_map one = {0}, parts = {0};
    d.photons.threads = 2;
    assert_int_equal(sg_photons_trace(w, &d.photons, &one, &err), SG_OK);
    assert_int_equal(one.blocks, nb);
    assert_int_equal(one.shot, 100000);
    d.photons.threads = 1;
    assert_int_equal(sg_photons_trace_more(w, &d.photons, nb / 2, &parts, &err), SG_OK);
    assert_int_equal(parts.blocks, nb / 2);
    assert_int_equal(parts.shot, (nb / 2) * SG_PHOTON_BLOCK);
    d.photons.threads = 2;
    assert_int_equal(sg_photons_trace_more(w, &d.photons, nb, &parts, &err), SG_OK);
    assert_maps_equal(&one, &parts);
    sg_bake *b1 = NULL, *b2 = NULL;
    assert_int_equal(sg_bake_create_from_photons(w, &d, &one, &b1, &err), SG_OK);
    assert_int_equal(sg_bake_create_from_photons(w, &d, &parts, &b2, &err), SG_OK);
    const char *p1 = sg_test_tmp_path("one.sgbake");
    assert_int_equal(sg_bake_save(b1, p1, SCENE_HASH, &err), SG_OK);
    assert_saves_as(b2, "parts.sgbake", p1);
    sg_bake *b3 = make_bake(w, 100000); /* sg_bake_create, one call */
    assert_saves_as(b3, "create.sgbake", p1);
    /* an incomplete map does not make a bake */
    sg_photon_map part = {0};
    assert_int_equal(sg_photons_trace_more(w, &d.photons, 3, &part, &err), SG_OK);
    sg_bake *none = NULL;
    assert_int_equal(sg_bake_create_from_photons(w, &d, &part, &none, &err), SG_ERR_INVALID_ARG);
    assert_null(none);
    sg_photon_map_free(&part);
    sg_bake_destroy(b1);
    sg_bake_destroy(b2);
    sg_bake_destroy(b3);
    sg_photon_map_free(&one);
    sg_photon_map_free(&parts);
    sg_world_destroy(w);
}

/* A job's progress calls: where each was, and a stop on call `stop_at`. */
typedef struct job_calls {
    int n, stop_at;
    sg_bake_progress at[4096];
} job_calls;

static int on_job_progress(void *user, const sg_bake_progress *p)
{
    job_calls *c = user;
    if (c->n < 4096)
        c->at[c->n] = *p;
    c->n++;
    return c->stop_at && c->n >= c->stop_at;
}

/* A glossy sphere on the ground, so that every stage has work: photons
 * (with the photon estimator), three levels of sample sites, glossy bins. */
static sg_world *job_world(void)
{
    return sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":3000,"
                                   "\"transform\":{\"translate\":[0,1,0]},\"material\":{\"type\":\"ggx\","
                                   "\"roughness\":0.5,\"specular\":0.3}},{\"builtin\":\"ground\",\"points\":3000}],"
                                   "\"envmap\":{\"builtin\":\"sunsky\"}}");
}

/* 3b. A job stopped at progress call k, saved, loaded and run to the end
 * on another thread count writes the same bake file as one run straight
 * through: for each estimator, at the first call of every stage and level
 * and in the middle of the longest ones. */
static void check_resume_everywhere(sg_bake_indirect indirect)
{
    sg_world *w = job_world();
    sg_bake_desc d = {.indirect = indirect, .photons = {.count = 40000, .seed = 3, .progress_seconds = -1.0},
                      .gather = {.k = 32}, .direct_samples = 8, .gather_rays = 8, .glossy_rays = 16};
    sg_error err = {0};
    sg_bake_job *j = NULL;
    job_calls *all = test_calloc(1, sizeof *all), *c = test_calloc(1, sizeof *c);
    assert_int_equal(sg_bake_job_create(w, &d, &j, &err), SG_OK);
    assert_int_equal(sg_bake_job_run(j, on_job_progress, all, &err), SG_OK);
    sg_bake *whole = NULL;
    assert_int_equal(sg_bake_job_finish(j, &whole, &err), SG_OK);
    sg_bake_job_destroy(j);
    const char *ref = sg_test_tmp_path("whole.sgbake");
    assert_int_equal(sg_bake_save(whole, ref, SCENE_HASH, &err), SG_OK);
    sg_bake_destroy(whole);
    assert_true(all->n > 8 && all->n < 4096);
    int stages[SG_BAKE_STAGE_DONE] = {0};
    for (int k = 1; k <= all->n; ++k) {
        const sg_bake_progress *p = &all->at[k - 1], *q = k > 1 ? &all->at[k - 2] : NULL;
        stages[p->stage] = 1;
        int first = !q || q->stage != p->stage || q->level != p->level;
        if (!first && k != all->n / 2 && k != all->n - 1)
            continue;
        memset(c, 0, sizeof *c);
        c->stop_at = k;
        assert_int_equal(sg_bake_job_create(w, &d, &j, &err), SG_OK);
        sg_status st = sg_bake_job_run(j, on_job_progress, c, &err);
        if (st == SG_OK) { /* the last call came after the last block */
            sg_bake_job_destroy(j);
            continue;
        }
        assert_int_equal(st, SG_ERR_CANCELLED);
        const char *ckpt = sg_test_tmp_path("job.ckpt");
        if (sg_bake_job_save(j, ckpt, SCENE_HASH, &err) != SG_OK)
            fail_msg("save at call %d (stage %d, level %d): %s", k, (int)p->stage, p->level, err.message);
        sg_bake_job_destroy(j);
        j = NULL;
        sg_bake_desc d2 = d;
        d2.gather.threads = d2.photons.threads = k % 2 ? 1 : 2;
        if (sg_bake_job_load(ckpt, w, &d2, SCENE_HASH, &j, &err) != SG_OK)
            fail_msg("load at call %d (stage %d, level %d): %s", k, (int)p->stage, p->level, err.message);
        assert_int_equal(sg_bake_job_run(j, NULL, NULL, &err), SG_OK);
        sg_bake *b = NULL;
        assert_int_equal(sg_bake_job_finish(j, &b, &err), SG_OK);
        sg_bake_job_destroy(j);
        char name[64];
        snprintf(name, sizeof name, "resumed_%d.sgbake", k);
        assert_saves_as(b, name, ref);
        sg_bake_destroy(b);
    }
    assert_true(stages[SG_BAKE_STAGE_SITES] && stages[SG_BAKE_STAGE_GLOSSY]);
    assert_true(stages[SG_BAKE_STAGE_PHOTONS] == (indirect == SG_BAKE_INDIRECT_PHOTONS));
    test_free(all);
    test_free(c);
    sg_world_destroy(w);
}

static void test_bake_job_resume_transport(void **state)
{
    (void)state;
    check_resume_everywhere(SG_BAKE_INDIRECT_TRANSPORT);
}

static void test_bake_job_resume_photons(void **state)
{
    (void)state;
    check_resume_everywhere(SG_BAKE_INDIRECT_PHOTONS);
}

/* A finished job is not saved as a checkpoint (its stage, DONE, is one no
 * load accepts): SG_ERR_INVALID_ARG, and nothing at the path. splatgi-bake
 * once wrote such a file when a Ctrl-C came during the last block of work,
 * and its --resume then failed ("section JOBS: stage 3"). */
static void test_bake_io_finished_job_not_checkpointed(void **state)
{
    (void)state;
    sg_world *w = job_world();
    sg_bake_desc d = {.direct_samples = 4, .gather_rays = 4, .photons = {.progress_seconds = -1.0}};
    sg_bake_job *j = NULL;
    sg_error err = {0};
    assert_int_equal(sg_bake_job_create(w, &d, &j, &err), SG_OK);
    assert_int_equal(sg_bake_job_run(j, NULL, NULL, &err), SG_OK);
    assert_int_equal(sg_bake_job_progress(j).stage, SG_BAKE_STAGE_DONE);
    const char *ckpt = sg_test_tmp_path("done.ckpt");
    remove(ckpt);
    assert_int_equal(sg_bake_job_save(j, ckpt, SCENE_HASH, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "finished"));
    FILE *f = fopen(ckpt, "rb");
    if (f) {
        fclose(f);
        fail_msg("%s was written for a finished job", ckpt);
    }
    sg_bake *b = NULL;
    assert_int_equal(sg_bake_job_finish(j, &b, &err), SG_OK);
    sg_bake_destroy(b);
    sg_bake_job_destroy(j);
    sg_world_destroy(w);
}

/* A job stopped in the stage `stage` (at the call after its first one), saved. */
static void save_stopped(const sg_world *w, const sg_bake_desc *d, sg_bake_stage stage, const char *path)
{
    sg_bake_job *j = NULL;
    job_calls *c = test_calloc(1, sizeof *c);
    assert_int_equal(sg_bake_job_create(w, d, &j, NULL), SG_OK);
    for (int k = 1, seen = 0;; ++k) {
        memset(c, 0, sizeof *c);
        c->stop_at = k;
        sg_bake_job_destroy(j);
        assert_int_equal(sg_bake_job_create(w, d, &j, NULL), SG_OK);
        assert_int_equal(sg_bake_job_run(j, on_job_progress, c, NULL), SG_ERR_CANCELLED);
        /* stopped in the stage with some of its work saved: how much is
         * done at the stage's first callbacks depends on the threads'
         * timing, and a damaged value must land in saved work (an empty
         * glossy section made test_bake_io_checkpoint_checks fail under
         * load) */
        sg_bake_progress p = sg_bake_job_progress(j);
        if (p.stage == stage && ++seen >= 2 && p.done > 0)
            break;
    }
    assert_int_equal(sg_bake_job_save(j, path, SCENE_HASH, NULL), SG_OK);
    sg_bake_job_destroy(j);
    test_free(c);
}

/* 2. A checkpoint read with other parameters, for another scene, as a
 * bake, or damaged: clean errors naming the file and what is wrong; a bake
 * read as a checkpoint too; a job saved before any work loads and runs. */
static void test_bake_io_checkpoint_checks(void **state)
{
    (void)state;
    sg_world *w = job_world();
    sg_bake_desc d = {.indirect = SG_BAKE_INDIRECT_PHOTONS, .photons = {.count = 40000, .seed = 7,
                      .progress_seconds = -1.0}, .direct_samples = 8, .gather_rays = 8, .glossy_rays = 16};
    sg_error err = {0};
    sg_bake_job *out = NULL;
    const char *ckpt = sg_test_tmp_path("checks.ckpt"), *sites = sg_test_tmp_path("sites.ckpt"), *gl = sg_test_tmp_path("glossy.ckpt");
    save_stopped(w, &d, SG_BAKE_STAGE_PHOTONS, ckpt);
    sg_bake_desc other = d;
    other.photons.seed = 8;
    assert_int_equal(sg_bake_job_load(ckpt, w, &other, SCENE_HASH, &out, &err), SG_ERR_INVALID_ARG);
    if (!strstr(err.message, "made with other bake parameters (photons, seed 7,") ||
        !strstr(err.message, "than these (photons, seed 8,"))
        fail_msg("message: %s", err.message);
    assert_int_equal(sg_bake_job_load(ckpt, w, &d, SCENE_HASH ^ 1, &out, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "made for another scene"));
    expect_load_fails(ckpt, w, SCENE_HASH, SG_ERR_INVALID_ARG, "a checkpoint of an unfinished bake");
    /* a record's flux made negative (with fresh CRCs), then a flipped byte, then half a file */
    const char *bad = sg_test_tmp_path("bad.ckpt");
    rewrite(ckpt, bad, "PHFG", 0, -2.0f, SG_BAKE_FLAG_CHECKPOINT);
    assert_int_equal(sg_bake_job_load(bad, w, &d, SCENE_HASH, &out, &err), SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "photon record 0: its flux is not finite and >= 0"));
    size_t n;
    unsigned char *bytes = read_all(ckpt, &n);
    bytes[n - 2] ^= 1;
    write_all(bad, bytes, n);
    assert_int_equal(sg_bake_job_load(bad, w, &d, SCENE_HASH, &out, &err), SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, bad));
    write_all(bad, bytes, n / 3);
    assert_int_equal(sg_bake_job_load(bad, w, &d, SCENE_HASH, &out, &err), SG_ERR_CORRUPT);
    free(bytes);
    /* the sites' sections: a hit naming a splat the scene lacks, a NaN
     * ratio, hit ranges out of order, a sample level above the job's */
    save_stopped(w, &d, SG_BAKE_STAGE_SITES, sites);
    rewrite(sites, bad, "H000", 0, float_of_bits(9000000u), SG_BAKE_FLAG_CHECKPOINT);
    assert_int_equal(sg_bake_job_load(bad, w, &d, SCENE_HASH, &out, &err), SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "model 0, hit 0: splat 9000000"));
    rewrite(sites, bad, "R000", 4, NAN, SG_BAKE_FLAG_CHECKPOINT);
    assert_int_equal(sg_bake_job_load(bad, w, &d, SCENE_HASH, &out, &err), SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "section R000: value 4 is NaN"));
    rewrite(sites, bad, "F000", 2, float_of_bits(0xffffffffu), SG_BAKE_FLAG_CHECKPOINT); /* first[1]'s low half */
    assert_int_equal(sg_bake_job_load(bad, w, &d, SCENE_HASH, &out, &err), SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "section F000: site 1's hits do not follow"));
    rewrite(sites, bad, "L000", 0, float_of_bits(0x07070707u), SG_BAKE_FLAG_CHECKPOINT); /* levels 7 */
    assert_int_equal(sg_bake_job_load(bad, w, &d, SCENE_HASH, &out, &err), SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "model 0, sample point 0: splat"));
    /* glossy bins: a NaN half */
    save_stopped(w, &d, SG_BAKE_STAGE_GLOSSY, gl);
    if (sg_bake_job_load(gl, w, &d, SCENE_HASH, &out, &err) != SG_OK)
        fail_msg("glossy checkpoint: %s", err.message);
    sg_bake_job_destroy(out);
    out = NULL;
    rewrite(gl, bad, "G000", 0, float_of_bits(0x7fc00000u), SG_BAKE_FLAG_CHECKPOINT);
    assert_int_equal(sg_bake_job_load(bad, w, &d, SCENE_HASH, &out, &err), SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "section G000: value 1 is not finite"));
    /* a finished bake is not a checkpoint */
    sg_bake *b = NULL;
    assert_int_equal(sg_bake_create(w, &d, &b, &err), SG_OK);
    const char *bk = sg_test_tmp_path("checks.sgbake");
    assert_int_equal(sg_bake_save(b, bk, SCENE_HASH, &err), SG_OK);
    assert_int_equal(sg_bake_job_load(bk, w, &d, SCENE_HASH, &out, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "a finished bake, not a checkpoint"));
    assert_null(out);
    /* a job saved before any work (Ctrl-C before the first block) loads and runs */
    sg_bake_job *j = NULL;
    assert_int_equal(sg_bake_job_create(w, &d, &j, &err), SG_OK);
    assert_int_equal(sg_bake_job_save(j, ckpt, SCENE_HASH, &err), SG_OK);
    sg_bake_job_destroy(j);
    assert_int_equal(sg_bake_job_load(ckpt, w, &d, SCENE_HASH, &out, &err), SG_OK);
    assert_int_equal(sg_bake_job_run(out, NULL, NULL, &err), SG_OK);
    sg_bake *b2 = NULL;
    assert_int_equal(sg_bake_job_finish(out, &b2, &err), SG_OK);
    assert_saves_as(b2, "from_empty.sgbake", bk);
    sg_bake_job_destroy(out);
    sg_bake_destroy(b);
    sg_bake_destroy(b2);
    sg_world_destroy(w);
}

typedef struct calls {
    int n;            /* calls so far                          */
    int cancel_at;    /* return 1 on this call (0: never)      */
    size_t last;      /* done_photons of the last call         */
    size_t total;     /* total_photons of the last call        */
    int decreasing;   /* a call reported fewer than the one before */
    int off_thread;   /* a call came from an OpenMP thread != 0   */
} calls;

static int count_calls(void *user, size_t done, size_t total)
{
    calls *c = user;
    c->n++;
    c->decreasing |= done < c->last;
    c->off_thread |= omp_get_thread_num() != 0;
    c->last = done;
    c->total = total;
    return c->cancel_at && c->n >= c->cancel_at;
}

/* 4. Progress after every block, counting up to the total, on thread 0;
 * cancel keeps the longest completed prefix, which equals the one-pass
 * map's first records and can be extended to the whole pass. */
static void test_photons_progress_and_cancel(void **state)
{
    (void)state;
    sg_world *w = small_world(2000);
    sg_error err = {0};
    calls c = {0};
    sg_photon_desc d = {.count = 30 * SG_PHOTON_BLOCK + 100, .seed = 3, .threads = 2, .progress = count_calls,
                        .progress_user = &c, .progress_seconds = -1.0};
    sg_photon_map full = {0}, part = {0};
    assert_int_equal(sg_photons_trace(w, &d, &full, &err), SG_OK);
    if (c.n < 2 || c.decreasing || c.off_thread || c.last != d.count || c.total != d.count)
        fail_msg("%d calls, decreasing %d, off thread %d, last %zu of %zu (want %zu)", c.n, c.decreasing,
                 c.off_thread, c.last, c.total, d.count);

    c = (calls){.cancel_at = 3};
    sg_status st = sg_photons_trace(w, &d, &part, &err);
    assert_int_equal(st, SG_ERR_CANCELLED);
    assert_int_equal(err.status, SG_ERR_CANCELLED);
    assert_non_null(strstr(err.message, "cancelled after"));
    assert_true(part.blocks < 31);
    assert_int_equal(part.shot, part.blocks * SG_PHOTON_BLOCK);
    size_t prefix = part.count; /* = the records of the full map's first part.blocks blocks */
    assert_true(prefix <= full.count);
    assert_memory_equal(part.px, full.px, prefix * sizeof(float));
    assert_memory_equal(part.fb, full.fb, prefix * sizeof(float));
    assert_memory_equal(part.model, full.model, prefix * sizeof(uint32_t));
    /* carry on, without the callback: the whole pass again */
    d.progress = NULL;
    assert_int_equal(sg_photons_trace_more(w, &d, sg_photon_block_count(&d), &part, &err), SG_OK);
    assert_maps_equal(&full, &part);
    /* a range outside the pass or before the map's end */
    assert_int_equal(sg_photons_trace_more(w, &d, 5, &part, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_photons_trace_more(w, &d, 32, &part, &err), SG_ERR_INVALID_ARG);
    assert_maps_equal(&full, &part);
    /* a cancel with the default interval still ends the call: the closing
     * report of a short pass cancels it with everything done */
    c = (calls){.cancel_at = 1};
    sg_photon_map tiny = {0};
    sg_photon_desc dt = {.count = 5000, .progress = count_calls, .progress_user = &c};
    assert_int_equal(sg_photons_trace(w, &dt, &tiny, &err), SG_ERR_CANCELLED);
    assert_true(c.n >= 1);
    assert_true(tiny.blocks <= 2);
    sg_photon_map_free(&tiny);
    sg_photon_map_free(&full);
    sg_photon_map_free(&part);
    sg_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bake_io_roundtrip),
        cmocka_unit_test(test_bake_io_param_hash),
        cmocka_unit_test(test_bake_io_ray_cone_key),
        cmocka_unit_test(test_bake_io_other_scene),
        cmocka_unit_test(test_bake_io_truncated_or_corrupt),
        cmocka_unit_test(test_bake_io_splat_count_mismatch),
        cmocka_unit_test(test_bake_io_bad_values),
        cmocka_unit_test(test_bake_io_glossy_roundtrip),
        cmocka_unit_test(test_bake_io_glossy_corrupt),
        cmocka_unit_test(test_bake_io_photons_in_parts_equal_one_pass),
        cmocka_unit_test(test_bake_job_resume_transport),
        cmocka_unit_test(test_bake_job_resume_photons),
        cmocka_unit_test(test_bake_io_checkpoint_checks),
        cmocka_unit_test(test_bake_io_finished_job_not_checkpointed),
        cmocka_unit_test(test_photons_progress_and_cancel),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
