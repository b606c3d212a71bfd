/* test_truth.c — the exact shapes of the stability cases and the view
 * comparison that turns them into hole rates and normal errors.
 *
 * Closed forms: a ray from (0,0,d) towards the origin meets the unit
 * sphere at t = d - 1 with normal +Z, and from the centre at t = 1 with the
 * outward normal along the ray; a slab test from inside a box leaves
 * through the far face. A sphere of radius R > 1 seen from distance D holds
 * the splat sphere of radius 1 inside its silhouette: the splat surface
 * covers the solid angle of a cone of half-angle asin(1/D) out of
 * asin(R/D), so the hole rate is the ratio of image areas
 * 1 - tan^2(asin(1/D)) / tan^2(asin(R/D)) (a pinhole images a cone of
 * half-angle a as a disc of radius tan a). */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/mesh.h"
#include "render/world.h"
#include "verify/cases.h"
#include "verify/truth.h"

static sg_ray ray_to(sg_vec3 o, sg_vec3 d)
{
    sg_ray r = {.org = o, .dir = sg_v3_normalize(d), .tmin = 0.0f, .tmax = INFINITY};
    return r;
}

/* 1. Sphere from outside and from inside; box from inside; rectangle. */
static void test_truth_closed_form_hits(void **state)
{
    (void)state;
    sg_truth t = {0};
    sg_error err = {0};
    assert_int_equal(sg_truth_add_sphere(&t, sg_v3(0, 0, 0), 1.0f, &err), SG_OK);
    float hit_t;
    sg_vec3 n;
    sg_ray r = ray_to(sg_v3(0, 0, 5), sg_v3(0, 0, -1));
    assert_int_equal(sg_truth_intersect(&t, &r, &hit_t, &n), 1);
    if (fabsf(hit_t - 4.0f) > 1e-5f || fabsf(n.z - 1.0f) > 1e-5f)
        fail_msg("sphere from outside: t %g n (%g %g %g), want 4 and +Z", (double)hit_t, (double)n.x, (double)n.y,
                 (double)n.z);
    r = ray_to(sg_v3(0, 0, 0), sg_v3(1, 0, 0));
    assert_int_equal(sg_truth_intersect(&t, &r, &hit_t, &n), 1);
    if (fabsf(hit_t - 1.0f) > 1e-5f || fabsf(n.x - 1.0f) > 1e-5f)
        fail_msg("sphere from inside: t %g n.x %g, want 1 and outward +X", (double)hit_t, (double)n.x);
    r = ray_to(sg_v3(0, 3, 0), sg_v3(1, 0, 0));
    assert_int_equal(sg_truth_intersect(&t, &r, &hit_t, &n), 0);
    sg_truth_free(&t);

    assert_int_equal(sg_truth_add_box(&t, sg_v3(-1, -2, -3), sg_v3(1, 2, 3), &err), SG_OK);
    r = ray_to(sg_v3(0, 0, 0), sg_v3(0, -1, 0));
    assert_int_equal(sg_truth_intersect(&t, &r, &hit_t, &n), 1);
    if (fabsf(hit_t - 2.0f) > 1e-5f || fabsf(n.y + 1.0f) > 1e-5f)
        fail_msg("box from inside: t %g n.y %g, want 2 and outward -Y", (double)hit_t, (double)n.y);
    r = ray_to(sg_v3(5, 0.5f, 0), sg_v3(-1, 0, 0));
    assert_int_equal(sg_truth_intersect(&t, &r, &hit_t, &n), 1);
    if (fabsf(hit_t - 4.0f) > 1e-5f || fabsf(n.x - 1.0f) > 1e-5f)
        fail_msg("box from outside: t %g n.x %g, want 4 and +X", (double)hit_t, (double)n.x);
    sg_truth_free(&t);

    assert_int_equal(sg_truth_add_rect(&t, 0.5f, -1, 1, -1, 1, &err), SG_OK);
    r = ray_to(sg_v3(0.9f, 2.5f, 0.9f), sg_v3(0, -1, 0));
    assert_int_equal(sg_truth_intersect(&t, &r, &hit_t, &n), 1);
    assert_true(fabsf(hit_t - 2.0f) < 1e-5f && n.y == 1.0f);
    r = ray_to(sg_v3(1.1f, 2.5f, 0), sg_v3(0, -1, 0));
    assert_int_equal(sg_truth_intersect(&t, &r, &hit_t, &n), 0);
    sg_truth_free(&t);
}

/* 2. A mesh (two triangles of the square z = 0, counter-clockwise seen
 * from +Z) gives the hit and the +Z normal, translated and scaled. */
