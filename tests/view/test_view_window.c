/* test_view_window.c — the viewer's frames and the splatgi-view program:
 * a tiny scene (sphere on ground, sky) baked here with 50k photons.
 *   1. frames: scale 1 is sg_bake_render bit for bit (and its display
 *      transform); scale 2 is the half-size render, display-transformed and
 *      upscaled nearest
 *   2. --headless: every path frame equals sg_bake_render of the same camera
 *      bit for bit (EXR), and its PNG equals the display transform of it
 *   3. the window under xvfb-run: the screenshot read back from GL is not
 *      blank and matches the headless frame (mean abs difference < 2/255);
 *      skipped without xvfb-run
 *   4. no display: the message and exit 1, before the world is built (a
 *      DISPLAY that names no server is found out at once, not after
 *      building the world and loading the bake); a --bake for another
 *      scene is refused from its header, before the world; the key help
 *      is printed when the window opens (test 3)
 */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "bake/bake.h"
#include "bake/bake_io.h"
#include "display/ocio.h"
#include "io/scene_file.h"
#include "render/world.h"
#include "view/campath.h"
#include "view/frame.h"

#define VIEW_BIN SG_TEST_BINARY_DIR "/../splatgi-view"
#define W 120
#define H 90

static const char scene_json[] =
    "{ \"models\": [ { \"builtin\": \"sphere\", \"points\": 20000, \"transform\": { \"translate\": [0, 1, 0] } },\n"
    "              { \"builtin\": \"ground\", \"points\": 20000 } ],\n"
    "  \"envmap\": { \"builtin\": \"sky\" },\n"
    "  \"cameras\": [ { \"name\": \"main\", \"eye\": [0, 2.5, 4], \"look\": [0, 0.8, 0], \"fov_deg\": 40 } ],\n"
    "  \"render\": { \"width\": 120, \"height\": 90 } }\n";

typedef struct fixture {
    char dir[1024];        /* work folder           */
    char scene[1100];      /* scene.json            */
    char bake_path[1100];  /* scene.sgbake          */
    sg_scene_file sf;
    sg_world *world;
    sg_bake *bake;
    sg_display *display;
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof *f);
    *state = f;
    sg_error err;
    snprintf(f->dir, sizeof f->dir, "%s", sg_test_tmpdir());
    const char *p = sg_test_write_file("scene.json", scene_json, strlen(scene_json));
    snprintf(f->scene, sizeof f->scene, "%s", p);
    snprintf(f->bake_path, sizeof f->bake_path, "%s/scene.sgbake", f->dir);
    if (sg_scene_file_load(f->scene, &f->sf, &err) != SG_OK || sg_world_create(&f->sf, &f->world, &err) != SG_OK) {
        fprintf(stderr, "%s\n", err.message);
        return -1;
    }
    sg_bake_desc bd = {.photons = {.count = 50000}};
    if (sg_bake_create(f->world, &bd, &f->bake, &err) != SG_OK ||
        sg_bake_save(f->bake, f->bake_path, sg_scene_file_hash(&f->sf, SG_SCENE_HASH_BAKE), &err) != SG_OK ||
        sg_display_create(NULL, &f->display, &err) != SG_OK) {
        fprintf(stderr, "%s\n", err.message);
        return -1;
    }
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    if (!f)
        return 0;
    sg_display_destroy(f->display);
    sg_bake_destroy(f->bake);
    sg_world_destroy(f->world);
    sg_scene_file_free(&f->sf);
    free(f);
    return 0;
}

static sg_image render_ref(const fixture *f, const sg_camera *cam, int w, int h)
{
    sg_bake_frame_desc fd = {.camera = *cam, .width = w, .height = h};
    sg_image img = {0};
    sg_error err;
    double sec;
    assert_int_equal(sg_bake_render(f->bake, f->world, &fd, &img, &sec, &err), SG_OK);
    return img;
}

static sg_camera main_camera(const fixture *f, float aspect)
{
    const sg_scene_camera *c = &f->sf.cameras[0];
    sg_camera cam;
    sg_error err;
    assert_int_equal(sg_camera_look_at(c->eye, c->look, c->up, c->fov_deg, aspect, &cam, &err), SG_OK);
    return cam;
}

