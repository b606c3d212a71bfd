/* test_transport.c — the bake's sample sites and transport solve
 * (bake/transport.h):
 *  1. a site's rays estimate the unshadowed irradiance without bias, and
 *     the visibility ratio is exactly 1 where nothing blocks the light;
 *  2. a site's figures do not depend on which other sites are gathered in
 *     the same call, nor on the thread count;
 *  3. sites inside a closed model stop after the pilot rays: no light,
 *     every hit on a back side;
 *  4. the solve reproduces a white furnace exactly (every site's
 *     E0 ratio + indirect equals E0), and an albedo-rho furnace by its
 *     closed form on an enclosure;
 *  5. the bake's lookup from inside a closed model is dark, as the
 *     reference is, while outside it is lit (light per side). */
#include "test_support.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "bake/bake.h"
#include "bake/samples.h"
#include "bake/transport.h"
#include "core/alloc.h"
#include "envmap/irradiance_table.h"
#include "points/room.h"
#include "ref/pathtrace.h"
#include "render/world.h"


static sg_sample_set every_splat(const sg_sites *ps, size_t n)
{
    sg_sample_set set = {0};
    set.splat = test_malloc(n * sizeof *set.splat);
    set.level = test_calloc(n, sizeof *set.level);
    for (size_t i = 0; i < n; ++i)
        set.splat[i] = (uint32_t)(i * (ps->count / n));
    set.count = set.capacity = n;
    return set;
}

static void free_set(sg_sample_set *set)
{
    test_free(set->splat);
    test_free(set->level);
}

/* 1. On the ground alone under the sun-and-sky map nothing blocks any ray:
 * every site's ratio is 1 exactly and no ray hits. E_u of the front side
 * estimates E0(+Y) = sg_envmap_irradiance without bias: over 256 sites
 * with independent lattice shifts the mean is within 4 standard errors
 * (the spread of the 256 estimates / 16) of the exact value. */
static void test_transport_unshadowed_estimate_unbiased(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"ground\",\"points\":4096}],"
                                          "\"envmap\":{\"builtin\":\"sunsky\"}}");
    const sg_sites *ps = sg_scene_sites(sg_world_scene(w, 0));
    sg_sample_set set = every_splat(ps, 256);
    sg_site_data sd = {0};
    sg_transport_desc td = {.env_rays = 16, .cos_rays = 16, .seed = 3};
    sg_error err = {0};
    if (sg_transport_gather(w, 0, &set, 0, &td, &sd, &err) != SG_OK)
        fail_msg("gather: %s", err.message);
    assert_int_equal(sd.count, 256);
    assert_int_equal(sd.hits, 0);
    double exact = sg_envmap_irradiance(sg_world_envmap(w), sg_v3(0, 1, 0)).y, sum = 0, sum2 = 0;
    for (size_t j = 0; j < 256; ++j) {
        for (int c = 0; c < 3; ++c)
            if (sd.ratio[6 * j + c] != 1.0f)
                fail_msg("site %zu: ratio %.9g where nothing blocks the light", j, (double)sd.ratio[6 * j + c]);
        double e = sd.unshadowed[6 * j + 1];
        sum += e;
        sum2 += e * e;
    }
    double mean = sum / 256, sd_e = sqrt(fmax(0.0, (sum2 - 256 * mean * mean) / 255)), se = sd_e / 16;
    fprintf(stderr, "unshadowed irradiance: mean of 256 sites %.5f, exact %.5f, standard error %.2g\n", mean, exact,
            se);
    if (!(fabs(mean - exact) <= 4.0 * se + 1e-5 * exact))
        fail_msg("E_u mean %.6f, exact %.6f (4 standard errors %.3g)", mean, exact, 4 * se);
    sg_site_data_free(&sd);
    free_set(&set);
    sg_world_destroy(w);
}

/* 2. Gathering sites 0..n in one call, or 0..n/2 and then the rest, on 1
 * or 2 threads gives the same bits. */
