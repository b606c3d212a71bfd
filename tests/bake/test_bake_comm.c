/* test_bake_comm.c — a bake job split over ranks (bake/bake_comm.h),
 * without MPI: the ranks are threads of this process sharing one world,
 * and the exchange is a concatenation behind a barrier. (The MPI program
 * itself is tests/bake/splatgi_bake_mpi.sh, registered only with MPI.)
 *  1. sg_bake_comm_share splits any count into contiguous shares in rank
 *     order that cover it exactly;
 *  2. a job run on 1, 2, 3 and 5 ranks (transport estimator, a glossy
 *     model: sample sites over two levels and glossy bins) saves the same
 *     bytes as a plain job, on every rank; so does the photon estimator
 *     on 3 ranks;
 *  3. a stop asked by one rank's progress callback alone stops every rank
 *     at the same round with the same progress; rank 0's job saved as a
 *     checkpoint, loaded and finished plainly saves the plain job's bytes.
 */
#include "test_support.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bake/bake.h"
#include "bake/bake_comm.h"
#include "bake/bake_io.h"
#include "bake/bake_job.h"
#include "core/alloc.h"
#include "render/world.h"

static const uint64_t SCENE_HASH = 0x5ce9e0000000c033ull;

enum { MAX_RANKS = 5 };

/* ---- in-process ranks ------------------------------------------------------ */

/* Ranks that disagree about the rounds would wait for each other forever:
 * the barrier gives up after BARRIER_SECONDS and ends the test with a
 * message instead of hanging until ctest's timeout. */
enum { BARRIER_SECONDS = 120 };

typedef struct hub {
    int size;
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int waiting;            /* ranks at the barrier                          */
    unsigned long gen;      /* barrier generation                            */
    const void *piece[MAX_RANKS];
    size_t bytes[MAX_RANKS];
    int stop[MAX_RANKS];
    long exchanges[MAX_RANKS];
} hub;

typedef struct rank_run {
    hub *h;
    int rank;
    const sg_world *w;
    sg_bake_desc d;
    int stop_at;            /* progress call that asks to stop (0: never)   */
    int calls;              /* progress calls so far                         */
    sg_status st;           /* of sg_bake_job_run                            */
    sg_bake_progress at;    /* where the job stood after the run             */
    sg_bake_job *job;       /* kept after a cancel (rank 0 saves it)          */
    char path[1024];        /* where the finished bake was saved              */
    char msg[600];
} rank_run;

static void barrier(hub *h, int rank)
{
    pthread_mutex_lock(&h->lock);
    unsigned long gen = h->gen;
    if (++h->waiting == h->size) {
        h->waiting = 0;
        ++h->gen;
        pthread_cond_broadcast(&h->cond);
    }
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until);
    until.tv_sec += BARRIER_SECONDS;
    while (gen == h->gen)
        if (pthread_cond_timedwait(&h->cond, &h->lock, &until) != 0 && gen == h->gen) {
            fprintf(stderr, "FAIL: rank %d waited %d s at exchange %ld: the ranks disagree about the rounds\n", rank,
                    (int)BARRIER_SECONDS, h->exchanges[rank]);
            exit(1);
        }
    pthread_mutex_unlock(&h->lock);
}

static sg_status exchange(void *user, const void *mine, size_t bytes, void **all, size_t *all_bytes, int *stop,
                          sg_error *err)
{
    rank_run *r = user;
    hub *h = r->h;
    h->piece[r->rank] = mine;
    h->bytes[r->rank] = bytes;
    h->stop[r->rank] = *stop;
    ++h->exchanges[r->rank];
    barrier(h, r->rank); /* every piece posted */
    size_t total = 0;
    int any = 0;
    for (int k = 0; k < h->size; ++k) {
        total += h->bytes[k];
        any |= h->stop[k];
    }
    unsigned char *buf = total ? sg_alloc_array(total, 1) : NULL;
    size_t at = 0;
    for (int k = 0; k < h->size && buf; ++k) {
        memcpy(buf + at, h->piece[k], h->bytes[k]);
        at += h->bytes[k];
    }
    barrier(h, r->rank); /* every rank has copied: pieces may go */
    if (total && !buf)
        return sg_error_set(err, SG_ERR_NOMEM, "test exchange: out of memory");
    *all = buf;
    *all_bytes = total;
    *stop = any;
    return SG_OK;
}

static int on_progress(void *user, const sg_bake_progress *p)
{
    rank_run *r = user;
    (void)p;
    ++r->calls;
    return r->stop_at && r->calls >= r->stop_at;
}

