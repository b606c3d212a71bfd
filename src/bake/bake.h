/* bake.h — baked incident light on the splats, and its lookup.
 *
 * What it does: stores the irradiance E arriving at each side of every
 * splat (front: along its normal; back: against it), so a lookup reads the
 * side the viewer sees and closed models, thin walls and rooms do not
 * leak. E = direct + indirect per side:
 *  - SAMPLE SITES (bake/samples.h, bake/transport.h): a subset of the
 *    splats chosen per model by a spacing from the material, both sides of
 *    each, refined where the light changes fast (shadow edges, contact
 *    regions and folds). One set of rays per site estimates the direct
 *    light as a visibility ratio (times the unshadowed irradiance at each
 *    splat's own normal) and records which surfaces send it indirect light;
 *  - INDIRECT light, by default (SG_BAKE_INDIRECT_TRANSPORT), from one
 *    sparse linear solve over the sites' hits (every bounce, no density
 *    estimate); with SG_BAKE_INDIRECT_PHOTONS from the first estimator, a
 *    photon pass (bake/photons.h) gathered at every splat by a kNN density
 *    estimate (bake/irradiance.h), kept for comparison;
 *  - values at sites are interpolated to every splat.
 * Glossy (GGX) models also get directional bins of the lobe-filtered
 * incident radiance S(wo) at their sample points (bake/glossy.h). Looking
 * up a hit interpolates E over the splats around it with the surface's own
 * MLS weights (sg_scene_hit_sites), on the side the ray arrived from, so
 * the baked light is as smooth as the surface, and applies the material:
 *     Lambert:  L_o = emission + rho(x) / pi * E
 *     GGX:      L_o = emission + (1 - k) rho(x) / pi * E + k S(wo),
 * S blended over the sample points the hit's splats map to, with the same
 * weights.
 *
 * States: CREATED by sg_bake_create, by sg_bake_create_from_photons
 * (gathered from a photon map traced in chunks, see photons.h) or LOADED
 * from a file (bake/bake_io.h); all answer lookups for the world they were
 * made for.
 *
 * Ownership: the bake keeps no pointer to the world; lookups take it as an
 * argument and must be given the same world (same scene file) the bake was
 * made for — the bake file's scene hash checks that on load.
 */
#ifndef SG_BAKE_BAKE_H
#define SG_BAKE_BAKE_H

#include <stddef.h>
#include <stdint.h>

#include "bake/irradiance.h"
#include "bake/photons.h"
#include "core/error.h"
#include "envmap/envmap.h"
#include "io/image.h"
#include "render/camera.h"
#include "render/world.h"

typedef struct sg_bake sg_bake; /* opaque */

/* How the indirect light is estimated. */
typedef enum sg_bake_indirect {
    SG_BAKE_INDIRECT_TRANSPORT = 0, /* rays from the sample sites and the
                                       transport solve (transport.h)      */
    SG_BAKE_INDIRECT_PHOTONS = 1    /* photon density estimate at every
                                       splat (photons.h, irradiance.h)     */
} sg_bake_indirect;

typedef struct sg_bake_desc {
    sg_bake_indirect indirect;   /* default SG_BAKE_INDIRECT_TRANSPORT      */
    sg_photon_desc photons;      /* count, seed, depth (photons.h defaults);
                                    the seed keys every random stream, the
                                    rest is used by the photon estimator */
    sg_irradiance_desc gather;   /* k (photons), normal_cos (the same-facing
                                    test of sample points too), threads   */
    int direct_samples;          /* envmap importance samples per sample
                                    site (transport.h); default 32; < 0:
                                    none, the photons carry the direct
                                    light as well (photon estimator only) */
    int gather_rays;             /* cosine-distributed rays per sample site;
                                    default 64 (transport), 32 (photons:
                                    they serve the direct light only)     */
    float sample_spacing;        /* spacing of the sample points, a multiple
                                    of each model's median splat radius;
                                    0: from the material (samples.h: 4
                                    diffuse, 2 + 2 roughness glossy);
                                    < 0: every splat is a sample point      */
    int refine_levels;           /* refinements of the sample points where
                                    the light changes fast; default 2;
                                    < 0: none                              */
    int glossy_res;              /* glossy bins per side, 4..32; 0: from
                                    the roughness (glossy.h, 4..32)          */
    int glossy_rays;             /* rays per glossy sample point; default
                                    128                                      */
    float ray_cone;              /* level of detail of the sample sites'
                                    rays (transport.h): each ray's cone is
                                    this many times the width of its share
                                    of the solid angle; 0: the default,
                                    SG_BAKE_RAY_CONE_DEFAULT; < 0: off, thin
                                    rays at full detail (resolved: -1)    */
} sg_bake_desc;

/* The default of sg_bake_desc.ray_cone (docs/hybrid.md, "Level of detail
 * for the bake's rays", measures 0, 1, 2 and 4); <= 0: off. */
