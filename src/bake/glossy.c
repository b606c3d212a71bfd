/* glossy.c — glossy bins: estimation at sample points and lookup (see
 * glossy.h for the estimator and the map).
 *
 * Sources: GGX D and the height-correlated Smith G2 as in material/bsdf.c
 * (Walter et al. 2007; Heitz 2014 eq. 99), the visible-normal pdf
 * G1(wo) D / (4 cos_o) (Heitz 2018); the balance heuristic over a mixture
 * of strategies with fixed sample counts (Veach 1997, §9.2).
 *
 * Invariants:
 *  1. the lobe evaluated here is sg_bsdf_eval's glossy term divided by k,
 *     and its pdf sg_bsdf_pdf's with specular 1 (the same alpha clamp), so
 *     the mixture pdf is the density the rays were drawn from;
 *  2. every stored bin is finite and >= 0 (a non-finite ray contribution
 *     is skipped);
 *  3. a sample's bins depend only on its splat index, the world, the bake
 *     and the parameters (counter-based random numbers), not on threads.
 */
#include "bake/glossy.h"

#include <math.h>
#include <omp.h>
#include <string.h>

#include "bake/bake.h"
#include "core/alloc.h"
#include "math/rng.h"
#include "render/world.h"
#include "sample/warp.h"

static const float INV_PI_F = 0.318309886183791f;

int sg_glossy_material(const sg_material *m) { return m->type == SG_MATERIAL_GGX && m->specular > 0.0f; }

static float lobe_alpha(const sg_material *m)
{
    float a = m->roughness * m->roughness;
    return a > SG_BSDF_MIN_ALPHA ? a : SG_BSDF_MIN_ALPHA;
}

int sg_glossy_default_res(const sg_material *m)
{
    if (!sg_glossy_material(m))
        return 0;
    float r = ceilf(2.4f / lobe_alpha(m));
    return r < (float)SG_GLOSSY_MIN_RES ? SG_GLOSSY_MIN_RES : (r > (float)SG_GLOSSY_MAX_RES ? SG_GLOSSY_MAX_RES : (int)r);
}

void sg_glossy_encode(sg_vec3 v, float *u, float *w)
{
    float z = v.z > 0.0f ? v.z : 0.0f;
    float s = fabsf(v.x) + fabsf(v.y) + z;
    float px = s > 0.0f ? v.x / s : 0.0f, py = s > 0.0f ? v.y / s : 0.0f;
    *u = px + py;
    *w = px - py;
}

sg_vec3 sg_glossy_decode(float u, float w)
{
    float px = 0.5f * (u + w), py = 0.5f * (u - w);
    float z = 1.0f - fabsf(px) - fabsf(py);
    return sg_v3_normalize(sg_v3(px, py, z > 0.0f ? z : 0.0f));
}

uint16_t sg_half_from_float(float f)
{
    if (!(f > 0.0f))
        return 0; /* zero, negative and NaN: S is >= 0 (invariant 2) */
    if (f >= 65504.0f)
        return 0x7bff;
    uint32_t x;
    memcpy(&x, &f, sizeof x);
    if (x < 0x38800000u) /* below 2^-14: a subnormal half, in units of 2^-24 */
        return (uint16_t)lrintf(f * 16777216.0f);
    uint32_t h = (x >> 13) - ((uint32_t)(127 - 15) << 10), rest = x & 0x1fffu;
    if (rest > 0x1000u || (rest == 0x1000u && (h & 1u)))
        ++h; /* may carry into the exponent: still correct, <= 0x7bff here */
    return (uint16_t)(h > 0x7bffu ? 0x7bffu : h);
}

float sg_half_to_float(uint16_t h)
{
    uint32_t s = (uint32_t)(h & 0x8000u) << 16, e = (h >> 10) & 0x1fu, m = h & 0x3ffu, x;
    if (e == 0) {
        float v = ldexpf((float)m, -24);
        return s ? -v : v;
    }
    if (e == 31)
        x = s | 0x7f800000u | (m << 13);
    else
        x = s | ((e + 112u) << 23) | (m << 13);
    float f;
    memcpy(&f, &x, sizeof f);
    return f;
}

static float smith_s(float a2, float c)
{
    float s2 = 1.0f - c * c;
    return sqrtf(c * c + a2 * (s2 > 0.0f ? s2 : 0.0f));
}

/* Per-bin constants of the lobe (local frame). */
typedef struct bin_geom {
    sg_vec3 wo;   /* bin centre direction, local            */
    float s_o;    /* smith_s(a2, wo.z)                       */
    float pdf_k;  /* G1(wo) / (4 wo.z): pdf = pdf_k D        */
} bin_geom;

