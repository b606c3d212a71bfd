/* bake_io.c — bakes and checkpoints in the .sgbake container (layout in
 * bake_io.h, container in bake_file.h).
 *
 * Invariants:
 *  1. a file's bytes depend only on the scene hash, the resolved
 *     parameters, the irradiance or records and the ray counts: nothing
 *     timed and nothing that depends on the thread count goes in, so equal
 *     bakes are equal files (what makes resume checkable with cmp);
 *  2. META elements 1..7, 19..22 and 24..27 hash (sg_bake_param_hash) to the
 *     header's parameter hash; load refuses a file where they do not;
 *  3. bytes from a file reach no assert: each value is range-checked and a
 *     failure is SG_ERR_CORRUPT naming the file, section, model or record;
 *  4. load builds nothing the caller sees until every check passed: *out is
 *     written last, on SG_OK only.
 */
#include "bake/bake_io.h"

#include <assert.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bake/bake_file.h"
#include "bake/bake_io_int.h"
#include "bake/glossy.h"
#include "bake/samples.h"
#include "core/alloc.h"


/* CNTS is read straight into the size_t counts sg_bake__new takes. */
_Static_assert(sizeof(size_t) == sizeof(uint64_t), "bake_io.c assumes a 64-bit size_t");

const char *const sg_bake_io__photon_tags[13] = {"PHPX", "PHPY", "PHPZ", "PHNX", "PHNY", "PHNZ", "PHWX",
                                         "PHWY", "PHWZ", "PHFR", "PHFG", "PHFB", "PHMD"};

void sg_bake_io__put_meta(uint64_t meta[SG_BAKE_META_COUNT], const sg_bake_desc *d, size_t blocks, size_t shot,
                          size_t records, size_t models, size_t splats, size_t samples, const sg_ray_stats *rays)
{
    uint32_t cos_bits;
    memcpy(&cos_bits, &d->gather.normal_cos, sizeof cos_bits);
    memset(meta, 0, SG_BAKE_META_COUNT * sizeof *meta);
    meta[META_VERSION] = META_LAYOUT;
    meta[META_COUNT] = d->photons.count;
    meta[META_SEED] = d->photons.seed;
    meta[META_MAX_DEPTH] = (uint64_t)d->photons.max_depth;
    meta[META_RR_DEPTH] = (uint64_t)d->photons.rr_depth;
    meta[META_K] = d->gather.k;
    meta[META_NORMAL_COS] = cos_bits;
    meta[META_BLOCK] = SG_PHOTON_BLOCK;
    meta[META_BLOCKS] = blocks;
    meta[META_SHOT] = shot;
    meta[META_RECORDS] = records;
    meta[META_MODELS] = models;
    meta[META_SPLATS] = splats;
    const uint64_t r[6] = {rays->rays, rays->nodes, rays->leaves, rays->isects, rays->splats, rays->hits};
    memcpy(meta + META_RAYS, r, sizeof r);
    meta[META_DIRECT] = (uint64_t)(int64_t)d->direct_samples;
    uint32_t sp_bits;
    memcpy(&sp_bits, &d->sample_spacing, sizeof sp_bits);
    meta[META_SPACING] = sp_bits;
    meta[META_GLOSSY_RES] = (uint64_t)d->glossy_res;
    meta[META_GLOSSY_RAYS] = (uint64_t)d->glossy_rays;
    meta[META_SAMPLES] = samples;
    meta[META_INDIRECT] = (uint64_t)d->indirect;
    meta[META_GATHER_RAYS] = (uint64_t)d->gather_rays;
    meta[META_REFINE] = (uint64_t)(int64_t)d->refine_levels;
    if (d->ray_cone > 0.0f) { /* off stays 0: the bytes of a bake made before the option */
        uint32_t rc_bits;
        memcpy(&rc_bits, &d->ray_cone, sizeof rc_bits);
        meta[META_RAY_CONE] = rc_bits;
    }
}

