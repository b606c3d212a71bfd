/* irradiance.h — density estimation of irradiance at every splat from the
 * photon map (the gather step of the bake).
 *
 * At a splat centre x with normal n, the k nearest photon records (sg_knn,
 * exact, ordered) give a disk of radius h = distance to the k-th; the
 * irradiance of each side of the splat (front: along n, back: against it)
 * is the flux of the records that arrived on that side of a surface facing
 * the same way (normals within normal_cos), weighted by the 2D Epanechnikov
 * kernel K(d) = 2 / (pi h^2) (1 - d^2 / h^2), which integrates to 1 over
 * the disk:  E(x) = sum_j Phi_j K(d_j)  [W / m^2].
 * Outgoing diffuse radiance is then rho / pi * E (the 1/pi that bakers are
 * known to forget; tested by the white furnace).
 */
#ifndef SG_BAKE_IRRADIANCE_H
#define SG_BAKE_IRRADIANCE_H

#include "bake/photons.h"
#include "core/error.h"
#include "render/world.h"

typedef struct sg_irradiance_desc {
    unsigned k;        /* photons per estimate; default 64                 */
    float normal_cos;  /* a record counts when n_record . n >= this;
                          default 0.7 (45 degrees)                        */
    int threads;       /* 0 = OpenMP default                               */
} sg_irradiance_desc;

/* For every model m, out[m] gets 6 * splat_count floats: the RGB irradiance
 * of each splat of sg_world_scene(w, m), front side then back side (sg_alloc_array; the caller frees
 * each with sg_free and the array of pointers too). Deterministic. */
sg_status sg_irradiance_gather(const sg_world *w, const sg_photon_map *pm, const sg_irradiance_desc *d, float ***out,
                               sg_error *err);

#endif
