/* bench_view_split — where a viewer frame's time goes, and the viewer's
 * renderer against the bake's, side by side (frames alternate, so both
 * see the same machine load).
 *
 * usage: bench_view_split SCENE.json PATH.txt BAKE.sgbake [WIDTH HEIGHT [STRIDE [THREADS]]]
 *
 * The world comes from SCENE.json (e.g. out/bench_view/dragon_1000000_diffuse.json
 * written by bench_view); BAKE.sgbake is loaded when it matches, else baked
 * as bench_view bakes (500000 photons, direct_samples 8) and saved there.
 * Every STRIDE-th key of PATH.txt (a campath file) is rendered by each
 * phase in turn:
 *   isect    one primary ray per pixel, sg_world_intersect only;
 *   weights  the same plus sg_scene_hit_sites (the bake lookup's gather);
 *   weights_ref  the same with sg_scene_hit_sites_reference (scalar);
 *   bake     sg_bake_render (the frame as bake.c makes it);
 *   view     sg_view_render (view/render.h; the viewer's frame);
 *   display  sg_display_apply of the frame to RGBA8;
 * and the mean per phase is printed (wall time, and the process's CPU
 * time over all threads, which other processes' load does not inflate),
 * with the load average before and after, and the largest difference between the bake's and the view's
 * images (relative, per channel).
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bench_common.h"
#include "bake/bake.h"
#include "bake/bake_io.h"
#include "display/ocio.h"
#include "io/scene_file.h"
#include "render/camera.h"
#include "render/world.h"
#include "view/campath.h"
#include "view/render.h"

enum { TILE = 16, LOOKUP = 32 };

/* CPU seconds of this process (all threads): unlike wall time, it does
 * not count the time other processes hold the cores, so A/B ratios stay
 * meaningful on a loaded machine. */
/* One primary ray per pixel in the bake's tile order; with_weights adds
 * the lookup's gather. Returns seconds; *sink keeps the work alive. */
static double primary_pass(const sg_world *w, const sg_camera *cam, int width, int height, int threads,
                           int with_weights, double *sink, sg_ray_stats *stats)
{
    sg_ray_stats st = {0};
    const bench_tiles tiles = bench_tiles_of(width, height, TILE);
    double acc = 0.0;
    double t0 = omp_get_wtime();
#pragma omp parallel num_threads(threads) reduction(+ : acc)
    {
    sg_ray_stats mine = {0};
#pragma omp for schedule(dynamic, 1)
    for (int t = 0; t < tiles.count; ++t) {
        const bench_rect b = bench_tile(&tiles, t);
        for (int y = b.y0; y < b.y1; ++y)
            for (int x = b.x0; x < b.x1; ++x) {
                sg_ray ray = sg_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, width, height);
                sg_world_hit h;
                if (!sg_world_intersect(w, &ray, &h, stats ? &mine : NULL))
                    continue;
                acc += h.hit.t;
                if (with_weights) {
                    uint32_t ids[LOOKUP];
                    float wts[LOOKUP];
                    int n = with_weights == 2
                                ? sg_scene_hit_sites_reference(sg_world_scene(w, h.model), &h.hit, ids, wts, LOOKUP)
                                : sg_scene_hit_sites(sg_world_scene(w, h.model), &h.hit, ids, wts, LOOKUP);
                    acc += wts[n - 1];
                }
            }
    }
#pragma omp critical
    sg_ray_stats_add(&st, &mine);
    }
    if (stats)
        sg_ray_stats_add(stats, &st);
    double s = omp_get_wtime() - t0;
    *sink += acc;
    return s;
}

