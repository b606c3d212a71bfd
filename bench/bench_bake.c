/* bench_bake — the PHOTON estimator's cost (time, memory, file size)
 * against model size and photon count, and its error against time next to
 * the reference path tracer's: the benchmark of the bake's first estimator
 * (SG_BAKE_INDIRECT_PHOTONS; the default transport estimator's is
 * bench_gi.c), kept to compare the two (DESIGN.md "Measuring").
 *
 * Scene: as bench_ref.c, the same construction and view: the Stanford
 * dragon sampled to each size, scaled to BENCH_SCENE_LENGTH units along its
 * longest side, standing on y = 0, Lambert albedo 0.7, on the builtin
 * ground (albedo 0.5), under courtyard.exr (the builtin "sky" when absent);
 * a JSON string through sg_scene_file_parse and sg_world_create.
 *
 * Bakes. Per size (--sizes) and photon count it traces one photon map per
 * kind (sg_photons_trace: with the direct light, or indirect only) and
 * bakes it once per (k, direct light) with sg_bake_create_from_photons,
 * which is sg_bake_create split in two so that the trace is shared: trace
 * and gather seconds (the gather includes the direct light's shadow rays
 * when it has them), photon records, irradiance and photon memory
 * (sg_bake_get_stats), the .sgbake file's size and save time (sg_bake_save
 * under --bake-dir, removed afterwards), and one lookup frame
 * (sg_bake_render) at --frame-size (512) for its time. Which bakes: every
 * size at --size-photons with --size-ks (photons carrying the direct light)
 * and --size-direct (shadow rays, the library's default 32); the curve
 * sizes also over a photon sweep (--photons; the largest curve size
 * --target-photons) with --ks, and with --direct shadow-ray samples at
 * --direct-photons.
 *
 * Error (the curve sizes): one more lookup frame at --size (128) and the
 * same camera, compared with sg_image_compare (relMSE, image_metrics.h, the
 * metric of bench_ref) against a converged reference rendered AT PIXEL
 * CENTRES: sg_ref_path at (x + 0.5, y + 0.5) per pixel, as
 * tests/bake/test_bake.c does, because the bake's frame looks up pixel
 * centres while sg_ref_render averages over each pixel (on this view a
 * jittered reference differs from the centred one by a relMSE far above
 * 0.01: printed when bench_ref's cached reference is found). The reference
 * (--ref-spp, seed 1) is cached under --cache-dir, keyed like bench_ref's
 * but tagged "centre". The reference renderer's own curve is the same
 * estimator at pixel centres with other seeds at spp = 1, 2, ...,
 * --max-spp, timed (best of --runs rounds), so that both curves are
 * unbiased against the same reference; its speed is checked against
 * sg_ref_render's at --frame-size.
 *
 * Target (the issue): the bake plus one lookup frame reaching relMSE <=
 * 0.01 in less wall time than the reference renderer needs for a 512x512
 * frame at the same error. Bake side: the fastest measured bake with
 * relMSE <= 0.01 at --size, timed as trace + gather + a --frame-size frame,
 * and once more as one sg_bake_create + sg_bake_render; the faster counts.
 * Reference side: the spp where its --size curve crosses 0.01 (log-log
 * interpolation) times --frame-size^2 pixels over sg_ref_render's measured
 * paths/s at --frame-size (best of a measurement before the sweep and one
 * after); and, as a check, the curve's interpolated time scaled by the
 * pixel count.
 *
 * Output: tables on stdout, DIR/bench_bake.csv and DIR/bench_bake.md, each
 * written whole to a temporary name and renamed. scripts/bench-bake.sh
 * draws DIR/bake_error_time.png from the CSV with gnuplot.
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
#include <unistd.h>

#include "core/cli.h"
#include "bench_common.h"
#include "bake/bake.h"
#include "bake/bake_io.h"
#include "bake/photons.h"
#include "core/alloc.h"
#include "io/image.h"
#include "io/mesh.h"
#include "io/scene_file.h"
#include "math/rng.h"
#include "metrics/image_metrics.h"
#include "ref/pathtrace.h"
#include "render/camera.h"
#include "render/world.h"

#define DEFAULT_MESH SG_SHARED_DATA_DIR "/meshes/stanford_dragon/dragon_vrip.ply"
#define DEFAULT_ENVMAP SG_SHARED_DATA_DIR "/envmaps/blender_studiolights/courtyard.exr"
/* Scene and view: bench_ref.c's, value for value (same JSON, same camera). */
#define RR_DEPTH 3             /* path tracer: its default                       */
#define BAKE_SEED 1
#define REF_SEED 1
#define CURVE_SEED 1000        /* curve point i uses CURVE_SEED + i (as bench_ref) */
#define CACHE_VERSION 2u       /* of the centred reference: bump when the path tracer changes */
#define CENTRE_TAG 0x63656e747265ull /* "centre": keys differ from bench_ref's */
/* bench_ref's cache key recipe, to find its jittered reference of the same
 * view (bench_ref.c: CACHE_VERSION, default --ref-spp). */
#define BENCH_REF_CACHE_VERSION 2u
#define BENCH_REF_SPP 4096
#define MAX_LIST 16
#define MAX_BAKES 256
#define MAX_CURVE 24

static const char usage[] =
    "usage: bench_bake [options]\n"
    "Bake time, memory and file size against model size and photon count, and\n"
    "the bake's error against time next to the reference path tracer's, on the\n"
    "Stanford dragon under an HDR map.\n"
    "  --mesh PATH          mesh to sample (default " DEFAULT_MESH ")\n"
    "  --envmap PATH        lat-long EXR (default courtyard.exr; builtin sky if absent)\n"
    "  --sizes A,B,...      point counts (default 32000,125000,1000000)\n"
    "  --curve-sizes A,...  sizes with the photon sweep and error curves\n"
    "                       (default 125000,1000000; each must be in --sizes)\n"
    "  --photons A,B,...    photon counts of the sweep on the curve sizes but the largest\n"
    "                       (default 250000,500000,1000000,2000000,4000000,8000000)\n"
    "  --target-photons A,. photon counts of the sweep on the largest curve size, the\n"
    "                       target's (default 1000000,2000000,4000000,8000000,16000000)\n"
    "  --ks A,B,...         gather k values of the photon sweeps (default 64,128); the\n"
    "                       photons carry the direct light (direct_samples -1)\n"
    "  --direct A,B,...     curve sizes: direct light by shadow rays, these samples per\n"
    "                       splat and strategy, at --direct-photons, first k (default 4,16,32)\n"
    "  --direct-photons N   photons of those bakes (default 1000000)\n"
    "  --spacings A,B,...   every shadow-ray bake once per sample spacing (sg_bake_desc.\n"
    "                       sample_spacing: 0 = the material's default, 'all' = every\n"
    "                       splat a sample point; default 0,all)\n"
    "  --size-photons N     photons of the model-size rows, every size (default 1000000)\n"
    "  --size-ks A,B,...    their k values, photons carrying direct light (default 64,128,256)\n"
    "  --size-direct A,...  and shadow-ray bakes at the first size k (default 32: the\n"
    "                       library's default bake)\n"
    "  --size N             error image side (default 128)\n"
    "  --frame-size N       timed frame side, of the bake and sg_ref_render (default 512)\n"
    "  --ref-spp N          centred reference paths per pixel (default 2048)\n"
    "  --max-spp N          largest reference-curve spp, a power of 2 (default 128)\n"
    "  --target X           relMSE of the issue's target (default 0.01)\n"
    "  --runs N             frames and curve renders: best of N (default 3)\n"
    "  --threads N          OpenMP threads (default: all)\n"
    "  --quick              32k points, small sweep and images: a smoke test (< 1 min)\n"
    "  --out-dir DIR        CSV and markdown folder (default docs; quick: out)\n"
    "  --cache-dir DIR      reference cache (default out/ref_cache)\n"
    "  --bake-dir DIR       where bake files are written and measured (default out/bench_bake)\n"
    "  --keep-bakes         keep the bake files\n"
    "  --help               this text\n";

typedef struct options {
    const char *mesh, *envmap;
    size_t sizes[MAX_LIST], curve_sizes[MAX_LIST], photons[MAX_LIST], target_photons[MAX_LIST];
    size_t ks[MAX_LIST], size_ks[MAX_LIST];
    int direct[MAX_LIST], size_direct[MAX_LIST]; /* shadow-ray samples; -1: photons carry direct light */
    float spacings[MAX_LIST];   /* sample_spacing of the shadow-ray bakes (0: material default, -1: every splat) */
    int n_spacings;
    int n_sizes, n_curve, n_photons, n_target_photons, n_ks, n_size_ks, n_direct, n_size_direct;
    size_t size_photons, direct_photons;
    int size, frame_size, ref_spp, max_spp, runs, threads, quick, keep_bakes;
    double target;
    const char *out_dir, *cache_dir, *bake_dir;
} options;

typedef struct world_row {
    size_t points, splats, dragon_splats;
    double seconds, scene_mib;
} world_row;

