/* splatgi-view — walk through a baked scene in a window (GLFW + OpenGL), or
 * render a camera path to files without one (--headless). Options, library
 * calls (view/navigator.h, view/campath.h, view/frame.h) and GL plumbing;
 * no rendering algorithm lives here. Run with --help for the options.
 *
 * Each window frame: navigator update -> sg_view_frame_render (1/scale
 * resolution while the camera moves, the scale from sg_view_move_scale
 * unless --move-scale fixes it; full when it stops) -> display
 * transform to RGBA8 -> glTexSubImage2D -> one textured quad (legacy GL,
 * which Mesa's llvmpipe under Xvfb runs) -> swap.
 */
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define GLFW_INCLUDE_NONE
#include <GL/gl.h>
#include <GLFW/glfw3.h>

#include "app/model_scene.h"
#include "core/cli.h"
#include "bake/bake.h"
#include "bake/bake_io.h"
#include "display/ocio.h"
#include "io/image.h"
#include "io/scene_file.h"
#include "render/camera.h"
#include "render/world.h"
#include "view/campath.h"
#include "view/frame.h"
#include "view/navigator.h"
#include "program.h"

#define OUT_DIR "out"

#define KEYS_HELP                                                                                 \
    "Keys: W/A/S/D or arrows move, Q/E down/up, Shift faster, left-drag looks,\n"                 \
    "O toggles orbit, R resets, +/- exposure, P screenshot (out/shot_NNNN.exr + .png),\n"          \
    "X toggles anti-aliasing of still frames (--aa), C starts/stops recording the\n"               \
    "camera path (out/path.txt), Esc quits.\n"

static const char usage[] =
    "usage: splatgi-view SCENE.json|MODEL [--bake FILE.sgbake] [options]\n"
    "Walks through a scene lit by its bake. Without --bake the bake is kept in\n"
    "out/<name>.sgbake and made there first when missing or out of date (default\n"
    "parameters; splatgi-bake -o out/<name>.sgbake makes one with others).\n"
    "\n"
    "  --bake FILE         the bake to show (must be up to date for the scene)\n"
    "  --camera NAME       first view: this camera of the scene file (default: the\n"
    "                      file's first camera, else a view framing the scene)\n"
    "  --width W --height H   window / frame size (default: the file's render size)\n"
    "  --display D --view V   OCIO display and view (default: the config's defaults)\n"
    "  --exposure E        exposure in stops (default 0)\n"
    "  --move-scale S      resolution divisor while moving: 1, 2, 4, 8, or auto (the\n"
    "                      default: the smallest of 2, 4, 8 whose frame fits 1/30 s)\n"
    "  --threads N         render threads (default: all)\n"
    "  --aa MODE           anti-aliasing of still (full-resolution) frames: none\n"
    "                      (default: one ray per pixel) or corner (rays through the\n"
    "                      pixel corners, each pixel refined where its corners differ)\n"
    "  --aa-threshold T    corner: contrast |a-b|/(a+b) above which a pixel is refined\n"
    "                      (default 0.1; coverage counts too)\n"
    "  --aa-depth D        corner: levels of refinement, 0..6 (default 2: at most a\n"
    "                      4 x 4 grid of squares a pixel; 0: Ye's four-corner average)\n"
    "  --path FILE         play a camera path (window), or render it (--headless)\n"
    "  --headless          no window: render every key of --path to --out DIR\n"
    "  --out DIR           headless output folder: frame_0000.png, ...\n"
    "  --exr               headless: also write frame_0000.exr (scene-linear)\n"
    "  --frames N          quit after N window frames\n"
    "  --screenshot-on-exit FILE.png   read the window back into a PNG on exit\n"
    "  --help              this text\n"
    "\n" SG_PROG_WORLD_OPTIONS "\n" SG_MODEL_SCENE_OPTIONS "\n" KEYS_HELP;

