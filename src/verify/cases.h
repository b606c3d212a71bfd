/* cases.h — the stability cases: inputs that break point-based surfaces,
 * each with the exact shape it was made from.
 *
 * What it does: sg_verify_case_make(i) writes case i's generated inputs
 * (PLY point clouds, an EXR envmap) under a work folder, and returns a
 * scene file (JSON parsed by sg_scene_file_parse) for a chosen surface
 * model, a camera, and the truth (verify/truth.h) to score holes and
 * normals against. Cases (name: what):
 *   sphere_clean      unit sphere, 20k Fibonacci points (the control)
 *   bunny_clean       assets/bunny.ply sampled to 20k points (control)
 *   coarse_2k         the same bunny with 2,000 points
 *   radii_small       sphere_clean with splat radii x 0.35 (holes)
 *   noisy_normals     sphere_clean with normals n + 0.4 g, g ~ N(0, I)
 *   missing_normals   bunny_clean with no normals in the file: estimated
 *                     by PCA + MST orientation (points/normals.h)
 *   sharp_cube        cube of side 2, 6 x 60^2 points, face normals
 *   thin_sheet        two 100^2 layers 0.01 apart, normals facing out
 *   grazing_view      a 4 x 4 plane seen 85 deg from its normal
 *   camera_inside     sphere_clean seen from its centre
 *   scale_1e-3        sphere_clean scaled by 1e-3 (camera too)
 *   scale_1e4         sphere_clean scaled by 1e4
 *   duplicates        sphere_clean with every point three times
 *   tiny_sun          sphere on a plane under the analytic sky with a sun of
 *                     radius 0.1 deg and radiance 2.5e6 (the default sun's
 *                     power in 1/25 of its solid angle)
 *   room              the built-in room (points/room.h: walls 0.2 thick, one
 *                     window) sampled to 60k points, under the analytic sun
 *                     and sky, seen from inside (issue 12)
 *   thin_wall         the same room with walls 0.04 thick (about half a
 *                     splat radius: each wall's two sides within each
 *                     other's support) but for the window wall (0.2, so the
 *                     same light comes in), same view; baseline: room
 *   folds             a close-up of the drapery of Lucy (../shared/data,
 *                     sampled to 100k points; the bunny where the folder is
 *                     absent), a concave closed scan
 * Point counts shrink (about / 6) with `small` (the CI sweep); coarse_2k
 * keeps its 2,000. The truth of room, thin_wall and folds is their mesh. Every case has a lambert material, albedo 0.7, and the
 * analytic "sky" envmap unless said otherwise. `baseline` names the clean
 * case a degraded one is compared with (same view), or -1.
 *
 * Ownership: sg_verify_case_free releases the scene file and truth.
 */
#ifndef SG_VERIFY_CASES_H
#define SG_VERIFY_CASES_H

#include "core/error.h"
#include "io/scene_file.h"
#include "render/camera.h"
#include "surface/scene.h"
#include "verify/truth.h"

typedef struct sg_verify_case {
    const char *name;      /* static string                              */
    const char *what;      /* one line, static                           */
    int baseline;          /* case index of the clean twin, or -1        */
    sg_scene_file scene;   /* one camera, "main"                         */
    sg_camera camera;      /* the view, aspect 1                         */
    sg_truth truth;
} sg_verify_case;

int sg_verify_case_count(void);
const char *sg_verify_case_name(int index);
/* Index of the clean twin of case index (same view), or -1. */
int sg_verify_case_baseline(int index);
/* Index of the case called name, or -1. */
int sg_verify_case_find(const char *name);

/* Builds case index for surface model `model` under work_dir (created).
 * small: the CI sizes. *out written only on SG_OK. */
sg_status sg_verify_case_make(int index, sg_surface_model model, int small, const char *work_dir,
                              sg_verify_case *out, sg_error *err);
void sg_verify_case_free(sg_verify_case *c);

/* Writes a binary little-endian PLY point cloud: x y z, and nx ny nz when
 * normals is non-NULL (3 floats per point each). Temporary name, rename. */
sg_status sg_verify_write_ply(const char *path, size_t count, const float *positions, const float *normals,
                              sg_error *err);

#endif
