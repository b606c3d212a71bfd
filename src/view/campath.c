/* campath.c — camera path files (campath.h).
 *
 * Invariants:
 *  1. keys[0 .. count) each pass campath__check; times are non-decreasing.
 *  2. count <= capacity; keys is NULL iff capacity == 0.
 */
#include "view/campath.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/alloc.h"
#include "core/file_mode.h"

#define CAMPATH__NUMBERS 11

/* NULL if k is a valid key, else what is wrong (static text or buf). */
static const char *campath__check(const sg_campath_key *k, char *buf, size_t bufsize)
{
    const sg_nav_view *v = &k->view;
    if (!isfinite(k->time) || !sg_v3_isfinite(v->eye) || !sg_v3_isfinite(v->look) || !sg_v3_isfinite(v->up) ||
        !isfinite(v->fov_deg))
        return "a number is not finite";
    if (!(v->fov_deg > 0.0f && v->fov_deg < 180.0f)) {
        snprintf(buf, bufsize, "fov %g is not in (0, 180)", (double)v->fov_deg);
        return buf;
    }
    sg_vec3 d = sg_v3_sub(v->look, v->eye);
    if (d.x == 0.0f && d.y == 0.0f && d.z == 0.0f)
        return "look equals eye";
    sg_vec3 c = sg_v3_cross(d, v->up);
    if (!(sg_v3_length(c) > 1e-6f * sg_v3_length(d) * sg_v3_length(v->up)))
        return "up is parallel to look - eye (or zero)";
    return NULL;
}

static sg_status campath__push(sg_campath *p, const sg_campath_key *k, sg_error *err)
{
    if (p->count == p->capacity) {
        size_t cap = p->capacity ? 2 * p->capacity : 64;
        if (p->keys == NULL) {
            p->keys = sg_alloc_array(cap, sizeof *p->keys);
            if (!p->keys)
                return sg_error_set(err, SG_ERR_NOMEM, "camera path: out of memory");
        } else if (!sg_realloc_array((void **)&p->keys, p->count, cap, sizeof *p->keys)) {
            return sg_error_set(err, SG_ERR_NOMEM, "camera path: out of memory");
        }
        p->capacity = cap;
    }
    p->keys[p->count++] = *k;
    return SG_OK;
}

sg_status sg_campath_append(sg_campath *p, const sg_campath_key *k, sg_error *err)
{
    if (!p || !k)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_campath_append: NULL argument");
    char buf[96];
    const char *why = campath__check(k, buf, sizeof buf);
    if (why)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera key %zu: %s", p->count, why);
    if (p->count && k->time < p->keys[p->count - 1].time)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "camera key %zu: time %.17g is before the previous key's %.17g",
                            p->count, k->time, p->keys[p->count - 1].time);
    return campath__push(p, k, err);
}

void sg_campath_free(sg_campath *p)
{
    if (!p)
        return;
    sg_free(p->keys);
    memset(p, 0, sizeof *p);
}

sg_status sg_campath_write(const sg_campath *p, const char *path, sg_error *err)
{
    if (!p || !path)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_campath_write: NULL argument");
    size_t n = strlen(path);
    char *tmp = malloc(n + 8);
    if (!tmp)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    memcpy(tmp, path, n);
    memcpy(tmp + n, ".XXXXXX", 8);
    sg_status st = SG_OK;
    FILE *f = NULL;
    int fd = mkstemp(tmp);
    if (fd < 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: cannot create a temporary file: %s", path, strerror(errno));
        goto done_free;
    }
    f = fdopen(fd, "w");
    if (!f) {
        st = sg_error_set(err, SG_ERR_IO, "%s: %s", path, strerror(errno));
        close(fd);
        goto done_remove;
    }
    fprintf(f, "# splatgi camera path: time eye.x eye.y eye.z look.x look.y look.z up.x up.y up.z fov\n");
    for (size_t i = 0; i < p->count; i++) {
        const sg_campath_key *k = &p->keys[i];
        const sg_nav_view *v = &k->view;
        fprintf(f, "%.17g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", k->time, (double)v->eye.x,
                (double)v->eye.y, (double)v->eye.z, (double)v->look.x, (double)v->look.y, (double)v->look.z,
                (double)v->up.x, (double)v->up.y, (double)v->up.z, (double)v->fov_deg);
    }
    int bad = ferror(f);
    if (fclose(f) != 0 || bad) {
        st = sg_error_set(err, SG_ERR_IO, "%s: write failed: %s", path, strerror(errno));
        goto done_remove;
    }
    /* mkstemp made it 0600: the mode every output gets (core/file_mode.h). */
    if (chmod(tmp, sg_output_file_mode(path)) != 0 || rename(tmp, path) != 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: rename failed: %s", path, strerror(errno));
        goto done_remove;
    }
    goto done_free;
done_remove:
    remove(tmp);
done_free:
    free(tmp);
    return st;
}