typedef struct options {
    const char *scene;      /* positional                              */
    const char *bake;       /* --bake                                  */
    const char *camera;     /* --camera                                */
    int width, height;      /* 0: the scene file's render size         */
    const char *display, *view;
    float exposure;
    int move_scale;
    int threads;
    const char *path;       /* --path                                  */
    int headless, exr;
    const char *out;        /* --out                                   */
    long frames;            /* 0: until closed                         */
    const char *screenshot; /* --screenshot-on-exit                    */
    sg_model_scene_desc model; /* the scene made for a model file     */
    const char *write_scene;   /* --write-scene                       */
    sg_prog_world world;       /* --world, --if-stale                 */
    sg_view_aa aa;             /* --aa, --aa-threshold, --aa-depth   */
} options;

static int fail(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;
static int fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "splatgi-view: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return 1;
}

static int parse_long(const char *opt, const char *s, long lo, long hi, long *out)
{
    sg_error e;
    return sg_cli_long(opt, s, lo, hi, out, &e) == SG_OK ? 1 : (fail("%s", e.message), 0);
}

/* Returns 0 to go on, 1 for an error, 2 after --help. */
static int parse_args(int argc, char **argv, options *o)
{
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return 2;
        }
        if (!strcmp(a, "--headless")) { o->headless = 1; continue; }
        if (!strcmp(a, "--exr")) { o->exr = 1; continue; }
        sg_error e = {0};
        int m = sg_model_scene_option(argc, argv, &i, &o->model, &o->write_scene, &e);
        if (m == 0)
            m = sg_prog_world_option(argc, argv, &i, &o->world, &e);
        if (m < 0)
            return fail("%s", e.message);
        if (m)
            continue;
        if (strncmp(a, "--", 2)) {
            if (o->scene)
                return fail("unexpected argument '%s' (one scene or model file; see --help)", a);
            o->scene = a;
            continue;
        }
        static const char *const with_value[] = {"--bake", "--camera", "--width", "--height", "--display",
                                                 "--view", "--exposure", "--move-scale", "--threads", "--path",
                                                 "--out", "--frames", "--screenshot-on-exit", "--aa",
                                                 "--aa-threshold", "--aa-depth"};
        int known = 0;
        for (size_t k = 0; k < sizeof with_value / sizeof with_value[0]; k++)
            known |= !strcmp(a, with_value[k]);
        if (!known)
            return fail("unknown option '%s' (see --help)", a);
        if (i + 1 >= argc)
            return fail("%s needs a value", a);
        const char *v = argv[++i];
        long n;
        if (!strcmp(a, "--bake")) o->bake = v;
        else if (!strcmp(a, "--camera")) o->camera = v;
        else if (!strcmp(a, "--display")) o->display = v;
        else if (!strcmp(a, "--view")) o->view = v;
        else if (!strcmp(a, "--path")) o->path = v;
        else if (!strcmp(a, "--out")) o->out = v;
        else if (!strcmp(a, "--screenshot-on-exit")) o->screenshot = v;
        else if (!strcmp(a, "--width") || !strcmp(a, "--height")) {
            if (!parse_long(a, v, 1, 16384, &n)) return 1;
            *(a[2] == 'w' ? &o->width : &o->height) = (int)n;
        } else if (!strcmp(a, "--move-scale")) {
            n = 0; /* auto */
            if (strcmp(v, "auto")) {
                char *end;
                n = strtol(v, &end, 10);
                if (end == v || *end || n < 1 || n > 8 || (n & (n - 1)))
                    return fail("--move-scale: '%s' is not 1, 2, 4, 8 or auto", v);
            }
            o->move_scale = (int)n;
        } else if (!strcmp(a, "--threads")) {
            if (!parse_long(a, v, 1, 4096, &n)) return 1;
            o->threads = (int)n;
        } else if (!strcmp(a, "--frames")) {
            if (!parse_long(a, v, 1, 1L << 30, &n)) return 1;
            o->frames = n;
        } else if (!strcmp(a, "--aa")) {
            if (!strcmp(v, "none")) o->aa.mode = SG_VIEW_AA_NONE;
            else if (!strcmp(v, "corner")) o->aa.mode = SG_VIEW_AA_CORNER;
            else return fail("--aa: '%s' is not none or corner", v);
        } else if (!strcmp(a, "--aa-depth")) {
            if (!parse_long(a, v, 0, SG_CORNER_AA_MAX_DEPTH, &n)) return 1;
            o->aa.max_depth = n == 0 ? -1 : (int)n; /* the desc's 0 is the default */
        } else if (!strcmp(a, "--aa-threshold")) {
            char *end;
            errno = 0;
            float t = strtof(v, &end);
            if (errno || end == v || *end || !(t > 0.0f) || !isfinite(t))
                return fail("--aa-threshold: '%s' is not a contrast > 0", v);
            o->aa.threshold = t;
        } else if (!strcmp(a, "--exposure")) {
            char *end;
            errno = 0;
            o->exposure = strtof(v, &end);
            if (errno || end == v || *end || !isfinite(o->exposure))
                return fail("--exposure: '%s' is not a number of stops", v);
        }
    }
    if (!o->scene)
        return fail("no scene or model file (usage: splatgi-view SCENE.json|MODEL [--bake FILE]; see --help)");
    if (o->headless && (!o->path || !o->out))
        return fail("--headless needs --path FILE and --out DIR");
    if (!o->headless && (o->out || o->exr))
        return fail("--out and --exr go with --headless");
    return 0;
}

