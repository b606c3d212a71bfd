/* test_leaks.c — no ray slips through a closed splat surface (issue 12):
 * thin walls stop every ray from either side, a ray leaving a fold is
 * stopped by the fold's other side however close, a hit always faces the
 * ray the way its crossing says, and a camera outside a model never sees
 * its inside (nor one inside it its outside). Both surface models.
 *
 * Each test counts failures over many rays and asserts zero: these are
 * geometric statements, not statistical ones, so any single counter-example
 * is a bug (it prints the first one). */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "points/model_points.h"
#include "points/radius.h"
#include "surface/scene.h"

static const float PI = 3.14159265358979f;

static sg_scene *build(const sg_pointset *ps, sg_surface_model model)
{
    sg_scene_desc d = {.model = model};
    sg_scene *s = NULL;
    sg_error err = {0};
    if (sg_scene_create(&d, ps, &s, &err) != SG_OK)
        fail_msg("sg_scene_create: %s", err.message);
    return s;
}

/* The rotation of the tilted walls: 35 degrees about x, then 20 about z,
 * so that no axis of the kd-tree is the wall's (cell shrinking slices a
 * cell along the dominant axis of its normals, which cancel in a wall). */
static sg_vec3 rot(sg_vec3 v, int inverse)
{
    const float a = 0.6108652f, b = 0.3490659f, ca = cosf(a), sa = sinf(a), cb = cosf(b), sb = sinf(b);
    if (!inverse) {
        v = sg_v3(v.x, ca * v.y - sa * v.z, sa * v.y + ca * v.z);
        return sg_v3(cb * v.x - sb * v.y, sb * v.x + cb * v.y, v.z);
    }
    v = sg_v3(cb * v.x + sb * v.y, -sb * v.x + cb * v.y, v.z);
    return sg_v3(v.x, ca * v.y + sa * v.z, -sa * v.y + ca * v.z);
}

/* A wall as thin as a splat radius or thinner stops every ray that meets
 * it, from either side and at any angle up to 75 degrees from its normal:
 * a camera ray (either face), a ray leaving a surface outwards (front
 * faces only: bounce and shadow rays), and as a shadow query. The hit is
 * the near layer, seen from the front. Before issue 12 the MLS field of
 * the two layers cancelled (F = (y - p) (W_top - W_bottom) keeps one sign
 * across a wall thinner than about r / 2) and these rays passed. */
