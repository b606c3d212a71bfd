/* bench_iso — the Implicit Surface Octree (surface/iso.h) against the MLS
 * scene (surface/scene.h) it samples: same points, same rays.
 *
 * Points come from a scanned mesh through sg_model_points_load
 * (area-weighted samples, kNN radii). Both surfaces are built from them
 * (wall and CPU seconds, memory), then the same primary camera rays are
 * cast through each for a whole view and a close-up (bench_trace's
 * framing: the dragon from front-left-above, and its head), OpenMP over
 * pixels, best of --frames. Printed side by side: build time, memory,
 * bytes per leaf and per point, leaves, depth, Mrays/s (wall; CPU seconds
 * beside it), per-ray counters, the ISO/MLS speed ratio, the fraction of
 * rays whose hit-or-miss agrees, and the median |Δt| of common hits in
 * units of the ISO leaf's edge. One CSV row per view is appended to
 * --csv (default out/bench_iso/bench_iso.csv).
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "bench_common.h"
#include "points/model_points.h"
#include "render/camera.h"
#include "surface/iso.h"
#include "surface/scene.h"

#define DEFAULT_MESH SG_SHARED_DATA_DIR "/meshes/stanford_dragon/dragon_vrip.ply"
#define FOV_DEG 40.0f
static const float whole_view_dir[3] = {0.6f, -0.35f, -1.0f};        /* as bench_trace */
static const float closeup_box[6] = {0.0f, 0.55f, 0.30f, 0.30f, 1.0f, 1.0f}; /* the dragon's head */

static const char usage[] =
    "usage: bench_iso [options]\n"
    "Build time, memory and ray-casting speed of the implicit surface octree\n"
    "against the MLS scene on the same points and rays.\n"
    "  --mesh PATH      mesh to sample (default the Stanford dragon)\n"
    "  --points N       points sampled (default 1000000)\n"
    "  --quick          125000 points, 256x256 rays, 1 frame\n"
    "  --size N         image side in rays (default 512)\n"
    "  --frames N       timed frames per surface and view, best kept (default 3)\n"
    "  --threads N      OpenMP threads (default 2)\n"
    "  --depth N        ISO max_depth (default 16)\n"
    "  --tolerance F    ISO tolerance (default 0.05)\n"
    "  --leaf-radii F   ISO leaf_radii (default 2)\n"
    "  --iso-only       no MLS scene: only the ISO's build and casts\n"
    "  --lod LIST       level-of-detail thresholds (pixels) to time against full\n"
    "                   detail, comma-separated (default 0.5,1,2,4; none: \"\")\n"
    "  --csv PATH       append rows (default out/bench_iso/bench_iso.csv)\n"
    "The ISO casts three times per view: one ray at a time (sg_iso_intersect),\n"
    "as 2x2 quads of pixels (sg_iso_intersect4) and as 4x4 blocks\n"
    "(sg_iso_intersect16, the viewer's path); all give the same hits, and the\n"
    "printed hit checksum (FNV-1a over each pixel's hit flag and t) lets two\n"
    "builds of the code be compared for identical results.\n";

typedef struct frame {
    double wall, cpu;     /* best frame                               */
    sg_ray_stats stats;   /* summed over one frame                    */
} frame;

/* Casts every pixel's ray through the ISO (iso != NULL) or the scene;
 * keeps hit flags and t of the last frame. quads: the ISO's rays as 2x2
 * quads of pixels through sg_iso_intersect4 (2; size even) or 4x4 blocks
 * through sg_iso_intersect16 (4, the viewer's path; size a multiple of 4);
 * 0: one at a time. */
