/* bake_cache.h — where a program keeps the bake of the scene it shows,
 * and whether the one there is up to date, told from the file's header
 * and its age alone (before the world is built).
 *
 * Path: <folder of the output>/<stem of the scene or model file>.sgbake:
 * `splatgi-view scan.ply` uses out/scan.sgbake, `splatgi-render
 * examples/bunny_sky.json --out out/f.png` out/bunny_sky.sgbake (the bake
 * scripts/run-default.sh makes).
 *
 * Up to date: the file opens as a finished bake (magic, version, header and
 * table checksums: bake/bake_file.h) made for this scene (scene hash), by
 * this build's estimators (the parameters in its META section hash to the
 * header's parameter hash; any parameters are fine: a bake made with more
 * photons is no reason to bake again), and is newer than the scene's model
 * and envmap files (the scene hash names files, not their contents).
 *
 * Errors: SG_ERR_INVALID_ARG for a path that does not fit the buffer.
 */
#ifndef SG_APP_BAKE_CACHE_H
#define SG_APP_BAKE_CACHE_H

#include <stddef.h>

#include "core/error.h"
#include "io/scene_file.h"

/* The bake path for input (a scene or model file) beside output (a file;
 * NULL or "": the folder "out"). */
sg_status sg_bake_cache_path(const char *input, const char *output, char *buf, size_t cap, sg_error *err);

/* 1 when the bake at path is up to date for sf (see above); 0 with *why
 * ("no bake yet", "made for another scene", "older than scan.ply", the
 * reader's message for a damaged file, ...) otherwise. */
int sg_bake_cache_fresh(const char *path, const sg_scene_file *sf, char *why, size_t why_cap);

#endif