void sg_bake_io__describe(const sg_bake_desc *d, uint64_t block, char *buf, size_t size)
{
    snprintf(buf, size,
             "%s, seed %" PRIu64 ", %d + %d rays per site, spacing %g, %d refinements, photons %zu, max depth %d, "
             "rr depth %d, k %u, normal_cos %g, block %" PRIu64 ", ray cone %g",
             d->indirect == SG_BAKE_INDIRECT_PHOTONS ? "photons" : "transport", d->photons.seed, d->direct_samples,
             d->gather_rays, (double)d->sample_spacing, d->refine_levels, d->photons.count, d->photons.max_depth,
             d->photons.rr_depth, d->gather.k, (double)d->gather.normal_cos, block,
             d->ray_cone > 0.0f ? (double)d->ray_cone : 0.0);
}

/* Reads and checks META (invariant 2, 3); *d gets the parameters. */
sg_status sg_bake_io__read_meta(const sg_bake_file *f, const char *path, uint64_t meta[SG_BAKE_META_COUNT],
                           sg_bake_desc *d, sg_error *err)
{
    const sg_bake_section *s = sg_bake_file_find(f, "META");
    if (!s)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: no META section", path);
    if (s->type != SG_BAKE_TYPE_U64 || s->count != SG_BAKE_META_COUNT)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section META: expected %u u64 values, found %" PRIu64
                                                 " elements of type %d",
                            path, SG_BAKE_META_COUNT, s->count, (int)s->type);
    sg_status st = sg_bake_file_read(f, "META", meta, SG_BAKE_META_COUNT * sizeof *meta, err);
    if (st != SG_OK)
        return st;
    if (meta[META_VERSION] != META_LAYOUT)
        return sg_error_set(err, SG_ERR_UNSUPPORTED,
                            "%s: section META: layout %" PRIu64 ", this build reads %u (%s; bake again)", path,
                            meta[META_VERSION], META_LAYOUT,
                            meta[META_VERSION] < META_LAYOUT ? "made before light per side and the transport solve"
                                                             : "made by a newer build");
    uint32_t cos_bits = (uint32_t)meta[META_NORMAL_COS], sp_bits = (uint32_t)meta[META_SPACING];
    uint32_t rc_bits = (uint32_t)meta[META_RAY_CONE];
    float normal_cos, spacing, ray_cone;
    memcpy(&normal_cos, &cos_bits, sizeof normal_cos);
    memcpy(&spacing, &sp_bits, sizeof spacing);
    memcpy(&ray_cone, &rc_bits, sizeof ray_cone);
    const char *bad = NULL;
    if (meta[META_COUNT] < 1 || meta[META_COUNT] > ((uint64_t)1 << 34)) bad = "photon count";
    else if (meta[META_SEED] == 0) bad = "seed";
    else if (meta[META_MAX_DEPTH] < 1 || meta[META_MAX_DEPTH] > INT32_MAX) bad = "max depth";
    else if (meta[META_RR_DEPTH] < 1 || meta[META_RR_DEPTH] > INT32_MAX) bad = "rr depth";
    else if (meta[META_K] < 1 || meta[META_K] > UINT32_MAX) bad = "k";
    else if (meta[META_NORMAL_COS] > UINT32_MAX || !(normal_cos >= -1.0f && normal_cos <= 1.0f) ||
             normal_cos == 0.0f)
        bad = "normal_cos";
    else if (meta[META_BLOCK] < 1 || meta[META_BLOCK] > ((uint64_t)1 << 34)) bad = "block size";
    else if ((int64_t)meta[META_DIRECT] < -1 || (int64_t)meta[META_DIRECT] == 0 ||
             (int64_t)meta[META_DIRECT] > INT32_MAX)
        bad = "direct samples";
    else if (meta[META_SPACING] > UINT32_MAX || !(spacing == -1.0f || (spacing >= 0.0f && spacing < 1e6f)))
        bad = "sample spacing";
    else if (meta[META_GLOSSY_RES] != 0 &&
             (meta[META_GLOSSY_RES] < SG_GLOSSY_MIN_RES || meta[META_GLOSSY_RES] > SG_GLOSSY_MAX_RES))
        bad = "glossy resolution";
    else if (meta[META_GLOSSY_RAYS] < 1 || meta[META_GLOSSY_RAYS] > INT32_MAX)
        bad = "glossy rays";
    else if (meta[META_INDIRECT] > SG_BAKE_INDIRECT_PHOTONS)
        bad = "indirect estimator";
    else if (meta[META_GATHER_RAYS] < 1 || meta[META_GATHER_RAYS] > INT32_MAX)
        bad = "gather rays";
    else if ((int64_t)meta[META_REFINE] < -1 || (int64_t)meta[META_REFINE] == 0 ||
             (int64_t)meta[META_REFINE] >= SG_SAMPLES_MAX_LEVEL)
        bad = "refinement levels";
    else if (meta[META_RAY_CONE] > UINT32_MAX ||
             (meta[META_RAY_CONE] != 0 && !(ray_cone > 0.0f && ray_cone <= SG_BAKE_RAY_CONE_MAX)))
        bad = "ray cone";
    if (bad)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section META: %s is out of range", path, bad);
    *d = (sg_bake_desc){.photons = {.count = (size_t)meta[META_COUNT],
                                    .seed = meta[META_SEED],
                                    .max_depth = (int)meta[META_MAX_DEPTH],
                                    .rr_depth = (int)meta[META_RR_DEPTH]},
                        .gather = {.k = (unsigned)meta[META_K], .normal_cos = normal_cos},
                        .direct_samples = (int)(int64_t)meta[META_DIRECT],
                        .sample_spacing = spacing,
                        .glossy_res = (int)meta[META_GLOSSY_RES],
                        .glossy_rays = (int)meta[META_GLOSSY_RAYS],
                        .indirect = (sg_bake_indirect)meta[META_INDIRECT],
                        .gather_rays = (int)meta[META_GATHER_RAYS],
                        .refine_levels = (int)(int64_t)meta[META_REFINE],
                        .ray_cone = meta[META_RAY_CONE] ? ray_cone : -1.0f};
    uint64_t h = 0;
    if (meta[META_BLOCK] == SG_PHOTON_BLOCK)
        h = sg_bake_param_hash(d);
    if (h != sg_bake_file_info(f)->param_hash) {
        if (meta[META_BLOCK] != SG_PHOTON_BLOCK)
            return sg_error_set(err, SG_ERR_UNSUPPORTED,
                                "%s: made with photon blocks of %" PRIu64 ", this build traces blocks of %d", path,
                                meta[META_BLOCK], SG_PHOTON_BLOCK);
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section META hashes to %016" PRIx64 ", the header says %016" PRIx64, path, h,
                            sg_bake_file_info(f)->param_hash);
    }
    return SG_OK;
}

