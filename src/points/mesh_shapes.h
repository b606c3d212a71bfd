/* mesh_shapes.h — analytic triangle meshes: a sphere and a square plane.
 *
 * The triangle counterparts of primitives.h, for the hybrid surface
 * (surface/hybrid.h): the scene files' builtin "ground" and "sphere" as
 * triangles, and tests with closed-form answers (watertightness on shared
 * edges and pole fans, furnace tests on a closed mesh).
 *   sphere: a latitude/longitude grid, `rings` bands from pole to pole and
 *           `segments` around, one shared vertex per pole (a fan of
 *           `segments` triangles), every edge shared by exactly two
 *           triangles (closed); counter-clockwise seen from outside, unit
 *           outward vertex normals;
 *   plane:  the square [-half, half]^2 at y = 0 as `side` x `side` cells of
 *           two triangles each, counter-clockwise seen from +Y, normals +Y.
 * No colours or radii (white).
 *
 * Ownership: *out is allocated with sg_alloc_array (free with
 * sg_mesh_free) and written only on SG_OK. Errors: SG_ERR_INVALID_ARG
 * (rings < 2, segments < 3, side < 1, radius or half not finite and > 0,
 * more than 2^28 triangles), SG_ERR_NOMEM.
 */
#ifndef SG_POINTS_MESH_SHAPES_H
#define SG_POINTS_MESH_SHAPES_H

#include "core/error.h"
#include "io/mesh.h"

sg_status sg_mesh_make_sphere(int rings, int segments, sg_vec3 centre, float radius, sg_mesh *out, sg_error *err);
sg_status sg_mesh_make_plane(int side, float half, sg_mesh *out, sg_error *err);

#endif
