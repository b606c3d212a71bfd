/* exr_read.h — read any flat OpenEXR image as float RGB (C interface to
 * OpenEXR's C++ library).
 *
 * What it does: opens part 0 of an OpenEXR file, scanline or tiled (level 0
 * of a mip/rip-mapped file), with any compression OpenEXR 3.1 decodes —
 * NONE, RLE, ZIPS, ZIP, PIZ, PXR24, B44, B44A and the lossy DWAA/DWAB that
 * real HDR maps use (which the core C API behind sg_image_read_exr cannot)
 * — and channels of type half, float or uint, converted to float:
 *   - R, G, B (A and any other channel ignored); a colour channel that is
 *     absent reads as 0, so an "R"-only file becomes red;
 *   - Y alone (luminance-only): grey, R = G = B = Y;
 *   - Y with RY, BY (luminance/chroma, subsampled chroma): converted by
 *     Imf::RgbaInputFile with the file's chromaticities (half precision).
 * Values are passed through untouched: negative values from the lossy
 * codecs, NaN and Inf stay as stored (sg_envmap clamps them).
 *
 * What it does NOT do: deep files (SG_ERR_UNSUPPORTED), parts other than 0,
 * layered channel names ("diffuse.R"; a file with neither R, G, B nor Y is
 * SG_ERR_UNSUPPORTED naming the first channels), subsampled R/G/B
 * (SG_ERR_UNSUPPORTED), data windows larger than SG_IMAGE_MAX_DIM.
 *
 * Layout: as sg_image (image.h): the data window becomes the image (its
 * origin is dropped), row 0 = the data window's top row (min y), RGB
 * interleaved floats, allocated with sg_alloc_array; free with
 * sg_image_free.
 *
 * Errors (the message always starts with the path):
 *  SG_ERR_IO          the file cannot be opened or read (an OS error);
 *  SG_ERR_CORRUPT     not an OpenEXR file, a header or pixel chunk the
 *                     library rejects, or a file with missing chunks
 *                     (truncated): the library's own message follows; a
 *                     data window too big for the file size (checked
 *                     before any pixel is read: even at the compression's
 *                     best ratio the pixels could not fit), naming both;
 *  SG_ERR_UNSUPPORTED see above; SG_ERR_NOMEM; SG_ERR_INVALID_ARG.
 * No C++ exception leaves this interface: each is caught and turned into
 * one of the codes above.
 * Thread-safety: reentrant; each call opens its own file. OpenEXR's global
 * thread pool is left as the application set it (default: no threads).
 */
#ifndef SG_IO_EXR_READ_H
#define SG_IO_EXR_READ_H

#ifdef __cplusplus
extern "C" {
#endif

#include "core/error.h"
#include "io/image.h"

/* Where the RGB values of the result came from. */
typedef enum sg_exr_source {
    SG_EXR_SOURCE_RGB = 0, /* R, G, B channels (some may be absent -> 0) */
    SG_EXR_SOURCE_Y = 1,   /* luminance only -> grey                     */
    SG_EXR_SOURCE_YC = 2   /* luminance + chroma, via RgbaInputFile      */
} sg_exr_source;

/* What sg_exr_read found in the file; filled only on SG_OK. */
typedef struct sg_exr_read_info {
    int tiled;            /* 1 when part 0 is tiled, 0 for scanlines     */
    int half;             /* 1 when every colour channel read is half    */
    int has_alpha;        /* 1 when an A channel exists (it is ignored)  */
    sg_exr_source source; /* which channels made R, G, B                 */
    char compression[8];  /* "none", "rle", "zips", "zip", "piz",
                             "pxr24", "b44", "b44a", "dwaa", "dwab"      */
} sg_exr_read_info;

/* Reads part 0 of the EXR at path into *out (allocated here). info may be
 * NULL. On failure *out and *info are untouched. */
sg_status sg_exr_read(const char *path, sg_image *out, sg_exr_read_info *info, sg_error *err);

/* The size of part 0's data window from the header alone, without reading
 * any pixel (the same errors as sg_exr_read for the file and its header).
 * Decoding time and memory grow with that size, and a few bytes can set
 * it (a constant 65536 x 65536 DWAB image fits in about 100 KB), so a
 * caller with a budget checks it first: the fuzz harness does. */
sg_status sg_exr_read_size(const char *path, int *width, int *height, sg_error *err);

#ifdef __cplusplus
}
#endif

#endif
