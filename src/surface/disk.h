/* disk.h — flat disk splats with deep blending (Kashyap 2010, §3.3-3.5).
 *
 * Splat i is the disk of radius r_i through p_i with normal n_i. A ray meets
 * several overlapping disks of one surface; all accepted hits within a depth
 * window behind the nearest one are blended with weights 1 - |x - p_i| / r_i
 * (Kashyap eq. 3.1), for position and normal. The window may reach into the
 * next kd-tree leaves ("deep" blending: splats of the same surface stored in
 * a neighbouring cell still count), so the traversal keeps a blend state
 * across leaves.
 */
#ifndef SG_SURFACE_DISK_H
#define SG_SURFACE_DISK_H

#include <stddef.h>
#include <stdint.h>

#include "math/ray.h"
#include "surface/splat_soa.h"

typedef struct sg_disk_blend {
    float t_near;    /* nearest accepted hit; INFINITY while none             */
    float t_end;     /* blending window end: t_near + depth * r_nearest       */
    float window;    /* depth factor, in radii of the nearest splat           */
    float facing;    /* sign of dir . n of the nearest hit: only hits facing
                        the same way blend (the other side of a thin sheet is
                        another surface)                                      */
    float wsum;      /* sum of blend weights                                  */
    sg_vec3 psum;    /* sum w x                                               */
    sg_vec3 nsum;    /* sum w n                                               */
    float wmax;      /* largest weight so far, and its splat                  */
    uint32_t best;
} sg_disk_blend;

void sg_disk_blend_init(sg_disk_blend *b, float window);

/* Processes the leaf's disks over the half-open interval [t0, t1): finds the
 * nearest accepted hit if none is known yet, then adds every accepted hit
 * inside the window. */
void sg_disk_leaf(const sg_splat_soa *s, size_t first, size_t count, const sg_ray *ray, float t0, float t1,
                  sg_disk_blend *b);

/* 1 if the leaf has any accepted disk hit in [t0, t1] (shadow rays). */
int sg_disk_leaf_any(const sg_splat_soa *s, size_t first, size_t count, const sg_ray *ray, float t0, float t1);

/* Writes the blended hit; returns 0 when nothing was hit. */
int sg_disk_blend_finish(const sg_disk_blend *b, const sg_ray *ray, sg_hit *hit);

#endif
