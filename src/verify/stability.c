/* stability.c — the stability map (verify.h, STABILITY): every case of
 * cases.h under every surface model (verify_int.h SG_VERIFY__MODELS: MLS,
 * disks, the ISO octree), each in a child process with a time
 * limit, so that a crash or a hang is a flagged row, not a lost run.
 *
 * Invariants:
 *  1. One row per (case, model) whatever happens in the child: ok, nan
 *     (a NaN/Inf pixel in either image, or a non-finite figure), timeout
 *     (killed after case_timeout_s), crash (killed by a signal), error
 *     (the child reported a failed call; its message is logged).
 *  2. The child writes its figures to a file under a temporary name and
 *     renames it; the parent reads only a complete file.
 *  3. No OpenMP team exists in the parent when it forks (verify.c runs
 *     this part first), so the children start with a clean runtime.
 */
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "bake/bake.h"
#include "verify/cases.h"
#include "verify/refcache.h"
#include "verify/truth.h"
#include "verify/verify_int.h"

#define STABILITY_DEPTH 64 /* path depth of the references (run_case) */
#define M SG_VERIFY__MODELS /* rows[M * case + model] */
#define NFIG 20 /* figures a child reports, in the order of fig_names */
static const char *const fig_names[NFIG] = {
    "points",       "truth_pixels", "hole_rate", "spill_rate", "normal_err_deg", "flipped_rate",
    "bake_rel_mse", "bake_energy_ratio", "bake_p99", "bake_nan", "ref_nan", "ref_lum", "bake_lum",
    "world_s",      "ref_s",        "ref_cached", "bake_s",   "ref_noise_rel_mse",
    "back_hit_rate", "camera_back_hit_rate"};
enum { F_POINTS, F_TRUTHPIX, F_HOLE, F_SPILL, F_NORMAL, F_FLIP, F_RELMSE, F_ENERGY, F_P99, F_BAKENAN, F_REFNAN,
       F_REFLUM, F_BAKELUM, F_WORLDS, F_REFS, F_CACHED, F_BAKES, F_NOISE, F_BACK, F_CAMBACK };
/* The CSV writes figures [0, F_BACK), then ref_energy_vs_clean and
 * baseline, then the rest: columns keep the places the charts read. */

typedef struct sizes {
    int image, spp, direct; /* direct: envmap rays per sample site (twice as many cosine rays) */
} sizes;

static sizes case_sizes(const vctx *c)
{
    if (c->d.ci)
        return (sizes){.image = 24, .spp = 16, .direct = 2};
    return (sizes){.image = 96, .spp = 256, .direct = 8};
}