typedef struct bake_row {
    size_t points, splats, photons, k, records;
    int direct;                 /* sg_bake_desc.direct_samples (-1: none)   */
    float spacing;              /* sg_bake_desc.sample_spacing              */
    size_t samples;             /* sample points, all models                */
    size_t bake_bytes;          /* sg_bake_stats.memory_bytes               */
    int curve;                  /* 1: error measured                        */
    double trace_s, gather_s, bake_s, save_s;
    size_t irr_bytes, photon_bytes, file_bytes;
    double frame_s, frame_big_s; /* lookup frame at --size, --frame-size     */
    double rel_mse, rel_mse_global, energy, p99;
} bake_row;

typedef struct ref_row {
    size_t points;
    int spp, width;
    double seconds, rel_mse, predicted, energy, p99;
    double paths_s;             /* throughput (for sg_ref_render rows)      */
    const char *kind;           /* "ref" (centred curve), "ref_render"      */
} ref_row;

typedef struct target_row {
    size_t points;
    int bake_found;             /* a bake reached the target                */
    const bake_row *bake;       /* the fastest that did (or the best one)   */
    double bake_wall, bake_wall_big;
    double first_wall_big;      /* the sweep's bake_s + frame_big_s         */
    double retime_s;            /* sg_bake_create + sg_bake_render at
                                   --frame-size in one go, again; NAN: not */
    int ref_extrapolated;       /* the curve never reached the target       */
    double ref_spp, ref_t_size; /* interpolated at the target               */
    double ref_paths_s_big;     /* sg_ref_render at --frame-size            */
    double ref_t_big, ref_t_big_scaled;
    double ratio, ratio_scaled;
} target_row;

typedef struct centre_info {
    size_t points;
    double noise, seconds, jitter_rel_mse;  /* jitter: NAN when not found  */
    uint64_t paths;
    int cached;
    char path[4096];
} centre_info;

#define fail(...) bench_fail("bench_bake", __VA_ARGS__) /* bench_common.h */

/* ---- options --------------------------------------------------------- */

static int parse_list(const char *s, unsigned long long lo, unsigned long long hi, size_t *vals, int *n)
{
    return sg_cli_size_list("list", s, lo, hi, vals, MAX_LIST, n, NULL) == SG_OK;
}

/* Direct-light sample counts: 1..65536. */
static int parse_ints(const char *s, int *vals, int *n)
{
    size_t v[MAX_LIST];
    if (!parse_list(s, 1, 65536, v, n))
        return 0;
    for (int i = 0; i < *n; ++i)
        vals[i] = (int)v[i];
    return 1;
}

/* "0,all,2.5": sample spacings; "all" is -1 (every splat). */
static int parse_spacings(const char *s, float *vals, int *n)
{
    *n = 0;
    while (*s) {
        char *end;
        double v;
        if (strncmp(s, "all", 3) == 0) {
            v = -1.0;
            end = (char *)s + 3;
        } else {
            errno = 0;
            v = strtod(s, &end);
            if (errno || end == s || !(v >= 0.0 && v < 1e6))
                return 0;
        }
        if (*n == MAX_LIST)
            return 0;
        vals[(*n)++] = (float)v;
        if (*end == ',')
            end++;
        else if (*end)
            return 0;
        s = end;
    }
    return *n > 0;
}

static void spacing_label(float sp, char *buf, size_t size)
{
    if (sp < 0.0f)
        snprintf(buf, size, "every splat");
    else if (sp == 0.0f)
        snprintf(buf, size, "sample points");
    else
        snprintf(buf, size, "spacing %g", (double)sp);
}

static void sort_sizes(size_t *v, int n)
{
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && v[j - 1] > v[j]; j--) {
            size_t t = v[j];
            v[j] = v[j - 1];
            v[j - 1] = t;
        }
}

static int in_list(const size_t *vals, int n, size_t v)
{
    for (int i = 0; i < n; i++)
        if (vals[i] == v)
            return 1;
    return 0;
}

/* Returns -1 to continue, else the exit status. */
static int parse_options(int argc, char **argv, options *o)
{
    memset(o, 0, sizeof *o);
    o->mesh = DEFAULT_MESH;
    o->envmap = DEFAULT_ENVMAP;
    o->cache_dir = "out/ref_cache";
    o->bake_dir = "out/bench_bake";
    o->runs = 3;
    o->target = 0.01;
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], "--quick") == 0)
            o->quick = 1;
    int q = o->quick;
    o->out_dir = q ? "out" : "docs";
    parse_list(q ? "32000" : "32000,125000,1000000", 1, 1ull << 34, o->sizes, &o->n_sizes);
    parse_list(q ? "32000" : "125000,1000000", 1, 1ull << 34, o->curve_sizes, &o->n_curve);
    parse_list(q ? "100000,400000" : "250000,500000,1000000,2000000,4000000,8000000", 1, 1ull << 34, o->photons,
               &o->n_photons);
    parse_list(q ? "100000,400000" : "1000000,2000000,4000000,8000000,16000000", 1, 1ull << 34, o->target_photons,
               &o->n_target_photons);
    parse_list(q ? "64" : "64,128", 1, 1ull << 34, o->ks, &o->n_ks);
    parse_list(q ? "64" : "64,128,256", 1, 1ull << 34, o->size_ks, &o->n_size_ks);
    parse_ints(q ? "4" : "4,16,32", o->direct, &o->n_direct);
    parse_ints(q ? "4" : "32", o->size_direct, &o->n_size_direct);
    parse_spacings("0,all", o->spacings, &o->n_spacings);
    o->direct_photons = q ? 100000 : 1000000;
    o->size_photons = q ? 200000 : 1000000;
    o->size = q ? 48 : 128;
    o->frame_size = q ? 128 : 512;
    o->ref_spp = q ? 256 : 2048;
    o->max_spp = q ? 16 : 128;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            fputs(usage, stdout);
            return 0;
        } else if (strcmp(a, "--quick") == 0)
            continue;
        else if (strcmp(a, "--keep-bakes") == 0) {
            o->keep_bakes = 1;
            continue;
        }
        if (!v)
            return fail("%s needs a value (see --help)", a);
        i++;
        long lv;
        if (strcmp(a, "--mesh") == 0)
            o->mesh = v;
        else if (strcmp(a, "--envmap") == 0)
            o->envmap = v;
        else if (strcmp(a, "--sizes") == 0) {
            if (!parse_list(v, 100, 100000000ull, o->sizes, &o->n_sizes))
                return fail("--sizes '%s': want up to %d counts >= 100, comma-separated", v, MAX_LIST);
        } else if (strcmp(a, "--curve-sizes") == 0) {
            if (strcmp(v, "none") == 0)
                o->n_curve = 0;
            else if (!parse_list(v, 100, 100000000ull, o->curve_sizes, &o->n_curve))
                return fail("--curve-sizes '%s': want point counts (or none)", v);
        } else if (strcmp(a, "--photons") == 0) {
            if (!parse_list(v, SG_PHOTON_BLOCK, 1ull << 34, o->photons, &o->n_photons))
                return fail("--photons '%s': want up to %d counts in %d..2^34", v, MAX_LIST, SG_PHOTON_BLOCK);
        } else if (strcmp(a, "--target-photons") == 0) {
            if (!parse_list(v, SG_PHOTON_BLOCK, 1ull << 34, o->target_photons, &o->n_target_photons))
                return fail("--target-photons '%s': want up to %d counts in %d..2^34", v, MAX_LIST, SG_PHOTON_BLOCK);
        } else if (strcmp(a, "--direct") == 0) {
            if (strcmp(v, "none") == 0)
                o->n_direct = 0;
            else if (!parse_ints(v, o->direct, &o->n_direct))
                return fail("--direct '%s': want up to %d values in 1..65536 (or none)", v, MAX_LIST);
        } else if (strcmp(a, "--size-direct") == 0) {
            if (strcmp(v, "none") == 0)
                o->n_size_direct = 0;
            else if (!parse_ints(v, o->size_direct, &o->n_size_direct))
                return fail("--size-direct '%s': want up to %d values in 1..65536 (or none)", v, MAX_LIST);
        } else if (strcmp(a, "--spacings") == 0) {
            if (!parse_spacings(v, o->spacings, &o->n_spacings))
                return fail("--spacings '%s': want up to %d values >= 0 or 'all'", v, MAX_LIST);
        } else if (strcmp(a, "--direct-photons") == 0) {
            if (!bench_parse_long(v, SG_PHOTON_BLOCK, 1L << 34, &lv))
                return fail("--direct-photons '%s': want %d..2^34", v, SG_PHOTON_BLOCK);
            o->direct_photons = (size_t)lv;
        } else if (strcmp(a, "--size-ks") == 0) {
            if (!parse_list(v, 1, 4096, o->size_ks, &o->n_size_ks))
                return fail("--size-ks '%s': want up to %d values in 1..4096", v, MAX_LIST);
        } else if (strcmp(a, "--size-photons") == 0) {
            if (!bench_parse_long(v, SG_PHOTON_BLOCK, 1L << 34, &lv))
                return fail("--size-photons '%s': want %d..2^34", v, SG_PHOTON_BLOCK);
            o->size_photons = (size_t)lv;
        } else if (strcmp(a, "--ks") == 0) {
            if (!parse_list(v, 1, 4096, o->ks, &o->n_ks))
                return fail("--ks '%s': want up to %d values in 1..4096", v, MAX_LIST);
        } else if (strcmp(a, "--size") == 0) {
            if (!bench_parse_int(v, 8, 4096, &o->size))
                return fail("--size '%s': want 8..4096", v);
        } else if (strcmp(a, "--frame-size") == 0) {
            if (!bench_parse_int(v, 8, 4096, &o->frame_size))
                return fail("--frame-size '%s': want 8..4096", v);
        } else if (strcmp(a, "--ref-spp") == 0) {
            if (!bench_parse_int(v, 2, 1 << 20, &o->ref_spp))
                return fail("--ref-spp '%s': want 2..1048576", v);
        } else if (strcmp(a, "--max-spp") == 0) {
            if (!bench_parse_int(v, 2, 1 << 16, &o->max_spp) || (o->max_spp & (o->max_spp - 1)))
                return fail("--max-spp '%s': want a power of 2 in 2..65536", v);
        } else if (strcmp(a, "--target") == 0) {
            char *end;
            o->target = strtod(v, &end);
            if (*end || !(o->target > 0 && o->target < 1))
                return fail("--target '%s': want a relMSE in (0, 1)", v);
        } else if (strcmp(a, "--runs") == 0) {
            if (!bench_parse_int(v, 1, 100, &o->runs))
                return fail("--runs '%s': want 1..100", v);
        } else if (strcmp(a, "--threads") == 0) {
            if (!bench_parse_int(v, 1, 4096, &o->threads))
                return fail("--threads '%s': want 1..4096", v);
        } else if (strcmp(a, "--out-dir") == 0)
            o->out_dir = v;
        else if (strcmp(a, "--cache-dir") == 0)
            o->cache_dir = v;
        else if (strcmp(a, "--bake-dir") == 0)
            o->bake_dir = v;
        else
            return fail("unknown option %s (see --help)", a);
    }
    for (int i = 0; i < o->n_curve; i++)
        if (!in_list(o->sizes, o->n_sizes, o->curve_sizes[i]))
            return fail("--curve-sizes: %zu is not one of --sizes", o->curve_sizes[i]);
    if (o->threads == 0)
        o->threads = omp_get_max_threads();
    return -1;
}

