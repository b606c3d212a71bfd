/* sweeps.c — speed against accuracy (verify.h: SURFACES, BAKE, SCALING,
 * HEADLINE) on the main scene: a scanned model standing on a ground of
 * splats under an HDR map, seen by a fixed camera.
 *
 * Invariants:
 *  1. Every error is against a converged reference at pixel centres
 *     (refcache.h) of the same scene and camera: the default MLS surface's
 *     for SURFACES (so a surface's own geometric error counts), the
 *     model's own for BAKE and HEADLINE.
 *  2. Frame times are the best of FRAME_RUNS, so a burst of load from
 *     elsewhere on a shared machine slows one run, not the figure.
 *  3. A row is written for every run that was asked for; a failed call
 *     stops the part with its message (never a silent gap).
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bake/bake.h"
#include "io/mesh.h"
#include "io/scene_file.h"
#include "render/render.h"
#include "render/world.h"
#include "verify/refcache.h"
#include "verify/verify_int.h"

#define FRAME_RUNS 2
#define SCENE_LENGTH 10.0f  /* the model's longest side, world units */
#define MODEL_ALBEDO 0.7f
#define GLOSSY_ROUGHNESS 0.3 /* the glossy bins' sweep: highlight about 10 degrees wide */
#define GLOSSY_SPECULAR 0.3
#define GROUND_ALBEDO 0.5f
#define TARGET_REL_MSE 0.01
#define ISO_DEFAULT_TOLERANCE 0.05 /* sg_iso_desc.tolerance's default (iso.h), for the CSV */

static const float view_dir[3] = {0.6f, -0.35f, -1.0f};

typedef struct mscene {
    const char *name;      /* "dragon", "bunny", ...                      */
    char mesh[4400];
    char env[4400];        /* "" = the analytic sky                       */
    float scale;
    sg_vec3 translate;
    sg_camera cam;
} mscene;

typedef struct surf_cfg {
    const char *name;
    sg_surface_model model;
    unsigned kd_disable;   /* sg_kd_disable flags (MLS and disks)            */
    int spc;               /* MLS samples per cell                           */
    float radius_scale;
    float iso_tolerance;   /* ISO patch error, smallest radii; 0 = default   */
    float iso_lod;         /* ISO camera rays' level of detail, pixels
                              ("iso_lod"); 0: full detail, so the error is
                              the bake's and the surface's, not the coarse
                              patches' (iso_lod1 shows those); < 0: the
                              surface's default (scaling: the viewer's)  */
} surf_cfg;

static const surf_cfg default_cfg = {"mls", SG_SURFACE_MLS, 0, 8, 1.0f, 0.0f, 0};

typedef struct plan {
    size_t points;         /* model points of SURFACES, BAKE, HEADLINE    */
    int image, frame, spp; /* error image side, timed frame side, ref spp */
    int direct;            /* SURFACES bakes' direct samples              */
    int scaling_direct;
    int ground;            /* the built-in ground under the model (not in
                              the CI sweep: its 90k splats would dominate) */
} plan;

static plan make_plan(const vctx *c)
{
    if (c->d.ci)
        return (plan){.points = 5000, .image = 32, .frame = 64, .spp = 16, .direct = 2,
                      .scaling_direct = 2, .ground = 0};
    return (plan){.points = 100000, .image = 128, .frame = 512, .spp = 1024, .direct = 16,
                  .scaling_direct = 4, .ground = 1};
}

static sg_status mscene_setup(const char *name, const char *mesh, const char *env, mscene *s, sg_error *err)
{
    memset(s, 0, sizeof *s);
    s->name = name;
    snprintf(s->mesh, sizeof s->mesh, "%s", mesh);
    if (env && access(env, R_OK) == 0)
        snprintf(s->env, sizeof s->env, "%s", env);
    sg_aabb b;
    sg_ground_placement pl;
    sg_status st = sg_mesh_read_bounds(mesh, &b, err);
    if (st != SG_OK)
        return st;
    if (sg_mesh_ground_placement(b, SCENE_LENGTH, &pl, NULL) != SG_OK)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: empty or degenerate bounds", mesh);
    s->scale = pl.scale;
    s->translate = pl.translate;
    return sg_camera_frame(pl.placed, sg_v3(view_dir[0], view_dir[1], view_dir[2]), sg_v3(0, 1, 0), 40.0f, 1.0f, 0.9f,
                           &s->cam, err);
}

/* The ISO tolerance cfg builds with (the CSV's column; 0 for the other
 * models). */
static double iso_tolerance(const surf_cfg *cfg)
{
    if (cfg->model != SG_SURFACE_ISO)
        return 0.0;
    return cfg->iso_tolerance > 0 ? (double)cfg->iso_tolerance : ISO_DEFAULT_TOLERANCE;
}

static void surface_json(char *out, size_t cap, const surf_cfg *cfg)
{
    char tol[96] = "";
    if (cfg->model == SG_SURFACE_ISO && cfg->iso_lod >= 0.0f)
        snprintf(tol, sizeof tol, ", \"iso_lod\": %g", (double)cfg->iso_lod);
    if (cfg->iso_tolerance > 0)
        snprintf(tol + strlen(tol), sizeof tol - strlen(tol), ", \"iso_tolerance\": %g", (double)cfg->iso_tolerance);
    snprintf(out, cap,
             "\"surface\": {\"model\": \"%s\", \"samples_per_cell\": %d, \"refinements\": {\"shrink\": %s, "
             "\"encourage\": %s, \"collapse\": %s}%s}",
             sg_verify__model_name(cfg->model), cfg->spc, (cfg->kd_disable & 1u) ? "false" : "true",
             (cfg->kd_disable & 2u) ? "false" : "true", (cfg->kd_disable & 4u) ? "false" : "true", tol);
}

