/* test_hdr.c — the Radiance RGBE reader (src/io/hdr.c).
 *
 * 1. Hand-made flat and run-length fixtures decode exactly to
 *    (m + 0.5) 2^(E - 136), E = 0 to black; header variants are accepted.
 * 2. Each malformed fixture gives the right code, a message naming the file
 *    (and the scanline where one applies), and leaves *out untouched.
 * 3. Every prefix and every single-byte change of a valid RLE file gives
 *    SG_OK or a clean error: no crash, no hang.
 * 4. The real three.js maps read as 1024 x 512 with the maxima of
 *    MANIFEST.md.
 */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "io/hdr.h"

typedef struct bytes {
    unsigned char b[4096]; /* fixture under construction */
    size_t n;              /* bytes used                 */
} bytes;

static void put(bytes *f, const void *p, size_t n)
{
    assert_true(f->n + n <= sizeof f->b);
    memcpy(f->b + f->n, p, n);
    f->n += n;
}
static void put_str(bytes *f, const char *s) { put(f, s, strlen(s)); }
static void put_u8(bytes *f, int v)
{
    unsigned char c = (unsigned char)v;
    put(f, &c, 1);
}

static float rgbe_value(int m, int e) { return e == 0 ? 0.0f : ((float)m + 0.5f) * ldexpf(1.0f, e - 136); }

static void expect_pixel(const sg_image *img, int x, int y, const unsigned char rgbe[4], const char *what)
{
    const float *p = img->data + 3 * ((size_t)y * img->width + x);
    for (int c = 0; c < 3; c++) {
        float want = rgbe_value(rgbe[c], rgbe[3]);
        if (p[c] != want)
            fail_msg("%s: pixel (%d, %d) channel %d: got %.9g, want %.9g (rgbe %d %d %d %d)", what, x, y, c,
                     (double)p[c], (double)want, rgbe[0], rgbe[1], rgbe[2], rgbe[3]);
    }
}

static sg_image read_ok(const char *name, const bytes *f)
{
    const char *path = sg_test_write_file(name, f->b, f->n);
    sg_image img = {0};
    sg_error err = {0};
    sg_status st = sg_hdr_read(path, &img, &err);
    if (st != SG_OK)
        fail_msg("%s: %s: %s", name, sg_status_name(st), err.message);
    return img;
}

/* Reads a fixture that must fail with want; checks the message names the
 * file and contains needle (if any), and that *out was not written. */
static void read_fails(const char *name, const bytes *f, sg_status want, const char *needle)
{
    const char *path = sg_test_write_file(name, f->b, f->n);
    sg_image img = {7, 9, (float *)&img, NULL}; /* sentinel: must stay */
    sg_error err = {0};
    sg_status st = sg_hdr_read(path, &img, &err);
    if (st != want)
        fail_msg("%s: got %s (%s), want %s", name, sg_status_name(st), err.message, sg_status_name(want));
    if (!strstr(err.message, name))
        fail_msg("%s: message does not name the file: \"%s\"", name, err.message);
    if (needle && !strstr(err.message, needle))
        fail_msg("%s: message lacks \"%s\": \"%s\"", name, needle, err.message);
    if (img.width != 7 || img.height != 9 || img.data != (float *)&img)
        fail_msg("%s: *out was written on failure", name);
}

/* A 3 x 2 image: widths below 8 are always flat. */
static const unsigned char flat_px[2][3][4] = {
    {{128, 64, 32, 129}, {0, 0, 0, 0}, {255, 255, 255, 140}},
    {{10, 200, 3, 100}, {17, 17, 17, 255}, {1, 2, 3, 128}},
};

static void make_flat(bytes *f, const char *header)
{
    f->n = 0;
    put_str(f, header);
    put_str(f, "-Y 2 +X 3\n");
    put(f, flat_px, sizeof flat_px);
}

static void test_hdr_flat_decodes_exactly(void **state)
{
    (void)state;
    bytes f;
    make_flat(&f, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n");
    sg_image img = read_ok("flat.hdr", &f);
    assert_int_equal(img.width, 3);
    assert_int_equal(img.height, 2);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 3; x++)
            expect_pixel(&img, x, y, flat_px[y][x], "flat.hdr");
    sg_image_free(&img);

    /* #?RGBE magic, ignored variables and comments, CRLF, no FORMAT line. */
    make_flat(&f, "#?RGBE\r\n# made by hand\r\nGAMMA=2.2\r\nEXPOSURE=4\r\nPRIMARIES=0 0 0 0 0 0 0 0\r\n\r\n");
    img = read_ok("flat_variants.hdr", &f);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 3; x++)
            expect_pixel(&img, x, y, flat_px[y][x], "flat_variants.hdr (EXPOSURE is ignored)");
    sg_image_free(&img);
}

/* A 10 x 2 RLE image. Row 0: R = run of 10 x 200; G = literal of 10;
 * B = run 4 x 7, literal 3, run 3 x 9; E = run of 10 x 130.
 * Row 1 is flat (mixing is legal): pixel x = (x, 2x, 255 - x, 120 + x). */
