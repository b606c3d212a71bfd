/* test_hybrid.c — the hybrid point/triangle hierarchy (surface/hybrid.h,
 * Ye 2005): exact triangle hits, level of detail, determinism, bad meshes.
 *
 *  1. hybrid::watertight_plane     rays straight down and oblique through
 *                                  every vertex and edge of a gridded plane
 *                                  (exact float coordinates) all hit it.
 *  2. hybrid::watertight_sphere    rays through every vertex, edge midpoint
 *                                  and edge third of a closed sphere mesh
 *                                  (pole fans included) all hit it.
 *  3. hybrid::lod_zero_is_full     a frame at lod 0 and at lod 1e-6 equals
 *                                  the full-detail frame bit for bit (and
 *                                  lod 2 does change it: LOD is live).
 *  4. hybrid::lod_error_bound      per pixel, a LOD hit lies within lod
 *                                  footprints of the exact one; the frame's
 *                                  error shrinks with the threshold.
 *  5. hybrid::threads_identical    1 and 2 build threads: same layout hash,
 *                                  same frame bit for bit.
 *  6. hybrid::no_self_hits         rays spawned outwards from hits on a
 *                                  convex mesh (triangle and LOD hits) meet
 *                                  nothing; inwards they meet the far side.
 *  7. hybrid::hit_sites            weights sum to 1, are the barycentrics,
 *                                  and agree on both sides of an edge; the
 *                                  scene hit's dominant site is the sorted
 *                                  first (ties, clamping, NaN).
 *  8. hybrid::bad_meshes           0 triangles, all degenerate, index out of
 *                                  range, NaN position: INVALID_ARG naming
 *                                  the element; some degenerate: counted and
 *                                  never hit; a non-manifold edge (three
 *                                  triangles) is traced, and rays through it
 *                                  hit.
 *  9. hybrid::kernels_agree      the SIMD triangle and sphere-bundle tests
 *                                  equal their scalar references bit for bit
 *                                  on random rays (exact-zero edge functions
 *                                  and point-sized lanes included).
 * 10. hybrid::scene_interface    through sg_scene: sites are unit-normal
 *                                  surface points with reach > 0; a hit's
 *                                  weights sum to 1, equal the hierarchy's
 *                                  barycentrics, agree across an edge; a
 *                                  ray without spread is full detail;
 *                                  spawned rays do not hit their start.
 * 11. hybrid::scene_errors       points for a hybrid scene, a mesh for a
 *                                  point model, a point-cloud file as a
 *                                  hybrid model: INVALID_ARG naming the
 *                                  file or the cause.
 * 12. hybrid::filter_nodes       sg_scene_filter_sites: a constant stays
 *                                  constant in every node; on the field
 *                                  f(p) = p.y the value a LOD hit reads lies
 *                                  within its node's diameter of f(hit);
 *                                  the plane's root is its centroid's f.
 * 13. hybrid::scene_file_roundtrip  "model": "hybrid" with "hybrid_lod" 2, 0
 *                                  (full detail) and absent: parsed as
 *                                  2, -1, the default; "hybrid_site_spacing"
 *                                  0.5, 0, absent as 0.5, -1, 0; written and
 *                                  read back the same, hash for hash; the
 *                                  spacing changes the hash.
 * 14. hybrid::sites_threads_identical  sg_hybrid_sites_create (parallel)
 *                                  on 1 and 2 threads: every site's 10
 *                                  channels equal byte for byte, stand-ins
 *                                  included, on a sphere and on a plane
 *                                  with lattices.
 * 15. hybrid::albedo_is_site_blend  sg_scene_hit_albedo (which skips the
 *                                  colour reads when every site is white)
 *                                  equals the blend of the hit's sites'
 *                                  colours by its weights, bit for bit, on
 *                                  random rays (triangle and LOD hits,
 *                                  misses), with and without colours;
 *                                  sg_scene_hit_albedo_sites (the lookup's
 *                                  sites, room for 32) gives the same bits.
 * 16. hybrid::intersect4_matches_single  packets of four rays (coherent,
 *                                  scattered and random quads; LOD off,
 *                                  on, mixed; both faces, FRONT_ONLY,
 *                                  BACK_ONLY; partial masks) give each ray
 *                                  its single-ray hit bit for bit, through
 *                                  the hierarchy and through sg_scene.
 *     (kernels_agree also checks sg_bundle_test16, a node against 16
 *     rays, against the single ray's scalar test, ray by ray, with its
 *     one-eye form sg_bundle_test16_eye for rays from one origin, and
 *     sg_bundle_cone_test, a bundle against a packet's cone, against its
 *     scalar reference and against rays inside the cone, and
 *     sg_tri_intersect8, a leaf of eight triangles against one ray, against
 *     its scalar reference.)
 * 17. hybrid::intersect16_matches_single  the same for 4x4 blocks of
 *                                  sixteen rays (sg_hybrid_intersect16,
 *                                  sg_scene_intersect16), with edge and
 *                                  random masks; rays outside the mask
 *                                  stay unwritten.
 * 18. hybrid::lattice_sites       desc.site_spacing: on irregular triangles
 *                                  a hit's three lattice sites blend to the
 *                                  hit point (linear precision, to the sites'
 *                                  inward shift), weights sum
 *                                  to 1, the dominant site is the largest;
 *                                  the 2-triangle square reads a field as
 *                                  the 16 x 16 grid does (2e-3); filtered
 *                                  into the root: the centroid's value; bad
 *                                  spacings named; 1 and 2 threads alike.
 * 19. hybrid::builtin_room_lattice the world's builtin room on the hybrid
 *                                  is 2 triangles a rectangle with lattices
 *                                  at its "points" spacing (world.c), the
 *                                  gridded room with "hybrid_site_spacing":
 *                                  0; the two hash apart.
 */
#include "test_support.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "points/mesh_shapes.h"
#include "points/room.h"
#include "accel/sphere_bundle.h"
#include "math/oct.h"
#include "math/triangle.h"
#include "surface/hybrid.h"
#include "surface/hybrid_int.h" /* the bundles, for the kernel comparison */
#include "surface/hybrid_scene.h"
#include "surface/scene.h"
#include "io/scene_file.h"
#include "render/world.h"

static sg_hybrid *build(const sg_mesh *m, int threads)
{
    sg_hybrid_desc d = {.threads = threads, .name = "test mesh"};
    sg_hybrid *h = NULL;
    sg_error err = {0};
    if (sg_hybrid_create(&d, m, &h, &err) != SG_OK)
        fail_msg("sg_hybrid_create: %s", err.message);
    return h;
}

static sg_mesh sphere_mesh(int rings, int segments)
{
    sg_mesh m;
    sg_error err = {0};
    if (sg_mesh_make_sphere(rings, segments, sg_v3(0, 0, 0), 1.0f, &m, &err) != SG_OK)
        fail_msg("sg_mesh_make_sphere: %s", err.message);
    return m;
}

static sg_vec3 vtx(const sg_mesh *m, uint32_t i)
{
    return sg_v3(m->positions[3 * (size_t)i], m->positions[3 * (size_t)i + 1], m->positions[3 * (size_t)i + 2]);
}

static sg_ray ray_to(sg_vec3 org, sg_vec3 target)
{
    return (sg_ray){.org = org, .dir = sg_v3_normalize(sg_v3_sub(target, org)), .tmin = 0.0f, .tmax = INFINITY};
}

/* ---- 1-2: watertight ------------------------------------------------------ */

static void test_hybrid_watertight_plane(void **state)
{
    (void)state;
    /* side 16 on half 8: vertices at the integers, every coordinate exact. */
    sg_mesh m;
    assert_int_equal(sg_mesh_make_plane(16, 8.0f, &m, NULL), SG_OK);
    sg_hybrid *h = build(&m, 0);
    /* Targets: every vertex, every edge's midpoint (axis edges and
     * diagonals), all exact in float. Directions: straight down, and
     * oblique with dyadic components so the origin is exact too. */
    const sg_vec3 offs[3] = {{0, 4, 0}, {1, 4, 0.5f}, {-0.25f, 2, 0.75f}};
    size_t rays = 0, missed = 0;
    /* Shared edges and vertices only: the interior (a ray through the
     * mesh's outer rim may pass just outside it after rounding). */
    for (int i = -7; i <= 7; ++i)
        for (int j = -7; j <= 7; ++j)
            for (int e = 0; e < 4; ++e) {
                /* e: the vertex, then midpoints towards +x, +z and of the cell's
                 * diagonal (the edge between its two triangles) */
                float x = (float)j + (e == 1 || e == 3 ? 0.5f : 0.0f), z = (float)i + (e >= 2 ? 0.5f : 0.0f);
                if (x >= 8.0f || z >= 8.0f)
                    continue;
                for (int o = 0; o < 3; ++o) {
                    sg_vec3 p = sg_v3(x, 0.0f, z);
                    sg_ray r = ray_to(sg_v3_add(p, offs[o]), p);
                    sg_hybrid_hit hit;
                    ++rays;
                    if (!sg_hybrid_intersect(h, &r, NULL, &hit, NULL)) {
                        if (missed++ < 5)
                            print_error("missed: target (%g, 0, %g) from offset %d\n", (double)x, (double)z, o);
                        continue;
                    }
                    /* The hit lies on the target up to the rounding of the
                     * normalised direction (t ~ 4, 1 ulp of dir ~ 6e-8). */
                    assert_true(sg_v3_length(sg_v3_sub(hit.p, p)) < 1e-5f);
                }
            }
    if (missed)
        fail_msg("%zu of %zu rays through vertices and edges of the plane missed", missed, rays);
    sg_hybrid_destroy(h);
    sg_mesh_free(&m);
}

static void test_hybrid_watertight_sphere(void **state)
{
    (void)state;
    sg_mesh m = sphere_mesh(12, 20);
    sg_hybrid *h = build(&m, 0);
    uint64_t rng = 15;
    size_t rays = 0, missed = 0;
    for (size_t t = 0; t < m.triangle_count; ++t)
        for (int e = 0; e < 3; ++e) {
            sg_vec3 a = vtx(&m, m.triangles[3 * t + e]), b = vtx(&m, m.triangles[3 * t + (e + 1) % 3]);
            const float s[3] = {0.0f, 0.5f, 1.0f / 3.0f}; /* the vertex, the midpoint, a third */
            for (int k = 0; k < 3; ++k) {
                sg_vec3 p = sg_v3_add(a, sg_v3_scale(sg_v3_sub(b, a), s[k]));
                /* From outside, within 60 degrees of the outward direction. */
                sg_vec3 j = sg_v3(sg_test_rand01(&rng) - 0.5f, sg_test_rand01(&rng) - 0.5f,
                                  sg_test_rand01(&rng) - 0.5f);
                sg_vec3 org = sg_v3_add(sg_v3_scale(sg_v3_normalize(p), 3.0f), sg_v3_scale(j, 2.0f));
                sg_ray r = ray_to(org, p);
                sg_hybrid_hit hit;
                ++rays;
                if (!sg_hybrid_intersect(h, &r, NULL, &hit, NULL) || hit.back) {
                    if (missed++ < 5)
                        print_error("missed: triangle %zu edge %d at %g\n", t, e, (double)s[k]);
                    continue;
                }
                /* Convex: the first crossing is the target itself (rounding
                 * of p and of dir over t ~ 3: well below 1e-5). */
                assert_true(sg_v3_length(sg_v3_sub(hit.p, p)) < 1e-5f);
            }
        }
    if (missed)
        fail_msg("%zu of %zu rays through vertices and edges of the sphere missed", missed, rays);
    sg_hybrid_destroy(h);
    sg_mesh_free(&m);
}

/* ---- 3-5: frames, level of detail ---------------------------------------- */

enum { FRAME = 96 };
static const float TAN_HALF = 0.45f;
static const sg_vec3 EYE = {0.3f, 0.5f, 3.5f};

static sg_ray camera_ray(int x, int y)
{
    float u = TAN_HALF * (2.0f * ((float)x + 0.5f) / FRAME - 1.0f);
    float v = TAN_HALF * (1.0f - 2.0f * ((float)y + 0.5f) / FRAME);
    sg_vec3 d = sg_v3_normalize(sg_v3(u, v, -1.0f));
    return (sg_ray){.org = EYE, .dir = d, .tmin = 0.0f, .tmax = INFINITY};
}

/* The frame's hits (FRAME^2), traced on `threads` threads; lod < 0: no
 * footprint at all. Returns the number of LOD hits. */
static uint64_t frame(const sg_hybrid *h, float lod, int threads, sg_hybrid_hit *hits)
{
    sg_footprint fp = sg_footprint_pinhole(TAN_HALF, FRAME, lod);
    uint64_t lod_hits = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1) reduction(+ : lod_hits)
    for (int y = 0; y < FRAME; ++y)
        for (int x = 0; x < FRAME; ++x) {
            sg_ray r = camera_ray(x, y);
            sg_hybrid_hit *hit = &hits[y * FRAME + x];
            sg_hybrid_intersect(h, &r, lod < 0.0f ? NULL : &fp, hit, NULL);
            lod_hits += hit->node != SG_INVALID_ID;
        }
    return lod_hits;
}

/* Bitwise comparison of the fields a hit defines. */
static int same_hit(const sg_hybrid_hit *a, const sg_hybrid_hit *b)
{
    return memcmp(&a->t, &b->t, sizeof a->t) == 0 && memcmp(&a->p, &b->p, sizeof a->p) == 0 &&
           memcmp(&a->ns, &b->ns, sizeof a->ns) == 0 && memcmp(&a->ng, &b->ng, sizeof a->ng) == 0 &&
           a->triangle == b->triangle && a->node == b->node && memcmp(&a->b1, &b->b1, sizeof a->b1) == 0 &&
           memcmp(&a->b2, &b->b2, sizeof a->b2) == 0 && a->back == b->back && a->slot == b->slot &&
           memcmp(a->vertex, b->vertex, sizeof a->vertex) == 0;
}

