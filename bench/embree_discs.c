/* embree_discs.c — Embree 3 oriented discs as bench_trace's reference (see
 * embree_discs.h).
 *
 * Invariants:
 *  1. Disc i is splat i: centre, radius and normal copied as floats,
 *     unchanged, so primID indexes the pointset (albedo lookup).
 *  2. A frame does the work sg_render_frame does per pixel in
 *     SG_SHADE_SIMPLE mode: one sg_camera_ray, one intersection, the same
 *     shading and the same tile schedule; only the intersector differs.
 *  3. the device, scene, build time and memory are embree_device.h's.
 */
#include "bench_common.h"
#include "embree_discs.h"

#include "embree_device.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <omp.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"

/* Same tile as render.c, so both renderers hand out the same work items. */
#define TILE 16

struct embree_discs {
    embree_device dev;             /* invariant 3                            */
    size_t count;                  /* discs                                  */
    float *ar, *ag, *ab;           /* albedo copies, sg_alloc_array          */
};

static sg_status embree__fail(embree_discs *e, sg_status st, sg_error *err, const char *what)
{
    sg_error_set(err, st, "embree_discs: %s%s%s", what, e->dev.error[0] ? ": " : "", e->dev.error);
    embree_discs_destroy(e);
    return st;
}

sg_status embree_discs_create(const sg_pointset *points, int threads, embree_discs **out,
                              sg_error *err)
{
    if (!points || !out || points->count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "embree_discs: a non-empty pointset is required");
    if (points->count > 0xFFFFFFF0u)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "embree_discs: %zu discs exceed 32-bit ids",
                            points->count);
    embree_discs *e = sg_calloc_array(1, sizeof *e);
    if (!e)
        return sg_error_set(err, SG_ERR_NOMEM, "embree_discs: out of memory");
    size_t n = points->count;
    e->count = n;
    e->ar = sg_alloc_array(n, sizeof(float));
    e->ag = sg_alloc_array(n, sizeof(float));
    e->ab = sg_alloc_array(n, sizeof(float));
    if (!e->ar || !e->ag || !e->ab) {
        embree_discs_destroy(e);
        return sg_error_set(err, SG_ERR_NOMEM, "embree_discs: out of memory for %zu albedos", n);
    }
    memcpy(e->ar, points->ar, n * sizeof(float));
    memcpy(e->ag, points->ag, n * sizeof(float));
    memcpy(e->ab, points->ab, n * sizeof(float));

    if (!embree_device_open(&e->dev, threads))
        return embree__fail(e, SG_ERR_UNSUPPORTED, err, "cannot make the device or scene");
    RTCGeometry g = rtcNewGeometry(e->dev.device, RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT);
    if (!g)
        return embree__fail(e, SG_ERR_UNSUPPORTED, err, "cannot make the geometry");
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                       4 * sizeof(float), n);
    float *nrm = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3,
                                         3 * sizeof(float), n);
    if (!v || !nrm) {
        rtcReleaseGeometry(g);
        return embree__fail(e, SG_ERR_NOMEM, err, "cannot allocate the disc buffers");
    }
    for (size_t i = 0; i < n; i++) { /* invariant 1 */
        v[4 * i + 0] = points->px[i];
        v[4 * i + 1] = points->py[i];
        v[4 * i + 2] = points->pz[i];
        v[4 * i + 3] = points->radius[i];
        nrm[3 * i + 0] = points->nx[i];
        nrm[3 * i + 1] = points->ny[i];
        nrm[3 * i + 2] = points->nz[i];
    }
    if (!embree_device_commit(&e->dev, g, RTC_BUILD_QUALITY_HIGH))
        return embree__fail(e, SG_ERR_UNSUPPORTED, err, "rtcCommitScene failed");
    *out = e;
    return SG_OK;
}

void embree_discs_destroy(embree_discs *e)
{
    if (!e)
        return;
    embree_device_close(&e->dev);
    sg_free(e->ar);
    sg_free(e->ag);
    sg_free(e->ab);
    sg_free(e);
}

const char *embree_discs_version(void) { return RTC_VERSION_STRING; }

double embree_discs_build_seconds(const embree_discs *e) { return e->dev.build_seconds; }
size_t embree_discs_memory_bytes(const embree_discs *e) { return e->dev.memory_bytes; }

/* One pixel: invariant 2 (render.c shade_pixel, SG_SHADE_SIMPLE). */
static int embree__pixel(const embree_discs *e, const sg_ray *r, float *rgb)
{
    struct RTCRayHit rh;
    embree_device_intersect1(&e->dev, r, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        rgb[0] = 0.1f;
        rgb[1] = 0.1f;
        rgb[2] = 0.12f;
        return 0;
    }
    sg_vec3 n = sg_v3_normalize(sg_v3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z));
    float k = 0.15f + 0.85f * fabsf(sg_v3_dot(n, r->dir));
    uint32_t id = rh.hit.primID;
    rgb[0] = e->ar[id] * k;
    rgb[1] = e->ag[id] * k;
    rgb[2] = e->ab[id] * k;
    return 1;
}

sg_status embree_discs_frame(const embree_discs *e, const sg_camera *cam, int width, int height,
                             int threads, sg_image *out, uint8_t *hit_mask,
                             embree_discs_stats *stats, sg_error *err)
{
    if (!e || !cam || !out || width <= 0 || height <= 0 || threads < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "embree_discs: bad frame arguments");
    sg_image img = {0};
    sg_status st = sg_image_alloc(&img, width, height, err);
    if (st != SG_OK)
        return st;
    const bench_tiles tiles = bench_tiles_of(width, height, TILE);
    uint64_t hits = 0;
    int nthreads = threads > 0 ? threads : omp_get_max_threads();
    double t0 = omp_get_wtime();
#pragma omp parallel for schedule(dynamic, 1) num_threads(nthreads) reduction(+ : hits)
    for (int t = 0; t < tiles.count; t++) {
        const bench_rect b = bench_tile(&tiles, t);
        for (int y = b.y0; y < b.y1; y++) {
            for (int x = b.x0; x < b.x1; x++) {
                sg_ray r = sg_camera_ray(cam, (float)x + 0.5f, (float)y + 0.5f, width, height);
                size_t pix = (size_t)y * (size_t)width + (size_t)x;
                int hit = embree__pixel(e, &r, img.data + 3 * pix);
                hits += (uint64_t)hit;
                if (hit_mask)
                    hit_mask[pix] = (uint8_t)hit;
            }
        }
    }
    double seconds = omp_get_wtime() - t0;
    *out = img;
    if (stats) {
        embree_discs_stats s = {0};
        s.rays = (uint64_t)width * (uint64_t)height;
        s.hits = hits;
        s.seconds = seconds;
        s.mrays_per_s = seconds > 0.0 ? (double)s.rays / seconds * 1e-6 : 0.0;
        *stats = s;
    }
    return SG_OK;
}
