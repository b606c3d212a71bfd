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

#include "core/alloc.h"
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

/* Keeps the points with keep[i] == 0 (the capped mask marks the others). */
static sg_status drop_marked(sg_pointset *ps, const unsigned char *mark, size_t marked, sg_error *err)
{
    sg_pointset kept = {0};
    sg_status st = sg_pointset_alloc(&kept, ps->count - marked, err);
    if (st != SG_OK)
        return st;
    size_t j = 0;
    for (size_t i = 0; i < ps->count; i++) {
        if (mark[i])
            continue;
        kept.px[j] = ps->px[i]; kept.py[j] = ps->py[i]; kept.pz[j] = ps->pz[i];
        kept.nx[j] = ps->nx[i]; kept.ny[j] = ps->ny[i]; kept.nz[j] = ps->nz[i];
        kept.ar[j] = ps->ar[i]; kept.ag[j] = ps->ag[i]; kept.ab[j] = ps->ab[i];
        kept.radius[j] = ps->radius[i];
        j++;
    }
    sg_pointset_free(ps);
    *ps = kept;
    return SG_OK;
}

/* Radii from the k-th neighbour with the cap; with drop_outliers the
 * capped points go and the rest are estimated again (their neighbours may
 * have included a dropped point). */
static sg_status estimate_radii(sg_pointset *ps, const sg_model_points_desc *d, sg_model_points_report *rep,
                                sg_error *err)
{
    sg_radius_stats rs;
    unsigned char *mark = NULL;
    if (d->drop_outliers && !(mark = sg_alloc_array(ps->count, 1)))
        return sg_error_set(err, SG_ERR_NOMEM, "out of memory for %zu outlier marks", ps->count);
    /* Normals are set by now: radii from each point's own layer, so a thin
     * wall's other side does not shrink them (radius.h). */
    sg_radius_desc rd = {.k = d->radius_k, .scale = d->radius_scale, .cap = d->radius_cap, .layers = 1,
                         .stats = &rs, .capped = mark};
    sg_status st = sg_points_estimate_radii(ps, &rd, err);
    if (st == SG_OK && mark && rs.capped > 0) {
        if (rs.capped > ps->count - 2) {
            st = sg_error_set(err, SG_ERR_INVALID_ARG, "dropping %zu outliers would leave %zu points", rs.capped,
                              ps->count - rs.capped);
        } else {
            rep->dropped = rs.capped;
            st = drop_marked(ps, mark, rs.capped, err);
            rd.capped = NULL;
            if (st == SG_OK)
                st = sg_points_estimate_radii(ps, &rd, err);
        }
    }
    sg_free(mark);
    if (st == SG_OK) {
        rep->capped = rs.capped;
        rep->median_radius = rs.median;
        rep->cap_radius = rs.cap_radius;
    }
    return st;
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
    size_t turned = 0, repeated = 0;
    if (mesh->triangle_count > 0) {
        sg_sample_desc sd = {.count = d->points, .seed = d->seed, .faces_turned = &turned, .faces_repeated = &repeated};
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
    sg_model_points_report rep = {.file_vertices = mesh->vertex_count, .file_triangles = mesh->triangle_count,
                                  .has_colors = mesh->colors != NULL, .faces_repeated = repeated,
                                  .faces_turned = turned};
    if (mesh->triangle_count == 0 && mesh->radii) {
        for (size_t i = 0; i < ps.count; i++)
            ps.radius[i] *= d->radius_scale;
    } else if ((st = estimate_radii(&ps, d, &rep, err)) != SG_OK) {
        goto fail;
    }
    if (!mesh->colors) {
        /* No colours in the file: no tint, the material's albedo is the
         * albedo (model_points.h). */
        for (size_t i = 0; i < ps.count; i++)
            ps.ar[i] = ps.ag[i] = ps.ab[i] = 1.0f;
    }
    st = sg_pointset_validate(&ps, err);
    if (st != SG_OK)
        goto fail;
    *out = ps;
    if (d->report)
        *d->report = rep;
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

