/* splatgi-bake — the bake program: reads a scene file, runs the bake as a
 * job (bake/bake_job.h: sample sites and the transport solve, or the photon
 * pass, then glossy bins) with a progress display, and writes the .sgbake
 * file atomically. Ctrl-C stops the job within a block of work, at any
 * stage, and writes a checkpoint (OUT.ckpt) that --resume continues; the
 * resumed bake is the same file, byte for byte, as one run straight
 * through. Options, library calls and a report; the algorithms live in
 * src/bake/.
 *
 * Under mpirun (bake_mpi.h, docs/mpi.md) every rank loads the same scene
 * or world file and runs the same job with the ranks' communicator
 * (bake/bake_comm.h); rank 0 alone prints progress and the report, writes
 * checkpoints and the .sgbake, which is the same file, byte for byte, as a
 * plain run's. A rank that fails says so with its rank and ends the whole
 * job (MPI_Abort) before anything is written; Ctrl-C is agreed on by all
 * ranks at the next round, so rank 0's checkpoint is the job's state.
 */
#include <errno.h>
#include <inttypes.h>
#include <omp.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "app/bake_cache.h"
#include "app/model_scene.h"
#include "app/preflight.h"
#include "bake/bake.h"
#include "core/alloc.h"
#include "bake/bake_file.h"
#include "bake/bake_io.h"
#include "bake/bake_job.h"
#include "bake_mpi.h"
#include "io/scene_file.h"
#include "program.h"
#include "render/world.h"

static const char usage[] =
    "usage: splatgi-bake SCENE.json|MODEL [-o OUT.sgbake] [options]\n"
    "Bakes the scene's global illumination into OUT: light per side of every splat,\n"
    "from rays at sample points (direct light, and the surfaces that send indirect\n"
    "light, solved for every bounce), and glossy bins for glossy models.\n"
    "  -o, --out FILE    the bake (default: SCENE with .sgbake for .json; for a\n"
    "                    model file out/MODEL.sgbake, where splatgi-view MODEL\n"
    "                    looks for it)\n"
    "  --direct N        envmap-sampled rays per sample site (default 32)\n"
    "  --gather-rays N   cosine-sampled rays per sample site (default 64)\n"
    "  --sample-spacing X  spacing of the sample points in median splat radii\n"
    "                    (default: from the material, 4 diffuse, 2 + 2 roughness\n"
    "                    glossy); 'all' or a negative X: every splat\n"
    "  --refine N        refinements of the sample points where light changes fast,\n"
    "                    0..7 (default 2)\n"
    "  --ray-cone X      level of detail of the sample points' rays, 0..16: each ray\n"
    "                    is a cone X times as wide as its share of the solid angle,\n"
    "                    so the ISO and hybrid surfaces stop at coarse nodes far\n"
    "                    away; 0: off, thin rays at full detail (default: the\n"
    "                    scene's \"bake\": {\"ray_cone\"}, else 0; docs/hybrid.md)\n"
    "  --seed S          random seed (default 1)\n"
    "  --indirect transport|photons  the indirect light's estimator (default\n"
    "                    transport); photons: the first estimator, a photon pass\n"
    "                    gathered by density estimation at every splat:\n"
    "  --photons N       photons shot (photons; default 1000000)\n"
    "  --k K             photons per irradiance estimate, 1..1024 (default 64)\n"
    "  --max-depth D     surface interactions per photon (default 8)\n"
    "  --glossy-res R    glossy bins per side, 4..32 (default: from the roughness)\n"
    "  --glossy-rays M   rays per glossy sample point (default 128)\n"
    "  --threads T       OpenMP threads (default: all); results do not depend on it\n"
    "  --if-stale        do nothing when OUT already holds a bake of this scene with\n"
    "                    these parameters and this format (checked by its header),\n"
    "                    newer than the scene's model and envmap files; with\n"
    "                    --world, also rebuild and rewrite a stale world file\n"
    "  --world FILE      load the models from this world file (splatgi-world,\n"
    "                    docs/world.md) instead of building them\n"
    "  --resume          continue from OUT.ckpt, left by an interrupted run with the\n"
    "                    same scene and options\n"
    "  --help\n"
    "Ctrl-C stops within a block of work and writes OUT.ckpt (exit status 130);\n"
    "a second Ctrl-C quits at once without one. A finished bake removes OUT.ckpt.\n"
    "Distributed (an MPI build): mpirun -np N splatgi-bake ... divides the bake among\n"
    "N ranks; rank 0 reports and writes the same file as one process (docs/mpi.md).\n"
    "\n" SG_MODEL_SCENE_OPTIONS;

