/* camera.h — a pinhole camera: eye, orthonormal frame, vertical field of
 * view and aspect ratio. Plain struct; world space, right-handed, +Y up.
 *
 * Image plane: pixel coordinates (px, py) in [0, width] x [0, height] with
 * (0, 0) the top-left corner of the top-left pixel, so the centre of pixel
 * (x, y) is (x + 0.5, y + 0.5). px grows along cam.right, py along -cam.up.
 * The vertical field of view spans the image height; the horizontal extent
 * is aspect times the vertical one (aspect = width / height for square
 * pixels).
 *
 * Use:
 *     sg_camera cam;
 *     sg_camera_look_at(eye, look, up, 45.0f, (float)w / h, &cam, &err);
 *     sg_ray r = sg_camera_ray(&cam, x + 0.5f, y + 0.5f, w, h);
 */
#ifndef SG_RENDER_CAMERA_H
#define SG_RENDER_CAMERA_H

#include "core/error.h"
#include "math/ray.h"
#include "math/vec3.h"

typedef struct sg_camera {
    sg_vec3 eye;         /* centre of projection                         */
    sg_vec3 forward;     /* unit view direction                          */
    sg_vec3 right;       /* unit, forward x up                           */
    sg_vec3 up;          /* unit, right x forward (image "up")           */
    float tan_half_fov;  /* tan(vertical fov / 2), > 0                   */
    float aspect;        /* horizontal extent / vertical extent, > 0     */
} sg_camera;

/* Builds a camera at eye looking at look. up need only be non-parallel to
 * the view direction; vfov_deg in (0, 180); aspect > 0. Errors
 * (SG_ERR_INVALID_ARG): eye == look, up parallel to the view, non-finite
 * input, fov or aspect out of range. *out is written only on SG_OK. */
sg_status sg_camera_look_at(sg_vec3 eye, sg_vec3 look, sg_vec3 up, float vfov_deg, float aspect,
                            sg_camera *out, sg_error *err);

/* Primary ray through image-plane point (px, py) of a width x height image
 * (see the header note for the coordinates): origin at the eye, unit
 * direction, [tmin, tmax] = [0, INFINITY], SG_RAY_ANY_FACE, spread = the
 * pixel's angular width (its footprint for levels of detail). */
sg_ray sg_camera_ray(const sg_camera *cam, float px, float py, int width, int height);

/* The camera rays through the centres of the 4 x 4 pixels from (x, y)
 * (ray q: pixel (x + q % 4, y + q / 4)), each sg_camera_ray's bits,
 * written in place. Returns the mask of those inside the image (bit q:
 * rays[q] written; the others are left as they are). */
unsigned sg_camera_block16(const sg_camera *cam, int x, int y, int width, int height, sg_ray rays[16]);

/* A camera looking along view_dir (need not be unit) at the centre of
 * bounds, far enough back that the sphere around the box fits inside both
 * the vertical and the horizontal field of view, scaled by margin (>= 1
 * leaves a border; 0 means 1.1). Errors as sg_camera_look_at, plus an empty
 * or non-finite box. */
sg_status sg_camera_frame(sg_aabb bounds, sg_vec3 view_dir, sg_vec3 up, float vfov_deg, float aspect,
                          float margin, sg_camera *out, sg_error *err);

#endif