/* The load averages at the start and the end (bench_load_avg). */
static char rp_load[2][64];

/* ---- the reference at pixel centres --------------------------------------- */

/* The path tracer's estimate through every pixel's centre (sg_ref_desc
 * pixel_centres): the radiance the bake's lookup frame shows. */
static sg_status centre_render(const sg_world *w, const sg_camera *cam, int size, int spp, uint64_t seed,
                               int threads, sg_ref_result *out, sg_error *err)
{
    sg_ref_desc d = {.camera = *cam, .width = size, .height = size, .spp = spp, .max_depth = BENCH_SCENE_MAX_DEPTH,
                     .rr_depth = RR_DEPTH, .seed = seed, .threads = threads, .pixel_centres = 1};
    return sg_ref_render(w, &d, out, err);
}

static sg_status get_centre_reference(const sg_world *w, sg_scene_file *sf, const sg_camera *cam,
                                      const options *o, sg_ref_result *ref, centre_info *ci, sg_error *err)
{
    uint64_t key = bench_ref_key(sf, o->size, o->ref_spp, REF_SEED, BENCH_SCENE_MAX_DEPTH, CACHE_VERSION) ^ CENTRE_TAG;
    char base[3900];
    if (snprintf(base, sizeof base, "%s/refc_%016" PRIx64, o->cache_dir, key) >= (int)sizeof base)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "cache folder path too long: %s", o->cache_dir);
    snprintf(ci->path, sizeof ci->path, "%s.exr", base);
    memset(ref, 0, sizeof *ref);
    if (bench_ref_cache_load(base, o->size, &ref->mean, &ref->std_error, &ref->seconds, &ref->paths)) {
        ci->seconds = ref->seconds;
        ci->paths = ref->paths;
        ci->cached = 1;
        return SG_OK;
    }
    printf("  centred reference: %dx%d at %d spp (%.3g paths) -> %s\n", o->size, o->size, o->ref_spp,
           (double)o->size * o->size * o->ref_spp, ci->path);
    fflush(stdout);
    sg_status st = centre_render(w, cam, o->size, o->ref_spp, REF_SEED, o->threads, ref, err);
    if (st != SG_OK)
        return st;
    ci->seconds = ref->seconds;
    ci->paths = ref->paths;
    ci->cached = 0;
    bench_ref_cache_store("bench_bake", o->cache_dir, base, &ref->mean, &ref->std_error, ref->seconds, ref->paths);
    return SG_OK;
}

/* bench_ref's jittered reference of this view, if its cache has one at
 * this size: relMSE(jittered, centred), the bias a jittered render carries
 * against the centred reference. NAN when absent. */
static double jitter_vs_centre(sg_scene_file *sf, const options *o, const sg_image *centre)
{
    uint64_t key = bench_ref_key(sf, o->size, BENCH_REF_SPP, REF_SEED, BENCH_SCENE_MAX_DEPTH, BENCH_REF_CACHE_VERSION);
    char path[4200];
    snprintf(path, sizeof path, "%s/ref_%016" PRIx64 ".exr", o->cache_dir, key);
    sg_image img = {0};
    sg_error err;
    if (access(path, R_OK) != 0 || sg_image_read_exr(path, &img, &err) != SG_OK)
        return NAN;
    sg_image_metrics m;
    double r = NAN;
    if (sg_image_compare(&img, centre, &m, NULL, &err) == SG_OK)
        r = m.rel_mse;
    sg_image_free(&img);
    printf("  bench_ref's jittered reference of this view found (%s): relMSE against the centred one %.4g\n", path,
           r);
    return r;
}

/* ---- measuring ----------------------------------------------------------- */

/* The centred curve, spp = 1, 2, ..., max_spp. Timed as the best of
 * --runs rounds over the whole curve (not --runs renders in a row), so that
 * a burst of load from elsewhere slows one round of a point, not all of
 * them; a point's image is the same every round (same seed). */
static sg_status ref_curve(const sg_world *w, const sg_camera *cam, const options *o, size_t points,
                           const sg_ref_result *ref, double ref_noise, ref_row *rows, int *count, sg_error *err)
{
    int n = 0;
    for (int spp = 1; spp <= o->max_spp && n < MAX_CURVE; spp *= 2)
        n++;
    for (int run = 0; run < o->runs; run++)
        for (int i = 0; i < n; i++) {
            int spp = 1 << i;
            ref_row *r = &rows[i];
            sg_ref_result res = {0};
            sg_status st = centre_render(w, cam, o->size, spp, CURVE_SEED + (uint64_t)i, o->threads, &res, err);
            if (st != SG_OK)
                return st;
            if (run > 0) {
                if (res.seconds < r->seconds)
                    r->seconds = res.seconds;
                sg_ref_result_free(&res);
                continue;
            }
            sg_image_metrics m;
            double own = NAN;
            st = sg_image_compare(&res.mean, &ref->mean, &m, NULL, err);
            if (st == SG_OK && spp > 1)
                st = sg_image_noise_rel_mse(&ref->mean, &res.std_error, m.epsilon, &own, err);
            *r = (ref_row){.points = points, .spp = spp, .width = o->size, .seconds = res.seconds,
                           .rel_mse = m.rel_mse, .predicted = own + ref_noise, .energy = m.energy_ratio_lum,
                           .p99 = m.p99_rel_error, .kind = "ref"};
            sg_ref_result_free(&res);
            if (st != SG_OK)
                return st;
        }
    for (int i = 0; i < n; i++) {
        ref_row *r = &rows[i];
        r->paths_s = (double)o->size * o->size * r->spp / r->seconds;
        char pred[32] = "n/a";
        if (isfinite(r->predicted))
            snprintf(pred, sizeof pred, "%.5f", r->predicted);
        printf("  ref %4d spp  %8.3f s  relMSE %.5f  (predicted %s)  energy %.4f  p99 %.3f\n", r->spp, r->seconds,
               r->rel_mse, pred, r->energy, r->p99);
    }
    fflush(stdout);
    *count = n;
    return SG_OK;
}

/* sg_ref_render at --frame-size, the spp of the curve's largest point
 * divided so that it takes about as long: paths/s of the real renderer
 * (jittered), best of --runs. */
static sg_status ref_render_speed(const sg_world *w, const sg_camera *cam, const options *o, size_t points,
                                  int spp, ref_row *r, sg_error *err)
{
    sg_ref_desc d = {.camera = *cam, .width = o->frame_size, .height = o->frame_size, .spp = spp,
                     .max_depth = BENCH_SCENE_MAX_DEPTH, .rr_depth = RR_DEPTH, .seed = REF_SEED, .threads = o->threads};
    double best = INFINITY;
    for (int run = 0; run < o->runs; run++) {
        sg_ref_result res = {0};
        sg_status st = sg_ref_render(w, &d, &res, err);
        if (st != SG_OK)
            return st;
        if (res.seconds < best)
            best = res.seconds;
        sg_ref_result_free(&res);
    }
    *r = (ref_row){.points = points, .spp = spp, .width = o->frame_size, .seconds = best, .rel_mse = NAN,
                   .predicted = NAN, .energy = NAN, .p99 = NAN,
                   .paths_s = (double)o->frame_size * o->frame_size * spp / best, .kind = "ref_render"};
    return SG_OK;
}