static void make_rle(bytes *f)
{
    f->n = 0;
    put_str(f, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 10\n");
    const unsigned char hdr[4] = {2, 2, 0, 10};
    put(f, hdr, 4);
    put_u8(f, 128 + 10), put_u8(f, 200);
    put_u8(f, 10);
    for (int x = 0; x < 10; x++)
        put_u8(f, 11 * x + 1);
    put_u8(f, 128 + 4), put_u8(f, 7);
    put_u8(f, 3), put_u8(f, 50), put_u8(f, 51), put_u8(f, 52);
    put_u8(f, 128 + 3), put_u8(f, 9);
    put_u8(f, 128 + 10), put_u8(f, 130);
    for (int x = 0; x < 10; x++) {
        unsigned char p[4] = {(unsigned char)x, (unsigned char)(2 * x), (unsigned char)(255 - x),
                              (unsigned char)(120 + x)};
        put(f, p, 4);
    }
}

static void rle_expected(int x, int y, unsigned char out[4])
{
    if (y == 0) {
        static const unsigned char b[10] = {7, 7, 7, 7, 50, 51, 52, 9, 9, 9};
        out[0] = 200, out[1] = (unsigned char)(11 * x + 1), out[2] = b[x], out[3] = 130;
    } else {
        out[0] = (unsigned char)x, out[1] = (unsigned char)(2 * x), out[2] = (unsigned char)(255 - x),
        out[3] = (unsigned char)(120 + x);
    }
}

static void test_hdr_rle_decodes_exactly(void **state)
{
    (void)state;
    bytes f;
    make_rle(&f);
    sg_image img = read_ok("rle.hdr", &f);
    assert_int_equal(img.width, 10);
    assert_int_equal(img.height, 2);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 10; x++) {
            unsigned char want[4];
            rle_expected(x, y, want);
            expect_pixel(&img, x, y, want, "rle.hdr");
        }
    sg_image_free(&img);
}

