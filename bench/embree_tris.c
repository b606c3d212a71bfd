/* embree_tris.c — Embree 3 triangles as bench_hybrid's reference (see
 * embree_tris.h).
 *
 * Invariants:
 *  1. Triangle i is the mesh's triangle i (primID indexes the mesh), and
 *     the vertex buffer is the mesh's positions, unchanged.
 *  2. A frame does per pixel what bench_hybrid's splatgi frame does: one
 *     sg_camera_ray, one intersection, the same shading and the same tile
 *     schedule; only the intersector differs.
 *  3. the device, scene, build time and memory are embree_device.h's.
 */
#include "bench_common.h"
#include "embree_tris.h"

#include "embree_device.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <omp.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "core/alloc.h"

#define TILE 16 /* the same tiles as bench_hybrid's splatgi frame */

struct embree_tris {
    embree_device dev;           /* invariant 3                             */
    size_t vertex_count;
    float *normals;              /* 3 per vertex, sg_alloc_array           */
    uint32_t *tris;              /* copy of the index buffer for shading   */
};

static sg_status fail(embree_tris *e, sg_status st, sg_error *err, const char *what)
{
    sg_error_set(err, st, "embree_tris: %s%s%s", what, e->dev.error[0] ? ": " : "", e->dev.error);
    embree_tris_destroy(e);
    return st;
}

sg_status embree_tris_create(const sg_mesh *m, const float *normals, embree_tris_quality quality, int threads,
                             embree_tris **out, sg_error *err)
{
    if (!m || !normals || !out || m->triangle_count == 0 || m->vertex_count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "embree_tris: a mesh with triangles and normals is required");
    embree_tris *e = sg_calloc_array(1, sizeof *e);
    if (!e)
        return sg_error_set(err, SG_ERR_NOMEM, "embree_tris: out of memory");
    e->vertex_count = m->vertex_count;
    e->normals = sg_alloc_array(m->vertex_count, 3 * sizeof(float));
    e->tris = sg_alloc_array(m->triangle_count, 3 * sizeof(uint32_t));
    if (!e->normals || !e->tris) {
        embree_tris_destroy(e);
        return sg_error_set(err, SG_ERR_NOMEM, "embree_tris: out of memory for the normals");
    }
    memcpy(e->normals, normals, m->vertex_count * 3 * sizeof(float));
    memcpy(e->tris, m->triangles, m->triangle_count * 3 * sizeof(uint32_t));
    if (!embree_device_open(&e->dev, threads))
        return fail(e, SG_ERR_UNSUPPORTED, err, "cannot make the device or scene");
    RTCGeometry g = rtcNewGeometry(e->dev.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!g)
        return fail(e, SG_ERR_UNSUPPORTED, err, "cannot make the geometry");
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                       m->vertex_count);
    uint32_t *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t),
                                           m->triangle_count);
    if (!v || !ix) {
        rtcReleaseGeometry(g);
        return fail(e, SG_ERR_NOMEM, err, "cannot allocate the buffers");
    }
    memcpy(v, m->positions, m->vertex_count * 3 * sizeof(float)); /* invariant 1 */
    memcpy(ix, m->triangles, m->triangle_count * 3 * sizeof(uint32_t));
    if (!embree_device_commit(&e->dev, g, quality == EMBREE_TRIS_MEDIUM ? RTC_BUILD_QUALITY_MEDIUM
                                                                          : RTC_BUILD_QUALITY_HIGH))
        return fail(e, SG_ERR_UNSUPPORTED, err, "rtcCommitScene failed");
    *out = e;
    return SG_OK;
}

void embree_tris_destroy(embree_tris *e)
{
    if (!e)
        return;
    embree_device_close(&e->dev);
    sg_free(e->normals);
    sg_free(e->tris);
    sg_free(e);
}

const char *embree_tris_version(void) { return RTC_VERSION_STRING; }
double embree_tris_build_seconds(const embree_tris *e) { return e->dev.build_seconds; }
size_t embree_tris_memory_bytes(const embree_tris *e) { return e->dev.memory_bytes; }

