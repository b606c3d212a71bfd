/* refcache.c — the centred reference and its disk cache (refcache.h).
 *
 * Invariants:
 *  1. The key changes with anything that changes the image: the scene
 *     (including the bytes of its files, not just their names), camera,
 *     size, spp, depth, seed and SG_VERIFY_REF_VERSION.
 *  2. A cache entry is used only when its .txt exists (written last) and
 *     both images read back at the requested size.
 *  3. Path index pixel * SG_REF_MAX_SPP + s, as sg_ref_render: the image is
 *     the same for any thread count.
 */
#include "verify/refcache.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/alloc.h"
#include "render/coverage.h"
#include "math/rng.h"
#include "verify/verify_int.h"

#define FNV_PRIME 0x100000001b3ull

static uint64_t fnv_bytes(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= FNV_PRIME;
    }
    return h;
}

uint64_t sg_verify_hash_file(uint64_t key, const char *path)
{
    FILE *f = path ? fopen(path, "rb") : NULL;
    if (!f)
        return fnv_bytes(key, "absent", 6);
    unsigned char buf[1 << 16];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        key = fnv_bytes(key, buf, n);
    fclose(f);
    return key;
}

uint64_t sg_verify_scene_key(const sg_scene_file *sf)
{
    uint64_t key = sg_scene_file_hash(sf, SG_SCENE_HASH_ALL);
    for (size_t i = 0; i < sf->model_count; i++)
        if (sf->models[i].path)
            key = sg_verify_hash_file(key, sf->models[i].path);
    if (sf->env.path)
        key = sg_verify_hash_file(key, sf->env.path);
    return key;
}

static sg_verify_ref_desc resolve(const sg_verify_ref_desc *d)
{
    sg_verify_ref_desc r = *d;
    if (r.max_depth == 0)
        r.max_depth = 8;
    if (r.seed == 0)
        r.seed = 1;
    return r;
}

uint64_t sg_verify_ref_key(const sg_verify_ref_desc *d0)
{
    sg_verify_ref_desc d = resolve(d0);
    uint64_t h = 0xcbf29ce484222325ull;
    h = fnv_bytes(h, &d.scene_key, sizeof d.scene_key);
    const sg_camera *c = &d.camera;
    float cam[14] = {c->eye.x,     c->eye.y,   c->eye.z,   c->forward.x, c->forward.y,      c->forward.z, c->right.x,
                     c->right.y,   c->right.z, c->up.x,    c->up.y,      c->up.z,           c->tan_half_fov,
                     c->aspect};
    h = fnv_bytes(h, cam, sizeof cam);
    int32_t ints[5] = {d.width, d.height, d.spp, d.max_depth, (int32_t)SG_VERIFY_REF_VERSION};
    h = fnv_bytes(h, ints, sizeof ints);
    h = fnv_bytes(h, &d.seed, sizeof d.seed);
    return sg_mix64(h);
}

sg_status sg_verify_reference(const sg_world *w, const sg_verify_ref_desc *d0, sg_ref_result *out, int *cached,
                              char *path, size_t path_cap, sg_error *err)
{
    sg_verify_ref_desc d = resolve(d0);
    if (d.width < 1 || d.height < 1 || d.spp < 1)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "reference: bad size %dx%d or spp %d", d.width, d.height,
                            d.spp);
    uint64_t key = sg_verify_ref_key(&d);
    char base[4000] = "", exr[4100], se[4100], txt[4100];
    if (d.cache_dir) {
        if (snprintf(base, sizeof base, "%s/%016" PRIx64, d.cache_dir, key) >= (int)sizeof base)
            return sg_error_set(err, SG_ERR_INVALID_ARG, "reference: cache path too long: %s", d.cache_dir);
        snprintf(exr, sizeof exr, "%s.exr", base);
        snprintf(se, sizeof se, "%s.se.exr", base);
        snprintf(txt, sizeof txt, "%s.txt", base);
        if (path)
            snprintf(path, path_cap, "%s", exr);
        FILE *f = fopen(txt, "r");
        if (f) {
            double secs = 0;
            unsigned long long paths = 0, c[4] = {0, 0, 0, 0};
            int ok = fscanf(f, "seconds %lf paths %llu surface_hits %llu back_hits %llu camera_back_hits %llu "
                               "back_paths %llu",
                            &secs, &paths, &c[0], &c[1], &c[2], &c[3]) == 6;
            fclose(f);
            sg_ref_result r = {0};
            sg_error ignored;
            if (ok && sg_image_read_exr(exr, &r.mean, &ignored) == SG_OK &&
                sg_image_read_exr(se, &r.std_error, &ignored) == SG_OK && r.mean.width == d.width &&
                r.mean.height == d.height && r.std_error.width == d.width && r.std_error.height == d.height) {
                r.seconds = secs;
                r.paths = paths;
                r.counts = (sg_ref_counts){.surface_hits = c[0], .back_hits = c[1], .camera_back_hits = c[2],
                                           .back_paths = c[3]};
                *out = r;
                *cached = 1;
                return SG_OK;
            }
            sg_ref_result_free(&r);
        }
    } else if (path && path_cap)
        path[0] = 0;
    sg_ref_result r = {0};
    sg_ref_desc rd = {.camera = d.camera, .width = d.width, .height = d.height, .spp = d.spp,
                      .max_depth = d.max_depth, .rr_depth = 3, .seed = d.seed, .pixel_centres = 1};
    sg_status st = sg_ref_render(w, &rd, &r, err);
    if (st != SG_OK)
        return st;
    if (d.cache_dir && sg_verify__make_dirs(d.cache_dir)) {
        sg_error werr;
        /* Coverage as alpha, as every EXR the project writes (the centre
         * rays: the paths all go through the centres). */
        float *alpha = NULL;
        sg_coverage_desc cd = {.camera = d.camera, .width = d.width, .height = d.height};
        int written = sg_coverage_render(w, &cd, &alpha, &werr) == SG_OK;
        r.mean.alpha = r.std_error.alpha = alpha; /* shared for the writes only */
        written = written && sg_image_write_exr(&r.mean, exr, &werr) == SG_OK &&
                  sg_image_write_exr(&r.std_error, se, &werr) == SG_OK;
        r.mean.alpha = r.std_error.alpha = NULL;
        sg_free(alpha);
        if (written) {
            char tmp[4200];
            snprintf(tmp, sizeof tmp, "%s.tmp%ld", txt, (long)getpid());
            FILE *f = fopen(tmp, "w");
            if (f) {
                int ok = fprintf(f,
                                 "seconds %.6f paths %llu surface_hits %llu back_hits %llu camera_back_hits %llu "
                                 "back_paths %llu\n",
                                 r.seconds, (unsigned long long)r.paths, (unsigned long long)r.counts.surface_hits,
                                 (unsigned long long)r.counts.back_hits,
                                 (unsigned long long)r.counts.camera_back_hits,
                                 (unsigned long long)r.counts.back_paths) > 0;
                ok = (fclose(f) == 0) && ok;
                if (!ok || rename(tmp, txt) != 0)
                    remove(tmp);
            }
        }
    }
    *out = r;
    *cached = 0;
    return SG_OK;
}
