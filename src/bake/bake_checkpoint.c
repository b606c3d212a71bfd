/* bake_checkpoint.c — a stopped bake job in a .sgbake file and back
 * (sg_bake_job_save, sg_bake_job_load: bake_io.h has the layout).
 *
 * Invariants:
 *  1. a checkpoint's bytes depend only on the scene hash, the parameters
 *     and the job's state (never on time or threads), so that a job saved,
 *     loaded and finished writes the same bake as one run straight through;
 *  2. every value read is checked against the world and the job's
 *     invariants (bake_job_int.h) before the job is built: a damaged file
 *     gives SG_ERR_CORRUPT naming the section and element, never an assert
 *     or an out-of-range index;
 *  3. *out is written last, on SG_OK only.
 */
#include <assert.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bake/bake_io_int.h"
#include "bake/bake_job_int.h"
#include "bake/glossy.h"
#include "core/alloc.h"

/* Sections per model: light E, samples S and their levels L, the sites'
 * ratio R, unshadowed U, sigma Q, distance D, hit ranges F, hits' splat H,
 * model M and weight K, glossy bins G. */
enum { MODEL_SECTIONS = 12, JOB_HEAD = 4, JOB_PER_MODEL = 3 };

static void tag_of(char *tag, char letter, size_t m) { snprintf(tag, 8, "%c%03X", letter, (unsigned)m); }

static sg_status add(sg_bake_writer *w, char letter, size_t m, sg_bake_type type, uint64_t count, const void *data,
                     sg_error *err)
{
    char tag[8];
    tag_of(tag, letter, m);
    return sg_bake_writer_add_section(w, tag, type, count, count ? data : NULL, err);
}

