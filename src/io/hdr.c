/* hdr.c — Radiance RGBE decoder (Ward, "Real Pixels", Graphics Gems II,
 * 1991; the run-length scheme of Radiance's color.c freadcolrs()).
 *
 * The whole file is read into memory first and decoded from a bounded
 * cursor, so every check is a comparison against the bytes left.
 *
 * Invariants:
 *  1. cur->pos <= cur->size at all times; every read of n bytes is preceded
 *     by a check that n bytes remain (truncation -> SG_ERR_CORRUPT).
 *  2. Every decoding loop advances x by at least one pixel per iteration
 *     (zero-length runs and literals are rejected), so decoding ends.
 *  3. The pixel array is allocated only after the header passed and the
 *     bytes left can hold the claimed size at the best possible compression
 *     (min_line_bytes), so a tiny file cannot request a huge allocation.
 *  4. *out is written only on success.
 */
#include "io/hdr.h"

#include <assert.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"

/* A header longer than this has no end-of-header blank line in any real
 * file; the limit turns a binary non-.hdr file into a clean error. */
#define HDR_MAX_HEADER_BYTES 65536

/* Widths for which Radiance writes new-style RLE lines (color.c MINELEN,
 * MAXELEN); other widths are always flat. */
#define HDR_RLE_MIN_WIDTH 8
#define HDR_RLE_MAX_WIDTH 0x7fff

typedef struct cursor {
    const uint8_t *data; /* file bytes                          */
    size_t size;         /* number of bytes in data             */
    size_t pos;          /* next byte to read (invariant 1)     */
    const char *name;    /* file name for messages              */
} cursor;

/* Reads one header line (without '\n', '\r' stripped) into line[cap].
 * Returns 1 on success, 0 at the end of the buffer or the header limit. */
static int read_line(cursor *c, char *line, size_t cap)
{
    size_t n = 0;
    while (c->pos < c->size && c->pos < HDR_MAX_HEADER_BYTES) {
        uint8_t b = c->data[c->pos++];
        if (b == '\n') {
            if (n > 0 && line[n - 1] == '\r')
                n--;
            line[n] = '\0';
            return 1;
        }
        if (n + 1 < cap)
            line[n++] = (char)b; /* over-long lines are cut, not overrun */
    }
    return 0;
}

/* Least number of bytes any scanline of this width can take (invariant 3):
 * flat lines take 4 bytes a pixel; an RLE line takes its 4-byte header and,
 * per channel, at least one 2-byte run for every 127 pixels. */
static size_t min_line_bytes(int width)
{
    size_t flat = 4 * (size_t)width;
    if (width < HDR_RLE_MIN_WIDTH || width > HDR_RLE_MAX_WIDTH)
        return flat;
    size_t rle = 4 + 4 * 2 * (((size_t)width + 126) / 127);
    return rle < flat ? rle : flat;
}

static inline void rgbe_to_float(const uint8_t rgbe[4], float *rgb)
{
    if (rgbe[3] == 0) {
        rgb[0] = rgb[1] = rgb[2] = 0.0f;
        return;
    }
    /* Radiance colr_color(): mantissa centre times 2^(E - 128 - 8). */
    float f = ldexpf(1.0f, (int)rgbe[3] - 136);
    rgb[0] = ((float)rgbe[0] + 0.5f) * f;
    rgb[1] = ((float)rgbe[1] + 0.5f) * f;
    rgb[2] = ((float)rgbe[2] + 0.5f) * f;
}

/* Decodes one new-style RLE line into the planes (4 x width bytes).
 * The 4-byte line header was consumed by the caller. */
