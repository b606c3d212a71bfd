/* program.c — see program.h. */
#include "program.h"

#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "app/bake_cache.h"
#include "app/preflight.h"
#include "bake/bake_io.h"
#include "render/world_file.h"

static const char *prog = "splatgi"; /* set once by sg_prog_init */

void sg_prog_init(const char *name) { prog = name; }

void sg_prog_say(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "%s: ", prog);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    fflush(stderr);
}

sg_status sg_prog_load_scene(const char *input, sg_model_scene_desc *md, const char *write_scene,
                             sg_scene_file *sf, sg_error *err)
{
    sg_status st;
    if (sg_model_scene_is_model(input)) {
        md->model = input;
        st = sg_model_scene_make(md, sf, err);
    } else {
        if (md->envmap || md->up != SG_SCENE_UP_POS_Y || md->points || md->radius_cap != 0.0f || md->drop_outliers)
            return sg_error_set(err, SG_ERR_INVALID_ARG,
                                "%s: --envmap, --up, --points, --radius-cap and --drop-outliers shape the scene made "
                                "for a model file; a scene file says these itself", input);
        st = sg_scene_file_load(input, sf, err);
    }
    if (st == SG_OK && write_scene) {
        if ((st = sg_scene_file_write(sf, write_scene, err)) != SG_OK)
            sg_scene_file_free(sf);
        else
            sg_prog_say("wrote the scene to %s", write_scene);
    }
    return st;
}

sg_status sg_prog_check_output(const char *path, sg_error *err)
{
    const char *slash = strrchr(path, '/');
    if (slash && slash != path) {
        char dir[4200];
        if (snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path) < (int)sizeof dir)
            mkdir(dir, 0777); /* EEXIST and the rest: the check below says */
    }
    return sg_preflight_output(path, 0, err);
}

typedef struct world_progress {
    double t0; /* omp_get_wtime at the start */
} world_progress;

static void on_world_event(void *user, sg_world_event kind, const char *message)
{
    world_progress *p = user;
    if (kind == SG_WORLD_STAGE)
        sg_prog_say("%5.1f s  %s", omp_get_wtime() - p->t0, message);
    else
        sg_prog_say("note: %s", message);
}

int sg_prog_world_option(int argc, char **argv, int *i, sg_prog_world *wo, sg_error *err)
{
    const char *a = argv[*i];
    if (!strcmp(a, "--if-stale")) {
        wo->if_stale = 1;
        return 1;
    }
    if (strcmp(a, "--world"))
        return 0;
    if (*i + 1 >= argc) {
        sg_error_set(err, SG_ERR_INVALID_ARG, "--world needs a value");
        return -1;
    }
    wo->path = argv[++*i];
    return 1;
}

static sg_status build_world(const char *input, const sg_scene_file *sf, uint64_t extra_bytes, sg_world **out,
                             sg_error *err)
{
    const char *skip = getenv("SPLATGI_NO_MEMORY_CHECK");
    if (!(skip && !strcmp(skip, "1"))) {
        sg_memory_estimate e;
        sg_status st = sg_preflight_estimate(sf, extra_bytes, &e, err);
        if (st == SG_OK && (st = sg_preflight_memory(input, &e, err)) != SG_OK) {
            size_t n = strlen(err->message);
            snprintf(err->message + n, sizeof err->message - n, " (SPLATGI_NO_MEMORY_CHECK=1 skips this check)");
        }
        if (st != SG_OK)
            return st;
    }
    world_progress p = {omp_get_wtime()};
    sg_world_desc d = {.on_event = on_world_event, .user = &p};
    sg_prog_say("building the world of %s", input);
    sg_status st = sg_world_create_desc(sf, &d, out, err);
    if (st == SG_OK)
        sg_prog_say("%5.1f s  world built", omp_get_wtime() - p.t0);
    return st;
}

sg_status sg_prog_build_world(const char *input, const sg_scene_file *sf, uint64_t extra_bytes,
                              const sg_prog_world *wo, sg_world **out, sg_error *err)
{
    if (!wo || !wo->path) {
        if (wo && wo->if_stale)
            return sg_error_set(err, SG_ERR_INVALID_ARG, "--if-stale goes with --world FILE");
        return build_world(input, sf, extra_bytes, out, err);
    }
    char why[SG_ERROR_MESSAGE_MAX];
    sg_status st = SG_OK;
    if (sg_world_file_fresh(wo->path, sf, why, sizeof why)) {
        world_progress p = {omp_get_wtime()};
        sg_world_desc d = {.on_event = on_world_event, .user = &p};
        st = sg_world_load(wo->path, sf, &d, out, err);
        if (st == SG_OK) {
            sg_prog_say("%5.1f s  world loaded from %s", omp_get_wtime() - p.t0, wo->path);
            return SG_OK;
        }
        if (!wo->if_stale)
            return st;
        snprintf(why, sizeof why, "%s", err->message); /* damaged: build it again */
    } else if (!wo->if_stale) {
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s (--if-stale rebuilds it; or: splatgi-world %s -o %s)", why,
                            input, wo->path);
    }
    if ((st = sg_world_file_replaceable(wo->path, err)) != SG_OK)
        return st;
    sg_prog_say("%s: building the world again: %s", wo->path, why);
    if ((st = sg_prog_check_output(wo->path, err)) != SG_OK)
        return st;
    sg_world *w = NULL;
    if ((st = build_world(input, sf, extra_bytes, &w, err)) != SG_OK)
        return st;
    double t0 = omp_get_wtime();
    if ((st = sg_world_save(w, sf, wo->path, err)) != SG_OK) {
        sg_world_destroy(w);
        return st;
    }
    sg_prog_say("%5.1f s  wrote the world to %s", omp_get_wtime() - t0, wo->path);
    *out = w;
    return SG_OK;
}

