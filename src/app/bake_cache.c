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

/* The parameters a bake's META section holds (bake_io.h, layout 3). */
static int meta_desc(const uint64_t *meta, sg_bake_desc *d)
{
    enum { COUNT = 1, SEED, MAX_DEPTH, RR_DEPTH, K, NORMAL_COS, BLOCK, DIRECT = 19, SPACING, GLOSSY_RES, GLOSSY_RAYS };
    if (meta[0] != 3 || meta[BLOCK] != SG_PHOTON_BLOCK)
        return 0;
    uint32_t cos_bits = (uint32_t)meta[NORMAL_COS], sp_bits = (uint32_t)meta[SPACING];
    float normal_cos, spacing;
    memcpy(&normal_cos, &cos_bits, 4);
    memcpy(&spacing, &sp_bits, 4);
    *d = (sg_bake_desc){.photons = {.count = (size_t)meta[COUNT], .seed = meta[SEED],
                                    .max_depth = (int)meta[MAX_DEPTH], .rr_depth = (int)meta[RR_DEPTH]},
                        .gather = {.k = (unsigned)meta[K], .normal_cos = normal_cos},
                        .direct_samples = (int)(int64_t)meta[DIRECT],
                        .sample_spacing = spacing,
                        .glossy_res = (int)meta[GLOSSY_RES],
                        .glossy_rays = (int)meta[GLOSSY_RAYS]};
    return 1;
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
    uint64_t meta[SG_BAKE_META_COUNT];
    sg_bake_desc d;
    const sg_bake_section *ms = sg_bake_file_find(f, "META");
    if (sg_bake_file_info(f)->flags & SG_BAKE_FLAG_CHECKPOINT)
        snprintf(why, why_cap, "a checkpoint of an interrupted bake, not a bake");
    else if (!ms || ms->size != sizeof meta || sg_bake_file_read(f, "META", meta, sizeof meta, &err) != SG_OK)
        snprintf(why, why_cap, "%s", err.message[0] ? err.message : "no readable META section");
    else if (!meta_desc(meta, &d) || sg_bake_param_hash(&d) != sg_bake_file_info(f)->param_hash)
        snprintf(why, why_cap, "made by an older splatgi (its estimators have changed since)");
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
