/* splatgi-render — headless frame renderer. Given a scene file or a model
 * file (splatgi-render scan.ply), renders the scene's world lit by its
 * bake (sg_bake_render), the bake kept beside the output and made first
 * when missing or out of date; with --model (or --default) renders a model
 * (or the built-in bunny scene) directly, one primary ray per pixel, Phong
 * or simple shading. Writes an EXR (with coverage as alpha) or a PNG.
 * Options, library calls and a report; no algorithm lives here. Run with
 * --help for the options.
 */
#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "app/model_scene.h"
#include "app/preflight.h"
#include "bake/bake.h"
#include "bake/bake_io.h"
#include "core/cli.h"
#include "io/image.h"
#include "io/scene_file.h"
#include "program.h"
#include "render/camera.h"
#include "render/coverage.h"
#include "render/default_scene.h"
#include "render/render.h"
#include "render/world.h"
#include "surface/scene.h"

#define DEFAULT_OUT "out/render.png"

static const char usage[] =
    "usage: splatgi-render SCENE.json|MODEL [--bake FILE] [options]   (lit by the bake)\n"
    "       splatgi-render [--model MODEL | --default] [options]      (direct shading)\n"
    "The first form renders the scene (or the scene made for a model file, see\n"
    "below) lit by its bake: --bake FILE, else OUT's folder/<name>.sgbake, made\n"
    "there first when missing or out of date. The second renders a model (or the\n"
    "built-in bunny scene) with one ray per pixel and a simple light.\n"
    "\n"
    "Model (direct shading)\n"
    "  --model PATH        .ply .obj .xyz .txt .pcd; a mesh is sampled to --points\n"
    "                      splats, a point cloud uses its vertices; a model\n"
    "                      without colours is shown light grey (0.8)\n"
    "  --default           the built-in scene: bunny on a ground plane (also when\n"
    "                      neither a scene nor --model is given)\n"
    "  --points N          samples on a mesh (default 250000)\n"
    "  --up AXIS           the model's up axis (x, y, z, -x, -y, -z); --up x,y,z\n"
    "                      sets the camera's up vector instead\n"
    "  --radius-k K        splat radius from the K-th nearest neighbour (default 8)\n"
    "  --radius-scale S    radius multiplier (default 1)\n"
    "Surface\n"
    "  --surface mls|disk|iso  implicit MLS surface (default), blended disks, or the\n"
    "                    MLS surface sampled into an implicit surface octree\n"
    "  --kernel hat|gaussian   MLS weight (default hat)\n"
    "  --samples K         MLS samples per leaf interval (default 8)\n"
    "  --no-shrink --no-encourage --no-collapse   turn off a kd-tree refinement\n"
    "  --no-refine         turn off all three\n"
    "Baked light (instead of Model and Surface)\n"
    "  --scene FILE.json   the same as giving the scene file first\n"
    "  --bake FILE.sgbake  its bake (splatgi-bake), which must be up to date;\n"
    "                      default: the cache beside --out\n"
    "  --camera NAME       a camera of the scene file (default: --eye if given,\n"
    "                      else the file's first camera, else a framed view);\n"
    "                      size defaults to the file's render width x height\n"
    "Frame\n"
    "  --shade simple|phong|normals   (default simple: |n.v|, no shadows)\n"
    "  --width W --height H           image size (default 512 x 512)\n"
    "  --eye x,y,z --look x,y,z --up x,y,z --fov DEG   camera (default: framed\n"
    "                      3/4 view; --look defaults to the model's centre)\n"
    "  --light x,y,z       direction towards the light (phong)\n"
    "  --threads N         OpenMP threads (default: all)\n"
    "  --repeat N          render N times, report best and mean (default 1)\n"
    "  --out FILE          .exr (scene-linear) or .png (sRGB); default " DEFAULT_OUT "\n"
    "  --stats             print per-ray traversal statistics and scene facts\n"
    "  --help              this text\n"
    "\n" SG_PROG_WORLD_OPTIONS "\n" SG_MODEL_SCENE_OPTIONS;

