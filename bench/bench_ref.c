/* bench_ref — the reference path tracer's speed, and its error against
 * time: the curve a bake has to beat (DESIGN.md "Measuring").
 *
 * Scene: the Stanford dragon sampled to each size (default 125k and 1M
 * points), scaled to BENCH_SCENE_LENGTH units along its longest side and standing
 * on y = 0, Lambert albedo 0.7, on the builtin ground (albedo 0.5), under
 * a real HDR map (courtyard.exr; the builtin "sky" when absent). The scene
 * is a JSON string that goes through sg_scene_file_parse and
 * sg_world_create, like any scene file.
 *
 * Per size it measures
 *   ref        sg_ref_render, speed_size^2 pixels at speed_spp paths:
 *              paths/s, rays/s (camera, shadow and bounce rays together);
 *   primary    sg_world_intersect on the pixel-centre camera rays alone;
 *   secondary  sg_world_intersect on incoherent rays alone: at each primary
 *              hit, SECONDARY_PER_HIT cosine-distributed directions about
 *              the normal facing the camera, spawned with
 *              sg_world_spawn_ray; made once, untimed, then traced in
 *              pixel order over an OpenMP team, best of --runs after a
 *              warm-up.
 * and, for one size (--curve-points, default the first), the error curve:
 * a converged reference (ref_size^2, ref_spp, seed 1; cached as EXR under
 * the cache folder, keyed by the scene hash with the files' sizes and
 * times), then renders with other seeds at spp = 1, 2, 4, ..., max_spp,
 * each compared with sg_image_compare (relMSE, image_metrics.h). Renders
 * are timed as the best of --runs (default 3): the cores are shared, and a
 * render with the same seed is bit-identical (pathtrace.h), so repeating it
 * changes the time only.
 *
 * Output: a table on stdout, DIR/bench_ref.csv (speed rows),
 * DIR/ref_error_time.csv (curve rows) and DIR/bench_ref.md, each written
 * whole to a temporary name and renamed. scripts/bench-ref.sh draws
 * DIR/ref_error_time.png from the curve CSV with gnuplot.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "core/cli.h"
#include "bench_common.h"
#include "core/alloc.h"
#include "io/image.h"
#include "io/mesh.h"
#include "io/scene_file.h"
#include "math/rng.h"
#include "metrics/image_metrics.h"
#include "ref/pathtrace.h"
#include "render/camera.h"
#include "render/world.h"
#include "sample/warp.h"

#define DEFAULT_MESH SG_SHARED_DATA_DIR "/meshes/stanford_dragon/dragon_vrip.ply"
#define DEFAULT_ENVMAP SG_SHARED_DATA_DIR "/envmaps/blender_studiolights/courtyard.exr"
#define SECONDARY_PER_HIT 4    /* cosine rays spawned at each primary hit      */
#define DEFAULT_RUNS 3         /* every timing: best of                         */
#define REF_SEED 1             /* the converged reference                       */
#define CURVE_SEED 1000        /* curve point i uses CURVE_SEED + i             */
/* Bump when the path tracer changes what it computes: old cached
 * references then stop matching. */
#define CACHE_VERSION 2u
#define MAX_SIZES 8
#define MAX_CURVE 32

/* Camera direction: front-left, above, as bench_trace's whole view. */
static const char usage[] =
    "usage: bench_ref [options]\n"
    "Speed of the reference path tracer and its error against time on the\n"
    "Stanford dragon under an HDR map.\n"
    "  --mesh PATH        mesh to sample (default " DEFAULT_MESH ")\n"
    "  --envmap PATH      lat-long EXR (default courtyard.exr; builtin sky if absent)\n"
    "  --sizes A,B,...    point counts (default 125000,1000000)\n"
    "  --quick            125000 points, small images: a smoke test (< 1 min)\n"
    "  --threads N        OpenMP threads (default: all)\n"
    "  --runs N           time every render and ray pass as the best of N (default 3)\n"
    "  --speed-size N     speed image side (default 512; quick 128)\n"
    "  --speed-spp N      speed paths per pixel (default 4; quick 2)\n"
    "  --curve-points N   size of the error curve (default: the first size; 0: none)\n"
    "  --ref-size N       reference/curve image side (default 128; quick 48)\n"
    "  --ref-spp N        reference paths per pixel (default 4096; quick 512)\n"
    "  --max-spp N        largest curve spp, a power of 2 (default 256; quick 16)\n"
    "  --out-dir DIR      CSV and markdown folder (default docs)\n"
    "  --cache-dir DIR    reference cache (default out/ref_cache)\n"
    "  --help             this text\n";

typedef struct options {
    const char *mesh, *envmap;
    size_t sizes[MAX_SIZES];
    int size_count;
    int quick, threads;
    int runs;                   /* timings: best of                 */
    int speed_size, speed_spp;
    long curve_points;          /* -1: the first size */
    int ref_size, ref_spp, max_spp;
    const char *out_dir, *cache_dir;
} options;

/* One speed measurement. sg_ray_stats counts one "ray" per model a world
 * query traverses (world.c: an intersect tests every model, an occlusion
 * query stops at the first that blocks), so its counters are per model
 * traversal; world rays are counted here where the bench makes the rays.
 * In sg_ref_render they are not known: traversals lie between 1 and
 * model_count per world ray, intersections exactly model_count. */
