/* test_envmap.c — environment map lookup and sampling (src/envmap/envmap.c)
 * and the analytic maps (src/envmap/analytic.c).
 *
 * 1. Mapping: the axes of DESIGN.md; uv -> dir -> uv and dir -> uv -> dir;
 *    rotation moves what the map shows from d to R_y(angle) d, both ways.
 * 2. Warp trio: invert(sample(u)) = u, sample(invert(d)) = d; the pdf
 *    returned by sample equals sg_envmap_pdf bit for bit; pdf integrates to
 *    1 (exactly per texel, and on an unaligned grid within a derived bound).
 * 3. Chi-square of sampled directions against weight x solid angle, the
 *    weights (the largest bilinear luminance in each texel) computed here
 *    from the image, on half-texel cells (so the in-texel distribution is
 *    tested too); alpha = 0.01, Sidak-corrected over the maps; cells pooled
 *    to >= 5 expected; fixed seed; black texels never drawn.
 * 4. Estimators: power by importance sampling and by uniform sampling vs
 *    the integral of the bilinear lookup (Gauss-Legendre here), within
 *    4 sigma / sqrt(N); L / pdf bounded by the sampling power; the studio
 *    map's pixel sum vs its closed form; tiny-sun irradiance variance under
 *    importance sampling vs uniform sampling (bound derived below).
 * 6. Bilinear lookup: against a reference written here from the formula of
 *    envmap.h, continuous across the u seam and near the poles; no
 *    direction with eval > 0 and pdf 0 on sparse maps.
 * 5. Texels: negative / NaN / Inf values counted and zeroed; intensity;
 *    the all-black map falls back to uniform sampling; bad arguments; the
 *    real maps load by path (.exr and .hdr) and count their negatives.
 */
#include "test_support.h"
#include "test_stats.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "envmap/analytic.h"
#include "envmap/envmap.h"
#include "io/image.h"
#include "math/rng.h"

#define PI 3.14159265358979323846
#define SEED 20240611u

/* ---- helpers ------------------------------------------------------------- */

static sg_envmap *make_map(const sg_image *img, float rotation_deg, float intensity)
{
    sg_envmap_desc d = {.image = img, .rotation_deg = rotation_deg, .intensity = intensity};
    sg_envmap *m = NULL;
    sg_error err = {0};
    sg_status st = sg_envmap_create(&d, &m, &err);
    if (st != SG_OK)
        fail_msg("sg_envmap_create: %s: %s", sg_status_name(st), err.message);
    return m;
}

static sg_image make_analytic(sg_analytic_type type, int w, int h)
{
    sg_analytic_desc d = {.type = type, .width = w, .height = h};
    sg_image img = {0};
    sg_error err = {0};
    sg_status st = sg_analytic_make(&d, &img, &err);
    if (st != SG_OK)
        fail_msg("sg_analytic_make(%s): %s: %s", sg_analytic_type_name(type), sg_status_name(st), err.message);
    return img;
}

/* R_y(a) of envmap.h, in double. */
static sg_vec3 rot_y(sg_vec3 d, double deg)
{
    double a = deg * PI / 180.0, c = cos(a), s = sin(a);
    return sg_v3((float)(d.x * c + d.z * s), d.y, (float)(-d.x * s + d.z * c));
}