static void test_truth_mesh_hit(void **state)
{
    (void)state;
    float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
    sg_mesh m = {.vertex_count = 4, .positions = pos, .triangle_count = 2, .triangles = tri};
    sg_truth t = {0};
    sg_error err = {0};
    assert_int_equal(sg_truth_add_mesh(&t, &m, sg_v3(10, 0, 0), 2.0f, &err), SG_OK);
    float hit_t;
    sg_vec3 n;
    sg_ray r = ray_to(sg_v3(11.5f, 1.9f, 3), sg_v3(0, 0, -1));
    assert_int_equal(sg_truth_intersect(&t, &r, &hit_t, &n), 1);
    if (fabsf(hit_t - 3.0f) > 1e-5f || fabsf(n.z - 1.0f) > 1e-5f)
        fail_msg("mesh: t %g n.z %g, want 3 and +Z", (double)hit_t, (double)n.z);
    r = ray_to(sg_v3(9.5f, 1.0f, 3), sg_v3(0, 0, -1)); /* outside the scaled square */
    assert_int_equal(sg_truth_intersect(&t, &r, &hit_t, &n), 0);
    sg_truth_free(&t);
}

/* 3. The clean sphere case: its splat surface covers the sphere (hole rate
 * under 1%) with normals within 2 degrees; scored against a truth sphere
 * of radius R = 1.5 instead, the holes are the silhouette ring (header). */
static void test_truth_view_holes_closed_form(void **state)
{
    (void)state;
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/cases", sg_test_tmpdir());
    sg_verify_case c;
    sg_error err = {0};
    if (sg_verify_case_make(sg_verify_case_find("sphere_clean"), SG_SURFACE_MLS, 1, dir, &c, &err) != SG_OK)
        fail_msg("case: %s", err.message);
    sg_world *w = NULL;
    if (sg_world_create(&c.scene, &w, &err) != SG_OK)
        fail_msg("world: %s", err.message);
    sg_truth_view_stats s;
    assert_int_equal(sg_truth_compare_view(&c.truth, w, &c.camera, 64, 64, &s, &err), SG_OK);
    if (!(s.hole_rate < 0.01 && s.normal_error_deg < 2.0 && s.truth_pixels > 500))
        fail_msg("clean sphere: hole rate %g, normal error %g deg, %zu truth pixels", s.hole_rate,
                 s.normal_error_deg, s.truth_pixels);

    const float R = 1.5f;
    sg_truth big = {0};
    assert_int_equal(sg_truth_add_sphere(&big, sg_v3(0, 0, 0), R, &err), SG_OK);
    assert_int_equal(sg_truth_compare_view(&big, w, &c.camera, 128, 128, &s, &err), SG_OK);
    double D = sg_v3_length(c.camera.eye);
    double a1 = asin(1.0 / D), aR = asin(R / D);
    double want = 1.0 - tan(a1) * tan(a1) / (tan(aR) * tan(aR));
    /* Pixel quantisation of the two discs' rims: well under 1% of the image. */
    printf("sphere scored against R = %g: hole rate %.4f, closed form %.4f\n", (double)R, s.hole_rate, want);
    if (fabs(s.hole_rate - want) > 0.01)
        fail_msg("sphere scored against R = %g: hole rate %g, want %g (D = %g)", (double)R, s.hole_rate, want, D);
    sg_truth_free(&big);
    sg_world_destroy(w);
    sg_verify_case_free(&c);
}

/* 4. Orientation: from inside the clean sphere every pixel sees it, with
 * the splats' outward normals agreeing with the truth's (nothing flipped);
 * the same points written with inward normals score every pixel flipped
 * and a mean normal error near 180 degrees. */