/* Everything a frame needs, loaded once. */
typedef struct viewer {
    options opt;
    sg_scene_file sf;
    sg_world *world;
    sg_bake *bake;
    sg_display *display;
    sg_nav_view home;    /* first view                                  */
    sg_campath path;     /* --path keys (count 0 without)               */
} viewer;

static void viewer_free(viewer *v)
{
    sg_campath_free(&v->path);
    sg_display_destroy(v->display);
    sg_bake_destroy(v->bake);
    sg_world_destroy(v->world);
    sg_scene_file_free(&v->sf);
}

/* Scene, bake plan (its header checked before the world), world, bake,
 * display, first view. */
static int viewer_load(viewer *v, sg_error *err)
{
    options *o = &v->opt;
    if (sg_prog_load_scene(o->scene, &o->model, o->write_scene, &v->sf, err) != SG_OK)
        return 0;
    if (o->path && sg_campath_read(o->path, &v->path, err) != SG_OK)
        return 0;
    const sg_scene_camera *cam = NULL;
    if (o->camera && !(cam = sg_scene_file_find_camera(&v->sf, o->camera))) {
        sg_error_set(err, SG_ERR_INVALID_ARG, "%s: no camera named '%s'", o->scene, o->camera);
        return 0;
    }
    sg_prog_bake plan;
    if (sg_prog_bake_plan(o->scene, NULL, o->bake, &v->sf, &plan, err) != SG_OK)
        return 0;
    double t0 = omp_get_wtime();
    if (sg_prog_build_world(o->scene, &v->sf, 0, &o->world, &v->world, err) != SG_OK)
        return 0;
    double t1 = omp_get_wtime();
    if (sg_prog_bake_obtain(&plan, &v->sf, v->world, &v->bake, err) != SG_OK)
        return 0;
    double t2 = omp_get_wtime();
    sg_display_desc dd = {.display = o->display, .view = o->view, .exposure_stops = o->exposure};
    if (sg_display_create(&dd, &v->display, err) != SG_OK)
        return 0;
    if (!cam && v->sf.camera_count)
        cam = &v->sf.cameras[0];
    if (cam) {
        v->home = (sg_nav_view){cam->eye, cam->look, cam->up, cam->fov_deg};
    } else if (sg_nav_frame_view(sg_world_bounds(v->world), &v->home, err) != SG_OK) {
        return 0;
    }
    sg_bake_stats bs;
    sg_bake_get_stats(v->bake, &bs);
    sg_display_info di;
    sg_display_get_info(v->display, &di);
    printf("splatgi-view: %s: %zu models, %zu splats; world %.2f s, bake %.3f s (%s); display %s / %s\n", o->scene,
           bs.models, bs.splats, t1 - t0, t2 - t1, plan.path, di.display, di.view);
    fflush(stdout);
    return 1;
}

