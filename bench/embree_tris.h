/* embree_tris.h — a triangle mesh in Embree 3, as bench_hybrid's speed and
 * memory reference. Benchmark-only: not part of libsplatgi.
 *
 * What it does: copies a mesh's positions and triangles into one
 * RTC_GEOMETRY_TYPE_TRIANGLE geometry (buffers Embree allocates, so its
 * memory monitor counts them), commits it with RTC_SCENE_FLAG_NONE and the
 * given build quality, and renders frames the way bench_hybrid renders
 * splatgi's: the same 16x16 tiles under `omp parallel for schedule(dynamic,
 * 1)`, the same primary rays (sg_camera_ray through pixel centres), one
 * rtcIntersect1 per pixel, and the same shading, grey 0.8 * (0.15 + 0.85
 * |n.v|) with n the vertex normals interpolated at Embree's barycentrics.
 *
 * Ownership: create copies what it needs (normals too), so the mesh may be
 * freed afterwards. Thread-safety: frames may run concurrently.
 */
#ifndef SG_BENCH_EMBREE_TRIS_H
#define SG_BENCH_EMBREE_TRIS_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "io/image.h"
#include "io/mesh.h"
#include "render/camera.h"

typedef struct embree_tris embree_tris; /* opaque */

typedef enum embree_tris_quality {
    EMBREE_TRIS_HIGH = 0,   /* RTC_BUILD_QUALITY_HIGH (spatial splits)   */
    EMBREE_TRIS_MEDIUM = 1  /* RTC_BUILD_QUALITY_MEDIUM (Embree default) */
} embree_tris_quality;

typedef struct embree_tris_stats {
    uint64_t rays, hits;
    double seconds;     /* wall time of the tiled loop      */
    double cpu_seconds; /* process CPU time of the same loop */
    double mrays_per_s;
} embree_tris_stats;

/* normals: 3 floats per vertex (unit), required: the shading normals both
 * renderers interpolate. Errors: SG_ERR_INVALID_ARG, SG_ERR_NOMEM,
 * SG_ERR_UNSUPPORTED for any Embree error. */
sg_status embree_tris_create(const sg_mesh *mesh, const float *normals, embree_tris_quality quality, int threads,
                             embree_tris **out, sg_error *err);
void embree_tris_destroy(embree_tris *e);
const char *embree_tris_version(void);
double embree_tris_build_seconds(const embree_tris *e);
/* Bytes Embree's memory monitor counted once the scene was committed: its
 * BVH and its copies of the vertex and index buffers. */
size_t embree_tris_memory_bytes(const embree_tris *e);

/* Renders width x height pixels into *out (allocated here). tri_ids, when
 * not NULL, receives width*height primitive ids (0xFFFFFFFF: miss) and
 * t_out the hit distances (INFINITY: miss). */
sg_status embree_tris_frame(const embree_tris *e, const sg_camera *cam, int width, int height, int threads,
                            sg_image *out, uint32_t *tri_ids, float *t_out, embree_tris_stats *stats,
                            sg_error *err);

/* The same frame traced as coherent packets: each 16x16 tile in blocks of
 * 4 x 4 pixels through rtcIntersect16 when the device traces 16-wide
 * packets natively, else 4 x 2 through rtcIntersect8 (*width_out gets 16
 * or 8). The rays, shading and tile schedule are embree_tris_frame's, so
 * the images agree pixel for pixel up to Embree's own packet rounding.
 * This is what the best CPU packet tracer gives on the same machine: the
 * bound the viewer's frame-rate targets are compared with. */
sg_status embree_tris_frame_packets(const embree_tris *e, const sg_camera *cam, int width, int height,
                                    int threads, sg_image *out, int *width_out, embree_tris_stats *stats,
                                    sg_error *err);

#endif