/* Set by the SIGINT handler, read by the progress callback and between
 * chunks. */
static volatile sig_atomic_t interrupted = 0;

static void on_sigint(int sig)
{
    (void)sig;
    /* Said at once (write(2) is async-signal-safe): under mpirun the ranks
     * may be killed before the checkpoint, and this line is then the
     * job's last word. Ranks other than 0 have stderr silenced. */
    static const char msg[] = "\nsplatgi-bake: interrupted: stopping after this block of work\n";
    if (!interrupted && write(STDERR_FILENO, msg, sizeof msg - 1) < 0)
        interrupted = 1; /* nothing to do about a failed write */
    interrupted = 1;
}

/* Where fail() writes, and the rank it names: ranks other than 0 have
 * stdout and stderr silenced (rank 0 says everything once) and keep a copy
 * of stderr for their own errors. */
static FILE *msg_out;
static int msg_rank = -1; /* -1: not distributed, no rank in messages */

typedef struct options {
    const char *scene, *out;
    sg_bake_desc desc;
    int threads;
    int resume;
    int if_stale;   /* --if-stale: keep an OUT made for this scene and these parameters */
    int ray_cone_set; /* --ray-cone given: the scene file's "bake" key yields */
    sg_model_scene_desc model; /* the scene made for a model file      */
    const char *write_scene;   /* --write-scene                        */
    sg_prog_world world;       /* --world; --if-stale applies to it too */
} options;

typedef struct progress {
    int tty;            /* stderr is a terminal: one line redrawn in place  */
    double t0;          /* when this stage began (omp_get_wtime)            */
    size_t start_done;  /* units already done when it began (resume)        */
    int stage, level;   /* the stage and level the line is about            */
    double last_print;  /* plain mode: when the last line was printed       */
    int drawn;          /* tty mode: a progress line is on screen           */
    int quiet;          /* a rank other than 0: no display                  */
} progress;

static int fail(const char *msg)
{
    FILE *f = msg_out ? msg_out : stderr;
    if (msg_rank >= 0)
        fprintf(f, "splatgi-bake: rank %d: %s\n", msg_rank, msg);
    else
        fprintf(f, "splatgi-bake: %s\n", msg);
    fflush(f);
    return 1;
}

static int parse_u64(const char *opt, const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
    char *end;
    errno = 0;
    unsigned long long v = s && *s != '-' ? strtoull(s, &end, 10) : 0;
    if (!s || *s == '-' || errno || *end || end == s || v < lo || v > hi) {
        fprintf(stderr, "splatgi-bake: %s: '%s' is not an integer in [%" PRIu64 ", %" PRIu64 "]\n", opt,
                s ? s : "", lo, hi);
        return 0;
    }
    *out = v;
    return 1;
}

static void fmt_duration(double s, char *buf, size_t size)
{
    if (!(s >= 0.0) || s > 1e7)
        snprintf(buf, size, "--:--");
    else if (s < 3600.0)
        snprintf(buf, size, "%d:%02d", (int)s / 60, (int)s % 60);
    else
        snprintf(buf, size, "%dh%02dm", (int)(s / 3600.0), (int)s % 3600 / 60);
}

static double mib(size_t bytes) { return (double)bytes / (1024.0 * 1024.0); }

static void end_progress_line(progress *p)
{
    if (p->tty && p->drawn) {
        fputc('\n', stderr);
        p->drawn = 0;
    }
}

static const char *stage_name(const sg_bake_progress *q, char *buf, size_t size)
{
    if (q->stage == SG_BAKE_STAGE_PHOTONS)
        return "photons";
    if (q->stage == SG_BAKE_STAGE_SITES) {
        snprintf(buf, size, "sample points, level %d", q->level);
        return buf;
    }
    return "glossy sample points";
}

