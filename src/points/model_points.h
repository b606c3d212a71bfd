/* model_points.h — turning a model file into splats.
 *
 * Pipeline (splatgi-render --model, the scene files' "path" models and the
 * built-in bunny):
 *   mesh     -> area-weighted samples with smooth (interpolated) normals
 *   cloud    -> its vertices; normals from the file, estimated where absent
 *   then     -> radius = scale x distance to the k-th nearest neighbour
 *               of its own layer (a thin wall's other side, normals
 *               opposed, does not count: points/radius.h), capped at
 *               radius_cap x the median (stray points, radius.h); with
 *               drop_outliers the capped points are removed and the
 *               radii of the rest estimated again (file radii, when
 *               present, are kept and scaled)
 *   colour   -> the file's colours, else white (1, 1, 1): a material's
 *               albedo is then the albedo (no tint the file does not have).
 * Every pointset returned passes sg_pointset_validate. Errors name the file.
 */
#ifndef SG_POINTS_MODEL_POINTS_H
#define SG_POINTS_MODEL_POINTS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "io/mesh.h"
#include "points/pointset.h"
#include "points/radius.h"

/* What loading found, for the caller to report. */
typedef struct sg_model_points_report {
    size_t file_vertices;  /* vertices in the file                        */
    size_t file_triangles; /* triangles in the file (0: a point cloud)    */
    bool has_colors;       /* the file has per-vertex colours             */
    size_t faces_repeated; /* triangles repeating an earlier one, left out */
    size_t faces_turned;   /* triangles turned to agree with neighbours   */
    size_t capped;         /* estimated radii lowered to the cap          */
    size_t dropped;        /* points removed by drop_outliers             */
    float median_radius;   /* median estimated radius (0: file radii)     */
    float cap_radius;      /* the cap (INFINITY: none; 0: file radii)     */
} sg_model_points_report;

/* How a model file becomes splats; zero means the documented default. */
typedef struct sg_model_points_desc {
    size_t points;       /* mesh: number of samples, default 250000;
                            point cloud: ignored (its vertices are used)   */
    unsigned radius_k;   /* radius from the k-th nearest neighbour; default 8 */
    float radius_scale;  /* radius multiplier; default 1                    */
    uint64_t seed;       /* mesh sampling seed; default 0 (a valid seed)    */
    float radius_cap;    /* estimated radii above radius_cap x the median
                            are capped to it (stray points, radius.h);
                            0: SG_RADIUS_CAP_DEFAULT; < 0: no cap         */
    bool drop_outliers;  /* drop the points whose radius was capped        */
    sg_model_points_report *report; /* optional out, filled on SG_OK      */
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
