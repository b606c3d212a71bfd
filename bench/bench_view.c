/* bench_view — the walkthrough viewer's frame time: mean and 95th
 * percentile over a recorded camera path, per model size, resolution and
 * bake material (issue "The interactive walkthrough viewer").
 *
 * Scene: the Stanford dragon sampled to each size (default 32k, 125k, 1M,
 * 4M points), scaled to BENCH_SCENE_LENGTH (10) units along its longest side and
 * standing on y = 0 (as bench_ref), on the builtin ground (Lambert 0.5),
 * under courtyard.exr (the builtin "sky" when absent). Two materials for
 * the dragon: "diffuse" (Lambert, albedo 0.7) and "glossy" (GGX, albedo
 * 0.7, roughness 0.3, specular 0.04). A glossy lookup also reads the
 * directional bins of the sample points under the hit (bake/glossy.h), and
 * its bake traces the bins' rays, so both cost more than the diffuse
 * ones. Each (size, material, surface) is its own world (the
 * material and the surface model live in the world) and its own bake
 * (--photons, --direct).
 *
 * Surfaces: --surfaces (default mls,iso) lists the surface models to
 * compare (surface/scene.h: "mls", "disk", "iso"); each is set on both
 * models, the dragon's and the ground's ("surface": {"model": ...}), and
 * each gets its own world build and bake (one after the other); then all
 * of them walk the path together, key by key in turn (walk_all), so a
 * change in the machine's load meets every surface alike and the
 * frame-time ratios between them (ISO/MLS in the targets) hold on a
 * shared machine. (Walking one surface after the other, a 1M run saw the
 * load fall from 7 to 2 between the two walks: ISO/MLS 0.36 in wall time,
 * 1.15 in CPU time.)
 * After each 512x512 walk the still frames of two keys (the first and
 * the middle of the close pass) are written as PNG to
 * out/bench_view/frame_N_MATERIAL_SURFACE_KEY.png, and the share of their
 * pixels whose 8-bit value moves by more than 2 against the first surface
 * of the list is reported (how far the images of the surfaces differ).
 *
 * Camera path: made here, deterministically, and written as a campath file
 * (view/campath.h) to out/bench_view/path.txt so `splatgi-view --path`
 * replays it; the scene files go next to it
 * (out/bench_view/dragon_N_MATERIAL_SURFACE.json).
 * 60 keys: 24 orbiting the dragon low (eye y = 3, radius 16), 24 orbiting
 * high (eye y = 10, radius 20), 12 on a close pass in front of the dragon.
 * Sizes >= --big-size (default 1M) walk every --big-stride-th key only
 * (default 2), sizes >= --huge-size (default 4M) every --huge-stride-th
 * (default 4; both stated in the output), to keep the full run within
 * minutes on 2 cores; --quick walks every 6th key. --glossy-up-to N skips
 * the glossy world and bake above N points (the glossy bake is the slow
 * one: bins at every glossy sample point).
 *
 * Frame: sg_view_frame_render at scale 1 (what the viewer does per still
 * frame: sg_view_render + OCIO display transform to RGBA8, frame.h), the
 * display made as the viewer makes it (the config's default display and
 * view, exposure 0). One warm-up frame (the first key), then every key
 * once, each timed with omp_get_wtime; mean and 95th percentile (nearest
 * rank) of those times; also the mean render (lookup) and display parts,
 * and the process's CPU time per frame (all threads: on a shared machine
 * the wall time also counts what other processes took of the cores).
 * After each still frame the same key as the viewer shows it while the
 * camera moves (--move-scale auto: sg_view_move_scale from the previous
 * moving frame, as if the camera moved along the whole path): its mean,
 * p95, fps and the mean scale chosen.
 *
 * Output: a table on stdout, DIR/bench_view.csv and DIR/bench_view.md
 * (written to a temporary name and renamed).
 */
#include <assert.h>
#include <errno.h>
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
#include "bake/bake.h"
#include "display/ocio.h"
#include "io/image.h"
#include "io/mesh.h"
#include "io/scene_file.h"
#include "render/camera.h"
#include "render/world.h"
#include "view/campath.h"
#include "view/frame.h"

#define DEFAULT_MESH SG_SHARED_DATA_DIR "/meshes/stanford_dragon/dragon_vrip.ply"
#define DEFAULT_ENVMAP SG_SHARED_DATA_DIR "/envmaps/blender_studiolights/courtyard.exr"
#define PATH_DIR "out/bench_view"

#define FOV_DEG 40.0f
#define DRAGON_ALBEDO 0.7f
#define GROUND_ALBEDO 0.5f
#define GGX_ROUGHNESS 0.3f
#define GGX_SPECULAR 0.04f
#define MAX_SIZES 8
#define N_RES 2
#define N_MAT 2
#define N_SURF 4 /* sg_surface_model values 0..3 */
#define N_SNAP 2 /* keys written as PNG and compared between surfaces */
#define SNAP_OFF 2 /* an 8-bit channel moved by more than this is "off" */
#define KEY_SECONDS 0.1 /* path time between keys */

static const int res_w[N_RES] = {512, 1024};
static const int res_h[N_RES] = {512, 768};
static const char *const mat_name[N_MAT] = {"diffuse", "glossy"};
/* Indexed by sg_surface_model (SG_SURFACE_MLS 0, DISK 1, ISO 2, HYBRID 3).
 * The hybrid traces the mesh's own triangles (and the ground as a
 * 128 x 128 grid): its size is the mesh's, whatever --sizes says. */
static const char *const surf_name[N_SURF] = {"mls", "disk", "iso", "hybrid"};
static const char *const surf_label[N_SURF] = {"MLS", "disk", "ISO", "hybrid"};