static void test_transport_sites_independent(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":4000,"
                                          "\"transform\":{\"translate\":[0,1,0]}},{\"builtin\":\"ground\","
                                          "\"points\":4000}],\"envmap\":{\"builtin\":\"sky\"}}");
    const sg_sites *ps = sg_scene_sites(sg_world_scene(w, 0));
    sg_sample_set set = every_splat(ps, 100);
    sg_transport_desc td = {.env_rays = 8, .cos_rays = 8, .seed = 9, .threads = 1};
    sg_site_data a = {0}, b = {0};
    assert_int_equal(sg_transport_gather(w, 0, &set, 0, &td, &a, NULL), SG_OK);
    set.count = 37;
    td.threads = 2;
    assert_int_equal(sg_transport_gather(w, 0, &set, 0, &td, &b, NULL), SG_OK);
    set.count = 100;
    assert_int_equal(sg_transport_gather(w, 0, &set, 0, &td, &b, NULL), SG_OK);
    assert_int_equal(a.count, b.count);
    assert_int_equal(a.hits, b.hits);
    assert_true(a.hits > 0);
    assert_memory_equal(a.ratio, b.ratio, 6 * a.count * sizeof(float));
    assert_memory_equal(a.unshadowed, b.unshadowed, 6 * a.count * sizeof(float));
    assert_memory_equal(a.first, b.first, (2 * a.count + 1) * sizeof(size_t));
    assert_memory_equal(a.hit_splat, b.hit_splat, a.hits * sizeof(uint32_t));
    assert_memory_equal(a.hit_model, b.hit_model, a.hits * sizeof(uint32_t));
    assert_memory_equal(a.hit_k, b.hit_k, a.hits * sizeof(float));
    sg_site_data_free(&a);
    sg_site_data_free(&b);
    free_set(&set);
    sg_world_destroy(w);
}

/* 3. The back sides of a closed sphere's splats look into the sphere: a
 * site whose pilot rays (at most 8) all meet back sides stops there, with
 * ratio 0. Their front sides see only the sky (no hit on the convex
 * sphere, ratio 1). A few back sites see a ray leave the sphere: a ray
 * that grazes the inside of the wall meets it again within a splat radius
 * at a normal within 25 degrees of its own, which the self test of ray.h
 * takes for its own surface (0.12% of cosine-distributed rays from inside
 * this sphere, measured); those sites trace all their rays. So: at least
 * 90% of the back sites stop after the pilot, and the back sides' mean
 * ratio is below 1e-3 (measured 3e-4). */
static void test_transport_inside_closed_model(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":6000}],"
                                          "\"envmap\":{\"builtin\":\"sky\"}}");
    const sg_sites *ps = sg_scene_sites(sg_world_scene(w, 0));
    sg_sample_set set = every_splat(ps, 200);
    sg_transport_desc td = {.env_rays = 32, .cos_rays = 64, .seed = 4};
    sg_site_data sd = {0};
    assert_int_equal(sg_transport_gather(w, 0, &set, 0, &td, &sd, NULL), SG_OK);
    size_t stopped = 0;
    double back_ratio = 0.0;
    for (size_t j = 0; j < sd.count; ++j) {
        size_t f0 = sd.first[2 * j], f1 = sd.first[2 * j + 1], b1 = sd.first[2 * j + 2];
        if (f1 != f0)
            fail_msg("site %zu, front: %zu rays hit the convex sphere", j, f1 - f0);
        if (b1 == f1)
            fail_msg("site %zu, back: no ray met the inside of the sphere", j);
        int inside = b1 - f1 <= 8;
        for (size_t h = f1; h < b1 && inside; ++h)
            inside = (sd.hit_model[h] & 1u) != 0;
        stopped += inside;
        for (int c = 0; c < 3; ++c)
            if (sd.ratio[6 * j + c] != 1.0f || (inside && sd.ratio[6 * j + 3 + c] != 0.0f))
                fail_msg("site %zu: ratios %g (front), %g (back)", j, (double)sd.ratio[6 * j + c],
                         (double)sd.ratio[6 * j + 3 + c]);
        back_ratio += sd.ratio[6 * j + 4];
    }
    back_ratio /= (double)sd.count;
    fprintf(stderr, "closed sphere: %zu of %zu back sites stopped after the pilot; back ratio %.3g\n", stopped,
            sd.count, back_ratio);
    if (!(stopped >= 0.9 * (double)sd.count) || !(back_ratio < 1e-3))
        fail_msg("%zu of %zu back sites inside (90%% expected), mean back ratio %.3g (bound 1e-3)", stopped, sd.count,
                 back_ratio);
    sg_site_data_free(&sd);
    free_set(&set);
    sg_world_destroy(w);
}

