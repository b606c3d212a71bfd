/* test_render.c — frame renderer, camera and image files.
 *
 *  1. render::threads_identical   PHONG with shadows: 1 and 2 threads give
 *                                  the same image bits and counters.
 *  2. render::camera_centre_ray    the ray through the centre pixel is the
 *                                  view direction; framing keeps the box centre.
 *     render::camera_block16       a 4x4 block's rays are sg_camera_ray's
 *                                  bit for bit (every field), the mask marks
 *                                  the pixels inside the image, and rays
 *                                  outside it are not written.
 *  3. render::exr_roundtrip        float (exact) and half, ZIP and none.
 *  4. render::png_written          PNG decodes to the sRGB OETF values; the
 *                                  temporary file is gone.
 *  5. render::missing_folder       SG_ERR_IO naming the path, no file left.
 */
#include "test_support.h"

#include <dirent.h>
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/alloc.h"
#include "io/image.h"
#include "io/mesh.h"
#include "points/model_points.h"
#include "points/pointset.h"
#include "render/camera.h"
#include "render/render.h"
#include "render/world.h"
#include "surface/scene.h"

/* ---- a small test scene: unit sphere resting on a square plane --------- */

#define SPHERE_POINTS 6000
#define PLANE_SIDE 80   /* plane points per side                      */
#define PLANE_HALF 3.0f /* plane covers [-3, 3]^2 at y = 0             */

/* Sphere of radius 1 centred at (0, 1, 0) by a Fibonacci lattice (even
 * spacing), plane y = 0 by a jittered grid; radius ~ 1.6 x spacing so that
 * every surface point is covered by several splats. */
static void make_test_points(sg_pointset *ps)
{
    sg_error err;
    size_t n_plane = (size_t)PLANE_SIDE * PLANE_SIDE;
    assert_int_equal(sg_pointset_alloc(ps, SPHERE_POINTS + n_plane, &err), SG_OK);
    const float golden = 2.39996323f; /* pi (3 - sqrt 5) */
    float sphere_r = 1.6f * sqrtf(4.0f * 3.14159265f / SPHERE_POINTS);
    for (size_t i = 0; i < SPHERE_POINTS; i++) {
        float y = 1.0f - 2.0f * ((float)i + 0.5f) / SPHERE_POINTS;
        float r = sqrtf(1.0f - y * y), phi = golden * (float)i;
        ps->nx[i] = r * cosf(phi);
        ps->ny[i] = y;
        ps->nz[i] = r * sinf(phi);
        ps->px[i] = ps->nx[i];
        ps->py[i] = 1.0f + y;
        ps->pz[i] = ps->nz[i];
        ps->radius[i] = sphere_r;
        ps->ar[i] = 0.8f;
        ps->ag[i] = 0.3f + 0.4f * (float)(i % 2);
        ps->ab[i] = 0.2f;
    }
    float spacing = 2.0f * PLANE_HALF / PLANE_SIDE;
    uint64_t rng = 12345;
    for (size_t j = 0; j < n_plane; j++) {
        size_t i = SPHERE_POINTS + j;
        float gx = (float)(j % PLANE_SIDE), gz = (float)(j / PLANE_SIDE);
        ps->px[i] = -PLANE_HALF + spacing * (gx + sg_test_rand01(&rng));
        ps->py[i] = 0.0f;
        ps->pz[i] = -PLANE_HALF + spacing * (gz + sg_test_rand01(&rng));
        ps->nx[i] = 0.0f;
        ps->ny[i] = 1.0f;
        ps->nz[i] = 0.0f;
        ps->radius[i] = 1.6f * spacing;
        ps->ar[i] = ps->ag[i] = ps->ab[i] = 0.6f;
    }
    assert_int_equal(sg_pointset_validate(ps, &err), SG_OK);
}

