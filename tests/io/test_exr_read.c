/* test_exr_read.c — the OpenEXR C++ reader (src/io/exr_read.cpp).
 *
 * 1. Fixtures written here with OpenEXR's core C API read back exactly:
 *    scanline and tiled, half and float, RGB, RGBA, Y only, R only, ZIP,
 *    PIZ, RLE and no compression, a data window with a non-zero origin.
 * 2. The real Blender studio lights (DWAB float, with small negatives) and
 *    three.js piz_compressed.exr (PIZ half) read as 1024 x 512 with the
 *    maxima of MANIFEST.md and the compression they declare.
 * 3. Truncated, garbled and missing files give SG_ERR_CORRUPT / SG_ERR_IO,
 *    a message naming the file, and leave *out untouched; no exception
 *    escapes (it would abort the test binary).
 */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <openexr.h>

#include "io/exr_read.h"
#include "io/image.h"

/* ---- fixture writer (core C API) -------------------------------------- */

typedef struct fixture {
    const char *name;          /* file name in the temp folder            */
    int tiled;                 /* 0 scanline, 1 tiled (8 x 4 tiles)       */
    int ox, oy;                /* data window origin                      */
    int w, h;                  /* data window size                        */
    const char *channels[4];   /* channel names, NULL-terminated          */
    exr_pixel_type_t type;     /* stored type of every channel            */
    exr_compression_t comp;    /* compression                             */
} fixture;

/* Luminance/chroma files subsample RY and BY 2 x 2; chroma 0 means grey. */
static int is_chroma(const char *name) { return strcmp(name, "RY") == 0 || strcmp(name, "BY") == 0; }

/* Value of channel c at pixel (x, y): distinct, exactly representable in
 * half (multiples of 1/8 below 256), some negative. */
static float value_at(int c, int x, int y) { return (float)((x * 7 + y * 13 + c * 29) % 61 - 9) / 8.0f; }

