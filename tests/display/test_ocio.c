/* test_ocio.c — the OpenColorIO display transform (src/display/ocio.cpp)
 * with the config splatgi ships (display/config.ocio).
 *
 * 1. Standard view: linear 0 -> 0, 1 -> 255, 0.18 -> 118 (sRGB OETF), a
 *    ramp within 1 step of the sRGB formula (float within 2e-4); RGBA
 *    layout (channel order, alpha 255, row 0 top).
 * 2. Every view is monotonic over 13 decades; Filmic-like keeps middle grey
 *    at 118, maps 1 and 1e3 below 255 and reaches 255 at 1e5; Raw clips.
 * 3. Exposure: +1 stop on 0.09 gives the bits of 0 stops on 0.18, at create
 *    and through sg_display_set_exposure; gamma 2.2 is out^(1/2.2).
 * 4. NaN, -Inf, negatives give 0 and +Inf gives 255, in every view (float
 *    within 1e-6: OCIO's CPU path uses a fast pow).
 * 5. $OCIO is respected (a copy of the shipped config whose default view is
 *    Raw), "" falls back to the shipped one, desc.config_path wins over it.
 * 6. Missing, garbled and LUT-less configs: SG_ERR_IO / SG_ERR_CORRUPT
 *    naming the path; unknown display or view: SG_ERR_INVALID_ARG listing
 *    the available ones; *out untouched on failure.
 * 7. 1 and 4 threads, in place and not, give identical bits.
 * 8. The 8-bit output (OCIO's half-in, 8-bit-out processor, ocio.cpp
 *    invariant 5) is within 1 of round(255 * the float output), channel by
 *    channel, for colours over 12 decades, in every view and exposure.
 */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "display/ocio.h"
#include "io/image.h"

static const char *const VIEWS[3] = {"Standard", "Filmic-like", "Raw"};

static double srgb_oetf(double y)
{
    return y <= 0.0031308 ? 12.92 * y : 1.055 * pow(y, 1.0 / 2.4) - 0.055;
}

static sg_display *open_view(const char *view, float stops)
{
    sg_display_desc desc = {.config_path = SG_OCIO_DEFAULT_CONFIG, .view = view,
                            .exposure_stops = stops};
    sg_display *d = NULL;
    sg_error err;
    sg_status st = sg_display_create(&desc, &d, &err);
    if (st != SG_OK)
        fail_msg("create view %s: %s: %s", view ? view : "(default)", sg_status_name(st), err.message);
    return d;
}

/* A 1-row grey image, pixel i = (v[i], v[i], v[i]). */
static sg_image grey_row(const float *v, int n)
{
    sg_image img;
    assert_int_equal(sg_image_alloc(&img, n, 1, NULL), SG_OK);
    for (int i = 0; i < n; i++)
        img.data[3 * i] = img.data[3 * i + 1] = img.data[3 * i + 2] = v[i];
    return img;
}

/* Red channel of the 8-bit output for grey inputs; checks R = G = B. */
static void apply8(const sg_display *d, const float *v, int n, int *out)
{
    sg_image img = grey_row(v, n);
    uint8_t *px = malloc((size_t)n * 4);
    assert_non_null(px);
    sg_error err;
    sg_status st = sg_display_apply(d, &img, px, &err);
    if (st != SG_OK)
        fail_msg("apply: %s", err.message);
    for (int i = 0; i < n; i++) {
        assert_int_equal(px[4 * i], px[4 * i + 1]);
        assert_int_equal(px[4 * i], px[4 * i + 2]);
        assert_int_equal(px[4 * i + 3], 255);
        out[i] = px[4 * i];
    }
    free(px);
    sg_image_free(&img);
}

static void applyf(const sg_display *d, const float *v, int n, float *out)
{
    sg_image img = grey_row(v, n);
    sg_error err;
    sg_status st = sg_display_apply_float(d, &img, img.data, &err);
    if (st != SG_OK)
        fail_msg("apply_float: %s", err.message);
    for (int i = 0; i < n; i++)
        out[i] = img.data[3 * i];
    sg_image_free(&img);
}

