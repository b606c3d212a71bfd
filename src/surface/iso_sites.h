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
 * After the corners come the node sites, one for each inner node with a
 * coarse patch (iso.h, "Levels of detail"), in depth-first order: the
 * cell's centre moved onto the node's plane (clamped into the cell), the
 * plane's normal, the representative leaf's splat's colour and reach.
 * They are never sample points (view.unsampled); once the bake has light
 * at the corners, sg_iso_sites_filter sets each to the area-weighted mean
 * of the light of the leaves below its node (each leaf the mean of its 8
 * corners, weighed by its face area), which an LOD hit reads: the light
 * of the surface the pixel covers, not a point sample of it (Kashyap
 * 2010, ch. 4: inner nodes hold filtered attributes).
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
    uint32_t *node_site; /* per inner node: its site, SG_INVALID_ID where
                            it has no coarse patch                      */
    uint8_t *unsampled;  /* per site: 1 for node sites (view.unsampled) */
    size_t corner_sites; /* sites [0, corner_sites) are the corners     */
    size_t node_count;   /* entries of node_site: the ISO's inner nodes */
} sg_iso_sites;

/* Errors: SG_ERR_NOMEM; SG_ERR_INVALID_ARG for 2^32 - 1 sites or more. On
 * failure *out is zeroed. */
sg_status sg_iso_sites_create(const sg_iso *iso, const sg_pointset *points, sg_iso_sites *out, sg_error *err);

/* Zeroes the struct; a zeroed struct is a no-op. */
void sg_iso_sites_free(sg_iso_sites *s);

/* The 8 corners of the hit's leaf and their trilinear weights at hit->p
 * (clamped into the leaf's box; sum 1), largest first is not promised.
 * Writes at most max entries, the largest weights renormalised when
 * max < 8; returns the count (0 for a hit without a leaf). An LOD hit
 * (hit->leaf = leaf_count + node) gives its node's site, weight 1. */
int sg_iso_hit_sites(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit, uint32_t *ids, float *weights,
                     int max);

/* The corner of the hit's leaf nearest hit->p (the largest trilinear
 * weight); SG_INVALID_ID for a hit without a leaf. */
uint32_t sg_iso_hit_site(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit);

/* Sets every node site's values (stride <= 16 floats a site) to the
 * area-weighted mean of its leaves' (each the mean of its 8 corners;
 * weight: the leaf's face area, edge^2). Means of finite values stay
 * finite, of non-negative ones non-negative. */
#define SG_ISO_FILTER_STRIDE_MAX 16 /* as sg_scene_filter_sites */
void sg_iso_sites_filter(const sg_iso *iso, const sg_iso_sites *s, float *values, size_t stride);

/* Bytes held behind s (for the scene's memory report). */
size_t sg_iso_sites_memory(const sg_iso_sites *s);

#endif
