/* verify.c — the verification suite's driver (verify.h) and the helpers
 * its parts share (verify_int.h).
 *
 * Order: STABILITY first (it forks; no OpenMP team exists yet in this
 * process), then the sweeps (sweeps.c), which run in this process.
 */
#include "verify/verify.h"

#include <errno.h>
#include <omp.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "verify/verify_int.h"

unsigned sg_verify_part_parse(const char *name)
{
    static const struct {
        const char *name;
        unsigned bit;
    } parts[] = {{"stability", SG_VERIFY_STABILITY}, {"surfaces", SG_VERIFY_SURFACES}, {"bake", SG_VERIFY_BAKE},
                 {"scaling", SG_VERIFY_SCALING},     {"headline", SG_VERIFY_HEADLINE}, {"gi", SG_VERIFY_GI},
                 {"all", SG_VERIFY_ALL}};
    for (size_t i = 0; i < sizeof parts / sizeof parts[0]; i++)
        if (strcmp(name, parts[i].name) == 0)
            return parts[i].bit;
    return 0;
}

void sg_verify__log(const vctx *c, const char *fmt, ...)
{
    if (!c->d.log)
        return;
    va_list ap;
    va_start(ap, fmt);
    vfprintf(c->d.log, fmt, ap);
    va_end(ap);
    fflush(c->d.log);
}

void sg_verify__tprintf(vtable *t, const char *fmt, ...)
{
    if (t->failed)
        return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        size_t room = t->cap - t->len;
        int n = vsnprintf(t->buf ? t->buf + t->len : NULL, t->buf ? room : 0, fmt, ap);
        va_end(ap);
        if (n < 0) {
            t->failed = 1;
            return;
        }
        if (t->buf && (size_t)n < room) {
            t->len += (size_t)n;
            return;
        }
        size_t cap = t->cap ? 2 * t->cap : 8192;
        while (cap - t->len <= (size_t)n)
            cap *= 2;
        char *nb = realloc(t->buf, cap);
        if (!nb) {
            t->failed = 1;
            return;
        }
        t->buf = nb;
        t->cap = cap;
    }
}

void sg_verify__tfree(vtable *t)
{
    free(t->buf);
    memset(t, 0, sizeof *t);
}

int sg_verify__make_dirs(const char *path)
{
    char buf[4096];
    if (snprintf(buf, sizeof buf, "%s", path) >= (int)sizeof buf)
        return 0;
    for (char *p = buf + 1; *p; p++)
        if (*p == '/') {
            *p = 0;
            if (mkdir(buf, 0777) != 0 && errno != EEXIST)
                return 0;
            *p = '/';
        }
    return mkdir(buf, 0777) == 0 || errno == EEXIST;
}

sg_status sg_verify__twrite(vtable *t, const char *dir, const char *name, sg_error *err)
{
    char path[4200], tmp[4300];
    if (t->failed)
        return sg_error_set(err, SG_ERR_NOMEM, "%s/%s: out of memory building the table", dir, name);
    if (!sg_verify__make_dirs(dir))
        return sg_error_set(err, SG_ERR_IO, "%s: cannot create: %s", dir, strerror(errno));
    snprintf(path, sizeof path, "%s/%s", dir, name);
    snprintf(tmp, sizeof tmp, "%s.tmp%ld", path, (long)getpid());
    FILE *f = fopen(tmp, "w");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot create: %s", tmp, strerror(errno));
    int ok = t->len == 0 || fwrite(t->buf, 1, t->len, f) == t->len;
    ok = (fclose(f) == 0) && ok;
    if (!ok || rename(tmp, path) != 0) {
        remove(tmp);
        return sg_error_set(err, SG_ERR_IO, "%s: cannot write", path);
    }
    return SG_OK;
}

sg_status sg_verify__compare(const vctx *c, const sg_image *a, const sg_image *ref, const char *name,
                             sg_image_metrics *m, sg_error *err)
{
    sg_image diff = {0};
    sg_status st = sg_image_compare(a, ref, m, name ? &diff : NULL, err);
    if (st != SG_OK || !name)
        return st;
    double lum = 0.2126 * m->mean_b[0] + 0.7152 * m->mean_b[1] + 0.0722 * m->mean_b[2];
    sg_image fc = {0};
    sg_error perr;
    char path[4300];
    snprintf(path, sizeof path, "%s/%s.png", c->d.diff_dir, name);
    if (!(lum > 0) || !sg_verify__make_dirs(c->d.diff_dir) ||
        sg_image_false_colour(&diff, 0.5 * lum, &fc, &perr) != SG_OK ||
        sg_image_write_png(&fc, path, 1.0f, &perr) != SG_OK)
        sg_verify__log(c, "  (no difference image %s)\n", path);
    sg_image_free(&fc);
    sg_image_free(&diff);
    return SG_OK;
}

double sg_verify__rss_mib(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f)
        return 0;
    char line[256];
    double kib = 0;
    while (fgets(line, sizeof line, f))
        if (strncmp(line, "VmRSS:", 6) == 0) {
            kib = strtod(line + 6, NULL);
            break;
        }
    fclose(f);
    return kib / 1024.0;
}

sg_status sg_verify_run(const sg_verify_desc *d, sg_verify_summary *summary, sg_error *err)
{
    sg_verify_summary sum = {0};
    vctx c = {.d = *d, .sum = &sum};
    static char diff_default[4200];
    if (!c.d.parts)
        c.d.parts = SG_VERIFY_ALL;
    if (!c.d.out_dir)
        c.d.out_dir = "out/verify";
    if (!c.d.diff_dir) {
        snprintf(diff_default, sizeof diff_default, "%s/diff", c.d.out_dir);
        c.d.diff_dir = diff_default;
    }
    if (!c.d.cache_dir)
        c.d.cache_dir = "out/verify/cache";
    if (!c.d.work_dir)
        c.d.work_dir = "out/verify/work";
    if (!c.d.data_dir)
        c.d.data_dir = SG_SHARED_DATA_DIR;
    if (!(c.d.case_timeout_s > 0))
        c.d.case_timeout_s = c.d.ci ? 60 : 300;
    if (c.d.n_sizes == 0) {
        static const size_t full[] = {2000, 8000, 32000, 128000, 512000, 1000000}, ci[] = {2000, 8000};
        const size_t *s = c.d.ci ? ci : full;
        c.d.n_sizes = c.d.ci ? 2 : 6;
        memcpy(c.d.sizes, s, sizeof(size_t) * (size_t)c.d.n_sizes);
    }
    if (c.d.n_sizes < 0 || c.d.n_sizes > SG_VERIFY_MAX_SIZES)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "verify: %d sizes (at most %d)", c.d.n_sizes,
                            SG_VERIFY_MAX_SIZES);
    if (!sg_verify__make_dirs(c.d.out_dir))
        return sg_error_set(err, SG_ERR_IO, "%s: cannot create: %s", c.d.out_dir, strerror(errno));
    double t0 = omp_get_wtime();
    sg_status st = SG_OK;
    if (c.d.parts & SG_VERIFY_STABILITY)
        st = sg_verify__stability(&c, err);
    if (st == SG_OK && (c.d.parts & ~(unsigned)(SG_VERIFY_STABILITY | SG_VERIFY_GI)))
        st = sg_verify__sweeps(&c, err);
    if (st == SG_OK && (c.d.parts & SG_VERIFY_GI))
        st = sg_verify__gi(&c, err);
    sum.seconds = omp_get_wtime() - t0;
    if (st == SG_OK && summary)
        *summary = sum;
    return st;
}
