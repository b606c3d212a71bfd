/* world.h — everything a renderer traces: the models of a scene file, each
 * with its own surface (sg_scene) and material, and the environment map.
 *
 * What it does: turns a parsed scene file (io/scene_file.h) into ray
 * queries over all models (nearest hit over every model's kd-tree), the
 * material and albedo at a hit, and the envmap. The bake, the reference
 * path tracer and the viewer share it: one way to load, one way to
 * intersect (DESIGN.md).
 * What it does not do: shading or sampling decisions.
 *
 * Builtin models: "bunny" (assets/bunny.ply sampled like any mesh: about
 * 10 units tall, standing on y = 0), "ground" (a 30 x 30 square of splats at
 * y = 0, normal +Y), "sphere" (unit sphere, outward normals, 100k points or
 * the model's "points"), "room" (points/room.h: a closed room with one
 * window, 4 x 4 x 2.5 inside, walls 0.2 thick, sampled like a mesh to the
 * model's "points", default 250k); each then goes through its transform.
 * None of them has colours (white splats): the material's albedo is theirs.
 *
 * Ownership: the world copies what it needs; the scene file may be freed
 * after sg_world_create. Queries are thread-safe; stats must be per thread.
 */
#ifndef SG_RENDER_WORLD_H
#define SG_RENDER_WORLD_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "envmap/envmap.h"
#include "io/scene_file.h"
#include "material/bsdf.h"
#include "surface/scene.h"

typedef struct sg_world sg_world; /* opaque */

typedef struct sg_world_hit {
    sg_hit hit;      /* as sg_scene_intersect; hit.splat indexes the model */
    uint32_t model;  /* index into the scene file's models                 */
} sg_world_hit;

/* Loads every model (building its kd-tree) and the envmap. On failure
 * *out is untouched and err names the model ("$.models[1]: ...") or file. */
sg_status sg_world_create(const sg_scene_file *sf, sg_world **out, sg_error *err);

/* What sg_world_create_desc tells its caller while it builds. */
typedef enum sg_world_event {
    SG_WORLD_STAGE = 0, /* a stage begins: "model 1 of 2 (scan.ply): reading" */
    SG_WORLD_NOTE = 1   /* the input was changed or is suspect, with counts:
                           capped radii, dropped outliers, zeroed envmap
                           texels; once per model or map                    */
} sg_world_event;

typedef struct sg_world_desc {
    /* Optional; called on the calling thread between stages (never from a
     * parallel region), message valid during the call only. */
    void (*on_event)(void *user, sg_world_event kind, const char *message);
    void *user;
} sg_world_desc;

/* sg_world_create with progress and notes (d may be NULL: none). */
sg_status sg_world_create_desc(const sg_scene_file *sf, const sg_world_desc *d, sg_world **out, sg_error *err);

/* NULL is a no-op. */
void sg_world_destroy(sg_world *w);

/* Nearest hit over all models in [tmin, tmax]; 0 on a miss. stats (may be
 * NULL) counts one ray (and at most one hit) per call, and the traversal
 * counters of every model it visits. */
int sg_world_intersect(const sg_world *w, const sg_ray *ray, sg_world_hit *h, sg_ray_stats *stats);

/* Up to four rays at once (bit r of mask: rays[r] is traced), e.g. a
 * 2 x 2 quad of camera rays: each gets exactly sg_world_intersect's hit
 * (bit for bit, tested). Rays that visit the models in the same order
 * (by box entry) share each model's traversal (sg_scene_intersect4);
 * otherwise they are traced in one packet per order. Returns the mask of the rays
 * that hit; h[r] of a ray outside mask is left alone. */
unsigned sg_world_intersect4(const sg_world *w, const sg_ray rays[4], unsigned mask, sg_world_hit h[4],
                             sg_ray_stats *stats);

/* sg_world_intersect4 for up to sixteen rays (bits 0-15 of mask), e.g. a
 * 4 x 4 block of camera rays: each gets exactly sg_world_intersect's hit.
 * Rays that visit the models in one order share each model's traversal
 * (sg_scene_intersect16); a block whose rays disagree is traced as one
 * packet per order. Only the entries of rays and h whose bit is set are
 * read or written. */
unsigned sg_world_intersect16(const sg_world *w, const sg_ray *rays, unsigned mask, sg_world_hit *h,
                              sg_ray_stats *stats);

/* 1 if any model is hit in [tmin, tmax]. */
int sg_world_occluded(const sg_world *w, const sg_ray *ray, sg_ray_stats *stats);

/* A secondary ray leaving h towards dir (sg_scene_spawn_ray of its model). */
sg_ray sg_world_spawn_ray(const sg_world *w, const sg_world_hit *h, sg_vec3 dir, float tmax);

const sg_material *sg_world_material(const sg_world *w, uint32_t model);

/* Diffuse albedo at the hit: the material's albedo times the splat's
 * colour where the material uses point colours (sg_material_albedo). */
sg_vec3 sg_world_albedo(const sg_world *w, const sg_world_hit *h);

/* sg_world_albedo(w, h), bit for bit, given the n sites and weights
 * sg_scene_hit_sites gave h (any max >= 3; sg_scene_hit_albedo_sites). */
sg_vec3 sg_world_albedo_sites(const sg_world *w, const sg_world_hit *h, const uint32_t *ids, const float *weights,
                              int n);

/* The same at light site `site` of model `model` (surface/sites.h). */
sg_vec3 sg_world_site_albedo(const sg_world *w, uint32_t model, uint32_t site);

const sg_envmap *sg_world_envmap(const sg_world *w);

size_t sg_world_model_count(const sg_world *w);
const sg_scene *sg_world_scene(const sg_world *w, uint32_t model);

/* Box of all models' supports, and its diagonal (the scene's unit length). */
sg_aabb sg_world_bounds(const sg_world *w);

#endif
