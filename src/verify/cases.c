/* cases.c — the stability cases (cases.h): generated inputs, their scene
 * files and their exact shapes.
 *
 * Invariants:
 *  1. Every input is a pure function of (case, small): the same PLY and
 *     EXR bytes every run, so the reference cache (keyed by file contents)
 *     hits on a second run.
 *  2. The truth is the shape the points were sampled from, in the same
 *     world frame as the scene file's transform puts the points.
 */
#include "verify/cases.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "envmap/analytic.h"
#include "io/mesh.h"
#include "math/rng.h"
#include "points/model_points.h"
#include "points/primitives.h"
#include "points/room.h"
#include "verify/verify_int.h"

enum {
    C_SPHERE_CLEAN, C_BUNNY_CLEAN, C_COARSE_2K, C_RADII_SMALL, C_NOISY_NORMALS, C_MISSING_NORMALS, C_SHARP_CUBE,
    C_THIN_SHEET, C_GRAZING, C_INSIDE, C_SCALE_SMALL, C_SCALE_LARGE, C_DUPLICATES, C_TINY_SUN, C_ROOM, C_THIN_WALL,
    C_FOLDS, C_COUNT
};

static const struct {
    const char *name, *what;
    int baseline;
} case_table[C_COUNT] = {
    {"sphere_clean", "unit sphere, Fibonacci points (control)", -1},
    {"bunny_clean", "bunny mesh sampled, normals from the mesh (control)", -1},
    {"coarse_2k", "bunny mesh sampled to 2,000 points", C_BUNNY_CLEAN},
    {"radii_small", "sphere, splat radii x 0.35", C_SPHERE_CLEAN},
    {"noisy_normals", "sphere, normals + 0.4 N(0,I), renormalised", C_SPHERE_CLEAN},
    {"missing_normals", "bunny points without normals (PCA + MST)", C_BUNNY_CLEAN},
    {"sharp_cube", "cube, side 2, face normals", -1},
    {"thin_sheet", "two layers 0.01 apart, normals facing out", -1},
    {"grazing_view", "plane seen 85 deg from its normal", -1},
    {"camera_inside", "sphere seen from its centre", -1},
    {"scale_1e-3", "sphere scaled by 1e-3, camera too", C_SPHERE_CLEAN},
    {"scale_1e4", "sphere scaled by 1e4, camera too", C_SPHERE_CLEAN},
    {"duplicates", "sphere, every point three times", C_SPHERE_CLEAN},
    {"tiny_sun", "sphere on a plane, sun 0.1 deg, 2.5e6", -1},
    {"room", "closed room, one window, sun and sky, camera inside", -1},
    {"thin_wall", "the room with walls 0.04 thick (~r/2) but the window's, same view", C_ROOM},
    {"folds", "close-up of Lucy's folds (a concave scan)", -1},
};

int sg_verify_case_count(void) { return C_COUNT; }

const char *sg_verify_case_name(int index)
{
    return index >= 0 && index < C_COUNT ? case_table[index].name : NULL;
}

int sg_verify_case_baseline(int index)
{
    return index >= 0 && index < C_COUNT ? case_table[index].baseline : -1;
}

int sg_verify_case_find(const char *name)
{
    for (int i = 0; i < C_COUNT; i++)
        if (strcmp(case_table[i].name, name) == 0)
            return i;
    return -1;
}

sg_status sg_verify_write_ply(const char *path, size_t count, const float *positions, const float *normals,
                              sg_error *err)
{
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.tmp%ld", path, (long)getpid());
    FILE *f = fopen(tmp, "wb");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot create: %s", tmp, strerror(errno));
    int ok = fprintf(f,
                     "ply\nformat binary_little_endian 1.0\ncomment splatgi-verify stability case\n"
                     "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n%s"
                     "end_header\n",
                     count, normals ? "property float nx\nproperty float ny\nproperty float nz\n" : "") > 0;
    for (size_t i = 0; i < count && ok; i++) {
        ok = fwrite(positions + 3 * i, sizeof(float), 3, f) == 3;
        if (ok && normals)
            ok = fwrite(normals + 3 * i, sizeof(float), 3, f) == 3;
    }
    ok = (fclose(f) == 0) && ok;
    if (!ok || rename(tmp, path) != 0) {
        remove(tmp);
        return sg_error_set(err, SG_ERR_IO, "%s: cannot write", path);
    }
    return SG_OK;
}

