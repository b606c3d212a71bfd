/* bake.h — baked incident light on the splats, and its lookup.
 *
 * What it does: one photon-style pass from the environment map through the
 * models' hierarchies (bake/photons.h) records where light lands after one
 * or more bounces; a gather (bake/irradiance.h) turns the records into
 * indirect irradiance at every splat. The direct irradiance comes from
 * shadow rays towards the envmap (bake/direct.h) at SAMPLE POINTS, a
 * subset of the splats chosen per model by a spacing from the material and
 * refined where the light changes fast (bake/samples.h), and is
 * interpolated to every splat, so E = direct + indirect per splat. (With
 * direct_samples < 0 the photons carry the direct light too.) Glossy
 * (GGX) models also get directional bins of the lobe-filtered incident
 * radiance S(wo) at their sample points (bake/glossy.h). Looking up a hit
 * interpolates E over the splats around it with the surface's own MLS
 * weights (sg_scene_hit_weights), so the baked light is as smooth as the
 * surface, and applies the material:
 *     Lambert:  L_o = emission + rho(x) / pi * E
 *     GGX:      L_o = emission + (1 - k) rho(x) / pi * E + k S(wo),
 * S blended over the sample points the hit's splats map to, with the same
 * weights.
 *
 * States: CREATED by sg_bake_create (traced and gathered), by
 * sg_bake_create_from_photons (gathered from a photon map traced in
 * chunks, see photons.h) or LOADED from a file (bake/bake_io.h); all answer
 * lookups for the world they were made for.
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
#include "io/image.h"
#include "render/camera.h"
#include "render/world.h"

typedef struct sg_bake sg_bake; /* opaque */

typedef struct sg_bake_desc {
    sg_photon_desc photons;      /* count, seed, depth (photons.h defaults) */
    sg_irradiance_desc gather;   /* k, normal_cos (irradiance.h defaults)    */
    int direct_samples;          /* direct light by shadow rays at the sample
                                    points (bake/direct.h), samples per point
                                    per strategy; default 32; < 0: none, the
                                    photons carry the direct light as well   */
    float sample_spacing;        /* spacing of the sample points, a multiple
                                    of each model's median splat radius;
                                    0: from the material (samples.h: 4
                                    diffuse, 2 + 2 roughness glossy);
                                    < 0: every splat is a sample point      */
    int glossy_res;              /* glossy bins per side, 4..32; 0: from
                                    the roughness (glossy.h, 4..32)          */
    int glossy_rays;             /* rays per glossy sample point; default
                                    128                                      */
} sg_bake_desc;

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
    double direct_seconds;     /* sample selection, the shadow rays of the
                                  direct light and its interpolation (part
                                  of gather_seconds); 0 for a loaded bake    */
    double glossy_seconds;     /* the glossy bins (part of gather_seconds)   */
    size_t memory_bytes;       /* all kept: the sum of the three below       */
    size_t irradiance_bytes;   /* E: 3 floats per splat                      */
    size_t sample_bytes;       /* kept per glossy model: the splat of each
                                  sample point and each splat's sample (u32)  */
    size_t glossy_bytes;       /* the bins: 3 R^2 halves per glossy point    */
    size_t photon_memory_bytes;/* the photon records while baking (freed)    */
} sg_bake_stats;

/* Traces the photons of d->photons (progress and cancel as in photons.h:
 * SG_ERR_CANCELLED, nothing kept) and gathers them. */
sg_status sg_bake_create(const sg_world *w, const sg_bake_desc *d, sg_bake **out, sg_error *err);

/* Gathers a photon map that holds the whole pass of d->photons (pm->blocks
 * = sg_photon_block_count(&d->photons), else SG_ERR_INVALID_ARG) into a
 * bake, and adds the direct light (d->direct_samples). The map must have
 * been traced with sg_bake_desc_resolve(d).photons: its flags say whether
 * photons record direct light. pm stays the caller's. Equal maps give
 * equal bakes. */
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
 * resolution and rays, and SG_BAKE_ALGORITHM, after defaults (so spelling
 * a default out changes nothing), as little-endian u64 (normal_cos: its
 * float bits). Threads and progress do not count: results ignore them.
 * Never 0. */
uint64_t sg_bake_param_hash(const sg_bake_desc *d);

/* Version of the estimators behind a bake's values; raised whenever the
 * same parameters start giving other values, so that a bake file made by
 * an older splatgi counts as made with other parameters (and
 * splatgi-bake --if-stale bakes again). 2: sparse direct light as a
 * visibility ratio times the tabulated unshadowed irradiance; 3: bright
 * texels of the table must also stand out from the mean. */
#define SG_BAKE_ALGORITHM 3u

size_t sg_bake_model_count(const sg_bake *b);

/* Model m's irradiance: 3 floats (RGB, W/m^2) per splat, in the order of
 * sg_scene_points(sg_world_scene(w, m)); *splats gets the splat count.
 * Owned by the bake. m < sg_bake_model_count(b). */
const float *sg_bake_irradiance_data(const sg_bake *b, uint32_t m, size_t *splats);

/* Sample points of model m (every splat when sample_spacing < 0). */
size_t sg_bake_sample_count(const sg_bake *b, uint32_t m);

/* Model m's glossy bins: *res = bins per side (0: the model has none, and
 * the other outputs are left alone), *count sample points, *splat the
 * splat of each (count u32), *nearest each splat's sample (u32 per splat),
 * *bins 3 res^2 halves per sample (glossy.h). Owned by the bake. */
void sg_bake_glossy_data(const sg_bake *b, uint32_t m, int *res, size_t *count, const uint32_t **splat,
                         const uint32_t **nearest, const uint16_t **bins);

/* Interpolated irradiance at a hit (RGB, W/m^2). */
sg_vec3 sg_bake_irradiance(const sg_bake *b, const sg_world *w, const sg_world_hit *h);

/* Outgoing radiance at a hit towards the viewer at direction wo (unit,
 * pointing away from the surface). */
sg_vec3 sg_bake_lookup(const sg_bake *b, const sg_world *w, const sg_world_hit *h, sg_vec3 wo);

typedef struct sg_bake_frame_desc {
    sg_camera camera;   /* required                     */
    int width, height;  /* default 512 x 512             */
    int threads;        /* 0 = OpenMP default            */
} sg_bake_frame_desc;

/* One primary ray per pixel, the bake's lookup at the hit, the envmap where
 * the ray escapes. *out is allocated here (sg_image_free). Deterministic. */
sg_status sg_bake_render(const sg_bake *b, const sg_world *w, const sg_bake_frame_desc *d, sg_image *out,
                         double *seconds, sg_error *err);

/* For bake_io.c only: an empty bake (irradiance zeroed) with models and
 * counts[m] splats per model, desc d (resolved) and stats s; and write
 * access to model m's irradiance. */
sg_status sg_bake__new(size_t models, const size_t *counts, const sg_bake_desc *d, const sg_bake_stats *s,
                       sg_bake **out, sg_error *err);
float *sg_bake__irradiance(sg_bake *b, uint32_t m);
/* For bake_io.c only: model m's sample count, and room for its glossy
 * bins (res per side, count samples); the arrays to fill through
 * sg_bake__glossy. Call before the bake is used; stats follow. */
void sg_bake__set_samples(sg_bake *b, uint32_t m, size_t samples);
sg_status sg_bake__alloc_glossy(sg_bake *b, uint32_t m, int res, size_t count, sg_error *err);
void sg_bake__glossy(sg_bake *b, uint32_t m, uint32_t **splat, uint32_t **nearest, uint16_t **bins);

#endif
