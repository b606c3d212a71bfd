/* bake_cache.c — see bake_cache.h. */
#include "app/bake_cache.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "bake/bake.h"
#include "bake/bake_file.h"
#include "bake/bake_io.h"

sg_status sg_bake_cache_path(const char *input, const char *output, char *buf, size_t cap, sg_error *err)
{
    const char *base = strrchr(input, '/');
    base = base ? base + 1 : input;
    const char *dot = strrchr(base, '.');
    int stem = dot && dot > base ? (int)(dot - base) : (int)strlen(base);
    int dir = 3; /* "out" */
    const char *folder = "out";
    if (output && output[0]) {
        const char *slash = strrchr(output, '/');
        folder = slash ? output : ".";
        dir = slash ? (slash == output ? 1 : (int)(slash - output)) : 1;
    }
    if (snprintf(buf, cap, "%.*s/%.*s.sgbake", dir, folder, stem, base) >= (int)cap)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: the bake path beside it is too long", input);
    return SG_OK;
}

/* 1 when path exists and was modified after t (seconds, nanoseconds). */
static int newer_than(const char *path, const struct stat *bake)
{
    struct stat st;
    if (!path || stat(path, &st) != 0)
        return 0;
    return st.st_mtim.tv_sec > bake->st_mtim.tv_sec ||
           (st.st_mtim.tv_sec == bake->st_mtim.tv_sec && st.st_mtim.tv_nsec > bake->st_mtim.tv_nsec);
}

static const char *base_name(const char *p)
{
    const char *s = strrchr(p, '/');
    return s ? s + 1 : p;
}

int sg_bake_cache_fresh(const char *path, const sg_scene_file *sf, char *why, size_t why_cap)
{
    struct stat st;
    if (stat(path, &st) != 0) {
        snprintf(why, why_cap, "%s", errno == ENOENT ? "no bake yet" : strerror(errno));
        return 0;
    }
    sg_error err = {0};
    sg_bake_file *f = NULL;
    int fresh = 0;
    if (sg_bake_file_open(path, sg_scene_file_hash(sf, SG_SCENE_HASH_BAKE), 0, &f, &err) != SG_OK) {
        snprintf(why, why_cap, "%s", err.message);
        return 0;
    }
    sg_bake_desc d;
    sg_status ds = SG_OK;
    if (sg_bake_file_info(f)->flags & SG_BAKE_FLAG_CHECKPOINT)
        snprintf(why, why_cap, "a checkpoint of an interrupted bake, not a bake");
    else if ((ds = sg_bake_file_desc(f, path, &d, &err)) == SG_ERR_UNSUPPORTED ||
             (ds == SG_ERR_CORRUPT && strstr(err.message, "hashes to")))
        snprintf(why, why_cap, "made by an older splatgi (its estimators have changed since)");
    else if (ds != SG_OK)
        snprintf(why, why_cap, "%s", err.message);
    else
        fresh = 1;
    sg_bake_file_close(f);
    for (size_t i = 0; fresh && i < sf->model_count; ++i)
        if (sf->models[i].kind == SG_SCENE_MODEL_FILE && newer_than(sf->models[i].path, &st)) {
            snprintf(why, why_cap, "older than %s", base_name(sf->models[i].path));
            fresh = 0;
        }
    if (fresh && sf->env.kind == SG_SCENE_ENV_FILE && newer_than(sf->env.path, &st)) {
        snprintf(why, why_cap, "older than %s", base_name(sf->env.path));
        fresh = 0;
    }
    return fresh;
}