sg_status sg_glossy_bake(const sg_world *w, const sg_bake *b, uint32_t m, const uint32_t *splats, size_t n,
                         uint64_t key_base, int res, int rays, uint64_t seed, int threads, uint16_t *bins,
                         sg_error *err)
{
    if (res < SG_GLOSSY_MIN_RES || res > SG_GLOSSY_MAX_RES || rays < 1)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "glossy bins: resolution %d (%d..%d), %d rays", res,
                            SG_GLOSSY_MIN_RES, SG_GLOSSY_MAX_RES, rays);
    const sg_material *mat = sg_world_material(w, m);
    sg_material lobe = *mat;
    lobe.type = SG_MATERIAL_GGX;
    lobe.specular = 1.0f;
    lobe.albedo = sg_v3(0.0f, 0.0f, 0.0f);
    float alpha = lobe_alpha(mat), a2 = alpha * alpha;
    int nb = res * res;
    bin_geom *g = sg_alloc_array((size_t)nb, sizeof *g);
    if (!g)
        return sg_error_set(err, SG_ERR_NOMEM, "glossy bins: out of memory");
    for (int j = 0; j < res; ++j)
        for (int i = 0; i < res; ++i) {
            bin_geom *q = &g[j * res + i];
            q->wo = sg_glossy_decode(-1.0f + (2.0f * (float)i + 1.0f) / (float)res,
                                     -1.0f + (2.0f * (float)j + 1.0f) / (float)res);
            float co = q->wo.z;
            q->s_o = smith_s(a2, co);
            q->pdf_k = (2.0f * co / (co + q->s_o)) / (4.0f * co);
        }
    /* Fixed shares of the strategies: the balance heuristic's c_x. */
    int n_env = rays / 3, n_cos = rays / 3, n_ggx = rays - n_env - n_cos;
    float c_env = (float)n_env / (float)rays, c_cos = (float)n_cos / (float)rays,
          c_ggx = (float)n_ggx / (float)rays / (float)nb;
    const sg_envmap *env = sg_world_envmap(w);
    const sg_sites *ps = sg_scene_sites(sg_world_scene(w, m));
    int nt = threads > 0 ? threads : omp_get_max_threads();
    size_t stride = 3 * (size_t)nb;
    int oom = 0; /* a thread could not get its scratch */
