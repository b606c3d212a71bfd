/* frame.c — viewer frames at a resolution scale (frame.h).
 *
 * Invariants:
 *  1. rgba holds width * height * 4 bytes whenever width > 0.
 *  2. scale > 0 iff linear holds a render, of size ceil(width / scale) x
 *     ceil(height / scale); rgba_low holds its RGBA8 when scale > 1.
 */
#include "view/frame.h"

#include <errno.h>
#include <math.h>
#include <omp.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/alloc.h"
#include "core/file_mode.h"
#include "view/render.h"

static void frame__forget(sg_view_frame *f)
{
    sg_image_free(&f->linear);
    sg_free(f->rgba_low);
    f->rgba_low = NULL;
    f->scale = 0;
}

void sg_view_frame_free(sg_view_frame *f)
{
    if (!f)
        return;
    frame__forget(f);
    sg_free(f->rgba);
    memset(f, 0, sizeof *f);
}

sg_status sg_view_frame_resize(sg_view_frame *f, int width, int height, sg_error *err)
{
    if (!f || width < 1 || height < 1 || width > SG_IMAGE_MAX_DIM || height > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "frame size %d x %d is not in [1, %d]", width, height,
                            SG_IMAGE_MAX_DIM);
    frame__forget(f);
    if (f->rgba && f->width == width && f->height == height)
        return SG_OK;
    uint8_t *rgba = sg_alloc_array((size_t)width * (size_t)height, 4);
    if (!rgba)
        return sg_error_set(err, SG_ERR_NOMEM, "frame %d x %d: out of memory", width, height);
    sg_free(f->rgba);
    f->rgba = rgba; /* invariant 1 */
    f->width = width;
    f->height = height;
    return SG_OK;
}

/* rgba (width x height) from rgba_low by nearest neighbour. */
static void frame__upscale(sg_view_frame *f)
{
    int s = f->scale, lw = f->linear.width;
    const uint32_t *src = (const uint32_t *)(const void *)f->rgba_low;
    uint32_t *dst = (uint32_t *)(void *)f->rgba;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < f->height; y++) {
        const uint32_t *row = src + (size_t)(y / s) * (size_t)lw;
        uint32_t *out = dst + (size_t)y * (size_t)f->width;
        for (int x = 0; x < f->width; x++)
            out[x] = row[x / s];
    }
}

sg_status sg_view_frame_redisplay(sg_view_frame *f, const sg_display *d, sg_error *err)
{
    if (!f || !d || f->scale < 1)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_view_frame_redisplay: nothing rendered");
    double t0 = omp_get_wtime();
    sg_status st;
    if (f->scale == 1) {
        st = sg_display_apply(d, &f->linear, f->rgba, err);
    } else {
        st = sg_display_apply(d, &f->linear, f->rgba_low, err);
        if (st == SG_OK)
            frame__upscale(f);
    }
    f->display_seconds = omp_get_wtime() - t0;
    return st;
}

int sg_view_move_scale(int current, double last_seconds, size_t last_pixels, int width, int height, double budget)
{
    if (!last_pixels || !(last_seconds > 0.0) || !isfinite(last_seconds) || width < 1 || height < 1)
        return 2;
    for (int s = 2; s < 8; s *= 2) {
        double pixels = (double)((width + s - 1) / s) * (double)((height + s - 1) / s);
        double predicted = last_seconds * pow(pixels / (double)last_pixels, SG_VIEW_MOVE_COST_EXPONENT);
        double limit = s < current ? 0.8 * budget : budget; /* hysteresis going finer */
        if (predicted <= limit)
            return s;
    }
    return 8;
}