/* The scene file of s with points model samples, configuration cfg on
 * every model, and the ground when ground is set. */
/* glossy: the model is GGX (roughness GLOSSY_ROUGHNESS, specular
 * GLOSSY_SPECULAR) instead of Lambert, for the glossy bins' sweep. */
static sg_status build_world(const mscene *s, size_t points, const surf_cfg *cfg, int ground, int glossy,
                             sg_scene_file *sf, sg_world **w, double *seconds, sg_error *err)
{
    char material[256];
    snprintf(material, sizeof material,
             glossy ? "{\"type\": \"ggx\", \"albedo\": [%g, %g, %g], \"roughness\": %g, \"specular\": %g,"
                      " \"use_point_colors\": false}"
                    : "{\"type\": \"lambert\", \"albedo\": [%g, %g, %g], \"use_point_colors\": false}",
             (double)MODEL_ALBEDO, (double)MODEL_ALBEDO, (double)MODEL_ALBEDO, GLOSSY_ROUGHNESS, GLOSSY_SPECULAR);
    char json[16384], surf[512], env[4500], ground_part[1024] = "";
    surface_json(surf, sizeof surf, cfg);
    if (s->env[0])
        snprintf(env, sizeof env, "{\"path\": \"%s\"}", s->env);
    else
        snprintf(env, sizeof env, "{\"builtin\": \"sky\"}");
    if (ground)
        snprintf(ground_part, sizeof ground_part,
                 ", {\"builtin\": \"ground\", \"material\": {\"type\": \"lambert\", \"albedo\": [%g, %g, %g],"
                 " \"use_point_colors\": false}, %s}",
                 (double)GROUND_ALBEDO, (double)GROUND_ALBEDO, (double)GROUND_ALBEDO, surf);
    const sg_camera *c = &s->cam;
    sg_vec3 look = sg_v3_add(c->eye, c->forward);
    int n = snprintf(json, sizeof json,
                     "{\"models\": [{\"path\": \"%s\", \"points\": %zu, \"radius_scale\": %g,"
                     " \"transform\": {\"translate\": [%.9g, %.9g, %.9g], \"scale\": %.9g},"
                     " \"material\": %s, %s}%s], \"envmap\": %s,"
                     " \"cameras\": [{\"name\": \"main\", \"eye\": [%.9g, %.9g, %.9g], \"look\": [%.9g, %.9g, %.9g],"
                     " \"up\": [0, 1, 0], \"fov_deg\": 40}], \"render\": {\"max_depth\": 8}}",
                     s->mesh, points, (double)cfg->radius_scale, (double)s->translate.x, (double)s->translate.y,
                     (double)s->translate.z, (double)s->scale, material, surf, ground_part, env, (double)c->eye.x, (double)c->eye.y,
                     (double)c->eye.z, (double)look.x, (double)look.y, (double)look.z);
    if (n < 0 || (size_t)n >= sizeof json)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: scene JSON too long (paths?)", s->name);
    sg_status st = sg_scene_file_parse(json, (size_t)n, s->name, NULL, sf, err);
    if (st != SG_OK)
        return st;
    double t0 = omp_get_wtime();
    st = sg_world_create(sf, w, err);
    *seconds = omp_get_wtime() - t0;
    if (st != SG_OK)
        sg_scene_file_free(sf);
    return st;
}

static double world_mib(const sg_world *w, size_t *splats)
{
    double bytes = 0;
    size_t n = 0;
    for (uint32_t m = 0; m < (uint32_t)sg_world_model_count(w); m++) {
        sg_scene_info info;
        sg_scene_get_info(sg_world_scene(w, m), &info);
        bytes += (double)info.memory_bytes;
        n += info.splat_count;
    }
    if (splats)
        *splats = n;
    return bytes / (1024.0 * 1024.0);
}

/* The reference, and the relMSE it owes to its own noise (*noise). */
static sg_status reference(const vctx *c, const plan *p, const sg_world *w, const sg_scene_file *sf,
                           const sg_camera *cam, sg_ref_result *ref, double *noise, sg_error *err)
{
    sg_verify_ref_desc rd = {.camera = *cam, .width = p->image, .height = p->image, .spp = p->spp,
                             .cache_dir = c->d.cache_dir, .scene_key = sg_verify_scene_key(sf)};
    int cached = 0;
    char path[4200];
    sg_status st = sg_verify_reference(w, &rd, ref, &cached, path, sizeof path, err);
    if (st == SG_OK)
        st = sg_image_noise_rel_mse(&ref->mean, &ref->std_error, 0.0, noise, err);
    if (st == SG_OK)
        sg_verify__log(c, "  reference %dx%d, %d spp: %.1f s%s, own noise relMSE %.2g (%s)\n", p->image, p->image,
                       p->spp, ref->seconds, cached ? ", cached" : "", *noise, path);
    return st;
}

/* Direct renderer (SG_SHADE_SIMPLE) over the first model: best-of time at
 * side `frame`, the counters of that frame, and the image at side `image`. */
typedef struct direct_run {
    double frame_s, mrays;
    sg_ray_stats st;
    sg_image img;          /* at the error size (caller frees)           */
} direct_run;

