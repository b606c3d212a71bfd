/* model_scene.h — the scene the programs make for a model file given
 * instead of a scene file (`splatgi-view scan.ply`), and the command-line
 * options that shape it.
 *
 * The scene (sg_model_scene_make):
 *   - the model, in its own units, turned so that its up axis is +Y
 *     (desc.up: scanners and photogrammetry often write Z-up), standing on
 *     y = 0 and centred on x = z = 0;
 *   - the builtin ground under it, a square 4 x the model's largest extent
 *     on a side, grey albedo 0.5, 0.36 x as many points as the model has
 *     splats (the default scene's ratio), within [10000, 360000];
 *   - the model's material: Lambert, albedo 0.8 grey where the file has no
 *     colours, 1 x the file's colours where it has them;
 *   - the builtin "sky", or the given .exr/.hdr map;
 *   - one camera, "main", framing the model from the front right,
 *     slightly above (40 degrees vertical field of view);
 *   - render size 800 x 600 (desc.width/height), other settings default.
 * Paths are made absolute, so the scene (sg_scene_file_write) may be saved
 * anywhere and a bake made from either form is the same bake.
 * Reading the model once here (for its bounds and colours) costs one more
 * parse of the file than building the world alone.
 *
 * Errors: the model reader's (naming the file), SG_ERR_INVALID_ARG for a
 * model whose points all coincide, SG_ERR_NOMEM. *out only on SG_OK.
 */
#ifndef SG_APP_MODEL_SCENE_H
#define SG_APP_MODEL_SCENE_H

#include <stdbool.h>
#include <stddef.h>

#include "core/error.h"
#include "io/scene_file.h"

typedef struct sg_model_scene_desc {
    const char *model;   /* REQUIRED: .ply .obj .xyz .txt .pcd              */
    const char *envmap;  /* .exr / .hdr; NULL: the builtin sky              */
    sg_scene_up up;      /* the model's up axis; default +Y                 */
    size_t points;       /* mesh samples; 0: 250000 (clouds: their points)  */
    float radius_cap;    /* as sg_model_points_desc: 0 default, < 0 none     */
    bool drop_outliers;  /* drop the points whose radius was capped         */
    int width, height;   /* render size; 0: 800 x 600                       */
} sg_model_scene_desc;

sg_status sg_model_scene_make(const sg_model_scene_desc *d, sg_scene_file *out, sg_error *err);

/* 1 when path names a model file by its extension (.ply .obj .xyz .txt
 * .pcd, any case), 0 otherwise (a scene file). */
int sg_model_scene_is_model(const char *path);

/* The model-file options every program takes:
 *   --envmap FILE       lat-long .exr/.hdr (default: the builtin sky)
 *   --up AXIS           the model's up axis: x, y, z, with an optional sign
 *   --points N          samples on a mesh (default 250000)
 *   --radius-cap X      cap radii at X x the median (default 8; 0: none)
 *   --drop-outliers     drop the points whose radius was capped
 *   --write-scene FILE  save the scene made for the model as FILE (JSON)
 * If argv[*i] is one of them, reads it (and its value, advancing *i) into
 * d / *write_scene and returns 1; returns 0 for any other argument and -1
 * with err set for a bad or missing value. "--up" followed by a value that
 * is no axis returns 0, so a program may read it otherwise (a camera's up
 * vector "0,1,0"). SG_MODEL_SCENE_OPTIONS is their --help text. */
int sg_model_scene_option(int argc, char **argv, int *i, sg_model_scene_desc *d, const char **write_scene,
                          sg_error *err);

#define SG_MODEL_SCENE_OPTIONS                                                                                     \
    "Model files (.ply .obj .xyz .txt .pcd) instead of a scene file: the model on a ground\n"                     \
    "sized to it, under the sky or --envmap, framed by the camera:\n"                                              \
    "  --envmap FILE       .exr or .hdr lat-long map (default: the builtin sky)\n"                                \
    "  --up AXIS           the model's up axis: x, y, z, -x, -y, -z (default y; z for Z-up scans)\n"              \
    "  --points N          samples on a mesh (default 250000; a point cloud uses its points)\n"                    \
    "  --radius-cap X      cap splat radii at X x the median (default 8; 0: no cap)\n"                            \
    "  --drop-outliers     drop the stray points whose radius was capped\n"                                        \
    "  --write-scene FILE  save the scene made for the model (JSON, to edit and reuse)\n"

#endif