static const char *write_fixture(const fixture *fx)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", sg_test_tmpdir(), fx->name);
    int nch = 0;
    while (nch < 4 && fx->channels[nch])
        nch++;
    float *planes[4] = {0};
    for (int c = 0; c < nch; c++) {
        planes[c] = malloc(sizeof(float) * (size_t)fx->w * fx->h);
        assert_non_null(planes[c]);
        for (int y = 0; y < fx->h; y++)
            for (int x = 0; x < fx->w; x++)
                planes[c][(size_t)y * fx->w + x] = is_chroma(fx->channels[c]) ? 0.0f : value_at(c, x, y);
    }
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_context_t ctx = NULL;
    int part = 0;
    assert_int_equal(exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init), EXR_ERR_SUCCESS);
    assert_int_equal(exr_add_part(ctx, "main", fx->tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part),
                     EXR_ERR_SUCCESS);
    exr_attr_box2i_t dw;
    dw.min.x = fx->ox;
    dw.min.y = fx->oy;
    dw.max.x = fx->ox + fx->w - 1;
    dw.max.y = fx->oy + fx->h - 1;
    exr_attr_v2f_t swc;
    swc.x = swc.y = 0.0f;
    assert_int_equal(exr_initialize_required_attr(ctx, part, &dw, &dw, 1.0f, &swc, 1.0f,
                                                  EXR_LINEORDER_INCREASING_Y, fx->comp),
                     EXR_ERR_SUCCESS);
    for (int c = 0; c < nch; c++)
        assert_int_equal(exr_add_channel(ctx, part, fx->channels[c], fx->type, EXR_PERCEPTUALLY_LOGARITHMIC,
                                         is_chroma(fx->channels[c]) ? 2 : 1, is_chroma(fx->channels[c]) ? 2 : 1),
                         EXR_ERR_SUCCESS);
    if (fx->tiled)
        assert_int_equal(exr_set_tile_descriptor(ctx, part, 8, 4, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN),
                         EXR_ERR_SUCCESS);
    assert_int_equal(exr_write_header(ctx), EXR_ERR_SUCCESS);

    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int initialised = 0;
    int32_t lines = 1;
    if (!fx->tiled)
        assert_int_equal(exr_get_scanlines_per_chunk(ctx, part, &lines), EXR_ERR_SUCCESS);
    int nx = fx->tiled ? (fx->w + 7) / 8 : 1, ny = fx->tiled ? (fx->h + 3) / 4 : (fx->h + lines - 1) / lines;
    for (int ty = 0; ty < ny; ty++) {
        for (int tx = 0; tx < nx; tx++) {
            exr_chunk_info_t ci;
            if (fx->tiled)
                assert_int_equal(exr_write_tile_chunk_info(ctx, part, tx, ty, 0, 0, &ci), EXR_ERR_SUCCESS);
            else
                assert_int_equal(exr_write_scanline_chunk_info(ctx, part, fx->oy + ty * lines, &ci),
                                 EXR_ERR_SUCCESS);
            assert_int_equal(initialised ? exr_encoding_update(ctx, part, &ci, &enc)
                                         : exr_encoding_initialize(ctx, part, &ci, &enc),
                             EXR_ERR_SUCCESS);
            /* Tile chunks give start_x/start_y relative to the data window
             * in 3.1? Derive the offset from the tile index instead. */
            int x0 = fx->tiled ? tx * 8 : 0, y0 = fx->tiled ? ty * 4 : ty * lines;
            for (int e = 0; e < enc.channel_count; e++) {
                exr_coding_channel_info_t *ch = &enc.channels[e];
                int c = 0;
                while (strcmp(fx->channels[c], ch->channel_name) != 0)
                    c++;
                /* Subsampled chroma is all zero: any stride reads zeros. */
                ch->user_pixel_stride = (int32_t)sizeof(float);
                ch->user_line_stride = (int32_t)sizeof(float) * fx->w;
                ch->user_bytes_per_element = (int16_t)sizeof(float);
                ch->user_data_type = EXR_PIXEL_FLOAT;
                ch->encode_from_ptr = (const uint8_t *)(planes[c] + (size_t)y0 * fx->w + x0);
            }
            if (!initialised) {
                initialised = 1;
                assert_int_equal(exr_encoding_choose_default_routines(ctx, part, &enc), EXR_ERR_SUCCESS);
            }
            assert_int_equal(exr_encoding_run(ctx, part, &enc), EXR_ERR_SUCCESS);
        }
    }
    exr_encoding_destroy(ctx, &enc);
    assert_int_equal(exr_finish(&ctx), EXR_ERR_SUCCESS);
    for (int c = 0; c < nch; c++)
        free(planes[c]);
    return path;
}

static int channel_index(const fixture *fx, const char *name)
{
    for (int c = 0; c < 4 && fx->channels[c]; c++)
        if (strcmp(fx->channels[c], name) == 0)
            return c;
    return -1;
}

