/* bench_world — what the world file (render/world_file.h) saves: the
 * seconds to build a world, to save it and to load it back, for the
 * dragon sampled to each --points count (the scene of bench_iso and
 * bench_view: the Stanford dragon mesh as one model file).
 *
 * Per count: the scene JSON is written to the output folder, the world
 * built (sg_world_create: sampling, radii, normals, the surface), saved
 * (sg_world_save), loaded (sg_world_load: map, every CRC, every array
 * check, the envmap), each timed in wall and CPU seconds, the file size
 * printed; then the same frame (phong shading, shadow rays) is rendered
 * from the built and the loaded model and compared byte for byte. The
 * load runs twice: with the file just written, in the page cache ("warm"),
 * and after posix_fadvise(DONTNEED) dropped this file's pages from the
 * cache ("cold": read from the disk; other files' pages are not touched).
 * One CSV row per count is appended to --csv (default
 * out/bench_world/bench_world.csv).
 */
#include <fcntl.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "bench_common.h"
#include "core/cli.h"
#include "io/scene_file.h"
#include "render/camera.h"
#include "render/render.h"
#include "render/world.h"
#include "render/world_file.h"

#define DEFAULT_MESH SG_SHARED_DATA_DIR "/meshes/stanford_dragon/dragon_vrip.ply"

static const char usage[] =
    "usage: bench_world [options]\n"
    "Build, save and load seconds of a world file, and whether a frame from\n"
    "the loaded world is the built one's, byte for byte.\n"
    "  --mesh PATH      mesh to sample (default the Stanford dragon)\n"
    "  --points LIST    comma-separated counts (default 250000,1000000)\n"
    "  --surface S      mls, disk or iso (default mls)\n"
    "  --threads N      OpenMP threads (default: all)\n"
    "  --out DIR        scene and world files (default out/bench_world)\n"
    "  --csv PATH       append rows (default out/bench_world/bench_world.csv)\n";

typedef struct timing {
    double wall, cpu;
} timing;

static timing since(double w0, double c0) { return (timing){omp_get_wtime() - w0, bench_cpu_seconds() - c0}; }

/* Drops path's pages from the page cache (clean after the writer's
 * fsync), so the next read comes from the disk; 1 on success. */
static int evict(const char *path)
{
    int fd = open(path, O_RDONLY);
    if (fd < 0)
        return 0;
    int ok = posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED) == 0;
    close(fd);
    return ok;
}

/* The frame of model 0 (phong, shadows) into *img. */
static int frame(const sg_world *w, sg_image *img, sg_error *err)
{
    sg_aabb b = sg_world_bounds(w);
    sg_vec3 c = sg_v3_scale(sg_v3_add(b.lo, b.hi), 0.5f);
    float d = sg_aabb_diagonal(b);
    sg_render_desc rd = {.width = 320, .height = 240, .shade = SG_SHADE_PHONG};
    sg_vec3 eye = sg_v3_add(c, sg_v3(0.6f * d, 0.35f * d, 0.9f * d));
    return sg_camera_look_at(eye, c, sg_v3(0, 1, 0), 40.0f, 320.0f / 240.0f, &rd.camera, err) == SG_OK &&
           sg_render_frame(sg_world_scene(w, 0), &rd, img, NULL, err) == SG_OK;
}