typedef struct speed_row {
    size_t points;
    const char *kind;           /* "ref", "primary", "secondary"       */
    int width, spp;             /* image side; ref: paths per pixel    */
    double seconds;             /* best (ray rows) or only (ref) run   */
    uint64_t rays;              /* world rays; 0 for ref (unknown)     */
    uint64_t traversals;        /* sg_ray_stats.rays: model traversals */
    uint64_t paths;             /* ref only                            */
    double paths_s, mrays_s, mrays_s_core, mtrav_s, trav_per_path;
    double nodes, leaves, isects, splats; /* per traversal             */
    double hit_rate;            /* world rays that hit; NaN for ref    */
} speed_row;

typedef struct curve_row {
    int spp;
    uint64_t seed;
    double seconds;             /* wall time, best of runs                 */
    double cpu_seconds;         /* process CPU time (all threads), best of
                                   runs: what other jobs on the cores do
                                   not inflate                             */
    double rel_mse, rel_mse_global, predicted, energy_lum, p99, ideal;
    size_t nonfinite;
} curve_row;

#define fail(...) bench_fail("bench_ref", __VA_ARGS__) /* bench_common.h */

/* ---- options --------------------------------------------------------- */

static int parse_sizes(const char *s, options *o)
{
    return sg_cli_size_list("--sizes", s, 100, 100000000ull, o->sizes, MAX_SIZES, &o->size_count, NULL) == SG_OK;
}

/* Returns -1 to continue, else the exit status. */
static int parse_options(int argc, char **argv, options *o)
{
    memset(o, 0, sizeof *o);
    o->mesh = DEFAULT_MESH;
    o->envmap = DEFAULT_ENVMAP;
    o->out_dir = "docs";
    o->cache_dir = "out/ref_cache";
    o->curve_points = -1;
    o->runs = DEFAULT_RUNS;
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], "--quick") == 0)
            o->quick = 1;
    parse_sizes(o->quick ? "125000" : "125000,1000000", o);
    o->speed_size = o->quick ? 128 : 512;
    o->speed_spp = o->quick ? 2 : 4;
    o->ref_size = o->quick ? 48 : 128;
    o->ref_spp = o->quick ? 512 : 4096;
    o->max_spp = o->quick ? 16 : 256;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            fputs(usage, stdout);
            return 0;
        } else if (strcmp(a, "--quick") == 0)
            continue;
        if (!v)
            return fail("%s needs a value (see --help)", a);
        i++;
        if (strcmp(a, "--mesh") == 0)
            o->mesh = v;
        else if (strcmp(a, "--envmap") == 0)
            o->envmap = v;
        else if (strcmp(a, "--sizes") == 0) {
            if (!parse_sizes(v, o))
                return fail("--sizes '%s': want up to %d counts >= 100, comma-separated", v, MAX_SIZES);
        } else if (strcmp(a, "--threads") == 0) {
            if (!bench_parse_int(v, 1, 4096, &o->threads))
                return fail("--threads '%s': want 1..4096", v);
        } else if (strcmp(a, "--runs") == 0) {
            if (!bench_parse_int(v, 1, 100, &o->runs))
                return fail("--runs '%s': want 1..100", v);
        } else if (strcmp(a, "--speed-size") == 0) {
            if (!bench_parse_int(v, 8, 4096, &o->speed_size))
                return fail("--speed-size '%s': want 8..4096", v);
        } else if (strcmp(a, "--speed-spp") == 0) {
            if (!bench_parse_int(v, 1, 65536, &o->speed_spp))
                return fail("--speed-spp '%s': want 1..65536", v);
        } else if (strcmp(a, "--curve-points") == 0) {
            if (!bench_parse_long(v, 0, 100000000, &o->curve_points))
                return fail("--curve-points '%s': want 0 (none) or a point count", v);
        } else if (strcmp(a, "--ref-size") == 0) {
            if (!bench_parse_int(v, 8, 4096, &o->ref_size))
                return fail("--ref-size '%s': want 8..4096", v);
        } else if (strcmp(a, "--ref-spp") == 0) {
            if (!bench_parse_int(v, 1, 1 << 20, &o->ref_spp))
                return fail("--ref-spp '%s': want 1..1048576", v);
        } else if (strcmp(a, "--max-spp") == 0) {
            if (!bench_parse_int(v, 1, 1 << 16, &o->max_spp) || (o->max_spp & (o->max_spp - 1)))
                return fail("--max-spp '%s': want a power of 2 in 1..65536", v);
        } else if (strcmp(a, "--out-dir") == 0)
            o->out_dir = v;
        else if (strcmp(a, "--cache-dir") == 0)
            o->cache_dir = v;
        else
            return fail("unknown option %s (see --help)", a);
    }
    if (o->threads == 0)
        o->threads = omp_get_max_threads();
    if (o->curve_points < 0)
        o->curve_points = (long)o->sizes[0];
    return -1;
}

/* ---- machine and files ------------------------------------------------- */






/* ---- scene ------------------------------------------------------------- */

/* ---- measuring ----------------------------------------------------------- */

/* Counters per model traversal (the struct's comment). */
static void per_traversal(speed_row *r, const sg_ray_stats *st, double seconds)
{
    double n = st->rays > 0 ? (double)st->rays : 1.0;
    r->traversals = st->rays;
    r->mtrav_s = (double)st->rays / seconds / 1e6;
    r->nodes = (double)st->nodes / n;
    r->leaves = (double)st->leaves / n;
    r->isects = (double)st->isects / n;
    r->splats = (double)st->splats / n;
}

