/* sample.h — point sets from meshes.
 *
 * Two ways to turn an sg_mesh into an sg_pointset:
 *
 * sg_points_from_vertices: one splat per vertex.
 *   position  = the vertex;
 *   normal    = the file normal if the mesh has normals (renormalised; a
 *               zero or non-finite file normal stays (0,0,0) = unknown);
 *               else, if the mesh has triangles, the area-weighted vertex
 *               normal (sum of the unnormalised face normals of the
 *               triangles using the vertex, i.e. weighted by area,
 *               normalised), (0,0,0) for a vertex in no triangle;
 *               else (0,0,0) for every vertex. Unknown normals are meant
 *               for sg_points_estimate_normals with SG_NORMALS_ONLY_MISSING.
 *   albedo    = the vertex colour, else 0.8 grey;
 *   radius    = the file radius, else 0 = unset: call
 *               sg_points_estimate_radii before sg_pointset_validate.
 *
 * sg_points_sample_mesh: `count` points spread over the triangles by area,
 *   deterministic and stratified: a CDF over triangle areas (zero-area
 *   triangles get no share), and point i takes the stratified uniform
 *   u_i = (i + xi_i) / count through the CDF, so a triangle holding the
 *   fraction f of the area receives count*f points within +-2. Within its
 *   triangle the point has barycentrics (1-sqrt(a), sqrt(a)(1-b), sqrt(a) b)
 *   (the square-root warp, uniform in area), and lies on the triangle's
 *   Phong tessellation (Boubekeur & Alexa 2008, shape factor 3/4: pulled
 *   towards the planes of its vertex normals, so that the splats'
 *   normals match the surface they sit on; a flat triangle stays flat).
 *   xi_i, a, b are
 *   sg_rng_float/bits keyed by (seed, i, 0, dim) with dim 0, 1, 2.
 *   normal = the barycentric interpolation of the vertex normals (file
 *            normals, where a file normal is missing the area-weighted one),
 *            normalised — smooth shading normals; the face normal where
 *            the interpolation vanishes. A triangle with the same vertices
 *            as an earlier one is left out (faces_repeated counts them;
 *            crude decimations repeat faces, some wound the other way).
 *            Face normals take a consistent
 *            orientation first: faces sharing an edge are made to agree,
 *            each connected piece faces outward when closed, else keeps
 *            the winding most of its faces have (faces_turned counts the
 *            triangles turned);
 *   albedo = interpolated vertex colours, else 0.8 grey;
 *   radius = radius_scale * sqrt(8 * A / (pi * count)), A the total area:
 *            the mean distance to the 8th nearest neighbour of a uniform
 *            (Poisson) sampling of that density, so it matches
 *            sg_points_estimate_radii's default up to sampling noise
 *            without a kNN pass. Callers wanting the measured spacing call
 *            sg_points_estimate_radii afterwards.
 *   Bit-identical results for any thread count (OpenMP parallel).
 *
 * Ownership: *out is overwritten (not freed first) and only on SG_OK; the
 * caller frees it with sg_pointset_free. The mesh is only read.
 * Errors: SG_ERR_INVALID_ARG (NULL arrays, a triangle index out of range,
 * a non-finite vertex position, count 0, no triangle of positive area —
 * each message names the element), SG_ERR_NOMEM.
 */
#ifndef SG_POINTS_SAMPLE_H
#define SG_POINTS_SAMPLE_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "io/mesh.h"
#include "points/pointset.h"

typedef struct sg_sample_desc {
    size_t count;       /* required: number of points to sample (>= 1)       */
    uint64_t seed;      /* random stream; every value is valid; default 0    */
    float radius_scale; /* multiplier of the analytic radius; 0 = 1.0        */
    size_t *faces_turned; /* optional out (on SG_OK): triangles whose winding
                             was turned to agree with their neighbours      */
    size_t *faces_repeated; /* optional out (on SG_OK): triangles with the
                               vertices of an earlier one, left out         */
} sg_sample_desc;

sg_status sg_points_from_vertices(const sg_mesh *m, sg_pointset *out, sg_error *err);

sg_status sg_points_sample_mesh(const sg_mesh *m, const sg_sample_desc *d, sg_pointset *out,
                                sg_error *err);

#endif
