/* envmap.h — HDR environment map: radiance lookup and importance sampling.
 *
 * What it does: holds a lat-long (equirectangular) radiance map, answers
 * "how much radiance arrives from direction d" and draws directions with
 * probability proportional to that radiance (its luminance), with the
 * matching pdf and the inverse warp. It is shared by the baker, the viewer
 * and the reference renderer (DESIGN.md: one way to sample the envmap).
 * What it does NOT do: mip-maps or prefiltering, colour management
 * (values are taken as scene-linear Rec.709), analytic sky models (see
 * analytic.h, which makes images for sg_envmap_create).
 *
 * Mapping (DESIGN.md "Conventions"; right-handed, +Y up). A unit direction
 * d in map space has
 *     u = 0.5 + atan2(d.z, d.x) / (2 pi)      in [0, 1]
 *     v = acos(d.y) / pi                      in [0, 1]
 * u = 0 is the left column of the image, v = 0 its top row (+Y, zenith);
 * the centre column looks along +X, u = 0.75 along +Z, u = 0.25 along -Z.
 * Texel (i, j) (column i, row j) covers u in [i/W, (i+1)/W) and
 * v in [j/H, (j+1)/H); the one containing (u, v) is i = floor(u W),
 * j = floor(v H), clamped to the image (u = 1 reads column W-1).
 * Inverse: phi = 2 pi (u - 0.5), theta = pi v,
 *     d = (sin theta cos phi, cos theta, sin theta sin phi).
 *
 * Rotation: desc.rotation_deg turns the map about +Y by the right-hand rule
 * (seen from above, +X turns towards -Z for a positive angle): what the
 * unrotated map shows in direction d, the rotated map shows in direction
 * R_y(angle) d, with R_y(a) (x, y, z) = (x cos a + z sin a, y,
 * -x sin a + z cos a). So world direction w looks up map direction
 * R_y(-angle) w, i.e. u_map = u_world + angle / 360 deg (mod 1).
 *
 * Radiance: bilinear between texel centres (as Blender and pbrt look maps
 * up): with x = u W - 0.5, y = v H - 0.5, i = floor(x), s = x - i,
 * j = floor(y), t = y - j,
 *     eval(d) = intensity x [(1-t)((1-s) T(i,j) + s T(i+1,j))
 *                            + t ((1-s) T(i,j+1) + s T(i+1,j+1))],
 * columns wrapping (i = -1 is W-1, i = W is 0), rows clamped (above the
 * centres of row 0 and below those of row H-1 the lookup is that row's, in
 * u only). At a texel centre it is the texel; sg_envmap_texel reads texels
 * exactly.
 *
 * Sampling (a 2D piecewise-constant distribution, pbrt-v4
 * PiecewiseConstant2D, in the coordinates (cos theta, phi)): texel (i, j)
 * has the weight w(i, j) = the largest luminance the bilinear lookup takes
 * inside it (found at the centre, the edge midpoints or the corners:
 * averages of the texel and its 8 neighbours). The marginal CDF picks row j
 * with probability proportional to
 *     sum_i w(i, j) * dOmega_j,  dOmega_j = (2 pi / W)(cos(pi j/H) - cos(pi (j+1)/H)),
 * the row's conditional CDF picks column i proportional to w(i, j); inside
 * the texel the direction is uniform in solid angle (linear in cos theta
 * and phi). Hence the solid-angle pdf is constant on a texel:
 *     pdf(d) = w(texel of d) / P_w,   P_w = sum_ij w(i, j) dOmega_j,
 * with lum = 0.2126 R + 0.7152 G + 0.0722 B (Rec.709), and
 *     pdf(d) > 0 wherever eval(d) != 0, and lum(eval(d)) / pdf(d) <= P_w x
 *     intensity (info.sampling_power): the estimator L / pdf is bounded.
 * u1 picks the row (theta), u2 the column (phi); both warps are monotone
 * and continuous, so sg_envmap_invert(sample(u1, u2)) = (u1, u2) up to
 * rounding.
 * All-black map (P = 0): sampling falls back to the uniform sphere,
 * cos theta = 1 - 2 u1, u = u2, pdf = 1 / (4 pi) everywhere (which is also
 * exactly what a constant map gives); info.uniform_fallback says so.
 *
 * Texels: negative, NaN and infinite channel values are set to 0 at
 * creation (lossy EXR codecs leave small negatives; a NaN would poison every
 * sum); info counts the texels concerned. A map read from a file (desc.path)
 * with no finite positive value at all is refused (SG_ERR_CORRUPT): an
 * all-NaN file would otherwise light a scene black without a word. Any map
 * whose power (or P_w) exceeds FLT_MAX / 2^24 is refused
 * (SG_ERR_INVALID_ARG): sums of light values over photons and samples
 * would overflow to infinity.
 *
 * Walkthrough:
 *     sg_envmap *env;
 *     sg_envmap_desc d = {.path = "city.exr", .rotation_deg = 90, .intensity = 2};
 *     if (sg_envmap_create(&d, &env, &err) != SG_OK) { report err.message; }
 *     float pdf;
 *     sg_vec3 w = sg_envmap_sample(env, u1, u2, &pdf);  // u1, u2 in [0,1)
 *     sg_vec3 L = sg_envmap_eval(env, w);                // estimate += L * f / pdf
 *     sg_envmap_destroy(env);
 *
 * Memory: the map copies the image (12 bytes a texel), keeps the sampling
 * weights (4 bytes a texel) and the CDFs in double (8 bytes a texel: a
 * texel 1e-12 of its row still gets a cell of positive width, so every lit
 * texel can be drawn). sg_envmap_destroy frees
 * all. Thread-safety: every query takes a const map and is thread-safe.
 * Errors (create only): SG_ERR_INVALID_ARG (no image and no path, bad
 * rotation or intensity, intensity overflowing a texel to infinity, power
 * overflowing), SG_ERR_CORRUPT (a file with no finite positive texel), the
 * readers' codes for a path (SG_ERR_IO, SG_ERR_CORRUPT, SG_ERR_UNSUPPORTED),
 * SG_ERR_NOMEM.
 */