typedef struct options {
    const char *model;          /* NULL: default scene                  */
    sg_model_points_desc points;
    sg_scene_desc scene;
    sg_shade_mode shade;
    int width, height;
    int have_eye, have_look, have_up, have_light;
    sg_vec3 eye, look, up, light;
    float fov;                  /* degrees                              */
    int threads;
    int repeat;
    const char *out;
    int stats;
    const char *scene_file;     /* --scene: render from a bake          */
    const char *bake;           /* --bake                               */
    const char *camera;         /* --camera                             */
    int have_width, have_height, have_model;
    sg_model_scene_desc model_scene; /* --envmap, --up AXIS, ...         */
    const char *write_scene;    /* --write-scene                        */
    sg_prog_world world;        /* --world, --if-stale                  */
} options;

static int fail(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;
static int fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "splatgi-render: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return 1;
}

static int parse_long(const char *opt, const char *s, long lo, long hi, long *out)
{
    sg_error e;
    return sg_cli_long(opt, s, lo, hi, out, &e) == SG_OK ? 1 : (fail("%s", e.message), 0);
}

static int parse_float(const char *opt, const char *s, float lo, float *out)
{
    sg_error e;
    return sg_cli_float_above(opt, s, lo, out, &e) == SG_OK ? 1 : (fail("%s", e.message), 0);
}

static int parse_vec3(const char *opt, const char *s, sg_vec3 *out)
{
    sg_error e;
    return sg_cli_vec3(opt, s, out, &e) == SG_OK ? 1 : (fail("%s", e.message), 0);
}

