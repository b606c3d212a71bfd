/* obj.c — Wavefront OBJ geometry reader (format: the "Object Files (.obj)"
 * appendix of the Alias|Wavefront Advanced Visualizer manual, geometry
 * statements v, vn and f only; see obj.h for the contract).
 *
 * OBJ is line-based text: a keyword, then blank-separated fields. Vertices
 * and normals are numbered in file order from 1; a face corner is
 * v, v/t, v//n or v/t/n, and negative numbers count back from the last
 * definition so far.
 *
 * Two passes over the file held in memory:
 *   count_pass: how many v, vn and triangles (so arrays are allocated once,
 *               exactly, and positive indices can be checked against the
 *               final vertex count even before later v lines are read);
 *   parse_pass: values, index resolution, fan triangulation, normal sums.
 *
 * Invariants:
 *  1. Both passes split lines and fields identically, so parse_pass never
 *     stores more v, vn or triangles than count_pass counted (checked).
 *  2. Every stored triangle index is < vertex_count.
 *  3. Scanning never reads past the file's last byte (the buffer's final
 *     '\0' from sg_io_read_all is never looked at as data).
 */
#include "io/obj.h"

#include <inttypes.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "core/alloc.h"
#include "io/ply.h" /* sg_io_read_all, sg_io_parse_number */

enum { TOKEN_ECHO = 24 }; /* characters of a bad field quoted in messages */

/* Blanks inside a line; '\r' counts so CRLF files read like LF files. */
static bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

typedef struct obj_line {
    const char *p;   /* cursor within the line */
    const char *end; /* the line's '\n' or the end of the file */
} obj_line;

/* Next field of the line, or false at its end or at a '#' comment. */
static bool next_field(obj_line *ln, const char **start, const char **stop)
{
    while (ln->p < ln->end && is_blank(*ln->p))
        ln->p++;
    if (ln->p == ln->end || *ln->p == '#')
        return false;
    *start = ln->p;
    while (ln->p < ln->end && !is_blank(*ln->p))
        ln->p++;
    *stop = ln->p;
    return true;
}

typedef enum obj_keyword { KW_OTHER, KW_V, KW_VN, KW_F } obj_keyword;

static obj_keyword keyword(obj_line *ln)
{
    const char *a, *b;
    if (!next_field(ln, &a, &b))
        return KW_OTHER;
    size_t n = (size_t)(b - a);
    if (n == 1 && a[0] == 'v')
        return KW_V;
    if (n == 2 && a[0] == 'v' && a[1] == 'n')
        return KW_VN;
    if (n == 1 && a[0] == 'f')
        return KW_F;
    return KW_OTHER;
}

typedef struct obj_counts {
    size_t v;         /* v lines                   */
    size_t vn;        /* vn lines                  */
    size_t tri;        /* triangles after fanning    */
    size_t corners;    /* face corners, all f lines  */
    size_t face_lines; /* f lines (one of fewer than 3 corners fails later) */
} obj_counts;

static void count_pass(const char *buf, size_t size, obj_counts *c)
{
    const char *p = buf, *end = buf + size;
    while (p < end) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        obj_line ln = {p, nl ? nl : end};
        p = nl ? nl + 1 : end;
        switch (keyword(&ln)) {
        case KW_V: c->v++; break;
        case KW_VN: c->vn++; break;
        case KW_F: {
            const char *a, *b;
            size_t corners = 0;
            while (next_field(&ln, &a, &b))
                corners++;
            c->face_lines++;
            c->corners += corners;
            if (corners >= 3)
                c->tri += corners - 2;
            break;
        }
        case KW_OTHER: break;
        }
    }
}