int main(int argc, char **argv)
{
    if (argc < 4) {
        fprintf(stderr, "usage: %s SCENE.json PATH.txt BAKE.sgbake [WIDTH HEIGHT [STRIDE [THREADS]]]\n", argv[0]);
        return 2;
    }
    int width = argc > 5 ? atoi(argv[4]) : 512, height = argc > 5 ? atoi(argv[5]) : 512;
    int stride = argc > 6 ? atoi(argv[6]) : 1;
    int threads = argc > 7 ? atoi(argv[7]) : omp_get_max_threads();
    /* SG_SPLIT_ONLY_VIEW=1: the viewer's frame alone (for profilers). */
    const char *only_env = getenv("SG_SPLIT_ONLY_VIEW");
    int only_view = only_env && *only_env == '1';
    /* SG_SPLIT_REPEAT=R: each view frame rendered R times; the best of the
     * R (least wall, least CPU) is printed too, which other processes on
     * shared cores inflate far less than the mean. */
    const char *repeat_env = getenv("SG_SPLIT_REPEAT");
    int repeat = repeat_env ? atoi(repeat_env) : 1;
    if (repeat < 1)
        repeat = 1;
    double best_wall = 0.0, best_cpu = 0.0;
    /* SG_SPLIT_DUMP=FILE: the view frames' RGB floats written one after
     * the other to FILE (width x height x 3 each, rows top first), so two
     * builds' frames can be compared value by value (bench/frame_diff.py). */
    const char *dump_path = getenv("SG_SPLIT_DUMP");
    FILE *dump = dump_path && *dump_path ? fopen(dump_path, "wb") : NULL;
    if (dump_path && *dump_path && !dump)
        return fprintf(stderr, "%s: cannot open for writing\n", dump_path), 1;
    if (width < 1 || height < 1 || stride < 1 || threads < 1)
        return fprintf(stderr, "bad size, stride or threads\n"), 2;
    sg_error err;
    sg_scene_file sf = {0};
    sg_world *w = NULL;
    sg_bake *b = NULL;
    sg_campath path = {0};
    sg_display *disp = NULL;
    if (sg_scene_file_load(argv[1], &sf, &err) != SG_OK || sg_campath_read(argv[2], &path, &err) != SG_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    double t0 = omp_get_wtime();
    if (sg_world_create(&sf, &w, &err) != SG_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    printf("world %.1f s\n", omp_get_wtime() - t0);
    uint64_t key = sg_scene_file_hash(&sf, SG_SCENE_HASH_BAKE);
    if (sg_bake_load(argv[3], w, key, &b, &err) != SG_OK) {
        printf("baking (%s)\n", err.message);
        sg_bake_desc bd = {.photons = {.count = 500000}, .direct_samples = 8};
        if (sg_bake_create(w, &bd, &b, &err) != SG_OK || sg_bake_save(b, argv[3], key, &err) != SG_OK) {
            fprintf(stderr, "%s\n", err.message);
            return 1;
        }
    }
    sg_display_desc dd = {.threads = threads};
    if (sg_display_create(&dd, &disp, &err) != SG_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    uint8_t *rgba = malloc((size_t)width * (size_t)height * 4);
    enum { ISECT, WEIGHTS, WEIGHTS_REF, BAKE, VIEW, DISPLAY, PHASES };
    static const char *const name[PHASES] = {"isect", "weights", "weights_ref", "bake", "view", "display"};
    double sum[PHASES] = {0}, cpu[PHASES] = {0}, sink = 0.0, maxrel = 0.0, c0;
    size_t differ = 0;
    uint64_t view_hash = 0xcbf29ce484222325ull; /* FNV-1a of the view frames' bits: compares builds */
    sg_ray_stats rs = {0};
    int frames = 0;
    double l0 = bench_load1();
    for (size_t k = 0; k < path.count; k += (size_t)stride) {
        sg_camera cam;
        if (sg_campath_camera(&path.keys[k], (float)width / (float)height, &cam, &err) != SG_OK)
            return fprintf(stderr, "%s\n", err.message), 1;
        sg_bake_frame_desc fd = {.camera = cam, .width = width, .height = height, .threads = threads};
        sg_image ib = {0}, iv = {0};
        double s;
        /* Alternate which renderer goes first, so neither always gets the warmer cache. */
        for (int pass = 0; pass < 2; ++pass) {
            c0 = bench_cpu_seconds();
            if ((pass == 0) == (k / (size_t)stride % 2 == 0)) {
                if (only_view)
                    continue;
                if (sg_bake_render(b, w, &fd, &ib, &s, &err) != SG_OK)
                    return fprintf(stderr, "%s\n", err.message), 1;
                sum[BAKE] += s;
                cpu[BAKE] += bench_cpu_seconds() - c0;
            } else {
                double bw = INFINITY, bc = INFINITY;
                for (int rep = 0; rep < repeat; ++rep) {
                    if (rep)
                        sg_image_free(&iv);
                    c0 = bench_cpu_seconds();
                    if (sg_view_render(b, w, &fd, &iv, &s, &err) != SG_OK)
                        return fprintf(stderr, "%s\n", err.message), 1;
                    double c = bench_cpu_seconds() - c0;
                    sum[VIEW] += s / repeat;
                    cpu[VIEW] += c / repeat;
                    bw = s < bw ? s : bw;
                    bc = c < bc ? c : bc;
                }
                best_wall += bw;
                best_cpu += bc;
            }
        }
        for (int ph = ISECT; ph <= WEIGHTS_REF && !only_view; ++ph) {
            c0 = bench_cpu_seconds();
            sum[ph] += primary_pass(w, &cam, width, height, threads, ph - ISECT, &sink, NULL);
            cpu[ph] += bench_cpu_seconds() - c0;
        }
        if (!only_view)
            primary_pass(w, &cam, width, height, threads, 0, &sink, &rs);
        t0 = omp_get_wtime();
        c0 = bench_cpu_seconds();
        if (sg_display_apply(disp, &iv, rgba, &err) != SG_OK)
            return fprintf(stderr, "%s\n", err.message), 1;
        sum[DISPLAY] += omp_get_wtime() - t0;
        cpu[DISPLAY] += bench_cpu_seconds() - c0;
        for (size_t i = 0; !only_view && i < (size_t)width * (size_t)height * 3; ++i) {
            double a = ib.data[i], v = iv.data[i];
            double rel = fabs(a - v) / fmax(fabs(a), 1e-6);
            if (a != v)
                ++differ;
            if (!(rel <= maxrel))
                maxrel = rel;
        }
        for (size_t i = 0; i < (size_t)width * (size_t)height * 3; ++i) {
            uint32_t bits;
            memcpy(&bits, &iv.data[i], sizeof bits);
            view_hash = (view_hash ^ bits) * 0x100000001b3ull;
        }
        if (dump && fwrite(iv.data, sizeof(float) * 3, (size_t)width * (size_t)height, dump) !=
                        (size_t)width * (size_t)height)
            return fprintf(stderr, "%s: write failed\n", dump_path), 1;
        sg_image_free(&ib);
        sg_image_free(&iv);
        ++frames;
    }
    printf("%dx%d, %d frames (every %d-th key), %d threads, load %.2f -> %.2f\n", width, height, frames, stride,
           threads, l0, bench_load1());
    for (int p = 0; p < PHASES; ++p)
        printf("  %-11s %8.2f ms/frame wall, %8.2f ms/frame CPU (all threads)\n", name[p], 1e3 * sum[p] / frames,
               1e3 * cpu[p] / frames);
    if (repeat > 1)
        printf("  view best of %d: %.2f ms/frame wall, %.2f ms/frame CPU (all threads)\n", repeat,
               1e3 * best_wall / frames, 1e3 * best_cpu / frames);
    printf("  weights - isect = %.2f ms wall, %.2f ms CPU (scalar reference: %.2f, %.2f); bake/view = %.3f wall, "
           "%.3f CPU\n",
           1e3 * (sum[WEIGHTS] - sum[ISECT]) / frames, 1e3 * (cpu[WEIGHTS] - cpu[ISECT]) / frames,
           1e3 * (sum[WEIGHTS_REF] - sum[ISECT]) / frames, 1e3 * (cpu[WEIGHTS_REF] - cpu[ISECT]) / frames,
           sum[BAKE] / sum[VIEW], cpu[BAKE] / cpu[VIEW]);
    printf("  view vs bake: %zu channel values differ, max relative difference %.3g (sink %g)\n", differ, maxrel,
           sink);
    printf("  view frames' hash %016llx\n", (unsigned long long)view_hash);
    double nr = (double)rs.rays;
    printf("  per primary ray: %.1f nodes, %.2f leaves, %.2f leaf tests, %.1f splats; %.1f%% hit\n", rs.nodes / nr,
           rs.leaves / nr, rs.isects / nr, rs.splats / nr, 100.0 * rs.hits / nr);
    if (dump && fclose(dump) != 0)
        return fprintf(stderr, "%s: write failed\n", dump_path), 1;
    free(rgba);
    sg_display_destroy(disp);
    sg_bake_destroy(b);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
    sg_campath_free(&path);
    return 0;
}