static void check_thin_wall(sg_surface_model model, float thick_in_radii, int tilted)
{
    const int g = 60;
    float r = 2.0f * 2.0f / (float)(g - 1);
    sg_pointset ps = {0};
    float h;
    /* a wall of a room, a sheet of paper: two g x g layers, radius 2h */
    sg_test_make_sheet(&ps, g, thick_in_radii * r, &h);
    r = 2.0f * h;
    float half = 0.5f * thick_in_radii * r;
    for (size_t i = 0; tilted && i < ps.count; ++i) {
        sg_vec3 p = rot(sg_pointset_position(&ps, i), 0), n = rot(sg_pointset_normal(&ps, i), 0);
        ps.px[i] = p.x, ps.py[i] = p.y, ps.pz[i] = p.z, ps.nx[i] = n.x, ps.ny[i] = n.y, ps.nz[i] = n.z;
    }
    sg_scene *s = build(&ps, model);
    uint64_t rng = 17;
    int failures = 0, rays = 0;
    for (int i = 0; i < 400; ++i) {
        float x = 1.6f * sg_test_rand01(&rng) - 0.8f, z = 1.6f * sg_test_rand01(&rng) - 0.8f;
        for (int side = 0; side < 2; ++side) {
            float sy = side ? -1.0f : 1.0f;
            sg_vec3 d = sg_test_random_dir(&rng);
            if (d.y * sy > 0.0f)
                d.y = -d.y;
            if (-d.y * sy < 0.26f) /* at most 75 degrees from the normal */
                d = sg_v3_normalize(sg_v3(d.x, -sy * 0.26f, d.z));
            sg_vec3 at = sg_v3(x, sy * half, z);
            for (int f = 0; f < 2; ++f) {
                uint32_t flags = f ? SG_RAY_FRONT_ONLY : SG_RAY_ANY_FACE;
                if (model == SG_SURFACE_DISK && thick_in_radii == 0.0f && flags == SG_RAY_ANY_FACE)
                    continue; /* coincident disks: documented to show either side (test_scene.c) */
                sg_ray ray = {.org = sg_v3_sub(at, sg_v3_scale(d, 0.5f)), .dir = d, .tmin = 0, .tmax = INFINITY,
                              .flags = flags};
                if (tilted)
                    ray.org = rot(ray.org, 0), ray.dir = rot(ray.dir, 0);
                sg_hit hit;
                ++rays;
                int ok = sg_scene_intersect(s, &ray, &hit, NULL);
                if (ok && tilted) /* back into the wall's frame */
                    hit.p = rot(hit.p, 1), hit.n = rot(hit.n, 1);
                const char *why = !ok                               ? "passed through"
                                  : !(sg_v3_dot(hit.n, d) < 0.0f)    ? "hit from behind"
                                  : !(hit.n.y * sy > 0.9f)           ? "normal of the far side"
                                  : !(fabsf(hit.p.y) <= half + 0.05f * r) ? "hit off the wall"
                                  : !sg_scene_occluded(s, &ray, NULL) ? "shadow query passed"
                                                                     : NULL;
                if (why && failures++ == 0)
                    fprintf(stderr, "model %d thickness %g r tilted %d side %d flags %u: ray to (%g, %g) dir (%g %g "
                                    "%g): %s (hit y %g, n.y %g)\n",
                            (int)model, thick_in_radii, tilted, side, flags, x, z, d.x, d.y, d.z, why,
                            ok ? hit.p.y : 0.0f, ok ? hit.n.y : 0.0f);
            }
        }
    }
    if (failures)
        fail_msg("model %d, wall %g radii thick%s: %d of %d rays not stopped by the near layer", (int)model,
                 thick_in_radii, tilted ? ", tilted" : "", failures, rays);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}

static void test_mls_thin_wall_stops_rays(void **state)
{
    (void)state;
    const float thick[] = {1.0f, 0.5f, 0.25f, 0.1f, 0.0f};
    for (int i = 0; i < 5; ++i)
        for (int tilted = 0; tilted < 2; ++tilted)
            check_thin_wall(SG_SURFACE_MLS, thick[i], tilted);
}
static void test_disk_thin_wall_stops_rays(void **state)
{
    (void)state;
    const float thick[] = {1.0f, 0.5f, 0.25f, 0.1f, 0.0f};
    for (int i = 0; i < 5; ++i)
        for (int tilted = 0; tilted < 2; ++tilted)
            check_thin_wall(SG_SURFACE_DISK, thick[i], tilted);
}

/* A closed spherical shell whose wall (two layers, outer facing out, inner
 * facing in) is 0.8 point spacings thick, radii by the k = 8 nearest
 * neighbours of both layers (as a scene file's model gets them: about 0.7
 * radii thick), seen from inside: every ray that leaves the inner
 * layer into the shell (front faces only, as a bounce or shadow ray) or
 * starts inside (any face) is stopped by the inner layer. Besides the field's groups this needs the
 * kd-tree's cell shrinking (§3.4.1) to keep the slices of a cell that hold
 * only a group's surface: it tested the single field, in which the layers
 * cancel, and culled them (without that, 11 of the 1500 rays here are not
 * stopped at the inner layer; before issue 12, with the single field, all
 * went through). */