sg_status sg_bake_job_save(const sg_bake_job *j, const char *path, uint64_t scene_hash, sg_error *err)
{
    assert(j && path && j->b);
    if (j->stage == SG_BAKE_STAGE_DONE)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: the bake is finished; save it, not a checkpoint", path);
    if (j->models > (SG_BAKE_MAX_SECTIONS - 16) / MODEL_SECTIONS)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: %zu models; a checkpoint holds at most %u", path, j->models,
                            (SG_BAKE_MAX_SECTIONS - 16) / MODEL_SECTIONS);
    uint64_t meta[SG_BAKE_META_COUNT];
    if (j->stage == SG_BAKE_STAGE_PHOTONS)
        sg_bake_io__put_meta(meta, &j->d, j->pm.blocks, j->pm.shot, j->pm.count, j->models, 0, 0, &j->pm.rays);
    else { /* the photon pass is over: its figures are the bake's */
        sg_bake_stats bs;
        sg_bake_get_stats(j->b, &bs);
        sg_bake_io__put_meta(meta, &j->d, sg_photon_block_count(&j->d.photons), bs.photons_shot, bs.photon_records,
                             j->models, 0, 0, &bs.rays);
    }
    size_t nh = JOB_HEAD + JOB_PER_MODEL * j->models;
    uint64_t *head = sg_calloc_array(nh, sizeof *head);
    if (!head)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    head[0] = (uint64_t)j->stage;
    head[1] = (uint64_t)j->level;
    head[2] = (uint64_t)j->prepared;
    head[3] = j->models;
    for (size_t m = 0; m < j->models; ++m) {
        const sg_bake_job_model *x = &j->mw[m];
        head[JOB_HEAD + JOB_PER_MODEL * m] = x->set.count;
        head[JOB_HEAD + JOB_PER_MODEL * m + 1] = x->sites.count;
        head[JOB_HEAD + JOB_PER_MODEL * m + 2] = x->glossy_done;
    }
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc wd = {.path = path, .scene_hash = scene_hash, .param_hash = sg_bake_param_hash(&j->d),
                              .flags = SG_BAKE_FLAG_CHECKPOINT,
                              .max_sections = (uint32_t)(16 + MODEL_SECTIONS * j->models)};
    sg_status st = sg_bake_writer_create(&wd, &w, err);
    if (st == SG_OK)
        st = sg_bake_writer_add_section(w, "META", SG_BAKE_TYPE_U64, SG_BAKE_META_COUNT, meta, err);
    if (st == SG_OK)
        st = sg_bake_writer_add_section(w, "JOBS", SG_BAKE_TYPE_U64, nh, head, err);
    if (st == SG_OK && j->stage == SG_BAKE_STAGE_PHOTONS) {
        const sg_photon_map *pm = &j->pm;
        const void *arrays[13] = {pm->px, pm->py, pm->pz, pm->nx, pm->ny, pm->nz, pm->wx,
                                  pm->wy, pm->wz, pm->fr, pm->fg, pm->fb, pm->model};
        for (int a = 0; a < 13 && st == SG_OK; ++a)
            st = sg_bake_writer_add_section(w, sg_bake_io__photon_tags[a], a < 12 ? SG_BAKE_TYPE_F32 : SG_BAKE_TYPE_U32,
                                            pm->count, pm->count ? arrays[a] : NULL, err);
    }
    for (size_t m = 0; m < j->models && st == SG_OK && j->stage != SG_BAKE_STAGE_PHOTONS; ++m) {
        const sg_bake_job_model *x = &j->mw[m];
        size_t n;
        const float *E = sg_bake_light_data(j->b, (uint32_t)m, &n);
        st = add(w, 'E', m, SG_BAKE_TYPE_F32, SG_BAKE_SPLAT_FLOATS * (uint64_t)n, E, err);
        if (st != SG_OK || !x->sampled || !j->prepared)
            continue;
        st = add(w, 'S', m, SG_BAKE_TYPE_U32, x->set.count, x->set.splat, err);
        if (st == SG_OK)
            st = add(w, 'L', m, SG_BAKE_TYPE_U8, x->set.count, x->set.level, err);
        if (st == SG_OK && j->stage == SG_BAKE_STAGE_SITES) {
            const sg_site_data *sd = &x->sites;
            uint64_t g = sd->count;
            if (st == SG_OK) st = add(w, 'R', m, SG_BAKE_TYPE_F32, 6 * g, sd->ratio, err);
            if (st == SG_OK) st = add(w, 'U', m, SG_BAKE_TYPE_F32, 6 * g, sd->unshadowed, err);
            if (st == SG_OK) st = add(w, 'Q', m, SG_BAKE_TYPE_F32, 2 * g, sd->sigma, err);
            if (st == SG_OK) st = add(w, 'D', m, SG_BAKE_TYPE_F32, 2 * g, sd->dist, err);
            if (st == SG_OK) st = add(w, 'F', m, SG_BAKE_TYPE_U64, g ? 2 * g + 1 : 0, sd->first, err);
            if (st == SG_OK) st = add(w, 'H', m, SG_BAKE_TYPE_U32, sd->hits, sd->hit_splat, err);
            if (st == SG_OK) st = add(w, 'M', m, SG_BAKE_TYPE_U32, sd->hits, sd->hit_model, err);
            if (st == SG_OK) st = add(w, 'K', m, SG_BAKE_TYPE_F32, sd->hits, sd->hit_k, err);
        }
        if (st == SG_OK && j->stage == SG_BAKE_STAGE_GLOSSY && x->glossy_done) {
            int res;
            size_t count;
            const uint32_t *gs, *gn;
            const uint16_t *gb;
            sg_bake_glossy_data(j->b, (uint32_t)m, &res, &count, &gs, &gn, &gb);
            assert(res > 0 && x->glossy_done <= count);
            st = add(w, 'G', m, SG_BAKE_TYPE_F16, 3 * (uint64_t)res * (uint64_t)res * x->glossy_done, gb, err);
        }
    }
    if (st == SG_OK)
        st = sg_bake_writer_commit(w, err);
    sg_bake_writer_destroy(w);
    sg_free(head);
    return st;
}

/* ---- loading ---------------------------------------------------------------- */

/* Finds section letter+m of `type` and exactly `count` elements; reads it
 * into dst (count elements, may be NULL when count is 0). */
