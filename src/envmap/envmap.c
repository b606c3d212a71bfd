/* envmap.c — lat-long environment map: bilinear lookup, importance
 * sampling (pbrt-v4 4th ed. §12.5.2 "Image Infinite Lights" and §A.5
 * piecewise constant 2D distributions), inverse warp and integrals.
 *
 * Lookup: bilinear between texel centres, as Blender and pbrt look maps up
 * (nearest texels made a 1k map behind a model look blocky).
 * Sampling: piecewise constant per texel, as pbrt, with two deviations.
 * (1) pbrt samples (u, v) uniformly inside the chosen texel and weights
 * rows by sin(theta) at the row centre, so its solid-angle pdf varies as
 * 1/sin(theta) inside a texel; here rows are weighted by their exact solid
 * angle and the direction is uniform in (cos theta, phi) inside the texel,
 * so the pdf is constant on a texel. (2) A texel's weight is not its own
 * luminance but the largest luminance the bilinear lookup takes inside it
 * (a bilinear function peaks at a corner of each quadrant: the centre, the
 * edge midpoints or the corners, so 9 candidate points). Hence
 *     pdf(d) > 0 wherever eval(d) != 0   (a black texel next to a lit one
 *                                         is lit near their border), and
 *     lum(eval(d)) / pdf(d) <= W_total   (no firefly from the lookup
 *                                         rising inside a texel),
 * W_total = sum of weight x texel solid angle (info.sampling_power).
 *
 * Invariants:
 *  1. rgb holds finite values >= 0 (clamped at creation), before intensity
 *     (applied after interpolating, so scaling a map scales every lookup
 *     exactly); weight holds each texel's sampling weight (2) above.
 *  2. marg[0] = 0, marg[H] = 1, nondecreasing; the same for each row of
 *     cond (W+1 entries), both over weight x solid angle; a row of zero
 *     weight has the uniform CDF i/W.
 *  3. find_cell returns a cell of positive width whenever the CDF has one
 *     (largest k with cdf[k] <= u), so a zero-weight row or texel is never
 *     drawn.
 *  4. sg_envmap_sample returns a direction whose texel (texel_of, the
 *     function eval and pdf use) is the texel it drew: the sampled pdf and
 *     sg_envmap_pdf agree bit for bit.
 *  5. power == 0 exactly when every texel is black (uniform fallback).
 *  6. power_rgb is the exact integral of the bilinear lookup over the
 *     sphere (closed form per row of texel centres, integrate_rows).
 */
#include "envmap/envmap.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "core/alloc.h"
#include "io/exr_read.h"
#include "io/hdr.h"

#define SG_PI 3.14159265358979323846

/* Rec.709 / sRGB luminance weights (ITU-R BT.709, Y row of RGB->XYZ). */
#define LUM_R 0.2126f
#define LUM_G 0.7152f
#define LUM_B 0.0722f

struct sg_envmap {
    int width, height;    /* W, H texels                                     */
    float *rgb;           /* 3 W H radiance, row 0 top, invariant 1           */
    float *weight;        /* W H sampling weights, invariant 1                */
    float intensity;      /* applied after interpolation (invariant 1)       */
    double *cond;         /* H rows of W+1 conditional CDF entries (inv. 2)  */
    double *marg;         /* H+1 marginal CDF entries over rows (inv. 2)     */
    double *row_cos;      /* H+1 values cos(pi j / H): row j spans [j+1, j]  */
    double power;         /* P = sum weight dOmega (invariant 5)             */
    float inv_power;      /* 1 / P, or 0 in the uniform fallback             */
    float cos_rot, sin_rot; /* rotation about +Y (header "Rotation")        */
    sg_vec3 power_rgb;    /* integral of the lookup, per channel (inv. 6)    */
    double power_rgb_d[3];/* the same in double, for the overflow check      */
    sg_envmap_info info;  /* what creation found                              */
};

/* ---- reading ------------------------------------------------------------ */