int main(int argc, char **argv)
{
    const char *mesh = DEFAULT_MESH, *csv = "out/bench_world/bench_world.csv", *outdir = "out/bench_world";
    const char *surface = "mls";
    size_t counts[8] = {250000, 1000000};
    int ncounts = 2, threads = 0;
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        sg_error e = {0};
        if (strcmp(a, "--help") == 0) {
            fputs(usage, stdout);
            return 0;
        } else if (!v) {
            return bench_fail("bench_world", "%s: missing value or unknown option\n%s", a, usage);
        }
        ++i;
        if (strcmp(a, "--mesh") == 0) mesh = v;
        else if (strcmp(a, "--surface") == 0) surface = v;
        else if (strcmp(a, "--threads") == 0) threads = atoi(v);
        else if (strcmp(a, "--out") == 0) outdir = v;
        else if (strcmp(a, "--csv") == 0) csv = v;
        else if (strcmp(a, "--points") == 0) {
            if (sg_cli_size_list(a, v, 1, 100000000ull, counts, 8, &ncounts, &e) != SG_OK)
                return bench_fail("bench_world", "%s", e.message);
        } else
            return bench_fail("bench_world", "unknown option %s\n%s", a, usage);
    }
    if (strcmp(surface, "mls") && strcmp(surface, "disk") && strcmp(surface, "iso"))
        return bench_fail("bench_world", "--surface: '%s' is not mls, disk or iso", surface);
    if (threads > 0)
        omp_set_num_threads(threads);
    if (!bench_make_dirs(outdir))
        return bench_fail("bench_world", "%s: cannot make the folder", outdir);
    char machine[256], command[1024] = "";
    bench_cpu_model(machine, sizeof machine);
    for (int i = 0; i < argc; ++i) {
        strncat(command, argv[i], sizeof command - strlen(command) - 2);
        strncat(command, " ", sizeof command - strlen(command) - 1);
    }
    printf("bench_world: machine %s, %d threads\ncommand: %s\n", machine, omp_get_max_threads(), command);
    printf("%10s %5s %9s %9s %8s %8s %8s %8s %8s %8s %9s %7s %9s\n", "points", "surf", "build_s", "build_cpu",
           "save_s", "save_cpu", "load_s", "load_cpu", "cold_s", "cold_cpu", "file_MiB", "speedup", "identical");

    struct stat sb;
    int fresh = stat(csv, &sb) != 0;
    FILE *f = fopen(csv, "a");
    if (!f)
        return bench_fail("bench_world", "%s: cannot open for appending", csv);
    if (fresh)
        fprintf(f, "machine,command,points,surface,threads,build_wall_s,build_cpu_s,save_wall_s,save_cpu_s,"
                   "load_wall_s,load_cpu_s,cold_load_wall_s,cold_load_cpu_s,file_bytes,identical\n");
    int rc = 0;
    for (int k = 0; k < ncounts && rc == 0; ++k) {
        char json[5000], scene_path[4200], world_path[4200], esc[4200];
        if (!bench_json_escape(mesh, esc, sizeof esc))
            return bench_fail("bench_world", "%s: path too long", mesh);
        snprintf(json, sizeof json, "{\"models\": [{\"path\": \"%s\", \"points\": %zu, \"surface\": {\"model\": \"%s\"}}]}",
                 esc, counts[k], surface);
        snprintf(scene_path, sizeof scene_path, "%s/dragon_%zu_%s.json", outdir, counts[k], surface);
        snprintf(world_path, sizeof world_path, "%s/dragon_%zu_%s.sgworld", outdir, counts[k], surface);
        FILE *s = fopen(scene_path, "w");
        if (!s || fputs(json, s) < 0 || fclose(s) != 0)
            return bench_fail("bench_world", "%s: cannot write", scene_path);
        sg_error err = {0};
        sg_scene_file sf = {0};
        sg_world *built = NULL, *loaded = NULL;
        sg_image a = {0}, b = {0};
        if (sg_scene_file_load(scene_path, &sf, &err) != SG_OK) {
            rc = bench_fail("bench_world", "%s", err.message);
            break;
        }
        double w0 = omp_get_wtime(), c0 = bench_cpu_seconds();
        if (sg_world_create(&sf, &built, &err) != SG_OK) {
            rc = bench_fail("bench_world", "build: %s", err.message);
            goto next;
        }
        timing tb = since(w0, c0);
        w0 = omp_get_wtime(), c0 = bench_cpu_seconds();
        if (sg_world_save(built, &sf, world_path, &err) != SG_OK) {
            rc = bench_fail("bench_world", "save: %s", err.message);
            goto next;
        }
        timing ts = since(w0, c0);
        w0 = omp_get_wtime(), c0 = bench_cpu_seconds();
        if (sg_world_load(world_path, &sf, NULL, &loaded, &err) != SG_OK) {
            rc = bench_fail("bench_world", "load: %s", err.message);
            goto next;
        }
        timing tl = since(w0, c0);
        sg_world_destroy(loaded);
        loaded = NULL;
        timing tc = {NAN, NAN};
        if (evict(world_path)) {
            w0 = omp_get_wtime(), c0 = bench_cpu_seconds();
            if (sg_world_load(world_path, &sf, NULL, &loaded, &err) != SG_OK) {
                rc = bench_fail("bench_world", "cold load: %s", err.message);
                goto next;
            }
            tc = since(w0, c0);
        } else if (sg_world_load(world_path, &sf, NULL, &loaded, &err) != SG_OK) {
            rc = bench_fail("bench_world", "load: %s", err.message);
            goto next;
        }
        if (!frame(built, &a, &err) || !frame(loaded, &b, &err)) {
            rc = bench_fail("bench_world", "frame: %s", err.message);
            goto next;
        }
        int same = memcmp(a.data, b.data, (size_t)3 * a.width * a.height * sizeof(float)) == 0;
        uint64_t bytes = stat(world_path, &sb) == 0 ? (uint64_t)sb.st_size : 0;
        printf("%10zu %5s %9.2f %9.2f %8.2f %8.2f %8.3f %8.3f %8.3f %8.3f %9.1f %6.0fx %9s\n", counts[k], surface,
               tb.wall, tb.cpu, ts.wall, ts.cpu, tl.wall, tl.cpu, tc.wall, tc.cpu, (double)bytes / 1048576.0,
               tb.wall / tl.wall, same ? "yes" : "NO");
        fprintf(f, "\"%s\",\"%s\",%zu,%s,%d,%.3f,%.3f,%.3f,%.3f,%.4f,%.4f,%.4f,%.4f,%llu,%d\n", machine, command,
                counts[k], surface, omp_get_max_threads(), tb.wall, tb.cpu, ts.wall, ts.cpu, tl.wall, tl.cpu, tc.wall,
                tc.cpu, (unsigned long long)bytes, same);
        fflush(f);
        if (!same)
            rc = bench_fail("bench_world", "%zu points: the loaded world's frame differs from the built one's",
                            counts[k]);
    next:
        sg_image_free(&a);
        sg_image_free(&b);
        sg_world_destroy(loaded);
        sg_world_destroy(built);
        sg_scene_file_free(&sf);
    }
    fclose(f);
    printf("\nappended to %s\n", csv);
    return rc;
}
