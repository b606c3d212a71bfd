/* bake_io.h — bakes and bake checkpoints (stopped bake jobs) in .sgbake files.
 *
 * What it does: writes a finished bake (sg_bake_save) or the state of a
 * stopped bake job (sg_bake_job_save: a checkpoint) into the .sgbake container
 * (bake/bake_file.h: checksummed sections, written to a temporary file and
 * renamed into place, so a crash or Ctrl-C never leaves half a file), and
 * reads them back with every value checked against the world it is for.
 * What it does NOT do: hash the scene (the caller passes
 * sg_scene_file_hash(sf, SG_SCENE_HASH_BAKE)), store the world, or store
 * anything that depends on time or thread count: the bytes of a bake file
 * are a function of the scene hash, the parameters and the records only,
 * so an interrupted-and-resumed bake compares equal (cmp) to one run
 * straight through.
 *
 * Header hashes: scene hash = the caller's; parameter hash =
 * sg_bake_param_hash(desc) (bake.h). Loading a bake or a checkpoint made
 * for another scene fails in sg_bake_file_open with both hashes named.
 *
 * Sections of a bake (flags 0):
 *   META  U64 x 28  the parameters and figures, layout below
 *   CNTS  U64 x M   splats per model, M = number of models
 *   SCNT  U64 x M   sample points per model (bake/samples.h)
 *   GRES  U64 x M   glossy bins per side per model, 0: no bins
 *   Emmm  F32 x 12n model mmm's light, SG_BAKE_SPLAT_FLOATS per splat (per
 *                   side: visibility ratio RGB, indirect irradiance RGB,
 *                   W/m^2; bake.h), in the
 *                   order of sg_scene_sites(sg_world_scene(w, m)); mmm is
 *                   the model index in 3 upper-case hex digits: "E000",
 *                   "E001", ... "E00A"; at most SG_BAKE_IO_MAX_MODELS models
 *   for each model mmm with GRES > 0 (R = GRES, P = SCNT), after its Emmm:
 *   Pmmm  U32 x P   the splat of each glossy sample point (< n)
 *   Nmmm  U32 x n   each splat's sample point (< P)
 *   Gmmm  F16 x 3 P R^2  the bins, sample point by sample point, bin
 *                   (i, j) at 3 (j R + i), RGB (bake/glossy.h), finite >= 0
 *   (a file holds at most SG_BAKE_MAX_SECTIONS sections in all)
 * Sections of a checkpoint (flags SG_BAKE_FLAG_CHECKPOINT), a stopped bake
 * job (bake_job.h; mmm the model index in 3 hex digits as above):
 *   META  U64 x 28  as for a bake; in stage PHOTONS [8] says which photon
 *                   blocks are done: the records are those of blocks
 *                   [0, META[8]) exactly
 *   JOBS  U64 x (4 + 3 M)  stage (sg_bake_stage), refinement level being
 *                   traced, level-0 samples made (0/1), M; then per model:
 *                   sample points, sample points whose sites are traced,
 *                   sample points whose glossy bins are final
 *   stage PHOTONS:
 *   PHPX PHPY PHPZ  F32 x R each: record positions (world space)
 *   PHNX PHNY PHNZ  F32 x R: normals
 *   PHWX PHWY PHWZ  F32 x R: incoming directions
 *   PHFR PHFG PHFB  F32 x R: flux, RGB
 *   PHMD            U32 x R: model index
 *   stages SITES and GLOSSY, per model mmm:
 *   Emmm  F32 x 12n the light per splat so far (the photon estimate or 0
 *                   in SITES; final in GLOSSY)
 *   Smmm, Lmmm  U32, U8 x P  each sample point's splat and level (once the
 *                   level-0 samples are made)
 *   stage SITES, G = the traced sample points:
 *   Rmmm, Ummm  F32 x 6G   visibility ratio, unshadowed irradiance per site
 *   Qmmm, Dmmm  F32 x 2G   ratio's standard error, harmonic mean distance
 *   Fmmm  U64 x (2G + 1)  hits of site i: [F[i], F[i+1])
 *   Hmmm, Mmmm, Kmmm  U32, U32, F32 x F[2G]  each hit's splat, model << 1 |
 *                   side, weight (transport.h)
 *   stage GLOSSY:
 *   Gmmm  F16 x 3 R^2 D  the final bins of the first D sample points
 * META, element i (u64; floats as their bits in the low 32 bits):
 *    0 layout version, 4         8 photon blocks done
 *    1 photon count              9 photons shot (those of the done blocks)
 *    2 seed                     10 photon records R
 *    3 max depth                11 models
 *    4 Russian roulette depth   12 splats, all models (0 in a checkpoint)
 *    5 k                        13..18 ray stats: rays, nodes, leaves,
 *    6 normal_cos (f32 bits)           isects, splats, hits
 *    7 SG_PHOTON_BLOCK          19 direct samples per sample point
 *                                  (int64; -1: none, photons carry it)
 *                               20 sample spacing (f32 bits; 0 from the
 *                                  material, -1 every splat)
 *                               21 glossy bins per side (0: from the
 *                                  roughness)
 *                               22 glossy rays per sample point
 *                               23 sample points, all models (0 in a
 *                                  checkpoint)
 *                               24 indirect estimator (sg_bake_indirect)
 *                               25 gather rays per sample site
 *                               26 refinement levels (int64; -1 none)
 *                               27 ray cone (f32 bits of
 *                                  sg_bake_desc.ray_cone; 0: off,
 *                                  as every bake before the option)
 * Element 0 is the META layout: 4. Older layouts (2: before sample points
 * and glossy bins; 3: one irradiance per splat, before light per side and
 * the transport solve) are refused with SG_ERR_UNSUPPORTED and a message to
 * bake again: their values mean something else.
 * Elements 1..7, 19..22 and 24..27 hash to the header's parameter hash
 * (checked on load); 27 only when it is not 0, so a bake without the ray
 * cone keeps the hash (and bytes) it had before the option. A build from
 * before the option reads a file with a ray cone as a hash mismatch
 * (SG_ERR_CORRUPT), never as a bake at full detail.
 *
 * Errors (messages begin with the path):
 *  SG_ERR_IO, SG_ERR_CORRUPT, SG_ERR_UNSUPPORTED  from bake_file.h, and
 *    SG_ERR_CORRUPT for a META that contradicts the header or itself, a
 *    value that is not finite or is negative ("x.sgbake: model 0, splat
 *    17: irradiance is nan"; "x.sgbake: section G000: sample point 3,
 *    bin 41: value is not finite"), an index out of range ("section N000:
 *    splat 17 names sample point 4294967295 of 212"), a record on a model
 *    the world lacks;
 *  SG_ERR_INVALID_ARG  another scene (bake_file.h's message); a model or
 *    splat count that differs from the world ("x.sgbake: model 1 has 30000
 *    light sites in the bake, 31000 in the scene"); a checkpoint given as a bake
 *    or the other way round; a checkpoint made with other parameters
 *    (both sets printed);
 *  SG_ERR_NOMEM.
 * Out-parameters are written only on SG_OK; a failed save leaves any file
 * already at path as it was.
 *
 * Thread-safety: no shared state; distinct paths may be used concurrently.
 */
