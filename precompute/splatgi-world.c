/* splatgi-world — builds a scene's world once and saves it as a world file
 * (render/world_file.h, docs/world.md), which splatgi-render, -bake, -view
 * and -ref then load with --world instead of building the models again.
 * Thin: parse options, call the library, report.
 */
#include <omp.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "program.h"
#include "render/world_file.h"

static const char usage[] =
    "usage: splatgi-world SCENE.json|MODEL -o OUT.sgworld [--if-stale]\n"
    "Builds the models of the scene (point sets, surfaces and their kd-trees or\n"
    "octrees, materials) and saves them to OUT, which the programs load with\n"
    "--world OUT in a fraction of the build time (docs/world.md).\n"
    "  -o, --out FILE    the world file (required)\n"
    "  --if-stale        do nothing when OUT already holds the world of this scene\n"
    "                    (same models, surface options and materials; model files\n"
    "                    of the same size and modification time)\n"
    "  --check           only load OUT and check every section; exit 0 if it is a\n"
    "                    fresh world of this scene\n"
    "  --help\n"
    "\n" SG_MODEL_SCENE_OPTIONS;

static int fail(const char *msg)
{
    sg_prog_say("%s", msg);
    return 1;
}

int main(int argc, char **argv)
{
    const char *scene = NULL, *out = NULL, *write_scene = NULL;
    int if_stale = 0, check = 0;
    sg_model_scene_desc md = {0};
    sg_prog_init("splatgi-world");
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i];
        sg_error e = {0};
        int ms = sg_model_scene_option(argc, argv, &i, &md, &write_scene, &e);
        if (ms < 0)
            return fail(e.message);
        if (ms)
            continue;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return 0;
        } else if (!strcmp(a, "--if-stale")) {
            if_stale = 1;
        } else if (!strcmp(a, "--check")) {
            check = 1;
        } else if (!strcmp(a, "-o") || !strcmp(a, "--out")) {
            if (i + 1 >= argc)
                return fail("-o needs a value");
            out = argv[++i];
        } else if (a[0] == '-') {
            sg_prog_say("unknown option '%s' (see --help)", a);
            return 1;
        } else if (!scene) {
            scene = a;
        } else {
            return fail("more than one scene file given");
        }
    }
    if (!scene || !out)
        return fail("give a scene or model file and -o OUT.sgworld (see --help)");

    sg_error err = {0};
    sg_scene_file sf = {0};
    sg_world *w = NULL;
    int rc = 1;
    char why[SG_ERROR_MESSAGE_MAX];
    if (sg_prog_load_scene(scene, &md, write_scene, &sf, &err) != SG_OK)
        goto done;
    if (check) {
        double t0 = omp_get_wtime();
        if (sg_world_load(out, &sf, NULL, &w, &err) != SG_OK)
            goto done;
        printf("splatgi-world: %s: a fresh world of %s, every section checked (%.2f s)\n", out, scene,
               omp_get_wtime() - t0);
        rc = 0;
        goto done;
    }
    if (if_stale) {
        if (sg_world_file_fresh(out, &sf, why, sizeof why)) {
            printf("splatgi-world: %s is up to date\n", out);
            rc = 0;
            goto done;
        }
        sg_prog_say("%s", why);
    }
    if (sg_world_file_replaceable(out, &err) != SG_OK || sg_prog_check_output(out, &err) != SG_OK)
        goto done;
    double t0 = omp_get_wtime();
    if (sg_prog_build_world(scene, &sf, 0, NULL, &w, &err) != SG_OK)
        goto done;
    double t_build = omp_get_wtime() - t0;
    t0 = omp_get_wtime();
    if (sg_world_save(w, &sf, out, &err) != SG_OK)
        goto done;
    struct stat sb;
    double mib = stat(out, &sb) == 0 ? (double)sb.st_size / (1024.0 * 1024.0) : 0.0;
    printf("splatgi-world: wrote %s: %.1f MiB, %zu models; built in %.2f s, saved in %.2f s\n", out, mib,
           sg_world_model_count(w), t_build, omp_get_wtime() - t0);
    rc = 0;
done:
    if (rc && err.message[0])
        fail(err.message);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
    return rc;
}