static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), m = strlen(ext);
    return n > m && strcasecmp(path + n - m, ext) == 0;
}

sg_status sg_envmap_read_image(const char *path, sg_image *out, sg_error *err)
{
    assert(out);
    if (!path || !path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "environment map path is empty");
    if (has_ext(path, ".exr"))
        return sg_exr_read(path, out, NULL, err);
    if (has_ext(path, ".hdr") || has_ext(path, ".pic"))
        return sg_hdr_read(path, out, err);
    /* Unknown name: look at the magic bytes. */
    unsigned char magic[4] = {0};
    FILE *f = fopen(path, "rb");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open", path);
    size_t got = fread(magic, 1, sizeof magic, f);
    fclose(f);
    if (got == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01)
        return sg_exr_read(path, out, NULL, err);
    if (got >= 2 && magic[0] == '#' && magic[1] == '?')
        return sg_hdr_read(path, out, err);
    return sg_error_set(err, SG_ERR_UNSUPPORTED,
                        "%s: neither OpenEXR nor Radiance .hdr (by extension or magic bytes)", path);
}

/* ---- mapping --------------------------------------------------------------- */

/* World -> map space: R_y(-angle). */
static inline sg_vec3 to_map(const sg_envmap *m, sg_vec3 d)
{
    if (!m)
        return d;
    return sg_v3(d.x * m->cos_rot - d.z * m->sin_rot, d.y, d.x * m->sin_rot + d.z * m->cos_rot);
}

/* Map -> world space: R_y(angle). */
static inline sg_vec3 to_world(const sg_envmap *m, sg_vec3 d)
{
    if (!m)
        return d;
    return sg_v3(d.x * m->cos_rot + d.z * m->sin_rot, d.y, -d.x * m->sin_rot + d.z * m->cos_rot);
}

/* Map-space direction -> (u, v); NaN-safe: a degenerate vector gives
 * (0.5, 0), the +Y pole. */
static inline void map_uv(sg_vec3 d, float *u, float *v)
{
    float len = sg_v3_length(d);
    float y = len > 0.0f && isfinite(len) ? d.y / len : 1.0f;
    y = y > 1.0f ? 1.0f : (y < -1.0f ? -1.0f : y);
    float phi = isfinite(len) ? atan2f(d.z, d.x) : 0.0f;
    *u = 0.5f + phi * (float)(0.5 / SG_PI);
    *v = acosf(y) * (float)(1.0 / SG_PI);
}

/* Texel index along one axis for coordinate t in [0, 1]; the comparison
 * form keeps a NaN (which cannot occur after map_uv) away from the cast. */
static inline int cell_index(float t, int n)
{
    float x = t * (float)n;
    if (!(x >= 0.0f))
        return 0;
    if (x >= (float)(n - 1))
        return n - 1;
    return (int)x;
}

/* The texel eval and pdf use for world direction w (invariant 4). */
static inline void texel_of(const sg_envmap *m, sg_vec3 w, int *i, int *j)
{
    float u, v;
    map_uv(to_map(m, w), &u, &v);
    *i = cell_index(u, m->width);
    *j = cell_index(v, m->height);
}

void sg_envmap_dir_to_uv(const sg_envmap *m, sg_vec3 dir, float *u, float *v)
{
    float uu, vv;
    map_uv(to_map(m, dir), &uu, &vv);
    if (u)
        *u = uu;
    if (v)
        *v = vv;
}

static inline sg_vec3 map_dir_from(double cos_theta, double u)
{
    double sin_theta = sqrt(fmax(0.0, 1.0 - cos_theta * cos_theta));
    double phi = 2.0 * SG_PI * (u - 0.5);
    return sg_v3((float)(sin_theta * cos(phi)), (float)cos_theta, (float)(sin_theta * sin(phi)));
}

sg_vec3 sg_envmap_uv_to_dir(const sg_envmap *m, float u, float v)
{
    return to_world(m, map_dir_from(cos(SG_PI * (double)v), (double)u));
}