sg_status sg_bake_file_desc(const sg_bake_file *f, const char *path, sg_bake_desc *out, sg_error *err)
{
    uint64_t meta[SG_BAKE_META_COUNT];
    return sg_bake_io__read_meta(f, path, meta, out, err);
}

/* What is wrong with an irradiance or flux value, or NULL. */
const char *sg_bake_io__bad_value(float v)
{
    if (isnan(v))
        return "NaN";
    if (!isfinite(v))
        return "infinite";
    return v < 0.0f ? "negative" : NULL;
}

sg_status sg_bake_save(const sg_bake *b, const char *path, uint64_t scene_hash, sg_error *err)
{
    assert(b && path);
    size_t models = sg_bake_model_count(b);
    if (models > SG_BAKE_IO_MAX_MODELS)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: %zu models; a bake file holds at most %u", path, models,
                            SG_BAKE_IO_MAX_MODELS);
    sg_bake_desc d = sg_bake_get_desc(b);
    sg_bake_stats stats;
    sg_bake_get_stats(b, &stats);
    uint64_t meta[SG_BAKE_META_COUNT];
    sg_bake_io__put_meta(meta, &d, sg_photon_block_count(&d.photons), stats.photons_shot, stats.photon_records, models,
             stats.splats, stats.sample_points, &stats.rays);
    uint64_t *counts = sg_alloc_array(3 * models, sizeof *counts);
    if (!counts)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    uint64_t *samples = counts + models, *gres = counts + 2 * models;
    size_t sections = models + 4;
    for (size_t m = 0; m < models; ++m) {
        size_t n;
        sg_bake_light_data(b, (uint32_t)m, &n);
        counts[m] = n;
        samples[m] = sg_bake_sample_count(b, (uint32_t)m);
        int res;
        size_t gc;
        const uint32_t *gs, *gn;
        const uint16_t *gb;
        sg_bake_glossy_data(b, (uint32_t)m, &res, &gc, &gs, &gn, &gb);
        gres[m] = (uint64_t)res;
        sections += res ? 3 : 0;
    }
    if (sections > SG_BAKE_MAX_SECTIONS) {
        sg_free(counts);
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: %zu sections (models and glossy bins); a bake file holds "
                                                     "at most %u", path, sections, SG_BAKE_MAX_SECTIONS);
    }
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc wd = {.path = path, .scene_hash = scene_hash, .param_hash = sg_bake_param_hash(&d),
                              .max_sections = (uint32_t)sections};
    sg_status st = sg_bake_writer_create(&wd, &w, err);
    if (st == SG_OK)
        st = sg_bake_writer_add_section(w, "META", SG_BAKE_TYPE_U64, SG_BAKE_META_COUNT, meta, err);
    if (st == SG_OK)
        st = sg_bake_writer_add_section(w, "CNTS", SG_BAKE_TYPE_U64, models, counts, err);
    if (st == SG_OK)
        st = sg_bake_writer_add_section(w, "SCNT", SG_BAKE_TYPE_U64, models, samples, err);
    if (st == SG_OK)
        st = sg_bake_writer_add_section(w, "GRES", SG_BAKE_TYPE_U64, models, gres, err);
    for (size_t m = 0; m < models && st == SG_OK; ++m) {
        char tag[8];
        snprintf(tag, sizeof tag, "E%03X", (unsigned)m);
        st = sg_bake_writer_add_section(w, tag, SG_BAKE_TYPE_F32, SG_BAKE_SPLAT_FLOATS * counts[m],
                                        sg_bake_light_data(b, (uint32_t)m, NULL), err);
        if (st != SG_OK || !gres[m])
            continue;
        int res;
        size_t gc;
        const uint32_t *gs, *gn;
        const uint16_t *gb;
        sg_bake_glossy_data(b, (uint32_t)m, &res, &gc, &gs, &gn, &gb);
        snprintf(tag, sizeof tag, "P%03X", (unsigned)m);
        st = sg_bake_writer_add_section(w, tag, SG_BAKE_TYPE_U32, gc, gs, err);
        if (st == SG_OK) {
            snprintf(tag, sizeof tag, "N%03X", (unsigned)m);
            st = sg_bake_writer_add_section(w, tag, SG_BAKE_TYPE_U32, counts[m], gn, err);
        }
        if (st == SG_OK) {
            snprintf(tag, sizeof tag, "G%03X", (unsigned)m);
            st = sg_bake_writer_add_section(w, tag, SG_BAKE_TYPE_F16, gc * 3 * (uint64_t)res * (uint64_t)res, gb,
                                            err);
        }
    }
    if (st == SG_OK)
        st = sg_bake_writer_commit(w, err);
    sg_bake_writer_destroy(w);
    sg_free(counts);
    return st;
}

