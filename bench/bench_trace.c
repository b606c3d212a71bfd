/* bench_trace — ray-casting speed of splatgi's point surfaces against
 * Embree 3 discs on the same splats and the same camera rays.
 *
 * For each model size (points sampled from a scanned mesh with
 * sg_model_points_load: area-weighted samples, kNN radii) and each view
 * (whole model; close-up of a detailed part), it builds and times:
 *   mls  refinements on   (kd_disable = 0)                Wald & Seidel 2005
 *   mls  refinements off  (SG_KD_NO_REFINEMENTS)          ditto, §3.4 off
 *   disk                  (refinements do not apply)      Kashyap 2010 ch. 3
 *   iso                   (the MLS surface in an octree)  Kashyap 2010 ch. 4
 * and renders 512x512 frames with sg_render_frame, SG_SHADE_SIMPLE (one
 * primary ray per pixel, no shadow rays): one warm-up frame, then the best
 * of N. Beside each row it renders the same pixels through Embree's
 * RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT (embree_discs.c) with the same
 * rays, tiles and shading, and reports the throughput ratio and the
 * fraction of pixels where both renderers agree on hit-or-miss.
 *
 * Output: a table on stdout, CSV (--csv) and a markdown table (--md), each
 * written whole to a temporary name and renamed. Programs are thin: the
 * measuring is library calls; this file only times and reports them.
 */
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/cli.h"
#include "bench_common.h"
#include "core/alloc.h"
#include "embree_discs.h"
#include "io/image.h"
#include "io/mesh.h"
#include "render/camera.h"
#include "render/default_scene.h"
#include "render/render.h"
#include "surface/scene.h"

#define DEFAULT_MESH SG_SHARED_DATA_DIR "/meshes/stanford_dragon/dragon_vrip.ply"
#define IMAGE_SIZE 512     /* pixels per side of every frame (the size) */
#define FOV_DEG 40.0f      /* vertical field of view of both views               */
#define MAX_SIZES 16
#define MAX_ROWS (MAX_SIZES * 2 * 4) /* sizes x views x configs */

/* Whole view: the camera sits front-left-above (-x, +y, +z of the centre),
 * looking down at the model; image right is about +x, so the dragon's head
 * (at -x) is on the left and turned towards the camera. */
static const float whole_view_dir[3] = {0.6f, -0.35f, -1.0f};
/* Close-up: the box framed, as fractions of the mesh's bounds (lo + f *
 * extent per axis); the default is the dragon's head: the -x end, the upper
 * part, the front (+z) side, chosen by rendering the views and looking.
 * --closeup-box replaces it for other meshes. */
static const float default_closeup_box[6] = {0.0f, 0.55f, 0.30f, 0.30f, 1.0f, 1.0f};
#define CLOSEUP_MARGIN 0.8f /* < 1: the box's sphere overfills the frame a little */
#define WHOLE_MARGIN 0.85f  /* the bounding sphere is loose around a long model */

static const char usage[] =
    "usage: bench_trace [options]\n"
    "Ray-casting speed of splatgi (MLS with/without kd-tree refinements, disks)\n"
    "against Embree 3 oriented discs on the same splats and rays.\n"
    "  --mesh PATH         scanned mesh to sample (default: the full Stanford dragon,\n"
    "                      " DEFAULT_MESH ")\n"
    "  --sizes A,B,...     point counts (default 2000,32000,125000,1000000)\n"
    "  --quick             sizes 2000,32000 only (smoke test)\n"
    "  --views LIST        whole,closeup (default both)\n"
    "  --closeup-box F6    close-up box as fractions of the bounds:\n"
    "                      x0,y0,z0,x1,y1,z1 (default: the dragon's head)\n"
    "  --frames N          timed frames per row, best reported (default 5)\n"
    "  --threads N         OpenMP threads for builds and frames (default: all)\n"
    "  --csv PATH          write the rows as CSV\n"
    "  --md PATH           write the table as markdown\n"
    "  --png-dir DIR       save the largest size's MLS frames as\n"
    "                      DIR/bench_whole.png and DIR/bench_closeup.png\n"
    "  --help              this text\n";