#ifndef SG_ENVMAP_ENVMAP_H
#define SG_ENVMAP_ENVMAP_H

#include <stddef.h>

#include "core/error.h"
#include "io/image.h"
#include "math/vec3.h"

typedef struct sg_envmap sg_envmap;

/* Creation options; zero means the default. Exactly one of image or path. */
typedef struct sg_envmap_desc {
    const sg_image *image; /* lat-long radiance, copied (not kept)          */
    const char *path;      /* else: file read by sg_envmap_read_image       */
    float rotation_deg;    /* about +Y, right-hand rule; default 0          */
    float intensity;       /* radiance multiplier, finite, >= 0; 0 means 1  */
} sg_envmap_desc;

/* What creation found; see sg_envmap_get_info. */
typedef struct sg_envmap_info {
    int width, height;       /* texels                                     */
    size_t negative_texels;  /* texels with a channel < 0, set to 0        */
    size_t nonfinite_texels; /* texels with a NaN or +-Inf channel, set 0  */
    size_t positive_texels;  /* texels with a finite channel > 0           */
    float min_value;         /* most negative stored value (0 if none)     */
    float max_value;         /* largest channel after clamp and intensity  */
    int uniform_fallback;    /* 1: every texel black, sampling is uniform  */
    float sampling_power;    /* P_w (before intensity): sum of the texels'
                                sampling weights x solid angle; bounds
                                lum(eval) / pdf (see Sampling)             */
} sg_envmap_info;

/* Reads a lat-long image by extension: ".exr" (sg_exr_read, any
 * compression), ".hdr" / ".pic" (sg_hdr_read); other names by their magic
 * bytes; neither -> SG_ERR_UNSUPPORTED. *out is allocated here. */
sg_status sg_envmap_read_image(const char *path, sg_image *out, sg_error *err);

/* Builds the map and its sampling tables. On failure *out is untouched. */
sg_status sg_envmap_create(const sg_envmap_desc *desc, sg_envmap **out, sg_error *err);

/* Frees the map; NULL is a no-op. */
void sg_envmap_destroy(sg_envmap *m);

void sg_envmap_get_info(const sg_envmap *m, sg_envmap_info *info);

/* Mapping of the header: world direction (need not be unit; the zero or a
 * non-finite vector maps to (0.5, 0)) -> (u, v) in [0, 1]^2, rotation of m
 * applied; m == NULL means no rotation (the bare DESIGN.md mapping). */
void sg_envmap_dir_to_uv(const sg_envmap *m, sg_vec3 dir, float *u, float *v);

/* Inverse: (u, v) in [0, 1]^2 -> unit world direction; m may be NULL. */
sg_vec3 sg_envmap_uv_to_dir(const sg_envmap *m, float u, float v);

/* Radiance arriving from world direction dir (towards the map), including
 * intensity; >= 0 and finite. Bilinear (see Radiance). */
sg_vec3 sg_envmap_eval(const sg_envmap *m, sg_vec3 dir);

/* Texel (i, j) as stored (clamped, intensity applied): column i in [0, W),
 * row j in [0, H), row 0 the top. */
sg_vec3 sg_envmap_texel(const sg_envmap *m, int i, int j);

/* Draws a unit world direction for (u1, u2) in [0, 1)^2; *pdf (solid
 * angle, sr^-1) is > 0 and equals sg_envmap_pdf(m, result) exactly (the
 * direction is kept inside the texel it was drawn from). pdf may be NULL. */
sg_vec3 sg_envmap_sample(const sg_envmap *m, float u1, float u2, float *pdf);

/* Solid-angle density of sg_envmap_sample at world direction dir (0 where
 * the map is black, unless the map is all black). */
float sg_envmap_pdf(const sg_envmap *m, sg_vec3 dir);

/* The (u1, u2) that sg_envmap_sample maps to dir (within rounding); inside a
 * black texel, the value at which its zero-width CDF cell sits. */
void sg_envmap_invert(const sg_envmap *m, sg_vec3 dir, float *u1, float *u2);

/* Integral of the radiance (the bilinear lookup) over the sphere, per
 * channel, in closed form: in u a row integrates to its mean, in v each
 * row's hat function between texel centres is integrated against
 * sin(theta). Units: radiance x sr; the "power" of pbrt's light tests. */
sg_vec3 sg_envmap_power(const sg_envmap *m);

/* Solid-angle mean of the radiance: sg_envmap_power / (4 pi). */
sg_vec3 sg_envmap_mean_radiance(const sg_envmap *m);

/* Irradiance on a plane with unit normal n facing the map:
 * integral of L(w) max(0, n.w) dw, by the midpoint rule on 4 x 4 cells of
 * equal solid angle inside each texel (uniform in phi and cos theta), the
 * lookup taken at each cell's centre. Relative error below 1e-3 for
 * H >= 64 on smooth maps (the midpoint rule on a bilinear lookup and the
 * cosine's curvature).
 * Cost O(16 W H); meant for tests and one-off normalisation. */
sg_vec3 sg_envmap_irradiance(const sg_envmap *m, sg_vec3 n);

#endif
