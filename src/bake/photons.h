/* photons.h — the light-tracing pass of the bake: photons from the
 * environment map, traced through every model's hierarchy with any number
 * of bounces, recorded where they land.
 *
 * A photon leaves the envmap in a direction drawn in proportion to the
 * map's luminance (sg_envmap_sample), from a uniform point of the disk that
 * covers the scene's bounding sphere across that direction. With N photons
 * its flux is Phi = L(d) pi R^2 / (pdf(d) N): the envmap's radiance through
 * that disk, shared out. At each surface it reaches it is recorded (with the
 * direction it came from), then it scatters by BSDF sampling with Russian
 * roulette, so direct light, shadows, inter-reflection and colour bleeding
 * all come out of one pass.
 *
 * Determinism: photon i uses sg_rng_float(seed, i, bounce, dim); photons are
 * traced in blocks of SG_PHOTON_BLOCK and the blocks' records concatenated
 * in block order, so the map is the same for any thread count, and the same
 * whether the blocks were traced in one call or in several (a map holding
 * blocks [0, k) extended by [k, n) equals the map of one pass over [0, n),
 * bit for bit).
 *
 * Progress and cancel: a map always holds a contiguous prefix of blocks,
 * [0, map->blocks). sg_photons_trace_more extends it; when the progress
 * callback asks to stop, the blocks already running finish, no new block
 * starts, and the map keeps the longest completed prefix, ready to be
 * extended later or saved as a checkpoint (bake/bake_io.h). Walkthrough of
 * a pass in chunks, as precompute/splatgi-bake.c does it:
 *     sg_photon_map m = {0};                   (or a loaded checkpoint)
 *     size_t n = sg_photon_block_count(&d);
 *     while (m.blocks < n) {
 *         size_t last = m.blocks + chunk < n ? m.blocks + chunk : n;
 *         st = sg_photons_trace_more(w, &d, last, &m, &err);
 *         if (st == SG_ERR_CANCELLED) { save m as a checkpoint; stop }
 *         if (st != SG_OK) fail;
 *     }
 *     sg_photon_map_free(&m);
 */
#ifndef SG_BAKE_PHOTONS_H
#define SG_BAKE_PHOTONS_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "render/world.h"

#define SG_PHOTON_BLOCK 4096

/* Progress report: done_photons of total_photons are traced (counting the
 * blocks already in the map). Return 0 to go on, nonzero to cancel. */
typedef int (*sg_photon_progress_fn)(void *user, size_t done_photons, size_t total_photons);

enum sg_photon_flags {
    /* Record only where a photon lands after at least one bounce: the
     * indirect light, when the direct light is computed another way
     * (the sample sites, bake/transport.h). The photon is still traced
     * from the envmap. */
    SG_PHOTONS_INDIRECT_ONLY = 1u << 0
};

typedef struct sg_photon_desc {
    size_t count;     /* photons shot; default 1,000,000; at most 2^34   */
    uint64_t seed;    /* default 1                                       */
    int max_depth;    /* surface interactions per photon; default 8      */
    int rr_depth;     /* Russian roulette from this bounce; default 2    */
    int threads;      /* 0 = OpenMP default                              */
    uint32_t flags;   /* sg_photon_flags                                  */
    /* Optional. Called only on the thread that called the trace function
     * (OpenMP thread 0 of the pass: never two calls at once, so it needs
     * no lock), between two blocks, when at least progress_seconds passed
     * since its last call; and once more when the call's blocks are all
     * done. It must not call back into the trace. Nonzero cancels. */
    sg_photon_progress_fn progress;
    void *progress_user;       /* passed to progress                     */
    double progress_seconds;   /* least time between calls; default 0.25;
                                  < 0: after every block thread 0 ends   */
} sg_photon_desc;

/* Photon records, structure of arrays; record j landed at p with the
 * surface normal n (facing the side it arrived from), coming from
 * direction w (unit, pointing away from the surface), carrying flux phi
 * (RGB, watts in the scene's units), on model `model`. */