/* Looked-up frame mean and the largest deviation from `expect` over the
 * covered pixels (green). */
static void furnace_frame(const sg_bake *b, const sg_world *w, sg_vec3 eye, sg_vec3 look, double expect,
                          double *mean, double *worst)
{
    sg_bake_frame_desc fd = {.width = 48, .height = 48};
    if (sg_camera_look_at(eye, look, sg_v3(0, 1, 0), 40.0f, 1.0f, &fd.camera, NULL) != SG_OK)
        fail_msg("camera");
    sg_image img;
    assert_int_equal(sg_bake_render(b, w, &fd, &img, NULL, NULL), SG_OK);
    double sum = 0, dev = 0;
    size_t n = 0;
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 48; ++x) {
            sg_ray r = sg_camera_ray(&fd.camera, (float)x + 0.5f, (float)y + 0.5f, 48, 48);
            sg_world_hit h;
            if (!sg_world_intersect(w, &r, &h, NULL))
                continue;
            double v = img.data[3 * (y * 48 + x) + 1];
            sum += v;
            dev = fmax(dev, fabs(v / expect - 1.0));
            ++n;
        }
    assert_true(n > 100);
    *mean = sum / (double)n;
    *worst = dev;
    sg_image_free(&img);
}

/* The looked-up frame of a default bake of the scene `json` from eye
 * towards look (furnace_frame). */