/* 1 */
static void test_display_standard_srgb(void **state)
{
    (void)state;
    sg_display *d = open_view("Standard", 0.0f);
    const float key[4] = {0.0f, 1.0f, 0.18f, 0.5f};
    int k[4];
    apply8(d, key, 4, k);
    if (k[0] != 0 || k[1] != 255 || abs(k[2] - 118) > 1 || abs(k[3] - 188) > 1)
        fail_msg("0 -> %d (want 0), 1 -> %d (255), 0.18 -> %d (118), 0.5 -> %d (188)", k[0], k[1],
                 k[2], k[3]);

    enum { N = 1001 };
    float v[N], f[N];
    int b[N];
    for (int i = 0; i < N; i++)
        v[i] = (float)i / (N - 1);
    apply8(d, v, N, b);
    applyf(d, v, N, f);
    for (int i = 0; i < N; i++) {
        double want = srgb_oetf(v[i]);
        if (fabs(f[i] - want) > 2e-4 || abs(b[i] - (int)lround(255.0 * want)) > 1)
            fail_msg("linear %.6f: float %.6f byte %d, sRGB OETF %.6f (byte %ld)", v[i], f[i], b[i],
                     want, lround(255.0 * want));
    }
    sg_display_destroy(d);
}

static void test_display_rgba_layout(void **state)
{
    (void)state;
    sg_display *d = open_view("Standard", 0.0f);
    sg_image img;
    assert_int_equal(sg_image_alloc(&img, 2, 3, NULL), SG_OK);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 2; x++) {
            float *p = img.data + 3 * (y * 2 + x);
            p[0] = 1.0f;                  /* R: white                  */
            p[1] = y == 0 ? 0.18f : 0.0f; /* G: only the top row       */
            p[2] = x == 1 ? 1.0f : 0.0f;  /* B: only the right column  */
        }
    uint8_t px[2 * 3 * 4];
    sg_error err;
    assert_int_equal(sg_display_apply(d, &img, px, &err), SG_OK);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 2; x++) {
            const uint8_t *p = px + 4 * (y * 2 + x);
            int g = y == 0 ? 118 : 0, bl = x == 1 ? 255 : 0;
            if (p[0] != 255 || abs(p[1] - g) > 1 || p[2] != bl || p[3] != 255)
                fail_msg("pixel (%d,%d) = %d %d %d %d, want 255 %d %d 255", x, y, p[0], p[1], p[2],
                         p[3], g, bl);
        }
    sg_image_free(&img);
    sg_display_destroy(d);
}

/* 2 */
static void test_display_views_monotonic(void **state)
{
    (void)state;
    enum { N = 2601 };
    static float v[N], f[N];
    static int b[N];
    v[0] = 0.0f;
    for (int i = 1; i < N; i++)
        v[i] = (float)pow(10.0, -7.0 + 13.0 * (i - 1) / (N - 2)); /* 1e-7 .. 1e6 */
    for (int k = 0; k < 3; k++) {
        sg_display *d = open_view(VIEWS[k], 0.0f);
        apply8(d, v, N, b);
        applyf(d, v, N, f);
        for (int i = 1; i < N; i++)
            if (b[i] < b[i - 1] || f[i] < f[i - 1])
                fail_msg("%s: not monotonic: %g -> %.7f (%d), %g -> %.7f (%d)", VIEWS[k], v[i - 1],
                         f[i - 1], b[i - 1], v[i], f[i], b[i]);
        if (b[0] != 0 || b[N - 1] != 255)
            fail_msg("%s: 0 -> %d, 1e6 -> %d (want 0, 255)", VIEWS[k], b[0], b[N - 1]);
        sg_display_destroy(d);
    }
}

