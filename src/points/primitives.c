/* primitives.c — analytic point sets. See primitives.h. */
#include "points/primitives.h"

#include <math.h>

#include "math/rng.h"

static const float PI_F = 3.14159265358979f;

/* Stream for the plane's jitter, apart from mesh sampling's streams. */
static const uint64_t PLANE_STREAM = 0x706C616E65ull;

static float radius_rule(float spacing, unsigned k, float scale)
{
    return (scale > 0.0f ? scale : 1.0f) * spacing * sqrtf((float)(k ? k : 8u) / PI_F);
}

static int bad_vec(sg_vec3 v) { return !sg_v3_isfinite(v); }

sg_status sg_points_make_sphere(const sg_sphere_points_desc *d, sg_pointset *out, sg_error *err)
{
    sg_sphere_points_desc s = d ? *d : (sg_sphere_points_desc){0};
    if (s.count == 0) s.count = 100000;
    if (s.radius == 0.0f) s.radius = 1.0f;
    if (s.albedo.x == 0.0f && s.albedo.y == 0.0f && s.albedo.z == 0.0f) s.albedo = sg_v3(0.8f, 0.8f, 0.8f);
    if (!(s.radius > 0.0f) || !isfinite(s.radius) || bad_vec(s.centre) || s.count > ((size_t)1 << 30))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sphere points: radius %g, %zu points is out of range",
                            (double)s.radius, s.count);
    sg_pointset p = {0};
    sg_status st = sg_pointset_alloc(&p, s.count, err);
    if (st != SG_OK)
        return st;
    const float golden = PI_F * (3.0f - sqrtf(5.0f));
    float h = sqrtf(4.0f * PI_F * s.radius * s.radius / (float)s.count);
    float r = radius_rule(h, s.radius_k, s.radius_scale);
    float sign = s.inward ? -1.0f : 1.0f;
    for (size_t i = 0; i < s.count; ++i) {
        /* Double precision for the spiral angle: i * golden loses all
         * fractional bits in float beyond ~1e6 points. */
        double y = 1.0 - 2.0 * ((double)i + 0.5) / (double)s.count;
        double rr = sqrt(1.0 - y * y), phi = (double)golden * (double)i;
        float x = (float)(cos(phi) * rr), z = (float)(sin(phi) * rr), yf = (float)y;
        p.px[i] = s.centre.x + s.radius * x;
        p.py[i] = s.centre.y + s.radius * yf;
        p.pz[i] = s.centre.z + s.radius * z;
        p.nx[i] = sign * x;
        p.ny[i] = sign * yf;
        p.nz[i] = sign * z;
        p.radius[i] = r;
        p.ar[i] = s.albedo.x;
        p.ag[i] = s.albedo.y;
        p.ab[i] = s.albedo.z;
    }
    *out = p;
    return SG_OK;
}

sg_status sg_points_make_plane(const sg_plane_points_desc *d, sg_pointset *out, sg_error *err)
{
    sg_plane_points_desc s = d ? *d : (sg_plane_points_desc){0};
    if (s.side == 0) s.side = 300;
    if (s.half == 0.0f) s.half = 15.0f;
    if (s.albedo.x == 0.0f && s.albedo.y == 0.0f && s.albedo.z == 0.0f) s.albedo = sg_v3(0.55f, 0.55f, 0.55f);
    if (s.side < 2 || s.side > 20000 || !(s.half > 0.0f) || !isfinite(s.half) || bad_vec(s.centre))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "plane points: %d points per side over +-%g is out of range",
                            s.side, (double)s.half);
    size_t n = (size_t)s.side * (size_t)s.side;
    sg_pointset g = {0};
    sg_status st = sg_pointset_alloc(&g, n, err);
    if (st != SG_OK)
        return st;
    float spacing = 2.0f * s.half / (float)s.side;
    float radius = radius_rule(spacing, s.radius_k, s.radius_scale);
    uint64_t seed = s.seed ^ PLANE_STREAM;
    for (size_t j = 0; j < n; j++) {
        float gx = (float)(j % (size_t)s.side), gz = (float)(j / (size_t)s.side);
        g.px[j] = s.centre.x - s.half + spacing * (gx + sg_rng_float(seed, j, 0, 0));
        g.py[j] = s.centre.y;
        g.pz[j] = s.centre.z - s.half + spacing * (gz + sg_rng_float(seed, j, 0, 1));
        g.nx[j] = 0.0f;
        g.ny[j] = 1.0f;
        g.nz[j] = 0.0f;
        g.radius[j] = radius;
        g.ar[j] = s.albedo.x;
        g.ag[j] = s.albedo.y;
        g.ab[j] = s.albedo.z;
    }
    *out = g;
    return SG_OK;
}
