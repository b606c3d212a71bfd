/* preflight.h — checks a program makes before the long work starts, so
 * that what would fail after minutes fails at once with the figure that
 * decides it.
 *
 *  - memory: the peak a world of this scene will take, estimated from its
 *    point counts (mesh samples asked for, the vertex count in a PLY or
 *    PCD header, a text cloud's size over its first line's length) times
 *    SG_PREFLIGHT_BYTES_PER_POINT, plus the model files themselves (read
 *    whole); refused above the memory available now (MemAvailable);
 *  - an output: its folder exists and takes a new file (one is created
 *    and removed), and holds at least the bytes the output needs;
 *  - a bake to load: its header against the scene (sg_bake_cache_fresh's
 *    checks), before the world is built.
 *
 * What it does NOT do: reserve anything; the checks can pass and the work
 * still fail if other programs take the memory or the disk meanwhile.
 */
#ifndef SG_APP_PREFLIGHT_H
#define SG_APP_PREFLIGHT_H

#include <stdint.h>

#include "core/error.h"
#include "io/scene_file.h"

/* Peak bytes of the process per point of the world, rounded up from the
 * maximum resident size of splatgi-render --model assets/bunny.ply (MLS
 * kd-tree with its refinements, the largest surface): 654 B at 0.25M
 * points, 677 B at 1M; docs/verify.md's scaling runs give 1.1-1.3 x
 * 400-500 B up to 24M points. */
#define SG_PREFLIGHT_BYTES_PER_POINT 700u

typedef struct sg_memory_estimate {
    uint64_t points;     /* splats of all models                          */
    uint64_t bytes;      /* estimated peak: points x BYTES_PER_POINT + files */
    uint64_t available;  /* memory available now (0: unknown)             */
    uint64_t total;      /* physical memory (0: unknown)                  */
} sg_memory_estimate;

/* The estimate for sf (extra_bytes added, e.g. a bake's photon records).
 * Errors: a model file that cannot be opened or whose header is bad
 * (the readers' messages). */
sg_status sg_preflight_estimate(const sg_scene_file *sf, uint64_t extra_bytes, sg_memory_estimate *out,
                                sg_error *err);

/* SG_ERR_NOMEM when e->bytes exceeds e->available, naming both (and the
 * points) and what to lower; SG_OK when it fits or nothing is known. */
sg_status sg_preflight_memory(const char *name, const sg_memory_estimate *e, sg_error *err);

/* The folder of path takes a new file, and its file system has at least
 * bytes free (statvfs, for unprivileged users). SG_ERR_IO naming the
 * folder and the figures. */
sg_status sg_preflight_output(const char *path, uint64_t bytes, sg_error *err);

/* Bytes a bake of these splat counts takes at least (irradiance of every
 * splat, the sample-point map of glossy models; the bins themselves
 * depend on the sample points and are not counted), for
 * sg_preflight_output. */
uint64_t sg_preflight_bake_bytes(uint64_t splats, uint64_t glossy_splats);

#endif