static void test_display_filmic_like_tone_curve(void **state)
{
    (void)state;
    sg_display *d = open_view("Filmic-like", 0.0f);
    const float v[6] = {0.0f, 0.18f, 1.0f, 16.0f, 1.0e3f, 1.0e5f};
    int b[6];
    apply8(d, v, 6, b);
    /* Grey where Standard puts it; 1 and 16 compressed but bright; 1e3
     * (12.4 stops over grey) still below white; white by 2^16 * grey. */
    if (b[0] != 0 || abs(b[1] - 118) > 1 || b[2] >= 255 || b[2] <= b[1] || b[3] >= 250 ||
        b[4] >= 255 || b[4] < 245 || b[5] != 255)
        fail_msg("Filmic-like: 0 -> %d, 0.18 -> %d, 1 -> %d, 16 -> %d, 1e3 -> %d, 1e5 -> %d", b[0],
                 b[1], b[2], b[3], b[4], b[5]);
    sg_display_destroy(d);

    d = open_view("Raw", 0.0f);
    const float r[4] = {0.25f, 0.5f, 2.0f, 1e-3f};
    float f[4];
    applyf(d, r, 4, f);
    if (fabsf(f[0] - 0.25f) > 1e-6f || fabsf(f[1] - 0.5f) > 1e-6f || f[2] != 1.0f ||
        fabsf(f[3] - 1e-3f) > 1e-8f)
        fail_msg("Raw: 0.25 -> %g, 0.5 -> %g, 2 -> %g, 1e-3 -> %g", f[0], f[1], f[2], f[3]);
    sg_display_destroy(d);
}

/* 3 */
static void test_display_exposure_doubles(void **state)
{
    (void)state;
    const float base[5] = {0.18f, 0.09f, 1.4f, 6.0f, 300.0f};
    float half[5], f0[5], f1[5];
    int b0[5], b1[5];
    for (int i = 0; i < 5; i++)
        half[i] = base[i] / 2;
    for (int k = 0; k < 3; k++) {
        sg_display *d0 = open_view(VIEWS[k], 0.0f), *d1 = open_view(VIEWS[k], 1.0f);
        apply8(d0, base, 5, b0);
        applyf(d0, base, 5, f0);
        apply8(d1, half, 5, b1);
        applyf(d1, half, 5, f1);
        for (int i = 0; i < 5; i++)
            if (b0[i] != b1[i] || f0[i] != f1[i])
                fail_msg("%s: %g at 0 stops -> %.7f (%d), %g at +1 -> %.7f (%d)", VIEWS[k], base[i],
                         f0[i], b0[i], half[i], f1[i], b1[i]);
        /* Changing the exposure later: -1 stop on 2x gives the same bits. */
        float twice[5];
        for (int i = 0; i < 5; i++)
            twice[i] = base[i] * 2;
        sg_error err;
        assert_int_equal(sg_display_set_exposure(d1, -1.0f, &err), SG_OK);
        applyf(d1, twice, 5, f1);
        for (int i = 0; i < 5; i++)
            if (f0[i] != f1[i])
                fail_msg("%s: set_exposure(-1) on %g -> %.7f, want %.7f", VIEWS[k], twice[i], f1[i],
                         f0[i]);
        sg_display_info info;
        sg_display_get_info(d1, &info);
        assert_true(info.exposure_stops == -1.0f);
        assert_int_equal(sg_display_set_exposure(d1, NAN, &err), SG_ERR_INVALID_ARG);
        sg_display_destroy(d0);
        sg_display_destroy(d1);
    }

    /* Display gamma 2.2 after the view. */
    sg_display_desc desc = {.config_path = SG_OCIO_DEFAULT_CONFIG, .gamma = 2.2f};
    sg_display *dg = NULL, *d0 = open_view("Standard", 0.0f);
    sg_error err;
    assert_int_equal(sg_display_create(&desc, &dg, &err), SG_OK);
    const float g[3] = {0.05f, 0.18f, 0.7f};
    float fg[3], fs[3];
    applyf(dg, g, 3, fg);
    applyf(d0, g, 3, fs);
    for (int i = 0; i < 3; i++)
        if (fabsf(fg[i] - powf(fs[i], 1.0f / 2.2f)) > 1e-6f)
            fail_msg("gamma 2.2: %g -> %.7f, Standard %.7f ^ (1/2.2) = %.7f", g[i], fg[i], fs[i],
                     powf(fs[i], 1.0f / 2.2f));
    sg_display_destroy(dg);
    sg_display_destroy(d0);

    sg_display *bad = (sg_display *)&err;
    desc.gamma = -1.0f;
    assert_int_equal(sg_display_create(&desc, &bad, &err), SG_ERR_INVALID_ARG);
    desc.gamma = 0.0f;
    desc.exposure_stops = INFINITY;
    assert_int_equal(sg_display_create(&desc, &bad, &err), SG_ERR_INVALID_ARG);
    assert_ptr_equal(bad, (sg_display *)&err);
}