static sg_status read_exact(const sg_bake_file *f, const char *path, char letter, size_t m, sg_bake_type type,
                            uint64_t count, void *dst, sg_error *err)
{
    char tag[8];
    tag_of(tag, letter, m);
    const sg_bake_section *s = sg_bake_file_find(f, tag);
    if (!s || s->type != type || s->count != count)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s is %s (expected %" PRIu64 " elements)", path, tag,
                            s ? "of the wrong type or length" : "missing", count);
    return count ? sg_bake_file_read(f, tag, dst, s->size, err) : SG_OK;
}

static sg_status load_photons(const sg_bake_file *f, const char *path, const uint64_t *meta, const sg_bake_desc *d,
                              size_t models, sg_photon_map *out, sg_error *err)
{
    sg_photon_map m = {0};
    uint64_t nblocks = sg_photon_block_count(&d->photons), blocks = meta[META_BLOCKS];
    uint64_t shot = blocks * SG_PHOTON_BLOCK < d->photons.count ? blocks * SG_PHOTON_BLOCK : d->photons.count;
    if (blocks > nblocks || meta[META_SHOT] != shot)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section META: %" PRIu64 " of %" PRIu64 " blocks done and %" PRIu64
                            " photons shot do not fit",
                            path, blocks, nblocks, meta[META_SHOT]);
    uint64_t R = meta[META_RECORDS];
    sg_status st = SG_OK;
    for (int a = 0; a < 13; ++a) {
        const sg_bake_section *s = sg_bake_file_find(f, sg_bake_io__photon_tags[a]);
        if (!s || s->type != (a < 12 ? SG_BAKE_TYPE_F32 : SG_BAKE_TYPE_U32) || s->count != R)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s is %s (META says %" PRIu64 " records)", path,
                                sg_bake_io__photon_tags[a], s ? "of the wrong type or length" : "missing", R);
    }
    /* R is bounded by the file size now (bake_file.h checked each section). */
    float **arrays[12] = {&m.px, &m.py, &m.pz, &m.nx, &m.ny, &m.nz, &m.wx, &m.wy, &m.wz, &m.fr, &m.fg, &m.fb};
    for (int a = 0; a < 12 && st == SG_OK; ++a)
        if (!(*arrays[a] = sg_alloc_array(R ? (size_t)R : 1, sizeof(float))))
            st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %" PRIu64 " photon records", path, R);
    if (st == SG_OK && !(m.model = sg_alloc_array(R ? (size_t)R : 1, sizeof(uint32_t))))
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %" PRIu64 " photon records", path, R);
    for (int a = 0; a < 13 && st == SG_OK && R; ++a) {
        void *dst = a < 12 ? (void *)*arrays[a] : (void *)m.model;
        st = sg_bake_file_read(f, sg_bake_io__photon_tags[a], dst, R * 4, err);
    }
    for (size_t j = 0; j < R && st == SG_OK; ++j) {
        const char *what = NULL;
        for (int a = 0; a < 9 && !what; ++a)
            if (!isfinite((*arrays[a])[j]))
                what = "a position, normal or direction is not finite";
        for (int a = 9; a < 12 && !what; ++a)
            if (sg_bake_io__bad_value((*arrays[a])[j]))
                what = "its flux is not finite and >= 0";
        if (!what && m.model[j] >= models)
            what = "its model is not in the scene";
        if (what)
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: photon record %zu: %s", path, j, what);
    }
    if (st != SG_OK) {
        sg_photon_map_free(&m);
        return st;
    }
    m.count = m.capacity = (size_t)R;
    m.blocks = (size_t)blocks;
    m.shot = (size_t)shot;
    m.rays = (sg_ray_stats){meta[META_RAYS], meta[META_RAYS + 1], meta[META_RAYS + 2],
                            meta[META_RAYS + 3], meta[META_RAYS + 4], meta[META_RAYS + 5]};
    *out = m;
    return SG_OK;
}

/* Floats that must be finite and >= 0 (or, where inf_ok, +infinity). */
static sg_status check_floats(const char *path, char letter, size_t m, const float *v, size_t n, int inf_ok,
                              sg_error *err)
{
    for (size_t i = 0; i < n; ++i) {
        const char *what = inf_ok && v[i] == INFINITY ? NULL : sg_bake_io__bad_value(v[i]);
        if (what)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %c%03X: value %zu is %s", path, letter,
                                (unsigned)m, i, what);
    }
    return SG_OK;
}

