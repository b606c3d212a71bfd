/* bench_hybrid — speed, memory and level-of-detail error of splatgi's
 * hybrid point/triangle hierarchy (surface/hybrid.h, Ye 2005) against
 * Embree 3 triangles on the same mesh and the same camera rays.
 *
 * For each scene — the scanned Stanford dragon (871k triangles), and a
 * scale scene made from it by cutting every triangle into split^2 (shared
 * edge vertices, so still watertight; split 5: 21.8M triangles) — and each
 * view (whole model; close-up of the head), it renders 512x512 frames, one
 * primary ray per pixel through the pixel centre, grey 0.8 x (0.15 + 0.85
 * |n.v|) with the vertex normals interpolated (the same normals in both
 * renderers), and reports side by side:
 *   embree         Embree 3 RTC_GEOMETRY_TYPE_TRIANGLE, build quality HIGH,
 *                  rtcIntersect1 per pixel (embree_tris.c);
 *   hybrid-stack   full detail (no footprint), ordered-stack traversal;
 *   hybrid-heap    full detail, Ye's heap (dragon only: a second build);
 *   hybrid lod L   the stack traversal with the pinhole footprint and
 *                  threshold L pixels, for every L of --lods;
 *   ... x16        (--packets) the stack and lod rows again through
 *                  sg_hybrid_intersect16 on 4x4 pixel blocks, as the
 *                  viewer traces camera rays, each alternating with
 *                  Embree's 16-ray packets (rtcIntersect16 on the same
 *                  blocks), the faster of Embree's two on coherent rays;
 *                  the frame must equal the single rays' pixel for pixel.
 * Every splatgi frame alternates with an Embree frame, so each row carries
 * its own Embree time measured under the same machine load, and the ratio
 * is fps / that Embree fps. Frames: one warm-up, then the best of N
 * (wall time) and the CPU time of that frame. Level-of-detail rows report
 * relMSE (metrics/image_metrics.h) against the hybrid's full-detail frame
 * of the same view. Full-detail rows report the fraction of pixels where
 * Embree and splatgi agree on hit-or-miss and on the triangle hit.
 *
 * Memory: splatgi's sg_hybrid_info.memory_bytes (everything it holds:
 * nodes, triangles, vertices, normals); Embree's memory monitor after the
 * commit (BVH and its copies of the vertex and index buffers) plus the
 * 12 bytes per vertex of float normals its frames interpolate.
 *
 * Output: a table on stdout, CSV (--csv) and markdown (--md), each written
 * to a temporary name and renamed. Programs are thin: the measuring is
 * library calls and Embree; this file times and reports them.
 */
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bench_common.h"
#include "core/alloc.h"
#include "core/cli.h"
#include "embree_tris.h"
#include "io/image.h"
#include "io/mesh.h"
#include "metrics/image_metrics.h"
#include "render/camera.h"
#include "surface/hybrid.h"

#define DEFAULT_MESH SG_SHARED_DATA_DIR "/meshes/stanford_dragon/dragon_vrip.ply"
#define QUICK_MESH SG_SHARED_DATA_DIR "/meshes/stanford_dragon/dragon_vrip_res3.ply"
#define IMAGE_SIZE 512
#define FOV_DEG 40.0f
#define TILE 16
#define MAX_LODS 16
#define MAX_ROWS 256

/* The views of bench_trace, so the figures read alike. */
static const float whole_view_dir[3] = {0.6f, -0.35f, -1.0f};
static const float closeup_box[6] = {0.0f, 0.55f, 0.30f, 0.30f, 1.0f, 1.0f};
#define CLOSEUP_MARGIN 0.8f
#define WHOLE_MARGIN 0.85f

static const char usage[] =
    "usage: bench_hybrid [options]\n"
    "Speed, memory and level-of-detail error of splatgi's hybrid point/triangle\n"
    "hierarchy against Embree 3 triangles on the same mesh and rays.\n"
    "  --mesh PATH       mesh (default: the full Stanford dragon, " DEFAULT_MESH ")\n"
    "  --split N         scale scene: every triangle cut into N^2 (default 5: 21.8M\n"
    "                    triangles from the dragon); 0 or 1: no scale scene\n"
    "  --lods A,B,...    level-of-detail thresholds in pixels (default 16,8,4,2,1,0;\n"
    "                    none: full detail only)\n"
    "  --views LIST      whole,closeup (default both)\n"
    "  --frames N        timed frames per row, best reported (default 5)\n"
    "  --threads N       OpenMP threads for builds and frames (default: all)\n"
    "  --leaf-max N      triangles per leaf, 1..8 (default 8)\n"
    "  --no-heap         skip the heap traversal rows\n"
    "  --embree-packets  also time Embree's packet traversal (rtcIntersect16/8 on\n"
    "                    4x4 / 4x2 pixel blocks) beside each full-detail row\n"
    "  --packets         after each hybrid-stack and lod row, a row ('x16') of the same\n"
    "                    frames through sg_hybrid_intersect16 on 4x4 pixel blocks (the\n"
    "                    viewer's camera rays), alternating with Embree's 16-ray packets\n"
    "                    (its ratio is to them); its pixels must equal the single rays'\n"
    "  --quick           smoke test: dragon_vrip_res3 (45k triangles), split 2, 2 frames\n"
    "  --csv PATH        write the rows as CSV\n"
    "  --md PATH         write the tables as markdown\n"
    "  --png-dir DIR     save the frames of the scale scene's whole view\n"
    "  --help            this text\n";

typedef struct options {
    const char *mesh;
    int split;
    float lods[MAX_LODS];
    int lod_count;
    int views[2];
    int frames, threads, leaf_max, heap, quick, embree_packets, packets;
    const char *csv, *md, *png_dir;
} options;