static void render_with_threads(const sg_scene *scene, int threads, sg_image *img, sg_render_stats *st)
{
    sg_error err;
    sg_render_desc d = {.width = 72, .height = 56, .shade = SG_SHADE_PHONG, .threads = threads,
                        .light_dir = {-0.5f, 0.8f, 0.45f}};
    assert_int_equal(sg_camera_look_at(sg_v3(3.5f, 3.0f, 4.5f), sg_v3(0, 0.8f, 0), sg_v3(0, 1, 0),
                                       40.0f, 72.0f / 56.0f, &d.camera, &err), SG_OK);
    sg_status s = sg_render_frame(scene, &d, img, st, &err);
    if (s != SG_OK)
        fail_msg("render (threads %d): %s", threads, err.message);
}

static void test_render_threads_identical(void **state)
{
    (void)state;
    sg_error err;
    sg_pointset ps = {0};
    make_test_points(&ps);
    sg_scene_desc sd = {.model = SG_SURFACE_MLS};
    sg_scene *scene = NULL;
    if (sg_scene_create(&sd, &ps, &scene, &err) != SG_OK)
        fail_msg("scene: %s", err.message);
    sg_pointset_free(&ps);

    sg_image a = {0}, b = {0};
    sg_render_stats sa, sb;
    render_with_threads(scene, 1, &a, &sa);
    render_with_threads(scene, 2, &b, &sb);
    assert_int_equal(a.width, b.width);
    assert_int_equal(a.height, b.height);
    size_t floats = (size_t)a.width * (size_t)a.height * 3;
    for (size_t i = 0; i < floats; i++) {
        if (memcmp(&a.data[i], &b.data[i], sizeof(float)) != 0)
            fail_msg("pixel %zu channel %zu: 1 thread %.9g, 2 threads %.9g", i / 3, i % 3,
                     (double)a.data[i], (double)b.data[i]);
    }
    /* The frame is not trivially empty: the model is hit, shadow rays are
     * cast, and some lit-facing hits are in shadow (darker than lit). */
    assert_int_equal(sa.primary_rays, (uint64_t)a.width * (uint64_t)a.height);
    assert_true(sa.primary.hits > sa.primary_rays / 4);
    assert_true(sa.shadow_rays > 0);
    assert_true(sa.shadow.hits > 0);
    assert_int_equal(sa.rays, sa.primary_rays + sa.shadow_rays);
    assert_int_equal(sa.shadow_rays, sb.shadow_rays);
    assert_memory_equal(&sa.primary, &sb.primary, sizeof sa.primary);
    assert_memory_equal(&sa.shadow, &sb.shadow, sizeof sa.shadow);
    for (size_t i = 0; i < floats; i++)
        assert_true(isfinite(a.data[i]));
    sg_image_free(&a);
    sg_image_free(&b);
    sg_scene_destroy(scene);
}