static double lum_of(const float *p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

/* Solid angle of a texel in row j of an H-row, W-column map. */
static double texel_omega(int j, int W, int H)
{
    return (cos(PI * j / H) - cos(PI * (j + 1) / H)) * 2.0 * PI / W;
}

static float u01(uint64_t item, uint32_t dim) { return sg_rng_float(SEED, item, 0, dim); }

/* Texel (i, j) of img with envmap.h's wrap in u and clamp in v. */
static const float *texel_wc(const sg_image *img, int i, int j)
{
    const int W = img->width, H = img->height;
    i = ((i % W) + W) % W;
    j = j < 0 ? 0 : j >= H ? H - 1 : j;
    return img->data + 3 * ((size_t)j * W + i);
}

/* The bilinear lookup of envmap.h at (u, v), in double, from the image. */
static void bilinear_ref(const sg_image *img, double u, double v, double out[3])
{
    double x = u * img->width - 0.5, y = v * img->height - 0.5;
    double fx = floor(x), s = x - fx;
    int i = (int)fx;
    int j0, j1;
    double t;
    if (y <= 0.0) {
        j0 = j1 = 0, t = 0.0;
    } else if (y >= img->height - 1) {
        j0 = j1 = img->height - 1, t = 0.0;
    } else {
        j0 = (int)floor(y), j1 = j0 + 1, t = y - j0;
    }
    for (int c = 0; c < 3; c++) {
        double a = texel_wc(img, i, j0)[c], b = texel_wc(img, i + 1, j0)[c];
        double cc = texel_wc(img, i, j1)[c], d = texel_wc(img, i + 1, j1)[c];
        out[c] = (1 - t) * ((1 - s) * a + s * b) + t * ((1 - s) * cc + s * d);
    }
}

/* A texel's sampling weight (envmap.h): the largest luminance of the
 * bilinear lookup inside it, found among its centre, 4 edge midpoints and
 * 4 corners (averages of itself and its neighbours, wrap/clamp). */
static double weight_ref(const sg_image *img, int i, int j)
{
    double w = 0.0;
    for (int dj = -1; dj <= 1; dj++)
        for (int di = -1; di <= 1; di++) {
            /* the point half a texel towards (di, dj): average of the texels
             * spanning it */
            double sum = 0.0;
            int n = 0;
            for (int a = 0; a <= (di != 0); a++)
                for (int b = 0; b <= (dj != 0); b++) {
                    sum += lum_of(texel_wc(img, i + a * di, j + b * dj));
                    n++;
                }
            w = fmax(w, sum / n);
        }
    return w;
}

/* Sum of weight x solid angle: the sampling power P_w of envmap.h. */
static double sampling_power_ref(const sg_image *img)
{
    double p = 0.0;
    for (int j = 0; j < img->height; j++)
        for (int i = 0; i < img->width; i++)
            p += weight_ref(img, i, j) * texel_omega(j, img->width, img->height);
    return p;
}

/* Integral of the bilinear lookup over the sphere, per channel: in u a
 * row's linear interpolation integrates to its mean (periodic); in v the
 * lookup is piecewise linear between row centres (flat beyond the first
 * and last), integrated against 2 pi . pi sin(pi v) by 8-point
 * Gauss-Legendre on each piece (error far below float rounding). */
static void bilinear_power_ref(const sg_image *img, double out[3])
{
    static const double gx[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                                 -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                                 0.7966664774136267,  0.9602898564975363};
    static const double gw[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
                                 0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
    const int W = img->width, H = img->height;
    out[0] = out[1] = out[2] = 0.0;
    for (int k = -1; k < H; k++) { /* piece between centres k and k + 1 (caps at -1 and H - 1) */
        double a = k < 0 ? 0.0 : (k + 0.5) / H, b = k + 1 >= H ? 1.0 : (k + 1.5) / H;
        int ja = k < 0 ? 0 : k, jb = k + 1 >= H ? H - 1 : k + 1;
        double ma[3] = {0, 0, 0}, mb[3] = {0, 0, 0};
        for (int i = 0; i < W; i++)
            for (int c = 0; c < 3; c++) {
                ma[c] += img->data[3 * ((size_t)ja * W + i) + c] / W;
                mb[c] += img->data[3 * ((size_t)jb * W + i) + c] / W;
            }
        for (int g = 0; g < 8; g++) {
            double v = 0.5 * (a + b) + 0.5 * (b - a) * gx[g], t = (v - a) / (b - a);
            double wv = gw[g] * 0.5 * (b - a) * 2.0 * PI * PI * sin(PI * v);
            for (int c = 0; c < 3; c++)
                out[c] += ((1 - t) * ma[c] + t * mb[c]) * wv;
        }
    }
}

/* A uniformly distributed unit direction. */
static sg_vec3 uniform_dir(uint64_t item)
{
    double z = 1.0 - 2.0 * u01(item, 10), phi = 2.0 * PI * u01(item, 11);
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    return sg_v3((float)(r * cos(phi)), (float)z, (float)(r * sin(phi)));
}

/* ---- 1. mapping ------------------------------------------------------------ */

static void expect_uv(const sg_envmap *m, sg_vec3 d, double u, double v, const char *what)
{
    float gu, gv;
    sg_envmap_dir_to_uv(m, d, &gu, &gv);
    double du = fabs(gu - u);
    du = fmin(du, 1.0 - du); /* u wraps */
    if (!(du < 1e-6 && fabs(gv - v) < 1e-6))
        fail_msg("%s: dir (%g, %g, %g) -> uv (%.8g, %.8g), want (%.8g, %.8g)", what, (double)d.x, (double)d.y,
                 (double)d.z, (double)gu, (double)gv, u, v);
}

static void test_envmap_mapping_axes_and_roundtrip(void **state)
{
    (void)state;
    /* DESIGN.md: centre column looks along +X; u = 0.5 + atan2(z, x)/2pi. */
    expect_uv(NULL, sg_v3(1, 0, 0), 0.5, 0.5, "+X");
    expect_uv(NULL, sg_v3(0, 0, 1), 0.75, 0.5, "+Z");
    expect_uv(NULL, sg_v3(0, 0, -1), 0.25, 0.5, "-Z");
    expect_uv(NULL, sg_v3(-1, 0, 0), 1.0, 0.5, "-X");
    expect_uv(NULL, sg_v3(0, 1, 0), 0.5, 0.0, "+Y");
    expect_uv(NULL, sg_v3(0, -1, 0), 0.5, 1.0, "-Y");
    expect_uv(NULL, sg_v3(2, 0, 0), 0.5, 0.5, "+X, not unit");

    sg_image img = make_analytic(SG_ANALYTIC_SKY, 16, 8);
    const double angles[] = {0.0, 90.0, 37.5, -123.0};
    for (size_t a = 0; a < sizeof angles / sizeof angles[0]; a++) {
        sg_envmap *m = make_map(&img, (float)angles[a], 0);
        /* uv -> dir -> uv on a grid away from the poles. */
        for (int iv = 1; iv < 40; iv++)
            for (int iu = 0; iu < 80; iu++) {
                float u = (iu + 0.5f) / 80, v = iv / 40.0f;
                sg_vec3 d = sg_envmap_uv_to_dir(m, u, v);
                if (fabsf(sg_v3_length(d) - 1.0f) > 1e-6f)
                    fail_msg("rot %g: uv (%g, %g) -> |d| = %.9g", angles[a], (double)u, (double)v,
                             (double)sg_v3_length(d));
                expect_uv(m, d, u, v, "uv->dir->uv");
                /* Rotation: the rotated map's (u, v) is R_y(angle) of the
                 * unrotated map's direction. */
                sg_vec3 d0 = sg_envmap_uv_to_dir(NULL, u, v), d1 = rot_y(d0, angles[a]);
                if (sg_v3_length(sg_v3_sub(d, d1)) > 2e-6f)
                    fail_msg("rot %g: uv (%g, %g): got (%g, %g, %g), want R_y d0 = (%g, %g, %g)", angles[a],
                             (double)u, (double)v, (double)d.x, (double)d.y, (double)d.z, (double)d1.x,
                             (double)d1.y, (double)d1.z);
            }
        /* dir -> uv -> dir for random directions. */
        for (uint64_t k = 0; k < 2000; k++) {
            sg_vec3 d = uniform_dir(k);
            float u, v;
            sg_envmap_dir_to_uv(m, d, &u, &v);
            sg_vec3 back = sg_envmap_uv_to_dir(m, u, v);
            if (sg_v3_length(sg_v3_sub(back, d)) > 2e-6f)
                fail_msg("rot %g: dir (%g, %g, %g) -> uv (%g, %g) -> (%g, %g, %g)", angles[a], (double)d.x,
                         (double)d.y, (double)d.z, (double)u, (double)v, (double)back.x, (double)back.y,
                         (double)back.z);
            /* Same (u, v) as the unrotated map at R_y(-angle) d. */
            expect_uv(NULL, rot_y(d, -angles[a]), u, v, "dir_to_uv with rotation");
        }
        sg_envmap_destroy(m);
    }
    /* Right-hand rule: +90 deg turns the centre column (+X) to -Z. */
    sg_envmap *m90 = make_map(&img, 90.0f, 0);
    expect_uv(m90, sg_v3(0, 0, -1), 0.5, 0.5, "rotation +90: centre column looks along -Z");
    sg_envmap_destroy(m90);
    sg_image_free(&img);
}

/* eval of the rotated map at R_y(a) d is the bilinear lookup of the
 * unrotated image at d: at texel centres the texel, inside texels the
 * blend of the 4 nearest centres (a nearest-texel lookup, which made maps
 * behind a model blocky, is 12 to 36 units off here). Tolerance: float
 * directions carry ~1e-7 rad, ~1e-6 texel, times the largest step between
 * neighbouring texels (72): 1e-4; 1e-5 of the values covers it. */
static void test_envmap_eval_bilinear_and_rotation(void **state)
{
    (void)state;
    const int W = 24, H = 12;
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, W, H, NULL), SG_OK);
    for (int t = 0; t < W * H; t++)
        for (int c = 0; c < 3; c++)
            img.data[3 * t + c] = (float)(t * 3 + c + 1);
    const double tol = 1e-5 * 3 * W * H;
    const float angles[] = {0.0f, 90.0f, 200.0f, -17.0f};
    for (size_t a = 0; a < sizeof angles / sizeof angles[0]; a++) {
        sg_envmap *m = make_map(&img, angles[a], 2.0f);
        for (int j = 0; j < H; j++)
            for (int i = 0; i < W; i++)
                /* The centre and several points inside texel (i, j). */
                for (int s = 0; s < 5; s++) {
                    float fu = s == 4 ? 0.5f : 0.1f + 0.8f * (s & 1), fv = s == 4 ? 0.5f : 0.1f + 0.8f * (s >> 1);
                    double u = (i + fu) / (double)W, v = (j + fv) / (double)H;
                    sg_vec3 d = sg_envmap_uv_to_dir(NULL, (float)u, (float)v);
                    sg_vec3 L = sg_envmap_eval(m, rot_y(d, angles[a]));
                    double want[3];
                    bilinear_ref(&img, u, v, want);
                    if (fabs(L.x - 2 * want[0]) > tol || fabs(L.y - 2 * want[1]) > tol ||
                        fabs(L.z - 2 * want[2]) > tol)
                        fail_msg("rot %g: texel (%d, %d) point %d: eval (%g, %g, %g), want 2 x (%g, %g, %g)",
                                 (double)angles[a], i, j, s, (double)L.x, (double)L.y, (double)L.z, want[0], want[1],
                                 want[2]);
                    if (s == 4) {
                        sg_vec3 T = sg_envmap_texel(m, i, j);
                        const float *p = img.data + 3 * (j * W + i);
                        assert_true(T.x == 2 * p[0] && T.y == 2 * p[1] && T.z == 2 * p[2]);
                    }
                }
        sg_envmap_destroy(m);
    }
    sg_image_free(&img);
}

/* The lookup is continuous: across the u seam (u = 0 is u = 1) and around
 * the poles (flat above the first row of centres), steps of 1e-4 change it
 * by no more than the gradient allows; a nearest lookup jumps a whole
 * texel step there. */
