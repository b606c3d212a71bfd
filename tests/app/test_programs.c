/* test_programs.c — the programs end to end on what a user types:
 *   1. a model file on the command line: splatgi-render box.obj --up z
 *      makes the scene, bakes it into out/box.sgbake, writes the image with
 *      coverage as alpha and the scene (--write-scene); the written scene
 *      renders from the same cached bake without baking again;
 *   2. splatgi-ref --pixel-centres: every path through its pixel's centre
 *      (with no bounce the image then ignores the seed);
 *   3. splatgi-ref's progress reaches a pipe while it runs;
 *   4. loud failures before the world is built: a scene too big for the
 *      memory, a bake for another scene or a damaged one, an output folder
 *      that does not exist (no "building the world" line in the log).
 * The programs run through system() in this binary's temp folder. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "io/image.h"

#define BIN SG_TEST_BINARY_DIR "/.."

static int run(const char *cmd)
{
    int rc = system(cmd);
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static void dump(const char *path)
{
    FILE *fp = fopen(path, "r");
    char line[1024];
    while (fp && fgets(line, sizeof line, fp))
        fputs(line, stderr);
    if (fp)
        fclose(fp);
}

static int file_has(const char *path, const char *needle)
{
    FILE *fp = fopen(path, "r");
    char line[2048];
    int found = 0;
    while (fp && !found && fgets(line, sizeof line, fp))
        found = strstr(line, needle) != NULL;
    if (fp)
        fclose(fp);
    return found;
}

/* Runs cmd (in the temp folder, output to log) expecting exit status rc. */
static void expect_run(const char *cmd, const char *log, int rc)
{
    char full[8192];
    snprintf(full, sizeof full, "cd '%s' && %s > '%s' 2>&1", sg_test_tmpdir(), cmd, log);
    int got = run(full);
    if (got != rc) {
        char path[1200];
        snprintf(path, sizeof path, "%s/%s", sg_test_tmpdir(), log);
        dump(path);
        fail_msg("%s: exit %d, want %d", cmd, got, rc);
    }
}

static int log_has(const char *log, const char *needle)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s", sg_test_tmpdir(), log);
    return file_has(path, needle);
}

static void expect_log(const char *log, const char *needle, int want)
{
    if (log_has(log, needle) != want) {
        char path[1200];
        snprintf(path, sizeof path, "%s/%s", sg_test_tmpdir(), log);
        dump(path);
        fail_msg("%s %s \"%s\"", log, want ? "lacks" : "has", needle);
    }
}

/* A 2 x 1 x 0.5 box, Z-up (its height along z), as OBJ: no colours. */
static const char BOX_OBJ[] = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nv 0 0 0.5\nv 2 0 0.5\nv 2 1 0.5\nv 0 1 0.5\n"
                              "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

static const char SMALL_SCENE[] =
    "{ \"models\": [ { \"builtin\": \"sphere\", \"points\": 3000, \"transform\": { \"translate\": [0, 1, 0] } },\n"
    "              { \"builtin\": \"ground\", \"points\": 2500 } ],\n"
    "  \"envmap\": { \"builtin\": \"sky\" },\n"
    "  \"cameras\": [ { \"name\": \"main\", \"eye\": [0, 2.5, 4], \"look\": [0, 0.8, 0] } ],\n"
    "  \"render\": { \"width\": 48, \"height\": 36, \"spp\": 4 } }\n";