static void test_render_camera_centre_ray(void **state)
{
    (void)state;
    sg_error err;
    sg_camera cam;
    sg_vec3 eye = sg_v3(1.0f, 2.0f, 3.0f), look = sg_v3(-2.0f, 0.5f, 0.25f);
    /* Odd sizes: pixel (50, 37) has its centre exactly at the image centre. */
    int w = 101, h = 75;
    assert_int_equal(sg_camera_look_at(eye, look, sg_v3(0, 1, 0), 50.0f, (float)w / (float)h, &cam, &err),
                     SG_OK);
    sg_ray r = sg_camera_ray(&cam, 50.0f + 0.5f, 37.0f + 0.5f, w, h);
    sg_vec3 want = sg_v3_normalize(sg_v3_sub(look, eye));
    if (fabsf(r.dir.x - want.x) > 1e-6f || fabsf(r.dir.y - want.y) > 1e-6f || fabsf(r.dir.z - want.z) > 1e-6f)
        fail_msg("centre ray (%g,%g,%g) != view (%g,%g,%g)", (double)r.dir.x, (double)r.dir.y,
                 (double)r.dir.z, (double)want.x, (double)want.y, (double)want.z);
    assert_memory_equal(&r.org, &eye, sizeof eye);
    /* Top-left pixel looks up and to the left of the view direction. */
    sg_ray tl = sg_camera_ray(&cam, 0.5f, 0.5f, w, h);
    assert_true(sg_v3_dot(tl.dir, cam.up) > 0.0f);
    assert_true(sg_v3_dot(tl.dir, cam.right) < 0.0f);
    /* Footprint: the angle between the rays of two neighbouring pixels
     * (the centre one and the one below it) is the centre ray's spread
     * to first order; an off-centre pixel's footprint is narrower. */
    sg_ray below = sg_camera_ray(&cam, 50.0f + 0.5f, 38.0f + 0.5f, w, h);
    float angle = acosf(sg_v3_dot(r.dir, below.dir));
    if (!(fabsf(r.spread - angle) < 1e-3f * angle))
        fail_msg("centre spread %g, angle to the next pixel %g", (double)r.spread, (double)angle);
    assert_true(tl.spread > 0.0f && tl.spread < r.spread);
    /* Framing: the centre ray passes through the box centre. */
    sg_aabb box = {{-1, 0, -2}, {3, 5, 1}};
    assert_int_equal(sg_camera_frame(box, sg_v3(-1, -0.5f, -1), sg_v3(0, 1, 0), 40.0f, 1.5f, 0.0f, &cam,
                                     &err), SG_OK);
    sg_vec3 c = sg_v3(1.0f, 2.5f, -0.5f);
    sg_vec3 to_c = sg_v3_normalize(sg_v3_sub(c, cam.eye));
    assert_true(sg_v3_dot(to_c, cam.forward) > 1.0f - 1e-5f);
    /* Bad input is an error, not a NaN camera. */
    assert_int_equal(sg_camera_look_at(eye, eye, sg_v3(0, 1, 0), 50.0f, 1.0f, &cam, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_camera_look_at(sg_v3(0, 0, 0), sg_v3(0, 5, 0), sg_v3(0, 1, 0), 50.0f, 1.0f, &cam,
                                       &err), SG_ERR_INVALID_ARG);
}

/* Names in the test's temp folder that start with prefix. */
static int count_entries(const char *dir, const char *prefix)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strncmp(e->d_name, prefix, strlen(prefix)) == 0)
            n++;
    closedir(d);
    return n;
}

static void test_render_camera_block16(void **state)
{
    (void)state;
    sg_error err;
    sg_camera cam;
    const int w = 37, h = 22; /* not multiples of 4: the last blocks are partial */
    assert_int_equal(sg_camera_look_at(sg_v3(0.3f, 1.7f, 4.1f), sg_v3(-0.2f, 0.4f, 0.1f), sg_v3(0, 1, 0), 53.0f,
                                       (float)w / (float)h, &cam, &err),
                     SG_OK);
    int blocks = 0;
    for (int y = -4; y < h + 4; y += 3) /* steps of 3: blocks that overlap every edge */
        for (int x = -4; x < w + 4; x += 3) {
            sg_ray rays[16];
            memset(rays, 0xA5, sizeof rays); /* a pattern no ray writes */
            unsigned mask = sg_camera_block16(&cam, x, y, w, h, rays);
            for (int q = 0; q < 16; ++q) {
                int px = x + (q & 3), py = y + (q >> 2);
                int inside = px >= 0 && py >= 0 && px < w && py < h;
                if ((int)(mask >> q & 1u) != inside)
                    fail_msg("block (%d, %d), ray %d: mask bit %u, pixel inside %d", x, y, q, mask >> q & 1u, inside);
                sg_ray want;
                if (inside)
                    want = sg_camera_ray(&cam, (float)px + 0.5f, (float)py + 0.5f, w, h);
                else
                    memset(&want, 0xA5, sizeof want);
                /* field by field: the struct's padding is not part of the ray */
                const float got_f[12] = {rays[q].org.x,    rays[q].org.y,    rays[q].org.z,  rays[q].dir.x,
                                         rays[q].dir.y,    rays[q].dir.z,    rays[q].tmin,   rays[q].tmax,
                                         rays[q].self_n.x, rays[q].self_n.y, rays[q].self_r, rays[q].spread};
                const float want_f[12] = {want.org.x,    want.org.y,    want.org.z,  want.dir.x,
                                          want.dir.y,    want.dir.z,    want.tmin,   want.tmax,
                                          want.self_n.x, want.self_n.y, want.self_r, want.spread};
                if (memcmp(got_f, want_f, sizeof got_f) != 0 || rays[q].flags != want.flags ||
                    memcmp(&rays[q].self_n.z, &want.self_n.z, sizeof(float)) != 0)
                    fail_msg("block (%d, %d), ray %d (pixel %d, %d): not sg_camera_ray's bits", x, y, q, px, py);
            }
            blocks += mask != 0;
        }
    assert_true(blocks > 50);
}

