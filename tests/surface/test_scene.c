/* test_scene.c — ray tracing the MLS and disk surfaces: accuracy on a
 * sampled sphere, no holes, sharp edges, thin sheets, seamless secondary
 * rays, SIMD/scalar agreement, bad input. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "surface/mls.h"
#include "surface/scene.h"

static const float PI = 3.14159265358979f;

/* N points on the sphere of radius R by the Fibonacci spiral: near-uniform
 * spacing h = sqrt(4 pi R^2 / N). Radius of support = 2h, so every surface
 * point is covered by several splats. */
static void make_sphere(sg_pointset *ps, size_t n, float R, float *spacing)
{
    assert_int_equal(sg_pointset_alloc(ps, n, NULL), SG_OK);
    float h = sqrtf(4.0f * PI * R * R / (float)n);
    const float golden = PI * (3.0f - sqrtf(5.0f));
    for (size_t i = 0; i < n; ++i) {
        float y = 1.0f - 2.0f * ((float)i + 0.5f) / (float)n;
        float rr = sqrtf(1.0f - y * y), phi = golden * (float)i;
        float x = cosf(phi) * rr, z = sinf(phi) * rr;
        ps->px[i] = R * x; ps->py[i] = R * y; ps->pz[i] = R * z;
        ps->nx[i] = x; ps->ny[i] = y; ps->nz[i] = z;
        ps->radius[i] = 2.0f * h;
    }
    *spacing = h;
}

static sg_scene *build(const sg_pointset *ps, sg_surface_model model, sg_kernel kernel, uint32_t disable)
{
    sg_scene_desc d = {.model = model, .kernel = kernel, .kd_disable = disable};
    sg_scene *s = NULL;
    sg_error err = {0};
    sg_status st = sg_scene_create(&d, ps, &s, &err);
    if (st != SG_OK)
        fail_msg("sg_scene_create: %s", err.message);
    return s;
}

/* A random unit vector from two uniforms. */
/* A ray from outside (distance 4R) towards the sphere point R * target,
 * entering at an angle of at most ~60 degrees from the normal. */
static sg_ray ray_at_sphere(sg_vec3 target, float R, uint64_t *rng)
{
    sg_vec3 jitter = sg_v3_scale(sg_test_random_dir(rng), 0.5f);
    sg_vec3 from = sg_v3_scale(sg_v3_normalize(sg_v3_add(target, jitter)), 4.0f * R);
    sg_vec3 to = sg_v3_scale(target, R);
    sg_ray r = {.org = from, .dir = sg_v3_normalize(sg_v3_sub(to, from)), .tmin = 0, .tmax = INFINITY};
    return r;
}

/* Hits on a sampled sphere lie on the true sphere, normals close to radial.
 *
 * Tolerances. The MLS surface through points of a sphere sits where x
 * meets the weighted mean p̄ of the points within r of x along n̄; the
 * points of a cap of radius r lie within r^2 / (2R) of the tangent plane, so
 * p̄ (and the root) lies within r^2 / (2R) of the sphere. The normal n̄ is
 * a weighted mean of unit normals within the cone of half-angle asin(r/R)
 * around the hit's radial direction, so it lies within that cone. */
static void check_sphere(sg_surface_model model, sg_kernel kernel, uint32_t disable)
{
    const float R = 1.0f;
    sg_pointset ps = {0};
    float h;
    make_sphere(&ps, 20000, R, &h);
    float r = 2.0f * h;
    sg_scene *s = build(&ps, model, kernel, disable);
    float pos_tol = r * r / (2.0f * R) + 1e-4f;
    float ang_tol = asinf(r / R);
    uint64_t rng = 1;
    int misses = 0;
    float worst_pos = 0, worst_ang = 0;
    for (int i = 0; i < 4000; ++i) {
        sg_vec3 target = sg_test_random_dir(&rng);
        sg_ray ray = ray_at_sphere(target, R, &rng);
        sg_hit hit;
        if (!sg_scene_intersect(s, &ray, &hit, NULL)) {
            ++misses;
            continue;
        }
        float dpos = fabsf(sg_v3_length(hit.p) - R);
        float cosang = sg_v3_dot(hit.n, sg_v3_normalize(hit.p));
        float ang = acosf(fminf(1.0f, cosang));
        worst_pos = fmaxf(worst_pos, dpos);
        worst_ang = fmaxf(worst_ang, ang);
        assert_true(hit.splat < ps.count);
    }
    if (misses || worst_pos > pos_tol || worst_ang > ang_tol)
        fail_msg("model %d kernel %d disable %u: %d misses of 4000, worst |p|-R %g (tol %g), "
                 "worst normal angle %g rad (tol %g)",
                 (int)model, (int)kernel, disable, misses, worst_pos, pos_tol, worst_ang, ang_tol);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}

static void test_mls_sphere_hat(void **state) { (void)state; check_sphere(SG_SURFACE_MLS, SG_KERNEL_HAT, 0); }
static void test_mls_sphere_gaussian(void **state) { (void)state; check_sphere(SG_SURFACE_MLS, SG_KERNEL_GAUSSIAN, 0); }
static void test_mls_sphere_no_refinements(void **state)
{
    (void)state;
    check_sphere(SG_SURFACE_MLS, SG_KERNEL_HAT, SG_KD_NO_REFINEMENTS);
}
static void test_mls_sphere_each_refinement_alone(void **state)
{
    (void)state;
    check_sphere(SG_SURFACE_MLS, SG_KERNEL_HAT, SG_KD_NO_ENCOURAGE | SG_KD_NO_COLLAPSE);
    check_sphere(SG_SURFACE_MLS, SG_KERNEL_HAT, SG_KD_NO_SHRINK | SG_KD_NO_COLLAPSE);
    check_sphere(SG_SURFACE_MLS, SG_KERNEL_HAT, SG_KD_NO_SHRINK | SG_KD_NO_ENCOURAGE);
}
static void test_disk_sphere(void **state) { (void)state; check_sphere(SG_SURFACE_DISK, SG_KERNEL_HAT, 0); }