static int frame_size(const viewer *v, int *w, int *h)
{
    *w = v->opt.width ? v->opt.width : v->sf.render.width;
    *h = v->opt.height ? v->opt.height : v->sf.render.height;
    return 1;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* --headless: every key of the path to DIR/frame_NNNN.png (+ .exr). */
static int run_headless(viewer *v)
{
    const options *o = &v->opt;
    sg_error err = {0};
    int w, h, rc = 1;
    frame_size(v, &w, &h);
    if (mkdir(o->out, 0777) != 0 && errno != EEXIST)
        return fail("%s: %s", o->out, strerror(errno));
    sg_view_frame f = {0};
    size_t n = v->path.count;
    double *times = malloc(n * sizeof *times);
    if (!times)
        return fail("out of memory");
    if (sg_view_frame_resize(&f, w, h, &err) != SG_OK)
        goto fail_err;
    f.aa = o->aa;
    char file[4096];
    double total_rays = 0.0, total_render = 0.0;
    for (size_t i = 0; i < n; i++) {
        double t0 = omp_get_wtime();
        sg_camera cam;
        if (sg_campath_camera(&v->path.keys[i], (float)w / (float)h, &cam, &err) != SG_OK) {
            fprintf(stderr, "splatgi-view: %s: key %zu: %s\n", o->path, i, err.message);
            goto done;
        }
        if (sg_view_frame_render(&f, v->bake, v->world, &cam, 1, o->threads, v->display, &err) != SG_OK)
            goto fail_err;
        times[i] = omp_get_wtime() - t0;
        total_rays += (double)f.rays;
        total_render += f.render_seconds;
        snprintf(file, sizeof file, "%s/frame_%04zu.png", o->out, i);
        if (sg_view_write_png_rgba8(f.rgba, w, h, file, &err) != SG_OK)
            goto fail_err;
        if (o->exr) {
            snprintf(file, sizeof file, "%s/frame_%04zu.exr", o->out, i);
            if (sg_image_write_exr(&f.linear, file, &err) != SG_OK)
                goto fail_err;
        }
        printf("frame %04zu: %.2f ms (render %.2f ms, display %.2f ms)\n", i, times[i] * 1e3,
               f.render_seconds * 1e3, f.display_seconds * 1e3);
    }
    qsort(times, n, sizeof *times, cmp_double);
    double mean = 0.0;
    for (size_t i = 0; i < n; i++)
        mean += times[i];
    mean /= (double)n;
    size_t k95 = (size_t)ceil(0.95 * (double)n);
    double p95 = times[(k95 ? k95 : 1) - 1];
    printf("splatgi-view: %zu frames %d x %d to %s: mean %.2f ms, 95th percentile %.2f ms, %.2f Mrays/s, %.3f rays "
           "a pixel (anti-aliasing %s)\n",
           n, w, h, o->out, mean * 1e3, p95 * 1e3, total_render > 0.0 ? total_rays / total_render * 1e-6 : 0.0,
           total_rays / ((double)n * w * h), o->aa.mode == SG_VIEW_AA_CORNER ? "corner" : "none");
    rc = 0;
    goto done;
fail_err:
    fprintf(stderr, "splatgi-view: %s\n", err.message);
done:
    sg_view_frame_free(&f);
    free(times);
    return rc;
}

/* ---- the window ---------------------------------------------------------- */

typedef struct app {
    viewer *v;
    GLFWwindow *win;
    sg_navigator nav;
    sg_view_frame frame;
    GLuint tex;
    int tex_w, tex_h;        /* texture size                           */
    int dirty;               /* render at full resolution next frame   */
    int redisplay;           /* exposure changed                       */
    float exposure;          /* stops                                  */
    int recording;           /* C: recording the path                  */
    double record_start;     /* glfwGetTime at C                       */
    sg_campath record;       /* keys recorded                          */
    int playing;             /* playing --path                         */
    double play_start;
    size_t play_index;       /* key shown (SIZE_MAX: none yet)          */
    int want_shot;           /* P pressed                              */
    double last_x, last_y;   /* cursor at the last frame               */
    int dragging;
} app;

static void ensure_out_dir(void)
{
    if (mkdir(OUT_DIR, 0777) != 0 && errno != EEXIST)
        fprintf(stderr, "splatgi-view: %s: %s\n", OUT_DIR, strerror(errno));
}

static void save_recording(app *a)
{
    sg_error err = {0};
    if (a->record.count == 0) {
        fprintf(stderr, "splatgi-view: nothing recorded\n");
        return;
    }
    ensure_out_dir();
    if (sg_campath_write(&a->record, OUT_DIR "/path.txt", &err) != SG_OK)
        fprintf(stderr, "splatgi-view: %s\n", err.message);
    else
        printf("splatgi-view: recorded %zu frames to " OUT_DIR "/path.txt\n", a->record.count);
    sg_campath_free(&a->record);
}

static void key_cb(GLFWwindow *win, int key, int scancode, int action, int mods)
{
    app *a = glfwGetWindowUserPointer(win);
    if (action != GLFW_PRESS)
        return;
    sg_error err = {0};
    switch (key) {
    case GLFW_KEY_ESCAPE: glfwSetWindowShouldClose(win, GLFW_TRUE); break;
    case GLFW_KEY_O:
        sg_nav_set_mode(&a->nav, a->nav.mode == SG_NAV_ORBIT ? SG_NAV_WALK : SG_NAV_ORBIT);
        a->playing = 0;
        a->dirty = 1;
        break;
    case GLFW_KEY_R: sg_nav_reset(&a->nav); a->playing = 0; a->dirty = 1; break;
    case GLFW_KEY_EQUAL: case GLFW_KEY_KP_ADD: case GLFW_KEY_MINUS: case GLFW_KEY_KP_SUBTRACT: {
        float e = a->exposure + ((key == GLFW_KEY_MINUS || key == GLFW_KEY_KP_SUBTRACT) ? -0.5f : 0.5f);
        if (sg_display_set_exposure(a->v->display, e, &err) == SG_OK) {
            a->exposure = e;
            a->redisplay = 1;
            printf("splatgi-view: exposure %+.1f stops\n", (double)e);
        }
        break;
    }
    case GLFW_KEY_P: a->want_shot = 1; break;
    case GLFW_KEY_X:
        a->frame.aa.mode = a->frame.aa.mode == SG_VIEW_AA_NONE ? SG_VIEW_AA_CORNER : SG_VIEW_AA_NONE;
        a->dirty = 1;
        printf("splatgi-view: anti-aliasing of still frames %s\n", a->frame.aa.mode ? "corner" : "off");
        break;
    case GLFW_KEY_C:
        if (a->recording) {
            a->recording = 0;
            save_recording(a);
        } else {
            a->recording = 1;
            a->record_start = glfwGetTime();
            printf("splatgi-view: recording the camera path (C stops)\n");
        }
        break;
    default: break;
    }
}

/* Texture of the window's size; the frame too. */
static int app_resize(app *a, int w, int h, sg_error *err)
{
    if (sg_view_frame_resize(&a->frame, w, h, err) != SG_OK)
        return 0;
    glBindTexture(GL_TEXTURE_2D, a->tex);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, w, h, 0, GL_RGBA, GL_UNSIGNED_BYTE, NULL);
    a->tex_w = w;
    a->tex_h = h;
    a->dirty = 1;
    return 1;
}

