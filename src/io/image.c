/* image.c — float RGB images, written as EXR (OpenEXR core C API) or PNG
 * (libpng), read back from scanline EXR.
 *
 * Invariants:
 *  1. A writer creates its output only under a temporary name in the
 *     destination folder (mkstemp "<path>.XXXXXX"); <path> appears, by
 *     rename(), only after the whole file was written and closed. Every
 *     failure path removes the temporary file.
 *  2. Neither library prints: OpenEXR reports through error_handler_fn into
 *     the exr_io of the context, libpng through png_error_fn into a
 *     png_failure, and both messages end up in the caller's sg_error.
 *  3. OpenEXR talks to the file only through the read/write/size callbacks
 *     below, so the context's user data is always our exr_io (the library's
 *     own file stream would replace it with a descriptor).
 *
 * Life of a write: make_temp -> encode into the temporary file ->
 * finish_temp (chmod, rename) | discard_temp.
 */
#include "io/image.h"

#include <assert.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openexr.h>
#include <png.h>

#include "core/alloc.h"
#include "core/file_mode.h"

sg_status sg_image_alloc(sg_image *img, int width, int height, sg_error *err)
{
    assert(img);
    if (width <= 0 || height <= 0 || width > SG_IMAGE_MAX_DIM || height > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "image size %dx%d is out of range (1..%d)",
                            width, height, SG_IMAGE_MAX_DIM);
    size_t pixels, floats;
    if (!sg_mul_size((size_t)width, (size_t)height, &pixels) || !sg_mul_size(pixels, 3, &floats))
        return sg_error_set(err, SG_ERR_NOMEM, "image %dx%d: size overflows", width, height);
    float *data = sg_calloc_array(floats, sizeof(float));
    if (!data)
        return sg_error_set(err, SG_ERR_NOMEM, "image %dx%d: out of memory", width, height);
    img->width = width;
    img->height = height;
    img->data = data;
    img->alpha = NULL; /* no coverage until a renderer gives one */
    return SG_OK;
}

void sg_image_free(sg_image *img)
{
    if (!img)
        return;
    sg_free(img->data);
    sg_free(img->alpha);
    img->data = NULL;
    img->alpha = NULL;
    img->width = 0;
    img->height = 0;
}

static sg_status check_image(const sg_image *img, const char *path, sg_error *err)
{
    if (!path || !path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "image path is empty");
    if (!img || !img->data || img->width <= 0 || img->height <= 0 ||
        img->width > SG_IMAGE_MAX_DIM || img->height > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: image is empty or has a bad size", path);
    return SG_OK;
}

/* ---- temporary files (invariant 1) ------------------------------------ */

typedef struct temp_file {
    char *name; /* "<path>.XXXXXX" made unique by mkstemp; NULL once gone */
    int fd;     /* open descriptor from mkstemp, or -1                   */
} temp_file;

static sg_status make_temp(const char *path, temp_file *t, sg_error *err)
{
    size_t n = strlen(path);
    t->fd = -1;
    t->name = malloc(n + 8);
    if (!t->name)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    memcpy(t->name, path, n);
    memcpy(t->name + n, ".XXXXXX", 8);
    t->fd = mkstemp(t->name);
    if (t->fd < 0) {
        int e = errno;
        free(t->name);
        t->name = NULL;
        return sg_error_set(err, SG_ERR_IO, "%s: cannot create a temporary file beside it: %s",
                            path, strerror(e));
    }
    return SG_OK;
}

static void discard_temp(temp_file *t)
{
    if (t->fd >= 0)
        close(t->fd);
    t->fd = -1;
    if (t->name)
        unlink(t->name);
    free(t->name);
    t->name = NULL;
}

/* The temporary file is complete and closed (t->fd == -1): give it the
 * mode every output gets (core/file_mode.h; mkstemp makes 0600) and move
 * it over path. */
static sg_status finish_temp(temp_file *t, const char *path, sg_error *err)
{
    assert(t->fd < 0 && t->name);
    if (chmod(t->name, sg_output_file_mode(path)) != 0 || rename(t->name, path) != 0) {
        int e = errno;
        discard_temp(t);
        return sg_error_set(err, SG_ERR_IO, "%s: cannot move the finished file into place: %s",
                            path, strerror(e));
    }
    free(t->name);
    t->name = NULL;
    return SG_OK;
}

static int has_extension(const char *path, const char *ext)
{
    size_t n = strlen(path), m = strlen(ext);
    return n > m && strcasecmp(path + n - m, ext) == 0;
}

/* ---- OpenEXR stream (invariants 2 and 3) ------------------------------ */

typedef struct exr_io {
    int fd;                /* file being read or written                   */
    const char *path;      /* name for messages                            */
    int io_errno;          /* errno of the last failed read/write, or 0    */
    char message[256];     /* last message from the library, or ""         */
} exr_io;

static void exr_on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    void *ud = NULL;
    if (exr_get_user_data(ctxt, &ud) == EXR_ERR_SUCCESS && ud) {
        exr_io *io = ud;
        snprintf(io->message, sizeof io->message, "%s", msg ? msg : exr_get_default_error_message(code));
    }
}