/* A lookup frame, best of runs; *img (optional) keeps the image. */
static sg_status bake_frame(const sg_bake *b, const sg_world *w, const sg_camera *cam, int size, int runs,
                            int threads, sg_image *img, double *seconds, sg_error *err)
{
    sg_bake_frame_desc fd = {.camera = *cam, .width = size, .height = size, .threads = threads};
    double best = INFINITY;
    for (int run = 0; run < runs; run++) {
        sg_image out = {0};
        double s = 0;
        sg_status st = sg_bake_render(b, w, &fd, &out, &s, err);
        if (st != SG_OK)
            return st;
        if (s < best)
            best = s;
        if (img && run == 0)
            *img = out;
        else
            sg_image_free(&out);
    }
    *seconds = best;
    return SG_OK;
}

static void print_bake_head(void)
{
    printf("  %8s %8s %4s %4s %7s %8s %8s %8s %8s %8s %9s %8s %9s %7s %8s %8s %9s %8s %7s\n", "points", "photons",
           "k", "dir", "spacing", "samples", "trace_s", "gather_s", "bake_s", "records", "bake_MiB", "ph_MiB",
           "file_MiB", "save_s", "frame_s", "frameB_s", "relMSE", "wall_s", "energy");
}

static void print_bake_row(const bake_row *r)
{
    char rel[32] = "-", wall[32] = "-", frame[32] = "-", energy[32] = "-";
    if (r->curve) {
        snprintf(rel, sizeof rel, "%.5f", r->rel_mse);
        snprintf(wall, sizeof wall, "%.2f", r->bake_s + r->frame_s);
        snprintf(frame, sizeof frame, "%.3f", r->frame_s);
        snprintf(energy, sizeof energy, "%.4f", r->energy);
    }
    printf("  %8zu %8zu %4zu %4d %7g %8zu %8.2f %8.2f %8.2f %8zu %9.2f %8.1f %9.2f %7.3f %8s %8.3f %9s %8s %7s\n",
           r->points, r->photons, r->k, r->direct, (double)r->spacing, r->samples, r->trace_s, r->gather_s, r->bake_s,
           r->records, (double)r->bake_bytes / 1048576.0,
           (double)r->photon_bytes / 1048576.0, (double)r->file_bytes / 1048576.0, r->save_s, frame,
           r->frame_big_s, rel, wall, energy);
}

/* Traces n photons once and gathers them with every k. */
/* Traces one photon map for `photons` and bakes it with every (ks[i],
 * direct[i]); the directs must all be > 0 (an indirect-only map) or all
 * -1 (a map with the direct light). */
static sg_status measure_bakes(const sg_world *w, const sg_camera *cam, uint64_t scene_hash, const options *o,
                               size_t points, size_t photons, const size_t *ks, const int *direct, int nks,
                               int curve, const sg_ref_result *ref, float exposure, bake_row *rows, int *count,
                               sg_error *err)
{
    if (nks == 0)
        return SG_OK;
    sg_bake_desc d = {.indirect = SG_BAKE_INDIRECT_PHOTONS};
    d.photons.count = photons;
    d.photons.seed = BAKE_SEED;
    d.photons.threads = o->threads;
    d.gather.threads = o->threads;
    d.direct_samples = direct[0];
    d = sg_bake_desc_resolve(&d);
    sg_photon_map pm = {0};
    sg_status st = sg_photons_trace(w, &d.photons, &pm, err);
    if (st != SG_OK)
        return st;
    for (int ii = 0; ii < nks * o->n_spacings && st == SG_OK; ii++) {
        int i = ii / o->n_spacings, si = ii % o->n_spacings;
        if (direct[i] <= 0 && si > 0)
            continue; /* no shadow rays: the spacing changes nothing */
        d.gather.k = (unsigned)ks[i];
        d.direct_samples = direct[i];
        d.sample_spacing = direct[i] > 0 ? o->spacings[si] : 0.0f;
        sg_bake *b = NULL;
        if ((st = sg_bake_create_from_photons(w, &d, &pm, &b, err)) != SG_OK)
            break;
        sg_bake_stats s;
        sg_bake_get_stats(b, &s);
        bake_row *r = &rows[(*count)];
        *r = (bake_row){.points = points, .splats = s.splats, .photons = photons, .k = ks[i], .direct = direct[i],
                        .spacing = d.sample_spacing, .samples = s.sample_points, .bake_bytes = s.memory_bytes,
                        .records = s.photon_records, .curve = curve, .trace_s = s.trace_seconds,
                        .gather_s = s.gather_seconds, .bake_s = s.trace_seconds + s.gather_seconds,
                        .irr_bytes = s.irradiance_bytes, .photon_bytes = s.photon_memory_bytes, .rel_mse = NAN,
                        .rel_mse_global = NAN, .energy = NAN, .p99 = NAN, .frame_s = NAN};
        char path[4200];
        snprintf(path, sizeof path, "%s/bake_%zu_%zu_k%zu_d%d_s%g.sgbake", o->bake_dir, points, photons, ks[i],
                 direct[i], (double)d.sample_spacing);
        double t0 = omp_get_wtime();
        st = sg_bake_save(b, path, scene_hash, err);
        r->save_s = omp_get_wtime() - t0;
        struct stat fst;
        if (st == SG_OK && stat(path, &fst) == 0)
            r->file_bytes = (size_t)fst.st_size;
        if (st == SG_OK && !o->keep_bakes)
            remove(path);
        if (st == SG_OK)
            st = bake_frame(b, w, cam, o->frame_size, o->runs, o->threads, NULL, &r->frame_big_s, err);
        if (st == SG_OK && curve) {
            sg_image img = {0};
            sg_image_metrics m;
            st = bake_frame(b, w, cam, o->size, o->runs, o->threads, &img, &r->frame_s, err);
            if (st == SG_OK)
                st = sg_image_compare(&img, &ref->mean, &m, NULL, err);
            if (st == SG_OK) {
                /* A preview beside the bake files, at the reference's exposure. */
                char png[4200];
                sg_error ignored;
                snprintf(png, sizeof png, "%s/bake_%zu_%zu_k%zu_d%d_s%g.png", o->bake_dir, points, photons, ks[i],
                         direct[i], (double)d.sample_spacing);
                if (exposure > 0)
                    sg_image_write_png(&img, png, exposure, &ignored);
                r->rel_mse = m.rel_mse;
                r->rel_mse_global = m.rel_mse_global;
                r->energy = m.energy_ratio_lum;
                r->p99 = m.p99_rel_error;
            }
            sg_image_free(&img);
        }
        sg_bake_destroy(b);
        if (st == SG_OK) {
            print_bake_row(r);
            fflush(stdout);
            (*count)++;
        }
    }
    sg_photon_map_free(&pm);
    return st;
}

typedef struct combo {
    size_t k;
    int direct;
} combo;

/* Appends every (k, direct) pair not there yet, sorted by direct (-1
 * last) then k. */
static void add_combos(combo *cs, int *n, const size_t *ks, int nks, const int *ds, int nds)
{
    for (int j = 0; j < nds; j++)
        for (int i = 0; i < nks; i++) {
            int seen = 0;
            for (int m = 0; m < *n; m++)
                seen |= cs[m].k == ks[i] && cs[m].direct == ds[j];
            if (!seen)
                cs[(*n)++] = (combo){ks[i], ds[j]};
        }
    for (int i = 1; i < *n; i++)
        for (int j = i; j > 0; j--) {
            unsigned da = (unsigned)cs[j - 1].direct, db = (unsigned)cs[j].direct; /* -1 sorts last */
            if (da < db || (da == db && cs[j - 1].k <= cs[j].k))
                break;
            combo t = cs[j];
            cs[j] = cs[j - 1];
            cs[j - 1] = t;
        }
}

/* x where y first falls to the target along increasing x, log-log
 * interpolated between the bracketing points; past the last point, the
 * 1/x law through it (*extrapolated = 1). */
static double crossing(const double *x, const double *y, int n, double target, int *extrapolated)
{
    *extrapolated = 0;
    for (int i = 0; i < n; i++) {
        if (!(y[i] <= target))
            continue;
        if (i == 0)
            return x[0];
        double t = (log(target) - log(y[i - 1])) / (log(y[i]) - log(y[i - 1]));
        return exp(log(x[i - 1]) + t * (log(x[i]) - log(x[i - 1])));
    }
    *extrapolated = 1;
    return n > 0 ? x[n - 1] * y[n - 1] / target : NAN;
}