static const char usage[] =
    "usage: bench_view [options]\n"
    "Viewer frame time (mean, p95) along a camera path on the Stanford dragon.\n"
    "  --mesh PATH       mesh to sample (default " DEFAULT_MESH ")\n"
    "  --envmap PATH     lat-long EXR (default courtyard.exr; builtin sky if absent)\n"
    "  --sizes A,B,...   point counts (default 32000,125000,1000000,4000000)\n"
    "  --quick           32000 points, every 6th key (about 1 min\n"
    "                    on quiet cores with the two default surfaces)\n"
    "  --photons N       bake photons (default 500000)\n"
    "  --direct N        bake direct_samples (default 8)\n"
    "  --big-size N      sizes >= N walk every --big-stride-th key (default 1000000)\n"
    "  --big-stride K    (default 2; quick: every size, 6)\n"
    "  --huge-size N     sizes >= N walk every --huge-stride-th key (default 4000000)\n"
    "  --huge-stride K   (default 4)\n"
    "  --glossy-up-to N  bake and walk the glossy material only for sizes <= N\n"
    "                    (default: every size)\n"
    "  --surfaces LIST   surface models, comma-separated, of mls, disk, iso, hybrid\n"
    "                    (default mls,iso): each its own world, bake and walk\n"
    "  --threads N       OpenMP threads (default: all)\n"
    "  --out-dir DIR     CSV and markdown folder (default docs)\n"
    "  --help            this text\n";

typedef struct options {
    const char *mesh, *envmap, *out_dir;
    size_t sizes[MAX_SIZES];
    int size_count, quick, threads, direct, big_stride, huge_stride;
    size_t photons, big_size, huge_size, glossy_up_to;
    int surfaces[N_SURF];      /* sg_surface_model values, in --surfaces order */
    int surface_count;
} options;

typedef struct row {
    size_t points;
    int mat;
    int surf;                  /* sg_surface_model of both models      */
    size_t splats;             /* all models                           */
    double world_s, bake_s, trace_s, gather_s;
    int width, height, frames, stride;
    double mean_ms, p95_ms, min_ms, max_ms, render_ms, display_ms, fps;
    double cpu_ms;             /* process CPU time per frame, all threads */
    double move_mean_ms, move_p95_ms, move_fps; /* the same keys as the viewer shows them moving */
    double move_scale;         /* mean scale --move-scale auto chose      */
    double snap_off[N_SNAP];   /* 512x512 only: % of the snapshot keys' pixels
                                  off by > SNAP_OFF against the first surface;
                                  NAN for the first surface itself         */
} row;

typedef struct report {
    const options *o;
    const char *machine, *env_used;
    const char *args;        /* bench_view's arguments, space-separated */
    int nproc;
    double load0, load1;     /* 1-minute load average at the start and the end */
    size_t keys;
    const row *rows;
    int nrows;
} report;

#define fail(...) bench_fail("bench_view", __VA_ARGS__) /* bench_common.h */

static int parse_size(const char *s, unsigned long long lo, unsigned long long hi, size_t *out)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return 0;
    *out = (size_t)v;
    return 1;
}

static int parse_sizes(const char *s, options *o)
{
    return sg_cli_size_list("--sizes", s, 100, 100000000ull, o->sizes, MAX_SIZES, &o->size_count, NULL) == SG_OK;
}

/* "mls,iso" -> o->surfaces; each name once, at least one. */
static int parse_surfaces(const char *s, options *o)
{
    int count = 0;
    while (*s) {
        size_t len = strcspn(s, ",");
        int found = -1;
        for (int k = 0; k < N_SURF; k++)
            if (strlen(surf_name[k]) == len && strncmp(s, surf_name[k], len) == 0)
                found = k;
        if (found < 0 || count == N_SURF)
            return 0;
        for (int j = 0; j < count; j++)
            if (o->surfaces[j] == found)
                return 0;
        o->surfaces[count++] = found;
        s += len;
        if (*s == ',' && *++s == '\0')
            return 0;
    }
    if (count == 0)
        return 0;
    o->surface_count = count;
    return 1;
}

/* Returns -1 to continue, else the exit status. */
static int parse_options(int argc, char **argv, options *o)
{
    memset(o, 0, sizeof *o);
    o->mesh = DEFAULT_MESH;
    o->envmap = DEFAULT_ENVMAP;
    o->out_dir = "docs";
    o->photons = 500000;
    o->direct = 8;
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], "--quick") == 0)
            o->quick = 1;
    o->big_size = o->quick ? 100 : 1000000;
    o->big_stride = o->quick ? 6 : 2;
    o->huge_size = 4000000;
    o->huge_stride = 4;
    o->glossy_up_to = (size_t)-1;
    parse_sizes(o->quick ? "32000" : "32000,125000,1000000,4000000", o);
    parse_surfaces("mls,iso", o);
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        size_t n;
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
        else if (strcmp(a, "--out-dir") == 0)
            o->out_dir = v;
        else if (strcmp(a, "--sizes") == 0) {
            if (!parse_sizes(v, o))
                return fail("--sizes '%s': want up to %d counts >= 100, comma-separated", v, MAX_SIZES);
        } else if (strcmp(a, "--photons") == 0) {
            if (!parse_size(v, 1000, 1ull << 34, &o->photons))
                return fail("--photons '%s': want 1000..2^34", v);
        } else if (strcmp(a, "--direct") == 0) {
            if (!parse_size(v, 0, 4096, &n))
                return fail("--direct '%s': want 0..4096", v);
            o->direct = n == 0 ? -1 : (int)n;
        } else if (strcmp(a, "--big-size") == 0) {
            if (!parse_size(v, 1, 1000000000ull, &o->big_size))
                return fail("--big-size '%s': want a point count", v);
        } else if (strcmp(a, "--big-stride") == 0) {
            if (!parse_size(v, 1, 60, &n))
                return fail("--big-stride '%s': want 1..60", v);
            o->big_stride = (int)n;
        } else if (strcmp(a, "--huge-size") == 0) {
            if (!parse_size(v, 1, 1000000000ull, &o->huge_size))
                return fail("--huge-size '%s': want a point count", v);
        } else if (strcmp(a, "--huge-stride") == 0) {
            if (!parse_size(v, 1, 60, &n))
                return fail("--huge-stride '%s': want 1..60", v);
            o->huge_stride = (int)n;
        } else if (strcmp(a, "--glossy-up-to") == 0) {
            if (!parse_size(v, 0, 1000000000ull, &o->glossy_up_to))
                return fail("--glossy-up-to '%s': want a point count", v);
        } else if (strcmp(a, "--surfaces") == 0) {
            if (!parse_surfaces(v, o))
                return fail("--surfaces '%s': want mls, disk, iso and/or hybrid, comma-separated, each once", v);
        } else if (strcmp(a, "--threads") == 0) {
            if (!parse_size(v, 1, 4096, &n))
                return fail("--threads '%s': want 1..4096", v);
            o->threads = (int)n;
        } else
            return fail("unknown option %s (see --help)", a);
    }
    if (o->threads == 0)
        o->threads = omp_get_max_threads();
    return -1;
}

