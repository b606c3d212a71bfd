/* analytic.c — formula environment maps (see analytic.h for each model).
 *
 * Invariants:
 *  1. Every texel holds finite values >= 0.
 *  2. The STUDIO lights and the SUNSKY disk are integrated exactly over the
 *     texel solid angle dOmega_j = (2 pi / W)(cos(pi j/H) - cos(pi (j+1)/H)),
 *     the measure envmap.c uses, so the map's integral is their closed form
 *     up to float rounding (the sun after its rescale).
 */
#include "envmap/analytic.h"

#include <assert.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"

#define SG_PI 3.14159265358979323846
#define DEG (SG_PI / 180.0)

/* Subsamples per texel side for the sun disk's coverage. */
#define SUN_SUBSAMPLES 8

static const sg_analytic_light studio_lights[] = {
    /* key: large warm softbox front right, above the horizon */
    {20.0f, 50.0f, 15.0f, 40.0f, {40.0f, 38.0f, 34.0f}},
    /* fill: wide, dim, cool, on the other side */
    {-80.0f, -40.0f, 5.0f, 30.0f, {6.0f, 7.0f, 8.0f}},
    /* rim: tall strip behind */
    {165.0f, 175.0f, 0.0f, 50.0f, {25.0f, 25.0f, 25.0f}},
    /* top: thin overhead strip */
    {-30.0f, 30.0f, 75.0f, 82.0f, {15.0f, 15.0f, 15.0f}},
};
static const float studio_background = 0.03f;

static const sg_vec3 sky_horizon = {1.0f, 0.95f, 0.9f};
static const sg_vec3 sky_zenith = {0.25f, 0.45f, 1.0f};
static const sg_vec3 sky_ground = {0.2f, 0.18f, 0.15f};

const sg_analytic_light *sg_analytic_studio_lights(int *count)
{
    if (count)
        *count = (int)(sizeof studio_lights / sizeof studio_lights[0]);
    return studio_lights;
}

sg_vec3 sg_analytic_studio_power(void)
{
    double p[3];
    for (int c = 0; c < 3; c++)
        p[c] = studio_background * 4.0 * SG_PI;
    int n;
    const sg_analytic_light *l = sg_analytic_studio_lights(&n);
    for (int k = 0; k < n; k++) {
        double omega = (l[k].az1_deg - l[k].az0_deg) * DEG *
                       (sin(l[k].el1_deg * DEG) - sin(l[k].el0_deg * DEG));
        p[0] += l[k].radiance.x * omega;
        p[1] += l[k].radiance.y * omega;
        p[2] += l[k].radiance.z * omega;
    }
    return sg_v3((float)p[0], (float)p[1], (float)p[2]);
}

sg_vec3 sg_analytic_default_sun_dir(void)
{
    double el = 40.0 * DEG, az = 30.0 * DEG;
    return sg_v3((float)(cos(el) * cos(az)), (float)sin(el), (float)(cos(el) * sin(az)));
}

const char *sg_analytic_type_name(sg_analytic_type type)
{
    switch (type) {
    case SG_ANALYTIC_UNIFORM: return "uniform";
    case SG_ANALYTIC_SKY: return "sky";
    case SG_ANALYTIC_SUNSKY: return "sunsky";
    case SG_ANALYTIC_STUDIO: return "studio";
    }
    return NULL;
}

sg_status sg_analytic_type_parse(const char *name, sg_analytic_type *out, sg_error *err)
{
    assert(out);
    for (int t = SG_ANALYTIC_UNIFORM; t <= SG_ANALYTIC_STUDIO; t++) {
        if (name && strcmp(name, sg_analytic_type_name((sg_analytic_type)t)) == 0) {
            *out = (sg_analytic_type)t;
            return SG_OK;
        }
    }
    return sg_error_set(err, SG_ERR_INVALID_ARG,
                        "unknown envmap type \"%s\" (choose uniform, sky, sunsky or studio)",
                        name ? name : "(null)");
}

static sg_vec3 sky_at(double y)
{
    if (y < 0.0)
        return sky_ground;
    float t = (float)sqrt(y);
    return sg_v3_add(sky_horizon, sg_v3_scale(sg_v3_sub(sky_zenith, sky_horizon), t));
}

