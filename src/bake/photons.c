/* photons.c — light tracing from the envmap (see photons.h).
 *
 * Random dimensions per photon i and interaction b:
 *   b = 0: 0, 1 envmap direction; 2, 3 point on the emitting disk;
 *   b >= 1: 0, 1, 2 BSDF sample; 3 Russian roulette.
 *
 * Invariants:
 *  1. a record's flux is finite and >= 0 per channel;
 *  2. record order = (block, photon in block, interaction): a function of
 *     the input only (thread-count independence), and a map holds exactly
 *     the records of blocks [0, m->blocks), so extending it block range by
 *     block range builds the same arrays as one pass;
 *  3. every array of a map has room for m->capacity >= m->count records;
 *  4. the progress callback runs on OpenMP thread 0 only (the caller's
 *     thread), between blocks: never concurrently, never inside a photon.
 *     The shared photon counter and the stop flag are touched once per
 *     block with OpenMP atomics; the per-photon loop sees neither.
 */
#include "bake/photons.h"

#include <assert.h>
#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/alloc.h"
#include "math/rng.h"

static const float PI_F = 3.14159265358979f;

typedef struct rec {
    float p[3], n[3], w[3], f[3];
    uint32_t model;
} rec;

typedef struct block {
    rec *r;
    size_t n, cap;
    sg_ray_stats rays;
    int failed;   /* out of memory: the block is incomplete */
    int done;     /* every photon of the block was traced   */
} block;

static int push(block *b, const rec *r)
{
    if (b->n == b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 4096;
        void *p = b->r;
        if (!sg_realloc_array(&p, b->n, cap, sizeof *b->r))
            return 0;
        b->r = p;
        b->cap = cap;
    }
    b->r[b->n++] = *r;
    return 1;
}

static float max3(sg_vec3 v) { return fmaxf(v.x, fmaxf(v.y, v.z)); }

static void trace_photon(const sg_world *w, const sg_photon_desc *d, uint64_t i, sg_vec3 centre, float radius,
                         float share, block *b)
{
    const sg_envmap *env = sg_world_envmap(w);
    float pdf;
    sg_vec3 dir_env = sg_envmap_sample(env, sg_rng_float(d->seed, i, 0, 0), sg_rng_float(d->seed, i, 0, 1), &pdf);
    if (!(pdf > 0.0f))
        return;
    sg_vec3 Le = sg_envmap_eval(env, dir_env);
    /* Uniform point of the disk of radius R across dir_env, outside the
     * bounding sphere; the photon travels towards the scene. */
    sg_vec3 t1, t2;
    sg_v3_basis(dir_env, &t1, &t2);
    float r = radius * sqrtf(sg_rng_float(d->seed, i, 0, 2)), phi = 2.0f * PI_F * sg_rng_float(d->seed, i, 0, 3);
    sg_vec3 o = sg_v3_add(centre, sg_v3_scale(dir_env, 1.01f * radius));
    o = sg_v3_madd(sg_v3_madd(o, t1, r * cosf(phi)), t2, r * sinf(phi));
    sg_vec3 flux = sg_v3_scale(Le, PI_F * radius * radius * share / pdf);
    sg_ray ray = {.org = o, .dir = sg_v3_scale(dir_env, -1.0f), .tmin = 0.0f, .tmax = INFINITY};
    for (int depth = 0; depth < d->max_depth; ++depth) {
        sg_world_hit h;
        if (!sg_world_intersect(w, &ray, &h, &b->rays))
            return;
        sg_vec3 wi = sg_v3_scale(ray.dir, -1.0f);
        sg_vec3 n = sg_v3_dot(h.hit.n, wi) < 0.0f ? sg_v3_scale(h.hit.n, -1.0f) : h.hit.n;
        rec r = {{h.hit.p.x, h.hit.p.y, h.hit.p.z}, {n.x, n.y, n.z}, {wi.x, wi.y, wi.z}, {flux.x, flux.y, flux.z},
                 h.model};
        if ((depth > 0 || !(d->flags & SG_PHOTONS_INDIRECT_ONLY)) && !push(b, &r)) {
            b->failed = 1;
            return;
        }
        uint32_t bn = (uint32_t)depth + 1;
        const sg_material *m = sg_world_material(w, h.model);
        sg_vec3 albedo = sg_world_albedo(w, &h);
        sg_vec3 wo, weight;
        float pdf_b;
        /* Scattering a photon: wi (where it came from) plays the role of
         * the view direction; the BSDF is reciprocal. */
        if (!sg_bsdf_sample(m, albedo, n, wi, sg_rng_float(d->seed, i, bn, 0), sg_rng_float(d->seed, i, bn, 1),
                            sg_rng_float(d->seed, i, bn, 2), &wo, &pdf_b, &weight))
            return;
        flux = sg_v3_mul(flux, weight);
        /* Russian roulette on the bounce's weight (<= 1), survival q =
         * its largest channel: a survivor's flux never grows (as in the
         * reference, pathtrace.c). */
        float q = max3(weight);
        if (depth + 1 >= d->rr_depth && q < 1.0f) {
            if (!(q > 0.0f) || sg_rng_float(d->seed, i, bn, 3) >= q)
                return;
            flux = sg_v3_scale(flux, 1.0f / q);
        }
        ray = sg_world_spawn_ray(w, &h, wo, INFINITY);
    }
}