static sg_status decode_rle_line(cursor *c, int y, int width, uint8_t *planes, sg_error *err)
{
    for (int ch = 0; ch < 4; ch++) {
        uint8_t *plane = planes + (size_t)ch * (size_t)width;
        int x = 0;
        while (x < width) {
            if (c->pos >= c->size)
                return sg_error_set(err, SG_ERR_CORRUPT,
                                    "%s: scanline %d: truncated (file ends in channel %d at x=%d)",
                                    c->name, y, ch, x);
            int code = c->data[c->pos++];
            if (code > 128) {
                int n = code - 128;
                if (n > width - x)
                    return sg_error_set(err, SG_ERR_CORRUPT,
                                        "%s: scanline %d: run of %d at x=%d overflows the row of %d "
                                        "(channel %d)",
                                        c->name, y, n, x, width, ch);
                if (c->pos >= c->size)
                    return sg_error_set(err, SG_ERR_CORRUPT,
                                        "%s: scanline %d: truncated (file ends in a run, channel %d)",
                                        c->name, y, ch);
                memset(plane + x, c->data[c->pos++], (size_t)n);
                x += n;
            } else {
                int n = code;
                if (n == 0) /* invariant 2 */
                    return sg_error_set(err, SG_ERR_CORRUPT,
                                        "%s: scanline %d: zero-length literal at x=%d (channel %d)",
                                        c->name, y, x, ch);
                if (n > width - x)
                    return sg_error_set(err, SG_ERR_CORRUPT,
                                        "%s: scanline %d: literal of %d at x=%d overflows the row of "
                                        "%d (channel %d)",
                                        c->name, y, n, x, width, ch);
                if (c->size - c->pos < (size_t)n)
                    return sg_error_set(err, SG_ERR_CORRUPT,
                                        "%s: scanline %d: truncated (file ends in a literal, channel "
                                        "%d)",
                                        c->name, y, ch);
                memcpy(plane + x, c->data + c->pos, (size_t)n);
                c->pos += (size_t)n;
                x += n;
            }
        }
    }
    return SG_OK;
}

/* Parses the header and resolution line; leaves c at the first pixel byte. */
static sg_status parse_header(cursor *c, int *width, int *height, sg_error *err)
{
    char line[256];
    if (!read_line(c, line, sizeof line) ||
        (strcmp(line, "#?RADIANCE") != 0 && strcmp(line, "#?RGBE") != 0))
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: not a Radiance picture (first line is not #?RADIANCE or #?RGBE)",
                            c->name);
    for (;;) {
        if (!read_line(c, line, sizeof line))
            return sg_error_set(err, SG_ERR_CORRUPT,
                                "%s: header has no end (no blank line within %d bytes)", c->name,
                                HDR_MAX_HEADER_BYTES);
        if (line[0] == '\0')
            break;
        if (strncmp(line, "FORMAT=", 7) == 0) {
            const char *f = line + 7;
            size_t n = strlen(f);
            while (n > 0 && (f[n - 1] == ' ' || f[n - 1] == '\t'))
                n--;
            if (n != 15 || strncmp(f, "32-bit_rle_rgbe", 15) != 0)
                return sg_error_set(err, SG_ERR_UNSUPPORTED,
                                    "%s: header: FORMAT=%s is not supported (only 32-bit_rle_rgbe)",
                                    c->name, f);
        }
        /* Everything else (EXPOSURE, GAMMA, PRIMARIES, comments) is ignored:
         * see hdr.h. */
    }
    if (!read_line(c, line, sizeof line))
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: resolution line missing", c->name);
    char a1[3], a2[3];
    long n1, n2;
    char tail;
    if (sscanf(line, "%2s %ld %2s %ld %c", a1, &n1, a2, &n2, &tail) != 4 ||
        (a1[0] != '-' && a1[0] != '+') || (a2[0] != '-' && a2[0] != '+') ||
        (a1[1] != 'X' && a1[1] != 'Y') || (a2[1] != 'X' && a2[1] != 'Y') || a1[1] == a2[1])
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: malformed resolution line \"%s\"", c->name, line);
    if (strcmp(a1, "-Y") != 0 || strcmp(a2, "+X") != 0)
        return sg_error_set(err, SG_ERR_UNSUPPORTED,
                            "%s: orientation \"%s\" is not supported (only -Y <height> +X <width>)",
                            c->name, line);
    if (n1 < 1 || n2 < 1 || n1 > SG_IMAGE_MAX_DIM || n2 > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: size %ld x %ld is out of range (1..%d)", c->name,
                            n2, n1, SG_IMAGE_MAX_DIM);
    *height = (int)n1;
    *width = (int)n2;
    return SG_OK;
}