/* The child's work: figures into fig[]. */
static sg_status run_case(const vctx *c, int ci, sg_surface_model model, double fig[NFIG], sg_error *err)
{
    sizes z = case_sizes(c);
    sg_verify_case vc = {0};
    sg_world *w = NULL;
    sg_bake *b = NULL;
    sg_ref_result ref = {0};
    sg_image frame = {0};
    sg_status st = sg_verify_case_make(ci, model, c->d.ci, c->d.work_dir, &vc, err);
    if (st != SG_OK)
        return st;
    double t0 = omp_get_wtime();
    st = sg_world_create(&vc.scene, &w, err);
    if (st != SG_OK)
        goto done;
    fig[F_WORLDS] = omp_get_wtime() - t0;
    fig[F_POINTS] = 0;
    for (uint32_t m = 0; m < (uint32_t)sg_world_model_count(w); m++) {
        sg_scene_info info;
        sg_scene_get_info(sg_world_scene(w, m), &info);
        fig[F_POINTS] += (double)info.splat_count;
    }
    sg_truth_view_stats tv;
    st = sg_truth_compare_view(&vc.truth, w, &vc.camera, z.image, z.image, &tv, err);
    if (st != SG_OK)
        goto done;
    fig[F_TRUTHPIX] = (double)tv.truth_pixels;
    fig[F_HOLE] = tv.hole_rate;
    fig[F_SPILL] = tv.spill_rate;
    fig[F_NORMAL] = tv.nonfinite_normals ? NAN : tv.normal_error_deg;
    fig[F_FLIP] = tv.flipped_rate;

    /* Depth 64: the bake sums every bounce, and in the closed room (albedo
     * 0.7, light leaves only through the window) 8 bounces lose about 4%
     * of the light (measured: the bake 6.4% above a depth-8 reference,
     * 2.1% above a depth-64 one); 0.7^64 is 1e-10. Open scenes end their
     * paths long before. */
    sg_verify_ref_desc rd = {.camera = vc.camera, .width = z.image, .height = z.image, .spp = z.spp,
                             .max_depth = STABILITY_DEPTH, .cache_dir = c->d.cache_dir, .scene_key = sg_verify_scene_key(&vc.scene)};
    int cached = 0;
    st = sg_verify_reference(w, &rd, &ref, &cached, NULL, 0, err);
    if (st != SG_OK)
        goto done;
    fig[F_REFS] = ref.seconds;
    fig[F_CACHED] = cached;
    /* Hits from behind (ref/pathtrace.h sg_ref_counts): per surface hit of
     * the reference's paths, and per camera ray (camera_inside: every camera
     * hit is one, legitimately; elsewhere each follows a leak). */
    fig[F_BACK] = ref.counts.surface_hits ? (double)ref.counts.back_hits / (double)ref.counts.surface_hits : 0.0;
    fig[F_CAMBACK] = (double)ref.counts.camera_back_hits / ((double)z.image * z.image * z.spp);
    /* The relMSE the reference owes to its own noise: a floor under the
     * bake's figure (image_metrics.h). */
    st = sg_image_noise_rel_mse(&ref.mean, &ref.std_error, 0.0, &fig[F_NOISE], err);
    if (st != SG_OK)
        goto done;

    sg_bake_desc bd = {.direct_samples = z.direct, .gather_rays = 2 * z.direct};
    t0 = omp_get_wtime();
    st = sg_bake_create(w, &bd, &b, err);
    if (st != SG_OK)
        goto done;
    fig[F_BAKES] = omp_get_wtime() - t0;
    sg_bake_frame_desc fd = {.camera = vc.camera, .width = z.image, .height = z.image};
    double secs;
    st = sg_bake_render(b, w, &fd, &frame, &secs, err);
    if (st != SG_OK)
        goto done;
    char name[128];
    snprintf(name, sizeof name, "stability_%s_%s%s", vc.name, sg_verify__model_name(model), c->d.ci ? "_ci" : "");
    sg_image_metrics m;
    st = sg_verify__compare(c, &frame, &ref.mean, name, &m, err);
    if (st != SG_OK)
        goto done;
    fig[F_RELMSE] = m.rel_mse;
    fig[F_ENERGY] = m.energy_ratio_lum;
    fig[F_P99] = m.p99_rel_error;
    fig[F_BAKENAN] = (double)(m.nan_pixels + m.inf_pixels);
    fig[F_REFNAN] = (double)m.ref_nonfinite_pixels;
    fig[F_REFLUM] = 0.2126 * m.mean_b[0] + 0.7152 * m.mean_b[1] + 0.0722 * m.mean_b[2];
    fig[F_BAKELUM] = 0.2126 * m.mean_a[0] + 0.7152 * m.mean_a[1] + 0.0722 * m.mean_a[2];
done:
    sg_image_free(&frame);
    sg_ref_result_free(&ref);
    sg_bake_destroy(b);
    sg_world_destroy(w);
    sg_verify_case_free(&vc);
    return st;
}

/* In the child: run, write the figures (or the error) to path, exit. */
static void child_main(const vctx *c, int ci, sg_surface_model model, const char *path)
{
    double fig[NFIG];
    for (int i = 0; i < NFIG; i++)
        fig[i] = NAN;
    sg_error err = {0};
    sg_status st = run_case(c, ci, model, fig, &err);
    char tmp[4400];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "w");
    if (f) {
        if (st == SG_OK)
            for (int i = 0; i < NFIG; i++)
                fprintf(f, "%.9g\n", fig[i]);
        else
            fprintf(f, "error %s\n", err.message);
        if (fclose(f) == 0)
            rename(tmp, path);
    }
    if (c->d.log)
        fflush(c->d.log);
    _exit(st == SG_OK ? 0 : 3);
}

typedef struct row {
    char status[16];
    double wall;
    int have;              /* figures read                              */
    double fig[NFIG];
} row;