/* 4 */
static void test_display_nan_negative_give_zero(void **state)
{
    (void)state;
    const float v[6] = {NAN, -1.0f, -INFINITY, -0.0f, -1e30f, INFINITY};
    const int want[6] = {0, 0, 0, 0, 0, 255};
    int b[6];
    float f[6];
    for (int k = 0; k < 3; k++)
        for (int e = 0; e < 2; e++) {
            sg_display *d = open_view(VIEWS[k], e ? 3.0f : 0.0f);
            apply8(d, v, 6, b);
            applyf(d, v, 6, f);
            for (int i = 0; i < 6; i++)
                if (b[i] != want[i] || fabsf(f[i] - (float)want[i] / 255.0f) > 1e-6f)
                    fail_msg("%s, %d stops: %g -> %d (float %g), want %d", VIEWS[k], e ? 3 : 0, v[i],
                             b[i], f[i], want[i]);
            sg_display_destroy(d);
        }
}

/* 5 */
static char *read_text(const char *path)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    assert_int_equal(fseek(f, 0, SEEK_END), 0);
    long n = ftell(f);
    assert_true(n > 0);
    rewind(f);
    char *s = malloc((size_t)n + 1);
    assert_non_null(s);
    assert_int_equal(fread(s, 1, (size_t)n, f), (size_t)n);
    s[n] = 0;
    fclose(f);
    return s;
}

/* Copy of s with the one occurrence of `from` replaced by `to` (fails the
 * test when `from` is absent, so a changed shipped config shows here). */
static char *replace_once(char *s, const char *from, const char *to)
{
    char *at = strstr(s, from);
    if (!at)
        fail_msg("shipped config lacks \"%s\"", from);
    size_t n = strlen(s) - strlen(from) + strlen(to);
    char *r = malloc(n + 1);
    assert_non_null(r);
    size_t pre = (size_t)(at - s);
    memcpy(r, s, pre);
    strcpy(r + pre, to);
    strcat(r, at + strlen(from));
    free(s);
    return r;
}

static void test_display_ocio_env_var(void **state)
{
    (void)state;
    char *cfg = read_text(SG_OCIO_DEFAULT_CONFIG);
    cfg = replace_once(cfg, "active_views: [Standard, Filmic-like, Raw]",
                       "active_views: [Raw, Standard, Filmic-like]");
    cfg = replace_once(cfg, "search_path: luts", "search_path: " SG_SOURCE_DIR "/display/luts");
    char path[1024];
    snprintf(path, sizeof path, "%s", sg_test_write_file("env_config.ocio", cfg, strlen(cfg)));
    free(cfg);

    sg_error err;
    sg_display *d = NULL;
    sg_display_info info;
    assert_int_equal(setenv("OCIO", path, 1), 0);
    sg_status st = sg_display_create(NULL, &d, &err);
    if (st != SG_OK)
        fail_msg("$OCIO=%s: %s", path, err.message);
    sg_display_get_info(d, &info);
    if (strcmp(info.config_path, path) != 0 || strcmp(info.config_from, "$OCIO") != 0 ||
        strcmp(info.view, "Raw") != 0 || strcmp(info.display, "sRGB") != 0)
        fail_msg("$OCIO=%s: loaded %s (from %s), %s / %s; want that file, view Raw", path,
                 info.config_path, info.config_from, info.display, info.view);
    const float v[2] = {0.25f, 4.0f};
    float f[2];
    applyf(d, v, 2, f); /* Raw: unchanged, clipped */
    if (fabsf(f[0] - 0.25f) > 1e-6f || f[1] != 1.0f)
        fail_msg("$OCIO default view Raw: 0.25 -> %g, 4 -> %g", f[0], f[1]);
    sg_display_destroy(d);

    /* The copy's views still work (its LUT found through search_path). */
    sg_display_desc desc = {.view = "Filmic-like"};
    assert_int_equal(sg_display_create(&desc, &d, &err), SG_OK);
    sg_display_destroy(d);

    /* desc.config_path wins over $OCIO. */
    desc = (sg_display_desc){.config_path = SG_OCIO_DEFAULT_CONFIG};
    assert_int_equal(sg_display_create(&desc, &d, &err), SG_OK);
    sg_display_get_info(d, &info);
    assert_string_equal(info.view, "Standard");
    assert_string_equal(info.config_from, "desc");
    sg_display_destroy(d);

    /* A missing $OCIO file is an error naming it and $OCIO. */
    assert_int_equal(setenv("OCIO", "/nonexistent/splatgi-env.ocio", 1), 0);
    sg_display *untouched = (sg_display *)&err;
    d = untouched;
    assert_int_equal(sg_display_create(NULL, &d, &err), SG_ERR_IO);
    assert_ptr_equal(d, untouched);
    if (!strstr(err.message, "/nonexistent/splatgi-env.ocio") || !strstr(err.message, "$OCIO"))
        fail_msg("missing $OCIO config: message \"%s\" names neither path nor $OCIO", err.message);

    /* Empty and unset $OCIO: the shipped config. */
    for (int unset = 0; unset < 2; unset++) {
        if (unset)
            assert_int_equal(unsetenv("OCIO"), 0);
        else
            assert_int_equal(setenv("OCIO", "", 1), 0);
        assert_int_equal(sg_display_create(NULL, &d, &err), SG_OK);
        sg_display_get_info(d, &info);
        if (strcmp(info.config_path, SG_OCIO_DEFAULT_CONFIG) != 0 ||
            strcmp(info.config_from, "default") != 0 || strcmp(info.view, "Standard") != 0)
            fail_msg("$OCIO %s: loaded %s (from %s) view %s", unset ? "unset" : "empty",
                     info.config_path, info.config_from, info.view);
        sg_display_destroy(d);
    }
}