sg_photon_desc sg_photon_desc_resolve(const sg_photon_desc *desc)
{
    sg_photon_desc d = desc ? *desc : (sg_photon_desc){0};
    if (d.count == 0) d.count = 1000000;
    if (d.seed == 0) d.seed = 1;
    if (d.max_depth <= 0) d.max_depth = 8;
    if (d.rr_depth <= 0) d.rr_depth = 2;
    if (d.progress_seconds == 0.0) d.progress_seconds = 0.25;
    return d;
}

size_t sg_photon_block_count(const sg_photon_desc *desc)
{
    sg_photon_desc d = sg_photon_desc_resolve(desc);
    return (d.count + SG_PHOTON_BLOCK - 1) / SG_PHOTON_BLOCK;
}

size_t sg_photon_map_bytes(size_t count) { return count * (12 * sizeof(float) + sizeof(uint32_t)); }

/* Grows every array of m to hold at least need records (invariant 3). On
 * failure the arrays that did grow stay valid and m->capacity keeps the old
 * value, which every array still holds. */
static int reserve(sg_photon_map *m, size_t need)
{
    if (need <= m->capacity && m->model)
        return 1;
    size_t cap = sg_grown_capacity(m->capacity, need);
    float **arrays[12] = {&m->px, &m->py, &m->pz, &m->nx, &m->ny, &m->nz,
                          &m->wx, &m->wy, &m->wz, &m->fr, &m->fg, &m->fb};
    for (int a = 0; a < 12; ++a) {
        void *p = *arrays[a];
        if (!sg_realloc_array(&p, m->count, cap, sizeof(float)))
            return 0;
        *arrays[a] = p;
    }
    void *p = m->model;
    if (!sg_realloc_array(&p, m->count, cap, sizeof(uint32_t)))
        return 0;
    m->model = p;
    m->capacity = cap;
    return 1;
}