static sg_status run_direct(const plan *p, const sg_world *w, const sg_camera *cam, direct_run *out,
                            sg_error *err)
{
    memset(out, 0, sizeof *out);
    const sg_scene *s = sg_world_scene(w, 0);
    sg_render_desc rd = {.camera = *cam, .width = p->frame, .height = p->frame, .shade = SG_SHADE_SIMPLE};
    out->frame_s = INFINITY;
    for (int r = 0; r < FRAME_RUNS; r++) {
        sg_image img = {0};
        sg_render_stats rs;
        sg_status st = sg_render_frame(s, &rd, &img, &rs, err);
        if (st != SG_OK)
            return st;
        sg_image_free(&img);
        if (rs.seconds < out->frame_s) {
            out->frame_s = rs.seconds;
            out->mrays = rs.mrays_per_s;
            out->st = rs.primary;
        }
    }
    rd.width = rd.height = p->image;
    return sg_render_frame(s, &rd, &out->img, NULL, err);
}

typedef struct bake_run {
    double bake_s, trace_s, gather_s, direct_s, bake_mib, frame_s;
    size_t sample_points;  /* of all models (sg_bake_stats)               */
    sg_image img;          /* lookup frame at the error size             */
} bake_run;

static sg_status run_bake(const plan *p, const sg_world *w, const sg_camera *cam, const sg_bake_desc *bd,
                          int want_image, bake_run *out, sg_error *err)
{
    memset(out, 0, sizeof *out);
    sg_bake *b = NULL;
    double t0 = omp_get_wtime();
    sg_status st = sg_bake_create(w, bd, &b, err);
    if (st != SG_OK)
        return st;
    out->bake_s = omp_get_wtime() - t0;
    sg_bake_stats bs;
    sg_bake_get_stats(b, &bs);
    out->trace_s = bs.trace_seconds;
    out->gather_s = bs.gather_seconds;
    out->direct_s = bs.direct_seconds;
    out->sample_points = bs.sample_points;
    out->bake_mib = (double)bs.memory_bytes / (1024.0 * 1024.0);
    sg_bake_frame_desc fd = {.camera = *cam, .width = p->frame, .height = p->frame};
    out->frame_s = INFINITY;
    for (int r = 0; r < FRAME_RUNS && st == SG_OK; r++) {
        sg_image img = {0};
        double secs = 0;
        st = sg_bake_render(b, w, &fd, &img, &secs, err);
        sg_image_free(&img);
        if (st == SG_OK && secs < out->frame_s)
            out->frame_s = secs;
    }
    if (st == SG_OK && want_image) {
        fd.width = fd.height = p->image;
        double secs;
        st = sg_bake_render(b, w, &fd, &out->img, &secs, err);
    }
    sg_bake_destroy(b);
    return st;
}

static double per_ray(uint64_t v, uint64_t rays) { return rays ? (double)v / (double)rays : 0.0; }

/* ---- SURFACES ------------------------------------------------------------ */

/* Whether configuration i is the first of its surface model (its
 * defaults: radius x 1, no options), which also meets its own reference. */
static int own_reference_wanted(const surf_cfg *cfgs, int i)
{
    for (int j = 0; j < i; j++)
        if (cfgs[j].model == cfgs[i].model)
            return 0;
    return cfgs[i].radius_scale == 1.0f && cfgs[i].iso_tolerance == 0.0f && cfgs[i].kd_disable == 0 &&
           cfgs[i].iso_lod == 0.0f;
}

