/* analytic.h — environment maps made from formulas, for tests and demos.
 *
 * What it does: fills a lat-long sg_image (the mapping of envmap.h, no
 * rotation) with one of four radiance distributions whose integrals are
 * known, so estimators can be checked against closed forms:
 *   SG_ANALYTIC_UNIFORM  constant radiance desc.radiance (default 1,1,1);
 *                        its irradiance on any plane is pi * radiance.
 *   SG_ANALYTIC_SKY      smooth gradient: above the horizon (y = cos theta
 *                        >= 0) horizon + (zenith - horizon) * sqrt(y) with
 *                        horizon (1.0, 0.95, 0.9), zenith (0.25, 0.45, 1.0);
 *                        below it a constant ground (0.2, 0.18, 0.15).
 *                        Each texel holds the value at its centre direction.
 *   SG_ANALYTIC_SUNSKY   SKY plus a sun disk of angular radius
 *                        desc.sun_radius_deg (default 0.5) and radiance
 *                        desc.sun_radiance (default 1e5, grey) around
 *                        desc.sun_dir (default elevation 40 deg, azimuth
 *                        30 deg from +X towards +Z). The disk is
 *                        rasterised with 8 x 8 subsamples per texel and then
 *                        scaled so that its integral over the texels is
 *                        exactly sun_radiance * 2 pi (1 - cos radius), the
 *                        true disk's, whatever the resolution (a disk smaller
 *                        than the subsamples lands whole in the texel that
 *                        contains sun_dir).
 *   SG_ANALYTIC_STUDIO   dark background (0.03, 0.03, 0.03) plus the four
 *                        rectangular emitters of sg_analytic_studio_lights,
 *                        each a box in (azimuth, elevation); a texel holds
 *                        background + radiance x the solid-angle fraction
 *                        of the texel the box covers (computed exactly in
 *                        phi and cos theta), so the map's integral equals
 *                        the closed form sg_analytic_studio_power.
 * What it does NOT do: physical sky models (Preetham, Hosek), files (the
 * splatgi-envmap program writes them with sg_image_write_exr).
 *
 * Azimuth is the map's phi = atan2(z, x) (0 = +X, the centre column;
 * 90 deg = +Z); elevation is 90 deg - theta (90 = +Y).
 * Ownership: *out is allocated with sg_image_alloc; free with
 * sg_image_free. Errors: SG_ERR_INVALID_ARG (unknown type, size outside
 * 1..SG_IMAGE_MAX_DIM, a non-finite or negative parameter), SG_ERR_NOMEM.
 * Thread-safety: reentrant.
 */
#ifndef SG_ENVMAP_ANALYTIC_H
#define SG_ENVMAP_ANALYTIC_H

#include "core/error.h"
#include "io/image.h"
#include "math/vec3.h"

typedef enum sg_analytic_type {
    SG_ANALYTIC_UNIFORM = 0,
    SG_ANALYTIC_SKY = 1,
    SG_ANALYTIC_SUNSKY = 2,
    SG_ANALYTIC_STUDIO = 3
} sg_analytic_type;

/* Options; zero means the default. */
typedef struct sg_analytic_desc {
    sg_analytic_type type; /* default SG_ANALYTIC_UNIFORM                   */
    int width;             /* default 1024, or 2 * height if height is set */
    int height;            /* default width / 2 (at least 1)               */
    sg_vec3 radiance;      /* UNIFORM only; default (1, 1, 1)              */
    sg_vec3 sun_dir;       /* SUNSKY: towards the sun, normalised here     */
    float sun_radius_deg;  /* SUNSKY: angular radius, default 0.5          */
    float sun_radiance;    /* SUNSKY: grey radiance, default 1e5           */
} sg_analytic_desc;

/* One studio emitter: radiance inside an (azimuth, elevation) box. */
typedef struct sg_analytic_light {
    float az0_deg, az1_deg; /* azimuth range, az0 < az1, within -180..180 */
    float el0_deg, el1_deg; /* elevation range, el0 < el1, within -90..90 */
    sg_vec3 radiance;       /* added to the background inside the box     */
} sg_analytic_light;

/* Makes the image described by desc. On failure *out is untouched. */
sg_status sg_analytic_make(const sg_analytic_desc *desc, sg_image *out, sg_error *err);

/* "uniform", "sky", "sunsky", "studio"; NULL for an unknown value. */
const char *sg_analytic_type_name(sg_analytic_type type);

/* Inverse of sg_analytic_type_name; SG_ERR_INVALID_ARG naming the word
 * and the choices for anything else. */
sg_status sg_analytic_type_parse(const char *name, sg_analytic_type *out, sg_error *err);

/* The studio emitters (a constant table) and their count. */
const sg_analytic_light *sg_analytic_studio_lights(int *count);

/* Closed-form integral over the sphere of the studio map's radiance, per
 * channel: background * 4 pi + sum over lights of radiance * solid angle,
 * solid angle of a box = (az1 - az0) (sin el1 - sin el0) in radians. */
sg_vec3 sg_analytic_studio_power(void);

/* Default sun direction of SUNSKY (unit). */
sg_vec3 sg_analytic_default_sun_dir(void);

#endif