/* Returns 0 to go on, 1 for an error, 2 after --help. */
static int parse_args(int argc, char **argv, options *o)
{
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        /* Flags without a value. */
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return 2;
        }
        if (!strcmp(a, "--default")) { o->model = NULL; o->have_model = 1; continue; }
        if (!strcmp(a, "--stats")) { o->stats = 1; continue; }
        if (!strcmp(a, "--no-shrink")) { o->scene.kd_disable |= SG_KD_NO_SHRINK; continue; }
        if (!strcmp(a, "--no-encourage")) { o->scene.kd_disable |= SG_KD_NO_ENCOURAGE; continue; }
        if (!strcmp(a, "--no-collapse")) { o->scene.kd_disable |= SG_KD_NO_COLLAPSE; continue; }
        if (!strcmp(a, "--no-refine")) { o->scene.kd_disable |= SG_KD_NO_REFINEMENTS; continue; }
        sg_error e = {0};
        int ms = sg_model_scene_option(argc, argv, &i, &o->model_scene, &o->write_scene, &e);
        if (ms == 0)
            ms = sg_prog_world_option(argc, argv, &i, &o->world, &e);
        if (ms < 0)
            return fail("%s", e.message);
        if (ms)
            continue;
        if (strncmp(a, "--", 2) && a[0] != '-') { /* the scene or model file */
            if (o->scene_file)
                return fail("unexpected argument '%s' (one scene or model file; see --help)", a);
            o->scene_file = a;
            continue;
        }
        static const char *const with_value[] = {
            "--model", "--radius-k", "--radius-scale", "--surface", "--kernel",
            "--samples", "--shade", "--width", "--height", "--eye", "--look", "--up", "--light",
            "--fov", "--threads", "--repeat", "--out", "--scene", "--bake", "--camera"};
        int known = 0;
        for (size_t k = 0; k < sizeof with_value / sizeof with_value[0]; k++)
            known |= !strcmp(a, with_value[k]);
        if (!known)
            return fail(strncmp(a, "--", 2) ? "unexpected argument '%s' (see --help)"
                                            : "unknown option '%s' (see --help)", a);
        if (i + 1 >= argc)
            return fail("%s needs a value", a);
        const char *v = argv[++i];
        long n;
        if (!strcmp(a, "--model")) {
            o->model = v;
            o->have_model = 1;
        } else if (!strcmp(a, "--scene")) {
            o->scene_file = v;
        } else if (!strcmp(a, "--bake")) {
            o->bake = v;
        } else if (!strcmp(a, "--camera")) {
            o->camera = v;
        } else if (!strcmp(a, "--radius-k")) {
            if (!parse_long(a, v, 1, 256, &n)) return 1;
            o->points.radius_k = (unsigned)n;
        } else if (!strcmp(a, "--radius-scale")) {
            if (!parse_float(a, v, 0.0f, &o->points.radius_scale)) return 1;
        } else if (!strcmp(a, "--surface")) {
            if (!strcmp(v, "mls")) o->scene.model = SG_SURFACE_MLS;
            else if (!strcmp(v, "disk")) o->scene.model = SG_SURFACE_DISK;
            else if (!strcmp(v, "iso")) o->scene.model = SG_SURFACE_ISO;
            else return fail("--surface: '%s' is not mls, disk or iso", v);
        } else if (!strcmp(a, "--kernel")) {
            if (!strcmp(v, "hat")) o->scene.kernel = SG_KERNEL_HAT;
            else if (!strcmp(v, "gaussian")) o->scene.kernel = SG_KERNEL_GAUSSIAN;
            else return fail("--kernel: '%s' is not hat or gaussian", v);
        } else if (!strcmp(a, "--samples")) {
            if (!parse_long(a, v, 1, 1024, &n)) return 1;
            o->scene.samples_per_cell = (int)n;
        } else if (!strcmp(a, "--shade")) {
            if (!strcmp(v, "simple")) o->shade = SG_SHADE_SIMPLE;
            else if (!strcmp(v, "phong")) o->shade = SG_SHADE_PHONG;
            else if (!strcmp(v, "normals")) o->shade = SG_SHADE_NORMALS;
            else return fail("--shade: '%s' is not simple, phong or normals", v);
        } else if (!strcmp(a, "--width")) {
            if (!parse_long(a, v, 1, SG_IMAGE_MAX_DIM, &n)) return 1;
            o->width = (int)n;
            o->have_width = 1;
        } else if (!strcmp(a, "--height")) {
            if (!parse_long(a, v, 1, SG_IMAGE_MAX_DIM, &n)) return 1;
            o->height = (int)n;
            o->have_height = 1;
        } else if (!strcmp(a, "--eye")) {
            if (!parse_vec3(a, v, &o->eye)) return 1;
            o->have_eye = 1;
        } else if (!strcmp(a, "--look")) {
            if (!parse_vec3(a, v, &o->look)) return 1;
            o->have_look = 1;
        } else if (!strcmp(a, "--up")) {
            if (!parse_vec3(a, v, &o->up)) return 1;
            o->have_up = 1;
        } else if (!strcmp(a, "--light")) {
            if (!parse_vec3(a, v, &o->light)) return 1;
            o->have_light = 1;
        } else if (!strcmp(a, "--fov")) {
            if (!parse_float(a, v, 0.0f, &o->fov)) return 1;
            if (!(o->fov < 180.0f)) return fail("--fov: '%s' is not below 180 degrees", v);
        } else if (!strcmp(a, "--threads")) {
            if (!parse_long(a, v, 1, 4096, &n)) return 1;
            o->threads = (int)n;
        } else if (!strcmp(a, "--repeat")) {
            if (!parse_long(a, v, 1, 100000, &n)) return 1;
            o->repeat = (int)n;
        } else if (!strcmp(a, "--out")) {
            o->out = v;
        }
    }
    if (o->bake && !o->scene_file)
        return fail("--bake lights a scene: give the scene or model file first (see --help)");
    if (o->scene_file && o->have_model)
        return fail("a scene or model file to render from its bake, or --model/--default to shade directly: not "
                    "both (see --help)");
    if (o->camera && !o->scene_file)
        return fail("--camera names a camera of a scene file");
    /* The direct renderer reads the model options itself. */
    o->points.points = o->model_scene.points;
    o->points.radius_cap = o->model_scene.radius_cap;
    o->points.drop_outliers = o->model_scene.drop_outliers;
    if (!o->scene_file && (o->model_scene.envmap || o->write_scene))
        return fail("--envmap and --write-scene make a scene for a model file given first (see --help)");
    return 0;
}