static sg_ref_desc ref_desc(const sg_camera *cam, int size, int spp, uint64_t seed, int threads)
{
    sg_ref_desc d = {.camera = *cam, .width = size, .height = size, .spp = spp, .max_depth = BENCH_SCENE_MAX_DEPTH,
                     .seed = seed, .threads = threads};
    return d;
}

/* sg_ref_render `runs` times; *res is the first render with the shortest
 * wall time of all (same desc: the same image every time), *cpu the
 * smallest process CPU time of a render (may be NULL). */
static sg_status render_best(const sg_world *w, const sg_ref_desc *d, int runs, sg_ref_result *res, double *cpu,
                             sg_error *err)
{
    sg_ref_result first = {0};
    double c0 = bench_cpu_seconds();
    sg_status st = sg_ref_render(w, d, &first, err);
    double best_cpu = bench_cpu_seconds() - c0;
    for (int k = 1; k < runs && st == SG_OK; k++) {
        sg_ref_result again = {0};
        c0 = bench_cpu_seconds();
        st = sg_ref_render(w, d, &again, err);
        best_cpu = fmin(best_cpu, bench_cpu_seconds() - c0);
        if (st == SG_OK && again.seconds < first.seconds)
            first.seconds = again.seconds;
        sg_ref_result_free(&again);
    }
    if (st != SG_OK) {
        sg_ref_result_free(&first);
        return st;
    }
    *res = first;
    if (cpu)
        *cpu = best_cpu;
    return SG_OK;
}

static sg_status measure_ref(const sg_world *w, const sg_camera *cam, const options *o, speed_row *r,
                             sg_error *err)
{
    sg_ref_desc d = ref_desc(cam, o->speed_size, o->speed_spp, REF_SEED, o->threads);
    sg_ref_result res = {0};
    sg_status st = render_best(w, &d, o->runs, &res, NULL, err);
    if (st != SG_OK)
        return st;
    r->kind = "ref";
    r->width = o->speed_size;
    r->spp = o->speed_spp;
    r->seconds = res.seconds;
    r->paths = res.paths;
    per_traversal(r, &res.rays, res.seconds);
    r->paths_s = (double)res.paths / res.seconds;
    r->trav_per_path = (double)res.rays.rays / (double)res.paths;
    r->hit_rate = NAN;
    sg_ref_result_free(&res);
    return SG_OK;
}

/* Primary and secondary rays alone (see the file's head comment). */
static sg_status measure_rays(const sg_world *w, const sg_camera *cam, const options *o, speed_row *prim,
                              speed_row *sec, sg_error *err)
{
    int size = o->speed_size;
    size_t npix = (size_t)size * (size_t)size;
    sg_ray *cam_rays = sg_alloc_array(npix, sizeof *cam_rays);
    sg_world_hit *hits = sg_alloc_array(npix, sizeof *hits);
    uint8_t *hit = sg_alloc_array(npix, 1);
    sg_ray *rays = sg_alloc_array(npix * SECONDARY_PER_HIT, sizeof *rays);
    sg_ray_stats *tstats = sg_calloc_array((size_t)o->threads, sizeof *tstats);
    sg_status st = SG_OK;
    if (!cam_rays || !hits || !hit || !rays || !tstats) {
        st = sg_error_set(err, SG_ERR_NOMEM, "secondary rays: out of memory for %zu pixels", npix);
        goto done;
    }
    for (size_t i = 0; i < npix; i++)
        cam_rays[i] = sg_camera_ray(cam, (float)(i % (size_t)size) + 0.5f, (float)(i / (size_t)size) + 0.5f, size,
                                    size);

    /* Primary rays: the same loop shape as the secondary one, best of N. */
    double best = INFINITY;
    sg_ray_stats pst = {0};
    for (int run = 0; run <= o->runs; run++) {
        memset(tstats, 0, (size_t)o->threads * sizeof *tstats);
        double t0 = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 256) num_threads(o->threads)
        for (size_t i = 0; i < npix; i++)
            hit[i] = (uint8_t)sg_world_intersect(w, &cam_rays[i], &hits[i], &tstats[omp_get_thread_num()]);
        double t = omp_get_wtime() - t0;
        if (run > 0 && t < best) { /* run 0 warms caches */
            best = t;
            memset(&pst, 0, sizeof pst);
            for (int k = 0; k < o->threads; k++)
                sg_ray_stats_add(&pst, &tstats[k]);
        }
    }
    prim->kind = "primary";
    prim->width = size;
    prim->seconds = best;
    per_traversal(prim, &pst, best);
    prim->rays = npix;
    prim->mrays_s = (double)npix / best / 1e6;
    prim->mrays_s_core = prim->mrays_s / o->threads;
    size_t nhit = 0;
    for (size_t i = 0; i < npix; i++)
        nhit += hit[i];
    prim->hit_rate = (double)nhit / (double)npix;

    /* Secondary rays, made once (untimed) in pixel order. Directions from
     * the counter-based generator keyed by pixel: the set ignores threads. */
    size_t nrays = 0;
    for (size_t i = 0; i < npix; i++) {
        if (!hit[i])
            continue;
        sg_vec3 n = hits[i].hit.n;
        if (sg_v3_dot(n, cam_rays[i].dir) > 0.0f)
            n = sg_v3_scale(n, -1.0f); /* the side the camera sees */
        sg_vec3 t, b;
        sg_v3_basis(n, &t, &b);
        for (uint32_t j = 0; j < SECONDARY_PER_HIT; j++) {
            sg_vec3 l = sg_warp_cosine_hemisphere_sample(sg_rng_float(7, i, 1, 2 * j), sg_rng_float(7, i, 1, 2 * j + 1));
            sg_vec3 dir = sg_v3_normalize(sg_v3_add(sg_v3_add(sg_v3_scale(t, l.x), sg_v3_scale(b, l.y)), sg_v3_scale(n, l.z)));
            rays[nrays++] = sg_world_spawn_ray(w, &hits[i], dir, INFINITY);
        }
    }
    best = INFINITY;
    sg_ray_stats sst = {0};
    size_t shit = 0; /* secondary rays that hit (same every run) */
    for (int run = 0; run <= o->runs; run++) {
        memset(tstats, 0, (size_t)o->threads * sizeof *tstats);
        size_t found = 0;
        double t0 = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 256) num_threads(o->threads) reduction(+ : found)
        for (size_t i = 0; i < nrays; i++) {
            sg_world_hit h;
            found += (size_t)sg_world_intersect(w, &rays[i], &h, &tstats[omp_get_thread_num()]);
        }
        shit = found;
        double t = omp_get_wtime() - t0;
        if (run > 0 && t < best) {
            best = t;
            memset(&sst, 0, sizeof sst);
            for (int k = 0; k < o->threads; k++)
                sg_ray_stats_add(&sst, &tstats[k]);
        }
    }
    sec->kind = "secondary";
    sec->width = size;
    sec->seconds = best;
    per_traversal(sec, &sst, best);
    sec->rays = nrays;
    sec->mrays_s = (double)nrays / best / 1e6;
    sec->mrays_s_core = sec->mrays_s / o->threads;
    sec->hit_rate = nrays > 0 ? (double)shit / (double)nrays : 0.0;

