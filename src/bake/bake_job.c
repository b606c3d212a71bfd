/* bake_job.c — the bake's pipeline (bake.c describes it) as a job in
 * stages that can stop between blocks and continue (see bake_job.h; the
 * job's state and its invariants: bake_job_int.h).
 *
 * Transitions and the function behind each:
 *   created (sg_bake_job_create, or loaded: bake_io.c) ->
 *   PHOTONS  run_photons: blocks of the photon pass; when all are traced,
 *            their kNN estimate becomes each splat's indirect light ->
 *   SITES    run_sites: level-0 sample points (prepare), then per level the
 *            sites' rays (sg_transport_gather, resumable per sample) and,
 *            below refine_levels, the solve and the refinement that adds
 *            the next level; at the end the final solve and the
 *            interpolation of every site's light to every splat ->
 *   GLOSSY   run_glossy: the bins of glossy models, block by block ->
 *   DONE     sg_bake_job_finish hands the bake over.
 * Every decision (refinement, interpolation) reads only state that is the
 * same however the work was split, so a resumed job ends in the same bits.
 */
#include "bake/bake_job_int.h"

#include <assert.h>
#include <math.h>
#include <omp.h>
#include <string.h>

#include "bake/glossy.h"
#include "bake/irradiance.h"
#include "core/alloc.h"
#include "envmap/irradiance_table.h"

/* Refinement of the sample points (samples.h): levels at s/2, s/4, ...
 * (refine_levels), where neighbouring visibility ratios differ by more than
 * half the larger value (a shadow edge differs by a factor 2 or more) and
 * by more than three standard errors of the difference (noise alone, which
 * at 4 + 4 rays often exceeds 50%, then refines almost nowhere), or where
 * a lit site's harmonic mean distance to what its rays see (Ward 1988's
 * R_h: indirect light changes over about that distance) is below
 * REFINE_DISTANCE spacings. Interpolation support: twice a sample's spacing
 * (a splat then sees about 4 pi samples, which averages their noise
 * without reaching past the next ring). */
static const float REFINE_THRESHOLD = 0.5f;
static const float REFINE_DISTANCE = 1.0f;
static const float SUPPORT = 2.0f;

enum {
    PHOTON_CHUNK = 16, /* photon blocks per call of sg_photons_trace_more  */
    GLOSSY_CHUNK = 32, /* glossy sample points per call of sg_glossy_bake  */
    /* Distributed rounds (bake_comm.h), per rank: enough work that an
     * exchange (a few MB at most) costs little next to it, little enough
     * that a cancel is seen within a second or so. */
    DIST_SITES = 512,          /* sample points' sites per rank and round,
                                  at most                                    */
    DIST_SITE_RAYS = 1 << 19,  /* rays per rank and round, at most (well
                                  under a second): many rays per site mean
                                  fewer sites per round, so that a Ctrl-C
                                  under mpirun, which kills the ranks a
                                  second after asking (docs/mpi.md), still
                                  finds them at a round's end              */
    DIST_GLOSSY = 4 * GLOSSY_CHUNK /* glossy sample points per rank and round */
};

/* ---- models ---------------------------------------------------------------- */

static void model_free(sg_bake_job_model *x)
{
    sg_sample_set_free(&x->set);
    sg_site_data_free(&x->sites);
    sg_free(x->e0);
    sg_free(x->nearest);
    sg_free(x->indirect);
    sg_free(x->off_surface);
    memset(x, 0, sizeof *x);
}

/* Spacing, random key base and e0 of every model (no samples yet). */
static sg_status setup_models(sg_bake_job *j, sg_error *err)
{
    const sg_bake_desc *d = &j->d;
    int direct = d->direct_samples > 0, transport = d->indirect == SG_BAKE_INDIRECT_TRANSPORT;
    const sg_irradiance_table *e0 = sg_bake__table(j->b);
    int threads = d->gather.threads > 0 ? d->gather.threads : omp_get_max_threads();
    uint64_t key_base = 0;
    for (size_t m = 0; m < j->models; ++m) {
        sg_bake_job_model *x = &j->mw[m];
        x->ps = sg_scene_sites(sg_world_scene(j->w, (uint32_t)m));
        x->key_base = key_base;
        key_base += x->ps->count;
        const sg_material *mat = sg_world_material(j->w, (uint32_t)m);
        x->sampled = x->ps->count > 0 && (direct || transport || sg_glossy_material(mat));
        if (!x->sampled)
            continue;
        x->s0 = -1.0f;
        if (d->sample_spacing >= 0.0f) {
            float med;
            sg_status st = sg_samples_median_radius(x->ps, &med, err);
            if (st != SG_OK)
                return st;
            x->s0 = (d->sample_spacing > 0.0f ? d->sample_spacing : sg_samples_default_spacing(mat)) * med;
        }
        if (x->s0 > 0.0f) { /* sites off the surface are only interpolated to */
            if (!(x->off_surface = sg_alloc_array(x->ps->count, sizeof *x->off_surface)))
                return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu splats", x->ps->count);
            if (sg_transport_off_surface_sites(j->w, (uint32_t)m, threads, x->off_surface) > 0 ||
                x->ps->unsampled) { /* the scene's own unsampled sites are marked too */
                x->view = *x->ps;
                x->view.unsampled = x->off_surface;
                x->ps = &x->view;
            } else {
                sg_free(x->off_surface);
                x->off_surface = NULL;
            }
        }
        if (!direct)
            continue;
        if (!(x->e0 = sg_alloc_array(6 * x->ps->count, sizeof *x->e0)))
            return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu splats", x->ps->count);
        const sg_sites *ps = x->ps;
        float *out = x->e0;
#pragma omp parallel for schedule(static) num_threads(threads)
        for (size_t i = 0; i < ps->count; ++i) {
            sg_vec3 n = sg_sites_normal(ps, i);
            sg_vec3 f = sg_irradiance_table_eval(e0, n), k = sg_irradiance_table_eval(e0, sg_v3_scale(n, -1.0f));
            float *o = out + 6 * i;
            o[0] = f.x, o[1] = f.y, o[2] = f.z, o[3] = k.x, o[4] = k.y, o[5] = k.z;
        }
    }
    return SG_OK;
}