sg_status sg_photons_trace_more(const sg_world *w, const sg_photon_desc *desc, size_t last_block, sg_photon_map *m,
                                sg_error *err)
{
    assert(w && m && m->count <= m->capacity);
    sg_photon_desc d = sg_photon_desc_resolve(desc);
    if (d.count > ((size_t)1 << 34))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "photons: %zu photons is too many", d.count);
    size_t nblocks = sg_photon_block_count(&d);
    if (last_block > nblocks || last_block < m->blocks)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "photons: cannot trace blocks [%zu, %zu) of a pass of %zu blocks", m->blocks,
                            last_block, nblocks);
    sg_aabb bb = sg_world_bounds(w);
    sg_vec3 centre = sg_v3_scale(sg_v3_add(bb.lo, bb.hi), 0.5f);
    float radius = 0.5f * sg_aabb_diagonal(bb);
    if (!(radius > 0.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "photons: the scene has no extent");
    size_t first = m->blocks, n = last_block - first;
    block *blocks = sg_calloc_array(n, sizeof *blocks);
    if (!blocks)
        return sg_error_set(err, SG_ERR_NOMEM, "photons: out of memory");
    double t0 = omp_get_wtime();
    int threads = d.threads > 0 ? d.threads : omp_get_max_threads();
    float share = 1.0f / (float)d.count; /* of the whole pass: chunks do not change it */
    size_t done_photons = m->shot;        /* shared; atomic updates, one per block */
    int stop = 0;                         /* shared; set on cancel or failure     */
    int cancelled = 0;                    /* written by thread 0 only             */
    double last_call = t0;                /* thread 0 only                        */
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (size_t k = 0; k < n; ++k) {
        int halt;
#pragma omp atomic read
        halt = stop;
        if (halt)
            continue;
        size_t bi = first + k;
        size_t end = (bi + 1) * SG_PHOTON_BLOCK < d.count ? (bi + 1) * SG_PHOTON_BLOCK : d.count;
        for (size_t i = bi * SG_PHOTON_BLOCK; i < end && !blocks[k].failed; ++i)
            trace_photon(w, &d, i, centre, radius, share, &blocks[k]);
        if (blocks[k].failed) {
#pragma omp atomic write
            stop = 1;
            continue;
        }
        blocks[k].done = 1;
        size_t now;
#pragma omp atomic capture
        now = done_photons += end - bi * SG_PHOTON_BLOCK;
        /* Invariant 4: only thread 0, the caller's thread, calls back. */
        if (d.progress && omp_get_thread_num() == 0) {
            double t = omp_get_wtime();
            if (d.progress_seconds < 0.0 || t - last_call >= d.progress_seconds) {
                last_call = t;
                if (d.progress(d.progress_user, now, d.count)) {
                    cancelled = 1;
#pragma omp atomic write
                    stop = 1;
                }
            }
        }
    }
    sg_status st = SG_OK;
    size_t prefix = 0, total = m->count;
    for (size_t k = 0; k < n; ++k)
        if (blocks[k].failed)
            st = sg_error_set(err, SG_ERR_NOMEM, "photons: out of memory for photon records");
    while (prefix < n && blocks[prefix].done)
        total += blocks[prefix++].n;
    if (st == SG_OK && !reserve(m, total))
        st = sg_error_set(err, SG_ERR_NOMEM, "photons: out of memory for %zu records", total);
    if (st == SG_OK) {
        size_t j = m->count; /* invariant 2: block order */
        for (size_t k = 0; k < prefix; ++k) {
            for (size_t r = 0; r < blocks[k].n; ++r, ++j) {
                const rec *q = &blocks[k].r[r];
                m->px[j] = q->p[0]; m->py[j] = q->p[1]; m->pz[j] = q->p[2];
                m->nx[j] = q->n[0]; m->ny[j] = q->n[1]; m->nz[j] = q->n[2];
                m->wx[j] = q->w[0]; m->wy[j] = q->w[1]; m->wz[j] = q->w[2];
                m->fr[j] = q->f[0]; m->fg[j] = q->f[1]; m->fb[j] = q->f[2];
                m->model[j] = q->model;
            }
            sg_ray_stats_add(&m->rays, &blocks[k].rays);
        }
        m->count = total;
        m->blocks = first + prefix;
        m->shot = m->blocks * SG_PHOTON_BLOCK < d.count ? m->blocks * SG_PHOTON_BLOCK : d.count;
        m->seconds += omp_get_wtime() - t0;
        /* The closing report, so a display reaches the end of each call. */
        if (!cancelled && d.progress && d.progress(d.progress_user, m->shot, d.count))
            cancelled = 1;
        if (cancelled)
            st = sg_error_set(err, SG_ERR_CANCELLED, "photons: cancelled after %zu of %zu photons", m->shot,
                              d.count);
    }
    for (size_t k = 0; k < n; ++k)
        sg_free(blocks[k].r);
    sg_free(blocks);
    return st;
}

sg_status sg_photons_trace(const sg_world *w, const sg_photon_desc *desc, sg_photon_map *out, sg_error *err)
{
    sg_photon_map m = {0};
    sg_status st = sg_photons_trace_more(w, desc, sg_photon_block_count(desc), &m, err);
    if (st != SG_OK && st != SG_ERR_CANCELLED) {
        sg_photon_map_free(&m);
        return st;
    }
    *out = m;
    return st;
}

sg_status sg_photons_trace_range(const sg_world *w, const sg_photon_desc *desc, size_t first_block,
                                 size_t last_block, sg_photon_map *out, sg_error *err)
{
    sg_photon_desc d = sg_photon_desc_resolve(desc);
    d.progress = NULL;
    /* An empty map that claims blocks [0, first_block): trace_more appends
     * only the blocks after them, each traced from its own photon indices
     * (invariant 2), so the records are exactly those of the range. */
    sg_photon_map m = {.blocks = first_block};
    sg_status st = sg_photons_trace_more(w, &d, last_block, &m, err);
    if (st != SG_OK) {
        sg_photon_map_free(&m);
        return st;
    }
    *out = m;
    return SG_OK;
}

