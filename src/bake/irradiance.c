/* irradiance.c — photon density estimation at the splats (see
 * irradiance.h).
 *
 * Invariants:
 *  1. every estimate is finite and >= 0 per channel;
 *  2. each splat's value depends only on the photon map and the splat
 *     (ordered kNN), so the result ignores the thread count.
 */
#include "bake/irradiance.h"

#include <math.h>
#include <omp.h>

#include "core/alloc.h"
#include "points/knn.h"

static const float PI_F = 3.14159265358979f;

enum { MAX_K = 1024 };

sg_status sg_irradiance_gather(const sg_world *w, const sg_photon_map *pm, const sg_irradiance_desc *desc,
                               float ***out, sg_error *err)
{
    sg_irradiance_desc d = desc ? *desc : (sg_irradiance_desc){0};
    if (d.k == 0) d.k = 64;
    if (d.normal_cos == 0.0f) d.normal_cos = 0.7f;
    if (d.k > MAX_K)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "irradiance: k = %u exceeds %d photons", d.k, MAX_K);
    size_t models = sg_world_model_count(w);
    float **E = sg_calloc_array(models, sizeof *E);
    if (!E)
        return sg_error_set(err, SG_ERR_NOMEM, "irradiance: out of memory");
    sg_status st = SG_OK;
    for (size_t m = 0; m < models; ++m) {
        size_t n = sg_scene_sites(sg_world_scene(w, (uint32_t)m))->count;
        if (!(E[m] = sg_calloc_array(6 * n, sizeof(float)))) {
            st = sg_error_set(err, SG_ERR_NOMEM, "irradiance: out of memory for %zu splats", n);
            goto fail;
        }
    }
    if (pm->count < d.k) /* too few photons for any estimate: all dark */
        goto done;
    sg_knn *tree = NULL;
    sg_knn_desc kd = {.count = pm->count, .px = pm->px, .py = pm->py, .pz = pm->pz};
    if ((st = sg_knn_create(&kd, &tree, err)) != SG_OK)
        goto fail;
    int threads = d.threads > 0 ? d.threads : omp_get_max_threads();
    for (size_t m = 0; m < models; ++m) {
        const sg_sites *ps = sg_scene_sites(sg_world_scene(w, (uint32_t)m));
        float *Em = E[m];
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads)
        for (size_t i = 0; i < ps->count; ++i) {
            uint32_t idx[MAX_K];
            float d2[MAX_K];
            sg_vec3 x = sg_sites_position(ps, i), n = sg_sites_normal(ps, i);
            size_t found = sg_knn_query(tree, x, d.k, UINT32_MAX, idx, d2);
            if (found < 2)
                continue;
            float h2 = d2[found - 1];
            if (!(h2 > 0.0f))
                continue;
            double e[6] = {0, 0, 0, 0, 0, 0}; /* front RGB, back RGB */
            float norm = 2.0f / (PI_F * h2);
            for (size_t j = 0; j < found; ++j) {
                uint32_t p = idx[j];
                /* A record's normal faces the side it arrived from: along
                 * n for the front, against it for the back. */
                float cn = pm->nx[p] * n.x + pm->ny[p] * n.y + pm->nz[p] * n.z;
                int side = cn < 0.0f;
                if ((side ? -cn : cn) < d.normal_cos)
                    continue;
                float k = norm * (1.0f - d2[j] / h2);
                e[3 * side + 0] += (double)pm->fr[p] * k;
                e[3 * side + 1] += (double)pm->fg[p] * k;
                e[3 * side + 2] += (double)pm->fb[p] * k;
            }
            for (int c = 0; c < 6; ++c)
                Em[6 * i + (size_t)c] = (float)e[c];
        }
    }
    sg_knn_destroy(tree);
done:
    *out = E;
    return SG_OK;
fail:
    for (size_t m = 0; m < models; ++m)
        sg_free(E[m]);
    sg_free(E);
    return st;
}
