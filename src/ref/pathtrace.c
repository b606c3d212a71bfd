/* pathtrace.c — unbiased path tracing with envmap/BSDF MIS. See
 * pathtrace.h for the estimator.
 *
 * Random dimensions per bounce b (sg_rng_float(seed, path, b, dim)):
 *   b = 0: dims 0, 1 jitter the pixel;
 *   b >= 1 (the vertex after b - 1 bounces): 0, 1 envmap sample; 2, 3, 4
 *   BSDF sample (lobe, direction); 5 Russian roulette.
 *
 * Invariants:
 *  1. beta (throughput) is finite and >= 0 in every channel, and after the
 *     first bounce at most 1 (BSDF weights are <= 1 and Russian roulette
 *     never raises a channel above 1);
 *  2. a direction's envmap radiance enters a path once: through NEE with
 *     weight w_l = p_l^2 / (p_l^2 + p_b^2), or through the escaped BSDF ray
 *     with w_b = p_b^2 / (p_l^2 + p_b^2), never both unweighted;
 *  3. each pixel depends only on its own paths (thread-count independence).
 */
#include "ref/pathtrace.h"

#include <assert.h>
#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/alloc.h"
#include "math/rng.h"

enum { TILE = 16 };

static sg_ref_desc with_defaults(const sg_ref_desc *d)
{
    sg_ref_desc r = *d;
    if (r.width <= 0) r.width = 512;
    if (r.height <= 0) r.height = 512;
    if (r.spp <= 0) r.spp = 64;
    if (r.max_depth <= 0) r.max_depth = r.max_depth < 0 ? 0 : 8;
    if (r.rr_depth <= 0) r.rr_depth = 3;
    if (r.seed == 0) r.seed = 1;
    return r;
}