static void test_envmap_eval_continuous(void **state)
{
    (void)state;
    const int W = 16, H = 8;
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, W, H, NULL), SG_OK);
    for (int t = 0; t < W * H; t++)
        for (int c = 0; c < 3; c++)
            img.data[3 * t + c] = (float)((t * 7919) % 101) + 1.0f;
    sg_envmap *m = make_map(&img, 0.0f, 0);
    /* Largest change per unit of u or v: 100 (value range) per texel. */
    const double h = 1e-4, lip = 100.0 * (W > H ? W : H), tol = 2.0 * lip * h + 1e-3;
    for (int k = 0; k < 400; k++) {
        double v = (k + 0.5) / 400.0;
        sg_vec3 a = sg_envmap_eval(m, sg_envmap_uv_to_dir(NULL, (float)(1.0 - h), (float)v));
        sg_vec3 b = sg_envmap_eval(m, sg_envmap_uv_to_dir(NULL, (float)h, (float)v));
        if (fabs(a.x - b.x) > tol)
            fail_msg("seam at v %g: %g left, %g right (tolerance %g)", v, (double)a.x, (double)b.x, tol);
        double u = (k + 0.5) / 400.0;
        sg_vec3 c = sg_envmap_eval(m, sg_envmap_uv_to_dir(NULL, (float)u, (float)(u * 0.999)));
        sg_vec3 d = sg_envmap_eval(m, sg_envmap_uv_to_dir(NULL, (float)(u + h), (float)(u * 0.999)));
        if (fabs(c.y - d.y) > tol)
            fail_msg("u %g: step of %g in u changed the lookup from %g to %g", u, h, (double)c.y, (double)d.y);
    }
    sg_envmap_destroy(m);
    sg_image_free(&img);
}

/* ---- 2. warp trio ------------------------------------------------------------ */

typedef struct test_map {
    const char *name;  /* for messages            */
    sg_image img;      /* radiance                */
    float rotation;    /* degrees                 */
    sg_envmap *m;      /* built from img          */
} test_map;

/* The maps most tests run on: smooth, blocky with bright boxes, a
 * tiny-sun map, each at a different rotation and aspect. */
static void make_test_maps(test_map maps[3])
{
    maps[0] = (test_map){"sky 32x16", make_analytic(SG_ANALYTIC_SKY, 32, 16), 0.0f, NULL};
    maps[1] = (test_map){"studio 64x32 rot 45", make_analytic(SG_ANALYTIC_STUDIO, 64, 32), 45.0f, NULL};
    maps[2] = (test_map){"sunsky 96x40 rot -70", make_analytic(SG_ANALYTIC_SUNSKY, 96, 40), -70.0f, NULL};
    for (int k = 0; k < 3; k++)
        maps[k].m = make_map(&maps[k].img, maps[k].rotation, 0);
}

static void free_test_maps(test_map maps[3])
{
    for (int k = 0; k < 3; k++) {
        sg_envmap_destroy(maps[k].m);
        sg_image_free(&maps[k].img);
    }
}

static void test_envmap_invert_roundtrip(void **state)
{
    (void)state;
    test_map maps[3];
    make_test_maps(maps);
    for (int k = 0; k < 3; k++) {
        const sg_envmap *m = maps[k].m;
        double worst = 0.0;
        for (uint64_t n = 0; n < 50000; n++) {
            float u1 = u01(n, 0), u2 = u01(n, 1), pdf, b1, b2;
            sg_vec3 d = sg_envmap_sample(m, u1, u2, &pdf);
            sg_envmap_invert(m, d, &b1, &b2);
            double e = fmax(fabs(b1 - u1), fabs(b2 - u2));
            worst = fmax(worst, e);
            /* Float directions carry ~1e-7 rad; the steepest CDF here (the
             * sun texel, ~60% of the mass over ~1/100 of a row's cos range)
             * magnifies that to ~1e-5. */
            if (e > 1e-4)
                fail_msg("%s: u (%.8g, %.8g) -> d (%g, %g, %g) -> u (%.8g, %.8g)", maps[k].name, (double)u1,
                         (double)u2, (double)d.x, (double)d.y, (double)d.z, (double)b1, (double)b2);
        }
        /* sample(invert(d)) = d wherever the map is lit (pdf > 0). */
        for (uint64_t n = 0; n < 20000; n++) {
            sg_vec3 d = uniform_dir(n);
            if (!(sg_envmap_pdf(m, d) > 0.0f))
                continue;
            float b1, b2;
            sg_envmap_invert(m, d, &b1, &b2);
            sg_vec3 back = sg_envmap_sample(m, b1, b2, NULL);
            if (sg_v3_length(sg_v3_sub(back, d)) > 1e-4f)
                fail_msg("%s: d (%g, %g, %g) -> u (%.8g, %.8g) -> (%g, %g, %g)", maps[k].name, (double)d.x,
                         (double)d.y, (double)d.z, (double)b1, (double)b2, (double)back.x, (double)back.y,
                         (double)back.z);
        }
        print_message("%s: worst |invert(sample(u)) - u| = %.3g\n", maps[k].name, worst);
    }
    free_test_maps(maps);
}

static void test_envmap_sample_pdf_matches_pdf(void **state)
{
    (void)state;
    test_map maps[3];
    make_test_maps(maps);
    for (int k = 0; k < 3; k++) {
        const sg_envmap *m = maps[k].m;
        for (uint64_t n = 0; n < 100000; n++) {
            float u1 = u01(n, 2), u2 = u01(n, 3), pdf = -1.0f;
            sg_vec3 d = sg_envmap_sample(m, u1, u2, &pdf);
            float q = sg_envmap_pdf(m, d);
            sg_vec3 L = sg_envmap_eval(m, d);
            if (!(pdf > 0.0f) || pdf != q || fabsf(sg_v3_length(d) - 1.0f) > 1e-6f ||
                !(L.x + L.y + L.z > 0.0f))
                fail_msg("%s: u (%.8g, %.8g): d (%g, %g, %g), sample pdf %.9g, sg_envmap_pdf %.9g, L (%g, %g, %g)",
                         maps[k].name, (double)u1, (double)u2, (double)d.x, (double)d.y, (double)d.z, (double)pdf,
                         (double)q, (double)L.x, (double)L.y, (double)L.z);
        }
        /* The edges of [0, 1)^2 too. */
        const float edge[] = {0.0f, 0x1.fffffep-1f, 0.5f};
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) {
                float pdf;
                sg_vec3 d = sg_envmap_sample(m, edge[a], edge[b], &pdf);
                assert_true(pdf > 0.0f && pdf == sg_envmap_pdf(m, d));
            }
    }
    free_test_maps(maps);
}

/* Sum of pdf x solid angle, exactly per texel: every texel's pdf is read
 * through the public pdf at a direction inside it (its centre, rotated). */
static double pdf_texel_sum(const sg_envmap *m, int W, int H, float rotation)
{
    double sum = 0.0;
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            sg_vec3 d = rot_y(sg_envmap_uv_to_dir(NULL, (i + 0.5f) / W, (j + 0.5f) / H), rotation);
            sum += (double)sg_envmap_pdf(m, d) * texel_omega(j, W, H);
        }
    return sum;
}

/* Midpoint rule on an n x n grid uniform in (phi, z) (equal solid angle
 * 4 pi / n^2 per cell), unaligned with the texels. Bound: the pdf is
 * constant on each texel, so a cell inside one texel contributes no error;
 * a cell whose corners lie in different texels errs by at most
 * (max - min of the pdf at its corners and centre) x its solid angle —
 * these cells are far smaller than a texel, so only texels touching a
 * corner can overlap them. *bound receives the sum of those terms. */
static double pdf_grid_sum(const sg_envmap *m, int n, double *bound)
{
    const double d_omega = 4.0 * PI / ((double)n * n);
    double sum = 0.0, b = 0.0;
    for (int iz = 0; iz < n; iz++)
        for (int ip = 0; ip < n; ip++) {
            double z[3] = {-1.0 + 2.0 * iz / n, -1.0 + 2.0 * (iz + 0.5) / n, -1.0 + 2.0 * (iz + 1) / n};
            double p[3] = {2.0 * PI * ip / n, 2.0 * PI * (ip + 0.5) / n, 2.0 * PI * (ip + 1) / n};
            float lo = INFINITY, hi = -INFINITY, centre = 0.0f;
            for (int a = 0; a < 3; a++)
                for (int c = 0; c < 3; c++) {
                    if ((a == 1) != (c == 1))
                        continue; /* corners and the centre */
                    double r = sqrt(fmax(0.0, 1.0 - z[a] * z[a]));
                    float q = sg_envmap_pdf(m, sg_v3((float)(r * cos(p[c])), (float)z[a], (float)(r * sin(p[c]))));
                    lo = fminf(lo, q);
                    hi = fmaxf(hi, q);
                    if (a == 1)
                        centre = q;
                }
            sum += centre * d_omega;
            b += (hi - lo) * d_omega;
        }
    *bound = b;
    return sum;
}