typedef struct sg_photon_map {
    size_t count;
    float *px, *py, *pz;
    float *nx, *ny, *nz;
    float *wx, *wy, *wz;
    float *fr, *fg, *fb;
    uint32_t *model;
    size_t shot;          /* photons emitted: those of blocks [0, blocks) */
    double seconds;       /* wall time of the passes, summed              */
    sg_ray_stats rays;    /* summed over blocks [0, blocks)               */
    size_t blocks;        /* the records are those of blocks [0, blocks)  */
    size_t capacity;      /* elements allocated per array (>= count)      */
} sg_photon_map;

/* d with every zero field replaced by its default (d may be NULL). */
sg_photon_desc sg_photon_desc_resolve(const sg_photon_desc *d);

/* Blocks in a pass of d's photon count (after defaults). */
size_t sg_photon_block_count(const sg_photon_desc *d);

/* Extends m, which holds blocks [0, m->blocks) of the pass d describes (a
 * zeroed map holds none), with blocks [m->blocks, last_block). m must come
 * from passes with the same world and the same d except threads and the
 * progress fields; the caller checks that (the checkpoint's parameter
 * hash). Arrays grow geometrically, so calling this per chunk is cheap;
 * scratch memory is about the records of the blocks traced in this call.
 * Returns:
 *  SG_OK              m holds blocks [0, last_block);
 *  SG_ERR_CANCELLED   the progress callback asked to stop: m holds the
 *                     longest completed prefix [0, m->blocks), m->blocks <=
 *                     last_block (possibly all of them), valid to extend;
 *  SG_ERR_INVALID_ARG last_block < m->blocks or past the pass, too many
 *                     photons, a scene with no extent; m unchanged;
 *  SG_ERR_NOMEM       m unchanged.
 * Thread-safety: m is used by this call alone; the world is only read. */
sg_status sg_photons_trace_more(const sg_world *w, const sg_photon_desc *d, size_t last_block, sg_photon_map *m,
                                sg_error *err);

/* The whole pass into *out (which it overwrites without freeing). Also on
 * SG_ERR_CANCELLED *out is written: the completed prefix, as above. */
sg_status sg_photons_trace(const sg_world *w, const sg_photon_desc *d, sg_photon_map *out, sg_error *err);

/* For the distributed bake (bake/bake_comm.h): blocks [first_block,
 * last_block) of the pass traced alone into *out (overwritten without
 * freeing): out->blocks = last_block, its records and rays those of the
 * range only, a piece for sg_photon_map_append_packed. No progress calls;
 * errors as sg_photons_trace_more. */
sg_status sg_photons_trace_range(const sg_world *w, const sg_photon_desc *d, size_t first_block,
                                 size_t last_block, sg_photon_map *out, sg_error *err);

/* A piece made by sg_photons_trace_range as bytes in this build's native
 * layout (u64 first and last block, u64 records, the 6 ray counters, then
 * the 13 arrays); *buf is allocated here (sg_free). */
sg_status sg_photon_map_pack(const sg_photon_map *piece, size_t first_block, void **buf, size_t *bytes,
                             sg_error *err);

/* Appends the piece packed at buf (at most `bytes` bytes: pieces may
 * follow) to m, whose next block must be the piece's first; *used gets its
 * length. The result equals the map traced in one pass (invariant 2 of
 * photons.c). SG_ERR_CORRUPT for a piece that does not fit its counts or
 * does not continue m; m unchanged then. d: the pass (for m->shot). */
sg_status sg_photon_map_append_packed(sg_photon_map *m, const sg_photon_desc *d, const void *buf, size_t bytes,
                                      size_t *used, sg_error *err);

/* Bytes a map of count records takes (the 13 arrays). */
size_t sg_photon_map_bytes(size_t count);

/* Frees the arrays and zeroes *m; NULL and zeroed maps are fine. */
void sg_photon_map_free(sg_photon_map *m);

#endif