/* 1 */
static void test_frame_scales(void **state)
{
    fixture *f = *state;
    sg_error err;
    sg_view_frame fr = {0};
    const int w = 101, h = 75; /* odd: the last low-res row and column are partly used */
    sg_camera cam = main_camera(f, (float)w / (float)h);
    assert_int_equal(sg_view_frame_resize(&fr, w, h, &err), SG_OK);
    assert_int_equal(sg_view_frame_render(&fr, f->bake, f->world, &cam, 1, 0, f->display, &err), SG_OK);
    sg_image ref = render_ref(f, &cam, w, h);
    assert_int_equal(fr.linear.width, w);
    assert_memory_equal(fr.linear.data, ref.data, sizeof(float) * 3 * w * h);
    uint8_t *rgba = malloc((size_t)w * h * 4);
    assert_int_equal(sg_display_apply(f->display, &ref, rgba, &err), SG_OK);
    assert_memory_equal(fr.rgba, rgba, (size_t)w * h * 4);
    sg_image_free(&ref);

    assert_int_equal(sg_view_frame_render(&fr, f->bake, f->world, &cam, 2, 0, f->display, &err), SG_OK);
    int lw = (w + 1) / 2, lh = (h + 1) / 2;
    assert_int_equal(fr.linear.width, lw);
    assert_int_equal(fr.linear.height, lh);
    assert_int_equal(fr.rays, (size_t)lw * lh);
    ref = render_ref(f, &cam, lw, lh);
    assert_memory_equal(fr.linear.data, ref.data, sizeof(float) * 3 * lw * lh);
    assert_int_equal(sg_display_apply(f->display, &ref, rgba, &err), SG_OK);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            assert_memory_equal(fr.rgba + 4 * ((size_t)y * w + x), rgba + 4 * ((size_t)(y / 2) * lw + x / 2), 4);
    sg_image_free(&ref);
    free(rgba);
    assert_int_equal(sg_view_frame_render(&fr, f->bake, f->world, &cam, 0, 0, f->display, &err),
                     SG_ERR_INVALID_ARG);
    sg_view_frame_free(&fr);
}