/* Interleaved points under construction. */
typedef struct cloud {
    size_t n, cap;
    float *p, *nrm;
} cloud;

static int cloud_push(cloud *c, sg_vec3 p, sg_vec3 n)
{
    if (c->n == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 4096;
        float *np = realloc(c->p, cap * 3 * sizeof(float));
        if (!np)
            return 0;
        c->p = np;
        float *nn = realloc(c->nrm, cap * 3 * sizeof(float));
        if (!nn)
            return 0;
        c->nrm = nn;
        c->cap = cap;
    }
    float *p3 = c->p + 3 * c->n, *n3 = c->nrm + 3 * c->n;
    p3[0] = p.x, p3[1] = p.y, p3[2] = p.z;
    n3[0] = n.x, n3[1] = n.y, n3[2] = n.z;
    c->n++;
    return 1;
}

static void cloud_free(cloud *c)
{
    free(c->p);
    free(c->nrm);
    memset(c, 0, sizeof *c);
}

static sg_status push_pointset(cloud *c, const sg_pointset *ps, sg_error *err)
{
    for (size_t i = 0; i < ps->count; i++)
        if (!cloud_push(c, sg_pointset_position(ps, i), sg_pointset_normal(ps, i)))
            return sg_error_set(err, SG_ERR_NOMEM, "case points: out of memory");
    return SG_OK;
}

static sg_status sphere_cloud(cloud *c, size_t count, sg_vec3 centre, sg_error *err)
{
    sg_sphere_points_desc d = {.count = count, .centre = centre, .radius = 1.0f};
    sg_pointset ps = {0};
    sg_status st = sg_points_make_sphere(&d, &ps, err);
    if (st == SG_OK)
        st = push_pointset(c, &ps, err);
    sg_pointset_free(&ps);
    return st;
}

static sg_status plane_cloud(cloud *c, int side, float half, float y, int flip, sg_error *err)
{
    sg_plane_points_desc d = {.side = side, .half = half, .centre = sg_v3(0, y, 0), .seed = 7};
    sg_pointset ps = {0};
    sg_status st = sg_points_make_plane(&d, &ps, err);
    if (st == SG_OK && flip)
        for (size_t i = 0; i < ps.count; i++)
            ps.ny[i] = -ps.ny[i];
    if (st == SG_OK)
        st = push_pointset(c, &ps, err);
    sg_pointset_free(&ps);
    return st;
}

/* side^2 jittered samples on each face of the cube [-1, 1]^3. */
static sg_status cube_cloud(cloud *c, int side, sg_error *err)
{
    uint64_t item = 0;
    for (int axis = 0; axis < 3; axis++)
        for (int sgn = -1; sgn <= 1; sgn += 2)
            for (int i = 0; i < side; i++)
                for (int j = 0; j < side; j++, item++) {
                    float u = -1.0f + 2.0f * ((float)i + sg_rng_float(3, item, 0, 0)) / (float)side;
                    float v = -1.0f + 2.0f * ((float)j + sg_rng_float(3, item, 0, 1)) / (float)side;
                    float p[3], n[3] = {0, 0, 0};
                    p[axis] = (float)sgn;
                    p[(axis + 1) % 3] = u;
                    p[(axis + 2) % 3] = v;
                    n[axis] = (float)sgn;
                    if (!cloud_push(c, sg_v3(p[0], p[1], p[2]), sg_v3(n[0], n[1], n[2])))
                        return sg_error_set(err, SG_ERR_NOMEM, "cube points: out of memory");
                }
    return SG_OK;
}

/* Samples mesh m to count points like any model (model_points.h) into c;
 * m is handed to *mesh_out on success (the truth) and freed otherwise. */
static sg_status push_mesh_samples(cloud *c, sg_mesh *m, const char *name, size_t count, uint64_t seed,
                                   sg_mesh *mesh_out, sg_error *err)
{
    sg_model_points_desc d = {.points = count, .seed = seed};
    sg_pointset ps = {0};
    sg_status st = sg_model_points_from_mesh(m, name, &d, &ps, err);
    if (st == SG_OK)
        st = push_pointset(c, &ps, err);
    sg_pointset_free(&ps);
    if (st == SG_OK)
        *mesh_out = *m;
    else
        sg_mesh_free(m);
    return st;
}

