/* pcd.c — PCL point clouds (see pcd.h; format: pointclouds.org, "The PCD
 * (Point Cloud Data) file format").
 *
 * Flow: read the file -> parse the header lines in order -> map fields to
 * roles -> check POINTS against the body size -> allocate -> read the
 * points (ascii tokens or binary records), skipping NaN points.
 *
 * Invariants:
 *  1. Nothing sized by the header is allocated before POINTS times the
 *     smallest record (binary: the record size; ascii: 2 bytes a value) is
 *     known to fit in the body.
 *  2. Binary reads never pass the end of the file: the record size times
 *     POINTS was checked against the body (1).
 */
#include "io/pcd.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "io/ply.h" /* sg_io_read_all, sg_io_parse_number */

enum { MAX_FIELDS = 64, TOKEN_ECHO = 24, NAME_MAX_LEN = 32 };

typedef enum role { R_SKIP = 0, R_X, R_Y, R_Z, R_NX, R_NY, R_NZ, R_RGB, R_R, R_G, R_B, R_RADIUS, R_COUNT } role;

typedef struct pcd_field {
    char name[NAME_MAX_LEN];
    unsigned size;  /* bytes per value: 1, 2, 4, 8 */
    char type;      /* 'I', 'U' or 'F'             */
    unsigned count; /* values                       */
    role r;
} pcd_field;

typedef struct pcd_header {
    pcd_field f[MAX_FIELDS];
    int nfields;
    uint64_t width, height, points;
    int binary;
    size_t body; /* offset of the first byte after the DATA line */
} pcd_header;

static const char *const KEYS[] = {"VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT",
                                   "POINTS", "DATA"};

static bool blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/* Next token of [*p, e) into [*ts, *te). */
static bool token(const char **p, const char *e, const char **ts, const char **te)
{
    const char *q = *p;
    while (q < e && blank(*q))
        ++q;
    if (q >= e)
        return false;
    *ts = q;
    while (q < e && !blank(*q))
        ++q;
    *te = q;
    *p = q;
    return true;
}

static bool tok_is(const char *s, const char *e, const char *w)
{
    size_t n = strlen(w);
    return (size_t)(e - s) == n && memcmp(s, w, n) == 0;
}

/* A whole unsigned decimal integer token. */
static bool tok_u64(const char *s, const char *e, uint64_t *out)
{
    uint64_t v = 0;
    if (s >= e)
        return false;
    for (; s < e; ++s) {
        if (*s < '0' || *s > '9' || v > (UINT64_MAX - 9) / 10)
            return false;
        v = v * 10 + (uint64_t)(*s - '0');
    }
    *out = v;
    return true;
}

static role role_of(const char *name)
{
    static const struct { const char *name; role r; } map[] = {
        {"x", R_X}, {"y", R_Y}, {"z", R_Z}, {"normal_x", R_NX}, {"normal_y", R_NY}, {"normal_z", R_NZ},
        {"rgb", R_RGB}, {"rgba", R_RGB}, {"r", R_R}, {"g", R_G}, {"b", R_B}, {"radius", R_RADIUS}};
    for (size_t i = 0; i < sizeof map / sizeof map[0]; ++i)
        if (strcmp(name, map[i].name) == 0)
            return map[i].r;
    return R_SKIP;
}