typedef struct row {
    char scene[32];
    size_t triangles;
    const char *view;
    char method[24];
    float lod;            /* -1: full detail, no footprint */
    double build_s, memory_mib, bytes_per_tri;
    double fps, mrays, cpu_ms;
    double embree_fps, ratio;
    double embree_cpu_ms, cpu_ratio; /* CPU time per frame: Embree's / ours */
    double packet_fps, packet_cpu_ms; /* Embree packets (--embree-packets); 0: not run */
    int packet_width;                 /* rays per Embree packet: 16 or 8 */
    double packet_agree;              /* share of pixels equal to the single-ray frame's */
    double pops, spheres, tris, lod_hit, hit;
    double rel_mse;       /* vs the hybrid full-detail frame; -1: n/a */
    double agree, same_tri; /* vs Embree (full detail); -1: n/a */
} row;

static row rows[MAX_ROWS];
static int nrows;

#define fail(...) bench_fail("bench_hybrid", __VA_ARGS__)

/* ---- options ----------------------------------------------------------- */

static int parse_lods(const char *s, options *o)
{
    char buf[256];
    if (strlen(s) >= sizeof buf)
        return 0;
    strcpy(buf, s);
    o->lod_count = 0;
    if (strcmp(s, "none") == 0)
        return 1;
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        char *end;
        errno = 0;
        float v = strtof(tok, &end);
        if (errno || end == tok || *end || !isfinite(v) || v < 0.0f || o->lod_count == MAX_LODS)
            return 0;
        o->lods[o->lod_count++] = v;
    }
    return o->lod_count > 0;
}


static int parse_options(int argc, char **argv, options *o)
{
    memset(o, 0, sizeof *o);
    o->mesh = DEFAULT_MESH;
    o->split = 5;
    parse_lods("16,8,4,2,1,0", o);
    o->views[0] = o->views[1] = 1;
    o->frames = 5;
    o->heap = 1;
    sg_error err;
    long v;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            fputs(usage, stdout);
            return 0;
        } else if (strcmp(a, "--quick") == 0) {
            o->quick = 1;
            o->mesh = QUICK_MESH;
            o->split = 2;
            o->frames = 2;
            continue;
        } else if (strcmp(a, "--embree-packets") == 0) {
            o->embree_packets = 1;
            continue;
        } else if (strcmp(a, "--packets") == 0) {
            o->packets = 1;
            continue;
        } else if (strcmp(a, "--no-heap") == 0) {
            o->heap = 0;
            continue;
        }
        if (!val)
            return fail("%s needs a value (see --help)", a);
        i++;
        if (strcmp(a, "--mesh") == 0) {
            o->mesh = val;
        } else if (strcmp(a, "--split") == 0) {
            if (sg_cli_long(a, val, 0, 16, &v, &err) != SG_OK)
                return fail("%s", err.message);
            o->split = (int)v;
        } else if (strcmp(a, "--lods") == 0) {
            if (!parse_lods(val, o))
                return fail("--lods '%s': want up to %d numbers >= 0, comma-separated", val, MAX_LODS);
        } else if (strcmp(a, "--views") == 0) {
            o->views[0] = strstr(val, "whole") != NULL;
            o->views[1] = strstr(val, "closeup") != NULL;
            if (!o->views[0] && !o->views[1])
                return fail("--views '%s': want whole, closeup or whole,closeup", val);
        } else if (strcmp(a, "--frames") == 0) {
            if (sg_cli_long(a, val, 1, 1000, &v, &err) != SG_OK)
                return fail("%s", err.message);
            o->frames = (int)v;
        } else if (strcmp(a, "--threads") == 0) {
            if (sg_cli_long(a, val, 1, 4096, &v, &err) != SG_OK)
                return fail("%s", err.message);
            o->threads = (int)v;
        } else if (strcmp(a, "--leaf-max") == 0) {
            if (sg_cli_long(a, val, 1, 8, &v, &err) != SG_OK)
                return fail("%s", err.message);
            o->leaf_max = (int)v;
        } else if (strcmp(a, "--csv") == 0) {
            o->csv = val;
        } else if (strcmp(a, "--md") == 0) {
            o->md = val;
        } else if (strcmp(a, "--png-dir") == 0) {
            o->png_dir = val;
        } else {
            return fail("unknown option %s (see --help)", a);
        }
    }
    if (o->threads == 0)
        o->threads = omp_get_max_threads();
    return -1;
}

/* ---- meshes ------------------------------------------------------------ */

/* Area-weighted vertex normals (what sg_hybrid computes itself when a mesh
 * has none), made here so that both renderers shade with the same ones. */
static sg_status add_normals(sg_mesh *m, sg_error *err)
{
    float *n = sg_calloc_array(m->vertex_count, 3 * sizeof(float));
    if (!n)
        return sg_error_set(err, SG_ERR_NOMEM, "out of memory for %zu normals", m->vertex_count);
    for (size_t t = 0; t < m->triangle_count; ++t) {
        const uint32_t *v = m->triangles + 3 * t;
        const float *a = m->positions + 3 * (size_t)v[0], *b = m->positions + 3 * (size_t)v[1];
        const float *c = m->positions + 3 * (size_t)v[2];
        sg_vec3 x = sg_v3_cross(sg_v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]), sg_v3(c[0] - a[0], c[1] - a[1], c[2] - a[2]));
        for (int k = 0; k < 3; ++k) {
            n[3 * (size_t)v[k]] += x.x;
            n[3 * (size_t)v[k] + 1] += x.y;
            n[3 * (size_t)v[k] + 2] += x.z;
        }
    }
    for (size_t i = 0; i < m->vertex_count; ++i) {
        sg_vec3 u = sg_v3_normalize(sg_v3(n[3 * i], n[3 * i + 1], n[3 * i + 2]));
        if (u.x == 0.0f && u.y == 0.0f && u.z == 0.0f)
            u = sg_v3(0, 1, 0); /* unused or cancelling: any unit vector */
        n[3 * i] = u.x;
        n[3 * i + 1] = u.y;
        n[3 * i + 2] = u.z;
    }
    sg_free(m->normals);
    m->normals = n;
    return SG_OK;
}