sg_status sg_hdr_read_memory(const void *data, size_t size, const char *name, sg_image *out,
                             sg_error *err)
{
    assert(out);
    if (!name)
        name = "<memory>";
    if (!data && size > 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: no data", name);
    cursor c = {.data = data, .size = size, .pos = 0, .name = name};
    int width = 0, height = 0;
    sg_status st = parse_header(&c, &width, &height, err);
    if (st != SG_OK)
        return st;

    /* Invariant 3. Division instead of multiplication: cannot overflow. */
    size_t left = c.size - c.pos;
    if (left / (size_t)height < min_line_bytes(width))
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: truncated: %zu bytes of pixels cannot hold %d x %d pixels", name, left,
                            width, height);

    sg_image img = {0};
    uint8_t *planes = NULL; /* 4 channel planes of one RLE line */
    st = sg_image_alloc(&img, width, height, err);
    if (st != SG_OK)
        goto fail;
    planes = sg_alloc_array((size_t)width, 4);
    if (!planes) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for a %d-pixel scanline", name, width);
        goto fail;
    }

    for (int y = 0; y < height; y++) {
        float *row = img.data + (size_t)y * (size_t)width * 3;
        const uint8_t *p = c.data + c.pos;
        size_t avail = c.size - c.pos;
        int rle = width >= HDR_RLE_MIN_WIDTH && width <= HDR_RLE_MAX_WIDTH && avail >= 4 &&
                  p[0] == 2 && p[1] == 2 && (p[2] & 0x80) == 0;
        if (rle) {
            int w = (p[2] << 8) | p[3];
            if (w != width) {
                st = sg_error_set(err, SG_ERR_CORRUPT,
                                  "%s: scanline %d: run-length header gives width %d, expected %d", name,
                                  y, w, width);
                goto fail;
            }
            c.pos += 4;
            st = decode_rle_line(&c, y, width, planes, err);
            if (st != SG_OK)
                goto fail;
            for (int x = 0; x < width; x++) {
                uint8_t rgbe[4] = {planes[x], planes[(size_t)width + x], planes[2 * (size_t)width + x],
                                   planes[3 * (size_t)width + x]};
                rgbe_to_float(rgbe, row + 3 * (size_t)x);
            }
        } else {
            if (avail / 4 < (size_t)width) {
                st = sg_error_set(err, SG_ERR_CORRUPT,
                                  "%s: scanline %d: truncated (flat line needs %d bytes, %zu left)", name,
                                  y, 4 * width, avail);
                goto fail;
            }
            for (int x = 0; x < width; x++) {
                const uint8_t *q = p + 4 * (size_t)x;
                if (x > 0 && q[0] == 1 && q[1] == 1 && q[2] == 1) {
                    st = sg_error_set(err, SG_ERR_UNSUPPORTED,
                                      "%s: scanline %d: old-style run-length record at x=%d is not "
                                      "supported",
                                      name, y, x);
                    goto fail;
                }
                rgbe_to_float(q, row + 3 * (size_t)x);
            }
            c.pos += 4 * (size_t)width;
        }
    }
    sg_free(planes);
    *out = img; /* invariant 4 */
    return SG_OK;

fail:
    sg_free(planes);
    sg_image_free(&img);
    return st;
}

sg_status sg_hdr_read(const char *path, sg_image *out, sg_error *err)
{
    assert(out);
    if (!path || !path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "hdr path is empty");
    FILE *f = fopen(path, "rb");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    sg_status st = SG_OK;
    uint8_t *buf = NULL;
    long size = -1;
    if (fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) != 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: cannot determine the file size: %s", path,
                          strerror(errno));
        goto done;
    }
    buf = sg_alloc_array((size_t)size, 1);
    if (!buf) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %ld bytes", path, size);
        goto done;
    }
    if (size > 0 && fread(buf, 1, (size_t)size, f) != (size_t)size) {
        st = sg_error_set(err, SG_ERR_IO, "%s: read failed", path);
        goto done;
    }
    st = sg_hdr_read_memory(buf, (size_t)size, path, out, err);
done:
    sg_free(buf);
    fclose(f);
    return st;
}