/* ---- lookup ------------------------------------------------------------------ */

static inline const float *texel(const sg_envmap *m, int i, int j)
{
    return m->rgb + 3 * ((size_t)j * (size_t)m->width + (size_t)i);
}

static inline float texel_pdf(const sg_envmap *m, int i, int j)
{
    if (m->info.uniform_fallback)
        return (float)(1.0 / (4.0 * SG_PI));
    return m->weight[(size_t)j * (size_t)m->width + (size_t)i] * m->inv_power;
}

/* Bilinear lookup at map coordinates (u, v) in [0, 1]^2, before intensity:
 * between texel centres ((i + 0.5) / W, (j + 0.5) / H), wrapping in u and
 * clamping in v (above the first row's centres and below the last row's
 * the value is their row's). */
static inline void bilerp(const sg_envmap *m, float u, float v, float out[3])
{
    const int W = m->width, H = m->height;
    float x = u * (float)W - 0.5f, y = v * (float)H - 0.5f;
    float fx = floorf(x);
    float s = x - fx;
    int i0 = (int)fx, i1 = i0 + 1;
    if (i0 < 0)
        i0 += W;
    if (i0 >= W)
        i0 -= W;
    if (i1 >= W)
        i1 -= W;
    int j0, j1;
    float t;
    if (!(y > 0.0f)) { /* NaN-safe: cannot occur after map_uv */
        j0 = j1 = 0;
        t = 0.0f;
    } else if (y >= (float)(H - 1)) {
        j0 = j1 = H - 1;
        t = 0.0f;
    } else {
        j0 = (int)y;
        j1 = j0 + 1;
        t = y - (float)j0;
    }
    const float *a = texel(m, i0, j0), *b = texel(m, i1, j0), *c = texel(m, i0, j1), *d = texel(m, i1, j1);
    for (int k = 0; k < 3; k++) {
        float top = a[k] + s * (b[k] - a[k]), bottom = c[k] + s * (d[k] - c[k]);
        float r = top + t * (bottom - top);
        out[k] = r > 0.0f ? r : 0.0f; /* rounding of the differences */
    }
}

sg_vec3 sg_envmap_eval(const sg_envmap *m, sg_vec3 dir)
{
    assert(m);
    float u, v, L[3];
    map_uv(to_map(m, dir), &u, &v);
    bilerp(m, u, v, L);
    return sg_v3(L[0] * m->intensity, L[1] * m->intensity, L[2] * m->intensity);
}

sg_vec3 sg_envmap_texel(const sg_envmap *m, int i, int j)
{
    assert(m && i >= 0 && i < m->width && j >= 0 && j < m->height);
    const float *p = texel(m, i, j);
    return sg_v3(p[0] * m->intensity, p[1] * m->intensity, p[2] * m->intensity);
}

float sg_envmap_pdf(const sg_envmap *m, sg_vec3 dir)
{
    assert(m);
    int i, j;
    texel_of(m, dir, &i, &j);
    return texel_pdf(m, i, j);
}

/* ---- sampling ------------------------------------------------------------------ */