done:
    sg_free(cam_rays);
    sg_free(hits);
    sg_free(hit);
    sg_free(rays);
    sg_free(tstats);
    return st;
}

/* ---- the converged reference, cached ---------------------------------- */

typedef struct reference {
    sg_image mean, std_error;
    double seconds;        /* render time (from the cache's note when reused) */
    uint64_t paths;
    int cached;            /* 1: read from the cache                         */
    char path[4096];       /* its EXR                                        */
} reference;

static sg_status get_reference(const sg_world *w, sg_scene_file *sf, const sg_camera *cam, const options *o,
                               double est_paths_s, reference *ref, sg_error *err)
{
    /* The key covers everything the image depends on except the thread
     * count: scene, camera, render settings, file contents (by size and
     * time) and the cache format. */
    uint64_t key = bench_ref_key(sf, o->ref_size, o->ref_spp, REF_SEED, BENCH_SCENE_MAX_DEPTH, CACHE_VERSION);
    char base[3900];
    if (snprintf(base, sizeof base, "%s/ref_%016" PRIx64, o->cache_dir, key) >= (int)sizeof base)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "cache folder path too long: %s", o->cache_dir);
    snprintf(ref->path, sizeof ref->path, "%s.exr", base);
    if (bench_ref_cache_load(base, o->ref_size, &ref->mean, &ref->std_error, &ref->seconds, &ref->paths)) {
        ref->cached = 1;
        return SG_OK;
    }

    double paths = (double)o->ref_size * o->ref_size * o->ref_spp;
    printf("  reference: %dx%d at %d spp (%.3g paths), about %.0f s at the measured speed -> %s\n",
           o->ref_size, o->ref_size, o->ref_spp, paths, est_paths_s > 0 ? paths / est_paths_s : 0.0, ref->path);
    fflush(stdout);
    sg_ref_desc d = ref_desc(cam, o->ref_size, o->ref_spp, REF_SEED, o->threads);
    sg_ref_result res = {0};
    sg_status st = sg_ref_render(w, &d, &res, err);
    if (st != SG_OK)
        return st;
    ref->mean = res.mean;
    ref->std_error = res.std_error;
    ref->seconds = res.seconds;
    ref->paths = res.paths;
    ref->cached = 0;
    bench_ref_cache_store("bench_ref", o->cache_dir, base, &ref->mean, &ref->std_error, ref->seconds, ref->paths);
    return SG_OK;
}

