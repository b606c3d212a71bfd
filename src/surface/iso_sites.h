/* iso_sites.h — the light sites of an implicit surface octree: its corners
 * (issue 13, "baked light in the corners").
 *
 * A bake stores light at every corner of the ISO's stored leaves; a hit
 * reads the 8 corners of its leaf with trilinear weights, so a lookup is a
 * trilinear read with no splat gather. Leaves of one size share corners,
 * so the light is continuous across them; where a leaf meets smaller
 * ones, the finer leaves' corners on the shared face are not the coarse
 * leaf's, and the light can step there by what it changes across the
 * coarse leaf (the same bound as the surface's own seam, iso.h rule c).
 *
 * Site c lies at its grid point, with the corner's stored MLS normal; its
 * colour and its reach (radius) are those of the representative splat of
 * the first leaf (in storage order) that uses it. The reach sets the
 * spacing of the bake's sample points (samples.h), so an ISO bake takes
 * as many sample points as an MLS bake of the same splats, although the
 * corners outnumber the splats (2.6 : 1 on the dragon) and are only
 * interpolated to.
 *
 * Use:
 *     sg_iso_sites s; sg_iso_sites_create(iso, &points, &s, &err);
 *     n = sg_iso_hit_sites(iso, &s, &hit, ids, w, 8);
 *     sg_iso_sites_free(&s);
 * The caller owns the struct; the arrays behind s.view are its own.
 */
#ifndef SG_SURFACE_ISO_SITES_H
#define SG_SURFACE_ISO_SITES_H

#include <stdint.h>

#include "core/error.h"
#include "math/ray.h"
#include "points/pointset.h"
#include "surface/iso.h"
#include "surface/sites.h"

typedef struct sg_iso_sites {
    sg_sites view;  /* what sg_scene_sites hands out                   */
    float *data;    /* the one allocation behind view's 10 arrays       */
    uint32_t *splat; /* per site: the splat giving its colour (and a
                        spawned ray's self radius, sg_scene_site_hit)   */
} sg_iso_sites;

/* Errors: SG_ERR_NOMEM. On failure *out is zeroed. */
sg_status sg_iso_sites_create(const sg_iso *iso, const sg_pointset *points, sg_iso_sites *out, sg_error *err);

/* Zeroes the struct; a zeroed struct is a no-op. */
void sg_iso_sites_free(sg_iso_sites *s);

/* The 8 corners of the hit's leaf and their trilinear weights at hit->p
 * (clamped into the leaf's box; sum 1), largest first is not promised.
 * Writes at most max entries, the largest weights renormalised when
 * max < 8; returns the count (0 for a hit without a leaf). */
int sg_iso_hit_sites(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit, uint32_t *ids, float *weights,
                     int max);

/* The corner of the hit's leaf nearest hit->p (the largest trilinear
 * weight); SG_INVALID_ID for a hit without a leaf. */
uint32_t sg_iso_hit_site(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit);

/* Bytes held behind s (for the scene's memory report). */
size_t sg_iso_sites_memory(const sg_iso_sites *s);

#endif
