/* embree_device.h — the Embree 3 device and scene the benchmarks' Embree
 * references share (embree_discs, embree_tris): a device with an error
 * callback that keeps the first message and a memory monitor that counts
 * what Embree holds, one scene, one geometry committed at a build quality.
 *
 * Use (d lives inside the caller's heap object: the callbacks keep &d):
 *     if (!embree_device_open(&e->dev, threads)) fail(e->dev.error);
 *     RTCGeometry g = rtcNewGeometry(e->dev.device, ...); fill its buffers
 *     if (!embree_device_commit(&e->dev, g, RTC_BUILD_QUALITY_HIGH)) fail(...);
 *     ... e->dev.scene, e->dev.build_seconds, e->dev.memory_bytes
 *     embree_device_close(&e->dev);    any state, also after a failure
 * Thread-safety: held_bytes is changed only by the monitor and read after
 * rtcCommitScene returns, when no build runs.
 */
#ifndef SG_BENCH_EMBREE_DEVICE_H
#define SG_BENCH_EMBREE_DEVICE_H

#include <embree3/rtcore.h>
#include <stdatomic.h>
#include <stddef.h>

#include "core/error.h"
#include "math/ray.h"

typedef struct embree_device {
    RTCDevice device;                 /* owns the scene                     */
    RTCScene scene;                   /* the one scene                      */
    double build_seconds;             /* rtcCommitScene wall time           */
    size_t memory_bytes;              /* held_bytes after the commit        */
    atomic_llong held_bytes;          /* memory monitor total               */
    char error[SG_ERROR_MESSAGE_MAX]; /* first Embree error message, or ""  */
} embree_device;

/* A device ("threads=N" when threads > 0) and an empty scene; 0 on
 * failure, with d->error saying why when Embree did. */
int embree_device_open(embree_device *d, int threads);

/* Attaches g (released here, in every case), commits the scene at
 * `quality` and records build_seconds and memory_bytes; 0 on failure. */
int embree_device_commit(embree_device *d, RTCGeometry g, enum RTCBuildQuality quality);

/* Traces ray r (tmin..tmax) through the scene, nearest hit into *rh
 * (rh->hit.geomID RTC_INVALID_GEOMETRY_ID on a miss). */
void embree_device_intersect1(const embree_device *d, const sg_ray *r, struct RTCRayHit *rh);

/* Releases the scene and the device; a zeroed or failed d is fine. */
void embree_device_close(embree_device *d);

#endif
