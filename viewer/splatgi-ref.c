/* splatgi-ref — the Monte Carlo reference renderer: reads a scene file (or
 * makes the scene for a model file), path traces one camera's view and
 * writes the mean image (EXR, coverage as alpha), its per-pixel standard
 * error (EXR) and a JSON summary. Options, library calls and a report; the
 * estimator lives in src/ref/pathtrace.c.
 */
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <cjson/cJSON.h>

#include "app/model_scene.h"
#include "app/preflight.h"
#include "core/alloc.h"
#include "core/cli.h"
#include "core/file_mode.h"
#include "io/image.h"
#include "io/scene_file.h"
#include "program.h"
#include "ref/pathtrace.h"
#include "render/coverage.h"
#include "render/world.h"

static const char usage[] =
    "usage: splatgi-ref SCENE.json|MODEL [options]\n"
    "Unbiased path tracing of a scene file (the reference the bake is judged by).\n"
    "  --camera NAME     camera of the scene file (default: its first; none:\n"
    "                    the models framed from the front, above)\n"
    "  --spp N           paths per pixel (default: the file's render.spp)\n"
    "  --max-depth N     scattering events per path (default: render.max_depth)\n"
    "  --width W --height H   image size (default: the file's)\n"
    "  --seed S --threads N\n"
    "  --progressive     render in passes of doubling size (1, 1, 2, 4, ... paths)\n"
    "                    and rewrite the outputs after each pass\n"
    "  --pixel-centres   every path through its pixel's centre (the rays of the\n"
    "                    lookup frame, for exact comparisons), not jittered\n"
    "  --out FILE.exr    mean radiance (default out/ref.exr); beside it\n"
    "                    FILE.stderr.exr (standard error) and FILE.json (summary);\n"
    "                    alpha: coverage, the share of a pixel showing a model\n"
    "                    (4 x 4 rays a pixel; 1 with --pixel-centres)\n"
    "  --help\n"
    "\n" SG_PROG_WORLD_OPTIONS "\n" SG_MODEL_SCENE_OPTIONS;

static int fail(const char *msg)
{
    fprintf(stderr, "splatgi-ref: %s\n", msg);
    return 1;
}

static int parse_int(const char *opt, const char *s, long lo, long hi, long *out)
{
    sg_error e;
    if (sg_cli_long(opt, s, lo, hi, out, &e) != SG_OK) {
        fprintf(stderr, "splatgi-ref: %s\n", e.message);
        return 0;
    }
    return 1;
}

/* FILE.exr -> FILE<suffix> */
static void sibling(const char *out, const char *suffix, char *buf, size_t size)
{
    size_t n = strlen(out);
    if (n > 4 && strcmp(out + n - 4, ".exr") == 0)
        n -= 4;
    snprintf(buf, size, "%.*s%s", (int)n, out, suffix);
}

static int write_summary(const char *path, const char *scene, const sg_ref_desc *d, const sg_ref_result *r,
                         uint64_t hash)
{
    cJSON *o = cJSON_CreateObject();
    char hex[32];
    snprintf(hex, sizeof hex, "%016" PRIx64, hash);
    cJSON_AddStringToObject(o, "scene", scene);
    cJSON_AddStringToObject(o, "scene_hash", hex);
    cJSON_AddNumberToObject(o, "width", d->width);
    cJSON_AddNumberToObject(o, "height", d->height);
    cJSON_AddNumberToObject(o, "spp", d->spp);
    cJSON_AddNumberToObject(o, "max_depth", d->max_depth);
    cJSON_AddNumberToObject(o, "seed", (double)d->seed);
    cJSON_AddBoolToObject(o, "pixel_centres", d->pixel_centres);
    double mean[3] = {r->mean_radiance[0], r->mean_radiance[1], r->mean_radiance[2]};
    cJSON_AddItemToObject(o, "mean_radiance", cJSON_CreateDoubleArray(mean, 3));
    cJSON_AddNumberToObject(o, "seconds", r->seconds);
    cJSON_AddNumberToObject(o, "paths", (double)r->paths);
    cJSON_AddNumberToObject(o, "rays", (double)r->rays.rays);
    cJSON_AddNumberToObject(o, "mrays_per_s", r->seconds > 0 ? (double)r->rays.rays / r->seconds / 1e6 : 0.0);
    /* Hits from behind (ref/pathtrace.h sg_ref_counts): on closed models
     * seen from outside each one follows a ray through a surface. */
    cJSON_AddNumberToObject(o, "surface_hits", (double)r->counts.surface_hits);
    cJSON_AddNumberToObject(o, "back_hits", (double)r->counts.back_hits);
    cJSON_AddNumberToObject(o, "camera_back_hits", (double)r->counts.camera_back_hits);
    cJSON_AddNumberToObject(o, "paths_with_back_hits", (double)r->counts.back_paths);
    char *text = cJSON_Print(o);
    cJSON_Delete(o);
    if (!text)
        return 0;
    /* Temporary name, then rename: no partial summary in place of a good one. */
    char tmp[4300];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp)
        return 0;
    FILE *f = fopen(tmp, "w");
    int ok = f && fputs(text, f) >= 0 && fputc('\n', f) != EOF;
    if (f && fclose(f) != 0)
        ok = 0;
    cJSON_free(text);
    if (!ok || chmod(tmp, sg_output_file_mode(path)) != 0 || rename(tmp, path) != 0) {
        remove(tmp);
        return 0;
    }
    return 1;
}

