/* ply.h — reads Stanford PLY files (ascii, binary_little_endian,
 * binary_big_endian, version 1.0) into an sg_mesh (see mesh.h).
 *
 * What it reads
 *   element vertex   x, y, z                  required, any numeric type
 *                    nx, ny, nz               optional (all three or ignored)
 *                    radius                   optional, must be finite and > 0
 *                    red, green, blue         optional colour (all three), or
 *                    diffuse_red, diffuse_green, diffuse_blue when the plain
 *                    names are absent. uchar (0..255) and ushort (0..65535)
 *                    values are sRGB-encoded and decoded to linear; float and
 *                    double values are already linear and clamped to [0,1].
 *   element face     property list <count type> <index type> vertex_indices
 *                    (or vertex_index). Any integer count and index types.
 *                    A polygon v0 v1 ... vn-1 becomes the fan (v0,vi,vi+1);
 *                    a face with fewer than 3 indices is an error.
 *   element tristrips  property list <count type> <index type> vertex_indices:
 *                    triangle strips, -1 ending each; strip triangle k is
 *                    (v_k, v_k+1, v_k+2) with the first two swapped for odd
 *                    k (OpenGL's rule: the winding is kept); triangles with
 *                    a repeated vertex (stitching) are dropped. Faces and
 *                    strips may come together; triangles are in file order.
 *   Every other element and property, scalar or list, is skipped. Header
 *   `comment` and `obj_info` lines are ignored; CRLF header lines are fine.
 *
 * What it does NOT do: no edges, materials, texture coordinates or other
 * point sizes (`psz` is not a radius); no vertex count above 2^32 - 1
 * (triangle indices are uint32).
 *
 * Normals contract: a vertex whose file normal is zero-length or not finite
 * gets the normal (0,0,0), meaning "unknown, estimate it" (point preparation
 * re-estimates those); this is not an error because real scans have them
 * (CGAL's hippo2.ply). Every other normal is rescaled to unit length.
 *
 * Errors: SG_ERR_IO when the file cannot be opened or read; SG_ERR_CORRUPT
 * for malformed, truncated or invalid content (NaN/Inf position, face index
 * out of range or negative, counts larger than the file can hold, no
 * vertices); SG_ERR_NOMEM when allocation fails or a count overflows size
 * arithmetic; SG_ERR_UNSUPPORTED for valid PLY that we do not handle (no
 * x,y,z, another format or version, integer colours wider than 16 bits).
 * The message names the file, the element and the fault:
 *   "bunny.ply: vertex 1042: x is NaN"
 *   "cube.ply: header: vertex count 4000000000 exceeds what the file can
 *    hold (123 bytes)"
 * Element numbers count from 0. Counts are checked against the file size
 * before anything is allocated. On failure *out is untouched and nothing is
 * left allocated.
 *
 * Thread-safety: reentrant; no global state.
 */
#ifndef SG_IO_PLY_H
#define SG_IO_PLY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "io/mesh.h"

/* Reads the PLY file at path into *out (arrays from sg_alloc_array; release
 * with sg_mesh_free). */
sg_status sg_ply_read(const char *path, sg_mesh *out, sg_error *err);

/* The vertex count and the face + tristrips record count its header
 * declares, reading the header alone (the first MiB at most): what a
 * memory estimate needs before loading. Errors as sg_ply_read's header. */
sg_status sg_ply_read_counts(const char *path, uint64_t *vertices, uint64_t *faces, sg_error *err);

/* Helpers shared by the model loaders (ply.c, obj.c; defined in mesh.c).
 * Not meant for use outside src/io. */

/* Reads the whole regular file at path into a fresh sg_alloc_array buffer
 * of *size + 1 bytes whose last byte is '\0'; the caller sg_frees *data.
 * SG_ERR_IO (open/read failure, not a regular file) or SG_ERR_NOMEM. */
sg_status sg_io_read_all(const char *path, char **data, size_t *size, sg_error *err);

/* Parses one decimal number starting exactly at *p (optional sign, digits,
 * optional fraction and exponent, or nan / inf / infinity in any case)
 * without reading at or past end, and independent of the C locale. On
 * success stores it in *out, advances *p past it and returns true; the
 * caller checks what follows. Returns false (leaving *p) when no number
 * starts at *p. Accurate to a double rounding of the exact value, so a
 * float written with 9 significant digits reads back to the same float
 * (up to rare halfway cases). */
bool sg_io_parse_number(const char **p, const char *end, double *out);

#endif
