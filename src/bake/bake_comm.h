/* bake_comm.h — the bake split over several processes (ranks), without
 * knowing how they talk.
 *
 * What it does: a bake job given a communicator (sg_bake_job_set_comm)
 * divides the expensive, independent work among the ranks and exchanges
 * the results, so that every rank ends with the whole bake, the same bits
 * as one process alone:
 *  - photon blocks (SG_BAKE_STAGE_PHOTONS), in rounds of `size` shares of
 *    consecutive blocks;
 *  - sample points whose sites' rays are traced (SG_BAKE_STAGE_SITES), in
 *    rounds of consecutive sample ranges, one range per rank;
 *  - glossy sample points (SG_BAKE_STAGE_GLOSSY), likewise.
 * Rank r takes the r-th consecutive share of a round, and the exchange
 * concatenates the shares in rank order, so what every rank holds after a
 * round is the prefix a single process holds after the same work: blocks
 * and samples in their own order, no floating-point sum across ranks
 * (each photon block, site and glossy point is computed alone, from
 * random streams keyed by its own index). The rest (refinement, transport
 * solve, interpolation, photon density estimate) is cheap next to the
 * rays and runs on every rank over the same data: same inputs, same bits.
 *
 * What it does NOT do: split the world (every rank holds all models, the
 * whole light and site data: memory per rank does not shrink), balance
 * load beyond equal shares, or survive a lost rank (the launcher ends the
 * job; docs/mpi.md).
 *
 * Cancel: the exchange also carries each rank's stop flag (its progress
 * callback asked to stop); when any rank asks, every rank stops after the
 * same round with the same state, so any rank's job is a valid checkpoint
 * (rank 0 writes it: precompute/splatgi-bake.c).
 *
 * The bytes exchanged are the ranks' native layout: every rank must run the
 * same build on the same kind of machine (the MPI program does).
 */
#ifndef SG_BAKE_BAKE_COMM_H
#define SG_BAKE_BAKE_COMM_H

#include <stddef.h>

#include "core/error.h"

typedef struct sg_bake_comm {
    int rank, size; /* this process, of size (>= 1); rank 0 reports       */
    /* Called by every rank in the same order with its own bytes (mine,
     * bytes; may be 0). On SG_OK *all holds every rank's bytes
     * concatenated in rank order (*all_bytes in all; allocated with
     * core/alloc.h, the caller frees it with sg_free; NULL when empty) and
     * *stop, which holds this rank's stop flag on entry, is 1 when any
     * rank's was. On an error the job fails with it. */
    sg_status (*exchange)(void *user, const void *mine, size_t bytes, void **all, size_t *all_bytes, int *stop,
                          sg_error *err);
    void *user; /* passed to exchange                                    */
} sg_bake_comm;

/* Share r of n items split among size ranks in order: [*lo, *hi), the
 * first n % size ranks one item more. */
static inline void sg_bake_comm_share(size_t n, int size, int r, size_t *lo, size_t *hi)
{
    size_t q = n / (size_t)size, extra = n % (size_t)size, ur = (size_t)r;
    *lo = ur * q + (ur < extra ? ur : extra);
    *hi = *lo + q + (ur < extra);
}

#endif