static void compute_target(const options *o, size_t points, const bake_row *bakes, int nb, const ref_row *refs,
                           int nr, target_row *t)
{
    memset(t, 0, sizeof *t);
    t->points = points;
    double best_err = INFINITY;
    for (int i = 0; i < nb; i++) {
        const bake_row *b = &bakes[i];
        if (b->points != points || !b->curve)
            continue;
        double wall = b->bake_s + b->frame_s;
        if (b->rel_mse <= o->target && (!t->bake_found || wall < t->bake_wall)) {
            t->bake_found = 1;
            t->bake = b;
            t->bake_wall = wall;
        }
        if (!t->bake_found && b->rel_mse < best_err) {
            best_err = b->rel_mse;
            t->bake = b;
            t->bake_wall = wall;
        }
    }
    if (t->bake)
        t->bake_wall_big = t->bake->bake_s + t->bake->frame_big_s;
    double spp[MAX_CURVE], secs[MAX_CURVE], err[MAX_CURVE];
    int n = 0;
    t->ref_paths_s_big = NAN;
    for (int i = 0; i < nr; i++) {
        if (refs[i].points != points)
            continue;
        if (strcmp(refs[i].kind, "ref") == 0 && n < MAX_CURVE) {
            spp[n] = refs[i].spp;
            secs[n] = refs[i].seconds;
            err[n] = refs[i].rel_mse;
            n++;
        } else if (strcmp(refs[i].kind, "ref_render") == 0)
            t->ref_paths_s_big = refs[i].paths_s;
    }
    int ex1, ex2;
    t->ref_spp = crossing(spp, err, n, o->target, &ex1);
    t->ref_t_size = crossing(secs, err, n, o->target, &ex2);
    t->ref_extrapolated = ex1 || ex2;
    double big = (double)o->frame_size * o->frame_size;
    t->ref_t_big = t->ref_spp * big / t->ref_paths_s_big;
    t->ref_t_big_scaled = t->ref_t_size * big / ((double)o->size * o->size);
    t->first_wall_big = t->bake_wall_big;
    t->retime_s = NAN;
    t->ratio = t->ref_t_big / t->bake_wall_big;
    t->ratio_scaled = t->ref_t_big_scaled / t->bake_wall_big;
}

/* The target's bake once more, the way a user makes it: sg_bake_create
 * (trace + gather + direct light) and one --frame-size lookup frame, timed
 * together; the target takes the faster of this and the sweep's figure
 * (the cores are shared: one slow run should not decide it). */
static sg_status ref_render_speed(const sg_world *w, const sg_camera *cam, const options *o, size_t points,
                                  int spp, ref_row *r, sg_error *err);

/* ... and sg_ref_render's speed once more right after, so that both sides
 * of the ratio are the best of runs spread over the whole benchmark; rr is
 * the ref_render row, updated to the faster measurement. */
static sg_status retime_target(const sg_world *w, const sg_camera *cam, const options *o, target_row *t,
                               ref_row *rr, sg_error *err)
{
    if (!t->bake_found)
        return SG_OK;
    ref_row again;
    sg_status rst = ref_render_speed(w, cam, o, t->points, rr->spp, &again, err);
    if (rst != SG_OK)
        return rst;
    printf("  sg_ref_render %dx%d, %d spp again: %.3f s, %.0f paths/s (before the sweep: %.0f paths/s)\n",
           o->frame_size, o->frame_size, rr->spp, again.seconds, again.paths_s, rr->paths_s);
    if (again.seconds < rr->seconds)
        *rr = again;
    t->ref_paths_s_big = rr->paths_s;
    t->ref_t_big = t->ref_spp * (double)o->frame_size * o->frame_size / t->ref_paths_s_big;
    sg_bake_desc d = {.indirect = SG_BAKE_INDIRECT_PHOTONS};
    d.photons.count = t->bake->photons;
    d.photons.seed = BAKE_SEED;
    d.photons.threads = o->threads;
    d.gather.k = (unsigned)t->bake->k;
    d.gather.threads = o->threads;
    d.direct_samples = t->bake->direct;
    d.sample_spacing = t->bake->spacing;
    sg_bake_frame_desc fd = {.camera = *cam, .width = o->frame_size, .height = o->frame_size,
                             .threads = o->threads};
    sg_bake *b = NULL;
    sg_image img = {0};
    double t0 = omp_get_wtime();
    sg_status st = sg_bake_create(w, &d, &b, err);
    if (st == SG_OK)
        st = sg_bake_render(b, w, &fd, &img, NULL, err);
    double wall = omp_get_wtime() - t0;
    sg_image_free(&img);
    sg_bake_destroy(b);
    if (st != SG_OK)
        return st;
    t->retime_s = wall;
    if (wall < t->bake_wall_big)
        t->bake_wall_big = wall;
    t->ratio = t->ref_t_big / t->bake_wall_big;
    t->ratio_scaled = t->ref_t_big_scaled / t->bake_wall_big;
    return SG_OK;
}

/* ---- reports ------------------------------------------------------------- */

typedef struct report {
    const options *o;
    const char *machine, *env_used;
    int nproc;
    float scale;
    sg_vec3 translate;
    const world_row *worlds;
    int n_worlds;
    const bake_row *bakes;
    int n_bakes;
    const ref_row *refs;
    int n_refs;
    const centre_info *centres;
    int n_centres;
    const target_row *targets;
    int n_targets;
    double total_s;
} report;

static const centre_info *find_centre(const report *rp, size_t points)
{
    for (int i = 0; i < rp->n_centres; i++)
        if (rp->centres[i].points == points)
            return &rp->centres[i];
    return NULL;
}

/* Numbers first, the envmap and the machine last, so that gnuplot's column
 * numbers do not depend on commas in the CPU name. Columns (1-based):
 *  1 kind (world, bake, ref: the centred reference-renderer curve,
 *    ref_render: sg_ref_render's speed), 2 points, 3 splats, 4 photons,
 *  5 k, 6 direct (samples per splat and strategy; -1: photons carry it),
 *  7 spp, 8 width (error image), 9 frame_width, 10 trace_s, 11 gather_s
 *  (kNN gather + direct shadow rays), 12 bake_s, 13 frame_s (width),
 *  14 frame_big_s (frame_width), 15 seconds, 16 wall_s (bake + frame at
 *  width; ref: render seconds), 17 wall_big_s, 18 rel_mse,
 *  19 rel_mse_predicted, 20 rel_mse_global, 21 energy_ratio_lum,
 *  22 p99_rel_error, 23 photon_records, 24 irradiance_bytes,
 *  25 photon_bytes, 26 file_bytes, 27 save_s, 28 paths_s, 29 ref_spp,
 *  30 ref_noise_rel_mse, 31 threads, 32 sample_spacing (shadow-ray bakes:
 *  0 the material's default, -1 every splat), 33 sample_points,
 *  34 bake_bytes (all the bake keeps: irradiance, sample points, glossy
 *  bins), 35 envmap, 36 machine.
 * scripts/bench-bake.sh reads 1, 2, 4, 5, 6, 7, 8, 16, 18, 29, 32, 35.
 * Figures that do not apply to a row are empty. */
static void csv_num(FILE *f, const char *fmt, double v)
{
    if (isfinite(v))
        fprintf(f, fmt, v);
    fputc(',', f);
}

static void csv_tail(FILE *f, const report *rp, size_t points, int with_ref, const bake_row *b)
{
    const centre_info *c = with_ref ? find_centre(rp, points) : NULL;
    if (c)
        fprintf(f, "%d,%.6g,", rp->o->ref_spp, c->noise);
    else
        fputs(",,", f);
    fprintf(f, "%d,", rp->o->threads);
    if (b)
        fprintf(f, "%g,%zu,%zu,", (double)b->spacing, b->samples, b->bake_bytes);
    else
        fputs(",,,", f);
    const char *slash = strrchr(rp->env_used, '/');
    bench_csv_text(f, slash ? slash + 1 : rp->env_used);
    fputc(',', f);
    bench_csv_text(f, rp->machine);
    fputc('\n', f);
}

static void write_csv(FILE *f, const void *ctx)
{
    const report *rp = ctx;
    const options *o = rp->o;
    fputs("kind,points,splats,photons,k,direct,spp,width,frame_width,trace_s,gather_s,bake_s,frame_s,"
          "frame_big_s,seconds,wall_s,wall_big_s,rel_mse,rel_mse_predicted,rel_mse_global,energy_ratio_lum,"
          "p99_rel_error,photon_records,irradiance_bytes,photon_bytes,file_bytes,save_s,paths_s,ref_spp,"
          "ref_noise_rel_mse,threads,sample_spacing,sample_points,bake_bytes,envmap,machine\n",
          f);
    for (int i = 0; i < rp->n_worlds; i++) {
        const world_row *r = &rp->worlds[i];
        fprintf(f, "world,%zu,%zu,,,,,,,,,,,,%.3f,,,,,,,,,,,,,,", r->points, r->splats, r->seconds);
        csv_tail(f, rp, r->points, 0, NULL);
    }
    for (int i = 0; i < rp->n_bakes; i++) {
        const bake_row *r = &rp->bakes[i];
        fprintf(f, "bake,%zu,%zu,%zu,%zu,%d,,", r->points, r->splats, r->photons, r->k, r->direct);
        if (r->curve)
            fprintf(f, "%d", o->size);
        fprintf(f, ",%d,%.4f,%.4f,%.4f,", o->frame_size, r->trace_s, r->gather_s, r->bake_s);
        csv_num(f, "%.4f", r->curve ? r->frame_s : NAN);
        csv_num(f, "%.4f", r->frame_big_s);
        csv_num(f, "%.4f", r->bake_s);
        csv_num(f, "%.4f", r->curve ? r->bake_s + r->frame_s : NAN);
        csv_num(f, "%.4f", r->bake_s + r->frame_big_s);
        csv_num(f, "%.6g", r->curve ? r->rel_mse : NAN);
        fputc(',', f);
        csv_num(f, "%.6g", r->curve ? r->rel_mse_global : NAN);
        csv_num(f, "%.5f", r->curve ? r->energy : NAN);
        csv_num(f, "%.5f", r->curve ? r->p99 : NAN);
        fprintf(f, "%zu,%zu,%zu,%zu,%.4f,,", r->records, r->irr_bytes, r->photon_bytes, r->file_bytes, r->save_s);
        csv_tail(f, rp, r->points, r->curve, r);
    }
    for (int i = 0; i < rp->n_refs; i++) {
        const ref_row *r = &rp->refs[i];
        int curve = strcmp(r->kind, "ref") == 0;
        fprintf(f, "%s,%zu,,,,,%d,", r->kind, r->points, r->spp);
        csv_num(f, "%.0f", curve ? (double)r->width : NAN);
        fprintf(f, "%d,,,,,,%.4f,", r->width, r->seconds);
        csv_num(f, "%.4f", curve ? r->seconds : NAN);
        fputc(',', f);
        csv_num(f, "%.6g", r->rel_mse);
        csv_num(f, "%.6g", r->predicted);
        fputc(',', f);
        csv_num(f, "%.5f", r->energy);
        csv_num(f, "%.5f", r->p99);
        fprintf(f, ",,,,,%.1f,", r->paths_s);
        csv_tail(f, rp, r->points, curve, NULL);
    }
}

