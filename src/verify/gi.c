/* gi.c — global illumination where it matters (verify.h: GI): concave scans
 * seen close up, so that folds, creases and their inter-reflections fill
 * the frame; the white furnace on the same scans; both indirect estimators
 * side by side, over a ladder of settings, as error against CPU time.
 *
 * Scenes ("close-ups"): a scan sampled to CLOSEUP_POINTS points, its longest
 * side SCENE_LENGTH units, standing on the built-in ground (albedo 0.5),
 * Lambert albedo 0.7, under a real HDR map, seen by a fixed close camera
 * (world units of that placement). And the interior: the built-in room
 * (CLOSEUP_POINTS points, window in the +X wall) with the bunny inside
 * (a quarter of that), albedo 0.7, lit only through the window by the
 * built-in sun and sky, seen from inside; its "model" is every covered
 * pixel. The whole ladder runs on lucy_torso and the room, its core rungs
 * on the others. With ci: the asset bunny under the sky.
 *
 * Per close-up:
 *  - the world's build, timed as process CPU seconds (both threads);
 *  - the converged reference at pixel centres (refcache.h), image x image
 *    at spp paths, and the relMSE it owes to its own noise;
 *  - every bake of the ladder (below): its CPU seconds, one frame x frame
 *    lookup frame's CPU seconds, and its image x image frame against the
 *    reference: relMSE over the frame and over the model's pixels (those
 *    whose centre ray hits model 0), the model's energy ratio, p99, and the
 *    share of the model's pixels within 3 of the reference's own standard
 *    errors of it (luminance);
 *  - the budget: the reference's paths per CPU second (a small render,
 *    timed), hence the CPU seconds of one frame x frame reference frame as
 *    accurate as the default bake (its noise relMSE falls as 1/spp), over
 *    the default bake's + one lookup frame's CPU seconds;
 *  - the white furnace: the scan alone (no ground; the room with its
 *    bunny), albedo 1, uniform sky L = 1; every covered pixel of the
 *    lookup frame should be 1: mean, smallest, largest, share beyond 3%;
 *  - the other surface models (other_surfaces: ISO, hybrid): the same
 *    world with every model on that surface, its own converged reference
 *    (cached under its own scene key), the default rung (and on sweep
 *    close-ups the rungs marked `surfaces`) against that reference and
 *    against the MLS world's, and the default bake's furnace on that
 *    surface. Against its own reference a bake shows the error of its
 *    light alone; against the MLS one, that plus the surface's geometric
 *    difference from the MLS surface (crevices bridged, a mesh's facets).
 * Output: gi.csv (column `surface`: mls, iso, hybrid; `reference`: own or
 * mls), furnace.csv (`surface`), gi.md in out_dir; difference images in
 * diff_dir; scripts/verify-charts.sh draws verify_gi.png from gi.csv's
 * MLS rows.
 *
 * Invariants:
 *  1. every bake of a close-up's world is compared with that world's
 *     reference (and a non-MLS world's also with the MLS world's);
 *  2. CPU times are process CPU time (clock_gettime), so another process's
 *     load does not inflate them (it can still slow memory);
 *  3. a row is written for every bake asked for; a failed call stops the
 *     part with its message.
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bake/bake.h"
#include "io/mesh.h"
#include "io/scene_file.h"
#include "metrics/image_metrics.h"
#include "ref/pathtrace.h"
#include "render/camera.h"
#include "render/world.h"
#include "verify/refcache.h"
#include "verify/verify_int.h"

#define SCENE_LENGTH 10.0f
#define CLOSEUP_POINTS 250000
#define MODEL_ALBEDO 0.7
#define GROUND_ALBEDO 0.5

typedef struct closeup {
    const char *name;
    const char *mesh;        /* under data_dir; NULL: the built-in bunny  */
    const char *env;         /* under data_dir; NULL: the built-in sky    */
    float eye[3], look[3], fov;
    int room;                /* the built-in room with the bunny inside,
                                under the built-in sun and sky (mesh and
                                env unused); its model is every covered
                                pixel, and paths run to ROOM_DEPTH        */
    int sweep;               /* the whole ladder; 0: its core rungs only  */
} closeup;

/* Path depth of the references: 8 bounces on a scan under the open sky
 * (the 9th carries well below 0.1% there); in the closed room, where a
 * path leaves only through the window, light of albedo 0.7 loses 0.7^n
 * after n bounces: 64 leaves 1e-10 (the bake's transport solve sums every
 * bounce). */
#define OPEN_DEPTH 8
#define ROOM_DEPTH 64

static const char COURTYARD[] = "envmaps/blender_studiolights/courtyard.exr";
static const char VENICE[] = "envmaps/threejs_equirect/venice_sunset_1k.hdr";

static const closeup closeups[] = {
    {"lucy_torso", "meshes/lucy/Lucy100k.ply", COURTYARD, {1.5f, 6.5f, -5.5f}, {0.0f, 6.2f, 0.0f}, 35.0f, 0, 1},
    {"room", NULL, NULL, {-1.75f, 1.55f, 1.6f}, {0.6f, 0.7f, -0.6f}, 65.0f, 1, 1},
    {"lucy_sunset", "meshes/lucy/Lucy100k.ply", VENICE, {1.5f, 6.5f, -5.5f}, {0.0f, 6.2f, 0.0f}, 35.0f, 0, 0},
    {"dragon_head", "meshes/stanford_dragon/dragon_vrip.ply", COURTYARD, {1.5f, 6.5f, 7.5f}, {-2.8f, 4.2f, 0.0f},
     32.0f, 0, 0},
    {"armadillo_chest", "meshes/armadillo/armadillo_50k.obj", COURTYARD, {1.5f, 6.8f, -6.5f}, {0.0f, 6.2f, 0.0f},
     38.0f, 0, 0},
};
static const closeup ci_closeup = {"bunny_ci", NULL, NULL, {4.0f, 6.0f, 9.0f}, {0.5f, 4.5f, 0.0f}, 40.0f, 0, 1};