static void *rank_main(void *arg)
{
    rank_run *r = arg;
    sg_error err = {0};
    sg_bake_job *j = NULL;
    sg_bake *b = NULL;
    sg_bake_comm c = {.rank = r->rank, .size = r->h->size, .exchange = exchange, .user = r};
    r->st = sg_bake_job_create(r->w, &r->d, &j, &err);
    if (r->st == SG_OK) {
        sg_bake_job_set_comm(j, &c);
        r->st = sg_bake_job_run(j, on_progress, r, &err);
        r->at = sg_bake_job_progress(j);
    }
    if (r->st == SG_OK && (r->st = sg_bake_job_finish(j, &b, &err)) == SG_OK)
        r->st = sg_bake_save(b, r->path, SCENE_HASH, &err);
    if (r->st == SG_ERR_CANCELLED) {
        r->job = j; /* the caller saves and destroys it */
        j = NULL;
    }
    snprintf(r->msg, sizeof r->msg, "%s", err.message);
    sg_bake_destroy(b);
    sg_bake_job_destroy(j);
    return NULL;
}

/* Runs the job of d on `size` thread ranks; rank k saves to "<tag>_rank<k>". */
static void run_ranks(const sg_world *w, const sg_bake_desc *d, int size, int stop_rank, int stop_at,
                      const char *tag, rank_run *runs)
{
    hub *h = calloc(1, sizeof *h);
    assert_non_null(h);
    h->size = size;
    pthread_mutex_init(&h->lock, NULL);
    pthread_cond_init(&h->cond, NULL);
    pthread_t th[MAX_RANKS];
    for (int k = 0; k < size; ++k) {
        runs[k] = (rank_run){.h = h, .rank = k, .w = w, .d = *d, .stop_at = k == stop_rank ? stop_at : 0};
        runs[k].d.photons.threads = runs[k].d.gather.threads = 1 + k % 2;
        snprintf(runs[k].path, sizeof runs[k].path, "%s", sg_test_tmp_path(tag));
        size_t n = strlen(runs[k].path);
        snprintf(runs[k].path + n, sizeof runs[k].path - n, "_rank%d.sgbake", k);
        assert_int_equal(pthread_create(&th[k], NULL, rank_main, &runs[k]), 0);
    }
    for (int k = 0; k < size; ++k)
        pthread_join(th[k], NULL);
    for (int k = 1; k < size; ++k)
        if (h->exchanges[k] != h->exchanges[0])
            fail_msg("rank %d made %ld exchanges, rank 0 %ld", k, h->exchanges[k], h->exchanges[0]);
    pthread_mutex_destroy(&h->lock);
    pthread_cond_destroy(&h->cond);
    free(h);
}

static void assert_same_file(const char *a, const char *b)
{
    size_t na = 0, nb = 0;
    void *x = sg_test_read_file(a, &na), *y = sg_test_read_file(b, &nb);
    assert_non_null(x);
    assert_non_null(y);
    if (na != nb || memcmp(x, y, na)) {
        size_t i = 0;
        while (i < na && i < nb && ((unsigned char *)x)[i] == ((unsigned char *)y)[i])
            ++i;
        fail_msg("%s (%zu bytes) and %s (%zu bytes) differ at byte %zu", a, na, b, nb, i);
    }
    free(x);
    free(y);
}

/* A plain job of d, saved to tag. */
static const char *plain_bake(const sg_world *w, const sg_bake_desc *d, const char *tag)
{
    sg_error err = {0};
    sg_bake *b = NULL;
    const char *path = sg_test_tmp_path(tag);
    if (sg_bake_create(w, d, &b, &err) != SG_OK || sg_bake_save(b, path, SCENE_HASH, &err) != SG_OK)
        fail_msg("plain bake: %s", err.message);
    sg_bake_destroy(b);
    return path;
}

/* A glossy sphere on a diffuse ground: sites, refinement, glossy bins. */
static sg_world *glossy_world(void)
{
    return sg_test_world_from_json("{\"models\":[{\"builtin\":\"sphere\",\"points\":3000,"
                                   "\"transform\":{\"translate\":[0,1,0]},\"material\":{\"type\":\"ggx\","
                                   "\"roughness\":0.5,\"specular\":0.3}},{\"builtin\":\"ground\",\"points\":3000}],"
                                   "\"envmap\":{\"builtin\":\"sunsky\"}}");
}

/* ---- 1. shares -------------------------------------------------------------- */

static void test_bake_comm_share_covers(void **state)
{
    (void)state;
    for (size_t n = 0; n < 40; ++n)
        for (int size = 1; size <= 7; ++size) {
            size_t next = 0;
            for (int r = 0; r < size; ++r) {
                size_t lo, hi;
                sg_bake_comm_share(n, size, r, &lo, &hi);
                if (lo != next || hi < lo || hi - lo > n / (size_t)size + 1)
                    fail_msg("n %zu, %d ranks: rank %d gets [%zu, %zu) after %zu", n, size, r, lo, hi, next);
                next = hi;
            }
            if (next != n)
                fail_msg("n %zu, %d ranks: shares end at %zu", n, size, next);
        }
}