static void check_shell(sg_surface_model model)
{
    const size_t n = 20000;
    const float golden = PI * (3.0f - sqrtf(5.0f)), h = sqrtf(4.0f * PI / (float)n);
    const float thick = 0.8f * h;
    sg_pointset ps = {0};
    assert_int_equal(sg_pointset_alloc(&ps, 2 * n, NULL), SG_OK);
    for (size_t k = 0; k < 2 * n; ++k) {
        size_t i = k % n;
        int inner = k >= n;
        float y = 1.0f - 2.0f * ((float)i + 0.5f) / (float)n, rr = sqrtf(1.0f - y * y);
        float phi = golden * (float)i + (inner ? 0.5f : 0.0f), R = 1.0f + (inner ? -0.5f : 0.5f) * thick;
        float s = inner ? -1.0f : 1.0f;
        ps.px[k] = R * cosf(phi) * rr, ps.py[k] = R * y, ps.pz[k] = R * sinf(phi) * rr;
        ps.nx[k] = s * cosf(phi) * rr, ps.ny[k] = s * y, ps.nz[k] = s * sinf(phi) * rr;
        ps.radius[k] = 1.0f;
    }
    sg_radius_desc rd = {0};
    assert_int_equal(sg_points_estimate_radii(&ps, &rd, NULL), SG_OK);
    float r = ps.radius[0];
    sg_scene *s = build(&ps, model);
    uint64_t rng = 23;
    int failures = 0;
    for (int i = 0; i < 1500; ++i) {
        sg_vec3 o = sg_v3_scale(sg_test_random_dir(&rng), 0.9f * sg_test_rand01(&rng));
        sg_ray ray = {.org = o, .dir = sg_test_random_dir(&rng), .tmin = 0, .tmax = INFINITY};
        sg_hit hit;
        int ok = sg_scene_intersect(s, &ray, &hit, NULL);
        if (ok && (i & 1)) { /* leave the hit into the shell, as a bounce does */
            sg_vec3 d = sg_test_random_dir_facing(&rng, hit.n);
            ray = sg_scene_spawn_ray(s, &hit, d, INFINITY);
            if (sg_v3_dot(d, sg_v3_normalize(hit.p)) > -0.2f)
                continue; /* within 12 degrees of the wall: the self test's blind spot (ray.h) */
            ok = sg_scene_intersect(s, &ray, &hit, NULL);
        }
        const char *why = !ok                                               ? "got out"
                          : !(sg_v3_dot(hit.n, ray.dir) < 0.0f)             ? "hit from behind"
                          : !(fabsf(sg_v3_length(hit.p) - (1.0f - 0.5f * thick)) < 0.1f * r) ? "hit off the inner layer"
                                                                             : NULL;
        if (why && failures++ == 0)
            fprintf(stderr, "model %d ray %d flags %u: %s (|p| %g)\n", (int)model, i, ray.flags, why,
                    ok ? sg_v3_length(hit.p) : 0.0f);
    }
    if (failures)
        fail_msg("model %d: %d of 1500 rays from inside a thin closed shell not stopped by its inner layer", (int)model,
                 failures);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_mls_thin_shell_holds_rays(void **state) { (void)state; check_shell(SG_SURFACE_MLS); }
static void test_disk_thin_shell_holds_rays(void **state) { (void)state; check_shell(SG_SURFACE_DISK); }

/* The inside of a cylinder of radius 2r (normals inwards: a fold, a pipe)
 * is concave: a ray leaving the wall at 10 to 12 degrees meets the wall
 * again after the chord 2 R sin(angle) = 0.7 to 0.83 r, where the wall has
 * turned by twice the angle, 20 to 24 degrees. Nearer than the splat
 * radius and within 25 degrees of the start normal, such a crossing once
 * counted as the ray's own surface (ray.h, seamless rays) and was skipped,
 * so the ray left through the wall. It rises above the tangent plane the
 * ray left by 0.12 to 0.17 r, which tells it from the reconstruction's
 * own bumps (SG_SELF_RISE): the ray is stopped. */
static void check_fold(sg_surface_model model)
{
    const int around = 48, along = 80;
    const float R = 1.0f, h = 2.0f * PI * R / (float)around, r = R / 2.0f; /* spacing h = 0.13 R */
    sg_pointset ps = {0};
    assert_int_equal(sg_pointset_alloc(&ps, (size_t)around * along, NULL), SG_OK);
    size_t k = 0;
    for (int j = 0; j < along; ++j)
        for (int i = 0; i < around; ++i, ++k) {
            float a = 2.0f * PI * ((float)i + 0.5f * (float)(j & 1)) / (float)around;
            ps.px[k] = R * cosf(a), ps.py[k] = R * sinf(a), ps.pz[k] = h * ((float)j - 0.5f * (float)along);
            ps.nx[k] = -cosf(a), ps.ny[k] = -sinf(a), ps.nz[k] = 0;
            ps.radius[k] = r;
        }
    sg_scene *s = build(&ps, model);
    uint64_t rng = 29;
    int failures = 0, rays = 0;
    for (int i = 0; i < 300; ++i) {
        /* A camera ray from the axis to the wall, then a ray leaving the hit
         * at the angle, around the axis one way or the other. */
        float a = 2.0f * PI * sg_test_rand01(&rng), zz = 0.3f * (sg_test_rand01(&rng) - 0.5f);
        sg_ray cam = {.org = sg_v3(0, 0, zz), .dir = sg_v3(cosf(a), sinf(a), 0), .tmin = 0, .tmax = INFINITY};
        sg_hit hit;
        if (!sg_scene_intersect(s, &cam, &hit, NULL))
            fail_msg("model %d: camera ray %d from the axis missed the pipe", (int)model, i);
        float ang = (10.0f + 2.0f * sg_test_rand01(&rng)) * PI / 180.0f, turn = sg_test_rand01(&rng) < 0.5f ? 1.0f : -1.0f;
        sg_vec3 tangent = sg_v3(-sinf(a) * turn, cosf(a) * turn, 0);
        sg_vec3 d = sg_v3_normalize(sg_v3_add(sg_v3_scale(tangent, cosf(ang)), sg_v3_scale(hit.n, sinf(ang))));
        sg_ray out = sg_scene_spawn_ray(s, &hit, d, INFINITY);
        sg_hit h2;
        ++rays;
        int ok = sg_scene_intersect(s, &out, &h2, NULL);
        /* expected: the chord, 2 R sin(angle) from the start */
        float chord = 2.0f * R * sinf(ang);
        const char *why = !ok                                  ? "left through the wall"
                          : !(fabsf(h2.t - chord) < 0.25f * r) ? "hit at the wrong place"
                          : !sg_scene_occluded(s, &out, NULL)   ? "shadow query passed"
                                                                : NULL;
        if (why && failures++ == 0)
            fprintf(stderr, "model %d: ray %d at %.1f deg: %s (t %g, chord %g)\n", (int)model, i,
                    (double)(ang * 180.0f / PI), why, ok ? h2.t : 0.0f, chord);
    }
    if (failures)
        fail_msg("model %d: %d of %d rays leaving the inside of a pipe of radius 2r at 10-12 degrees got out",
                 (int)model, failures, rays);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_mls_fold_stops_shallow_rays(void **state) { (void)state; check_fold(SG_SURFACE_MLS); }
static void test_disk_fold_stops_shallow_rays(void **state) { (void)state; check_fold(SG_SURFACE_DISK); }

/* The side of a hit is the side its crossing says: a ray that accepts only
 * front faces gets a normal facing it, and a camera ray from outside the
 * model never meets a surface from behind. Rays graze the scanned bunny at
 * 80 to 90 degrees from the normal at random splats (silhouettes, creases,
 * the ears' thin rims), where the interpolated normal and the field's
 * crossing used to disagree (MLS) and disks overhanging a rim faced away
 * from a camera that had not entered the model. */
static void check_sides(sg_surface_model model)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/bunny.ply", SG_ASSET_DIR);
    sg_pointset ps = {0};
    sg_error err = {0};
    sg_model_points_desc md = {.points = 30000};
    if (sg_model_points_load(path, &md, &ps, &err) != SG_OK)
        fail_msg("%s", err.message);
    sg_scene *s = build(&ps, model);
    sg_scene_info info;
    sg_scene_get_info(s, &info);
    uint64_t rng = 41;
    int failures = 0, rays = 0;
    for (int i = 0; i < 6000; ++i) {
        uint32_t j = (uint32_t)(sg_test_rand01(&rng) * (float)ps.count) % (uint32_t)ps.count;
        sg_vec3 p = sg_pointset_position(&ps, j), n = sg_pointset_normal(&ps, j);
        sg_vec3 t = sg_test_random_dir(&rng);
        t = sg_v3_normalize(sg_v3_sub(t, sg_v3_scale(n, sg_v3_dot(t, n))));
        float ang = (60.0f + 25.0f * sg_test_rand01(&rng)) * PI / 180.0f;
        sg_vec3 d = sg_v3_normalize(sg_v3_add(sg_v3_scale(n, -cosf(ang)), sg_v3_scale(t, sinf(ang))));
        /* From well outside the model's box, along d through p. */
        sg_ray ray = {.org = sg_v3_sub(p, sg_v3_scale(d, info.diagonal)), .dir = d, .tmin = 0, .tmax = INFINITY};
        for (int f = 0; f < 2; ++f) {
            ray.flags = f ? SG_RAY_FRONT_ONLY : SG_RAY_ANY_FACE;
            sg_hit hit;
            ++rays;
            if (sg_scene_intersect(s, &ray, &hit, NULL) && !(sg_v3_dot(hit.n, d) < 0.0f) && failures++ == 0)
                fprintf(stderr, "model %d ray %d flags %u: hit at t %g with dot(dir, n) = %g\n", (int)model, i,
                        ray.flags, hit.t, sg_v3_dot(hit.n, d));
        }
    }
    if (failures)
        fail_msg("model %d: %d of %d rays from outside met a surface from behind", (int)model, failures, rays);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_mls_outside_rays_meet_front_faces(void **state) { (void)state; check_sides(SG_SURFACE_MLS); }
static void test_disk_outside_rays_meet_front_faces(void **state) { (void)state; check_sides(SG_SURFACE_DISK); }

/* ...while a camera inside a closed model sees its inside: every ray from
 * the centre of a sampled sphere meets the sphere from behind (the rules
 * above must not turn the inside into a front). */
static void check_inside(sg_surface_model model)
{
    sg_pointset ps = {0};
    const size_t n = 20000;
    assert_int_equal(sg_pointset_alloc(&ps, n, NULL), SG_OK);
    float h = sqrtf(4.0f * PI / (float)n);
    const float golden = PI * (3.0f - sqrtf(5.0f));
    for (size_t i = 0; i < n; ++i) {
        float y = 1.0f - 2.0f * ((float)i + 0.5f) / (float)n, rr = sqrtf(1.0f - y * y), phi = golden * (float)i;
        ps.px[i] = cosf(phi) * rr, ps.py[i] = y, ps.pz[i] = sinf(phi) * rr;
        ps.nx[i] = ps.px[i], ps.ny[i] = y, ps.nz[i] = ps.pz[i];
        ps.radius[i] = 2.0f * h;
    }
    sg_scene *s = build(&ps, model);
    uint64_t rng = 5;
    int failures = 0;
    for (int i = 0; i < 3000; ++i) {
        sg_vec3 o = sg_v3_scale(sg_test_random_dir(&rng), 0.3f * sg_test_rand01(&rng));
        sg_ray ray = {.org = o, .dir = sg_test_random_dir(&rng), .tmin = 0, .tmax = INFINITY};
        sg_hit hit;
        if (!(sg_scene_intersect(s, &ray, &hit, NULL) && sg_v3_dot(hit.n, ray.dir) > 0.0f) && failures++ == 0)
            fprintf(stderr, "model %d ray %d from inside: no back-face hit\n", (int)model, i);
    }
    if (failures)
        fail_msg("model %d: %d of 3000 rays from inside a sphere did not see its inside", (int)model, failures);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_mls_inside_rays_meet_back_faces(void **state) { (void)state; check_inside(SG_SURFACE_MLS); }
static void test_disk_inside_rays_meet_back_faces(void **state) { (void)state; check_inside(SG_SURFACE_DISK); }

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mls_thin_wall_stops_rays),
        cmocka_unit_test(test_disk_thin_wall_stops_rays),
        cmocka_unit_test(test_mls_thin_shell_holds_rays),
        cmocka_unit_test(test_disk_thin_shell_holds_rays),
        cmocka_unit_test(test_mls_fold_stops_shallow_rays),
        cmocka_unit_test(test_disk_fold_stops_shallow_rays),
        cmocka_unit_test(test_mls_outside_rays_meet_front_faces),
        cmocka_unit_test(test_disk_outside_rays_meet_front_faces),
        cmocka_unit_test(test_mls_inside_rays_meet_back_faces),
        cmocka_unit_test(test_disk_inside_rays_meet_back_faces),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