static int closeup_depth(const closeup *cu) { return cu->room ? ROOM_DEPTH : OPEN_DEPTH; }

/* The ladder of bakes: a point of the error-against-time chart each. */
typedef struct rung {
    const char *label;
    sg_bake_indirect indirect;
    float spacing;           /* sg_bake_desc.sample_spacing (0: default)  */
    int env_rays, cos_rays;  /* direct_samples, gather_rays               */
    size_t photons;          /* photon estimator                           */
    unsigned k;              /* photon estimator's gather; 0: 64          */
    int is_default;          /* the library's defaults: the budget's bake */
    int chart;               /* on the error-against-time curve (the rest
                                are the gather-ray and k sweeps)          */
    int core;                /* run on every close-up (the others only on
                                those with sweep)                         */
    int surfaces;            /* also on the other surface models' worlds of
                                the sweep close-ups (the default rung runs
                                on every close-up's)                       */
} rung;

static const rung ladder[] = {
    /* the transport estimator from coarse to fine: the curve */
    {"s8 16+32", SG_BAKE_INDIRECT_TRANSPORT, 8.0f, 16, 32, 0, 0, 0, 1, 0, 0},
    {"s4 16+32", SG_BAKE_INDIRECT_TRANSPORT, 4.0f, 16, 32, 0, 0, 0, 1, 1, 0},
    {"default", SG_BAKE_INDIRECT_TRANSPORT, 0.0f, 0, 0, 0, 0, 1, 1, 1, 0},
    {"s2 32+64", SG_BAKE_INDIRECT_TRANSPORT, 2.0f, 32, 64, 0, 0, 0, 1, 0, 0},
    {"s2 64+128", SG_BAKE_INDIRECT_TRANSPORT, 2.0f, 64, 128, 0, 0, 0, 1, 1, 1},
    {"s1 64+128", SG_BAKE_INDIRECT_TRANSPORT, 1.0f, 64, 128, 0, 0, 0, 1, 0, 0},
    {"s1 128+256", SG_BAKE_INDIRECT_TRANSPORT, 1.0f, 128, 256, 0, 0, 0, 1, 0, 0},
    /* gather rays alone, at the default spacing and envmap rays */
    {"32+16", SG_BAKE_INDIRECT_TRANSPORT, 0.0f, 32, 16, 0, 0, 0, 0, 0, 0},
    {"32+32", SG_BAKE_INDIRECT_TRANSPORT, 0.0f, 32, 32, 0, 0, 0, 0, 0, 0},
    {"32+128", SG_BAKE_INDIRECT_TRANSPORT, 0.0f, 32, 128, 0, 0, 0, 0, 0, 0},
    {"32+256", SG_BAKE_INDIRECT_TRANSPORT, 0.0f, 32, 256, 0, 0, 0, 0, 0, 0},
    /* the photon estimator: photons (its curve), then k */
    {"1M photons", SG_BAKE_INDIRECT_PHOTONS, 0.0f, 0, 0, 1000000, 0, 0, 1, 1, 0},
    {"4M photons", SG_BAKE_INDIRECT_PHOTONS, 0.0f, 0, 0, 4000000, 0, 0, 1, 1, 0},
    {"16M photons", SG_BAKE_INDIRECT_PHOTONS, 0.0f, 0, 0, 16000000, 0, 0, 1, 0, 0},
    {"1M k16", SG_BAKE_INDIRECT_PHOTONS, 0.0f, 0, 0, 1000000, 16, 0, 0, 0, 0},
    {"1M k256", SG_BAKE_INDIRECT_PHOTONS, 0.0f, 0, 0, 1000000, 256, 0, 0, 0, 0},
};
static const rung ci_ladder[] = {
    {"default", SG_BAKE_INDIRECT_TRANSPORT, 0.0f, 8, 16, 0, 0, 1, 1, 1, 0},
    {"photons", SG_BAKE_INDIRECT_PHOTONS, 0.0f, 0, 0, 20000, 0, 0, 1, 1, 0},
};

/* The surface models measured beside the default MLS (whose world runs the
 * ladder and is the other rows' second reference), by scene-file name
 * ("surface": {"model": ...}), each with its camera rays' level-of-detail
 * member set to 0: the bake frames then trace the exact surface, as the
 * reference does (refcache.h, version 5), so a row measures the surface
 * and its light, not the viewer's coarse patches (docs/iso.md,
 * docs/hybrid.md). Which models take which (make_world): every model
 * kind is sampled into points, so all take the ISO; the hybrid needs
 * triangles, which the builtins (room, ground, bunny) are made as
 * (render/world.c), and a scan file has only if it is a mesh: a point
 * cloud's close-up is skipped for the hybrid, with the reason logged. */
typedef struct gsurface {
    const char *name;        /* scene-file name, and the CSV's surface    */
    const char *lod;         /* its camera rays' level-of-detail member   */
    int needs_triangles;     /* the hybrid: a file model must be a mesh   */
} gsurface;

static const gsurface mls_surface = {"mls", NULL, 0};
static const gsurface other_surfaces[] = {{"iso", "iso_lod", 0}, {"hybrid", "hybrid_lod", 1}};