/* No holes: a dense grid of parallel rays across the sphere's silhouette
 * disk (shrunk by one splat radius, where the surface must be) all hit. */
static void check_no_holes(sg_surface_model model)
{
    sg_pointset ps = {0};
    float h;
    make_sphere(&ps, 50000, 1.0f, &h);
    sg_scene *s = build(&ps, model, SG_KERNEL_HAT, 0);
    float inner = 1.0f - 2.0f * h;
    int misses = 0, rays = 0;
    for (int view = 0; view < 3; ++view) {
        for (int i = 0; i < 200; ++i)
            for (int j = 0; j < 200; ++j) {
                float u = -1.0f + 2.0f * ((float)i + 0.5f) / 200.0f, v = -1.0f + 2.0f * ((float)j + 0.5f) / 200.0f;
                if (u * u + v * v > inner * inner)
                    continue;
                sg_vec3 o = view == 0 ? sg_v3(u, v, 5) : view == 1 ? sg_v3(5, u, v) : sg_v3(u, 5, v);
                sg_vec3 d = view == 0 ? sg_v3(0, 0, -1) : view == 1 ? sg_v3(-1, 0, 0) : sg_v3(0, -1, 0);
                sg_ray ray = {.org = o, .dir = d, .tmin = 0, .tmax = INFINITY};
                ++rays;
                sg_hit hit;
                if (!sg_scene_intersect(s, &ray, &hit, NULL)) {
                    if (misses < 5)
                        fprintf(stderr, "miss: view %d u %g v %g\n", view, u, v);
                    ++misses;
                }
            }
    }
    if (misses)
        fail_msg("model %d: %d of %d rays missed a closed, densely sampled sphere", (int)model, misses, rays);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_mls_no_holes(void **state) { (void)state; check_no_holes(SG_SURFACE_MLS); }
static void test_disk_no_holes(void **state) { (void)state; check_no_holes(SG_SURFACE_DISK); }

/* Sharp-edged cube, documented behaviour: the MLS surface rounds edges and
 * corners within one splat radius r, the disks overhang them by at most r;
 * both stay closed (every ray aimed at the cube hits) and face centres get
 * the face normal. */
/* The sharp-edged cube of 80 x 80 splats a face, radius r = 2 h, as a
 * scene of the given model. */
static sg_scene *cube_scene(sg_pointset *ps, sg_surface_model model, float *r)
{
    float h;
    sg_test_make_cube(ps, 80, &h);
    *r = 2.0f * h;
    return build(ps, model, SG_KERNEL_HAT, 0);
}

static void check_cube(sg_surface_model model)
{
    sg_pointset ps = {0};
    float r;
    sg_scene *s = cube_scene(&ps, model, &r);
    uint64_t rng = 7;
    int misses = 0;
    float worst = 0;
    for (int i = 0; i < 3000; ++i) {
        /* Aim at a random point of the cube's surface, edges included. */
        sg_vec3 t = sg_v3(2 * sg_test_rand01(&rng) - 1, 2 * sg_test_rand01(&rng) - 1, 2 * sg_test_rand01(&rng) - 1);
        int axis = (int)(3 * sg_test_rand01(&rng)) % 3;
        float side = sg_test_rand01(&rng) < 0.5f ? -1.0f : 1.0f;
        if (axis == 0) t.x = side; else if (axis == 1) t.y = side; else t.z = side;
        sg_vec3 o = sg_v3_scale(sg_v3_normalize(sg_v3_add(t, sg_v3_scale(sg_test_random_dir(&rng), 0.3f))), 6.0f);
        sg_ray ray = {.org = o, .dir = sg_v3_normalize(sg_v3_sub(t, o)), .tmin = 0, .tmax = INFINITY};
        sg_hit hit;
        if (!sg_scene_intersect(s, &ray, &hit, NULL)) {
            ++misses;
            continue;
        }
        /* Distance from the cube's surface: the max-norm minus 1. */
        float m = fmaxf(fabsf(hit.p.x), fmaxf(fabsf(hit.p.y), fabsf(hit.p.z)));
        worst = fmaxf(worst, fabsf(m - 1.0f));
    }
    for (int f = 0; f < 6; ++f) {
        sg_vec3 n = sg_v3(f == 0 ? 1.f : f == 1 ? -1.f : 0.f, f == 2 ? 1.f : f == 3 ? -1.f : 0.f,
                          f == 4 ? 1.f : f == 5 ? -1.f : 0.f);
        sg_ray ray = {.org = sg_v3_scale(n, 5), .dir = sg_v3_scale(n, -1), .tmin = 0, .tmax = INFINITY};
        sg_hit hit;
        assert_true(sg_scene_intersect(s, &ray, &hit, NULL));
        assert_true(sg_v3_dot(hit.n, n) > 0.999f);
        assert_true(fabsf(hit.t - 4.0f) < 1e-3f);
    }
    if (misses || worst > r)
        fail_msg("cube, model %d: %d misses of 3000, worst distance from the faces %g (bound r = %g)", (int)model,
                 misses, worst, r);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_mls_cube_edges(void **state) { (void)state; check_cube(SG_SURFACE_MLS); }

/* The room's window, in small: a ray passing a convex edge of the cube on
 * the open side, crossing the plane of the face it enters (x = 1, facing
 * +x) a height m above the edge while it rises through the plane of the
 * other face (y = 1, whose splats face away from it and which it starts
 * behind). Each face's group of splats alone continues its plane past the
 * edge by up to r, so before mls.c's past_back_layer such rays met that
 * overhang: a window's reveals narrowed it (the built-in room's by 9% for
 * the sun). Now rays passing more than r / 4 above the edge miss, and rays
 * aimed more than r / 4 below it still hit the face (the edge is not cut
 * back instead). Both ray flags, since the sun's shadow rays are front-only
 * and a path's camera rays accept either face. */
static void test_mls_convex_edge_no_overhang(void **state)
{
    (void)state;
    sg_pointset ps = {0};
    float r;
    sg_scene *s = cube_scene(&ps, SG_SURFACE_MLS, &r);
    uint64_t rng = 11;
    int over = 0, under = 0, rays = 0;
    for (int i = 0; i < 400; ++i) {
        float m = (sg_test_rand01(&rng) < 0.5f ? 1.0f : -1.0f) * r * (0.25f + 0.75f * sg_test_rand01(&rng));
        float z = 1.6f * sg_test_rand01(&rng) - 0.8f, slope = 0.3f + 1.5f * sg_test_rand01(&rng);
        sg_vec3 aim = sg_v3(1.0f, 1.0f + m, z), o = sg_v3_add(aim, sg_v3(2.0f, -2.0f * slope, 0.0f));
        for (int f = 0; f < 2; ++f) {
            sg_ray ray = {.org = o, .dir = sg_v3_normalize(sg_v3_sub(aim, o)), .tmin = 0, .tmax = INFINITY,
                          .flags = f ? SG_RAY_FRONT_ONLY : SG_RAY_ANY_FACE};
            sg_hit hit;
            int got = sg_scene_intersect(s, &ray, &hit, NULL);
            ++rays;
            if (m > 0.0f && got && hit.p.x > 0.9f) /* the overhang (the far faces lie at x = -1) */
                ++over;
            if (m < 0.0f && !(got && fabsf(hit.p.x - 1.0f) < 0.25f * r && hit.n.x > 0.9f))
                ++under;
        }
    }
    if (over || under)
        fail_msg("convex edge: %d of %d rays met the faces' overhang, %d missed the face below the edge", over, rays,
                 under);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_disk_cube_edges(void **state) { (void)state; check_cube(SG_SURFACE_DISK); }

/* Thin two-sided sheet of thickness `thick` (in splat radii). Documented
 * behaviour: each side is seen from its own side with its own normal, at
 * any thickness, for both models:
 *  - disks, because back-facing disks are never hit by a front-only ray and
 *    a primary ray meets the near layer first;
 *  - MLS, because the two layers' splats carry layer keys (scene.c) and a
 *    ray takes the field of the layer facing it apart from the other
 *    (mls.c, "groups of splats"). Before issue 12 the two sides' weights
 *    cancelled in the normal sum: across the sheet F = (y - p) (W_top -
 *    W_bottom) kept one sign when the layers were much closer than r, so a
 *    sheet thinner than about r / 2 vanished.
 * With zero thickness the disks of both sides coincide: a ray that accepts
 * any face sees either, a front-only ray (a camera outside) its own side.
 * `expect_hits` says which of the two the test asserts. */
static void check_sheet(sg_surface_model model, float thick_in_radii, int expect_hits, uint32_t ray_flags)
{
    sg_pointset ps = {0};
    const int g = 60;
    float h = 2.0f / (float)(g - 1), r = 2.0f * h;
    float thick = thick_in_radii * r;
    sg_test_make_sheet(&ps, g, thick, &h);
    sg_scene *s = build(&ps, model, SG_KERNEL_HAT, 0);
    uint64_t rng = 3;
    int hits = 0, rays = 0;
    for (int i = 0; i < 300; ++i) {
        float x = 1.6f * sg_test_rand01(&rng) - 0.8f, z = 1.6f * sg_test_rand01(&rng) - 0.8f;
        for (int side = 0; side < 2; ++side) {
            float sy = side ? -1.0f : 1.0f;
            sg_vec3 o = sg_v3(x + 0.3f, 3.0f * sy, z - 0.2f);
            sg_ray ray = {.org = o, .dir = sg_v3_normalize(sg_v3_sub(sg_v3(x, 0, z), o)), .tmin = 0, .tmax = INFINITY,
                          .flags = ray_flags};
            sg_hit hit;
            ++rays;
            if (!sg_scene_intersect(s, &ray, &hit, NULL))
                continue;
            ++hits;
            /* A hit lies between the layers' outer faces (the disks of the
             * far layer are back-facing to this ray) with its own side's normal. */
            if (expect_hits && (!(hit.n.y * sy > 0.9f) || fabsf(hit.p.y) > 0.5f * thick + 1e-4f))
                fail_msg("sheet model %d thick %g r: ray %d side %d: hit y %g (half thickness %g), normal y %g",
                         (int)model, thick_in_radii, i, side, hit.p.y, 0.5f * thick, hit.n.y);
        }
    }
    if (expect_hits && hits != rays)
        fail_msg("sheet model %d thick %g r: %d of %d rays missed", (int)model, thick_in_radii, rays - hits, rays);
    if (!expect_hits && hits != 0)
        fail_msg("sheet model %d thick %g r: documented to vanish, but %d of %d rays hit", (int)model,
                 thick_in_radii, hits, rays);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_mls_thin_sheet(void **state)
{
    (void)state;
    check_sheet(SG_SURFACE_MLS, 1.0f, 1, SG_RAY_ANY_FACE);
    check_sheet(SG_SURFACE_MLS, 0.25f, 1, SG_RAY_ANY_FACE);
    check_sheet(SG_SURFACE_MLS, 0.0f, 1, SG_RAY_ANY_FACE);
    check_sheet(SG_SURFACE_MLS, 0.0f, 1, SG_RAY_FRONT_ONLY);
}
static void test_disk_thin_sheet(void **state)
{
    (void)state;
    check_sheet(SG_SURFACE_DISK, 1.0f, 1, SG_RAY_ANY_FACE);
    check_sheet(SG_SURFACE_DISK, 0.25f, 1, SG_RAY_ANY_FACE);
    /* Coincident layers: only the ray's face expectation can tell them apart. */
    check_sheet(SG_SURFACE_DISK, 0.0f, 1, SG_RAY_FRONT_ONLY);
}

/* Seamless secondary rays (Kashyap §3.6): a ray leaving the sphere outward
 * never hits the sphere it starts on; no epsilon is involved. */
static void check_self_shadow(sg_surface_model model)
{
    sg_pointset ps = {0};
    float h;
    make_sphere(&ps, 20000, 1.0f, &h);
    float r = 2.0f * h;
    sg_scene *s = build(&ps, model, SG_KERNEL_HAT, 0);
    uint64_t rng = 11;
    int self_hits = 0, tested = 0;
    for (int i = 0; i < 2000; ++i) {
        sg_vec3 target = sg_test_random_dir(&rng);
        sg_ray ray = ray_at_sphere(target, 1.0f, &rng);
        sg_hit hit;
        assert_true(sg_scene_intersect(s, &ray, &hit, NULL));
        sg_vec3 d = sg_test_random_dir_facing(&rng, hit.n);
        sg_ray sec = sg_scene_spawn_ray(s, &hit, d, INFINITY);
        /* Every direction, grazing ones included: there a neighbouring disk
         * or a bump of the reconstructed surface faces the ray, and the
         * self test of the spawned ray (ray.h) must reject it. */
        (void)r;
        ++tested;
        if (sg_scene_occluded(s, &sec, NULL)) {
            ++self_hits;
            fprintf(stderr, "self hit: cos(d, n) = %g\n", sg_v3_dot(d, hit.n));
        }
    }
    assert_int_equal(tested, 2000);
    if (self_hits)
        fail_msg("model %d: %d of %d outgoing rays hit the convex surface they leave", (int)model, self_hits, tested);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_mls_no_self_shadow(void **state) { (void)state; check_self_shadow(SG_SURFACE_MLS); }
static void test_disk_no_self_shadow(void **state) { (void)state; check_self_shadow(SG_SURFACE_DISK); }

/* ...and a ray leaving the floor towards the wall in a concave corner hits
 * the wall, however close: the case a minimum-distance epsilon gets wrong. */
static void check_corner(sg_surface_model model)
{
    int g = 60;
    sg_pointset ps = {0};
    assert_int_equal(sg_pointset_alloc(&ps, (size_t)2 * g * g, NULL), SG_OK);
    float h = 2.0f / (float)(g - 1);
    size_t k = 0;
    for (int i = 0; i < g; ++i)
        for (int j = 0; j < g; ++j) {
            float a = h * (float)i, b = -1.0f + h * (float)j;
            /* floor y = 0 (x in [0,2]) facing +y; wall x = 0 (y in [0,2]) facing +x */
            ps.px[k] = a; ps.py[k] = 0; ps.pz[k] = b; ps.nx[k] = 0; ps.ny[k] = 1; ps.nz[k] = 0;
            ps.radius[k++] = 2.0f * h;
            ps.px[k] = 0; ps.py[k] = a; ps.pz[k] = b; ps.nx[k] = 1; ps.ny[k] = 0; ps.nz[k] = 0;
            ps.radius[k++] = 2.0f * h;
        }
    sg_scene *s = build(&ps, model, SG_KERNEL_HAT, 0);
    for (int i = 1; i <= 20; ++i) {
        float x = 0.1f * (float)i; /* from inside the rounded corner outwards */
        sg_ray down = {.org = sg_v3(x, 1.5f, 0.1f), .dir = sg_v3(0, -1, 0), .tmin = 0, .tmax = INFINITY};
        sg_hit hit;
        assert_true(sg_scene_intersect(s, &down, &hit, NULL));
        sg_vec3 to_wall = sg_v3_normalize(sg_v3(-1.0f, 0.2f, 0.0f));
        if (sg_v3_dot(to_wall, hit.n) <= 0.0f)
            continue; /* inside the rounding the normal already faces the wall */
        sg_ray sec = sg_scene_spawn_ray(s, &hit, to_wall, INFINITY);
        sg_hit h2;
        if (!sg_scene_intersect(s, &sec, &h2, NULL))
            fail_msg("model %d: ray from the floor at x = %g towards the wall missed it", (int)model, hit.p.x);
        assert_true(h2.n.x > 0.5f);
        assert_true(h2.p.x < 2.0f * h + 1e-3f);
    }
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}
static void test_mls_corner_reflection(void **state) { (void)state; check_corner(SG_SURFACE_MLS); }
static void test_disk_corner_reflection(void **state) { (void)state; check_corner(SG_SURFACE_DISK); }

/* The SIMD sampling kernel agrees with the scalar reference field. */
static void test_mls_simd_matches_scalar(void **state)
{
    (void)state;
    enum { N = 40 };
    float px[N], py[N], pz[N], nx[N], ny[N], nz[N], r[N], ir[N];
    uint32_t id[N];
    sg_splat_soa s = {px, py, pz, nx, ny, nz, r, ir, id, NULL}; /* no layer keys: one field */
    uint64_t rng = 5;
    for (int trial = 0; trial < 200; ++trial) {
        for (int i = 0; i < N; ++i) {
            px[i] = sg_test_rand01(&rng); py[i] = 0.2f * sg_test_rand01(&rng); pz[i] = sg_test_rand01(&rng);
            sg_vec3 n = sg_v3_normalize(sg_v3_add(sg_v3(0, 2, 0), sg_test_random_dir(&rng)));
            nx[i] = n.x; ny[i] = n.y; nz[i] = n.z;
            r[i] = 0.1f + 0.3f * sg_test_rand01(&rng);
            ir[i] = 1.0f / r[i];
            id[i] = (uint32_t)i;
        }
        sg_ray ray = {.org = sg_v3(sg_test_rand01(&rng), 1.0f, sg_test_rand01(&rng)), .tmin = 0, .tmax = 10};
        ray.dir = sg_v3_normalize(sg_v3(sg_test_rand01(&rng) - 0.5f, -1.0f, sg_test_rand01(&rng) - 0.5f));
        float t[8], F[8], W[8];
        for (int l = 0; l < 8; ++l)
            t[l] = 0.6f + 0.1f * (float)l;
        for (int kern = 0; kern < 2; ++kern) {
            sg_mls_eval8(&s, 0, N, (sg_kernel)kern, &ray, t, F, W);
            for (int l = 0; l < 8; ++l) {
                float Wr;
                float Fr = sg_mls_field(&s, 0, N, (sg_kernel)kern, sg_v3_madd(ray.org, ray.dir, t[l]), &Wr, NULL, NULL);
                /* The kernel gets |x - p|^2 as (t - tc)^2 + (|q|^2 - tc^2): the
                 * subtraction loses up to ~2 eps |q|^2 ~ 5e-7 (|q| <= 2) of d^2,
                 * so each hat weight may differ by 5e-7 / (2 d r) <= 2.5e-5
                 * (d, r >= 0.1); over N splats W by up to N * 2.5e-5 = 1e-3,
                 * and F (a sum of w (x - p) . N, |x - p| <= 1.5, |N| <= W + 1e-3)
                 * by about 1e-3 * 1.5 * (W + 1e-3) plus the same for N. */
                float tolW = (float)N * 2.5e-5f;
                float tolF = 2.0f * tolW * 1.5f * (Wr + tolW);
                if (fabsf(F[l] - Fr) > tolF || fabsf(W[l] - Wr) > tolW)
                    fail_msg("trial %d kernel %d lane %d: simd F %g W %g, scalar F %g W %g", trial, kern, l, F[l],
                             W[l], Fr, Wr);
            }
        }
    }
}

/* A gap in the supports no longer than the sample spacing (max_spacing x
 * the smallest radius) does not hide the crossing across it; a longer one
 * does (mls.c, invariant 2). Two splats of radius 1 on the plane y = 0,
 * facing +y, with a gap of g between their supports along x; a ray slanted
 * down through the plane at x = 0, sampled densely (64 samples over its
 * 3-long interval, spacing 0.048) so that samples land in the gap. Before
 * the bridge, a ray tunnelled wherever a sample did (the default bunny
 * frame's dark pixels). */
static void test_mls_bridges_short_support_gap(void **state)
{
    (void)state;
    const float gaps[2] = {0.3f, 0.7f}; /* bridged (< 0.5), not bridged */
    for (int gi = 0; gi < 2; ++gi) {
        const float g = gaps[gi];
        float px[2] = {-1.0f - 0.5f * g, 1.0f + 0.5f * g}, py[2] = {0, 0}, pz[2] = {0, 0};
        float nx[2] = {0, 0}, ny[2] = {1, 1}, nz[2] = {0, 0}, r[2] = {1, 1}, ir[2] = {1, 1};
        uint32_t id[2] = {0, 1};
        sg_splat_soa s = {px, py, pz, nx, ny, nz, r, ir, id, NULL};
        const sg_mls_params mp = {.kernel = SG_KERNEL_HAT, .samples = 64, .max_spacing = 0.5f};
        for (int face = 0; face < 2; ++face) {
            sg_ray ray = {.org = sg_v3(-2.0f, 0.1f, 0.0f), .tmin = 0, .tmax = 10,
                          .flags = face ? SG_RAY_FRONT_ONLY : SG_RAY_ANY_FACE};
            ray.dir = sg_v3_normalize(sg_v3(1.0f, -0.05f, 0.0f));
            /* The leaf's interval: x from -1.5 to 1.5. */
            float t0 = 0.5f / ray.dir.x, t1 = 3.5f / ray.dir.x;
            sg_hit h;
            int got = sg_mls_intersect_leaf(&s, 0, 2, &mp, &ray, t0, t1, &h, NULL);
            if (gi == 0) {
                if (!got)
                    fail_msg("gap %g, face flags %u: the ray tunnels through the plane", g, ray.flags);
                /* The crossing lies in the gap, within its width of x = 0,
                 * on the plane's front (the ray enters). */
                assert_true(fabsf(h.p.x) <= 0.5f * g + 0.05f);
                assert_true(sg_v3_dot(h.n, ray.dir) < 0.0f);
                assert_true(h.splat == 0 || h.splat == 1);
            } else if (got)
                fail_msg("gap %g: a crossing bridged across a gap wider than the spacing (x %g)", g, h.p.x);
        }
    }
}

/* mls.c invariant 7: a camera ray (SG_RAY_PRIMARY) that meets the supports
 * again past a gap wider than the bridge, already behind the splats facing
 * it, enters where they begin; the same ray without the flag passes (the
 * bridge test above), and so does a camera ray that stays in front of the
 * plane or comes from behind it (the normals face away from it). */
static void test_mls_camera_ray_enters_at_rim(void **state)
{
    (void)state;
    const float g = 0.7f; /* wider than the bridge (0.5) */
    float px[2] = {-1.0f - 0.5f * g, 1.0f + 0.5f * g}, py[2] = {0, 0}, pz[2] = {0, 0};
    float nx[2] = {0, 0}, ny[2] = {1, 1}, nz[2] = {0, 0}, r[2] = {1, 1}, ir[2] = {1, 1};
    uint32_t id[2] = {0, 1};
    sg_splat_soa s = {px, py, pz, nx, ny, nz, r, ir, id, NULL};
    const sg_mls_params mp = {.kernel = SG_KERNEL_HAT, .samples = 64, .max_spacing = 0.5f};
    /* origin y, direction y: down through the plane in the gap; above it
     * throughout; up through it from below */
    const float oy[3] = {0.1f, 0.1f, -0.1f}, dy[3] = {-0.05f, 0.02f, 0.05f};
    for (int c = 0; c < 3; ++c)
        for (int primary = 0; primary < 2; ++primary) {
            sg_ray ray = {.org = sg_v3(-2.0f, oy[c], 0.0f), .tmin = 0, .tmax = 10,
                          .flags = primary ? SG_RAY_PRIMARY : SG_RAY_ANY_FACE};
            ray.dir = sg_v3_normalize(sg_v3(1.0f, dy[c], 0.0f));
            float t0 = 0.5f / ray.dir.x, t1 = 3.5f / ray.dir.x;
            sg_hit h;
            int got = sg_mls_intersect_leaf(&s, 0, 2, &mp, &ray, t0, t1, &h, NULL);
            if (c == 0 && primary) {
                if (!got)
                    fail_msg("a camera ray behind the plane past the gap passes through it");
                /* The right splat's support begins at x = 0.5 g + 1 - 1; the
                 * first covered sample lies within one sample spacing of it. */
                assert_true(h.p.x >= 0.5f * g - 1e-4f && h.p.x <= 0.5f * g + 0.1f);
                /* ... and the hit lies on the plane (the front surface; one
                 * splat's field is its plane distance), not at the sample
                 * behind it, where the ray is: y = -0.02 or so there */
                const float ray_y = ray.org.y + ray.dir.y * h.t;
                if (!(fabsf(h.p.y) < 1e-5f) || !(ray_y < -0.005f))
                    fail_msg("rim entry at y %g (the ray there: %g); want it on the plane y = 0", h.p.y, ray_y);
                assert_true(sg_v3_dot(h.n, ray.dir) < 0.0f);
                assert_int_equal(h.splat, 1);
            } else if (got)
                fail_msg("case %d, flags %u: a hit at x %g where the ray should pass", c, ray.flags, h.p.x);
        }
}

/* sg_scene_hit_sites (SIMD pre-filter) gives its scalar reference's
 * result bit for bit: same count, ids and weights, at hits from random
 * rays and at points pushed off the hit so that splats sit right at the
 * edge of their support (where the pre-filter's slack matters), with a
 * small max so that the "replace the smallest" path runs too. */
static void check_hit_weights(sg_surface_model model, sg_kernel kernel)
{
    enum { MAXW = 32, RAYS = 3000 };
    sg_pointset ps = {0};
    float h;
    make_sphere(&ps, 20000, 1.0f, &h);
    sg_scene *s = build(&ps, model, kernel, 0);
    uint64_t rng = 7;
    int hits = 0, many = 0;
    for (int i = 0; i < RAYS; ++i) {
        sg_ray ray = ray_at_sphere(sg_test_random_dir(&rng), 1.0f, &rng);
        sg_hit hit;
        if (!sg_scene_intersect(s, &ray, &hit, NULL))
            continue;
        ++hits;
        for (int variant = 0; variant < 3; ++variant) {
            sg_hit q = hit;
            int max = variant == 2 ? 3 : MAXW;
            if (variant == 1) /* off the hit by up to a splat radius */
                q.p = sg_v3_add(q.p, sg_v3_scale(sg_test_random_dir(&rng), 2.0f * h * sg_test_rand01(&rng)));
            uint32_t ida[MAXW], idb[MAXW];
            float wa[MAXW], wb[MAXW];
            int na = sg_scene_hit_sites(s, &q, ida, wa, max);
            int nb = sg_scene_hit_sites_reference(s, &q, idb, wb, max);
            many += na == max;
            int same = na == nb;
            for (int j = 0; same && j < na; ++j)
                same = ida[j] == idb[j] && memcmp(&wa[j], &wb[j], sizeof wa[j]) == 0;
            if (!same)
                fail_msg("model %d kernel %d ray %d variant %d: %d weights, reference %d; first: id %u %.9g, "
                         "reference id %u %.9g",
                         (int)model, (int)kernel, i, variant, na, nb, ida[0], wa[0], idb[0], wb[0]);
        }
    }
    assert_true(hits > RAYS / 2 && many > 0);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}

static void test_mls_hit_weights_match_reference(void **state)
{
    (void)state;
    check_hit_weights(SG_SURFACE_MLS, SG_KERNEL_HAT);
    check_hit_weights(SG_SURFACE_MLS, SG_KERNEL_GAUSSIAN);
}
static void test_disk_hit_weights_match_reference(void **state)
{
    (void)state;
    check_hit_weights(SG_SURFACE_DISK, SG_KERNEL_HAT);
}

/* sg_scene_intersect4 gives every ray the hit sg_scene_intersect gives it,
 * bit for bit: quads of camera-like rays from one eye (shared traversal,
 * including rays that miss, graze or hit the far side of a gap), partial
 * masks, and quads that cannot share (different origins or direction
 * signs; disks). */
static void check_intersect4(sg_surface_model model)
{
    sg_pointset ps = {0};
    float h;
    make_sphere(&ps, 20000, 1.0f, &h);
    sg_scene *s = build(&ps, model, SG_KERNEL_HAT, 0);
    uint64_t rng = 3;
    int hits = 0, rays_traced = 0;
    for (int i = 0; i < 2000; ++i) {
        sg_vec3 eye = sg_v3_scale(sg_test_random_dir(&rng), 2.0f + 3.0f * sg_test_rand01(&rng));
        sg_vec3 at = sg_v3_scale(sg_test_random_dir(&rng), 1.3f * sg_test_rand01(&rng));
        sg_vec3 fwd = sg_v3_normalize(sg_v3_sub(at, eye));
        sg_vec3 u = sg_v3_normalize(sg_v3_cross(fwd, fabsf(fwd.y) < 0.9f ? sg_v3(0, 1, 0) : sg_v3(1, 0, 0)));
        sg_vec3 v = sg_v3_cross(u, fwd);
        float pix = i % 4 == 0 ? 0.05f : 0.002f; /* wide quads too */
        sg_ray rays[4];
        for (int q = 0; q < 4; ++q) {
            sg_vec3 d = sg_v3_add(fwd, sg_v3_add(sg_v3_scale(u, pix * (float)(q & 1)), sg_v3_scale(v, pix * (float)(q >> 1))));
            rays[q] = (sg_ray){.org = eye, .dir = sg_v3_normalize(d), .tmin = 0, .tmax = INFINITY};
        }
        if (i % 7 == 1) /* one ray from elsewhere: no sharing */
            rays[2].org = sg_v3_add(eye, sg_v3(0.01f, 0, 0));
        if (i % 5 == 2) /* a finite tmax, as a later model of a world sets */
            rays[1].tmax = 0.5f * sg_v3_length(sg_v3_sub(eye, at));
        unsigned mask = i % 3 == 0 ? 15u : (unsigned)(1 + i % 15);
        sg_hit h4[4], h1;
        for (int q = 0; q < 4; ++q)
            h4[q].splat = 12345u; /* must stay for rays outside mask */
        unsigned got = sg_scene_intersect4(s, rays, mask, h4, NULL);
        for (int q = 0; q < 4; ++q) {
            if (!(mask >> q & 1u)) {
                assert_int_equal(h4[q].splat, 12345u);
                assert_false(got >> q & 1u);
                continue;
            }
            ++rays_traced;
            int f = sg_scene_intersect(s, &rays[q], &h1, NULL);
            if (f != (int)(got >> q & 1u))
                fail_msg("model %d quad %d ray %d: intersect %d, intersect4 %u", (int)model, i, q, f, got >> q & 1u);
            if (!f) {
                assert_int_equal(h4[q].splat, SG_INVALID_ID);
                continue;
            }
            ++hits;
            if (memcmp(&h1.t, &h4[q].t, sizeof h1.t) || memcmp(&h1.p, &h4[q].p, sizeof h1.p) ||
                memcmp(&h1.n, &h4[q].n, sizeof h1.n) || h1.splat != h4[q].splat || h1.leaf != h4[q].leaf)
                fail_msg("model %d quad %d ray %d: t %.9g / %.9g, splat %u / %u, leaf %u / %u", (int)model, i, q,
                         h1.t, h4[q].t, h1.splat, h4[q].splat, h1.leaf, h4[q].leaf);
        }
    }
    print_message("model %d: %d hits of %d rays\n", (int)model, hits, rays_traced);
    assert_true(hits > rays_traced / 4 && hits < rays_traced);
    /* Stats: one ray per traced ray. */
    sg_ray_stats st = {0};
    sg_ray rays[4];
    for (int q = 0; q < 4; ++q)
        rays[q] = (sg_ray){.org = sg_v3(0, 0, 5), .dir = sg_v3_normalize(sg_v3(0.01f * q, 0, -1)), .tmax = INFINITY};
    assert_int_equal(sg_scene_intersect4(s, rays, 7u, (sg_hit[4]){0}, &st), 7u);
    assert_int_equal(st.rays, 3);
    assert_int_equal(st.hits, 3);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}

static void test_mls_intersect4_matches_single(void **state)
{
    (void)state;
    check_intersect4(SG_SURFACE_MLS);
}
static void test_disk_intersect4_matches_single(void **state)
{
    (void)state;
    check_intersect4(SG_SURFACE_DISK);
}

/* Layer keys (scene.c) mark splats near a fold: none on a smooth sphere;
 * on the same sphere with noisy normals n + 0.4 N(0, I) (the stability
 * map's noisy_normals) only where the smoothed layer normals of
 * neighbours still differ by more than 26 degrees, at most 1 splat in 10
 * (measured: 5.1%; with 5 smoothing passes 4.3%, but Lucy's folds then
 * let 1.8x as many rays through, bench_leaks); every splat of a thin
 * two-sided sheet (each lies within one radius of the opposed layer). */
static void test_mls_layer_keys(void **state)
{
    (void)state;
    sg_pointset ps = {0};
    float h;
    make_sphere(&ps, 20000, 1.0f, &h);
    sg_scene *s = build(&ps, SG_SURFACE_MLS, SG_KERNEL_HAT, 0);
    sg_scene_info info;
    sg_scene_get_info(s, &info);
    assert_int_equal(info.keyed_count, 0);
    sg_scene_destroy(s);
    uint64_t rng = 99;
    for (size_t i = 0; i < ps.count; ++i) {
        /* Gaussian by Box-Muller, as the stability case makes it */
        float g[3];
        for (int c = 0; c < 3; ++c) {
            float u1 = sg_test_rand01(&rng), u2 = sg_test_rand01(&rng);
            g[c] = sqrtf(-2.0f * logf(1.0f - u1)) * cosf(2.0f * PI * u2);
        }
        sg_vec3 n = sg_v3_normalize(sg_v3(ps.nx[i] + 0.4f * g[0], ps.ny[i] + 0.4f * g[1], ps.nz[i] + 0.4f * g[2]));
        ps.nx[i] = n.x, ps.ny[i] = n.y, ps.nz[i] = n.z;
    }
    s = build(&ps, SG_SURFACE_MLS, SG_KERNEL_HAT, 0);
    sg_scene_get_info(s, &info);
    if (info.keyed_count * 10 > info.splat_count)
        fail_msg("noisy sphere: %zu of %zu splats keyed", info.keyed_count, info.splat_count);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
    sg_test_make_sheet(&ps, 60, 0.25f * 2.0f * 2.0f / 59.0f, &h);
    s = build(&ps, SG_SURFACE_MLS, SG_KERNEL_HAT, 0);
    sg_scene_get_info(s, &info);
    assert_int_equal(info.keyed_count, info.splat_count);
    sg_scene_destroy(s);
    s = build(&ps, SG_SURFACE_DISK, SG_KERNEL_HAT, 0);
    sg_scene_get_info(s, &info);
    assert_int_equal(info.keyed_count, 0); /* disks need no keys */
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}

/* Bad input names the problem and creates nothing. */
static void test_scene_rejects_bad_points(void **state)
{
    (void)state;
    sg_pointset empty = {0};
    sg_scene *s = (sg_scene *)0x1;
    sg_error err = {0};
    assert_int_equal(sg_scene_create(NULL, &empty, &s, &err), SG_ERR_INVALID_ARG);
    assert_ptr_equal(s, (sg_scene *)0x1);
    assert_non_null(strstr(err.message, "empty"));

    sg_pointset ps = {0};
    float h;
    make_sphere(&ps, 100, 1.0f, &h);
    ps.radius[42] = NAN;
    assert_int_not_equal(sg_scene_create(NULL, &ps, &s, &err), SG_OK);
    assert_ptr_equal(s, (sg_scene *)0x1);
    assert_non_null(strstr(err.message, "42"));
    sg_pointset_free(&ps);
}

/* Per-ray statistics count what the traversal did. */
static void test_scene_stats(void **state)
{
    (void)state;
    sg_pointset ps = {0};
    float h;
    make_sphere(&ps, 5000, 1.0f, &h);
    sg_scene *s = build(&ps, SG_SURFACE_MLS, SG_KERNEL_HAT, 0);
    sg_ray_stats st = {0};
    sg_ray hit_ray = {.org = sg_v3(0, 0, 5), .dir = sg_v3(0, 0, -1), .tmin = 0, .tmax = INFINITY};
    sg_ray miss_ray = {.org = sg_v3(0, 3, 5), .dir = sg_v3(0, 0, -1), .tmin = 0, .tmax = INFINITY};
    sg_hit hit;
    assert_true(sg_scene_intersect(s, &hit_ray, &hit, &st));
    assert_false(sg_scene_intersect(s, &miss_ray, &hit, &st));
    assert_int_equal(hit.splat, SG_INVALID_ID);
    assert_int_equal(st.rays, 2);
    assert_int_equal(st.hits, 1);
    assert_true(st.nodes >= st.leaves && st.leaves >= st.isects && st.isects >= 1 && st.splats >= st.isects);
    sg_scene_info info;
    sg_scene_get_info(s, &info);
    assert_int_equal(info.splat_count, 5000);
    assert_true(info.leaf_count > 1 && info.splat_refs >= 5000 && info.memory_bytes > 0);
    sg_scene_destroy(s);
    sg_pointset_free(&ps);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mls_sphere_hat),
        cmocka_unit_test(test_mls_sphere_gaussian),
        cmocka_unit_test(test_mls_sphere_no_refinements),
        cmocka_unit_test(test_mls_sphere_each_refinement_alone),
        cmocka_unit_test(test_disk_sphere),
        cmocka_unit_test(test_mls_no_holes),
        cmocka_unit_test(test_disk_no_holes),
        cmocka_unit_test(test_mls_cube_edges),
        cmocka_unit_test(test_mls_convex_edge_no_overhang),
        cmocka_unit_test(test_disk_cube_edges),
        cmocka_unit_test(test_mls_thin_sheet),
        cmocka_unit_test(test_disk_thin_sheet),
        cmocka_unit_test(test_mls_no_self_shadow),
        cmocka_unit_test(test_disk_no_self_shadow),
        cmocka_unit_test(test_mls_corner_reflection),
        cmocka_unit_test(test_disk_corner_reflection),
        cmocka_unit_test(test_mls_simd_matches_scalar),
        cmocka_unit_test(test_mls_bridges_short_support_gap),
        cmocka_unit_test(test_mls_camera_ray_enters_at_rim),
        cmocka_unit_test(test_mls_hit_weights_match_reference),
        cmocka_unit_test(test_disk_hit_weights_match_reference),
        cmocka_unit_test(test_mls_intersect4_matches_single),
        cmocka_unit_test(test_disk_intersect4_matches_single),
        cmocka_unit_test(test_mls_layer_keys),
        cmocka_unit_test(test_scene_rejects_bad_points),
        cmocka_unit_test(test_scene_stats),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