static void draw_quad(const app *a)
{
    glViewport(0, 0, a->tex_w, a->tex_h);
    glClear(GL_COLOR_BUFFER_BIT);
    glEnable(GL_TEXTURE_2D);
    glBindTexture(GL_TEXTURE_2D, a->tex);
    glBegin(GL_QUADS); /* row 0 of the texture is the image's top */
    glTexCoord2f(0.0f, 1.0f); glVertex2f(-1.0f, -1.0f);
    glTexCoord2f(1.0f, 1.0f); glVertex2f(1.0f, -1.0f);
    glTexCoord2f(1.0f, 0.0f); glVertex2f(1.0f, 1.0f);
    glTexCoord2f(0.0f, 0.0f); glVertex2f(-1.0f, 1.0f);
    glEnd();
}

/* The back buffer (just drawn) as top-down RGBA8 into a PNG. */
static int read_back_png(const app *a, const char *path)
{
    int w = a->tex_w, h = a->tex_h;
    uint8_t *px = malloc((size_t)w * (size_t)h * 4), *row = malloc((size_t)w * 4);
    int ok = 0;
    if (px && row) {
        glPixelStorei(GL_PACK_ALIGNMENT, 1);
        glReadBuffer(GL_BACK);
        glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, px);
        for (int y = 0; y < h / 2; y++) { /* GL rows run bottom-up */
            memcpy(row, px + (size_t)y * w * 4, (size_t)w * 4);
            memcpy(px + (size_t)y * w * 4, px + (size_t)(h - 1 - y) * w * 4, (size_t)w * 4);
            memcpy(px + (size_t)(h - 1 - y) * w * 4, row, (size_t)w * 4);
        }
        sg_error err = {0};
        if (sg_view_write_png_rgba8(px, w, h, path, &err) == SG_OK)
            ok = 1;
        else
            fprintf(stderr, "splatgi-view: %s\n", err.message);
    }
    free(px);
    free(row);
    return ok;
}