static void furnace_bake(const char *json, sg_vec3 eye, sg_vec3 look, double expect, double *mean, double *worst)
{
    sg_world *w = sg_test_world_from_json(json);
    sg_bake_desc d = {.photons = {.seed = 5}};
    sg_bake *b = NULL;
    sg_error err = {0};
    if (sg_bake_create(w, &d, &b, &err) != SG_OK)
        fail_msg("bake: %s", err.message);
    furnace_frame(b, w, eye, look, expect, mean, worst);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

/* 4. White furnace (albedo 1, uniform sky L): the sites' weights are scaled
 * to integrate cos exactly, so every site's E0 ratio + indirect is E0 and
 * the solve has nothing to add noise to: each covered pixel is L to the
 * solve's tolerance (1e-5) and the interpolation's rounding. The issue's
 * bounds are 3% per pixel and 0.5% for the mean; 1% per pixel is asked
 * here, which the first estimator (photons, pixels 0.26 to 1.29 on a
 * statue) fails by far. The scene has a contact region (the sphere on the
 * plane), a concave model (the bunny) and the ground's rim. The same holds
 * for every surface model: the ISO's corners take the sites' light by the
 * same normalised interpolation and a hit blends 8 corners with weights
 * summing to 1, so its frame is held to the same bounds. */
static void white_furnace_every_pixel(const char *model)
{
    char json[1024];
    snprintf(json, sizeof json,
             "{\"models\":[{\"builtin\":\"sphere\",\"points\":20000,\"transform\":{\"translate\":[-1.2,1,0]},"
             "\"material\":{\"albedo\":[1,1,1],\"use_point_colors\":false},\"surface\":{\"model\":\"%s\"}},"
             "{\"builtin\":\"bunny\",\"points\":30000,\"transform\":{\"translate\":[1.2,0,0],\"scale\":0.2},"
             "\"material\":{\"albedo\":[1,1,1],\"use_point_colors\":false},\"surface\":{\"model\":\"%s\"}},"
             "{\"builtin\":\"ground\",\"points\":20000,\"transform\":{\"scale\":0.2},"
             "\"material\":{\"albedo\":[1,1,1],\"use_point_colors\":false},\"surface\":{\"model\":\"%s\"}}],"
             "\"envmap\":{\"builtin\":\"uniform\",\"radiance\":[0.7,0.7,0.7]}}",
             model, model, model);
    double mean, worst;
    furnace_bake(json, sg_v3(0, 3.0f, 5.0f), sg_v3(0, 0.8f, 0), 0.7, &mean, &worst);
    fprintf(stderr, "white furnace (%s): mean %.5f (0.7), largest pixel deviation %.4f\n", model, mean, worst);
    if (!(fabs(mean / 0.7 - 1.0) <= 0.005) || !(worst <= 0.01))
        fail_msg("furnace (%s): mean %.5f (0.7 within 0.5%%), a pixel %.2f%% off (bound 1%%)", model, mean,
                 100 * worst);
}

static void test_transport_white_furnace_every_pixel(void **state)
{
    (void)state;
    white_furnace_every_pixel("mls");
}

static void test_transport_white_furnace_every_pixel_iso(void **state)
{
    (void)state;
    white_furnace_every_pixel("iso");
}

/* The hybrid hierarchy (issue 15): the sphere as a closed mesh of 20k
 * triangles, the bunny's and the ground's triangles; light at vertices
 * and nodes, a hit blends three vertices by its barycentrics (sum 1) or
 * reads one node: the same bounds. */
static void test_transport_white_furnace_every_pixel_hybrid(void **state)
{
    (void)state;
    white_furnace_every_pixel("hybrid");
}

/* 4b. The white furnace inside the room (the hybrid's default: 2
 * triangles a rectangle with lattices), lit through its window: a bounce
 * keeps about 98% of the light there, so the solve's stopping rule
 * matters. Stopping at a change of 10 ppm a sweep (before stop 31) left
 * every pixel about 6e-4 dark (0.99942 of the sky at 250k points); the
 * rule on the predicted remaining error (transport.c, "Stopping") keeps
 * it within the tolerance, 1e-5 of the largest value, plus the float
 * interpolation's rounding: every pixel within 2e-4 is asked. */
static void test_transport_white_furnace_room(void **state)
{
    (void)state;
    double mean, worst;
    furnace_bake("{\"models\":[{\"builtin\":\"room\",\"points\":40000,\"material\":{\"albedo\":[1,1,1],"
                 "\"use_point_colors\":false},\"surface\":{\"model\":\"hybrid\"}}],"
                 "\"envmap\":{\"builtin\":\"uniform\",\"radiance\":[0.7,0.7,0.7]}}",
                 sg_v3(-1.75f, 1.55f, 1.6f), sg_v3(0.6f, 0.7f, -0.6f), 0.7, &mean, &worst);
    fprintf(stderr, "white furnace (hybrid room): mean %.6f (0.7), largest pixel deviation %.2e\n", mean, worst);
    if (!(worst <= 2e-4))
        fail_msg("furnace in the room: mean %.6f (0.7), a pixel %.2e off (bound 2e-4)", mean, worst);
}

/* 5. Light per side. From the centre of a closed sphere under the sky the
 * reference sees (almost) nothing: only light through gaps between
 * splats. The bake's lookup of the inside (back) sides must be as dark:
 * its mean below 1% of the outside's (it is 0 here: the sites inside see
 * only the inside). The same sphere from outside is lit. */
static void camera_inside_closed_model(const char *model)
{
    char json[512];
    snprintf(json, sizeof json,
             "{\"models\":[{\"builtin\":\"sphere\",\"points\":20000,\"surface\":{\"model\":\"%s\"},"
             "\"material\":{\"albedo\":[0.7,0.7,0.7],\"use_point_colors\":false}}],"
             "\"envmap\":{\"builtin\":\"sky\"}}",
             model);
    sg_world *w = sg_test_world_from_json(json);
    sg_bake_desc d = {.photons = {.seed = 5}};
    sg_bake *b = NULL;
    assert_int_equal(sg_bake_create(w, &d, &b, NULL), SG_OK);
    double inside, outside, worst;
    furnace_frame(b, w, sg_v3(0, 0, 0.01f), sg_v3(0, 0, -1), 1.0, &inside, &worst);
    furnace_frame(b, w, sg_v3(0, 0.5f, 3.0f), sg_v3(0, 0, 0), 1.0, &outside, &worst);
    sg_ref_desc rd = {.width = 16, .height = 16, .spp = 64, .max_depth = 8, .seed = 3};
    sg_camera_look_at(sg_v3(0, 0, 0.01f), sg_v3(0, 0, -1), sg_v3(0, 1, 0), 40.0f, 1.0f, &rd.camera, NULL);
    sg_ref_result r;
    assert_int_equal(sg_ref_render(w, &rd, &r, NULL), SG_OK);
    fprintf(stderr, "closed sphere (%s): inside %.3g, outside %.3g, reference inside %.3g\n", model, inside,
            outside, r.mean_radiance[1]);
    if (!(inside <= 0.01 * outside) || !(r.mean_radiance[1] <= 0.01 * outside))
        fail_msg("inside a closed sphere (%s): bake %.4g, reference %.4g, outside %.4g", model, inside,
                 r.mean_radiance[1], outside);
    sg_ref_result_free(&r);
    sg_bake_destroy(b);
    sg_world_destroy(w);
}

static void test_transport_camera_inside_closed_model(void **state)
{
    (void)state;
    camera_inside_closed_model("mls");
}

static void test_transport_camera_inside_closed_model_iso(void **state)
{
    (void)state;
    camera_inside_closed_model("iso");
}

static void test_transport_camera_inside_closed_model_hybrid(void **state)
{
    (void)state;
    camera_inside_closed_model("hybrid");
}

/* Sites off the surface (sg_transport_off_surface_sites). On a sphere of
 * splats, every splat names the surface over it: none is marked. In the
 * built-in room on the ISO octree, the corners in the room's floor and the
 * corners under its level inside a wall's foot are the two kinds: the
 * first name the floor, the second lie in the wall (their rays passed the
 * wall from behind and read the sky: floor corners by the walls 10-25
 * times too bright in a bake without refinement). */
static void test_transport_off_surface_sites(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":6000}]}");
    const sg_sites *ps = sg_scene_sites(sg_world_scene(w, 0));
    uint8_t *off = sg_alloc_array(ps->count, sizeof *off);
    assert_non_null(off);
    assert_int_equal(sg_transport_off_surface_sites(w, 0, 0, off), 0);
    sg_free(off);
    sg_world_destroy(w);

    w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"room\",\"points\":60000,"
                                "\"surface\":{\"model\":\"iso\"}}]}");
    ps = sg_scene_sites(sg_world_scene(w, 0));
    off = sg_alloc_array(ps->count, sizeof *off);
    assert_non_null(off);
    size_t n = sg_transport_off_surface_sites(w, 0, 0, off);
    size_t floor = 0, floor_off = 0, foot = 0, foot_on = 0;
    for (size_t i = 0; i < ps->count; ++i) {
        sg_vec3 p = sg_sites_position(ps, i), nn = sg_sites_normal(ps, i);
        if (ps->unsampled && ps->unsampled[i])
            continue; /* a node site (iso_sites.h): marked, never looked at */
        if (nn.y < 0.99f || p.y > 0.0f || p.y < -0.05f)
            continue; /* floor-facing corners just under the floor */
        float ax = fabsf(p.x), az = fabsf(p.z);
        if (ax < 1.8f && az < 1.8f) {
            floor++;
            floor_off += off[i];
        } else if (fmaxf(ax, az) > 2.0f && fmaxf(ax, az) < 2.2f && fminf(ax, az) < 1.8f) {
            foot++; /* beyond a wall's inner face, in its foot */
            foot_on += !off[i];
        }
    }
    fprintf(stderr, "room (ISO): %zu of %zu sites off the surface; floor %zu of %zu; in a wall's foot %zu of %zu on\n",
            n, ps->count, floor_off, floor, foot_on, foot);
    /* Not every corner in a wall's foot: the octree's surface has pockets
     * of air under the wall's rounding, up to 0.09 deep here, and a corner
     * under such a pocket names its floor (measured: 906 of 987 off;
     * left to the ISO's concave edges, docs/verify.md). */
    if (floor < 1000 || foot < 500 || floor_off || foot_on > foot / 10)
        fail_msg("room floor corners off the surface: %zu of %zu (none expected); corners in a wall's foot taken as "
                 "on the surface: %zu of %zu (at most 10%%)",
                 floor_off, floor, foot_on, foot);
    sg_free(off);
    sg_world_destroy(w);
}

