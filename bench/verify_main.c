/* splatgi-verify — the verification suite's front end (src/verify/verify.h):
 * parses options, runs the chosen parts, reports. Charts are drawn from its
 * CSV by scripts/verify-charts.sh; scripts/verify.sh does both.
 *
 * Exit status: 0 all good; 1 an error (message on stderr); 2 the run
 * finished but a stability case was flagged (NaN, timeout, crash, error). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/cli.h"
#include "verify/cases.h"
#include "verify/verify.h"

static const char usage[] =
    "usage: splatgi-verify [options]\n"
    "Speed against accuracy and the stability map: CSV and Markdown in --out-dir.\n"
    "  --ci               tiny sizes, built-in bunny only (the ctest sweep, < 1 min)\n"
    "  --parts A,B,...    stability, surfaces, bake, scaling, headline, gi, all (default all)\n"
    "  --sizes A,B,...    scaling point counts (default 2000,8000,32000,128000,512000,1000000;\n"
    "                     the process peaks at ~0.6 KB per point: 24M needs ~13 GiB;\n"
    "                     --ci: 2000,8000)\n"
    "  --case NAME        stability: only this case (see --list-cases)\n"
    "  --timeout S        stability: seconds per case and model (default 300; --ci 60)\n"
    "  --out-dir DIR      tables (default out/verify)\n"
    "  --diff-dir DIR     difference images (default OUT/diff)\n"
    "  --cache-dir DIR    converged references (default out/verify/cache)\n"
    "  --work-dir DIR     generated stability inputs (default out/verify/work)\n"
    "  --data-dir DIR     real data (default ../shared/data beside the source tree)\n"
    "  --list-cases       print the stability cases and exit\n"
    "  --quiet            no progress lines\n"
    "  --help             this text\n";

static int parse_sizes(const char *s, sg_verify_desc *d)
{
    return sg_cli_size_list("--sizes", s, 100, 100000000ull, d->sizes, SG_VERIFY_MAX_SIZES, &d->n_sizes, NULL) == SG_OK;
}

int main(int argc, char **argv)
{
    sg_verify_desc d = {.log = stdout};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            fputs(usage, stdout);
            return 0;
        } else if (strcmp(a, "--ci") == 0)
            d.ci = 1;
        else if (strcmp(a, "--quiet") == 0)
            d.log = NULL;
        else if (strcmp(a, "--list-cases") == 0) {
            for (int c = 0; c < sg_verify_case_count(); c++)
                printf("%s\n", sg_verify_case_name(c));
            return 0;
        } else if (!v) {
            fprintf(stderr, "splatgi-verify: %s needs a value or is unknown (see --help)\n", a);
            return 1;
        } else {
            i++;
            if (strcmp(a, "--parts") == 0) {
                char buf[256];
                snprintf(buf, sizeof buf, "%s", v);
                d.parts = 0;
                for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
                    unsigned bit = sg_verify_part_parse(tok);
                    if (!bit) {
                        fprintf(stderr, "splatgi-verify: --parts: unknown part '%s'\n", tok);
                        return 1;
                    }
                    d.parts |= bit;
                }
            } else if (strcmp(a, "--sizes") == 0) {
                if (!parse_sizes(v, &d)) {
                    fprintf(stderr, "splatgi-verify: --sizes '%s': want up to %d counts in [100, 1e8]\n", v,
                            SG_VERIFY_MAX_SIZES);
                    return 1;
                }
            } else if (strcmp(a, "--case") == 0) {
                if (sg_verify_case_find(v) < 0) {
                    fprintf(stderr, "splatgi-verify: --case '%s': no such case (see --list-cases)\n", v);
                    return 1;
                }
                d.only_case = v;
            } else if (strcmp(a, "--timeout") == 0) {
                char *end;
                d.case_timeout_s = strtod(v, &end);
                if (*end || !(d.case_timeout_s > 0)) {
                    fprintf(stderr, "splatgi-verify: --timeout '%s': want seconds > 0\n", v);
                    return 1;
                }
            } else if (strcmp(a, "--out-dir") == 0)
                d.out_dir = v;
            else if (strcmp(a, "--diff-dir") == 0)
                d.diff_dir = v;
            else if (strcmp(a, "--cache-dir") == 0)
                d.cache_dir = v;
            else if (strcmp(a, "--work-dir") == 0)
                d.work_dir = v;
            else if (strcmp(a, "--data-dir") == 0)
                d.data_dir = v;
            else {
                fprintf(stderr, "splatgi-verify: unknown option %s (see --help)\n", a);
                return 1;
            }
        }
    }
    sg_verify_summary s;
    sg_error err = {0};
    if (sg_verify_run(&d, &s, &err) != SG_OK) {
        fprintf(stderr, "splatgi-verify: %s\n", err.message);
        return 1;
    }
    printf("splatgi-verify: %d rows in %.0f s; stability runs %d, flagged %d\n", s.rows, s.seconds, s.cases_run,
           s.flagged);
    return s.flagged ? 2 : 0;
}