typedef enum view_kind { VIEW_WHOLE = 0, VIEW_CLOSEUP = 1 } view_kind;
static const char *const view_names[2] = {"whole", "closeup"};

typedef struct config {
    const char *surface;   /* CSV name of the model          */
    const char *refine;    /* "on", "off" or "n/a"           */
    sg_surface_model model;
    uint32_t kd_disable;
} config;

static const config configs[4] = {
    {"mls", "on", SG_SURFACE_MLS, 0},
    {"mls", "off", SG_SURFACE_MLS, SG_KD_NO_REFINEMENTS},
    {"disk", "n/a", SG_SURFACE_DISK, 0},
    {"iso", "n/a", SG_SURFACE_ISO, 0},
};

typedef struct options {
    const char *mesh;
    size_t sizes[MAX_SIZES];
    int size_count;
    int views[2];          /* views[v] != 0: render view v */
    float closeup_box[6];
    int frames;
    int threads;           /* 0 before defaults: all        */
    const char *csv, *md, *png_dir;
} options;

typedef struct row {
    size_t points;
    const char *view, *surface, *refine;
    double build_s, memory_mb, fps, mrays_s, mrays_s_per_core;
    double nodes, leaves, isects, splats, hit_rate; /* per primary ray */
    double embree_build_s, embree_mrays_s, ratio, agreement;
} row;

#define fail(...) bench_fail("bench_trace", __VA_ARGS__) /* bench_common.h */

/* ---- options --------------------------------------------------------- */

static int parse_sizes(const char *s, options *o)
{
    return sg_cli_size_list("--sizes", s, 2, 100000000ull, o->sizes, MAX_SIZES, &o->size_count, NULL) == SG_OK;
}

static int parse_views(const char *s, options *o)
{
    o->views[0] = o->views[1] = 0;
    char buf[64];
    if (strlen(s) >= sizeof buf)
        return 0;
    strcpy(buf, s);
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        if (strcmp(tok, "whole") == 0)
            o->views[VIEW_WHOLE] = 1;
        else if (strcmp(tok, "closeup") == 0)
            o->views[VIEW_CLOSEUP] = 1;
        else
            return 0;
    }
    return o->views[0] || o->views[1];
}

static int parse_box(const char *s, float box[6])
{
    for (int i = 0; i < 6; i++) {
        char *end;
        errno = 0;
        float v = strtof(s, &end);
        if (errno || end == s || !isfinite(v))
            return 0;
        box[i] = v;
        if (i < 5 && *end != ',')
            return 0;
        s = end + (i < 5);
        if (i == 5 && *end)
            return 0;
    }
    return box[0] < box[3] && box[1] < box[4] && box[2] < box[5];
}

/* Returns -1 to continue, else the exit status. */
static int parse_options(int argc, char **argv, options *o)
{
    memset(o, 0, sizeof *o);
    o->mesh = DEFAULT_MESH;
    parse_sizes("2000,32000,125000,1000000", o);
    o->views[VIEW_WHOLE] = o->views[VIEW_CLOSEUP] = 1;
    memcpy(o->closeup_box, default_closeup_box, sizeof o->closeup_box);
    o->frames = 5;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            fputs(usage, stdout);
            return 0;
        } else if (strcmp(a, "--quick") == 0) {
            parse_sizes("2000,32000", o);
            continue;
        }
        if (!v)
            return fail("%s needs a value (see --help)", a);
        i++;
        if (strcmp(a, "--mesh") == 0)
            o->mesh = v;
        else if (strcmp(a, "--sizes") == 0) {
            if (!parse_sizes(v, o))
                return fail("--sizes '%s': want up to %d counts >= 2, comma-separated", v, MAX_SIZES);
        } else if (strcmp(a, "--views") == 0) {
            if (!parse_views(v, o))
                return fail("--views '%s': want whole, closeup or whole,closeup", v);
        } else if (strcmp(a, "--closeup-box") == 0) {
            if (!parse_box(v, o->closeup_box))
                return fail("--closeup-box '%s': want x0,y0,z0,x1,y1,z1 with x0<x1, y0<y1, z0<z1", v);
        } else if (strcmp(a, "--frames") == 0) {
            if (!bench_parse_int(v, 1, 1000, &o->frames))
                return fail("--frames '%s': want 1..1000", v);
        } else if (strcmp(a, "--threads") == 0) {
            if (!bench_parse_int(v, 1, 4096, &o->threads))
                return fail("--threads '%s': want 1..4096", v);
        } else if (strcmp(a, "--csv") == 0)
            o->csv = v;
        else if (strcmp(a, "--md") == 0)
            o->md = v;
        else if (strcmp(a, "--png-dir") == 0)
            o->png_dir = v;
        else
            return fail("unknown option %s (see --help)", a);
    }
    if (o->threads == 0)
        o->threads = omp_get_max_threads();
    return -1;
}