/* Parses the three numbers of a v or vn line into out[0..2]. */
static sg_status parse_xyz(const char *path, size_t line, obj_line *ln, const char *what, bool reject_nonfinite,
                           float *out, sg_error *err)
{
    static const char *const AXIS[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; a++) {
        const char *s, *e;
        if (!next_field(ln, &s, &e))
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: %s has %d coordinates, needs 3", path, line,
                                what, a);
        const char *q = s;
        double v;
        if (!sg_io_parse_number(&q, e, &v) || q != e)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: %s %s: '%.*s' is not a number", path, line, what,
                                AXIS[a], (int)((e - s) < TOKEN_ECHO ? (e - s) : TOKEN_ECHO), s);
        float f = (float)v;
        if (reject_nonfinite && !isfinite(f))
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: %s %s is %s", path, line, what, AXIS[a],
                                isnan(v) ? "NaN" : isinf(v) ? "infinite" : "out of float range");
        out[a] = f;
    }
    return SG_OK;
}

/* One integer of a face corner; false if there are no digits. Values past
 * +-10^15 saturate: they are out of range either way. */
static bool parse_index(const char **pp, const char *end, int64_t *out)
{
    const char *p = *pp;
    bool neg = false;
    if (p < end && (*p == '-' || *p == '+')) {
        neg = *p == '-';
        p++;
    }
    if (p == end || *p < '0' || *p > '9')
        return false;
    int64_t v = 0;
    for (; p < end && *p >= '0' && *p <= '9'; p++) {
        if (v < INT64_C(1000000000000000))
            v = v * 10 + (*p - '0');
    }
    *out = neg ? -v : v;
    *pp = p;
    return true;
}

typedef struct obj_corner {
    int64_t v;    /* vertex index as written           */
    int64_t n;    /* normal index as written, or 0     */
} obj_corner;

/* v, v/t, v//n or v/t/n; the texture index is checked but not kept. */
static bool parse_corner(const char *s, const char *e, obj_corner *c)
{
    int64_t t;
    c->n = 0;
    if (!parse_index(&s, e, &c->v))
        return false;
    if (s == e)
        return true;
    if (*s++ != '/' || s == e)
        return false; /* "1/" names nothing after the slash */
    if (*s != '/' && !parse_index(&s, e, &t))
        return false;
    if (s == e)
        return true;
    if (*s++ != '/')
        return false;
    return parse_index(&s, e, &c->n) && s == e && c->n != 0;
}

/* Turns a written index into a 0-based one: positive counts from the
 * start (checked against the final count), negative back from the number
 * defined so far. */
static bool resolve(int64_t idx, size_t defined, size_t total, size_t *out)
{
    if (idx > 0 && (uint64_t)idx <= total) {
        *out = (size_t)(idx - 1);
        return true;
    }
    if (idx < 0 && (uint64_t)(-idx) <= defined) {
        *out = defined - (size_t)(-idx);
        return true;
    }
    return false;
}

typedef struct obj_out {
    float *positions;  /* 3 per v                                        */
    float *vn;         /* 3 per vn line, or NULL when there are none     */
    uint32_t *pair;    /* 2 per corner that names a normal: (v, vn)      */
    uint32_t *tri;     /* 3 per triangle                                 */
    size_t nv, nn;     /* v and vn lines read so far                     */
    size_t npair, nt;  /* pairs and triangles stored so far              */
    bool all_corners_have_normals;
} obj_out;