static sg_status parse_header(const char *path, const char *buf, size_t size, pcd_header *h, sg_error *err)
{
    const char *p = buf, *end = buf + size;
    size_t line = 0, next_key = 0;
    int have_size = 0, have_type = 0, have_count = 0, have_points = 0;
    while (p < end) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        const char *s = p, *e = nl ? nl : end;
        p = nl ? nl + 1 : end;
        ++line;
        const char *ts, *te;
        const char *q = s;
        if (!token(&q, e, &ts, &te) || *ts == '#')
            continue;
        size_t k = 0;
        while (k < sizeof KEYS / sizeof KEYS[0] && !tok_is(ts, te, KEYS[k]))
            ++k;
        if (k == sizeof KEYS / sizeof KEYS[0])
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %zu: unknown keyword '%.*s'", path, line,
                                (int)((te - ts) < TOKEN_ECHO ? (te - ts) : TOKEN_ECHO), ts);
        /* The keywords keep their order; VERSION, COUNT, WIDTH, HEIGHT,
         * VIEWPOINT and POINTS may be left out (older and hand-made files). */
        static const bool OPTIONAL[] = {true, false, false, false, true, true, true, true, true, false};
        size_t missing = k < next_key ? next_key : k;
        for (size_t j = next_key; j < k && missing == k; ++j)
            if (!OPTIONAL[j])
                missing = j;
        if (missing != k)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %zu: %s out of order (expected %s)", path,
                                line, KEYS[k], missing < sizeof KEYS / sizeof KEYS[0] ? KEYS[missing] : "the data");
        next_key = k + 1;
        const char *key = KEYS[k];
        int n = 0;
        switch (k) {
        case 0: /* VERSION */
        case 7: /* VIEWPOINT */
            break;
        case 1: /* FIELDS */
            while (token(&q, e, &ts, &te)) {
                if (h->nfields == MAX_FIELDS)
                    return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: line %zu: more than %d fields", path,
                                        line, MAX_FIELDS);
                if ((size_t)(te - ts) >= NAME_MAX_LEN)
                    return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %zu: field name '%.*s...' too long",
                                        path, line, TOKEN_ECHO, ts);
                pcd_field *f = &h->f[h->nfields++];
                memcpy(f->name, ts, (size_t)(te - ts));
                f->name[te - ts] = '\0';
                f->count = 1;
            }
            if (h->nfields == 0)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %zu: FIELDS lists no field", path, line);
            break;
        case 2: case 3: case 4: /* SIZE, TYPE, COUNT */
            while (token(&q, e, &ts, &te)) {
                if (n == h->nfields)
                    return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %zu: %s has more entries than the %d "
                                        "FIELDS", path, line, key, h->nfields);
                pcd_field *f = &h->f[n++];
                uint64_t v = 0;
                if (k == 3) {
                    if (te - ts != 1 || (*ts != 'I' && *ts != 'U' && *ts != 'F'))
                        return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %zu: TYPE of field %s: '%.*s' is "
                                            "not I, U or F", path, line, f->name,
                                            (int)((te - ts) < TOKEN_ECHO ? (te - ts) : TOKEN_ECHO), ts);
                    f->type = *ts;
                } else if (!tok_u64(ts, te, &v) || v == 0 || (k == 2 && v != 1 && v != 2 && v != 4 && v != 8) ||
                           v > 1u << 20) {
                    return sg_error_set(err, k == 2 && v > 0 && v <= 8 ? SG_ERR_UNSUPPORTED : SG_ERR_CORRUPT,
                                        "%s: header: line %zu: %s of field %s: '%.*s' is not %s", path, line, key,
                                        f->name, (int)((te - ts) < TOKEN_ECHO ? (te - ts) : TOKEN_ECHO), ts,
                                        k == 2 ? "1, 2, 4 or 8" : "a count in [1, 1048576]");
                } else if (k == 2) {
                    f->size = (unsigned)v;
                } else {
                    f->count = (unsigned)v;
                }
            }
            if (n != h->nfields)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %zu: %s has %d entries for %d FIELDS",
                                    path, line, key, n, h->nfields);
            *(k == 2 ? &have_size : k == 3 ? &have_type : &have_count) = 1;
            break;
        case 5: case 6: case 8: { /* WIDTH, HEIGHT, POINTS */
            uint64_t v;
            if (!token(&q, e, &ts, &te) || !tok_u64(ts, te, &v))
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %zu: %s needs a whole number", path, line,
                                    key);
            *(k == 5 ? &h->width : k == 6 ? &h->height : &h->points) = v;
            have_points |= k == 8;
            break;
        }
        case 9: /* DATA */
            if (!token(&q, e, &ts, &te))
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %zu: DATA needs ascii or binary", path,
                                    line);
            if (tok_is(ts, te, "ascii"))
                h->binary = 0;
            else if (tok_is(ts, te, "binary"))
                h->binary = 1;
            else if (tok_is(ts, te, "binary_compressed"))
                return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: DATA binary_compressed is not read; convert the file "
                                    "with: pcl_convert_pcd_ascii_binary %s out.pcd 1", path, path);
            else
                return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: line %zu: DATA '%.*s' is not ascii or "
                                    "binary", path, line, (int)((te - ts) < TOKEN_ECHO ? (te - ts) : TOKEN_ECHO), ts);
            h->body = (size_t)(p - buf);
            if (!have_size || !have_type)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: SIZE or TYPE is missing", path);
            (void)have_count; /* COUNT is optional: 1 each */
            if (!have_points && h->width && h->height && h->height <= UINT64_MAX / h->width)
                h->points = h->width * h->height;
            if (h->width && h->height && (h->height > UINT64_MAX / h->width || h->width * h->height != h->points))
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: WIDTH %" PRIu64 " x HEIGHT %" PRIu64
                                    " is not POINTS %" PRIu64, path, h->width, h->height, h->points);
            return SG_OK;
        default: break;
        }
    }
    return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: no DATA line (not a PCD file?)", path);
}