static int64_t exr_io_read(exr_const_context_t ctxt, void *ud, void *buffer, uint64_t sz,
                           uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    exr_io *io = ud;
    uint64_t done = 0;
    while (done < sz) {
        ssize_t r = pread(io->fd, (char *)buffer + done, (size_t)(sz - done), (off_t)(offset + done));
        if (r < 0) {
            if (errno == EINTR)
                continue;
            io->io_errno = errno;
            error_cb(ctxt, EXR_ERR_READ_IO, "read failed: %s", strerror(errno));
            return -1;
        }
        if (r == 0)
            break; /* end of file: the library reports the short read */
        done += (uint64_t)r;
    }
    return (int64_t)done;
}

static int64_t exr_io_write(exr_const_context_t ctxt, void *ud, const void *buffer, uint64_t sz,
                            uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    exr_io *io = ud;
    uint64_t done = 0;
    while (done < sz) {
        ssize_t r = pwrite(io->fd, (const char *)buffer + done, (size_t)(sz - done),
                           (off_t)(offset + done));
        if (r < 0) {
            if (errno == EINTR)
                continue;
            io->io_errno = errno;
            error_cb(ctxt, EXR_ERR_WRITE_IO, "write failed: %s", strerror(errno));
            return -1;
        }
        done += (uint64_t)r;
    }
    return (int64_t)done;
}

static int64_t exr_io_size(exr_const_context_t ctxt, void *ud)
{
    exr_io *io = ud;
    struct stat st;
    return fstat(io->fd, &st) == 0 ? (int64_t)st.st_size : -1;
}

static exr_context_initializer_t exr_init_for(exr_io *io)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_on_error;
    init.user_data = io;
    init.read_fn = exr_io_read;
    init.size_fn = exr_io_size;
    init.write_fn = exr_io_write;
    /* The descriptor stays ours: no destroy_fn, we close it. */
    return init;
}

/* Turns an OpenEXR failure into our status and message. */
static sg_status exr_fail(sg_error *err, const exr_io *io, exr_result_t rv, int writing,
                          const char *what)
{
    sg_status st;
    switch (rv) {
    case EXR_ERR_OUT_OF_MEMORY: st = SG_ERR_NOMEM; break;
    case EXR_ERR_FILE_ACCESS:
    case EXR_ERR_READ_IO:
    case EXR_ERR_WRITE_IO: st = SG_ERR_IO; break;
    case EXR_ERR_FEATURE_NOT_IMPLEMENTED: st = SG_ERR_UNSUPPORTED; break;
    default: st = writing ? SG_ERR_IO : SG_ERR_CORRUPT; break;
    }
    const char *detail = io->message[0] ? io->message : exr_get_default_error_message(rv);
    return sg_error_set(err, st, "%s: %s: %s", io->path, what, detail);
}

/* ---- EXR writing ------------------------------------------------------- */

/* Writes every scanline chunk of img into an open write context whose
 * header is written. */