/* 6 */
static void expect_error(const sg_display_desc *desc, sg_status want, const char *needle1,
                         const char *needle2)
{
    sg_error err;
    sg_display *untouched = (sg_display *)&err, *d = untouched;
    sg_status st = sg_display_create(desc, &d, &err);
    if (st != want || !strstr(err.message, needle1) || (needle2 && !strstr(err.message, needle2)))
        fail_msg("config %s display %s view %s: got %s \"%s\"; want %s naming \"%s\"%s%s",
                 desc->config_path, desc->display ? desc->display : "-", desc->view ? desc->view : "-",
                 sg_status_name(st), err.message, sg_status_name(want), needle1,
                 needle2 ? " and " : "", needle2 ? needle2 : "");
    assert_ptr_equal(d, untouched);
}

static void test_display_bad_config(void **state)
{
    (void)state;
    sg_display_desc desc = {.config_path = "/nonexistent/dir/config.ocio"};
    expect_error(&desc, SG_ERR_IO, "/nonexistent/dir/config.ocio", "No such file");

    desc.config_path = sg_test_tmpdir(); /* a folder */
    expect_error(&desc, SG_ERR_IO, sg_test_tmpdir(), NULL);

    const char garbage[] = "ocio_profile_version: 2\nroles: [this is : not {a config\n";
    char path[1024];
    snprintf(path, sizeof path, "%s", sg_test_write_file("garbage.ocio", garbage, sizeof garbage - 1));
    desc.config_path = path;
    expect_error(&desc, SG_ERR_CORRUPT, path, NULL);

    const char not_yaml[] = "\x89PNG\r\n\x1a\n binary";
    snprintf(path, sizeof path, "%s", sg_test_write_file("png.ocio", not_yaml, sizeof not_yaml - 1));
    expect_error(&desc, SG_ERR_CORRUPT, path, NULL);

    /* A copy without its LUT folder: the Filmic-like view's file is missing. */
    char *cfg = read_text(SG_OCIO_DEFAULT_CONFIG);
    snprintf(path, sizeof path, "%s", sg_test_write_file("nolut.ocio", cfg, strlen(cfg)));
    free(cfg);
    desc.view = "Filmic-like";
    expect_error(&desc, SG_ERR_IO, path, "filmic_like.spi1d");
    desc.view = "Standard"; /* the views that need no file still work */
    sg_display *d = NULL;
    sg_error err;
    assert_int_equal(sg_display_create(&desc, &d, &err), SG_OK);
    sg_display_destroy(d);
}

