/* world_int.h — the layout of sg_world, shared by world.c (builds and
 * queries it) and world_file.c (saves and loads it). Not a public header.
 */
#ifndef SG_RENDER_WORLD_INT_H
#define SG_RENDER_WORLD_INT_H

#include "bake/bake_file.h"
#include "render/world.h"

struct sg_world {
    size_t count;            /* models                              */
    sg_scene **scenes;       /* one kd-tree per model (invariant 1) */
    sg_material *materials;  /* one material per model             */
    sg_envmap *env;
    sg_aabb bounds;
    sg_aabb *model_bounds;   /* each model's support box, for culling    */
    sg_bake_file *file;      /* a loaded world: the mapped world file the
                                scenes borrow their arrays from; closed by
                                destroy after them (NULL when built)     */
};

/* The envmap of the scene file, as sg_world_create makes it. */
sg_status sg_world__make_envmap(const sg_scene_env *e, sg_envmap **out, sg_error *err);

/* d->on_event(kind, printf-formatted message), if any. */
void sg_world__say(const sg_world_desc *d, sg_world_event kind, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* The note on an envmap's non-finite texels, if it had any. */
void sg_world__note_envmap(const sg_world_desc *d, const sg_scene_env *e, const sg_envmap *env);

/* Where ray r enters box b, or INFINITY when it misses it within
 * [r->tmin, r->tmax] (the models' order along a ray). */
float sg_world__box_entry(const sg_aabb *b, const sg_ray *r);

/* sg_world__box_entry of boxes[0..n-1] for the rays of mask (bit i:
 * rays[i]; up to 16), bit for bit, in out[k][i]; SIMD across the rays
 * where v16.h has it. Lanes outside mask are neither read nor written. */
void sg_world__box_entry16(const sg_aabb *boxes, size_t n, const sg_ray *rays, unsigned mask, float (*out)[16]);

/* Takes model i's bounds from its scene into model_bounds[i] and bounds. */
void sg_world__add_bounds(sg_world *w, size_t i);

#endif