/* One binary value of field f at p (little-endian) as a double; for the
 * rgb role the raw bits are wanted instead: see read_bits. */
static double read_binary(const pcd_field *f, const unsigned char *p)
{
    uint64_t u = 0;
    for (unsigned b = 0; b < f->size; ++b)
        u |= (uint64_t)p[b] << (8 * b);
    if (f->type == 'F') {
        if (f->size == 4) {
            uint32_t w = (uint32_t)u;
            float x;
            memcpy(&x, &w, 4);
            return x;
        }
        if (f->size == 8) {
            double x;
            memcpy(&x, &u, 8);
            return x;
        }
        return NAN; /* F of size 1 or 2: rejected in map_fields */
    }
    if (f->type == 'U')
        return (double)u;
    unsigned shift = 64 - 8 * f->size; /* sign-extend */
    return (double)((int64_t)(u << shift) >> shift);
}

static float srgb8_to_linear(unsigned c)
{
    double x = c / 255.0;
    return (float)(x <= 0.04045 ? x / 12.92 : pow((x + 0.055) / 1.055, 2.4));
}

static sg_status map_fields(const char *path, pcd_header *h, int where[R_COUNT], sg_error *err)
{
    for (int r = 0; r < R_COUNT; ++r)
        where[r] = -1;
    for (int i = 0; i < h->nfields; ++i) {
        pcd_field *f = &h->f[i];
        if (f->type == 'F' && f->size != 4 && f->size != 8)
            return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: field %s: float of %u bytes", path, f->name,
                                f->size);
        f->r = role_of(f->name);
        if (f->r != R_SKIP && f->count != 1)
            f->r = R_SKIP; /* a multi-value x is no coordinate we know */
        if (f->r != R_SKIP && where[f->r] < 0)
            where[f->r] = i;
        else
            f->r = R_SKIP;
    }
    if (where[R_X] < 0 || where[R_Y] < 0 || where[R_Z] < 0)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: no x, y and z fields", path);
    if (where[R_RGB] >= 0 && h->f[where[R_RGB]].size != 4)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: field %s has %u bytes; PCL packs it in 4", path,
                            h->f[where[R_RGB]].name, h->f[where[R_RGB]].size);
    return SG_OK;
}

