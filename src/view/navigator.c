/* navigator.c — walk and orbit camera control (navigator.h).
 *
 * Invariants:
 *  1. |pitch| <= SG_NAV_PITCH_MAX_DEG in radians after every call.
 *  2. In orbit mode, eye = centre - orbit_distance * forward(yaw, pitch),
 *     and orbit_distance >= min_distance.
 *  3. at_home implies eye, fov and the view direction are home's.
 */
#include "view/navigator.h"

#include <assert.h>
#include <math.h>

#define NAV__PI 3.14159265358979323846f

static float nav__pitch_max(void) { return SG_NAV_PITCH_MAX_DEG * NAV__PI / 180.0f; }

static float nav__clamp_pitch(float p)
{
    float m = nav__pitch_max();
    return p > m ? m : (p < -m ? -m : p);
}

sg_vec3 sg_nav_forward(float yaw, float pitch)
{
    float cp = cosf(pitch);
    return sg_v3(cp * sinf(yaw), sinf(pitch), -cp * cosf(yaw));
}

/* yaw and pitch of direction d (need not be unit, non-zero). */
static void nav__angles(sg_vec3 d, float *yaw, float *pitch)
{
    d = sg_v3_normalize(d);
    float y = d.y > 1.0f ? 1.0f : (d.y < -1.0f ? -1.0f : d.y);
    *pitch = nav__clamp_pitch(asinf(y));
    *yaw = (d.x == 0.0f && d.z == 0.0f) ? 0.0f : atan2f(d.x, -d.z);
}

static void nav__place_orbit(sg_navigator *n)
{
    n->eye = sg_v3_madd(n->centre, sg_nav_forward(n->yaw, n->pitch), -n->orbit_distance); /* invariant 2 */
}

void sg_nav_init(sg_navigator *n, const sg_nav_view *home, sg_aabb bounds)
{
    assert(n && home);
    float diag = sg_aabb_diagonal(bounds);
    int have_box = diag > 0.0f && isfinite(diag);
    n->home = *home;
    n->speed = have_box ? SG_NAV_SPEED_FRACTION * diag : 1.0f;
    n->centre = have_box ? sg_v3_scale(sg_v3_add(bounds.lo, bounds.hi), 0.5f) : home->look;
    n->min_distance = have_box ? SG_NAV_ORBIT_MIN_FRACTION * diag : 0.01f;
    n->look_distance = sg_v3_length(sg_v3_sub(home->look, home->eye));
    sg_nav_reset(n);
}

void sg_nav_reset(sg_navigator *n)
{
    n->mode = SG_NAV_WALK;
    n->eye = n->home.eye;
    n->fov_deg = n->home.fov_deg;
    nav__angles(sg_v3_sub(n->home.look, n->home.eye), &n->yaw, &n->pitch);
    n->orbit_distance = sg_v3_length(sg_v3_sub(n->eye, n->centre));
    n->at_home = 1; /* invariant 3 */
}

void sg_nav_set_mode(sg_navigator *n, sg_nav_mode mode)
{
    if (mode == n->mode)
        return;
    n->mode = mode;
    if (mode == SG_NAV_ORBIT) {
        sg_vec3 to_centre = sg_v3_sub(n->centre, n->eye);
        float dist = sg_v3_length(to_centre);
        if (dist > 0.0f)
            nav__angles(to_centre, &n->yaw, &n->pitch);
        n->orbit_distance = dist < n->min_distance ? n->min_distance : dist;
        nav__place_orbit(n);
        n->at_home = 0;
    }
}

int sg_nav_update(sg_navigator *n, const sg_nav_input *in, float dt)
{
    assert(n && in && dt >= 0.0f);
    float old_yaw = n->yaw, old_pitch = n->pitch;
    sg_vec3 old_eye = n->eye;

    n->yaw += in->look_dx * SG_NAV_LOOK_RATE;
    n->pitch = nav__clamp_pitch(n->pitch - in->look_dy * SG_NAV_LOOK_RATE); /* invariant 1 */
    n->yaw = remainderf(n->yaw, 2.0f * NAV__PI);

    float speed = n->speed * (in->fast ? SG_NAV_FAST_FACTOR : 1.0f);
    float fwd = (float)((in->forward != 0) - (in->back != 0));
    float side = (float)((in->right != 0) - (in->left != 0));
    float lift = (float)((in->up != 0) - (in->down != 0));

    if (n->mode == SG_NAV_WALK) {
        sg_vec3 f = sg_nav_forward(n->yaw, n->pitch);
        sg_vec3 r = sg_v3_normalize(sg_v3_cross(f, sg_v3(0.0f, 1.0f, 0.0f)));
        sg_vec3 move = sg_v3_add(sg_v3_add(sg_v3_scale(f, fwd), sg_v3_scale(r, side)),
                                 sg_v3(0.0f, lift, 0.0f));
        float len = sg_v3_length(move);
        if (len > 0.0f)
            n->eye = sg_v3_madd(n->eye, move, speed * dt / len);
    } else {
        n->yaw = remainderf(n->yaw - side * SG_NAV_ORBIT_RATE * dt, 2.0f * NAV__PI);
        n->pitch = nav__clamp_pitch(n->pitch - lift * SG_NAV_ORBIT_RATE * dt);
        n->orbit_distance -= fwd * speed * dt;
        if (n->orbit_distance < n->min_distance)
            n->orbit_distance = n->min_distance;
        nav__place_orbit(n);
    }
    int moved = n->yaw != old_yaw || n->pitch != old_pitch || n->eye.x != old_eye.x || n->eye.y != old_eye.y ||
                n->eye.z != old_eye.z;
    if (moved)
        n->at_home = 0;
    return moved;
}

sg_nav_view sg_nav_get_view(const sg_navigator *n)
{
    if (n->at_home)
        return n->home;
    sg_nav_view v;
    float d = n->mode == SG_NAV_ORBIT ? n->orbit_distance : n->look_distance;
    if (!(d > 0.0f))
        d = 1.0f;
    v.eye = n->eye;
    v.look = sg_v3_madd(n->eye, sg_nav_forward(n->yaw, n->pitch), d);
    v.up = sg_v3(0.0f, 1.0f, 0.0f);
    v.fov_deg = n->fov_deg;
    return v;
}

sg_status sg_nav_camera(const sg_navigator *n, float aspect, sg_camera *out, sg_error *err)
{
    sg_nav_view v = sg_nav_get_view(n);
    return sg_camera_look_at(v.eye, v.look, v.up, v.fov_deg, aspect, out, err);
}

sg_status sg_nav_frame_view(sg_aabb bounds, sg_nav_view *out, sg_error *err)
{
    sg_camera cam;
    sg_vec3 up = sg_v3(0.0f, 1.0f, 0.0f);
    sg_status st = sg_camera_frame(bounds, sg_v3(0.0f, -0.35f, -1.0f), up, 40.0f, 1.0f, 0.0f, &cam, err);
    if (st != SG_OK)
        return st;
    out->eye = cam.eye;
    out->look = sg_v3_scale(sg_v3_add(bounds.lo, bounds.hi), 0.5f);
    out->up = up;
    out->fov_deg = 40.0f;
    return SG_OK;
}
