/* model_points.h — turning a model file into splats.
 *
 * Pipeline (splatgi-render --model, the scene files' "path" models and the
 * built-in bunny):
 *   mesh     -> area-weighted samples with smooth (interpolated) normals
 *   cloud    -> its vertices; normals from the file, estimated where absent
 *   then     -> radius = scale x distance to the k-th nearest neighbour
 *               of its own layer (a thin wall's other side, normals
 *               opposed, does not count: points/radius.h)
 *               (file radii, when present, are kept and scaled)
 *   albedo   -> the file's colours, else the clay colour below.
 * Every pointset returned passes sg_pointset_validate. Errors name the file.
 */
#ifndef SG_POINTS_MODEL_POINTS_H
#define SG_POINTS_MODEL_POINTS_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "io/mesh.h"
#include "points/pointset.h"

/* Albedo of model splats when the file has no colours: a light clay. */
#define SG_DEFAULT_ALBEDO_R 0.78f
#define SG_DEFAULT_ALBEDO_G 0.62f
#define SG_DEFAULT_ALBEDO_B 0.50f

/* How a model file becomes splats; zero means the documented default. */
typedef struct sg_model_points_desc {
    size_t points;       /* mesh: number of samples, default 250000;
                            point cloud: ignored (its vertices are used)   */
    unsigned radius_k;   /* radius from the k-th nearest neighbour; default 8 */
    float radius_scale;  /* radius multiplier; default 1                    */
    uint64_t seed;       /* mesh sampling seed; default 0 (a valid seed)    */
} sg_model_points_desc;

/* Loads a .ply or .obj (sg_mesh_read) and makes splats as described above.
 * d may be NULL. *out is written only on SG_OK. */
sg_status sg_model_points_load(const char *path, const sg_model_points_desc *d, sg_pointset *out,
                               sg_error *err);

/* Same pipeline on a mesh already in memory; path only names it in
 * messages. d may be NULL. */
sg_status sg_model_points_from_mesh(const sg_mesh *mesh, const char *path, const sg_model_points_desc *d,
                                    sg_pointset *out, sg_error *err);

#endif
