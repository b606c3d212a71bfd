/* transport.h — light at the bake's sample sites: one set of rays per site
 * gives both the direct light and the surfaces that send it indirect light,
 * and one sparse linear solve gives every bounce of the indirect light.
 *
 * A SITE is one side of a sample point (bake/samples.h): side 0 faces along
 * the splat's normal n (front), side 1 along -n (back). Light is kept per
 * side, so the inside of a closed model, a wall's far side or a room's
 * interior sees only the light that reaches that side.
 *
 * Rays of a site (x its splat's centre, m the side's normal): env_rays
 * directions drawn by the envmap's importance sampling and cos_rays
 * cosine-weighted over m's hemisphere, combined by the power heuristic
 * (Veach 1997) for those counts: ray j of strategy a carries the estimator
 * weight k_j = cos_j w_a(wi_j) / (n_a p_a(wi_j)), with
 * w_a = (n_a p_a)^2 / sum_b (n_b p_b)^2, so that for any incident radiance
 * L_in, sum_j k_j L_in(wi_j) is an unbiased estimate of the irradiance
 * E = int L_in cos dw. The 2D samples are a rank-1 (R2) lattice with a
 * random shift per site and strategy: stratified over the hemisphere and
 * over the map's importance, unbiased by the shift. A ray either escapes,
 * and the envmap L_env(wi) lights the site directly, or hits a surface y.
 * With the same rays:
 *   E_u = sum_j k_j L_env(wi_j)            unshadowed direct irradiance
 *   E_d = sum_{j escapes} k_j L_env(wi_j)  shadowed direct irradiance
 *   D   = E_d / E_u   (RGB)                the visibility ratio, 1 exactly
 *                                          where nothing blocks the light
 *   hits (y_j, side_j, k_j)                 the surfaces reached
 * The site's direct light elsewhere is D times the unshadowed irradiance at
 * the normal there (envmap/irradiance_table.h): shadows move, cosines are
 * exact (docs/bake.md).
 *
 * The indirect irradiance I of every site then solves one linear system.
 * A ray that hits y on side s_y sees y's outgoing radiance
 *     L_o(y) = emission(y) + R(y) (E0(y, s_y) D_t + I_t),   t = t(y, s_y)
 * where t(y, s) is the site of y's nearest same-facing sample point on side
 * s, R the diffuse reflectance (albedo / pi; a glossy material reflects
 * here as diffuse light with the lobe's hemispherical albedo: glossy-to-
 * glossy paths are not resolved) and E0(y, s) the unshadowed irradiance at
 * y's normal on side s. Hence
 *     I = C + T I,  C_x = sum_h k_h (emission_h + R_h E0_h D_t(h)),
 *                   T_xt = sum_{h of x with t(h) = t} k_h R_h
 * solved by Jacobi iteration from I = C until no value changes by more
 * than a relative 1e-5 of the largest: every bounce, no photon density
 * estimate, hence no kernel bias at folds and creases, and the estimate
 * converges as rays and sample points grow (the error left is the
 * interpolation between sample points and the nearest-site read at y).
 *
 * Level of detail (issues 13, 15): with desc.ray_cone > 0 each ray carries
 * a cone (sg_ray.spread), the width of the solid angle it stands for among
 * the site's rays times ray_cone, so the surfaces with levels of detail
 * (ISO, hybrid) stop at coarse nodes far from the site. A ray towards a
 * bright spot of the map (the sun), drawn densely by the envmap strategy,
 * stands for a tiny solid angle and stays sharp. The estimator is the
 * same; only what the rays hit changes (docs/hybrid.md measures it).
 *
 * Determinism: random numbers are sg_rng_float(seed, key, stream, dim) with
 * key = the global index of the sample's splat (splats of models before m,
 * plus its index), so a site's rays do not depend on which other sites are
 * computed or on threads; hits are stored in site order; the solve runs
 * row by row in a fixed order. Same inputs, same bits, any thread count.
 *
 * Ownership: sg_site_data is the caller's (zero it, then grow it with
 * sg_transport_gather; free with sg_site_data_free).
 */
#ifndef SG_BAKE_TRANSPORT_H
#define SG_BAKE_TRANSPORT_H

#include <stddef.h>
#include <stdint.h>

#include "bake/samples.h"
#include "core/error.h"
#include "render/world.h"

enum { SG_SIDES = 2 };

typedef struct sg_transport_desc {
    int env_rays;     /* envmap importance samples per site; default 32   */
    int cos_rays;     /* cosine samples per site; default 64              */
    uint64_t seed;    /* default 1                                       */
    int threads;      /* 0 = OpenMP default                              */
    float ray_cone;   /* level of detail of the sites' rays: each ray's
                         cone (sg_ray.spread) is ray_cone times the width
                         of its share of the solid angle
                         (sg_transport_ray_spread); <= 0 or not finite:
                         thin rays at full detail, the bits of a bake
                         without it                                      */
    /* Optional, called between blocks of sites on the calling thread:
     * done of total sites so far; nonzero cancels (SG_ERR_CANCELLED, the
     * sites already done are kept). */
    int (*progress)(void *user, size_t done, size_t total);
    void *progress_user;
} sg_transport_desc;