/* A frame's counters from its loop's totals. */
static embree_tris_stats frame_stats(int width, int height, uint64_t hits, double seconds, double cpu)
{
    embree_tris_stats s = {0};
    s.rays = (uint64_t)width * (uint64_t)height;
    s.hits = hits;
    s.seconds = seconds;
    s.cpu_seconds = cpu;
    s.mrays_per_s = seconds > 0.0 ? (double)s.rays / seconds * 1e-6 : 0.0;
    return s;
}

/* The shading of a hit on triangle prim at barycentrics (u, v) seen along
 * dir: invariant 2; a miss (prim RTC_INVALID_GEOMETRY_ID) gets the
 * background. Returns 1 for a hit. */
static int shade(const embree_tris *e, unsigned prim, float u, float w, sg_vec3 dir, float *rgb)
{
    if (prim == RTC_INVALID_GEOMETRY_ID) {
        rgb[0] = 0.1f;
        rgb[1] = 0.1f;
        rgb[2] = 0.12f;
        return 0;
    }
    const uint32_t *v = e->tris + 3 * (size_t)prim;
    const float *n0 = e->normals + 3 * (size_t)v[0], *n1 = e->normals + 3 * (size_t)v[1];
    const float *n2 = e->normals + 3 * (size_t)v[2];
    float b0 = 1.0f - u - w;
    sg_vec3 n = sg_v3_normalize(sg_v3(b0 * n0[0] + u * n1[0] + w * n2[0], b0 * n0[1] + u * n1[1] + w * n2[1],
                                      b0 * n0[2] + u * n1[2] + w * n2[2]));
    float k = 0.8f * (0.15f + 0.85f * fabsf(sg_v3_dot(n, dir)));
    rgb[0] = rgb[1] = rgb[2] = k;
    return 1;
}

/* One pixel: invariant 2. */
static int pixel(const embree_tris *e, const sg_ray *r, float *rgb, uint32_t *id, float *t)
{
    struct RTCRayHit rh;
    embree_device_intersect1(&e->dev, r, &rh);
    unsigned prim = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? RTC_INVALID_GEOMETRY_ID : rh.hit.primID;
    int hit = shade(e, prim, rh.hit.u, rh.hit.v, r->dir, rgb);
    *id = hit ? rh.hit.primID : 0xFFFFFFFFu;
    *t = hit ? rh.ray.tfar : INFINITY;
    return hit;
}

sg_status embree_tris_frame(const embree_tris *e, const sg_camera *cam, int width, int height, int threads,
                            sg_image *out, uint32_t *tri_ids, float *t_out, embree_tris_stats *stats,
                            sg_error *err)
{
    if (!e || !cam || !out || width <= 0 || height <= 0 || threads < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "embree_tris: bad frame arguments");
    sg_image img = {0};
    sg_status st = sg_image_alloc(&img, width, height, err);
    if (st != SG_OK)
        return st;
    const bench_tiles tiles = bench_tiles_of(width, height, TILE);
    uint64_t hits = 0;
    int nthreads = threads > 0 ? threads : omp_get_max_threads();
    double c0 = bench_cpu_seconds(), t0 = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 1) num_threads(nthreads) reduction(+ : hits)
    for (int t = 0; t < tiles.count; t++) {
        const bench_rect b = bench_tile(&tiles, t);
        for (int y = b.y0; y < b.y1; y++)
            for (int x = b.x0; x < b.x1; x++) {
                sg_ray r = sg_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, width, height);
                size_t pix = (size_t)y * (size_t)width + (size_t)x;
                uint32_t id;
                float tt;
                hits += (uint64_t)pixel(e, &r, img.data + 3 * pix, &id, &tt);
                if (tri_ids)
                    tri_ids[pix] = id;
                if (t_out)
                    t_out[pix] = tt;
            }
    }
    double seconds = omp_get_wtime() - t0, cpu = bench_cpu_seconds() - c0;
    *out = img;
    if (stats)
        *stats = frame_stats(width, height, hits, seconds, cpu);
    return SG_OK;
}

/* Traces rays[0..N) (N = 8 or 16, lanes with valid[l] = 0 ignored) as one
 * coherent packet through rtcIntersect8 or rtcIntersect16, whose ray-hit
 * structs have the same fields at different strides; prim[l] gets the hit
 * triangle (RTC_INVALID_GEOMETRY_ID: miss) and (u[l], v[l]) its
 * barycentrics. */