static void test_hdr_malformed_fixtures(void **state)
{
    (void)state;
    bytes f;

    make_rle(&f);
    f.n -= 20; /* cut inside the flat row 1 */
    read_fails("cut_flat_row.hdr", &f, SG_ERR_CORRUPT, "scanline 1");

    make_rle(&f);
    f.n = 72; /* header is 46 bytes, RLE row 0 bytes 46..72: cut its last byte */
    read_fails("cut_rle_row.hdr", &f, SG_ERR_CORRUPT, "scanline 0");

    make_rle(&f);
    f.b[50] = 128 + 11; /* first R run: 11 pixels in a row of 10 */
    read_fails("run_overflow.hdr", &f, SG_ERR_CORRUPT, "scanline 0: run of 11");

    make_rle(&f);
    f.b[52] = 0; /* G literal of length 0 */
    read_fails("zero_literal.hdr", &f, SG_ERR_CORRUPT, "zero-length literal");

    make_rle(&f);
    f.b[52] = 11; /* G literal of 11 */
    read_fails("literal_overflow.hdr", &f, SG_ERR_CORRUPT, "literal of 11");

    make_rle(&f);
    f.b[49] = 12; /* RLE line header says width 12 */
    read_fails("rle_width.hdr", &f, SG_ERR_CORRUPT, "gives width 12");

    const char *bad_res[][2] = {
        {"-Y 65536 +X 65536\n", "truncated"},  /* claims 16 G pixels in a few bytes */
        {"-Y 0 +X 3\n", "out of range"},
        {"-Y 2 +X 70000\n", "out of range"},
        {"-Y two +X 3\n", "malformed resolution"},
        {"-Y 2\n", "malformed resolution"},
        {"-Y 2 +Y 3\n", "malformed resolution"},
    };
    for (size_t k = 0; k < sizeof bad_res / sizeof bad_res[0]; k++) {
        f.n = 0;
        put_str(&f, "#?RADIANCE\n\n");
        put_str(&f, bad_res[k][0]);
        put(&f, flat_px, sizeof flat_px);
        char name[32];
        snprintf(name, sizeof name, "bad_res_%zu.hdr", k);
        read_fails(name, &f, SG_ERR_CORRUPT, bad_res[k][1]);
    }

    const char *orient[] = {"+Y 2 +X 3\n", "-Y 2 -X 3\n", "+X 3 -Y 2\n", "-X 3 +Y 2\n"};
    for (size_t k = 0; k < sizeof orient / sizeof orient[0]; k++) {
        f.n = 0;
        put_str(&f, "#?RADIANCE\n\n");
        put_str(&f, orient[k]);
        put(&f, flat_px, sizeof flat_px);
        char name[32];
        snprintf(name, sizeof name, "orient_%zu.hdr", k);
        read_fails(name, &f, SG_ERR_UNSUPPORTED, "orientation");
    }

    make_flat(&f, "#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n");
    read_fails("xyze.hdr", &f, SG_ERR_UNSUPPORTED, "32-bit_rle_xyze");

    make_flat(&f, "#?PNG-ish\n\n");
    read_fails("magic.hdr", &f, SG_ERR_CORRUPT, "not a Radiance picture");

    f.n = 0;
    put_str(&f, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n"); /* no blank line, no pixels */
    read_fails("no_end.hdr", &f, SG_ERR_CORRUPT, "header has no end");

    f.n = 0;
    put_str(&f, "#?RADIANCE\n\n");
    read_fails("no_resolution.hdr", &f, SG_ERR_CORRUPT, "resolution line missing");

    /* Old-style run (1,1,1,n) in a flat line: Radiance would repeat. */
    make_flat(&f, "#?RADIANCE\n\n");
    unsigned char old[4] = {1, 1, 1, 2};
    memcpy(f.b + f.n - 8, old, 4); /* pixel (1, 1) */
    read_fails("old_rle.hdr", &f, SG_ERR_UNSUPPORTED, "scanline 1: old-style");

    sg_image img = {0};
    sg_error err = {0};
    char missing[600];
    snprintf(missing, sizeof missing, "%s/does_not_exist.hdr", sg_test_tmpdir());
    assert_int_equal(sg_hdr_read(missing, &img, &err), SG_ERR_IO);
    assert_non_null(strstr(err.message, "does_not_exist.hdr"));
}

/* Invariants 1 and 2 of hdr.c under damage: every prefix, and every byte
 * set to each of a few telling values, ends in SG_OK or a clean error. */
static void test_hdr_damage_never_crashes(void **state)
{
    (void)state;
    bytes f;
    make_rle(&f);
    for (size_t n = 0; n < f.n; n++) {
        sg_image img = {0};
        sg_error err = {0};
        sg_status st = sg_hdr_read_memory(f.b, n, "prefix.hdr", &img, &err);
        if (st == SG_OK)
            fail_msg("prefix of %zu of %zu bytes read as OK", n, f.n);
        if (!strstr(err.message, "prefix.hdr"))
            fail_msg("prefix %zu: message does not name the file: %s", n, err.message);
    }
    static const unsigned char values[] = {0, 1, 2, 127, 128, 129, 255};
    size_t ok = 0, bad = 0;
    for (size_t i = 0; i < f.n; i++) {
        for (size_t k = 0; k < sizeof values; k++) {
            bytes g = f;
            g.b[i] = values[k];
            sg_image img = {0};
            sg_error err = {0};
            sg_status st = sg_hdr_read_memory(g.b, g.n, "mutant.hdr", &img, &err);
            if (st == SG_OK) {
                ok++;
                assert_non_null(img.data);
                sg_image_free(&img);
            } else {
                bad++;
                if (!strstr(err.message, "mutant.hdr"))
                    fail_msg("byte %zu = %d: message does not name the file: %s", i, values[k],
                             err.message);
            }
        }
    }
    print_message("damage: %zu mutants read, %zu rejected cleanly\n", ok, bad);
}

static void test_hdr_real_files(void **state)
{
    (void)state;
    static const struct {
        const char *file;
        double max; /* MANIFEST.md */
    } real[] = {
        {"envmaps/threejs_equirect/blouberg_sunrise_2_1k.hdr", 50},
        {"envmaps/threejs_equirect/pedestrian_overpass_1k.hdr", 34},
        {"envmaps/threejs_equirect/royal_esplanade_1k.hdr", 5.0e4},
        {"envmaps/threejs_equirect/venice_sunset_1k.hdr", 90},
    };
    for (size_t k = 0; k < sizeof real / sizeof real[0]; k++) {
        const char *path = sg_test_shared_data(real[k].file);
        if (!path)
            continue;
        sg_image img = {0};
        sg_error err = {0};
        sg_status st = sg_hdr_read(path, &img, &err);
        if (st != SG_OK)
            fail_msg("%s: %s: %s", real[k].file, sg_status_name(st), err.message);
        assert_int_equal(img.width, 1024);
        assert_int_equal(img.height, 512);
        double mx = 0;
        for (size_t i = 0; i < 3 * (size_t)img.width * img.height; i++) {
            if (!(img.data[i] >= 0.0f) || !isfinite(img.data[i]))
                fail_msg("%s: value %zu is %g", real[k].file, i, (double)img.data[i]);
            mx = img.data[i] > mx ? img.data[i] : mx;
        }
        print_message("%s: max %.6g (MANIFEST about %.3g)\n", real[k].file, mx, real[k].max);
        /* MANIFEST gives about two digits; RGBE's mantissa step is <= 1/128. */
        if (!(mx > 0.9 * real[k].max && mx < 1.1 * real[k].max))
            fail_msg("%s: max %g, MANIFEST says about %g", real[k].file, mx, real[k].max);
        sg_image_free(&img);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hdr_flat_decodes_exactly),
        cmocka_unit_test(test_hdr_rle_decodes_exactly),
        cmocka_unit_test(test_hdr_malformed_fixtures),
        cmocka_unit_test(test_hdr_damage_never_crashes),
        cmocka_unit_test(test_hdr_real_files),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