/* ---- machine and files ------------------------------------------------ */




/* CPU seconds of the process over all its threads: what the frame cost
 * the machine, whatever other processes took of the cores meanwhile. */
static void write_text(FILE *f, const void *ctx)
{
    fputs((const char *)ctx, f);
}


/* ---- scene and path ---------------------------------------------------- */

static int scene_json(const options *o, const bench_scene *s, size_t points, int mat, int surf, char *out,
                      size_t cap)
{
    char mesh[2048], env[2048], envpart[2200], material[256];
    if (!bench_json_escape(o->mesh, mesh, sizeof mesh) || !bench_json_escape(o->envmap, env, sizeof env))
        return 0;
    if (s->have_envmap)
        snprintf(envpart, sizeof envpart, "{\"path\": \"%s\"}", env);
    else
        snprintf(envpart, sizeof envpart, "{\"builtin\": \"sky\"}");
    if (mat == 0)
        snprintf(material, sizeof material,
                 "{\"type\": \"lambert\", \"albedo\": [%g, %g, %g], \"use_point_colors\": false}",
                 (double)DRAGON_ALBEDO, (double)DRAGON_ALBEDO, (double)DRAGON_ALBEDO);
    else
        snprintf(material, sizeof material,
                 "{\"type\": \"ggx\", \"albedo\": [%g, %g, %g], \"roughness\": %g, \"specular\": %g,"
                 " \"use_point_colors\": false}",
                 (double)DRAGON_ALBEDO, (double)DRAGON_ALBEDO, (double)DRAGON_ALBEDO, (double)GGX_ROUGHNESS,
                 (double)GGX_SPECULAR);
    int n = snprintf(out, cap,
                     "{\"models\": [\n"
                     "  {\"path\": \"%s\", \"points\": %zu,\n"
                     "   \"transform\": {\"translate\": [%.9g, %.9g, %.9g], \"scale\": %.9g},\n"
                     "   \"material\": %s,\n"
                     "   \"surface\": {\"model\": \"%s\"}},\n"
                     "  {\"builtin\": \"ground\",\n"
                     "   \"material\": {\"type\": \"lambert\", \"albedo\": [%g, %g, %g],"
                     " \"use_point_colors\": false},\n"
                     "   \"surface\": {\"model\": \"%s\"}}],\n"
                     " \"envmap\": %s,\n"
                     " \"cameras\": [{\"name\": \"main\", \"eye\": [0, 3, 16], \"look\": [0, %.4g, 0], \"up\": [0, 1, 0],"
                     " \"fov_deg\": %g}],\n"
                     " \"render\": {\"width\": 512, \"height\": 512}}\n",
                     mesh, points, (double)s->translate.x, (double)s->translate.y, (double)s->translate.z,
                     (double)s->scale, material, surf_name[surf], (double)GROUND_ALBEDO, (double)GROUND_ALBEDO,
                     (double)GROUND_ALBEDO, surf_name[surf], envpart, (double)(0.4f * s->world_box.hi.y),
                     (double)FOV_DEG);
    return n > 0 && (size_t)n < cap;
}

/* The path of the file's head comment, around world_box (centred in x, z,
 * standing on y = 0). */
static sg_status make_path(const bench_scene *s, sg_campath *p, sg_error *err)
{
    const float pi = 3.14159265f;
    float h = s->world_box.hi.y;
    sg_vec3 target = sg_v3(0.0f, 0.4f * h, 0.0f);
    size_t k = 0;
    for (int ring = 0; ring < 2; ring++) {
        float radius = ring == 0 ? 16.0f : 20.0f, y = ring == 0 ? 3.0f : 10.0f;
        for (int i = 0; i < 24; i++, k++) {
            float a = 2.0f * pi * (float)i / 24.0f + (ring ? pi / 24.0f : 0.0f);
            sg_campath_key key = {.time = KEY_SECONDS * (double)k,
                                  .view = {.eye = sg_v3(radius * sinf(a), y, radius * cosf(a)),
                                           .look = target, .up = sg_v3(0, 1, 0), .fov_deg = FOV_DEG}};
            sg_status st = sg_campath_append(p, &key, err);
            if (st != SG_OK)
                return st;
        }
    }
    /* Close pass: along x in front of the dragon (z = front + 3), looking
     * at the part of the dragon straight ahead. */
    float zf = s->world_box.hi.z + 3.0f;
    for (int i = 0; i < 12; i++, k++) {
        float t = (float)i / 11.0f;
        float x = -7.0f + 14.0f * t;
        sg_campath_key key = {.time = KEY_SECONDS * (double)k,
                              .view = {.eye = sg_v3(x, 0.6f * h, zf),
                                       .look = sg_v3(0.6f * x, 0.45f * h, 0.0f), .up = sg_v3(0, 1, 0),
                                       .fov_deg = FOV_DEG}};
        sg_status st = sg_campath_append(p, &key, err);
        if (st != SG_OK)
            return st;
    }
    return SG_OK;
}

/* ---- measuring ----------------------------------------------------------- */

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Mean and nearest-rank 95th percentile of t[0..m) (sorts t), in ms. */
static void summarise(double *t, size_t m, double *mean_ms, double *p95_ms)
{
    double sum = 0;
    for (size_t i = 0; i < m; i++)
        sum += t[i];
    qsort(t, m, sizeof *t, cmp_double);
    size_t rank = (size_t)ceil(0.95 * (double)m); /* nearest rank, 1-based */
    *mean_ms = 1e3 * sum / (double)m;
    *p95_ms = 1e3 * t[rank > 0 ? rank - 1 : 0];
}

/* One surface's walk along the path at one frame size. Each key: the still
 * frame (scale 1, timed with its CPU time and parts), then the frame the
 * viewer shows while moving: the scale chosen by sg_view_move_scale from
 * the moving frame before (the first from the warm-up frame), the image
 * upscaled to the window. The surfaces' walks are interleaved key by key
 * (walk_all), so a change in the machine's load meets them alike. */
typedef struct walker {
    const sg_bake *b;
    const sg_world *w;
    row *r;                    /* filled by walker_end                      */
    sg_view_frame f;
    double *t, *tm;            /* still and moving frame seconds, per key   */
    double render, display, cpu, scales; /* sums over the keys walked       */
    size_t m;                  /* keys walked                               */
    int move;                  /* the viewer's moving scale, chained        */
    double move_s;             /* seconds of the moving frame before        */
    size_t move_px;            /* its primary rays                          */
} walker;