static void test_display_unknown_view_lists(void **state)
{
    (void)state;
    sg_display_desc desc = {.config_path = SG_OCIO_DEFAULT_CONFIG, .view = "Vivid"};
    expect_error(&desc, SG_ERR_INVALID_ARG, "\"Vivid\"", "views: Standard, Filmic-like, Raw");
    expect_error(&desc, SG_ERR_INVALID_ARG, SG_OCIO_DEFAULT_CONFIG, NULL);
    desc = (sg_display_desc){.config_path = SG_OCIO_DEFAULT_CONFIG, .display = "DCI-P3"};
    expect_error(&desc, SG_ERR_INVALID_ARG, "\"DCI-P3\"", "displays: sRGB");

    /* sg_display_list: the displays, their views, an unknown display. */
    sg_display *d = open_view(NULL, 0.0f);
    sg_display_names names;
    sg_error err;
    assert_int_equal(sg_display_list(d, NULL, &names, &err), SG_OK);
    assert_int_equal(names.count, 1);
    assert_string_equal(names.names[0], "sRGB");
    assert_int_equal(sg_display_list(d, "sRGB", &names, &err), SG_OK);
    assert_int_equal(names.count, 3);
    for (int i = 0; i < 3; i++)
        assert_string_equal(names.names[i], VIEWS[i]);
    sg_display_names kept = names;
    assert_int_equal(sg_display_list(d, "DCI-P3", &names, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "displays: sRGB"));
    assert_int_equal(names.count, kept.count);
    assert_ptr_equal(names.names, kept.names);
    sg_display_info info;
    sg_display_get_info(d, &info);
    assert_string_equal(info.display, "sRGB");
    assert_string_equal(info.view, "Standard");
    assert_true(info.gamma == 1.0f);
    sg_display_destroy(d);
    sg_display_destroy(NULL);
}

/* 7 */
static void test_display_threads_identical(void **state)
{
    (void)state;
    enum { W = 301, H = 97 };
    sg_image img;
    assert_int_equal(sg_image_alloc(&img, W, H, NULL), SG_OK);
    uint64_t rs = 42;
    for (int i = 0; i < 3 * W * H; i++)
        img.data[i] = expf(16.0f * sg_test_rand01(&rs) - 9.0f); /* 1e-4 .. 1e3 */
    for (int k = 0; k < 3; k++) {
        float *out[2];
        uint8_t *px[2];
        for (int t = 0; t < 2; t++) {
            sg_display_desc desc = {.config_path = SG_OCIO_DEFAULT_CONFIG, .view = VIEWS[k],
                                    .threads = t ? 4 : 1, .exposure_stops = 0.5f};
            sg_display *d = NULL;
            sg_error err;
            assert_int_equal(sg_display_create(&desc, &d, &err), SG_OK);
            out[t] = malloc(sizeof(float) * 3 * W * H);
            px[t] = malloc(4 * W * H);
            assert_non_null(out[t]);
            assert_non_null(px[t]);
            assert_int_equal(sg_display_apply_float(d, &img, out[t], &err), SG_OK);
            assert_int_equal(sg_display_apply(d, &img, px[t], &err), SG_OK);
            if (t == 1) { /* in place gives the same bits */
                sg_image copy;
                assert_int_equal(sg_image_alloc(&copy, W, H, NULL), SG_OK);
                memcpy(copy.data, img.data, sizeof(float) * 3 * W * H);
                assert_int_equal(sg_display_apply_float(d, &copy, copy.data, &err), SG_OK);
                assert_memory_equal(copy.data, out[1], sizeof(float) * 3 * W * H);
                /* a partial overlap is refused */
                assert_int_equal(sg_display_apply_float(d, &copy, copy.data + 3, &err),
                                 SG_ERR_INVALID_ARG);
                sg_image_free(&copy);
            }
            sg_display_destroy(d);
        }
        for (int i = 0; i < 3 * W * H; i++)
            if (out[0][i] != out[1][i])
                fail_msg("%s: value %d: 1 thread %.9g, 4 threads %.9g", VIEWS[k], i, out[0][i],
                         out[1][i]);
        assert_memory_equal(px[0], px[1], 4 * W * H);
        for (int t = 0; t < 2; t++) {
            free(out[t]);
            free(px[t]);
        }
    }
    sg_image_free(&img);
}