/* ---- machine ---------------------------------------------------------- */


/* ---- cameras ---------------------------------------------------------- */

static sg_status make_cameras(sg_aabb b, const options *o, sg_camera cams[2], sg_error *err)
{
    sg_vec3 up = sg_v3(0, 1, 0);
    sg_vec3 dir = sg_v3(whole_view_dir[0], whole_view_dir[1], whole_view_dir[2]);
    sg_status st = sg_camera_frame(b, dir, up, FOV_DEG, 1.0f, WHOLE_MARGIN, &cams[VIEW_WHOLE], err);
    if (st != SG_OK)
        return st;
    sg_vec3 ext = sg_v3_sub(b.hi, b.lo);
    const float *f = o->closeup_box;
    sg_aabb part = {sg_v3_add(b.lo, sg_v3_mul(ext, sg_v3(f[0], f[1], f[2]))),
                    sg_v3_add(b.lo, sg_v3_mul(ext, sg_v3(f[3], f[4], f[5])))};
    return sg_camera_frame(part, dir, up, FOV_DEG, 1.0f, CLOSEUP_MARGIN, &cams[VIEW_CLOSEUP], err);
}

/* ---- measuring -------------------------------------------------------- */

/* Hit-or-miss of every pixel's primary ray through splatgi (untimed). */
static void splatgi_hit_mask(const sg_scene *s, const sg_camera *cam, int threads, uint8_t *mask)
{
    int n = IMAGE_SIZE * IMAGE_SIZE;
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads)
    for (int i = 0; i < n; i++) {
        int x = i % IMAGE_SIZE, y = i / IMAGE_SIZE;
        sg_ray r = sg_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, IMAGE_SIZE, IMAGE_SIZE);
        sg_hit h;
        mask[i] = (uint8_t)sg_scene_intersect(s, &r, &h, NULL);
    }
}

/* One row: splatgi's and Embree's warm-up and best frames, then the
 * hit-mask agreement. *img receives splatgi's last frame. */
static sg_status measure_row(const sg_scene *s, const embree_discs *e, const sg_camera *cam,
                             const options *o, row *r, sg_image *img, uint8_t *mask_a,
                             uint8_t *mask_b, sg_error *err)
{
    sg_render_desc rd = {.camera = *cam, .width = IMAGE_SIZE, .height = IMAGE_SIZE,
                         .shade = SG_SHADE_SIMPLE, .threads = o->threads};
    sg_render_stats best = {0};
    embree_discs_stats ebest = {0};
    /* Frame 0 warms both up. The two renderers alternate frame by frame so
     * that both see the same machine load (others may share the cores). */
    for (int f = 0; f <= o->frames; f++) {
        sg_render_stats st;
        sg_image_free(img);
        sg_status rc = sg_render_frame(s, &rd, img, &st, err);
        if (rc != SG_OK)
            return rc;
        if (f > 0 && (best.rays == 0 || st.seconds < best.seconds))
            best = st;
        sg_image eimg = {0};
        embree_discs_stats est;
        rc = embree_discs_frame(e, cam, IMAGE_SIZE, IMAGE_SIZE, o->threads, &eimg,
                                f == 0 ? mask_b : NULL, &est, err);
        sg_image_free(&eimg);
        if (rc != SG_OK)
            return rc;
        if (f > 0 && (ebest.rays == 0 || est.seconds < ebest.seconds))
            ebest = est;
    }
    splatgi_hit_mask(s, cam, o->threads, mask_a);
    size_t same = 0, n = (size_t)IMAGE_SIZE * IMAGE_SIZE;
    for (size_t i = 0; i < n; i++)
        same += mask_a[i] == mask_b[i];

    double rays = (double)best.primary_rays;
    const sg_ray_stats *p = &best.primary;
    r->fps = best.seconds > 0.0 ? 1.0 / best.seconds : 0.0;
    r->mrays_s = best.mrays_per_s;
    r->mrays_s_per_core = best.mrays_per_s / o->threads;
    r->nodes = (double)p->nodes / rays;
    r->leaves = (double)p->leaves / rays;
    r->isects = (double)p->isects / rays;
    r->splats = (double)p->splats / rays;
    r->hit_rate = (double)p->hits / rays;
    r->embree_mrays_s = ebest.mrays_per_s;
    r->ratio = ebest.mrays_per_s > 0.0 ? best.mrays_per_s / ebest.mrays_per_s : 0.0;
    r->agreement = (double)same / (double)n;
    return SG_OK;
}