typedef struct edge_ref {
    uint64_t key; /* min vertex << 32 | max vertex */
    uint32_t slot; /* 3 * triangle + edge          */
} edge_ref;

static int edge_cmp(const void *a, const void *b)
{
    const edge_ref *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->slot < y->slot ? -1 : (x->slot > y->slot);
}

/* Every triangle cut into s^2 by dividing its edges into s parts. Points
 * on an edge are computed from the edge's lower vertex id towards the
 * higher, once per edge, and shared: the cut mesh is as watertight as the
 * input and has the same surface. */
static sg_status subdivide(const sg_mesh *in, int s, sg_mesh *out, sg_error *err)
{
    const size_t nt = in->triangle_count, ne_ref = 3 * nt;
    sg_mesh m = {0};
    edge_ref *refs = sg_alloc_array(ne_ref, sizeof *refs);
    uint32_t *edge_first = sg_alloc_array(ne_ref, sizeof *edge_first); /* per slot: first new vertex of its edge */
    if (!refs || !edge_first) {
        sg_free(refs);
        sg_free(edge_first);
        return sg_error_set(err, SG_ERR_NOMEM, "subdivide: out of memory");
    }
    for (size_t t = 0; t < nt; ++t)
        for (int k = 0; k < 3; ++k) {
            uint32_t a = in->triangles[3 * t + (size_t)k], b = in->triangles[3 * t + (size_t)((k + 1) % 3)];
            uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
            refs[3 * t + (size_t)k] = (edge_ref){((uint64_t)lo << 32) | hi, (uint32_t)(3 * t + (size_t)k)};
        }
    qsort(refs, ne_ref, sizeof *refs, edge_cmp);
    size_t edges = 0;
    for (size_t i = 0; i < ne_ref; ++i)
        edges += i == 0 || refs[i].key != refs[i - 1].key;
    const size_t per_edge = (size_t)(s - 1), per_tri = (size_t)(s - 1) * (size_t)(s - 2) / 2;
    m.vertex_count = in->vertex_count + edges * per_edge + nt * per_tri;
    m.triangle_count = nt * (size_t)s * (size_t)s;
    m.positions = sg_alloc_array(m.vertex_count, 3 * sizeof(float));
    m.triangles = sg_alloc_array(m.triangle_count, 3 * sizeof(uint32_t));
    if (!m.positions || !m.triangles || m.vertex_count >= 0xFFFFFFFFu) {
        sg_free(refs);
        sg_free(edge_first);
        sg_mesh_free(&m);
        return sg_error_set(err, SG_ERR_NOMEM, "subdivide: out of memory for %zu triangles", m.triangle_count);
    }
    memcpy(m.positions, in->positions, in->vertex_count * 3 * sizeof(float));
    size_t next = in->vertex_count;
    for (size_t i = 0; i < ne_ref; ++i) {
        if (i == 0 || refs[i].key != refs[i - 1].key) {
            uint32_t lo = (uint32_t)(refs[i].key >> 32), hi = (uint32_t)refs[i].key;
            const float *a = in->positions + 3 * (size_t)lo, *b = in->positions + 3 * (size_t)hi;
            for (int j = 1; j < s; ++j) {
                float f = (float)j / (float)s;
                for (int c = 0; c < 3; ++c)
                    m.positions[3 * (next + (size_t)j - 1) + (size_t)c] = a[c] + (b[c] - a[c]) * f;
            }
            next += per_edge;
        }
        edge_first[refs[i].slot] = (uint32_t)(next - per_edge);
    }
    sg_free(refs);
    uint32_t grid[(16 + 1) * (16 + 1)];
    size_t tout = 0;
    for (size_t t = 0; t < nt; ++t) {
        const uint32_t *v = in->triangles + 3 * t;
        const float *A = in->positions + 3 * (size_t)v[0], *B = in->positions + 3 * (size_t)v[1];
        const float *C = in->positions + 3 * (size_t)v[2];
#define G(i, j) grid[(i) * (s + 1) + (j)]
        /* P(i, j) = A + (B - A) i / s + (C - A) j / s. */
        for (int i = 0; i <= s; ++i)
            for (int j = 0; i + j <= s; ++j) {
                uint32_t id;
                if (i == 0 && j == 0) id = v[0];
                else if (i == s) id = v[1];
                else if (j == s) id = v[2];
                else if (j == 0 || i == 0 || i + j == s) {
                    /* On edge k from corner v[k] to v[k+1], at step q of s. */
                    int k = j == 0 ? 0 : (i + j == s ? 1 : 2);
                    int q = k == 0 ? i : (k == 1 ? j : s - j);
                    uint32_t a = v[k], b = v[(k + 1) % 3];
                    uint32_t first = edge_first[3 * t + (size_t)k];
                    id = first + (uint32_t)(a < b ? q - 1 : s - q - 1);
                } else {
                    id = (uint32_t)next++;
                    for (int c = 0; c < 3; ++c)
                        m.positions[3 * (size_t)id + (size_t)c] =
                            A[c] + (B[c] - A[c]) * ((float)i / (float)s) + (C[c] - A[c]) * ((float)j / (float)s);
                }
                G(i, j) = id;
            }
        for (int i = 0; i < s; ++i)
            for (int j = 0; i + j < s; ++j) {
                uint32_t *o = m.triangles + 3 * tout++;
                o[0] = G(i, j), o[1] = G(i + 1, j), o[2] = G(i, j + 1);
                if (i + j < s - 1) {
                    o = m.triangles + 3 * tout++;
                    o[0] = G(i + 1, j), o[1] = G(i + 1, j + 1), o[2] = G(i, j + 1);
                }
            }
#undef G
    }
    sg_free(edge_first);
    if (tout != m.triangle_count || next != m.vertex_count) {
        sg_mesh_free(&m);
        return sg_error_set(err, SG_ERR_INVALID_ARG, "subdivide: counted %zu triangles and %zu vertices, made %zu and %zu",
                            m.triangle_count, m.vertex_count, tout, next);
    }
    *out = m;
    return SG_OK;
}