static void fill_test_image(sg_image *img, int w, int h)
{
    sg_error err;
    assert_int_equal(sg_image_alloc(img, w, h, &err), SG_OK);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float *p = img->data + 3 * ((size_t)y * (size_t)w + (size_t)x);
            p[0] = (float)x / (float)w;
            p[1] = 100.0f * (float)y / (float)h - 3.0f; /* negatives and > 1 */
            p[2] = 0.001f * (float)(x * y) + 1e-5f;
        }
}

static void check_exr_roundtrip(const sg_image *img, const char *name, sg_exr_desc d, float rel_tol)
{
    sg_error err;
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", sg_test_tmpdir(), name);
    if (sg_image_write_exr_desc(img, path, &d, &err) != SG_OK)
        fail_msg("write %s: %s", path, err.message);
    sg_image back = {0};
    if (sg_image_read_exr(path, &back, &err) != SG_OK)
        fail_msg("read %s: %s", path, err.message);
    assert_int_equal(back.width, img->width);
    assert_int_equal(back.height, img->height);
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    for (size_t i = 0; i < n; i++) {
        float a = img->data[i], b = back.data[i];
        int ok = rel_tol == 0.0f ? memcmp(&a, &b, sizeof a) == 0 : fabsf(a - b) <= rel_tol * fabsf(a) + 1e-7f;
        if (!ok)
            fail_msg("%s: pixel %zu channel %zu: wrote %.9g, read %.9g", name, i / 3, i % 3, (double)a,
                     (double)b);
    }
    sg_image_free(&back);
}

static void test_render_exr_roundtrip(void **state)
{
    (void)state;
    sg_image img = {0};
    fill_test_image(&img, 37, 41); /* 41 rows: the last ZIP chunk is partial */
    img.data[5] = INFINITY;
    check_exr_roundtrip(&img, "float_zip.exr", (sg_exr_desc){.pixel = SG_EXR_FLOAT, .compression = SG_EXR_ZIP}, 0.0f);
    check_exr_roundtrip(&img, "float_none.exr", (sg_exr_desc){.pixel = SG_EXR_FLOAT, .compression = SG_EXR_NONE}, 0.0f);
    img.data[5] = 1.0f;
    /* Half: 11 significant bits, so relative error <= 2^-11; values below
     * 2^-14 are subnormal and get the absolute slack. */
    check_exr_roundtrip(&img, "half_zip.exr", (sg_exr_desc){.pixel = SG_EXR_HALF, .compression = SG_EXR_ZIP},
                        1.0f / 2048.0f);
    check_exr_roundtrip(&img, "half_none.exr", (sg_exr_desc){.pixel = SG_EXR_HALF, .compression = SG_EXR_NONE},
                        1.0f / 2048.0f);
    assert_int_equal(count_entries(sg_test_tmpdir(), "float_zip.exr."), 0);
    /* A file that is not an EXR, or a truncated one, is SG_ERR_CORRUPT
     * naming the file; a missing file is SG_ERR_IO. */
    sg_error err;
    sg_image back = {0};
    const char *junk = sg_test_write_file("junk.exr", "not an exr file at all", 22);
    sg_status s = sg_image_read_exr(junk, &back, &err);
    if (s != SG_ERR_CORRUPT || !strstr(err.message, "junk.exr"))
        fail_msg("junk.exr: %s \"%s\", want SG_ERR_CORRUPT naming the file", sg_status_name(s), err.message);
    assert_null(back.data);

    char path[1024];
    snprintf(path, sizeof path, "%s/float_none.exr", sg_test_tmpdir());
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    static unsigned char bytes[1 << 16];
    size_t n = fread(bytes, 1, sizeof bytes, f);
    fclose(f);
    assert_true(n > 2000 && n < sizeof bytes);
    const char *cut = sg_test_write_file("truncated.exr", bytes, n / 2);
    s = sg_image_read_exr(cut, &back, &err);
    if (s != SG_ERR_CORRUPT || !strstr(err.message, "truncated.exr"))
        fail_msg("truncated.exr: %s \"%s\", want SG_ERR_CORRUPT naming the file", sg_status_name(s),
                 err.message);
    assert_null(back.data);

    snprintf(path, sizeof path, "%s/absent.exr", sg_test_tmpdir());
    s = sg_image_read_exr(path, &back, &err);
    if (s != SG_ERR_IO || !strstr(err.message, "absent.exr"))
        fail_msg("absent.exr: %s \"%s\", want SG_ERR_IO naming the file", sg_status_name(s), err.message);
    sg_image_free(&img);
}

