/* default_scene.c — the built-in bunny scene and the model -> splats
 * pipeline (see default_scene.h).
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
#include "points/normals.h"
#include "points/primitives.h"
#include "points/radius.h"
#include "points/sample.h"


/* Seed offset of the ground jitter, so it never shares a stream with the
 * mesh samples of the same seed. */

static sg_model_points_desc model_defaults(const sg_model_points_desc *d)
{
    sg_model_points_desc r = d ? *d : (sg_model_points_desc){0};
    if (r.points == 0)
        r.points = 250000;
    if (r.radius_k == 0)
        r.radius_k = 8;
    if (r.radius_scale == 0.0f)
        r.radius_scale = 1.0f;
    return r;
}

/* Mesh (already read from path) -> validated splats, as the header says. */
static sg_status mesh_to_points(const sg_mesh *mesh, const char *path, const sg_model_points_desc *d,
                                sg_pointset *out, sg_error *err)
{
    sg_pointset ps = {0};
    sg_status st;
    if (!(d->radius_scale > 0.0f) || !isfinite(d->radius_scale))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: radius scale %g must be > 0", path,
                            (double)d->radius_scale);
    if (mesh->triangle_count > 0) {
        sg_sample_desc sd = {.count = d->points, .seed = d->seed};
        st = sg_points_sample_mesh(mesh, &sd, &ps, err);
    } else {
        st = sg_points_from_vertices(mesh, &ps, err);
    }
    if (st != SG_OK)
        goto fail;

    if (mesh->triangle_count == 0) {
        size_t missing = 0; /* vertices without a usable normal */
        for (size_t i = 0; i < ps.count; i++)
            if (ps.nx[i] == 0.0f && ps.ny[i] == 0.0f && ps.nz[i] == 0.0f)
                missing++;
        if (missing) {
            sg_normals_desc nd = {.flags = SG_NORMALS_ONLY_MISSING};
            st = sg_points_estimate_normals(&ps, &nd, err);
            if (st != SG_OK)
                goto fail;
        }
    }
    if (mesh->triangle_count == 0 && mesh->radii) {
        for (size_t i = 0; i < ps.count; i++)
            ps.radius[i] *= d->radius_scale;
    } else {
        sg_radius_desc rd = {.k = d->radius_k, .scale = d->radius_scale};
        st = sg_points_estimate_radii(&ps, &rd, err);
        if (st != SG_OK)
            goto fail;
    }
    if (!mesh->colors) {
        for (size_t i = 0; i < ps.count; i++) {
            ps.ar[i] = SG_DEFAULT_ALBEDO_R;
            ps.ag[i] = SG_DEFAULT_ALBEDO_G;
            ps.ab[i] = SG_DEFAULT_ALBEDO_B;
        }
    }
    st = sg_pointset_validate(&ps, err);
    if (st != SG_OK)
        goto fail;
    *out = ps;
    return SG_OK;

fail:
    sg_pointset_free(&ps);
    /* Name the file when the points stage did not. */
    if (err && !strstr(err->message, path)) {
        char msg[SG_ERROR_MESSAGE_MAX];
        snprintf(msg, sizeof msg, "%s", err->message);
        sg_error_set(err, st, "%s: %s", path, msg);
    }
    return st;
}

sg_status sg_model_points_load(const char *path, const sg_model_points_desc *d, sg_pointset *out,
                               sg_error *err)
{
    if (!path || !path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "model path is empty");
    sg_model_points_desc md = model_defaults(d);
    sg_mesh mesh = {0};
    sg_status st = sg_mesh_read(path, &mesh, err);
    if (st != SG_OK)
        return st;
    st = mesh_to_points(&mesh, path, &md, out, err);
    sg_mesh_free(&mesh);
    return st;
}

sg_status sg_default_scene_load(const sg_default_scene_desc *d, sg_default_scene *out, sg_error *err)
{
    sg_default_scene_desc dd = d ? *d : (sg_default_scene_desc){0};
    sg_model_points_desc md = model_defaults(&dd.model);
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
    st = mesh_to_points(&mesh, path, &md, &bunny, err);
    if (st != SG_OK)
        goto done;
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