typedef struct report {
    const char *machine, *mesh;
    int threads, nproc, frames, split;
    double embree_mib[2]; /* per scene: Embree's memory, MiB (BVH, buffers, normals) */
    double load[2];       /* 1-minute load average at the start and the end */
} report;

static report rep;

static int scene_index(const char *label) { return strcmp(label, "dragon") == 0 ? 0 : 1; }

/* ---- frames ------------------------------------------------------------ */

typedef struct frame_stats {
    double seconds, cpu;
    sg_hybrid_stats st;
} frame_stats;

static void shade(const sg_ray *r, int hit, const sg_hybrid_hit *h, float rgb[3])
{
    if (hit) {
        float k = 0.8f * (0.15f + 0.85f * fabsf(sg_v3_dot(h->ns, r->dir)));
        rgb[0] = rgb[1] = rgb[2] = k;
    } else {
        rgb[0] = 0.1f;
        rgb[1] = 0.1f;
        rgb[2] = 0.12f;
    }
}

/* The rows of a tile's 4x4 blocks through sg_hybrid_intersect16, as the
 * viewer traces camera rays (tiles are whole blocks: 512 = 32 x 16). */
static void hybrid_blocks(const sg_hybrid *h, const sg_camera *cam, const sg_footprint *fp, bench_rect b,
                          sg_image *img, uint32_t *tri_ids, sg_hybrid_stats *stats)
{
    for (int by = b.y0; by < b.y1; by += 4)
        for (int bx = b.x0; bx < b.x1; bx += 4) {
            sg_ray rays[16];
            sg_footprint fps[16];
            sg_hybrid_hit hits[16];
            const unsigned mask = sg_camera_block16(cam, bx, by, IMAGE_SIZE, IMAGE_SIZE, rays);
            for (int i = 0; fp && i < 16; i++)
                fps[i] = *fp;
            unsigned hit = sg_hybrid_intersect16(h, rays, mask, fp ? fps : NULL, hits, stats);
            for (int i = 0; i < 16; i++) {
                if (!(mask >> i & 1u))
                    continue;
                size_t pix = (size_t)(by + (i >> 2)) * IMAGE_SIZE + (size_t)(bx + (i & 3));
                shade(&rays[i], (int)(hit >> i & 1u), &hits[i], img->data + 3 * pix);
                if (tri_ids)
                    tri_ids[pix] = hits[i].triangle;
            }
        }
}

/* The splatgi frame: bench/embree_tris.c's loop with sg_hybrid_intersect
 * (packets: 4x4 blocks through sg_hybrid_intersect16). */
static sg_status hybrid_frame(const sg_hybrid *h, const sg_camera *cam, const sg_footprint *fp, int threads,
                              int packets, sg_image *out, uint32_t *tri_ids, frame_stats *fs, sg_error *err)
{
    sg_image img = {0};
    sg_status st = sg_image_alloc(&img, IMAGE_SIZE, IMAGE_SIZE, err);
    if (st != SG_OK)
        return st;
    const bench_tiles tiles = bench_tiles_of(IMAGE_SIZE, IMAGE_SIZE, TILE);
    sg_hybrid_stats total = {0};
    double c0 = bench_cpu_seconds(), t0 = omp_get_wtime();
#pragma omp parallel num_threads(threads)
    {
        sg_hybrid_stats local = {0};
#pragma omp for schedule(dynamic, 1)
        for (int t = 0; t < tiles.count; t++) {
            const bench_rect b = bench_tile(&tiles, t);
            if (packets) {
                hybrid_blocks(h, cam, fp, b, &img, tri_ids, &local);
                continue;
            }
            for (int y = b.y0; y < b.y1; y++)
                for (int x = b.x0; x < b.x1; x++) {
                    sg_ray r = sg_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, IMAGE_SIZE, IMAGE_SIZE);
                    size_t pix = (size_t)y * IMAGE_SIZE + (size_t)x;
                    sg_hybrid_hit hit;
                    int found = sg_hybrid_intersect(h, &r, fp, &hit, &local);
                    shade(&r, found, &hit, img.data + 3 * pix);
                    if (tri_ids)
                        tri_ids[pix] = hit.triangle;
                }
        }
#pragma omp critical
        sg_hybrid_stats_add(&total, &local);
    }
    fs->seconds = omp_get_wtime() - t0;
    fs->cpu = bench_cpu_seconds() - c0;
    fs->st = total;
    *out = img;
    return SG_OK;
}

/* ---- measuring --------------------------------------------------------- */

typedef struct scene_ctx {
    const char *label;
    size_t triangles;
    const embree_tris *e;
    const options *o;
} scene_ctx;

