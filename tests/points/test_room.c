/* test_room.c — the built-in room (points/room.h): a closed, consistently
 * oriented wall boundary with one window, and, sampled to splats for
 * either surface model, a room whose walls let no ray out except through
 * the window. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "points/room.h"
#include "render/world.h"

/* The mesh is closed and oriented outwards from the wall material: the
 * divergence theorem's signed volume, sum over triangles of
 * p0 . (p1 x p2) / 6, is the material's volume, outer box minus inner box
 * minus the window's tunnel (walls 0.2, 0.05, and 0.04 with a window wall
 * 0.2 thick: the stability map's thin_wall), and every normal is its triangle's
 * counter-clockwise one (a flipped face, a missing one or a gap would
 * change the sum by at least that face's share). */
static void test_room_mesh_closed(void **state)
{
    (void)state;
    const float walls[] = {0.2f, 0.05f, 0.04f}, window_walls[] = {0.0f, 0.0f, 0.2f};
    /* k = 3: the default walls as grids of cells (the hybrid surface's
     * room): the same closed boundary in more triangles */
    for (int k = 0; k < 4; ++k) {
        sg_room_desc d = k < 3 ? (sg_room_desc){.wall = walls[k], .window_wall = window_walls[k]}
                               : (sg_room_desc){.cell = 0.3f};
        sg_mesh m;
        assert_int_equal(sg_room_mesh(&d, &m, NULL), SG_OK);
        double vol = 0.0;
        for (size_t t = 0; t < m.triangle_count; ++t) {
            const float *a = m.positions + 3 * m.triangles[3 * t], *b = m.positions + 3 * m.triangles[3 * t + 1],
                        *c = m.positions + 3 * m.triangles[3 * t + 2];
            double cx = (double)b[1] * c[2] - (double)b[2] * c[1], cy = (double)b[2] * c[0] - (double)b[0] * c[2],
                   cz = (double)b[0] * c[1] - (double)b[1] * c[0];
            vol += (a[0] * cx + a[1] * cy + a[2] * cz) / 6.0;
            /* normal = the counter-clockwise one */
            double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
            const float *vn = m.normals + 3 * m.triangles[3 * t];
            assert_true(n[0] * vn[0] + n[1] * vn[1] + n[2] * vn[2] > 0.0);
        }
        if (k == 3) /* 4 x 4 floor in cells of 0.3: 14 x 14 cells */
            assert_true(m.triangle_count > 2 * 14 * 14);
        double w = k < 3 ? walls[k] : SG_ROOM_WALL;
        double wx = k < 3 && window_walls[k] > 0.0f ? window_walls[k] : w, H = SG_ROOM_HALF, T = SG_ROOM_HEIGHT;
        double expect = (2.0 * H + w + wx) * 2.0 * (H + w) * (T + 2.0 * w) - 4.0 * H * H * T -
                        2.0 * SG_ROOM_WINDOW_Z * (SG_ROOM_WINDOW_Y1 - SG_ROOM_WINDOW_Y0) * wx;
        if (!(fabs(vol - expect) < 1e-5 * expect))
            fail_msg("wall %g, window wall %g: signed volume %.9g, expected %.9g", w, wx, vol, expect);
        sg_mesh_free(&m);
    }
    sg_room_desc bad = {.wall = -1.0f};
    sg_mesh m;
    sg_error err = {0};
    assert_int_equal(sg_room_mesh(&bad, &m, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "wall thickness"));
    sg_room_desc bad_cell = {.cell = NAN};
    assert_int_equal(sg_room_mesh(&bad_cell, &m, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "cell size"));
}

/* Where a ray from inside leaves the room's inner box: 1 when through the
 * window's opening in the +X wall (it may then meet a reveal, or go out). */
static int leaves_by_window(sg_vec3 o, sg_vec3 d)
{
    const float H = SG_ROOM_HALF, T = SG_ROOM_HEIGHT;
    float t = INFINITY;
    for (int a = 0; a < 3; ++a) {
        float oa = a == 0 ? o.x : a == 1 ? o.y : o.z, da = a == 0 ? d.x : a == 1 ? d.y : d.z;
        float lo = a == 1 ? 0.0f : -H, hi = a == 1 ? T : H;
        if (da > 0.0f)
            t = fminf(t, (hi - oa) / da);
        else if (da < 0.0f)
            t = fminf(t, (lo - oa) / da);
    }
    sg_vec3 p = sg_v3_madd(o, d, t);
    return p.x > H - 1e-4f && fabsf(p.z) < SG_ROOM_WINDOW_Z && p.y > SG_ROOM_WINDOW_Y0 && p.y < SG_ROOM_WINDOW_Y1;
}

/* Sampled to splats, the room keeps every ray from inside in, whatever the
 * surface model: camera rays from inside meet the walls from the front and
 * a shadow query from inside is occluded, unless the ray heads for the
 * window (then either may happen: a reveal may stop it). 20,000 points:
 * walls 0.2 thick are about 2 splat radii. */
static void check_room_holds_rays(const char *model)
{
    char json[512];
    snprintf(json, sizeof json,
             "{\"models\":[{\"builtin\":\"room\",\"points\":20000,\"surface\":{\"model\":\"%s\"}}]}", model);
    sg_world *w = sg_test_world_from_json(json);
    uint64_t rng = 77;
    int failures = 0, by_window = 0;
    for (int i = 0; i < 4000; ++i) {
        sg_vec3 o = sg_v3(3.2f * sg_test_rand01(&rng) - 1.6f, 0.3f + 1.9f * sg_test_rand01(&rng),
                          3.2f * sg_test_rand01(&rng) - 1.6f);
        sg_vec3 d = sg_test_random_dir(&rng);
        sg_ray ray = {.org = o, .dir = d, .tmin = 0, .tmax = INFINITY};
        if (leaves_by_window(o, d)) {
            ++by_window;
            continue;
        }
        sg_world_hit h;
        int hit = sg_world_intersect(w, &ray, &h, NULL);
        ray.flags = SG_RAY_FRONT_ONLY;
        const char *why = !hit                                 ? "got out"
                          : !(sg_v3_dot(h.hit.n, d) < 0.0f)    ? "met a wall from behind"
                          : !sg_world_occluded(w, &ray, NULL) ? "shadow query got out"
                                                               : NULL;
        if (why && failures++ == 0)
            fprintf(stderr, "%s: ray %d from (%g %g %g) dir (%g %g %g): %s\n", model, i, o.x, o.y, o.z, d.x, d.y,
                    d.z, why);
    }
    print_message("%s: %d of 4000 rays head for the window\n", model, by_window);
    assert_true(by_window > 0);
    if (failures)
        fail_msg("%s: %d rays from inside the room got out other than by the window", model, failures);
    sg_world_destroy(w);
}
static void test_room_holds_rays_mls(void **state) { (void)state; check_room_holds_rays("mls"); }
static void test_room_holds_rays_disk(void **state) { (void)state; check_room_holds_rays("disk"); }
/* As triangles (cells of sqrt(162 / 20000) = 0.09): watertight also where
 * the window wall's pieces meet the floor's edge in T-junctions. */
static void test_room_holds_rays_hybrid(void **state) { (void)state; check_room_holds_rays("hybrid"); }

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_room_mesh_closed),
        cmocka_unit_test(test_room_holds_rays_mls),
        cmocka_unit_test(test_room_holds_rays_disk),
        cmocka_unit_test(test_room_holds_rays_hybrid),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