static void test_render_png_written(void **state)
{
    (void)state;
    sg_error err;
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, 4, 2, &err), SG_OK);
    const float values[8] = {0.0f, 0.5f, 1.0f, 2.0f, -1.0f, NAN, 0.002f, 0.2f};
    for (int i = 0; i < 8; i++)
        img.data[3 * i] = img.data[3 * i + 1] = img.data[3 * i + 2] = values[i];
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", sg_test_tmpdir(), "out.png");
    if (sg_image_write(&img, path, 1.0f, &err) != SG_OK)
        fail_msg("write %s: %s", path, err.message);
    /* Written again over the existing file: still one file, no temporary. */
    if (sg_image_write_png(&img, path, 1.0f, &err) != SG_OK)
        fail_msg("rewrite %s: %s", path, err.message);
    assert_int_equal(count_entries(sg_test_tmpdir(), "out.png"), 1);

    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    assert_true(png_image_begin_read_from_file(&pi, path));
    assert_int_equal(pi.width, 4);
    assert_int_equal(pi.height, 2);
    pi.format = PNG_FORMAT_RGB;
    unsigned char px[4 * 2 * 3];
    assert_true(png_image_finish_read(&pi, NULL, px, 0, NULL));
    /* sRGB OETF: 0.5 -> 0.7354 -> 188; 0.002 -> 12.92 * 0.002 -> 7;
     * 0.2 -> 0.4845 -> 124; clamps and NaN -> 0. */
    const unsigned char want[8] = {0, 188, 255, 255, 0, 0, 7, 124};
    for (int i = 0; i < 8; i++)
        if (px[3 * i] != want[i])
            fail_msg("pixel %d: linear %g -> %u, want %u", i, (double)values[i], px[3 * i], want[i]);
    /* Exposure scales before the clamp: 0.5 * 2 = 1 -> 255. */
    assert_int_equal(sg_image_write_png(&img, path, 2.0f, &err), SG_OK);
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    assert_true(png_image_begin_read_from_file(&pi, path));
    pi.format = PNG_FORMAT_RGB;
    assert_true(png_image_finish_read(&pi, NULL, px, 0, NULL));
    assert_int_equal(px[3], 255);
    /* Unknown extension is refused. */
    assert_int_equal(sg_image_write(&img, "x.jpg", 1.0f, &err), SG_ERR_INVALID_ARG);
    sg_image_free(&img);
}