/* ---- 2. any rank count, the same bytes ----------------------------------------- */

static void test_bake_comm_ranks_equal_plain(void **state)
{
    (void)state;
    sg_world *w = glossy_world();
    sg_bake_desc d = {.direct_samples = 8, .gather_rays = 8, .glossy_rays = 16, .photons = {.seed = 5}};
    char ref[1024]; /* tmp_path's ring is reused below */
    snprintf(ref, sizeof ref, "%s", plain_bake(w, &d, "plain.sgbake"));
    int sizes[] = {1, 2, 3, 5};
    rank_run runs[MAX_RANKS];
    for (size_t s = 0; s < sizeof sizes / sizeof *sizes; ++s) {
        char tag[32];
        snprintf(tag, sizeof tag, "np%d", sizes[s]);
        run_ranks(w, &d, sizes[s], -1, 0, tag, runs);
        for (int k = 0; k < sizes[s]; ++k) {
            if (runs[k].st != SG_OK)
                fail_msg("%d ranks: rank %d: %s", sizes[s], k, runs[k].msg);
            assert_same_file(ref, runs[k].path);
        }
    }
    sg_world_destroy(w);
}

static void test_bake_comm_photons_equal_plain(void **state)
{
    (void)state;
    sg_world *w = glossy_world();
    sg_bake_desc d = {.indirect = SG_BAKE_INDIRECT_PHOTONS, .photons = {.count = 150000, .seed = 3},
                      .gather = {.k = 32}, .direct_samples = 8, .gather_rays = 8, .glossy_rays = 16};
    char ref[1024];
    snprintf(ref, sizeof ref, "%s", plain_bake(w, &d, "plain_photons.sgbake"));
    rank_run runs[MAX_RANKS];
    run_ranks(w, &d, 3, -1, 0, "photons3", runs);
    for (int k = 0; k < 3; ++k) {
        if (runs[k].st != SG_OK)
            fail_msg("rank %d: %s", k, runs[k].msg);
        assert_same_file(ref, runs[k].path);
    }
    sg_world_destroy(w);
}

/* ---- 3. a stop on one rank stops all at the same round -------------------------- */

static void test_bake_comm_stop_agreed(void **state)
{
    (void)state;
    sg_world *w = glossy_world();
    sg_bake_desc d = {.direct_samples = 8, .gather_rays = 8, .glossy_rays = 16, .photons = {.seed = 5}};
    char ref[1024];
    snprintf(ref, sizeof ref, "%s", plain_bake(w, &d, "plain_stop.sgbake"));
    rank_run runs[MAX_RANKS];
    run_ranks(w, &d, 3, 1, 2, "stop3", runs); /* rank 1 asks at its 2nd call */
    for (int k = 0; k < 3; ++k) {
        if (runs[k].st != SG_ERR_CANCELLED)
            fail_msg("rank %d: status %d (%s), expected cancelled", k, (int)runs[k].st, runs[k].msg);
        if (memcmp(&runs[k].at, &runs[0].at, sizeof runs[0].at))
            fail_msg("rank %d stopped at %zu of %zu (stage %d), rank 0 at %zu of %zu (stage %d)", k, runs[k].at.done,
                     runs[k].at.total, (int)runs[k].at.stage, runs[0].at.done, runs[0].at.total,
                     (int)runs[0].at.stage);
    }
    if (runs[0].at.stage == SG_BAKE_STAGE_DONE)
        fail_msg("the ranks stopped only when done (%d progress calls on rank 1)", runs[1].calls);
    sg_error err = {0};
    const char *ckpt = sg_test_tmp_path("stop3.ckpt");
    assert_int_equal(sg_bake_job_save(runs[0].job, ckpt, SCENE_HASH, &err), SG_OK);
    for (int k = 0; k < 3; ++k)
        sg_bake_job_destroy(runs[k].job);
    sg_bake_job *j = NULL;
    sg_bake *b = NULL;
    sg_bake_desc d2 = sg_bake_desc_resolve(&d);
    assert_int_equal(sg_bake_job_load(ckpt, w, &d2, SCENE_HASH, &j, &err), SG_OK);
    assert_int_equal(sg_bake_job_run(j, NULL, NULL, &err), SG_OK);
    assert_int_equal(sg_bake_job_finish(j, &b, &err), SG_OK);
    const char *out = sg_test_tmp_path("stop3_resumed.sgbake");
    assert_int_equal(sg_bake_save(b, out, SCENE_HASH, &err), SG_OK);
    assert_same_file(ref, out);
    sg_bake_destroy(b);
    sg_bake_job_destroy(j);
    sg_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bake_comm_share_covers),
        cmocka_unit_test(test_bake_comm_ranks_equal_plain),
        cmocka_unit_test(test_bake_comm_photons_equal_plain),
        cmocka_unit_test(test_bake_comm_stop_agreed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
