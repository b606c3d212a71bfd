/* preflight.c — see preflight.h. */
#include "app/preflight.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include "io/pcd.h"
#include "io/ply.h"

#define MESH_DEFAULT_POINTS 250000u /* model_points.h */

static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), m = strlen(ext);
    return n > m && strcasecmp(path + n - m, ext) == 0;
}

/* Points a text cloud holds: its size over the length of its first point
 * line (lines of one file are alike). */
static uint64_t text_points(const char *path, uint64_t size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    char line[4096];
    uint64_t len = 0;
    while (fgets(line, sizeof line, f)) {
        const char *p = line;
        while (*p == ' ' || *p == '\t')
            p++;
        if (*p == '#' || *p == '\n' || *p == '\r' || (p[0] == '/' && p[1] == '/'))
            continue;
        len = strlen(line);
        break;
    }
    fclose(f);
    return len ? size / len + 1 : 0;
}

/* Splats of model m and the bytes of its file. */
static sg_status model_points(const sg_scene_model *m, uint64_t *points, uint64_t *file_bytes, sg_error *err)
{
    uint64_t asked = m->points.points;
    *file_bytes = 0;
    switch (m->kind) {
    case SG_SCENE_MODEL_GROUND: {
        uint64_t side = asked ? (uint64_t)(sqrt((double)asked) + 0.5) : 300;
        *points = side * side;
        return SG_OK;
    }
    case SG_SCENE_MODEL_SPHERE: *points = asked ? asked : 100000; return SG_OK;
    case SG_SCENE_MODEL_BUNNY: *points = asked ? asked : MESH_DEFAULT_POINTS; return SG_OK;
    case SG_SCENE_MODEL_FILE: break;
    default: *points = asked; return SG_OK;
    }
    struct stat st;
    if (stat(m->path, &st) != 0)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", m->path, strerror(errno));
    *file_bytes = (uint64_t)st.st_size;
    uint64_t mesh = asked ? asked : MESH_DEFAULT_POINTS;
    sg_status s = SG_OK;
    if (has_ext(m->path, ".ply")) {
        uint64_t v = 0, f = 0;
        s = sg_ply_read_counts(m->path, &v, &f, err);
        *points = f ? mesh : v;
    } else if (has_ext(m->path, ".pcd")) {
        s = sg_pcd_read_count(m->path, points, err);
    } else if (has_ext(m->path, ".obj")) {
        *points = mesh; /* faces or not: the file's vertices are in file_bytes */
    } else {
        *points = text_points(m->path, *file_bytes);
    }
    return s;
}

static uint64_t meminfo(const char *key)
{
    FILE *f = fopen("/proc/meminfo", "r");
    if (!f)
        return 0;
    char line[256];
    unsigned long long kb = 0;
    size_t n = strlen(key);
    while (fgets(line, sizeof line, f))
        if (strncmp(line, key, n) == 0 && sscanf(line + n, " %llu", &kb) == 1)
            break;
    fclose(f);
    return (uint64_t)kb * 1024u;
}

sg_status sg_preflight_estimate(const sg_scene_file *sf, uint64_t extra_bytes, sg_memory_estimate *out,
                                sg_error *err)
{
    sg_memory_estimate e = {0};
    uint64_t files = 0;
    for (size_t i = 0; i < sf->model_count; ++i) {
        uint64_t p = 0, fb = 0;
        sg_status s = model_points(&sf->models[i], &p, &fb, err);
        if (s != SG_OK)
            return s;
        e.points += p;
        files += fb;
    }
    e.bytes = e.points * SG_PREFLIGHT_BYTES_PER_POINT + files + extra_bytes;
    e.available = meminfo("MemAvailable:");
    e.total = meminfo("MemTotal:");
    if (!e.total) {
        long pages = sysconf(_SC_PHYS_PAGES), avail = sysconf(_SC_AVPHYS_PAGES), size = sysconf(_SC_PAGESIZE);
        e.total = pages > 0 && size > 0 ? (uint64_t)pages * (uint64_t)size : 0;
        e.available = avail > 0 && size > 0 ? (uint64_t)avail * (uint64_t)size : 0;
    }
    *out = e;
    return SG_OK;
}

static double gib(uint64_t b) { return (double)b / (1024.0 * 1024.0 * 1024.0); }

sg_status sg_preflight_memory(const char *name, const sg_memory_estimate *e, sg_error *err)
{
    if (!e->available || e->bytes <= e->available)
        return SG_OK;
    return sg_error_set(err, SG_ERR_NOMEM,
                        "%s: the scene needs about %.1f GiB (%llu splats x ~%u B at the peak, plus the model files), "
                        "but this machine has %.1f GiB available (%.1f GiB in all): lower the models' \"points\" "
                        "(or --points) or use a machine with more memory",
                        name, gib(e->bytes), (unsigned long long)e->points, SG_PREFLIGHT_BYTES_PER_POINT,
                        gib(e->available), gib(e->total));
}

sg_status sg_preflight_output(const char *path, uint64_t bytes, sg_error *err)
{
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (snprintf(dir, sizeof dir, "%.*s", slash == path ? 1 : (int)(slash - path), path) >= (int)sizeof dir)
        return sg_error_set(err, SG_ERR_IO, "%s: path too long", path);
    char probe[4200];
    snprintf(probe, sizeof probe, "%s/.splatgi-probe.XXXXXX", dir);
    int fd = mkstemp(probe);
    if (fd < 0)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot write in %s: %s", path, dir, strerror(errno));
    close(fd);
    unlink(probe);
    struct statvfs vs;
    if (bytes && statvfs(dir, &vs) == 0) {
        uint64_t free_bytes = (uint64_t)vs.f_bavail * (uint64_t)vs.f_frsize;
        if (free_bytes < bytes)
            return sg_error_set(err, SG_ERR_IO, "%s: needs at least %.1f MiB, %s has %.1f MiB free", path,
                                (double)bytes / 1048576.0, dir, (double)free_bytes / 1048576.0);
    }
    return SG_OK;
}

uint64_t sg_preflight_bake_bytes(uint64_t splats, uint64_t glossy_splats)
{
    /* E sections: 3 floats a splat; N sections of glossy models: a u32 a
     * splat; 4 KiB for the header, table and META. */
    return 12u * splats + 4u * glossy_splats + 4096u;
}
