/* bench_common.h — scaffolding the benchmark programs share: the machine
 * line, output folders, files written whole (temporary name, then
 * rename), JSON strings, a cache key over a file's contents, and where a
 * scanned mesh is placed in the benchmark scenes. */
#ifndef SG_BENCH_COMMON_H
#define SG_BENCH_COMMON_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "core/error.h"
#include "io/mesh.h"
#include "math/vec3.h"

/* A width x height frame cut into size x size tiles, numbered row by row
 * (the last row and column may be partial): the frames' parallel schedule,
 * one tile per OpenMP iteration. */
typedef struct bench_tiles {
    int width, height, size;
    int per_row, count;
} bench_tiles;

/* Pixels [x0, x1) x [y0, y1) of one tile. */
typedef struct bench_rect {
    int x0, y0, x1, y1;
} bench_rect;

static inline bench_tiles bench_tiles_of(int width, int height, int size)
{
    bench_tiles t = {width, height, size, (width + size - 1) / size, 0};
    t.count = t.per_row * ((height + size - 1) / size);
    return t;
}

static inline bench_rect bench_tile(const bench_tiles *t, int i)
{
    bench_rect r = {(i % t->per_row) * t->size, (i / t->per_row) * t->size, 0, 0};
    r.x1 = r.x0 + t->size < t->width ? r.x0 + t->size : t->width;
    r.y1 = r.y0 + t->size < t->height ? r.y0 + t->size : t->height;
    return r;
}

/* "prog: message" on stderr; returns 1, the programs' failure value
 * (so `return bench_fail(...)` ends main). */
int bench_fail(const char *prog, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* The CPU model from /proc/cpuinfo ("unknown" if absent). */
void bench_cpu_model(char *out, size_t cap);

/* CPU seconds of this process, all its threads (CLOCK_PROCESS_CPUTIME_ID):
 * unlike wall time, not inflated by other work sharing the cores. */
double bench_cpu_seconds(void);

/* The 1-minute load average (/proc/loadavg), NaN where unreadable:
 * others' work on the cores, printed beside the figures. */
double bench_load1(void);

/* mkdir -p; 1 on success. */
int bench_make_dirs(const char *path);

/* Writes a file through fn(f, ctx) to a temporary name and renames it
 * into place; 0 on success, 1 (after a message on stderr) on failure, with
 * nothing left behind. */
typedef void (*writer_fn)(FILE *f, const void *ctx);
int bench_write_file(const char *path, writer_fn fn, const void *ctx);

/* s as the inside of a JSON string; 1 if it fit in cap. */
int bench_json_escape(const char *s, char *out, size_t cap);

/* Mixes the size and modification time of the file at path into key (a
 * cache key). */
uint64_t bench_mix_file(uint64_t key, const char *path);

/* Where the benchmarks put a scanned mesh: sg_mesh_ground_placement
 * (io/mesh.h) of the mesh file's vertex box, `length` world units along its
 * longest side. SG_ERR_INVALID_ARG, naming the file, for an empty or
 * degenerate mesh; the mesh reader's errors otherwise. */
sg_status bench_place_mesh(const char *mesh_path, float length, sg_ground_placement *out, sg_error *err);

#endif