static size_t count_different(const sg_hybrid_hit *a, const sg_hybrid_hit *b)
{
    size_t n = 0;
    for (size_t i = 0; i < (size_t)FRAME * FRAME; ++i)
        n += !same_hit(&a[i], &b[i]);
    return n;
}

/* A sphere fine enough that its nodes fall below a pixel: 64k triangles,
 * edges of ~0.025 at distance ~3.5, where a pixel is 2 * 0.45 / 96 * 3.5
 * = 0.033 wide. */
static sg_mesh fine_sphere(void) { return sphere_mesh(128, 256); }

static void test_hybrid_lod_zero_is_full(void **state)
{
    (void)state;
    sg_mesh m = fine_sphere();
    sg_hybrid *h = build(&m, 0);
    sg_hybrid_hit *full = sg_alloc_array(FRAME * FRAME, sizeof *full);
    sg_hybrid_hit *lod = sg_alloc_array(FRAME * FRAME, sizeof *lod);
    assert_non_null(full);
    assert_non_null(lod);
    frame(h, -1.0f, 2, full);
    const float zero_like[2] = {0.0f, 1e-6f};
    for (int k = 0; k < 2; ++k) {
        uint64_t lod_hits = frame(h, zero_like[k], 2, lod);
        size_t diff = count_different(full, lod);
        if (lod_hits || diff)
            fail_msg("lod %g: %llu LOD hits, %zu of %d pixels differ from full detail", (double)zero_like[k],
                     (unsigned long long)lod_hits, diff, FRAME * FRAME);
    }
    /* The same frame at lod 2 must differ, or the test above proves nothing. */
    uint64_t lod_hits = frame(h, 2.0f, 2, lod);
    if (lod_hits == 0 || count_different(full, lod) == 0)
        fail_msg("lod 2 changed nothing (%llu LOD hits): the footprint is not in effect",
                 (unsigned long long)lod_hits);
    sg_free(full);
    sg_free(lod);
    sg_hybrid_destroy(h);
    sg_mesh_free(&m);
}

static void test_hybrid_lod_error_bound(void **state)
{
    (void)state;
    sg_mesh m = fine_sphere();
    sg_hybrid *h = build(&m, 0);
    sg_hybrid_hit *full = sg_alloc_array(FRAME * FRAME, sizeof *full);
    sg_hybrid_hit *lod = sg_alloc_array(FRAME * FRAME, sizeof *lod);
    assert_non_null(full);
    assert_non_null(lod);
    frame(h, -1.0f, 2, full);
    const float spread = 2.0f * TAN_HALF / FRAME;
    const float thresholds[4] = {4.0f, 2.0f, 1.0f, 0.5f};
    double prev_mean = INFINITY;
    for (int k = 0; k < 4; ++k) {
        const float L = thresholds[k];
        uint64_t lod_hits = frame(h, L, 2, lod);
        double sum = 0.0, worst = 0.0;
        size_t coverage_diff = 0, far_from_outline = 0, too_large = 0;
        for (int y = 0; y < FRAME; ++y)
            for (int x = 0; x < FRAME; ++x) {
                size_t i = (size_t)y * FRAME + x;
                int a = full[i].triangle != SG_INVALID_ID, b = lod[i].node != SG_INVALID_ID || lod[i].triangle != SG_INVALID_ID;
                if (a != b) {
                    /* A disk lies in its node's sphere, under L footprints
                     * across, so it can change coverage only within L
                     * pixels of the exact outline: some pixel that near
                     * has the other full-detail coverage. */
                    ++coverage_diff;
                    int reach = (int)ceilf(L), near = 0;
                    for (int dy = -reach; dy <= reach && !near; ++dy)
                        for (int dx = -reach; dx <= reach && !near; ++dx) {
                            int yy = y + dy, xx = x + dx;
                            if (yy >= 0 && yy < FRAME && xx >= 0 && xx < FRAME)
                                near = (full[(size_t)yy * FRAME + xx].triangle != SG_INVALID_ID) != a;
                        }
                    far_from_outline += !near;
                    continue;
                }
                if (!a)
                    continue;
                if (lod[i].node != SG_INVALID_ID) {
                    /* The criterion itself: 2R < L spread b, b the centre's
                     * distance along the ray, within R of the hit's t. */
                    float R = sg_hybrid_node_radius(h, lod[i].node);
                    too_large += !(R > 0.0f && 2.0f * R < L * spread * (lod[i].t + R));
                }
                /* A node is hit as a disk only when its diameter 2R is below L
                 * footprints w(b) = spread * b, b its centre's distance along
                 * the ray; the disk and the node's triangles lie in its
                 * sphere, and on a convex mesh the exact hit of a ray through
                 * the disk is on those triangles or a neighbour's within the
                 * same sphere: |p_lod - p_full| <= 2R < L w(b), and b is within
                 * R of t. The error in footprints is therefore below L. */
                double e = sg_v3_length(sg_v3_sub(lod[i].p, full[i].p)) / (spread * full[i].t);
                sum += e;
                if (e > worst)
                    worst = e;
            }
        double mean = sum / (double)(FRAME * FRAME);
        print_message("lod %g: %llu LOD hits, mean error %.4f, worst %.4f footprints, %zu coverage changes\n",
                      (double)L, (unsigned long long)lod_hits, mean, worst, coverage_diff);
        if (!(worst < L) || far_from_outline || too_large)
            fail_msg("lod %g: worst error %g footprints (bound %g), %zu of %zu coverage changes away from the "
                     "outline, %zu nodes hit above the threshold", (double)L, worst, (double)L, far_from_outline,
                     coverage_diff, too_large);
        /* Shrinks with the threshold: each halving of L leaves no more error. */
        if (!(mean <= prev_mean))
            fail_msg("lod %g: mean error %g above %g at twice the threshold", (double)L, mean, prev_mean);
        prev_mean = mean;
    }
    sg_free(full);
    sg_free(lod);
    sg_hybrid_destroy(h);
    sg_mesh_free(&m);
}

static void test_hybrid_threads_identical(void **state)
{
    (void)state;
    sg_mesh m = fine_sphere();
    sg_hybrid *h1 = build(&m, 1), *h2 = build(&m, 2);
    uint64_t a = sg_hybrid_layout_hash(h1), b = sg_hybrid_layout_hash(h2);
    if (a != b)
        fail_msg("layout hash: 1 thread %016llx, 2 threads %016llx", (unsigned long long)a, (unsigned long long)b);
    sg_hybrid_hit *f1 = sg_alloc_array(FRAME * FRAME, sizeof *f1);
    sg_hybrid_hit *f2 = sg_alloc_array(FRAME * FRAME, sizeof *f2);
    assert_non_null(f1);
    assert_non_null(f2);
    frame(h1, 1.0f, 1, f1);
    frame(h2, 1.0f, 2, f2);
    size_t diff = count_different(f1, f2);
    if (diff)
        fail_msg("%zu pixels differ between 1 and 2 threads", diff);
    sg_free(f1);
    sg_free(f2);
    sg_hybrid_destroy(h1);
    sg_hybrid_destroy(h2);
    sg_mesh_free(&m);
}

/* The ordered stack and Ye's heap visit nodes in different orders; the
 * hit is the minimum over the accepted crossings either way (invariant 2
 * of hybrid_trace.c), so frames agree bit for bit at full detail and at
 * every level of detail on the sphere and, where ../shared/data is, the
 * 45k-triangle dragon (a scanned, bumpy surface: disks of every size). */
static void test_hybrid_lod_orders_agree(void **state)
{
    (void)state;
    sg_mesh meshes[2] = {fine_sphere(), {0}};
    int count = 1;
    const char *path = sg_test_shared_data("meshes/stanford_dragon/dragon_vrip_res3.ply");
    sg_error err = {0};
    if (path && sg_mesh_read(path, &meshes[1], &err) == SG_OK) {
        /* into the sphere's frame: centre at the origin, 2 units across */
        sg_aabb b = sg_aabb_empty();
        for (size_t i = 0; i < meshes[1].vertex_count; ++i)
            b = sg_aabb_grow(b, vtx(&meshes[1], (uint32_t)i));
        sg_vec3 c = sg_v3_scale(sg_v3_add(b.lo, b.hi), 0.5f);
        float s = 2.0f / sg_v3_length(sg_v3_sub(b.hi, b.lo));
        for (size_t i = 0; i < 3 * meshes[1].vertex_count; ++i)
            meshes[1].positions[i] = (meshes[1].positions[i] - (&c.x)[i % 3]) * s;
        sg_free(meshes[1].normals);
        meshes[1].normals = NULL;
        count = 2;
    }
    sg_hybrid_hit *a = sg_alloc_array(FRAME * FRAME, sizeof *a), *b = sg_alloc_array(FRAME * FRAME, sizeof *b);
    assert_non_null(a);
    assert_non_null(b);
    const float lods[] = {-1.0f, 0.5f, 1.0f, 2.0f, 4.0f, 16.0f};
    for (int m = 0; m < count; ++m) {
        sg_hybrid_desc d = {.threads = 2, .name = "test mesh"};
        sg_hybrid *hs = NULL, *hh = NULL;
        assert_int_equal(sg_hybrid_create(&d, &meshes[m], &hs, &err), SG_OK);
        d.traversal = SG_HYBRID_TRAVERSE_HEAP;
        assert_int_equal(sg_hybrid_create(&d, &meshes[m], &hh, &err), SG_OK);
        for (size_t k = 0; k < sizeof lods / sizeof lods[0]; ++k) {
            uint64_t na = frame(hs, lods[k], 2, a);
            frame(hh, lods[k], 2, b);
            size_t diff = count_different(a, b);
            print_message("%s, lod %g: %llu LOD hits, %zu pixels differ\n", m ? "dragon" : "sphere", (double)lods[k],
                          (unsigned long long)na, diff);
            if (diff)
                fail_msg("%s at lod %g: %zu of %d pixels differ between stack and heap", m ? "dragon" : "sphere",
                         (double)lods[k], diff, FRAME * FRAME);
        }
        sg_hybrid_destroy(hs);
        sg_hybrid_destroy(hh);
    }
    sg_free(a);
    sg_free(b);
    for (int m = 0; m < count; ++m)
        sg_mesh_free(&meshes[m]);
}

/* ---- 6-7: spawned rays, sites --------------------------------------------- */

static void test_hybrid_no_self_hits(void **state)
{
    (void)state;
    sg_mesh m = fine_sphere();
    sg_hybrid *h = build(&m, 0);
    sg_footprint fp = sg_footprint_pinhole(TAN_HALF, FRAME, 2.0f);
    uint64_t rng = 7;
    size_t hits = 0, lod_hits = 0, self = 0, through = 0;
    for (int y = 0; y < FRAME; y += 3)
        for (int x = 0; x < FRAME; x += 3) {
            sg_ray r = camera_ray(x, y);
            sg_hybrid_hit hit;
            if (!sg_hybrid_intersect(h, &r, (x + y) % 2 ? &fp : NULL, &hit, NULL))
                continue;
            ++hits;
            lod_hits += hit.node != SG_INVALID_ID;
            for (int k = 0; k < 8; ++k) {
                sg_vec3 d = sg_test_random_dir(&rng);
                int out = sg_v3_dot(d, hit.ng) > 0.0f;
                sg_ray s = sg_hybrid_spawn_ray(h, &hit, d, INFINITY);
                sg_hybrid_hit sh;
                int got = sg_hybrid_intersect(h, &s, NULL, &sh, NULL);
                if (out && got) {
                    if (self++ < 5)
                        print_error("outward ray from (%g %g %g) hit at t = %g\n", (double)hit.p.x,
                                    (double)hit.p.y, (double)hit.p.z, (double)sh.t);
                } else if (!out && hit.node == SG_INVALID_ID && (!got || !(sh.t > 1e-5f))) {
                    /* Inward from a triangle: the far side. A hit on the
                     * ray's own triangle would lie at t ~ rounding (1e-7);
                     * a real chord under 1e-5 needs a start within 1e-5 of
                     * an edge and a direction within the 1.4 degree
                     * dihedral angle of it, odds ~1e-5 per ray. (A LOD hit
                     * lies on a disk up to R off the facets, so an inward
                     * ray from it may graze past the sphere: not checked.) */
                    if (through++ < 5)
                        print_error("inward ray from (%g %g %g): hit %d at t = %g\n", (double)hit.p.x,
                                    (double)hit.p.y, (double)hit.p.z, got, (double)sh.t);
                }
            }
        }
    assert_true(hits > 200); /* the sphere covers ~1/3 of the 32 x 32 rays */
    assert_true(lod_hits > 0);
    if (self || through)
        fail_msg("%zu outward rays hit the sphere, %zu inward rays missed its far side (%zu hits)", self, through,
                 hits);
    sg_hybrid_destroy(h);
    sg_mesh_free(&m);
}

