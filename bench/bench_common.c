/* bench_common.c — scaffolding the benchmark programs share (see
 * bench_common.h). */
#include "bench_common.h"

#include <time.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/stat.h>
#include <stdarg.h>
#include <unistd.h>

#include <math.h>

#include "io/mesh.h"
#include "math/rng.h"

int bench_fail(const char *prog, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "%s: ", prog);
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\n");
    va_end(ap);
    return 1;
}

/* This file's own messages. */
#define fail(...) bench_fail("bench", __VA_ARGS__)

/* The first "model name" of /proc/cpuinfo, or "unknown". */
void bench_cpu_model(char *out, size_t cap)
{
    snprintf(out, cap, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "model name", 10) != 0)
            continue;
        const char *c = strchr(line, ':');
        if (!c)
            continue;
        c++;
        while (*c == ' ' || *c == '\t')
            c++;
        snprintf(out, cap, "%s", c);
        out[strcspn(out, "\r\n")] = '\0';
        break;
    }
    fclose(f);
}

/* mkdir -p. */
int bench_make_dirs(const char *path)
{
    char buf[4096];
    if (snprintf(buf, sizeof buf, "%s", path) >= (int)sizeof buf)
        return 0;
    for (char *p = buf + 1;; p++) {
        if (*p == '/' || *p == '\0') {
            char c = *p;
            *p = '\0';
            if (mkdir(buf, 0777) != 0 && errno != EEXIST)
                return 0;
            *p = c;
            if (c == '\0')
                break;
        }
    }
    return 1;
}

/* Writes `text` producers to path through a temporary file and rename. */
int bench_write_file(const char *path, writer_fn fn, const void *ctx)
{
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp%ld", path, (long)getpid()) >= (int)sizeof tmp)
        return fail("%s: path too long", path);
    FILE *f = fopen(tmp, "w");
    if (!f)
        return fail("%s: cannot open: %s", tmp, strerror(errno));
    fn(f, ctx);
    int bad = ferror(f);
    if (fclose(f) != 0 || bad) {
        remove(tmp);
        return fail("%s: write failed", tmp);
    }
    if (rename(tmp, path) != 0) {
        remove(tmp);
        return fail("%s: cannot rename to %s: %s", tmp, path, strerror(errno));
    }
    return 0;
}

/* A JSON string body: quotes, backslashes and control bytes escaped. */
int bench_json_escape(const char *s, char *out, size_t cap)
{
    size_t k = 0;
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        char tmp[8];
        int n = c == '"' || c == '\\' ? snprintf(tmp, sizeof tmp, "\\%c", c)
                : c < 0x20            ? snprintf(tmp, sizeof tmp, "\\u%04x", c)
                                      : snprintf(tmp, sizeof tmp, "%c", c);
        if (k + (size_t)n + 1 > cap)
            return 0;
        memcpy(out + k, tmp, (size_t)n);
        k += (size_t)n;
    }
    out[k] = '\0';
    return 1;
}

/* The files a cached reference depends on, by size and modification time
 * (sg_scene_file_hash covers paths only). */
uint64_t bench_mix_file(uint64_t key, const char *path)
{
    struct stat st;
    if (!path || stat(path, &st) != 0)
        return sg_mix64(key ^ 0x5bd1e995u);
    key = sg_mix64(key ^ (uint64_t)st.st_size);
    return sg_mix64(key ^ (uint64_t)st.st_mtime);
}

sg_status bench_place_mesh(const char *mesh_path, float length, sg_ground_placement *out, sg_error *err)
{
    sg_aabb b;
    sg_status st = sg_mesh_read_bounds(mesh_path, &b, err);
    if (st != SG_OK)
        return st;
    if (sg_mesh_ground_placement(b, length, out, NULL) != SG_OK)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: empty or degenerate bounds", mesh_path);
    return SG_OK;
}

double bench_cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double bench_load1(void)
{
    double l = NAN;
    FILE *f = fopen("/proc/loadavg", "r");
    if (f) {
        if (fscanf(f, "%lf", &l) != 1)
            l = NAN;
        fclose(f);
    }
    return l;
}

