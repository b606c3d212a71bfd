/* splatgi-bake — the bake program: reads a scene file, traces the photon
 * pass in chunks with a progress display, gathers irradiance at every
 * splat (direct light at sample points, glossy bins) and writes the .sgbake file atomically. Ctrl-C stops at the next
 * photon block and writes a checkpoint (OUT.ckpt) that --resume continues;
 * the resumed bake is the same file, byte for byte, as one run straight
 * through. Options, library calls and a report; the algorithms live in
 * src/bake/.
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
#include "bake/bake_file.h"
#include "bake/bake_io.h"
#include "io/scene_file.h"
#include "program.h"
#include "render/world.h"

static const char usage[] =
    "usage: splatgi-bake SCENE.json|MODEL [-o OUT.sgbake] [options]\n"
    "Bakes the scene's global illumination (photon pass + irradiance gather) into OUT.\n"
    "  -o, --out FILE    the bake (default: SCENE with .sgbake for .json; for a\n"
    "                    model file out/MODEL.sgbake, where splatgi-view MODEL\n"
    "                    looks for it)\n"
    "  --photons N       photons shot (default 1000000)\n"
    "  --k K             photons per irradiance estimate, 1..1024 (default 64)\n"
    "  --seed S          random seed (default 1)\n"
    "  --max-depth D     surface interactions per photon (default 8)\n"
    "  --sample-spacing X  spacing of the sample points (direct light, glossy bins) in\n"
    "                    median splat radii (default: from the material, 4 diffuse,\n"
    "                    2 + 2 roughness glossy); 'all' or a negative X: every splat\n"
    "  --glossy-res R    glossy bins per side, 4..32 (default: from the roughness)\n"
    "  --glossy-rays M   rays per glossy sample point (default 128)\n"
    "  --threads T       OpenMP threads (default: all); results do not depend on it\n"
    "  --if-stale        do nothing when OUT already holds a bake of this scene with\n"
    "                    these parameters and this format (checked by its header),\n"
    "                    newer than the scene's model and envmap files\n"
    "  --resume          continue from OUT.ckpt, left by an interrupted run with the\n"
    "                    same scene and options\n"
    "  --help\n"
    "Ctrl-C stops at the next block of photons and writes OUT.ckpt (exit status 130);\n"
    "a second Ctrl-C quits at once without one. A finished bake removes OUT.ckpt.\n"
    "\n" SG_MODEL_SCENE_OPTIONS;

/* Set by the SIGINT handler, read by the progress callback and between
 * chunks. */
static volatile sig_atomic_t interrupted = 0;

static void on_sigint(int sig)
{
    (void)sig;
    interrupted = 1;
}

typedef struct options {
    const char *scene, *out;
    sg_bake_desc desc;
    int threads;
    int resume;
    int if_stale;   /* --if-stale: keep an OUT made for this scene and these parameters */
    sg_model_scene_desc model; /* the scene made for a model file      */
    const char *write_scene;   /* --write-scene                        */
} options;

typedef struct progress {
    int tty;            /* stderr is a terminal: one line redrawn in place  */
    double t0;          /* when this run's tracing began (omp_get_wtime)    */
    size_t start_done;  /* photons already done when it began (resume)      */
    double last_print;  /* plain mode: when the last line was printed       */
    int drawn;          /* tty mode: a progress line is on screen           */
} progress;