static void test_hybrid_hit_sites(void **state)
{
    (void)state;
    sg_mesh m;
    assert_int_equal(sg_mesh_make_plane(1, 1.0f, &m, NULL), SG_OK);
    sg_hybrid *h = build(&m, 0);
    /* The diagonal x + z = 0 of the square [-1, 1]^2 splits it into two
     * triangles (mesh_shapes.c); rays just either side of it. */
    const float eps = 1e-4f;
    sg_hybrid_hit a, b;
    sg_ray ra = ray_to(sg_v3(0.3f + eps, 2, -0.3f + eps), sg_v3(0.3f + eps, 0, -0.3f + eps));
    sg_ray rb = ray_to(sg_v3(0.3f - eps, 2, -0.3f - eps), sg_v3(0.3f - eps, 0, -0.3f - eps));
    assert_true(sg_hybrid_intersect(h, &ra, NULL, &a, NULL));
    assert_true(sg_hybrid_intersect(h, &rb, NULL, &b, NULL));
    assert_int_not_equal(a.triangle, b.triangle);
    uint32_t ia[3], ib[3];
    float wa[3], wb[3];
    assert_int_equal(sg_hybrid_hit_sites(h, &a, ia, wa, 3), 3);
    assert_int_equal(sg_hybrid_hit_sites(h, &b, ib, wb, 3), 3);
    /* Per vertex, the weight each side gives it: the two triangles share
     * the diagonal's vertices, and the vertex off the diagonal weighs ~0.
     * Weights are linear in position with gradient 1 / (cell side 2) per
     * unit, so the two sides differ by at most 2 eps sqrt 2 / 2 < 4 eps. */
    float per_vertex[2][4] = {{0}};
    float sum_a = 0.0f, sum_b = 0.0f;
    for (int k = 0; k < 3; ++k) {
        assert_true(ia[k] < 4 && ib[k] < 4);
        per_vertex[0][ia[k]] += wa[k];
        per_vertex[1][ib[k]] += wb[k];
        sum_a += wa[k];
        sum_b += wb[k];
    }
    assert_float_equal(sum_a, 1.0f, 1e-6f);
    assert_float_equal(sum_b, 1.0f, 1e-6f);
    for (int v = 0; v < 4; ++v)
        if (fabsf(per_vertex[0][v] - per_vertex[1][v]) > 4.0f * eps)
            fail_msg("vertex %d: weight %g on one side of the edge, %g on the other", v, (double)per_vertex[0][v],
                     (double)per_vertex[1][v]);
    /* max 1: the largest weight alone, renormalised. */
    assert_int_equal(sg_hybrid_hit_sites(h, &a, ia, wa, 1), 1);
    assert_float_equal(wa[0], 1.0f, 0.0f);
    /* A scene hit's site (sg_hybrid__dominant_site, branch-free) is that
     * first id: barycentrics on a grid of eighths (ties between two and
     * three weights), beyond [0, 1] (clamped), random, and NaN. */
    uint64_t rng = 5;
    const uint32_t v3[3] = {11, 22, 33};
    for (int n = 0; n < 3000; ++n) {
        float b1 = n < 400 ? (float)(n % 20 - 2) / 8.0f : 3.0f * sg_test_rand01(&rng) - 1.0f;
        float b2 = n < 400 ? (float)(n / 20 - 2) / 8.0f : 3.0f * sg_test_rand01(&rng) - 1.0f;
        if (n % 1000 == 499)
            b1 = NAN;
        if (n % 1000 == 999)
            b2 = NAN;
        uint32_t id;
        float wt;
        sg_hybrid__triangle_sites(v3, b1, b2, &id, &wt, 1);
        if (sg_hybrid__dominant_site(v3, b1, b2) != id)
            fail_msg("b1 %g, b2 %g: dominant site %u, sorted first %u", (double)b1, (double)b2,
                     sg_hybrid__dominant_site(v3, b1, b2), id);
    }
    sg_hybrid_destroy(h);
    sg_mesh_free(&m);
}

/* ---- 8: bad meshes ---------------------------------------------------------- */

static sg_mesh raw_mesh(size_t nv, const float *pos, size_t nt, const uint32_t *tri)
{
    sg_mesh m = {.vertex_count = nv, .triangle_count = nt};
    m.positions = sg_alloc_array(nv, 3 * sizeof(float));
    assert_non_null(m.positions);
    memcpy(m.positions, pos, nv * 3 * sizeof(float));
    if (nt) {
        m.triangles = sg_alloc_array(nt, 3 * sizeof(uint32_t));
        assert_non_null(m.triangles);
        memcpy(m.triangles, tri, nt * 3 * sizeof(uint32_t));
    }
    return m;
}

static void expect_error(const sg_mesh *m, sg_status want, const char *needle)
{
    sg_hybrid_desc d = {.name = "bad.ply"};
    sg_hybrid *h = (sg_hybrid *)(uintptr_t)1; /* must stay untouched */
    sg_error err = {0};
    sg_status st = sg_hybrid_create(&d, m, &h, &err);
    if (st != want || !strstr(err.message, needle) || !strstr(err.message, "bad.ply") ||
        h != (sg_hybrid *)(uintptr_t)1)
        fail_msg("status %d (want %d), message \"%s\" (want \"%s\")", (int)st, (int)want, err.message, needle);
}

static void test_hybrid_bad_meshes(void **state)
{
    (void)state;
    const float quad[] = {0, 0, 0, 1, 0, 0, 1, 0, 1, 0, 0, 1, 0.5f, 0, 0.5f};
    {
        sg_mesh m = raw_mesh(4, quad, 0, NULL);
        expect_error(&m, SG_ERR_INVALID_ARG, "no triangles");
        sg_mesh_free(&m);
    }
    {
        const uint32_t t[] = {0, 1, 1, 2, 2, 2, 0, 4, 2}; /* repeated vertices; collinear (0, 4, 2) */
        sg_mesh m = raw_mesh(5, quad, 3, t);
        expect_error(&m, SG_ERR_INVALID_ARG, "all 3 triangles have zero area");
        sg_mesh_free(&m);
    }
    {
        const uint32_t t[] = {0, 3, 2, 0, 2, 7};
        sg_mesh m = raw_mesh(5, quad, 2, t);
        expect_error(&m, SG_ERR_INVALID_ARG, "triangle 1: vertex index 7 is out of range");
        sg_mesh_free(&m);
    }
    {
        const uint32_t t[] = {0, 3, 2};
        sg_mesh m = raw_mesh(5, quad, 1, t);
        m.positions[3 * 2 + 1] = NAN;
        expect_error(&m, SG_ERR_INVALID_ARG, "vertex 2: position is not finite");
        sg_mesh_free(&m);
    }
    {
        /* Some degenerate: left out, counted, never hit. Triangle 1 is the
         * collinear (0, 4, 2) along the quad's diagonal. */
        const uint32_t t[] = {0, 3, 2, 0, 4, 2, 0, 2, 1};
        sg_mesh m = raw_mesh(5, quad, 3, t);
        sg_hybrid *h = build(&m, 0);
        sg_hybrid_info info;
        sg_hybrid_get_info(h, &info);
        assert_int_equal(info.degenerate_count, 1);
        assert_int_equal(info.triangle_count, 2);
        for (int k = 0; k <= 10; ++k) {
            float s = 0.1f * (float)k; /* along the diagonal, where the degenerate one lies */
            sg_ray r = ray_to(sg_v3(s, 1, s), sg_v3(s, 0, s));
            sg_hybrid_hit hit;
            assert_true(sg_hybrid_intersect(h, &r, NULL, &hit, NULL));
            assert_int_not_equal(hit.triangle, 1);
        }
        sg_hybrid_destroy(h);
        sg_mesh_free(&m);
    }
    {
        /* Non-manifold: three triangles on the edge (0,0,0)-(1,0,0), as
         * fins at 0, 120 and 240 degrees about it. Traced as given: rays
         * through the edge hit (one of them). */
        const float fin[] = {0, 0, 0, 1, 0, 0, 0.5f, 1, 0, 0.5f, -0.5f, 0.8660254f, 0.5f, -0.5f, -0.8660254f};
        const uint32_t t[] = {0, 1, 2, 0, 1, 3, 0, 1, 4};
        sg_mesh m = raw_mesh(5, fin, 3, t);
        sg_hybrid *h = build(&m, 0);
        for (int k = 1; k < 10; ++k) {
            float x = 0.1f * (float)k;
            sg_vec3 p = sg_v3(x, 0, 0);
            const sg_vec3 from[3] = {{x, 0.3f, 2}, {x, 2, -0.3f}, {x, -1.5f, 0.1f}};
            for (int f = 0; f < 3; ++f) {
                sg_ray r = ray_to(from[f], p);
                sg_hybrid_hit hit;
                if (!sg_hybrid_intersect(h, &r, NULL, &hit, NULL))
                    fail_msg("ray %d through the non-manifold edge at x = %g missed", f, (double)x);
                assert_true(hit.triangle < 3);
            }
        }
        sg_hybrid_destroy(h);
        sg_mesh_free(&m);
    }
}

/* ---- 9: SIMD kernels against their scalar references ------------------------ */

/* Case n of the triangle kernels' tests: `count` triangles in v and the
 * ray's set-up. Every fourth case has integer vertices met by the ray
 * down the z axis from (0, 0, 5), so that edge functions come out exactly
 * 0 (the fallback); the others are random. */
static sg_tri_ray kernel_case(uint64_t *rng, int n, int count, float v[][3][3])
{
    for (int l = 0; l < count; ++l)
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a)
                v[l][k][a] = n % 4 == 0 ? (float)(int)(4.0f * sg_test_rand01(rng)) - 2.0f
                                        : 4.0f * sg_test_rand01(rng) - 2.0f;
    sg_vec3 o = n % 4 == 0 ? sg_v3(0, 0, 5) : sg_v3(sg_test_rand01(rng) - 0.5f, sg_test_rand01(rng) - 0.5f, 5);
    sg_vec3 d = n % 4 == 0 ? sg_v3(0, 0, -1) : sg_v3_normalize(sg_v3(sg_test_rand01(rng) - 0.5f,
                                                                    sg_test_rand01(rng) - 0.5f, -1));
    return sg_tri_ray_prepare(o, d);
}