/* Allocates for n keys and renders the untimed warm-up frame (key 0). */
static sg_status walker_begin(walker *k, const sg_display *d, const sg_campath *p, size_t n, int threads,
                              sg_error *err)
{
    k->t = malloc(n * sizeof *k->t);
    k->tm = malloc(n * sizeof *k->tm);
    if (!k->t || !k->tm)
        return sg_error_set(err, SG_ERR_NOMEM, "frame times");
    sg_status st = sg_view_frame_resize(&k->f, k->r->width, k->r->height, err);
    sg_camera cam;
    if (st == SG_OK)
        st = sg_campath_camera(&p->keys[0], (float)k->r->width / (float)k->r->height, &cam, err);
    if (st == SG_OK)
        st = sg_view_frame_render(&k->f, k->b, k->w, &cam, 1, threads, d, err);
    k->move = k->f.scale; /* the viewer's state when the camera starts moving */
    k->move_s = k->f.render_seconds + k->f.display_seconds;
    k->move_px = k->f.rays;
    return st;
}

static sg_status walker_key(walker *k, const sg_display *d, const sg_campath_key *key, int threads, sg_error *err)
{
    const row *r = k->r;
    sg_camera cam;
    sg_status st = sg_campath_camera(key, (float)r->width / (float)r->height, &cam, err);
    if (st != SG_OK)
        return st;
    double t0 = omp_get_wtime(), c0 = bench_cpu_seconds();
    st = sg_view_frame_render(&k->f, k->b, k->w, &cam, 1, threads, d, err);
    k->t[k->m] = omp_get_wtime() - t0;
    k->cpu += bench_cpu_seconds() - c0;
    k->render += k->f.render_seconds;
    k->display += k->f.display_seconds;
    if (st != SG_OK)
        return st;
    k->move = sg_view_move_scale(k->move, k->move_s, k->move_px, r->width, r->height, SG_VIEW_MOVE_BUDGET_SECONDS);
    t0 = omp_get_wtime();
    st = sg_view_frame_render(&k->f, k->b, k->w, &cam, k->move, threads, d, err);
    k->tm[k->m++] = omp_get_wtime() - t0;
    k->move_s = k->f.render_seconds + k->f.display_seconds;
    k->move_px = k->f.rays;
    k->scales += k->move;
    return st;
}

static void walker_end(walker *k, int stride)
{
    row *r = k->r;
    size_t m = k->m;
    summarise(k->tm, m, &r->move_mean_ms, &r->move_p95_ms);
    r->move_fps = 1e3 / r->move_mean_ms;
    r->move_scale = k->scales / (double)m;
    summarise(k->t, m, &r->mean_ms, &r->p95_ms);
    r->frames = (int)m;
    r->stride = stride;
    r->min_ms = 1e3 * k->t[0];
    r->max_ms = 1e3 * k->t[m - 1];
    r->render_ms = 1e3 * k->render / (double)m;
    r->display_ms = 1e3 * k->display / (double)m;
    r->fps = 1e3 / r->mean_ms;
    r->cpu_ms = 1e3 * k->cpu / (double)m;
}

static void walker_free(walker *k)
{
    free(k->t);
    free(k->tm);
    sg_view_frame_free(&k->f);
}

/* Walks every --surfaces world along the path at one frame size, key by
 * key in turn: k[0..count) come with b, w and r set (r's width, height). */
static sg_status walk_all(walker *k, int count, const sg_display *d, const sg_campath *p, int stride, int threads,
                          sg_error *err)
{
    size_t n = (p->count + (size_t)stride - 1) / (size_t)stride;
    sg_status st = SG_OK;
    for (int s = 0; s < count && st == SG_OK; s++)
        st = walker_begin(&k[s], d, p, n, threads, err);
    for (size_t i = 0; i < p->count && st == SG_OK; i += (size_t)stride)
        for (int s = 0; s < count && st == SG_OK; s++)
            st = walker_key(&k[s], d, &p->keys[i], threads, err);
    for (int s = 0; s < count; s++) {
        if (st == SG_OK)
            walker_end(&k[s], stride);
        walker_free(&k[s]);
    }
    return st;
}

/* The still frames of the snapshot keys at the row's size: written as PNG
 * (the linear render, plain sRGB: for looking, not for measuring) to
 * STEM_KEY.png, their RGBA8 display frames kept in ref[] for the first
 * surface of the list (first != 0) and compared with ref[] for the
 * others: r->snap_off[k] = % of pixels with a channel off by > SNAP_OFF. */
static sg_status snapshots(const sg_bake *b, const sg_world *w, const sg_display *d, const sg_campath *p,
                           int threads, const char *stem, int first, uint8_t *const ref[N_SNAP], row *r,
                           sg_error *err)
{
    static const size_t snap_key[N_SNAP] = {0, 54}; /* first low orbit key, middle of the close pass */
    sg_view_frame f = {0};
    size_t px = (size_t)r->width * (size_t)r->height;
    sg_status st = sg_view_frame_resize(&f, r->width, r->height, err);
    for (int k = 0; k < N_SNAP && st == SG_OK; k++) {
        r->snap_off[k] = NAN;
        if (snap_key[k] >= p->count)
            continue;
        sg_camera cam;
        st = sg_campath_camera(&p->keys[snap_key[k]], (float)r->width / (float)r->height, &cam, err);
        if (st == SG_OK)
            st = sg_view_frame_render(&f, b, w, &cam, 1, threads, d, err);
        if (st != SG_OK)
            break;
        char png[600];
        snprintf(png, sizeof png, "%s_%zu.png", stem, snap_key[k]);
        if (sg_image_write_png(&f.linear, png, 1.0f, err) != SG_OK)
            printf("bench_view: %s not written: %s\n", png, err->message); /* a picture only: go on */
        if (first) {
            memcpy(ref[k], f.rgba, 4 * px);
            continue;
        }
        size_t off = 0;
        for (size_t i = 0; i < px; i++) {
            int worst = 0;
            for (int c = 0; c < 3; c++) {
                int dv = abs((int)f.rgba[4 * i + c] - (int)ref[k][4 * i + c]);
                worst = dv > worst ? dv : worst;
            }
            off += worst > SNAP_OFF;
        }
        r->snap_off[k] = 100.0 * (double)off / (double)px;
    }
    sg_view_frame_free(&f);
    return st;
}