static void test_exr_read_fixtures_roundtrip(void **state)
{
    (void)state;
    static const fixture fixtures[] = {
        {"rgb_float_zip.exr", 0, 0, 0, 13, 21, {"R", "G", "B"}, EXR_PIXEL_FLOAT, EXR_COMPRESSION_ZIP},
        {"rgb_half_piz.exr", 0, 0, 0, 17, 9, {"R", "G", "B"}, EXR_PIXEL_HALF, EXR_COMPRESSION_PIZ},
        {"rgba_half_rle.exr", 0, 0, 0, 9, 5, {"R", "G", "B", "A"}, EXR_PIXEL_HALF, EXR_COMPRESSION_RLE},
        {"tiled_rgb_float.exr", 1, 0, 0, 19, 10, {"R", "G", "B"}, EXR_PIXEL_FLOAT, EXR_COMPRESSION_ZIP},
        {"tiled_y_half_origin.exr", 1, -5, 7, 12, 9, {"Y"}, EXR_PIXEL_HALF, EXR_COMPRESSION_PIZ},
        {"y_float_none.exr", 0, 3, -2, 6, 4, {"Y"}, EXR_PIXEL_FLOAT, EXR_COMPRESSION_NONE},
        {"r_only_half.exr", 0, 0, 0, 5, 3, {"R"}, EXR_PIXEL_HALF, EXR_COMPRESSION_ZIPS},
    };
    for (size_t k = 0; k < sizeof fixtures / sizeof fixtures[0]; k++) {
        const fixture *fx = &fixtures[k];
        const char *path = write_fixture(fx);
        sg_image img = {0};
        sg_exr_read_info info;
        sg_error err = {0};
        sg_status st = sg_exr_read(path, &img, &info, &err);
        if (st != SG_OK)
            fail_msg("%s: %s: %s", fx->name, sg_status_name(st), err.message);
        assert_int_equal(img.width, fx->w);
        assert_int_equal(img.height, fx->h);
        int w = 0, h = 0;
        assert_int_equal(sg_exr_read_size(path, &w, &h, &err), SG_OK);
        assert_int_equal(w, fx->w);
        assert_int_equal(h, fx->h);
        assert_int_equal(info.tiled, fx->tiled);
        assert_int_equal(info.half, fx->type == EXR_PIXEL_HALF);
        assert_int_equal(info.has_alpha, channel_index(fx, "A") >= 0);
        int y_only = channel_index(fx, "Y") >= 0;
        assert_int_equal(info.source, y_only ? SG_EXR_SOURCE_Y : SG_EXR_SOURCE_RGB);
        for (int y = 0; y < fx->h; y++)
            for (int x = 0; x < fx->w; x++)
                for (int c = 0; c < 3; c++) {
                    int src = y_only ? 0 : channel_index(fx, c == 0 ? "R" : c == 1 ? "G" : "B");
                    float want = src >= 0 ? value_at(src, x, y) : 0.0f;
                    float got = img.data[3 * ((size_t)y * img.width + x) + c];
                    if (got != want)
                        fail_msg("%s (%s, compression %s): pixel (%d, %d) channel %d: got %g, want %g",
                                 fx->name, fx->tiled ? "tiled" : "scanline", info.compression, x, y, c,
                                 (double)got, (double)want);
                }
        sg_image_free(&img);
    }
}

/* Luminance/chroma (RgbaOutputFile's WRITE_YC layout) with zero chroma is
 * grey: R = G = B = Y, through RgbaInputFile's half-precision path. Y is
 * positive here (the YC conversion is defined for Y > 0 only). */
static void test_exr_read_luminance_chroma(void **state)
{
    (void)state;
    static const fixture fx = {"yc_half.exr", 0, 0, 0, 8, 6, {"Y", "RY", "BY"}, EXR_PIXEL_HALF,
                               EXR_COMPRESSION_ZIP};
    const char *path = write_fixture(&fx);
    sg_image img = {0};
    sg_exr_read_info info;
    sg_error err = {0};
    sg_status st = sg_exr_read(path, &img, &info, &err);
    if (st != SG_OK)
        fail_msg("%s: %s: %s", fx.name, sg_status_name(st), err.message);
    assert_int_equal(info.source, SG_EXR_SOURCE_YC);
    for (int y = 0; y < fx.h; y++)
        for (int x = 0; x < fx.w; x++) {
            float want = value_at(0, x, y);
            if (want <= 0.0f)
                continue;
            for (int c = 0; c < 3; c++) {
                float got = img.data[3 * ((size_t)y * img.width + x) + c];
                /* half has 11 significant bits: 2^-10 relative per rounding,
                 * the RGB<->YC matrices round twice. */
                if (!(fabsf(got - want) <= 4e-3f * want))
                    fail_msg("yc: pixel (%d, %d) channel %d: got %g, want %g", x, y, c, (double)got,
                             (double)want);
            }
        }
    sg_image_free(&img);
}