static void test_envmap_pdf_integrates_to_one(void **state)
{
    (void)state;
    test_map maps[3];
    make_test_maps(maps);
    for (int k = 0; k < 3; k++) {
        double s = pdf_texel_sum(maps[k].m, maps[k].img.width, maps[k].img.height, maps[k].rotation);
        /* pdf is a float per texel (relative rounding 6e-8). */
        if (fabs(s - 1.0) > 1e-6)
            fail_msg("%s: sum over texels of pdf x solid angle = %.9f", maps[k].name, s);
        double bound;
        double g = pdf_grid_sum(maps[k].m, 1024, &bound);
        print_message("%s: texel sum %.9f, grid sum %.6f (bound %.2g)\n", maps[k].name, s, g, bound);
        if (fabs(g - 1.0) > bound + 1e-6)
            fail_msg("%s: grid sum of pdf x solid angle = %.6f, outside 1 +- %.3g", maps[k].name, g, bound);
    }
    free_test_maps(maps);
}

/* ---- 3. chi-square ------------------------------------------------------------ */


/* Pearson chi-square over cells, pooling cells with < 5 expected into one
 * (pbrt-v4 chi2test). Returns the p-value; a count in a zero-expected cell
 * fails the test at once. */
static double chi2_pvalue(const double *observed, const double *expected, size_t n, const char *name, int *dof_out)
{
    double chi2 = 0.0, pool_o = 0.0, pool_e = 0.0;
    int dof = 0;
    for (size_t k = 0; k < n; k++) {
        if (expected[k] == 0.0) {
            if (observed[k] > 0.0)
                fail_msg("%s: cell %zu has expected 0 but %g samples", name, k, observed[k]);
            continue;
        }
        if (expected[k] < 5.0) {
            pool_o += observed[k];
            pool_e += expected[k];
            continue;
        }
        double diff = observed[k] - expected[k];
        chi2 += diff * diff / expected[k];
        dof++;
    }
    if (pool_e > 0.0) {
        double diff = pool_o - pool_e;
        chi2 += diff * diff / pool_e;
        dof++;
    }
    dof -= 1;
    *dof_out = dof;
    return sg_test_gamma_q(0.5 * dof, 0.5 * chi2);
}

static void test_envmap_chi_square(void **state)
{
    (void)state;
    test_map maps[3];
    make_test_maps(maps);
    const int n_maps = 3;
    const double alpha = 0.01;
    const double alpha_each = 1.0 - pow(1.0 - alpha, 1.0 / n_maps); /* Sidak */
    const uint64_t N = 1000000;
    for (int k = 0; k < n_maps; k++) {
        const int W = maps[k].img.width, H = maps[k].img.height;
        /* Cells: each texel split in half in u and in half of its solid
         * angle in cos theta (rotation about +Y keeps cos theta = d.y). */
        size_t cells = (size_t)4 * W * H;
        double *obs = calloc(cells, sizeof(double)), *expct = calloc(cells, sizeof(double));
        assert_true(obs && expct);
        double P = sampling_power_ref(&maps[k].img);
        for (int j = 0; j < H; j++)
            for (int i = 0; i < W; i++) {
                double p = weight_ref(&maps[k].img, i, j) * texel_omega(j, W, H) / P;
                for (int s = 0; s < 4; s++)
                    expct[4 * ((size_t)j * W + i) + s] = N * p / 4.0;
            }
        for (uint64_t n = 0; n < N; n++) {
            sg_vec3 d = sg_envmap_sample(maps[k].m, u01(n, 4), u01(n, 5), NULL);
            float u, v;
            sg_envmap_dir_to_uv(maps[k].m, d, &u, &v);
            int i = (int)fminf(W - 1, fmaxf(0, floorf(u * W))), j = (int)fminf(H - 1, fmaxf(0, floorf(v * H)));
            int right = u * W - i >= 0.5f;
            double mid = 0.5 * (cos(PI * j / H) + cos(PI * (j + 1) / H));
            int lower = d.y < mid;
            obs[4 * ((size_t)j * W + i) + 2 * lower + right] += 1.0;
        }
        int dof;
        double pval = chi2_pvalue(obs, expct, cells, maps[k].name, &dof);
        print_message("%s: chi-square over %zu cells, dof %d, p = %.4f (reject below %.5f)\n", maps[k].name, cells,
                      dof, pval, alpha_each);
        if (!(pval >= alpha_each)) {
            /* Dump the table for plotting, as pbrt does. */
            char path[700];
            snprintf(path, sizeof path, "%s/chi2_map%d.txt", sg_test_tmpdir(), k);
            FILE *f = fopen(path, "w");
            for (size_t c = 0; f && c < cells; c++)
                fprintf(f, "%zu %g %g\n", c, obs[c], expct[c]);
            if (f)
                fclose(f);
            fail_msg("%s: chi-square p = %g < %g (table in %s)", maps[k].name, pval, alpha_each, path);
        }
        free(obs);
        free(expct);
    }
    free_test_maps(maps);
}

/* Half the texels black (a checker): no sample may land where the lookup
 * is black (the black texels are lit towards their lit neighbours, and
 * drawn there). */
static void test_envmap_black_texels_never_sampled(void **state)
{
    (void)state;
    const int W = 20, H = 10;
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, W, H, NULL), SG_OK);
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++)
            if ((i + j) % 2 == 0 && j != 3) /* and one whole black row */
                img.data[3 * (j * W + i) + (i % 3)] = 1.0f + j;
    sg_envmap *m = make_map(&img, 33.0f, 0);
    for (uint64_t n = 0; n < 200000; n++) {
        float pdf;
        sg_vec3 d = sg_envmap_sample(m, u01(n, 6), u01(n, 7), &pdf);
        sg_vec3 L = sg_envmap_eval(m, d);
        if (!(L.x + L.y + L.z > 0.0f) || !(pdf > 0.0f))
            fail_msg("sample %llu landed on a black texel: d (%g, %g, %g), pdf %g", (unsigned long long)n,
                     (double)d.x, (double)d.y, (double)d.z, (double)pdf);
    }
    sg_envmap_destroy(m);
    sg_image_free(&img);
}

/* No direction with eval > 0 and pdf 0: on sparse maps (single lit texels
 * in the top row, at the u seam, mid-map, two touching at a corner) every
 * direction where the bilinear lookup is lit has pdf > 0, and L / pdf stays
 * within the sampling power. Weighting texels by their own luminance, as a
 * nearest lookup allows, leaves the lit rim around each texel with pdf 0:
 * an estimator that never samples where light is, biased low. Directions:
 * a dense grid around each lit texel plus uniform ones. */