static int run(const char *cmd)
{
    int rc = system(cmd);
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static void dump(const char *path)
{
    FILE *fp = fopen(path, "r");
    if (!fp)
        return;
    char line[512];
    while (fgets(line, sizeof line, fp))
        fputs(line, stderr);
    fclose(fp);
}

static int file_has(const char *path, const char *needle)
{
    FILE *fp = fopen(path, "r");
    if (!fp)
        return 0;
    char line[1024];
    int found = 0;
    while (!found && fgets(line, sizeof line, fp))
        found = strstr(line, needle) != NULL;
    fclose(fp);
    return found;
}

/* Renders a 3-key path headless into DIR/hl (shared by tests 2 and 3). */
static void headless(fixture *f, sg_campath *path)
{
    char walk[1200], cmd[8192], log[1200];
    const sg_scene_camera *c = &f->sf.cameras[0];
    sg_campath p = {0};
    sg_error err;
    for (int i = 0; i < 3; i++) {
        sg_campath_key k = {.time = 0.1 * i, .view = {c->eye, c->look, c->up, c->fov_deg}};
        k.view.eye.x += 0.4f * (float)i;
        k.view.fov_deg += 5.0f * (float)i;
        assert_int_equal(sg_campath_append(&p, &k, &err), SG_OK);
    }
    snprintf(walk, sizeof walk, "%s/walk.txt", f->dir);
    assert_int_equal(sg_campath_write(&p, walk, &err), SG_OK);
    snprintf(log, sizeof log, "%s/headless.log", f->dir);
    snprintf(cmd, sizeof cmd, "'%s' '%s' --bake '%s' --headless --path '%s' --out '%s/hl' --exr > '%s' 2>&1",
             VIEW_BIN, f->scene, f->bake_path, walk, f->dir, log);
    int rc = run(cmd);
    if (rc != 0)
        dump(log);
    assert_int_equal(rc, 0);
    assert_true(file_has(log, "95th percentile"));
    assert_true(file_has(log, "frame 0002:"));
    *path = p;
}

/* 2 */
static void test_headless_equals_render(void **state)
{
    fixture *f = *state;
    sg_campath p;
    headless(f, &p);
    sg_error err;
    uint8_t *rgba = malloc((size_t)W * H * 4);
    for (size_t i = 0; i < p.count; i++) {
        char file[1200];
        sg_camera cam;
        assert_int_equal(sg_campath_camera(&p.keys[i], (float)W / H, &cam, &err), SG_OK);
        sg_image ref = render_ref(f, &cam, W, H);
        sg_image got = {0};
        snprintf(file, sizeof file, "%s/hl/frame_%04zu.exr", f->dir, i);
        assert_int_equal(sg_image_read_exr(file, &got, &err), SG_OK);
        assert_int_equal(got.width, W);
        assert_int_equal(got.height, H);
        assert_memory_equal(got.data, ref.data, sizeof(float) * 3 * W * H);
        assert_int_equal(sg_display_apply(f->display, &ref, rgba, &err), SG_OK);
        uint8_t *png;
        int pw, ph;
        snprintf(file, sizeof file, "%s/hl/frame_%04zu.png", f->dir, i);
        assert_int_equal(sg_view_read_png_rgba8(file, &png, &pw, &ph, &err), SG_OK);
        assert_int_equal(pw, W);
        assert_int_equal(ph, H);
        assert_memory_equal(png, rgba, (size_t)W * H * 4);
        free(png);
        sg_image_free(&ref);
        sg_image_free(&got);
    }
    free(rgba);
    sg_campath_free(&p);
}

/* 3 */
static void test_window_screenshot(void **state)
{
    fixture *f = *state;
    if (run("command -v xvfb-run > /dev/null 2>&1") != 0) {
        fprintf(stderr, "xvfb-run not found: window test skipped\n");
        skip();
    }
    sg_campath p;
    headless(f, &p);
    sg_campath_free(&p);
    char cmd[8192], log[1200], shot[1200], hl[1200];
    snprintf(log, sizeof log, "%s/window.log", f->dir);
    snprintf(shot, sizeof shot, "%s/window.png", f->dir);
    snprintf(hl, sizeof hl, "%s/hl/frame_0000.png", f->dir);
    snprintf(cmd, sizeof cmd,
             "xvfb-run -a -s '-screen 0 640x480x24' '%s' '%s' --bake '%s' --frames 4 --screenshot-on-exit '%s' "
             "> '%s' 2>&1",
             VIEW_BIN, f->scene, f->bake_path, shot, log);
    int rc = run(cmd);
    if (rc != 0)
        dump(log);
    assert_int_equal(rc, 0);
    sg_error err;
    uint8_t *a, *b;
    int aw, ah, bw, bh;
    assert_int_equal(sg_view_read_png_rgba8(shot, &a, &aw, &ah, &err), SG_OK);
    assert_int_equal(sg_view_read_png_rgba8(hl, &b, &bw, &bh, &err), SG_OK);
    assert_int_equal(aw, W);
    assert_int_equal(ah, H);
    assert_int_equal(bw, W);
    assert_int_equal(bh, H);
    double sum = 0.0, sum2 = 0.0, diff = 0.0;
    size_t n = (size_t)W * H;
    for (size_t i = 0; i < n; i++) {
        for (int c = 0; c < 3; c++) {
            double v = a[4 * i + c] / 255.0;
            sum += v;
            sum2 += v * v;
            diff += fabs(v - b[4 * i + c] / 255.0);
        }
    }
    double mean = sum / (3.0 * n), var = sum2 / (3.0 * n) - mean * mean, mad = diff / (3.0 * n);
    fprintf(stderr, "window screenshot: mean %.4f, variance %.5f, mean abs difference to headless %.6f\n", mean,
            var, mad);
    assert_true(var > 1e-3);            /* not blank: a sphere, ground and sky */
    assert_true(mad < 2.0 / 255.0);
    /* How to move, said once the window is open. */
    assert_true(file_has(log, "Keys: W/A/S/D or arrows move"));
    assert_true(file_has(log, "P screenshot"));
    free(a);
    free(b);
}

/* 4 */
static void test_no_display_no_bake(void **state)
{
    fixture *f = *state;
    char cmd[8192], log[1200];
    snprintf(log, sizeof log, "%s/nodisplay.log", f->dir);
    snprintf(cmd, sizeof cmd, "env -u DISPLAY -u WAYLAND_DISPLAY '%s' '%s' --bake '%s' > '%s' 2>&1", VIEW_BIN,
             f->scene, f->bake_path, log);
    assert_int_equal(run(cmd), 1);
    assert_true(file_has(log, "splatgi-view: no display available (DISPLAY is not set); use --headless --path "
                              "walk.txt --out DIR"));
    /* A display that is set but not there: refused before the world (the
     * world used to be built and the bake loaded first). */
    snprintf(cmd, sizeof cmd, "env -u WAYLAND_DISPLAY DISPLAY=:87 '%s' '%s' --bake '%s' > '%s' 2>&1", VIEW_BIN,
             f->scene, f->bake_path, log);
    assert_int_equal(run(cmd), 1);
    assert_true(file_has(log, "splatgi-view: no display available (glfwInit failed"));
    assert_false(file_has(log, "building the world"));
    assert_false(file_has(log, "models,"));
    /* A bake of another scene: refused from its header, before the world. */
    char other[1200];
    snprintf(other, sizeof other, "%s/other.json", f->dir);
    FILE *fp = fopen(other, "w");
    assert_non_null(fp);
    fputs("{\"models\": [{\"builtin\": \"sphere\", \"points\": 1000}]}", fp);
    fclose(fp);
    char walk[1200];
    snprintf(walk, sizeof walk, "%s/one_key.txt", f->dir);
    fp = fopen(walk, "w");
    assert_non_null(fp);
    fputs("0 0 2 5 0 0 0 0 1 0 40\n", fp);
    fclose(fp);
    snprintf(cmd, sizeof cmd, "'%s' '%s' --bake '%s' --headless --path '%s' --out '%s/o' > '%s' 2>&1", VIEW_BIN,
             other, f->bake_path, walk, f->dir, log);
    assert_int_equal(run(cmd), 1);
    assert_true(file_has(log, "scene.sgbake: made for another scene"));
    assert_false(file_has(log, "building the world"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frame_scales), cmocka_unit_test(test_headless_equals_render),
        cmocka_unit_test(test_window_screenshot), cmocka_unit_test(test_no_display_no_bake),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