static void test_render_missing_folder(void **state)
{
    (void)state;
    sg_error err;
    sg_image img = {0};
    fill_test_image(&img, 8, 8);
    const char *exts[2] = {"png", "exr"};
    for (int i = 0; i < 2; i++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/no/such/folder/img.%s", sg_test_tmpdir(), exts[i]);
        sg_status s = sg_image_write(&img, path, 1.0f, &err);
        if (s != SG_ERR_IO)
            fail_msg("%s: status %s, want SG_ERR_IO", path, sg_status_name(s));
        if (!strstr(err.message, path))
            fail_msg("message \"%s\" does not name %s", err.message, path);
        assert_int_not_equal(access(path, F_OK), 0);
    }
    sg_image_free(&img);
}

/* The builtin ground honours "points": a grid of round(sqrt(points)) per
 * side (it used to ignore it and always make 300 x 300); absent, 300 x 300. */
static void test_world_ground_points(void **state)
{
    (void)state;
    const char *json[] = {"{\"models\":[{\"builtin\":\"ground\",\"points\":2500}]}",
                          "{\"models\":[{\"builtin\":\"ground\",\"points\":3000}]}",
                          "{\"models\":[{\"builtin\":\"ground\",\"points\":1}]}",
                          "{\"models\":[{\"builtin\":\"ground\"}]}"};
    const size_t want[] = {2500, 55 * 55, 4, 90000};
    for (int i = 0; i < 4; ++i) {
        sg_world *w = sg_test_world_from_json(json[i]);
        size_t n = sg_scene_points(sg_world_scene(w, 0))->count;
        if (n != want[i])
            fail_msg("%s: %zu splats, want %zu", json[i], n, want[i]);
        sg_world_destroy(w);
    }
}

/* An icosahedron (level 0) or its 4-way subdivision (level 1), vertices on
 * the unit sphere, outward winding, no normals (the sampler's smooth ones). */