/* A scene or model file's world, lit by its bake. */
static int render_from_bake(const options *o0)
{
    options ov = *o0;
    const options *o = &ov;
    int code = 1;
    sg_error err = {0};
    sg_scene_file sf = {0};
    sg_world *world = NULL;
    sg_bake *bake = NULL;
    sg_image img = {0};
    sg_prog_bake plan;
    const sg_scene_camera *cam = NULL;
    if (sg_prog_load_scene(o->scene_file, &ov.model_scene, o->write_scene, &sf, &err) != SG_OK)
        goto done;
    if (o->camera && !(cam = sg_scene_file_find_camera(&sf, o->camera))) {
        sg_error_set(&err, SG_ERR_INVALID_ARG, "%s: no camera named '%s'", o->scene_file, o->camera);
        goto done;
    }
    /* The output and the bake's header before the world is built. */
    if (sg_prog_check_output(o->out, &err) != SG_OK ||
        sg_prog_bake_plan(o->scene_file, o->out, o->bake, &sf, &plan, &err) != SG_OK)
        goto done;
    double t0 = omp_get_wtime();
    if (sg_prog_build_world(o->scene_file, &sf, 0, &o->world, &world, &err) != SG_OK)
        goto done;
    double t_world = omp_get_wtime() - t0;
    t0 = omp_get_wtime();
    if (sg_prog_bake_obtain(&plan, &sf, world, &bake, &err) != SG_OK)
        goto done;
    double t_load = omp_get_wtime() - t0;
    sg_bake_frame_desc fd = {.width = o->have_width ? o->width : sf.render.width,
                             .height = o->have_height ? o->height : sf.render.height,
                             .threads = o->threads};
    float aspect = (float)fd.width / (float)fd.height;
    if (!cam && !o->have_eye && sf.camera_count)
        cam = &sf.cameras[0];
    sg_aabb bounds = sg_world_bounds(world);
    sg_vec3 centre = sg_v3_scale(sg_v3_add(bounds.lo, bounds.hi), 0.5f);
    sg_vec3 up = o->have_up ? o->up : sg_v3(0, 1, 0);
    sg_status st;
    if (cam)
        st = sg_camera_look_at(cam->eye, cam->look, cam->up, cam->fov_deg, aspect, &fd.camera, &err);
    else if (o->have_eye)
        st = sg_camera_look_at(o->eye, o->have_look ? o->look : centre, up, o->fov, aspect, &fd.camera, &err);
    else
        st = sg_camera_frame(bounds, sg_v3(0.0f, -0.35f, -1.0f), up, o->fov, aspect, 0.0f, &fd.camera, &err);
    if (st != SG_OK)
        goto done;
    double best = DBL_MAX, total = 0.0;
    for (int r = 0; r < o->repeat; r++) {
        double sec = 0.0;
        sg_image_free(&img);
        if (sg_bake_render(bake, world, &fd, &img, &sec, &err) != SG_OK)
            goto done;
        best = sec < best ? sec : best;
        total += sec;
    }
    /* Coverage, the alpha of an EXR: which of the frame's rays hit. */
    sg_coverage_desc cd = {.camera = fd.camera, .width = img.width, .height = img.height, .threads = o->threads};
    if (sg_coverage_render(world, &cd, &img.alpha, &err) != SG_OK)
        goto done;
    if (sg_image_write(&img, o->out, 1.0f, &err) != SG_OK)
        goto done;
    sg_bake_stats bs;
    sg_bake_get_stats(bake, &bs);
    printf("splatgi-render: %dx%d from %s (%zu splats, %zu photons), world %.2f s, bake %.3f s, "
           "frame %.1f ms best / %.1f ms mean (%d run%s) -> %s\n",
           img.width, img.height, plan.path, bs.splats, bs.photons_shot, t_world, t_load, best * 1e3,
           total / o->repeat * 1e3, o->repeat, o->repeat == 1 ? "" : "s", o->out);
    code = 0;
done:
    if (code)
        fprintf(stderr, "splatgi-render: %s\n", err.message[0] ? err.message : "failed");
    sg_image_free(&img);
    sg_bake_destroy(bake);
    sg_world_destroy(world);
    sg_scene_file_free(&sf);
    return code;
}