static void test_truth_view_flipped_normals(void **state)
{
    (void)state;
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/cases", sg_test_tmpdir());
    sg_verify_case c;
    sg_error err = {0};
    if (sg_verify_case_make(sg_verify_case_find("camera_inside"), SG_SURFACE_DISK, 1, dir, &c, &err) != SG_OK)
        fail_msg("case: %s", err.message);
    sg_world *w = NULL;
    if (sg_world_create(&c.scene, &w, &err) != SG_OK)
        fail_msg("world: %s", err.message);
    sg_truth_view_stats s;
    assert_int_equal(sg_truth_compare_view(&c.truth, w, &c.camera, 32, 32, &s, &err), SG_OK);
    assert_int_equal(s.truth_pixels, 32 * 32);
    if (!(s.hole_rate < 0.01 && s.flipped_rate == 0.0 && s.normal_error_deg < 2.0))
        fail_msg("inside: hole rate %g, flipped %g, normal error %g", s.hole_rate, s.flipped_rate,
                 s.normal_error_deg);
    sg_world_destroy(w);

    /* The sphere's points with inward normals, seen from outside. */
    const sg_scene *sc = NULL;
    sg_verify_case clean;
    if (sg_verify_case_make(sg_verify_case_find("sphere_clean"), SG_SURFACE_MLS, 1, dir, &clean, &err) != SG_OK)
        fail_msg("case: %s", err.message);
    if (sg_world_create(&clean.scene, &w, &err) != SG_OK)
        fail_msg("world: %s", err.message);
    sc = sg_world_scene(w, 0);
    const sg_pointset *ps = sg_scene_points(sc);
    size_t n = ps->count;
    float *p = malloc(n * 3 * sizeof(float)), *nn = malloc(n * 3 * sizeof(float));
    assert_non_null(p);
    assert_non_null(nn);
    for (size_t i = 0; i < n; i++) {
        p[3 * i] = ps->px[i], p[3 * i + 1] = ps->py[i], p[3 * i + 2] = ps->pz[i];
        nn[3 * i] = -ps->nx[i], nn[3 * i + 1] = -ps->ny[i], nn[3 * i + 2] = -ps->nz[i];
    }
    char ply[4300], json[9000];
    snprintf(ply, sizeof ply, "%s/inward.ply", dir);
    assert_int_equal(sg_verify_write_ply(ply, n, p, nn, &err), SG_OK);
    free(p);
    free(nn);
    sg_world_destroy(w);
    snprintf(json, sizeof json, "{\"models\": [{\"path\": \"%s\"}]}", ply);
    sg_scene_file sf = {0};
    if (sg_scene_file_parse(json, strlen(json), "inward", NULL, &sf, &err) != SG_OK ||
        sg_world_create(&sf, &w, &err) != SG_OK)
        fail_msg("inward sphere: %s", err.message);
    assert_int_equal(sg_truth_compare_view(&clean.truth, w, &clean.camera, 32, 32, &s, &err), SG_OK);
    if (!(s.both > 100 && s.flipped_rate > 0.95 && s.normal_error_deg > 170.0))
        fail_msg("inward normals: %zu pixels hit by both, flipped %g, normal error %g deg", s.both, s.flipped_rate,
                 s.normal_error_deg);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
    sg_verify_case_free(&clean);
    sg_verify_case_free(&c);
}

/* 5. The PLY writer: what sg_mesh_read reads back, with and without normals. */
static void test_verify_write_ply_roundtrip(void **state)
{
    (void)state;
    char path[4200];
    snprintf(path, sizeof path, "%s/three.ply", sg_test_tmpdir());
    float p[9] = {0, 1, 2, 3, 4, 5, -6, 7.5f, 1e-3f}, n[9] = {1, 0, 0, 0, 1, 0, 0, 0, -1};
    sg_error err = {0};
    for (int with = 0; with < 2; with++) {
        assert_int_equal(sg_verify_write_ply(path, 3, p, with ? n : NULL, &err), SG_OK);
        sg_mesh m = {0};
        if (sg_mesh_read(path, &m, &err) != SG_OK)
            fail_msg("read back: %s", err.message);
        assert_int_equal(m.vertex_count, 3);
        assert_int_equal(m.triangle_count, 0);
        assert_memory_equal(m.positions, p, sizeof p);
        if (with) {
            assert_non_null(m.normals);
            assert_memory_equal(m.normals, n, sizeof n);
        } else
            assert_null(m.normals);
        sg_mesh_free(&m);
    }
}

/* 6. Every case builds at the CI size and has a truth and a camera. */
static void test_verify_cases_build(void **state)
{
    (void)state;
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/cases", sg_test_tmpdir());
    assert_true(sg_verify_case_count() >= 11);
    for (int i = 0; i < sg_verify_case_count(); i++) {
        sg_verify_case c;
        sg_error err = {0};
        if (sg_verify_case_make(i, SG_SURFACE_MLS, 1, dir, &c, &err) != SG_OK)
            fail_msg("case %s: %s", sg_verify_case_name(i), err.message);
        assert_true(c.truth.count >= 1);
        assert_int_equal(c.scene.camera_count, 1);
        assert_int_equal(sg_verify_case_find(c.name), i);
        int b = sg_verify_case_baseline(i);
        assert_true(b < sg_verify_case_count() && b != i);
        sg_verify_case_free(&c);
    }
    assert_int_equal(sg_verify_case_find("no such case"), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_truth_closed_form_hits),    cmocka_unit_test(test_truth_mesh_hit),
        cmocka_unit_test(test_truth_view_holes_closed_form), cmocka_unit_test(test_truth_view_flipped_normals),
        cmocka_unit_test(test_verify_write_ply_roundtrip), cmocka_unit_test(test_verify_cases_build),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