int bench_parse_long(const char *s, long lo, long hi, long *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return 0;
    *out = v;
    return 1;
}

int bench_parse_int(const char *s, long lo, long hi, int *out)
{
    long v;
    if (!bench_parse_long(s, lo, hi, &v))
        return 0;
    *out = (int)v;
    return 1;
}

void bench_load_avg(char *out, size_t cap)
{
    snprintf(out, cap, "unknown");
    FILE *f = fopen("/proc/loadavg", "r");
    if (!f)
        return;
    double a, b, c;
    if (fscanf(f, "%lf %lf %lf", &a, &b, &c) == 3)
        snprintf(out, cap, "%.2f %.2f %.2f", a, b, c);
    fclose(f);
}

const char *bench_rel_path(const char *p, char *buf, size_t cap)
{
    const char *s = strstr(p, "shared/data/");
    if (!s)
        return p;
    snprintf(buf, cap, "../%s", s);
    return buf;
}

void bench_csv_text(FILE *f, const char *s)
{
    if (!strpbrk(s, ",\"\n")) {
        fputs(s, f);
        return;
    }
    fputc('"', f);
    for (; *s; s++) {
        if (*s == '"')
            fputc('"', f);
        fputc(*s, f);
    }
    fputc('"', f);
}

bench_scene_desc bench_dragon_scene(const char *mesh, const char *envmap)
{
    return (bench_scene_desc){.mesh = mesh,
                              .envmap = envmap,
                              .length = BENCH_SCENE_LENGTH,
                              .view_dir = {0.6f, -0.35f, -1.0f},
                              .fov_deg = BENCH_SCENE_FOV_DEG,
                              .margin = 0.9f, /* < 1: the bounding sphere of a long model is loose */
                              .model_albedo = BENCH_SCENE_MODEL_ALBEDO,
                              .ground_albedo = BENCH_SCENE_GROUND_ALBEDO,
                              .max_depth = BENCH_SCENE_MAX_DEPTH};
}

sg_status bench_scene_setup(const bench_scene_desc *d, bench_scene *s, sg_error *err)
{
    sg_ground_placement pl;
    sg_status st = bench_place_mesh(d->mesh, d->length, &pl, err);
    if (st != SG_OK)
        return st;
    s->scale = pl.scale;
    s->translate = pl.translate;
    s->world_box = pl.placed;
    s->have_envmap = access(d->envmap, R_OK) == 0;
    return sg_camera_frame(s->world_box, d->view_dir, sg_v3(0, 1, 0), d->fov_deg, 1.0f, d->margin, &s->camera, err);
}

int bench_scene_json(const bench_scene_desc *d, const bench_scene *s, size_t points, char *out, size_t cap)
{
    char mesh[2048], env[2048], envpart[2200];
    if (!bench_json_escape(d->mesh, mesh, sizeof mesh) || !bench_json_escape(d->envmap, env, sizeof env))
        return 0;
    if (s->have_envmap)
        snprintf(envpart, sizeof envpart, "{\"path\": \"%s\"}", env);
    else
        snprintf(envpart, sizeof envpart, "{\"builtin\": \"sky\"}");
    const sg_camera *c = &s->camera;
    sg_vec3 look = sg_v3_add(c->eye, c->forward);
    const double ma = d->model_albedo, ga = d->ground_albedo;
    int n = snprintf(out, cap,
                     "{\"models\": ["
                     "{\"path\": \"%s\", \"points\": %zu,"
                     " \"transform\": {\"translate\": [%.9g, %.9g, %.9g], \"scale\": %.9g},"
                     " \"material\": {\"type\": \"lambert\", \"albedo\": [%g, %g, %g], \"use_point_colors\": false}},"
                     "{\"builtin\": \"ground\","
                     " \"material\": {\"type\": \"lambert\", \"albedo\": [%g, %g, %g], \"use_point_colors\": false}}],"
                     " \"envmap\": %s,"
                     " \"cameras\": [{\"name\": \"main\", \"eye\": [%.9g, %.9g, %.9g],"
                     " \"look\": [%.9g, %.9g, %.9g], \"up\": [0, 1, 0], \"fov_deg\": %g}],"
                     " \"render\": {\"max_depth\": %d}}",
                     mesh, points, (double)s->translate.x, (double)s->translate.y, (double)s->translate.z,
                     (double)s->scale, ma, ma, ma, ga, ga, ga, envpart, (double)c->eye.x, (double)c->eye.y,
                     (double)c->eye.z, (double)look.x, (double)look.y, (double)look.z, (double)d->fov_deg,
                     d->max_depth);
    return n > 0 && (size_t)n < cap;
}