/* Level-0 sample points of every sampled model. */
static sg_status first_samples(sg_bake_job *j, sg_error *err)
{
    for (size_t m = 0; m < j->models; ++m) {
        sg_bake_job_model *x = &j->mw[m];
        if (!x->sampled)
            continue;
        if (x->s0 > 0.0f) {
            sg_status st = sg_samples_thin(x->ps, x->s0, j->d.gather.normal_cos, NULL, 0, 0, &x->set, err);
            if (st != SG_OK)
                return st;
            continue;
        }
        if (!(x->set.splat = sg_alloc_array(x->ps->count, sizeof *x->set.splat)) ||
            !(x->set.level = sg_calloc_array(x->ps->count, sizeof *x->set.level)))
            return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu sample points", x->ps->count);
        for (size_t i = 0; i < x->ps->count; ++i)
            x->set.splat[i] = (uint32_t)i;
        x->set.count = x->set.capacity = x->ps->count;
    }
    j->prepared = 1;
    return SG_OK;
}

static sg_status nearest_samples(sg_bake_job_model *x, float normal_cos, int threads, sg_error *err)
{
    sg_free(x->nearest);
    if (!(x->nearest = sg_alloc_array(x->ps->count ? x->ps->count : 1, sizeof *x->nearest)))
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu splats' sample points", x->ps->count);
    if (x->s0 > 0.0f)
        return sg_samples_nearest(x->ps, &x->set, x->s0, normal_cos, threads, x->nearest, err);
    for (size_t i = 0; i < x->ps->count; ++i)
        x->nearest[i] = (uint32_t)i;
    return SG_OK;
}

/* ---- the sites ------------------------------------------------------------- */

/* The transport solve over every model's current sites. */
static sg_status solve_indirect(sg_bake_job *j, sg_error *err)
{
    sg_transport_model *tm = sg_calloc_array(j->models, sizeof *tm);
    float **ind = sg_calloc_array(j->models, sizeof *ind);
    sg_status st = SG_OK;
    if (!tm || !ind) {
        st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
        goto done;
    }
    for (size_t m = 0; m < j->models && st == SG_OK; ++m) {
        sg_bake_job_model *x = &j->mw[m];
        assert(x->sampled && x->sites.count == x->set.count); /* invariant 2, the level traced */
        if ((st = nearest_samples(x, j->d.gather.normal_cos, j->d.gather.threads, err)) != SG_OK)
            break;
        sg_free(x->indirect);
        if (!(x->indirect = sg_alloc_array(6 * (x->set.count ? x->set.count : 1), sizeof(float)))) {
            st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for the indirect light");
            break;
        }
        tm[m] = (sg_transport_model){.sites = &x->sites, .nearest = x->nearest, .e0 = x->e0};
        ind[m] = x->indirect;
    }
    if (st == SG_OK)
        st = sg_transport_solve(j->w, tm, 0, j->d.gather.threads, ind, &j->ts, err);
done:
    sg_free(tm);
    sg_free(ind);
    return st;
}

/* Marks the samples of `level` to refine: a jump of the visibility ratio
 * on either side (samples.h), or, with the transport estimator, a lit side
 * whose rays see surfaces closer than REFINE_DISTANCE spacings on the
 * harmonic mean (the indirect light varies over that distance; unlit
 * sides, such as the inside of a closed model, are left alone). */