static sg_status parse_face(const char *path, size_t line, obj_line *ln, const obj_counts *c, obj_out *o,
                            sg_error *err)
{
    const char *s, *e;
    size_t corner = 0;
    uint32_t first = 0, prev = 0; /* fan: (first, prev, current) */
    while (next_field(ln, &s, &e)) {
        obj_corner cr;
        if (!parse_corner(s, e, &cr))
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: malformed face corner '%.*s'", path, line,
                                (int)((e - s) < TOKEN_ECHO ? (e - s) : TOKEN_ECHO), s);
        if (cr.v == 0)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: face index 0 is invalid (OBJ counts from 1)",
                                path, line);
        size_t vi, ni;
        if (!resolve(cr.v, o->nv, c->v, &vi))
            return sg_error_set(err, SG_ERR_CORRUPT,
                                "%s: line %zu: face index %" PRId64 " out of range (%zu vertices)", path, line, cr.v,
                                cr.v < 0 ? o->nv : c->v);
        uint32_t cur = (uint32_t)vi; /* invariant 2; vi < c->v <= UINT32_MAX */
        if (cr.n == 0) {
            o->all_corners_have_normals = false;
        } else {
            if (!resolve(cr.n, o->nn, c->vn, &ni))
                return sg_error_set(err, SG_ERR_CORRUPT,
                                    "%s: line %zu: face normal index %" PRId64 " out of range (%zu normals)", path,
                                    line, cr.n, cr.n < 0 ? o->nn : c->vn);
            if (o->npair == c->corners) /* invariant 1 */
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: corner count changed between passes", path,
                                    line);
            /* A positive index may name a vn defined further down, so the
             * pair is summed only after the whole file is read. */
            o->pair[2 * o->npair] = cur;
            o->pair[2 * o->npair + 1] = (uint32_t)ni;
            o->npair++;
        }
        if (corner == 0) {
            first = cur;
        } else if (corner >= 2) {
            if (o->nt == c->tri) /* invariant 1 */
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: face count changed between passes", path,
                                    line);
            uint32_t *t = &o->tri[3 * o->nt++];
            t[0] = first;
            t[1] = prev;
            t[2] = cur;
        }
        prev = cur;
        corner++;
    }
    /* "f 1 2" is no polygon; taking it quietly would leave a model whose
     * faces are all like it as a cloud of its vertices. */
    if (corner < 3)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: face has %zu vertex ind%s; a face needs at least 3",
                            path, line, corner, corner == 1 ? "ex" : "ices");
    return SG_OK;
}

static sg_status parse_pass(const char *path, const char *buf, size_t size, const obj_counts *c, obj_out *o,
                            sg_error *err)
{
    const char *p = buf, *end = buf + size;
    size_t line = 0;
    while (p < end) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        obj_line ln = {p, nl ? nl : end};
        p = nl ? nl + 1 : end;
        line++;
        sg_status st = SG_OK;
        switch (keyword(&ln)) {
        case KW_V:
            if (o->nv == c->v) /* invariant 1 */
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: vertex count changed between passes", path,
                                    line);
            st = parse_xyz(path, line, &ln, "vertex", true, &o->positions[3 * o->nv], err);
            o->nv++;
            break;
        case KW_VN:
            if (o->nn == c->vn) /* invariant 1 */
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: line %zu: normal count changed between passes", path,
                                    line);
            /* NaN normals are kept: they end as (0,0,0), "unknown". */
            st = parse_xyz(path, line, &ln, "normal", false, &o->vn[3 * o->nn], err);
            o->nn++;
            break;
        case KW_F: st = parse_face(path, line, &ln, c, o, err); break;
        case KW_OTHER: break;
        }
        if (st != SG_OK)
            return st;
    }
    return SG_OK;
}

/* Scales n to unit length, or to (0,0,0) when that is impossible (the
 * "unknown" normal of the obj.h contract). */
static void normalize_or_zero(float *n)
{
    double x = n[0], y = n[1], z = n[2];
    double len = sqrt(x * x + y * y + z * z);
    if (!(len > 0.0) || !isfinite(len)) {
        n[0] = n[1] = n[2] = 0.0f;
        return;
    }
    n[0] = (float)(x / len);
    n[1] = (float)(y / len);
    n[2] = (float)(z / len);
}

/* Per-vertex normals from the corner pairs (obj.h), or NULL in *normals
 * when some vertex has none. */
