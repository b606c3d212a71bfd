/* bake_io_int.h — what bake_io.c shares with the checkpoint code
 * (bake_checkpoint.c): the META section's layout (bake_io.h documents
 * it), and its writer and checked reader.
 */
#ifndef SG_BAKE_BAKE_IO_INT_H
#define SG_BAKE_BAKE_IO_INT_H

#include <stddef.h>
#include <stdint.h>

#include "bake/bake.h"
#include "bake/bake_file.h"
#include "bake/bake_io.h"

enum {
    META_VERSION = 0, META_COUNT, META_SEED, META_MAX_DEPTH, META_RR_DEPTH, META_K, META_NORMAL_COS,
    META_BLOCK, META_BLOCKS, META_SHOT, META_RECORDS, META_MODELS, META_SPLATS, META_RAYS /* 6 of them */,
    META_DIRECT = META_RAYS + 6 /* direct samples per splat, as int64; -1 none */,
    META_SPACING, META_GLOSSY_RES, META_GLOSSY_RAYS, META_SAMPLES,
    META_INDIRECT /* sg_bake_indirect */, META_GATHER_RAYS, META_REFINE /* int64; -1 none */,
    META_RAY_CONE /* float bits of ray_cone; 0: off (an element that was 0 before the option) */
};
#define META_LAYOUT 4u

/* The photon record sections, in the order of sg_photon_map's arrays
 * (positions, normals, directions, flux, model). */
extern const char *const sg_bake_io__photon_tags[13];

/* META of parameters d and the given figures. */
void sg_bake_io__put_meta(uint64_t meta[SG_BAKE_META_COUNT], const sg_bake_desc *d, size_t blocks, size_t shot,
                          size_t records, size_t models, size_t splats, size_t samples, const sg_ray_stats *rays);

/* Reads META and checks it (ranges, the header's parameter hash); *d gets
 * the parameters. Messages begin with path. */
sg_status sg_bake_io__read_meta(const sg_bake_file *f, const char *path, uint64_t meta[SG_BAKE_META_COUNT],
                                sg_bake_desc *d, sg_error *err);

/* The parameters in words, for "made with other parameters" messages. */
void sg_bake_io__describe(const sg_bake_desc *d, uint64_t block, char *buf, size_t size);

/* What is wrong with a stored value that must be finite and >= 0, or NULL. */
const char *sg_bake_io__bad_value(float v);

/* A U64 section of exactly n values into out. */
sg_status sg_bake_io__read_u64s(const sg_bake_file *f, const char *path, const char *tag, size_t n, uint64_t *out,
                                sg_error *err);

#endif
