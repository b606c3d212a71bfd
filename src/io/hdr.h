/* hdr.h — Radiance .hdr (RGBE) reader.
 *
 * What it does: decodes a Radiance picture ("#?RADIANCE" or "#?RGBE" magic,
 * FORMAT=32-bit_rle_rgbe) into a float RGB sg_image. Scanlines may be flat
 * (4 bytes R, G, B, E per pixel) or new-style run-length encoded (each line
 * starts 2, 2, width>>8, width&255, then the four channel planes, each as
 * runs "128+n, byte" (n = 1..127) and literals "n, n bytes" (n = 1..128)).
 * Lines of either kind may be mixed in one file, as Radiance allows.
 *
 * What it does NOT do:
 *  - orientations other than the standard "-Y <height> +X <width>" (top row
 *    first, left to right): SG_ERR_UNSUPPORTED naming the resolution line;
 *  - FORMAT=32-bit_rle_xyze (CIE XYZ) or any other format: SG_ERR_UNSUPPORTED;
 *  - old-style (pre-1991) run-length records, i.e. a pixel 1,1,1,n after
 *    the first pixel of a flat line: SG_ERR_UNSUPPORTED (Radiance would read
 *    them as "repeat the previous pixel", so reading them as colours would
 *    silently give a wrong image);
 *  - header variables: EXPOSURE, COLORCORR, GAMMA, PRIMARIES, comments and
 *    every other line are ignored, as Blender, stb_image and three.js do.
 *    The stored values are taken as scene-linear Rec.709 radiance.
 *
 * Decoding of one pixel (Radiance's colr_color(), also Blender's): with
 * exponent byte E = 0 the pixel is black; otherwise channel c is
 * (m_c + 0.5) * 2^(E - 136), the centre of the quantisation interval that
 * the truncating encoders (Radiance setcolr, Walter's float2rgbe) produce.
 *
 * Layout of the result: as sg_image (image.h): row 0 is the first scanline
 * in the file (the top), RGB interleaved, allocated with sg_alloc_array;
 * free it with sg_image_free.
 *
 * Errors (the message names the file, and the scanline where one applies):
 *  SG_ERR_IO        the file cannot be opened or read;
 *  SG_ERR_CORRUPT   bad magic, header without an end, malformed resolution
 *                   line, size outside 1..SG_IMAGE_MAX_DIM, a file too short
 *                   for its size, a truncated scanline, a run or literal
 *                   that is empty or overflows its row, an RLE line whose
 *                   width disagrees with the header;
 *  SG_ERR_UNSUPPORTED  see above;
 *  SG_ERR_NOMEM, SG_ERR_INVALID_ARG.
 * Every loop advances through a bounded buffer, so no input can hang the
 * reader, and the size check comes before the pixel allocation, so a short
 * file cannot make it allocate gigabytes.
 * Thread-safety: reentrant; no global state.
 */
#ifndef SG_IO_HDR_H
#define SG_IO_HDR_H

#include <stddef.h>

#include "core/error.h"
#include "io/image.h"

/* Reads the Radiance file at path into *out (allocated here). On failure
 * *out is untouched. */
sg_status sg_hdr_read(const char *path, sg_image *out, sg_error *err);

/* Same from size bytes in memory (not kept past the call); name is used in
 * messages only (NULL reads as "<memory>"). */
sg_status sg_hdr_read_memory(const void *data, size_t size, const char *name, sg_image *out,
                             sg_error *err);

#endif