static void test_display_bad_args(void **state)
{
    (void)state;
    sg_display *d = open_view("Standard", 0.0f);
    sg_error err;
    uint8_t px[16];
    sg_image empty = {0, 0, NULL, NULL};
    assert_int_equal(sg_display_apply(d, &empty, px, &err), SG_ERR_INVALID_ARG);
    const float v[1] = {0.5f};
    sg_image one = grey_row(v, 1);
    assert_int_equal(sg_display_apply(d, &one, NULL, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_display_apply(NULL, &one, px, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_display_apply_float(d, NULL, one.data, &err), SG_ERR_INVALID_ARG);
    assert_int_equal(sg_display_create(NULL, NULL, &err), SG_ERR_INVALID_ARG);
    sg_display_desc desc = {.config_path = SG_OCIO_DEFAULT_CONFIG, .threads = -2};
    sg_display *out = NULL;
    assert_int_equal(sg_display_create(&desc, &out, &err), SG_ERR_INVALID_ARG);
    assert_null(out);
    sg_image_free(&one);
    sg_display_destroy(d);
}

/* 8 */
static void test_display_bytes_match_float(void **state)
{
    (void)state;
    enum { N = 4000 };
    sg_image img;
    assert_int_equal(sg_image_alloc(&img, N, 1, NULL), SG_OK);
    float *f = malloc(sizeof(float) * 3 * N);
    uint8_t *px = malloc(4 * N);
    assert_non_null(f);
    assert_non_null(px);
    uint64_t rng = 7;
    for (int i = 0; i < 3 * N; i++) { /* 1e-6 .. 1e6, log-uniform, channels apart */
        rng = rng * 6364136223846793005ull + 1442695040888963407ull;
        img.data[i] = powf(10.0f, -6.0f + 12.0f * (float)(rng >> 40) / (float)(1u << 24));
    }
    for (int k = 0; k < 3; k++)
        for (int e = -1; e <= 1; e++) {
            sg_display *d = open_view(VIEWS[k], 2.5f * (float)e);
            sg_error err;
            if (sg_display_apply(d, &img, px, &err) != SG_OK || sg_display_apply_float(d, &img, f, &err) != SG_OK)
                fail_msg("%s: %s", VIEWS[k], err.message);
            int over = 0;
            for (int i = 0; i < N; i++) {
                if (px[4 * i + 3] != 255)
                    fail_msg("%s, %g stops, pixel %d: alpha %d", VIEWS[k], 2.5 * e, i, px[4 * i + 3]);
                for (int c = 0; c < 3; c++) {
                    long want = lround(255.0 * f[3 * i + c]);
                    if (labs((long)px[4 * i + c] - want) > 1)
                        fail_msg("%s, %g stops, pixel %d channel %d: linear %g -> byte %d, float %g (byte %ld)",
                                 VIEWS[k], 2.5 * e, i, c, (double)img.data[3 * i + c], px[4 * i + c],
                                 (double)f[3 * i + c], want);
                    over += px[4 * i + c] != want;
                }
            }
            print_message("%s, %g stops: %d of %d bytes 1 off the float output\n", VIEWS[k], 2.5 * e, over, 3 * N);
            sg_display_destroy(d);
        }
    free(px);
    free(f);
    sg_image_free(&img);
}

int main(void)
{
    /* The results must not depend on the caller's OCIO setup. */
    unsetenv("OCIO");
    unsetenv("OCIO_ACTIVE_DISPLAYS");
    unsetenv("OCIO_ACTIVE_VIEWS");
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_display_standard_srgb),
        cmocka_unit_test(test_display_rgba_layout),
        cmocka_unit_test(test_display_views_monotonic),
        cmocka_unit_test(test_display_filmic_like_tone_curve),
        cmocka_unit_test(test_display_exposure_doubles),
        cmocka_unit_test(test_display_nan_negative_give_zero),
        cmocka_unit_test(test_display_ocio_env_var),
        cmocka_unit_test(test_display_bad_config),
        cmocka_unit_test(test_display_unknown_view_lists),
        cmocka_unit_test(test_display_threads_identical),
        cmocka_unit_test(test_display_bad_args),
        cmocka_unit_test(test_display_bytes_match_float),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