typedef struct gplan {
    size_t points;
    int image, frame, spp, budget_side, budget_spp;
} gplan;

static gplan make_plan(const vctx *c)
{
    if (c->d.ci)
        return (gplan){.points = 5000, .image = 24, .frame = 32, .spp = 16, .budget_side = 16, .budget_spp = 2};
    return (gplan){.points = CLOSEUP_POINTS, .image = 128, .frame = 512, .spp = 2048, .budget_side = 64,
                   .budget_spp = 16};
}

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double lum(const float *p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

/* The scene file of a close-up: its scan placed on the ground (ground 0:
 * the scan alone), materials of albedo `albedo`, the map or a uniform
 * sky of radiance 1 (furnace), every model on surface gs. When the scan
 * cannot take gs (a point-cloud file for the hybrid), *w is NULL and
 * *skip says why (SG_OK). */
static sg_status make_world(const vctx *c, const closeup *cu, size_t points, int furnace, const gsurface *gs,
                            sg_scene_file *sf, sg_world **w, double *cpu_s, const char **skip, sg_error *err)
{
    char model[5000], env[5000], json[12000], mesh[4400], surf[128] = "";
    double albedo = furnace ? 1.0 : MODEL_ALBEDO;
    *w = NULL;
    *skip = NULL;
    if (gs->lod) /* the same member on every model, ground and room included */
        snprintf(surf, sizeof surf, ", \"surface\": {\"model\": \"%s\", \"%s\": 0}", gs->name, gs->lod);
    if (cu->room) {
        /* examples/room_sunsky.json's room and bunny, in grey */
        snprintf(model, sizeof model,
                 "{\"builtin\": \"room\", \"points\": %zu, \"material\": {\"type\": \"lambert\", \"albedo\": "
                 "[%g, %g, %g], \"use_point_colors\": false}%s}, {\"builtin\": \"bunny\", \"points\": %zu, "
                 "\"transform\": {\"translate\": [0.2, 0, -0.3], \"rotate_deg\": [0, -60, 0], \"scale\": 0.12}, "
                 "\"material\": {\"type\": \"lambert\", \"albedo\": [%g, %g, %g], \"use_point_colors\": false}%s}",
                 points, albedo, albedo, albedo, surf, points / 4, albedo, albedo, albedo, surf);
    } else if (cu->mesh) {
        snprintf(mesh, sizeof mesh, "%s/%s", c->d.data_dir, cu->mesh);
        /* its box places it; only a surface that needs triangles reads
         * the whole file to see whether it has any */
        sg_aabb b;
        sg_ground_placement pl;
        sg_status st = sg_mesh_read_bounds(mesh, &b, err);
        if (st != SG_OK)
            return st;
        if (gs->needs_triangles) {
            sg_mesh m = {0};
            if ((st = sg_mesh_read(mesh, &m, err)) != SG_OK)
                return st;
            size_t triangles = m.triangle_count;
            sg_mesh_free(&m);
            if (triangles == 0) {
                *skip = "the scan is a point cloud (no triangles)";
                return SG_OK;
            }
        }
        if ((st = sg_mesh_ground_placement(b, SCENE_LENGTH, &pl, err)) != SG_OK)
            return st;
        snprintf(model, sizeof model,
                 "{\"path\": \"%s\", \"points\": %zu, \"transform\": {\"translate\": [%.9g, %.9g, %.9g], "
                 "\"scale\": %.9g}, \"material\": {\"type\": \"lambert\", \"albedo\": [%g, %g, %g], "
                 "\"use_point_colors\": false}%s}",
                 mesh, points, (double)pl.translate.x, (double)pl.translate.y, (double)pl.translate.z,
                 (double)pl.scale, albedo, albedo, albedo, surf);
    } else {
        snprintf(model, sizeof model,
                 "{\"builtin\": \"bunny\", \"points\": %zu, \"material\": {\"type\": \"lambert\", \"albedo\": "
                 "[%g, %g, %g], \"use_point_colors\": false}%s}",
                 points, albedo, albedo, albedo, surf);
    }
    if (furnace)
        snprintf(env, sizeof env, "{\"builtin\": \"uniform\", \"radiance\": [1, 1, 1]}");
    else if (cu->room)
        snprintf(env, sizeof env, "{\"builtin\": \"sunsky\"}");
    else if (cu->env)
        snprintf(env, sizeof env, "{\"path\": \"%s/%s\"}", c->d.data_dir, cu->env);
    else
        snprintf(env, sizeof env, "{\"builtin\": \"sky\"}");
    char ground[384] = "";
    if (!furnace && !cu->room)
        snprintf(ground, sizeof ground,
                 ", {\"builtin\": \"ground\", \"material\": {\"type\": \"lambert\", \"albedo\": [%g, %g, %g], "
                 "\"use_point_colors\": false}%s}",
                 GROUND_ALBEDO, GROUND_ALBEDO, GROUND_ALBEDO, surf);
    int n = snprintf(json, sizeof json,
                     "{\"models\": [%s%s], \"envmap\": %s, \"cameras\": [{\"name\": \"main\", \"eye\": [%.9g, %.9g, "
                     "%.9g], \"look\": [%.9g, %.9g, %.9g], \"fov_deg\": %g}], \"render\": {\"max_depth\": %d}}",
                     model, ground, env, (double)cu->eye[0], (double)cu->eye[1], (double)cu->eye[2],
                     (double)cu->look[0], (double)cu->look[1], (double)cu->look[2], (double)cu->fov,
                     furnace ? 1024 : closeup_depth(cu));
    if (n < 0 || (size_t)n >= sizeof json)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: scene JSON too long (paths?)", cu->name);
    sg_status st = sg_scene_file_parse(json, (size_t)n, cu->name, NULL, sf, err);
    if (st != SG_OK)
        return st;
    double t0 = cpu_now();
    st = sg_world_create(sf, w, err);
    *cpu_s = cpu_now() - t0;
    if (st != SG_OK)
        sg_scene_file_free(sf);
    return st;
}

static sg_camera closeup_camera(const closeup *cu)
{
    sg_camera cam;
    sg_camera_look_at(sg_v3(cu->eye[0], cu->eye[1], cu->eye[2]), sg_v3(cu->look[0], cu->look[1], cu->look[2]),
                      sg_v3(0, 1, 0), cu->fov, 1.0f, &cam, NULL);
    return cam;
}

/* Per pixel of an n x n frame: 1 where the centre ray hits model 0 (any
 * model with all). */
static sg_status model_mask(const sg_world *w, const sg_camera *cam, int n, int all, unsigned char **out,
                            sg_error *err)
{
    unsigned char *mask = calloc((size_t)n * (size_t)n, 1);
    if (!mask)
        return sg_error_set(err, SG_ERR_NOMEM, "out of memory");
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            sg_ray r = sg_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, n, n);
            sg_world_hit h;
            mask[(size_t)y * (size_t)n + (size_t)x] = sg_world_intersect(w, &r, &h, NULL) && (all || h.model == 0);
        }
    *out = mask;
    return SG_OK;
}