enum { PACK_HEAD = 9 * sizeof(uint64_t) };

sg_status sg_photon_map_pack(const sg_photon_map *piece, size_t first_block, void **buf, size_t *bytes,
                             sg_error *err)
{
    size_t n = piece->count, rec_bytes = sg_photon_map_bytes(1), total;
    if (!sg_mul_size(n, rec_bytes, &total) || total > SIZE_MAX - PACK_HEAD)
        return sg_error_set(err, SG_ERR_NOMEM, "photons: %zu records are too many to send", n);
    total += PACK_HEAD;
    unsigned char *out = sg_alloc_array(total, 1), *p = out;
    if (!out)
        return sg_error_set(err, SG_ERR_NOMEM, "photons: out of memory for %zu bytes of records to send", total);
    const sg_ray_stats *r = &piece->rays;
    uint64_t head[9] = {first_block, piece->blocks, n, r->rays, r->nodes, r->leaves, r->isects, r->splats, r->hits};
    memcpy(p, head, sizeof head);
    p += sizeof head;
    const float *arrays[12] = {piece->px, piece->py, piece->pz, piece->nx, piece->ny, piece->nz,
                               piece->wx, piece->wy, piece->wz, piece->fr, piece->fg, piece->fb};
    for (int a = 0; a < 12 && n; ++a, p += n * sizeof(float))
        memcpy(p, arrays[a], n * sizeof(float));
    if (n)
        memcpy(p, piece->model, n * sizeof(uint32_t));
    *buf = out;
    *bytes = total;
    return SG_OK;
}

sg_status sg_photon_map_append_packed(sg_photon_map *m, const sg_photon_desc *desc, const void *buf, size_t bytes,
                                      size_t *used, sg_error *err)
{
    sg_photon_desc d = sg_photon_desc_resolve(desc);
    const unsigned char *p = buf;
    uint64_t head[9];
    if (bytes < PACK_HEAD)
        return sg_error_set(err, SG_ERR_CORRUPT, "photons: a piece of %zu bytes is cut short", bytes);
    memcpy(head, p, sizeof head);
    p += PACK_HEAD;
    size_t n = (size_t)head[2], rec_bytes = sg_photon_map_bytes(1);
    if (head[0] != m->blocks || head[1] < head[0] || head[1] > sg_photon_block_count(&d) ||
        n > (bytes - PACK_HEAD) / rec_bytes)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "photons: a piece of blocks [%llu, %llu) with %zu records does not continue a map of "
                            "%zu blocks",
                            (unsigned long long)head[0], (unsigned long long)head[1], n, m->blocks);
    if (!reserve(m, m->count + n))
        return sg_error_set(err, SG_ERR_NOMEM, "photons: out of memory for %zu records", m->count + n);
    float *arrays[12] = {m->px, m->py, m->pz, m->nx, m->ny, m->nz, m->wx, m->wy, m->wz, m->fr, m->fg, m->fb};
    for (int a = 0; a < 12 && n; ++a, p += n * sizeof(float))
        memcpy(arrays[a] + m->count, p, n * sizeof(float));
    if (n)
        memcpy(m->model + m->count, p, n * sizeof(uint32_t));
    p += n * sizeof(uint32_t);
    sg_ray_stats r = {.rays = head[3], .nodes = head[4], .leaves = head[5], .isects = head[6], .splats = head[7],
                      .hits = head[8]};
    sg_ray_stats_add(&m->rays, &r);
    m->count += n;
    m->blocks = (size_t)head[1];
    m->shot = m->blocks * SG_PHOTON_BLOCK < d.count ? m->blocks * SG_PHOTON_BLOCK : d.count;
    *used = (size_t)(p - (const unsigned char *)buf);
    return SG_OK;
}

void sg_photon_map_free(sg_photon_map *m)
{
    if (!m)
        return;
    float *arrays[12] = {m->px, m->py, m->pz, m->nx, m->ny, m->nz, m->wx, m->wy, m->wz, m->fr, m->fg, m->fb};
    for (int a = 0; a < 12; ++a)
        sg_free(arrays[a]);
    sg_free(m->model);
    memset(m, 0, sizeof *m);
}
