/* coverage.c — see coverage.h. A ray through image point (px, py) is
 * sg_camera_ray's, as every renderer makes it, so n = 1 hits what the
 * lookup frame hits, ray for ray. */
#include "render/coverage.h"

#include <omp.h>

#include "core/alloc.h"
#include "io/image.h"

sg_status sg_coverage_render(const sg_world *w, const sg_coverage_desc *d, float **alpha, sg_error *err)
{
    if (!w || !d || !alpha)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "coverage: NULL argument");
    int n = d->per_side ? d->per_side : 1;
    if (d->width < 1 || d->height < 1 || d->width > SG_IMAGE_MAX_DIM || d->height > SG_IMAGE_MAX_DIM || n < 1 ||
        n > 16)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "coverage: size %dx%d or %d rays per side out of range",
                            d->width, d->height, n);
    float *a = sg_alloc_array((size_t)d->width * (size_t)d->height, sizeof(float));
    if (!a)
        return sg_error_set(err, SG_ERR_NOMEM, "coverage: out of memory for %dx%d", d->width, d->height);
    int threads = d->threads > 0 ? d->threads : omp_get_max_threads();
    const float inv = 1.0f / (float)(n * n);
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads)
    for (int y = 0; y < d->height; ++y)
        for (int x = 0; x < d->width; ++x) {
            int hits = 0;
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i) {
                    sg_ray r = sg_camera_ray(&d->camera, (float)x + ((float)i + 0.5f) / (float)n,
                                             (float)y + ((float)j + 0.5f) / (float)n, d->width, d->height);
                    sg_world_hit h;
                    hits += sg_world_intersect(w, &r, &h, NULL);
                }
            a[(size_t)y * (size_t)d->width + (size_t)x] = (float)hits * inv;
        }
    *alpha = a;
    return SG_OK;
}