/* One splatgi configuration on one view, alternating with Embree frames.
 * keep (may be NULL) receives splatgi's last frame. single (packet rows
 * only): the same configuration's single-ray frame, which the packets'
 * first frame must equal pixel for pixel (sg_hybrid_intersect16 promises
 * the single rays' bits). */
static sg_status measure(const scene_ctx *sc, const sg_hybrid *h, const char *method, const sg_camera *cam,
                         const char *view, float lod, const sg_image *full, uint32_t *ids_a, uint32_t *ids_b,
                         const sg_image *single, sg_image *keep, sg_error *err)
{
    const options *o = sc->o;
    const int packets = single != NULL;
    sg_footprint fp = sg_footprint_pinhole(cam->tan_half_fov, IMAGE_SIZE, lod);
    const sg_footprint *fpp = lod >= 0.0f ? &fp : NULL;
    frame_stats best = {0};
    embree_tris_stats ebest = {0}, pbest = {0};
    int pwidth = 0;
    double packet_agree = -1.0;
    sg_image img = {0};
    for (int f = 0; f <= o->frames; f++) {
        frame_stats fs;
        sg_image_free(&img);
        sg_status st = hybrid_frame(h, cam, fpp, o->threads, packets, &img, f == 0 ? ids_a : NULL, &fs, err);
        if (st != SG_OK)
            return st;
        if (packets && f == 0) {
            size_t differ = 0, n = 3 * (size_t)IMAGE_SIZE * IMAGE_SIZE;
            for (size_t i = 0; i < n; ++i)
                differ += img.data[i] != single->data[i];
            if (differ) {
                sg_image_free(&img);
                return sg_error_set(err, SG_ERR_INVALID_ARG,
                                    "%s %s: %zu channel values of the 4x4 packets' frame differ from the single "
                                    "rays'", view, method, differ);
            }
        }
        if (f > 0 && (best.seconds == 0.0 || fs.seconds < best.seconds))
            best = fs;
        sg_image eimg = {0};
        embree_tris_stats es;
        if (packets)
            st = embree_tris_frame_packets(sc->e, cam, IMAGE_SIZE, IMAGE_SIZE, o->threads, &eimg, &pwidth, &es, err);
        else
            st = embree_tris_frame(sc->e, cam, IMAGE_SIZE, IMAGE_SIZE, o->threads, &eimg, f == 0 ? ids_b : NULL,
                                   NULL, &es, err);
        if (st != SG_OK) {
            sg_image_free(&img);
            return st;
        }
        if (f > 0 && (ebest.seconds == 0.0 || es.seconds < ebest.seconds))
            ebest = es;
        if (o->embree_packets && lod < 0.0f && !packets) {
            sg_image pimg = {0};
            st = embree_tris_frame_packets(sc->e, cam, IMAGE_SIZE, IMAGE_SIZE, o->threads, &pimg, &pwidth, &es,
                                           err);
            if (st != SG_OK) {
                sg_image_free(&eimg);
                sg_image_free(&img);
                return st;
            }
            if (f == 0) { /* the packets' image against rtcIntersect1's: pixels within 1e-4 */
                size_t same = 0, n = (size_t)IMAGE_SIZE * IMAGE_SIZE;
                for (size_t i = 0; i < 3 * n; i += 3)
                    same += fabsf(pimg.data[i] - eimg.data[i]) <= 1e-4f;
                packet_agree = (double)same / (double)n;
            }
            sg_image_free(&pimg);
            if (f > 0 && (pbest.seconds == 0.0 || es.seconds < pbest.seconds))
                pbest = es;
        }
        sg_image_free(&eimg);
    }
    row *r = &rows[nrows++];
    memset(r, 0, sizeof *r);
    snprintf(r->scene, sizeof r->scene, "%s", sc->label);
    r->triangles = sc->triangles;
    r->view = view;
    snprintf(r->method, sizeof r->method, "%s", method);
    r->lod = lod;
    sg_hybrid_info info;
    sg_hybrid_get_info(h, &info);
    r->build_s = info.build_seconds;
    r->memory_mib = (double)info.memory_bytes / 1048576.0;
    r->bytes_per_tri = info.bytes_per_triangle;
    const double rays = (double)IMAGE_SIZE * IMAGE_SIZE;
    r->fps = 1.0 / best.seconds;
    r->mrays = rays / best.seconds * 1e-6;
    r->cpu_ms = best.cpu * 1e3;
    r->embree_fps = 1.0 / ebest.seconds;
    r->ratio = r->fps / r->embree_fps;
    r->embree_cpu_ms = ebest.cpu_seconds * 1e3;
    r->cpu_ratio = r->embree_cpu_ms / r->cpu_ms;
    if (pbest.seconds > 0.0) {
        r->packet_fps = 1.0 / pbest.seconds;
        r->packet_cpu_ms = pbest.cpu_seconds * 1e3;
        r->packet_width = pwidth;
        r->packet_agree = packet_agree;
    }
    r->pops = (double)best.st.pops / rays;
    r->spheres = (double)best.st.spheres / rays;
    r->tris = (double)best.st.triangles / rays;
    r->lod_hit = (double)best.st.lod_hits / rays;
    r->hit = (double)best.st.hits / rays;
    r->rel_mse = -1.0;
    r->agree = r->same_tri = -1.0;
    if (full && lod >= 0.0f) {
        sg_image_metrics m;
        if (sg_image_compare(&img, full, &m, NULL, err) != SG_OK) {
            sg_image_free(&img);
            return err->status;
        }
        r->rel_mse = m.rel_mse;
    }
    if (lod < 0.0f && ids_a && ids_b) {
        size_t same_hit = 0, same_tri = 0, n = (size_t)IMAGE_SIZE * IMAGE_SIZE;
        for (size_t i = 0; i < n; ++i) {
            same_hit += (ids_a[i] == SG_INVALID_ID) == (ids_b[i] == 0xFFFFFFFFu);
            same_tri += ids_a[i] == ids_b[i];
        }
        r->agree = (double)same_hit / (double)n;
        r->same_tri = (double)same_tri / (double)n;
    }
    printf("  %-8s %-7s %-16s: %6.2f fps %6.3f Mrays/s cpu %6.1f ms | Embree%s %6.2f fps cpu %6.1f ms | ratio %.3f "
           "cpu ratio %.3f | pops %.1f tris %.1f lodhit %.3f hit %.3f",
           r->scene, view, method, r->fps, r->mrays, r->cpu_ms, packets ? " x16" : "", r->embree_fps, r->embree_cpu_ms, r->ratio,
           r->cpu_ratio, r->pops, r->tris, r->lod_hit, r->hit);
    if (lod >= 0.0f)
        printf(" (lod %g)", (double)lod);
    if (r->rel_mse >= 0.0)
        printf(" relMSE %.5f", r->rel_mse);
    if (r->agree >= 0.0)
        printf(" agree %.5f same-tri %.5f", r->agree, r->same_tri);
    if (r->packet_fps > 0.0)
        printf(" | Embree %d-ray packets %6.2f fps cpu %6.1f ms (same pixels as single rays: %.5f)", r->packet_width,
               r->packet_fps, r->packet_cpu_ms, r->packet_agree);
    printf("\n");
    fflush(stdout);
    if (keep) {
        sg_image_free(keep);
        *keep = img;
    } else {
        sg_image_free(&img);
    }
    return SG_OK;
}