/* 1 */
static void test_model_file_to_image(void **state)
{
    (void)state;
    sg_test_write_file("box.obj", BOX_OBJ, sizeof BOX_OBJ - 1);
    expect_run(BIN "/splatgi-render box.obj --up z --points 3000 --width 64 --height 48 --out out/box.exr "
                   "--write-scene box.json",
               "box1.log", 0);
    expect_log("box1.log", "building the world of box.obj", 1);
    expect_log("box1.log", "out/box.sgbake: no bake yet: baking it", 1);
    expect_log("box1.log", "model 1 of 2 (box.obj): building the MLS surface of 3000 splats", 1);
    char path[1200];
    snprintf(path, sizeof path, "%s/out/box.exr", sg_test_tmpdir());
    sg_image img = {0};
    sg_error err = {0};
    if (sg_image_read_exr(path, &img, &err) != SG_OK)
        fail_msg("%s", err.message);
    assert_non_null(img.alpha);
    /* The framed box fills the middle; the corners see sky or ground. */
    size_t n = (size_t)img.width * (size_t)img.height, hits = 0;
    for (size_t i = 0; i < n; i++) {
        assert_true(img.alpha[i] == 0.0f || img.alpha[i] == 1.0f);
        hits += img.alpha[i] == 1.0f;
    }
    assert_true(img.alpha[(size_t)(img.height / 2) * img.width + img.width / 2] == 1.0f);
    assert_true(hits > n / 10 && hits < n); /* the sky at the top */
    sg_image_free(&img);
    /* The written scene is the same scene: the cached bake serves it. */
    expect_run(BIN "/splatgi-render box.json --width 64 --height 48 --out out/box2.png", "box2.log", 0);
    expect_log("box2.log", "baking it", 0);
    expect_log("box2.log", "from out/box.sgbake", 1);
}

/* The small scene seen from below the sphere, looking up into the sky's
 * gradient. */
static const char UP_SCENE[] =
    "{ \"models\": [ { \"builtin\": \"sphere\", \"points\": 3000, \"transform\": { \"translate\": [0, 1, 0] } } ],\n"
    "  \"envmap\": { \"builtin\": \"sky\" },\n"
    "  \"cameras\": [ { \"name\": \"main\", \"eye\": [0, 0.5, 4], \"look\": [0, 2.5, 0] } ],\n"
    "  \"render\": { \"width\": 48, \"height\": 36, \"spp\": 4 } }\n";

/* 2 */
static void test_ref_pixel_centres(void **state)
{
    (void)state;
    sg_test_write_file("small.json", UP_SCENE, sizeof UP_SCENE - 1);
    const char *const runs[4][2] = {{"--pixel-centres --seed 1", "c1.exr"}, {"--pixel-centres --seed 2", "c2.exr"},
                                    {"--seed 1", "j1.exr"}, {"--seed 2", "j2.exr"}};
    sg_image img[4] = {{0}};
    for (int k = 0; k < 4; k++) {
        char cmd[1024], path[1200];
        snprintf(cmd, sizeof cmd, BIN "/splatgi-ref small.json --max-depth 0 --spp 2 %s --out out/%s", runs[k][0],
                 runs[k][1]);
        expect_run(cmd, "ref.log", 0);
        snprintf(path, sizeof path, "%s/out/%s", sg_test_tmpdir(), runs[k][1]);
        sg_error err = {0};
        if (sg_image_read_exr(path, &img[k], &err) != SG_OK)
            fail_msg("%s", err.message);
        assert_non_null(img[k].alpha);
    }
    /* Where the centre ray sees the sky (alpha 0) the value is the sky in
     * that direction, whatever the seed; jittered, it moves with the seed.
     * (Where it hits, the direct light is still sampled.) */
    size_t sky = 0, same_c = 0, same_j = 0;
    for (size_t i = 0; i < 48 * 36; i++) {
        if (img[0].alpha[i] != 0.0f)
            continue;
        sky++;
        same_c += memcmp(img[0].data + 3 * i, img[1].data + 3 * i, 3 * sizeof(float)) == 0;
        same_j += memcmp(img[2].data + 3 * i, img[3].data + 3 * i, 3 * sizeof(float)) == 0;
    }
    if (!(sky > 100) || same_c != sky || same_j > sky / 2)
        fail_msg("%zu sky pixels: %zu equal between centred runs (want all), %zu between jittered (want few)", sky,
                 same_c, same_j);
    assert_true(sky < 48 * 36); /* the sphere is in view too */
    expect_log("ref.log", "48x36, 2 spp", 1);
    char json[1200];
    snprintf(json, sizeof json, "%s/out/c2.json", sg_test_tmpdir());
    assert_true(file_has(json, "\"pixel_centres\":\ttrue"));
    for (int k = 0; k < 4; k++)
        sg_image_free(&img[k]);
}