/* P: the current view at full resolution, EXR (scene-linear) and PNG. */
static void screenshot(app *a, const sg_camera *cam)
{
    sg_error err = {0};
    viewer *v = a->v;
    if (a->frame.scale != 1 &&
        sg_view_frame_render(&a->frame, v->bake, v->world, cam, 1, v->opt.threads, v->display, &err) != SG_OK) {
        fprintf(stderr, "splatgi-view: screenshot: %s\n", err.message);
        return;
    }
    ensure_out_dir();
    char exr[64], png[64];
    struct stat st;
    for (int i = 0; i < 10000; i++) {
        snprintf(exr, sizeof exr, OUT_DIR "/shot_%04d.exr", i);
        snprintf(png, sizeof png, OUT_DIR "/shot_%04d.png", i);
        if (stat(exr, &st) != 0 && stat(png, &st) != 0)
            break;
    }
    if (sg_image_write_exr(&a->frame.linear, exr, &err) != SG_OK ||
        sg_view_write_png_rgba8(a->frame.rgba, a->frame.width, a->frame.height, png, &err) != SG_OK)
        fprintf(stderr, "splatgi-view: screenshot: %s\n", err.message);
    else
        printf("splatgi-view: saved %s and %s\n", exr, png);
}

static void read_input(app *a, sg_nav_input *in)
{
    GLFWwindow *w = a->win;
#define DOWN(k) (glfwGetKey(w, (k)) == GLFW_PRESS)
    in->forward = DOWN(GLFW_KEY_W) || DOWN(GLFW_KEY_UP);
    in->back = DOWN(GLFW_KEY_S) || DOWN(GLFW_KEY_DOWN);
    in->left = DOWN(GLFW_KEY_A) || DOWN(GLFW_KEY_LEFT);
    in->right = DOWN(GLFW_KEY_D) || DOWN(GLFW_KEY_RIGHT);
    in->down = DOWN(GLFW_KEY_Q);
    in->up = DOWN(GLFW_KEY_E);
    in->fast = DOWN(GLFW_KEY_LEFT_SHIFT) || DOWN(GLFW_KEY_RIGHT_SHIFT);
#undef DOWN
    double x, y;
    glfwGetCursorPos(w, &x, &y);
    int drag = glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
    if (drag && a->dragging) {
        in->look_dx = (float)(x - a->last_x);
        in->look_dy = (float)(y - a->last_y);
    }
    a->dragging = drag;
    a->last_x = x;
    a->last_y = y;
}

/* The window; GLFW is initialised (main checks the display before the
 * world is built). */