static frame cast(const sg_scene *scene, const sg_iso *iso, const sg_camera *cam, int size, int threads, int frames,
                  int quads, uint8_t *hit, float *t, uint32_t *leaf)
{
    frame best = {.wall = INFINITY};
    int n = size * size;
    for (int f = 0; f < frames; ++f) {
        sg_ray_stats total = {0};
        double w0 = omp_get_wtime(), c0 = bench_cpu_seconds();
#pragma omp parallel num_threads(threads)
        {
            sg_ray_stats st = {0};
            if (quads) {
                /* side x side blocks, row-major as the viewer's 4 x 4 */
                int side = quads == 4 ? 4 : 2, per = size / side;
#pragma omp for schedule(dynamic, 16)
                for (int q = 0; q < per * per; ++q) {
                    int px[16], py[16], nr = side * side;
                    sg_ray r[16];
                    sg_hit h[16];
                    for (int k = 0; k < nr; ++k) {
                        px[k] = side * (q % per) + k % side;
                        py[k] = side * (q / per) + k / side;
                        r[k] = sg_camera_ray(cam, (float)px[k] + 0.5f, (float)py[k] + 0.5f, size, size);
                    }
                    unsigned got = side == 4 ? sg_iso_intersect16(iso, r, 0xFFFFu, h, &st)
                                             : sg_iso_intersect4(iso, r, 15u, h, &st);
                    for (int k = 0; k < nr; ++k) {
                        int i = py[k] * size + px[k], g = (int)(got >> k & 1u);
                        hit[i] = (uint8_t)g;
                        t[i] = g ? h[k].t : 0.0f;
                        if (leaf)
                            leaf[i] = g ? h[k].leaf : 0;
                    }
                }
            } else {
#pragma omp for schedule(dynamic, 256)
                for (int i = 0; i < n; ++i) {
                    sg_ray r = sg_camera_ray(cam, (float)(i % size) + 0.5f, (float)(i / size) + 0.5f, size, size);
                    sg_hit h;
                    int got = iso ? sg_iso_intersect(iso, &r, &h, &st) : sg_scene_intersect(scene, &r, &h, &st);
                    hit[i] = (uint8_t)got;
                    t[i] = got ? h.t : 0.0f;
                    if (leaf)
                        leaf[i] = got ? h.leaf : 0;
                }
            }
#pragma omp critical
            sg_ray_stats_add(&total, &st);
        }
        double wall = omp_get_wtime() - w0, cpu = bench_cpu_seconds() - c0;
        if (wall < best.wall) {
            best.wall = wall;
            best.cpu = cpu;
            best.stats = total;
        }
    }
    return best;
}

/* Level of detail against full detail (the blocks' frame with lod 0: hit
 * flags h0, distances t0), one line per threshold of list: CPU s per frame,
 * node steps and leaves per ray, pixels whose hit-or-miss differs, and
 * the mean and largest |dt| / t of common hits (the hit moves by at most
 * sqrt(3) cell edges, a cell below lod footprints: |dt| / t <= sqrt(3) x
 * lod x the pixel angle). The ISO is left at its default threshold. */
static void lod_sweep(sg_iso *iso, const sg_camera *cam, int size, int threads, int frames, const char *list,
                      double cpu0, sg_ray_stats st0, const uint8_t *h0, const float *t0)
{
    if (!list || !*list)
        return;
    int n = size * size;
    uint8_t *h = malloc((size_t)n);
    float *t = malloc((size_t)n * sizeof *t);
    if (!h || !t) {
        free(h);
        free(t);
        return;
    }
    double r0 = st0.rays ? (double)st0.rays : 1.0;
    printf("  level of detail (4x4 blocks; lod 0 = full detail):\n");
    printf("  %8s %10s %8s %10s %10s %10s %12s %12s\n", "lod px", "CPU s", "speedup", "nodes/ray",
           "leaves/ray", "hit/miss", "mean dt/t", "max dt/t");
    printf("  %8s %10.4f %8.2f %10.2f %10.3f %10s %12s %12s\n", "0", cpu0, 1.0, (double)st0.nodes / r0,
           (double)st0.leaves / r0, "-", "-", "-");
    for (const char *c = list; *c;) {
        char *end;
        float lod = strtof(c, &end);
        if (end == c || !(lod >= 0.0f))
            break;
        sg_iso_set_lod(iso, lod);
        frame fl = cast(NULL, iso, cam, size, threads, frames, 4, h, t, NULL);
        int differ = 0, both = 0;
        double sum = 0.0, worst = 0.0;
        for (int i = 0; i < n; ++i) {
            differ += h[i] != h0[i];
            if (h[i] && h0[i]) {
                double d = fabs((double)t[i] - (double)t0[i]) / (double)t0[i];
                sum += d;
                worst = d > worst ? d : worst;
                both++;
            }
        }
        double rl = fl.stats.rays ? (double)fl.stats.rays : 1.0;
        printf("  %8g %10.4f %8.2f %10.2f %10.3f %10d %12.2e %12.2e\n", (double)lod, fl.cpu, cpu0 / fl.cpu,
               (double)fl.stats.nodes / rl, (double)fl.stats.leaves / rl, differ, both ? sum / both : 0.0, worst);
        c = *end == ',' ? end + 1 : end;
    }
    sg_iso_set_lod(iso, SG_ISO_LOD_DEFAULT);
    free(h);
    free(t);
}