static sg_status mark_refine(const sg_bake_desc *d, const sg_bake_job_model *x, uint8_t level, double lit_floor,
                             uint8_t *mark, sg_error *err)
{
    size_t n = x->set.count;
    float *v = sg_alloc_array(3 * (n ? n : 1), sizeof *v), *sg = sg_alloc_array(n ? n : 1, sizeof *sg);
    sg_status st = SG_OK;
    if (!v || !sg) {
        st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for refinement");
        goto done;
    }
    for (int side = 0; side < SG_SIDES && st == SG_OK; ++side) {
        for (size_t k = 0; k < n; ++k) {
            memcpy(v + 3 * k, x->sites.ratio + 6 * k + 3 * side, 3 * sizeof *v);
            sg[k] = x->sites.sigma[2 * k + (size_t)side];
        }
        st = sg_samples_mark_jumps(x->ps, x->s0, d->gather.normal_cos, v, sg, REFINE_THRESHOLD, level, &x->set,
                                   mark, err);
    }
    if (st != SG_OK || d->indirect != SG_BAKE_INDIRECT_TRANSPORT)
        goto done;
    float limit = REFINE_DISTANCE * ldexpf(x->s0, -(int)level);
    for (size_t k = 0; k < n; ++k) {
        if (x->set.level[k] != level || mark[k])
            continue;
        for (int side = 0; side < SG_SIDES; ++side) {
            const float *e0 = x->e0 + 6 * (size_t)x->set.splat[k] + 3 * side;
            const float *D = x->sites.ratio + 6 * k + 3 * side, *I = x->indirect + 6 * k + 3 * side;
            double lit = 0.2126 * (e0[0] * D[0] + I[0]) + 0.7152 * (e0[1] * D[1] + I[1]) +
                         0.0722 * (e0[2] * D[2] + I[2]);
            if (lit > lit_floor && x->sites.dist[2 * k + (size_t)side] < limit)
                mark[k] = 1;
        }
    }
done:
    sg_free(v);
    sg_free(sg);
    return st;
}

/* Mean luminance of the light at all sites of every model: the scale below
 * which a side counts as unlit for refinement (1% of it). */
static double mean_site_light(const sg_bake_job *j)
{
    static const double Y[3] = {0.2126, 0.7152, 0.0722};
    double sum = 0.0;
    size_t n = 0;
    for (size_t m = 0; m < j->models; ++m) {
        const sg_bake_job_model *x = &j->mw[m];
        for (size_t k = 0; x->sampled && k < x->set.count; ++k) {
            const float *e0 = x->e0 + 6 * (size_t)x->set.splat[k];
            const float *D = x->sites.ratio + 6 * k, *I = x->indirect ? x->indirect + 6 * k : NULL;
            for (int c = 0; c < 3; ++c)
                sum += Y[c] * (e0[c] * D[c] + (I ? I[c] : 0.0f));
            ++n;
        }
    }
    return n ? sum / (double)n : 0.0;
}

/* Refinement after a level is traced: marks, thinning at half the spacing;
 * *added gets the new samples over all models. */
static sg_status refine(sg_bake_job *j, size_t *added, sg_error *err)
{
    *added = 0;
    sg_status st = SG_OK;
    if (j->d.indirect == SG_BAKE_INDIRECT_TRANSPORT && (st = solve_indirect(j, err)) != SG_OK)
        return st;
    double floor_lit = 0.01 * mean_site_light(j);
    for (size_t m = 0; m < j->models && st == SG_OK; ++m) {
        sg_bake_job_model *x = &j->mw[m];
        if (!x->sampled || !(x->s0 > 0.0f))
            continue;
        uint8_t *mark = sg_calloc_array(x->set.count ? x->set.count : 1, sizeof *mark);
        size_t n = 0;
        if (!mark)
            return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for refinement");
        st = mark_refine(&j->d, x, (uint8_t)j->level, floor_lit, mark, err);
        if (st == SG_OK)
            st = sg_samples_refine_marked(x->ps, x->s0, j->d.gather.normal_cos, mark, (uint8_t)j->level, &x->set, &n,
                                          err);
        sg_free(mark);
        *added += n;
    }
    return st;
}

/* Sites to splats: 12 channels per sample (per side the visibility ratio
 * and the indirect light), interpolated (samples.h) or copied when every
 * splat is a sample; the indirect light adds to what the bake holds (the
 * photon estimate, or zero). */