static void test_exr_read_real_files(void **state)
{
    (void)state;
    static const struct {
        const char *file;
        const char *compression;
        int half;
        double max; /* MANIFEST.md, about two digits */
        int negatives; /* MANIFEST: DWAB leaves small negative values */
    } real[] = {
        {"envmaps/blender_studiolights/city.exr", "dwab", 0, 3.4e4, 1},
        {"envmaps/blender_studiolights/courtyard.exr", "dwab", 0, 56, 1},
        {"envmaps/blender_studiolights/forest.exr", "dwab", 0, 1.0e3, 1},
        {"envmaps/blender_studiolights/interior.exr", "dwab", 0, 3.4e4, 1},
        {"envmaps/blender_studiolights/night.exr", "dwab", 0, 7.2e3, 1},
        {"envmaps/blender_studiolights/studio.exr", "dwab", 0, 118, 1},
        {"envmaps/blender_studiolights/sunrise.exr", "dwab", 0, 3.4e4, 1},
        {"envmaps/blender_studiolights/sunset.exr", "dwab", 0, 6.5e3, 1},
        {"envmaps/threejs_equirect/piz_compressed.exr", "piz", 1, 20, 0},
    };
    for (size_t k = 0; k < sizeof real / sizeof real[0]; k++) {
        const char *path = sg_test_shared_data(real[k].file);
        if (!path)
            continue;
        sg_image img = {0};
        sg_exr_read_info info;
        sg_error err = {0};
        sg_status st = sg_exr_read(path, &img, &info, &err);
        if (st != SG_OK)
            fail_msg("%s: %s: %s", real[k].file, sg_status_name(st), err.message);
        assert_int_equal(img.width, 1024);
        assert_int_equal(img.height, 512);
        assert_string_equal(info.compression, real[k].compression);
        assert_int_equal(info.half, real[k].half);
        assert_int_equal(info.tiled, 0);
        double mx = -INFINITY, mn = INFINITY;
        size_t negative = 0;
        for (size_t i = 0; i < 3 * (size_t)img.width * img.height; i++) {
            float v = img.data[i];
            if (!isfinite(v))
                fail_msg("%s: value %zu is %g", real[k].file, i, (double)v);
            mx = v > mx ? v : mx;
            mn = v < mn ? v : mn;
            negative += v < 0.0f;
        }
        print_message("%s: %s, max %.6g (MANIFEST about %.3g), min %.3g, %zu negative values\n", real[k].file,
                      info.compression, mx, real[k].max, mn, negative);
        if (!(mx > 0.9 * real[k].max && mx < 1.1 * real[k].max))
            fail_msg("%s: max %g, MANIFEST says about %g", real[k].file, mx, real[k].max);
        if (real[k].negatives && (negative == 0 || mn < -0.1))
            fail_msg("%s: %zu negative values, min %g: MANIFEST says small negatives (~ -0.004)",
                     real[k].file, negative, mn);
        if (!real[k].negatives && mn < 0.0)
            fail_msg("%s: min %g, expected no negative values", real[k].file, mn);
        sg_image_free(&img);
    }
}

static void read_fails(const char *path, const char *name, sg_status want1, sg_status want2)
{
    sg_image img = {7, 9, (float *)&img, NULL}; /* sentinel: must stay */
    sg_exr_read_info info = {.tiled = 42};
    sg_error err = {0};
    sg_status st = sg_exr_read(path, &img, &info, &err);
    if (st != want1 && st != want2)
        fail_msg("%s: got %s (%s), want %s", name, sg_status_name(st), err.message, sg_status_name(want1));
    if (!strstr(err.message, name))
        fail_msg("%s: message does not name the file: \"%s\"", name, err.message);
    if (img.width != 7 || img.height != 9 || img.data != (float *)&img || info.tiled != 42)
        fail_msg("%s: *out or *info written on failure", name);
}

static void *slurp(const char *path, size_t *size) { return sg_test_read_file(path, size); }