/* A U64 section of n values (SCNT, GRES): one per model. */
sg_status sg_bake_io__read_u64s(const sg_bake_file *f, const char *path, const char *tag, size_t n, uint64_t *out,
                           sg_error *err)
{
    const sg_bake_section *s = sg_bake_file_find(f, tag);
    if (!s || s->type != SG_BAKE_TYPE_U64 || s->count != n)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s is %s (expected %zu u64 values)", path, tag,
                            s ? "of the wrong type or length" : "missing", n);
    return sg_bake_file_read(f, tag, out, n * sizeof *out, err);
}

/* Model m's glossy sections (P: sample splats, N: per-splat sample, G:
 * bins), read into b and checked (invariant 3). */
static sg_status read_glossy(const sg_bake_file *f, const char *path, sg_bake *b, uint32_t m, int res,
                             uint64_t samples, uint64_t splats, sg_error *err)
{
    char tp[8], tn[8], tg[8];
    snprintf(tp, sizeof tp, "P%03X", (unsigned)m);
    snprintf(tn, sizeof tn, "N%03X", (unsigned)m);
    snprintf(tg, sizeof tg, "G%03X", (unsigned)m);
    const sg_bake_section *sp = sg_bake_file_find(f, tp), *sn = sg_bake_file_find(f, tn),
                          *sgb = sg_bake_file_find(f, tg);
    uint64_t nbins = samples * 3 * (uint64_t)res * (uint64_t)res;
    const char *bad = !sp || sp->type != SG_BAKE_TYPE_U32 || sp->count != samples ? tp
                      : !sn || sn->type != SG_BAKE_TYPE_U32 || sn->count != splats ? tn
                      : !sgb || sgb->type != SG_BAKE_TYPE_F16 || sgb->count != nbins ? tg
                                                                                     : NULL;
    if (bad)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section %s is missing or of the wrong type or length (model %u: %" PRIu64
                            " glossy sample points of %d x %d bins, %" PRIu64 " splats)",
                            path, bad, m, samples, res, res, splats);
    /* sizes are bounded by the file now (bake_file.h checked each section) */
    sg_status st = sg_bake__alloc_glossy(b, m, res, (size_t)samples, err);
    if (st != SG_OK)
        return st;
    uint32_t *ps, *pn;
    uint16_t *pb;
    sg_bake__glossy(b, m, &ps, &pn, &pb);
    if ((st = sg_bake_file_read(f, tp, ps, sp->size, err)) != SG_OK ||
        (st = sg_bake_file_read(f, tn, pn, sn->size, err)) != SG_OK ||
        (st = sg_bake_file_read(f, tg, pb, sgb->size, err)) != SG_OK)
        return st;
    for (uint64_t j = 0; j < samples; ++j)
        if (ps[j] >= splats)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s: sample point %" PRIu64 " names splat %" PRIu32
                                                     " of %" PRIu64, path, tp, j, ps[j], splats);
    for (uint64_t i = 0; i < splats; ++i)
        if (pn[i] >= samples)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s: splat %" PRIu64 " names sample point %" PRIu32
                                                     " of %" PRIu64, path, tn, i, pn[i], samples);
    for (uint64_t k = 0; k < nbins; ++k)
        if ((pb[k] & 0x8000u) || (pb[k] & 0x7c00u) == 0x7c00u)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s: sample point %" PRIu64 ", bin %" PRIu64
                                                     ": value is %s",
                                path, tg, k / (3 * (uint64_t)res * (uint64_t)res),
                                k / 3 % ((uint64_t)res * (uint64_t)res),
                                (pb[k] & 0x7c00u) == 0x7c00u ? "not finite" : "negative");
    return SG_OK;
}