static sg_status make_cameras(sg_aabb b, sg_camera cams[2], sg_error *err)
{
    sg_vec3 up = sg_v3(0, 1, 0), dir = sg_v3(whole_view_dir[0], whole_view_dir[1], whole_view_dir[2]);
    sg_status st = sg_camera_frame(b, dir, up, FOV_DEG, 1.0f, WHOLE_MARGIN, &cams[0], err);
    if (st != SG_OK)
        return st;
    sg_vec3 ext = sg_v3_sub(b.hi, b.lo);
    const float *f = closeup_box;
    sg_aabb part = {sg_v3_add(b.lo, sg_v3_mul(ext, sg_v3(f[0], f[1], f[2]))),
                    sg_v3_add(b.lo, sg_v3_mul(ext, sg_v3(f[3], f[4], f[5])))};
    return sg_camera_frame(part, dir, up, FOV_DEG, 1.0f, CLOSEUP_MARGIN, &cams[1], err);
}

static const char *const view_names[2] = {"whole", "closeup"};

/* All rows of one scene. */
static int run_scene(const char *label, const sg_mesh *mesh, const sg_camera cams[2], int with_heap,
                     const options *o, const char *png_dir)
{
    sg_error err;
    printf("\n%s: %zu triangles, %zu vertices\n", label, mesh->triangle_count, mesh->vertex_count);
    embree_tris *e = NULL;
    if (embree_tris_create(mesh, mesh->normals, EMBREE_TRIS_HIGH, o->threads, &e, &err) != SG_OK)
        return fail("%s", err.message);
    size_t ebytes = embree_tris_memory_bytes(e) + mesh->vertex_count * 3 * sizeof(float);
    printf("  Embree: build %.2f s, %.1f MiB (BVH and buffers %.1f MiB + float normals %.1f MiB), %.1f B/triangle\n",
           embree_tris_build_seconds(e), (double)ebytes / 1048576.0,
           (double)embree_tris_memory_bytes(e) / 1048576.0,
           (double)(mesh->vertex_count * 12) / 1048576.0, (double)ebytes / (double)mesh->triangle_count);
    fflush(stdout);
    sg_hybrid *hs = NULL, *hh = NULL;
    sg_hybrid_desc d = {.threads = o->threads, .leaf_max = o->leaf_max, .name = label};
    if (sg_hybrid_create(&d, mesh, &hs, &err) != SG_OK) {
        embree_tris_destroy(e);
        return fail("%s", err.message);
    }
    sg_hybrid_info info;
    sg_hybrid_get_info(hs, &info);
    printf("  splatgi hybrid: build %.2f s, %.1f MiB, %.1f B/triangle (nodes %.1f, triangles %.1f, vertices %.1f, "
           "normals %.1f), %zu nodes, %zu leaves, width %d, leaf max %d, depth %d; memory ratio to Embree %.3f\n",
           info.build_seconds, (double)info.memory_bytes / 1048576.0, info.bytes_per_triangle,
           (double)info.memory_nodes / (double)info.triangle_count,
           (double)info.memory_triangles / (double)info.triangle_count,
           (double)info.memory_vertices / (double)info.triangle_count,
           (double)info.memory_normals / (double)info.triangle_count, info.node_count, info.leaf_count, info.width,
           info.leaf_max, info.depth, (double)info.memory_bytes / (double)ebytes);
    fflush(stdout);
    if (with_heap) {
        d.traversal = SG_HYBRID_TRAVERSE_HEAP;
        if (sg_hybrid_create(&d, mesh, &hh, &err) != SG_OK) {
            sg_hybrid_destroy(hs);
            embree_tris_destroy(e);
            return fail("%s", err.message);
        }
    }
    scene_ctx sc = {label, mesh->triangle_count, e, o};
    rep.embree_mib[scene_index(label)] = (double)ebytes / 1048576.0;
    size_t npix = (size_t)IMAGE_SIZE * IMAGE_SIZE;
    uint32_t *ids_a = sg_alloc_array(npix, sizeof *ids_a), *ids_b = sg_alloc_array(npix, sizeof *ids_b);
    int status = 0;
    if (!ids_a || !ids_b)
        status = fail("out of memory");
    for (int v = 0; v < 2 && status == 0; v++) {
        if (!o->views[v])
            continue;
        sg_image full = {0}, img = {0};
        if (measure(&sc, hs, "hybrid-stack", &cams[v], view_names[v], -1.0f, NULL, ids_a, ids_b, NULL, &full,
                    &err) != SG_OK) {
            status = fail("%s", err.message);
            break;
        }
        if (o->packets && measure(&sc, hs, "hybrid-stack x16", &cams[v], view_names[v], -1.0f, NULL, NULL, NULL,
                                  &full, NULL, &err) != SG_OK) {
            status = fail("%s", err.message);
            break;
        }
        if (hh && measure(&sc, hh, "hybrid-heap", &cams[v], view_names[v], -1.0f, NULL, ids_a, ids_b, NULL, NULL,
                          &err) != SG_OK) {
            status = fail("%s", err.message);
            break;
        }
        for (int li = 0; li < o->lod_count && status == 0; li++) {
            if (measure(&sc, hs, "hybrid-lod", &cams[v], view_names[v], o->lods[li], &full, NULL, NULL, NULL, &img,
                        &err) != SG_OK) {
                status = fail("%s", err.message);
                break;
            }
            if (o->packets && measure(&sc, hs, "hybrid-lod x16", &cams[v], view_names[v], o->lods[li], &full, NULL,
                                      NULL, &img, NULL, &err) != SG_OK) {
                status = fail("%s", err.message);
                break;
            }
            if (png_dir && v == 0) {
                char path[4096];
                snprintf(path, sizeof path, "%s/hybrid_%s_lod%g.png", png_dir, label, (double)o->lods[li]);
                if (sg_image_write_png(&img, path, 1.0f, &err) != SG_OK)
                    status = fail("%s", err.message);
            }
        }
        if (png_dir && v == 0 && status == 0) {
            char path[4096];
            snprintf(path, sizeof path, "%s/hybrid_%s_full.png", png_dir, label);
            if (sg_image_write_png(&full, path, 1.0f, &err) != SG_OK)
                status = fail("%s", err.message);
        }
        sg_image_free(&full);
        sg_image_free(&img);
    }
    sg_free(ids_a);
    sg_free(ids_b);
    sg_hybrid_destroy(hs);
    sg_hybrid_destroy(hh);
    embree_tris_destroy(e);
    return status;
}