sg_status sg_pcd_read(const char *path, sg_mesh *out, sg_error *err)
{
    if (!path || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_pcd_read: path and out must not be NULL");
    char *buf = NULL;
    size_t size = 0;
    sg_mesh m = {0};
    pcd_header *h = NULL;
    sg_status st = sg_io_read_all(path, &buf, &size, err);
    if (st != SG_OK)
        return st;
    h = sg_calloc_array(1, sizeof *h);
    if (!h) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the header", path);
        goto fail;
    }
    if ((st = parse_header(path, buf, size, h, err)) != SG_OK)
        goto fail;
    int where[R_COUNT];
    if ((st = map_fields(path, h, where, err)) != SG_OK)
        goto fail;
    const bool normals = where[R_NX] >= 0 && where[R_NY] >= 0 && where[R_NZ] >= 0;
    const bool packed = where[R_RGB] >= 0;
    const bool colors = packed || (where[R_R] >= 0 && where[R_G] >= 0 && where[R_B] >= 0);
    const bool radii = where[R_RADIUS] >= 0;

    /* Invariant 1. */
    size_t record = 0, values = 0;
    for (int i = 0; i < h->nfields; ++i) {
        record += (size_t)h->f[i].size * h->f[i].count;
        values += h->f[i].count;
    }
    const size_t body = size - h->body;
    const size_t least = h->binary ? record : 2 * values;
    if (h->points > UINT32_MAX)
        st = sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: POINTS %" PRIu64 " exceeds the 32-bit range", path,
                          h->points);
    else if (h->points == 0 || (h->points > body / least + (h->binary ? 0 : 1)))
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: header: POINTS %" PRIu64 " %s", path, h->points,
                          h->points == 0 ? "(no points)" : "exceeds what the file can hold");
    if (st != SG_OK)
        goto fail;
    size_t n = (size_t)h->points;
    m.positions = sg_alloc_array(n, 3 * sizeof(float));
    m.normals = normals ? sg_alloc_array(n, 3 * sizeof(float)) : NULL;
    m.colors = colors ? sg_alloc_array(n, 3 * sizeof(float)) : NULL;
    m.radii = radii ? sg_alloc_array(n, sizeof(float)) : NULL;
    if (!m.positions || (normals && !m.normals) || (colors && !m.colors) || (radii && !m.radii)) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu points", path, n);
        goto fail;
    }

    const char *p = buf + h->body, *end = buf + size;
    size_t kept = 0;
    double val[R_COUNT];
    uint32_t rgb_bits = 0;
    for (size_t i = 0; i < n; ++i) {
        for (int r = 0; r < R_COUNT; ++r)
            val[r] = 0.0;
        if (h->binary) {
            const unsigned char *rec = (const unsigned char *)p + i * record; /* invariant 2 */
            for (int k = 0; k < h->nfields; ++k) {
                const pcd_field *f = &h->f[k];
                if (f->r != R_SKIP) {
                    val[f->r] = read_binary(f, rec);
                    if (f->r == R_RGB)
                        memcpy(&rgb_bits, rec, 4); /* little-endian host (CMake checks none; x86/arm) */
                }
                rec += (size_t)f->size * f->count;
            }
        } else {
            /* One point a line: the next non-blank line, exactly `values`
             * numbers on it. */
            const char *ls = p, *le = p;
            for (;;) {
                if (p >= end) {
                    st = sg_error_set(err, SG_ERR_CORRUPT, "%s: point %zu: file ends (truncated; POINTS %zu)", path,
                                      i, n);
                    goto fail;
                }
                const char *nl = memchr(p, '\n', (size_t)(end - p));
                ls = p;
                le = nl ? nl : end;
                p = nl ? nl + 1 : end;
                const char *q = ls;
                while (q < le && blank(*q))
                    ++q;
                if (q < le)
                    break;
            }
            size_t got = 0;
            const char *ts, *te, *q = ls;
            for (int k = 0; k < h->nfields; ++k) {
                const pcd_field *f = &h->f[k];
                for (unsigned c = 0; c < f->count; ++c, ++got) {
                    double v;
                    const char *vq;
                    if (!token(&q, le, &ts, &te)) {
                        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: point %zu: %zu values, expected %zu", path, i,
                                          got, values);
                        goto fail;
                    }
                    vq = ts;
                    if (!sg_io_parse_number(&vq, te, &v) || vq != te) {
                        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: point %zu: field %s: '%.*s' is not a number",
                                          path, i, f->name, (int)((te - ts) < TOKEN_ECHO ? (te - ts) : TOKEN_ECHO), ts);
                        goto fail;
                    }
                    if (f->r == R_SKIP)
                        continue;
                    val[f->r] = v;
                    if (f->r == R_RGB) {
                        /* ascii rgb: the float whose bits hold the colour
                         * (TYPE F), or the integer itself (TYPE U/I). */
                        if (f->type == 'F') {
                            float fl = (float)v;
                            memcpy(&rgb_bits, &fl, 4);
                        } else if (v >= 0.0 && v <= 4294967295.0) { /* NaN fails too */
                            rgb_bits = (uint32_t)v;
                        } else {
                            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: point %zu: field %s: %g is not a packed "
                                              "colour (0 to 4294967295)", path, i, f->name, v);
                            goto fail;
                        }
                    }
                }
            }
            if (token(&q, le, &ts, &te)) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: point %zu: more than the %zu values of the FIELDS", path,
                                  i, values);
                goto fail;
            }
        }
        if (isnan(val[R_X]) || isnan(val[R_Y]) || isnan(val[R_Z]))
            continue; /* no measurement (organized clouds) */
        for (int a = 0; a < 3; ++a) {
            float x = (float)val[R_X + a];
            if (!isfinite(x)) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: point %zu: %c is %s", path, i, "xyz"[a],
                                  isinf(val[R_X + a]) ? "infinite" : "out of float range");
                goto fail;
            }
            m.positions[3 * kept + a] = x;
        }
        if (normals) {
            double len = sqrt(val[R_NX] * val[R_NX] + val[R_NY] * val[R_NY] + val[R_NZ] * val[R_NZ]);
            for (int a = 0; a < 3; ++a)
                m.normals[3 * kept + a] = len > 0.0 && isfinite(len) ? (float)(val[R_NX + a] / len) : 0.0f;
        }
        if (colors) {
            unsigned c[3];
            if (packed) {
                c[0] = (rgb_bits >> 16) & 255u;
                c[1] = (rgb_bits >> 8) & 255u;
                c[2] = rgb_bits & 255u;
            } else {
                for (int a = 0; a < 3; ++a) {
                    double x = val[R_R + a];
                    if (!(x >= 0.0 && x <= 255.0)) {
                        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: point %zu: colour %c = %g is outside [0, 255]",
                                          path, i, "rgb"[a], x);
                        goto fail;
                    }
                    c[a] = (unsigned)(x + 0.5);
                }
            }
            for (int a = 0; a < 3; ++a)
                m.colors[3 * kept + a] = srgb8_to_linear(c[a]);
        }
        if (radii) {
            float r = (float)val[R_RADIUS];
            if (!(r > 0.0f) || !isfinite(r)) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: point %zu: radius %g is not positive and finite", path, i,
                                  val[R_RADIUS]);
                goto fail;
            }
            m.radii[kept] = r;
        }
        ++kept;
    }
    if (kept == 0) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: all %zu points are NaN (no measurement)", path, n);
        goto fail;
    }
    m.vertex_count = kept;
    sg_free(h);
    sg_free(buf);
    *out = m;
    return SG_OK;

fail:
    sg_mesh_free(&m);
    sg_free(h);
    sg_free(buf);
    return st;
}

sg_status sg_pcd_read_count(const char *path, uint64_t *points, sg_error *err)
{
    enum { PEEK = 1 << 16 }; /* a header is a few hundred bytes */
    FILE *f = fopen(path, "rb");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    char *buf = sg_alloc_array(PEEK, 1);
    pcd_header *h = sg_calloc_array(1, sizeof *h);
    sg_status st = SG_OK;
    if (!buf || !h)
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the header", path);
    else if ((st = parse_header(path, buf, fread(buf, 1, PEEK, f), h, err)) == SG_OK)
        *points = h->points;
    sg_free(h);
    sg_free(buf);
    fclose(f);
    return st;
}