static void md_bake_table(FILE *f, const report *rp, int curve)
{
    if (curve)
        fputs("| points | photons | k | direct | sample points | trace s | gather s | bake s | frame s | bake + frame s | "
              "relMSE | global | energy | p99 |\n|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
              f);
    else
        fputs("| points | splats (all) | photons | k | direct | sample points | trace s | gather s | bake s | records | "
              "bake MiB | photon MiB | file MiB | save s | frame s |\n"
              "|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
              f);
    for (int i = 0; i < rp->n_bakes; i++) {
        const bake_row *r = &rp->bakes[i];
        char dir[64], sp[32];
        spacing_label(r->spacing, sp, sizeof sp);
        if (r->direct > 0)
            snprintf(dir, sizeof dir, "S = %d, %s", r->direct, sp);
        else
            snprintf(dir, sizeof dir, "photons");
        char npts[32] = "-";
        if (r->samples)
            snprintf(npts, sizeof npts, "%zu", r->samples);
        if (curve && r->curve)
            fprintf(f, "| %zu | %zu | %zu | %s | %s | %.2f | %.2f | %.2f | %.3f | %.2f | %.4g | %.4g | %.4f | %.3f |\n",
                    r->points, r->photons, r->k, dir, npts, r->trace_s, r->gather_s, r->bake_s, r->frame_s,
                    r->bake_s + r->frame_s, r->rel_mse, r->rel_mse_global, r->energy, r->p99);
        else if (!curve)
            fprintf(f, "| %zu | %zu | %zu | %zu | %s | %s | %.2f | %.2f | %.2f | %zu | %.2f | %.1f | %.2f | %.3f | %.3f |\n",
                    r->points, r->splats, r->photons, r->k, dir, npts, r->trace_s, r->gather_s, r->bake_s, r->records,
                    (double)r->bake_bytes / 1048576.0, (double)r->photon_bytes / 1048576.0,
                    (double)r->file_bytes / 1048576.0, r->save_s, r->frame_big_s);
    }
}

static void write_md(FILE *f, const void *ctx)
{
    const report *rp = ctx;
    const options *o = rp->o;
    char mesh[4200];
    fprintf(f, "# The bake: cost against model size and photons, error against time\n\n");
    fprintf(f, "Written by `scripts/bench-bake.sh` (bench/bench_bake.c); see bench/README.md.\n\n");
    fprintf(f, "Machine: %s, nproc %d; %d threads used; the run took %.0f s. Timings share the cores with whatever "
               "else ran: load average %s at the start, %s at the end (1, 5, 15 min).\n\n",
            rp->machine, rp->nproc, o->threads, rp->total_s, rp_load[0], rp_load[1]);
    fprintf(f, "Scene (as bench_ref, same JSON and camera): %s sampled to N points (area-weighted, kNN radii "
               "k = 8, MLS surface), scaled by %.4g and translated by (%.4g, %.4g, %.4g) so that it is %.0f units "
               "long and stands on y = 0, Lambert albedo %.1f; builtin ground (albedo %.1f); envmap %s. Camera: "
               "40° vertical fov, the dragon framed from the front-left, above.\n\n",
            bench_rel_path(o->mesh, mesh, sizeof mesh), (double)rp->scale, (double)rp->translate.x,
            (double)rp->translate.y, (double)rp->translate.z, (double)BENCH_SCENE_LENGTH, (double)BENCH_SCENE_MODEL_ALBEDO,
            (double)BENCH_SCENE_GROUND_ALBEDO, rp->env_used);
    fprintf(f, "Bake: `sg_photons_trace` (seed %d, max depth 8, Russian roulette from bounce 2: the defaults), "
               "then `sg_bake_create_from_photons` once per (k, direct) on the same map (bake s = trace s + "
               "gather s, what `sg_bake_create` takes). direct: `photons` = `direct_samples` -1, the photons "
               "carry the direct light too and the gather is the kNN estimate alone; `S = n` = the direct light "
               "by n + n shadow rays per sample point (envmap and cosine sampling, bake/transport.h; 32 is the "
               "library's default) at `sample points` (bake/samples.h: the material's default spacing, 4 median "
               "splat radii for these Lambert models, refined twice where the light changes fast, then "
               "interpolated to every splat: the library's default) or at `every splat` (sample_spacing < 0, "
               "the bake before sample points), the photons record indirect light only (fewer records), and "
               "gather s includes the shadow rays, whose cost grows with the number of sample points. Memory "
               "(bake MiB): `sg_bake_get_stats` memory_bytes, all the bake keeps (irradiance per splat; sample "
               "points and glossy bins, none for these Lambert models); photon records while baking, freed. File: `sg_bake_save` to %s (removed after "
               "measuring). Frame: `sg_bake_render`, best of %d.\n\n",
            BAKE_SEED, o->bake_dir, o->runs);
    fprintf(f, "## World build\n\n| points | splats (dragon + ground) | world s |\n|---:|---:|---:|\n");
    for (int i = 0; i < rp->n_worlds; i++)
        fprintf(f, "| %zu | %zu | %.1f |\n", rp->worlds[i].points, rp->worlds[i].splats, rp->worlds[i].seconds);
    fprintf(f, "\n## Bake cost against model size and photon count\n\nEvery size at %zu photons (k and "
               "direct light as the library's defaults and around them); the curve sizes also at every photon "
               "count of their sweeps. frame s: one %dx%d lookup frame.\n\n",
            o->size_photons, o->frame_size, o->frame_size);
    md_bake_table(f, rp, 0);
    if (rp->n_centres == 0)
        return;
    fprintf(f, "\n## Error against time\n\n");
    fprintf(f, "Every bake above on a curve size also renders a %dx%d lookup frame at the reference's camera, "
               "compared with `sg_image_compare` (relMSE = mean over pixels and channels of (a-b)^2 / (b^2 + 0.01 "
               "mean(b)^2), the metric of bench_ref) against a converged reference rendered **at pixel centres**: "
               "`sg_ref_path` at (x + 0.5, y + 0.5), %d paths per pixel, seed %d, the estimator of "
               "`sg_ref_render` without pixel jitter (nothing added to src/), because the lookup frame shows "
               "pixel centres while `sg_ref_render` averages over each pixel.",
            o->size, o->size, o->ref_spp, REF_SEED);
    for (int i = 0; i < rp->n_centres; i++) {
        const centre_info *c = &rp->centres[i];
        fprintf(f, " %zu points: %.0f s%s, own noise relMSE %.3g", c->points, c->seconds,
                c->cached ? " (cached)" : "", c->noise);
        if (isfinite(c->jitter_rel_mse))
            fprintf(f, "; bench_ref's jittered %d-spp reference of the same view differs from it by relMSE "
                       "%.3g (what jitter alone costs against a centred reference)",
                    BENCH_REF_SPP, c->jitter_rel_mse);
        fputc('.', f);
    }
    fprintf(f, " The reference renderer's curve is the same centred estimator with seeds %d+ at spp = 1, 2, "
               "..., %d, timed (best of %d): unbiased, so its relMSE is its variance plus the reference's "
               "noise (predicted: from the per-pixel standard errors).\n\n",
            CURVE_SEED, o->max_spp, o->runs);
    md_bake_table(f, rp, 1);
    fprintf(f, "\n| points | reference renderer | spp | size | s | relMSE | predicted | paths/s |\n"
               "|---:|---|---:|---:|---:|---:|---:|---:|\n");
    for (int i = 0; i < rp->n_refs; i++) {
        const ref_row *r = &rp->refs[i];
        if (strcmp(r->kind, "ref") == 0) {
            char pred[32] = "n/a";
            if (isfinite(r->predicted))
                snprintf(pred, sizeof pred, "%.4g", r->predicted);
            fprintf(f, "| %zu | centred | %d | %d | %.3f | %.4g | %s | %.0f |\n", r->points, r->spp, r->width,
                    r->seconds, r->rel_mse, pred, r->paths_s);
        } else
            fprintf(f, "| %zu | `sg_ref_render` (speed) | %d | %d | %.3f | - | - | %.0f |\n", r->points, r->spp,
                    r->width, r->seconds, r->paths_s);
    }
    fprintf(f, "\n![relMSE against wall time](bake_error_time.png)\n");
    fprintf(f, "\n## The target\n\n");
    fprintf(f, "Issue: the bake plus one lookup frame reaches relMSE <= %g against the converged reference in "
               "less wall time than the reference renderer needs for a single %dx%d frame at the same error. "
               "Bake side: the fastest bake with relMSE <= %g at %dx%d, timed as trace + gather + one %dx%d "
               "lookup frame (the bake's error does not depend on the frame size: one lookup per pixel "
               "centre). Reference side: the spp at which its %dx%d curve crosses %g (log-log interpolation "
               "between the bracketing points), times %dx%d pixels, over `sg_ref_render`'s paths/s measured "
               "at %dx%d; check: the curve's interpolated time x (%d/%d)^2, the pixel-count scaling. The bake is "
               "timed twice: in the sweep (trace, gather and frame timed apart) and again right after, as one "
               "`sg_bake_create` + `sg_bake_render` call pair; the faster counts (shared cores); likewise `sg_ref_render`'s speed is measured before the sweep and "
               "again after the bake's second timing, and the faster counts.\n\n",
            o->target, o->frame_size, o->frame_size, o->target, o->size, o->size, o->frame_size, o->frame_size,
            o->size, o->size, o->target, o->frame_size, o->frame_size, o->frame_size, o->frame_size,
            o->frame_size, o->size);
    fprintf(f, "| points | bake reaching %g | its relMSE | bake + %d frame s (sweep; again) | reference spp | "
               "reference %d s (measured speed) | (pixel scaling) | ratio ref / bake |\n"
               "|---:|---|---:|---:|---:|---:|---:|---:|\n",
            o->target, o->frame_size, o->frame_size);
    for (int i = 0; i < rp->n_targets; i++) {
        const target_row *t = &rp->targets[i];
        if (!t->bake)
            continue;
        char dir[80], sp[32];
        spacing_label(t->bake->spacing, sp, sizeof sp);
        if (t->bake->direct > 0)
            snprintf(dir, sizeof dir, "S = %d, %s (%zu)", t->bake->direct, sp, t->bake->samples);
        else
            snprintf(dir, sizeof dir, "direct light from photons");
        fprintf(f, "| %zu | %s%zu photons, k %zu, %s | %.4g | **%.2f** (%.2f; %.2f) | %.1f%s | **%.1f** | %.1f | "
                   "**%.2f**%s |\n",
                t->points, t->bake_found ? "" : "NOT REACHED; best: ", t->bake->photons, t->bake->k, dir,
                t->bake->rel_mse, t->bake_wall_big, t->first_wall_big, t->retime_s, t->ref_spp,
                t->ref_extrapolated ? " (extrapolated 1/spp)" : "", t->ref_t_big, t->ref_t_big_scaled, t->ratio,
                t->bake_found ? "" : " (target not reached)");
    }
}

