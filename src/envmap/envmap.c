/* envmap.c — lat-long environment map: lookup, importance sampling
 * (pbrt-v4 4th ed. §12.5.2 "Image Infinite Lights" and §A.5 piecewise
 * constant 2D distributions), inverse warp and integrals.
 *
 * One deviation from pbrt: pbrt samples (u, v) uniformly inside the chosen
 * texel and weights rows by sin(theta) at the row centre, so its
 * solid-angle pdf varies as 1/sin(theta) inside a texel. Here rows are
 * weighted by their exact solid angle and the direction is uniform in
 * (cos theta, phi) inside the texel, so pdf = lum(texel) / P exactly and
 * the lookup and the pdf are the same piecewise-constant function.
 *
 * Invariants:
 *  1. rgb holds finite values >= 0 (clamped at creation, intensity applied).
 *  2. marg[0] = 0, marg[H] = 1, nondecreasing; the same for each row of
 *     cond (W+1 entries); a black row has the uniform CDF i/W.
 *  3. find_cell returns a cell of positive width whenever the CDF has one
 *     (largest k with cdf[k] <= u), so a zero-weight row or texel is never
 *     drawn.
 *  4. sg_envmap_sample returns a direction whose texel (texel_of, the
 *     function eval and pdf use) is the texel it drew: the sampled pdf and
 *     sg_envmap_pdf agree bit for bit.
 *  5. power == 0 exactly when every texel is black (uniform fallback).
 */
#include "envmap/envmap.h"

#include <assert.h>
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
    double *cond;         /* H rows of W+1 conditional CDF entries (inv. 2)  */
    double *marg;         /* H+1 marginal CDF entries over rows (inv. 2)     */
    double *row_cos;      /* H+1 values cos(pi j / H): row j spans [j+1, j]  */
    double power;         /* P = sum lum dOmega (invariant 5)                */
    float inv_power;      /* 1 / P, or 0 in the uniform fallback             */
    float cos_rot, sin_rot; /* rotation about +Y (header "Rotation")        */
    sg_vec3 power_rgb;    /* sum rgb dOmega, per channel                      */
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

static inline float texel_lum(const sg_envmap *m, int i, int j)
{
    const float *p = m->rgb + 3 * ((size_t)j * (size_t)m->width + (size_t)i);
    return LUM_R * p[0] + LUM_G * p[1] + LUM_B * p[2];
}

static inline float texel_pdf(const sg_envmap *m, int i, int j)
{
    if (m->info.uniform_fallback)
        return (float)(1.0 / (4.0 * SG_PI));
    return texel_lum(m, i, j) * m->inv_power;
}

sg_vec3 sg_envmap_eval(const sg_envmap *m, sg_vec3 dir)
{
    assert(m);
    int i, j;
    texel_of(m, dir, &i, &j);
    const float *p = m->rgb + 3 * ((size_t)j * (size_t)m->width + (size_t)i);
    return sg_v3(p[0], p[1], p[2]);
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
    enum { SUB = 4 }; /* subcells per texel side: see the header's error bound */
    const int W = m->width, H = m->height;
    sg_vec3 nm = sg_v3_normalize(to_map(m, n));
    /* cos(phi), sin(phi) of every subcolumn centre, shared by all rows. */
    double sum[3] = {0, 0, 0};
    for (int j = 0; j < H; j++) {
        double c0 = m->row_cos[j], c1 = m->row_cos[j + 1];
        double d_omega = (c0 - c1) * (2.0 * SG_PI / W) / (SUB * SUB); /* per subcell */
        for (int i = 0; i < W; i++) {
            double cos_sum = 0.0; /* sum of max(0, n.w) over the subcells */
            for (int sj = 0; sj < SUB; sj++) {
                double c = c0 + (c1 - c0) * (sj + 0.5) / SUB;
                double s = sqrt(fmax(0.0, 1.0 - c * c));
                for (int si = 0; si < SUB; si++) {
                    double phi = 2.0 * SG_PI * (((double)i + (si + 0.5) / SUB) / W - 0.5);
                    double dot = nm.x * s * cos(phi) + nm.y * c + nm.z * s * sin(phi);
                    if (dot > 0.0)
                        cos_sum += dot;
                }
            }
            if (cos_sum > 0.0) {
                const float *p = m->rgb + 3 * ((size_t)j * (size_t)W + (size_t)i);
                for (int k = 0; k < 3; k++)
                    sum[k] += p[k] * cos_sum * d_omega;
            }
        }
    }
    return sg_v3((float)sum[0], (float)sum[1], (float)sum[2]);
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
    sg_free(m->cond);
    sg_free(m->marg);
    sg_free(m->row_cos);
    sg_free(m);
}