static void test_envmap_lit_lookup_has_positive_pdf(void **state)
{
    (void)state;
    const int W = 32, H = 16;
    static const int lit[][2] = {{5, 0}, {0, 7}, {31, 9}, {17, 11}, {18, 12}, {9, 15}};
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, W, H, NULL), SG_OK);
    for (size_t k = 0; k < sizeof lit / sizeof lit[0]; k++)
        img.data[3 * ((size_t)lit[k][1] * W + lit[k][0]) + k % 3] = 10.0f + (float)k;
    for (int rot = 0; rot < 2; rot++) {
        float angle = rot ? 33.0f : 0.0f;
        sg_envmap *m = make_map(&img, angle, 0);
        sg_envmap_info info;
        sg_envmap_get_info(m, &info);
        size_t lit_dirs = 0;
        for (size_t k = 0; k < sizeof lit / sizeof lit[0] + 1; k++) {
            int n = k < sizeof lit / sizeof lit[0] ? 121 : 20000;
            for (int q = 0; q < n; q++) {
                sg_vec3 d;
                if (k < sizeof lit / sizeof lit[0]) { /* 11 x 11 points over the 3 x 3 texels around it */
                    double u = (lit[k][0] - 1 + 3.0 * ((q % 11) + 0.5) / 11.0) / W;
                    double v = (lit[k][1] - 1 + 3.0 * ((q / 11) + 0.5) / 11.0) / H;
                    u -= floor(u);
                    v = fmin(fmax(v, 1e-4), 1.0 - 1e-4);
                    d = rot_y(sg_envmap_uv_to_dir(NULL, (float)u, (float)v), angle);
                } else {
                    d = uniform_dir((uint64_t)q + 777);
                }
                sg_vec3 L = sg_envmap_eval(m, d);
                float pdf = sg_envmap_pdf(m, d);
                double lum = 0.2126 * L.x + 0.7152 * L.y + 0.0722 * L.z;
                if (!(lum > 0.0))
                    continue;
                lit_dirs++;
                if (!(pdf > 0.0f))
                    fail_msg("rot %g: d (%g, %g, %g) near lit texel %zu: eval (%g, %g, %g) > 0 but pdf 0",
                             (double)angle, (double)d.x, (double)d.y, (double)d.z, k, (double)L.x, (double)L.y,
                             (double)L.z);
                if (!(lum / pdf <= info.sampling_power * (1.0 + 1e-5)))
                    fail_msg("rot %g: lum(L) / pdf = %g above the sampling power %g", (double)angle, lum / pdf,
                             (double)info.sampling_power);
            }
        }
        assert_true(lit_dirs > 300); /* the grids did reach lit directions */
        sg_envmap_destroy(m);
    }
    sg_image_free(&img);
}

/* ---- 4. estimators -------------------------------------------------------------- */

typedef struct stats {
    double sum, sum2; /* of the samples  */
    uint64_t n;       /* sample count    */
} stats;

static void add(stats *s, double x)
{
    s->sum += x;
    s->sum2 += x * x;
    s->n++;
}
static double mean_of(const stats *s) { return s->sum / s->n; }
static double sigma_of(const stats *s)
{
    double m = mean_of(s);
    return sqrt(fmax(0.0, s->sum2 / s->n - m * m));
}

/* Sum over pixels of L x texel solid angle, in double (the reference). */
static void pixel_power(const sg_image *img, double out[3])
{
    out[0] = out[1] = out[2] = 0.0;
    for (int j = 0; j < img->height; j++)
        for (int i = 0; i < img->width; i++)
            for (int c = 0; c < 3; c++)
                out[c] += img->data[3 * (j * img->width + i) + c] * texel_omega(j, img->width, img->height);
}

/* The estimator X = L_c(d) / pdf(d), d ~ pdf, has mean
 *   E[X] = integral of L_c(d) / pdf(d) pdf(d) dd = integral of L_c = power_c,
 * because pdf > 0 wherever L != 0. By the central limit theorem the sample
 * mean lies within 4 sigma / sqrt(N) of it except with probability 6e-5;
 * sigma is the sample standard deviation of X; 1e-5 |mean| more covers the
 * float rounding of each X. The reference is the integral of the bilinear
 * lookup (bilinear_power_ref), which sg_envmap_power must equal within
 * float rounding.
 * The luminance estimator is bounded: pdf = w / P_w with w the largest
 * luminance of the lookup in the texel, so 0 <= lum(L) / pdf <= P_w for
 * every sample (no fireflies from the lookup rising inside a texel); P_w
 * (info.sampling_power) is checked against sampling_power_ref.
 * The uniform estimator X = 4 pi L_c(d), d uniform, has the same mean. */
static void test_envmap_power_estimators(void **state)
{
    (void)state;
    test_map maps[3];
    make_test_maps(maps);
    const uint64_t N = 200000;
    for (int k = 0; k < 3; k++) {
        const sg_envmap *m = maps[k].m;
        double ref[3];
        bilinear_power_ref(&maps[k].img, ref);
        sg_vec3 api = sg_envmap_power(m);
        const float apic[3] = {api.x, api.y, api.z};
        sg_envmap_info info;
        sg_envmap_get_info(m, &info);
        double pw = sampling_power_ref(&maps[k].img);
        if (fabs(info.sampling_power - pw) > 1e-5 * pw)
            fail_msg("%s: sampling power %.9g, computed here %.9g", maps[k].name, (double)info.sampling_power, pw);
        stats is[4] = {{0}}, uni[3] = {{0}};
        double lum_max = 0.0;
        for (uint64_t n = 0; n < N; n++) {
            float pdf;
            sg_vec3 d = sg_envmap_sample(m, u01(n, 8), u01(n, 9), &pdf);
            sg_vec3 L = sg_envmap_eval(m, d);
            add(&is[0], L.x / pdf);
            add(&is[1], L.y / pdf);
            add(&is[2], L.z / pdf);
            double xl = (0.2126 * L.x + 0.7152 * L.y + 0.0722 * L.z) / pdf;
            add(&is[3], xl);
            lum_max = fmax(lum_max, xl);
            sg_vec3 w = uniform_dir(n);
            sg_vec3 Lu = sg_envmap_eval(m, w);
            add(&uni[0], 4 * PI * Lu.x);
            add(&uni[1], 4 * PI * Lu.y);
            add(&uni[2], 4 * PI * Lu.z);
        }
        for (int c = 0; c < 3; c++) {
            if (fabs(apic[c] - ref[c]) > 1e-5 * ref[c])
                fail_msg("%s: sg_envmap_power channel %d = %.9g, integral of the lookup %.9g", maps[k].name, c,
                         (double)apic[c], ref[c]);
            double tol = 4 * sigma_of(&is[c]) / sqrt((double)N) + 1e-5 * fabs(mean_of(&is[c]));
            if (fabs(mean_of(&is[c]) - ref[c]) > tol)
                fail_msg("%s: importance-sampled power channel %d = %.9g, integral %.9g, tolerance %.3g",
                         maps[k].name, c, mean_of(&is[c]), ref[c], tol);
            double tol_u = 4 * sigma_of(&uni[c]) / sqrt((double)N);
            if (fabs(mean_of(&uni[c]) - ref[c]) > tol_u)
                fail_msg("%s: uniformly sampled power channel %d = %.9g, integral %.9g, tolerance %.3g",
                         maps[k].name, c, mean_of(&uni[c]), ref[c], tol_u);
        }
        double ref_lum = 0.2126 * ref[0] + 0.7152 * ref[1] + 0.0722 * ref[2];
        double tol_l = 4 * sigma_of(&is[3]) / sqrt((double)N) + 1e-5 * ref_lum;
        print_message("%s: power R %.6g (IS %.6g +- %.2g, uniform %.6g +- %.2g); luminance sigma %.3g, "
                      "largest L/pdf %.6g of P_w %.6g\n",
                      maps[k].name, ref[0], mean_of(&is[0]), sigma_of(&is[0]) / sqrt((double)N), mean_of(&uni[0]),
                      sigma_of(&uni[0]) / sqrt((double)N), sigma_of(&is[3]), lum_max, pw);
        if (fabs(mean_of(&is[3]) - ref_lum) > tol_l)
            fail_msg("%s: luminance estimator mean %.9g, want %.9g +- %.3g", maps[k].name, mean_of(&is[3]), ref_lum,
                     tol_l);
        if (!(lum_max <= pw * (1 + 1e-5)))
            fail_msg("%s: lum(L) / pdf reached %.9g, above the sampling power %.9g", maps[k].name, lum_max, pw);
    }
    free_test_maps(maps);
}

/* The studio map's pixel sum equals its closed form (analytic.c integrates
 * the boxes exactly per texel); texel values are floats, so 1e-5. */
