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
#include "io/image.h"
#include "io/mesh.h"
#include "io/scene_file.h"
#include "render/camera.h"
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

/* A whole decimal number in [lo, hi]: 1 and *out set, else 0 (trailing
 * characters, overflow and an empty string are errors). */
int bench_parse_long(const char *s, long lo, long hi, long *out);
int bench_parse_int(const char *s, long lo, long hi, int *out);

/* The first three fields of /proc/loadavg ("unknown" where unreadable). */
void bench_load_avg(char *out, size_t cap);

/* A path under the shared data folder as the docs name it, relative to
 * the checkout ("../shared/data/..."), in buf; other paths as they are. */
const char *bench_rel_path(const char *p, char *buf, size_t cap);

/* A CSV field: quoted when it holds a comma, quote or newline. */
void bench_csv_text(FILE *f, const char *s);

/* Where the benchmarks put a scanned mesh: sg_mesh_ground_placement
 * (io/mesh.h) of the mesh file's vertex box, `length` world units along its
 * longest side. SG_ERR_INVALID_ARG, naming the file, for an empty or
 * degenerate mesh; the mesh reader's errors otherwise. */
sg_status bench_place_mesh(const char *mesh_path, float length, sg_ground_placement *out, sg_error *err);

/* The key of a cached reference: the scene (all parts) with the
 * reference's size (square), spp, seed and depth set in sf->render, the
 * model and envmap files' sizes and times, and a version of the cache. */
uint64_t bench_ref_key(sg_scene_file *sf, int size, int spp, uint64_t seed, int max_depth, uint32_t version);

/* A path-traced reference cached as BASE.exr (the mean), BASE.stderr.exr
 * (its standard error) and BASE.txt ("seconds S paths N", written last:
 * with it, both images are complete). bench_ref_cache_load: 1 with the
 * images, seconds and paths when all three are there and the images are
 * size x size; else 0, nothing allocated. bench_ref_cache_store: writes
 * them; a failure is a warning naming prog on stderr (the cache only
 * saves time). */
int bench_ref_cache_load(const char *base, int size, sg_image *mean, sg_image *std_error, double *seconds,
                         uint64_t *paths);
void bench_ref_cache_store(const char *prog, const char *cache_dir, const char *base, const sg_image *mean,
                           const sg_image *std_error, double seconds, uint64_t paths);

/* The scene bench_ref and bench_bake share: the mesh placed on the
 * builtin ground (bench_place_mesh), framed by one camera from view_dir,
 * lit by the envmap file, or by the builtin sky where that file is
 * missing. */
typedef struct bench_scene_desc {
    const char *mesh, *envmap;
    float length;            /* world units along the mesh's longest side   */
    sg_vec3 view_dir;        /* the camera looks along it                   */
    float fov_deg;           /* vertical field of view                      */
    float margin;            /* sg_camera_frame's margin                    */
    float model_albedo, ground_albedo;
    int max_depth;           /* "render": {"max_depth"} of the scene file   */
} bench_scene_desc;

typedef struct bench_scene {
    float scale;          /* mesh units -> world                     */
    sg_vec3 translate;    /* after scaling: centred in x, z; y_min 0 */
    sg_aabb world_box;    /* the mesh's vertex box in world space    */
    sg_camera camera;     /* framing world_box (aspect 1)            */
    int have_envmap;      /* d->envmap exists                        */
} bench_scene;

/* The dragon scene of bench_ref and bench_bake: SCENE_LENGTH units long,
 * seen from (0.6, -0.35, -1) with a vertical field of view of FOV_DEG,
 * Lambert albedos 0.7 (the mesh) and 0.5 (the ground), paths of at most
 * 8 bounces (the path tracer's default). */
#define BENCH_SCENE_LENGTH 10.0f
#define BENCH_SCENE_FOV_DEG 40.0f
#define BENCH_SCENE_MODEL_ALBEDO 0.7f
#define BENCH_SCENE_GROUND_ALBEDO 0.5f
#define BENCH_SCENE_MAX_DEPTH 8
bench_scene_desc bench_dragon_scene(const char *mesh, const char *envmap);

sg_status bench_scene_setup(const bench_scene_desc *d, bench_scene *s, sg_error *err);

/* The scene file text with `points` samples of the mesh; 1 if it fit in
 * cap. Render settings other than max_depth are left to the caller (they
 * go into cache keys, not into the world). */
int bench_scene_json(const bench_scene_desc *d, const bench_scene *s, size_t points, char *out, size_t cap);

#endif