/* The job's progress callback: runs on the main thread only (bake_job.h),
 * so it may print; returns nonzero after Ctrl-C. */
static int on_progress(void *user, const sg_bake_progress *q)
{
    progress *p = user;
    if (p->quiet)
        return interrupted != 0;
    double now = omp_get_wtime();
    if ((int)q->stage != p->stage || q->level != p->level) { /* a new stage: a new line */
        end_progress_line(p);
        p->stage = (int)q->stage;
        p->level = q->level;
        p->t0 = now;
        p->start_done = q->done;
    }
    double t = now - p->t0;
    double rate = t > 0.0 ? (double)(q->done - p->start_done) / t : 0.0;
    char left[32], name[64];
    fmt_duration(rate > 0.0 && q->total >= q->done ? (double)(q->total - q->done) / rate : -1.0, left, sizeof left);
    double pct = q->total ? 100.0 * (double)q->done / (double)q->total : 100.0;
    const char *what = stage_name(q, name, sizeof name);
    if (p->tty) {
        fprintf(stderr, "\r  %5.1f%%  %zu of %zu %s  %s left   ", pct, q->done, q->total, what, left);
        fflush(stderr);
        p->drawn = 1;
    } else if (now - p->last_print >= 5.0 || q->done == q->total) {
        fprintf(stderr, "splatgi-bake: %5.1f%%, %zu of %zu %s, %s left\n", pct, q->done, q->total, what, left);
        p->last_print = now;
    }
    return interrupted != 0;
}