/* Per model: what the rays of its sites found. Site (sample j, side s) is
 * site 2 j + s. Sites grow with the sample set (refinement appends). */
typedef struct sg_site_data {
    size_t count;        /* sample points gathered (sites = 2 count)       */
    size_t capacity;
    float *ratio;        /* 3 per site: D, the visibility ratio (RGB)      */
    float *unshadowed;   /* 3 per site: E_u, the unshadowed estimate       */
    float *sigma;        /* per site: standard error of D's luminance       */
    float *dist;         /* per site: harmonic mean distance of all rays,
                            escaped ones at infinity (Ward 1988's R_h);
                            INFINITY when nothing was hit                 */
    size_t *first;       /* 2 count + 1: hits of site i are
                            [first[i], first[i+1])                         */
    size_t hits, hit_capacity;
    uint32_t *hit_splat; /* splat reached                                  */
    uint32_t *hit_model; /* its model << 1 | the side reached              */
    float *hit_k;        /* estimator weight k [sr]                        */
} sg_site_data;

void sg_site_data_free(sg_site_data *sd);

/* d with every zero field replaced by its default. */
sg_transport_desc sg_transport_desc_resolve(const sg_transport_desc *d);

/* The spread (sg_ray.spread) a site's ray of d (resolved) gets: the
 * envmap strategy's density pe and the cosine strategy's pc at its
 * direction (per steradian). d->ray_cone times sqrt of the solid angle
 * the ray stands for among the site's rays, 1 / (env_rays pe + cos_rays
 * pc), at most 2 pi / (env_rays + cos_rays) (derivation: transport.c);
 * 0 when d->ray_cone is not > 0. Pure. */
float sg_transport_ray_spread(const sg_transport_desc *d, float pe, float pc);

/* Traces the rays of the sites of samples [sd->count, set->count) of model
 * m and appends their results to sd. key_base: splats of the models before
 * m. On SG_ERR_CANCELLED sd holds a prefix of the samples (sd->count says
 * how many), valid to continue from. */
sg_status sg_transport_gather(const sg_world *w, uint32_t m, const sg_sample_set *set, uint64_t key_base,
                              const sg_transport_desc *d, sg_site_data *sd, sg_error *err);

/* Marks the sites of model m that name no surface they can light from
 * outside (out[i] = 1, else 0): those whose way down to their surface
 * (one reach above them, along -n, either face) meets an exit first or
 * no crossing facing their way within a reach. Their rays would leave from
 * inside the model or off its surface (an octree's corners under a floor
 * at a wall's foot, in the pocket where a floor's smooth surface runs on
 * under a wall) and pass walls from behind, so they must not be sample
 * points (sites.h unsampled). Sites the scene already marks unsampled
 * (the ISO's node sites) are marked without a look and not counted.
 * Returns how many it found; deterministic, any thread count. */
size_t sg_transport_off_surface_sites(const sg_world *w, uint32_t m, int threads, uint8_t *out);

/* For the distributed bake (bake/bake_comm.h): the sites of all of sd's
 * samples as bytes, in this build's native layout (u64 samples, u64 hits,
 * then ratio, unshadowed, sigma, dist, the hits per site as u64, and the
 * hits' splat, model and k arrays); *buf is allocated here (sg_free). */
sg_status sg_site_data_pack(const sg_site_data *sd, void **buf, size_t *bytes, sg_error *err);

/* Appends the samples packed at buf (at most `bytes` bytes: pieces may
 * follow) to sd, as if sg_transport_gather had traced them next; *used
 * gets the piece's length. SG_ERR_CORRUPT for a piece that does not fit
 * its own counts; sd unchanged then. */
sg_status sg_site_data_append_packed(sg_site_data *sd, const void *buf, size_t bytes, size_t *used, sg_error *err);

/* The per-model inputs of the solve. */
typedef struct sg_transport_model {
    const sg_site_data *sites;   /* gathered, sites->count samples         */
    const uint32_t *nearest;     /* per splat: the sample t of its nearest
                                    same-facing sample point (< sites->count) */
    const float *e0;             /* per splat, 6 floats: the unshadowed
                                    irradiance at its normal, front then
                                    back (RGB each)                        */
} sg_transport_model;

typedef struct sg_transport_stats {
    size_t sites, entries;   /* rows and nonzero entries of T             */
    int iterations;          /* Jacobi sweeps until converged             */
    double residual;         /* last sweep's largest change / largest I   */
} sg_transport_stats;

/* Solves I = C + T I over the sites of all models (above). indirect[m]
 * gets 3 floats per site of model m (its sites->count samples x 2 sides),
 * RGB irradiance, finite and >= 0. max_iterations <= 0: 10000. */
sg_status sg_transport_solve(const sg_world *w, const sg_transport_model *models, int max_iterations, int threads,
                             float **indirect, sg_transport_stats *stats, sg_error *err);

/* The diffuse reflectance R = (outgoing radiance) / (irradiance) of a
 * material with albedo rho for the transport (above): rho / pi for Lambert,
 * ((1 - k) rho + k A) / pi for GGX, A the lobe's hemispherical albedo. */
sg_vec3 sg_transport_reflectance(const sg_material *m, sg_vec3 rho);

#endif