/* ---- output ------------------------------------------------------------- */

static void write_csv(FILE *f, const void *ctx)
{
    const report *rp = ctx;
    fputs("points,material,surface,width,height,frames,key_stride,mean_ms,p95_ms,min_ms,max_ms,render_ms,display_ms,"
          "mean_fps,cpu_ms,splats,world_s,bake_s,trace_s,gather_s,photons,direct_samples,threads,load_start,load_end,"
          "envmap,machine,move_scale,move_mean_ms,move_p95_ms,move_fps,snap_off_key0_pct,snap_off_key54_pct\n",
          f);
    for (int i = 0; i < rp->nrows; i++) {
        const row *r = &rp->rows[i];
        fprintf(f, "%zu,%s,%s,%d,%d,%d,%d,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.2f,%.3f,%zu,%.2f,%.2f,%.2f,%.2f,%zu,%d,%d,"
                   "%.2f,%.2f,\"%s\",\"%s\",%.2f,%.3f,%.3f,%.2f,%.3f,%.3f\n",
                r->points, mat_name[r->mat], surf_name[r->surf], r->width, r->height, r->frames, r->stride,
                r->mean_ms, r->p95_ms, r->min_ms, r->max_ms, r->render_ms, r->display_ms, r->fps, r->cpu_ms,
                r->splats, r->world_s, r->bake_s, r->trace_s, r->gather_s, rp->o->photons, rp->o->direct,
                rp->o->threads, rp->load0, rp->load1, rp->env_used, rp->machine, r->move_scale,
                r->move_mean_ms, r->move_p95_ms, r->move_fps, r->snap_off[0], r->snap_off[1]);
    }
}

static const row *find_row(const report *rp, size_t points, int mat, int surf, int width)
{
    for (int i = 0; i < rp->nrows; i++)
        if (rp->rows[i].points == points && rp->rows[i].mat == mat && rp->rows[i].surf == surf &&
            rp->rows[i].width == width)
            return &rp->rows[i];
    return NULL;
}

/* The targets at 1M points, diffuse, one line per surface and
 * resolution; returns how many rows it found. */
static int write_targets(FILE *f, const report *rp)
{
    const options *o = rp->o;
    static const double target_fps[N_RES] = {30.0, 15.0};
    int found = 0;
    for (int s = 0; s < o->surface_count; s++)
        for (int ri = 0; ri < N_RES; ri++)
            found += find_row(rp, 1000000, 0, o->surfaces[s], res_w[ri]) != NULL;
    if (found == 0)
        return 0;
    fputs("| surface | size | target | mean ms | p95 ms | mean fps | met | CPU ms | fps on idle cores | "
          "moving fps (scale) | world build s | bake s |\n"
          "|---|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|\n",
          f);
    for (int s = 0; s < o->surface_count; s++)
        for (int ri = 0; ri < N_RES; ri++) {
            const row *r = find_row(rp, 1000000, 0, o->surfaces[s], res_w[ri]);
            if (!r)
                continue;
            fprintf(f, "| %s | %dx%d | >= %g fps | %.1f | %.1f | %.1f | %s | %.1f | %.1f | %.1f (%.2f) | %.1f | "
                       "%.1f |\n",
                    surf_label[r->surf], r->width, r->height, target_fps[ri], r->mean_ms, r->p95_ms, r->fps,
                    r->fps >= target_fps[ri] ? "met" : "NOT met", r->cpu_ms, 1e3 * o->threads / r->cpu_ms,
                    r->move_fps, r->move_scale, r->world_s, r->bake_s);
        }
    return found;
}

/* Each surface after the first against the first of --surfaces (ISO/MLS
 * with the default list): frame time, p95, CPU time, world build and bake
 * ratios, and how far their snapshots differ. */
static void write_ratios(FILE *f, const report *rp)
{
    const options *o = rp->o;
    if (o->surface_count < 2)
        return;
    int base = o->surfaces[0];
    fprintf(f, "\n## Surfaces side by side (ratios against %s, same run)\n\n"
               "Each ratio is the other surface's figure over %s's for the same size, material and frame "
               "size, the frames measured key by key in turn in this process (a ratio below 1: the other "
               "surface is faster). *Pixels off* = share of the pixels of the 512x512 still frame whose 8-bit display "
               "value moves by more than %d in some channel against %s's frame of the same key (keys 0: low "
               "orbit, 54: close pass; PNGs in `" PATH_DIR "/frame_N_MATERIAL_SURFACE_KEY.png`). It counts "
               "both what the surfaces put where (silhouettes, thin parts) and the two bakes' own noise: "
               "their light sites differ (splat sample points against the octree's corners), so the grain of "
               "a modest bake differs pixel by pixel even where the surfaces agree.\n\n",
            surf_label[base], surf_label[base], SNAP_OFF, surf_label[base]);
    fputs("| points | material | surface | size | mean ms ratio | p95 ms ratio | CPU ms ratio | world build ratio | "
          "bake ratio | pixels off, key 0 | pixels off, key 54 |\n"
          "|---:|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
          f);
    for (int i = 0; i < rp->nrows; i++) {
        const row *r = &rp->rows[i];
        if (r->surf == base)
            continue;
        const row *m = find_row(rp, r->points, r->mat, base, r->width);
        if (!m)
            continue;
        fprintf(f, "| %zu | %s | %s/%s | %dx%d | %.2f | %.2f | %.2f | %.2f | %.2f |", r->points, mat_name[r->mat],
                surf_label[r->surf], surf_label[base], r->width, r->height, r->mean_ms / m->mean_ms,
                r->p95_ms / m->p95_ms, r->cpu_ms / m->cpu_ms, r->world_s / m->world_s, r->bake_s / m->bake_s);
        for (int k = 0; k < N_SNAP; k++)
            if (isnan(r->snap_off[k]))
                fputs(" — |", f);
            else
                fprintf(f, " %.1f%% |", r->snap_off[k]);
        fputs("\n", f);
    }
}

/* A path as the docs show it: from "../shared/" on when it reaches the
 * shared data through the checkout's parent (no machine's folder names). */
static const char *shown_path(const char *path)
{
    const char *shared = strstr(path, "../shared/");
    return shared ? shared : path;
}

