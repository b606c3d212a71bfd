/* default_scene.c — the built-in bunny scene (see default_scene.h); the
 * model -> splats pipeline is points/model_points.c.
 *
 * Invariants:
 *  1. Every pointset returned passes sg_pointset_validate (finite
 *     positions, radius > 0, unit normals).
 *  2. The default scene's ground lies at exactly y = ground_y, the lowest
 *     bunny vertex, so the bunny stands on it (its samples are convex
 *     combinations of vertices, hence never below).
 *  3. Everything is a function of the desc (sampling and ground jitter are
 *     keyed by the seed), so the scene is the same for any thread count.
 */
#include "render/default_scene.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "core/alloc.h"
#include "io/mesh.h"
#include "math/rng.h"
#include "points/primitives.h"


sg_status sg_default_scene_load(const sg_default_scene_desc *d, sg_default_scene *out, sg_error *err)
{
    sg_default_scene_desc dd = d ? *d : (sg_default_scene_desc){0};
    sg_model_points_desc md = dd.model;
    if (md.radius_k == 0)
        md.radius_k = 8;
    if (md.radius_scale == 0.0f)
        md.radius_scale = 1.0f;
    if (dd.ground_side == 0)
        dd.ground_side = 300;
    if (dd.ground_half == 0.0f)
        dd.ground_half = 15.0f;
    if (!dd.asset_dir)
        dd.asset_dir = SG_ASSET_DIR;
    if (dd.ground_side < 2 || dd.ground_side > 20000 || !(dd.ground_half > 0.0f) || !isfinite(dd.ground_half))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "default scene: ground %d points per side over +-%g is out of range",
                            dd.ground_side, (double)dd.ground_half);

    char path[4096];
    if (snprintf(path, sizeof path, "%s/bunny.ply", dd.asset_dir) >= (int)sizeof path)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "default scene: asset folder name is too long");
    if (access(path, R_OK) != 0)
        return sg_error_set(err, SG_ERR_IO, "%s is missing: run scripts/setup.sh to create it", path);

    sg_mesh mesh = {0};
    sg_pointset bunny = {0}, ground = {0}, all = {0};
    sg_status st = sg_mesh_read(path, &mesh, err);
    if (st != SG_OK)
        return st;
    if (mesh.triangle_count == 0) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: has no triangles (run scripts/setup.sh again)", path);
        goto done;
    }
    float ground_y = INFINITY; /* lowest vertex (invariant 2) */
    for (size_t i = 0; i < mesh.vertex_count; i++)
        ground_y = fminf(ground_y, mesh.positions[3 * i + 1]);
    st = sg_model_points_from_mesh(&mesh, path, &md, &bunny, err);
    if (st != SG_OK)
        goto done;
    /* The default scene's own look: a light clay bunny (the file has no
     * colours, and model points without colours are white). */
    for (size_t i = 0; i < bunny.count; i++) {
        bunny.ar[i] = 0.78f;
        bunny.ag[i] = 0.62f;
        bunny.ab[i] = 0.50f;
    }
    sg_aabb box = sg_pointset_bounds(&bunny);
    sg_vec3 centre = sg_v3(0.5f * (box.lo.x + box.hi.x), ground_y, 0.5f * (box.lo.z + box.hi.z));
    sg_plane_points_desc pd = {.side = dd.ground_side, .half = dd.ground_half, .centre = centre,
                               .radius_k = md.radius_k, .radius_scale = md.radius_scale, .seed = md.seed};
    st = sg_points_make_plane(&pd, &ground, err);
    if (st != SG_OK)
        goto done;
    st = sg_pointset_append(&all, &bunny, err);
    if (st == SG_OK)
        st = sg_pointset_append(&all, &ground, err);
    if (st != SG_OK)
        goto done;
    out->points = all;
    all = (sg_pointset){0};
    out->model_count = bunny.count;
    out->model_bounds = box;
    out->ground_y = ground_y;
    /* Upper left and in front of the default camera: the shadow falls
     * behind the bunny to the right, where the camera sees it. */
    out->light_dir = sg_v3_normalize(sg_v3(-0.85f, 0.65f, 0.1f));
done:
    sg_pointset_free(&all);
    sg_pointset_free(&ground);
    sg_pointset_free(&bunny);
    sg_mesh_free(&mesh);
    return st;
}

void sg_default_scene_free(sg_default_scene *s)
{
    if (!s)
        return;
    sg_pointset_free(&s->points);
    memset(s, 0, sizeof *s);
}

sg_status sg_default_scene_camera(const sg_default_scene *s, float vfov_deg, float aspect,
                                  sg_camera *out, sg_error *err)
{
    if (!s || s->model_count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "default scene: not loaded");
    if (vfov_deg == 0.0f)
        vfov_deg = 40.0f;
    /* The bunny faces -x/+z: look at its face and left side from the
     * front left, about 20 degrees above the horizon. */
    sg_vec3 view = sg_v3(0.6f, -0.38f, -0.75f);
    return sg_camera_frame(s->model_bounds, view, sg_v3(0, 1, 0), vfov_deg, aspect, 0.9f, out, err);
}