/* Returns 0 to go on, 1 for an error, 2 after --help. */
static int parse_args(int argc, char **argv, options *o)
{
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        uint64_t n;
        sg_error e = {0};
        int ms = sg_model_scene_option(argc, argv, &i, &o->model, &o->write_scene, &e);
        if (ms < 0)
            return fail(e.message);
        if (ms)
            continue;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return 2;
        } else if (!strcmp(a, "--resume")) {
            o->resume = 1;
        } else if (!strcmp(a, "--if-stale")) {
            o->if_stale = 1;
            o->world.if_stale = 1;
        } else if (!strcmp(a, "--world")) {
            if (!v)
                return fprintf(stderr, "splatgi-bake: %s needs a value\n", a), 1;
            o->world.path = v;
            ++i;
        } else if (!strcmp(a, "-o") || !strcmp(a, "--out")) {
            if (!v)
                return fprintf(stderr, "splatgi-bake: %s needs a value\n", a), 1;
            o->out = v;
            ++i;
        } else if (!strcmp(a, "--photons")) {
            if (!parse_u64(a, v, 1, (uint64_t)1 << 34, &n)) return 1;
            o->desc.photons.count = (size_t)n;
            ++i;
        } else if (!strcmp(a, "--k")) {
            if (!parse_u64(a, v, 1, 1024, &n)) return 1;
            o->desc.gather.k = (unsigned)n;
            ++i;
        } else if (!strcmp(a, "--seed")) {
            if (!parse_u64(a, v, 1, UINT64_MAX, &n)) return 1;
            o->desc.photons.seed = n;
            ++i;
        } else if (!strcmp(a, "--max-depth")) {
            if (!parse_u64(a, v, 1, 1024, &n)) return 1;
            o->desc.photons.max_depth = (int)n;
            ++i;
        } else if (!strcmp(a, "--direct")) {
            if (!parse_u64(a, v, 1, 1 << 20, &n)) return 1;
            o->desc.direct_samples = (int)n;
            ++i;
        } else if (!strcmp(a, "--gather-rays")) {
            if (!parse_u64(a, v, 1, 1 << 20, &n)) return 1;
            o->desc.gather_rays = (int)n;
            ++i;
        } else if (!strcmp(a, "--refine")) {
            if (!parse_u64(a, v, 0, 7, &n)) return 1;
            o->desc.refine_levels = n ? (int)n : -1;
            ++i;
        } else if (!strcmp(a, "--indirect")) {
            if (!v || (strcmp(v, "transport") && strcmp(v, "photons"))) {
                fprintf(stderr, "splatgi-bake: %s: '%s' is not 'transport' or 'photons'\n", a, v ? v : "");
                return 1;
            }
            o->desc.indirect = !strcmp(v, "photons") ? SG_BAKE_INDIRECT_PHOTONS : SG_BAKE_INDIRECT_TRANSPORT;
            ++i;
        } else if (!strcmp(a, "--sample-spacing")) {
            char *end = NULL;
            double x = v ? strtod(v, &end) : 0.0;
            if (v && !strcmp(v, "all"))
                x = -1.0, end = (char *)v + 3;
            if (!v || !end || *end || end == v || !(x == x) || x == 0.0 || x > 1e6) {
                fprintf(stderr, "splatgi-bake: %s: '%s' is not a positive number or 'all'\n", a, v ? v : "");
                return 1;
            }
            o->desc.sample_spacing = (float)x;
            ++i;
        } else if (!strcmp(a, "--ray-cone")) {
            char *end = NULL;
            double x = v ? strtod(v, &end) : 0.0;
            if (!v || !end || *end || end == v || !(x >= 0.0 && x <= SG_BAKE_RAY_CONE_MAX)) {
                fprintf(stderr, "splatgi-bake: %s: '%s' is not a number in [0, %g]\n", a, v ? v : "",
                        (double)SG_BAKE_RAY_CONE_MAX);
                return 1;
            }
            o->desc.ray_cone = x > 0.0 ? (float)x : -1.0f; /* 0 on the command line: off */
            o->ray_cone_set = 1;
            ++i;
        } else if (!strcmp(a, "--glossy-res")) {
            if (!parse_u64(a, v, 4, 32, &n)) return 1;
            o->desc.glossy_res = (int)n;
            ++i;
        } else if (!strcmp(a, "--glossy-rays")) {
            if (!parse_u64(a, v, 1, 1 << 20, &n)) return 1;
            o->desc.glossy_rays = (int)n;
            ++i;
        } else if (!strcmp(a, "--threads")) {
            if (!parse_u64(a, v, 1, 4096, &n)) return 1;
            o->threads = (int)n;
            ++i;
        } else if (a[0] == '-') {
            fprintf(stderr, "splatgi-bake: unknown option '%s' (see --help)\n", a);
            return 1;
        } else if (!o->scene) {
            o->scene = a;
        } else {
            return fail("more than one scene or model file given (see --help)");
        }
    }
    if (!o->scene)
        return fail("no scene or model file given (see --help)");
    return 0;
}

/* "splatgi-bake ARGS --resume", to tell the user how to go on. */
static void print_resume_command(int argc, char **argv)
{
    fprintf(stderr, "splatgi-bake: to resume:");
    int has_resume = 0;
    for (int i = 0; i < argc; ++i) {
        fprintf(stderr, " %s", argv[i]);
        has_resume |= !strcmp(argv[i], "--resume");
    }
    fprintf(stderr, "%s\n", has_resume ? "" : " --resume");
}

/* Every rank waits here until all arrive (a round with no data). */
static sg_status barrier(sg_mpi *mpi, int *stop, sg_error *err)
{
    void *all = NULL;
    size_t n = 0;
    int s = *stop;
    sg_status st = mpi->comm.exchange(mpi->comm.user, NULL, 0, &all, &n, &s, err);
    sg_free(all);
    if (st == SG_OK)
        *stop = s;
    return st;
}

/* The ranks must start the job from the same state (the same parameters,
 * and on --resume the same checkpoint): each sends its parameter hash,
 * stage, level and progress, and every rank compares them with rank 0's. */
