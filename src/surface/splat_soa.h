/* splat_soa.h — the per-reference splat data the intersection kernels
 * stream through: one entry per (leaf, splat) reference, stored leaf by leaf
 * so that a leaf's splats are contiguous in memory (Kashyap 2010, §3.4,
 * measured about 30% faster than chasing indices). Structure of arrays.
 */
#ifndef SG_SURFACE_SPLAT_SOA_H
#define SG_SURFACE_SPLAT_SOA_H

#include <stdint.h>

typedef struct sg_splat_soa {
    float *px, *py, *pz; /* centre                                  */
    float *nx, *ny, *nz; /* unit normal                             */
    float *r;            /* radius of support                       */
    float *inv_r;        /* 1 / r, precomputed                      */
    uint32_t *id;        /* index of the splat in the scene's pointset */
    uint32_t *key;       /* MLS: the splat's layer key (scene.c): its
                            layer normal as three int8 in bits 0-7,
                            8-15, 16-23 where an opposed layer is near,
                            else 0; it puts the splat in a group for a
                            ray (mls.c). NULL: no keys (disks)      */
} sg_splat_soa;

#endif