static int cmp_double(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

/* spp = 1, 2, 4, ..., max_spp against the reference; fills rows. */
static sg_status measure_curve(const sg_world *w, const sg_camera *cam, const options *o, const reference *ref,
                               double ref_noise, curve_row *rows, int *count, sg_error *err)
{
    int n = 0;
    for (int spp = 1; spp <= o->max_spp && n < MAX_CURVE; spp *= 2, n++) {
        curve_row *r = &rows[n];
        sg_ref_desc d = ref_desc(cam, o->ref_size, spp, CURVE_SEED + (uint64_t)n, o->threads);
        sg_ref_result res = {0};
        double cpu = NAN;
        sg_status st = render_best(w, &d, o->runs, &res, &cpu, err);
        if (st != SG_OK)
            return st;
        sg_image_metrics m;
        double own = NAN;
        st = sg_image_compare(&res.mean, &ref->mean, &m, NULL, err);
        if (st == SG_OK && spp > 1)
            st = sg_image_noise_rel_mse(&ref->mean, &res.std_error, m.epsilon, &own, err);
        if (st != SG_OK) {
            sg_ref_result_free(&res);
            return st;
        }
        r->spp = spp;
        r->seed = d.seed;
        r->seconds = res.seconds;
        r->cpu_seconds = cpu;
        r->rel_mse = m.rel_mse;
        r->rel_mse_global = m.rel_mse_global;
        /* Independent estimates: E[relMSE] ~ own variance + the reference's
         * (spp = 1 has no variance estimate). */
        r->predicted = own + ref_noise;
        r->energy_lum = m.energy_ratio_lum;
        r->p99 = m.p99_rel_error;
        r->nonfinite = m.nan_pixels + m.inf_pixels;
        sg_ref_result_free(&res);
        char pred[32] = "n/a";
        if (isfinite(r->predicted))
            snprintf(pred, sizeof pred, "%.5f", r->predicted);
        printf("  %6d spp  %8.3f s (cpu %7.3f s)  relMSE %.5f  (predicted %s)  global %.5f  energy %.4f  p99 %.3f%s\n", spp,
               r->seconds, r->cpu_seconds, r->rel_mse, pred, r->rel_mse_global, r->energy_lum, r->p99,
               r->nonfinite ? "  NON-FINITE PIXELS" : "");
        fflush(stdout);
    }
    /* The 1/t line: relMSE x t = C, C the median of the points' products,
     * so that one render slowed by other jobs on the cores cannot move it. */
    double prod[MAX_CURVE];
    for (int i = 0; i < n; i++)
        prod[i] = rows[i].rel_mse * rows[i].seconds;
    qsort(prod, (size_t)n, sizeof prod[0], cmp_double);
    double c = n == 0 ? 0.0 : n % 2 ? prod[n / 2] : 0.5 * (prod[n / 2 - 1] + prod[n / 2]);
    for (int i = 0; i < n; i++)
        rows[i].ideal = c / rows[i].seconds;
    *count = n;
    return SG_OK;
}

/* ---- reports ------------------------------------------------------------- */

typedef struct report {
    const options *o;
    const speed_row *speed;
    int speed_count;
    const curve_row *curve;
    int curve_count;
    const char *machine;
    int nproc, omp_max;
    const char *env_used;       /* the envmap file or "builtin sky"      */
    float scale;
    sg_vec3 translate;
    double ref_seconds, ref_noise;
    uint64_t ref_paths;
    int ref_cached;
    const char *ref_path;
} report;

static void write_speed_csv(FILE *f, const void *ctx)
{
    const report *rp = ctx;
    fputs("machine,threads,points,kind,width,spp,seconds,rays,traversals,paths,paths_s,mrays_s,"
          "mrays_s_per_core,mtraversals_s,traversals_per_path,nodes,leaves,isects,splats,hit_rate\n",
          f);
    /* Figures that do not apply to a row are empty fields. */
    for (int i = 0; i < rp->speed_count; i++) {
        const speed_row *r = &rp->speed[i];
        int ref = r->paths > 0;
        bench_csv_text(f, rp->machine);
        fprintf(f, ",%d,%zu,%s,%d,", rp->o->threads, r->points, r->kind, r->width);
        if (ref)
            fprintf(f, "%d", r->spp);
        fprintf(f, ",%.4f,", r->seconds);
        if (!ref)
            fprintf(f, "%" PRIu64, r->rays);
        fprintf(f, ",%" PRIu64 ",", r->traversals);
        if (ref)
            fprintf(f, "%" PRIu64 ",%.1f,,,", r->paths, r->paths_s);
        else
            fprintf(f, ",,%.4f,%.4f,", r->mrays_s, r->mrays_s_core);
        fprintf(f, "%.4f,", r->mtrav_s);
        if (ref)
            fprintf(f, "%.3f", r->trav_per_path);
        fprintf(f, ",%.3f,%.3f,%.3f,%.3f,", r->nodes, r->leaves, r->isects, r->splats);
        if (!ref)
            fprintf(f, "%.4f", r->hit_rate);
        fputc('\n', f);
    }
}

/* Numbers first, then the envmap's name and the machine, so that gnuplot's
 * column numbers do not depend on commas in the CPU name
 * (scripts/bench-ref.sh reads columns 1, 3, 4, 5, 10 to 14 and 17). */
static void write_curve_csv(FILE *f, const void *ctx)
{
    const report *rp = ctx;
    fputs("spp,seed,seconds,rel_mse,rel_mse_predicted,rel_mse_global,energy_ratio_lum,p99_rel_error,"
          "nonfinite,ref_size,ref_spp,ideal_rel_mse,ref_noise_rel_mse,points,threads,cpu_seconds,envmap,machine\n",
          f);
    for (int i = 0; i < rp->curve_count; i++) {
        const curve_row *r = &rp->curve[i];
        fprintf(f, "%d,%" PRIu64 ",%.5f,%.6g,", r->spp, r->seed, r->seconds, r->rel_mse);
        if (isfinite(r->predicted))
            fprintf(f, "%.6g", r->predicted);
        fprintf(f, ",%.6g,%.5f,%.5f,%zu,%d,%d,%.6g,%.6g,%ld,%d,", r->rel_mse_global, r->energy_lum, r->p99,
                r->nonfinite, rp->o->ref_size, rp->o->ref_spp, r->ideal, rp->ref_noise, rp->o->curve_points,
                rp->o->threads);
        fprintf(f, "%.5f,", r->cpu_seconds);
        const char *slash = strrchr(rp->env_used, '/');
        bench_csv_text(f, slash ? slash + 1 : rp->env_used);
        fputc(',', f);
        bench_csv_text(f, rp->machine);
        fputc('\n', f);
    }
}

/* The cells that apply to ref rows or to ray rows only, "-" elsewhere:
 * paths/s, rays, Mrays/s, Mrays/s per core, traversals per path, hit. */
static void row_cells(const speed_row *r, char c[6][32])
{
    for (int k = 0; k < 6; k++)
        snprintf(c[k], 32, "-");
    if (r->paths > 0) {
        snprintf(c[0], 32, "%.0f", r->paths_s);
        snprintf(c[4], 32, "%.2f", r->trav_per_path);
    } else {
        snprintf(c[1], 32, "%" PRIu64, r->rays);
        snprintf(c[2], 32, "%.3f", r->mrays_s);
        snprintf(c[3], 32, "%.3f", r->mrays_s_core);
        snprintf(c[5], 32, "%.3f", r->hit_rate);
    }
}

static void write_md(FILE *f, const void *ctx)
{
    const report *rp = ctx;
    const options *o = rp->o;
    char mesh[4200];
    fprintf(f, "# Reference path tracer: speed, and error against time\n\n");
    fprintf(f, "Written by `scripts/bench-ref.sh` (bench/bench_ref.c); see bench/README.md.\n\n");
    fprintf(f, "Machine: %s, nproc %d, omp_get_max_threads %d; %d threads used.\n", rp->machine, rp->nproc,
            rp->omp_max, o->threads);
    fprintf(f, "Scene: %s sampled to N points (area-weighted, kNN radii k = 8, MLS surface), scaled by %.4g "
               "and translated by (%.4g, %.4g, %.4g) so that it is %.0f units long and stands on y = 0, Lambert "
               "albedo %.1f; builtin ground (30 x 30, albedo %.1f); envmap %s. Camera: 40° vertical fov, "
               "framing the dragon from the front-left, above. Paths: max_depth %d, Russian roulette from "
               "bounce 3.\n\n",
            bench_rel_path(o->mesh, mesh, sizeof mesh), (double)rp->scale, (double)rp->translate.x, (double)rp->translate.y,
            (double)rp->translate.z, (double)BENCH_SCENE_LENGTH, (double)BENCH_SCENE_MODEL_ALBEDO, (double)BENCH_SCENE_GROUND_ALBEDO,
            rp->env_used, BENCH_SCENE_MAX_DEPTH);
    fprintf(f, "## Speed\n\n");
    fprintf(f, "`ref`: `sg_ref_render`, %dx%d at %d spp (camera, shadow and bounce rays), best of %d. `primary`: "
               "`sg_world_intersect` on the pixel-centre camera rays alone. `secondary`: "
               "`sg_world_intersect` alone on %d cosine-distributed rays per primary hit, spawned with "
               "`sg_world_spawn_ray` (incoherent), best of %d after a warm-up. Mrays/s counts world rays "
               "(a ray against the whole scene). `sg_ray_stats` counts model traversals instead: a world "
               "intersection traverses both models (dragon, ground), an occlusion query one or both, so "
               "`sg_ref_render`'s world-ray count is not known and its speed is given in paths/s and "
               "model traversals/s (Mtrav/s). Counters are per model traversal, as bench_trace's per ray: "
               "kd-tree node steps, leaves visited, surface intersection tests, splats evaluated; hit = "
               "fraction of world rays that hit.\n\n",
            o->speed_size, o->speed_size, o->speed_spp, o->runs, SECONDARY_PER_HIT, o->runs);
    fputs("| points | kind | s | paths/s | rays | Mrays/s | Mrays/s/core | traversals | Mtrav/s | trav/path "
          "| nodes | leaves | isects | splats | hit |\n"
          "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
          f);
    for (int i = 0; i < rp->speed_count; i++) {
        const speed_row *r = &rp->speed[i];
        char c[6][32];
        row_cells(r, c);
        fprintf(f, "| %zu | %s | %.2f | %s | %s | %s | %s | %" PRIu64 " | %.3f | %s | %.1f | %.2f | %.2f | %.1f | %s |\n",
                r->points, r->kind, r->seconds, c[0], c[1], c[2], c[3], r->traversals, r->mtrav_s, c[4], r->nodes,
                r->leaves, r->isects, r->splats, c[5]);
    }
    if (rp->curve_count == 0)
        return;
    fprintf(f, "\n## Error against time (%ld points)\n\n", o->curve_points);
    fprintf(f, "Reference: %dx%d at %d spp (%.3g paths), seed %d, %.0f s%s (`%s`); its own noise is relMSE %.3g "
               "(from its standard-error image). Each row renders the same view with another seed (time: the "
               "best of %d identical renders) and compares it with `sg_image_compare`: relMSE = mean over pixels and channels of "
               "(a-b)^2 / (b^2 + 0.01 mean(b)^2) (src/metrics/image_metrics.h); predicted = the render's "
               "own variance term plus the reference's (n/a at 1 spp); global = sum (a-b)^2 / sum b^2; "
               "energy = luminance mean ratio; p99 = 99th-percentile per-pixel RMS relative error; "
               "ideal = C / t, the 1/t law of an unbiased estimator, C the median of relMSE x t over the rows; "
               "cpu = process CPU time of the render (all threads), which other jobs on the cores do not "
               "inflate as they do the wall time.\n\n",
            o->ref_size, o->ref_size, o->ref_spp, (double)rp->ref_paths, REF_SEED, rp->ref_seconds,
            rp->ref_cached ? ", cached" : "", rp->ref_path, rp->ref_noise, o->runs);
    fputs("| spp | s | cpu s | relMSE | predicted | ideal 1/t | global | energy | p99 |\n"
          "|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
          f);
    for (int i = 0; i < rp->curve_count; i++) {
        const curve_row *r = &rp->curve[i];
        char pred[32] = "n/a";
        if (isfinite(r->predicted))
            snprintf(pred, sizeof pred, "%.4g", r->predicted);
        fprintf(f, "| %d | %.3f | %.3f | %.4g | %s | %.4g | %.4g | %.4f | %.3f |\n", r->spp, r->seconds,
                r->cpu_seconds, r->rel_mse, pred,
                r->ideal, r->rel_mse_global, r->energy_lum, r->p99);
    }
    fprintf(f, "\n![relMSE against render time](ref_error_time.png)\n");
}

static void print_speed_head(void)
{
    printf("%8s %-9s %7s %8s %8s %8s %6s %9s %7s %6s %6s %6s %6s %6s %5s\n", "points", "kind", "s", "paths/s", "rays",
           "Mrays/s", "/core", "travs", "Mtrav/s", "t/path", "nodes", "leaves", "isects", "splats", "hit");
}

static void print_speed_row(const speed_row *r)
{
    char c[6][32];
    row_cells(r, c);
    printf("%8zu %-9s %7.2f %8s %8s %8s %6s %9" PRIu64 " %7.3f %6s %6.1f %6.2f %6.2f %6.1f %5s\n", r->points,
           r->kind, r->seconds, c[0], c[1], c[2], c[3], r->traversals, r->mtrav_s, c[4], r->nodes, r->leaves,
           r->isects, r->splats, c[5]);
}

/* ---- main ------------------------------------------------------------- */

int main(int argc, char **argv)
{
    options o;
    int rc = parse_options(argc, argv, &o);
    if (rc >= 0)
        return rc;
    if (access(o.mesh, R_OK) != 0) {
        printf("bench_ref: skipped: mesh %s not found (pass --mesh PATH)\n", o.mesh);
        return 0;
    }
    omp_set_num_threads(o.threads); /* world builds too */

    char machine[256];
    bench_cpu_model(machine, sizeof machine);
    int nproc = (int)sysconf(_SC_NPROCESSORS_ONLN);
    int omp_max = omp_get_max_threads();
    printf("bench_ref: machine %s, nproc %d, omp_get_max_threads %d, threads %d%s\n", machine, nproc, omp_max,
           o.threads, o.quick ? " (quick)" : "");

    sg_error err;
    const bench_scene_desc sd = bench_dragon_scene(o.mesh, o.envmap);
    bench_scene setup;
    double t0 = omp_get_wtime();
    if (bench_scene_setup(&sd, &setup, &err) != SG_OK)
        return fail("%s", err.message);
    static char env_buf[4200];
    const char *env_used = setup.have_envmap ? bench_rel_path(o.envmap, env_buf, sizeof env_buf) : "builtin sky (envmap file not found)";
    printf("bench_ref: mesh %s: scale %.5g, translate (%.4g, %.4g, %.4g); vertex box in world (%.3g %.3g %.3g)-"
           "(%.3g %.3g %.3g) (%.1f s)\n",
           o.mesh, (double)setup.scale, (double)setup.translate.x, (double)setup.translate.y,
           (double)setup.translate.z, (double)setup.world_box.lo.x, (double)setup.world_box.lo.y,
           (double)setup.world_box.lo.z, (double)setup.world_box.hi.x, (double)setup.world_box.hi.y,
           (double)setup.world_box.hi.z, omp_get_wtime() - t0);
    printf("bench_ref: envmap %s; speed %dx%d at %d spp; curve %dx%d, reference %d spp, spp 1..%d; timings best "
           "of %d\n",
           env_used, o.speed_size, o.speed_size, o.speed_spp, o.ref_size, o.ref_size, o.ref_spp, o.max_spp, o.runs);

    static speed_row speed[MAX_SIZES * 3];
    static curve_row curve[MAX_CURVE];
    int nspeed = 0, ncurve = 0;
    report rp = {.o = &o, .machine = machine, .nproc = nproc, .omp_max = omp_max, .env_used = env_used,
                 .scale = setup.scale, .translate = setup.translate};
    reference ref = {0};
    int status = 0;
    static char json[16384];

    for (int si = 0; si < o.size_count && status == 0; si++) {
        size_t n = o.sizes[si];
        sg_scene_file sf = {0};
        sg_world *w = NULL;
        if (!bench_scene_json(&sd, &setup, n, json, sizeof json)) {
            status = fail("scene JSON too long (paths?)");
            break;
        }
        if (sg_scene_file_parse(json, strlen(json), "bench_ref.json", NULL, &sf, &err) != SG_OK) {
            status = fail("%s", err.message);
            break;
        }
        t0 = omp_get_wtime();
        if (sg_world_create(&sf, &w, &err) != SG_OK) {
            sg_scene_file_free(&sf);
            status = fail("%zu points: %s", n, err.message);
            break;
        }
        double world_s = omp_get_wtime() - t0;
        sg_scene_info info;
        sg_scene_get_info(sg_world_scene(w, 0), &info);
        const sg_scene_camera *sc = &sf.cameras[0];
        sg_camera cam;
        if (sg_camera_look_at(sc->eye, sc->look, sc->up, sc->fov_deg, 1.0f, &cam, &err) != SG_OK) {
            status = fail("camera: %s", err.message);
            goto next;
        }
        printf("\n%zu points: world (sampling, radii, kd-trees, envmap) %.1f s; dragon: %zu splats, build %.2f s, "
               "%.1f MiB, support box (%.3g %.3g %.3g)-(%.3g %.3g %.3g)\n",
               n, world_s, info.splat_count, info.build_seconds, (double)info.memory_bytes / 1048576.0,
               (double)info.bounds.lo.x, (double)info.bounds.lo.y, (double)info.bounds.lo.z,
               (double)info.bounds.hi.x, (double)info.bounds.hi.y, (double)info.bounds.hi.z);
        fflush(stdout);

        speed_row *r = &speed[nspeed];
        memset(r, 0, 3 * sizeof *r);
        r[0].points = r[1].points = r[2].points = n;
        if (measure_ref(w, &cam, &o, &r[0], &err) != SG_OK ||
            measure_rays(w, &cam, &o, &r[1], &r[2], &err) != SG_OK) {
            status = fail("%zu points: %s", n, err.message);
            goto next;
        }
        print_speed_head();
        for (int k = 0; k < 3; k++)
            print_speed_row(&r[k]);
        fflush(stdout);
        nspeed += 3;

        if ((long)n == o.curve_points) {
            if (get_reference(w, &sf, &cam, &o, r[0].paths_s, &ref, &err) != SG_OK) {
                status = fail("reference: %s", err.message);
                goto next;
            }
            if (sg_image_noise_rel_mse(&ref.mean, &ref.std_error, 0.0, &rp.ref_noise, &err) != SG_OK) {
                status = fail("reference noise: %s", err.message);
                goto next;
            }
            printf("  reference %dx%d, %d spp: %.1f s%s, own noise relMSE %.3g (%s)\n", o.ref_size, o.ref_size,
                   o.ref_spp, ref.seconds, ref.cached ? " (cached)" : "", rp.ref_noise, ref.path);
            if (bench_make_dirs(o.out_dir)) {
                /* A preview, exposed so the image's mean luminance is 0.18. */
                double lum = 0;
                size_t np = (size_t)ref.mean.width * (size_t)ref.mean.height;
                for (size_t i = 0; i < np; i++)
                    lum += 0.2126 * ref.mean.data[3 * i] + 0.7152 * ref.mean.data[3 * i + 1] +
                           0.0722 * ref.mean.data[3 * i + 2];
                lum /= (double)np;
                char png[4200];
                snprintf(png, sizeof png, "%s/bench_ref_reference.png", o.out_dir);
                if (lum > 0 && sg_image_write_png(&ref.mean, png, (float)(0.18 / lum), &err) == SG_OK)
                    printf("  wrote %s\n", png);
            }
            rp.ref_seconds = ref.seconds;
            rp.ref_paths = ref.paths;
            rp.ref_cached = ref.cached;
            rp.ref_path = ref.path;
            printf("  error against time (seeds %d+):\n", CURVE_SEED);
            if (measure_curve(w, &cam, &o, &ref, rp.ref_noise, curve, &ncurve, &err) != SG_OK) {
                status = fail("curve: %s", err.message);
                goto next;
            }
        }
    next:
        sg_world_destroy(w);
        sg_scene_file_free(&sf);
    }

    printf("\nsummary (%s, %d threads)\n", machine, o.threads);
    print_speed_head();
    for (int i = 0; i < nspeed; i++)
        print_speed_row(&speed[i]);
    if (ncurve > 0) {
        printf("error against time, %ld points, %dx%d; reference %d spp (noise relMSE %.3g)\n", o.curve_points,
               o.ref_size, o.ref_size, o.ref_spp, rp.ref_noise);
        printf("%6s %9s %9s %10s %10s %10s %10s %8s %7s\n", "spp", "s", "cpu s", "relMSE", "predicted", "ideal",
               "global", "energy", "p99");
        for (int i = 0; i < ncurve; i++) {
            const curve_row *c = &curve[i];
            char pred[32] = "n/a";
            if (isfinite(c->predicted))
                snprintf(pred, sizeof pred, "%.5f", c->predicted);
            printf("%6d %9.3f %9.3f %10.5f %10s %10.5f %10.5f %8.4f %7.3f\n", c->spp, c->seconds, c->cpu_seconds,
                   c->rel_mse, pred, c->ideal, c->rel_mse_global, c->energy_lum, c->p99);
        }
    }

    rp.speed = speed;
    rp.speed_count = nspeed;
    rp.curve = curve;
    rp.curve_count = ncurve;
    if (status == 0 && !bench_make_dirs(o.out_dir))
        status = fail("cannot create %s: %s", o.out_dir, strerror(errno));
    if (status == 0) {
        char path[4200];
        snprintf(path, sizeof path, "%s/bench_ref.csv", o.out_dir);
        if (bench_write_file(path, write_speed_csv, &rp) == 0)
            printf("bench_ref: wrote %s\n", path);
        else
            status = 1;
        if (ncurve > 0) {
            snprintf(path, sizeof path, "%s/ref_error_time.csv", o.out_dir);
            if (bench_write_file(path, write_curve_csv, &rp) == 0)
                printf("bench_ref: wrote %s\n", path);
            else
                status = 1;
        }
        snprintf(path, sizeof path, "%s/bench_ref.md", o.out_dir);
        if (bench_write_file(path, write_md, &rp) == 0)
            printf("bench_ref: wrote %s\n", path);
        else
            status = 1;
    }
    sg_image_free(&ref.mean);
    sg_image_free(&ref.std_error);
    return status;
}
