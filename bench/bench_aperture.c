/* bench_aperture — how much of the sun the built-in room's window lets in,
 * per surface model, against the exact window (docs/iso.md, "Sharp convex
 * edges"; docs/surfaces.md, "Convex edges: no overhang into an opening").
 *
 * Rays start on a grid of --grid x --grid cell centres on the plane
 * y = 0.05 inside the room (x, z in [-2, 2]; 250k points, no bunny) and
 * go towards a sun at 40 degrees elevation, at azimuths 0, 30 and 60
 * degrees from +X towards +Z. A ray that meets no surface escapes through
 * the window. The exact window (room.h: the opening z in [-0.6, 0.6],
 * y in [0.9, 1.9] through the +X wall, x in [2, 2 + wall]) lets a ray out
 * exactly when its points at x = 2 and x = 2 + wall both lie in the
 * opening (the tunnel is convex). Printed: escapes over the exact count,
 * for front-only rays (the sun's shadow rays) and rays accepting either
 * face (a path's camera rays), and the build's CPU seconds.
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "io/scene_file.h"
#include "points/room.h"
#include "render/world.h"

static const char usage[] =
    "usage: bench_aperture [--surface mls|iso|disk] [--points N] [--grid N]\n"
    "Escapes of sun rays through the built-in room's window over the exact window's\n"
    "(defaults: iso, 250000 points, grid 1000).\n";

static double cpu_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
    const char *surface = "iso";
    long points = 250000, grid = 1000;
    const double wall = SG_ROOM_WALL; /* the builtin room's */
    for (int i = 1; i < argc; ++i) {
        if (!strcmp(argv[i], "--surface") && i + 1 < argc)
            surface = argv[++i];
        else if (!strcmp(argv[i], "--points") && i + 1 < argc)
            points = atol(argv[++i]);
        else if (!strcmp(argv[i], "--grid") && i + 1 < argc)
            grid = atol(argv[++i]);
        else {
            fputs(usage, stderr);
            return 2;
        }
    }
    char json[1024];
    snprintf(json, sizeof json,
             "{\"models\": [{\"builtin\": \"room\", \"points\": %ld, \"surface\": {\"model\": "
             "\"%s\"}}], \"envmap\": {\"builtin\": \"sunsky\"}}",
             points, surface);
    sg_scene_file sf = {0};
    sg_error err = {0};
    if (sg_scene_file_parse(json, strlen(json), "bench_aperture", NULL, &sf, &err) != SG_OK) {
        fprintf(stderr, "bench_aperture: %s\n", err.message);
        return 1;
    }
    double c0 = cpu_now(), w0 = omp_get_wtime();
    sg_world *w = NULL;
    if (sg_world_create(&sf, &w, &err) != SG_OK) {
        fprintf(stderr, "bench_aperture: %s\n", err.message);
        sg_scene_file_free(&sf);
        return 1;
    }
    printf("surface %s, %ld points, wall %g: world build %.2f s CPU, %.2f s wall\n", surface, points, wall,
           cpu_now() - c0, omp_get_wtime() - w0);
    const float az[3] = {0.0f, 30.0f, 60.0f}, elev = 40.0f * 3.14159265f / 180.0f;
    const float x1 = SG_ROOM_HALF, x2 = SG_ROOM_HALF + (float)wall;
    for (int a = 0; a < 3; ++a) {
        float phi = az[a] * 3.14159265f / 180.0f;
        sg_vec3 d = sg_v3(cosf(elev) * cosf(phi), sinf(elev), cosf(elev) * sinf(phi));
        long exact = 0, esc[2] = {0, 0};
#pragma omp parallel for schedule(dynamic, 8) reduction(+ : exact) reduction(+ : esc[:2])
        for (long i = 0; i < grid; ++i)
            for (long j = 0; j < grid; ++j) {
                float x = -SG_ROOM_HALF + 2.0f * SG_ROOM_HALF * ((float)i + 0.5f) / (float)grid;
                float z = -SG_ROOM_HALF + 2.0f * SG_ROOM_HALF * ((float)j + 0.5f) / (float)grid;
                sg_vec3 o = sg_v3(x, 0.05f, z);
                int in = 1;
                for (int e = 0; e < 2; ++e) {
                    float t = ((e ? x2 : x1) - x) / d.x;
                    float y = o.y + t * d.y, zz = o.z + t * d.z;
                    in &= y >= SG_ROOM_WINDOW_Y0 && y <= SG_ROOM_WINDOW_Y1 && zz >= -SG_ROOM_WINDOW_Z &&
                          zz <= SG_ROOM_WINDOW_Z;
                }
                exact += in;
                for (int f = 0; f < 2; ++f) {
                    sg_ray ray = {.org = o, .dir = d, .tmin = 0.0f, .tmax = INFINITY,
                                  .flags = f ? SG_RAY_ANY_FACE : SG_RAY_FRONT_ONLY};
                    sg_world_hit h;
                    esc[f] += !sg_world_intersect(w, &ray, &h, NULL);
                }
            }
        printf("azimuth %2.0f: exact %ld, front-only %ld (%.4f), either face %ld (%.4f)\n", (double)az[a], exact,
               esc[0], (double)esc[0] / (double)exact, esc[1], (double)esc[1] / (double)exact);
    }
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
    return 0;
}