typedef struct bake_figs {
    double bake_cpu, frame_cpu; /* the bake's; one frame x frame lookup frame's */
    double rel_mse, rel_mse_model, energy_model, p99, within3; /* against one
                                   reference (score)                      */
    size_t model_pixels;
} bake_figs;

/* The bake settings of a rung (the rest the library's defaults). */
static sg_bake_desc rung_desc(const rung *r)
{
    return (sg_bake_desc){.indirect = r->indirect, .photons = {.count = r->photons}, .gather = {.k = r->k},
                          .direct_samples = r->env_rays, .gather_rays = r->cos_rays, .sample_spacing = r->spacing};
}

/* Whether rung r runs on the other surface models' worlds of cu (and is a
 * row of gi.md's surfaces table). */
static int surface_rung(const closeup *cu, const rung *r) { return r->is_default || (cu->sweep && r->surfaces); }

/* One bake of the ladder on w: its image x image lookup frame in *img
 * (the caller's: sg_image_free), the CPU seconds of the bake and of one
 * frame x frame lookup frame in f. */
static sg_status bake_frame(const gplan *p, const sg_world *w, const sg_camera *cam, const rung *r, sg_image *img,
                            bake_figs *f, sg_error *err)
{
    sg_bake_desc bd = rung_desc(r);
    sg_bake *b = NULL;
    double t0 = cpu_now();
    sg_status st = sg_bake_create(w, &bd, &b, err);
    if (st != SG_OK)
        return st;
    f->bake_cpu = cpu_now() - t0;
    sg_image frame = {0};
    sg_bake_frame_desc fd = {.camera = *cam, .width = p->frame, .height = p->frame};
    t0 = cpu_now();
    st = sg_bake_render(b, w, &fd, &frame, NULL, err);
    f->frame_cpu = cpu_now() - t0;
    sg_image_free(&frame);
    fd.width = fd.height = p->image;
    if (st == SG_OK)
        st = sg_bake_render(b, w, &fd, img, NULL, err);
    sg_bake_destroy(b);
    return st;
}

/* The difference image's name: gi_<scene>[_<surface>]_<label>[_vs_mls],
 * blanks and '+' as '_'. */
static void diff_name(char *name, size_t cap, const closeup *cu, const gsurface *gs, const char *label, int vs_mls)
{
    if (gs->lod)
        snprintf(name, cap, "gi_%s_%s_%s%s", cu->name, gs->name, label, vs_mls ? "_vs_mls" : "");
    else
        snprintf(name, cap, "gi_%s_%s", cu->name, label);
    for (char *q = name; *q; ++q)
        if (*q == ' ' || *q == '+')
            *q = '_';
}

/* A lookup frame against a reference: relMSE and p99 over the frame, and
 * over the model's pixels (mask) relMSE, energy ratio and the share within
 * 3 of the reference's standard errors; the difference image as name. */
static sg_status score(const vctx *c, const gplan *p, const sg_image *img, const sg_ref_result *ref,
                       const unsigned char *mask, const char *name, bake_figs *f, sg_error *err)
{
    sg_image_metrics m;
    sg_status st = sg_verify__compare(c, img, &ref->mean, name, &m, err);
    if (st != SG_OK)
        return st;
    f->rel_mse = m.rel_mse;
    f->p99 = m.p99_rel_error;
    double sa = 0, sb = 0, rel = 0, eps = m.epsilon;
    size_t n = 0, in3 = 0;
    for (size_t i = 0; i < (size_t)p->image * (size_t)p->image; ++i) {
        if (!mask[i])
            continue;
        const float *a = img->data + 3 * i, *bb = ref->mean.data + 3 * i, *se = ref->std_error.data + 3 * i;
        double la = lum(a), lb = lum(bb);
        sa += la;
        sb += lb;
        for (int ch = 0; ch < 3; ++ch)
            rel += ((double)a[ch] - bb[ch]) * ((double)a[ch] - bb[ch]) / ((double)bb[ch] * bb[ch] + eps) / 3.0;
        in3 += fabs(la - lb) <= 3.0 * lum(se);
        ++n;
    }
    f->model_pixels = n;
    f->rel_mse_model = n ? rel / (double)n : 0.0;
    f->energy_model = sb > 0 ? sa / sb : 0.0;
    f->within3 = n ? (double)in3 / (double)n : 0.0;
    return SG_OK;
}