static sg_status vertex_normals(const char *path, const obj_counts *c, const obj_out *o, float **normals,
                                sg_error *err)
{
    *normals = NULL;
    if (c->vn == 0)
        return SG_OK;
    if (c->face_lines == 0) {
        if (c->vn != c->v)
            return SG_OK;
        float *n = sg_alloc_array(c->v, 3 * sizeof(float));
        if (!n)
            return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu normals", path, c->v);
        memcpy(n, o->vn, c->v * 3 * sizeof(float));
        for (size_t i = 0; i < c->v; i++)
            normalize_or_zero(&n[3 * i]);
        *normals = n;
        return SG_OK;
    }
    if (!o->all_corners_have_normals)
        return SG_OK;

    sg_status st = SG_OK;
    float *n = sg_calloc_array(c->v, 3 * sizeof(float));
    unsigned char *seen = sg_calloc_array(c->v, 1); /* vertex got a normal */
    if (!n || !seen) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu normals", path, c->v);
        goto fail;
    }
    for (size_t k = 0; k < o->npair; k++) {
        uint32_t v = o->pair[2 * k], vn = o->pair[2 * k + 1];
        n[3 * v + 0] += o->vn[3 * vn + 0];
        n[3 * v + 1] += o->vn[3 * vn + 1];
        n[3 * v + 2] += o->vn[3 * vn + 2];
        seen[v] = 1;
    }
    for (size_t i = 0; i < c->v; i++) {
        if (!seen[i])
            goto fail; /* a vertex no face uses: normals stay NULL */
        normalize_or_zero(&n[3 * i]);
    }
    sg_free(seen);
    *normals = n;
    return SG_OK;

fail:
    sg_free(seen);
    sg_free(n);
    return st;
}

sg_status sg_obj_read(const char *path, sg_mesh *out, sg_error *err)
{
    if (!path || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_obj_read: path and out must not be NULL");

    char *buf = NULL;                                   /* whole file            */
    size_t size = 0;                                    /* its bytes             */
    obj_counts c = {0};                                 /* from count_pass       */
    obj_out o = {.all_corners_have_normals = true};     /* filled by parse_pass  */
    float *normals = NULL;                              /* per-vertex result     */
    sg_status st = sg_io_read_all(path, &buf, &size, err);
    if (st != SG_OK)
        return st;

    count_pass(buf, size, &c);
    if (c.v == 0) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: no vertices", path);
        goto fail;
    }
    if (c.v > UINT32_MAX) {
        st = sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: %zu vertices exceed the 32-bit index range", path, c.v);
        goto fail;
    }
    /* Every count is at most the file size, so these sizes are bounded. */
    o.positions = sg_alloc_array(c.v, 3 * sizeof(float));
    if (c.vn > 0) {
        o.vn = sg_alloc_array(c.vn, 3 * sizeof(float));
        o.pair = sg_alloc_array(c.corners, 2 * sizeof(uint32_t));
    }
    if (c.tri > 0)
        o.tri = sg_alloc_array(c.tri, 3 * sizeof(uint32_t));
    if (!o.positions || (c.vn > 0 && (!o.vn || !o.pair)) || (c.tri > 0 && !o.tri)) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu vertices and %zu triangles", path, c.v,
                          c.tri);
        goto fail;
    }
    if ((st = parse_pass(path, buf, size, &c, &o, err)) != SG_OK)
        goto fail;
    if ((st = vertex_normals(path, &c, &o, &normals, err)) != SG_OK)
        goto fail;

    sg_free(o.pair);
    sg_free(o.vn);
    sg_free(buf);
    *out = (sg_mesh){
        .vertex_count = c.v,
        .positions = o.positions,
        .normals = normals,
        .triangle_count = o.nt,
        .triangles = o.nt > 0 ? o.tri : NULL,
    };
    if (o.nt == 0)
        sg_free(o.tri);
    return SG_OK;

fail:
    sg_free(o.tri);
    sg_free(o.pair);
    sg_free(o.vn);
    sg_free(o.positions);
    sg_free(buf);
    return st;
}