static void test_exr_read_truncated_and_corrupt(void **state)
{
    (void)state;
    /* A small ZIP fixture cut at several points: inside the magic, the
     * header, the chunk table and the pixel chunks. */
    static const fixture fx = {"cut_src.exr", 0, 0, 0, 40, 64, {"R", "G", "B"}, EXR_PIXEL_FLOAT,
                               EXR_COMPRESSION_ZIP};
    size_t size;
    unsigned char *full = slurp(write_fixture(&fx), &size);
    const double cuts[] = {0.0, 0.01, 0.1, 0.3, 0.5, 0.9, 0.999};
    for (size_t k = 0; k < sizeof cuts / sizeof cuts[0]; k++) {
        size_t n = (size_t)(cuts[k] * (double)size);
        char name[64];
        snprintf(name, sizeof name, "cut_%zu_of_%zu.exr", n, size);
        const char *path = sg_test_write_file(name, full, n);
        read_fails(path, name, SG_ERR_CORRUPT, SG_ERR_CORRUPT);
    }
    /* Garbled pixel data: every byte after the header and offsets zeroed;
     * zlib refuses it. */
    unsigned char *garbled = malloc(size);
    assert_non_null(garbled);
    memcpy(garbled, full, size);
    memset(garbled + size / 2, 0xA5, size - size / 2);
    read_fails(sg_test_write_file("garbled.exr", garbled, size), "garbled.exr", SG_ERR_CORRUPT,
               SG_ERR_CORRUPT);
    free(garbled);
    free(full);

    read_fails(sg_test_write_file("text.exr", "not an exr file at all\n", 23), "text.exr", SG_ERR_CORRUPT,
               SG_ERR_CORRUPT);

    /* The real PIZ map cut in the middle of its pixel data. */
    const char *piz = sg_test_shared_data("envmaps/threejs_equirect/piz_compressed.exr");
    if (piz) {
        unsigned char *data = slurp(piz, &size);
        read_fails(sg_test_write_file("piz_half.exr", data, size / 2), "piz_half.exr", SG_ERR_CORRUPT,
                   SG_ERR_CORRUPT);
        free(data);
    }
    const char *dwab = sg_test_shared_data("envmaps/blender_studiolights/studio.exr");
    if (dwab) {
        unsigned char *data = slurp(dwab, &size);
        read_fails(sg_test_write_file("dwab_cut.exr", data, size - 1000), "dwab_cut.exr", SG_ERR_CORRUPT,
                   SG_ERR_CORRUPT);
        free(data);
    }

    char missing[600];
    snprintf(missing, sizeof missing, "%s/does_not_exist.exr", sg_test_tmpdir());
    read_fails(missing, "does_not_exist.exr", SG_ERR_IO, SG_ERR_IO);

    /* The header-only size fails the same way, naming the file. */
    int w = -1, h = -1;
    sg_error err = {0};
    assert_int_equal(sg_exr_read_size(missing, &w, &h, &err), SG_ERR_IO);
    assert_non_null(strstr(err.message, "does_not_exist.exr: cannot open"));
    assert_int_equal(sg_exr_read_size(sg_test_write_file("text.exr", "not an exr file at all\n", 23), &w, &h, &err),
                     SG_ERR_CORRUPT);
    assert_non_null(strstr(err.message, "text.exr: not an OpenEXR file"));
    assert_int_equal(w, -1); /* untouched on failure */
    assert_int_equal(h, -1);
}

/* A header claiming 20000 x 10000 pixels in a ~100 KB ZIP file: refused
 * from the header and the file size, before any pixel is allocated (it
 * took 10 s to fail in the decoder), naming both figures. The bytes of
 * dataWindow (box2i: 4 int32 after "dataWindow\0box2i\0" and its size)
 * are patched in the written file. */
