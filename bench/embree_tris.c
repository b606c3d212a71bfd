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

/* One pixel: invariant 2. */
static int pixel(const embree_tris *e, const sg_ray *r, float *rgb, uint32_t *id, float *t)
{
    struct RTCRayHit rh;
    embree_device_intersect1(&e->dev, r, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        rgb[0] = 0.1f;
        rgb[1] = 0.1f;
        rgb[2] = 0.12f;
        *id = 0xFFFFFFFFu;
        *t = INFINITY;
        return 0;
    }
    const uint32_t *v = e->tris + 3 * (size_t)rh.hit.primID;
    const float *n0 = e->normals + 3 * (size_t)v[0], *n1 = e->normals + 3 * (size_t)v[1];
    const float *n2 = e->normals + 3 * (size_t)v[2];
    float u = rh.hit.u, w = rh.hit.v, b0 = 1.0f - u - w;
    sg_vec3 n = sg_v3_normalize(sg_v3(b0 * n0[0] + u * n1[0] + w * n2[0], b0 * n0[1] + u * n1[1] + w * n2[1],
                                      b0 * n0[2] + u * n1[2] + w * n2[2]));
    float k = 0.8f * (0.15f + 0.85f * fabsf(sg_v3_dot(n, r->dir)));
    rgb[0] = rgb[1] = rgb[2] = k;
    *id = rh.hit.primID;
    *t = rh.ray.tfar;
    return 1;
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
    int tiles_x = (width + TILE - 1) / TILE, tiles_y = (height + TILE - 1) / TILE;
    int tiles = tiles_x * tiles_y;
    uint64_t hits = 0;
    int nthreads = threads > 0 ? threads : omp_get_max_threads();
    double c0 = bench_cpu_seconds(), t0 = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 1) num_threads(nthreads) reduction(+ : hits)
    for (int t = 0; t < tiles; t++) {
        int x0 = (t % tiles_x) * TILE, y0 = (t / tiles_x) * TILE;
        int x1 = x0 + TILE < width ? x0 + TILE : width;
        int y1 = y0 + TILE < height ? y0 + TILE : height;
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++) {
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
    if (stats) {
        embree_tris_stats s = {0};
        s.rays = (uint64_t)width * (uint64_t)height;
        s.hits = hits;
        s.seconds = seconds;
        s.cpu_seconds = cpu;
        s.mrays_per_s = seconds > 0.0 ? (double)s.rays / seconds * 1e-6 : 0.0;
        *stats = s;
    }
    return SG_OK;
}