#define SG_BAKE_RAY_CONE_DEFAULT 0.0f
#define SG_BAKE_RAY_CONE_MAX 16.0f /* the largest a file or option may set */

/* Figures of a bake. (Not sg_bake_info: that name is the bake file's
 * header, bake_file.h.) */
typedef struct sg_bake_stats {
    size_t models;
    size_t splats;             /* every splat of every model                 */
    size_t sample_points;      /* all models (sg_bake_sample_count per model) */
    size_t glossy_points;      /* sample points with glossy bins             */
    size_t photons_shot;
    size_t photon_records;
    sg_ray_stats rays;         /* of the photon pass                         */
    double trace_seconds, gather_seconds;  /* 0 for a loaded bake; gather
                                              includes the direct light    */
    double direct_seconds;     /* the sample sites: their selection and
                                  rays, the transport solve and the
                                  interpolation (part of gather_seconds);
                                  0 for a loaded bake                      */
    size_t site_hits;          /* rays of the sites that hit a surface      */
    int transport_iterations;  /* sweeps of the transport solve (0: none)   */
    double glossy_seconds;     /* the glossy bins (part of gather_seconds)   */
    double shared_seconds;     /* the part of trace and gather seconds that a
                                  distributed bake does not divide among
                                  ranks (bake_comm.h: sample thinning,
                                  refinement, solves, interpolation, the
                                  photon density estimate); 0 when loaded  */
    size_t memory_bytes;       /* all kept: the sum of the three below       */
    size_t irradiance_bytes;   /* the light per splat: SG_BAKE_SPLAT_FLOATS
                                  floats                                   */
    size_t sample_bytes;       /* kept per glossy model: the splat of each
                                  sample point and each splat's sample (u32)  */
    size_t glossy_bytes;       /* the bins: 3 R^2 halves per glossy point    */
    size_t photon_memory_bytes;/* the photon records while baking (freed)    */
} sg_bake_stats;

/* Bakes: the photon pass first with SG_BAKE_INDIRECT_PHOTONS (progress
 * and cancel as in photons.h: SG_ERR_CANCELLED, nothing kept), then the
 * sample sites and the indirect light. */
sg_status sg_bake_create(const sg_world *w, const sg_bake_desc *d, sg_bake **out, sg_error *err);

/* SG_BAKE_INDIRECT_PHOTONS only: gathers a photon map that holds the whole
 * pass of d->photons (pm->blocks = sg_photon_block_count(&d->photons), else
 * SG_ERR_INVALID_ARG) into a bake, and adds the direct light
 * (d->direct_samples). The map must have been traced with
 * sg_bake_desc_resolve(d).photons: its flags say whether photons record
 * direct light. pm stays the caller's. Equal maps give equal bakes. */
sg_status sg_bake_create_from_photons(const sg_world *w, const sg_bake_desc *d, const sg_photon_map *pm,
                                      sg_bake **out, sg_error *err);

void sg_bake_destroy(sg_bake *b);
void sg_bake_get_stats(const sg_bake *b, sg_bake_stats *stats);

/* d with every zero field replaced by its default (the photon and gather
 * defaults of photons.h and irradiance.h). */
sg_bake_desc sg_bake_desc_resolve(const sg_bake_desc *d);

/* The parameters the bake was made with, defaults filled in; threads and
 * progress fields are 0/NULL. */
sg_bake_desc sg_bake_get_desc(const sg_bake *b);

/* 64-bit FNV-1a of the parameters that change a bake's values: photon
 * count, seed, max depth, Russian roulette depth, k, normal_cos,
 * SG_PHOTON_BLOCK, direct samples, sample spacing (float bits), glossy
 * resolution and rays, the indirect estimator, gather rays, refinement
 * levels and SG_BAKE_ALGORITHM, after defaults (so spelling
 * a default out changes nothing), as little-endian u64 (normal_cos: its
 * float bits). Threads and progress do not count: results ignore them.
 * Never 0. */
uint64_t sg_bake_param_hash(const sg_bake_desc *d);

/* Version of the estimators behind a bake's values; raised whenever the
 * same parameters start giving other values, so that a bake file made by
 * an older splatgi counts as made with other parameters (and
 * splatgi-bake --if-stale bakes again). 2: sparse direct light as a
 * visibility ratio times the tabulated unshadowed irradiance; 3: bright
 * texels of the table must also stand out from the mean; 4: light per
 * side, sample sites with stratified rays, indirect light by the transport
 * solve; 5: the bilinear envmap lookup and its sampling (envmap.h), white
 * points for files without colours, mesh samples on the Phong-tessellated
 * surface; 6: sites off the surface are never sample points, and in the
 * interpolation a refined level hides the coarser ones (samples.h); 7: the
 * MLS surface bridges gaps in the supports up to a sample spacing (mls.c),
 * so its rays see other hits; 8: a lookup whose only weighted sites face
 * away from the hit's normal takes its sites as they are (it read zero
 * weights: bake.c keep_facing), which the glossy bins' rays read. */