/* The part's tables, filled close-up by close-up and written at its end. */
typedef struct gtables {
    vtable csv;              /* gi.csv                                    */
    vtable fcsv;             /* furnace.csv                               */
    vtable md;               /* gi.md: the MLS ladder                     */
    vtable smd;              /* gi.md: the surfaces on the close-ups      */
    vtable fmd;              /* gi.md: the furnace                        */
    vtable bmd;              /* gi.md: the budget                         */
} gtables;

/* One gi.csv row: rung r on surface gs against the reference `reference`
 * ("own": the world's own surface; "mls": the MLS world's), whose noise
 * relMSE is noise. */
static void csv_row(gtables *g, const gplan *p, const closeup *cu, const rung *r, const gsurface *gs,
                    const char *reference, double world_cpu, const bake_figs *f, double noise)
{
    sg_verify__tprintf(&g->csv, "%s,%s,%s,%g,%d,%d,%zu,%zu,%.3f,%.3f,%.4f,%d,%.3f,%.6g,%.6g,%.6g,%.6g,%.4f,%zu,"
                                "%.3g,%d,%d,%u,%d,%s,%s\n",
                       cu->name, r->indirect == SG_BAKE_INDIRECT_PHOTONS ? "photons" : "transport", r->label,
                       (double)r->spacing, r->env_rays, r->cos_rays, r->photons, p->points, world_cpu, f->bake_cpu,
                       f->frame_cpu, p->frame, world_cpu + f->bake_cpu + f->frame_cpu, f->rel_mse, f->rel_mse_model,
                       f->energy_model, f->p99, f->within3, f->model_pixels, noise, p->spp, p->image,
                       r->k ? r->k : 64u, r->chart, gs->name, reference);
    g->csv.rows++;
}

/* A row of gi.md's surfaces table: a rung's bake against its own
 * surface's reference and the MLS one (the same for MLS). */
typedef struct srow {
    const rung *r;
    bake_figs own, mls;
} srow;

typedef struct furnace_figs {
    size_t pixels;
    double mean, lo, hi, beyond3, bake_cpu;
} furnace_figs;

static void surface_md_rows(gtables *g, const closeup *cu, const gsurface *gs, const srow *sr, int n,
                            const furnace_figs *ff)
{
    for (int i = 0; i < n; ++i)
        sg_verify__tprintf(&g->smd, "| %s | %s | %s | %.1f | %.5f | %.5f | %.5f / %.5f | %.4f / %.4f | %.3f / %.3f | "
                                    "%.4f | %.4f | %.4f |\n",
                           cu->name, gs->name, sr[i].r->label, sr[i].own.bake_cpu, sr[i].own.rel_mse,
                           sr[i].mls.rel_mse, sr[i].own.rel_mse_model, sr[i].mls.rel_mse_model,
                           sr[i].own.energy_model, sr[i].mls.energy_model, sr[i].own.p99, sr[i].mls.p99, ff->mean,
                           ff->lo, ff->hi);
}

/* The reference path tracer's paths per CPU second on this scene: a small
 * render at pixel centres, timed. */
static sg_status ref_rate(const gplan *p, const sg_world *w, const sg_camera *cam, int max_depth,
                         double *paths_per_cpu_s, sg_error *err)
{
    sg_ref_desc rd = {.camera = *cam, .width = p->budget_side, .height = p->budget_side, .spp = p->budget_spp,
                      .max_depth = max_depth, .seed = 77, .pixel_centres = 1};
    sg_ref_result r = {0};
    double t0 = cpu_now();
    sg_status st = sg_ref_render(w, &rd, &r, err);
    double cpu = cpu_now() - t0;
    if (st == SG_OK)
        *paths_per_cpu_s = cpu > 0 ? (double)r.paths / cpu : 0.0;
    sg_ref_result_free(&r);
    return st;
}

/* The white furnace on w, the close-up's furnace world (make_world) on
 * surface gs: every covered pixel should be 1. */