static void print_stats(const options *o, const sg_scene_info *info, const sg_render_stats *st,
                        double best, double mean, size_t splats)
{
    const sg_ray_stats *p = &st->primary;
    double r = p->rays ? (double)p->rays : 1.0;
    printf("\n%-28s %s\n", "surface",
           o->scene.model == SG_SURFACE_DISK ? "disk" : o->scene.model == SG_SURFACE_ISO ? "iso" : "mls");
    printf("%-28s %zu\n", "splats", splats);
    printf("%-28s %.3f s\n", "build time", info->build_seconds);
    printf("%-28s %.1f MiB\n", "scene memory", (double)info->memory_bytes / (1024.0 * 1024.0));
    printf("%-28s %zu nodes, %zu leaves (%zu empty), depth %d\n", "kd-tree", info->node_count,
           info->leaf_count, info->empty_leaf_count, info->depth);
    printf("%-28s %.2f\n", "splat refs per splat",
           info->splat_count ? (double)info->splat_refs / (double)info->splat_count : 0.0);
    printf("%-28s %.2f\n", "splat refs per full leaf",
           info->leaf_count > info->empty_leaf_count
               ? (double)info->splat_refs / (double)(info->leaf_count - info->empty_leaf_count)
               : 0.0);
    printf("\nper primary ray (%llu rays, %.1f%% hit)\n", (unsigned long long)p->rays,
           100.0 * (double)p->hits / r);
    printf("  %-26s %.2f\n", "nodes traversed", (double)p->nodes / r);
    printf("  %-26s %.2f\n", "leaves visited", (double)p->leaves / r);
    printf("  %-26s %.2f\n", "intersection tests", (double)p->isects / r);
    printf("  %-26s %.2f\n", "splats evaluated", (double)p->splats / r);
    if (st->shadow_rays) {
        const sg_ray_stats *s = &st->shadow;
        double rs = s->rays ? (double)s->rays : 1.0;
        printf("per shadow ray (%llu rays, %.1f%% occluded)\n", (unsigned long long)s->rays,
               100.0 * (double)s->hits / rs);
        printf("  %-26s %.2f\n", "nodes traversed", (double)s->nodes / rs);
        printf("  %-26s %.2f\n", "splats evaluated", (double)s->splats / rs);
    }
    printf("\n%-28s %.2f (best), %.2f (mean)\n", "Mrays/s", (double)st->rays / best * 1e-6,
           (double)st->rays / mean * 1e-6);
    printf("%-28s %.2f (best), %.2f (mean)\n", "fps", 1.0 / best, 1.0 / mean);
    printf("%-28s %d\n", "threads", o->threads > 0 ? o->threads : omp_get_max_threads());
}

