/* xyz.h — reads text point clouds (.xyz, .txt: one point a line) into an
 * sg_mesh with no triangles (see mesh.h).
 *
 * What it reads: lines of numbers separated by blanks, tabs, commas or
 * semicolons; every point line has the same number of columns:
 *   3  x y z
 *   4  x y z s               (s: a scalar such as intensity, ignored)
 *   6  x y z nx ny nz        when every (nx, ny, nz) of the file has unit
 *                            length within 10 % (or is zero: unknown), else
 *   6  x y z r g b
 *   7  x y z s r g b
 *   9  x y z nx ny nz r g b
 * Colours are display (sRGB-encoded) values, 0..255 when any colour value
 * of the file exceeds 1, else 0..1; they are decoded to linear [0,1].
 * Blank lines and lines starting with '#' or "//" (CloudCompare's header)
 * are skipped. Normals are rescaled to unit length; a zero or non-finite
 * one becomes (0,0,0), "unknown, estimate it" (the ply.h contract).
 *
 * What it does NOT do: radii, point counts on a first line (.pts), other
 * column layouts (an error naming the line and the count).
 *
 * Errors (SG_ERR_CORRUPT unless said; messages name the file and the
 * 1-based line): a value that is not a number ("scan.xyz: line 7: column 2:
 * 'abc' is not a number"), a NaN or infinite coordinate, a line with
 * another column count than the first point line, an unsupported count,
 * colours outside [0, 255] or negative, no points; SG_ERR_IO, SG_ERR_NOMEM;
 * SG_ERR_UNSUPPORTED for 2^32 or more points. On failure *out is untouched.
 *
 * Thread-safety: reentrant.
 */
#ifndef SG_IO_XYZ_H
#define SG_IO_XYZ_H

#include "core/error.h"
#include "io/mesh.h"

sg_status sg_xyz_read(const char *path, sg_mesh *out, sg_error *err);

#endif