static void write_md(FILE *f, const void *ctx)
{
    const report *rp = ctx;
    const options *o = rp->o;
    char surfs[64] = "";
    for (int s = 0; s < o->surface_count; s++) {
        size_t used = strlen(surfs);
        snprintf(surfs + used, sizeof surfs - used, "%s%s", s ? ", " : "", surf_name[o->surfaces[s]]);
    }
    fprintf(f, "# Viewer frame time\n\n"
               "Machine: %s, %d cores, %d OpenMP threads; load average %.2f at the start, %.2f at the end "
               "(the cores are shared: with a load above %d, wall times include the time other processes held "
               "the cores; *CPU ms* is the process's CPU time per frame over all its threads, which does not "
               "include that: on an idle machine a frame takes about CPU ms / threads). "
               "Made by `scripts/bench-view.sh` (bench/bench_view.c), which ran `bench_view%s`.\n\n",
            rp->machine, rp->nproc, o->threads, rp->load0, rp->load1, rp->nproc, rp->args);
    fprintf(f, "Scene: the Stanford dragon sampled to N points, %g units long, standing on the builtin ground, "
               "under `%s`. Bakes: the default transport estimator, %d envmap rays per sample site and the "
               "default cosine rays; *diffuse* = Lambert albedo %g, *glossy* = GGX "
               "albedo %g, roughness %g, specular %g. A glossy lookup also reads the directional bins "
               "of the sample points under the hit (bake/glossy.h), so its frames cost more than the diffuse "
               "ones.\n\n",
            (double)BENCH_SCENE_LENGTH, shown_path(rp->env_used), o->direct, (double)DRAGON_ALBEDO,
            (double)DRAGON_ALBEDO, (double)GGX_ROUGHNESS, (double)GGX_SPECULAR);
    fprintf(f, "Surfaces (`--surfaces`): %s. Each is set on both models, the dragon's and the ground's "
               "(`\"surface\": {\"model\": ...}`, surface/scene.h: *mls* = the MLS surface on the splats' "
               "kd-tree, *disk* = disk splats, *iso* = the implicit surface octree sampled from the MLS "
               "surface, whose corners are the bake's light sites). Each has its own world build and bake, "
               "one after the other (so their times meet whatever load the machine had then); then the "
               "surfaces walk the path together, key by key in turn, so their frame times share the load "
               "of the moment and their ratios hold on a shared machine.\n\n",
            surfs);
    fprintf(f, "Path: %zu keys (24 orbiting low, 24 orbiting high, 12 on a close pass), written to "
               "`" PATH_DIR "/path.txt` with the scene files `" PATH_DIR "/dragon_N_MATERIAL_SURFACE.json` "
               "(the notes below, from before the surfaces were compared, name the MLS file "
               "`dragon_N_MATERIAL.json`); replay "
               "with `splatgi-bake " PATH_DIR "/dragon_1000000_diffuse_iso.json -o d.sgbake && splatgi-view "
               PATH_DIR "/dragon_1000000_diffuse_iso.json --bake d.sgbake --path " PATH_DIR "/path.txt`. "
               "Sizes >= %zu walk every %d-th key only, sizes >= %zu every %d-th (column *frames*)%s. "
               "Frame = `sg_view_frame_render` at scale 1 (`sg_view_render`: one primary ray per pixel, traced "
               "as 2x2 quads sharing the traversal, and the bake's lookup, the image of "
               "`sg_bake_render` bit for bit; then the OCIO display transform to RGBA8, default display and "
               "view), timed with `omp_get_wtime` after one warm-up frame; p95 = nearest-rank 95th percentile; "
               "render and display = the frame's two parts (means). *Moving* = the frame splatgi-view shows "
               "while the camera moves, timed after each still frame: `--move-scale auto` (the default) renders "
               "1/s of the width and height, s the smallest of 2, 4 and 8 whose frame is predicted to fit %.1f ms "
               "from the moving frame before (chained along the path, as if the camera never stopped), and "
               "upscales it to the window; *scale* = the mean s.\n\n",
            rp->keys, o->big_size, o->big_stride, o->huge_size, o->huge_stride,
            o->glossy_up_to == (size_t)-1 ? "" : "; the glossy material only up to the size in "
                                                   "`--glossy-up-to`",
            1e3 * SG_VIEW_MOVE_BUDGET_SECONDS);
    fputs("| points | material | surface | size | frames | mean ms | p95 ms | mean fps | render ms | display ms | "
          "min ms | max ms | CPU ms | moving mean ms | moving p95 ms | moving fps | scale |\n"
          "|---:|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
          f);
    for (int i = 0; i < rp->nrows; i++) {
        const row *r = &rp->rows[i];
        fprintf(f, "| %zu | %s | %s | %dx%d | %d | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | "
                   "%.1f | %.1f | %.2f |\n",
                r->points, mat_name[r->mat], surf_label[r->surf], r->width, r->height, r->frames, r->mean_ms,
                r->p95_ms, r->fps, r->render_ms, r->display_ms, r->min_ms, r->max_ms, r->cpu_ms, r->move_mean_ms,
                r->move_p95_ms, r->move_fps, r->move_scale);
    }
    fputs("\n## Build and bake\n\n| points | material | surface | splats (all models) | world build s | bake s | "
          "trace s | gather + direct s |\n|---:|---|---|---:|---:|---:|---:|---:|\n",
          f);
    for (int i = 0; i < rp->nrows; i++) {
        const row *r = &rp->rows[i];
        if (r->width != res_w[0])
            continue;
        fprintf(f, "| %zu | %s | %s | %zu | %.1f | %.1f | %.1f | %.1f |\n", r->points, mat_name[r->mat],
                surf_label[r->surf], r->splats, r->world_s, r->bake_s, r->trace_s, r->gather_s);
    }
    fputs("\n## Targets (issue: 1M points, diffuse bake)\n\n", f);
    if (write_targets(f, rp) == 0)
        fputs("Not measured (no 1000000-point diffuse run).\n", f);
    else {
        fprintf(f, "\n*fps on idle cores* = 1000 x %d threads / CPU ms; *moving* = `--move-scale auto`; the viewer "
                   "refines to the full frame once the camera has been still for %g s.\n",
                o->threads, SG_VIEW_MOVE_HOLD_SECONDS);
        int base = o->surfaces[0];
        for (int s = 1; s < o->surface_count; s++)
            for (int ri = 0; ri < N_RES; ri++) {
                const row *m = find_row(rp, 1000000, 0, base, res_w[ri]);
                const row *r = find_row(rp, 1000000, 0, o->surfaces[s], res_w[ri]);
                if (m && r)
                    fprintf(f, "- %s/%s frame time at %dx%d, same run: mean %.2f, p95 %.2f, CPU %.2f "
                               "(%.1f against %.1f ms).\n",
                            surf_label[r->surf], surf_label[base], r->width, r->height, r->mean_ms / m->mean_ms,
                            r->p95_ms / m->p95_ms, r->cpu_ms / m->cpu_ms, r->mean_ms, m->mean_ms);
            }
    }
    write_ratios(f, rp);
    /* The frame's profile split is measured by bench_view_split and kept
     * in OUT_DIR/bench_view_split.md; shown here when present. */
    char split[4200];
    snprintf(split, sizeof split, "%s/bench_view_split.md", o->out_dir);
    FILE *sf = fopen(split, "r");
    if (sf) {
        char buf[4096];
        size_t n;
        fputs("\n", f);
        while ((n = fread(buf, 1, sizeof buf, sf)) > 0)
            fwrite(buf, 1, n, f);
        fclose(sf);
    }
}

