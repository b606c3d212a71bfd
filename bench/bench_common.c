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