/* 7. The rays' cones (transport.c sg_transport_ray_spread): off for
 * ray_cone 0, < 0 or NaN; on, ray_cone sqrt(1 / (ne p_e + nc p_c)) capped
 * at ray_cone sqrt(2 pi / (ne + nc)): for 32 + 64 rays under a uniform sky
 * (p_e = 1/(4 pi)) at the zenith (p_c = 1/pi) sqrt(1 / (8/pi + 64/pi)) =
 * sqrt(pi / 72) = 0.2089; near the horizon (p_c = 0.01/pi) the cap,
 * sqrt(2 pi / 96) = 0.2558; towards a sun drawn with p_e = 1000, about
 * sqrt(1 / 32000) = 0.00559; linear in ray_cone. */
static void test_transport_ray_spread(void **state)
{
    (void)state;
    const float pi = 3.14159265358979f;
    sg_transport_desc d = {.env_rays = 32, .cos_rays = 64};
    const float cones[3] = {0.0f, -1.0f, NAN};
    for (int i = 0; i < 3; ++i) {
        d.ray_cone = cones[i];
        assert_true(sg_transport_ray_spread(&d, 1.0f / (4.0f * pi), 1.0f / pi) == 0.0f);
    }
    const struct { float cone, pe, pc, expect; } cases[] = {
        {1.0f, 1.0f / (4.0f * pi), 1.0f / pi, sqrtf(pi / 72.0f)},
        {1.0f, 1.0f / (4.0f * pi), 0.01f / pi, sqrtf(2.0f * pi / 96.0f)},
        {1.0f, 1000.0f, 0.5f / pi, sqrtf(1.0f / (32000.0f + 32.0f / pi))},
        {4.0f, 1.0f / (4.0f * pi), 1.0f / pi, 4.0f * sqrtf(pi / 72.0f)},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        d.ray_cone = cases[i].cone;
        float got = sg_transport_ray_spread(&d, cases[i].pe, cases[i].pc);
        if (!(fabsf(got - cases[i].expect) <= 1e-5f * cases[i].expect))
            fail_msg("case %zu: cone %g, p_e %g, p_c %g: spread %.7g, expected %.7g", i, (double)cases[i].cone,
                     (double)cases[i].pe, (double)cases[i].pc, (double)got, (double)cases[i].expect);
    }
}