static void test_hybrid_kernels_agree(void **state)
{
    (void)state;
    uint64_t rng = 99;
#if SG_V16_SIMD
    /* sg_oct_decode16 (a packet's shading normals) against sg_oct_decode:
     * encodings of random unit vectors, random codes, the square's edges,
     * axes and corners, and codes on the fold (|x| + |y| = 1, z = 0) */
    for (int n = 0; n < 4000; ++n) {
        uint32_t code[16];
        for (int i = 0; i < 16; ++i) {
            const int16_t edge[7] = {0, 1, -1, 16383, -16384, 32767, -32767};
            /* two draws of 16 bits each (a float draw has 24 significant bits) */
            const uint32_t lo = (uint32_t)(sg_test_rand01(&rng) * 65536.0f), hi = (uint32_t)(sg_test_rand01(&rng) * 65536.0f);
            const uint32_t u = lo | hi << 16;
            const int16_t k = (int16_t)(lo & 0x7FFFu), sx = hi & 1u ? -1 : 1, sy = hi & 2u ? -1 : 1;
            if (n % 4 == 0)
                code[i] = sg_oct_encode(sg_test_random_dir(&rng));
            else if (n % 4 == 1)
                code[i] = u;
            else if (n % 4 == 2)
                code[i] = (uint32_t)(uint16_t)edge[lo % 7] | (uint32_t)(uint16_t)edge[hi % 7] << 16;
            else /* on the fold: |x| + |y| = 32767, where z rounds to 0 or just past it */
                code[i] = (uint32_t)(uint16_t)(int16_t)(sx * k) | (uint32_t)(uint16_t)(int16_t)(sy * (32767 - k)) << 16;
        }
        sg_v16 x, y, z;
        sg_oct_decode16(code, &x, &y, &z);
        _Alignas(64) float gx[16], gy[16], gz[16];
        sg_v16_store(gx, x), sg_v16_store(gy, y), sg_v16_store(gz, z);
        for (int i = 0; i < 16; ++i) {
            const sg_vec3 want = sg_oct_decode(code[i]), got = sg_v3(gx[i], gy[i], gz[i]);
            if (memcmp(&want, &got, sizeof want) != 0)
                fail_msg("oct code %08x: sg_oct_decode %.9g %.9g %.9g, sg_oct_decode16 %.9g %.9g %.9g", code[i],
                         (double)want.x, (double)want.y, (double)want.z, (double)got.x, (double)got.y, (double)got.z);
        }
    }
#endif
    /* Triangles: random, and some sharing vertices with the ray's origin
     * axis so that edge functions come out exactly 0 (the fallback). */
    size_t differ = 0, hits = 0;
    for (int n = 0; n < 20000; ++n) {
        float v[4][3][3];
        sg_tri_ray tr = kernel_case(&rng, n, 4, v);
        sg_tri4 t4;
        for (int l = 0; l < 4; ++l)
            sg_tri4_gather(&t4, l, &tr, v[l][0], v[l][1], v[l][2]);
        sg_tri4_hit a, b;
        unsigned ma = sg_tri_intersect4(&tr, &t4, 15u, 0.0f, INFINITY, &a);
        unsigned mb = sg_tri_intersect4_scalar(&tr, &t4, 15u, 0.0f, INFINITY, &b);
        int same = ma == mb && (a.front & ma) == (b.front & mb);
        for (int l = 0; l < 4 && same; ++l)
            if (ma >> l & 1u)
                same = memcmp(&a.t[l], &b.t[l], 4) == 0 && memcmp(&a.b1[l], &b.b1[l], 4) == 0 &&
                       memcmp(&a.b2[l], &b.b2[l], 4) == 0;
        differ += !same;
        hits += (size_t)__builtin_popcount(ma);
    }
    if (differ)
        fail_msg("triangles: %zu of 20000 groups of 4 differ between SIMD and scalar", differ);
    assert_true(hits > 1000); /* the comparison saw hits, not only misses */

    /* A leaf of up to eight triangles against one ray (sg_tri_intersect8,
     * the sparse packets' leaf test): random and integer triangles as
     * above, partial leaves (valid masks) and finite far limits. */
    size_t diff8 = 0, hits8 = 0, exact8 = 0; /* exact8: hits on the integer leaves */
    for (int n = 0; n < 20000; ++n) {
        float v[8][3][3];
        sg_tri_ray tr = kernel_case(&rng, n, 8, v);
        sg_tri8 t8;
        for (int l = 0; l < 8; ++l)
            sg_tri8_gather(&t8, l, &tr, v[l][0], v[l][1], v[l][2]);
        const unsigned valid = n % 3 == 0 ? (1u << (1 + n % 8)) - 1u : 255u;
        const float tmax = n % 5 == 4 ? 6.0f * sg_test_rand01(&rng) : INFINITY;
        sg_tri8_hit a, b;
        unsigned ma = sg_tri_intersect8(&tr, &t8, valid, 0.0f, tmax, &a);
        unsigned mb = sg_tri_intersect8_scalar(&tr, &t8, valid, 0.0f, tmax, &b);
        int same = ma == mb && (a.front & ma) == (b.front & mb), lane = -1;
        for (int l = 0; l < 8 && same; ++l)
            if (ma >> l & 1u && !(memcmp(&a.t[l], &b.t[l], 4) == 0 && memcmp(&a.b1[l], &b.b1[l], 4) == 0 &&
                                  memcmp(&a.b2[l], &b.b2[l], 4) == 0))
                same = 0, lane = l;
        if (!same && !diff8)
            print_message("leaf %d (valid 0x%02x, tmax %g): SIMD mask 0x%02x, scalar 0x%02x; lane %d: t %.9g / %.9g, "
                          "b1 %.9g / %.9g, b2 %.9g / %.9g\n",
                          n, valid, (double)tmax, ma, mb, lane, lane < 0 ? 0.0 : (double)a.t[lane],
                          lane < 0 ? 0.0 : (double)b.t[lane], lane < 0 ? 0.0 : (double)a.b1[lane],
                          lane < 0 ? 0.0 : (double)b.b1[lane], lane < 0 ? 0.0 : (double)a.b2[lane],
                          lane < 0 ? 0.0 : (double)b.b2[lane]);
        diff8 += !same;
        hits8 += (size_t)__builtin_popcount(ma);
        /* the integer triangles met by the axis ray: through vertices and
         * edges, so their hits come from the exact fallback */
        exact8 += n % 4 == 0 ? (size_t)__builtin_popcount(ma) : 0u;
    }
    if (diff8)
        fail_msg("triangles: %zu of 20000 leaves of 8 differ between SIMD and scalar", diff8);
    assert_true(hits8 > 1000 && exact8 > 100);

#if SG_V16_SIMD
    /* One triangle against sixteen rays of one origin and axis order
     * (sg_tri_intersect16), each lane against sg_tri_intersect: random
     * triangles, and integer ones met by axis rays (edge functions exactly
     * 0: reported in exact0, never decided by the kernel); per-ray tmax. */
    size_t tdiff = 0, thits = 0, texact = 0;
    for (int n = 0; n < 5000; ++n) {
        float v[3][3];
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a)
                v[k][a] = n % 4 == 0 ? (float)(int)(4.0f * sg_test_rand01(&rng)) - 2.0f
                                     : 4.0f * sg_test_rand01(&rng) - 2.0f;
        sg_vec3 o = n % 4 == 0 ? sg_v3(0, 0, 5) : sg_v3(sg_test_rand01(&rng) - 0.5f, sg_test_rand01(&rng) - 0.5f, 5);
        sg_tri_ray tr[16];
        sg_tri_shear16 sh;
        float tmin[16], tmax[16];
        unsigned valid = 0;
        for (int i = 0; i < 16; ++i) {
            sg_vec3 d = n % 4 == 0 && i < 4 ? sg_v3(0, 0, -1)
                                           : sg_v3_normalize(sg_v3(sg_test_rand01(&rng) - 0.5f,
                                                                   sg_test_rand01(&rng) - 0.5f, -1));
            tr[i] = sg_tri_ray_prepare(o, d);
            sh.sx[i] = tr[i].sx, sh.sy[i] = tr[i].sy, sh.sz[i] = tr[i].sz;
            tmin[i] = 0.0f;
            tmax[i] = i % 5 == 4 ? 6.0f * sg_test_rand01(&rng) : INFINITY;
            valid |= (unsigned)(tr[i].kx == tr[0].kx && tr[i].ky == tr[0].ky && tr[i].kz == tr[0].kz) << i;
        }
        const int k[3] = {tr[0].kx, tr[0].ky, tr[0].kz};
        float a[3], b[3], c[3];
        for (int q = 0; q < 3; ++q) {
            a[q] = v[0][k[q]] - tr[0].org[k[q]];
            b[q] = v[1][k[q]] - tr[0].org[k[q]];
            c[q] = v[2][k[q]] - tr[0].org[k[q]];
        }
        sg_tri16_hit th;
        unsigned e0;
        unsigned m16 = sg_tri_intersect16(&sh, a, b, c, valid, tmin, tmax, &th, &e0);
        texact += (size_t)__builtin_popcount(e0);
        for (int i = 0; i < 16; ++i) {
            if (!(valid >> i & 1u) || e0 >> i & 1u) {
                tdiff += (m16 >> i & 1u) != 0;
                continue;
            }
            sg_tri_hit one;
            int hit = sg_tri_intersect(&tr[i], v[0], v[1], v[2], tmin[i], tmax[i], &one);
            thits += (size_t)hit;
            if (hit != (int)(m16 >> i & 1u) ||
                (hit && (memcmp(&one.t, &th.t[i], 4) || memcmp(&one.b1, &th.b1[i], 4) ||
                         memcmp(&one.b2, &th.b2[i], 4) || one.front != (int)(th.front >> i & 1u)))) {
                if (!tdiff)
                    print_message("triangle %d ray %d: alone %d t %.9g, in sixteen %u t %.9g\n", n, i, hit,
                                  (double)one.t, m16 >> i & 1u, (double)th.t[i]);
                ++tdiff;
            }
        }
    }
    print_message("triangles x 16 rays: %zu hits, %zu lanes left to the exact fallback\n", thits, texact);
    if (tdiff)
        fail_msg("triangles x 16 rays: %zu lanes differ from sg_tri_intersect", tdiff);
    assert_true(thits > 1000 && texact > 100);
#endif

    /* Bundles of a real hierarchy, rays with and without a footprint. */
    sg_mesh m = sphere_mesh(32, 64);
    sg_hybrid *h = build(&m, 0);
    size_t bdiff = 0, entered = 0, points = 0;
    for (size_t bi = 0; bi < h->tree.bundle_count; ++bi)
        for (int k = 0; k < 16; ++k) {
            /* aimed near lane k % W's centre (NaN for an empty lane: a
             * NaN ray, which both must treat alike) */
            const sg_stree_bundle *B = &h->tree.bundles[bi];
            int l = k % SG_STREE_WIDTH;
            sg_vec3 c = sg_v3(B->cx[l], B->cy[l], B->cz[l]);
            sg_vec3 o = sg_v3_scale(sg_test_random_dir(&rng), 3.0f);
            sg_vec3 d = sg_v3_normalize(sg_v3_add(sg_v3_sub(c, o), sg_v3_scale(sg_test_random_dir(&rng), 0.1f)));
            sg_bundle_ray br = {.o = {o.x, o.y, o.z}, .d = {d.x, d.y, d.z}, .tmin = 0.0f,
                                .lod0 = k % 2 ? 0.01f : 0.0f, .lod1 = k % 2 ? 0.05f : 0.0f};
            float ta[SG_STREE_WIDTH], tb[SG_STREE_WIDTH];
            unsigned la, lb;
            unsigned ma = sg_bundle_test(&h->tree.bundles[bi], &br, INFINITY, ta, &la);
            unsigned mb = sg_bundle_test_scalar(&h->tree.bundles[bi], &br, INFINITY, tb, &lb);
            int same = ma == mb && (la & ma) == (lb & mb);
            for (int l = 0; l < SG_STREE_WIDTH && same; ++l)
                if (ma >> l & 1u)
                    same = memcmp(&ta[l], &tb[l], 4) == 0;
            bdiff += !same;
            entered += (size_t)__builtin_popcount(ma);
            points += (size_t)__builtin_popcount(la & ma);
        }
    print_message("bundles: %zu lanes entered, %zu point-sized\n", entered, points);
    if (bdiff)
        fail_msg("bundles: %zu tests differ between SIMD and scalar", bdiff);
    assert_true(entered > 100 && points > 10);

    /* One node against sixteen rays (sg_bundle_test16) is, per ray, the
     * single ray's test of that lane: rays from one eye and from many,
     * with and without footprints, finite and infinite far limits. */
    size_t rdiff = 0, rentered = 0, rpoints = 0;
    for (size_t bi = 0; bi < h->tree.bundle_count; ++bi) {
        const sg_stree_bundle *B = &h->tree.bundles[bi];
        sg_bundle_ray16 r16;
        float tfar[16];
        sg_bundle_ray one[16];
        sg_vec3 eye = sg_v3_scale(sg_test_random_dir(&rng), 3.0f);
        for (int i = 0; i < 16; ++i) {
            int l = (int)(bi + (size_t)i) % SG_STREE_WIDTH;
            sg_vec3 c = sg_v3(B->cx[l], B->cy[l], B->cz[l]);
            sg_vec3 o = bi % 2 ? eye : sg_v3_scale(sg_test_random_dir(&rng), 3.0f);
            sg_vec3 d = sg_v3_normalize(sg_v3_add(sg_v3_sub(c, o), sg_v3_scale(sg_test_random_dir(&rng), 0.1f)));
            one[i] = (sg_bundle_ray){.o = {o.x, o.y, o.z}, .d = {d.x, d.y, d.z}, .tmin = 0.0f,
                                     .lod0 = i % 2 ? 0.01f : 0.0f, .lod1 = i % 2 ? 0.05f : 0.0f};
            r16.ox[i] = o.x, r16.oy[i] = o.y, r16.oz[i] = o.z;
            r16.dx[i] = d.x, r16.dy[i] = d.y, r16.dz[i] = d.z;
            r16.tmin[i] = 0.0f, r16.lod0[i] = one[i].lod0, r16.lod1[i] = one[i].lod1;
            tfar[i] = i % 3 ? INFINITY : 3.0f * sg_test_rand01(&rng);
        }
        for (int l = 0; l < SG_STREE_WIDTH; ++l) {
            float ta[16], tb[16], tc[SG_STREE_WIDTH];
            unsigned la, lb;
            unsigned ma = sg_bundle_test16(B, l, &r16, tfar, ta, &la);
            unsigned mb = sg_bundle_test16_scalar(B, l, &r16, tfar, tb, &lb);
            if (bi % 2) { /* one eye: the eye kernel gives the same bits */
                float te[16];
                unsigned le, me = sg_bundle_test16_eye(B, l, &r16, tfar, te, &le);
                for (int i = 0; i < 16; ++i)
                    if ((me >> i & 1u) != (ma >> i & 1u) ||
                        ((ma >> i & 1u) && ((le >> i & 1u) != (la >> i & 1u) || memcmp(&te[i], &ta[i], 4) != 0))) {
                        if (!rdiff)
                            print_message("bundle %zu lane %d ray %d (one eye): entered %u / %u, tin %.9g / %.9g\n",
                                          bi, l, i, me >> i & 1u, ma >> i & 1u, (double)te[i], (double)ta[i]);
                        ++rdiff;
                    }
            }
            for (int i = 0; i < 16; ++i) {
                unsigned lc;
                unsigned mc = sg_bundle_test_scalar(B, &one[i], tfar[i], tc, &lc);
                int hit = (int)(mc >> l & 1u);
                if ((int)(ma >> i & 1u) != hit || (int)(mb >> i & 1u) != hit ||
                    (hit && ((la >> i & 1u) != (lc >> l & 1u) || (lb >> i & 1u) != (lc >> l & 1u) ||
                             memcmp(&ta[i], &tc[l], 4) != 0 || memcmp(&tb[i], &tc[l], 4) != 0))) {
                    if (!rdiff)
                        print_message("bundle %zu lane %d ray %d: entered %u / %u / %d, tin %.9g / %.9g / %.9g\n", bi,
                                      l, i, ma >> i & 1u, mb >> i & 1u, hit, (double)ta[i], (double)tb[i],
                                      (double)tc[l]);
                    ++rdiff;
                }
                rentered += (size_t)hit;
                rpoints += (size_t)(hit && (lc >> l & 1u));
            }
        }
    }
    print_message("bundles x 16 rays: %zu entered, %zu point-sized\n", rentered, rpoints);
    if (rdiff)
        fail_msg("bundles x 16 rays: %zu ray-node tests differ from the single ray's", rdiff);
    assert_true(rentered > 1000 && rpoints > 10);

    /* A bundle against a packet's cone (sg_bundle_cone_test) is its scalar
     * reference, and never drops a child that a ray inside the cone enters:
     * eight cones a bundle, of half-angle 0.5 to 15 degrees, aimed near a
     * child; centres with empty lanes (NaN) aim NaN cones, which both must
     * treat alike. */
    size_t cdiff = 0, cmissed = 0, cin = 0, cout = 0;
    for (size_t bi = 0; bi < 8 * h->tree.bundle_count; ++bi) {
        const sg_stree_bundle *B = &h->tree.bundles[bi / 8];
        int l = (int)(bi % SG_STREE_WIDTH);
        sg_vec3 c = sg_v3(B->cx[l], B->cy[l], B->cz[l]);
        sg_vec3 o = sg_v3_scale(sg_test_random_dir(&rng), 3.0f);
        sg_vec3 a = sg_v3_normalize(sg_v3_add(sg_v3_sub(c, o), sg_v3_scale(sg_test_random_dir(&rng), 0.2f)));
        float ang = (0.5f + 14.5f * sg_test_rand01(&rng)) * 3.14159265f / 180.0f;
        sg_bundle_cone C = {.o = {o.x, o.y, o.z}, .a = {a.x, a.y, a.z}, .sin = sinf(ang), .cos = cosf(ang)};
        unsigned ka = sg_bundle_cone_test(B, &C), kb = sg_bundle_cone_test_scalar(B, &C);
        if (ka != kb) {
            if (!cdiff)
                print_message("bundle %zu: cone children 0x%02x (SIMD) / 0x%02x (scalar)\n", bi / 8, ka, kb);
            ++cdiff;
        }
        cin += (size_t)__builtin_popcount(ka);
        for (int q = 0; q < SG_STREE_WIDTH; ++q)
            cout += (size_t)(B->r[q] == B->r[q] && !(ka >> q & 1u));
        /* rays inside the cone (the axis tilted by less than ang) */
        for (int k = 0; k < 4; ++k) {
            sg_vec3 d = sg_v3_normalize(sg_v3_add(a, sg_v3_scale(sg_test_random_dir(&rng), 0.9f * sinf(ang))));
            if (sg_v3_dot(d, a) < cosf(ang))
                continue;
            sg_bundle_ray br = {.o = {o.x, o.y, o.z}, .d = {d.x, d.y, d.z}, .tmin = 0.0f};
            float tin[SG_STREE_WIDTH];
            unsigned lod, entered_by = sg_bundle_test_scalar(B, &br, INFINITY, tin, &lod);
            if (entered_by & ~(ka & kb)) {
                if (!cmissed)
                    print_message("bundle %zu: a ray in the cone enters 0x%02x, the cone keeps 0x%02x / 0x%02x\n",
                                  bi / 8, entered_by, ka, kb);
                ++cmissed;
            }
        }
    }
    print_message("bundles against cones: %zu children kept, %zu skipped\n", cin, cout);
    if (cdiff || cmissed)
        fail_msg("cones: %zu masks differ between SIMD and scalar, %zu drop a child a ray enters", cdiff, cmissed);
    assert_true(cin > 100 && cout > 100);
    sg_hybrid_destroy(h);
    sg_mesh_free(&m);
}

