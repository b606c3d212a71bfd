/* pcd.h — reads Point Cloud Library .pcd files (format v0.5-v0.7, DATA
 * ascii or binary) into an sg_mesh with no triangles (see mesh.h).
 *
 * What it reads: the header lines VERSION, FIELDS, SIZE, TYPE, COUNT,
 * WIDTH, HEIGHT, VIEWPOINT (ignored: PCL does not apply it to the points
 * either), POINTS and DATA, in that order ('#' comment lines anywhere in
 * the header), then the points:
 *   x y z                         required, any numeric type
 *   normal_x normal_y normal_z    optional normals (all three)
 *   rgb or rgba                   optional colour, PCL's packing: the 4
 *                                 bytes of the field (F or U, size 4) hold
 *                                 0xAARRGGBB; 8-bit sRGB, decoded to linear
 *   r g b                         separate 8-bit channels, when there is no
 *                                 rgb/rgba field
 *   radius                        optional splat radius (> 0, finite)
 *   anything else (intensity, curvature, ...) is skipped.
 * DATA ascii: one point a line, COUNT values per field; DATA binary: packed
 * little-endian records of sum(SIZE x COUNT) bytes. Points with a NaN
 * coordinate (PCL's "no measurement" in organized clouds, is_dense false)
 * are skipped; an infinite coordinate is an error.
 *
 * What it does NOT do: DATA binary_compressed (SG_ERR_UNSUPPORTED; PCL's
 * pcl_convert_pcd_ascii_binary converts it), fields with COUNT > 1 other
 * than skipped ones (e.g. a 33-value FPFH histogram is skipped).
 *
 * Errors: SG_ERR_CORRUPT for a malformed header (names the line and the
 * keyword), inconsistent SIZE/TYPE/COUNT lists, WIDTH x HEIGHT != POINTS,
 * a POINTS count the body cannot hold (checked before allocating), a
 * malformed or missing value ("scan.pcd: point 17: field y: 'abc' is not a
 * number"), a radius that is not > 0; SG_ERR_UNSUPPORTED (no x y z, other
 * DATA kinds, sizes other than 1, 2, 4, 8); SG_ERR_IO, SG_ERR_NOMEM. No
 * points left after skipping NaNs is SG_ERR_CORRUPT. On failure *out is
 * untouched.
 *
 * Thread-safety: reentrant.
 */
#ifndef SG_IO_PCD_H
#define SG_IO_PCD_H

#include <stdint.h>

#include "core/error.h"
#include "io/mesh.h"

sg_status sg_pcd_read(const char *path, sg_mesh *out, sg_error *err);

/* POINTS of the header, reading the header alone (for memory estimates). */
sg_status sg_pcd_read_count(const char *path, uint64_t *points, sg_error *err);

#endif