static sg_status interpolate(sg_bake_job *j, sg_error *err)
{
    sg_status st = SG_OK;
    float *vals = NULL, *out = NULL;
    for (size_t m = 0; m < j->models && st == SG_OK; ++m) {
        sg_bake_job_model *x = &j->mw[m];
        if (!x->sampled || j->d.direct_samples <= 0)
            continue;
        size_t n = x->set.count, ns = x->ps->count;
        sg_free(vals);
        sg_free(out);
        vals = sg_alloc_array(12 * (n ? n : 1), sizeof *vals);
        out = x->s0 > 0.0f ? sg_alloc_array(12 * ns, sizeof *out) : NULL;
        if (!vals || (x->s0 > 0.0f && !out)) {
            st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for the interpolation of %zu splats", ns);
            break;
        }
        for (size_t k = 0; k < n; ++k) {
            memcpy(vals + 12 * k, x->sites.ratio + 6 * k, 6 * sizeof *vals);
            if (x->indirect)
                memcpy(vals + 12 * k + 6, x->indirect + 6 * k, 6 * sizeof *vals);
            else
                memset(vals + 12 * k + 6, 0, 6 * sizeof *vals);
        }
        const float *v = vals;
        if (x->s0 > 0.0f) {
            st = sg_samples_interpolate_n(x->ps, &x->set, x->s0, SUPPORT, j->d.gather.normal_cos, vals, 12,
                                          j->d.gather.threads, out, err);
            v = out;
        }
        float *E = sg_bake__light(j->b, (uint32_t)m);
        for (size_t i = 0; i < ns && st == SG_OK; ++i)
            for (int side = 0; side < SG_SIDES; ++side)
                for (int c = 0; c < 3; ++c) {
                    float *o = E + SG_BAKE_SPLAT_FLOATS * i + 6 * side;
                    float r = v[12 * i + 3 * side + c], ind = o[3 + c] + v[12 * i + 6 + 3 * side + c];
                    o[c] = isfinite(r) && r > 0.0f ? r : 0.0f; /* bake.c invariant 1 */
                    o[3 + c] = isfinite(ind) && ind > 0.0f ? ind : 0.0f;
                }
        /* Sites made of others (the hybrid's nodes) from their final light:
         * means of non-negative finite values keep invariant 1. */
        if (st == SG_OK)
            sg_scene_filter_sites(sg_world_scene(j->w, (uint32_t)m), E, SG_BAKE_SPLAT_FLOATS);
    }
    sg_free(vals);
    sg_free(out);
    return st;
}

/* ---- running ------------------------------------------------------------------ */

typedef struct runner {
    sg_bake_job *j;
    sg_bake_progress_fn fn;
    void *user;
    double last;       /* when fn was last called                         */
    double every;      /* least time between calls                        */
    int stop;          /* fn asked to stop                                 */
    size_t base;       /* SITES: samples traced before the current call    */
} runner;

/* Calls fn when `every` has passed (or `force`); returns the stop flag. */
static int report(runner *r, size_t done, size_t total, int force)
{
    if (!r->fn || r->stop)
        return r->stop;
    double now = omp_get_wtime();
    if (!force && r->every >= 0.0 && now - r->last < r->every)
        return 0;
    r->last = now;
    sg_bake_progress p = {.stage = r->j->stage, .level = r->j->level, .done = done, .total = total};
    r->stop = r->fn(r->user, &p) != 0;
    return r->stop;
}

static int on_photons(void *user, size_t done, size_t total) { return report(user, done, total, 0); }

static int sites_progress(runner *r, int force)
{
    size_t all = 0, traced = 0;
    for (size_t m = 0; m < r->j->models; ++m) {
        all += r->j->mw[m].set.count;
        traced += r->j->mw[m].sites.count;
    }
    return report(r, traced, all, force);
}

static int on_sites(void *user, size_t done, size_t total)
{
    (void)done;
    (void)total;
    return sites_progress(user, 0);
}

/* Distributed rounds ask before every exchange (a round is a fraction of
 * a second of work or more), so a Ctrl-C is agreed on at the next round;
 * the program's display keeps its own pace. */
static void sites_report(runner *r) { sites_progress(r, 1); }

/* ---- distributed rounds (bake_comm.h) ----------------------------------------- */

/* Sends this rank's piece (freed here) and receives every rank's, in rank
 * order; the stop flags are combined into r->stop, so every rank decides
 * the same. */
static sg_status exchange(runner *r, void *mine, size_t bytes, void **all, size_t *all_bytes, sg_error *err)
{
    const sg_bake_comm *c = &r->j->comm;
    int stop = r->stop;
    *all = NULL;
    *all_bytes = 0;
    sg_status st = c->exchange(c->user, mine, bytes, all, all_bytes, &stop, err);
    sg_free(mine);
    if (st == SG_OK)
        r->stop = stop;
    return st;
}

/* A round with no data: every rank learns whether any asked to stop. */
static sg_status agree_stop(runner *r, sg_error *err)
{
    void *all;
    size_t n;
    sg_status st = exchange(r, NULL, 0, &all, &n, err);
    sg_free(all);
    return st;
}

/* The photon pass in rounds: each rank traces its share of the round's
 * blocks; the pieces, appended in rank order, continue the map exactly as
 * one process's blocks would (photons.h). */