static float power_heuristic(float a, float b)
{
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

static float max3(sg_vec3 v) { return fmaxf(v.x, fmaxf(v.y, v.z)); }

sg_vec3 sg_ref_path(const sg_world *w, const sg_ref_desc *d, float x, float y, uint64_t path, sg_ray_stats *st)
{
    return sg_ref_path_counted(w, d, x, y, path, st, NULL);
}

sg_vec3 sg_ref_path_counted(const sg_world *w, const sg_ref_desc *d, float x, float y, uint64_t path,
                            sg_ray_stats *st, sg_ref_counts *counts)
{
    sg_ref_counts c = {0}; /* this path's hits (pathtrace.h) */
    const sg_envmap *env = sg_world_envmap(w);
    sg_ray ray = sg_camera_ray(&d->camera, x, y, d->width, d->height);
    /* The reference sees the exact surface: its camera rays carry no
     * footprint, so surfaces with levels of detail (ISO, hybrid) trace
     * them to full depth. With the pixel's footprint its primary hits were
     * the coarse patches the viewer takes, and a bake's lookup frame then
     * agreed with its "reference" on the very approximation it should be
     * measured against. */
    ray.spread = 0.0f;
    sg_vec3 L = {0, 0, 0}, beta = {1, 1, 1};
    float prev_pdf_b = 0.0f; /* pdf of the BSDF sample that made `ray` */
    for (int depth = 0;; ++depth) {
        sg_world_hit h;
        if (!sg_world_intersect(w, &ray, &h, st)) {
            sg_vec3 Le = sg_envmap_eval(env, ray.dir);
            float wgt = depth == 0 ? 1.0f : power_heuristic(prev_pdf_b, sg_envmap_pdf(env, ray.dir));
            L = sg_v3_add(L, sg_v3_scale(sg_v3_mul(beta, Le), wgt));
            break;
        }
        c.surface_hits++;
        if ((depth == 0 || (ray.flags & SG_RAY_FRONT_ONLY)) && sg_v3_dot(ray.dir, h.hit.n) > 0.0f) {
            c.back_hits++;
            c.camera_back_hits += depth == 0;
        }
        const sg_material *m = sg_world_material(w, h.model);
        sg_vec3 albedo = sg_world_albedo(w, &h);
        sg_vec3 wo = sg_v3_scale(ray.dir, -1.0f);
        /* Two-sided shading: the side the ray arrives from. */
        sg_vec3 n = sg_v3_dot(h.hit.n, wo) < 0.0f ? sg_v3_scale(h.hit.n, -1.0f) : h.hit.n;
        /* Emitters are found by BSDF sampling only: weight 1. */
        L = sg_v3_add(L, sg_v3_mul(beta, m->emission));
        if (depth >= d->max_depth)
            break;
        uint32_t b = (uint32_t)depth + 1;

        /* Next-event estimation towards the envmap. */
        float pdf_l;
        sg_vec3 wl = sg_envmap_sample(env, sg_rng_float(d->seed, path, b, 0), sg_rng_float(d->seed, path, b, 1), &pdf_l);
        float cos_l = sg_v3_dot(wl, n);
        if (pdf_l > 0.0f && cos_l > 0.0f) {
            sg_vec3 f = sg_bsdf_eval(m, albedo, n, wo, wl);
            if (max3(f) > 0.0f) {
                sg_ray shadow = sg_world_spawn_ray(w, &h, wl, INFINITY);
                if (!sg_world_occluded(w, &shadow, st)) {
                    float wgt = power_heuristic(pdf_l, sg_bsdf_pdf(m, n, wo, wl));
                    sg_vec3 Le = sg_envmap_eval(env, wl);
                    L = sg_v3_add(L, sg_v3_scale(sg_v3_mul(sg_v3_mul(beta, f), Le), cos_l * wgt / pdf_l));
                }
            }
        }

        /* Continue by BSDF sampling. */
        sg_vec3 wi, weight;
        float pdf_b;
        if (!sg_bsdf_sample(m, albedo, n, wo, sg_rng_float(d->seed, path, b, 2), sg_rng_float(d->seed, path, b, 3),
                            sg_rng_float(d->seed, path, b, 4), &wi, &pdf_b, &weight))
            break;
        beta = sg_v3_mul(beta, weight);
        prev_pdf_b = pdf_b;
        /* Russian roulette only on a path whose throughput fell below 1,
         * surviving with probability q = its largest channel: the survivor
         * carries beta / q, at most 1 in every channel (invariant 1). A
         * floor such as min(0.95, max beta) would divide by 0.95 at every
         * bounce of a bright path, letting throughput grow without bound:
         * a heavy tail of rare huge paths that the per-pixel sample
         * variance does not see, so the standard errors understate the
         * error (tested: z-scores of two references). */
        float q = max3(beta);
        if (depth + 1 >= d->rr_depth && q < 1.0f) {
            if (!(q > 0.0f) || sg_rng_float(d->seed, path, b, 5) >= q)
                break;
            beta = sg_v3_scale(beta, 1.0f / q);
        }
        assert(sg_v3_isfinite(beta) && beta.x >= 0.0f && beta.y >= 0.0f && beta.z >= 0.0f); /* invariant 1 */
        ray = sg_world_spawn_ray(w, &h, wi, INFINITY);
    }
    if (counts) {
        c.back_paths = c.back_hits > 0;
        sg_ref_counts_add(counts, &c);
    }
    return L;
}

sg_status sg_ref_render(const sg_world *w, const sg_ref_desc *desc, sg_ref_result *out, sg_error *err)
{
    if (!w || !desc || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "reference: NULL argument");
    sg_ref_desc d = with_defaults(desc);
    if (d.width > 16384 || d.height > 16384)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "reference: image %dx%d is too large", d.width, d.height);
    if ((uint64_t)d.first_sample + (uint64_t)d.spp > SG_REF_MAX_SPP)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "reference: samples %u + %d exceed %u per pixel",
                            d.first_sample, d.spp, SG_REF_MAX_SPP);
    sg_ref_result r = {0};
    sg_status st = sg_image_alloc(&r.mean, d.width, d.height, err);
    if (st == SG_OK)
        st = sg_image_alloc(&r.std_error, d.width, d.height, err);
    if (st != SG_OK) {
        sg_ref_result_free(&r);
        return st;
    }
    int tiles_x = (d.width + TILE - 1) / TILE, tiles_y = (d.height + TILE - 1) / TILE, tiles = tiles_x * tiles_y;
    sg_ray_stats *tile_stats = sg_calloc_array((size_t)tiles, sizeof *tile_stats);
    sg_ref_counts *tile_counts = sg_calloc_array((size_t)tiles, sizeof *tile_counts);
    if (!tile_stats || !tile_counts) {
        sg_free(tile_stats);
        sg_free(tile_counts);
        sg_ref_result_free(&r);
        return sg_error_set(err, SG_ERR_NOMEM, "reference: out of memory");
    }
    double t0 = omp_get_wtime();
    int threads = d.threads > 0 ? d.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (int t = 0; t < tiles; ++t) {
        int x0 = (t % tiles_x) * TILE, y0 = (t / tiles_x) * TILE;
        for (int y = y0; y < y0 + TILE && y < d.height; ++y)
            for (int x = x0; x < x0 + TILE && x < d.width; ++x) {
                uint64_t pixel = (uint64_t)y * (uint64_t)d.width + (uint64_t)x;
                double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
                for (int s = 0; s < d.spp; ++s) {
                    uint64_t path = pixel * SG_REF_MAX_SPP + d.first_sample + (uint64_t)s;
                    float jx = d.pixel_centres ? 0.5f : sg_rng_float(d.seed, path, 0, 0),
                          jy = d.pixel_centres ? 0.5f : sg_rng_float(d.seed, path, 0, 1);
                    sg_vec3 L = sg_ref_path_counted(w, &d, (float)x + jx, (float)y + jy, path, &tile_stats[t],
                                                    &tile_counts[t]);
                    double v[3] = {L.x, L.y, L.z};
                    for (int c = 0; c < 3; ++c) {
                        sum[c] += v[c];
                        sum2[c] += v[c] * v[c];
                    }
                }
                float *m = r.mean.data + 3 * pixel, *e = r.std_error.data + 3 * pixel;
                double n = (double)d.spp;
                for (int c = 0; c < 3; ++c) {
                    double mean = sum[c] / n;
                    double var = n > 1 ? fmax(0.0, (sum2[c] - n * mean * mean) / (n - 1.0)) : 0.0;
                    m[c] = (float)mean;
                    e[c] = (float)sqrt(var / n);
                }
            }
    }
    r.seconds = omp_get_wtime() - t0;
    for (int t = 0; t < tiles; ++t) {
        sg_ray_stats_add(&r.rays, &tile_stats[t]);
        sg_ref_counts_add(&r.counts, &tile_counts[t]);
    }
    sg_free(tile_stats);
    sg_free(tile_counts);
    size_t npix = (size_t)d.width * (size_t)d.height;
    for (size_t i = 0; i < npix; ++i)
        for (int c = 0; c < 3; ++c)
            r.mean_radiance[c] += r.mean.data[3 * i + c];
    for (int c = 0; c < 3; ++c)
        r.mean_radiance[c] /= (double)npix;
    r.paths = (uint64_t)npix * (uint64_t)d.spp;
    *out = r;
    return SG_OK;
}

