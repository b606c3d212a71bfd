/* cli.h — parsing command-line option values, for the programs.
 *
 * The programs (viewer/, precompute/, bench/) share these so that every
 * option error reads the same: "--width: 'abc' is not an integer in
 * [1, 65536]". They never print: the program prefixes its name and prints
 * err->message. *out is written only on SG_OK.
 */
#ifndef SG_CORE_CLI_H
#define SG_CORE_CLI_H

#include <stddef.h>

#include "core/error.h"
#include "math/vec3.h"

/* A whole decimal integer in [lo, hi]. s may be NULL (a missing value). */
sg_status sg_cli_long(const char *opt, const char *s, long lo, long hi, long *out, sg_error *err);

/* A finite number > lo (strictly: lo is a lower limit such as 0). */
sg_status sg_cli_float_above(const char *opt, const char *s, float lo, float *out, sg_error *err);

/* A comma-separated list "a,b,c" of whole decimal numbers, each in [lo, hi],
 * at most cap of them, into vals[0..*n). Empty items and a trailing comma
 * are errors; on an error vals may be partly written, *n is not. */
sg_status sg_cli_size_list(const char *opt, const char *s, unsigned long long lo, unsigned long long hi, size_t *vals,
                           int cap, int *n, sg_error *err);

/* Three finite numbers "x,y,z". */
sg_status sg_cli_vec3(const char *opt, const char *s, sg_vec3 *out, sg_error *err);

#endif