static sg_status photons_dist(runner *r, const sg_photon_desc *pd, size_t nblocks, sg_error *err)
{
    sg_bake_job *j = r->j;
    const sg_bake_comm *c = &j->comm;
    while (j->pm.blocks < nblocks) {
        double t0 = omp_get_wtime();
        size_t left = nblocks - j->pm.blocks, per = (size_t)PHOTON_CHUNK * (size_t)c->size;
        size_t lo, hi;
        sg_bake_comm_share(left < per ? left : per, c->size, c->rank, &lo, &hi);
        sg_photon_map piece = {.blocks = j->pm.blocks + hi};
        void *buf = NULL, *all = NULL;
        size_t bytes = 0, all_bytes = 0, at = 0;
        sg_status st = SG_OK;
        if (hi > lo)
            st = sg_photons_trace_range(j->w, pd, j->pm.blocks + lo, j->pm.blocks + hi, &piece, err);
        if (st == SG_OK)
            st = sg_photon_map_pack(&piece, j->pm.blocks + lo, &buf, &bytes, err);
        sg_photon_map_free(&piece);
        report(r, j->pm.shot, pd->count, 1);
        if (st == SG_OK)
            st = exchange(r, buf, bytes, &all, &all_bytes, err);
        for (int k = 0; k < c->size && st == SG_OK; ++k) {
            size_t used;
            st = sg_photon_map_append_packed(&j->pm, pd, (const char *)all + at, all_bytes - at, &used, err);
            at += used;
        }
        if (st == SG_OK && at != all_bytes)
            st = sg_error_set(err, SG_ERR_CORRUPT, "photons: %zu bytes left over after a round", all_bytes - at);
        sg_free(all);
        j->pm.seconds += omp_get_wtime() - t0;
        if (st != SG_OK)
            return st;
        if (r->stop)
            return sg_error_set(err, SG_ERR_CANCELLED, "photons: cancelled after %zu of %zu photons", j->pm.shot,
                                pd->count);
    }
    return SG_OK;
}

/* The sites of model m's samples [sites.count, set.count) in rounds: each
 * rank traces its share of the round's samples (their random streams are
 * keyed by splat, transport.h), the pieces appended in rank order. */
static sg_status sites_dist(runner *r, uint32_t m, const sg_transport_desc *td, sg_error *err)
{
    sg_bake_job *j = r->j;
    sg_bake_job_model *x = &j->mw[m];
    const sg_bake_comm *c = &j->comm;
    sg_transport_desc t = *td;
    t.progress = NULL; /* rounds are the unit of progress and cancel */
    while (x->sites.count < x->set.count) {
        size_t rays = 2 * ((size_t)td->env_rays + (size_t)td->cos_rays), each = DIST_SITE_RAYS / (rays ? rays : 1);
        each = each < 16 ? 16 : each > DIST_SITES ? DIST_SITES : each;
        size_t base = x->sites.count, left = x->set.count - base, per = each * (size_t)c->size;
        size_t lo, hi;
        sg_bake_comm_share(left < per ? left : per, c->size, c->rank, &lo, &hi);
        sg_sample_set share = {.count = hi - lo, .capacity = hi - lo, .splat = x->set.splat + base + lo,
                               .level = x->set.level + base + lo};
        sg_site_data mine = {0};
        void *buf = NULL, *all = NULL;
        size_t bytes = 0, all_bytes = 0, at = 0;
        sg_status st = sg_transport_gather(j->w, m, &share, x->key_base, &t, &mine, err);
        if (st == SG_OK)
            st = sg_site_data_pack(&mine, &buf, &bytes, err);
        sg_site_data_free(&mine);
        sites_report(r);
        if (st == SG_OK)
            st = exchange(r, buf, bytes, &all, &all_bytes, err);
        for (int k = 0; k < c->size && st == SG_OK; ++k) {
            size_t used;
            st = sg_site_data_append_packed(&x->sites, (const char *)all + at, all_bytes - at, &used, err);
            at += used;
        }
        if (st == SG_OK && (at != all_bytes || x->sites.count != base + (left < per ? left : per)))
            st = sg_error_set(err, SG_ERR_CORRUPT, "bake: a round of sites of model %u came back with %zu samples",
                              m, x->sites.count - base);
        sg_free(all);
        if (st != SG_OK)
            return st;
        if (r->stop)
            return sg_error_set(err, SG_ERR_CANCELLED, "bake: cancelled after %zu of %zu sample points",
                                x->sites.count, x->set.count);
    }
    return SG_OK;
}

/* Glossy bins of model m's samples [glossy_done, count) in rounds, into
 * bins (stride halves per sample), as sites_dist. */