static int run_window(viewer *v)
{
    const options *o = &v->opt;
    int w, h, rc = 1;
    long frames = 0; /* drawn */
    frame_size(v, &w, &h);
    app a = {.v = v, .exposure = o->exposure, .play_index = (size_t)-1};
    a.frame.aa = o->aa;
    sg_error err = {0};
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 2);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 1);
    a.win = glfwCreateWindow(w, h, "splatgi-view", NULL, NULL);
    if (!a.win) {
        const char *why = NULL;
        glfwGetError(&why);
        fprintf(stderr, "splatgi-view: cannot open a window: %s\n", why ? why : "unknown reason");
        return 1;
    }
    fputs(KEYS_HELP, stdout); /* the window is open: how to move in it */
    fflush(stdout);
    glfwMakeContextCurrent(a.win);
    glfwSwapInterval(0);
    glfwSetWindowUserPointer(a.win, &a);
    glfwSetKeyCallback(a.win, key_cb);
    glGenTextures(1, &a.tex);
    glBindTexture(GL_TEXTURE_2D, a.tex);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexEnvi(GL_TEXTURE_ENV, GL_TEXTURE_ENV_MODE, GL_REPLACE);
    glClearColor(0.0f, 0.0f, 0.0f, 1.0f);

    sg_nav_init(&a.nav, &v->home, sg_world_bounds(v->world));
    if (v->path.count) {
        a.playing = 1;
        a.play_start = glfwGetTime();
    }
    int fw, fh;
    glfwGetFramebufferSize(a.win, &fw, &fh);
    if (!app_resize(&a, fw, fh, &err))
        goto fail_err;

    double last = glfwGetTime(), last_move = -1e9, title_at = last, acc_ms = 0.0, acc_rays = 0.0,
           acc_render = 0.0;
    long title_frames = 0;
    while (!glfwWindowShouldClose(a.win)) {
        glfwPollEvents();
        double now = glfwGetTime();
        float dt = (float)(now - last);
        if (dt > 0.1f)
            dt = 0.1f;
        last = now;
        sg_nav_input in = {0};
        read_input(&a, &in);
        int moved = sg_nav_update(&a.nav, &in, dt);
        if (moved)
            a.playing = 0;
        sg_nav_view view = sg_nav_get_view(&a.nav);
        if (a.playing) {
            size_t k = sg_campath_index_at(&v->path, now - a.play_start);
            view = v->path.keys[k].view;
            if (k != a.play_index) {
                a.play_index = k;
                a.dirty = 1;
            }
            if (now - a.play_start > v->path.keys[v->path.count - 1].time) {
                a.playing = 0; /* stay at the last key's view until the user moves */
                sg_nav_view last_view = view;
                sg_nav_init(&a.nav, &last_view, sg_world_bounds(v->world));
            }
        }
        if (moved)
            last_move = now;
        int moving = now - last_move < SG_VIEW_MOVE_HOLD_SECONDS;

        glfwGetFramebufferSize(a.win, &fw, &fh);
        if (fw > 0 && fh > 0 && (fw != a.tex_w || fh != a.tex_h) && !app_resize(&a, fw, fh, &err))
            goto fail_err;

        sg_camera cam;
        if (sg_camera_look_at(view.eye, view.look, view.up, view.fov_deg, (float)a.tex_w / (float)a.tex_h, &cam,
                              &err) != SG_OK)
            goto fail_err;
        int scale = 1;
        if (moving)
            scale = o->move_scale ? o->move_scale
                                  : sg_view_move_scale(a.frame.scale, a.frame.render_seconds + a.frame.display_seconds,
                                                       a.frame.rays, a.tex_w, a.tex_h, SG_VIEW_MOVE_BUDGET_SECONDS);
        double t0 = omp_get_wtime();
        int upload = 0;
        if (moved || a.dirty || (!moving && a.frame.scale != 1)) {
            if (sg_view_frame_render(&a.frame, v->bake, v->world, &cam, scale, o->threads, v->display, &err) !=
                SG_OK)
                goto fail_err;
            acc_rays += (double)a.frame.rays;
            acc_render += a.frame.render_seconds;
            a.dirty = a.redisplay = 0;
            upload = 1;
        } else if (a.redisplay) {
            if (sg_view_frame_redisplay(&a.frame, v->display, &err) != SG_OK)
                goto fail_err;
            a.redisplay = 0;
            upload = 1;
        }
        if (upload) {
            glBindTexture(GL_TEXTURE_2D, a.tex);
            glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, a.tex_w, a.tex_h, GL_RGBA, GL_UNSIGNED_BYTE, a.frame.rgba);
        }
        if (a.want_shot) {
            a.want_shot = 0;
            screenshot(&a, &cam);
        }
        if (a.recording) {
            sg_campath_key k = {.time = now - a.record_start, .view = view};
            if (sg_campath_append(&a.record, &k, &err) != SG_OK)
                fprintf(stderr, "splatgi-view: recording: %s\n", err.message);
        }
        draw_quad(&a);
        frames++;
        int last_frame = o->frames && frames >= o->frames;
        if (last_frame && o->screenshot) {
            glFinish();
            if (!read_back_png(&a, o->screenshot))
                goto done;
            printf("splatgi-view: window read back to %s\n", o->screenshot);
        }
        glfwSwapBuffers(a.win);
        acc_ms += (omp_get_wtime() - t0) * 1e3;
        title_frames++;
        if (now - title_at >= 0.5) {
            char title[160], res[24] = "";
            double fps = (double)title_frames / (now - title_at);
            if (scale > 1)
                snprintf(res, sizeof res, ", 1/%d res", scale);
            snprintf(title, sizeof title, "splatgi-view  %.1f ms  %.0f fps  %.1f Mrays/s  [%s%s%s]",
                     acc_ms / (double)title_frames, fps, acc_render > 0.0 ? acc_rays / acc_render * 1e-6 : 0.0,
                     a.nav.mode == SG_NAV_ORBIT ? "orbit" : "walk", res, a.recording ? ", REC" : "");
            glfwSetWindowTitle(a.win, title);
            title_at = now;
            title_frames = 0;
            acc_ms = acc_rays = acc_render = 0.0;
        }
        if (last_frame)
            glfwSetWindowShouldClose(a.win, GLFW_TRUE);
        else if (!upload && !moving && !a.playing)
            glfwWaitEventsTimeout(0.05); /* still: nothing to render */
    }
    rc = 0;
    goto done;