#define SG_BAKE_ALGORITHM 8u

size_t sg_bake_model_count(const sg_bake *b);

/* Floats of baked light per splat: per side (front, along the splat's
 * normal, then back), the visibility ratio of the direct light (RGB) and
 * the indirect irradiance (RGB, W/m^2). The irradiance of a side with
 * normal n is E = E0(n) * ratio + indirect, E0 the envmap's unshadowed
 * irradiance at n (envmap/irradiance_table.h), evaluated at the normal of
 * the point looked up. */
#define SG_BAKE_SPLAT_FLOATS 12

/* Model m's light: SG_BAKE_SPLAT_FLOATS floats per splat (above), in the
 * order of sg_scene_sites(sg_world_scene(w, m)); *splats gets the splat
 * count. Owned by the bake. m < sg_bake_model_count(b). */
const float *sg_bake_light_data(const sg_bake *b, uint32_t m, size_t *splats);

/* The irradiance (RGB, W/m^2) of one side (0 front, 1 back) of splat
 * `splat` of model m, at its own normal. */
sg_vec3 sg_bake_splat_irradiance(const sg_bake *b, const sg_world *w, uint32_t m, size_t splat, int side);

/* Sample points of model m (every splat when sample_spacing < 0). */
size_t sg_bake_sample_count(const sg_bake *b, uint32_t m);

/* Model m's glossy bins: *res = bins per side (0: the model has none, and
 * the other outputs are left alone), *count sample points, *splat the
 * splat of each (count u32), *nearest each splat's sample (u32 per splat),
 * *bins 3 res^2 halves per sample (glossy.h). Owned by the bake. */
void sg_bake_glossy_data(const sg_bake *b, uint32_t m, int *res, size_t *count, const uint32_t **splat,
                         const uint32_t **nearest, const uint16_t **bins);

/* Interpolated irradiance at a hit (RGB, W/m^2) on the side that faces wo
 * (unit, pointing away from the surface: towards the viewer). */
sg_vec3 sg_bake_irradiance(const sg_bake *b, const sg_world *w, const sg_world_hit *h, sg_vec3 wo);

/* Outgoing radiance at a hit towards the viewer at direction wo (unit,
 * pointing away from the surface). */
sg_vec3 sg_bake_lookup(const sg_bake *b, const sg_world *w, const sg_world_hit *h, sg_vec3 wo);

/* sg_bake_lookup for up to sixteen hits (bit r of mask: h[r] seen along
 * wo[r]): out[r] is sg_bake_lookup(b, w, &h[r], wo[r]), bit for bit. The
 * sites of all of them are found first and their data prefetched, so a
 * block of pixels waits on memory once rather than pixel by pixel. Only
 * the entries whose bit is set are read or written. */
void sg_bake_lookup16(const sg_bake *b, const sg_world *w, const sg_world_hit *h, const sg_vec3 *wo, unsigned mask,
                      sg_vec3 *out);

typedef struct sg_bake_frame_desc {
    sg_camera camera;   /* required                     */
    int width, height;  /* default 512 x 512             */
    int threads;        /* 0 = OpenMP default            */
} sg_bake_frame_desc;

/* One primary ray per pixel, the bake's lookup at the hit, the envmap where
 * the ray escapes. *out is allocated here (sg_image_free). Deterministic. */
sg_status sg_bake_render(const sg_bake *b, const sg_world *w, const sg_bake_frame_desc *d, sg_image *out,
                         double *seconds, sg_error *err);

/* For bake_io.c only: an empty bake (light zeroed) for a world with
 * envmap env (its irradiance table is built here), models and counts[m]
 * splats per model, desc d (resolved) and stats s; and write access to
 * model m's light (SG_BAKE_SPLAT_FLOATS per splat). */
sg_status sg_bake__new(const sg_envmap *env, size_t models, const size_t *counts, const sg_bake_desc *d,
                       const sg_bake_stats *s, sg_bake **out, sg_error *err);
float *sg_bake__light(sg_bake *b, uint32_t m);
/* For bake_job.c: the bake's table of unshadowed irradiance (the world's
 * envmap), its figures to fill, and their memory fields to recount. */
struct sg_irradiance_table;
const struct sg_irradiance_table *sg_bake__table(const sg_bake *b);
sg_bake_stats *sg_bake__stats(sg_bake *b);
void sg_bake__update_memory(sg_bake *b);
/* For bake_io.c only: model m's sample count, and room for its glossy
 * bins (res per side, count samples); the arrays to fill through
 * sg_bake__glossy. Call before the bake is used; stats follow. */
void sg_bake__set_samples(sg_bake *b, uint32_t m, size_t samples);
sg_status sg_bake__alloc_glossy(sg_bake *b, uint32_t m, int res, size_t count, sg_error *err);
void sg_bake__glossy(sg_bake *b, uint32_t m, uint32_t **splat, uint32_t **nearest, uint16_t **bins);

#endif
