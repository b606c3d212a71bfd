/* image.h — scene-linear RGB images and their files (EXR, PNG).
 *
 * What it does: holds a float RGB image in memory and writes it as OpenEXR
 * (scene-linear, half or float channels R, G, B) or as an 8-bit sRGB PNG
 * (display-referred preview); reads back scanline EXR files with the
 * compressions the OpenEXR 3.1 core C API decodes (none, RLE, ZIPS, ZIP,
 * PIZ, PXR24, B44, B44A).
 * What it does NOT do: DWAA/DWAB decoding (SG_ERR_UNSUPPORTED here; a later
 * C++ reader handles them), tiled or deep or multi-part EXR reading, PNG
 * alpha, colour management (PNG applies the plain sRGB OETF, no OCIO view).
 *
 * Alpha: an image may carry coverage, the share of each pixel where the
 * camera sees a model (render/coverage.h); EXR files then get an "A"
 * channel (unpremultiplied: RGB is the pixel's radiance, sky included, A
 * how much of it is model), and the EXR reader fills alpha from one.
 *
 * Layout: pixel (x, y) is data[3 * (y * width + x) + c], c = 0 R, 1 G, 2 B;
 * row 0 is the top row; rows are tightly packed (stride 12 * width bytes);
 * the array comes from sg_alloc_array (64-byte aligned).
 *
 * Files: every writer writes to a temporary file in the destination folder
 * ("<path>.XXXXXX") and rename()s it over <path> only when the file is
 * complete; on any failure the temporary file is removed and an existing
 * <path> is left as it was (DESIGN.md "Outputs are written to a temporary
 * name and renamed when complete").
 *
 * Errors: SG_ERR_IO (open/write/rename failed; the message names the path),
 * SG_ERR_CORRUPT (a file the EXR library cannot parse), SG_ERR_UNSUPPORTED
 * (valid EXR we do not read), SG_ERR_INVALID_ARG, SG_ERR_NOMEM.
 * Thread-safety: all functions are reentrant; distinct images and paths may
 * be used from several threads.
 */
#ifndef SG_IO_IMAGE_H
#define SG_IO_IMAGE_H

#include "core/error.h"

typedef struct sg_image {
    int width;    /* pixels per row, > 0 once allocated                 */
    int height;   /* rows, > 0 once allocated                           */
    float *data;  /* 3 * width * height floats, RGB interleaved, row 0 top */
    float *alpha; /* width * height coverage values in [0,1], row 0 top;
                     NULL: none (no A channel). Owned by the image
                     (sg_alloc_array), freed by sg_image_free.             */
} sg_image;

/* Largest width or height accepted by sg_image_alloc and the readers. */
#define SG_IMAGE_MAX_DIM 65536

/* Allocates a zero-filled width x height image into *img (whose previous
 * contents are not freed), alpha NULL. On failure *img is untouched. */
sg_status sg_image_alloc(sg_image *img, int width, int height, sg_error *err);

/* Frees the pixels (and alpha) and zeroes the struct; NULL and zeroed
 * images are fine. */
void sg_image_free(sg_image *img);

/* Pixel type of the channels an EXR file stores. */
typedef enum sg_exr_pixel {
    SG_EXR_FLOAT = 0, /* 32-bit float: exact round trip (default)      */
    SG_EXR_HALF = 1   /* 16-bit half: half the size, ~3 decimal digits */
} sg_exr_pixel;

typedef enum sg_exr_compression {
    SG_EXR_ZIP = 0,  /* zlib over 16 scanlines, lossless (default)     */
    SG_EXR_NONE = 1  /* uncompressed                                   */
} sg_exr_compression;

/* EXR write options; zero means the documented defaults. */
typedef struct sg_exr_desc {
    sg_exr_pixel pixel;             /* default SG_EXR_FLOAT          */
    sg_exr_compression compression; /* default SG_EXR_ZIP            */
} sg_exr_desc;

/* Writes img as a single-part scanline EXR with channels R, G, B
 * (scene-linear values as given, NaN and Inf included), and A when
 * img->alpha is set. desc may be NULL. */
sg_status sg_image_write_exr_desc(const sg_image *img, const char *path,
                                  const sg_exr_desc *desc, sg_error *err);

/* Same with the defaults: float channels, ZIP compression. */
sg_status sg_image_write_exr(const sg_image *img, const char *path, sg_error *err);

/* Writes an 8-bit RGB PNG: each channel is v = clamp(exposure * linear, 0, 1)
 * (NaN -> 0), encoded with the sRGB OETF and rounded; the file carries an
 * sRGB chunk. exposure must be finite and >= 0. */
sg_status sg_image_write_png(const sg_image *img, const char *path, float exposure,
                             sg_error *err);

/* Chooses the writer by the extension of path (".exr" or ".png",
 * case-insensitive; EXR with the defaults, exposure used by PNG only).
 * Any other extension is SG_ERR_INVALID_ARG. */
sg_status sg_image_write(const sg_image *img, const char *path, float exposure,
                         sg_error *err);

/* Reads a single-part scanline EXR with R, G and B channels (half, float or
 * uint, full resolution) into *out (allocated here; free with
 * sg_image_free), and an A channel into out->alpha (NULL without one).
 * Other channels are ignored; the data window becomes the image (its
 * origin is dropped). On failure *out is untouched. */
sg_status sg_image_read_exr(const char *path, sg_image *out, sg_error *err);

#endif