/* ---- reports ---------------------------------------------------------- */

static const char table_head[] =
    "| points | view | surface | refine | build s | MiB | fps | Mrays/s | Mrays/s/core "
    "| nodes | leaves | isects | splats | hit | Embree build s | Embree Mrays/s | splatgi/Embree "
    "| agree |\n"
    "|---:|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";

static void print_row_text(FILE *f, const row *r)
{
    fprintf(f,
            "%8zu %-7s %-4s %-3s %8.2f %7.1f %7.1f %7.3f %7.3f %7.1f %6.2f %6.2f %7.1f %5.3f "
            "| %7.3f %7.2f %6.3f %6.4f\n",
            r->points, r->view, r->surface, r->refine, r->build_s, r->memory_mb, r->fps, r->mrays_s,
            r->mrays_s_per_core, r->nodes, r->leaves, r->isects, r->splats, r->hit_rate,
            r->embree_build_s, r->embree_mrays_s, r->ratio, r->agreement);
}

static void print_head_text(FILE *f)
{
    fprintf(f, "%8s %-7s %-4s %-3s %8s %7s %7s %7s %7s %7s %6s %6s %7s %5s | %7s %7s %6s %6s\n",
            "points", "view", "surf", "ref", "build_s", "MiB", "fps", "Mrays/s", "/core", "nodes",
            "leaves", "isects", "splats", "hit", "E.build", "E.Mr/s", "ratio", "agree");
}


typedef struct report {
    const row *rows;
    int count;
    const char *machine;
    int threads, nproc, omp_max, frames;
    const char *mesh;
} report;

static void write_csv(FILE *f, const void *ctx)
{
    const report *rp = ctx;
    fputs("machine,threads,points,view,surface,refinements,build_s,memory_mb,fps,mrays_s,"
          "mrays_s_per_core,nodes,leaves,isects,splats,hit_rate,embree_build_s,embree_mrays_s,"
          "ratio,agreement\n",
          f);
    for (int i = 0; i < rp->count; i++) {
        const row *r = &rp->rows[i];
        bench_csv_text(f, rp->machine);
        fprintf(f, ",%d,%zu,%s,%s,%s,%.4f,%.2f,%.3f,%.4f,%.4f,%.3f,%.3f,%.3f,%.3f,%.4f,%.4f,%.4f,"
                   "%.4f,%.5f\n",
                rp->threads, r->points, r->view, r->surface, r->refine, r->build_s, r->memory_mb,
                r->fps, r->mrays_s, r->mrays_s_per_core, r->nodes, r->leaves, r->isects, r->splats,
                r->hit_rate, r->embree_build_s, r->embree_mrays_s, r->ratio, r->agreement);
    }
}

