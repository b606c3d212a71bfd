/* bake_job_int.h — the inside of a bake job, for bake_job.c and the
 * checkpoint code of bake_io.c only.
 *
 * Invariants (bake_job.c checks them with asserts, bake_io.c checks every
 * value read from a file against them):
 *  1. stage PHOTONS: pm holds blocks [0, pm.blocks) of the pass; nothing
 *     else has been computed;
 *  2. stage SITES, prepared: every sampled model's set holds its samples of
 *     levels 0 .. level, and sites.count <= set.count (the first
 *     sites.count have their rays traced); b's light holds the photon
 *     estimate (photon estimator) or zeros;
 *  3. stage GLOSSY: b's light is final; glossy_done <= set.count for every
 *     model with bins, whose bins of samples [0, glossy_done) are final;
 *  4. stage DONE: b is the finished bake (until finished off).
 */
#ifndef SG_BAKE_BAKE_JOB_INT_H
#define SG_BAKE_BAKE_JOB_INT_H

#include "bake/bake_comm.h"
#include "bake/bake_job.h"
#include "bake/photons.h"
#include "bake/samples.h"
#include "bake/transport.h"

/* One model's part of the job. */
typedef struct sg_bake_job_model {
    const sg_sites *ps;  /* the scene's sites, or &view                    */
    sg_sites view;       /* the scene's sites, unsampled = off_surface       */
    uint8_t *off_surface; /* per site: 1 = names no surface (transport.h
                            sg_transport_off_surface_sites); NULL: none   */
    float s0;            /* spacing of level 0; <= 0: every splat is a sample */
    int sampled;         /* the model has sample points                      */
    uint64_t key_base;   /* splats of the models before it: random streams   */
    sg_sample_set set;
    sg_site_data sites;
    float *e0;           /* 6 per splat: unshadowed irradiance, both sides   */
    uint32_t *nearest;   /* per splat: its nearest same-facing sample         */
    float *indirect;     /* 6 per sample: the sites' solved indirect light    */
    size_t glossy_done;  /* samples whose glossy bins are final               */
} sg_bake_job_model;

struct sg_bake_job {
    const sg_world *w;
    sg_bake_desc d;          /* resolved                                     */
    sg_bake *b;              /* the bake being made; NULL once finished      */
    sg_photon_map pm;        /* photon estimator, stage PHOTONS              */
    int pm_borrowed;         /* pm is the caller's (not freed here)          */
    size_t models;
    sg_bake_job_model *mw;   /* models entries                               */
    sg_bake_stage stage;
    int level;               /* SITES: the level being traced                */
    int prepared;            /* SITES: level-0 samples and e0 made           */
    sg_transport_stats ts;   /* of the last solve                            */
    double seconds[3];       /* wall time per stage, this process            */
    double shared_seconds;   /* of which the work not divided among ranks
                                (bake_comm.h), this process                 */
    sg_bake_comm comm;       /* the ranks sharing the work (bake_comm.h)     */
    int distributed;         /* comm was set: work in rounds over the ranks   */
};

/* For bake_io.c: a job of stage `stage` whose per-model state the caller
 * fills (sets, sites, glossy bins, the bake's light) before running it;
 * its models' spacing, e0 and key bases are made here as for a new job. */
sg_status sg_bake_job__new(const sg_world *w, const sg_bake_desc *d, sg_bake_stage stage, int level,
                           sg_bake_job **out, sg_error *err);

/* For sg_bake_create_from_photons: the job's photon pass is the caller's
 * complete map pm (shared, not copied: it must live until the job has run
 * past the photon stage). */
void sg_bake_job__borrow_photons(sg_bake_job *j, const sg_photon_map *pm);

#endif
