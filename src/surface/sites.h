/* sites.h — light sites: the places where a bake stores light on a surface.
 *
 * Every surface representation names its own sites (../shared/DESIGN.md,
 * "Surface representations behind one interface"): for MLS and disk
 * surfaces they are the splats; an implicit surface octree's are its
 * corners, a triangle hierarchy's its vertices. The bake computes light at
 * sites and never asks which representation it holds; a lookup blends the
 * sites around a hit with the weights sg_scene_hit_sites gives.
 *
 * Site i lies at (px[i], py[i], pz[i]) with unit normal (nx[i], ny[i],
 * nz[i]), the side its front light faces; radius[i] is its reach, the
 * distance over which its light is interpolated (a splat's radius), which
 * sets the spacing of the bake's sample points.
 *
 * A view, not an owner: the arrays belong to the scene that returned it and
 * live as long as it does.
 */
#ifndef SG_SURFACE_SITES_H
#define SG_SURFACE_SITES_H

#include <stddef.h>
#include <stdint.h>

#include "math/vec3.h"
#include "points/pointset.h"

typedef struct sg_sites {
    size_t count;
    const float *px, *py, *pz; /* positions, world space     */
    const float *nx, *ny, *nz; /* unit normals (front side)  */
    const float *radius;       /* reach, > 0                 */
    const float *ar, *ag, *ab; /* the points' colour there (linear RGB): the
                                  material input of light arriving at it */
    const uint8_t *unsampled;  /* per site, nonzero: never a sample point of
                                  a bake, only interpolated to (a site off
                                  the surface, bake/transport.h); NULL: none */
    int white;                 /* 1: every colour is (1, 1, 1) and the
                                  surface's albedo of a hit never reads ar,
                                  ag, ab (a mesh without vertex colours), so
                                  a lookup need not fetch them            */
} sg_sites;

static inline sg_vec3 sg_sites_position(const sg_sites *s, size_t i)
{
    return sg_v3(s->px[i], s->py[i], s->pz[i]);
}

static inline sg_vec3 sg_sites_normal(const sg_sites *s, size_t i)
{
    return sg_v3(s->nx[i], s->ny[i], s->nz[i]);
}

/* The splats of a point set as sites (MLS and disk surfaces; tests). */
static inline sg_sites sg_sites_of_pointset(const sg_pointset *ps)
{
    return (sg_sites){.count = ps->count, .px = ps->px, .py = ps->py, .pz = ps->pz,
                      .nx = ps->nx, .ny = ps->ny, .nz = ps->nz, .radius = ps->radius,
                      .ar = ps->ar, .ag = ps->ag, .ab = ps->ab};
}

#endif