static void write_md(FILE *f, const void *ctx)
{
    const report *rp = ctx;
    fprintf(f, "# Ray-casting speed: splatgi vs Embree 3 discs\n\n");
    fprintf(f, "Written by `scripts/bench-trace.sh` (bench/bench_trace.c); see bench/README.md.\n\n");
    fprintf(f, "Machine: %s, nproc %d, omp_get_max_threads %d; %d threads used. Embree %s.\n",
            rp->machine, rp->nproc, rp->omp_max, rp->threads, embree_discs_version());
    /* The data folder's own path, not this checkout's absolute one. */
    const char *mesh = strstr(rp->mesh, "shared/data/");
    fprintf(f, "Model: %s%s, sampled with sg_model_points_load (area-weighted, kNN radii k = 8).\n",
            mesh ? "../" : "", mesh ? mesh : rp->mesh);
    fprintf(f, "Frames: %dx%d, SG_SHADE_SIMPLE (one primary ray per pixel), best of %d after one "
               "warm-up. Per-ray counters: kd-tree nodes traversed, leaf cells visited, surface "
               "intersection tests, splats evaluated; hit = fraction of rays that hit. "
               "agree = fraction of pixels where splatgi and Embree both hit or both miss.\n\n",
            IMAGE_SIZE, IMAGE_SIZE, rp->frames);
    fputs(table_head, f);
    for (int i = 0; i < rp->count; i++) {
        const row *r = &rp->rows[i];
        fprintf(f, "| %zu | %s | %s | %s | %.2f | %.1f | %.1f | %.3f | %.3f | %.1f | %.2f | %.2f "
                   "| %.1f | %.3f | %.3f | %.2f | %.3f | %.4f |\n",
                r->points, r->view, r->surface, r->refine, r->build_s, r->memory_mb, r->fps,
                r->mrays_s, r->mrays_s_per_core, r->nodes, r->leaves, r->isects, r->splats,
                r->hit_rate, r->embree_build_s, r->embree_mrays_s, r->ratio, r->agreement);
    }
}

/* ---- main ------------------------------------------------------------- */