static void test_envmap_studio_closed_form(void **state)
{
    (void)state;
    const int sizes[][2] = {{64, 32}, {100, 37}, {1024, 512}};
    sg_vec3 cf = sg_analytic_studio_power();
    const float cfc[3] = {cf.x, cf.y, cf.z};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        sg_image img = make_analytic(SG_ANALYTIC_STUDIO, sizes[s][0], sizes[s][1]);
        double ref[3];
        pixel_power(&img, ref);
        for (int c = 0; c < 3; c++)
            if (fabs(ref[c] - cfc[c]) > 1e-5 * cfc[c])
                fail_msg("studio %dx%d channel %d: pixel sum %.9g, closed form %.9g", sizes[s][0], sizes[s][1], c,
                         ref[c], (double)cfc[c]);
        sg_image_free(&img);
    }
    /* Sun disk integral = 1e5 x 2 pi (1 - cos 0.5 deg) at any resolution. */
    const double sun = 1e5 * 2.0 * PI * (1.0 - cos(0.5 * PI / 180.0));
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        sg_image sky = make_analytic(SG_ANALYTIC_SKY, sizes[s][0], sizes[s][1]);
        sg_image sunsky = make_analytic(SG_ANALYTIC_SUNSKY, sizes[s][0], sizes[s][1]);
        double a[3], b[3];
        pixel_power(&sky, a);
        pixel_power(&sunsky, b);
        for (int c = 0; c < 3; c++)
            if (fabs((b[c] - a[c]) - sun) > 1e-4 * sun)
                fail_msg("sunsky %dx%d channel %d: sun integral %.9g, want %.9g", sizes[s][0], sizes[s][1], c,
                         b[c] - a[c], sun);
        sg_image_free(&sky);
        sg_image_free(&sunsky);
    }
}

/* Irradiance of a constant map on any plane is pi L (sg_envmap_irradiance
 * claims relative error < 1e-3 for H >= 64). */
static void test_envmap_uniform_irradiance(void **state)
{
    (void)state;
    sg_analytic_desc d = {.type = SG_ANALYTIC_UNIFORM, .width = 128, .radiance = {2.0f, 1.0f, 0.5f}};
    sg_image img = {0};
    assert_int_equal(sg_analytic_make(&d, &img, NULL), SG_OK);
    sg_envmap *m = make_map(&img, 10.0f, 0);
    sg_vec3 mean = sg_envmap_mean_radiance(m);
    assert_true(fabsf(mean.x - 2.0f) < 1e-5f && fabsf(mean.y - 1.0f) < 1e-5f && fabsf(mean.z - 0.5f) < 1e-5f);
    for (uint64_t k = 0; k < 8; k++) {
        sg_vec3 n = uniform_dir(k + 1000);
        sg_vec3 E = sg_envmap_irradiance(m, n);
        if (fabs(E.x - 2.0 * PI) > 1e-3 * 2.0 * PI || fabs(E.z - 0.5 * PI) > 1e-3 * 0.5 * PI)
            fail_msg("uniform map: irradiance on n (%g, %g, %g) = (%.7g, %.7g, %.7g), want pi x (2, 1, 0.5)",
                     (double)n.x, (double)n.y, (double)n.z, (double)E.x, (double)E.y, (double)E.z);
    }
    sg_envmap_destroy(m);
    sg_image_free(&img);
}

/* Tiny sun (0.5 deg, radiance 1e5) over the sky at 1024 x 512: irradiance
 * on the horizontal plane, luminance channel, estimated from N samples.
 *
 * Importance sampling: Y = lum(L(d)) cos+(d) / pdf(d) = P cos+(d), because
 * pdf(d) = lum(L(d)) / P exactly. cos+ lies in [0, 1], so (Popoviciu)
 *     Var_IS <= P^2 / 4,
 * P = integral of lum ~ 4 pi 0.38 (sky) + 1e5 x 2 pi (1 - cos 0.5 deg)
 * (sun, 23.9) ~ 29, so Var_IS <= ~2e2.
 * Uniform sampling: Y = 4 pi lum(L(d)) cos+(d), whose variance is
 *     Var_U = 4 pi integral of lum^2 cos+^2 - E^2
 * computed exactly here from the texels (cos+^2 by the midpoint rule per
 * texel); the sun alone gives ~ 4 pi 1e10 Omega_sun sin^2(40 deg) ~ 1.2e7.
 * Var_U is computed, not measured: N uniform samples hit the sun about
 * N Omega_sun / 4 pi ~ 2e-5 N times, so a measured Var_U would mostly say 0.
 * Asserted: measured Var_IS <= P^2 / 4 (holds for any sample), and
 * Var_U / Var_IS >= 1e4 (the bound gives >= 6e4); the IS mean matches
 * sg_envmap_irradiance within 4 sigma / sqrt(N) + its 1e-3 quadrature
 * error. */
static void test_envmap_tiny_sun_variance(void **state)
{
    (void)state;
    sg_image img = make_analytic(SG_ANALYTIC_SUNSKY, 1024, 512);
    sg_envmap *m = make_map(&img, 0, 0);
    const int W = img.width, H = img.height;
    const sg_vec3 n = {0, 1, 0};

    double P = 0.0, int_l2c2 = 0.0, E = 0.0;
    for (int j = 0; j < H; j++) {
        double c = cos(PI * (j + 0.5) / H), cp = c > 0 ? c : 0; /* n = +Y: cos+ = max(0, y) */
        for (int i = 0; i < W; i++) {
            double l = lum_of(img.data + 3 * (j * W + i)), om = texel_omega(j, W, H);
            P += l * om;
            E += l * cp * om;
            int_l2c2 += l * l * cp * cp * om;
        }
    }
    double var_u = 4.0 * PI * int_l2c2 - E * E;

    const uint64_t N = 100000;
    stats s = {0};
    for (uint64_t k = 0; k < N; k++) {
        float pdf;
        sg_vec3 d = sg_envmap_sample(m, u01(k, 12), u01(k, 13), &pdf);
        sg_vec3 L = sg_envmap_eval(m, d);
        double cosp = fmax(0.0, sg_v3_dot(n, d));
        add(&s, (0.2126 * L.x + 0.7152 * L.y + 0.0722 * L.z) * cosp / pdf);
    }
    double var_is = sigma_of(&s) * sigma_of(&s);
    sg_vec3 Eq = sg_envmap_irradiance(m, n);
    double E_ref = 0.2126 * Eq.x + 0.7152 * Eq.y + 0.0722 * Eq.z;
    print_message("tiny sun: P %.4g, E %.5g (IS %.5g), Var_IS %.4g (bound P^2/4 = %.4g), Var_U %.4g, ratio %.3g\n", P,
                  E_ref, mean_of(&s), var_is, P * P / 4, var_u, var_u / var_is);
    if (!(var_is <= P * P / 4 * (1 + 1e-5)))
        fail_msg("Var_IS %g exceeds the bound P^2/4 = %g", var_is, P * P / 4);
    if (!(var_u >= 1e4 * var_is))
        fail_msg("Var_U %g is not >= 1e4 x Var_IS %g", var_u, var_is);
    double tol = 4 * sigma_of(&s) / sqrt((double)N) + 1e-3 * E_ref;
    if (fabs(mean_of(&s) - E_ref) > tol)
        fail_msg("IS irradiance %g, quadrature %g, tolerance %g", mean_of(&s), E_ref, tol);
    sg_envmap_destroy(m);
    sg_image_free(&img);
}

/* ---- 5. texels, fallback, arguments, files ------------------------------------------ */