/* Parses one line (len bytes, no newline) into *k; returns NULL or what is
 * wrong (in buf). */
static const char *campath__parse_line(const char *s, size_t len, sg_campath_key *k, char *buf, size_t bufsize)
{
    double v[CAMPATH__NUMBERS];
    int got = 0;
    char num[128];
    size_t i = 0;
    while (i < len) {
        while (i < len && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r'))
            i++;
        if (i == len)
            break;
        size_t start = i;
        while (i < len && s[i] != ' ' && s[i] != '\t' && s[i] != '\r')
            i++;
        size_t w = i - start;
        if (got < CAMPATH__NUMBERS) {
            if (w >= sizeof num) {
                snprintf(buf, bufsize, "number %d is too long", got + 1);
                return buf;
            }
            memcpy(num, s + start, w);
            num[w] = '\0';
            char *end;
            errno = 0;
            double x = strtod(num, &end);
            if (end == num || *end || errno == ERANGE) {
                snprintf(buf, bufsize, "number %d: '%.64s' is not a number", got + 1, num);
                return buf;
            }
            v[got] = x;
        }
        got++;
    }
    if (got != CAMPATH__NUMBERS) {
        snprintf(buf, bufsize, "expected 11 numbers (time eye.xyz look.xyz up.xyz fov), got %d", got);
        return buf;
    }
    k->time = v[0];
    k->view.eye = sg_v3((float)v[1], (float)v[2], (float)v[3]);
    k->view.look = sg_v3((float)v[4], (float)v[5], (float)v[6]);
    k->view.up = sg_v3((float)v[7], (float)v[8], (float)v[9]);
    k->view.fov_deg = (float)v[10];
    return campath__check(k, buf, bufsize);
}

sg_status sg_campath_parse(const char *text, size_t len, const char *name, sg_campath *out, sg_error *err)
{
    if (!text || !name || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_campath_parse: NULL argument");
    sg_campath p = {0};
    sg_status st = SG_OK;
    size_t line = 0, pos = 0;
    char buf[160];
    while (pos < len) {
        size_t end = pos;
        while (end < len && text[end] != '\n')
            end++;
        line++;
        size_t a = pos;
        while (a < end && (text[a] == ' ' || text[a] == '\t' || text[a] == '\r'))
            a++;
        if (a < end && text[a] != '#') {
            sg_campath_key k;
            const char *why = campath__parse_line(text + a, end - a, &k, buf, sizeof buf);
            if (!why && p.count && k.time < p.keys[p.count - 1].time) {
                snprintf(buf, sizeof buf, "time %.17g is before the previous key's %.17g", k.time,
                         p.keys[p.count - 1].time);
                why = buf;
            }
            if (why) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s:%zu: %s", name, line, why);
                goto fail;
            }
            if ((st = campath__push(&p, &k, err)) != SG_OK)
                goto fail;
        }
        pos = end + 1;
    }
    if (p.count == 0) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: no camera keys", name);
        goto fail;
    }
    *out = p;
    return SG_OK;
fail:
    sg_campath_free(&p);
    return st;
}

sg_status sg_campath_read(const char *path, sg_campath *out, sg_error *err)
{
    if (!path || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_campath_read: NULL argument");
    FILE *f = fopen(path, "rb");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: %s", path, strerror(errno));
    char *text = NULL;
    size_t len = 0, cap = 0;
    sg_status st = SG_OK;
    for (;;) {
        if (len == cap) {
            size_t ncap = cap ? 2 * cap : 4096;
            char *t = realloc(text, ncap);
            if (!t) {
                st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
                goto done;
            }
            text = t;
            cap = ncap;
        }
        size_t got = fread(text + len, 1, cap - len, f);
        len += got;
        if (got == 0)
            break;
    }
    if (ferror(f)) {
        st = sg_error_set(err, SG_ERR_IO, "%s: read failed", path);
        goto done;
    }
    st = sg_campath_parse(text ? text : "", len, path, out, err);
done:
    free(text);
    fclose(f);
    return st;
}

sg_status sg_campath_camera(const sg_campath_key *k, float aspect, sg_camera *out, sg_error *err)
{
    const sg_nav_view *v = &k->view;
    return sg_camera_look_at(v->eye, v->look, v->up, v->fov_deg, aspect, out, err);
}

size_t sg_campath_index_at(const sg_campath *p, double t)
{
    size_t lo = 0, hi = p->count; /* first key with time > t lies in [lo, hi] */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (p->keys[mid].time <= t)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo ? lo - 1 : 0;
}
