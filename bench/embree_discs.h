/* embree_discs.h — the same splats as flat oriented discs in Embree 3, as
 * the speed reference for bench_trace. Benchmark-only: not part of
 * libsplatgi, and the only code in the project that includes Embree.
 *
 * What it does: copies a pointset's centres, radii and normals into one
 * RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT geometry (vertex buffer FLOAT4 =
 * x, y, z, radius; normal buffer FLOAT3), commits it with
 * RTC_SCENE_FLAG_NONE and RTC_BUILD_QUALITY_HIGH, and renders frames the
 * way sg_render_frame does with SG_SHADE_SIMPLE: the same 16x16 tiles
 * under `omp parallel for schedule(dynamic, 1)`, the same primary rays
 * (sg_camera_ray through pixel centres), one rtcIntersect1 per pixel and
 * the same shading, albedo * (0.15 + 0.85 |n.v|), with the disc normal.
 * What it does NOT do: blending of overlapping discs or any MLS surface:
 * it is the plain nearest disc, so images differ from splatgi's in detail.
 *
 * Use:
 *     embree_discs *e;
 *     if (embree_discs_create(&points, threads, &e, &err) != SG_OK) ...
 *     embree_discs_frame(e, &cam, 512, 512, threads, &img, NULL, &st, &err);
 *     embree_discs_destroy(e);
 *
 * Ownership: create copies what it needs (Embree owns its buffers; albedo
 * is copied), so the pointset may be freed afterwards.
 * Thread-safety: frames on a committed scene may run concurrently.
 */
#ifndef SG_BENCH_EMBREE_DISCS_H
#define SG_BENCH_EMBREE_DISCS_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "io/image.h"
#include "points/pointset.h"
#include "render/camera.h"

typedef struct embree_discs embree_discs; /* opaque */

typedef struct embree_discs_stats {
    uint64_t rays;      /* primary rays, one per pixel               */
    uint64_t hits;      /* rays that hit a disc                      */
    double seconds;     /* wall time of the tiled tracing loop       */
    double mrays_per_s; /* rays / seconds / 1e6                      */
} embree_discs_stats;

/* Builds the Embree device (with "threads=N" when threads > 0) and scene.
 * Errors: SG_ERR_INVALID_ARG (empty pointset), SG_ERR_NOMEM, and
 * SG_ERR_UNSUPPORTED for any Embree error (its message is kept). */
sg_status embree_discs_create(const sg_pointset *points, int threads, embree_discs **out,
                              sg_error *err);

/* Embree's version string, e.g. "3.13.5". */
const char *embree_discs_version(void);

/* NULL is a no-op. */
void embree_discs_destroy(embree_discs *e);

/* Wall time of rtcCommitScene (the BVH build), and the bytes Embree's
 * memory monitor counted as held once the scene was committed. */
double embree_discs_build_seconds(const embree_discs *e);
size_t embree_discs_memory_bytes(const embree_discs *e);

/* Renders width x height pixels into *out (allocated here; free with
 * sg_image_free). hit_mask, when not NULL, receives width*height bytes,
 * 1 where the pixel's ray hit a disc (row 0 top). threads 0 = OpenMP
 * default. *out and *stats are written only on SG_OK. */
sg_status embree_discs_frame(const embree_discs *e, const sg_camera *cam, int width, int height,
                             int threads, sg_image *out, uint8_t *hit_mask,
                             embree_discs_stats *stats, sg_error *err);

#endif