/* FNV-1a over each pixel's hit flag and t bits. */
static uint64_t hit_checksum(const uint8_t *hit, const float *t, int n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (int i = 0; i < n; ++i) {
        uint32_t bits;
        memcpy(&bits, &t[i], sizeof bits);
        uint64_t v = (uint64_t)hit[i] << 32 | bits;
        for (int b = 0; b < 5; ++b) {
            h ^= (v >> (8 * b)) & 0xFFu;
            h *= 0x100000001b3ull;
        }
    }
    return h;
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    const char *mesh = DEFAULT_MESH, *csv = "out/bench_iso/bench_iso.csv";
    size_t points = 1000000;
    int size = 512, frames = 3, threads = 2, iso_only = 0;
    const char *lod_list = "0.5,1,2,4";
    sg_iso_desc idesc = {0};
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--quick") == 0) {
            points = 125000;
            size = 256;
            frames = 1;
        } else if (strcmp(a, "--iso-only") == 0) {
            iso_only = 1;
        } else if (strcmp(a, "--help") == 0) {
            fputs(usage, stdout);
            return 0;
        } else if (!v) {
            return bench_fail("bench_iso", "%s: missing value or unknown option\n%s", a, usage);
        } else {
            ++i;
            if (strcmp(a, "--mesh") == 0) mesh = v;
            else if (strcmp(a, "--points") == 0) points = strtoull(v, NULL, 10);
            else if (strcmp(a, "--size") == 0) size = atoi(v);
            else if (strcmp(a, "--frames") == 0) frames = atoi(v);
            else if (strcmp(a, "--threads") == 0) threads = atoi(v);
            else if (strcmp(a, "--depth") == 0) idesc.max_depth = atoi(v);
            else if (strcmp(a, "--tolerance") == 0) idesc.tolerance = strtof(v, NULL);
            else if (strcmp(a, "--leaf-radii") == 0) idesc.leaf_radii = strtof(v, NULL);
            else if (strcmp(a, "--csv") == 0) csv = v;
            else if (strcmp(a, "--lod") == 0) lod_list = v;
            else return bench_fail("bench_iso", "unknown option %s\n%s", a, usage);
        }
    }
    if (points == 0 || size < 4 || size % 4 || frames < 1 || threads < 1)
        return bench_fail("bench_iso", "--points, --frames and --threads must be positive, --size a multiple of 4");
    idesc.threads = threads;

    char machine[256], command[1024] = "";
    bench_cpu_model(machine, sizeof machine);
    for (int i = 0; i < argc; ++i) {
        strncat(command, argv[i], sizeof command - strlen(command) - 2);
        strncat(command, " ", sizeof command - strlen(command) - 1);
    }
    printf("bench_iso: machine %s, %d threads\ncommand: %s\n", machine, threads, command);

    sg_error err = {0};
    sg_pointset ps = {0};
    sg_model_points_desc md = {.points = points};
    double t0 = omp_get_wtime();
    if (sg_model_points_load(mesh, &md, &ps, &err) != SG_OK)
        return bench_fail("bench_iso", "%s", err.message);
    printf("points: %zu from %s (%.2f s)\n", ps.count, mesh, omp_get_wtime() - t0);

    /* builds */
    sg_scene_desc sd = {.model = SG_SURFACE_MLS, .threads = threads};
    sg_scene *scene = NULL;
    double w0 = omp_get_wtime(), c0 = bench_cpu_seconds();
    if (!iso_only && sg_scene_create(&sd, &ps, &scene, &err) != SG_OK)
        return bench_fail("bench_iso", "mls: %s", err.message);
    double mls_wall = omp_get_wtime() - w0, mls_cpu = bench_cpu_seconds() - c0;
    sg_iso *iso = NULL;
    w0 = omp_get_wtime();
    c0 = bench_cpu_seconds();
    if (sg_iso_create(&idesc, &ps, &iso, &err) != SG_OK)
        return bench_fail("bench_iso", "iso: %s", err.message);
    double iso_wall = omp_get_wtime() - w0, iso_cpu = bench_cpu_seconds() - c0;
    sg_scene_info si = {0};
    sg_iso_info ii;
    if (scene)
        sg_scene_get_info(scene, &si);
    sg_iso_get_info(iso, &ii);
    printf("\n%-28s %14s %14s\n", "", "MLS kd-tree", "ISO");
    printf("%-28s %14.2f %14.2f\n", "build wall s", mls_wall, iso_wall);
    printf("%-28s %14.2f %14.2f\n", "build CPU s", mls_cpu, iso_cpu);
    printf("%-28s %14.1f %14.1f\n", "memory MB", (double)si.memory_bytes / 1e6, (double)ii.memory_bytes / 1e6);
    printf("%-28s %14zu %14zu\n", "leaves", si.leaf_count, ii.leaf_count);
    printf("%-28s %14.1f %14.1f\n", "bytes per leaf",
           si.leaf_count ? (double)si.memory_bytes / (double)si.leaf_count : 0.0, ii.bytes_per_leaf);
    printf("%-28s %14.1f %14.1f\n", "bytes per point", (double)si.memory_bytes / (double)ps.count,
           ii.bytes_per_point);
    printf("%-28s %14d %14d\n", "depth", si.depth, ii.depth);
    printf("%-28s %14s %14zu / %zu\n", "ISO inner nodes / corners", "", ii.node_count, ii.corner_count);

    sg_aabb b = sg_pointset_bounds(&ps);
    sg_camera cams[2];
    sg_vec3 dir = sg_v3(whole_view_dir[0], whole_view_dir[1], whole_view_dir[2]), up = sg_v3(0, 1, 0);
    sg_vec3 ext = sg_v3_sub(b.hi, b.lo);
    sg_aabb part = {sg_v3_add(b.lo, sg_v3_mul(ext, sg_v3(closeup_box[0], closeup_box[1], closeup_box[2]))),
                    sg_v3_add(b.lo, sg_v3_mul(ext, sg_v3(closeup_box[3], closeup_box[4], closeup_box[5])))};
    if (sg_camera_frame(b, dir, up, FOV_DEG, 1.0f, 0.85f, &cams[0], &err) != SG_OK ||
        sg_camera_frame(part, dir, up, FOV_DEG, 1.0f, 0.8f, &cams[1], &err) != SG_OK)
        return bench_fail("bench_iso", "camera: %s", err.message);

    int n = size * size;
    uint8_t *ha = calloc((size_t)n, 1), *hb = malloc((size_t)n), *hq = malloc((size_t)n);
    float *ta = calloc((size_t)n, sizeof *ta), *tb = malloc((size_t)n * sizeof *tb),
          *tq = malloc((size_t)n * sizeof *tq), *dt = malloc((size_t)n * sizeof *dt);
    uint32_t *lb = malloc((size_t)n * sizeof *lb);
    sg_aabb *boxes = malloc((ii.leaf_count ? ii.leaf_count : 1) * sizeof *boxes);
    if (!ha || !hb || !hq || !ta || !tb || !tq || !dt || !lb || !boxes)
        return bench_fail("bench_iso", "out of memory for %d rays", n);
    sg_iso_leaf_boxes(iso, boxes);

    bench_make_dirs("out/bench_iso");
    struct stat sb;
    int fresh = stat(csv, &sb) != 0;
    FILE *f = fopen(csv, "a");
    if (!f)
        return bench_fail("bench_iso", "%s: cannot open for appending", csv);
    if (fresh)
        fprintf(f, "machine,command,points,threads,view,rays,mls_build_wall_s,mls_build_cpu_s,iso_build_wall_s,"
                   "iso_build_cpu_s,mls_bytes,iso_bytes,iso_leaves,iso_corners,iso_nodes,iso_bytes_per_leaf,"
                   "iso_bytes_per_point,iso_depth,mls_mrays_s,iso_mrays_s,mls_cpu_s,iso_cpu_s,speed_ratio,"
                   "agree,median_dt_over_leaf,iso_nodes_per_ray,iso_leaves_per_ray,iso_roots_per_ray,iso_quads_cpu_s\n");
    static const char *const names[2] = {"whole", "closeup"};
    for (int v = 0; v < 2; ++v) {
        frame fm = {0};
        if (scene)
            fm = cast(scene, NULL, &cams[v], size, threads, frames, 0, ha, ta, NULL);
        frame fi = cast(NULL, iso, &cams[v], size, threads, frames, 0, hb, tb, lb);
        frame fq = cast(NULL, iso, &cams[v], size, threads, frames, 2, hq, tq, NULL);
        uint64_t sum_single = hit_checksum(hb, tb, n), sum_quads = hit_checksum(hq, tq, n);
        frame fx = cast(NULL, iso, &cams[v], size, threads, frames, 4, hq, tq, NULL);
        uint64_t sum_blocks = hit_checksum(hq, tq, n);
        sg_iso_set_lod(iso, 0.0f);
        frame f0 = cast(NULL, iso, &cams[v], size, threads, frames, 4, hq, tq, NULL);
        sg_iso_set_lod(iso, SG_ISO_LOD_DEFAULT);
        int same = 0, both = 0;
        for (int i = 0; i < n; ++i) {
            same += ha[i] == hb[i];
            if (ha[i] && hb[i])
                dt[both++] = fabsf(ta[i] - tb[i]) / (boxes[lb[i]].hi.x - boxes[lb[i]].lo.x);
        }
        qsort(dt, (size_t)both, sizeof *dt, cmp_float);
        double med = both ? (double)dt[both / 2] : 0.0, agree = (double)same / n;
        double mm = scene ? n / fm.wall / 1e6 : 0.0, mi = n / fi.wall / 1e6;
        double rm = fm.stats.rays ? (double)fm.stats.rays : 1.0, ri = (double)fi.stats.rays;
        printf("\nview %s, %dx%d rays (%d MLS hits, %d ISO hits), best of %d:\n", names[v], size, size,
               (int)fm.stats.hits, (int)fi.stats.hits, frames);
        printf("%-28s %14.2f %14.2f   ISO/MLS %.2f\n", "Mrays/s (wall)", mm, mi, mi / mm);
        printf("%-28s %14.3f %14.3f\n", "CPU s per frame", fm.cpu, fi.cpu);
        printf("%-28s %14s %14.3f   (2x2 quads)\n", "CPU s per frame, quads", "", fq.cpu);
        printf("%-28s %14s %14.3f   (4x4 blocks, the viewer's path)\n", "CPU s per frame, blocks", "", fx.cpu);
        printf("%-28s %14s %014llx  %s %s\n", "ISO hit checksum", "", (unsigned long long)sum_single,
               sum_single == sum_quads ? "(quads: the same)" : "(QUADS DIFFER)",
               sum_single == sum_blocks ? "(blocks: the same)" : "(BLOCKS DIFFER)");
        printf("%-28s %14.1f %14.1f\n", "nodes per ray", (double)fm.stats.nodes / rm, (double)fi.stats.nodes / ri);
        printf("%-28s %14.1f %14.1f\n", "leaves per ray", (double)fm.stats.leaves / rm, (double)fi.stats.leaves / ri);
        printf("%-28s %14.1f %14.1f\n", "leaf tests per ray", (double)fm.stats.isects / rm,
               (double)fi.stats.isects / ri);
        printf("%-28s %14.1f %14.2f\n", "splats / roots per ray", (double)fm.stats.splats / rm,
               (double)fi.stats.splats / ri);
        printf("%-28s %14.4f   median |dt| / leaf edge %.4f (%d common hits)\n", "hit/miss agree", agree, med, both);
        lod_sweep(iso, &cams[v], size, threads, frames, lod_list, f0.cpu, f0.stats, hq, tq);
        fprintf(f,
                "\"%s\",\"%s\",%zu,%d,%s,%d,%.3f,%.3f,%.3f,%.3f,%zu,%zu,%zu,%zu,%zu,%.2f,%.2f,%d,%.3f,%.3f,%.4f,"
                "%.4f,%.3f,%.5f,%.5f,%.2f,%.2f,%.3f,%.4f\n",
                machine, command, ps.count, threads, names[v], n, mls_wall, mls_cpu, iso_wall, iso_cpu,
                si.memory_bytes, ii.memory_bytes, ii.leaf_count, ii.corner_count, ii.node_count, ii.bytes_per_leaf,
                ii.bytes_per_point, ii.depth, mm, mi, fm.cpu, fi.cpu, scene ? mi / mm : 0.0, agree, med,
                (double)fi.stats.nodes / ri, (double)fi.stats.leaves / ri, (double)fi.stats.splats / ri, fq.cpu);
    }
    fclose(f);
    printf("\nappended to %s\n", csv);
    free(ha); free(hb); free(hq); free(ta); free(tb); free(tq); free(dt); free(lb); free(boxes);
    sg_iso_destroy(iso);
    sg_scene_destroy(scene);
    sg_pointset_free(&ps);
    return 0;
}
