/* warp.c — square-to-disk/sphere/hemisphere warps (see warp.h).
 *
 * Sources: concentric map and its inverse, Shirley & Chiu 1997 as written
 * in pbrt-v4 util/sampling.h (SampleUniformDiskConcentric,
 * InvertUniformDiskConcentricSample); Malley's method, pbrt-v4 §A.5.3.
 *
 * Invariants:
 *  1. sample maps [0,1)^2 onto the support; pdf integrates to 1 over it.
 *  2. invert(sample(u)) = u up to rounding away from the seams.
 *  3. No sample returns NaN: square roots take max(0, .) of their
 *     arguments, which rounding can push slightly below zero.
 */
#include "sample/warp.h"

#include <math.h>

#define PI_F 3.14159265358979323846f
#define INV_PI_F 0.31830988618379067154f
#define PI_OVER_2 1.57079632679489661923f
#define PI_OVER_4 0.78539816339487448847f
#define TWO_PI 6.28318530717958647692f

static float clamp01(float x) { return x < 0.0f ? 0.0f : (x > 1.0f ? 1.0f : x); }

void sg_warp_disk_sample(float u0, float u1, float p[2])
{
    float ox = 2.0f * u0 - 1.0f, oy = 2.0f * u1 - 1.0f;
    if (ox == 0.0f && oy == 0.0f) {
        p[0] = p[1] = 0.0f;
        return;
    }
    /* Squares map to circles wedge by wedge: the larger coordinate is the
     * radius, the ratio an angle within the wedge. */
    float r, theta;
    if (fabsf(ox) > fabsf(oy)) {
        r = ox;
        theta = PI_OVER_4 * (oy / ox);
    } else {
        r = oy;
        theta = PI_OVER_2 - PI_OVER_4 * (ox / oy);
    }
    p[0] = r * cosf(theta);
    p[1] = r * sinf(theta);
}

float sg_warp_disk_pdf(float x, float y) { return x * x + y * y <= 1.0f ? INV_PI_F : 0.0f; }

void sg_warp_disk_invert(float x, float y, float u[2])
{
    float theta = atan2f(y, x); /* (-pi, pi] */
    float r = sqrtf(x * x + y * y);
    float ox, oy;
    if (fabsf(theta) < PI_OVER_4 || fabsf(theta) > 3.0f * PI_OVER_4) {
        /* Left or right wedge: |ox| was the larger coordinate. */
        ox = r = copysignf(r, x);
        if (x < 0.0f)
            oy = (y < 0.0f ? (PI_F + theta) : (theta - PI_F)) * r / PI_OVER_4;
        else
            oy = theta * r / PI_OVER_4;
    } else {
        oy = r = copysignf(r, y);
        if (y < 0.0f)
            ox = -(PI_OVER_2 + theta) * r / PI_OVER_4;
        else
            ox = (PI_OVER_2 - theta) * r / PI_OVER_4;
    }
    u[0] = clamp01(0.5f * (ox + 1.0f));
    u[1] = clamp01(0.5f * (oy + 1.0f));
}

/* Azimuth of d in [0, 1) turns. */
static float azimuth01(sg_vec3 d)
{
    float phi = atan2f(d.y, d.x);
    if (phi < 0.0f)
        phi += TWO_PI;
    float u = phi / TWO_PI;
    return u >= 1.0f ? 0.0f : u;
}

static sg_vec3 from_z_phi(float z, float u1)
{
    float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    float phi = TWO_PI * u1;
    return sg_v3(r * cosf(phi), r * sinf(phi), z);
}

sg_vec3 sg_warp_sphere_sample(float u0, float u1) { return from_z_phi(1.0f - 2.0f * u0, u1); }

float sg_warp_sphere_pdf(sg_vec3 d)
{
    (void)d;
    return 0.25f * INV_PI_F;
}

void sg_warp_sphere_invert(sg_vec3 d, float u[2])
{
    u[0] = clamp01(0.5f * (1.0f - d.z));
    u[1] = azimuth01(d);
}

sg_vec3 sg_warp_hemisphere_sample(float u0, float u1) { return from_z_phi(u0, u1); }

float sg_warp_hemisphere_pdf(sg_vec3 d) { return d.z >= 0.0f ? 0.5f * INV_PI_F : 0.0f; }

void sg_warp_hemisphere_invert(sg_vec3 d, float u[2])
{
    u[0] = clamp01(d.z);
    u[1] = azimuth01(d);
}

sg_vec3 sg_warp_cosine_hemisphere_sample(float u0, float u1)
{
    /* Malley: uniform on the disk, projected up, is cos-distributed. */
    float p[2];
    sg_warp_disk_sample(u0, u1, p);
    float z = sqrtf(fmaxf(0.0f, 1.0f - p[0] * p[0] - p[1] * p[1]));
    return sg_v3(p[0], p[1], z);
}

float sg_warp_cosine_hemisphere_pdf(sg_vec3 d) { return d.z > 0.0f ? d.z * INV_PI_F : 0.0f; }

void sg_warp_cosine_hemisphere_invert(sg_vec3 d, float u[2]) { sg_warp_disk_invert(d.x, d.y, u); }
