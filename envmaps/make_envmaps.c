/* splatgi-envmap — writes an analytic environment map (analytic.h) to an
 * EXR file: options, one library call, a report. Run with --help.
 */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "envmap/analytic.h"
#include "envmap/envmap.h"
#include "io/image.h"

static const char usage[] =
    "usage: splatgi-envmap --type T [--width W] [--height H] [--out FILE]\n"
    "Writes an analytic lat-long environment map as a float EXR (ZIP).\n"
    "\n"
    "  --type T      uniform | sky | sunsky | studio (required)\n"
    "                uniform: radiance 1; sky: blue gradient over a brown ground;\n"
    "                sunsky: sky + 0.5 deg sun of radiance 1e5 at elevation 40 deg;\n"
    "                studio: dark room with four rectangular softboxes\n"
    "  --width W     columns (default 1024, or 2 x height)\n"
    "  --height H    rows (default width / 2)\n"
    "  --out FILE    output .exr (default <type>.exr in the current folder)\n"
    "  --help        this text\n"
    "Mapping: u = 0.5 + atan2(z, x) / 2pi, v = acos(y) / pi, +Y up (DESIGN.md).\n";

static int parse_int(const char *opt, const char *s, int *out)
{
    char *end = NULL;
    errno = 0;
    long v = s ? strtol(s, &end, 10) : 0;
    if (!s || errno || end == s || *end || v < 1 || v > INT_MAX) {
        fprintf(stderr, "splatgi-envmap: %s needs a positive integer, got \"%s\"\n", opt,
                s ? s : "");
        return 0;
    }
    *out = (int)v;
    return 1;
}

int main(int argc, char **argv)
{
    sg_analytic_desc desc = {0};
    const char *type = NULL, *out = NULL;
    for (int a = 1; a < argc; a++) {
        const char *arg = argv[a], *val = a + 1 < argc ? argv[a + 1] : NULL;
        if (strcmp(arg, "--help") == 0 || strcmp(arg, "-h") == 0) {
            fputs(usage, stdout);
            return 0;
        } else if (strcmp(arg, "--type") == 0 && val) {
            type = val;
            a++;
        } else if (strcmp(arg, "--width") == 0) {
            if (!parse_int(arg, val, &desc.width))
                return 2;
            a++;
        } else if (strcmp(arg, "--height") == 0) {
            if (!parse_int(arg, val, &desc.height))
                return 2;
            a++;
        } else if (strcmp(arg, "--out") == 0 && val) {
            out = val;
            a++;
        } else {
            fprintf(stderr, "splatgi-envmap: unknown or incomplete option \"%s\"\n\n%s", arg, usage);
            return 2;
        }
    }
    if (!type) {
        fprintf(stderr, "splatgi-envmap: --type is required\n\n%s", usage);
        return 2;
    }
    sg_error err = {0};
    if (sg_analytic_type_parse(type, &desc.type, &err) != SG_OK) {
        fprintf(stderr, "splatgi-envmap: %s\n", err.message);
        return 2;
    }
    char default_out[64];
    if (!out) {
        snprintf(default_out, sizeof default_out, "%s.exr", type);
        out = default_out;
    }

    sg_image img = {0};
    sg_envmap *env = NULL;
    int rc = 1;
    if (sg_analytic_make(&desc, &img, &err) != SG_OK)
        goto done;
    sg_envmap_desc ed = {.image = &img};
    if (sg_envmap_create(&ed, &env, &err) != SG_OK)
        goto done;
    if (sg_image_write_exr(&img, out, &err) != SG_OK)
        goto done;
    sg_envmap_info info;
    sg_envmap_get_info(env, &info);
    sg_vec3 mean = sg_envmap_mean_radiance(env);
    sg_vec3 up = sg_envmap_irradiance(env, sg_v3(0, 1, 0));
    printf("wrote %s: %s %dx%d, max %.6g, mean radiance (%.6g, %.6g, %.6g), "
           "irradiance on +Y (%.6g, %.6g, %.6g)\n",
           out, type, info.width, info.height, (double)info.max_value, (double)mean.x, (double)mean.y,
           (double)mean.z, (double)up.x, (double)up.y, (double)up.z);
    rc = 0;
done:
    if (rc)
        fprintf(stderr, "splatgi-envmap: %s\n", err.message);
    sg_envmap_destroy(env);
    sg_image_free(&img);
    return rc;
}