/* Model m's samples and sites (stage SITES) into x; counts from JOBS. */
static sg_status load_sites(const sg_bake_file *f, const char *path, const sg_world *w, size_t m, int level,
                            uint64_t count, uint64_t gathered, int with_sites, sg_bake_job_model *x, sg_error *err)
{
    size_t splats = x->ps->count;
    sg_sample_set *set = &x->set;
    if (!(set->splat = sg_alloc_array(count ? (size_t)count : 1, sizeof *set->splat)) ||
        !(set->level = sg_alloc_array(count ? (size_t)count : 1, sizeof *set->level)))
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    set->count = set->capacity = (size_t)count;
    sg_status st = read_exact(f, path, 'S', m, SG_BAKE_TYPE_U32, count, set->splat, err);
    if (st == SG_OK)
        st = read_exact(f, path, 'L', m, SG_BAKE_TYPE_U8, count, set->level, err);
    for (size_t k = 0; k < count && st == SG_OK; ++k)
        if (set->splat[k] >= splats || set->level[k] > level)
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: model %zu, sample point %zu: splat %" PRIu32
                                                   " of %zu, level %d of %d",
                              path, m, k, set->splat[k], splats, (int)set->level[k], level);
    if (st != SG_OK || !with_sites)
        return st;
    sg_site_data *sd = &x->sites;
    size_t g = (size_t)gathered;
    sd->capacity = g ? g : 1;
    if (!(sd->ratio = sg_alloc_array(6 * sd->capacity, sizeof(float))) ||
        !(sd->unshadowed = sg_alloc_array(6 * sd->capacity, sizeof(float))) ||
        !(sd->sigma = sg_alloc_array(2 * sd->capacity, sizeof(float))) ||
        !(sd->dist = sg_alloc_array(2 * sd->capacity, sizeof(float))) ||
        !(sd->first = sg_calloc_array(2 * sd->capacity + 1, sizeof(size_t))))
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    if ((st = read_exact(f, path, 'R', m, SG_BAKE_TYPE_F32, 6 * gathered, sd->ratio, err)) != SG_OK ||
        (st = read_exact(f, path, 'U', m, SG_BAKE_TYPE_F32, 6 * gathered, sd->unshadowed, err)) != SG_OK ||
        (st = read_exact(f, path, 'Q', m, SG_BAKE_TYPE_F32, 2 * gathered, sd->sigma, err)) != SG_OK ||
        (st = read_exact(f, path, 'D', m, SG_BAKE_TYPE_F32, 2 * gathered, sd->dist, err)) != SG_OK ||
        (st = read_exact(f, path, 'F', m, SG_BAKE_TYPE_U64, g ? 2 * gathered + 1 : 0, sd->first, err)) != SG_OK)
        return st;
    if ((st = check_floats(path, 'R', m, sd->ratio, 6 * g, 0, err)) != SG_OK ||
        (st = check_floats(path, 'U', m, sd->unshadowed, 6 * g, 0, err)) != SG_OK ||
        (st = check_floats(path, 'Q', m, sd->sigma, 2 * g, 0, err)) != SG_OK ||
        (st = check_floats(path, 'D', m, sd->dist, 2 * g, 1, err)) != SG_OK)
        return st;
    for (size_t i = 0; i < 2 * g; ++i)
        if (sd->first[i + 1] < sd->first[i] || (i == 0 && sd->first[0] != 0))
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: section F%03X: site %zu's hits do not follow its "
                                                     "predecessor's",
                                path, (unsigned)m, i);
    /* first[2g] is bounded by H's size, which the file bounds */
    char tag[8];
    tag_of(tag, 'H', m);
    const sg_bake_section *sh = sg_bake_file_find(f, tag);
    uint64_t hits = g ? sd->first[2 * g] : 0;
    if (!sh || sh->count != hits)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s is %s (the sites name %" PRIu64 " hits)", path, tag,
                            sh ? "of the wrong length" : "missing", hits);
    sd->hit_capacity = hits ? (size_t)hits : 1;
    if (!(sd->hit_splat = sg_alloc_array(sd->hit_capacity, sizeof(uint32_t))) ||
        !(sd->hit_model = sg_alloc_array(sd->hit_capacity, sizeof(uint32_t))) ||
        !(sd->hit_k = sg_alloc_array(sd->hit_capacity, sizeof(float))))
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %" PRIu64 " hits", path, hits);
    if ((st = read_exact(f, path, 'H', m, SG_BAKE_TYPE_U32, hits, sd->hit_splat, err)) != SG_OK ||
        (st = read_exact(f, path, 'M', m, SG_BAKE_TYPE_U32, hits, sd->hit_model, err)) != SG_OK ||
        (st = read_exact(f, path, 'K', m, SG_BAKE_TYPE_F32, hits, sd->hit_k, err)) != SG_OK)
        return st;
    size_t models = sg_world_model_count(w);
    for (size_t h = 0; h < hits; ++h) {
        uint32_t hm = sd->hit_model[h] >> 1;
        if (hm >= models || sd->hit_splat[h] >= sg_scene_sites(sg_world_scene(w, hm))->count ||
            !(sd->hit_k[h] > 0.0f) || !isfinite(sd->hit_k[h]))
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: model %zu, hit %zu: splat %" PRIu32 " of model %" PRIu32
                                                     ", weight %g: not in the scene or not a weight",
                                path, m, h, sd->hit_splat[h], hm, (double)sd->hit_k[h]);
    }
    sd->count = g;
    sd->hits = (size_t)hits;
    return SG_OK;
}