#pragma omp parallel num_threads(nt)
    {
        double *acc = sg_alloc_array(stride, sizeof *acc);
        float *fb = sg_alloc_array((size_t)nb, sizeof *fb);
        if (!acc || !fb) {
#pragma omp atomic write
            oom = 1;
        }
#pragma omp for schedule(dynamic, 16)
        for (size_t s = 0; s < n; ++s) {
            if (!acc || !fb)
                continue; /* reported after the loop */
            uint32_t i = splats[s];
            sg_vec3 nrm = sg_sites_normal(ps, i), t, bt;
            sg_v3_basis(nrm, &t, &bt);
            sg_world_hit h = {.hit = sg_scene_site_hit(sg_world_scene(w, m), i), .model = m};
            uint64_t key = key_base + i;
            memset(acc, 0, stride * sizeof *acc);
            for (int r = 0; r < rays; ++r) {
                float u0 = sg_rng_float(seed, key, 1, 3u * (uint32_t)r),
                      u1 = sg_rng_float(seed, key, 1, 3u * (uint32_t)r + 1),
                      u2 = sg_rng_float(seed, key, 1, 3u * (uint32_t)r + 2);
                sg_vec3 wi;
                if (r < n_env) {
                    float pdf;
                    wi = sg_envmap_sample(env, u1, u2, &pdf);
                    if (!(pdf > 0.0f))
                        continue;
                } else if (r < n_env + n_cos) {
                    sg_vec3 l = sg_warp_cosine_hemisphere_sample(u1, u2);
                    wi = sg_v3_normalize(sg_v3_add(sg_v3_add(sg_v3_scale(t, l.x), sg_v3_scale(bt, l.y)),
                                                   sg_v3_scale(nrm, l.z)));
                } else {
                    int bi = (int)(u0 * (float)nb);
                    if (bi >= nb)
                        bi = nb - 1;
                    sg_vec3 wl = g[bi].wo;
                    sg_vec3 wo = sg_v3_add(sg_v3_add(sg_v3_scale(t, wl.x), sg_v3_scale(bt, wl.y)),
                                           sg_v3_scale(nrm, wl.z));
                    float pdf;
                    sg_vec3 wgt;
                    if (!sg_bsdf_sample(&lobe, lobe.albedo, nrm, sg_v3_normalize(wo), 0.0f, u1, u2, &wi, &pdf,
                                        &wgt))
                        continue;
                }
                sg_vec3 wl = sg_v3(sg_v3_dot(t, wi), sg_v3_dot(bt, wi), sg_v3_dot(nrm, wi));
                float ci = wl.z;
                if (!(ci > 0.0f))
                    continue;
                /* Incident radiance: the envmap, or the diffuse bake where
                 * the ray hits a surface (final gather). */
                sg_vec3 L;
                sg_ray ray = sg_world_spawn_ray(w, &h, wi, INFINITY);
                sg_world_hit hh;
                if (sg_world_intersect(w, &ray, &hh, NULL)) {
                    const sg_material *hm = sg_world_material(w, hh.model);
                    /* the diffuse share of the surface hit: (1 - k) rho / pi E */
                    float kd = sg_glossy_material(hm) ? 1.0f - (hm->specular < 1.0f ? hm->specular : 1.0f) : 1.0f;
                    sg_vec3 E = sg_bake_irradiance(b, w, &hh, sg_v3_scale(wi, -1.0f));
                    L = sg_v3_add(hm->emission, sg_v3_scale(sg_v3_mul(sg_world_albedo(w, &hh), E), kd * INV_PI_F));
                } else {
                    L = sg_envmap_eval(env, wi);
                }
                if (!(L.x > 0.0f || L.y > 0.0f || L.z > 0.0f))
                    continue;
                float s_i = smith_s(a2, ci), pdf_sum = 0.0f;
                for (int k = 0; k < nb; ++k) {
                    sg_vec3 hv = sg_v3_add(g[k].wo, wl);
                    float hxy = hv.x * hv.x + hv.y * hv.y, hl2 = hxy + hv.z * hv.z;
                    float tt = hxy + a2 * hv.z * hv.z;
                    float D = a2 * INV_PI_F * hl2 * hl2 / (tt * tt);
                    fb[k] = D * 0.5f / (g[k].wo.z * s_i + ci * g[k].s_o);
                    pdf_sum += g[k].pdf_k * D;
                }
                float p_mix = c_env * sg_envmap_pdf(env, wi) + c_cos * ci * INV_PI_F + c_ggx * pdf_sum;
                if (!(p_mix > 0.0f))
                    continue;
                float k0 = ci / p_mix;
                if (!isfinite(k0))
                    continue;
                for (int k = 0; k < nb; ++k) {
                    float v = fb[k] * k0;
                    acc[3 * k] += (double)(L.x * v);
                    acc[3 * k + 1] += (double)(L.y * v);
                    acc[3 * k + 2] += (double)(L.z * v);
                }
            }
            uint16_t *out = bins + s * stride;
            for (size_t k = 0; k < stride; ++k) {
                double v = acc[k] / rays;
                out[k] = sg_half_from_float(isfinite(v) ? (float)v : 0.0f);
            }
        }
        sg_free(acc);
        sg_free(fb);
    }
    sg_free(g);
    if (oom)
        return sg_error_set(err, SG_ERR_NOMEM, "glossy bins: out of memory for %d bins of scratch", nb);
    return SG_OK;
}

sg_vec3 sg_glossy_eval(const uint16_t *bins, int res, sg_vec3 n_s, sg_vec3 n_h, sg_vec3 wo)
{
    float cos_h = sg_v3_dot(wo, n_h);
    if (!(cos_h > 0.0f))
        return sg_v3(0.0f, 0.0f, 0.0f);
    sg_vec3 r = sg_v3_sub(sg_v3_scale(n_h, 2.0f * cos_h), wo);
    sg_vec3 wp = sg_v3_sub(sg_v3_scale(n_s, 2.0f * sg_v3_dot(r, n_s)), r);
    sg_vec3 t, b;
    sg_v3_basis(n_s, &t, &b);
    float u, w;
    sg_glossy_encode(sg_v3(sg_v3_dot(t, wp), sg_v3_dot(b, wp), sg_v3_dot(n_s, wp)), &u, &w);
    float fu = (u + 1.0f) * 0.5f * (float)res - 0.5f, fw = (w + 1.0f) * 0.5f * (float)res - 0.5f;
    float hi = (float)(res - 1);
    fu = fu < 0.0f ? 0.0f : (fu > hi ? hi : fu);
    fw = fw < 0.0f ? 0.0f : (fw > hi ? hi : fw);
    int i0 = (int)fu, j0 = (int)fw;
    int i1 = i0 + 1 < res ? i0 + 1 : i0, j1 = j0 + 1 < res ? j0 + 1 : j0;
    float tu = fu - (float)i0, tw = fw - (float)j0;
    const int id[4] = {j0 * res + i0, j0 * res + i1, j1 * res + i0, j1 * res + i1};
    const float wt[4] = {(1 - tu) * (1 - tw), tu * (1 - tw), (1 - tu) * tw, tu * tw};
    float c[3] = {0, 0, 0};
    for (int k = 0; k < 4; ++k)
        for (int ch = 0; ch < 3; ++ch)
            c[ch] += wt[k] * sg_half_to_float(bins[3 * (size_t)id[k] + (size_t)ch]);
    return sg_v3(c[0], c[1], c[2]);
}
