/* bake_job.h — a bake in steps: progress, cancel, checkpoint and resume.
 *
 * What it does: runs the bake's pipeline (bake.c describes it) as a job
 * that reports progress between blocks of work and stops, when asked,
 * within a block (a few milliseconds to a second), keeping every finished
 * block; a stopped job can be saved as a checkpoint (bake_io.h:
 * sg_bake_job_save) and later loaded and continued. The finished bake is
 * the same, bit for bit, whether the job ran straight through, was
 * stopped and continued, saved and loaded in between, or ran on any
 * number of threads: sg_bake_create is a job run to the end.
 *
 * Stages, in order (a stage with nothing to do is skipped):
 *   SG_BAKE_STAGE_PHOTONS  the photon pass (SG_BAKE_INDIRECT_PHOTONS only),
 *                          in blocks of SG_PHOTON_BLOCK photons
 *   SG_BAKE_STAGE_SITES    the rays of the sample sites, level by level of
 *                          refinement (progress.level), in blocks of
 *                          sample points; then the transport solve and the
 *                          interpolation to every splat (not interruptible:
 *                          a second or two for a million splats)
 *   SG_BAKE_STAGE_GLOSSY   the glossy bins of glossy models, in blocks of
 *                          sample points
 *   SG_BAKE_STAGE_DONE
 *
 * Walkthrough, as precompute/splatgi-bake.c uses it:
 *     sg_bake_job *j;
 *     sg_bake_job_create(w, &desc, &j, &err);     (or sg_bake_job_load)
 *     st = sg_bake_job_run(j, on_progress, user, &err);
 *     if (st == SG_ERR_CANCELLED) sg_bake_job_save(j, "x.sgbake.ckpt", hash, &err);
 *     else if (st == SG_OK) sg_bake_job_finish(j, &bake, &err);
 *     sg_bake_job_destroy(j);
 *
 * Ownership: the job keeps a pointer to the world, which must outlive it
 * and not change. Thread-safety: a job is used by one thread at a time
 * (its run uses OpenMP inside).
 */
#ifndef SG_BAKE_BAKE_JOB_H
#define SG_BAKE_BAKE_JOB_H

#include <stddef.h>

#include "bake/bake.h"
#include "bake/bake_comm.h"
#include "core/error.h"
#include "render/world.h"

typedef struct sg_bake_job sg_bake_job; /* opaque */

typedef enum sg_bake_stage {
    SG_BAKE_STAGE_PHOTONS = 0,
    SG_BAKE_STAGE_SITES = 1,
    SG_BAKE_STAGE_GLOSSY = 2,
    SG_BAKE_STAGE_DONE = 3
} sg_bake_stage;

typedef struct sg_bake_progress {
    sg_bake_stage stage;
    int level;          /* SITES: the refinement level being traced       */
    size_t done, total; /* units of the stage so far: photons (PHOTONS),
                           sample points (SITES, of this level; GLOSSY,
                           glossy ones)                                  */
} sg_bake_progress;

/* Called on the thread that called sg_bake_job_run, between blocks, at
 * most every progress_seconds (bake desc: photons.progress_seconds) and
 * once at the end of each stage or level; nonzero asks the job to stop. It
 * must not call back into the job. */
typedef int (*sg_bake_progress_fn)(void *user, const sg_bake_progress *p);

/* A job for world w and parameters d (resolved here). Checks the
 * parameters (glossy resolution, photon count); nothing is traced yet. */
sg_status sg_bake_job_create(const sg_world *w, const sg_bake_desc *d, sg_bake_job **out, sg_error *err);

/* Runs the remaining stages. SG_OK: done (sg_bake_job_finish may be
 * called); SG_ERR_CANCELLED: progress asked to stop; the job holds every
 * finished block and may be run again, saved, or destroyed; other
 * errors: the job is unusable (destroy it). progress may be NULL. */
sg_status sg_bake_job_run(sg_bake_job *j, sg_bake_progress_fn progress, void *user, sg_error *err);

/* Where the job stands. */
sg_bake_progress sg_bake_job_progress(const sg_bake_job *j);

/* The finished bake (after sg_bake_job_run returned SG_OK), moved out of
 * the job: *out is the caller's (sg_bake_destroy). SG_ERR_INVALID_ARG if
 * the job is not done or was finished already. */
sg_status sg_bake_job_finish(sg_bake_job *j, sg_bake **out, sg_error *err);

/* Splits the job's remaining work among c->size ranks (bake_comm.h):
 * every rank runs its own job of the same world, parameters and state
 * (created, or loaded from the same checkpoint) with the same c->size and
 * its own c->rank, and calls sg_bake_job_run at the same time; each ends
 * with the same bake and the same progress, bit for bit, as one job alone.
 * Progress is reported on every rank (a program prints rank 0's). c is
 * copied; c->user must outlive the job's runs. Also for c->size == 1. */
void sg_bake_job_set_comm(sg_bake_job *j, const sg_bake_comm *c);

/* NULL is a no-op. */
void sg_bake_job_destroy(sg_bake_job *j);

/* The parameters of the job, resolved. */
sg_bake_desc sg_bake_job_desc(const sg_bake_job *j);

#endif