static void print_target(const options *o, const target_row *t)
{
    if (!t->bake)
        return;
    printf("target, %zu points: ", t->points);
    if (t->bake_found)
        printf("bake reaches relMSE %.5f <= %g with %zu photons, k %zu, direct %d, sample spacing %g (%zu points): "
               "bake %.2f s + %dx%d frame %.3f s "
               "= %.2f s; + %dx%d frame %.3f s = %.2f s; again (sg_bake_create + sg_bake_render %dx%d): %.2f s; "
               "taken: %.2f s\n",
               t->bake->rel_mse, o->target, t->bake->photons, t->bake->k, t->bake->direct, (double)t->bake->spacing,
               t->bake->samples, t->bake->bake_s,
               o->size, o->size, t->bake->frame_s, t->bake_wall, o->frame_size, o->frame_size,
               t->bake->frame_big_s, t->first_wall_big, o->frame_size, o->frame_size, t->retime_s,
               t->bake_wall_big);
    else
        printf("NO bake reached relMSE %g; best %.5f (%zu photons, k %zu, %.2f s + %dx%d frame = %.2f s)\n",
               o->target, t->bake->rel_mse, t->bake->photons, t->bake->k, t->bake->bake_s, o->frame_size,
               o->frame_size, t->bake_wall_big);
    printf("  reference renderer at relMSE %g: %.1f spp%s; %dx%d: %.2f s; %dx%d: %.1f s at sg_ref_render's "
           "%.0f paths/s (pixel scaling of the %d curve: %.1f s)\n",
           o->target, t->ref_spp, t->ref_extrapolated ? " (extrapolated)" : "", o->size, o->size, t->ref_t_size,
           o->frame_size, o->frame_size, t->ref_t_big, t->ref_paths_s_big, o->size, t->ref_t_big_scaled);
    printf("  ratio reference / bake (%dx%d): %.2f (pixel scaling: %.2f)%s\n", o->frame_size, o->frame_size,
           t->ratio, t->ratio_scaled, t->bake_found ? "" : "  [target not reached by the bake]");
}

/* ---- main ------------------------------------------------------------- */