static sg_status furnace(const vctx *c, const gplan *p, const closeup *cu, const sg_world *w, const gsurface *gs,
                         const rung *r, gtables *g, furnace_figs *ff, sg_error *err)
{
    sg_status st;
    sg_camera cam = closeup_camera(cu);
    sg_bake_desc bd = rung_desc(r);
    sg_bake *b = NULL;
    sg_image img = {0};
    double t0 = cpu_now();
    if ((st = sg_bake_create(w, &bd, &b, err)) == SG_OK) {
        double bake_cpu = cpu_now() - t0;
        sg_bake_frame_desc fd = {.camera = cam, .width = p->image, .height = p->image};
        if ((st = sg_bake_render(b, w, &fd, &img, NULL, err)) == SG_OK) {
            double sum = 0, lo = INFINITY, hi = -INFINITY;
            size_t n = 0, out3 = 0;
            for (int y = 0; y < p->image; ++y)
                for (int x = 0; x < p->image; ++x) {
                    sg_ray ray = sg_camera_ray(&cam, (float)x + 0.5f, (float)y + 0.5f, p->image, p->image);
                    sg_world_hit h;
                    if (!sg_world_intersect(w, &ray, &h, NULL))
                        continue;
                    double v = lum(img.data + 3 * ((size_t)y * (size_t)p->image + (size_t)x));
                    sum += v;
                    lo = v < lo ? v : lo;
                    hi = v > hi ? v : hi;
                    out3 += fabs(v - 1.0) > 0.03;
                    ++n;
                }
            *ff = (furnace_figs){.pixels = n, .mean = n ? sum / (double)n : 0.0, .lo = lo, .hi = hi,
                                 .beyond3 = n ? (double)out3 / (double)n : 0.0, .bake_cpu = bake_cpu};
            sg_verify__tprintf(&g->fcsv, "%s,%s,%zu,%.6f,%.6f,%.6f,%.6f,%.3f,%s\n", cu->name, r->label, n, ff->mean,
                               lo, hi, ff->beyond3, bake_cpu, gs->name);
            g->fcsv.rows++;
            sg_verify__tprintf(&g->fmd, "| %s | %s | %s | %zu | %.4f | %.4f | %.4f | %.2f%% | %.1f |\n", cu->name,
                               gs->name, r->label, n, ff->mean, lo, hi, 100.0 * ff->beyond3, bake_cpu);
            sg_verify__log(c, "  furnace %-16s %-6s %-10s mean %.4f, pixels [%.4f, %.4f], %.2f%% beyond 3%%\n",
                           cu->name, gs->name, r->label, ff->mean, lo, hi, 100.0 * ff->beyond3);
        }
        sg_bake_destroy(b);
    }
    sg_image_free(&img);
    return st;
}

/* The furnaces of a close-up on surface gs: the default bake's (in *ff)
 * and, on MLS, the photon estimator's beside it. */
static sg_status furnaces(const vctx *c, const gplan *p, const closeup *cu, const gsurface *gs, const rung *rungs,
                          int nrungs, gtables *g, furnace_figs *ff, sg_error *err)
{
    sg_scene_file sf = {0};
    sg_world *w = NULL;
    double world_cpu;
    const char *skip;
    sg_status st = make_world(c, cu, p->points, 1, gs, &sf, &w, &world_cpu, &skip, err);
    (void)world_cpu;
    if (st != SG_OK || !w) /* skip: not met, the scan took gs in the lit world */
        return st;
    const char *photons = c->d.ci ? "photons" : "1M photons";
    for (int k = 0; k < nrungs && st == SG_OK; ++k) {
        furnace_figs other;
        if (rungs[k].is_default)
            st = furnace(c, p, cu, w, gs, &rungs[k], g, ff, err);
        else if (!gs->lod && rungs[k].indirect == SG_BAKE_INDIRECT_PHOTONS && !strcmp(rungs[k].label, photons))
            st = furnace(c, p, cu, w, gs, &rungs[k], g, &other, err);
    }
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
    return st;
}

/* The close-up's converged reference on world w, cached under its scene's
 * own key (each surface model its own), and the relMSE of its own noise. */
static sg_status closeup_reference(const vctx *c, const gplan *p, const closeup *cu, const sg_scene_file *sf,
                                   const sg_world *w, sg_ref_result *ref, double *noise, int *cached, sg_error *err)
{
    sg_verify_ref_desc rd = {.camera = closeup_camera(cu), .width = p->image, .height = p->image, .spp = p->spp,
                             .max_depth = closeup_depth(cu), .cache_dir = c->d.cache_dir,
                             .scene_key = sg_verify_scene_key(sf)};
    sg_status st = sg_verify_reference(w, &rd, ref, cached, NULL, 0, err);
    if (st == SG_OK)
        st = sg_image_noise_rel_mse(&ref->mean, &ref->std_error, 0.0, noise, err);
    return st;
}

/* The close-up on the default MLS surface: its reference (*ref, the
 * caller's to free, kept as the other surfaces' second reference; its
 * noise in *noise), the ladder's rows and the budget; the rows of the
 * surfaces table in sr[*nsr]. */