static sg_status part_surfaces(vctx *c, const plan *p, const mscene *ms, sg_error *err)
{
    /* The first is the yardstick (reference and direct frame) of the rest. */
    static const surf_cfg full[] = {
        {"mls", SG_SURFACE_MLS, 0, 8, 1.0f, 0, 0},          {"mls_no_refinements", SG_SURFACE_MLS, 7, 8, 1.0f, 0, 0},
        {"mls_no_shrink", SG_SURFACE_MLS, 1, 8, 1.0f, 0, 0}, {"mls_no_collapse", SG_SURFACE_MLS, 4, 8, 1.0f, 0, 0},
        {"mls_spc4", SG_SURFACE_MLS, 0, 4, 1.0f, 0, 0},     {"mls_spc16", SG_SURFACE_MLS, 0, 16, 1.0f, 0, 0},
        {"mls_r0.75", SG_SURFACE_MLS, 0, 8, 0.75f, 0, 0},   {"mls_r1.5", SG_SURFACE_MLS, 0, 8, 1.5f, 0, 0},
        {"disk", SG_SURFACE_DISK, 0, 8, 1.0f, 0, 0},        {"disk_r0.75", SG_SURFACE_DISK, 0, 8, 0.75f, 0, 0},
        {"disk_r1.5", SG_SURFACE_DISK, 0, 8, 1.5f, 0, 0},   {"iso", SG_SURFACE_ISO, 0, 8, 1.0f, 0, 0},
        {"iso_tol0.02", SG_SURFACE_ISO, 0, 8, 1.0f, 0.02f, 0}, {"iso_tol0.1", SG_SURFACE_ISO, 0, 8, 1.0f, 0.1f, 0},
        {"iso_r1.5", SG_SURFACE_ISO, 0, 8, 1.5f, 0, 0}, {"iso_lod1", SG_SURFACE_ISO, 0, 8, 1.0f, 0, 1.0f}};
    static const surf_cfg ci[] = {{"mls", SG_SURFACE_MLS, 0, 8, 1.0f, 0, 0},
                                  {"mls_no_refinements", SG_SURFACE_MLS, 7, 8, 1.0f, 0, 0},
                                  {"disk", SG_SURFACE_DISK, 0, 8, 1.0f, 0, 0},
                                  {"disk_r1.5", SG_SURFACE_DISK, 0, 8, 1.5f, 0, 0},
                                  {"iso", SG_SURFACE_ISO, 0, 8, 1.0f, 0, 0},
                                  {"iso_lod1", SG_SURFACE_ISO, 0, 8, 1.0f, 0, 1.0f}};
    const surf_cfg *cfgs = c->d.ci ? ci : full;
    int n = c->d.ci ? (int)(sizeof ci / sizeof ci[0]) : (int)(sizeof full / sizeof full[0]);
    vtable t = {0};
    sg_verify__tprintf(&t, "config,model,kd_disable,samples_per_cell,radius_scale,points,renderer,build_s,bake_s,"
                           "frame_s,fps,frame_size,rel_mse,energy_ratio,p99,nan,nodes_per_ray,leaves_per_ray,"
                           "isects_per_ray,splats_per_ray,scene_mib,ref_noise,iso_tolerance,iso_lod\n");
    sg_ref_result ref = {0};
    sg_image direct_ref = {0};
    double noise = 0;
    sg_status st = SG_OK;
    sg_bake_desc bd = {.direct_samples = p->direct, .gather_rays = 2 * p->direct};
    sg_verify__log(c, "surfaces: %s, %zu points%s, bake %d + %d rays per sample site; error %dx%d, frames %dx%d\n",
                   ms->name, p->points, p->ground ? " + ground" : "", p->direct, 2 * p->direct, p->image, p->image,
                   p->frame, p->frame);
    for (int i = 0; i < n && st == SG_OK; i++) {
        const surf_cfg *cfg = &cfgs[i];
        sg_scene_file sf = {0};
        sg_world *w = NULL;
        double build_s = 0;
        st = build_world(ms, p->points, cfg, p->ground, 0, &sf, &w, &build_s, err);
        if (st != SG_OK)
            break;
        size_t splats;
        double mib = world_mib(w, &splats);
        if (i == 0)
            st = reference(c, p, w, &sf, &ms->cam, &ref, &noise, err);
        direct_run dr = {0};
        bake_run br = {0};
        if (st == SG_OK)
            st = run_direct(p, w, &ms->cam, &dr, err);
        if (st == SG_OK && i == 0) { /* the default surface's direct frame is the yardstick */
            direct_ref = dr.img;
            dr.img = (sg_image){0};
        }
        if (st == SG_OK)
            st = run_bake(p, w, &ms->cam, &bd, 1, &br, err);
        sg_image_metrics mb = {0}, md = {0};
        char name[160];
        if (st == SG_OK) {
            snprintf(name, sizeof name, "surfaces_%s_%s_bake%s", ms->name, cfg->name, c->d.ci ? "_ci" : "");
            st = sg_verify__compare(c, &br.img, &ref.mean, name, &mb, err);
        }
        if (st == SG_OK) {
            if (i == 0)
                st = sg_verify__compare(c, &direct_ref, &direct_ref, NULL, &md, err);
            else {
                snprintf(name, sizeof name, "surfaces_%s_%s_direct%s", ms->name, cfg->name, c->d.ci ? "_ci" : "");
                st = sg_verify__compare(c, &dr.img, &direct_ref, name, &md, err);
            }
        }
        /* The first configuration of each other model also meets the
         * reference of its own surface: the bake's error apart from the
         * surface's difference from MLS (the same light on the same
         * geometry as the camera sees it). */
        sg_image_metrics mo = {0};
        double own_noise = 0;
        int own = 0;
        if (st == SG_OK && i > 0 && own_reference_wanted(cfgs, i)) {
            sg_ref_result oref = {0};
            st = reference(c, p, w, &sf, &ms->cam, &oref, &own_noise, err);
            if (st == SG_OK) {
                snprintf(name, sizeof name, "surfaces_%s_%s_bake_own%s", ms->name, cfg->name, c->d.ci ? "_ci" : "");
                st = sg_verify__compare(c, &br.img, &oref.mean, name, &mo, err);
                own = st == SG_OK;
            }
            sg_ref_result_free(&oref);
        }
        if (st == SG_OK) {
            const sg_ray_stats *rs = &dr.st;
            for (int k = 0; k < 2 + own; k++) {
                const sg_image_metrics *m = k == 0 ? &mb : k == 1 ? &md : &mo;
                double fs = k == 1 ? dr.frame_s : br.frame_s;
                sg_verify__tprintf(&t, "%s,%s,%u,%d,%g,%zu,%s,%.4f,%.4f,%.6f,%.3f,%d,%.6g,%.6g,%.6g,%zu,%.3f,%.3f,%.3f,%.3f,%.3f,%.3g,%g,%g\n",
                                   cfg->name, sg_verify__model_name(cfg->model), cfg->kd_disable, cfg->spc,
                                   (double)cfg->radius_scale, splats,
                                   k == 0 ? "bake_lookup" : k == 1 ? "direct" : "bake_own_surface", build_s,
                                   k == 1 ? 0.0 : br.bake_s, fs, fs > 0 ? 1.0 / fs : 0.0, p->frame, m->rel_mse,
                                   m->energy_ratio_lum, m->p99_rel_error, m->nan_pixels + m->inf_pixels,
                                   per_ray(rs->nodes, rs->rays), per_ray(rs->leaves, rs->rays),
                                   per_ray(rs->isects, rs->rays), per_ray(rs->splats, rs->rays), mib,
                                   k == 0 ? noise : k == 2 ? own_noise : 0.0,
                                   iso_tolerance(cfg), (double)cfg->iso_lod);
                t.rows++;
            }
            sg_verify__log(c, "  %-20s build %.2f s, bake %.2f s, lookup frame %.4f s, relMSE %.5f energy %.4f; "
                              "direct frame %.4f s, vs mls %.5f; %.1f nodes %.2f leaves %.1f splats per ray\n",
                           cfg->name, build_s, br.bake_s, br.frame_s, mb.rel_mse, mb.energy_ratio_lum, dr.frame_s,
                           md.rel_mse, per_ray(rs->nodes, rs->rays), per_ray(rs->leaves, rs->rays),
                           per_ray(rs->splats, rs->rays));
            if (own)
                sg_verify__log(c, "  %-20s bake against its own surface's reference: relMSE %.5f energy %.4f\n",
                               cfg->name, mo.rel_mse, mo.energy_ratio_lum);
        }
        sg_image_free(&dr.img);
        sg_image_free(&br.img);
        sg_world_destroy(w);
        sg_scene_file_free(&sf);
    }
    if (st == SG_OK)
        st = sg_verify__twrite(&t, c->d.out_dir, "surfaces.csv", err);
    c->sum->rows += t.rows;
    sg_verify__tfree(&t);
    sg_image_free(&direct_ref);
    sg_ref_result_free(&ref);
    return st;
}