static sg_status bunny_cloud(cloud *c, size_t count, sg_mesh *mesh_out, sg_error *err)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/bunny.ply", SG_ASSET_DIR);
    sg_mesh m = {0};
    sg_status st = sg_mesh_read(path, &m, err);
    if (st != SG_OK)
        return st;
    return push_mesh_samples(c, &m, path, count, 11, mesh_out, err);
}

static double mesh_area(const sg_mesh *m)
{
    double a = 0.0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        const float *p0 = m->positions + 3 * m->triangles[3 * t], *p1 = m->positions + 3 * m->triangles[3 * t + 1],
                    *p2 = m->positions + 3 * m->triangles[3 * t + 2];
        sg_vec3 e1 = sg_v3(p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]);
        sg_vec3 e2 = sg_v3(p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]);
        a += 0.5 * sg_v3_length(sg_v3_cross(e1, e2));
    }
    return a;
}

/* The built-in room (points/room.h) with walls `wall` thick, sampled to
 * count points like a mesh; the mesh is the truth. */
static sg_status room_cloud(cloud *c, size_t count, float wall, sg_mesh *mesh_out, sg_error *err)
{
    /* The window wall keeps the room's thickness: the same opening lets the
     * same light in, so the thin room's light differs only by leaks. And
     * the same density of points as the room's (count is the thick room's):
     * MLS rounds the window's edges by a fraction of a radius, and a few
     * percent of the window's area is as much light. */
    sg_room_desc rd = {.wall = wall, .window_wall = SG_ROOM_WALL}, thick = {0};
    sg_mesh m = {0}, t = {0};
    sg_status st = sg_room_mesh(&rd, &m, err);
    if (st == SG_OK)
        st = sg_room_mesh(&thick, &t, err);
    if (st != SG_OK) {
        sg_mesh_free(&m);
        return st;
    }
    count = (size_t)llround((double)count * mesh_area(&m) / mesh_area(&t));
    sg_mesh_free(&t);
    return push_mesh_samples(c, &m, "room", count, 13, mesh_out, err);
}

/* A closed concave scan with deep folds: Lucy (../shared/data), or the
 * bunny where that folder is absent (the case then says so in `what`),
 * sampled like any mesh and placed 2 units tall on y = 0 (points and the
 * truth alike). */
static sg_status folds_cloud(cloud *c, size_t count, sg_mesh *mesh_out, sg_vec3 *translate, float *scale,
                             int *is_lucy, sg_error *err)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/meshes/lucy/Lucy100k.ply", SG_SHARED_DATA_DIR);
    *is_lucy = access(path, R_OK) == 0;
    if (!*is_lucy)
        snprintf(path, sizeof path, "%s/bunny.ply", SG_ASSET_DIR);
    sg_mesh m = {0};
    sg_status st = sg_mesh_read(path, &m, err);
    if (st != SG_OK)
        return st;
    sg_ground_placement pl;
    st = sg_mesh_ground_placement(sg_mesh_bounds(&m), 2.0f, &pl, err);
    sg_model_points_desc d = {.points = count, .seed = 17};
    sg_pointset ps = {0};
    if (st == SG_OK)
        st = sg_model_points_from_mesh(&m, path, &d, &ps, err);
    for (size_t i = 0; st == SG_OK && i < ps.count; i++) {
        sg_vec3 p = sg_v3_add(pl.translate, sg_v3_scale(sg_pointset_position(&ps, i), pl.scale));
        if (!cloud_push(c, p, sg_pointset_normal(&ps, i)))
            st = sg_error_set(err, SG_ERR_NOMEM, "folds: out of memory");
    }
    sg_pointset_free(&ps);
    if (st == SG_OK) {
        *mesh_out = m;
        *translate = pl.translate;
        *scale = pl.scale;
    } else
        sg_mesh_free(&m);
    return st;
}

static float gauss(uint64_t item, uint32_t dim)
{
    float u1 = sg_rng_float(5, item, 0, 2 * dim), u2 = sg_rng_float(5, item, 0, 2 * dim + 1);
    return sqrtf(-2.0f * logf(1.0f - u1)) * cosf(6.28318531f * u2);
}

typedef struct json_buf {
    char *s;
    size_t len, cap;
    int overflow;
} json_buf;

