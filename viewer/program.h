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

/* Where the world comes from (render/world_file.h): --world FILE and
 * --if-stale, which every program that builds a world takes. */
typedef struct sg_prog_world {
    const char *path; /* --world: the world file; NULL: build it         */
    int if_stale;     /* --if-stale: build and rewrite path when it is
                         missing, stale or unreadable, instead of failing */
} sg_prog_world;

/* If argv[*i] is --world FILE or --if-stale, reads it into *wo (advancing
 * *i past a value) and returns 1; 0 for any other argument; -1 with err
 * set for a missing value. SG_PROG_WORLD_OPTIONS is their --help text. */
int sg_prog_world_option(int argc, char **argv, int *i, sg_prog_world *wo, sg_error *err);

#define SG_PROG_WORLD_OPTIONS                                                                                      \
    "World file (docs/world.md): the built models saved once (splatgi-world)\n"                                     \
    "  --world FILE.sgworld  load the models from FILE instead of building them; it\n"                              \
    "                      must be of this scene and its model files unchanged\n"                                  \
    "  --if-stale          with --world: build the models and (re)write FILE when it\n"                            \
    "                      is missing, of another scene, an input changed or it is damaged\n"

/* The world of sf. Without wo->path (wo may be NULL): the memory check
 * (app/preflight.h; skipped when the environment has
 * SPLATGI_NO_MEMORY_CHECK=1), then the build, saying each stage and every
 * note on stderr as it comes. extra_bytes: what the program adds (a bake's
 * photon records). With wo->path: loads that world file when it is fresh
 * (render/world_file.h); otherwise an error saying why, or with
 * wo->if_stale the build as above and the file written. */
sg_status sg_prog_build_world(const char *input, const sg_scene_file *sf, uint64_t extra_bytes,
                              const sg_prog_world *wo, sg_world **out, sg_error *err);

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

/* The scene file's "bake" options (io/scene_file.h sg_scene_bake) into d:
 * a ray cone given there (0 there: off); left as it is where the file
 * gives none. A program's own options override them. */
void sg_prog_bake_desc_from_scene(const sg_scene_file *sf, sg_bake_desc *d);

/* With the world built: bakes when plan->need (default parameters, a
 * progress line, the free space checked first), then loads the bake. */
sg_status sg_prog_bake_obtain(const sg_prog_bake *plan, const sg_scene_file *sf, const sg_world *w, sg_bake **out,
                              sg_error *err);

#endif
