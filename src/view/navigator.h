/* navigator.h — the viewer's camera controller: walk and orbit.
 *
 * What it does: turns the state of the input (keys held, mouse motion since
 * the last update) and the time step into a camera, as a pure function of
 * (navigator, input, dt): no clock, no window, no globals, so tests drive it
 * headless and a recorded input replays exactly.
 *   walk   W/S (or arrows) move along the view direction, A/D sideways,
 *          Q/E down/up along world +Y; mouse motion turns (yaw) and tilts
 *          (pitch, clamped to +-SG_NAV_PITCH_MAX_DEG). Speed is
 *          SG_NAV_SPEED_FRACTION of the scene's bounds diagonal per second
 *          (times SG_NAV_FAST_FACTOR while "fast" is held); diagonal moves
 *          are normalised, so the eye moves speed * dt whatever keys combine.
 *   orbit  the eye circles the centre of the scene's bounds at a fixed
 *          distance: mouse motion and A/D change yaw, W/S the distance
 *          (never below SG_NAV_ORBIT_MIN_FRACTION of the diagonal); the view
 *          always points at the centre.
 *   reset  back to the home view (sg_nav_reset), in the current mode's
 *          terms: the exact home eye/look/up/fov in walk mode.
 * What it does NOT do: roll (up is world +Y: the home view's up is used
 * only while at home), collision with the model, smoothing or inertia.
 *
 * Angles: yaw and pitch in radians; the view direction is
 *     forward = (cos(pitch) sin(yaw), sin(pitch), -cos(pitch) cos(yaw))
 * so yaw 0, pitch 0 looks along -Z; positive yaw turns towards +X.
 * Mouse: dx > 0 (right) increases yaw, dy > 0 (down, window coordinates)
 * decreases pitch; SG_NAV_LOOK_RATE radians per pixel.
 *
 * Use:
 *     sg_navigator nav;
 *     sg_nav_init(&nav, &home, sg_world_bounds(world));
 *     each frame: moved = sg_nav_update(&nav, &input, dt);
 *                 sg_nav_camera(&nav, (float)w / h, &cam, &err);
 */
#ifndef SG_VIEW_NAVIGATOR_H
#define SG_VIEW_NAVIGATOR_H

#include "core/error.h"
#include "math/vec3.h"
#include "render/camera.h"

#define SG_NAV_PITCH_MAX_DEG 89.0f      /* |pitch| limit                       */
#define SG_NAV_SPEED_FRACTION 0.25f     /* walk speed: diagonal per second x  */
#define SG_NAV_FAST_FACTOR 4.0f         /* speed multiplier with "fast"       */
#define SG_NAV_LOOK_RATE 0.004f         /* radians per pixel of mouse motion  */
#define SG_NAV_ORBIT_RATE 1.0f          /* radians per second for A/D orbit   */
#define SG_NAV_ORBIT_MIN_FRACTION 0.02f /* least orbit distance: diagonal x   */

typedef enum sg_nav_mode {
    SG_NAV_WALK = 0,
    SG_NAV_ORBIT = 1
} sg_nav_mode;

/* A view as the scene file and camera paths spell it. */
typedef struct sg_nav_view {
    sg_vec3 eye, look, up; /* world space; look != eye                 */
    float fov_deg;         /* vertical field of view, (0, 180)         */
} sg_nav_view;

/* Input since the last update; zero = nothing pressed, no motion. */
typedef struct sg_nav_input {
    int forward, back;     /* W / Up arrow, S / Down arrow held (0/1)   */
    int left, right;       /* A / Left, D / Right                       */
    int down, up;          /* Q, E                                       */
    int fast;              /* Shift                                      */
    float look_dx, look_dy;/* mouse drag, pixels, window coordinates    */
} sg_nav_input;

typedef struct sg_navigator {
    sg_nav_mode mode;       /* walk or orbit                              */
    sg_vec3 eye;            /* current eye                                */
    float yaw, pitch;       /* current view direction (header note)       */
    float fov_deg;          /* vertical fov                               */
    float speed;            /* walk speed, world units per second         */
    sg_vec3 centre;         /* orbit centre: the bounds' centre           */
    float orbit_distance;   /* |eye - centre| in orbit mode               */
    float min_distance;     /* least orbit distance                       */
    float look_distance;    /* |look - eye| of the home view              */
    sg_nav_view home;       /* the first view, for reset                  */
    int at_home;            /* 1 until the first move after init/reset:
                               sg_nav_get_view returns home exactly       */
} sg_navigator;

/* Starts at home (its look - eye sets yaw and pitch) in walk mode; speed
 * and the orbit centre come from bounds (an empty box: speed 1, centre =
 * home.look). home must be valid (look != eye, finite). */
void sg_nav_init(sg_navigator *n, const sg_nav_view *home, sg_aabb bounds);

/* Advances by dt seconds (>= 0) of input. Returns 1 if the view changed. */
int sg_nav_update(sg_navigator *n, const sg_nav_input *in, float dt);

/* Switches mode. To orbit: the distance is the eye's to the centre (at
 * least the minimum) and the view turns to the centre. To walk: the view
 * is kept. */
void sg_nav_set_mode(sg_navigator *n, sg_nav_mode mode);

/* Back to the home view, in walk mode. */
void sg_nav_reset(sg_navigator *n);

/* The unit view direction of yaw and pitch. */
sg_vec3 sg_nav_forward(float yaw, float pitch);

/* The current view (look at look_distance along the view direction; the
 * home view itself while at home). */
sg_nav_view sg_nav_get_view(const sg_navigator *n);

/* The current view as a camera with the given aspect (width / height). */
sg_status sg_nav_camera(const sg_navigator *n, float aspect, sg_camera *out, sg_error *err);

/* A view framing bounds (sg_camera_frame's 3/4 view from the front, 40
 * degrees), for scenes without cameras. SG_ERR_INVALID_ARG for an empty box. */
sg_status sg_nav_frame_view(sg_aabb bounds, sg_nav_view *out, sg_error *err);

#endif
