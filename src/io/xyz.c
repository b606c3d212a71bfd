/* xyz.c — text point clouds (see xyz.h).
 *
 * Flow: read the whole file -> one pass counting point lines and columns
 * and deciding whether columns 4..6 of a 6-column file are normals ->
 * allocate -> a second pass storing the values.
 *
 * Invariants:
 *  1. Allocation is bounded by the file: a point line takes at least 6
 *     bytes ("0 0 0\n"), so points <= size / 6 + 1.
 *  2. Both passes split lines and fields the same way (next_line,
 *     next_field), so the second pass finds exactly what the first counted.
 */
#include "io/xyz.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "core/alloc.h"
#include "io/ply.h" /* sg_io_read_all, sg_io_parse_number */

enum { TOKEN_ECHO = 24, MAX_COLUMNS = 16 };

typedef struct line_iter {
    const char *p, *end;
    size_t number; /* 1-based number of the line last returned */
} line_iter;

/* The next line [*s, *e) without its '\n' / "\r\n"; false at the end. */
static bool next_line(line_iter *it, const char **s, const char **e)
{
    if (it->p >= it->end)
        return false;
    const char *nl = memchr(it->p, '\n', (size_t)(it->end - it->p));
    *s = it->p;
    *e = nl ? nl : it->end;
    it->p = nl ? nl + 1 : it->end;
    if (*e > *s && (*e)[-1] == '\r')
        --*e;
    it->number++;
    return true;
}

static bool is_sep(char c) { return c == ' ' || c == '\t' || c == ',' || c == ';' || c == '\r'; }

/* The next field of [*p, e); false when only separators are left. */
static bool next_field(const char **p, const char *e, const char **fs, const char **fe)
{
    const char *q = *p;
    while (q < e && is_sep(*q))
        ++q;
    if (q >= e)
        return false;
    *fs = q;
    while (q < e && !is_sep(*q))
        ++q;
    *fe = q;
    *p = q;
    return true;
}

/* A line to skip: blank, '#' or "//" first. */
static bool skip_line(const char *s, const char *e)
{
    while (s < e && is_sep(*s))
        ++s;
    return s == e || *s == '#' || (e - s >= 2 && s[0] == '/' && s[1] == '/');
}

/* Parses the fields of one line into v[0..*n). */
static sg_status parse_line(const char *path, size_t line, const char *s, const char *e, double *v, int *n,
                            sg_error *err)
{
    const char *fs, *fe;
    *n = 0;
    while (next_field(&s, e, &fs, &fe)) {
        if (*n == MAX_COLUMNS)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: more than %d columns", path, line, MAX_COLUMNS);
        const char *q = fs;
        if (!sg_io_parse_number(&q, fe, &v[*n]) || q != fe)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: column %d: '%.*s' is not a number", path, line,
                                *n + 1, (int)((fe - fs) < TOKEN_ECHO ? (fe - fs) : TOKEN_ECHO), fs);
        ++*n;
    }
    return SG_OK;
}

/* Column layout: where normals and colours start (-1: none). */
typedef struct layout {
    int columns, normal, color;
} layout;

static float srgb_to_linear(double c)
{
    return (float)(c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4));
}