/* ---- BAKE ----------------------------------------------------------------- */

typedef struct bake_pt {
    const char *sweep;
    sg_bake_indirect indirect; /* the estimator                                    */
    size_t photons;            /* photon estimator                                 */
    size_t k;                  /* photon estimator's gather                        */
    int direct;                /* envmap rays per sample site (-1: photons carry it) */
    int gather_rays;           /* cosine rays per sample site; 0 = default         */
    float spacing;             /* sg_bake_desc.sample_spacing: 0 the material's, < 0 every splat */
    int glossy;                /* 1: the GGX model (build_world), whose bins the next two set */
    int glossy_res, glossy_rays; /* sg_bake_desc's; 0 = defaults                  */
} bake_pt;

static sg_status part_bake(vctx *c, const plan *p, const mscene *ms, sg_error *err)
{
    bake_pt pts[64];
    int n = 0;
    const sg_bake_indirect T = SG_BAKE_INDIRECT_TRANSPORT, P = SG_BAKE_INDIRECT_PHOTONS;
    if (c->d.ci) {
        pts[n++] = (bake_pt){"transport_rays", T, 0, 0, 4, 8, 0.0f, 0, 0, 0};
        pts[n++] = (bake_pt){"transport_rays", T, 0, 0, 8, 16, 0.0f, 0, 0, 0};
        pts[n++] = (bake_pt){"transport_spacing", T, 0, 0, 8, 16, 8.0f, 0, 0, 0};
        static const size_t ph[] = {10000, 40000};
        for (int i = 0; i < 2; i++)
            pts[n++] = (bake_pt){"photons", P, ph[i], 64, 2, 0, 0.0f, 0, 0, 0};
        pts[n++] = (bake_pt){"photons_carry_direct", P, 20000, 64, -1, 0, 0.0f, 0, 0, 0};
        pts[n++] = (bake_pt){"k", P, 20000, 16, 2, 0, 0.0f, 0, 0, 0};
    } else {
        /* The transport estimator: rays per site (envmap + cosine; the
         * default is 32 + 64), then the sample spacing at the default rays
         * (2, 8 x the median radius and every splat beside the default 4). */
        static const int er[] = {8, 16, 32, 64};
        for (int i = 0; i < 4; i++)
            pts[n++] = (bake_pt){"transport_rays", T, 0, 0, er[i], 2 * er[i], 0.0f, 0, 0, 0};
        static const float sp[] = {2.0f, 8.0f, -1.0f};
        for (int i = 0; i < 3; i++)
            pts[n++] = (bake_pt){"transport_spacing", T, 0, 0, 32, 64, sp[i], 0, 0, 0};
        /* The photon estimator (the first bake): photon count with direct
         * light from 16 + 32 rays per sample site, photons carrying the
         * direct light too, and the gather's k. */
        static const size_t ph[] = {250000, 1000000, 4000000};
        for (int i = 0; i < 3; i++)
            pts[n++] = (bake_pt){"photons", P, ph[i], 64, 16, 0, 0.0f, 0, 0, 0};
        for (int i = 0; i < 3; i++)
            pts[n++] = (bake_pt){"photons_carry_direct", P, ph[i], 64, -1, 0, 0.0f, 0, 0, 0};
        static const size_t ks[] = {16, 32, 128};
        for (int i = 0; i < 3; i++)
            pts[n++] = (bake_pt){"k", P, 1000000, ks[i], 16, 0, 0.0f, 0, 0, 0};
        /* Directional resolution, on the same model made glossy (GGX,
         * roughness 0.3: R = 27 by default) against its own reference:
         * bins per side R and rays per glossy sample point M. */
        static const int gr[] = {8, 16, 0, 32};
        for (int i = 0; i < 4; i++)
            pts[n++] = (bake_pt){"glossy_res", T, 0, 0, 0, 0, 0.0f, 1, gr[i], 0};
        static const int gm[] = {32, 512};
        for (int i = 0; i < 2; i++)
            pts[n++] = (bake_pt){"glossy_rays", T, 0, 0, 0, 0, 0.0f, 1, 0, gm[i]};
    }
    /* World 0 the Lambert model, world 1 (built when a glossy row comes)
     * the same model glossy; each with its own reference. */
    sg_scene_file sf[2] = {{0}};
    sg_world *w[2] = {NULL, NULL};
    sg_ref_result ref[2];
    memset(ref, 0, sizeof ref);
    double noise[2] = {0, 0}, build_s = 0;
    size_t splats[2] = {0, 0};
    sg_status st = build_world(ms, p->points, &default_cfg, p->ground, 0, &sf[0], &w[0], &build_s, err);
    if (st != SG_OK)
        return st;
    world_mib(w[0], &splats[0]);
    sg_verify__log(c, "bake: %s, %zu splats, %d bakes\n", ms->name, splats[0], n);
    st = reference(c, p, w[0], &sf[0], &ms->cam, &ref[0], &noise[0], err);
    vtable t = {0};
    sg_verify__tprintf(&t, "sweep,photons,k,direct,points,trace_s,gather_s,direct_s,bake_s,bake_mib,frame_s,fps,"
                           "frame_size,rel_mse,energy_ratio,p99,nan,ref_noise,spacing,sample_points,glossy,"
                           "glossy_res,glossy_rays,estimator,gather_rays\n");
    double best_s = INFINITY, best_err = INFINITY;
    int best = -1, best_reached = 0;
    for (int i = 0; i < n && st == SG_OK; i++) {
        int g = pts[i].glossy;
        if (g && !w[1]) {
            if ((st = build_world(ms, p->points, &default_cfg, p->ground, 1, &sf[1], &w[1], &build_s, err)) != SG_OK)
                break;
            world_mib(w[1], &splats[1]);
            sg_verify__log(c, "bake: %s glossy (GGX roughness %g, specular %g)\n", ms->name, GLOSSY_ROUGHNESS,
                           GLOSSY_SPECULAR);
            if ((st = reference(c, p, w[1], &sf[1], &ms->cam, &ref[1], &noise[1], err)) != SG_OK)
                break;
        }
        sg_bake_desc bd = {.indirect = pts[i].indirect, .photons = {.count = pts[i].photons},
                           .gather = {.k = (unsigned)pts[i].k}, .direct_samples = pts[i].direct,
                           .gather_rays = pts[i].gather_rays, .sample_spacing = pts[i].spacing,
                           .glossy_res = pts[i].glossy_res, .glossy_rays = pts[i].glossy_rays};
        sg_bake_desc rd = sg_bake_desc_resolve(&bd);
        bake_run br;
        st = run_bake(p, w[g], &ms->cam, &bd, 1, &br, err);
        if (st != SG_OK)
            break;
        sg_image_metrics m;
        char name[160];
        snprintf(name, sizeof name, "bake_%s_%s_p%zu_k%zu_d%d_g%d_s%g_r%d_m%d%s", ms->name, pts[i].sweep,
                 pts[i].photons, pts[i].k, rd.direct_samples, rd.gather_rays, (double)pts[i].spacing,
                 pts[i].glossy_res, pts[i].glossy_rays, c->d.ci ? "_ci" : "");
        st = sg_verify__compare(c, &br.img, &ref[g].mean, name, &m, err);
        sg_image_free(&br.img);
        if (st != SG_OK)
            break;
        sg_verify__tprintf(&t, "%s,%zu,%zu,%d,%zu,%.4f,%.4f,%.4f,%.4f,%.3f,%.6f,%.3f,%d,%.6g,%.6g,%.6g,%zu,%.3g,%g,%zu,"
                               "%d,%d,%d,%s,%d\n",
                           pts[i].sweep, pts[i].photons, pts[i].k, rd.direct_samples, splats[g], br.trace_s,
                           br.gather_s, br.direct_s, br.bake_s, br.bake_mib, br.frame_s, 1.0 / br.frame_s, p->frame,
                           m.rel_mse, m.energy_ratio_lum, m.p99_rel_error, m.nan_pixels + m.inf_pixels, noise[g],
                           (double)pts[i].spacing, br.sample_points, g, pts[i].glossy_res, pts[i].glossy_rays,
                           rd.indirect == SG_BAKE_INDIRECT_PHOTONS ? "photons" : "transport", rd.gather_rays);
        t.rows++;
        sg_verify__log(c, "  %-21s photons %8zu k %3zu rays %3d + %3d spacing %4g: bake %.2f s (photons %.2f), "
                          "relMSE %.5f energy %.4f p99 %.3f\n",
                       pts[i].sweep, pts[i].photons, pts[i].k, rd.direct_samples, rd.gather_rays,
                       (double)pts[i].spacing, br.bake_s, br.trace_s, m.rel_mse, m.energy_ratio_lum, m.p99_rel_error);
        int reached = m.rel_mse <= TARGET_REL_MSE;
        if (g) /* the headline's model is Lambert: pick among those */
            continue;
        if (reached && (!best_reached || br.bake_s < best_s)) {
            best = i, best_s = br.bake_s, best_reached = 1;
        } else if (!best_reached && m.rel_mse < best_err) {
            best = i, best_err = m.rel_mse;
        }
    }
    if (st == SG_OK)
        st = sg_verify__twrite(&t, c->d.out_dir, "bake.csv", err);
    if (st == SG_OK && best >= 0) {
        snprintf(c->best_config, sizeof c->best_config, "%s relMSE <= %g", best_reached ? "fastest bake with" :
                 "most accurate bake (none reached", TARGET_REL_MSE);
        if (!best_reached)
            strncat(c->best_config, ")", sizeof c->best_config - strlen(c->best_config) - 1);
        c->best_desc = (sg_bake_desc){.indirect = pts[best].indirect, .photons = {.count = pts[best].photons},
                                      .gather = {.k = (unsigned)pts[best].k}, .direct_samples = pts[best].direct,
                                      .gather_rays = pts[best].gather_rays, .sample_spacing = pts[best].spacing};
    }
    c->sum->rows += t.rows;
    sg_verify__tfree(&t);
    for (int g = 0; g < 2; g++) {
        sg_ref_result_free(&ref[g]);
        sg_world_destroy(w[g]);
        sg_scene_file_free(&sf[g]);
    }
    return st;
}