static void run_child(const vctx *c, int ci, sg_surface_model model, row *r)
{
    char path[4300];
    snprintf(path, sizeof path, "%s/row_%s_%s.txt", c->d.work_dir, sg_verify_case_name(ci), sg_verify__model_name(model));
    remove(path);
    memset(r, 0, sizeof *r);
    if (c->d.log)
        fflush(c->d.log);
    fflush(stdout);
    fflush(stderr);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    pid_t pid = fork();
    if (pid < 0) {
        snprintf(r->status, sizeof r->status, "error");
        sg_verify__log(c, "  fork failed: %s\n", strerror(errno));
        return;
    }
    if (pid == 0)
        child_main(c, ci, model, path);
    int wstatus = 0, killed = 0;
    for (;;) {
        pid_t w = waitpid(pid, &wstatus, WNOHANG);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        double el = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
        if (w == pid)
            break;
        if (w < 0 && errno != EINTR)
            break;
        if (el > c->d.case_timeout_s && !killed) {
            kill(pid, SIGKILL);
            killed = 1;
        }
        struct timespec nap = {0, 20 * 1000 * 1000};
        nanosleep(&nap, NULL);
    }
    r->wall = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    if (killed) {
        snprintf(r->status, sizeof r->status, "timeout");
        return;
    }
    if (WIFSIGNALED(wstatus)) {
        snprintf(r->status, sizeof r->status, "crash");
        sg_verify__log(c, "  %s/%s: killed by signal %d\n", sg_verify_case_name(ci), sg_verify__model_name(model),
                       WTERMSIG(wstatus));
        return;
    }
    FILE *f = fopen(path, "r");
    char line[1200] = "";
    if (!f) {
        snprintf(r->status, sizeof r->status, "error");
        return;
    }
    if (WEXITSTATUS(wstatus) != 0) {
        if (fgets(line, sizeof line, f))
            sg_verify__log(c, "  %s/%s: %s", sg_verify_case_name(ci), sg_verify__model_name(model), line);
        fclose(f);
        snprintf(r->status, sizeof r->status, "error");
        return;
    }
    int n = 0;
    while (n < NFIG && fgets(line, sizeof line, f))
        r->fig[n++] = strtod(line, NULL);
    fclose(f);
    remove(path);
    if (n != NFIG) {
        snprintf(r->status, sizeof r->status, "error");
        return;
    }
    r->have = 1;
    int bad = r->fig[F_BAKENAN] > 0 || r->fig[F_REFNAN] > 0;
    for (int i = 0; i < NFIG; i++)
        if (!isfinite(r->fig[i]))
            bad = 1;
    snprintf(r->status, sizeof r->status, "%s", bad ? "nan" : "ok");
}

static void csv_num(vtable *t, int have, double v, const char *fmt)
{
    sg_verify__tprintf(t, ",");
    if (have)
        sg_verify__tprintf(t, fmt, v);
}