/* 8. The sites' rays carry the cone: on the gridded hybrid room
 * ("hybrid_site_spacing": 0; the default room is a few triangles with
 * lattices, whose hierarchy has no small nodes), the gather with
 * ray_cone 4 meets the hierarchy's inner nodes (light sites past the
 * vertices, hybrid.h) where the thin rays of ray_cone 0 meet vertices
 * only; the direct light's visibility ratio barely moves (the room's
 * faces are flat, so a node's disk lies on its triangles: the mean
 * |ratio difference| over the lit sites is below 0.02); and 0, -1 and NaN
 * give the same bits. */
static void test_transport_ray_cone_reaches_nodes(void **state)
{
    (void)state;
    sg_world *w = sg_test_world_from_json("{\"models\":[{\"builtin\":\"room\",\"points\":20000,"
                                          "\"surface\":{\"model\":\"hybrid\",\"hybrid_site_spacing\":0}}],"
                                          "\"envmap\":{\"builtin\":\"sunsky\"}}");
    const sg_sites *ps = sg_scene_sites(sg_world_scene(w, 0));
    /* vertex sites come first, then node slots (hybrid_scene.h): the
     * room's mesh as world.c builds it for 20000 points */
    sg_mesh mesh = {0};
    sg_room_desc rd = {.cell = sqrtf(162.0f / 20000.0f)};
    assert_int_equal(sg_room_mesh(&rd, &mesh, NULL), SG_OK);
    const size_t nv = mesh.vertex_count;
    sg_mesh_free(&mesh);
    assert_true(nv < ps->count);
    sg_sample_set set = every_splat(ps, 300);
    sg_site_data sd[4] = {{0}};
    const float cones[4] = {0.0f, -1.0f, NAN, 4.0f};
    for (int k = 0; k < 4; ++k) {
        sg_transport_desc td = {.env_rays = 16, .cos_rays = 32, .seed = 5, .ray_cone = cones[k]};
        assert_int_equal(sg_transport_gather(w, 0, &set, 0, &td, &sd[k], NULL), SG_OK);
    }
    for (int k = 1; k < 3; ++k) {
        assert_int_equal(sd[k].hits, sd[0].hits);
        assert_memory_equal(sd[k].ratio, sd[0].ratio, 6 * sd[0].count * sizeof(float));
        assert_memory_equal(sd[k].hit_splat, sd[0].hit_splat, sd[0].hits * sizeof(uint32_t));
        assert_memory_equal(sd[k].hit_k, sd[0].hit_k, sd[0].hits * sizeof(float));
    }
    size_t nodes0 = 0, nodes4 = 0;
    for (size_t h = 0; h < sd[0].hits; ++h)
        nodes0 += sd[0].hit_splat[h] >= nv;
    for (size_t h = 0; h < sd[3].hits; ++h)
        nodes4 += sd[3].hit_splat[h] >= nv;
    double diff = 0.0;
    size_t lit = 0;
    for (size_t i = 0; i < 6 * sd[0].count; ++i)
        if (sd[0].unshadowed[i] > 0.0f) {
            diff += fabs((double)sd[3].ratio[i] - (double)sd[0].ratio[i]);
            ++lit;
        }
    diff /= lit ? (double)lit : 1.0;
    printf("hits %zu (thin) %zu (cone 4); on inner nodes %zu, %zu; mean |ratio difference| %.4f over %zu\n",
           sd[0].hits, sd[3].hits, nodes0, nodes4, diff, lit);
    if (nodes0 != 0 || nodes4 < sd[3].hits / 4 || !(diff < 0.02))
        fail_msg("thin rays met %zu nodes (expected 0), cone 4 %zu of %zu hits (expected a quarter or more); "
                 "ratio moved by %.4f (expected < 0.02)",
                 nodes0, nodes4, sd[3].hits, diff);
    for (int k = 0; k < 4; ++k)
        sg_site_data_free(&sd[k]);
    free_set(&set);
    sg_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_transport_unshadowed_estimate_unbiased),
        cmocka_unit_test(test_transport_sites_independent),
        cmocka_unit_test(test_transport_inside_closed_model),
        cmocka_unit_test(test_transport_off_surface_sites),
        cmocka_unit_test(test_transport_white_furnace_every_pixel),
        cmocka_unit_test(test_transport_white_furnace_every_pixel_iso),
        cmocka_unit_test(test_transport_white_furnace_every_pixel_hybrid),
        cmocka_unit_test(test_transport_white_furnace_room),
        cmocka_unit_test(test_transport_camera_inside_closed_model),
        cmocka_unit_test(test_transport_camera_inside_closed_model_iso),
        cmocka_unit_test(test_transport_camera_inside_closed_model_hybrid),
        cmocka_unit_test(test_transport_ray_spread),
        cmocka_unit_test(test_transport_ray_cone_reaches_nodes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