static sg_status check_same_job(sg_mpi *mpi, const sg_bake_job *job, sg_error *err)
{
    sg_bake_desc jd = sg_bake_job_desc(job);
    sg_bake_progress p = sg_bake_job_progress(job);
    uint64_t mine[5] = {sg_bake_param_hash(&jd), (uint64_t)p.stage, (uint64_t)p.level, p.done, p.total};
    uint64_t *buf = sg_alloc_array(5, sizeof *buf);
    if (!buf)
        return sg_error_set(err, SG_ERR_NOMEM, "out of memory");
    memcpy(buf, mine, sizeof mine);
    void *all = NULL;
    size_t n = 0;
    int stop = 0;
    sg_status st = mpi->comm.exchange(mpi->comm.user, buf, sizeof mine, &all, &n, &stop, err);
    sg_free(buf);
    if (st != SG_OK)
        return st;
    if (n != (size_t)mpi->size * sizeof mine)
        st = sg_error_set(err, SG_ERR_CORRUPT, "the ranks' job states came back with %zu bytes", n);
    for (int r = 1; r < mpi->size && st == SG_OK; ++r)
        if (memcmp((const char *)all + (size_t)r * sizeof mine, all, sizeof mine))
            st = sg_error_set(err, SG_ERR_INVALID_ARG,
                              "rank %d starts the bake at another point or with other parameters than rank 0 "
                              "(a different checkpoint or scene?)", r);
    sg_free(all);
    return st;
}