sg_status sg_verify__stability(vctx *c, sg_error *err)
{
    int n = sg_verify_case_count();
    row *rows = calloc((size_t)n * M, sizeof *rows);
    if (!rows)
        return sg_error_set(err, SG_ERR_NOMEM, "stability: out of memory");
    if (!sg_verify__make_dirs(c->d.work_dir)) {
        free(rows);
        return sg_error_set(err, SG_ERR_IO, "%s: cannot create: %s", c->d.work_dir, strerror(errno));
    }
    sizes z = case_sizes(c);
    char models[64] = "";
    for (int m = 0; m < M; m++)
        snprintf(models + strlen(models), sizeof models - strlen(models), "%s%s", m ? ", " : "",
                 sg_verify__model_name((sg_surface_model)m));
    sg_verify__log(c, "stability: %d cases x {%s}; %dx%d, reference %d spp, bake %d + %d rays per sample "
                      "site; limit %.3g s per run\n",
                   n, models, z.image, z.image, z.spp, z.direct, 2 * z.direct, c->d.case_timeout_s);
    int run[64] = {0}; /* run[i]: case i selected (--case) */
    if (n > 64) {
        free(rows);
        return sg_error_set(err, SG_ERR_INVALID_ARG, "stability: %d cases, at most 64", n);
    }
    for (int i = 0; i < n; i++) {
        run[i] = !c->d.only_case || strcmp(c->d.only_case, sg_verify_case_name(i)) == 0;
        if (!run[i])
            continue;
        for (int m = 0; m < M; m++) {
            row *r = &rows[M * i + m];
            run_child(c, i, (sg_surface_model)m, r);
            c->sum->cases_run++;
            if (strcmp(r->status, "ok") != 0)
                c->sum->flagged++;
            if (r->have)
                sg_verify__log(c,
                               "  %-16s %-4s %-7s %5.1f s  holes %6.2f%%  normal %6.2f deg  bake relMSE %.4f energy "
                               "%.4f  NaN %g/%g\n",
                               sg_verify_case_name(i), sg_verify__model_name((sg_surface_model)m), r->status, r->wall,
                               100 * r->fig[F_HOLE], r->fig[F_NORMAL], r->fig[F_RELMSE], r->fig[F_ENERGY],
                               r->fig[F_BAKENAN], r->fig[F_REFNAN]);
            else
                sg_verify__log(c, "  %-16s %-4s %-7s %5.1f s\n", sg_verify_case_name(i),
                               sg_verify__model_name((sg_surface_model)m), r->status, r->wall);
        }
    }
    vtable t = {0};
    sg_verify__tprintf(&t, "case,model,status,wall_s");
    for (int k = 0; k < F_BACK; k++)
        sg_verify__tprintf(&t, ",%s", fig_names[k]);
    sg_verify__tprintf(&t, ",ref_energy_vs_clean,baseline");
    for (int k = F_BACK; k < NFIG; k++)
        sg_verify__tprintf(&t, ",%s", fig_names[k]);
    sg_verify__tprintf(&t, "\n");
    for (int i = 0; i < n; i++)
        for (int m = 0; m < M && run[i]; m++) {
            const row *r = &rows[M * i + m];
            sg_verify__tprintf(&t, "%s,%s,%s,%.3f", sg_verify_case_name(i), sg_verify__model_name((sg_surface_model)m),
                               r->status, r->wall);
            for (int k = 0; k < F_BACK; k++)
                csv_num(&t, r->have, r->fig[k], "%.6g");
            int base = sg_verify_case_baseline(i);
            const row *b = base >= 0 ? &rows[M * base + m] : NULL;
            int have = r->have && b && b->have && b->fig[F_REFLUM] > 0;
            csv_num(&t, have, have ? r->fig[F_REFLUM] / b->fig[F_REFLUM] : 0, "%.6g");
            sg_verify__tprintf(&t, ",%s", base >= 0 ? sg_verify_case_name(base) : "-");
            for (int k = F_BACK; k < NFIG; k++)
                csv_num(&t, r->have, r->fig[k], "%.6g");
            sg_verify__tprintf(&t, "\n");
            t.rows++;
        }
    sg_status st = sg_verify__twrite(&t, c->d.out_dir, "stability.csv", err);
    c->sum->rows += t.rows;
    sg_verify__tfree(&t);

    /* The Markdown map: one line per case, the models side by side in
     * each cell ("mls / disk / iso"). */
    char head[64] = "";
    for (int m = 0; m < M; m++)
        snprintf(head + strlen(head), sizeof head - strlen(head), "%s%s", m ? " / " : "",
                 sg_verify__model_name((sg_surface_model)m));
    vtable md = {0};
    sg_verify__tprintf(&md,
                       "| case | status (%s) | holes %% (%s) | normal error deg | flipped %% | "
                       "bake energy error %% | bake relMSE | NaN bake+ref | back hits %% of hits | "
                       "reference energy vs clean |\n"
                       "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
                       head, head);
    static const char *const fmt[7] = {"%.2f", "%.1f", "%.1f", "%+.1f", "%.4f", "%g", "%.3f"};
    for (int i = 0; i < n; i++) {
        if (!run[i])
            continue;
        const row *rr = &rows[M * i];
        sg_verify__tprintf(&md, "| %s | ", sg_verify_case_name(i));
        for (int m = 0; m < M; m++)
            sg_verify__tprintf(&md, "%s%s", m ? " / " : "", rr[m].status);
        for (int k = 0; k < 7; k++) {
            sg_verify__tprintf(&md, " | ");
            for (int m = 0; m < M; m++) {
                const row *r = &rr[m];
                double v[7] = {100 * r->fig[F_HOLE], r->fig[F_NORMAL], 100 * r->fig[F_FLIP],
                               100 * (r->fig[F_ENERGY] - 1), r->fig[F_RELMSE], r->fig[F_BAKENAN] + r->fig[F_REFNAN],
                               100 * r->fig[F_BACK]};
                char x[32];
                if (r->have)
                    snprintf(x, sizeof x, fmt[k], v[k]);
                else
                    snprintf(x, sizeof x, "–");
                sg_verify__tprintf(&md, "%s%s", m ? " / " : "", x);
            }
        }
        sg_verify__tprintf(&md, " | ");
        int base = sg_verify_case_baseline(i);
        for (int m = 0; m < M; m++) {
            const row *r = &rr[m], *b = base >= 0 ? &rows[M * base + m] : NULL;
            sg_verify__tprintf(&md, "%s", m ? " / " : "");
            if (r->have && b && b->have && b->fig[F_REFLUM] > 0)
                sg_verify__tprintf(&md, "%.3f", r->fig[F_REFLUM] / b->fig[F_REFLUM]);
            else
                sg_verify__tprintf(&md, "–");
        }
        sg_verify__tprintf(&md, " |\n");
    }
    if (st == SG_OK)
        st = sg_verify__twrite(&md, c->d.out_dir, "stability.md", err);
    sg_verify__tfree(&md);
    free(rows);
    return st;
}