static void test_exr_read_data_window_against_file_size(void **state)
{
    (void)state;
    /* Noise does not compress: ~100 KB, so the 625-entry chunk table the
     * patched header calls for lies inside the file. */
    sg_image src = {0};
    assert_int_equal(sg_image_alloc(&src, 128, 64, NULL), SG_OK);
    uint64_t rng = 7;
    for (int i = 0; i < 3 * 128 * 64; i++)
        src.data[i] = sg_test_rand01(&rng);
    char src_path[600];
    snprintf(src_path, sizeof src_path, "%s/window_src.exr", sg_test_tmpdir());
    assert_int_equal(sg_image_write_exr(&src, src_path, NULL), SG_OK);
    sg_image_free(&src);
    size_t size;
    unsigned char *data = slurp(src_path, &size);
    static const char key[] = "dataWindow\0box2i\0";
    unsigned char *at = NULL;
    for (size_t i = 0; i + sizeof key + 20 < size && !at; i++)
        if (memcmp(data + i, key, sizeof key - 1) == 0)
            at = data + i + sizeof key - 1 + 4;
    assert_non_null(at);
    const int32_t box[4] = {0, 0, 19999, 9999}; /* little-endian host, as the file */
    memcpy(at, box, sizeof box);
    const char *path = sg_test_write_file("claims_20000x10000.exr", data, size);
    sg_image img = {0};
    sg_error err = {0};
    /* The header alone states the size (what a caller with a budget checks). */
    int w = 0, h = 0;
    assert_int_equal(sg_exr_read_size(path, &w, &h, &err), SG_OK);
    assert_int_equal(w, 20000);
    assert_int_equal(h, 10000);
    sg_status st = sg_exr_read(path, &img, NULL, &err);
    if (st != SG_ERR_CORRUPT || !strstr(err.message, "claims_20000x10000.exr: data window 20000x10000 (zip "
                                                     "compression) needs at least") ||
        !strstr(err.message, "the file has"))
        fail_msg("got %s \"%s\"", sg_status_name(st), err.message);
    assert_null(img.data);
    free(data);
}

/* A header attribute stating more bytes than the file has (the fuzzer's
 * 514-byte file whose "type" string claimed 1.9 GB: OpenEXR allocated and
 * read it for 11 s) is refused before the library parses the header,
 * naming the attribute; so is one with a negative size. The int32 size
 * follows "compression\0compression\0". */
static void test_exr_read_attribute_size_against_file_size(void **state)
{
    (void)state;
    static const fixture fx = {"attr_src.exr", 0, 0, 0, 8, 4, {"R", "G", "B"}, EXR_PIXEL_HALF,
                               EXR_COMPRESSION_ZIP};
    size_t size;
    unsigned char *data = slurp(write_fixture(&fx), &size);
    static const char key[] = "compression\0compression\0";
    unsigned char *at = NULL;
    for (size_t i = 0; i + sizeof key + 4 < size && !at; i++)
        if (memcmp(data + i, key, sizeof key - 1) == 0)
            at = data + i + sizeof key - 1;
    assert_non_null(at);
    static const int32_t sizes[2] = {1929379853, -5};
    for (int k = 0; k < 2; k++) {
        memcpy(at, &sizes[k], 4); /* little-endian host, as the file */
        const char *path = sg_test_write_file("attr_bomb.exr", data, size);
        sg_image img = {0};
        sg_error err = {0};
        sg_status st = sg_exr_read(path, &img, NULL, &err);
        if (st != SG_ERR_CORRUPT || !strstr(err.message, "attr_bomb.exr: header attribute \"compression\" "
                                                         "(compression) states"))
            fail_msg("size %d: got %s \"%s\"", sizes[k], sg_status_name(st), err.message);
        assert_null(img.data);
        int w = -1, h = -1;
        assert_int_equal(sg_exr_read_size(path, &w, &h, &err), SG_ERR_CORRUPT);
    }
    free(data);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exr_read_attribute_size_against_file_size),
        cmocka_unit_test(test_exr_read_data_window_against_file_size),
        cmocka_unit_test(test_exr_read_fixtures_roundtrip),
        cmocka_unit_test(test_exr_read_luminance_chroma),
        cmocka_unit_test(test_exr_read_real_files),
        cmocka_unit_test(test_exr_read_truncated_and_corrupt),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