static void print_row(const row *r)
{
    printf("%8zu %-8s %-4s %4dx%-4d %6d %8.1f %8.1f %7.1f %9.1f %9.1f %7.1f %7.1f %7.1f %9.1f %7.1f\n", r->points,
           mat_name[r->mat], surf_name[r->surf], r->width, r->height, r->frames, r->mean_ms, r->p95_ms, r->fps,
           r->render_ms, r->display_ms, r->min_ms, r->max_ms, r->cpu_ms, r->move_mean_ms, r->move_fps);
}

static void print_head(void)
{
    printf("%8s %-8s %-4s %9s %6s %8s %8s %7s %9s %9s %7s %7s %7s %9s %7s\n", "points", "material", "surf", "size",
           "frames", "mean ms", "p95 ms", "fps", "render ms", "disp ms", "min ms", "max ms", "CPU ms", "move ms",
           "move fps");
}

/* ---- main ---------------------------------------------------------------- */

int main(int argc, char **argv)
{
    options o;
    int rc = parse_options(argc, argv, &o);
    if (rc >= 0)
        return rc;
    if (access(o.mesh, R_OK) != 0) {
        printf("bench_view: skipped: mesh %s not found (pass --mesh PATH)\n", o.mesh);
        return 0;
    }
    omp_set_num_threads(o.threads);

    char machine[256];
    bench_cpu_model(machine, sizeof machine);
    static char args[1024];
    for (int i = 1; i < argc; i++) {
        size_t used = strlen(args);
        snprintf(args + used, sizeof args - used, " %s", argv[i]);
    }
    report rp = {.o = &o, .machine = machine, .nproc = (int)sysconf(_SC_NPROCESSORS_ONLN), .args = args};
    rp.load0 = bench_load1();
    printf("bench_view: machine %s, nproc %d, omp_get_max_threads %d, threads %d, load %.2f%s\n", machine,
           rp.nproc, omp_get_max_threads(), o.threads, rp.load0, o.quick ? " (quick)" : "");

    sg_error err;
    bench_scene setup = {0};
    const bench_scene_desc sd = bench_dragon_scene(o.mesh, o.envmap);
    if (bench_scene_setup(&sd, &setup, &err) != SG_OK)
        return fail("%s", err.message);
    rp.env_used = setup.have_envmap ? o.envmap : "builtin sky (envmap file not found)";

    sg_campath path = {0};
    if (make_path(&setup, &path, &err) != SG_OK)
        return fail("path: %s", err.message);
    rp.keys = path.count;
    if (!bench_make_dirs(PATH_DIR))
        return fail("cannot create %s: %s", PATH_DIR, strerror(errno));
    if (sg_campath_write(&path, PATH_DIR "/path.txt", &err) != SG_OK)
        return fail("%s", err.message);
    printf("bench_view: envmap %s; bake %zu photons, direct_samples %d; path %zu keys -> %s\n", rp.env_used,
           o.photons, o.direct, path.count, PATH_DIR "/path.txt");

    sg_display *disp = NULL;
    sg_display_desc dd = {.exposure_stops = 0.0f, .threads = o.threads};
    if (sg_display_create(&dd, &disp, &err) != SG_OK)
        return fail("display: %s", err.message);
    sg_display_info di;
    sg_display_get_info(disp, &di);
    printf("bench_view: display %s / %s (config %s)\n", di.display, di.view, di.config_from);

    static row rows[MAX_SIZES * N_MAT * N_SURF * N_RES];
    int nrows = 0, status = 0;
    static char json[16384];
    /* The first surface's snapshot frames, 512x512 RGBA8, per (size, material). */
    static uint8_t snap_ref[N_SNAP][4 * 512 * 512];
    uint8_t *const snap_refs[N_SNAP] = {snap_ref[0], snap_ref[1]};
    assert((size_t)res_w[0] * (size_t)res_h[0] * 4 <= sizeof snap_ref[0]); /* snapshots are at res 0 */
    for (int si = 0; si < o.size_count && status == 0; si++) {
        size_t n = o.sizes[si];
        int stride = n >= o.huge_size ? o.huge_stride : n >= o.big_size ? o.big_stride : 1;
        for (int mat = 0; mat < N_MAT && status == 0; mat++) {
            if (mat == 1 && n > o.glossy_up_to) {
                printf("\n%zu points, %s: skipped (--glossy-up-to %zu)\n", n, mat_name[mat], o.glossy_up_to);
                continue;
            }
            /* Every surface's world and bake first, then their walks key
             * by key in turn (walk_all); rows go in surface order. */
            sg_scene_file sf[N_SURF] = {{0}};
            sg_world *w[N_SURF] = {NULL};
            sg_bake *b[N_SURF] = {NULL};
            row *rs = &rows[nrows];
            for (int s = 0; s < o.surface_count && status == 0; s++) {
                int surf = o.surfaces[s];
                char jpath[512];
                snprintf(jpath, sizeof jpath, PATH_DIR "/dragon_%zu_%s_%s.json", n, mat_name[mat], surf_name[surf]);
                if (!scene_json(&o, &setup, n, mat, surf, json, sizeof json)) {
                    status = fail("scene JSON too long");
                    break;
                }
                bench_write_file(jpath, write_text, json);
                if (sg_scene_file_parse(json, strlen(json), jpath, NULL, &sf[s], &err) != SG_OK) {
                    status = fail("%s", err.message);
                    break;
                }
                double t0 = omp_get_wtime();
                if (sg_world_create(&sf[s], &w[s], &err) != SG_OK) {
                    status = fail("%zu points, %s: %s", n, surf_name[surf], err.message);
                    break;
                }
                double world_s = omp_get_wtime() - t0;
                size_t splats = 0;
                for (uint32_t m = 0; m < sg_world_model_count(w[s]); m++) {
                    sg_scene_info info;
                    sg_scene_get_info(sg_world_scene(w[s], m), &info);
                    splats += info.splat_count;
                }
                printf("%zu points, %s, %s: world %.1f s (%zu splats); ", n, mat_name[mat], surf_name[surf],
                       world_s, splats);
                fflush(stdout);
                sg_bake_desc bd = {.photons = {.count = o.photons, .threads = o.threads}, .direct_samples = o.direct};
                t0 = omp_get_wtime();
                if (sg_bake_create(w[s], &bd, &b[s], &err) != SG_OK) {
                    status = fail("%zu points, %s: bake: %s", n, surf_name[surf], err.message);
                    break;
                }
                double bake_s = omp_get_wtime() - t0;
                sg_bake_stats bs;
                sg_bake_get_stats(b[s], &bs);
                printf("bake %.1f s (trace %.1f, gather + direct %.1f)\n", bake_s, bs.trace_seconds,
                       bake_s - bs.trace_seconds);
                for (int ri = 0; ri < N_RES; ri++)
                    rs[s * N_RES + ri] = (row){.points = n, .mat = mat, .surf = surf, .splats = splats,
                                               .world_s = world_s, .bake_s = bake_s, .trace_s = bs.trace_seconds,
                                               .gather_s = bake_s - bs.trace_seconds, .width = res_w[ri],
                                               .height = res_h[ri], .snap_off = {NAN, NAN}};
            }
            for (int ri = 0; ri < N_RES && status == 0; ri++) {
                walker k[N_SURF] = {{0}};
                for (int s = 0; s < o.surface_count; s++)
                    k[s] = (walker){.b = b[s], .w = w[s], .r = &rs[s * N_RES + ri]};
                if (walk_all(k, o.surface_count, disp, &path, stride, o.threads, &err) != SG_OK) {
                    status = fail("%zu points: frame: %s", n, err.message);
                    break;
                }
                for (int s = 0; s < o.surface_count && status == 0 && ri == 0; s++) {
                    char stem[512];
                    snprintf(stem, sizeof stem, PATH_DIR "/frame_%zu_%s_%s", n, mat_name[mat],
                             surf_name[o.surfaces[s]]);
                    if (snapshots(b[s], w[s], disp, &path, o.threads, stem, s == 0, snap_refs, &rs[s * N_RES],
                                  &err) != SG_OK)
                        status = fail("%zu points: snapshot: %s", n, err.message);
                }
            }
            if (status == 0) {
                print_head();
                for (int i = 0; i < o.surface_count * N_RES; i++)
                    print_row(&rs[i]);
                printf("\n");
                fflush(stdout);
                nrows += o.surface_count * N_RES;
            }
            for (int s = 0; s < o.surface_count; s++) {
                sg_bake_destroy(b[s]);
                sg_world_destroy(w[s]);
                sg_scene_file_free(&sf[s]);
            }
        }
    }
    rp.load1 = bench_load1();
    rp.rows = rows;
    rp.nrows = nrows;

    printf("\nsummary (%s, %d threads, load %.2f -> %.2f)\n", machine, o.threads, rp.load0, rp.load1);
    print_head();
    for (int i = 0; i < nrows; i++)
        print_row(&rows[i]);
    for (int s = 0; s < o.surface_count; s++) {
        int surf = o.surfaces[s];
        const row *a = find_row(&rp, 1000000, 0, surf, 512), *bb = find_row(&rp, 1000000, 0, surf, 1024);
        const row *ma = find_row(&rp, 1000000, 0, o.surfaces[0], 512);
        const row *mb = find_row(&rp, 1000000, 0, o.surfaces[0], 1024);
        if (a)
            printf("target 1M diffuse %s 512x512 >= 30 fps: %.1f fps (%s)", surf_label[surf], a->fps,
                   a->fps >= 30 ? "met" : "NOT met");
        if (a && s > 0 && ma)
            printf("; %s/%s mean %.2f", surf_label[surf], surf_label[o.surfaces[0]], a->mean_ms / ma->mean_ms);
        if (a)
            printf("\n");
        if (bb)
            printf("target 1M diffuse %s 1024x768 >= 15 fps: %.1f fps (%s)", surf_label[surf], bb->fps,
                   bb->fps >= 15 ? "met" : "NOT met");
        if (bb && s > 0 && mb)
            printf("; %s/%s mean %.2f", surf_label[surf], surf_label[o.surfaces[0]], bb->mean_ms / mb->mean_ms);
        if (bb)
            printf("\n");
    }
    for (int i = 0; i < nrows; i++)
        if (rows[i].width == res_w[0] && !isnan(rows[i].snap_off[0]))
            printf("%zu %s %s vs %s: pixels off by > %d/255: key 0 %.1f%%, key 54 %.1f%%\n", rows[i].points,
                   mat_name[rows[i].mat], surf_label[rows[i].surf], surf_label[o.surfaces[0]], SNAP_OFF,
                   rows[i].snap_off[0], rows[i].snap_off[1]);

    if (nrows > 0 && bench_make_dirs(o.out_dir)) {
        char p[4200];
        snprintf(p, sizeof p, "%s/bench_view.csv", o.out_dir);
        if (bench_write_file(p, write_csv, &rp) == 0)
            printf("bench_view: wrote %s\n", p);
        else
            status = 1;
        snprintf(p, sizeof p, "%s/bench_view.md", o.out_dir);
        if (bench_write_file(p, write_md, &rp) == 0)
            printf("bench_view: wrote %s\n", p);
        else
            status = 1;
    }
    sg_display_destroy(disp);
    sg_campath_free(&path);
    return status;
}