static void fill_sky(sg_image *img)
{
    const int W = img->width, H = img->height;
    for (int j = 0; j < H; j++) {
        /* Row centre direction's height; the sky does not depend on phi. */
        sg_vec3 L = sky_at(cos(SG_PI * (j + 0.5) / H));
        for (int i = 0; i < W; i++) {
            float *p = img->data + 3 * ((size_t)j * W + i);
            p[0] = L.x;
            p[1] = L.y;
            p[2] = L.z;
        }
    }
}

static inline double overlap(double a0, double a1, double b0, double b1)
{
    double lo = a0 > b0 ? a0 : b0, hi = a1 < b1 ? a1 : b1;
    return hi > lo ? hi - lo : 0.0;
}

static void fill_studio(sg_image *img)
{
    const int W = img->width, H = img->height;
    for (size_t t = 0; t < 3 * (size_t)W * H; t++)
        img->data[t] = studio_background;
    int n;
    const sg_analytic_light *l = sg_analytic_studio_lights(&n);
    for (int k = 0; k < n; k++) {
        /* The box in (phi, cos theta), where solid angle is area. */
        double phi0 = l[k].az0_deg * DEG, phi1 = l[k].az1_deg * DEG;
        double z0 = sin(l[k].el0_deg * DEG), z1 = sin(l[k].el1_deg * DEG);
        for (int j = 0; j < H; j++) {
            double c0 = cos(SG_PI * (j + 1) / H), c1 = cos(SG_PI * j / H); /* c0 < c1 */
            double fz = overlap(c0, c1, z0, z1) / (c1 - c0);
            if (fz <= 0.0)
                continue;
            for (int i = 0; i < W; i++) {
                double p0 = 2.0 * SG_PI * ((double)i / W - 0.5);
                double p1 = 2.0 * SG_PI * ((double)(i + 1) / W - 0.5);
                double f = fz * overlap(p0, p1, phi0, phi1) / (p1 - p0);
                if (f <= 0.0)
                    continue;
                float *p = img->data + 3 * ((size_t)j * W + i);
                p[0] += (float)(f * l[k].radiance.x);
                p[1] += (float)(f * l[k].radiance.y);
                p[2] += (float)(f * l[k].radiance.z);
            }
        }
    }
}

/* Adds the sun disk (invariant 2); needs a scratch array of W * H floats
 * for the coverage fractions. */
static sg_status add_sun(sg_image *img, sg_vec3 sun, double radius, double radiance, sg_error *err)
{
    const int W = img->width, H = img->height;
    float *cover = sg_calloc_array((size_t)W * (size_t)H, sizeof(float)); /* fraction per texel */
    if (!cover)
        return sg_error_set(err, SG_ERR_NOMEM, "sunsky %dx%d: out of memory", W, H);
    const double cos_r = cos(radius);
    /* Rows that can touch the disk: theta within radius of the sun's. */
    double theta_s = acos(fmax(-1.0, fmin(1.0, (double)sun.y)));
    int j0 = (int)floor((theta_s - radius) / SG_PI * H) - 1;
    int j1 = (int)floor((theta_s + radius) / SG_PI * H) + 1;
    j0 = j0 < 0 ? 0 : j0;
    j1 = j1 > H - 1 ? H - 1 : j1;
    double weighted = 0.0; /* sum over texels of coverage * dOmega */
    for (int j = j0; j <= j1; j++) {
        double c_top = cos(SG_PI * j / H), c_bot = cos(SG_PI * (j + 1) / H);
        double d_omega = (c_top - c_bot) * 2.0 * SG_PI / W;
        for (int i = 0; i < W; i++) {
            int hits = 0;
            /* Subsamples of equal solid angle: uniform in phi and cos. */
            for (int b = 0; b < SUN_SUBSAMPLES; b++) {
                double c = c_top + (c_bot - c_top) * (b + 0.5) / SUN_SUBSAMPLES;
                double s = sqrt(fmax(0.0, 1.0 - c * c));
                for (int a = 0; a < SUN_SUBSAMPLES; a++) {
                    double phi = 2.0 * SG_PI * ((i + (a + 0.5) / SUN_SUBSAMPLES) / W - 0.5);
                    double dot = s * cos(phi) * sun.x + c * sun.y + s * sin(phi) * sun.z;
                    hits += dot >= cos_r;
                }
            }
            if (hits) {
                float f = (float)hits / (SUN_SUBSAMPLES * SUN_SUBSAMPLES);
                cover[(size_t)j * W + i] = f;
                weighted += f * d_omega;
            }
        }
    }
    const double disk_omega = 2.0 * SG_PI * (1.0 - cos_r);
    if (weighted <= 0.0) {
        /* Disk smaller than the subsample spacing: all of it in one texel. */
        float u = (float)(0.5 + atan2(sun.z, sun.x) / (2.0 * SG_PI));
        float v = (float)(acos(fmax(-1.0, fmin(1.0, (double)sun.y))) / SG_PI);
        int i = (int)fmin(W - 1, fmax(0.0, floor(u * W)));
        int j = (int)fmin(H - 1, fmax(0.0, floor(v * H)));
        cover[(size_t)j * W + i] = 1.0f;
        weighted = (cos(SG_PI * j / H) - cos(SG_PI * (j + 1) / H)) * 2.0 * SG_PI / W;
    }
    double scale = radiance * disk_omega / weighted;
    for (size_t t = 0; t < (size_t)W * H; t++) {
        if (cover[t] > 0.0f) {
            float add = (float)(cover[t] * scale);
            img->data[3 * t + 0] += add;
            img->data[3 * t + 1] += add;
            img->data[3 * t + 2] += add;
        }
    }
    sg_free(cover);
    return SG_OK;
}