/* ---- reports ----------------------------------------------------------- */

static void write_csv(FILE *f, const void *ctx)
{
    (void)ctx;
    fputs("machine,threads,scene,triangles,view,method,lod,build_s,memory_mib,bytes_per_triangle,embree_memory_mib,"
          "memory_ratio,fps,mrays_s,cpu_ms,embree_fps,ratio,pops,spheres,tris,lod_hit,hit,rel_mse,agree,same_tri\n",
          f);
    for (int i = 0; i < nrows; i++) {
        const row *r = &rows[i];
        int s = scene_index(r->scene);
        fprintf(f, "\"%s\",%d,%s,%zu,%s,%s,%g,%.3f,%.2f,%.2f,%.2f,%.4f,%.3f,%.4f,%.2f,%.3f,%.4f,%.3f,%.3f,%.3f,%.5f,"
                   "%.5f,%.6f,%.5f,%.5f\n",
                rep.machine, rep.threads, r->scene, r->triangles, r->view, r->method, (double)r->lod, r->build_s,
                r->memory_mib, r->bytes_per_tri, rep.embree_mib[s], r->memory_mib / rep.embree_mib[s], r->fps,
                r->mrays, r->cpu_ms, r->embree_fps, r->ratio, r->pops, r->spheres, r->tris, r->lod_hit, r->hit,
                r->rel_mse, r->agree, r->same_tri);
    }
}