static sg_status glossy_dist(runner *r, uint32_t m, const uint32_t *splat, int res, size_t stride, uint16_t *bins,
                             size_t *done, size_t total, sg_error *err)
{
    sg_bake_job *j = r->j;
    sg_bake_job_model *x = &j->mw[m];
    const sg_bake_comm *c = &j->comm;
    while (x->glossy_done < x->set.count) {
        size_t base = x->glossy_done, left = x->set.count - base, per = (size_t)DIST_GLOSSY * (size_t)c->size;
        size_t round = left < per ? left : per, lo, hi;
        sg_bake_comm_share(round, c->size, c->rank, &lo, &hi);
        void *all = NULL;
        size_t all_bytes = 0;
        sg_status st = SG_OK;
        uint16_t *mine = sg_alloc_array((hi - lo) * stride + 1, sizeof *mine);
        if (!mine)
            return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory for %zu glossy sample points", hi - lo);
        for (size_t s = lo; s < hi && st == SG_OK; s += GLOSSY_CHUNK) {
            size_t n = hi - s < GLOSSY_CHUNK ? hi - s : GLOSSY_CHUNK;
            st = sg_glossy_bake(j->w, j->b, m, splat + base + s, n, x->key_base, res, j->d.glossy_rays,
                                j->d.photons.seed ^ 0x6105ull, j->d.gather.threads, mine + (s - lo) * stride, err);
        }
        report(r, *done, total, 1);
        if (st != SG_OK) {
            sg_free(mine);
            return st;
        }
        if ((st = exchange(r, mine, (hi - lo) * stride * sizeof *mine, &all, &all_bytes, err)) != SG_OK)
            return st;
        if (all_bytes != round * stride * sizeof *bins) {
            sg_free(all);
            return sg_error_set(err, SG_ERR_CORRUPT, "bake: a round of %zu glossy sample points came back with "
                                "%zu bytes", round, all_bytes);
        }
        memcpy(bins + base * stride, all, all_bytes); /* rank order = sample order */
        sg_free(all);
        x->glossy_done += round;
        *done += round;
        if (r->stop)
            return sg_error_set(err, SG_ERR_CANCELLED, "bake: cancelled in the glossy bins");
    }
    return SG_OK;
}

static sg_status run_photons(runner *r, sg_error *err)
{
    sg_bake_job *j = r->j;
    sg_photon_desc pd = j->d.photons;
    pd.progress = on_photons;
    pd.progress_user = r;
    pd.progress_seconds = -1.0; /* the runner keeps time */
    size_t nblocks = sg_photon_block_count(&pd);
    if (j->distributed) {
        sg_status st = photons_dist(r, &pd, nblocks, err);
        if (st != SG_OK)
            return st;
    }
    while (j->pm.blocks < nblocks) {
        size_t last = j->pm.blocks + PHOTON_CHUNK < nblocks ? j->pm.blocks + PHOTON_CHUNK : nblocks;
        sg_status st = sg_photons_trace_more(j->w, &pd, last, &j->pm, err);
        if (st != SG_OK)
            return st; /* SG_ERR_CANCELLED keeps the completed prefix (photons.h) */
    }
    report(r, j->pm.shot, pd.count, 1);
    float **E = NULL;
    double t0 = omp_get_wtime();
    sg_status st = sg_irradiance_gather(j->w, &j->pm, &j->d.gather, &E, err);
    if (st != SG_OK)
        return st;
    j->shared_seconds += omp_get_wtime() - t0;
    for (size_t m = 0; m < j->models; ++m) { /* the photons' E per side is indirect light */
        float *L = sg_bake__light(j->b, (uint32_t)m);
        size_t n = j->mw[m].ps->count;
        for (size_t i = 0; i < n; ++i)
            for (int side = 0; side < SG_SIDES; ++side)
                memcpy(L + SG_BAKE_SPLAT_FLOATS * i + 6 * side + 3, E[m] + 6 * i + 3 * side, 3 * sizeof(float));
        sg_free(E[m]);
    }
    sg_free(E);
    sg_bake_stats *s = sg_bake__stats(j->b);
    s->trace_seconds = j->pm.seconds;
    s->photons_shot = j->pm.shot;
    s->photon_records = j->pm.count;
    s->rays = j->pm.rays;
    s->photon_memory_bytes = sg_photon_map_bytes(j->pm.count);
    if (j->pm_borrowed)
        memset(&j->pm, 0, sizeof j->pm);
    else
        sg_photon_map_free(&j->pm);
    j->pm_borrowed = 0;
    j->stage = SG_BAKE_STAGE_SITES;
    return SG_OK;
}

static sg_status run_sites(runner *r, sg_error *err)
{
    sg_bake_job *j = r->j;
    sg_status st = SG_OK;
    if (j->d.direct_samples <= 0) { /* photons carry everything: no rays from sites */
        j->stage = SG_BAKE_STAGE_GLOSSY;
        return j->prepared ? SG_OK : first_samples(j, err);
    }
    double t0 = omp_get_wtime();
    if (!j->prepared && (st = first_samples(j, err)) != SG_OK)
        return st;
    j->shared_seconds += omp_get_wtime() - t0;
    sg_transport_desc td = {.env_rays = j->d.direct_samples, .cos_rays = j->d.gather_rays,
                            .seed = j->d.photons.seed ^ 0xD1EC7ull, .threads = j->d.gather.threads,
                            .ray_cone = j->d.ray_cone,
                            .progress = on_sites, .progress_user = r};
    for (;;) {
        for (size_t m = 0; m < j->models; ++m) {
            sg_bake_job_model *x = &j->mw[m];
            if (!x->sampled)
                continue;
            st = j->distributed ? sites_dist(r, (uint32_t)m, &td, err)
                                : sg_transport_gather(j->w, (uint32_t)m, &x->set, x->key_base, &td, &x->sites, err);
            if (st != SG_OK)
                return st; /* SG_ERR_CANCELLED: sites.count says how far (invariant 2) */
        }
        on_sites(r, 0, 0);
        if (j->distributed && (st = agree_stop(r, err)) != SG_OK)
            return st;
        if (r->stop)
            return sg_error_set(err, SG_ERR_CANCELLED, "bake: cancelled after level %d", j->level);
        size_t added = 0;
        t0 = omp_get_wtime();
        int last = j->level >= j->d.refine_levels || (st = refine(j, &added, err)) != SG_OK || added == 0;
        j->shared_seconds += omp_get_wtime() - t0;
        if (last)
            break;
        ++j->level;
    }
    if (st != SG_OK)
        return st;
    t0 = omp_get_wtime();
    if (j->d.indirect == SG_BAKE_INDIRECT_TRANSPORT && (st = solve_indirect(j, err)) != SG_OK)
        return st;
    if ((st = interpolate(j, err)) != SG_OK)
        return st;
    j->shared_seconds += omp_get_wtime() - t0;
    j->stage = SG_BAKE_STAGE_GLOSSY;
    return SG_OK;
}