static sg_mesh icosphere(int level)
{
    static const float t = 1.6180339887f;
    float v0[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                       {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    static const uint32_t f0[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    size_t nv = level ? 12 + 30 : 12, nt = level ? 80 : 20;
    sg_mesh m = {.vertex_count = nv, .triangle_count = nt};
    m.positions = sg_alloc_array(nv, 3 * sizeof(float));
    m.triangles = sg_alloc_array(nt, 3 * sizeof(uint32_t));
    assert_true(m.positions && m.triangles);
    for (int i = 0; i < 12; i++) {
        float l = sqrtf(v0[i][0] * v0[i][0] + v0[i][1] * v0[i][1] + v0[i][2] * v0[i][2]);
        for (int a = 0; a < 3; a++)
            m.positions[3 * i + a] = v0[i][a] / l;
    }
    if (!level) {
        memcpy(m.triangles, f0, sizeof f0);
        return m;
    }
    uint32_t edge_mid[12][12];
    memset(edge_mid, 0xFF, sizeof edge_mid);
    size_t next = 12;
    for (int f = 0; f < 20; f++) {
        uint32_t mid[3];
        for (int e = 0; e < 3; e++) {
            uint32_t a = f0[f][e], b = f0[f][(e + 1) % 3];
            if (edge_mid[a][b] == UINT32_MAX) {
                float p[3], l = 0.0f;
                for (int c = 0; c < 3; c++)
                    p[c] = 0.5f * (m.positions[3 * a + c] + m.positions[3 * b + c]), l += p[c] * p[c];
                for (int c = 0; c < 3; c++)
                    m.positions[3 * next + c] = p[c] / sqrtf(l);
                edge_mid[a][b] = edge_mid[b][a] = (uint32_t)next++;
            }
            mid[e] = edge_mid[a][b];
        }
        const uint32_t sub[4][3] = {{f0[f][0], mid[0], mid[2]}, {f0[f][1], mid[1], mid[0]},
                                    {f0[f][2], mid[2], mid[1]}, {mid[0], mid[1], mid[2]}};
        memcpy(m.triangles + 12 * f, sub, sizeof sub);
    }
    return m;
}

/* Phong renders of coarse models showed speckled self-shadowing: splats on
 * the flat triangles with smooth normals left the splat surface open along
 * the edges, and rays through the gaps saw the shadowed inside. A coarse
 * convex body cannot shadow itself: where the sphere it approximates turns
 * towards the light (n.l >= 0.5), no pixel may be in shadow. Shadowed
 * pixels are told by value: the light adds at least 0.5 x albedo x light
 * colour to the ambient term (render.h defaults). Before the fix 4.3%
 * (20 faces) and 1.0% (80 faces) of those pixels were in shadow. */
static void test_render_phong_coarse_convex_no_speckles(void **state)
{
    (void)state;
    for (int level = 0; level < 2; level++) {
        sg_mesh mesh = icosphere(level);
        sg_pointset ps;
        sg_error err;
        sg_model_points_desc md = {.points = 60000};
        if (sg_model_points_from_mesh(&mesh, "icosphere", &md, &ps, &err) != SG_OK)
            fail_msg("%s", err.message);
        sg_scene *sc = NULL;
        assert_int_equal(sg_scene_create(&(sg_scene_desc){0}, &ps, &sc, &err), SG_OK);
        const int W = 200;
        const sg_vec3 light = sg_v3_normalize(sg_v3(-0.5f, 0.8f, 0.45f));
        size_t lit = 0, dark = 0;
        for (int view = 0; view < 3; view++) {
            static const float dirs[3][3] = {{-0.6f, -0.35f, -1.0f}, {1.0f, -0.2f, 0.3f}, {0.2f, -0.9f, 0.4f}};
            sg_render_desc rd = {.width = W, .height = W, .shade = SG_SHADE_PHONG, .light_dir = light};
            assert_int_equal(sg_camera_frame(sg_pointset_bounds(&ps), sg_v3(dirs[view][0], dirs[view][1], dirs[view][2]),
                                             sg_v3(0, 1, 0), 40.0f, 1.0f, 0.0f, &rd.camera, &err),
                             SG_OK);
            sg_image img = {0};
            assert_int_equal(sg_render_frame(sc, &rd, &img, NULL, &err), SG_OK);
            for (int y = 0; y < W; y++)
                for (int x = 0; x < W; x++) {
                    /* The normal of the unit sphere where the pixel's ray meets it. */
                    sg_ray r = sg_camera_ray(&rd.camera, x + 0.5f, y + 0.5f, W, W);
                    float b = sg_v3_dot(r.org, r.dir), c = sg_v3_dot(r.org, r.org) - 0.9f; /* inside the facets */
                    float disc = b * b - c;
                    if (!(disc > 0.0f) || img.alpha[y * W + x] != 1.0f)
                        continue;
                    sg_vec3 n = sg_v3_normalize(sg_v3_madd(r.org, r.dir, -b - sqrtf(disc)));
                    if (sg_v3_dot(n, light) < 0.5f)
                        continue;
                    lit++;
                    /* albedo 0.8 x (ambient 0.3 x sky 0.6..0.9) < 0.22; lit: + 0.8 x 0.5 x 1.35 */
                    dark += img.data[3 * (y * W + x) + 2] < 0.45f;
                }
            sg_image_free(&img);
        }
        print_message("icosphere level %d: %zu of %zu lit pixels in shadow\n", level, dark, lit);
        if (!(lit > 3000) || dark > lit / 1000)
            fail_msg("icosphere level %d: %zu of %zu pixels facing the light are in shadow", level, dark, lit);
        sg_scene_destroy(sc);
        sg_pointset_free(&ps);
        sg_mesh_free(&mesh);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_threads_identical),
        cmocka_unit_test(test_render_camera_centre_ray),
        cmocka_unit_test(test_render_camera_block16),
        cmocka_unit_test(test_render_exr_roundtrip),
        cmocka_unit_test(test_render_png_written),
        cmocka_unit_test(test_render_missing_folder),
        cmocka_unit_test(test_world_ground_points),
        cmocka_unit_test(test_render_phong_coarse_convex_no_speckles),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