int main(int argc, char **argv)
{
    options o = {.width = 512, .height = 512, .fov = 40.0f, .repeat = 1, .out = DEFAULT_OUT};
    sg_prog_init("splatgi-render");
    int pr = parse_args(argc, argv, &o);
    if (pr)
        return pr == 2 ? 0 : 1;
    if (o.scene_file)
        return render_from_bake(&o);

    int code = 1;
    sg_error err = {0};
    sg_default_scene def = {0};
    sg_pointset model = {0};
    const sg_pointset *points;
    sg_aabb bounds;          /* what the camera frames */
    sg_vec3 light = sg_v3(-0.5f, 0.8f, 0.45f);
    sg_scene *scene = NULL;
    sg_image img = {0};
    sg_render_desc rd = {.width = o.width, .height = o.height, .shade = o.shade, .threads = o.threads};
    float aspect = (float)o.width / (float)o.height;

    if (sg_prog_check_output(o.out, &err) != SG_OK)
        goto done;
    if (o.model) {
        sg_model_points_report rep;
        o.points.report = &rep;
        if (sg_model_points_load(o.model, &o.points, &model, &err) != SG_OK)
            goto done;
        if (!rep.has_colors) /* white points under this light: show them in a light grey */
            for (size_t i = 0; i < model.count; i++)
                model.ar[i] = model.ag[i] = model.ab[i] = 0.8f;
        if (rep.capped || rep.dropped)
            fprintf(stderr, "splatgi-render: note: %s: %zu splat radii capped at %.4g (%g x the median), %zu stray "
                            "points dropped\n", o.model, rep.capped, (double)rep.cap_radius,
                    (double)(o.points.radius_cap > 0.0f ? o.points.radius_cap : SG_RADIUS_CAP_DEFAULT), rep.dropped);
        if (o.model_scene.up != SG_SCENE_UP_POS_Y) /* --up z: a Z-up scan stood upright */
            for (size_t i = 0; i < model.count; i++) {
                sg_vec3 p = sg_scene_up_apply(o.model_scene.up, sg_pointset_position(&model, i));
                sg_vec3 n = sg_scene_up_apply(o.model_scene.up, sg_pointset_normal(&model, i));
                model.px[i] = p.x, model.py[i] = p.y, model.pz[i] = p.z;
                model.nx[i] = n.x, model.ny[i] = n.y, model.nz[i] = n.z;
            }
        points = &model;
        bounds = sg_pointset_bounds(&model);
    } else {
        sg_default_scene_desc dd = {.model = o.points};
        if (sg_default_scene_load(&dd, &def, &err) != SG_OK)
            goto done;
        points = &def.points;
        bounds = def.model_bounds;
        light = def.light_dir;
    }
    if (o.have_light)
        light = o.light;
    rd.light_dir = light;

    /* Camera: explicit eye wins; otherwise the default scene's view or a
     * framed 3/4 view of the model. */
    sg_vec3 centre = sg_v3_scale(sg_v3_add(bounds.lo, bounds.hi), 0.5f);
    sg_vec3 up = o.have_up ? o.up : sg_v3(0, 1, 0);
    sg_status st;
    if (o.have_eye)
        st = sg_camera_look_at(o.eye, o.have_look ? o.look : centre, up, o.fov, aspect, &rd.camera, &err);
    else if (!o.model && !o.have_look && !o.have_up)
        st = sg_default_scene_camera(&def, o.fov, aspect, &rd.camera, &err);
    else {
        sg_vec3 target = o.have_look ? o.look : centre;
        sg_aabb box = {sg_v3_add(bounds.lo, sg_v3_sub(target, centre)),
                       sg_v3_add(bounds.hi, sg_v3_sub(target, centre))};
        st = sg_camera_frame(box, sg_v3(-0.6f, -0.35f, -1.0f), up, o.fov, aspect, 0.0f, &rd.camera, &err);
    }
    if (st != SG_OK)
        goto done;

    if (sg_scene_create(&o.scene, points, &scene, &err) != SG_OK)
        goto done;
    size_t splats = points->count;
    sg_pointset_free(&model);
    sg_default_scene_free(&def);

    sg_render_stats stats = {0};
    double best = DBL_MAX, total = 0.0;
    for (int r = 0; r < o.repeat; r++) {
        sg_image_free(&img);
        if (sg_render_frame(scene, &rd, &img, &stats, &err) != SG_OK)
            goto done;
        best = stats.seconds < best ? stats.seconds : best;
        total += stats.seconds;
    }
    double mean = total / o.repeat;
    if (!(best > 0.0)) best = 1e-9;
    if (!(mean > 0.0)) mean = 1e-9;
    if (sg_image_write(&img, o.out, 1.0f, &err) != SG_OK)
        goto done;

    sg_scene_info info;
    sg_scene_get_info(scene, &info);
    printf("splatgi-render: %dx%d, %zu splats, build %.2f s, frame %.1f ms best / %.1f ms mean "
           "(%d run%s), %.2f Mrays/s -> %s\n",
           img.width, img.height, splats, info.build_seconds, best * 1e3, mean * 1e3, o.repeat,
           o.repeat == 1 ? "" : "s", (double)stats.rays / best * 1e-6, o.out);
    if (o.stats)
        print_stats(&o, &info, &stats, best, mean, splats);
    code = 0;
done:
    if (code)
        fprintf(stderr, "splatgi-render: %s\n", err.message[0] ? err.message : "failed");
    sg_image_free(&img);
    sg_scene_destroy(scene);
    sg_pointset_free(&model);
    sg_default_scene_free(&def);
    return code;
}
