/* embree_device.c — see embree_device.h. */
#include "embree_device.h"

#include <omp.h>
#include <stdio.h>
#include <string.h>

static void on_error(void *user, enum RTCError code, const char *str)
{
    embree_device *d = user;
    if (d->error[0] == '\0')
        snprintf(d->error, sizeof d->error, "embree error %d: %s", (int)code, str ? str : "?");
}

static bool on_memory(void *user, ssize_t bytes, bool post)
{
    (void)post;
    embree_device *d = user;
    atomic_fetch_add(&d->held_bytes, (long long)bytes);
    return true; /* never refuse an allocation */
}

int embree_device_open(embree_device *d, int threads)
{
    atomic_init(&d->held_bytes, 0);
    char config[64] = "";
    if (threads > 0)
        snprintf(config, sizeof config, "threads=%d", threads);
    d->device = rtcNewDevice(config);
    if (!d->device)
        return 0;
    rtcSetDeviceErrorFunction(d->device, on_error, d);
    rtcSetDeviceMemoryMonitorFunction(d->device, on_memory, d);
    d->scene = rtcNewScene(d->device);
    return d->scene != NULL;
}

int embree_device_commit(embree_device *d, RTCGeometry g, enum RTCBuildQuality quality)
{
    rtcCommitGeometry(g);
    rtcAttachGeometry(d->scene, g);
    rtcReleaseGeometry(g);
    rtcSetSceneFlags(d->scene, RTC_SCENE_FLAG_NONE);
    rtcSetSceneBuildQuality(d->scene, quality);
    double t0 = omp_get_wtime();
    rtcCommitScene(d->scene);
    d->build_seconds = omp_get_wtime() - t0;
    if (rtcGetDeviceError(d->device) != RTC_ERROR_NONE || d->error[0])
        return 0;
    long long held = atomic_load(&d->held_bytes);
    d->memory_bytes = held > 0 ? (size_t)held : 0;
    return 1;
}

void embree_device_close(embree_device *d)
{
    if (d->scene)
        rtcReleaseScene(d->scene);
    if (d->device)
        rtcReleaseDevice(d->device);
    d->scene = NULL;
    d->device = NULL;
}

void embree_device_intersect1(const embree_device *d, const sg_ray *r, struct RTCRayHit *rh)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    rh->ray.org_x = r->org.x;
    rh->ray.org_y = r->org.y;
    rh->ray.org_z = r->org.z;
    rh->ray.tnear = r->tmin;
    rh->ray.dir_x = r->dir.x;
    rh->ray.dir_y = r->dir.y;
    rh->ray.dir_z = r->dir.z;
    rh->ray.time = 0.0f;
    rh->ray.tfar = r->tmax;
    rh->ray.mask = 0xFFFFFFFFu;
    rh->ray.id = 0;
    rh->ray.flags = 0;
    rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(d->scene, &ctx, rh);
}