uint64_t bench_ref_key(sg_scene_file *sf, int size, int spp, uint64_t seed, int max_depth, uint32_t version)
{
    sf->render.width = sf->render.height = size;
    sf->render.spp = spp;
    sf->render.seed = seed;
    sf->render.max_depth = max_depth;
    uint64_t key = sg_scene_file_hash(sf, SG_SCENE_HASH_ALL);
    key = bench_mix_file(key, sf->models[0].path);
    key = bench_mix_file(key, sf->env.path);
    return sg_mix64(key ^ version);
}

/* The three file names of a cached reference (bench_ref_cache_load). */
static int cache_paths(const char *base, char mean[4096], char se[4096], char note[4096])
{
    return snprintf(mean, 4096, "%s.exr", base) < 4096 && snprintf(se, 4096, "%s.stderr.exr", base) < 4096 &&
           snprintf(note, 4096, "%s.txt", base) < 4096;
}

int bench_ref_cache_load(const char *base, int size, sg_image *mean, sg_image *std_error, double *seconds,
                         uint64_t *paths)
{
    char mean_path[4096], se_path[4096], note_path[4096];
    memset(mean, 0, sizeof *mean);
    memset(std_error, 0, sizeof *std_error);
    if (!cache_paths(base, mean_path, se_path, note_path))
        return 0;
    FILE *note = fopen(note_path, "r");
    if (!note)
        return 0;
    double secs = 0;
    unsigned long long n = 0;
    int ok = fscanf(note, "seconds %lf paths %llu", &secs, &n) == 2;
    fclose(note);
    sg_error ignored;
    if (ok && sg_image_read_exr(mean_path, mean, &ignored) == SG_OK &&
        sg_image_read_exr(se_path, std_error, &ignored) == SG_OK && mean->width == size && mean->height == size &&
        std_error->width == size && std_error->height == size) {
        *seconds = secs;
        *paths = n;
        return 1;
    }
    sg_image_free(mean);
    sg_image_free(std_error);
    return 0;
}

void bench_ref_cache_store(const char *prog, const char *cache_dir, const char *base, const sg_image *mean,
                           const sg_image *std_error, double seconds, uint64_t paths)
{
    char mean_path[4096], se_path[4096], note_path[4096];
    sg_error werr;
    if (!cache_paths(base, mean_path, se_path, note_path))
        fprintf(stderr, "%s: warning: reference not cached: path too long\n", prog);
    else if (!bench_make_dirs(cache_dir))
        fprintf(stderr, "%s: warning: cannot create %s: %s\n", prog, cache_dir, strerror(errno));
    else if (sg_image_write_exr(mean, mean_path, &werr) != SG_OK || sg_image_write_exr(std_error, se_path, &werr) != SG_OK)
        fprintf(stderr, "%s: warning: reference not cached: %s\n", prog, werr.message);
    else {
        FILE *f = fopen(note_path, "w");
        int ok = f && fprintf(f, "seconds %.6f paths %llu\n", seconds, (unsigned long long)paths) >= 0;
        if (f && fclose(f) != 0)
            ok = 0;
        if (!ok)
            fprintf(stderr, "%s: warning: cannot write %s\n", prog, note_path);
    }
}