sg_status sg_xyz_read(const char *path, sg_mesh *out, sg_error *err)
{
    if (!path || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_xyz_read: path and out must not be NULL");
    char *buf = NULL;
    size_t size = 0;
    sg_mesh m = {0};
    sg_status st = sg_io_read_all(path, &buf, &size, err);
    if (st != SG_OK)
        return st;

    /* Pass 1: count, check the column count, decide normals vs colours. */
    layout lay = {0, -1, -1};
    size_t points = 0, first_line = 0;
    bool six_unit = true;    /* every 4..6 triple of a 6-column file has unit length (or 0) */
    double color_max = 0.0;  /* largest colour value, for the 0..255 / 0..1 decision */
    double v[MAX_COLUMNS];
    line_iter it = {buf, buf + size, 0};
    const char *s, *e;
    while (next_line(&it, &s, &e)) {
        if (skip_line(s, e))
            continue;
        int n;
        if ((st = parse_line(path, it.number, s, e, v, &n, err)) != SG_OK)
            goto fail;
        if (points == 0) {
            lay.columns = n;
            first_line = it.number;
            if (n != 3 && n != 4 && n != 6 && n != 7 && n != 9) {
                st = sg_error_set(err, SG_ERR_CORRUPT,
                                  "%s: line %zu: %d columns; expected x y z [nx ny nz] [r g b] (3, 6 or 9 columns; "
                                  "4 or 7 with a scalar after z)", path, it.number, n);
                goto fail;
            }
        } else if (n != lay.columns) {
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: %d columns, but line %zu has %d", path, it.number, n,
                              first_line, lay.columns);
            goto fail;
        }
        for (int a = 0; a < 3; ++a)
            if (!isfinite((float)v[a])) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: %c is %s", path, it.number, "xyz"[a],
                                  isnan(v[a]) ? "NaN" : isinf(v[a]) ? "infinite" : "out of float range");
                goto fail;
            }
        if (n == 6) {
            double len = sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5]);
            six_unit &= len == 0.0 || fabs(len - 1.0) <= 0.1;
        }
        int c0 = n == 6 || n == 7 ? n - 3 : n == 9 ? 6 : -1;
        for (int c = 0; c0 >= 0 && c < 3; ++c)
            color_max = fmax(color_max, v[c0 + c]);
        if (++points > UINT32_MAX) {
            st = sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: more than 2^32 - 1 points", path);
            goto fail;
        }
    }
    if (points == 0) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: no points (expected lines of x y z)", path);
        goto fail;
    }
    switch (lay.columns) {
    case 6: lay.normal = six_unit ? 3 : -1; lay.color = six_unit ? -1 : 3; break;
    case 7: lay.color = 4; break;
    case 9: lay.normal = 3; lay.color = 6; break;
    default: break;
    }
    if (lay.color < 0)
        color_max = 0.0;
    const double color_scale = color_max > 1.0 ? 1.0 / 255.0 : 1.0;

    /* Invariant 1 bounds these. */
    m.vertex_count = points;
    m.positions = sg_alloc_array(points, 3 * sizeof(float));
    if (lay.normal >= 0)
        m.normals = sg_alloc_array(points, 3 * sizeof(float));
    if (lay.color >= 0)
        m.colors = sg_alloc_array(points, 3 * sizeof(float));
    if (!m.positions || (lay.normal >= 0 && !m.normals) || (lay.color >= 0 && !m.colors)) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu points", path, points);
        goto fail;
    }

    /* Pass 2: store (invariant 2). */
    it = (line_iter){buf, buf + size, 0};
    size_t i = 0;
    while (next_line(&it, &s, &e)) {
        if (skip_line(s, e))
            continue;
        int n;
        if ((st = parse_line(path, it.number, s, e, v, &n, err)) != SG_OK)
            goto fail;
        for (int a = 0; a < 3; ++a)
            m.positions[3 * i + a] = (float)v[a];
        if (lay.normal >= 0) {
            double len = sqrt(v[lay.normal] * v[lay.normal] + v[lay.normal + 1] * v[lay.normal + 1] +
                              v[lay.normal + 2] * v[lay.normal + 2]);
            for (int a = 0; a < 3; ++a)
                m.normals[3 * i + a] = len > 0.0 && isfinite(len) ? (float)(v[lay.normal + a] / len) : 0.0f;
        }
        if (lay.color >= 0) {
            for (int c = 0; c < 3; ++c) {
                double x = v[lay.color + c] * color_scale;
                if (!(x >= 0.0 && x <= 1.0)) {
                    st = sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: colour %c = %g is outside [0, %s]", path,
                                      it.number, "rgb"[c], v[lay.color + c], color_scale < 1.0 ? "255" : "1");
                    goto fail;
                }
                m.colors[3 * i + c] = srgb_to_linear(x);
            }
        }
        ++i;
    }
    sg_free(buf);
    *out = m;
    return SG_OK;

fail:
    sg_mesh_free(&m);
    sg_free(buf);
    return st;
}
