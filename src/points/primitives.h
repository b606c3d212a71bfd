/* primitives.h — analytic point sets: a sphere and a square plane.
 *
 * For tests with closed-form answers (furnace tests, a sphere on a plane)
 * and for the scene files' "builtin" models. Both place points evenly so
 * that the radius rule is known in closed form:
 *   sphere: N points on the Fibonacci spiral, spacing h = sqrt(4 pi R^2 / N);
 *   plane:  side x side jittered grid, spacing h = 2 half / side;
 * radius = radius_scale x h x sqrt(k / pi), the expected distance to the
 * k-th nearest neighbour of a uniform 2D density (k = 8 by default), the same
 * rule sg_points_estimate_radii measures on scans.
 */
#ifndef SG_POINTS_PRIMITIVES_H
#define SG_POINTS_PRIMITIVES_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "points/pointset.h"

typedef struct sg_sphere_points_desc {
    size_t count;         /* points; default 100000                       */
    sg_vec3 centre;       /* default origin                               */
    float radius;         /* sphere radius R; default 1                   */
    int inward;           /* normals point to the centre (a room seen
                             from inside); default 0: outward            */
    unsigned radius_k;    /* default 8                                    */
    float radius_scale;   /* default 1                                    */
    sg_vec3 albedo;       /* default (0.8, 0.8, 0.8)                      */
} sg_sphere_points_desc;

typedef struct sg_plane_points_desc {
    int side;             /* points per side; default 300                 */
    float half;           /* covers centre +- half in x and z; default 15 */
    sg_vec3 centre;       /* the plane is y = centre.y, normal +Y         */
    unsigned radius_k;    /* default 8                                    */
    float radius_scale;   /* default 1                                    */
    uint64_t seed;        /* jitter seed; default 0                       */
    sg_vec3 albedo;       /* default (0.55, 0.55, 0.55)                   */
} sg_plane_points_desc;

/* Both write *out only on SG_OK; d may be NULL (all defaults). */
sg_status sg_points_make_sphere(const sg_sphere_points_desc *d, sg_pointset *out, sg_error *err);
sg_status sg_points_make_plane(const sg_plane_points_desc *d, sg_pointset *out, sg_error *err);

#endif