static void jprintf(json_buf *b, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

#include <stdarg.h>
static void jprintf(json_buf *b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(b->s + b->len, b->cap - b->len, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= b->cap - b->len)
        b->overflow = 1;
    else
        b->len += (size_t)n;
}

static void model_json(json_buf *b, int first, const char *ply, float radius_scale, float scale,
                       sg_surface_model model)
{
    jprintf(b,
            "%s{\"path\": \"%s\", \"radius_scale\": %g, \"transform\": {\"scale\": %.9g},"
            " \"material\": {\"type\": \"lambert\", \"albedo\": [0.7, 0.7, 0.7], \"use_point_colors\": false},"
            " \"surface\": {\"model\": \"%s\"}}",
            first ? "" : ", ", ply, (double)radius_scale, (double)scale, sg_verify__model_name(model));
}

sg_status sg_verify_case_make(int index, sg_surface_model model, int small, const char *work_dir,
                              sg_verify_case *out, sg_error *err)
{
    if (index < 0 || index >= C_COUNT)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "no stability case %d", index);
    if (!sg_verify__make_dirs(work_dir))
        return sg_error_set(err, SG_ERR_IO, "%s: cannot create: %s", work_dir, strerror(errno));
    sg_verify_case c = {.name = case_table[index].name, .what = case_table[index].what,
                        .baseline = case_table[index].baseline};
    cloud pts = {0}, ground = {0};
    sg_mesh mesh = {0};
    char ply[4200], ground_ply[4200], env_exr[4200];
    char json_mem[16384];
    json_buf jb = {json_mem, 0, sizeof json_mem, 0};
    size_t n_sphere = small ? 3000 : 20000, n_bunny = small ? 3000 : 20000;
    float radius_scale = 1.0f, scale = 1.0f;
    int with_normals = 1, dup = 1;
    const char *env = "{\"builtin\": \"sky\"}";
    char env_path_json[4400];
    sg_vec3 view = sg_v3(0.6f, -0.35f, -1.0f);
    float fov = 40.0f;
    sg_status st = SG_OK;
    snprintf(ply, sizeof ply, "%s/%s%s.ply", work_dir, c.name, small ? "_ci" : "");

    switch (index) {
    case C_SPHERE_CLEAN: case C_RADII_SMALL: case C_NOISY_NORMALS: case C_INSIDE:
    case C_SCALE_SMALL: case C_SCALE_LARGE: case C_DUPLICATES:
        st = sphere_cloud(&pts, n_sphere, sg_v3(0, 0, 0), err);
        if (st == SG_OK)
            st = sg_truth_add_sphere(&c.truth, sg_v3(0, 0, 0), 1.0f, err);
        if (index == C_RADII_SMALL)
            radius_scale = 0.35f;
        if (index == C_NOISY_NORMALS)
            for (size_t i = 0; i < pts.n; i++) {
                float *nn = pts.nrm + 3 * i;
                sg_vec3 v = sg_v3_normalize(sg_v3(nn[0] + 0.4f * gauss(i, 0), nn[1] + 0.4f * gauss(i, 1),
                                                  nn[2] + 0.4f * gauss(i, 2)));
                nn[0] = v.x, nn[1] = v.y, nn[2] = v.z;
            }
        if (index == C_SCALE_SMALL)
            scale = 1e-3f;
        if (index == C_SCALE_LARGE)
            scale = 1e4f;
        if (index == C_DUPLICATES)
            dup = 3;
        break;
    case C_BUNNY_CLEAN: case C_COARSE_2K: case C_MISSING_NORMALS:
        st = bunny_cloud(&pts, index == C_COARSE_2K ? 2000 : n_bunny, &mesh, err);
        if (st == SG_OK)
            st = sg_truth_add_mesh(&c.truth, &mesh, sg_v3(0, 0, 0), 1.0f, err);
        with_normals = index != C_MISSING_NORMALS;
        break;
    case C_SHARP_CUBE:
        st = cube_cloud(&pts, small ? 24 : 60, err);
        if (st == SG_OK)
            st = sg_truth_add_box(&c.truth, sg_v3(-1, -1, -1), sg_v3(1, 1, 1), err);
        break;
    case C_THIN_SHEET:
        st = plane_cloud(&pts, small ? 40 : 100, 1.0f, 0.005f, 0, err);
        if (st == SG_OK)
            st = plane_cloud(&pts, small ? 40 : 100, 1.0f, -0.005f, 1, err);
        if (st == SG_OK)
            st = sg_truth_add_box(&c.truth, sg_v3(-1, -0.005f, -1), sg_v3(1, 0.005f, 1), err);
        break;
    case C_GRAZING:
        st = plane_cloud(&pts, small ? 60 : 160, 2.0f, 0.0f, 0, err);
        if (st == SG_OK)
            st = sg_truth_add_rect(&c.truth, 0.0f, -2, 2, -2, 2, err);
        break;
    case C_ROOM: case C_THIN_WALL: {
        /* Walls 0.2 thick (about 2.5 splat radii at 60k points), or 0.04
         * (about r/2) but for the window wall: the thin room is the room
         * with its walls' two sides within each other's support, to be
         * lit exactly as the thick one (reference energy vs clean 1). */
        size_t n = small ? 10000 : 60000;
        st = room_cloud(&pts, n, index == C_ROOM ? SG_ROOM_WALL : 0.04f, &mesh, err);
        if (st == SG_OK)
            st = sg_truth_add_mesh(&c.truth, &mesh, sg_v3(0, 0, 0), 1.0f, err);
        env = "{\"builtin\": \"sunsky\"}";
        break;
    }
    case C_FOLDS: {
        sg_vec3 tr;
        float sc;
        int lucy;
        st = folds_cloud(&pts, small ? 20000 : 100000, &mesh, &tr, &sc, &lucy, err);
        if (st == SG_OK)
            st = sg_truth_add_mesh(&c.truth, &mesh, tr, sc, err);
        if (!lucy)
            c.what = "close-up of the bunny (../shared/data/meshes/lucy absent)";
        break;
    }
    case C_TINY_SUN:
        st = sphere_cloud(&pts, n_sphere, sg_v3(0, 1, 0), err);
        if (st == SG_OK)
            st = plane_cloud(&ground, small ? 30 : 80, 4.0f, 0.0f, 0, err);
        if (st == SG_OK)
            st = sg_truth_add_sphere(&c.truth, sg_v3(0, 1, 0), 1.0f, err);
        if (st == SG_OK)
            st = sg_truth_add_rect(&c.truth, 0.0f, -4, 4, -4, 4, err);
        snprintf(env_exr, sizeof env_exr, "%s/tiny_sun.exr", work_dir);
        if (st == SG_OK && access(env_exr, R_OK) != 0) {
            sg_analytic_desc ad = {.type = SG_ANALYTIC_SUNSKY, .width = 1024, .sun_radius_deg = 0.1f,
                                   .sun_radiance = 2.5e6f};
            sg_image img = {0};
            st = sg_analytic_make(&ad, &img, err);
            if (st == SG_OK)
                st = sg_image_write_exr(&img, env_exr, err);
            sg_image_free(&img);
        }
        snprintf(env_path_json, sizeof env_path_json, "{\"path\": \"%s\"}", env_exr);
        env = env_path_json;
        break;
    }
    if (st != SG_OK)
        goto fail;

    /* Duplicates: every point written dup times in a row. */
    if (dup > 1) {
        cloud d = {0};
        for (size_t i = 0; i < pts.n; i++)
            for (int k = 0; k < dup; k++)
                if (!cloud_push(&d, sg_v3(pts.p[3 * i], pts.p[3 * i + 1], pts.p[3 * i + 2]),
                                sg_v3(pts.nrm[3 * i], pts.nrm[3 * i + 1], pts.nrm[3 * i + 2]))) {
                    cloud_free(&d);
                    st = sg_error_set(err, SG_ERR_NOMEM, "duplicates: out of memory");
                    goto fail;
                }
        cloud_free(&pts);
        pts = d;
    }
    st = sg_verify_write_ply(ply, pts.n, pts.p, with_normals ? pts.nrm : NULL, err);
    if (st != SG_OK)
        goto fail;
    if (ground.n) {
        snprintf(ground_ply, sizeof ground_ply, "%s/%s_ground%s.ply", work_dir, c.name, small ? "_ci" : "");
        st = sg_verify_write_ply(ground_ply, ground.n, ground.p, ground.nrm, err);
        if (st != SG_OK)
            goto fail;
    }

    /* The view: framed on the truth's points (unit scale), then scaled. */
    sg_aabb box = sg_aabb_empty();
    for (size_t i = 0; i < pts.n; i++)
        box = sg_aabb_grow(box, sg_v3(pts.p[3 * i], pts.p[3 * i + 1], pts.p[3 * i + 2]));
    sg_vec3 up = sg_v3(0, 1, 0);
    if (index == C_THIN_SHEET)
        view = sg_v3(0.5f, -0.8f, -0.6f);
    if (index == C_SHARP_CUBE)
        view = sg_v3(-0.7f, -0.55f, -1.0f);
    if (index == C_TINY_SUN)
        view = sg_v3(0.5f, -0.45f, -1.0f);
    if (index == C_INSIDE) {
        st = sg_camera_look_at(sg_v3(0, 0, 0), sg_v3(1.0f, -0.2f, 0.3f), up, 80.0f, 1.0f, &c.camera, err);
        fov = 80.0f;
    } else if (index == C_ROOM || index == C_THIN_WALL) {
        /* from a back corner towards the window wall and the floor the sun lights */
        st = sg_camera_look_at(sg_v3(-1.6f, 1.5f, 1.5f), sg_v3(1.0f, 0.8f, -0.4f), up, 70.0f, 1.0f, &c.camera, err);
        fov = 70.0f;
    } else if (index == C_FOLDS) {
        /* the middle of the figure (drapery) from the front (-z), close */
        sg_aabb f = box;
        float h = f.hi.y - f.lo.y, cx = 0.5f * (f.lo.x + f.hi.x);
        f.lo.y = f.lo.y + 0.35f * h, f.hi.y = f.lo.y + 0.22f * h;
        f.lo.x = cx - 0.11f * h, f.hi.x = cx + 0.11f * h;
        st = sg_camera_frame(f, sg_v3(0, -0.15f, 1.0f), up, fov, 1.0f, 0.9f, &c.camera, err);
    } else if (index == C_GRAZING) {
        /* 85 deg from the normal: elevation 5 deg, 3 units away. */
        float el = 5.0f * 3.14159265f / 180.0f;
        st = sg_camera_look_at(sg_v3(0, 3.0f * sinf(el), 3.0f * cosf(el)), sg_v3(0, 0, 0), up, 40.0f, 1.0f,
                               &c.camera, err);
    } else
        st = sg_camera_frame(box, view, up, fov, 1.0f, 1.05f, &c.camera, err);
    if (st != SG_OK)
        goto fail;
    if (scale != 1.0f) {
        c.camera.eye = sg_v3_scale(c.camera.eye, scale);
        c.truth.parts[0].r *= scale;
    }
    sg_vec3 look = sg_v3_add(c.camera.eye, sg_v3_scale(c.camera.forward, scale));

    jprintf(&jb, "{\"models\": [");
    model_json(&jb, 1, ply, radius_scale, scale, model);
    if (ground.n)
        model_json(&jb, 0, ground_ply, 1.0f, 1.0f, model);
    jprintf(&jb,
            "], \"envmap\": %s, \"cameras\": [{\"name\": \"main\", \"eye\": [%.9g, %.9g, %.9g],"
            " \"look\": [%.9g, %.9g, %.9g], \"up\": [0, 1, 0], \"fov_deg\": %g}], \"render\": {\"max_depth\": 64}}",
            env, (double)c.camera.eye.x, (double)c.camera.eye.y, (double)c.camera.eye.z, (double)look.x,
            (double)look.y, (double)look.z, (double)fov);
    if (jb.overflow) {
        st = sg_error_set(err, SG_ERR_INVALID_ARG, "%s: scene JSON too long (work folder path?)", c.name);
        goto fail;
    }
    st = sg_scene_file_parse(jb.s, jb.len, c.name, NULL, &c.scene, err);
    if (st != SG_OK)
        goto fail;
    cloud_free(&pts);
    cloud_free(&ground);
    sg_mesh_free(&mesh);
    *out = c;
    return SG_OK;
fail:
    cloud_free(&pts);
    cloud_free(&ground);
    sg_mesh_free(&mesh);
    sg_truth_free(&c.truth);
    return st;
}

void sg_verify_case_free(sg_verify_case *c)
{
    if (!c)
        return;
    sg_scene_file_free(&c->scene);
    sg_truth_free(&c->truth);
    memset(c, 0, sizeof *c);
}