fail_err:
    fprintf(stderr, "splatgi-view: %s\n", err.message);
done:
    if (a.recording)
        save_recording(&a);
    sg_campath_free(&a.record);
    sg_view_frame_free(&a.frame);
    glDeleteTextures(1, &a.tex);
    glfwDestroyWindow(a.win);
    printf("splatgi-view: %ld frames\n", frames);
    return rc;
}

int main(int argc, char **argv)
{
    viewer v = {0};
    v.opt.move_scale = 0; /* auto */
    sg_prog_init("splatgi-view");
    int r = parse_args(argc, argv, &v.opt);
    if (r)
        return r == 2 ? 0 : 1;
    /* The display first: finding it missing after building the world
     * wastes the build. */
    if (!v.opt.headless) {
        if (!getenv("DISPLAY") && !getenv("WAYLAND_DISPLAY"))
            return fail("no display available (DISPLAY is not set); use --headless --path walk.txt --out DIR");
        if (!glfwInit()) {
            const char *why = NULL;
            glfwGetError(&why);
            return fail("no display available (glfwInit failed: %s); use --headless --path walk.txt --out DIR",
                        why ? why : "unknown reason");
        }
    }
    sg_error err = {0};
    int rc = 1;
    if (!viewer_load(&v, &err))
        fprintf(stderr, "splatgi-view: %s\n", err.message);
    else
        rc = v.opt.headless ? run_headless(&v) : run_window(&v);
    viewer_free(&v);
    if (!v.opt.headless)
        glfwTerminate();
    return rc;
}