static void test_envmap_bad_texels_counted_and_zeroed(void **state)
{
    (void)state;
    const int W = 8, H = 4;
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, W, H, NULL), SG_OK);
    for (int t = 0; t < 3 * W * H; t++)
        img.data[t] = 0.5f;
    img.data[3 * 1 + 0] = -0.004f;                      /* texel 1: one negative  */
    img.data[3 * 2 + 1] = -0.25f, img.data[3 * 2 + 2] = -1e-6f; /* texel 2: two     */
    img.data[3 * 5 + 2] = -0.001f;                      /* texel 5                */
    img.data[3 * 9 + 0] = NAN;                          /* texel 9: NaN           */
    img.data[3 * 10 + 1] = INFINITY;                    /* texel 10: +Inf         */
    img.data[3 * 11 + 2] = -INFINITY;                   /* texel 11: -Inf (non-finite, not negative) */
    sg_envmap *m = make_map(&img, 0, 3.0f);
    sg_envmap_info info;
    sg_envmap_get_info(m, &info);
    assert_int_equal(info.width, W);
    assert_int_equal(info.height, H);
    assert_int_equal(info.negative_texels, 3);
    assert_int_equal(info.nonfinite_texels, 3);
    assert_true(info.min_value == -0.25f);
    assert_true(info.max_value == 1.5f);
    assert_int_equal(info.uniform_fallback, 0);
    const int bad[] = {1, 2, 5, 9, 10, 11};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        int i = bad[k] % W, j = bad[k] / W;
        sg_vec3 L = sg_envmap_texel(m, i, j);
        const float want[3] = {0.5f * 3, 0.5f * 3, 0.5f * 3};
        const float got[3] = {L.x, L.y, L.z};
        for (int c = 0; c < 3; c++) {
            float orig = img.data[3 * bad[k] + c];
            float w = (isfinite(orig) && orig >= 0.0f) ? want[c] : 0.0f;
            if (got[c] != w)
                fail_msg("texel %d channel %d (stored %g): eval %g, want %g", bad[k], c, (double)orig, (double)got[c],
                         (double)w);
        }
    }
    sg_envmap_destroy(m);
    sg_image_free(&img);
}

static void test_envmap_intensity_scales_radiance_not_pdf(void **state)
{
    (void)state;
    sg_image img = make_analytic(SG_ANALYTIC_STUDIO, 48, 24);
    sg_envmap *a = make_map(&img, 20.0f, 0), *b = make_map(&img, 20.0f, 2.5f);
    for (uint64_t k = 0; k < 1000; k++) {
        sg_vec3 d = uniform_dir(k);
        sg_vec3 La = sg_envmap_eval(a, d), Lb = sg_envmap_eval(b, d);
        float pa = sg_envmap_pdf(a, d), pb = sg_envmap_pdf(b, d);
        if (Lb.x != 2.5f * La.x || fabsf(pa - pb) > 1e-6f * pa)
            fail_msg("d %llu: L %g vs 2.5 x %g, pdf %.9g vs %.9g", (unsigned long long)k, (double)Lb.x, (double)La.x,
                     (double)pb, (double)pa);
    }
    sg_vec3 pa = sg_envmap_power(a), pb = sg_envmap_power(b);
    assert_true(fabsf(pb.y - 2.5f * pa.y) <= 1e-5f * pb.y);
    sg_envmap_destroy(a);
    sg_envmap_destroy(b);
    sg_image_free(&img);
}

static void test_envmap_all_black_is_uniform(void **state)
{
    (void)state;
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, 16, 8, NULL), SG_OK); /* zero-filled */
    sg_envmap *m = make_map(&img, 45.0f, 0);
    sg_envmap_info info;
    sg_envmap_get_info(m, &info);
    assert_int_equal(info.uniform_fallback, 1);
    const float want = (float)(1.0 / (4.0 * PI));
    double mean[3] = {0, 0, 0}, mean_y2 = 0.0;
    const uint64_t N = 100000;
    for (uint64_t n = 0; n < N; n++) {
        float u1 = u01(n, 14), u2 = u01(n, 15), pdf, b1, b2;
        sg_vec3 d = sg_envmap_sample(m, u1, u2, &pdf);
        assert_true(pdf == want && sg_envmap_pdf(m, d) == want);
        sg_envmap_invert(m, d, &b1, &b2);
        if (fabsf(b1 - u1) > 1e-5f || fabsf(b2 - u2) > 1e-5f)
            fail_msg("uniform fallback: u (%g, %g) -> u (%g, %g)", (double)u1, (double)u2, (double)b1, (double)b2);
        mean[0] += d.x, mean[1] += d.y, mean[2] += d.z;
        mean_y2 += (double)d.y * d.y;
    }
    /* Uniform on the sphere: E[d] = 0 with sigma 1/sqrt(3) per component,
     * E[y^2] = 1/3 with sigma sqrt(4/45). */
    const double tol = 4.0 / sqrt(3.0 * N), tol2 = 4.0 * sqrt(4.0 / 45.0 / N);
    for (int c = 0; c < 3; c++)
        if (fabs(mean[c] / N) > tol)
            fail_msg("uniform fallback: mean of component %d = %g (tolerance %g)", c, mean[c] / N, tol);
    if (fabs(mean_y2 / N - 1.0 / 3.0) > tol2)
        fail_msg("uniform fallback: E[y^2] = %g, want 1/3 +- %g", mean_y2 / N, tol2);
    double bound;
    double g = pdf_grid_sum(m, 256, &bound);
    assert_true(fabs(g - 1.0) < 1e-5);
    sg_vec3 p = sg_envmap_power(m);
    assert_true(p.x == 0.0f && p.y == 0.0f && p.z == 0.0f);
    sg_envmap_destroy(m);
    sg_image_free(&img);
}

static void expect_create_fails(const sg_envmap_desc *d, sg_status want, const char *needle, const char *what)
{
    sg_envmap *m = (sg_envmap *)&m; /* sentinel: must stay */
    sg_error err = {0};
    sg_status st = sg_envmap_create(d, &m, &err);
    if (st != want)
        fail_msg("%s: got %s (%s), want %s", what, sg_status_name(st), err.message, sg_status_name(want));
    if (needle && !strstr(err.message, needle))
        fail_msg("%s: message lacks \"%s\": %s", what, needle, err.message);
    if (m != (sg_envmap *)&m)
        fail_msg("%s: *out written on failure", what);
}

static void test_envmap_create_rejects_bad_input(void **state)
{
    (void)state;
    sg_image img = make_analytic(SG_ANALYTIC_SKY, 8, 4);
    sg_image empty = {0};
    expect_create_fails(NULL, SG_ERR_INVALID_ARG, NULL, "NULL desc");
    expect_create_fails(&(sg_envmap_desc){0}, SG_ERR_INVALID_ARG,
                        "exactly one", "neither image nor path");
    expect_create_fails(&(sg_envmap_desc){.image = &img, .path = "x.exr"}, SG_ERR_INVALID_ARG,
                        "exactly one", "both");
    expect_create_fails(&(sg_envmap_desc){.image = &empty}, SG_ERR_INVALID_ARG,
                        "empty", "empty image");
    expect_create_fails(&(sg_envmap_desc){.image = &img, .rotation_deg = NAN}, SG_ERR_INVALID_ARG,
                        "rotation", "NaN rotation");
    expect_create_fails(&(sg_envmap_desc){.image = &img, .intensity = -1.0f}, SG_ERR_INVALID_ARG,
                        "intensity", "negative intensity");
    expect_create_fails(&(sg_envmap_desc){.image = &img, .intensity = INFINITY}, SG_ERR_INVALID_ARG,
                        "intensity", "Inf intensity");
    img.data[5] = 100.0f; /* x 3e38 overflows float */
    expect_create_fails(&(sg_envmap_desc){.image = &img, .intensity = 3e38f}, SG_ERR_INVALID_ARG,
                        "overflow", "overflowing intensity");

    char path[700];
    snprintf(path, sizeof path, "%s/missing_map.exr", sg_test_tmpdir());
    expect_create_fails(&(sg_envmap_desc){.path = path}, SG_ERR_IO, "missing_map.exr", "missing .exr");
    snprintf(path, sizeof path, "%s/missing_map.hdr", sg_test_tmpdir());
    expect_create_fails(&(sg_envmap_desc){.path = path}, SG_ERR_IO, "missing_map.hdr", "missing .hdr");
    const char *junk = sg_test_write_file("junk.map", "P6\n1 1\n255\nabc", 14);
    expect_create_fails(&(sg_envmap_desc){.path = junk}, SG_ERR_UNSUPPORTED, "junk.map", "unknown format");
    static const char hdr_bytes[] = "#?RADIANCE\n\n-Y 4 +X 8\n\2\2\0\10\377";
    const char *bad_hdr = sg_test_write_file("bad.hdr", hdr_bytes, sizeof hdr_bytes - 1);
    expect_create_fails(&(sg_envmap_desc){.path = bad_hdr}, SG_ERR_CORRUPT, "bad.hdr", "truncated .hdr");
    sg_image_free(&img);
}