sg_status sg_prog_bake_plan(const char *input, const char *output, const char *explicit_bake,
                            const sg_scene_file *sf, sg_prog_bake *plan, sg_error *err)
{
    memset(plan, 0, sizeof *plan);
    if (explicit_bake) {
        if (snprintf(plan->path, sizeof plan->path, "%s", explicit_bake) >= (int)sizeof plan->path)
            return sg_error_set(err, SG_ERR_INVALID_ARG, "--bake: path too long");
        plan->explicit_path = 1;
    } else {
        sg_status st = sg_bake_cache_path(input, output, plan->path, sizeof plan->path, err);
        if (st != SG_OK)
            return st;
    }
    /* The header before the world (6-11 s of building for nothing). */
    if (sg_bake_cache_fresh(plan->path, sf, plan->why, sizeof plan->why))
        return SG_OK;
    if (plan->explicit_path)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: %s (bake it with: splatgi-bake %s -o %s)", plan->path,
                            plan->why, input, plan->path);
    plan->need = 1;
    return sg_prog_check_output(plan->path, err);
}

typedef struct bake_progress {
    double t0, last;
    int tty;
} bake_progress;

static int on_photons(void *user, size_t done, size_t total)
{
    bake_progress *p = user;
    double now = omp_get_wtime();
    if (p->tty) {
        fprintf(stderr, "\r%s: baking: %5.1f%% of %zu photons   ", prog, 100.0 * (double)done / (double)total, total);
        if (done == total)
            fputc('\n', stderr);
        fflush(stderr);
    } else if (now - p->last >= 5.0 || done == total) {
        sg_prog_say("baking: %5.1f%% of %zu photons, %.1f s", 100.0 * (double)done / (double)total, total,
                    now - p->t0);
        p->last = now;
    }
    return 0;
}

void sg_prog_bake_desc_from_scene(const sg_scene_file *sf, sg_bake_desc *d)
{
    if (sf->bake.ray_cone >= 0.0f) /* given; bake.h: < 0 is off, 0 the default */
        d->ray_cone = sf->bake.ray_cone > 0.0f ? sf->bake.ray_cone : -1.0f;
}

sg_status sg_prog_bake_obtain(const sg_prog_bake *plan, const sg_scene_file *sf, const sg_world *w, sg_bake **out,
                              sg_error *err)
{
    uint64_t hash = sg_scene_file_hash(sf, SG_SCENE_HASH_BAKE);
    if (plan->need) {
        uint64_t splats = 0, glossy = 0;
        for (size_t m = 0; m < sg_world_model_count(w); ++m) {
            size_t n = sg_scene_sites(sg_world_scene(w, (uint32_t)m))->count;
            splats += n;
            if (sg_world_material(w, (uint32_t)m)->type == SG_MATERIAL_GGX)
                glossy += n;
        }
        sg_status st = sg_preflight_output(plan->path, sg_preflight_bake_bytes(splats, glossy), err);
        if (st != SG_OK)
            return st;
        sg_prog_say("%s: %s: baking it (default parameters; splatgi-bake chooses others)", plan->path, plan->why);
        bake_progress bp = {.t0 = omp_get_wtime(), .tty = isatty(STDERR_FILENO)};
        bp.last = bp.t0;
        sg_bake_desc d = {.photons = {.progress = on_photons, .progress_user = &bp}};
        sg_prog_bake_desc_from_scene(sf, &d);
        sg_bake *b = NULL;
        if ((st = sg_bake_create(w, &d, &b, err)) != SG_OK)
            return st;
        st = sg_bake_save(b, plan->path, hash, err);
        sg_bake_destroy(b);
        if (st != SG_OK)
            return st;
        sg_prog_say("baked %s in %.1f s", plan->path, omp_get_wtime() - bp.t0);
    }
    return sg_bake_load(plan->path, w, hash, out, err);
}