/* Copies the image, clamps bad values, applies intensity (invariant 1). */
static sg_status copy_texels(sg_envmap *m, const sg_image *img, float intensity, const char *name,
                             sg_error *err)
{
    size_t n = (size_t)img->width * (size_t)img->height;
    float max_value = 0.0f, min_value = 0.0f;
    for (size_t t = 0; t < n; t++) {
        int negative = 0, nonfinite = 0;
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
            x *= intensity;
            if (!isfinite(x))
                return sg_error_set(err, SG_ERR_INVALID_ARG,
                                    "%s: texel (%zu, %zu): intensity %g makes the value %g overflow",
                                    name, t % (size_t)img->width, t / (size_t)img->width,
                                    (double)intensity, (double)img->data[3 * t + c]);
            if (x > max_value)
                max_value = x;
            m->rgb[3 * t + c] = x;
        }
        m->info.negative_texels += (size_t)negative;
        m->info.nonfinite_texels += (size_t)nonfinite;
    }
    m->info.min_value = min_value;
    m->info.max_value = max_value;
    return SG_OK;
}

/* Builds row_cos, cond, marg, power (invariants 2 and 5). */
static void build_tables(sg_envmap *m)
{
    const int W = m->width, H = m->height;
    for (int j = 0; j <= H; j++)
        m->row_cos[j] = cos(SG_PI * j / H);
    m->row_cos[0] = 1.0;
    m->row_cos[H] = -1.0;
    double power = 0.0, prgb[3] = {0, 0, 0};
    m->marg[0] = 0.0;
    for (int j = 0; j < H; j++) {
        double d_omega = (m->row_cos[j] - m->row_cos[j + 1]) * (2.0 * SG_PI / W);
        double *row = m->cond + (size_t)j * (size_t)(W + 1);
        double acc = 0.0;
        row[0] = 0.0;
        for (int i = 0; i < W; i++) {
            const float *p = m->rgb + 3 * ((size_t)j * (size_t)W + (size_t)i);
            acc += (double)texel_lum(m, i, j);
            row[i + 1] = acc;
            for (int c = 0; c < 3; c++)
                prgb[c] += (double)p[c] * d_omega;
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
    m->power_rgb = sg_v3((float)prgb[0], (float)prgb[1], (float)prgb[2]);
}

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
        !(m->cond = sg_alloc_array(cond_count, sizeof(double))) ||
        !(m->marg = sg_alloc_array(H + 1, sizeof(double))) ||
        !(m->row_cos = sg_alloc_array(H + 1, sizeof(double)))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for a %zux%zu map", name, W, H);
        goto fail;
    }
    m->width = img->width;
    m->height = img->height;
    m->info.width = img->width;
    m->info.height = img->height;
    double rot = (double)desc->rotation_deg * (SG_PI / 180.0);
    m->cos_rot = (float)cos(rot);
    m->sin_rot = (float)sin(rot);

    st = copy_texels(m, img, intensity, name, err);
    if (st != SG_OK)
        goto fail;
    build_tables(m);
    sg_image_free(&loaded);
    *out = m;
    return SG_OK;

fail:
    sg_envmap_destroy(m);
    sg_image_free(&loaded);
    return st;
}