void sg_ref_result_free(sg_ref_result *r)
{
    if (!r)
        return;
    sg_image_free(&r->mean);
    sg_image_free(&r->std_error);
    memset(r, 0, sizeof *r);
}

sg_status sg_ref_result_merge(sg_ref_result *a, int na, const sg_ref_result *b, int nb, sg_error *err)
{
    if (!a || !b || na < 1 || nb < 1)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "reference merge: bad arguments");
    if (a->mean.width != b->mean.width || a->mean.height != b->mean.height)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "reference merge: %dx%d and %dx%d images", a->mean.width,
                            a->mean.height, b->mean.width, b->mean.height);
    size_t n = (size_t)3 * (size_t)a->mean.width * (size_t)a->mean.height;
    double n1 = na, n2 = nb, nt = n1 + n2;
    for (size_t i = 0; i < n; ++i) {
        /* sum = n m; sum of squares = (n - 1) s^2 + n m^2, s^2 = n se^2. */
        double m1 = a->mean.data[i], m2 = b->mean.data[i];
        double se1 = a->std_error.data[i], se2 = b->std_error.data[i];
        double q1 = (n1 - 1.0) * n1 * se1 * se1 + n1 * m1 * m1;
        double q2 = (n2 - 1.0) * n2 * se2 * se2 + n2 * m2 * m2;
        double mean = (n1 * m1 + n2 * m2) / nt;
        double var = fmax(0.0, (q1 + q2 - nt * mean * mean) / (nt - 1.0));
        a->mean.data[i] = (float)mean;
        a->std_error.data[i] = (float)sqrt(var / nt);
    }
    for (int c = 0; c < 3; ++c)
        a->mean_radiance[c] = (n1 * a->mean_radiance[c] + n2 * b->mean_radiance[c]) / nt;
    a->seconds += b->seconds;
    a->paths += b->paths;
    sg_ray_stats_add(&a->rays, &b->rays);
    sg_ref_counts_add(&a->counts, &b->counts);
    return SG_OK;
}