/* Largest k in [0, n-1] with cdf[k] <= u, for u in [0, 1) (invariant 3). */
static int find_cell(const double *cdf, int n, double u)
{
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = lo + (hi - lo + 1) / 2;
        if (cdf[mid] <= u)
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

/* Position of u inside cell [a, b): in [0, 1]. */
static inline double cell_fraction(double u, double a, double b)
{
    double t = b > a ? (u - a) / (b - a) : 0.5;
    return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
}

/* Nudges applied to the in-texel fractions when rounding put the direction
 * into a neighbouring texel (invariant 4): each pulls (t - 0.5) closer to
 * the centre; the last one is the centre itself, which lies half a texel
 * from every edge, far beyond float rounding. */
static const double nudge[] = {1.0, 0.999, 0.99, 0.9, 0.5, 0.0};

sg_vec3 sg_envmap_sample(const sg_envmap *m, float u1, float u2, float *pdf)
{
    assert(m);
    /* Clamp into [0, 1); NaN becomes 0 (the comparison form is NaN-safe). */
    double a = !(u1 >= 0.0f) ? 0.0 : (u1 >= 1.0f ? 0x1.fffffffffffffp-1 : (double)u1);
    double b = !(u2 >= 0.0f) ? 0.0 : (u2 >= 1.0f ? 0x1.fffffffffffffp-1 : (double)u2);
    if (m->info.uniform_fallback) {
        if (pdf)
            *pdf = (float)(1.0 / (4.0 * SG_PI));
        return to_world(m, map_dir_from(1.0 - 2.0 * a, b));
    }
    const int W = m->width, H = m->height;
    int j = find_cell(m->marg, H, a);
    const double *row = m->cond + (size_t)j * (size_t)(W + 1);
    int i = find_cell(row, W, b);
    double t1 = cell_fraction(a, m->marg[j], m->marg[j + 1]);
    double t2 = cell_fraction(b, row[i], row[i + 1]);
    sg_vec3 w = {0, 1, 0};
    for (size_t k = 0; k < sizeof nudge / sizeof nudge[0]; k++) {
        double s1 = 0.5 + (t1 - 0.5) * nudge[k], s2 = 0.5 + (t2 - 0.5) * nudge[k];
        /* Uniform in solid angle inside the texel: linear in cos theta. */
        double c = m->row_cos[j] + s1 * (m->row_cos[j + 1] - m->row_cos[j]);
        w = to_world(m, map_dir_from(c, ((double)i + s2) / (double)W));
        int ci, cj;
        texel_of(m, w, &ci, &cj);
        if (ci == i && cj == j)
            break;
    }
    if (pdf)
        *pdf = texel_pdf(m, i, j);
    return w;
}

/* The largest float below 1 for anything at or above 1: the warp's domain
 * is [0, 1). */
static inline float below_one(double x)
{
    float f = (float)x;
    return f < 1.0f ? f : 0x1.fffffep-1f;
}

void sg_envmap_invert(const sg_envmap *m, sg_vec3 dir, float *u1, float *u2)
{
    assert(m);
    sg_vec3 d = sg_v3_normalize(to_map(m, dir));
    if (!sg_v3_isfinite(d) || sg_v3_dot(d, d) == 0.0f)
        d = sg_v3(0, 1, 0); /* the same fallback as map_uv */
    float u, v;
    map_uv(d, &u, &v);
    double cos_theta = d.y > 1.0f ? 1.0 : (d.y < -1.0f ? -1.0 : (double)d.y);
    double r1, r2;
    if (m->info.uniform_fallback) {
        r1 = 0.5 * (1.0 - cos_theta);
        r2 = u;
    } else {
        const int W = m->width, H = m->height;
        int i = cell_index(u, W), j = cell_index(v, H);
        const double *row = m->cond + (size_t)j * (size_t)(W + 1);
        double c0 = m->row_cos[j], c1 = m->row_cos[j + 1]; /* c0 > c1 */
        double t1 = (c0 - cos_theta) / (c0 - c1);
        t1 = t1 < 0.0 ? 0.0 : (t1 > 1.0 ? 1.0 : t1);
        double t2 = (double)u * W - i;
        t2 = t2 < 0.0 ? 0.0 : (t2 > 1.0 ? 1.0 : t2);
        r1 = m->marg[j] + t1 * (m->marg[j + 1] - m->marg[j]);
        r2 = row[i] + t2 * (row[i + 1] - row[i]);
    }
    if (u1)
        *u1 = below_one(r1);
    if (u2)
        *u2 = below_one(r2);
}

/* ---- integrals ------------------------------------------------------------------- */

sg_vec3 sg_envmap_power(const sg_envmap *m)
{
    assert(m);
    return m->power_rgb;
}

sg_vec3 sg_envmap_mean_radiance(const sg_envmap *m)
{
    assert(m);
    return sg_v3_scale(m->power_rgb, (float)(1.0 / (4.0 * SG_PI)));
}

sg_vec3 sg_envmap_irradiance(const sg_envmap *m, sg_vec3 n)
{
    assert(m);
    enum { SUB = 4, BLOCK = 512 }; /* subcells per texel side (header's bound); subcolumns a block */
    const int W = m->width, H = m->height, SW = SUB * W;
    sg_vec3 nm = sg_v3_normalize(to_map(m, n));
    double sum[3] = {0, 0, 0};
    /* Subcolumns in blocks, each block's cos and sin of phi and bilinear
     * neighbours in u (bilerp's rule, wrapping) computed once for all rows. */
    double cs[BLOCK][2];
    int col[BLOCK][2];
    float cw[BLOCK];
    for (int k0 = 0; k0 < SW; k0 += BLOCK) {
        int nk = SW - k0 < BLOCK ? SW - k0 : BLOCK;
        for (int b = 0; b < nk; b++) {
            double uu = ((double)(k0 + b) + 0.5) / SW, phi = 2.0 * SG_PI * (uu - 0.5);
            cs[b][0] = cos(phi);
            cs[b][1] = sin(phi);
            float x = (float)uu * (float)W - 0.5f, fx = floorf(x);
            int i0 = (int)fx;
            col[b][0] = i0 < 0 ? i0 + W : i0;
            col[b][1] = i0 + 1 >= W ? i0 + 1 - W : i0 + 1;
            cw[b] = x - fx;
        }
        for (int j = 0; j < H; j++) {
            double c0 = m->row_cos[j], c1 = m->row_cos[j + 1];
            double d_omega = (c0 - c1) * (2.0 * SG_PI / W) / (SUB * SUB); /* per subcell */
            for (int sj = 0; sj < SUB; sj++) {
                double c = c0 + (c1 - c0) * (sj + 0.5) / SUB;
                double st = sqrt(fmax(0.0, 1.0 - c * c));
                /* bilerp's rows and weight at this subrow (clamped in v) */
                float y = (float)(acos(c) / SG_PI) * (float)H - 0.5f, t = 0.0f;
                int j0, j1;
                if (!(y > 0.0f)) {
                    j0 = j1 = 0;
                } else if (y >= (float)(H - 1)) {
                    j0 = j1 = H - 1;
                } else {
                    j0 = (int)y;
                    j1 = j0 + 1;
                    t = y - (float)j0;
                }
                for (int b = 0; b < nk; b++) {
                    double dot = nm.x * st * cs[b][0] + nm.y * c + nm.z * st * cs[b][1];
                    if (!(dot > 0.0))
                        continue;
                    const float *p00 = texel(m, col[b][0], j0), *p10 = texel(m, col[b][1], j0);
                    const float *p01 = texel(m, col[b][0], j1), *p11 = texel(m, col[b][1], j1);
                    float s = cw[b];
                    for (int q = 0; q < 3; q++) {
                        float top = p00[q] + s * (p10[q] - p00[q]), bottom = p01[q] + s * (p11[q] - p01[q]);
                        float L = top + t * (bottom - top);
                        sum[q] += (L > 0.0f ? L : 0.0f) * dot * d_omega;
                    }
                }
            }
        }
    }
    return sg_v3((float)(sum[0] * m->intensity), (float)(sum[1] * m->intensity), (float)(sum[2] * m->intensity));
}

/* ---- creation ---------------------------------------------------------------------- */

void sg_envmap_get_info(const sg_envmap *m, sg_envmap_info *info)
{
    assert(m && info);
    *info = m->info;
}

void sg_envmap_destroy(sg_envmap *m)
{
    if (!m)
        return;
    sg_free(m->rgb);
    sg_free(m->weight);
    sg_free(m->cond);
    sg_free(m->marg);
    sg_free(m->row_cos);
    sg_free(m);
}

/* Copies the image and clamps bad values (invariant 1); checks that the
 * intensity does not overflow a texel; counts what it changed. */
static sg_status copy_texels(sg_envmap *m, const sg_image *img, float intensity, const char *name,
                             sg_error *err)
{
    size_t n = (size_t)img->width * (size_t)img->height;
    float max_value = 0.0f, min_value = 0.0f;
    for (size_t t = 0; t < n; t++) {
        int negative = 0, nonfinite = 0, positive = 0;
        for (int c = 0; c < 3; c++) {
            float x = img->data[3 * t + c];
            if (!isfinite(x)) {
                nonfinite = 1;
                x = 0.0f;
            } else if (x < 0.0f) {
                negative = 1;
                if (x < min_value)
                    min_value = x;
                x = 0.0f;
            }
            positive |= x > 0.0f;
            if (!isfinite(x * intensity))
                return sg_error_set(err, SG_ERR_INVALID_ARG,
                                    "%s: texel (%zu, %zu): intensity %g makes the value %g overflow",
                                    name, t % (size_t)img->width, t / (size_t)img->width,
                                    (double)intensity, (double)img->data[3 * t + c]);
            if (x * intensity > max_value)
                max_value = x * intensity;
            m->rgb[3 * t + c] = x;
        }
        m->info.negative_texels += (size_t)negative;
        m->info.nonfinite_texels += (size_t)nonfinite;
        m->info.positive_texels += (size_t)positive;
    }
    m->info.min_value = min_value;
    m->info.max_value = max_value;
    return SG_OK;
}

static inline double lum_at(const sg_envmap *m, int i, int j)
{
    const float *p = texel(m, i, j);
    return (double)LUM_R * p[0] + (double)LUM_G * p[1] + (double)LUM_B * p[2];
}

/* Sampling weight of every texel: the largest luminance the bilinear
 * lookup takes in it (header deviation 2). Neighbours wrap in u and clamp
 * in v, as bilerp does. */
static void build_weights(sg_envmap *m)
{
    const int W = m->width, H = m->height;
    for (int j = 0; j < H; j++) {
        int ju = j > 0 ? j - 1 : 0, jd = j + 1 < H ? j + 1 : H - 1;
        for (int i = 0; i < W; i++) {
            int il = i > 0 ? i - 1 : W - 1, ir = i + 1 < W ? i + 1 : 0;
            double c = lum_at(m, i, j), l = lum_at(m, il, j), r = lum_at(m, ir, j);
            double up = lum_at(m, i, ju), dn = lum_at(m, i, jd);
            double w = c;
            const double edge[4] = {l, r, up, dn};
            for (int k = 0; k < 4; k++)
                w = fmax(w, 0.5 * (c + edge[k]));
            w = fmax(w, 0.25 * (c + l + up + lum_at(m, il, ju)));
            w = fmax(w, 0.25 * (c + r + up + lum_at(m, ir, ju)));
            w = fmax(w, 0.25 * (c + l + dn + lum_at(m, il, jd)));
            w = fmax(w, 0.25 * (c + r + dn + lum_at(m, ir, jd)));
            /* Rounded up to a float, so the bound of the header holds. */
            float f = (float)w;
            if ((double)f < w)
                f = nextafterf(f, INFINITY);
            m->weight[(size_t)j * (size_t)W + (size_t)i] = f;
        }
    }
}

/* pi x integral over [a, b] of the linear function through (a, ya) and
 * (b, yb) times sin(pi v): the solid angle per unit u a hat-shaped weight
 * sweeps (dOmega = 2 pi du . pi sin(pi v) dv). The differences are written
 * without cancellation-prone cos(a) - cos(b). */
static double weighted_band(double a, double b, double ya, double yb)
{
    if (!(b > a))
        return 0.0;
    const double pi = SG_PI, h = b - a;
    /* int_a^b sin(pi v) dv = 2 sin(pi (a + b) / 2) sin(pi h / 2) / pi */
    double i0 = 2.0 * sin(pi * (a + b) / 2.0) * sin(pi * h / 2.0) / pi;
    /* int_a^b (v - a) sin(pi v) dv = -h cos(pi b) / pi + (sin pi b - sin pi a) / pi^2 */
    double i1 = -h * cos(pi * b) / pi + 2.0 * cos(pi * (a + b) / 2.0) * sin(pi * h / 2.0) / (pi * pi);
    return pi * (ya * i0 + (yb - ya) / h * i1);
}

/* Exact integral of the bilinear lookup (invariant 6). In u the linear
 * interpolation of a periodic row integrates to the row's mean; in v the
 * lookup is sum_j row_j h_j(v) with hat functions h_j between the centres
 * v_j = (j + 0.5) / H, flat above v_0 and below v_H-1. */
static void integrate_rows(sg_envmap *m)
{
    const int W = m->width, H = m->height;
    double p[3] = {0, 0, 0};
    for (int j = 0; j < H; j++) {
        double vj = (j + 0.5) / H, omega = 0.0;
        if (j == 0)
            omega += weighted_band(0.0, vj, 1.0, 1.0);
        else
            omega += weighted_band((j - 0.5) / H, vj, 0.0, 1.0);
        if (j == H - 1)
            omega += weighted_band(vj, 1.0, 1.0, 1.0);
        else
            omega += weighted_band(vj, (j + 1.5) / H, 1.0, 0.0);
        double row[3] = {0, 0, 0};
        for (int i = 0; i < W; i++)
            for (int c = 0; c < 3; c++)
                row[c] += texel(m, i, j)[c];
        for (int c = 0; c < 3; c++)
            p[c] += row[c] / W * 2.0 * SG_PI * omega;
    }
    for (int c = 0; c < 3; c++)
        m->power_rgb_d[c] = p[c] * m->intensity;
}

/* Builds row_cos, cond, marg, power (invariants 2 and 5). */
static void build_tables(sg_envmap *m)
{
    const int W = m->width, H = m->height;
    for (int j = 0; j <= H; j++)
        m->row_cos[j] = cos(SG_PI * j / H);
    m->row_cos[0] = 1.0;
    m->row_cos[H] = -1.0;
    double power = 0.0;
    m->marg[0] = 0.0;
    for (int j = 0; j < H; j++) {
        double d_omega = (m->row_cos[j] - m->row_cos[j + 1]) * (2.0 * SG_PI / W);
        double *row = m->cond + (size_t)j * (size_t)(W + 1);
        const float *wt = m->weight + (size_t)j * (size_t)W;
        double acc = 0.0;
        row[0] = 0.0;
        for (int i = 0; i < W; i++) {
            acc += (double)wt[i];
            row[i + 1] = acc;
        }
        if (acc > 0.0) {
            for (int i = 1; i < W; i++)
                row[i] /= acc;
        } else {
            for (int i = 1; i < W; i++)
                row[i] = (double)i / W;
        }
        row[W] = 1.0;
        power += acc * d_omega;
        m->marg[j + 1] = power;
    }
    if (power > 0.0) {
        for (int j = 1; j < H; j++)
            m->marg[j] /= power;
    } else {
        for (int j = 1; j < H; j++)
            m->marg[j] = (double)j / H;
    }
    m->marg[H] = 1.0;
    m->power = power;
    m->inv_power = power > 0.0 ? (float)(1.0 / power) : 0.0f;
    m->info.uniform_fallback = !(power > 0.0);
    m->info.sampling_power = (float)power;
    integrate_rows(m);
    m->power_rgb = sg_v3((float)m->power_rgb_d[0], (float)m->power_rgb_d[1], (float)m->power_rgb_d[2]);
}

/* Light values are summed over many photons and samples: keep 2^24 of
 * float's range free above a map's power. */
#define POWER_MAX (FLT_MAX / 16777216.0)

sg_status sg_envmap_create(const sg_envmap_desc *desc, sg_envmap **out, sg_error *err)
{
    assert(out);
    if (!desc)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "envmap: desc is NULL");
    if ((desc->image != NULL) == (desc->path != NULL))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "envmap: give exactly one of image and path");
    const char *name = desc->path ? desc->path : "envmap image";
    if (!isfinite(desc->rotation_deg))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: rotation %g is not finite", name,
                            (double)desc->rotation_deg);
    if (!isfinite(desc->intensity) || desc->intensity < 0.0f)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: intensity %g is not finite and >= 0", name,
                            (double)desc->intensity);
    float intensity = desc->intensity == 0.0f ? 1.0f : desc->intensity;

    sg_status st = SG_OK;
    sg_image loaded = {0}; /* the file's pixels when desc->path is used */
    sg_envmap *m = NULL;
    const sg_image *img = desc->image;
    if (desc->path) {
        st = sg_envmap_read_image(desc->path, &loaded, err);
        if (st != SG_OK)
            return st;
        img = &loaded;
    }
    if (!img->data || img->width <= 0 || img->height <= 0 || img->width > SG_IMAGE_MAX_DIM ||
        img->height > SG_IMAGE_MAX_DIM) {
        st = sg_error_set(err, SG_ERR_INVALID_ARG, "%s: image is empty or has a bad size %dx%d", name,
                          img->width, img->height);
        goto fail;
    }

    const size_t W = (size_t)img->width, H = (size_t)img->height;
    size_t texels, cond_count;
    m = sg_calloc_array(1, sizeof *m);
    if (!m) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", name);
        goto fail;
    }
    if (!sg_mul_size(W, H, &texels) || !sg_mul_size(W + 1, H, &cond_count) ||
        !(m->rgb = sg_alloc_array(texels, 3 * sizeof(float))) ||
        !(m->weight = sg_alloc_array(texels, sizeof(float))) ||
        !(m->cond = sg_alloc_array(cond_count, sizeof(double))) ||
        !(m->marg = sg_alloc_array(H + 1, sizeof(double))) ||
        !(m->row_cos = sg_alloc_array(H + 1, sizeof(double)))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for a %zux%zu map", name, W, H);
        goto fail;
    }
    m->width = img->width;
    m->height = img->height;
    m->intensity = intensity;
    m->info.width = img->width;
    m->info.height = img->height;
    double rot = (double)desc->rotation_deg * (SG_PI / 180.0);
    m->cos_rot = (float)cos(rot);
    m->sin_rot = (float)sin(rot);

    st = copy_texels(m, img, intensity, name, err);
    if (st != SG_OK)
        goto fail;
    /* A map read from a file with nothing finite and positive in it (all
     * NaN, say) would light the scene black without a word: refuse it. An
     * image made in memory may be black on purpose (a dark sky). */
    if (desc->path && m->info.positive_texels == 0) {
        st = sg_error_set(err, SG_ERR_CORRUPT,
                          "%s: no texel has a finite positive value (%zu of %zu texels NaN or infinite, %zu "
                          "negative): not a usable environment map",
                          name, m->info.nonfinite_texels, texels, m->info.negative_texels);
        goto fail;
    }
    build_weights(m);
    build_tables(m);
    double worst = m->power * intensity; /* the sampling weights' power bounds f / pdf */
    for (int c = 0; c < 3; c++)
        worst = fmax(worst, m->power_rgb_d[c]);
    if (!(worst <= POWER_MAX)) {
        st = sg_error_set(err, SG_ERR_INVALID_ARG,
                          "%s: the map's power (radiance over the sphere, intensity %g applied) is %.3g, more than "
                          "sums of light values can hold (%.3g); its largest texel is %.3g",
                          name, (double)intensity, worst, (double)POWER_MAX, (double)m->info.max_value);
        goto fail;
    }
    sg_image_free(&loaded);
    *out = m;
    return SG_OK;

fail:
    sg_envmap_destroy(m);
    sg_image_free(&loaded);
    return st;
}