int main(int argc, char **argv)
{
    options o;
    int rc = parse_options(argc, argv, &o);
    if (rc >= 0)
        return rc;
    if (access(o.mesh, R_OK) != 0) {
        printf("bench_bake: skipped: mesh %s not found (pass --mesh PATH)\n", o.mesh);
        return 0;
    }
    omp_set_num_threads(o.threads);
    double t_start = omp_get_wtime();
    char machine[256];
    bench_cpu_model(machine, sizeof machine);
    int nproc = (int)sysconf(_SC_NPROCESSORS_ONLN);
    printf("bench_bake: machine %s, nproc %d, omp_get_max_threads %d, threads %d%s\n", machine, nproc,
           omp_get_max_threads(), o.threads, o.quick ? " (quick)" : "");

    sg_error err;
    const bench_scene_desc sd = bench_dragon_scene(o.mesh, o.envmap);
    bench_scene setup;
    if (bench_scene_setup(&sd, &setup, &err) != SG_OK)
        return fail("%s", err.message);
    static char env_buf[4200];
    const char *env_used =
        setup.have_envmap ? bench_rel_path(o.envmap, env_buf, sizeof env_buf) : "builtin sky (envmap file not found)";
    printf("bench_bake: envmap %s; error images %dx%d, reference %d spp at pixel centres, curve spp 1..%d; "
           "frames %dx%d; ks",
           env_used, o.size, o.size, o.ref_spp, o.max_spp, o.frame_size, o.frame_size);
    for (int i = 0; i < o.n_ks; i++)
        printf(" %zu", o.ks[i]);
    printf("\n");
    if (!bench_make_dirs(o.bake_dir))
        return fail("cannot create %s: %s", o.bake_dir, strerror(errno));

    static world_row worlds[MAX_LIST];
    static bake_row bakes[MAX_BAKES];
    static ref_row refs[MAX_LIST * (MAX_CURVE + 1)];
    static centre_info centres[MAX_LIST];
    static target_row targets[MAX_LIST];
    int nw = 0, nb = 0, nr = 0, nc = 0, nt = 0, status = 0;
    static char json[16384];
    size_t max_curve = 0;
    for (int i = 0; i < o.n_curve; i++)
        if (o.curve_sizes[i] > max_curve)
            max_curve = o.curve_sizes[i];
    bench_load_avg(rp_load[0], sizeof rp_load[0]);

    for (int si = 0; si < o.n_sizes && status == 0; si++) {
        size_t n = o.sizes[si];
        int curve = in_list(o.curve_sizes, o.n_curve, n);
        sg_scene_file sf = {0};
        sg_world *w = NULL;
        sg_ref_result ref = {0};
        float exposure = 0.0f;
        ref_row *rr = NULL;         /* this size's sg_ref_render speed row */
        if (!bench_scene_json(&sd, &setup, n, json, sizeof json)) {
            status = fail("scene JSON too long (paths?)");
            break;
        }
        if (sg_scene_file_parse(json, strlen(json), "bench_bake.json", NULL, &sf, &err) != SG_OK) {
            status = fail("%s", err.message);
            break;
        }
        double t0 = omp_get_wtime();
        if (sg_world_create(&sf, &w, &err) != SG_OK) {
            sg_scene_file_free(&sf);
            status = fail("%zu points: %s", n, err.message);
            break;
        }
        world_row *wr = &worlds[nw++];
        *wr = (world_row){.points = n, .seconds = omp_get_wtime() - t0};
        for (uint32_t m = 0; m < (uint32_t)sg_world_model_count(w); m++) {
            sg_scene_info info;
            sg_scene_get_info(sg_world_scene(w, m), &info);
            wr->splats += info.splat_count;
            if (m == 0)
                wr->dragon_splats = info.splat_count;
        }
        uint64_t scene_hash = sg_scene_file_hash(&sf, SG_SCENE_HASH_BAKE);
        const sg_scene_camera *sc = &sf.cameras[0];
        sg_camera cam;
        sg_aabb wb = sg_world_bounds(w);
        printf("\n%zu points: world %.1f s; splats %zu (dragon %zu + ground %zu); world bounds (%.3g %.3g %.3g)-"
               "(%.3g %.3g %.3g)\n",
               n, wr->seconds, wr->splats, wr->dragon_splats, wr->splats - wr->dragon_splats, (double)wb.lo.x,
               (double)wb.lo.y, (double)wb.lo.z, (double)wb.hi.x, (double)wb.hi.y, (double)wb.hi.z);
        fflush(stdout);
        if (sg_camera_look_at(sc->eye, sc->look, sc->up, sc->fov_deg, 1.0f, &cam, &err) != SG_OK) {
            status = fail("camera: %s", err.message);
            goto next;
        }
        if (curve) {
            centre_info *ci = &centres[nc];
            memset(ci, 0, sizeof *ci);
            ci->points = n;
            if (get_centre_reference(w, &sf, &cam, &o, &ref, ci, &err) != SG_OK ||
                sg_image_noise_rel_mse(&ref.mean, &ref.std_error, 0.0, &ci->noise, &err) != SG_OK) {
                status = fail("reference: %s", err.message);
                goto next;
            }
            nc++;
            printf("  centred reference %dx%d, %d spp: %.1f s%s, own noise relMSE %.3g (%s)\n", o.size, o.size,
                   o.ref_spp, ci->seconds, ci->cached ? " (cached)" : "", ci->noise, ci->path);
            ci->jitter_rel_mse = jitter_vs_centre(&sf, &o, &ref.mean);
            {
                /* A preview beside the bake files, exposed to mean luminance 0.18. */
                double lum = 0;
                size_t np = (size_t)o.size * (size_t)o.size;
                for (size_t i = 0; i < np; i++)
                    lum += 0.2126 * ref.mean.data[3 * i] + 0.7152 * ref.mean.data[3 * i + 1] +
                           0.0722 * ref.mean.data[3 * i + 2];
                lum /= (double)np;
                char png[4200];
                snprintf(png, sizeof png, "%s/reference_centred_%zu.png", o.bake_dir, n);
                exposure = lum > 0 ? (float)(0.18 / lum) : 0.0f;
                if (lum > 0 && sg_image_write_png(&ref.mean, png, exposure, &err) == SG_OK)
                    printf("  wrote %s\n", png);
            }
            int count = 0;
            if (ref_curve(w, &cam, &o, n, &ref, ci->noise, &refs[nr], &count, &err) != SG_OK) {
                status = fail("reference curve: %s", err.message);
                goto next;
            }
            nr += count;
            /* sg_ref_render at the frame size, about as long as the
             * curve's largest point: the real renderer's speed. */
            int spp = o.max_spp * o.size * o.size / (o.frame_size * o.frame_size);
            if (spp < 1)
                spp = 1;
            rr = &refs[nr];
            if (ref_render_speed(w, &cam, &o, n, spp, &refs[nr], &err) != SG_OK) {
                status = fail("sg_ref_render: %s", err.message);
                goto next;
            }
            printf("  sg_ref_render %dx%d, %d spp: %.3f s, %.0f paths/s (centred curve at %d spp: %.0f paths/s)\n",
                   o.frame_size, o.frame_size, spp, refs[nr].seconds, refs[nr].paths_s, o.max_spp,
                   refs[nr - 1].paths_s);
            nr++;
        }
        print_bake_head();
        {
            /* Photon counts: the sweep (curve sizes; the largest has its
             * own) and the model-size count, ascending; ks: the sweep's,
             * and the model-size ones at that count. */
            const size_t *sweep = n == max_curve ? o.target_photons : o.photons;
            int nsweep = !curve ? 0 : n == max_curve ? o.n_target_photons : o.n_photons;
            size_t counts[MAX_LIST + 2];
            int ncounts = 0;
            for (int i = 0; i < nsweep; i++)
                if (!in_list(counts, ncounts, sweep[i]))
                    counts[ncounts++] = sweep[i];
            if (!in_list(counts, ncounts, o.size_photons))
                counts[ncounts++] = o.size_photons;
            if (curve && o.n_direct > 0 && !in_list(counts, ncounts, o.direct_photons))
                counts[ncounts++] = o.direct_photons;
            sort_sizes(counts, ncounts);
            for (int pi = 0; pi < ncounts && status == 0; pi++) {
                /* (k, direct) pairs: the sweep's and the model-size ones,
                 * without repeats; then per map kind (indirect-only for
                 * direct > 0, everything for -1). */
                combo cs[4 * MAX_LIST * MAX_LIST];
                int ncs = 0;
                static const int carry = -1;
                if (in_list(sweep, nsweep, counts[pi]))
                    add_combos(cs, &ncs, o.ks, o.n_ks, &carry, 1);
                if (curve && counts[pi] == o.direct_photons)
                    add_combos(cs, &ncs, o.ks, 1, o.direct, o.n_direct);
                if (counts[pi] == o.size_photons) {
                    add_combos(cs, &ncs, o.size_ks, o.n_size_ks, &carry, 1);
                    add_combos(cs, &ncs, o.size_ks, 1, o.size_direct, o.n_size_direct);
                }
                if (nb + ncs * o.n_spacings > MAX_BAKES) {
                    status = fail("too many bakes (at most %d)", MAX_BAKES);
                    break;
                }
                for (int kind = 0; kind < 2 && status == 0; kind++) {
                    size_t ks[4 * MAX_LIST * MAX_LIST];
                    int ds[4 * MAX_LIST * MAX_LIST], nks = 0;
                    for (int i = 0; i < ncs; i++)
                        if ((cs[i].direct > 0) == (kind == 0)) {
                            ks[nks] = cs[i].k;
                            ds[nks++] = cs[i].direct;
                        }
                    if (measure_bakes(w, &cam, scene_hash, &o, n, counts[pi], ks, ds, nks, curve, &ref, exposure,
                                      bakes, &nb, &err) != SG_OK)
                        status = fail("%zu points, %zu photons: %s", n, counts[pi], err.message);
                }
            }
        }
        if (curve && status == 0) {
            compute_target(&o, n, bakes, nb, refs, nr, &targets[nt]);
            if (retime_target(w, &cam, &o, &targets[nt], rr, &err) != SG_OK)
                status = fail("%zu points, retiming the target's bake: %s", n, err.message);
            print_target(&o, &targets[nt]);
            nt++;
        }
    next:
        sg_ref_result_free(&ref);
        sg_world_destroy(w);
        sg_scene_file_free(&sf);
    }

    bench_load_avg(rp_load[1], sizeof rp_load[1]);
    double total_s = omp_get_wtime() - t_start;
    printf("\nsummary (%s, %d threads; total %.0f s; load average at start %s, at end %s)\n", machine, o.threads,
           total_s, rp_load[0], rp_load[1]);
    printf("bake cost (frameB_s: one %dx%d lookup frame; frame_s, wall_s = bake + frame, relMSE: %dx%d)\n",
           o.frame_size, o.frame_size, o.size, o.size);
    print_bake_head();
    for (int i = 0; i < nb; i++)
        print_bake_row(&bakes[i]);
    if (nr > 0) {
        printf("reference renderer (centred curve at %dx%d; ref_render: sg_ref_render speed at %dx%d)\n", o.size,
               o.size, o.frame_size, o.frame_size);
        printf("  %8s %10s %5s %5s %9s %10s %10s %10s\n", "points", "kind", "spp", "size", "s", "relMSE",
               "predicted", "paths/s");
        for (int i = 0; i < nr; i++)
            printf("  %8zu %10s %5d %5d %9.3f %10.5f %10.5f %10.0f\n", refs[i].points, refs[i].kind, refs[i].spp,
                   refs[i].width, refs[i].seconds, refs[i].rel_mse, refs[i].predicted, refs[i].paths_s);
    }
    for (int i = 0; i < nt; i++)
        print_target(&o, &targets[i]);

    report rp = {.o = &o, .machine = machine, .env_used = env_used, .nproc = nproc, .scale = setup.scale,
                 .translate = setup.translate, .worlds = worlds, .n_worlds = nw, .bakes = bakes, .n_bakes = nb,
                 .refs = refs, .n_refs = nr, .centres = centres, .n_centres = nc, .targets = targets,
                 .n_targets = nt, .total_s = total_s};
    if (status == 0 && !bench_make_dirs(o.out_dir))
        status = fail("cannot create %s: %s", o.out_dir, strerror(errno));
    if (status == 0) {
        char path[4200];
        snprintf(path, sizeof path, "%s/bench_bake.csv", o.out_dir);
        if (bench_write_file(path, write_csv, &rp) == 0)
            printf("bench_bake: wrote %s\n", path);
        else
            status = 1;
        snprintf(path, sizeof path, "%s/bench_bake.md", o.out_dir);
        if (bench_write_file(path, write_md, &rp) == 0)
            printf("bench_bake: wrote %s\n", path);
        else
            status = 1;
    }
    return status;
}