static sg_status mls_ladder(const vctx *c, const gplan *p, const closeup *cu, const rung *rungs, int nrungs,
                            gtables *g, sg_ref_result *ref, double *noise, srow *sr, int *nsr, sg_error *err)
{
    sg_scene_file sf = {0};
    sg_world *w = NULL;
    double world_cpu = 0, rate = 0;
    const char *skip;
    unsigned char *mask = NULL;
    int cached = 0;
    sg_status st = make_world(c, cu, p->points, 0, &mls_surface, &sf, &w, &world_cpu, &skip, err);
    if (st != SG_OK)
        return st;
    sg_camera cam = closeup_camera(cu);
    sg_verify__log(c, "gi: %s, world %.1f CPU s\n", cu->name, world_cpu);
    st = closeup_reference(c, p, cu, &sf, w, ref, noise, &cached, err);
    if (st == SG_OK)
        st = model_mask(w, &cam, p->image, cu->room, &mask, err);
    if (st == SG_OK)
        st = ref_rate(p, w, &cam, closeup_depth(cu), &rate, err);
    if (st == SG_OK)
        sg_verify__log(c, "  reference %d spp%s, own noise relMSE %.2g; %.0f paths per CPU s\n", p->spp,
                       cached ? " (cached)" : "", *noise, rate);
    for (int k = 0; k < nrungs && st == SG_OK; ++k) {
        const rung *r = &rungs[k];
        if (!cu->sweep && !r->core)
            continue;
        bake_figs f = {0};
        sg_image img = {0};
        char name[200];
        diff_name(name, sizeof name, cu, &mls_surface, r->label, 0);
        if ((st = bake_frame(p, w, &cam, r, &img, &f, err)) == SG_OK)
            st = score(c, p, &img, ref, mask, name, &f, err);
        sg_image_free(&img);
        if (st != SG_OK)
            break;
        csv_row(g, p, cu, r, &mls_surface, "own", world_cpu, &f, *noise);
        sg_verify__tprintf(&g->md, "| %s | %s | %.1f | %.5f | %.5f | %.4f | %.3f | %.3f |\n", cu->name, r->label,
                           f.bake_cpu, f.rel_mse, f.rel_mse_model, f.energy_model, f.p99, f.within3);
        sg_verify__log(c, "  %-12s bake %6.1f CPU s, relMSE %.5f (model %.5f), energy %.4f, p99 %.3f, in 3 "
                          "sigma %.3f\n",
                       r->label, f.bake_cpu, f.rel_mse, f.rel_mse_model, f.energy_model, f.p99, f.within3);
        if (surface_rung(cu, r))
            sr[(*nsr)++] = (srow){r, f, f};
        if (r->is_default && rate > 0 && f.rel_mse > 0) {
            double spp = *noise * (double)p->spp / f.rel_mse;
            double ref_cpu = spp * (double)p->frame * (double)p->frame / rate, ours = f.bake_cpu + f.frame_cpu;
            sg_verify__tprintf(&g->bmd, "| %s | %.1f | %.5f | %.0f | %.1f | %.1f |\n", cu->name, ours, f.rel_mse,
                               spp, ref_cpu, ref_cpu / ours);
            sg_verify__log(c, "  budget: bake + frame %.1f CPU s; the reference needs %.0f spp, %.1f CPU s: "
                              "%.1fx\n",
                           ours, spp, ref_cpu, ref_cpu / ours);
        }
    }
    free(mask);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
    return st;
}

/* The close-up on surface gs (not MLS): its world, its own reference, and
 * the surface rungs' bakes against both it and the MLS world's reference
 * mls_ref (noise relMSE mls_noise): one gi.csv row each; then its furnace
 * and its rows of the surfaces table. A scan that cannot take gs is
 * skipped, with the reason logged. */
static sg_status other_surface(const vctx *c, const gplan *p, const closeup *cu, const gsurface *gs,
                               const rung *rungs, int nrungs, const sg_ref_result *mls_ref, double mls_noise,
                               gtables *g, sg_error *err)
{
    sg_scene_file sf = {0};
    sg_world *w = NULL;
    double world_cpu = 0, noise = 0;
    const char *skip;
    unsigned char *mask = NULL;
    sg_ref_result ref = {0};
    int cached = 0, nsr = 0;
    srow sr[sizeof ladder / sizeof ladder[0]];
    sg_status st = make_world(c, cu, p->points, 0, gs, &sf, &w, &world_cpu, &skip, err);
    if (st != SG_OK)
        return st;
    if (!w) {
        sg_verify__log(c, "gi: %s on %s skipped: %s\n", cu->name, gs->name, skip);
        return SG_OK;
    }
    sg_camera cam = closeup_camera(cu);
    sg_verify__log(c, "gi: %s on %s, world %.1f CPU s\n", cu->name, gs->name, world_cpu);
    st = closeup_reference(c, p, cu, &sf, w, &ref, &noise, &cached, err);
    if (st == SG_OK)
        st = model_mask(w, &cam, p->image, cu->room, &mask, err);
    if (st == SG_OK)
        sg_verify__log(c, "  %s reference %d spp%s, own noise relMSE %.2g\n", gs->name, p->spp,
                       cached ? " (cached)" : "", noise);
    for (int k = 0; k < nrungs && st == SG_OK; ++k) {
        const rung *r = &rungs[k];
        if (!surface_rung(cu, r))
            continue;
        srow row = {.r = r};
        sg_image img = {0};
        char name[200];
        if ((st = bake_frame(p, w, &cam, r, &img, &row.own, err)) == SG_OK) {
            diff_name(name, sizeof name, cu, gs, r->label, 0);
            st = score(c, p, &img, &ref, mask, name, &row.own, err);
        }
        row.mls.bake_cpu = row.own.bake_cpu;
        row.mls.frame_cpu = row.own.frame_cpu;
        if (st == SG_OK) {
            diff_name(name, sizeof name, cu, gs, r->label, 1);
            st = score(c, p, &img, mls_ref, mask, name, &row.mls, err);
        }
        sg_image_free(&img);
        if (st != SG_OK)
            break;
        csv_row(g, p, cu, r, gs, "own", world_cpu, &row.own, noise);
        csv_row(g, p, cu, r, gs, "mls", world_cpu, &row.mls, mls_noise);
        sg_verify__log(c, "  %-6s %-12s bake %6.1f CPU s, relMSE %.5f (model %.5f), energy %.4f, p99 %.3f; "
                          "against MLS: relMSE %.5f (model %.5f), energy %.4f\n",
                       gs->name, r->label, row.own.bake_cpu, row.own.rel_mse, row.own.rel_mse_model,
                       row.own.energy_model, row.own.p99, row.mls.rel_mse, row.mls.rel_mse_model,
                       row.mls.energy_model);
        sr[nsr++] = row;
    }
    free(mask);
    sg_ref_result_free(&ref);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
    furnace_figs ff = {0};
    if (st == SG_OK)
        st = furnaces(c, p, cu, gs, rungs, nrungs, g, &ff, err);
    if (st == SG_OK)
        surface_md_rows(g, cu, gs, sr, nsr, &ff);
    return st;
}