static int fail(const char *msg)
{
    fprintf(stderr, "splatgi-bake: %s\n", msg);
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

/* The photon pass's progress callback: runs on the main thread only
 * (photons.h), so it may print; returns nonzero after Ctrl-C. */
static int on_progress(void *user, size_t done, size_t total)
{
    progress *p = user;
    double now = omp_get_wtime(), t = now - p->t0;
    double rate = t > 0.0 ? (double)(done - p->start_done) / t : 0.0;
    char left[32];
    fmt_duration(rate > 0.0 ? (double)(total - done) / rate : -1.0, left, sizeof left);
    double pct = 100.0 * (double)done / (double)total;
    if (p->tty) {
        fprintf(stderr, "\r  %5.1f%%  %zu of %zu photons  %.3f Mphotons/s  %s left   ", pct, done, total,
                rate * 1e-6, left);
        fflush(stderr);
        p->drawn = 1;
    } else if (now - p->last_print >= 5.0 || done == total) {
        fprintf(stderr, "splatgi-bake: %5.1f%%, %zu of %zu photons, %.3f Mphotons/s, %s left\n", pct, done, total,
                rate * 1e-6, left);
        p->last_print = now;
    }
    return interrupted != 0;
}

static void end_progress_line(progress *p)
{
    if (p->tty && p->drawn) {
        fputc('\n', stderr);
        p->drawn = 0;
    }
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

int main(int argc, char **argv)
{
    options o = {0};
    sg_prog_init("splatgi-bake");
    int pr = parse_args(argc, argv, &o);
    if (pr)
        return pr == 2 ? 0 : 1;
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
    sg_photon_map pm = {0};
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
    if (sg_prog_check_output(o.out, &err) != SG_OK ||
        sg_prog_build_world(o.scene, &sf, sg_photon_map_bytes(2 * d.photons.count), &world, &err) != SG_OK) {
        fail(err.message);
        goto done;
    }
    double t_world = omp_get_wtime() - t_start;
    size_t splats = 0, glossy = 0, models = sg_world_model_count(world);
    for (size_t m = 0; m < models; ++m) {
        size_t n = sg_scene_points(sg_world_scene(world, (uint32_t)m))->count;
        splats += n;
        glossy += sg_world_material(world, (uint32_t)m)->type == SG_MATERIAL_GGX ? n : 0;
    }
    /* A full disk found before the bake, not after it. */
    if (sg_preflight_output(o.out, sg_preflight_bake_bytes(splats, glossy), &err) != SG_OK) {
        fail(err.message);
        goto done;
    }

    if (o.resume) {
        if (sg_bake_checkpoint_load(ckpt, world, &d, scene_hash, &pm, &err) != SG_OK) {
            fail(err.message);
            if (err.status == SG_ERR_INVALID_ARG)
                fprintf(stderr, "splatgi-bake: resume with the scene and options of the interrupted run\n");
            goto done;
        }
    } else if (have_ckpt) {
        fprintf(stderr, "splatgi-bake: note: %s exists; starting over (--resume continues it)\n", ckpt);
    }

    size_t nblocks = sg_photon_block_count(&d.photons);
    /* Chunks bound the scratch memory (records are copied into the map
     * after each chunk) and keep every thread busy: 16 blocks a thread at
     * least, at most 64 chunks. Ctrl-C needs no chunk end: the progress
     * callback cancels at the next block and the map keeps the prefix. */
    int threads = o.threads > 0 ? o.threads : omp_get_max_threads();
    size_t chunk = (nblocks + 63) / 64;
    if (chunk < (size_t)threads * 16)
        chunk = (size_t)threads * 16;
    printf("splatgi-bake: %s: %zu models, %zu splats, world built in %.2f s\n", o.scene, models, splats, t_world);
    printf("splatgi-bake: %zu photons in %zu blocks of %d, %d thread%s%s", d.photons.count, nblocks, SG_PHOTON_BLOCK,
           threads, threads == 1 ? "" : "s", pm.blocks ? "" : "\n");
    if (pm.blocks)
        printf(", resuming after %zu photons (%zu blocks) from %s\n", pm.shot, pm.blocks, ckpt);
    fflush(stdout);

    progress prog = {.tty = isatty(STDERR_FILENO), .t0 = omp_get_wtime(), .start_done = pm.shot};
    prog.last_print = prog.t0;
    d.photons.progress = on_progress;
    d.photons.progress_user = &prog;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_sigint;
    sa.sa_flags = SA_RESETHAND; /* a second Ctrl-C quits at once */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);

    double t_trace0 = omp_get_wtime();
    sg_status st = SG_OK;
    while (pm.blocks < nblocks && !interrupted && st == SG_OK) {
        size_t last = nblocks - pm.blocks > chunk ? pm.blocks + chunk : nblocks;
        st = sg_photons_trace_more(world, &d.photons, last, &pm, &err);
    }
    double t_trace = omp_get_wtime() - t_trace0;
    end_progress_line(&prog);
    if (st != SG_OK && st != SG_ERR_CANCELLED) {
        fail(err.message);
        goto done;
    }

    sg_bake_stats bs = {0};
    double t_gather = 0.0;
    if (!interrupted) {
        double t0 = omp_get_wtime();
        if (sg_bake_create_from_photons(world, &d, &pm, &bake, &err) != SG_OK) {
            fail(err.message);
            goto done;
        }
        t_gather = omp_get_wtime() - t0;
        sg_bake_get_stats(bake, &bs);
    }
    if (interrupted) { /* during the trace or the gather: keep the photons */
        double t0 = omp_get_wtime();
        if (sg_bake_checkpoint_save(ckpt, &d, &pm, scene_hash, &err) != SG_OK) {
            fail(err.message);
            goto done;
        }
        fprintf(stderr,
                "splatgi-bake: interrupted after %zu of %zu photons (%.1f%%); checkpoint %s written in %.2f s "
                "(%.1f MiB)\n",
                pm.shot, d.photons.count, 100.0 * (double)pm.shot / (double)d.photons.count, ckpt,
                omp_get_wtime() - t0, mib(sg_photon_map_bytes(pm.count)));
        print_resume_command(argc, argv);
        rc = 130;
        goto done;
    }
    size_t records = pm.count;
    sg_photon_map_free(&pm);

    double t0 = omp_get_wtime();
    if (sg_bake_save(bake, o.out, scene_hash, &err) != SG_OK) {
        fail(err.message);
        goto done;
    }
    double t_write = omp_get_wtime() - t0;
    if (remove(ckpt) != 0 && errno != ENOENT)
        fprintf(stderr, "splatgi-bake: warning: cannot remove %s: %s\n", ckpt, strerror(errno));
    long long file_size = stat(o.out, &stbuf) == 0 ? (long long)stbuf.st_size : -1;

    size_t traced = bs.photons_shot - prog.start_done;
    printf("splatgi-bake: %s -> %s (%.2f MiB)\n", o.scene, o.out, file_size >= 0 ? (double)file_size / 1048576.0 : 0.0);
    printf("  %-18s %zu photons in %.2f s (%.3f Mphotons/s); the pass: %zu records, %.2f M rays\n", "trace",
           traced, t_trace, t_trace > 0 ? (double)traced / t_trace * 1e-6 : 0.0, records,
           (double)bs.rays.rays * 1e-6);
    printf("  %-18s k = %u, normal_cos = %g, %.2f s\n", "gather", d.gather.k, (double)d.gather.normal_cos,
           t_gather - bs.direct_seconds - bs.glossy_seconds);
    if (d.direct_samples > 0)
        printf("  %-18s %d + %d shadow rays per sample point, %.2f s (with choosing and interpolating them)\n",
               "direct light", d.direct_samples, d.direct_samples, bs.direct_seconds);
    if (bs.glossy_points)
        printf("  %-18s %zu sample points, %d rays each, %.2f s\n", "glossy bins", bs.glossy_points,
               d.glossy_rays, bs.glossy_seconds);
    printf("  %-18s %.2f s\n", "write", t_write);
    printf("  %-18s %.2f s (world %.2f s)\n", "total", omp_get_wtime() - t_start, t_world);
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
               sg_scene_points(sg_world_scene(world, (uint32_t)m))->count);
        if (res)
            printf(", glossy bins %d x %d", res, res);
        printf("\n");
    }
    printf("  %-18s %.1f MiB (freed before the write)\n", "photon records", mib(bs.photon_memory_bytes));
    printf("  %-18s %.1f MiB (%zu splats x 3 floats)\n", "irradiance", mib(bs.irradiance_bytes), bs.splats);
    printf("  %-18s %.1f MiB (glossy models: sample point per splat, splat per sample point)\n", "sample points",
           mib(bs.sample_bytes));
    printf("  %-18s %.1f MiB (%zu points x 3 R^2 halves)\n", "glossy bins", mib(bs.glossy_bytes), bs.glossy_points);
    printf("  %-18s %.1f MiB\n", "bake memory", mib(bs.memory_bytes));
    rc = 0;
done:
    sg_bake_destroy(bake);
    sg_photon_map_free(&pm);
    sg_world_destroy(world);
    sg_scene_file_free(&sf);
    return rc;
}
