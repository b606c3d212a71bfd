/* obj.h — reads Wavefront OBJ geometry (vertices, normals, polygons) into
 * an sg_mesh (see mesh.h).
 *
 * What it reads
 *   v x y z [...]     a vertex; anything after z (w, vertex colours) is
 *                     ignored.
 *   vn x y z          a normal.
 *   f a b c ...       a polygon; each corner is i, i/t, i//n or i/t/n.
 *                     Indices count from 1; negative indices are relative
 *                     (-1 is the last v or vn defined so far). A polygon
 *                     v0 ... vn-1 becomes the fan (v0,vi,vi+1); a face
 *                     with fewer than 3 corners is an error.
 *   Every other line (vt, vp, o, g, s, l, p, usemtl, mtllib, # comments)
 *   is ignored, as is anything after a '#' on a face line.
 *
 * Normals: OBJ normals belong to face corners, sg_mesh normals to vertices.
 * When every face corner names a normal and every vertex is used by some
 * face, vertex i gets the normalised sum of the vn named at its corners;
 * otherwise normals stay NULL. A file with no faces and exactly as many vn
 * as v lines (a point cloud) pairs them by order. Contract shared with
 * ply.h: a normal whose sum is zero-length or not finite is (0,0,0),
 * meaning "unknown, estimate it". No colours or radii are read.
 *
 * Errors: SG_ERR_IO when the file cannot be opened or read; SG_ERR_CORRUPT
 * for a malformed number, a vertex or normal with fewer than 3 coordinates,
 * a NaN/Inf coordinate, face index 0 or out of range, a face of fewer than
 * 3 corners ("line 4: face has 2 vertex indices; a face needs at least
 * 3"), or no vertices;
 * SG_ERR_NOMEM when allocation fails; SG_ERR_UNSUPPORTED for 2^32 or more
 * vertices (triangle indices are uint32).
 * Messages name the file and the 1-based line:
 *   "m.obj: line 17: face index 9 out of range (8 vertices)"
 * On failure *out is untouched and nothing is left allocated.
 *
 * Thread-safety: reentrant; no global state.
 */
#ifndef SG_IO_OBJ_H
#define SG_IO_OBJ_H

#include "core/error.h"
#include "io/mesh.h"

/* Reads the OBJ file at path into *out (arrays from sg_alloc_array;
 * release with sg_mesh_free). */
sg_status sg_obj_read(const char *path, sg_mesh *out, sg_error *err);

#endif