/* Loud failures: a map file with no finite positive texel (all NaN, or all
 * zero and negative) used to light scenes black with exit 0; a map whose
 * power overflows baked infinite light. Both are refused, naming the file
 * and the figures; an all-black image made in memory (a dark sky on
 * purpose) still falls back to uniform sampling. */
static void test_envmap_refuses_unusable_maps(void **state)
{
    (void)state;
    sg_image img = {0};
    assert_int_equal(sg_image_alloc(&img, 16, 8, NULL), SG_OK);
    char path[700];
    for (int t = 0; t < 3 * 16 * 8; t++)
        img.data[t] = NAN;
    img.data[7] = INFINITY;
    snprintf(path, sizeof path, "%s/all_nan.exr", sg_test_tmpdir());
    assert_int_equal(sg_image_write_exr(&img, path, NULL), SG_OK);
    expect_create_fails(&(sg_envmap_desc){.path = path}, SG_ERR_CORRUPT,
                        "all_nan.exr: no texel has a finite positive value (128 of 128 texels NaN or infinite",
                        "all-NaN file");
    for (int t = 0; t < 3 * 16 * 8; t++)
        img.data[t] = t % 2 ? 0.0f : -1.0f;
    snprintf(path, sizeof path, "%s/all_dark.exr", sg_test_tmpdir());
    assert_int_equal(sg_image_write_exr(&img, path, NULL), SG_OK);
    expect_create_fails(&(sg_envmap_desc){.path = path}, SG_ERR_CORRUPT, "no texel has a finite positive value",
                        "black and negative file");
    /* Values near float's largest: finite texels, infinite light. */
    for (int t = 0; t < 3 * 16 * 8; t++)
        img.data[t] = 3e38f;
    snprintf(path, sizeof path, "%s/huge.exr", sg_test_tmpdir());
    assert_int_equal(sg_image_write_exr(&img, path, NULL), SG_OK);
    expect_create_fails(&(sg_envmap_desc){.path = path}, SG_ERR_INVALID_ARG,
                        "huge.exr: the map's power (radiance over the sphere, intensity 1 applied) is",
                        "3e38 file");
    expect_create_fails(&(sg_envmap_desc){.image = &img}, SG_ERR_INVALID_ARG, "more than sums of light values can "
                        "hold", "3e38 image");
    /* Just under the limit is fine: 1e30 everywhere (power 1.3e31). */
    for (int t = 0; t < 3 * 16 * 8; t++)
        img.data[t] = 1e30f;
    sg_envmap *m = make_map(&img, 0, 0);
    sg_envmap_destroy(m);
    /* An all-black image in memory is a dark sky: uniform fallback. */
    memset(img.data, 0, 3 * 16 * 8 * sizeof(float));
    m = make_map(&img, 0, 0);
    sg_envmap_info info;
    sg_envmap_get_info(m, &info);
    assert_int_equal(info.uniform_fallback, 1);
    sg_envmap_destroy(m);
    sg_image_free(&img);
}

/* Paths: an EXR written here (by extension and, renamed, by magic), and
 * the real maps; DWAB negatives are counted, PIZ and .hdr have none. */
static void test_envmap_load_files(void **state)
{
    (void)state;
    sg_image img = make_analytic(SG_ANALYTIC_STUDIO, 32, 16);
    char path[700];
    snprintf(path, sizeof path, "%s/studio.exr", sg_test_tmpdir());
    assert_int_equal(sg_image_write_exr(&img, path, NULL), SG_OK);
    char noext[700];
    snprintf(noext, sizeof noext, "%s/studio_map", sg_test_tmpdir());
    assert_int_equal(rename(path, noext), 0);
    sg_envmap *m = NULL;
    sg_error err = {0};
    sg_status st = sg_envmap_create(&(sg_envmap_desc){.path = noext}, &m, &err);
    if (st != SG_OK)
        fail_msg("%s: %s", noext, err.message);
    sg_vec3 p = sg_envmap_power(m);
    double ref[3];
    bilinear_power_ref(&img, ref);
    if (!(fabs(p.x - ref[0]) < 1e-5 * ref[0]))
        fail_msg("%s: power %.9g, integral of the lookup %.9g", noext, (double)p.x, ref[0]);
    sg_envmap_destroy(m);
    sg_image_free(&img);

    static const struct {
        const char *file;
        int negatives; /* 1: the DWAB maps carry small negatives */
    } real[] = {
        {"envmaps/blender_studiolights/city.exr", 1},
        {"envmaps/blender_studiolights/studio.exr", 1},
        {"envmaps/threejs_equirect/piz_compressed.exr", 0},
        {"envmaps/threejs_equirect/venice_sunset_1k.hdr", 0},
    };
    for (size_t k = 0; k < sizeof real / sizeof real[0]; k++) {
        const char *fp = sg_test_shared_data(real[k].file);
        if (!fp)
            continue;
        m = NULL;
        st = sg_envmap_create(&(sg_envmap_desc){.path = fp, .rotation_deg = 30.0f}, &m, &err);
        if (st != SG_OK)
            fail_msg("%s: %s: %s", real[k].file, sg_status_name(st), err.message);
        sg_envmap_info info;
        sg_envmap_get_info(m, &info);
        sg_vec3 mean = sg_envmap_mean_radiance(m);
        print_message("%s: %dx%d, %zu negative texels (min %.3g), %zu non-finite, max %.5g, mean (%.4g, %.4g, %.4g)\n",
                      real[k].file, info.width, info.height, info.negative_texels, (double)info.min_value,
                      info.nonfinite_texels, (double)info.max_value, (double)mean.x, (double)mean.y, (double)mean.z);
        assert_int_equal(info.width, 1024);
        assert_int_equal(info.height, 512);
        assert_int_equal(info.nonfinite_texels, 0);
        assert_int_equal(info.uniform_fallback, 0);
        if (real[k].negatives ? (info.negative_texels == 0 || info.min_value < -0.1f) : info.negative_texels != 0)
            fail_msg("%s: %zu negative texels, min %g", real[k].file, info.negative_texels, (double)info.min_value);
        for (uint64_t n = 0; n < 1000; n++) {
            float pdf;
            sg_vec3 d = sg_envmap_sample(m, u01(n, 16), u01(n, 17), &pdf);
            assert_true(pdf > 0.0f && pdf == sg_envmap_pdf(m, d));
        }
        sg_envmap_destroy(m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_envmap_mapping_axes_and_roundtrip),
        cmocka_unit_test(test_envmap_eval_bilinear_and_rotation),
        cmocka_unit_test(test_envmap_eval_continuous),
        cmocka_unit_test(test_envmap_invert_roundtrip),
        cmocka_unit_test(test_envmap_sample_pdf_matches_pdf),
        cmocka_unit_test(test_envmap_pdf_integrates_to_one),
        cmocka_unit_test(test_envmap_chi_square),
        cmocka_unit_test(test_envmap_black_texels_never_sampled),
        cmocka_unit_test(test_envmap_lit_lookup_has_positive_pdf),
        cmocka_unit_test(test_envmap_power_estimators),
        cmocka_unit_test(test_envmap_studio_closed_form),
        cmocka_unit_test(test_envmap_uniform_irradiance),
        cmocka_unit_test(test_envmap_tiny_sun_variance),
        cmocka_unit_test(test_envmap_bad_texels_counted_and_zeroed),
        cmocka_unit_test(test_envmap_intensity_scales_radiance_not_pdf),
        cmocka_unit_test(test_envmap_all_black_is_uniform),
        cmocka_unit_test(test_envmap_create_rejects_bad_input),
        cmocka_unit_test(test_envmap_refuses_unusable_maps),
        cmocka_unit_test(test_envmap_load_files),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