static void write_md(FILE *f, const void *ctx)
{
    (void)ctx;
    fprintf(f, "# Hybrid point/triangle hierarchy vs Embree 3 triangles\n\n");
    fprintf(f, "Written by `build/bench/bench_hybrid --md docs/bench_hybrid.md` (bench/bench_hybrid.c); see docs/hybrid.md.\n\n");
    fprintf(f, "Machine: %s, nproc %d; %d threads used; load average (1 min) %.2f at the start, %.2f at the end. "
               "Embree %s (build quality HIGH).\n",
            rep.machine, rep.nproc, rep.threads, rep.load[0], rep.load[1], embree_tris_version());
    const char *mesh = strstr(rep.mesh, "shared/data/");
    fprintf(f, "Mesh: %s%s; scale scene: every triangle cut into %d^2. Frames 512x512, one primary ray per pixel, "
               "best of %d after one warm-up, each splatgi frame alternating with an Embree frame (the Embree "
               "fps column is that row's own).\n\n",
            mesh ? "../" : "", mesh ? mesh : rep.mesh, rep.split, rep.frames);
    fprintf(f, "| scene | triangles | view | method | lod px | build s | MiB | B/tri | Embree MiB | mem ratio | fps | "
               "Mrays/s | CPU ms | Embree fps | ratio | pops/ray | tris/ray | LOD hits | relMSE vs full | agree | "
               "same tri |\n");
    fprintf(f, "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (int i = 0; i < nrows; i++) {
        const row *r = &rows[i];
        int s = scene_index(r->scene);
        char lod[16], rel[24], agree[16], same[16];
        snprintf(lod, sizeof lod, r->lod < 0.0f ? "full" : "%g", (double)r->lod);
        snprintf(rel, sizeof rel, r->rel_mse < 0.0 ? "" : "%.5f", r->rel_mse);
        snprintf(agree, sizeof agree, r->agree < 0.0 ? "" : "%.4f", r->agree);
        snprintf(same, sizeof same, r->same_tri < 0.0 ? "" : "%.4f", r->same_tri);
        fprintf(f, "| %s | %zu | %s | %s | %s | %.2f | %.1f | %.1f | %.1f | %.3f | %.2f | %.3f | %.1f | %.2f | %.3f | "
                   "%.1f | %.1f | %.3f | %s | %s | %s |\n",
                r->scene, r->triangles, r->view, r->method, lod, r->build_s, r->memory_mib, r->bytes_per_tri,
                rep.embree_mib[s], r->memory_mib / rep.embree_mib[s], r->fps, r->mrays, r->cpu_ms, r->embree_fps,
                r->ratio, r->pops, r->tris, r->lod_hit, rel, agree, same);
    }
    for (int i = 0; i < nrows; i++)
        if (strstr(rows[i].method, "x16")) {
            fprintf(f, "\nRows *x16* (`--packets`): 4x4 blocks through sg_hybrid_intersect16 (pixels equal to the "
                       "single rays'; pops and sphere tests counted once a block), and their Embree fps is "
                       "rtcIntersect16's on the same blocks.\n");
            break;
        }
    int packets = 0;
    for (int i = 0; i < nrows; i++)
        packets += rows[i].packet_fps > 0.0;
    if (!packets)
        return;
    fprintf(f, "\nEmbree's packet traversal (`--embree-packets`): the same frames through rtcIntersect16 (4x4 pixels) "
               "or rtcIntersect8 (4x2), timed in the same alternation; *single* is the row's rtcIntersect1 frame.\n\n");
    fprintf(f, "| scene | view | method | splatgi fps | Embree single fps | Embree packet fps | packet width | "
               "packet / single | splatgi / packet | pixels as single |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n");
    for (int i = 0; i < nrows; i++) {
        const row *r = &rows[i];
        if (r->packet_fps > 0.0)
            fprintf(f, "| %s | %s | %s | %.2f | %.2f | %.2f | %d | %.2f | %.3f | %.5f |\n", r->scene, r->view,
                    r->method, r->fps, r->embree_fps, r->packet_fps, r->packet_width, r->packet_fps / r->embree_fps,
                    r->fps / r->packet_fps, r->packet_agree);
    }
}

int main(int argc, char **argv)
{
    options o;
    int rc = parse_options(argc, argv, &o);
    if (rc >= 0)
        return rc;
    if (access(o.mesh, R_OK) != 0) {
        printf("bench_hybrid: skipped: mesh %s not found (pass --mesh PATH)\n", o.mesh);
        return 0;
    }
    char machine[256];
    bench_cpu_model(machine, sizeof machine);
    int nproc = (int)sysconf(_SC_NPROCESSORS_ONLN);
    printf("bench_hybrid: machine %s, nproc %d, threads %d, Embree %s, %dx%d frames, best of %d\n", machine, nproc,
           o.threads, embree_tris_version(), IMAGE_SIZE, IMAGE_SIZE, o.frames);
    rep = (report){.machine = machine, .mesh = o.mesh, .threads = o.threads, .nproc = nproc, .frames = o.frames,
                   .split = o.split, .load = {bench_load1(), NAN}};

    sg_error err;
    sg_mesh mesh = {0};
    double t0 = omp_get_wtime();
    if (sg_mesh_read(o.mesh, &mesh, &err) != SG_OK)
        return fail("%s", err.message);
    if (mesh.triangle_count == 0)
        return fail("%s: no triangles", o.mesh);
    if (add_normals(&mesh, &err) != SG_OK)
        return fail("%s", err.message);
    printf("bench_hybrid: %s: %zu vertices, %zu triangles, read in %.2f s\n", o.mesh, mesh.vertex_count,
           mesh.triangle_count, omp_get_wtime() - t0);
    sg_aabb bounds = sg_aabb_empty();
    for (size_t i = 0; i < mesh.vertex_count; i++)
        bounds = sg_aabb_grow(bounds, sg_v3(mesh.positions[3 * i], mesh.positions[3 * i + 1], mesh.positions[3 * i + 2]));
    sg_camera cams[2];
    if (make_cameras(bounds, cams, &err) != SG_OK)
        return fail("camera: %s", err.message);

    int status = run_scene("dragon", &mesh, cams, o.heap, &o, NULL);
    if (status == 0 && o.split > 1) {
        sg_mesh big = {0};
        t0 = omp_get_wtime();
        if (subdivide(&mesh, o.split, &big, &err) != SG_OK || add_normals(&big, &err) != SG_OK) {
            status = fail("%s", err.message);
        } else {
            sg_mesh_free(&mesh); /* only the scale scene from here on */
            printf("\nbench_hybrid: scale scene: split %d: %zu triangles, %zu vertices, made in %.1f s\n", o.split,
                   big.triangle_count, big.vertex_count, omp_get_wtime() - t0);
            char label[32];
            snprintf(label, sizeof label, "dragon-x%d", o.split * o.split);
            status = run_scene(label, &big, cams, 0, &o, o.png_dir);
        }
        sg_mesh_free(&big);
    }
    sg_mesh_free(&mesh);
    rep.load[1] = bench_load1();
    printf("bench_hybrid: load average %.2f at the start, %.2f at the end\n", rep.load[0], rep.load[1]);
    if (o.csv && bench_write_file(o.csv, write_csv, NULL) == 0)
        printf("bench_hybrid: wrote %s\n", o.csv);
    if (o.md && bench_write_file(o.md, write_md, NULL) == 0)
        printf("bench_hybrid: wrote %s\n", o.md);
    return status;
}
