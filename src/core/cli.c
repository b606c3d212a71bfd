/* cli.c — option values (see cli.h). */
#include "core/cli.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

sg_status sg_cli_long(const char *opt, const char *s, long lo, long hi, long *out, sg_error *err)
{
    char *end = NULL;
    errno = 0;
    long v = s ? strtol(s, &end, 10) : 0;
    if (!s || errno || end == s || *end || v < lo || v > hi)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: '%s' is not an integer in [%ld, %ld]", opt, s ? s : "",
                            lo, hi);
    *out = v;
    return SG_OK;
}

sg_status sg_cli_float_above(const char *opt, const char *s, float lo, float *out, sg_error *err)
{
    char *end = NULL;
    errno = 0;
    float v = s ? strtof(s, &end) : 0.0f;
    if (!s || errno || end == s || *end || !isfinite(v) || !(v > lo))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: '%s' is not a number > %g", opt, s ? s : "", (double)lo);
    *out = v;
    return SG_OK;
}

sg_status sg_cli_size_list(const char *opt, const char *s, unsigned long long lo, unsigned long long hi, size_t *vals,
                           int cap, int *n, sg_error *err)
{
    int count = 0;
    for (const char *p = s; p && *p && count < cap;) {
        char *end;
        errno = 0;
        unsigned long long v = strtoull(p, &end, 10);
        if (errno || end == p || v < lo || v > hi)
            break;
        vals[count++] = (size_t)v;
        if (*end == '\0') {
            *n = count;
            return SG_OK;
        }
        if (*end != ',')
            break;
        p = end + 1;
    }
    return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: '%s' is not a list of at most %d integers in [%llu, %llu]", opt,
                        s ? s : "", cap, lo, hi);
}

sg_status sg_cli_vec3(const char *opt, const char *s, sg_vec3 *out, sg_error *err)
{
    float v[3];
    const char *p = s;
    for (int i = 0; p && i < 3; i++) {
        char *end;
        errno = 0;
        v[i] = strtof(p, &end);
        if (errno || end == p || !isfinite(v[i]) || (i < 2 ? *end != ',' : *end != '\0'))
            return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: '%s' is not x,y,z", opt, s);
        p = end + 1;
    }
    if (!s)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: missing x,y,z", opt);
    *out = sg_v3(v[0], v[1], v[2]);
    return SG_OK;
}