static exr_result_t exr_write_pixels(exr_context_t ctx, const sg_image *img, const char **what)
{
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    if (rv != EXR_ERR_SUCCESS || lines <= 0) {
        *what = "scanlines per chunk";
        return rv != EXR_ERR_SUCCESS ? rv : EXR_ERR_UNKNOWN;
    }
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int initialised = 0; /* enc holds library buffers to destroy */
    size_t row_bytes = (size_t)img->width * 3 * sizeof(float);
    for (int y = 0; y < img->height; y += lines) {
        exr_chunk_info_t cinfo;
        *what = "chunk info";
        rv = exr_write_scanline_chunk_info(ctx, 0, y, &cinfo);
        if (rv != EXR_ERR_SUCCESS)
            break;
        *what = "encoder setup";
        rv = initialised ? exr_encoding_update(ctx, 0, &cinfo, &enc)
                         : exr_encoding_initialize(ctx, 0, &cinfo, &enc);
        if (rv != EXR_ERR_SUCCESS)
            break;
        for (int c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ch = &enc.channels[c];
            ch->user_bytes_per_element = (int16_t)sizeof(float);
            ch->user_data_type = EXR_PIXEL_FLOAT;
            if (ch->channel_name[0] == 'A') { /* alpha: its own plane */
                ch->user_pixel_stride = (int32_t)sizeof(float);
                ch->user_line_stride = img->width * (int32_t)sizeof(float);
                ch->encode_from_ptr = (const uint8_t *)(img->alpha + (size_t)cinfo.start_y * (size_t)img->width);
                continue;
            }
            /* Channels come sorted by name (A, B, G, R). */
            int offset = ch->channel_name[0] == 'R' ? 0 : ch->channel_name[0] == 'G' ? 1 : 2;
            ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
            ch->user_line_stride = (int32_t)row_bytes;
            ch->encode_from_ptr =
                (const uint8_t *)(img->data + (size_t)cinfo.start_y * (size_t)img->width * 3 + offset);
        }
        if (!initialised) {
            initialised = 1;
            rv = exr_encoding_choose_default_routines(ctx, 0, &enc);
            if (rv != EXR_ERR_SUCCESS)
                break;
        }
        *what = "encoding";
        rv = exr_encoding_run(ctx, 0, &enc);
        if (rv != EXR_ERR_SUCCESS)
            break;
    }
    if (initialised)
        exr_encoding_destroy(ctx, &enc);
    return rv;
}

