/* program.h — what the four programs (splatgi-view, -render, -ref, -bake)
 * share beyond the library: reading a scene or a model file, building the
 * world with a progress line per stage, finding or making the bake the
 * scene needs, reporting on stderr. Linked into the programs only (CMake
 * target splatgi_program): the library itself never prints.
 */
#ifndef SG_PROGRAM_H
#define SG_PROGRAM_H

#include <stdint.h>

#include "app/model_scene.h"
#include "bake/bake.h"
#include "core/error.h"
#include "io/scene_file.h"
#include "render/world.h"

/* The program's name for messages ("splatgi-view"); call first. */
void sg_prog_init(const char *name);

/* "<name>: <message>" on stderr. */
void sg_prog_say(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

/* A scene file, or the scene made for a model file (app/model_scene.h,
 * md->model set here); written to write_scene when given. */
sg_status sg_prog_load_scene(const char *input, sg_model_scene_desc *md, const char *write_scene,
                             sg_scene_file *sf, sg_error *err);

/* The memory check (app/preflight.h; skipped when the environment has
 * SPLATGI_NO_MEMORY_CHECK=1), then the world, saying each stage and every
 * note on stderr as it comes. extra_bytes: what the program adds (a bake's
 * photon records). */
sg_status sg_prog_build_world(const char *input, const sg_scene_file *sf, uint64_t extra_bytes, sg_world **out,
                              sg_error *err);

/* An output about to be written: its folder is made when missing (one
 * level: "out" for out/frame.png, not a whole path), then checked for
 * taking a new file (app/preflight.h), before the work starts. */
sg_status sg_prog_check_output(const char *path, sg_error *err);

/* The bake a program shows: --bake FILE (explicit: it must be a fresh bake
 * of this scene) or the cache beside the output (app/bake_cache.h),
 * checked from its header before the world is built. */
typedef struct sg_prog_bake {
    char path[4200];
    int explicit_path; /* given by --bake                          */
    int need;          /* to be made (cache missing or stale)       */
    char why[600];     /* why it is made again                      */
} sg_prog_bake;

/* Decides path and need (before the world). An explicit bake that is not
 * fresh is an error here, naming why; a stale cache is checked for being
 * writable. */
sg_status sg_prog_bake_plan(const char *input, const char *output, const char *explicit_bake,
                            const sg_scene_file *sf, sg_prog_bake *plan, sg_error *err);

/* With the world built: bakes when plan->need (default parameters, a
 * progress line, the free space checked first), then loads the bake. */
sg_status sg_prog_bake_obtain(const sg_prog_bake *plan, const sg_scene_file *sf, const sg_world *w, sg_bake **out,
                              sg_error *err);

#endif