sg_status sg_verify__gi(vctx *c, sg_error *err)
{
    gplan p = make_plan(c);
    const closeup *list = c->d.ci ? &ci_closeup : closeups;
    int nscenes = c->d.ci ? 1 : (int)(sizeof closeups / sizeof closeups[0]);
    const rung *rungs = c->d.ci ? ci_ladder : ladder;
    int nrungs = c->d.ci ? (int)(sizeof ci_ladder / sizeof ci_ladder[0]) : (int)(sizeof ladder / sizeof ladder[0]);
    gtables g = {0};
    sg_verify__tprintf(&g.csv, "scene,estimator,label,spacing,env_rays,cos_rays,photons,points,world_cpu_s,bake_cpu_s,"
                               "frame_cpu_s,frame_size,total_cpu_s,rel_mse,rel_mse_model,energy_model,p99,within3,"
                               "model_pixels,ref_noise,ref_spp,image_size,k,chart,surface,reference\n");
    sg_verify__tprintf(&g.fcsv, "scene,bake,pixels,mean,min,max,beyond3,bake_cpu_s,surface\n");
    sg_verify__tprintf(&g.md, "Close-ups of concave scans (%zu points each, on the ground) and the room lit through "
                              "its window (as many, and the bunny inside), %dx%d lookup frame against a %d-spp "
                              "reference at pixel centres; CPU seconds of both threads; model: the pixels of the "
                              "scan (of the room: every covered pixel). The default MLS surface.\n\n| scene | bake | "
                              "bake CPU s | relMSE | relMSE model | energy model | p99 | within ref. 3 sigma |\n"
                              "|---|---|---:|---:|---:|---:|---:|---:|\n",
                       p.points, p.image, p.image, p.spp);
    sg_verify__tprintf(&g.smd, "\nSurfaces on the close-ups: the same worlds with every model on the ISO or the "
                               "hybrid triangle hierarchy (camera rays at full detail), each bake against the "
                               "reference of its own surface (the error of its light) and against the MLS "
                               "world's (adding the surface's geometric difference); figure pairs: own / MLS "
                               "reference. Furnace: the default bake's, on that surface.\n\n| scene | surface | "
                               "bake | bake CPU s | relMSE vs own ref | relMSE vs MLS ref | model relMSE | "
                               "energy (model) | p99 | furnace mean | min | max |\n"
                               "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    sg_verify__tprintf(&g.fmd, "\nWhite furnace (the scan alone, the room with its bunny, albedo 1, uniform sky L = "
                               "1, %dx%d): every pixel should be 1.\n\n| scene | surface | bake | pixels | mean | "
                               "smallest | largest | beyond 3%% | bake CPU s |\n"
                               "|---|---|---|---:|---:|---:|---:|---:|---:|\n",
                       p.image, p.image);
    sg_verify__tprintf(&g.bmd, "\nBudget: the default bake + one %dx%d lookup frame against one %dx%d reference frame "
                               "as accurate (CPU seconds; the reference's noise relMSE falls as 1/spp from its "
                               "%d-spp value).\n\n| scene | bake + frame CPU s | relMSE | reference spp for it | "
                               "reference frame CPU s | ratio |\n|---|---:|---:|---:|---:|---:|\n",
                       p.frame, p.frame, p.frame, p.frame, p.spp);
    sg_status st = SG_OK;
    for (int s = 0; s < nscenes && st == SG_OK; ++s) {
        const closeup *cu = &list[s];
        if (cu->mesh) {
            char path[4400];
            snprintf(path, sizeof path, "%s/%s", c->d.data_dir, cu->mesh);
            if (access(path, R_OK) != 0) {
                sg_verify__log(c, "gi: %s not found: %s skipped\n", path, cu->name);
                continue;
            }
        }
        sg_ref_result ref = {0};
        double noise = 0;
        srow sr[sizeof ladder / sizeof ladder[0]];
        int nsr = 0;
        furnace_figs ff = {0};
        st = mls_ladder(c, &p, cu, rungs, nrungs, &g, &ref, &noise, sr, &nsr, err);
        if (st == SG_OK)
            st = furnaces(c, &p, cu, &mls_surface, rungs, nrungs, &g, &ff, err);
        if (st == SG_OK)
            surface_md_rows(&g, cu, &mls_surface, sr, nsr, &ff);
        for (size_t k = 0; k < sizeof other_surfaces / sizeof other_surfaces[0] && st == SG_OK; ++k)
            st = other_surface(c, &p, cu, &other_surfaces[k], rungs, nrungs, &ref, noise, &g, err);
        sg_ref_result_free(&ref);
    }
    if (st == SG_OK)
        st = sg_verify__twrite(&g.csv, c->d.out_dir, "gi.csv", err);
    if (st == SG_OK)
        st = sg_verify__twrite(&g.fcsv, c->d.out_dir, "furnace.csv", err);
    if (st == SG_OK) {
        sg_verify__tprintf(&g.md, "%s%s%s", g.smd.buf ? g.smd.buf : "", g.fmd.buf ? g.fmd.buf : "",
                           g.bmd.buf ? g.bmd.buf : "");
        st = sg_verify__twrite(&g.md, c->d.out_dir, "gi.md", err);
    }
    c->sum->rows += g.csv.rows + g.fcsv.rows;
    sg_verify__tfree(&g.csv);
    sg_verify__tfree(&g.fcsv);
    sg_verify__tfree(&g.md);
    sg_verify__tfree(&g.smd);
    sg_verify__tfree(&g.fmd);
    sg_verify__tfree(&g.bmd);
    return st;
}