sg_status sg_view_frame_render(sg_view_frame *f, const sg_bake *b, const sg_world *w, const sg_camera *cam,
                               int scale, int threads, const sg_display *d, sg_error *err)
{
    if (!f || !b || !w || !cam || !d || !f->rgba)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_view_frame_render: NULL argument or no size");
    if (scale < 1 || scale > SG_VIEW_MAX_SCALE)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "resolution scale %d is not in [1, %d]", scale,
                            SG_VIEW_MAX_SCALE);
    frame__forget(f);
    int lw = (f->width + scale - 1) / scale, lh = (f->height + scale - 1) / scale;
    if (scale > 1) {
        f->rgba_low = sg_alloc_array((size_t)lw * (size_t)lh, 4);
        if (!f->rgba_low)
            return sg_error_set(err, SG_ERR_NOMEM, "frame %d x %d: out of memory", lw, lh);
    }
    sg_bake_frame_desc fd = {.camera = *cam, .width = lw, .height = lh, .threads = threads};
    sg_corner_aa_stats as = {0};
    sg_image img = {0};
    sg_status st = sg_view_render_aa(b, w, &fd, scale == 1 ? &f->aa : NULL, &img, &as, err);
    if (st != SG_OK) {
        frame__forget(f);
        return st;
    }
    f->linear = img;
    f->scale = scale; /* invariant 2 */
    f->render_seconds = as.seconds;
    f->rays = (size_t)as.samples;
    st = sg_view_frame_redisplay(f, d, err);
    if (st != SG_OK)
        frame__forget(f);
    return st;
}

sg_status sg_view_write_png_rgba8(const uint8_t *rgba, int width, int height, const char *path, sg_error *err)
{
    if (!rgba || !path || width < 1 || height < 1)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_view_write_png_rgba8: bad arguments");
    size_t n = (size_t)width * (size_t)height;
    size_t plen = strlen(path);
    uint8_t *rgb = malloc(n * 3);
    char *tmp = malloc(plen + 8);
    sg_status st = SG_OK;
    int fd = -1;
    FILE *fp = NULL;
    if (!rgb || !tmp) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    for (size_t i = 0; i < n; i++) {
        rgb[3 * i + 0] = rgba[4 * i + 0];
        rgb[3 * i + 1] = rgba[4 * i + 1];
        rgb[3 * i + 2] = rgba[4 * i + 2];
    }
    memcpy(tmp, path, plen);
    memcpy(tmp + plen, ".XXXXXX", 8);
    fd = mkstemp(tmp);
    if (fd < 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: cannot create a temporary file: %s", path, strerror(errno));
        goto done;
    }
    fp = fdopen(fd, "wb");
    if (!fp) {
        st = sg_error_set(err, SG_ERR_IO, "%s: %s", path, strerror(errno));
        close(fd);
        goto done_remove;
    }
    png_image im;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    im.width = (png_uint_32)width;
    im.height = (png_uint_32)height;
    im.format = PNG_FORMAT_RGB;
    int ok = png_image_write_to_stdio(&im, fp, 0, rgb, 0, NULL);
    if (!ok) {
        st = sg_error_set(err, SG_ERR_IO, "%s: PNG write failed: %s", path, im.message);
        png_image_free(&im);
        fclose(fp);
        goto done_remove;
    }
    if (fclose(fp) != 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: write failed: %s", path, strerror(errno));
        goto done_remove;
    }
    /* mkstemp made it 0600: the mode every output gets (core/file_mode.h). */
    if (chmod(tmp, sg_output_file_mode(path)) != 0 || rename(tmp, path) != 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: rename failed: %s", path, strerror(errno));
        goto done_remove;
    }
    goto done;
done_remove:
    remove(tmp);
done:
    free(tmp);
    free(rgb);
    return st;
}

sg_status sg_view_read_png_rgba8(const char *path, uint8_t **out, int *width, int *height, sg_error *err)
{
    if (!path || !out || !width || !height)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_view_read_png_rgba8: NULL argument");
    png_image im;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&im, path))
        return sg_error_set(err, SG_ERR_IO, "%s: %s", path, im.message);
    im.format = PNG_FORMAT_RGBA;
    uint8_t *buf = malloc(PNG_IMAGE_SIZE(im));
    if (!buf) {
        png_image_free(&im);
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    }
    if (!png_image_finish_read(&im, NULL, buf, 0, NULL)) {
        free(buf);
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: %s", path, im.message);
    }
    *out = buf;
    *width = (int)im.width;
    *height = (int)im.height;
    return SG_OK;
}
