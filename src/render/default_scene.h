/* default_scene.h — the built-in scene: the bunny on a ground plane.
 *
 * The default scene is the Stanford bunny (assets/bunny.ply, made by
 * scripts/setup.sh from the npm package bunny@1.0.1: 1839 vertices, 3674
 * triangles, Y-up, about 10 units tall) sampled to splats in a light clay
 * colour (0.78, 0.62, 0.50), standing on a
 * square ground plane of splats; with it come a default camera (a 3/4 view
 * of the bunny from slightly above) and a light direction (upper left,
 * in front). It is what `splatgi-render --default` and the benchmarks draw.
 *
 * Models become splats through points/model_points.h.
 *
 * Ownership: the pointsets returned are the caller's; free them with
 * sg_default_scene_free / sg_pointset_free. Errors name the file.
 */
#ifndef SG_RENDER_DEFAULT_SCENE_H
#define SG_RENDER_DEFAULT_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "points/model_points.h"
#include "points/pointset.h"
#include "render/camera.h"

/* Default scene options; zero means the documented default. */
typedef struct sg_default_scene_desc {
    sg_model_points_desc model; /* the bunny's sampling, as above             */
    int ground_side;            /* ground points per side; default 300        */
    float ground_half;          /* ground covers centre +- this, in x and z;
                                   default 15 (the bunny is ~10 wide)        */
    const char *asset_dir;      /* folder with bunny.ply; default SG_ASSET_DIR */
} sg_default_scene_desc;

typedef struct sg_default_scene {
    sg_pointset points;   /* bunny splats [0, model_count), then the ground */
    size_t model_count;   /* splats of the bunny                           */
    sg_aabb model_bounds; /* box of the bunny's splat centres               */
    float ground_y;       /* height of the ground: the bunny's lowest vertex */
    sg_vec3 light_dir;    /* unit direction towards the default light        */
} sg_default_scene;

/* Builds the default scene into *out. The ground is a jittered grid (one
 * point per cell, seeded from desc.model.seed) at y = ground_y exactly,
 * normal +Y, grey albedo 0.55, radius = radius_scale x spacing x
 * sqrt(k / pi): the expected k-th neighbour distance of a uniform 2D
 * density, the same rule as the bunny's radii. A missing bunny.ply is
 * SG_ERR_IO with a message saying to run scripts/setup.sh. */
sg_status sg_default_scene_load(const sg_default_scene_desc *d, sg_default_scene *out, sg_error *err);

/* Frees the pointset and zeroes *s; NULL and zeroed are fine. */
void sg_default_scene_free(sg_default_scene *s);

/* The default camera for an image of the given aspect (width / height): a
 * 3/4 view of the bunny from the front right, slightly above, framing the
 * bunny with the given vertical fov (degrees; 0 = 40). */
sg_status sg_default_scene_camera(const sg_default_scene *s, float vfov_deg, float aspect,
                                  sg_camera *out, sg_error *err);

#endif