#define TRACE_PACKET(TYPE, CALL, N)                                                                     \
    do {                                                                                               \
        _Alignas(64) struct TYPE p;                                                                    \
        struct RTCIntersectContext ctx;                                                                \
        rtcInitIntersectContext(&ctx);                                                                 \
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;                                               \
        for (int l = 0; l < (N); l++) {                                                                \
            p.ray.org_x[l] = rays[l].org.x, p.ray.org_y[l] = rays[l].org.y, p.ray.org_z[l] = rays[l].org.z; \
            p.ray.dir_x[l] = rays[l].dir.x, p.ray.dir_y[l] = rays[l].dir.y, p.ray.dir_z[l] = rays[l].dir.z; \
            p.ray.tnear[l] = rays[l].tmin, p.ray.tfar[l] = rays[l].tmax, p.ray.time[l] = 0.0f;         \
            p.ray.mask[l] = 0xFFFFFFFFu, p.ray.id[l] = (unsigned)l, p.ray.flags[l] = 0;               \
            p.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID, p.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;  \
        }                                                                                              \
        CALL(valid, e->dev.scene, &ctx, &p);                                                           \
        for (int l = 0; l < (N); l++) {                                                                \
            prim[l] = p.hit.geomID[l] == RTC_INVALID_GEOMETRY_ID ? RTC_INVALID_GEOMETRY_ID : p.hit.primID[l]; \
            u[l] = p.hit.u[l], v[l] = p.hit.v[l];                                                      \
        }                                                                                              \
    } while (0)

static void trace_packet(const embree_tris *e, int n, const sg_ray *rays, const int *valid, unsigned *prim,
                         float *u, float *v)
{
    if (n == 16)
        TRACE_PACKET(RTCRayHit16, rtcIntersect16, 16);
    else
        TRACE_PACKET(RTCRayHit8, rtcIntersect8, 8);
}

sg_status embree_tris_frame_packets(const embree_tris *e, const sg_camera *cam, int width, int height,
                                    int threads, sg_image *out, int *width_out, embree_tris_stats *stats,
                                    sg_error *err)
{
    if (!e || !cam || !out || width <= 0 || height <= 0 || threads < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "embree_tris: bad frame arguments");
    const int n16 = rtcGetDeviceProperty(e->dev.device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0;
    const int n8 = rtcGetDeviceProperty(e->dev.device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) != 0;
    if (!n16 && !n8)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "embree_tris: the device traces neither 8- nor 16-wide packets");
    /* PW x PH pixels per packet of N rays */
    const int N = n16 ? 16 : 8, PW = 4, PH = N / PW;
    sg_image img = {0};
    sg_status st = sg_image_alloc(&img, width, height, err);
    if (st != SG_OK)
        return st;
    const bench_tiles tiles = bench_tiles_of(width, height, TILE);
    uint64_t hits = 0;
    int nthreads = threads > 0 ? threads : omp_get_max_threads();
    double c0 = bench_cpu_seconds(), t0 = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 1) num_threads(nthreads) reduction(+ : hits)
    for (int t = 0; t < tiles.count; t++) {
        const bench_rect b = bench_tile(&tiles, t);
        for (int py = b.y0; py < b.y1; py += PH)
            for (int px = b.x0; px < b.x1; px += PW) {
                sg_ray rays[16];
                _Alignas(64) int valid[16];
                unsigned prim[16];
                float u[16], v[16];
                for (int l = 0; l < N; l++) {
                    int x = px + l % PW, y = py + l / PW;
                    valid[l] = x < b.x1 && y < b.y1 ? -1 : 0;
                    rays[l] = sg_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, width, height);
                }
                trace_packet(e, N, rays, valid, prim, u, v);
                for (int l = 0; l < N; l++) {
                    if (!valid[l])
                        continue;
                    int x = px + l % PW, y = py + l / PW;
                    hits += (uint64_t)shade(e, prim[l], u[l], v[l], rays[l].dir,
                                            img.data + 3 * ((size_t)y * (size_t)width + (size_t)x));
                }
            }
    }
    double seconds = omp_get_wtime() - t0, cpu = bench_cpu_seconds() - c0;
    *out = img;
    if (width_out)
        *width_out = N;
    if (stats)
        *stats = frame_stats(width, height, hits, seconds, cpu);
    return SG_OK;
}