sg_status sg_bake_job_load(const char *path, const sg_world *w, const sg_bake_desc *desc, uint64_t scene_hash,
                           sg_bake_job **out, sg_error *err)
{
    assert(path && w && out);
    sg_bake_desc want = sg_bake_desc_resolve(desc);
    sg_bake_file *f = NULL;
    sg_bake_job *j = NULL;
    uint64_t *head = NULL;
    sg_status st = sg_bake_file_open(path, scene_hash, 0, &f, err);
    if (st != SG_OK)
        return st;
    if (!(sg_bake_file_info(f)->flags & SG_BAKE_FLAG_CHECKPOINT)) {
        st = sg_error_set(err, SG_ERR_INVALID_ARG, "%s: a finished bake, not a checkpoint", path);
        goto done;
    }
    uint64_t meta[SG_BAKE_META_COUNT];
    sg_bake_desc d;
    if ((st = sg_bake_io__read_meta(f, path, meta, &d, err)) != SG_OK)
        goto done;
    if (sg_bake_param_hash(&d) != sg_bake_param_hash(&want)) {
        char had[400], asked[400];
        sg_bake_io__describe(&d, meta[META_BLOCK], had, sizeof had);
        sg_bake_io__describe(&want, SG_PHOTON_BLOCK, asked, sizeof asked);
        st = sg_error_set(err, SG_ERR_INVALID_ARG, "%s: made with other bake parameters (%s) than these (%s)", path,
                          had, asked);
        goto done;
    }
    size_t models = sg_world_model_count(w);
    const sg_bake_section *js = sg_bake_file_find(f, "JOBS");
    if (!js || js->type != SG_BAKE_TYPE_U64 || js->count < JOB_HEAD || js->count != JOB_HEAD + JOB_PER_MODEL * models) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section JOBS is %s (the scene has %zu models)", path,
                          js ? "of the wrong type or length" : "missing", models);
        goto done;
    }
    if (!(head = sg_alloc_array((size_t)js->count, sizeof *head))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    if ((st = sg_bake_file_read(f, "JOBS", head, js->size, err)) != SG_OK)
        goto done;
    uint64_t stage = head[0], level = head[1], prepared = head[2];
    if (stage > SG_BAKE_STAGE_GLOSSY || (stage == SG_BAKE_STAGE_PHOTONS && d.indirect != SG_BAKE_INDIRECT_PHOTONS) ||
        level > (uint64_t)(d.refine_levels > 0 ? d.refine_levels : 0) || prepared > 1 ||
        (stage == SG_BAKE_STAGE_GLOSSY && !prepared) || head[3] != models) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section JOBS: stage %" PRIu64 ", level %" PRIu64
                                               ", %" PRIu64 " models do not fit these parameters and this scene",
                          path, stage, level, head[3]);
        goto done;
    }
    if ((st = sg_bake_job__new(w, &d, (sg_bake_stage)stage, (int)level, &j, err)) != SG_OK)
        goto done;
    j->prepared = (int)prepared;
    if (stage == SG_BAKE_STAGE_PHOTONS) {
        st = load_photons(f, path, meta, &d, models, &j->pm, err);
        goto loaded;
    }
    if (d.indirect == SG_BAKE_INDIRECT_PHOTONS) { /* the pass's figures, which the bake file keeps */
        sg_bake_stats *s = sg_bake__stats(j->b);
        s->photons_shot = (size_t)meta[META_SHOT];
        s->photon_records = (size_t)meta[META_RECORDS];
        s->rays = (sg_ray_stats){meta[META_RAYS], meta[META_RAYS + 1], meta[META_RAYS + 2],
                                 meta[META_RAYS + 3], meta[META_RAYS + 4], meta[META_RAYS + 5]};
    }
    for (size_t m = 0; m < models && st == SG_OK; ++m) {
        sg_bake_job_model *x = &j->mw[m];
        uint64_t count = head[JOB_HEAD + JOB_PER_MODEL * m], gathered = head[JOB_HEAD + JOB_PER_MODEL * m + 1],
                 gdone = head[JOB_HEAD + JOB_PER_MODEL * m + 2];
        size_t n = x->ps->count;
        float *E = sg_bake__light(j->b, (uint32_t)m);
        if ((st = read_exact(f, path, 'E', m, SG_BAKE_TYPE_F32, SG_BAKE_SPLAT_FLOATS * (uint64_t)n, E, err)) != SG_OK ||
            (st = check_floats(path, 'E', m, E, SG_BAKE_SPLAT_FLOATS * n, 0, err)) != SG_OK)
            break;
        int sampled = x->sampled && prepared;
        if (count > n || gathered > count || gdone > count || (!sampled && (count || gathered || gdone)) ||
            (stage != SG_BAKE_STAGE_GLOSSY && gdone)) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section JOBS: model %zu: %" PRIu64 " sample points, %" PRIu64
                                                   " traced, %" PRIu64 " glossy, of %zu splats do not fit",
                              path, m, count, gathered, gdone, n);
            break;
        }
        if (!sampled)
            continue;
        if ((st = load_sites(f, path, w, m, (int)level, count, gathered, stage == SG_BAKE_STAGE_SITES, x, err)) !=
            SG_OK)
            break;
        if (stage != SG_BAKE_STAGE_GLOSSY || gdone == 0)
            continue;
        const sg_material *mat = sg_world_material(w, (uint32_t)m);
        int res = sg_glossy_material(mat) ? (d.glossy_res ? d.glossy_res : sg_glossy_default_res(mat)) : 0;
        if (!res) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section JOBS: model %zu has glossy bins but no glossy "
                                                   "material", path, m);
            break;
        }
        if ((st = sg_bake__alloc_glossy(j->b, (uint32_t)m, res, (size_t)count, err)) != SG_OK)
            break;
        uint32_t *gs, *gn;
        uint16_t *gb;
        sg_bake__glossy(j->b, (uint32_t)m, &gs, &gn, &gb);
        uint64_t nb = 3 * (uint64_t)res * (uint64_t)res * gdone;
        if ((st = read_exact(f, path, 'G', m, SG_BAKE_TYPE_F16, nb, gb, err)) != SG_OK)
            break;
        for (uint64_t k = 0; k < nb; ++k)
            if ((gb[k] & 0x8000u) || (gb[k] & 0x7c00u) == 0x7c00u) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section G%03X: value %" PRIu64 " is %s", path,
                                  (unsigned)m, k, (gb[k] & 0x7c00u) == 0x7c00u ? "not finite" : "negative");
                break;
            }
        x->glossy_done = (size_t)gdone;
    }
loaded:
    if (st != SG_OK)
        goto done;
    *out = j;
    j = NULL;
done:
    sg_bake_job_destroy(j);
    sg_free(head);
    sg_bake_file_close(f);
    return st;
}