static int glossy_res(const sg_bake_job *j, uint32_t m)
{
    const sg_material *mat = sg_world_material(j->w, m);
    if (!sg_glossy_material(mat) || !j->mw[m].sampled || j->mw[m].set.count == 0)
        return 0;
    return j->d.glossy_res ? j->d.glossy_res : sg_glossy_default_res(mat);
}

static sg_status run_glossy(runner *r, sg_error *err)
{
    sg_bake_job *j = r->j;
    size_t total = 0, done = 0;
    for (size_t m = 0; m < j->models; ++m)
        if (glossy_res(j, (uint32_t)m)) {
            total += j->mw[m].set.count;
            done += j->mw[m].glossy_done;
        }
    for (size_t m = 0; m < j->models; ++m) {
        sg_bake_job_model *x = &j->mw[m];
        int res = glossy_res(j, (uint32_t)m);
        if (!res)
            continue;
        int have;
        size_t count;
        const uint32_t *gs, *gn;
        const uint16_t *gb;
        sg_bake_glossy_data(j->b, (uint32_t)m, &have, &count, &gs, &gn, &gb);
        sg_status st = SG_OK;
        if (!have && (st = sg_bake__alloc_glossy(j->b, (uint32_t)m, res, x->set.count, err)) != SG_OK)
            return st;
        uint32_t *splat, *nearest;
        uint16_t *bins;
        sg_bake__glossy(j->b, (uint32_t)m, &splat, &nearest, &bins);
        memcpy(splat, x->set.splat, x->set.count * sizeof *splat);
        double t0 = omp_get_wtime();
        if (!x->nearest && (st = nearest_samples(x, j->d.gather.normal_cos, j->d.gather.threads, err)) != SG_OK)
            return st;
        j->shared_seconds += omp_get_wtime() - t0;
        memcpy(nearest, x->nearest, x->ps->count * sizeof *nearest);
        size_t stride = 3 * (size_t)res * (size_t)res;
        if (j->distributed && (st = glossy_dist(r, (uint32_t)m, splat, res, stride, bins, &done, total, err)) != SG_OK)
            return st;
        while (x->glossy_done < x->set.count) {
            if (report(r, done, total, 0))
                return sg_error_set(err, SG_ERR_CANCELLED, "bake: cancelled in the glossy bins");
            size_t n = x->set.count - x->glossy_done < GLOSSY_CHUNK ? x->set.count - x->glossy_done : GLOSSY_CHUNK;
            if ((st = sg_glossy_bake(j->w, j->b, (uint32_t)m, splat + x->glossy_done, n, x->key_base, res,
                                     j->d.glossy_rays, j->d.photons.seed ^ 0x6105ull, j->d.gather.threads,
                                     bins + x->glossy_done * stride, err)) != SG_OK)
                return st;
            x->glossy_done += n;
            done += n;
        }
    }
    if (total)
        report(r, done, total, 1);
    j->stage = SG_BAKE_STAGE_DONE;
    return SG_OK;
}

sg_status sg_bake_job_run(sg_bake_job *j, sg_bake_progress_fn progress, void *user, sg_error *err)
{
    if (!j->b)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake: the job was finished already");
    runner r = {.j = j, .fn = progress, .user = user, .last = omp_get_wtime(), .every = j->d.photons.progress_seconds};
    sg_status st = SG_OK;
    while (st == SG_OK && j->stage != SG_BAKE_STAGE_DONE) {
        double t0 = omp_get_wtime();
        sg_bake_stage at = j->stage;
        switch (at) {
        case SG_BAKE_STAGE_PHOTONS: st = run_photons(&r, err); break;
        case SG_BAKE_STAGE_SITES: st = run_sites(&r, err); break;
        case SG_BAKE_STAGE_GLOSSY: st = run_glossy(&r, err); break;
        default: st = sg_error_set(err, SG_ERR_INVALID_ARG, "bake: job in stage %d", (int)at); break;
        }
        j->seconds[at < 3 ? at : 2] += omp_get_wtime() - t0;
    }
    return st;
}

/* ---- life cycle ------------------------------------------------------------------ */