sg_status sg_image_write_exr_desc(const sg_image *img, const char *path, const sg_exr_desc *desc,
                                  sg_error *err)
{
    sg_status st = check_image(img, path, err);
    if (st != SG_OK)
        return st;
    sg_exr_desc d = desc ? *desc : (sg_exr_desc){0};
    if ((d.pixel != SG_EXR_FLOAT && d.pixel != SG_EXR_HALF) ||
        (d.compression != SG_EXR_ZIP && d.compression != SG_EXR_NONE))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: bad EXR pixel type or compression", path);
    exr_pixel_type_t ptype = d.pixel == SG_EXR_HALF ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT;
    exr_compression_t ctype = d.compression == SG_EXR_NONE ? EXR_COMPRESSION_NONE : EXR_COMPRESSION_ZIP;

    temp_file tmp;
    st = make_temp(path, &tmp, err);
    if (st != SG_OK)
        return st;

    exr_io io = {.fd = tmp.fd, .path = path};
    exr_context_initializer_t init = exr_init_for(&io);
    exr_context_t ctx = NULL;
    const char *what = "start";
    int part = 0;
    /* The temporary name, so that nothing the library might do to "its"
     * file on failure can touch an existing <path> (invariant 1). */
    exr_result_t rv = exr_start_write(&ctx, tmp.name, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS)
        goto fail_exr;
    what = "header";
    rv = exr_add_part(ctx, NULL, EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctx, part, img->width, img->height, ctype);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_channel(ctx, part, "R", ptype, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_channel(ctx, part, "G", ptype, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_channel(ctx, part, "B", ptype, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS && img->alpha)
        rv = exr_add_channel(ctx, part, "A", ptype, EXR_PERCEPTUALLY_LINEAR, 1, 1);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctx);
    if (rv != EXR_ERR_SUCCESS)
        goto fail_exr;
    rv = exr_write_pixels(ctx, img, &what);
    if (rv != EXR_ERR_SUCCESS)
        goto fail_exr;
    what = "finishing";
    rv = exr_finish(&ctx); /* writes the chunk offset table */
    ctx = NULL;
    if (rv != EXR_ERR_SUCCESS)
        goto fail_exr;
    if (close(tmp.fd) != 0) {
        int e = errno;
        tmp.fd = -1;
        discard_temp(&tmp);
        return sg_error_set(err, SG_ERR_IO, "%s: closing the file failed: %s", path, strerror(e));
    }
    tmp.fd = -1;
    return finish_temp(&tmp, path, err);

fail_exr:
    if (ctx)
        exr_finish(&ctx);
    discard_temp(&tmp);
    return exr_fail(err, &io, rv, 1, what);
}

sg_status sg_image_write_exr(const sg_image *img, const char *path, sg_error *err)
{
    return sg_image_write_exr_desc(img, path, NULL, err);
}

/* ---- EXR reading ------------------------------------------------------- */

sg_status sg_image_read_exr(const char *path, sg_image *out, sg_error *err)
{
    assert(out);
    if (!path || !path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "image path is empty");
    int fd = open(path, O_RDONLY);
    if (fd < 0)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", path, strerror(errno));

    exr_io io = {.fd = fd, .path = path};
    exr_context_initializer_t init = exr_init_for(&io);
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    exr_context_t ctx = NULL;
    sg_image img = {0};
    sg_status st = SG_OK;
    const char *what = "header";
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialised = 0; /* dec holds library buffers to destroy */

    exr_result_t rv = exr_start_read(&ctx, path, &init);
    if (rv != EXR_ERR_SUCCESS)
        goto fail_exr;

    int parts = 0;
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    int32_t lines = 0;
    rv = exr_get_count(ctx, &parts);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_storage(ctx, 0, &storage);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_data_window(ctx, 0, &dw);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_channels(ctx, 0, &chl);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    if (rv != EXR_ERR_SUCCESS)
        goto fail_exr;
    if (storage != EXR_STORAGE_SCANLINE) {
        st = sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: only scanline EXR files are read (part 0 is %s)",
                          path, storage == EXR_STORAGE_TILED ? "tiled" : "deep");
        goto done;
    }
    int64_t w64 = (int64_t)dw.max.x - dw.min.x + 1, h64 = (int64_t)dw.max.y - dw.min.y + 1;
    if (w64 <= 0 || h64 <= 0 || w64 > SG_IMAGE_MAX_DIM || h64 > SG_IMAGE_MAX_DIM) {
        st = sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: data window %lldx%lld is out of range", path,
                          (long long)w64, (long long)h64);
        goto done;
    }
    static const char *const wanted[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; c++) {
        int found = 0;
        for (int i = 0; i < chl->num_channels; i++) {
            const exr_attr_chlist_entry_t *e = &chl->entries[i];
            if (strcmp(e->name.str, wanted[c]) != 0)
                continue;
            found = 1;
            if (e->x_sampling != 1 || e->y_sampling != 1) {
                st = sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: channel %s is subsampled", path, wanted[c]);
                goto done;
            }
        }
        if (!found) {
            st = sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: no channel %s (R, G and B are required)",
                              path, wanted[c]);
            goto done;
        }
    }
    st = sg_image_alloc(&img, (int)w64, (int)h64, err);
    if (st != SG_OK)
        goto done;
    for (int i = 0; i < chl->num_channels; i++)
        if (strcmp(chl->entries[i].name.str, "A") == 0 && chl->entries[i].x_sampling == 1 &&
            chl->entries[i].y_sampling == 1 && !(img.alpha = sg_calloc_array((size_t)w64 * (size_t)h64, sizeof(float)))) {
            st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the alpha channel", path);
            goto done;
        }

    size_t row_bytes = (size_t)img.width * 3 * sizeof(float);
    for (int64_t y = dw.min.y; y <= dw.max.y; y += lines) {
        exr_chunk_info_t cinfo;
        what = "chunk table";
        rv = exr_read_scanline_chunk_info(ctx, 0, (int)y, &cinfo);
        if (rv != EXR_ERR_SUCCESS)
            goto fail_exr;
        what = "decoder setup";
        rv = initialised ? exr_decoding_update(ctx, 0, &cinfo, &dec)
                         : exr_decoding_initialize(ctx, 0, &cinfo, &dec);
        if (rv != EXR_ERR_SUCCESS)
            goto fail_exr;
        int first = !initialised;
        initialised = 1;
        int64_t row = (int64_t)cinfo.start_y - dw.min.y;
        if (row < 0 || row + cinfo.height > h64) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: chunk %d: scanlines %d..%d lie outside the data window",
                              path, cinfo.idx, cinfo.start_y, cinfo.start_y + cinfo.height - 1);
            goto done;
        }
        for (int c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            int offset = -1;
            for (int k = 0; k < 3; k++)
                if (strcmp(ch->channel_name, wanted[k]) == 0)
                    offset = k;
            if (img.alpha && strcmp(ch->channel_name, "A") == 0) {
                ch->user_pixel_stride = (int32_t)sizeof(float);
                ch->user_line_stride = img.width * (int32_t)sizeof(float);
                ch->user_bytes_per_element = (int16_t)sizeof(float);
                ch->user_data_type = EXR_PIXEL_FLOAT;
                ch->decode_to_ptr = (uint8_t *)(img.alpha + (size_t)row * (size_t)img.width);
                continue;
            }
            if (offset < 0) {
                ch->decode_to_ptr = NULL; /* skipped by the decoder */
                continue;
            }
            ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
            ch->user_line_stride = (int32_t)row_bytes;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->decode_to_ptr = (uint8_t *)(img.data + (size_t)row * (size_t)img.width * 3 + offset);
        }
        if (first) {
            rv = exr_decoding_choose_default_routines(ctx, 0, &dec);
            if (rv != EXR_ERR_SUCCESS)
                goto fail_exr;
        }
        what = "decoding";
        rv = exr_decoding_run(ctx, 0, &dec);
        if (rv != EXR_ERR_SUCCESS) {
            char where[64];
            snprintf(where, sizeof where, "decoding scanlines %d..%d", cinfo.start_y,
                     cinfo.start_y + cinfo.height - 1);
            st = exr_fail(err, &io, rv, 0, where);
            goto done;
        }
    }
    *out = img;
    img.data = NULL;
    img.alpha = NULL;
    goto done;