/* ---- 10-11: behind sg_scene ------------------------------------------------- */

static sg_scene *hybrid_scene(const sg_mesh *m, float lod, float site_spacing)
{
    sg_scene_desc d = {.model = SG_SURFACE_HYBRID, .hybrid_lod = lod, .hybrid_site_spacing = site_spacing};
    sg_scene *sc = NULL;
    sg_error err = {0};
    if (sg_scene_create_mesh(&d, m, "test mesh", &sc, &err) != SG_OK)
        fail_msg("sg_scene_create_mesh: %s", err.message);
    return sc;
}

static sg_scene *mesh_scene(const sg_mesh *m, float lod) { return hybrid_scene(m, lod, 0.0f); }

static void test_hybrid_scene_interface(void **state)
{
    (void)state;
    sg_mesh m = fine_sphere();
    sg_scene *sc = mesh_scene(&m, 2.0f);
    sg_hybrid *h = build(&m, 0);
    const sg_sites *st = sg_scene_sites(sc);
    assert_int_equal(st->count, sg_hybrid_site_count(h));
    for (size_t i = 0; i < st->count; ++i) {
        sg_vec3 p = sg_sites_position(st, i), n = sg_sites_normal(st, i);
        /* every site on the unit sphere's surface, up to a node disk's
         * offset (well under its reach) */
        if (!(fabsf(sg_v3_length(n) - 1.0f) < 1e-3f) || !(st->radius[i] > 0.0f) ||
            !(fabsf(sg_v3_length(p) - 1.0f) <= st->radius[i]) || !(sg_v3_dot(n, sg_v3_normalize(p)) > 0.5f))
            fail_msg("site %zu: |p| %g, |n| %g, reach %g, n.p %g", i, (double)sg_v3_length(p),
                     (double)sg_v3_length(n), (double)st->radius[i], (double)sg_v3_dot(n, sg_v3_normalize(p)));
    }
    size_t hits = 0, lod_hits = 0, self = 0;
    uint64_t rng = 3;
    for (int y = 0; y < FRAME; y += 2)
        for (int x = 0; x < FRAME; x += 2) {
            sg_ray r = camera_ray(x, y);
            sg_hit a;
            sg_hybrid_hit b;
            int ha = sg_scene_intersect(sc, &r, &a, NULL); /* spread 0: full detail */
            int hb = sg_hybrid_intersect(h, &r, NULL, &b, NULL);
            assert_int_equal(ha, hb);
            if (!ha)
                continue;
            ++hits;
            assert_memory_equal(&a.t, &b.t, sizeof a.t);
            uint32_t ia[3], ib[3];
            float wa[3], wb[3];
            int na = sg_scene_hit_sites(sc, &a, ia, wa, 3), nb = sg_hybrid_hit_sites(h, &b, ib, wb, 3);
            assert_int_equal(na, 3);
            assert_int_equal(nb, 3);
            float sum = 0.0f;
            /* the hit carries the triangle test's barycentrics (stop 25):
             * the scene's weights are the hierarchy's, bit for bit */
            if (memcmp(&a.b1, &b.b1, sizeof a.b1) || memcmp(&a.b2, &b.b2, sizeof a.b2))
                fail_msg("pixel (%d, %d): barycentrics (%.9g, %.9g) in the hit, (%.9g, %.9g) in the hierarchy", x,
                         y, (double)a.b1, (double)a.b2, (double)b.b1, (double)b.b2);
            for (int k = 0; k < 3; ++k) {
                assert_int_equal(ia[k], ib[k]);
                if (memcmp(&wa[k], &wb[k], sizeof wa[k]))
                    fail_msg("pixel (%d, %d): weight %d is %.9g via the scene, %.9g in the hierarchy", x, y, k,
                             (double)wa[k], (double)wb[k]);
                sum += wa[k];
            }
            /* and they are p's: the vertices blended with them give p
             * (float rounding of the unit sphere, ~1e-7) */
            sg_vec3 q = sg_v3(0.0f, 0.0f, 0.0f);
            for (int k = 0; k < 3; ++k)
                q = sg_v3_madd(q, sg_sites_position(st, ib[k]), wa[k]);
            if (!(sg_v3_length(sg_v3_sub(q, a.p)) < 1e-5f))
                fail_msg("pixel (%d, %d): the weights blend the vertices to %g from p", x, y,
                         (double)sg_v3_length(sg_v3_sub(q, a.p)));
            assert_float_equal(sum, 1.0f, 1e-6f);
            assert_int_equal(sg_scene_hit_site(sc, &a), a.splat);
            /* with a footprint: LOD hits read their node alone */
            r.spread = 2.0f * TAN_HALF / FRAME;
            sg_hit l;
            if (sg_scene_intersect(sc, &r, &l, NULL) && l.leaf == SG_INVALID_ID) {
                ++lod_hits;
                assert_int_equal(sg_scene_hit_sites(sc, &l, ia, wa, 3), 1);
                assert_true(ia[0] >= m.vertex_count && ia[0] < st->count);
            }
            /* spawned outwards: the sphere is convex, nothing to hit */
            for (int k = 0; k < 4; ++k) {
                sg_vec3 d = sg_test_random_dir_facing(&rng, a.n);
                sg_ray s2 = sg_scene_spawn_ray(sc, &a, d, INFINITY);
                sg_hit x2;
                self += (size_t)sg_scene_intersect(sc, &s2, &x2, NULL);
            }
        }
    assert_true(hits > 500);
    assert_true(lod_hits > 0);
    if (self)
        fail_msg("%zu rays spawned outwards from the convex sphere hit it", self);
    sg_hybrid_destroy(h);
    sg_scene_destroy(sc);
    sg_mesh_free(&m);
}