sg_status sg_bake_job__new(const sg_world *w, const sg_bake_desc *desc, sg_bake_stage stage, int level,
                           sg_bake_job **out, sg_error *err)
{
    sg_bake_desc d = sg_bake_desc_resolve(desc);
    if (d.glossy_res != 0 && (d.glossy_res < SG_GLOSSY_MIN_RES || d.glossy_res > SG_GLOSSY_MAX_RES))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake: glossy resolution %d is not in %d..%d", d.glossy_res,
                            SG_GLOSSY_MIN_RES, SG_GLOSSY_MAX_RES);
    if (d.indirect == SG_BAKE_INDIRECT_PHOTONS && d.photons.count > ((size_t)1 << 34))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake: %zu photons is too many", d.photons.count);
    sg_bake_job *j = sg_calloc_array(1, sizeof *j);
    if (!j)
        return sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
    j->w = w;
    j->d = d;
    j->stage = stage;
    j->level = level;
    j->models = sg_world_model_count(w);
    size_t *counts = sg_alloc_array(j->models ? j->models : 1, sizeof *counts);
    sg_status st = SG_OK;
    if (!counts || !(j->mw = sg_calloc_array(j->models ? j->models : 1, sizeof *j->mw))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "bake: out of memory");
        goto fail;
    }
    for (size_t m = 0; m < j->models; ++m)
        counts[m] = sg_scene_sites(sg_world_scene(w, (uint32_t)m))->count;
    if ((st = sg_bake__new(sg_world_envmap(w), j->models, counts, &d, NULL, &j->b, err)) != SG_OK)
        goto fail;
    if ((st = setup_models(j, err)) != SG_OK)
        goto fail;
    sg_free(counts);
    *out = j;
    return SG_OK;
fail:
    sg_free(counts);
    sg_bake_job_destroy(j);
    return st;
}

sg_status sg_bake_job_create(const sg_world *w, const sg_bake_desc *desc, sg_bake_job **out, sg_error *err)
{
    sg_bake_desc d = sg_bake_desc_resolve(desc);
    return sg_bake_job__new(w, &d, d.indirect == SG_BAKE_INDIRECT_PHOTONS ? SG_BAKE_STAGE_PHOTONS : SG_BAKE_STAGE_SITES,
                            0, out, err);
}

sg_bake_progress sg_bake_job_progress(const sg_bake_job *j)
{
    sg_bake_progress p = {.stage = j->stage, .level = j->level};
    if (j->stage == SG_BAKE_STAGE_PHOTONS) {
        p.done = j->pm.shot;
        p.total = j->d.photons.count;
    } else
        for (size_t m = 0; m < j->models; ++m) {
            p.total += j->mw[m].set.count;
            p.done += j->stage == SG_BAKE_STAGE_SITES ? j->mw[m].sites.count : j->mw[m].glossy_done;
        }
    return p;
}

sg_bake_desc sg_bake_job_desc(const sg_bake_job *j) { return j->d; }

sg_status sg_bake_job_finish(sg_bake_job *j, sg_bake **out, sg_error *err)
{
    if (j->stage != SG_BAKE_STAGE_DONE || !j->b)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake: the job is %s", j->b ? "not done" : "finished already");
    sg_bake_stats *s = sg_bake__stats(j->b);
    s->site_hits = 0;
    for (size_t m = 0; m < j->models; ++m) {
        sg_bake__set_samples(j->b, (uint32_t)m, j->mw[m].sampled ? j->mw[m].set.count : 0);
        s->site_hits += j->mw[m].sites.hits;
    }
    s->transport_iterations = j->ts.iterations;
    s->direct_seconds = j->seconds[SG_BAKE_STAGE_SITES];
    s->glossy_seconds = j->seconds[SG_BAKE_STAGE_GLOSSY];
    s->shared_seconds = j->shared_seconds;
    s->gather_seconds = j->seconds[SG_BAKE_STAGE_SITES] + j->seconds[SG_BAKE_STAGE_GLOSSY];
    sg_bake__update_memory(j->b);
    *out = j->b;
    j->b = NULL;
    return SG_OK;
}

void sg_bake_job_set_comm(sg_bake_job *j, const sg_bake_comm *c)
{
    assert(c && c->size >= 1 && c->rank >= 0 && c->rank < c->size && c->exchange);
    j->comm = *c;
    j->distributed = 1;
}

void sg_bake_job__borrow_photons(sg_bake_job *j, const sg_photon_map *pm)
{
    assert(j->stage == SG_BAKE_STAGE_PHOTONS && j->pm.blocks == 0);
    j->pm = *pm;
    j->pm_borrowed = 1;
}

void sg_bake_job_destroy(sg_bake_job *j)
{
    if (!j)
        return;
    for (size_t m = 0; j->mw && m < j->models; ++m)
        model_free(&j->mw[m]);
    sg_free(j->mw);
    if (!j->pm_borrowed)
        sg_photon_map_free(&j->pm);
    sg_bake_destroy(j->b);
    sg_free(j);
}