int main(int argc, char **argv)
{
    options o;
    int rc = parse_options(argc, argv, &o);
    if (rc >= 0)
        return rc;
    if (access(o.mesh, R_OK) != 0) {
        printf("bench_trace: skipped: mesh %s not found (pass --mesh PATH)\n", o.mesh);
        return 0;
    }

    char machine[256];
    bench_cpu_model(machine, sizeof machine);
    int nproc = (int)sysconf(_SC_NPROCESSORS_ONLN);
    int omp_max = omp_get_max_threads();
    printf("bench_trace: machine %s, nproc %d, omp_get_max_threads %d, threads %d, Embree %s\n",
           machine, nproc, omp_max, o.threads, embree_discs_version());
    printf("bench_trace: %dx%d frames, SG_SHADE_SIMPLE, best of %d after 1 warm-up\n", IMAGE_SIZE,
           IMAGE_SIZE, o.frames);

    sg_error err;
    sg_aabb bounds;
    double t0 = omp_get_wtime();
    /* The cameras frame the mesh's vertices: the same for every sample count. */
    if (sg_mesh_read_bounds(o.mesh, &bounds, &err) != SG_OK)
        return fail("%s", err.message);
    printf("bench_trace: mesh %s, bounds (%g %g %g)-(%g %g %g), read in %.2f s\n", o.mesh,
           (double)bounds.lo.x, (double)bounds.lo.y, (double)bounds.lo.z, (double)bounds.hi.x,
           (double)bounds.hi.y, (double)bounds.hi.z, omp_get_wtime() - t0);
    sg_camera cams[2];
    if (make_cameras(bounds, &o, cams, &err) != SG_OK)
        return fail("camera: %s", err.message);

    size_t largest = 0;
    for (int i = 0; i < o.size_count; i++)
        largest = o.sizes[i] > largest ? o.sizes[i] : largest;

    static row rows[MAX_ROWS];
    int nrows = 0;
    uint8_t *mask_a = sg_alloc_array((size_t)IMAGE_SIZE * IMAGE_SIZE, 1);
    uint8_t *mask_b = sg_alloc_array((size_t)IMAGE_SIZE * IMAGE_SIZE, 1);
    if (!mask_a || !mask_b)
        return fail("out of memory");
    int status = 0;

    for (int si = 0; si < o.size_count && status == 0; si++) {
        size_t n = o.sizes[si];
        sg_pointset ps = {0};
        sg_model_points_desc md = {.points = n};
        t0 = omp_get_wtime();
        if (sg_model_points_load(o.mesh, &md, &ps, &err) != SG_OK) {
            status = fail("%s", err.message);
            break;
        }
        double load_s = omp_get_wtime() - t0;
        embree_discs *e = NULL;
        if (embree_discs_create(&ps, o.threads, &e, &err) != SG_OK) {
            sg_pointset_free(&ps);
            status = fail("%s", err.message);
            break;
        }
        printf("\n%zu points: sampled with kNN radii in %.2f s; Embree discs: build %.3f s, "
               "%.1f MiB\n",
               ps.count, load_s, embree_discs_build_seconds(e),
               (double)embree_discs_memory_bytes(e) / 1048576.0);
        for (int ci = 0; ci < (int)(sizeof configs / sizeof configs[0]) && status == 0; ci++) {
            const config *c = &configs[ci];
            sg_scene_desc sd = {.model = c->model, .kd_disable = c->kd_disable,
                                .threads = o.threads};
            sg_scene *s = NULL;
            if (sg_scene_create(&sd, &ps, &s, &err) != SG_OK) {
                status = fail("%zu points, %s refine %s: %s", n, c->surface, c->refine, err.message);
                break;
            }
            sg_scene_info info;
            sg_scene_get_info(s, &info);
            printf("  %s refine %-3s: build %.2f s, %.1f MiB, %zu nodes, %zu leaves (%zu empty), "
                   "depth %d, %.1f refs/splat\n",
                   c->surface, c->refine, info.build_seconds, (double)info.memory_bytes / 1048576.0,
                   info.node_count, info.leaf_count, info.empty_leaf_count, info.depth,
                   (double)info.splat_refs / (double)info.splat_count);
            fflush(stdout);
            for (int v = 0; v < 2 && status == 0; v++) {
                if (!o.views[v])
                    continue;
                row *r = &rows[nrows];
                memset(r, 0, sizeof *r);
                r->points = ps.count;
                r->view = view_names[v];
                r->surface = c->surface;
                r->refine = c->refine;
                r->build_s = info.build_seconds;
                r->memory_mb = (double)info.memory_bytes / 1048576.0;
                r->embree_build_s = embree_discs_build_seconds(e);
                sg_image img = {0};
                if (measure_row(s, e, &cams[v], &o, r, &img, mask_a, mask_b, &err) != SG_OK) {
                    status = fail("%s", err.message);
                    break;
                }
                if (o.png_dir && n == largest && ci == 0) {
                    char path[4096];
                    snprintf(path, sizeof path, "%s/bench_%s.png", o.png_dir, view_names[v]);
                    if (sg_image_write_png(&img, path, 1.0f, &err) != SG_OK)
                        status = fail("%s", err.message);
                    else
                        printf("  wrote %s\n", path);
                }
                sg_image_free(&img);
                if (nrows == 0)
                    print_head_text(stdout);
                print_row_text(stdout, r);
                fflush(stdout);
                nrows++;
            }
            sg_scene_destroy(s);
        }
        embree_discs_destroy(e);
        sg_pointset_free(&ps);
    }
    sg_free(mask_a);
    sg_free(mask_b);

    printf("\nsummary (%s, %d threads; per-ray counters; E. = Embree discs, ratio = splatgi/Embree "
           "Mrays/s, agree = same hit-or-miss)\n",
           machine, o.threads);
    print_head_text(stdout);
    for (int i = 0; i < nrows; i++)
        print_row_text(stdout, &rows[i]);

    report rp = {rows, nrows, machine, o.threads, nproc, omp_max, o.frames, o.mesh};
    if (o.csv) {
        if (bench_write_file(o.csv, write_csv, &rp) == 0)
            printf("bench_trace: wrote %s\n", o.csv);
        else
            status = 1;
    }
    if (o.md) {
        if (bench_write_file(o.md, write_md, &rp) == 0)
            printf("bench_trace: wrote %s\n", o.md);
        else
            status = 1;
    }
    return status;
}
