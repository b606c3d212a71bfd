/* photons.h — the light-tracing pass of the bake: photons from the
 * environment map, traced through every model's hierarchy with any number
 * of bounces, recorded where they land.
 *
 * A photon leaves the envmap in a direction drawn in proportion to the
 * map's luminance (sg_envmap_sample), from a uniform point of the disk that
 * covers the scene's bounding sphere across that direction. With N photons
 * its flux is Phi = L(d) pi R^2 / (pdf(d) N): the envmap's radiance through
 * that disk, shared out. At each surface it reaches it is recorded (with the
 * direction it came from), then it scatters by BSDF sampling with Russian
 * roulette, so direct light, shadows, inter-reflection and colour bleeding
 * all come out of one pass.
 *
 * Determinism: photon i uses sg_rng_float(seed, i, bounce, dim); photons are
 * traced in blocks of SG_PHOTON_BLOCK and the blocks' records concatenated
 * in block order, so the map is the same for any thread count.
 */
#ifndef SG_BAKE_PHOTONS_H
#define SG_BAKE_PHOTONS_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "render/world.h"

#define SG_PHOTON_BLOCK 4096

typedef struct sg_photon_desc {
    size_t count;     /* photons shot; default 1,000,000                 */
    uint64_t seed;    /* default 1                                       */
    int max_depth;    /* surface interactions per photon; default 8      */
    int rr_depth;     /* Russian roulette from this bounce; default 2    */
    int threads;      /* 0 = OpenMP default                              */
} sg_photon_desc;

/* Photon records, structure of arrays; record j landed at p with the
 * surface normal n (facing the side it arrived from), coming from
 * direction w (unit, pointing away from the surface), carrying flux phi
 * (RGB, watts in the scene's units), on model `model`. */
typedef struct sg_photon_map {
    size_t count;
    float *px, *py, *pz;
    float *nx, *ny, *nz;
    float *wx, *wy, *wz;
    float *fr, *fg, *fb;
    uint32_t *model;
    size_t shot;          /* photons emitted                              */
    double seconds;       /* wall time of the pass                        */
    sg_ray_stats rays;
} sg_photon_map;

sg_status sg_photons_trace(const sg_world *w, const sg_photon_desc *d, sg_photon_map *out, sg_error *err);

void sg_photon_map_free(sg_photon_map *m);

#endif