/* ---- SCALING -------------------------------------------------------------- */

/* Every size under every surface model (verify_int.h SG_VERIFY__MODELS),
 * each with its defaults. */
static sg_status part_scaling(vctx *c, const plan *p, const mscene *ms, sg_error *err)
{
    vtable t = {0};
    sg_verify__tprintf(&t, "points,splats,build_s,scene_mib,rss_mib,direct_frame_s,direct_fps,mrays_s,nodes_per_ray,"
                           "leaves_per_ray,isects_per_ray,splats_per_ray,bake_s,bake_mib,lookup_frame_s,lookup_fps,"
                           "frame_size,model\n");
    sg_status st = SG_OK;
    sg_verify__log(c, "scaling: %s alone, frames %dx%d, bakes %d + %d rays per sample site\n", ms->name, p->frame,
                   p->frame, p->scaling_direct, 2 * p->scaling_direct);
    for (int i = 0; i < c->d.n_sizes && st == SG_OK; i++)
        for (int m = 0; m < SG_VERIFY__MODELS && st == SG_OK; m++) {
            surf_cfg cfg = default_cfg;
            cfg.model = (sg_surface_model)m;
            cfg.iso_lod = -1.0f; /* the frames the viewer shows */
            cfg.name = sg_verify__model_name(cfg.model);
            sg_scene_file sf = {0};
            sg_world *w = NULL;
            double build_s = 0;
            st = build_world(ms, c->d.sizes[i], &cfg, 0, 0, &sf, &w, &build_s, err);
            if (st != SG_OK)
                break;
            size_t splats;
            double mib = world_mib(w, &splats);
            direct_run dr;
            st = run_direct(p, w, &ms->cam, &dr, err);
            bake_run br = {0};
            sg_bake_desc bd = {.direct_samples = p->scaling_direct, .gather_rays = 2 * p->scaling_direct};
            if (st == SG_OK)
                st = run_bake(p, w, &ms->cam, &bd, 0, &br, err);
            double rss = sg_verify__rss_mib();
            if (st == SG_OK) {
                const sg_ray_stats *rs = &dr.st;
                sg_verify__tprintf(&t, "%zu,%zu,%.4f,%.3f,%.1f,%.6f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.4f,%.3f,%.6f,%.3f,%d,%s\n",
                                   c->d.sizes[i], splats, build_s, mib, rss, dr.frame_s, 1.0 / dr.frame_s, dr.mrays,
                                   per_ray(rs->nodes, rs->rays), per_ray(rs->leaves, rs->rays),
                                   per_ray(rs->isects, rs->rays), per_ray(rs->splats, rs->rays), br.bake_s, br.bake_mib,
                                   br.frame_s, 1.0 / br.frame_s, p->frame, cfg.name);
                t.rows++;
                sg_verify__log(c, "  %9zu points %-4s: build %.2f s, %.1f MiB (RSS %.0f MiB); direct %.1f fps, %.1f nodes "
                                  "%.2f leaves %.1f splats per ray; bake %.2f s, lookup %.1f fps\n",
                               c->d.sizes[i], cfg.name, build_s, mib, rss, 1.0 / dr.frame_s,
                               per_ray(rs->nodes, rs->rays), per_ray(rs->leaves, rs->rays),
                               per_ray(rs->splats, rs->rays), br.bake_s, 1.0 / br.frame_s);
            }
            sg_image_free(&dr.img);
            sg_world_destroy(w);
            sg_scene_file_free(&sf);
        }
    if (st == SG_OK)
        st = sg_verify__twrite(&t, c->d.out_dir, "scaling.csv", err);
    c->sum->rows += t.rows;
    sg_verify__tfree(&t);
    return st;
}