static void test_hybrid_scene_errors(void **state)
{
    (void)state;
    sg_error err = {0};
    sg_scene *sc = NULL;
    /* points for a hybrid scene */
    float xyz[3] = {0, 0, 0}, nrm[3] = {0, 1, 0}, rad = 1, col[3] = {1, 1, 1};
    sg_pointset ps = {.count = 1, .px = &xyz[0], .py = &xyz[1], .pz = &xyz[2], .nx = &nrm[0], .ny = &nrm[1],
                      .nz = &nrm[2], .radius = &rad, .ar = &col[0], .ag = &col[1], .ab = &col[2]};
    sg_scene_desc hd = {.model = SG_SURFACE_HYBRID};
    assert_int_equal(sg_scene_create(&hd, &ps, &sc, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "needs a triangle mesh"));
    assert_null(sc);
    /* a mesh for a point model */
    sg_mesh m;
    assert_int_equal(sg_mesh_make_plane(2, 1.0f, &m, NULL), SG_OK);
    sg_scene_desc md = {.model = SG_SURFACE_MLS};
    assert_int_equal(sg_scene_create_mesh(&md, &m, "plane.ply", &sc, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "plane.ply"));
    assert_null(sc);
    sg_mesh_free(&m);
    /* a point cloud (a PLY without faces) as a hybrid model: the world's
     * error names the file and says why */
    const char ply[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                       "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
    const char *path = sg_test_write_file("cloud.ply", ply, sizeof ply - 1);
    char json[4200];
    snprintf(json, sizeof json, "{\"models\":[{\"path\":\"%s\",\"surface\":{\"model\":\"hybrid\"}}]}", path);
    sg_scene_file sf;
    assert_int_equal(sg_scene_file_parse(json, strlen(json), "test.json", NULL, &sf, &err), SG_OK);
    sg_world *w = NULL;
    assert_int_equal(sg_world_create(&sf, &w, &err), SG_ERR_INVALID_ARG);
    if (!strstr(err.message, "cloud.ply") || !strstr(err.message, "no triangles"))
        fail_msg("message \"%s\" should name cloud.ply and say it has no triangles", err.message);
    assert_null(w);
    sg_scene_file_free(&sf);
}

static void test_hybrid_filter_nodes(void **state)
{
    (void)state;
    sg_mesh m = fine_sphere();
    sg_scene *sc = mesh_scene(&m, 2.0f);
    const sg_sites *st = sg_scene_sites(sc);
    const size_t n = st->count, nv = m.vertex_count;
    float *v = sg_alloc_array(n, 2 * sizeof(float));
    assert_non_null(v);
    for (size_t i = 0; i < n; ++i) {
        v[2 * i] = i < nv ? 0.25f : -1.0f; /* nodes: garbage the filter must replace */
        v[2 * i + 1] = i < nv ? st->py[i] : -100.0f;
    }
    sg_scene_filter_sites(sc, v, 2);
    size_t lod = 0;
    /* every node the hierarchy has (a radius) got the constant: a mean of
     * equal values, to float rounding of the double sum */
    sg_hybrid *h = build(&m, 0);
    for (size_t k = 0; k < n - nv; ++k)
        if (sg_hybrid_node_radius(h, (uint32_t)k) > 0.0f && !(fabsf(v[2 * (nv + k)] - 0.25f) <= 1e-7f))
            fail_msg("node %zu: filtered constant %g (0.25)", k, (double)v[2 * (nv + k)]);
    for (int y = 0; y < FRAME; ++y)
        for (int x = 0; x < FRAME; ++x) {
            sg_ray r = camera_ray(x, y);
            r.spread = 2.0f * TAN_HALF / FRAME;
            sg_hit hit;
            if (!sg_scene_intersect(sc, &r, &hit, NULL) || hit.leaf != SG_INVALID_ID)
                continue;
            ++lod;
            uint32_t id;
            float w;
            assert_int_equal(sg_scene_hit_sites(sc, &hit, &id, &w, 1), 1);
            /* f is 1-Lipschitz: the node's triangles and the hit both lie in
             * its sphere, so their mean differs from f(hit) by < 2R */
            float R = sg_hybrid_node_radius(h, (uint32_t)(id - nv));
            if (!(fabsf(v[2 * id + 1] - hit.p.y) < 2.0f * R))
                fail_msg("LOD hit at y = %g reads %g from node %u of radius %g", (double)hit.p.y,
                         (double)v[2 * id + 1], id - (uint32_t)nv, (double)R);
        }
    assert_true(lod > 0);
    sg_hybrid_destroy(h);
    sg_free(v);
    sg_scene_destroy(sc);
    sg_mesh_free(&m);

    /* The plane [-1, 1]^2: the root's value of f = x + 2 is the centroid's, 2. */
    assert_int_equal(sg_mesh_make_plane(8, 1.0f, &m, NULL), SG_OK);
    sc = mesh_scene(&m, 1.0f);
    st = sg_scene_sites(sc);
    float *u = sg_alloc_array(st->count, sizeof(float));
    assert_non_null(u);
    for (size_t i = 0; i < st->count; ++i)
        u[i] = i < m.vertex_count ? st->px[i] + 2.0f : 0.0f;
    sg_scene_filter_sites(sc, u, 1);
    assert_float_equal(u[m.vertex_count], 2.0f, 1e-6f);
    sg_free(u);
    sg_scene_destroy(sc);
    sg_mesh_free(&m);
}

static void test_hybrid_scene_file_roundtrip(void **state)
{
    (void)state;
    const char *json = "{\"models\":[{\"builtin\":\"ground\",\"surface\":{\"model\":\"hybrid\",\"hybrid_lod\":2,"
                       "\"hybrid_site_spacing\":0.5}},"
                       "{\"builtin\":\"sphere\",\"surface\":{\"model\":\"hybrid\",\"hybrid_lod\":0,"
                       "\"hybrid_site_spacing\":0}},"
                       "{\"builtin\":\"bunny\",\"surface\":{\"model\":\"hybrid\"}}]}";
    sg_scene_file sf, back;
    sg_error err = {0};
    assert_int_equal(sg_scene_file_parse(json, strlen(json), "test.json", NULL, &sf, &err), SG_OK);
    const float want[3] = {2.0f, -1.0f, 0.0f}, spacing[3] = {0.5f, -1.0f, 0.0f};
    for (int k = 0; k < 3; ++k) {
        assert_int_equal(sf.models[k].surface.model, SG_SURFACE_HYBRID);
        assert_float_equal(sf.models[k].surface.hybrid_lod, want[k], 0.0f);
        assert_float_equal(sf.models[k].surface.hybrid_site_spacing, spacing[k], 0.0f);
    }
    char path[700];
    snprintf(path, sizeof path, "%s/hybrid_scene.json", sg_test_tmpdir());
    assert_int_equal(sg_scene_file_write(&sf, path, &err), SG_OK);
    if (sg_scene_file_load(path, &back, &err) != SG_OK)
        fail_msg("%s", err.message);
    for (int k = 0; k < 3; ++k) {
        assert_int_equal(back.models[k].surface.model, SG_SURFACE_HYBRID);
        assert_float_equal(back.models[k].surface.hybrid_lod, want[k], 0.0f);
        assert_float_equal(back.models[k].surface.hybrid_site_spacing, spacing[k], 0.0f);
    }
    assert_true(sg_scene_file_hash(&back, SG_SCENE_HASH_ALL) == sg_scene_file_hash(&sf, SG_SCENE_HASH_ALL));
    /* the spacing is hashed (it makes the sites a bake fills) */
    const uint64_t h0 = sg_scene_file_hash(&sf, SG_SCENE_HASH_ALL);
    sf.models[0].surface.hybrid_site_spacing = 0.25f;
    assert_true(sg_scene_file_hash(&sf, SG_SCENE_HASH_ALL) != h0);
    sf.models[0].surface.hybrid_site_spacing = 0.5f;
    sg_scene_file_free(&back);
    sg_scene_file_free(&sf);
}

/* ---- 14: parallel sites ---------------------------------------------------- */

/* sg_hybrid_sites_create of h on 1 and 2 threads: every site's channels
 * byte for byte (stand-ins included where h has any). */
static void check_sites_threads(const sg_hybrid *h, int want_stand_ins)
{
    sg_hybrid_sites s[2];
    sg_error err = {0};
    const int saved = omp_get_max_threads();
    for (int k = 0; k < 2; ++k) {
        omp_set_num_threads(k + 1);
        if (sg_hybrid_sites_create(h, &s[k], &err) != SG_OK)
            fail_msg("sg_hybrid_sites_create on %d threads: %s", k + 1, err.message);
    }
    omp_set_num_threads(saved);
    assert_int_equal(s[0].view.count, s[1].view.count);
    const size_t n = s[0].view.count;
    size_t stand_ins = 0;
    for (size_t i = 1; i < n; ++i) /* stand-ins copy the first real site */
        stand_ins += memcmp(&s[0].view.px[i], &s[0].view.px[0], sizeof(float)) == 0 &&
                     memcmp(&s[0].view.radius[i], &s[0].view.radius[0], sizeof(float)) == 0;
    if (want_stand_ins)
        assert_true(stand_ins > 0); /* the comparison covers them */
    const float *a[10] = {s[0].view.px, s[0].view.py, s[0].view.pz, s[0].view.nx, s[0].view.ny,
                          s[0].view.nz, s[0].view.radius, s[0].view.ar, s[0].view.ag, s[0].view.ab};
    const float *b[10] = {s[1].view.px, s[1].view.py, s[1].view.pz, s[1].view.nx, s[1].view.ny,
                          s[1].view.nz, s[1].view.radius, s[1].view.ar, s[1].view.ag, s[1].view.ab};
    for (int c = 0; c < 10; ++c)
        for (size_t i = 0; i < n; ++i)
            if (memcmp(&a[c][i], &b[c][i], sizeof(float)) != 0)
                fail_msg("site %zu of %zu (%s), channel %d: %.9g on 1 thread, %.9g on 2", i, n,
                         i < s[0].vertex_count ? "vertex" : "node", c, (double)a[c][i], (double)b[c][i]);
    sg_hybrid_sites_free(&s[0]);
    sg_hybrid_sites_free(&s[1]);
}

static void test_hybrid_sites_threads_identical(void **state)
{
    (void)state;
    /* coloured, so the colour channels carry data too */
    sg_mesh m = fine_sphere();
    m.colors = sg_alloc_array(m.vertex_count, 3 * sizeof(float));
    assert_non_null(m.colors);
    for (size_t i = 0; i < 3 * m.vertex_count; ++i)
        m.colors[i] = 0.5f + 0.5f * m.positions[i];
    sg_hybrid *h = build(&m, 0);
    check_sites_threads(h, 1);
    sg_hybrid_destroy(h);
    sg_mesh_free(&m);
    /* a coloured plane of 2 x 8 triangles with lattices (their sites'
     * reach is a parallel loop of its own; the mesh's vertices become
     * stand-ins) */
    assert_int_equal(sg_mesh_make_plane(8, 4.0f, &m, NULL), SG_OK);
    m.colors = sg_alloc_array(m.vertex_count, 3 * sizeof(float));
    assert_non_null(m.colors);
    for (size_t i = 0; i < 3 * m.vertex_count; ++i)
        m.colors[i] = 0.5f + 0.1f * m.positions[i];
    sg_hybrid_desc d = {.site_spacing = 0.07f};
    sg_error err = {0};
    if (sg_hybrid_create(&d, &m, &h, &err) != SG_OK)
        fail_msg("sg_hybrid_create: %s", err.message);
    sg_hybrid_info hi;
    sg_hybrid_get_info(h, &hi);
    assert_int_equal(hi.lattice_triangles, 128);
    check_sites_threads(h, 1);
    sg_hybrid_destroy(h);
    sg_mesh_free(&m);
}

/* ---- 15: albedo ------------------------------------------------------------ */

static void test_hybrid_albedo_is_site_blend(void **state)
{
    (void)state;
    for (int coloured = 0; coloured < 2; ++coloured) {
        sg_mesh m = fine_sphere();
        if (coloured) {
            m.colors = sg_alloc_array(m.vertex_count, 3 * sizeof(float));
            assert_non_null(m.colors);
            for (size_t i = 0; i < 3 * m.vertex_count; ++i)
                m.colors[i] = 0.5f + 0.5f * m.positions[i];
        }
        sg_scene *sc = mesh_scene(&m, 2.0f);
        const sg_sites *st = sg_scene_sites(sc);
        /* white (the lookup then fetches no colours): only without vertex
         * colours, and then every site's colour is 1 */
        assert_int_equal(st->white, !coloured);
        for (size_t i = 0; st->white && i < st->count; ++i)
            if (st->ar[i] != 1.0f || st->ag[i] != 1.0f || st->ab[i] != 1.0f)
                fail_msg("white sites, site %zu: colour %g %g %g", i, (double)st->ar[i], (double)st->ag[i],
                         (double)st->ab[i]);
        uint64_t rng = 5;
        size_t kinds[3] = {0}; /* misses, triangle hits, LOD hits */
        for (int i = 0; i < 20000; ++i) {
            sg_vec3 org = sg_v3_scale(sg_test_random_dir(&rng), 2.0f + 3.0f * sg_test_rand01(&rng));
            sg_ray r = ray_to(org, sg_v3_scale(sg_test_random_dir(&rng), 1.2f * sg_test_rand01(&rng)));
            r.spread = i % 2 ? 0.01f : 0.0f;
            sg_hit hit;
            if (!sg_scene_intersect(sc, &r, &hit, NULL)) {
                ++kinds[0];
                continue;
            }
            ++kinds[hit.leaf == SG_INVALID_ID ? 2 : 1];
            uint32_t ids[3];
            float w[3];
            int n = sg_scene_hit_sites(sc, &hit, ids, w, 3);
            sg_vec3 want = sg_v3(0.0f, 0.0f, 0.0f);
            for (int k = 0; k < n; ++k)
                want = sg_v3_madd(want, sg_v3(st->ar[ids[k]], st->ag[ids[k]], st->ab[ids[k]]), w[k]);
            sg_vec3 got = sg_scene_hit_albedo(sc, &hit);
            if (memcmp(&got, &want, sizeof got) != 0)
                fail_msg("%s mesh, ray %d (%s hit, %d sites): albedo %.9g %.9g %.9g, blend of sites %.9g %.9g %.9g",
                         coloured ? "coloured" : "plain", i, hit.leaf == SG_INVALID_ID ? "LOD" : "triangle", n,
                         (double)got.x, (double)got.y, (double)got.z, (double)want.x, (double)want.y,
                         (double)want.z);
            /* the lookup's way: from the sites it found with room for 32 */
            uint32_t ids32[32];
            float w32[32];
            int n32 = sg_scene_hit_sites(sc, &hit, ids32, w32, 32);
            sg_vec3 from_sites = sg_scene_hit_albedo_sites(sc, &hit, ids32, w32, n32);
            if (memcmp(&got, &from_sites, sizeof got) != 0)
                fail_msg("%s mesh, ray %d: albedo %.9g %.9g %.9g, from the lookup's %d sites %.9g %.9g %.9g",
                         coloured ? "coloured" : "plain", i, (double)got.x, (double)got.y, (double)got.z, n32,
                         (double)from_sites.x, (double)from_sites.y, (double)from_sites.z);
        }
        print_message("%s: %zu misses, %zu triangle hits, %zu LOD hits\n", coloured ? "coloured" : "plain",
                      kinds[0], kinds[1], kinds[2]);
        assert_true(kinds[0] > 100 && kinds[1] > 1000 && kinds[2] > 100);
        sg_scene_destroy(sc);
        sg_mesh_free(&m);
    }
}

/* ---- 16: packets ---------------------------------------------------------- */

/* side x side rays of a camera at eye looking at look, n x n pixels over a
 * 40-degree view: pixel (x, y) and its neighbours `step` pixels apart
 * right and down (step 1: a coherent block; larger: scattered); random:
 * each ray its own eye and direction. */
static void block_rays(uint64_t *rng, sg_vec3 c, float R, int kind, uint32_t flags, float spread, int side,
                       sg_ray *rays)
{
    enum { N = 64 };
    sg_vec3 eye = sg_v3_add(c, sg_v3_scale(sg_test_random_dir(rng), R * (0.3f + 3.0f * sg_test_rand01(rng))));
    sg_vec3 look = sg_v3_add(c, sg_v3_scale(sg_test_random_dir(rng), 0.5f * R * sg_test_rand01(rng)));
    sg_vec3 fw = sg_v3_normalize(sg_v3_sub(look, eye));
    sg_vec3 rt = sg_v3_normalize(sg_v3_cross(fw, fabsf(fw.y) < 0.9f ? sg_v3(0, 1, 0) : sg_v3(1, 0, 0)));
    sg_vec3 up = sg_v3_cross(rt, fw);
    const float th = tanf(20.0f * 3.14159265f / 180.0f);
    int step = kind == 0 ? 1 : 1 + (int)(16.0f * sg_test_rand01(rng));
    int span = (side - 1) * step;
    int x = (int)((float)(N - span) * sg_test_rand01(rng)), y = (int)((float)(N - span) * sg_test_rand01(rng));
    for (int r = 0; r < side * side; ++r) {
        float u = th * (2.0f * ((float)(x + (r % side) * step) + 0.5f) / N - 1.0f);
        float v = th * (1.0f - 2.0f * ((float)(y + (r / side) * step) + 0.5f) / N);
        sg_vec3 d = sg_v3_normalize(sg_v3_add(fw, sg_v3_add(sg_v3_scale(rt, u), sg_v3_scale(up, v))));
        rays[r] = (sg_ray){.org = eye, .dir = d, .tmin = 0.0f, .tmax = INFINITY, .flags = flags,
                           .spread = spread * 2.0f * th / N};
        if (kind == 2) { /* random: own eye, towards the model */
            rays[r].org = sg_v3_add(c, sg_v3_scale(sg_test_random_dir(rng), R * (0.3f + 3.0f * sg_test_rand01(rng))));
            sg_vec3 to = sg_v3_add(c, sg_v3_scale(sg_test_random_dir(rng), R * sg_test_rand01(rng)));
            rays[r].dir = sg_v3_normalize(sg_v3_sub(to, rays[r].org));
        }
    }
}

static void quad_rays(uint64_t *rng, sg_vec3 c, float R, int kind, uint32_t flags, float spread, sg_ray rays[4])
{
    block_rays(rng, c, R, kind, flags, spread, 2, rays);
}

/* The meshes the packet tests run on: the fine sphere, the bunny and,
 * where ../shared/data is, the 45k-triangle dragon. Returns how many. */
static int packet_meshes(sg_mesh meshes[3])
{
    meshes[0] = fine_sphere();
    meshes[1] = meshes[2] = (sg_mesh){0};
    sg_error err = {0};
    if (sg_mesh_read(SG_ASSET_DIR "/bunny.ply", &meshes[1], &err) != SG_OK)
        fail_msg("bunny: %s", err.message);
    const char *path = sg_test_shared_data("meshes/stanford_dragon/dragon_vrip_res3.ply");
    return path && sg_mesh_read(path, &meshes[2], &err) == SG_OK ? 3 : 2;
}

/* One packet of a packet test, for its messages. */
typedef struct packet_case {
    const char *mesh, *width; /* "four", "sixteen"                       */
    int q, kind, r; /* packet, its kind, the ray in it                   */
    uint32_t flags;
    float lod;
    unsigned mask;
} packet_case;

typedef struct packet_counts {
    size_t checked, hits, lod_hits, partly;
} packet_counts;

/* Ray r of a packet against itself alone, through the hierarchy (got, in:
 * the packet's answer) and through the scene (sgot, sin): the same hit,
 * bit for bit. Returns whether it hits alone. */
static int check_packet_ray(const packet_case *pc, const sg_hybrid *h, const sg_scene *sc, const sg_ray *ray,
                            const sg_footprint *fp, unsigned got, const sg_hybrid_hit *in, unsigned sgot,
                            const sg_hit *sin, packet_counts *n)
{
    sg_hybrid_hit one;
    int hs = sg_hybrid_intersect(h, ray, fp, &one, NULL);
    ++n->checked;
    n->hits += (size_t)hs;
    n->lod_hits += (size_t)(hs && one.node != SG_INVALID_ID);
    if (hs != (int)got || (hs && !same_hit(&one, in)))
        fail_msg("%s, packet %d (kind %d, flags %u, lod %g, mask %#x), ray %d: alone %d (t %.9g, triangle %u, "
                 "node %u), in %s %u (t %.9g, triangle %u, node %u)",
                 pc->mesh, pc->q, pc->kind, pc->flags, (double)pc->lod, pc->mask, pc->r, hs, (double)one.t, one.triangle,
                 one.node, pc->width, got, (double)in->t, in->triangle, in->node);
    sg_hit sone;
    int ss = sg_scene_intersect(sc, ray, &sone, NULL);
    if (ss != (int)sgot ||
        (ss && (memcmp(&sone.t, &sin->t, sizeof sone.t) || memcmp(&sone.p, &sin->p, sizeof sone.p) ||
                memcmp(&sone.n, &sin->n, sizeof sone.n) || sone.splat != sin->splat || sone.leaf != sin->leaf)) ||
        (!ss && sin->splat != SG_INVALID_ID))
        fail_msg("%s, packet %d (kind %d, flags %u), ray %d through the scene: alone %d (t %.9g, splat %u), "
                 "in %s %u (t %.9g, splat %u)",
                 pc->mesh, pc->q, pc->kind, pc->flags, pc->r, ss, (double)sone.t, sone.splat, pc->width, sgot,
                 (double)sin->t, sin->splat);
    return hs;
}

/* The packets covered what they should: hits and misses, LOD hits, and
 * packets whose rays part. */
static void check_packet_counts(const packet_counts *n)
{
    assert_true(n->hits > n->checked / 5 && n->hits < n->checked * 9 / 10 && n->lod_hits > 100 && n->partly > 100);
}

/* sg_hybrid_intersect4 and sg_scene_intersect4 give each ray of a packet
 * its single-ray hit, bit for bit (hybrid_trace.c "Packets"), on the fine
 * sphere, the bunny and, where ../shared/data is, the 45k-triangle dragon:
 * coherent, scattered and random quads; full detail, LOD at 1 and 4
 * pixels (lod differing within a packet too); both faces, FRONT_ONLY,
 * BACK_ONLY; full and partial masks, and finite tmax. */
static void test_hybrid_intersect4_matches_single(void **state)
{
    (void)state;
    sg_mesh meshes[3];
    const char *names[3] = {"sphere", "bunny", "dragon"};
    int count = packet_meshes(meshes);
    const uint32_t flags[3] = {SG_RAY_ANY_FACE, SG_RAY_FRONT_ONLY, SG_RAY_BACK_ONLY};
    const float lods[3] = {0.0f, 1.0f, 4.0f};
    uint64_t rng = 17;
    for (int mi = 0; mi < count; ++mi) {
        sg_hybrid *h = build(&meshes[mi], 2);
        sg_scene *sc = mesh_scene(&meshes[mi], 1.0f);
        sg_hybrid_info info;
        sg_hybrid_get_info(h, &info);
        sg_vec3 c = sg_v3_scale(sg_v3_add(info.bounds.lo, info.bounds.hi), 0.5f);
        float R = 0.5f * info.diagonal;
        packet_counts n = {0};
        for (int q = 0; q < 3000; ++q) {
            const int kind = q % 3;
            const uint32_t fl = flags[q / 3 % 3];
            const float lod = lods[q / 9 % 3];
            sg_ray rays[4];
            quad_rays(&rng, c, R, kind, fl, lod > 0.0f ? 1.0f : 0.0f, rays);
            if (q % 7 == 6) /* a finite tmax */
                for (int r = 0; r < 4; ++r)
                    rays[r].tmax = 2.0f * R * sg_test_rand01(&rng);
            sg_footprint fp[4];
            for (int r = 0; r < 4; ++r)
                fp[r] = (sg_footprint){0.0f, rays[r].spread, q % 11 == 10 ? lods[r % 3] : lod};
            const unsigned mask = q % 5 == 4 ? 0xDu : 0xFu;
            sg_hybrid_hit four[4];
            const sg_footprint *fpp = lod > 0.0f || q % 11 == 10 ? fp : NULL;
            unsigned got = sg_hybrid_intersect4(h, rays, mask, fpp, four, NULL);
            sg_hit sfour[4];
            unsigned sgot = sg_scene_intersect4(sc, rays, mask, sfour, NULL);
            unsigned alone = 0;
            for (int r = 0; r < 4; ++r) {
                if (!(mask >> r & 1u))
                    continue;
                packet_case pc = {names[mi], "four", q, kind, r, fl, lod, mask};
                alone |= (unsigned)check_packet_ray(&pc, h, sc, &rays[r], fpp ? &fp[r] : NULL, got >> r & 1u,
                                                    &four[r], sgot >> r & 1u, &sfour[r], &n) << r;
            }
            n.partly += alone != 0 && alone != mask;
        }
        print_message("%s: %zu rays in packets, %zu hits (%zu LOD), %zu packets partly hit\n", names[mi], n.checked,
                      n.hits, n.lod_hits, n.partly);
        check_packet_counts(&n);
        sg_scene_destroy(sc);
        sg_hybrid_destroy(h);
    }
    for (int mi = 0; mi < count; ++mi)
        sg_mesh_free(&meshes[mi]);
}

/* sg_hybrid_intersect16 and sg_scene_intersect16 give each ray of a 4x4
 * block its single-ray hit, bit for bit, as intersect4_matches_single
 * checks for quads: coherent, scattered and random blocks; full detail,
 * LOD at 1 and 4 pixels and mixed within a block; both faces, FRONT_ONLY,
 * BACK_ONLY; full, partial (a block on the frame's edge) and random
 * masks; finite tmax, per ray too. Rays outside the mask are not written. */
static void test_hybrid_intersect16_matches_single(void **state)
{
    (void)state;
    sg_mesh meshes[3];
    const char *names[3] = {"sphere", "bunny", "dragon"};
    int count = packet_meshes(meshes);
    const uint32_t flags[3] = {SG_RAY_ANY_FACE, SG_RAY_FRONT_ONLY, SG_RAY_BACK_ONLY};
    const float lods[3] = {0.0f, 1.0f, 4.0f};
    uint64_t rng = 23;
    for (int mi = 0; mi < count; ++mi) {
        sg_hybrid *h = build(&meshes[mi], 2);
        sg_scene *sc = mesh_scene(&meshes[mi], 1.0f);
        sg_hybrid_info info;
        sg_hybrid_get_info(h, &info);
        sg_vec3 c = sg_v3_scale(sg_v3_add(info.bounds.lo, info.bounds.hi), 0.5f);
        float R = 0.5f * info.diagonal;
        packet_counts n = {0};
        for (int q = 0; q < 1500; ++q) {
            const int kind = q % 3;
            const uint32_t fl = flags[q / 3 % 3];
            const float lod = lods[q / 9 % 3];
            sg_ray rays[16];
            block_rays(&rng, c, R, kind, fl, lod > 0.0f ? 1.0f : 0.0f, 4, rays);
            if (q % 7 == 6) /* a finite tmax, one per ray */
                for (int r = 0; r < 16; ++r)
                    rays[r].tmax = 2.0f * R * sg_test_rand01(&rng);
            sg_footprint fp[16];
            for (int r = 0; r < 16; ++r)
                fp[r] = (sg_footprint){0.0f, rays[r].spread, q % 11 == 10 ? lods[r % 3] : lod};
            unsigned mask = 0xFFFFu;
            if (q % 5 == 3)
                mask = 0x0777u; /* a block on the frame's right and bottom edges */
            else if (q % 5 == 4)
                mask = 1u + (unsigned)(65534.0f * sg_test_rand01(&rng));
            sg_hybrid_hit sixteen[16];
            sg_hit ssix[16];
            for (int r = 0; r < 16; ++r) {
                sixteen[r].t = ssix[r].t = -1.0f; /* must stay for rays outside mask */
                ssix[r].splat = 12345u;
            }
            const sg_footprint *fpp = lod > 0.0f || q % 11 == 10 ? fp : NULL;
            unsigned got = sg_hybrid_intersect16(h, rays, mask, fpp, sixteen, NULL);
            unsigned sgot = sg_scene_intersect16(sc, rays, mask, ssix, NULL);
            unsigned alone = 0;
            for (int r = 0; r < 16; ++r) {
                if (!(mask >> r & 1u)) {
                    if (got >> r & 1u || sgot >> r & 1u || sixteen[r].t != -1.0f || ssix[r].t != -1.0f ||
                        ssix[r].splat != 12345u)
                        fail_msg("%s, block %d: ray %d outside mask %#x was written", names[mi], q, r, mask);
                    continue;
                }
                packet_case pc = {names[mi], "sixteen", q, kind, r, fl, lod, mask};
                alone |= (unsigned)check_packet_ray(&pc, h, sc, &rays[r], fpp ? &fp[r] : NULL, got >> r & 1u,
                                                    &sixteen[r], sgot >> r & 1u, &ssix[r], &n) << r;
            }
            n.partly += alone != 0 && alone != mask;
        }
        print_message("%s: %zu rays in blocks of 16, %zu hits (%zu LOD), %zu blocks partly hit\n", names[mi],
                      n.checked, n.hits, n.lod_hits, n.partly);
        check_packet_counts(&n);
        sg_scene_destroy(sc);
        sg_hybrid_destroy(h);
    }
    for (int mi = 0; mi < count; ++mi)
        sg_mesh_free(&meshes[mi]);
}

/* ---- 18: lattices of light sites ------------------------------------------ */

static sg_scene *lattice_scene(const sg_mesh *m, float spacing) { return hybrid_scene(m, 0.0f, spacing); }

/* The facts of the hierarchy lattice_scene builds (the same desc: the
 * same hierarchy, threads_identical). */
static sg_hybrid_info lattice_info(const sg_mesh *m, float spacing)
{
    sg_hybrid_desc d = {.site_spacing = spacing};
    sg_hybrid *h = NULL;
    sg_error err = {0};
    if (sg_hybrid_create(&d, m, &h, &err) != SG_OK)
        fail_msg("sg_hybrid_create: %s", err.message);
    sg_hybrid_info hi;
    sg_hybrid_get_info(h, &hi);
    sg_hybrid_destroy(h);
    return hi;
}

/* A smooth field over the sites, for interpolation comparisons. */
static float field(sg_vec3 p) { return sinf(3.0f * p.x) + cosf(2.0f * p.z) + 0.5f * p.y; }

/* The field interpolated at a hit from its sites, and the sites' blend of
 * positions (= the hit point where the weights are barycentrics of a flat
 * small triangle: linear precision). */
static float interpolate(const sg_scene *sc, const sg_hit *hit, sg_vec3 *blend, float *wsum, uint32_t ids[3])
{
    const sg_sites *st = sg_scene_sites(sc);
    float w[3], f = 0.0f;
    int n = sg_scene_hit_sites(sc, hit, ids, w, 3);
    assert_int_equal(n, 3);
    *blend = sg_v3(0, 0, 0);
    *wsum = 0.0f;
    for (int k = 0; k < 3; ++k) {
        sg_vec3 p = sg_sites_position(st, ids[k]);
        *blend = sg_v3_madd(*blend, p, w[k]);
        *wsum += w[k];
        f += w[k] * field(p);
    }
    return f;
}

static void test_hybrid_lattice_sites(void **state)
{
    (void)state;
    /* (a) Irregular triangles (acute, obtuse, a sliver; not in one plane)
     * with lattices of 4 to 40 rows: every hit's three sites are lattice
     * sites of its triangle, its weights sum to 1, their blend of the
     * sites' positions is the hit point (so the small triangle and its
     * weights are the right ones: up and down swapped, or a row off, move
     * it by a cell), the dominant site is the largest weight's, and the
     * sites are on the surface with unit normals and reach > 0. */
    static const float P[] = {0, 0, 0, 4, 0.3f, 0, 1, 0.2f, 3, 5, 1, 3.5f, -3, 0.5f, 2, 9, 0.1f, 0.4f};
    static const uint32_t T[] = {0, 2, 1, 1, 2, 3, 0, 4, 2, 1, 3, 5};
    sg_mesh m = {.positions = (float *)P, .triangles = (uint32_t *)T, .vertex_count = 6, .triangle_count = 4};
    sg_scene *sc = lattice_scene(&m, 0.2f);
    const sg_sites *st = sg_scene_sites(sc);
    sg_hybrid_info hi = lattice_info(&m, 0.2f);
    assert_int_equal(hi.lattice_triangles, 4);
    assert_true(hi.lattice_sites > 4 * 15 && hi.vertex_count == 6 + hi.lattice_sites);
    uint64_t rng = 5;
    int hits = 0, down = 0;
    for (int k = 0; k < 20000; ++k) {
        const uint32_t *t = T + 3 * (k % 4);
        float a = sg_test_rand01(&rng), b = sg_test_rand01(&rng);
        if (a + b > 1.0f)
            a = 1.0f - a, b = 1.0f - b;
        sg_vec3 v0 = vtx(&m, t[0]), v1 = vtx(&m, t[1]), v2 = vtx(&m, t[2]);
        sg_vec3 target = sg_v3_add(v0, sg_v3_add(sg_v3_scale(sg_v3_sub(v1, v0), a), sg_v3_scale(sg_v3_sub(v2, v0), b)));
        sg_vec3 o = sg_v3_add(target, sg_v3(0.3f * sg_test_rand01(&rng), 5.0f, 0.3f * sg_test_rand01(&rng)));
        sg_ray r = ray_to(o, target);
        sg_hit hit;
        if (!sg_scene_intersect(sc, &r, &hit, NULL))
            continue;
        ++hits;
        uint32_t ids[3];
        sg_vec3 blend;
        float wsum;
        (void)interpolate(sc, &hit, &blend, &wsum, ids);
        for (int q = 0; q < 3; ++q)
            if (ids[q] < 6 || ids[q] >= hi.vertex_count)
                fail_msg("hit %d: site %u is not a lattice site (6 .. %zu)", k, ids[q], hi.vertex_count - 1);
        if (!(fabsf(wsum - 1.0f) < 1e-6f))
            fail_msg("hit %d: weights sum to %.9g", k, (double)wsum);
        /* the sites sit 3e-3 of a cell inside their triangle (hybrid.c
         * SHRINK): their blend is off the hit by at most 3e-3 x the longest
         * small edge (< 2 spacings, 0.4), 1.2e-3; a wrong small triangle
         * is off by a good part of a cell (0.02 with up and down swapped) */
        if (!(sg_v3_length(sg_v3_sub(blend, hit.p)) < 1.5e-3f))
            fail_msg("hit %d at (%g %g %g): its sites blend to (%g %g %g)", k, (double)hit.p.x, (double)hit.p.y,
                     (double)hit.p.z, (double)blend.x, (double)blend.y, (double)blend.z);
        uint32_t id1;
        float w1;
        assert_int_equal(sg_scene_hit_sites(sc, &hit, &id1, &w1, 1), 1);
        assert_int_equal(hit.splat, id1);
        /* a down triangle's first site is (i + 1, j + 1): two rows on */
        down += ids[0] > ids[1] && ids[0] > ids[2];
    }
    assert_true(hits > 19000 && down > hits / 4);
    for (size_t i = 6; i < hi.vertex_count; ++i) {
        sg_vec3 nn = sg_sites_normal(st, (uint32_t)i);
        if (!(fabsf(sg_v3_length(nn) - 1.0f) < 1e-3f) || !(st->radius[i] > 0.0f) || !(st->radius[i] < 0.4f))
            fail_msg("lattice site %zu: normal length %g, reach %g", i, (double)sg_v3_length(nn),
                     (double)st->radius[i]);
    }
    sg_scene_destroy(sc);

    /* (b) The square [-1, 1]^2 as 2 triangles with lattices of spacing
     * 2 / 16 reads light as the same square as 16 x 16 gridded cells does
     * (world.c's ground): its sites are the grid's vertices (twice on the
     * diagonal), a hit's small triangle is the grid's, the field
     * interpolated from either equal but for the lattice sites' inward
     * shift; 2 x 153 sites. */
    sg_mesh grid, two;
    assert_int_equal(sg_mesh_make_plane(16, 1.0f, &grid, NULL), SG_OK);
    assert_int_equal(sg_mesh_make_plane(1, 1.0f, &two, NULL), SG_OK);
    sg_scene *sg = lattice_scene(&grid, 0.0f), *sl = lattice_scene(&two, 2.0f / 16.0f);
    hi = lattice_info(&two, 2.0f / 16.0f);
    assert_int_equal(hi.lattice_triangles, 2);
    assert_int_equal(hi.lattice_sites, 2 * 17 * 18 / 2);
    float worst = 0.0f;
    for (int k = 0; k < 20000; ++k) {
        sg_vec3 target = sg_v3(1.98f * sg_test_rand01(&rng) - 0.99f, 0.0f, 1.98f * sg_test_rand01(&rng) - 0.99f);
        sg_ray r = ray_to(sg_v3_add(target, sg_v3(0.7f * sg_test_rand01(&rng) - 0.35f, 2.0f, 0.2f)), target);
        sg_hit hg, hl;
        assert_true(sg_scene_intersect(sg, &r, &hg, NULL) && sg_scene_intersect(sl, &r, &hl, NULL));
        uint32_t ig[3], il[3];
        sg_vec3 bg, bl;
        float sg_w, sl_w;
        float fg = interpolate(sg, &hg, &bg, &sg_w, ig), fl = interpolate(sl, &hl, &bl, &sl_w, il);
        worst = fmaxf(worst, fabsf(fg - fl));
        /* the lattice's sites sit 3e-3 of a cell (hypotenuse 0.177) inside
         * their triangles: |grad field| <= 3.6 moves the field by at most
         * 1.9e-3 there; a wrong small triangle moves it by a good part of
         * a cell's 0.45 */
        if (!(fabsf(fg - fl) < 2e-3f))
            fail_msg("at (%g, %g): the grid gives %.7g, the lattice %.7g", (double)target.x, (double)target.z,
                     (double)fg, (double)fl);
    }
    printf("lattice against grid: largest difference %.3g over 20000 hits\n", (double)worst);
    /* (c) Filtered into the nodes: f = x + 2 over the lattice averages to
     * the centroid's 2 at the root (lattice_mean's counts of small
     * triangles per site). */
    st = sg_scene_sites(sl);
    float *u = sg_alloc_array(st->count, sizeof(float));
    assert_non_null(u);
    for (size_t i = 0; i < st->count; ++i)
        u[i] = i < hi.vertex_count ? st->px[i] + 2.0f : -50.0f;
    sg_scene_filter_sites(sl, u, 1);
    assert_float_equal(u[hi.vertex_count], 2.0f, 1e-6f);
    sg_free(u);
    sg_scene_destroy(sg);
    sg_scene_destroy(sl);

    /* (d) Bad spacings name the cause; 1 and 2 threads give one layout. */
    sg_error err = {0};
    sg_hybrid *h = NULL;
    const float bad[] = {NAN, -1.0f, INFINITY};
    for (int k = 0; k < 3; ++k) {
        sg_hybrid_desc d = {.site_spacing = bad[k], .name = "plane"};
        assert_int_equal(sg_hybrid_create(&d, &two, &h, &err), SG_ERR_INVALID_ARG);
        assert_non_null(strstr(err.message, "plane: site spacing"));
    }
    /* the scene refuses a non-finite spacing before it allocates (a NaN
     * once returned with the scene leaked: valgrind's case here) */
    sg_scene *none = NULL;
    sg_scene_desc sdn = {.model = SG_SURFACE_HYBRID, .hybrid_site_spacing = NAN};
    assert_int_equal(sg_scene_create_mesh(&sdn, &two, "plane", &none, &err), SG_ERR_INVALID_ARG);
    assert_null(none);
    assert_non_null(strstr(err.message, "plane: hybrid site spacing"));
    sg_hybrid_desc tiny = {.site_spacing = 1e-4f, .name = "plane"};
    assert_int_equal(sg_hybrid_create(&tiny, &two, &h, &err), SG_ERR_INVALID_ARG);
    assert_non_null(strstr(err.message, "lattice rows, more than 8192"));
    sg_hybrid_desc d1 = {.site_spacing = 0.01f, .threads = 1}, d2 = {.site_spacing = 0.01f, .threads = 2};
    sg_hybrid *h1 = NULL, *h2 = NULL;
    assert_int_equal(sg_hybrid_create(&d1, &two, &h1, &err), SG_OK);
    assert_int_equal(sg_hybrid_create(&d2, &two, &h2, &err), SG_OK);
    assert_true(sg_hybrid_layout_hash(h1) == sg_hybrid_layout_hash(h2));
    sg_hybrid_destroy(h1);
    sg_hybrid_destroy(h2);
    sg_mesh_free(&grid);
    sg_mesh_free(&two);
}

/* ---- 19: the builtin room on lattices ---------------------------------------- */

/* The vertex count of the world's first scene (a hybrid scene's
 * splat_count: its mesh's vertices and lattice sites, scene.h). */
static size_t world_sites(const char *json)
{
    sg_world *w = sg_test_world_from_json(json);
    sg_scene_info si;
    sg_scene_get_info(sg_world_scene(w, 0), &si);
    sg_world_destroy(w);
    return si.splat_count;
}

static void test_hybrid_builtin_room_lattice(void **state)
{
    (void)state;
    const char *lattice = "{\"models\":[{\"builtin\":\"room\",\"points\":20000,\"surface\":{\"model\":\"hybrid\"}}]}";
    const char *gridded = "{\"models\":[{\"builtin\":\"room\",\"points\":20000,"
                          "\"surface\":{\"model\":\"hybrid\",\"hybrid_site_spacing\":0}}]}";
    /* world.c: cells of sqrt(162 m^2 / points) */
    const float cell = (float)fmax(0.005, sqrt(162.0 / 20000.0));
    sg_mesh two, grid;
    sg_room_desc rd = {.cell = cell};
    assert_int_equal(sg_room_mesh(NULL, &two, NULL), SG_OK);
    assert_int_equal(sg_room_mesh(&rd, &grid, NULL), SG_OK);
    const sg_hybrid_info hl = lattice_info(&two, cell), hg = lattice_info(&grid, 0.0f);
    assert_true(hl.triangle_count == two.triangle_count && hl.lattice_triangles > 0);
    assert_true(hg.lattice_triangles == 0 && hg.triangle_count > 10 * hl.triangle_count);
    const size_t nl = world_sites(lattice), ng = world_sites(gridded);
    if (nl != hl.vertex_count || ng != hg.vertex_count)
        fail_msg("room vertices: default %zu (want the lattice room's %zu), spacing 0 %zu (want the grid's %zu)", nl,
                 hl.vertex_count, ng, hg.vertex_count);
    /* the bakes of the two are not interchangeable */
    sg_scene_file a, b;
    sg_error err = {0};
    assert_int_equal(sg_scene_file_parse(lattice, strlen(lattice), "a.json", NULL, &a, &err), SG_OK);
    assert_int_equal(sg_scene_file_parse(gridded, strlen(gridded), "b.json", NULL, &b, &err), SG_OK);
    assert_true(sg_scene_file_hash(&a, SG_SCENE_HASH_ALL) != sg_scene_file_hash(&b, SG_SCENE_HASH_ALL));
    sg_scene_file_free(&a);
    sg_scene_file_free(&b);
    sg_mesh_free(&two);
    sg_mesh_free(&grid);
}

/* Invariant 5 of hybrid_int.h: the vertices are numbered by first use in
 * leaf order, unused ones last, whatever order the mesh gave them in. The
 * sphere with its vertices shuffled (and one unused vertex put among them)
 * gives, slot for slot, the same triangles' vertex ids, positions, normals
 * and colours as the sphere in its own order; walking the triangles in
 * leaf order meets the ids 0, 1, 2, ... each first, and the unused vertex
 * keeps its position and colour at the last id. Fails with the mesh's
 * numbering kept (the shuffled ids). */
static void test_hybrid_vertices_in_leaf_order(void **state)
{
    (void)state;
    sg_mesh a = sphere_mesh(24, 48);
    sg_free(a.normals); /* computed from the triangles, in both */
    a.normals = NULL;
    const size_t nv = a.vertex_count + 1, nt = a.triangle_count;
    a.colors = sg_alloc_array(a.vertex_count, 3 * sizeof(float));
    assert_non_null(a.colors);
    for (size_t i = 0; i < 3 * a.vertex_count; ++i)
        a.colors[i] = (float)(i % 97) / 97.0f;
    /* b: a's vertices at shuffled[v], the unused one at its middle */
    uint32_t *at = sg_alloc_array(nv, sizeof *at);
    sg_mesh b = {.vertex_count = nv, .triangle_count = nt};
    b.positions = sg_alloc_array(nv, 3 * sizeof(float));
    b.colors = sg_alloc_array(nv, 3 * sizeof(float));
    b.triangles = sg_alloc_array(nt, 3 * sizeof(uint32_t));
    assert_true(at && b.positions && b.colors && b.triangles);
    for (size_t v = 0; v < nv; ++v)
        at[v] = (uint32_t)v;
    uint64_t rng = 17;
    for (size_t v = nv - 1; v > 0; --v) { /* Fisher-Yates */
        size_t j = (size_t)(sg_test_rand01(&rng) * (float)(v + 1));
        j = j > v ? v : j;
        uint32_t t = at[v];
        at[v] = at[j];
        at[j] = t;
    }
    const float unused[3] = {7.0f, 8.0f, 9.0f}, unused_rgb[3] = {0.25f, 0.5f, 0.75f};
    for (size_t v = 0; v < nv; ++v) {
        const int extra = v == a.vertex_count; /* the unused vertex */
        memcpy(b.positions + 3 * (size_t)at[v], extra ? unused : a.positions + 3 * v, 3 * sizeof(float));
        memcpy(b.colors + 3 * (size_t)at[v], extra ? unused_rgb : a.colors + 3 * v, 3 * sizeof(float));
    }
    for (size_t i = 0; i < 3 * nt; ++i)
        b.triangles[i] = at[a.triangles[i]];
    sg_hybrid *ha = build(&a, 2), *hb = build(&b, 2);
    assert_int_equal(ha->info.triangle_count, hb->info.triangle_count);
    uint32_t next = 0;
    for (size_t i = 0; i < 3 * ha->info.triangle_count; ++i) {
        const uint32_t va = ha->tri[i], vb = hb->tri[i];
        if (vb > next)
            fail_msg("slot %zu corner %zu: vertex %u before vertex %u was used", i / 3, i % 3, vb, next);
        next += vb == next;
        if (va != vb || memcmp(ha->pos + 3 * (size_t)va, hb->pos + 3 * (size_t)vb, 3 * sizeof(float)) ||
            memcmp(ha->vcolor + 3 * (size_t)va, hb->vcolor + 3 * (size_t)vb, 3 * sizeof(float)) ||
            ha->vnormal[va] != hb->vnormal[vb])
            fail_msg("slot %zu corner %zu: vertex %u of the sphere, %u of the shuffled sphere differ", i / 3, i % 3,
                     va, vb);
    }
    assert_int_equal(next, a.vertex_count); /* every vertex of the sphere is used */
    assert_memory_equal(hb->pos + 3 * a.vertex_count, unused, sizeof unused);
    assert_memory_equal(hb->vcolor + 3 * a.vertex_count, unused_rgb, sizeof unused_rgb);
    sg_hybrid_destroy(ha);
    sg_hybrid_destroy(hb);
    sg_free(at);
    sg_mesh_free(&a);
    sg_mesh_free(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hybrid_watertight_plane),
        cmocka_unit_test(test_hybrid_watertight_sphere),
        cmocka_unit_test(test_hybrid_lod_zero_is_full),
        cmocka_unit_test(test_hybrid_lod_error_bound),
        cmocka_unit_test(test_hybrid_threads_identical),
        cmocka_unit_test(test_hybrid_lod_orders_agree),
        cmocka_unit_test(test_hybrid_no_self_hits),
        cmocka_unit_test(test_hybrid_hit_sites),
        cmocka_unit_test(test_hybrid_bad_meshes),
        cmocka_unit_test(test_hybrid_kernels_agree),
        cmocka_unit_test(test_hybrid_scene_interface),
        cmocka_unit_test(test_hybrid_scene_errors),
        cmocka_unit_test(test_hybrid_filter_nodes),
        cmocka_unit_test(test_hybrid_scene_file_roundtrip),
        cmocka_unit_test(test_hybrid_sites_threads_identical),
        cmocka_unit_test(test_hybrid_albedo_is_site_blend),
        cmocka_unit_test(test_hybrid_intersect4_matches_single),
        cmocka_unit_test(test_hybrid_intersect16_matches_single),
        cmocka_unit_test(test_hybrid_lattice_sites),
        cmocka_unit_test(test_hybrid_builtin_room_lattice),
        cmocka_unit_test(test_hybrid_vertices_in_leaf_order),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