sg_status sg_bake_load(const char *path, const sg_world *w, uint64_t scene_hash, sg_bake **out, sg_error *err)
{
    assert(path && w && out);
    sg_bake_file *f = NULL;
    sg_bake *b = NULL;
    uint64_t *counts = NULL;
    sg_status st = sg_bake_file_open(path, scene_hash, 0, &f, err);
    if (st != SG_OK)
        return st;
    if (sg_bake_file_info(f)->flags & SG_BAKE_FLAG_CHECKPOINT) {
        st = sg_error_set(err, SG_ERR_INVALID_ARG,
                          "%s: a checkpoint of an unfinished bake, not a bake (resume the bake to finish it)", path);
        goto done;
    }
    uint64_t meta[SG_BAKE_META_COUNT];
    sg_bake_desc d;
    if ((st = sg_bake_io__read_meta(f, path, meta, &d, err)) != SG_OK)
        goto done;
    size_t models = sg_world_model_count(w);
    const sg_bake_section *cs = sg_bake_file_find(f, "CNTS");
    if (!cs || cs->type != SG_BAKE_TYPE_U64 || cs->count != meta[META_MODELS]) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section CNTS is %s (META says %" PRIu64 " models)", path,
                          cs ? "of the wrong type or length" : "missing", meta[META_MODELS]);
        goto done;
    }
    if (cs->count != models) {
        st = sg_error_set(err, SG_ERR_INVALID_ARG, "%s: %" PRIu64 " models in the bake, %zu in the scene", path,
                          cs->count, models);
        goto done;
    }
    if (!(counts = sg_alloc_array(models, sizeof *counts))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    if ((st = sg_bake_file_read(f, "CNTS", counts, models * sizeof *counts, err)) != SG_OK)
        goto done;
    uint64_t splats = 0;
    for (size_t m = 0; m < models; ++m) {
        size_t n = sg_scene_sites(sg_world_scene(w, (uint32_t)m))->count;
        if (counts[m] != n) {
            st = sg_error_set(err, SG_ERR_INVALID_ARG, "%s: model %zu has %" PRIu64 " light sites in the bake, %zu in the scene",
                              path, m, counts[m], n);
            goto done;
        }
        splats += counts[m];
    }
    if (splats != meta[META_SPLATS]) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section META: %" PRIu64 " splats, CNTS adds up to %" PRIu64, path,
                          meta[META_SPLATS], splats);
        goto done;
    }
    sg_bake_stats stats = {.photons_shot = (size_t)meta[META_SHOT], .photon_records = (size_t)meta[META_RECORDS],
                           .rays = {meta[META_RAYS], meta[META_RAYS + 1], meta[META_RAYS + 2],
                                    meta[META_RAYS + 3], meta[META_RAYS + 4], meta[META_RAYS + 5]}};
    size_t *sizes = (size_t *)counts; /* u64 as size_t: same width (asserted above) */
    if ((st = sg_bake__new(sg_world_envmap(w), models, sizes, &d, &stats, &b, err)) != SG_OK)
        goto done;
    for (size_t m = 0; m < models; ++m) {
        char tag[8];
        snprintf(tag, sizeof tag, "E%03X", (unsigned)m);
        const sg_bake_section *s = sg_bake_file_find(f, tag);
        if (!s || s->type != SG_BAKE_TYPE_F32 || s->count != SG_BAKE_SPLAT_FLOATS * counts[m]) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s is %s (expected %" PRIu64 " floats)", path, tag,
                              s ? "of the wrong type or length" : "missing", SG_BAKE_SPLAT_FLOATS * counts[m]);
            goto done;
        }
        float *E = sg_bake__light(b, (uint32_t)m);
        if ((st = sg_bake_file_read(f, tag, E, s->size, err)) != SG_OK)
            goto done;
        for (size_t i = 0; i < SG_BAKE_SPLAT_FLOATS * counts[m]; ++i) {
            const char *what = sg_bake_io__bad_value(E[i]);
            if (what) {
                size_t k = i % SG_BAKE_SPLAT_FLOATS;
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: model %zu, splat %zu: %s %s is %s (%g)", path, m,
                                  i / SG_BAKE_SPLAT_FLOATS, k < 6 ? "front" : "back",
                                  k % 6 < 3 ? "visibility ratio" : "indirect irradiance", what, (double)E[i]);
                goto done;
            }
        }
    }
    uint64_t *per = NULL; /* SCNT then GRES */
    if (!(per = sg_alloc_array(2 * models, sizeof *per))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    if ((st = sg_bake_io__read_u64s(f, path, "SCNT", models, per, err)) != SG_OK ||
        (st = sg_bake_io__read_u64s(f, path, "GRES", models, per + models, err)) != SG_OK)
        goto free_per;
    uint64_t samples = 0;
    for (size_t m = 0; m < models && st == SG_OK; ++m) {
        uint64_t ns = per[m], res = per[models + m];
        if (ns > counts[m] || (res && (res < SG_GLOSSY_MIN_RES || res > SG_GLOSSY_MAX_RES || ns == 0))) {
            st = sg_error_set(err, SG_ERR_CORRUPT,
                              "%s: model %zu: %" PRIu64 " sample points of %" PRIu64 " splats, glossy resolution %"
                              PRIu64 " do not fit",
                              path, m, ns, counts[m], res);
            break;
        }
        samples += ns;
        sg_bake__set_samples(b, (uint32_t)m, (size_t)ns);
        if (res)
            st = read_glossy(f, path, b, (uint32_t)m, (int)res, ns, counts[m], err);
    }
    if (st == SG_OK && samples != meta[META_SAMPLES])
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section META: %" PRIu64 " sample points, SCNT adds up to %" PRIu64,
                          path, meta[META_SAMPLES], samples);
free_per:
    sg_free(per);
    if (st != SG_OK)
        goto done;
    *out = b;
    b = NULL;
done:
    sg_bake_destroy(b);
    sg_free(counts);
    sg_bake_file_close(f);
    return st;
}
