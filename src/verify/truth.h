/* truth.h — the shape a point set was made from, traced exactly, and what
 * the splat surface gets wrong about it (holes, normals).
 *
 * What it does: holds up to SG_TRUTH_MAX_PARTS analytic or meshed parts
 * (sphere, axis-aligned box, horizontal rectangle, triangle mesh) and finds
 * the nearest crossing of a ray with them, with the true outward normal.
 * sg_truth_compare_view casts one primary ray per pixel centre against both
 * the truth and a world's splat surface and counts, over the pixels, where
 * they disagree: the stability map's hole rate and normal error.
 * What it does NOT do: acceleration (meshes are tested triangle by
 * triangle: meant for the few-thousand-triangle shapes of the stability
 * cases), shading.
 *
 * Definitions (sg_truth_view_stats):
 *   truth pixels  T = pixels whose centre ray hits the truth
 *   hole rate     |{i in T : the splat surface is missed}| / |T|
 *   spill rate    |{i not in T : the splat surface is hit}| / (pixels - |T|)
 *                 (0 when every pixel is in T)
 *   normal error  mean over pixels hit by both of acos(n_splat . n_true) in
 *                 degrees; n_true is the outward normal of the truth, so a
 *                 splat normal pointing inwards counts as 180 degrees
 *   flipped       fraction of those pixels with n_splat . n_true < 0
 *
 * Ownership: sg_truth_add_mesh copies the mesh; sg_truth_free releases it.
 * Thread-safety: queries are const and reentrant.
 */
#ifndef SG_VERIFY_TRUTH_H
#define SG_VERIFY_TRUTH_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "io/mesh.h"
#include "math/ray.h"
#include "render/camera.h"
#include "render/world.h"

#define SG_TRUTH_MAX_PARTS 4

typedef enum sg_truth_kind {
    SG_TRUTH_SPHERE = 0, /* centre a, radius r                          */
    SG_TRUTH_BOX = 1,    /* box [a, b]                                   */
    SG_TRUTH_RECT = 2,   /* y = a.y, a.x <= x <= b.x, a.z <= z <= b.z;
                            normal +Y (seen from below: -Y)             */
    SG_TRUTH_MESH = 3    /* triangles of `mesh`, outward = counter-clockwise */
} sg_truth_kind;

typedef struct sg_truth_part {
    sg_truth_kind kind;
    sg_vec3 a, b;
    float r;
    float *tri;          /* MESH: 9 floats per triangle (owned)          */
    size_t tri_count;
} sg_truth_part;

typedef struct sg_truth {
    sg_truth_part parts[SG_TRUTH_MAX_PARTS];
    int count;
} sg_truth;

/* Adders: SG_ERR_INVALID_ARG when full. */
sg_status sg_truth_add_sphere(sg_truth *t, sg_vec3 centre, float radius, sg_error *err);
sg_status sg_truth_add_box(sg_truth *t, sg_vec3 lo, sg_vec3 hi, sg_error *err);
sg_status sg_truth_add_rect(sg_truth *t, float y, float x0, float x1, float z0, float z1, sg_error *err);
/* The mesh's triangles, each vertex p mapped to translate + scale * p. */
sg_status sg_truth_add_mesh(sg_truth *t, const sg_mesh *m, sg_vec3 translate, float scale, sg_error *err);
void sg_truth_free(sg_truth *t);

/* Nearest crossing with t in (ray->tmin, ray->tmax]; 1 and *t_out, *n_out
 * (unit, outward) on a hit, else 0. */
int sg_truth_intersect(const sg_truth *t, const sg_ray *ray, float *t_out, sg_vec3 *n_out);

typedef struct sg_truth_view_stats {
    size_t pixels;          /* width * height                            */
    size_t truth_pixels;    /* |T|                                       */
    size_t holes;           /* in T, splat surface missed                */
    size_t spills;          /* not in T, splat surface hit               */
    size_t both;            /* hit by both                               */
    size_t flipped;         /* of both: n_splat . n_true < 0             */
    double hole_rate, spill_rate, normal_error_deg, flipped_rate;
    size_t nonfinite_normals; /* splat hits with a non-finite normal     */
} sg_truth_view_stats;

/* One ray per pixel centre (sg_camera_ray, without its footprint: the
 * surfaces at full detail, as the reference sees them) against the truth
 * and the world. Errors: SG_ERR_INVALID_ARG (bad size). */
sg_status sg_truth_compare_view(const sg_truth *t, const sg_world *w, const sg_camera *cam, int width, int height,
                                sg_truth_view_stats *out, sg_error *err);

#endif
