/* bake.h — baked incident light on the splats, and its lookup.
 *
 * What it does: one photon-style pass from the environment map through the
 * models' hierarchies (bake/photons.h) records where light lands after any
 * number of bounces; a gather (bake/irradiance.h) turns the records into
 * irradiance E at every splat. Looking up a hit interpolates E over the
 * splats around it with the surface's own MLS weights
 * (sg_scene_hit_weights), so the baked light is as smooth as the surface,
 * and applies the material: L_o = emission + rho(x) / pi * E.
 * What it does not do (yet): directional bins for glossy highlights — a
 * glossy material's lobe is looked up as if diffuse (its albedo is kept,
 * its highlight is not).
 *
 * States: CREATED by sg_bake_create (traced and gathered) or LOADED from a
 * file; both answer lookups for the world they were made for.
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
} sg_bake_desc;

typedef struct sg_bake_info {
    size_t models;
    size_t splats;             /* sample points: every splat of every model */
    size_t photons_shot;
    size_t photon_records;
    double trace_seconds, gather_seconds;
    size_t memory_bytes;       /* the irradiance arrays                      */
} sg_bake_info;

sg_status sg_bake_create(const sg_world *w, const sg_bake_desc *d, sg_bake **out, sg_error *err);
void sg_bake_destroy(sg_bake *b);
void sg_bake_get_info(const sg_bake *b, sg_bake_info *info);

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

#endif