/* ---- HEADLINE ------------------------------------------------------------- */

static sg_status part_headline(vctx *c, const plan *p, const mscene *models, int nmodels, sg_error *err)
{
    sg_bake_desc best = sg_bake_desc_resolve(c->best_config[0] ? &c->best_desc : NULL);
    const char *why = c->best_config[0] ? c->best_config : "the library's defaults (BAKE part not run)";
    size_t photons = best.photons.count, k = best.gather.k;
    int direct = best.direct_samples, pe = best.indirect == SG_BAKE_INDIRECT_PHOTONS;
    char bake_text[200];
    if (pe)
        snprintf(bake_text, sizeof bake_text, "photon estimator, %zu photons, gather k %zu, %d + %d rays per sample site",
                 photons, k, direct, best.gather_rays);
    else
        snprintf(bake_text, sizeof bake_text, "transport estimator, %d + %d rays per sample site, spacing %s", direct,
                 best.gather_rays, best.sample_spacing > 0 ? "set" : (best.sample_spacing < 0 ? "every splat" : "default"));
    sg_verify__log(c, "headline: %d models, bake: %s (%s)\n", nmodels, bake_text, why);
    vtable t = {0}, md = {0};
    sg_verify__tprintf(&t, "model,points,splats,photons,k,direct,bake_s,lookup_frame_s,fps,frame_size,scene_mib,"
                           "bake_mib,rss_mib,rel_mse,energy_ratio,p99,nan,ref_spp,image_size,ref_noise,estimator,"
                           "gather_rays\n");
    sg_verify__tprintf(&md, "Bake: %s (%s, chosen by the bake sweep on the first model). fps: the bake's lookup "
                            "frame at %dx%d; error: its %dx%d frame against a %d-spp reference at pixel centres.\n\n"
                            "| model | points (+ ground) | fps | bake s | memory MiB (scene + bake; process RSS) | "
                            "relMSE | energy ratio | p99 rel. error | NaN |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
                       bake_text, why, p->frame, p->frame, p->image, p->image, p->spp);
    sg_status st = SG_OK;
    for (int i = 0; i < nmodels && st == SG_OK; i++) {
        const mscene *ms = &models[i];
        sg_scene_file sf = {0};
        sg_world *w = NULL;
        double build_s = 0;
        st = build_world(ms, p->points, &default_cfg, p->ground, 0, &sf, &w, &build_s, err);
        if (st != SG_OK)
            break;
        size_t splats;
        double mib = world_mib(w, &splats);
        sg_ref_result ref = {0};
        double noise = 0;
        st = reference(c, p, w, &sf, &ms->cam, &ref, &noise, err);
        bake_run br = {0};
        if (st == SG_OK)
            st = run_bake(p, w, &ms->cam, &best, 1, &br, err);
        sg_image_metrics m;
        char name[160];
        snprintf(name, sizeof name, "headline_%s%s", ms->name, c->d.ci ? "_ci" : "");
        if (st == SG_OK)
            st = sg_verify__compare(c, &br.img, &ref.mean, name, &m, err);
        double rss = sg_verify__rss_mib();
        if (st == SG_OK) {
            sg_verify__tprintf(&t, "%s,%zu,%zu,%zu,%zu,%d,%.4f,%.6f,%.3f,%d,%.3f,%.3f,%.1f,%.6g,%.6g,%.6g,%zu,%d,%d,%.3g,"
                                   "%s,%d\n",
                               ms->name, p->points, splats, photons, k, direct, br.bake_s, br.frame_s,
                               1.0 / br.frame_s, p->frame, mib, br.bake_mib, rss, m.rel_mse, m.energy_ratio_lum,
                               m.p99_rel_error, m.nan_pixels + m.inf_pixels, p->spp, p->image, noise,
                               pe ? "photons" : "transport", best.gather_rays);
            t.rows++;
            sg_verify__tprintf(&md, "| %s | %zu (%zu) | %.1f | %.2f | %.1f + %.1f; %.0f | %.4f | %.4f | %.3f | %zu |\n",
                               ms->name, p->points, splats, 1.0 / br.frame_s, br.bake_s, mib, br.bake_mib, rss,
                               m.rel_mse, m.energy_ratio_lum, m.p99_rel_error, m.nan_pixels + m.inf_pixels);
            sg_verify__log(c, "  %-10s bake %.2f s, %.1f fps, %.1f + %.1f MiB, relMSE %.5f, energy %.4f\n", ms->name,
                           br.bake_s, 1.0 / br.frame_s, mib, br.bake_mib, m.rel_mse, m.energy_ratio_lum);
        }
        sg_image_free(&br.img);
        sg_ref_result_free(&ref);
        sg_world_destroy(w);
        sg_scene_file_free(&sf);
    }
    if (st == SG_OK)
        st = sg_verify__twrite(&t, c->d.out_dir, "headline.csv", err);
    if (st == SG_OK)
        st = sg_verify__twrite(&md, c->d.out_dir, "headline.md", err);
    c->sum->rows += t.rows;
    sg_verify__tfree(&t);
    sg_verify__tfree(&md);
    return st;
}

