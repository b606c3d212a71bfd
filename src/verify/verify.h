/* verify.h — the verification suite: speed against accuracy, and the
 * stability map (issue 6). The `splatgi-verify` program is its front end.
 *
 * What it does, by part (desc.parts):
 *   STABILITY  every stability case (verify/cases.h) x surface model (MLS,
 *              disks, the ISO octree: verify_int.h), each in its own child process with a time limit:
 *              hole rate, spill rate, normal error (verify/truth.h) of the
 *              primary view; the bake's lookup frame against the cached
 *              converged reference (verify/refcache.h): relMSE, energy
 *              ratio, p99, NaN/Inf counts of both images; the reference's
 *              energy against its clean twin's. A child that crashes, runs
 *              out of time, or yields a non-finite figure is flagged in the
 *              `status` column (ok, nan, timeout, crash, error).
 *   SURFACES   the main scene (the Stanford dragon on the built-in ground
 *              under courtyard.exr when ../shared/data has them, else the
 *              built-in bunny under the analytic sky; with `ci` always the
 *              bunny, without the ground) for each surface
 *              configuration (MLS / disks / ISO, kd-tree refinements,
 *              samples per cell, splat radius scale, ISO tolerance, ISO
 *              level of detail: the ISO rows trace camera rays to full
 *              depth except iso_lod1, the viewer's default of 1 pixel): one bake with fixed parameters;
 *              its lookup frame time and error against the reference of
 *              the default MLS surface; the direct renderer's frame time,
 *              per-ray traversal counters, and its difference from the
 *              default MLS surface's direct frame.
 *   BAKE       the default surface; bakes over photon count, gather k and
 *              direct-light samples (the sg_bake_desc fields): bake time,
 *              memory and error.
 *   SCALING    the main model alone at each of desc.sizes points under
 *              each surface model (its defaults): build
 *              time, memory (scene, bake, process RSS), direct frame time
 *              and per-ray counters (node steps, leaves, splats), bake time
 *              and lookup frame time.
 *   HEADLINE   each model (dragon, bunny, armadillo, Lucy: those present)
 *              with the best bake configuration found by BAKE (the fastest
 *              with relMSE <= 0.01, else the most accurate): fps, bake
 *              time, memory, error.
 *   GI         global illumination where it matters (verify/gi.c): concave
 *              scans seen close up (Lucy, the dragon, the armadillo under
 *              real maps, the room lit through its window; with `ci` the
 *              asset bunny), a ladder of bakes of both indirect estimators
 *              as error against CPU time on the default MLS surface, the
 *              budget against the reference, and the white furnace on the
 *              same scans, pixel by pixel. Then each close-up again with
 *              every model on the ISO and on the hybrid hierarchy (a
 *              point-cloud scan cannot be a hybrid: skipped, logged): its
 *              own reference, the default bake (and s2 64+128 on Lucy's
 *              torso and the room) against that reference (the error of
 *              the light: gi.csv reference "own") and against the MLS
 *              world's (plus the surface's geometric difference:
 *              reference "mls"), and the default bake's furnace on it
 *              (gi.csv and furnace.csv column `surface`).
 * Output, in desc.out_dir: stability.csv, surfaces.csv, bake.csv,
 * scaling.csv, headline.csv, gi.csv, furnace.csv, and stability.md,
 * headline.md, gi.md (each written
 * to a temporary name and renamed); one false-colour difference PNG per
 * measured run in desc.diff_dir. Charts are drawn from the CSV by
 * scripts/verify-charts.sh (gnuplot).
 *
 * Processes: STABILITY forks; it runs before any other part, so that the
 * parent has not started an OpenMP team when it forks.
 * Errors: SG_ERR_IO (cannot write the outputs), SG_ERR_INVALID_ARG, and
 * any error of the main scene's set-up. A flagged stability case is not an
 * error: *flagged counts them.
 */
#ifndef SG_VERIFY_VERIFY_H
#define SG_VERIFY_VERIFY_H

#include <stddef.h>
#include <stdio.h>

#include "core/error.h"

enum sg_verify_part {
    SG_VERIFY_STABILITY = 1u << 0,
    SG_VERIFY_SURFACES = 1u << 1,
    SG_VERIFY_BAKE = 1u << 2,
    SG_VERIFY_SCALING = 1u << 3,
    SG_VERIFY_HEADLINE = 1u << 4,
    SG_VERIFY_GI = 1u << 5,
    SG_VERIFY_ALL = 63u
};

#define SG_VERIFY_MAX_SIZES 16

typedef struct sg_verify_desc {
    unsigned parts;          /* sg_verify_part bits; 0 = all               */
    int ci;                  /* tiny sizes, bunny only: the CI sweep       */
    const char *out_dir;     /* CSV and Markdown; default "out/verify"     */
    const char *diff_dir;    /* difference images; default <out_dir>/diff  */
    const char *cache_dir;   /* reference cache; default "out/verify/cache" */
    const char *work_dir;    /* generated inputs; default "out/verify/work" */
    const char *data_dir;    /* real data; default SG_SHARED_DATA_DIR      */
    size_t sizes[SG_VERIFY_MAX_SIZES]; /* SCALING point counts; n_sizes 0 =
                                default 2k,8k,32k,128k,512k,1M (ci 2k,8k) */
    int n_sizes;
    double case_timeout_s;   /* per stability child; default 300 (ci 60)   */
    const char *only_case;   /* STABILITY: just this case; NULL = all      */
    FILE *log;               /* progress lines; NULL = silent             */
} sg_verify_desc;

typedef struct sg_verify_summary {
    int cases_run;           /* stability (case, model) children          */
    int flagged;             /* of those, status other than ok            */
    int rows;                /* CSV rows written over all tables          */
    double seconds;
} sg_verify_summary;

sg_status sg_verify_run(const sg_verify_desc *d, sg_verify_summary *summary, sg_error *err);

/* The names of the parts, for option parsing ("stability", "surfaces",
 * "bake", "scaling", "headline", "gi"); 0 for an unknown name. */
unsigned sg_verify_part_parse(const char *name);

#endif