int main(int argc, char **argv)
{
    const char *scene_path = NULL, *camera = NULL, *out = "out/ref.exr", *write_scene = NULL;
    long spp = 0, depth = -1, width = 0, height = 0, threads = 0, seed = -1;
    int progressive = 0, centres = 0;
    sg_model_scene_desc md = {0};
    sg_prog_world wo = {0}; /* --world, --if-stale */
    sg_prog_init("splatgi-ref");
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        sg_error oe = {0};
        int ms = sg_model_scene_option(argc, argv, &i, &md, &write_scene, &oe);
        if (ms == 0)
            ms = sg_prog_world_option(argc, argv, &i, &wo, &oe);
        if (ms < 0)
            return fail(oe.message);
        if (ms)
            continue;
        if (!strcmp(a, "--help")) {
            fputs(usage, stdout);
            return 0;
        } else if (!strcmp(a, "--progressive")) {
            progressive = 1;
        } else if (!strcmp(a, "--pixel-centres") || !strcmp(a, "--pixel-centers")) {
            centres = 1;
        } else if (!strcmp(a, "--camera") && v) {
            camera = v;
            ++i;
        } else if (!strcmp(a, "--out") && v) {
            out = v;
            ++i;
        } else if (!strcmp(a, "--spp")) {
            if (!parse_int(a, v, 1, SG_REF_MAX_SPP, &spp)) return 1;
            ++i;
        } else if (!strcmp(a, "--max-depth")) {
            if (!parse_int(a, v, 0, 100000, &depth)) return 1;
            ++i;
        } else if (!strcmp(a, "--width")) {
            if (!parse_int(a, v, 1, 16384, &width)) return 1;
            ++i;
        } else if (!strcmp(a, "--height")) {
            if (!parse_int(a, v, 1, 16384, &height)) return 1;
            ++i;
        } else if (!strcmp(a, "--threads")) {
            if (!parse_int(a, v, 1, 4096, &threads)) return 1;
            ++i;
        } else if (!strcmp(a, "--seed")) {
            if (!parse_int(a, v, 0, 2147483647L, &seed)) return 1;
            ++i;
        } else if (a[0] == '-') {
            fprintf(stderr, "splatgi-ref: unknown option '%s' (see --help)\n", a);
            return 1;
        } else if (!scene_path) {
            scene_path = a;
        } else {
            return fail("more than one scene file given");
        }
    }
    if (!scene_path)
        return fail("no scene or model file given (see --help)");

    sg_error err = {0};
    sg_scene_file sf = {0};
    sg_world *world = NULL;
    int rc = 1;
    sg_ref_result r = {0};
    float *coverage = NULL; /* alpha of both images (render/coverage.h) */
    const sg_scene_camera *cam0 = NULL;
    if (sg_prog_load_scene(scene_path, &md, write_scene, &sf, &err) != SG_OK) {
        fail(err.message);
        goto done;
    }
    if (camera && !(cam0 = sg_scene_file_find_camera(&sf, camera))) {
        fprintf(stderr, "splatgi-ref: %s: no camera named '%s'\n", scene_path, camera);
        goto done;
    }
    /* Where the outputs go, before the world is built. */
    if (sg_prog_check_output(out, &err) != SG_OK || sg_prog_build_world(scene_path, &sf, 0, &wo, &world, &err) != SG_OK) {
        fail(err.message);
        goto done;
    }
    sg_ref_desc d = {
        .width = width ? (int)width : sf.render.width,
        .height = height ? (int)height : sf.render.height,
        .spp = spp ? (int)spp : sf.render.spp,
        .max_depth = depth >= 0 ? (int)depth : sf.render.max_depth,
        .seed = seed >= 0 ? (uint64_t)seed : sf.render.seed,
        .threads = threads ? (int)threads : sf.render.threads,
        .pixel_centres = centres,
    };
    float aspect = (float)d.width / (float)d.height;
    const sg_scene_camera *cam = camera ? cam0 : (sf.camera_count ? &sf.cameras[0] : NULL);
    sg_status st = cam ? sg_camera_look_at(cam->eye, cam->look, cam->up, cam->fov_deg, aspect, &d.camera, &err)
                       : sg_camera_frame(sg_world_bounds(world), sg_v3(0.0f, -0.35f, -1.0f), sg_v3(0, 1, 0), 40.0f,
                                         aspect, 0.0f, &d.camera, &err);
    if (st != SG_OK) {
        fail(err.message);
        goto done;
    }
    char se_path[4200], json_path[4200];
    sibling(out, ".stderr.exr", se_path, sizeof se_path);
    sibling(out, ".json", json_path, sizeof json_path);
    /* Coverage, the alpha of both images: the area of each pixel where the
     * camera sees a model (4 x 4 rays; the centre ray alone when every path
     * goes through it). */
    sg_coverage_desc cd = {.camera = d.camera, .width = d.width, .height = d.height, .per_side = centres ? 1 : 4,
                           .threads = d.threads};
    if (sg_coverage_render(world, &cd, &coverage, &err) != SG_OK) {
        fail(err.message);
        goto done;
    }
    int total = d.spp, done_spp = 0;
    while (done_spp < total) {
        /* One pass, or doubling passes: the image after each has as many
         * paths as all before it together. */
        int n = progressive ? (done_spp ? done_spp : 1) : total;
        if (n > total - done_spp)
            n = total - done_spp;
        sg_ref_desc pass = d;
        pass.spp = n;
        pass.first_sample = (uint32_t)done_spp;
        sg_ref_result pr;
        if (sg_ref_render(world, &pass, &pr, &err) != SG_OK) {
            fail(err.message);
            goto done;
        }
        if (done_spp == 0) {
            r = pr;
        } else {
            st = sg_ref_result_merge(&r, done_spp, &pr, n, &err);
            sg_ref_result_free(&pr);
            if (st != SG_OK) {
                fail(err.message);
                goto done;
            }
        }
        done_spp += n;
        d.spp = done_spp;
        r.mean.alpha = r.std_error.alpha = coverage; /* shared for the writes only */
        st = sg_image_write(&r.mean, out, 1.0f, &err);
        if (st == SG_OK)
            st = sg_image_write(&r.std_error, se_path, 1.0f, &err);
        r.mean.alpha = r.std_error.alpha = NULL;
        if (st != SG_OK) {
            fail(err.message);
            goto done;
        }
        if (!write_summary(json_path, scene_path, &d, &r, sg_scene_file_hash(&sf, SG_SCENE_HASH_ALL))) {
            fprintf(stderr, "splatgi-ref: %s: cannot write the summary\n", json_path);
            goto done;
        }
        if (progressive) {
            printf("splatgi-ref: %d of %d spp, %.2f s\n", done_spp, total, r.seconds);
            fflush(stdout); /* a pipe buffers: the progress would come at the end */
        }
    }
    printf("splatgi-ref: %dx%d, %d spp, %.2f s, %.2f Mrays/s, mean radiance (%.5g, %.5g, %.5g) -> %s\n", d.width,
           d.height, d.spp, r.seconds, r.seconds > 0 ? (double)r.rays.rays / r.seconds / 1e6 : 0.0,
           r.mean_radiance[0], r.mean_radiance[1], r.mean_radiance[2], out);
    rc = 0;
done:
    sg_free(coverage);
    sg_ref_result_free(&r);
    sg_world_destroy(world);
    sg_scene_file_free(&sf);
    return rc;
}