#ifndef SG_BAKE_BAKE_IO_H
#define SG_BAKE_BAKE_IO_H

#include <stdint.h>

#include "bake/bake.h"
#include "bake/bake_file.h"
#include "bake/bake_job.h"
#include "bake/photons.h"
#include "core/error.h"
#include "render/world.h"

#define SG_BAKE_IO_MAX_MODELS 4094u /* "E000".."EFFD": 4096 sections minus META and CNTS */
#define SG_BAKE_META_COUNT 28u      /* u64 elements of META                          */

/* Writes b to path atomically. */
sg_status sg_bake_save(const sg_bake *b, const char *path, uint64_t scene_hash, sg_error *err);

/* Reads the bake at path for world w: checks scene_hash, that the file is a
 * finished bake, that its model and splat counts are w's, and every value.
 * *out: release with sg_bake_destroy. */
sg_status sg_bake_load(const char *path, const sg_world *w, uint64_t scene_hash, sg_bake **out, sg_error *err);

/* The parameters the bake or checkpoint f (opened from path) was made with:
 * its META section read and checked, and its parameter hash equal to the
 * header's. SG_ERR_UNSUPPORTED for a META layout of another splatgi (an
 * older estimator: bake again), SG_ERR_CORRUPT otherwise. For caches that
 * decide whether a file on disk is still current (app/bake_cache.h). */
sg_status sg_bake_file_desc(const sg_bake_file *f, const char *path, sg_bake_desc *out, sg_error *err);

/* Writes job j (bake_job.h), stopped or not yet run, to path atomically,
 * flagged SG_BAKE_FLAG_CHECKPOINT (sections above). A finished job (stage
 * DONE) is SG_ERR_INVALID_ARG and writes nothing: its bake is to be
 * finished and saved, and a checkpoint of it could not be resumed. */
sg_status sg_bake_job_save(const sg_bake_job *j, const char *path, uint64_t scene_hash, sg_error *err);

/* Reads a checkpoint made for scene_hash and the parameters of d (else
 * SG_ERR_INVALID_ARG naming both parameter sets) into a job for world w, to
 * be run on: the bake it ends in is the same, bit for bit, as a job run
 * straight through. Every value is checked (SG_ERR_CORRUPT naming the
 * section, model and element). *out: release with sg_bake_job_destroy. */
sg_status sg_bake_job_load(const char *path, const sg_world *w, const sg_bake_desc *d, uint64_t scene_hash,
                           sg_bake_job **out, sg_error *err);

#endif