/* 3: the first progress line arrives while the render runs (a pipe is
 * fully buffered: without a flush every line came at the very end). */
static void test_ref_progress_reaches_a_pipe(void **state)
{
    (void)state;
    sg_test_write_file("small.json", SMALL_SCENE, sizeof SMALL_SCENE - 1);
    char cmd[2048], json[1200], line[512];
    snprintf(cmd, sizeof cmd, "cd '%s' && " BIN "/splatgi-ref small.json --spp 256 --progressive --width 64 "
             "--height 48 --out out/piped.exr 2>/dev/null", sg_test_tmpdir());
    snprintf(json, sizeof json, "%s/out/piped.json", sg_test_tmpdir());
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    assert_non_null(fgets(line, sizeof line, p));
    /* Read the summary as it is now: the run must not be over. */
    FILE *f = fopen(json, "r");
    char text[4096] = "";
    if (f) {
        size_t n = fread(text, 1, sizeof text - 1, f);
        text[n] = '\0';
        fclose(f);
    }
    while (fgets(line, sizeof line, p)) {
    }
    int rc = pclose(p);
    assert_int_equal(WEXITSTATUS(rc), 0);
    if (!strstr(text, "\"spp\"") || strstr(text, "\"spp\":\t256"))
        fail_msg("the first progress line came only when all 256 spp were done: %s", text);
}

/* 4 */
static void test_loud_failures_before_the_world(void **state)
{
    (void)state;
    sg_test_write_file("small.json", SMALL_SCENE, sizeof SMALL_SCENE - 1);
    static const char big[] = "{ \"models\": [ { \"builtin\": \"bunny\", \"points\": 1000000000 } ] }";
    sg_test_write_file("big.json", big, sizeof big - 1);
    expect_run(BIN "/splatgi-render big.json --out out/big.png", "big.log", 1);
    expect_log("big.log", "big.json: the scene needs about 651.9 GiB (1000000000 splats", 1);
    expect_log("big.log", "building the world", 0);
    expect_run(BIN "/splatgi-bake big.json -o out/big.sgbake", "bigbake.log", 1);
    expect_log("bigbake.log", "the scene needs about", 1);
    /* A damaged bake given with --bake: refused from its header. */
    sg_test_write_file("junk.sgbake", "SGBAKE\0\nnot really a bake at all, just bytes", 48);
    expect_run(BIN "/splatgi-render small.json --bake junk.sgbake --out out/j.png", "junk.log", 1);
    expect_log("junk.log", "junk.sgbake", 1);
    expect_log("junk.log", "building the world", 0);
    /* No such output folder: refused before the work. */
    expect_run(BIN "/splatgi-render small.json --out no/such/dir/x.png", "nodir.log", 1);
    expect_log("nodir.log", "cannot write in no/such/dir", 1);
    expect_log("nodir.log", "building the world", 0);
    expect_run(BIN "/splatgi-bake small.json -o no/such/dir/x.sgbake", "nodir2.log", 1);
    expect_log("nodir2.log", "cannot write in no/such/dir", 1);
    expect_log("nodir2.log", "building the world", 0);
    expect_run(BIN "/splatgi-ref small.json --out no/such/dir/x.exr", "nodir3.log", 1);
    expect_log("nodir3.log", "cannot write in no/such/dir", 1);
    /* Options that shape a model's scene, given with a scene file. */
    expect_run(BIN "/splatgi-ref small.json --up z", "upjson.log", 1);
    expect_log("upjson.log", "shape the scene made for a model file", 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_model_file_to_image),
        cmocka_unit_test(test_ref_pixel_centres),
        cmocka_unit_test(test_ref_progress_reaches_a_pipe),
        cmocka_unit_test(test_loud_failures_before_the_world),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