sg_status sg_verify__sweeps(vctx *c, sg_error *err)
{
    plan p = make_plan(c);
    char path[4200], env[4200];
    static const struct {
        const char *name, *mesh;
    } data_models[] = {{"dragon", "meshes/stanford_dragon/dragon_vrip.ply"},
                       {"bunny", NULL},
                       {"armadillo", "meshes/armadillo/armadillo_50k.obj"},
                       {"lucy", "meshes/lucy/Lucy100k.ply"}};
    mscene models[4];
    int nm = 0;
    snprintf(env, sizeof env, "%s/envmaps/blender_studiolights/courtyard.exr", c->d.data_dir);
    sg_status st = SG_OK;
    for (int i = 0; i < 4 && st == SG_OK; i++) {
        if (data_models[i].mesh) {
            if (c->d.ci)
                continue; /* the CI sweep uses the asset bunny only */
            snprintf(path, sizeof path, "%s/%s", c->d.data_dir, data_models[i].mesh);
            if (access(path, R_OK) != 0) {
                sg_verify__log(c, "(%s not found: %s skipped)\n", path, data_models[i].name);
                continue;
            }
        } else
            snprintf(path, sizeof path, "%s/bunny.ply", SG_ASSET_DIR);
        st = mscene_setup(data_models[i].name, path, c->d.ci ? NULL : env, &models[nm], err);
        if (st == SG_OK)
            nm++;
    }
    if (st != SG_OK)
        return st;
    if (nm == 0)
        return sg_error_set(err, SG_ERR_IO, "no model found (assets/bunny.ply: run scripts/setup.sh)");
    const mscene *main = &models[0];
    sg_verify__log(c, "main scene: %s (%s) under %s\n", main->name, main->mesh, main->env[0] ? main->env : "the analytic sky");
    if (st == SG_OK && (c->d.parts & SG_VERIFY_SURFACES))
        st = part_surfaces(c, &p, main, err);
    if (st == SG_OK && (c->d.parts & SG_VERIFY_BAKE))
        st = part_bake(c, &p, main, err);
    if (st == SG_OK && (c->d.parts & SG_VERIFY_SCALING))
        st = part_scaling(c, &p, main, err);
    if (st == SG_OK && (c->d.parts & SG_VERIFY_HEADLINE))
        st = part_headline(c, &p, models, nm, err);
    return st;
}
