/* camera.c — pinhole camera (see camera.h).
 *
 * Invariants of a camera built here:
 *  1. forward, right, up are unit length and mutually orthogonal, with
 *     right = forward x up_hint normalised and up = right x forward;
 *  2. tan_half_fov and aspect are finite and > 0.
 */
#include "render/camera.h"

#include <math.h>

#include "math/v16.h"

#define PI_F 3.14159265358979323846f

sg_status sg_camera_look_at(sg_vec3 eye, sg_vec3 look, sg_vec3 up, float vfov_deg, float aspect,
                            sg_camera *out, sg_error *err)
{
    if (!sg_v3_isfinite(eye) || !sg_v3_isfinite(look) || !sg_v3_isfinite(up))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera: eye, look and up must be finite");
    if (!(vfov_deg > 0.0f && vfov_deg < 180.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera: fov %g is outside (0, 180) degrees",
                            (double)vfov_deg);
    if (!(aspect > 0.0f) || !isfinite(aspect))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera: aspect %g must be > 0", (double)aspect);
    sg_vec3 d = sg_v3_sub(look, eye);
    float len = sg_v3_length(d);
    if (!(len > 0.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera: eye and look are the same point");
    sg_vec3 f = sg_v3_scale(d, 1.0f / len);
    sg_vec3 u = sg_v3_normalize(up);
    sg_vec3 r = sg_v3_cross(f, u);
    /* |f x u| = sin(angle): below ~0.06 degrees the frame is ill-defined. */
    if (!(sg_v3_length(r) > 1e-3f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera: up (%g,%g,%g) is parallel to the view direction",
                            (double)up.x, (double)up.y, (double)up.z);
    r = sg_v3_normalize(r);
    sg_camera cam = {
        .eye = eye,
        .forward = f,
        .right = r,
        .up = sg_v3_cross(r, f),
        .tan_half_fov = tanf(0.5f * vfov_deg * PI_F / 180.0f),
        .aspect = aspect,
    };
    *out = cam;
    return SG_OK;
}

/* Every field of a camera ray from its direction and spread. */
static inline void set_camera_ray(const sg_camera *cam, sg_vec3 dir, float spread, sg_ray *ray)
{
    ray->org = cam->eye;
    ray->dir = dir;
    ray->tmin = 0.0f;
    ray->tmax = INFINITY;
    ray->flags = SG_RAY_ANY_FACE | SG_RAY_PRIMARY;
    ray->self_n = sg_v3(0.0f, 0.0f, 0.0f);
    ray->self_r = 0.0f;
    ray->spread = spread;
}

/* The ray of sg_camera_ray, written in place: sg_camera_block16 fills its
 * array through this, so no temporary is copied (that copy's 16-byte
 * loads of 4-byte stores stalled on store forwarding, 2-3% of the hybrid
 * viewer's frame), and both give the same bits. */
static inline void camera_ray(const sg_camera *cam, float px, float py, int width, int height, sg_ray *ray)
{
    /* Screen coordinates in [-1, 1], +y up; the centre maps to exactly 0 so
     * the centre ray is the view direction. */
    float sx = 2.0f * px / (float)width - 1.0f;
    float sy = 1.0f - 2.0f * py / (float)height;
    sg_vec3 d = cam->forward;
    d = sg_v3_madd(d, cam->right, sx * cam->tan_half_fov * cam->aspect);
    d = sg_v3_madd(d, cam->up, sy * cam->tan_half_fov);
    /* The pixel is 2 tan(fov/2) / height wide on the image plane at unit
     * forward distance, which the ray reaches after |d|. */
    float len = sg_v3_length(d);
    set_camera_ray(cam, sg_v3_scale(d, 1.0f / len), 2.0f * cam->tan_half_fov / ((float)height * len), ray);
}

sg_ray sg_camera_ray(const sg_camera *cam, float px, float py, int width, int height)
{
    sg_ray ray;
    camera_ray(cam, px, py, width, height, &ray);
    return ray;
}

#if SG_V16_SIMD
/* A whole block across 16 lanes: camera_ray's operations in its order
 * (no contraction: the library is built as ISO C), so the same bits. */
static void camera_block16_simd(const sg_camera *cam, int x, int y, int width, int height, sg_ray rays[16])
{
    _Alignas(64) float fx[16], fy[16];
    for (int q = 0; q < 16; ++q) {
        fx[q] = (float)(x + (q & 3)) + 0.5f;
        fy[q] = (float)(y + (q >> 2)) + 0.5f;
    }
    const sg_v16 two = sg_v16_set1(2.0f), one = sg_v16_set1(1.0f);
    const sg_v16 sx = sg_v16_sub(sg_v16_div(sg_v16_mul(two, sg_v16_load(fx)), sg_v16_set1((float)width)), one);
    const sg_v16 sy = sg_v16_sub(one, sg_v16_div(sg_v16_mul(two, sg_v16_load(fy)), sg_v16_set1((float)height)));
    const sg_v16 kx = sg_v16_mul(sg_v16_mul(sx, sg_v16_set1(cam->tan_half_fov)), sg_v16_set1(cam->aspect));
    const sg_v16 ky = sg_v16_mul(sy, sg_v16_set1(cam->tan_half_fov));
    const float *f = &cam->forward.x, *r = &cam->right.x, *u = &cam->up.x;
    sg_v16 d[3];
    for (int c = 0; c < 3; ++c) {
        d[c] = sg_v16_add(sg_v16_set1(f[c]), sg_v16_mul(sg_v16_set1(r[c]), kx));
        d[c] = sg_v16_add(d[c], sg_v16_mul(sg_v16_set1(u[c]), ky));
    }
    const sg_v16 len = sg_v16_sqrt(
        sg_v16_add(sg_v16_add(sg_v16_mul(d[0], d[0]), sg_v16_mul(d[1], d[1])), sg_v16_mul(d[2], d[2])));
    const sg_v16 inv = sg_v16_div(one, len);
    _Alignas(64) float dx[16], dy[16], dz[16], sp[16];
    sg_v16_store(dx, sg_v16_mul(d[0], inv));
    sg_v16_store(dy, sg_v16_mul(d[1], inv));
    sg_v16_store(dz, sg_v16_mul(d[2], inv));
    sg_v16_store(sp, sg_v16_div(sg_v16_set1(2.0f * cam->tan_half_fov), sg_v16_mul(sg_v16_set1((float)height), len)));
    for (int q = 0; q < 16; ++q)
        set_camera_ray(cam, sg_v3(dx[q], dy[q], dz[q]), sp[q], &rays[q]);
}
#endif

unsigned sg_camera_block16(const sg_camera *cam, int x, int y, int width, int height, sg_ray rays[16])
{
#if SG_V16_SIMD
    if (x >= 0 && y >= 0 && x + 4 <= width && y + 4 <= height) {
        camera_block16_simd(cam, x, y, width, height, rays);
        return 0xFFFFu;
    }
#endif
    unsigned mask = 0;
    for (int q = 0; q < 16; ++q) {
        int px = x + (q & 3), py = y + (q >> 2);
        if (px < 0 || py < 0 || px >= width || py >= height)
            continue;
        camera_ray(cam, (float)px + 0.5f, (float)py + 0.5f, width, height, &rays[q]);
        mask |= 1u << q;
    }
    return mask;
}

sg_status sg_camera_frame(sg_aabb bounds, sg_vec3 view_dir, sg_vec3 up, float vfov_deg, float aspect,
                          float margin, sg_camera *out, sg_error *err)
{
    if (!(bounds.hi.x >= bounds.lo.x && bounds.hi.y >= bounds.lo.y && bounds.hi.z >= bounds.lo.z) ||
        !sg_v3_isfinite(bounds.lo) || !sg_v3_isfinite(bounds.hi))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera: the box to frame is empty or not finite");
    if (margin == 0.0f)
        margin = 1.1f;
    if (!(margin > 0.0f) || !isfinite(margin))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera: margin %g must be > 0", (double)margin);
    sg_vec3 dir = sg_v3_normalize(view_dir);
    if (!sg_v3_isfinite(view_dir) || sg_v3_dot(dir, dir) == 0.0f)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera: view direction has zero length");
    if (!(vfov_deg > 0.0f && vfov_deg < 180.0f) || !(aspect > 0.0f) || !isfinite(aspect))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera: fov %g or aspect %g out of range",
                            (double)vfov_deg, (double)aspect);
    sg_vec3 centre = sg_v3_scale(sg_v3_add(bounds.lo, bounds.hi), 0.5f);
    float radius = 0.5f * sg_aabb_diagonal(bounds);
    if (!(radius > 0.0f))
        radius = 1.0f; /* a single point: any distance frames it */
    float tv = tanf(0.5f * vfov_deg * PI_F / 180.0f);
    float th = tv * aspect;
    /* A sphere of radius r fits a half-angle a at distance r / sin(a). */
    float half = atanf(th < tv ? th : tv);
    float dist = margin * radius / sinf(half);
    sg_vec3 eye = sg_v3_madd(centre, dir, -dist);
    return sg_camera_look_at(eye, centre, up, vfov_deg, aspect, out, err);
}
