/* direct.c — direct irradiance at the splats (see direct.h).
 *
 * Invariant: every value is finite and >= 0 (NaN-producing samples,
 * e.g. a zero pdf, are skipped, never added).
 */
#include "bake/direct.h"

#include <math.h>
#include <omp.h>

#include "math/rng.h"
#include "sample/warp.h"

static float power2(float a, float b)
{
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* Local frame around n -> world. */
static sg_vec3 to_world(sg_vec3 n, sg_vec3 v)
{
    sg_vec3 t, b;
    sg_v3_basis(n, &t, &b);
    return sg_v3_add(sg_v3_add(sg_v3_scale(t, v.x), sg_v3_scale(b, v.y)), sg_v3_scale(n, v.z));
}

sg_status sg_direct_irradiance_at(const sg_world *w, uint32_t m, const uint32_t *splats, size_t n,
                                  uint64_t key_base, int samples, uint64_t seed, int threads, float *out,
                                  float *unshadowed, float *sigma, sg_error *err)
{
    if (samples < 1)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "direct light: %d samples per splat", samples);
    const sg_envmap *env = sg_world_envmap(w);
    const float inv_pi = 0.318309886183791f;
    int nt = threads > 0 ? threads : omp_get_max_threads();
    const sg_pointset *ps = sg_scene_points(sg_world_scene(w, m));
    if (!splats)
        n = ps->count;
#pragma omp parallel for schedule(dynamic, 64) num_threads(nt)
    for (size_t j = 0; j < n; ++j) {
        size_t i = splats ? splats[j] : j;
        sg_vec3 n_i = sg_pointset_normal(ps, i);
        sg_world_hit h = {.hit = {.t = 0.0f, .p = sg_pointset_position(ps, i), .n = n_i, .splat = (uint32_t)i,
                                  .leaf = UINT32_MAX},
                          .model = m};
        uint64_t key = key_base + i;
        double e[3] = {0, 0, 0}, y2 = 0.0; /* y2: sum of squared per-sample luminances */
        double a[3] = {0, 0, 0};            /* the same samples, visibility ignored    */
        double ya2 = 0.0, yya = 0.0;        /* sums of y_a^2 and y y_a per sample       */
        for (int s = 0; s < samples; ++s) {
            double before = 0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2];
            double before_a = 0.2126 * a[0] + 0.7152 * a[1] + 0.0722 * a[2];
            uint32_t d0 = (uint32_t)(4 * s);
            /* Envmap sampling. */
            float pl;
            sg_vec3 wl = sg_envmap_sample(env, sg_rng_float(seed, key, 0, d0), sg_rng_float(seed, key, 0, d0 + 1), &pl);
            float cl = sg_v3_dot(wl, n_i);
            if (pl > 0.0f && cl > 0.0f) {
                sg_vec3 L = sg_envmap_eval(env, wl);
                float k = cl * power2(pl, cl * inv_pi) / pl;
                a[0] += L.x * k; a[1] += L.y * k; a[2] += L.z * k;
                sg_ray r = sg_world_spawn_ray(w, &h, wl, INFINITY);
                if (!sg_world_occluded(w, &r, NULL)) {
                    e[0] += L.x * k; e[1] += L.y * k; e[2] += L.z * k;
                }
            }
            /* Cosine sampling. */
            sg_vec3 loc = sg_warp_cosine_hemisphere_sample(sg_rng_float(seed, key, 0, d0 + 2),
                                                           sg_rng_float(seed, key, 0, d0 + 3));
            float pc = sg_warp_cosine_hemisphere_pdf(loc);
            if (pc > 0.0f) {
                sg_vec3 wc = sg_v3_normalize(to_world(n_i, loc));
                sg_vec3 L = sg_envmap_eval(env, wc);
                /* cos / pc = pi exactly; kept in the general form. */
                float k = loc.z * power2(pc, sg_envmap_pdf(env, wc)) / pc;
                a[0] += L.x * k; a[1] += L.y * k; a[2] += L.z * k;
                sg_ray r = sg_world_spawn_ray(w, &h, wc, INFINITY);
                if (!sg_world_occluded(w, &r, NULL)) {
                    e[0] += L.x * k; e[1] += L.y * k; e[2] += L.z * k;
                }
            }
            double y = 0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2] - before;
            double ya = 0.2126 * a[0] + 0.7152 * a[1] + 0.0722 * a[2] - before_a;
            y2 += y * y;
            ya2 += ya * ya;
            yya += y * ya;
        }
        if (sigma && unshadowed) {
            /* Ratio r = sum y / sum y_a of two means over the same samples:
             * by the delta method Var(r) ~ Var(y - r y_a) / (S mean(y_a)^2),
             * with sum (y - r y_a)^2 = y2 - 2 r yya + r^2 ya2. */
            double sy = 0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2];
            double sa = 0.2126 * a[0] + 0.7152 * a[1] + 0.0722 * a[2];
            double se = 0.0;
            if (sa > 0.0 && samples > 1) {
                double r = sy / sa, ma = sa / samples;
                double ss = y2 - 2.0 * r * yya + r * r * ya2;
                double var = ss > 0.0 ? ss / (samples - 1) : 0.0;
                se = sqrt(var / samples) / ma;
            }
            sigma[j] = isfinite(se) ? (float)se : 0.0f;
        } else if (sigma) {
            double mean = (0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]) / samples;
            double var = samples > 1 ? (y2 / samples - mean * mean) * samples / (samples - 1) : mean * mean;
            double se = sqrt(var > 0.0 ? var / samples : 0.0);
            sigma[j] = isfinite(se) ? (float)se : 0.0f;
        }
        for (int c = 0; c < 3; ++c) {
            double v = e[c] / samples;
            out[3 * j + c] = isfinite(v) && v > 0.0 ? (float)v : 0.0f;
            if (unshadowed) {
                double u = a[c] / samples;
                unshadowed[3 * j + c] = isfinite(u) && u > 0.0 ? (float)u : 0.0f;
            }
        }
    }
    return SG_OK;
}