fail_exr:
    st = exr_fail(err, &io, rv, 0, what);
done:
    if (initialised)
        exr_decoding_destroy(ctx, &dec);
    if (ctx)
        exr_finish(&ctx);
    close(fd);
    sg_image_free(&img);
    return st;
}

/* ---- PNG --------------------------------------------------------------- */

/* sRGB OETF (IEC 61966-2-1) of v in [0,1], to 8 bits with rounding. */
static unsigned char srgb8(float v)
{
    if (!(v > 0.0f)) /* also catches NaN */
        return 0;
    if (v >= 1.0f)
        return 255;
    float e = v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
    return (unsigned char)(e * 255.0f + 0.5f);
}

typedef struct png_failure {
    jmp_buf jump;       /* where png_error_fn returns to      */
    char message[256];  /* libpng's reason                    */
} png_failure;

static void png_error_fn(png_structp png, png_const_charp msg)
{
    png_failure *f = png_get_error_ptr(png);
    snprintf(f->message, sizeof f->message, "%s", msg);
    longjmp(f->jump, 1);
}

static void png_warning_fn(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg; /* the library never prints; warnings change nothing here */
}

/* Encodes rows into the open file f; returns 0 or -1 with fail->message. */
static int png_encode(FILE *f, int width, int height, unsigned char *const *rows, png_failure *fail)
{
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, fail, png_error_fn, png_warning_fn);
    if (!png) {
        snprintf(fail->message, sizeof fail->message, "out of memory");
        return -1;
    }
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        snprintf(fail->message, sizeof fail->message, "out of memory");
        return -1;
    }
    if (setjmp(fail->jump)) {
        png_destroy_write_struct(&png, &info);
        return -1;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    png_write_image(png, (png_bytepp)rows);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return 0;
}

sg_status sg_image_write_png(const sg_image *img, const char *path, float exposure, sg_error *err)
{
    sg_status st = check_image(img, path, err);
    if (st != SG_OK)
        return st;
    if (!isfinite(exposure) || exposure < 0.0f)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: exposure %g must be finite and >= 0", path,
                            (double)exposure);
    size_t w = (size_t)img->width, h = (size_t)img->height;
    size_t row_bytes = w * 3;
    unsigned char *pixels = sg_alloc_array(h, row_bytes); /* 8-bit sRGB, row 0 top */
    unsigned char **rows = sg_alloc_array(h, sizeof *rows);
    temp_file tmp = {NULL, -1};
    FILE *f = NULL;
    if (!pixels || !rows) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    for (size_t y = 0; y < h; y++) {
        rows[y] = pixels + y * row_bytes;
        const float *src = img->data + y * w * 3;
        for (size_t i = 0; i < row_bytes; i++)
            rows[y][i] = srgb8(exposure * src[i]);
    }

    st = make_temp(path, &tmp, err);
    if (st != SG_OK)
        goto done;
    f = fdopen(tmp.fd, "wb");
    if (!f) {
        st = sg_error_set(err, SG_ERR_IO, "%s: %s", path, strerror(errno));
        discard_temp(&tmp);
        goto done;
    }
    tmp.fd = -1; /* owned by f now */
    png_failure fail = {.message = ""};
    int bad = png_encode(f, img->width, img->height, rows, &fail);
    int ferr = ferror(f);
    int cerr = fclose(f);
    int e = errno;
    if (bad || ferr || cerr != 0) {
        if (bad)
            st = sg_error_set(err, SG_ERR_IO, "%s: PNG encoding failed: %s", path, fail.message);
        else
            st = sg_error_set(err, SG_ERR_IO, "%s: write failed: %s", path, strerror(e));
        discard_temp(&tmp);
        goto done;
    }
    st = finish_temp(&tmp, path, err);
done:
    sg_free(rows);
    sg_free(pixels);
    return st;
}

sg_status sg_image_write(const sg_image *img, const char *path, float exposure, sg_error *err)
{
    if (path && has_extension(path, ".exr"))
        return sg_image_write_exr(img, path, err);
    if (path && has_extension(path, ".png"))
        return sg_image_write_png(img, path, exposure, err);
    return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: unknown image type (use .exr or .png)",
                        path ? path : "(null)");
}