sg_status sg_analytic_make(const sg_analytic_desc *desc, sg_image *out, sg_error *err)
{
    assert(out);
    sg_analytic_desc d = desc ? *desc : (sg_analytic_desc){0};
    const char *name = sg_analytic_type_name(d.type);
    if (!name)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "analytic envmap: unknown type %d", (int)d.type);
    if (d.width < 0 || d.height < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: size %dx%d is negative", name, d.width,
                            d.height);
    if (d.width == 0)
        d.width = d.height ? (d.height > SG_IMAGE_MAX_DIM / 2 ? SG_IMAGE_MAX_DIM : 2 * d.height) : 1024;
    if (d.height == 0)
        d.height = d.width / 2 > 0 ? d.width / 2 : 1;
    if (d.width > SG_IMAGE_MAX_DIM || d.height > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: size %dx%d is out of range (1..%d)", name,
                            d.width, d.height, SG_IMAGE_MAX_DIM);
    if (d.radiance.x == 0.0f && d.radiance.y == 0.0f && d.radiance.z == 0.0f)
        d.radiance = sg_v3(1.0f, 1.0f, 1.0f);
    if (!sg_v3_isfinite(d.radiance) || d.radiance.x < 0.0f || d.radiance.y < 0.0f ||
        d.radiance.z < 0.0f)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: radiance (%g, %g, %g) is not finite and >= 0",
                            name, (double)d.radiance.x, (double)d.radiance.y, (double)d.radiance.z);
    if (d.sun_radius_deg == 0.0f)
        d.sun_radius_deg = 0.5f;
    if (d.sun_radiance == 0.0f)
        d.sun_radiance = 1e5f;
    if (!isfinite(d.sun_radius_deg) || d.sun_radius_deg < 0.0f || d.sun_radius_deg > 90.0f ||
        !isfinite(d.sun_radiance) || d.sun_radiance < 0.0f)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: sun radius %g deg (0..90) or radiance %g (>= 0) out of range", name,
                            (double)d.sun_radius_deg, (double)d.sun_radiance);
    sg_vec3 sun = sg_v3_normalize(d.sun_dir);
    if (!sg_v3_isfinite(d.sun_dir) || sg_v3_dot(sun, sun) == 0.0f)
        sun = sg_analytic_default_sun_dir();

    sg_image img = {0};
    sg_status st = sg_image_alloc(&img, d.width, d.height, err);
    if (st != SG_OK)
        return st;
    switch (d.type) {
    case SG_ANALYTIC_UNIFORM:
        for (size_t t = 0; t < (size_t)d.width * d.height; t++) {
            img.data[3 * t + 0] = d.radiance.x;
            img.data[3 * t + 1] = d.radiance.y;
            img.data[3 * t + 2] = d.radiance.z;
        }
        break;
    case SG_ANALYTIC_SKY: fill_sky(&img); break;
    case SG_ANALYTIC_SUNSKY:
        fill_sky(&img);
        st = add_sun(&img, sun, d.sun_radius_deg * DEG, d.sun_radiance, err);
        break;
    case SG_ANALYTIC_STUDIO: fill_studio(&img); break;
    }
    if (st != SG_OK) {
        sg_image_free(&img);
        return st;
    }
    *out = img;
    return SG_OK;
}
