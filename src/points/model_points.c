/* model_points.c — model file -> splats (see model_points.h).
 *
 * Invariant: every pointset returned passes sg_pointset_validate (finite
 * positions, radius > 0, unit normals); everything is a function of the
 * desc (sampling is keyed by the seed), so the result is the same for any
 * thread count.
 */
#include "points/model_points.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "points/normals.h"
#include "points/radius.h"
#include "points/sample.h"

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

sg_status sg_model_points_from_mesh(const sg_mesh *mesh, const char *path, const sg_model_points_desc *dd,
                                    sg_pointset *out, sg_error *err)
{
    sg_model_points_desc dv = model_defaults(dd);
    const sg_model_points_desc *d = &dv;
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
        /* normals are set by now: radii from each point's own layer (a thin
         * wall's other side does not shrink them, radius.h) */
        sg_radius_desc rd = {.k = d->radius_k, .scale = d->radius_scale, .layers = 1};
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
    st = sg_model_points_from_mesh(&mesh, path, &md, out, err);
    sg_mesh_free(&mesh);
    return st;
}