static int bake_main(int argc, char **argv, sg_mpi *mpi)
{
    options o = {0};
    int root = mpi->rank == 0; /* writes and reports */
    sg_prog_init("splatgi-bake");
    int pr = parse_args(argc, argv, &o);
    if (pr)
        return pr == 2 ? 0 : 1;
    if (!o.world.path)
        o.world.if_stale = 0; /* --if-stale alone is about the bake */
    char out_buf[4200], ckpt[4300];
    if (!o.out && sg_model_scene_is_model(o.scene)) {
        /* Where splatgi-view MODEL looks (app/bake_cache.h). */
        sg_error e = {0};
        if (sg_bake_cache_path(o.scene, NULL, out_buf, sizeof out_buf, &e) != SG_OK)
            return fail(e.message);
        o.out = out_buf;
    }
    if (!o.out) {
        size_t n = strlen(o.scene);
        if (n > 5 && !strcmp(o.scene + n - 5, ".json"))
            n -= 5;
        if (snprintf(out_buf, sizeof out_buf, "%.*s.sgbake", (int)n, o.scene) >= (int)sizeof out_buf)
            return fail("scene path too long");
        o.out = out_buf;
    }
    if (snprintf(ckpt, sizeof ckpt, "%s.ckpt", o.out) >= (int)sizeof ckpt)
        return fail("output path too long");
    if (o.threads > 0)
        omp_set_num_threads(o.threads);
    o.desc.photons.threads = o.desc.gather.threads = o.threads;
    sg_bake_desc d = sg_bake_desc_resolve(&o.desc);

    int rc = 1;
    sg_error err = {0};
    sg_scene_file sf = {0};
    sg_world *world = NULL;
    sg_bake_job *job = NULL;
    sg_bake *bake = NULL;
    double t_start = omp_get_wtime();

    struct stat stbuf;
    int have_ckpt = stat(ckpt, &stbuf) == 0;
    if (o.resume && !have_ckpt) {
        fprintf(stderr, "splatgi-bake: %s: no checkpoint to resume (a finished bake removes it)\n", ckpt);
        goto done;
    }
    if (sg_prog_load_scene(o.scene, &o.model, o.write_scene, &sf, &err) != SG_OK) {
        fail(err.message);
        goto done;
    }
    if (!o.ray_cone_set) { /* the scene's "bake" key, unless --ray-cone */
        sg_prog_bake_desc_from_scene(&sf, &o.desc);
        d = sg_bake_desc_resolve(&o.desc);
    }
    uint64_t scene_hash = sg_scene_file_hash(&sf, SG_SCENE_HASH_BAKE);
    if (o.if_stale && !o.resume) {
        /* The header's scene and parameter hashes say whether OUT is this
         * bake; the parameter hash covers every value that changes it. */
        sg_bake_file *f = NULL;
        sg_error e2 = {0};
        char why[600] = "";
        int opened = sg_bake_file_open(o.out, scene_hash, sg_bake_param_hash(&d), &f, &e2) == SG_OK &&
                     !(sg_bake_file_info(f)->flags & SG_BAKE_FLAG_CHECKPOINT);
        sg_bake_file_close(f);
        /* The header names files, not their contents: also older than an
         * input means stale (app/bake_cache.h). */
        if (opened && sg_bake_cache_fresh(o.out, &sf, why, sizeof why)) {
            printf("splatgi-bake: %s is up to date\n", o.out);
            rc = 0;
            goto done;
        }
        if (stat(o.out, &stbuf) == 0)
            printf("splatgi-bake: %s is stale (%s): baking again\n", o.out, opened ? why : e2.message);
    }
    /* Where the bake goes, and the memory it needs, before the world. */
    /* --world FILE --if-stale may rewrite FILE: rank 0 alone does, the
     * others then load what it left. */
    int world_first = mpi->active && o.world.path && o.world.if_stale;
    if (world_first && !root) {
        int stop = 0;
        if (barrier(mpi, &stop, &err) != SG_OK) {
            fail(err.message);
            goto done;
        }
        o.world.if_stale = 0;
    }
    if (sg_prog_check_output(o.out, &err) != SG_OK ||
        sg_prog_build_world(o.scene, &sf, sg_photon_map_bytes(2 * d.photons.count), &o.world, &world, &err) != SG_OK) {
        fail(err.message);
        goto done;
    }
    if (world_first && root) {
        int stop = 0;
        if (barrier(mpi, &stop, &err) != SG_OK) {
            fail(err.message);
            goto done;
        }
    }
    double t_world = omp_get_wtime() - t_start;
    size_t splats = 0, glossy = 0, models = sg_world_model_count(world);
    for (size_t m = 0; m < models; ++m) {
        size_t n = sg_scene_sites(sg_world_scene(world, (uint32_t)m))->count;
        splats += n;
        glossy += sg_world_material(world, (uint32_t)m)->type == SG_MATERIAL_GGX ? n : 0;
    }
    /* A full disk found before the bake, not after it. */
    if (sg_preflight_output(o.out, sg_preflight_bake_bytes(splats, glossy), &err) != SG_OK) {
        fail(err.message);
        goto done;
    }

    if (o.resume) {
        if (sg_bake_job_load(ckpt, world, &d, scene_hash, &job, &err) != SG_OK) {
            fail(err.message);
            if (err.status == SG_ERR_INVALID_ARG)
                fprintf(stderr, "splatgi-bake: resume with the scene and options of the interrupted run\n");
            goto done;
        }
    } else {
        if (have_ckpt)
            fprintf(stderr, "splatgi-bake: note: %s exists; starting over (--resume continues it)\n", ckpt);
        if (sg_bake_job_create(world, &d, &job, &err) != SG_OK) {
            fail(err.message);
            goto done;
        }
    }
    if (mpi->active) {
        sg_bake_job_set_comm(job, &mpi->comm);
        if (check_same_job(mpi, job, &err) != SG_OK) {
            fail(err.message);
            goto done;
        }
    }
    int threads = o.threads > 0 ? o.threads : omp_get_max_threads();
    printf("splatgi-bake: %s: %zu models, %zu splats, world built in %.2f s\n", o.scene, models, splats, t_world);
    if (mpi->active)
        printf("splatgi-bake: distributed over %d rank%s (%s), %d thread%s each\n", mpi->size,
               mpi->size == 1 ? "" : "s", mpi->library, threads, threads == 1 ? "" : "s");
    if (d.indirect == SG_BAKE_INDIRECT_PHOTONS)
        printf("splatgi-bake: photon estimator: %zu photons in %zu blocks of %d, k %u; ", d.photons.count,
               sg_photon_block_count(&d.photons), SG_PHOTON_BLOCK, d.gather.k);
    else
        printf("splatgi-bake: transport estimator: ");
    printf("%d + %d rays per sample site, %d refinements, ", d.direct_samples, d.gather_rays,
           d.refine_levels > 0 ? d.refine_levels : 0);
    if (d.ray_cone > 0.0f)
        printf("ray cone %g, ", (double)d.ray_cone);
    printf("%d thread%s\n", threads, threads == 1 ? "" : "s");
    sg_bake_progress at = sg_bake_job_progress(job);
    if (o.resume) {
        char name[64];
        printf("splatgi-bake: resuming from %s: %zu of %zu %s done\n", ckpt, at.done, at.total,
               stage_name(&at, name, sizeof name));
    }
    fflush(stdout);

    progress prog = {.tty = isatty(STDERR_FILENO), .t0 = omp_get_wtime(), .start_done = at.done,
                     .stage = (int)at.stage, .level = at.level, .quiet = !root};
    prog.last_print = prog.t0;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_sigint;
    sa.sa_flags = SA_RESETHAND; /* a second Ctrl-C quits at once */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    if (mpi->active) /* mpirun passes Ctrl-C on to the ranks as SIGTERM */
        sigaction(SIGTERM, &sa, NULL);

    double t_run0 = omp_get_wtime();
    sg_status st = sg_bake_job_run(job, on_progress, &prog, &err);
    double t_run = omp_get_wtime() - t_run0;
    end_progress_line(&prog);
    /* A Ctrl-C that came during the job's last block of work finds the job
     * done: its bake is written as usual (a checkpoint of a finished job
     * could not be resumed, and all the work is there). */
    int stop = st == SG_ERR_CANCELLED;
    if (st == SG_OK && interrupted)
        fprintf(stderr, "splatgi-bake: the bake was finished when the interrupt came; writing it\n");
    if (mpi->active && (st == SG_OK || st == SG_ERR_CANCELLED)) {
        /* A Ctrl-C after the job's last round: all ranks decide alike. */
        if (barrier(mpi, &stop, &err) != SG_OK) {
            fail(err.message);
            goto done;
        }
    }
    if (stop && !root) {
        rc = 130; /* rank 0 writes the checkpoint */
        goto done;
    }
    if (stop) {
        double t0 = omp_get_wtime();
        if (sg_bake_job_save(job, ckpt, scene_hash, &err) != SG_OK) {
            fail(err.message);
            goto done;
        }
        at = sg_bake_job_progress(job);
        char name[64];
        long long ck_size = stat(ckpt, &stbuf) == 0 ? (long long)stbuf.st_size : 0;
        fprintf(stderr,
                "splatgi-bake: interrupted at %zu of %zu %s; checkpoint %s written in %.2f s (%.1f MiB)\n",
                at.done, at.total, stage_name(&at, name, sizeof name), ckpt, omp_get_wtime() - t0,
                (double)ck_size / 1048576.0);
        print_resume_command(argc, argv);
        rc = 130;
        goto done;
    }
    if (st != SG_OK || sg_bake_job_finish(job, &bake, &err) != SG_OK) {
        fail(err.message);
        goto done;
    }
    if (!root) { /* rank 0 writes the bake */
        rc = 0;
        goto done;
    }
    sg_bake_stats bs = {0};
    sg_bake_get_stats(bake, &bs);
    double t0 = omp_get_wtime();
    if (sg_bake_save(bake, o.out, scene_hash, &err) != SG_OK) {
        fail(err.message);
        goto done;
    }
    double t_write = omp_get_wtime() - t0;
    if (remove(ckpt) != 0 && errno != ENOENT)
        fprintf(stderr, "splatgi-bake: warning: cannot remove %s: %s\n", ckpt, strerror(errno));
    long long file_size = stat(o.out, &stbuf) == 0 ? (long long)stbuf.st_size : -1;

    printf("splatgi-bake: %s -> %s (%.2f MiB)\n", o.scene, o.out, file_size >= 0 ? (double)file_size / 1048576.0 : 0.0);
    if (d.indirect == SG_BAKE_INDIRECT_PHOTONS)
        printf("  %-18s %zu photons, %zu records, %.2f M rays, %.2f s; k = %u\n", "photons", bs.photons_shot,
               bs.photon_records, (double)bs.rays.rays * 1e-6, bs.trace_seconds, d.gather.k);
    if (d.direct_samples > 0)
        printf("  %-18s %d + %d rays per site (front and back of each sample point), %zu hit a surface; "
               "%d solve sweeps; %.2f s\n",
               "sample sites", d.direct_samples, d.gather_rays, bs.site_hits, bs.transport_iterations,
               bs.direct_seconds);
    if (bs.glossy_points)
        printf("  %-18s %zu sample points, %d rays each, %.2f s\n", "glossy bins", bs.glossy_points,
               d.glossy_rays, bs.glossy_seconds);
    if (mpi->active)
        printf("  %-18s %d ranks; not divided: %.2f s (thinning, refinement, solves, interpolation%s); "
               "%ld exchanges, rank 0 sent %.2f MiB and received %.2f MiB in %.2f s\n",
               "distributed", mpi->size, bs.shared_seconds,
               d.indirect == SG_BAKE_INDIRECT_PHOTONS ? ", photon density" : "", mpi->exchanges, mib((size_t)mpi->sent),
               mib((size_t)mpi->received), mpi->seconds);
    else
        printf("  %-18s %.2f s (thinning, refinement, solves, interpolation: what ranks would repeat)\n",
               "not divisible", bs.shared_seconds);
    printf("  %-18s %.2f s\n", "write", t_write);
    printf("  %-18s %.2f s (world %.2f s, bake %.2f s in this run)\n", "total", omp_get_wtime() - t_start, t_world,
           t_run);
    printf("  %-18s %zu of %zu splats (%.2f%%)%s\n", "sample points", bs.sample_points, bs.splats,
           bs.splats ? 100.0 * (double)bs.sample_points / (double)bs.splats : 0.0,
           d.sample_spacing < 0.0f ? ", every splat (--sample-spacing all)" : "");
    for (size_t m = 0; m < models; ++m) {
        int res = 0;
        size_t gc = 0;
        const uint32_t *gs, *gn;
        const uint16_t *gb;
        sg_bake_glossy_data(bake, (uint32_t)m, &res, &gc, &gs, &gn, &gb);
        printf("    model %-10zu %zu sample points of %zu splats", m, sg_bake_sample_count(bake, (uint32_t)m),
               sg_scene_sites(sg_world_scene(world, (uint32_t)m))->count);
        if (res)
            printf(", glossy bins %d x %d", res, res);
        printf("\n");
    }
    if (d.indirect == SG_BAKE_INDIRECT_PHOTONS)
        printf("  %-18s %.1f MiB (freed before the write)\n", "photon records", mib(bs.photon_memory_bytes));
    printf("  %-18s %.1f MiB (%zu splats x %d floats)\n", "light", mib(bs.irradiance_bytes), bs.splats,
           SG_BAKE_SPLAT_FLOATS);
    printf("  %-18s %.1f MiB (glossy models: sample point per splat, splat per sample point)\n", "sample points",
           mib(bs.sample_bytes));
    printf("  %-18s %.1f MiB (%zu points x 3 R^2 halves)\n", "glossy bins", mib(bs.glossy_bytes), bs.glossy_points);
    printf("  %-18s %.1f MiB\n", "bake memory", mib(bs.memory_bytes));
    rc = 0;
done:
    sg_bake_destroy(bake);
    sg_bake_job_destroy(job);
    sg_world_destroy(world);
    sg_scene_file_free(&sf);
    return rc;
}

/* Ranks other than 0 keep quiet: rank 0 says everything once. */
static void quiet_rank(const sg_mpi *mpi)
{
    int fd = dup(STDERR_FILENO);
    msg_out = fd >= 0 ? fdopen(fd, "w") : NULL;
    if (!freopen("/dev/null", "w", stdout) || (msg_out && !freopen("/dev/null", "w", stderr)))
        msg_out = NULL; /* keep what works: messages on stderr */
    (void)mpi;
}

int main(int argc, char **argv)
{
    sg_mpi mpi;
    if (sg_mpi_start(&argc, &argv, &mpi) != 0)
        return 1;
    if (mpi.active && mpi.size > 1) {
        msg_rank = mpi.rank;
        if (mpi.rank > 0)
            quiet_rank(&mpi);
    }
    int rc = bake_main(argc, argv, &mpi);
    /* A failed rank ends them all: the others may be waiting for it in
     * an exchange. Nothing has been written (rank 0 writes last). */
    if (mpi.active && rc != 0 && rc != 130)
        sg_mpi_abort(&mpi, rc);
    return sg_mpi_finish(&mpi, rc);
}
