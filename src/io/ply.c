/* ply.c — Stanford PLY reader (format: Turk 1994, "The PLY Polygon File
 * Format"; see ply.h for what is read and the error contract).
 *
 * A PLY file is a text header that declares elements (name, count) and
 * their properties (scalar type + name, or list count type + item type +
 * name), ended by "end_header", then a body holding each element's records
 * in declaration order: whitespace-separated numbers (ascii) or packed
 * values in little- or big-endian byte order (binary).
 *
 * The loader reads the whole file into memory, then
 *   read_all -> parse_header -> plan_layout (roles, size check)
 *            -> allocate -> read_body (vertex / face / skip) -> *out.
 *
 * Invariants:
 *  1. Before anything is allocated, the sum over elements of count times
 *     the smallest possible record size is at most the body size, so no
 *     array is larger than a small multiple of the file.
 *  2. The body cursor never passes `end`: binary reads check the bytes
 *     left first; ascii scanning stops at `end` (the buffer also ends in
 *     '\0', see mesh.c).
 *  3. Every loop over records or list items consumes at least one byte
 *     per step or has a bounded count (elements whose records take no
 *     bytes are skipped whole), so a hostile count cannot make it hang.
 *  4. Every triangle index is < vertex_count when stored.
 *  5. Faces have at least 3 indices; a triangle strip (element tristrips,
 *     -1 ends a strip) yields (v_k, v_k+1, v_k+2), the first two swapped
 *     for odd k (the strip's winding kept), dropping the triangles with a
 *     repeated vertex that strips use for stitching.
 */
#include "io/ply.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"

enum {
    MAX_ELEMENTS = 64,    /* more than any real PLY declares             */
    MAX_PROPERTIES = 512, /* over all elements                           */
    MAX_TOKENS = 8,       /* longest header line: property list a b name */
    TOKEN_ECHO = 24       /* characters of a bad token quoted in messages */
};

typedef enum ply_type {
    T_NONE = 0, /* "not a list" as a count type */
    T_I8,
    T_U8,
    T_I16,
    T_U16,
    T_I32,
    T_U32,
    T_F32,
    T_F64,
    T_COUNT
} ply_type;

static const struct {
    const char *name;  /* PLY 1.0 name             */
    const char *alias; /* sized name used by many writers */
} TYPE_NAMES[T_COUNT] = {
    [T_I8] = {"char", "int8"},     [T_U8] = {"uchar", "uint8"},    [T_I16] = {"short", "int16"},
    [T_U16] = {"ushort", "uint16"}, [T_I32] = {"int", "int32"},     [T_U32] = {"uint", "uint32"},
    [T_F32] = {"float", "float32"}, [T_F64] = {"double", "float64"},
};
static const unsigned TYPE_SIZE[T_COUNT] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
static const double TYPE_MIN[T_COUNT] = {0, -128.0, 0, -32768.0, 0, -2147483648.0, 0, 0, 0};
static const double TYPE_MAX[T_COUNT] = {0, 127.0, 255.0, 32767.0, 65535.0, 2147483647.0, 4294967295.0, 0, 0};

static bool type_is_integer(ply_type t) { return t >= T_I8 && t <= T_U32; }

typedef struct ply_prop {
    const char *name;    /* NUL-terminated, points into the header text */
    ply_type type;       /* scalar type, or the item type of a list     */
    ply_type count_type; /* list length type; T_NONE for a scalar       */
} ply_prop;

typedef struct ply_element {
    const char *name;  /* NUL-terminated, points into the header text */
    uint64_t count;    /* records declared                            */
    size_t first_prop; /* index of its first property in props[]     */
    size_t prop_count; /* number of its properties                    */
} ply_element;

typedef enum ply_format { FMT_ASCII, FMT_BINARY_LE, FMT_BINARY_BE } ply_format;

typedef struct ply_header {
    ply_format format;
    ply_element elems[MAX_ELEMENTS];
    size_t elem_count;
    ply_prop props[MAX_PROPERTIES];
    size_t prop_count;
    size_t body_offset; /* first byte after end_header's line break */
} ply_header;

/* What a vertex property means to us. R_NONE is also the scratch slot that
 * unused values are written to. */
typedef enum vertex_role {
    R_NONE = 0,
    R_X, R_Y, R_Z,
    R_NX, R_NY, R_NZ,
    R_RED, R_GREEN, R_BLUE,
    R_RADIUS,
    R_COUNT
} vertex_role;

typedef struct ply_plan {
    size_t vertex_elem;                   /* index of "vertex" in elems[]        */
    size_t face_elem;                     /* index of "face", or SIZE_MAX        */
    size_t face_list;                     /* vertex_indices within face elem     */
    size_t strip_elem;                    /* index of "tristrips", or SIZE_MAX   */
    size_t strip_list;                    /* vertex_indices within strip elem    */
    unsigned char role[MAX_PROPERTIES];   /* role of each vertex property        */
    ply_type role_type[R_COUNT];          /* type of the property with that role */
    bool has_normals, has_colors, has_radius;
    size_t vertex_count;                  /* == elems[vertex_elem].count         */
    size_t face_count;                    /* records of the face element         */
} ply_plan;

typedef enum read_result { RD_OK, RD_EOF, RD_MALFORMED, RD_RANGE } read_result;

typedef struct ply_reader {
    const char *path;
    ply_format format;
    const unsigned char *p;   /* cursor in the body                     */
    const unsigned char *end; /* one past the last body byte            */
    const unsigned char *tok; /* start of the last ascii token read     */
    sg_error *err;
} ply_reader;

typedef struct tri_buf {
    uint32_t *idx; /* 3 per triangle              */
    size_t count;  /* triangles stored            */
    size_t cap;    /* triangles that fit in idx   */
} tri_buf;

/* ---- header ------------------------------------------------------------ */

static bool is_space(unsigned char c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

/* Splits line[0,len) at blanks, NUL-terminating tokens in place; returns
 * the number of tokens (which may exceed max; only max are stored). */
static size_t tokenize(char *line, size_t len, char **tok, size_t max)
{
    size_t n = 0, i = 0;
    while (i < len) {
        while (i < len && is_space((unsigned char)line[i]))
            i++;
        if (i == len)
            break;
        if (n < max)
            tok[n] = line + i;
        n++;
        while (i < len && !is_space((unsigned char)line[i]))
            i++;
        line[i++] = '\0'; /* line[len] is a line break or the buffer's final NUL */
    }
    return n;
}

static ply_type parse_type(const char *s)
{
    for (int t = T_I8; t < T_COUNT; t++) {
        if (strcmp(s, TYPE_NAMES[t].name) == 0 || strcmp(s, TYPE_NAMES[t].alias) == 0)
            return (ply_type)t;
    }
    return T_NONE;
}

/* Decimal digits only; 0 ok, 1 malformed, 2 too large for uint64. */
static int parse_count(const char *s, uint64_t *out)
{
    uint64_t v = 0;
    if (!*s)
        return 1;
    for (; *s; s++) {
        if (*s < '0' || *s > '9')
            return 1;
        unsigned d = (unsigned)(*s - '0');
        if (v > (UINT64_MAX - d) / 10)
            return 2;
        v = v * 10 + d;
    }
    *out = v;
    return 0;
}

/* True when some line's first token is "end_header". Checked before the
 * header is interpreted, so that a cut-off header reads as what it is
 * rather than as whatever its last partial line happens to say. */
static bool has_end_header(const char *buf, size_t size)
{
    static const char MARK[] = "end_header";
    const size_t mark_len = sizeof MARK - 1;
    size_t pos = 0;
    while (pos < size) {
        const char *nl = memchr(buf + pos, '\n', size - pos);
        size_t end = nl ? (size_t)(nl - buf) : size;
        size_t i = pos;
        while (i < end && (buf[i] == ' ' || buf[i] == '\t'))
            i++;
        if (end - i >= mark_len && memcmp(buf + i, MARK, mark_len) == 0 &&
            (i + mark_len == end || is_space((unsigned char)buf[i + mark_len])))
            return true;
        pos = end + 1;
    }
    return false;
}

static sg_status parse_header(const char *path, char *buf, size_t size, ply_header *h, sg_error *err)
{
    if (size == 0)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: empty file", path);
    if (!has_end_header(buf, size)) {
        /* Still say "not a PLY file" for files that are nothing like one. */
        if (size < 3 || memcmp(buf, "ply", 3) != 0)
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: not a PLY file (first line is not 'ply')", path);
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: missing end_header", path);
    }
    bool have_format = false;
    size_t pos = 0;
    unsigned line = 0;
    while (pos < size) {
        char *s = buf + pos;
        const char *nl = memchr(s, '\n', size - pos);
        size_t len = nl ? (size_t)(nl - s) : size - pos;
        size_t next = nl ? pos + len + 1 : size;
        line++;
        if (len > 0 && s[len - 1] == '\r')
            len--;
        char *tok[MAX_TOKENS];
        size_t ntok = tokenize(s, len, tok, MAX_TOKENS);

        if (line == 1) {
            if (ntok != 1 || strcmp(tok[0], "ply") != 0)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: not a PLY file (first line is not 'ply')",
                                    path);
            pos = next;
            continue;
        }
        if (ntok == 0 || strcmp(tok[0], "comment") == 0 || strcmp(tok[0], "obj_info") == 0) {
            pos = next;
            continue;
        }
        if (strcmp(tok[0], "format") == 0) {
            if (ntok != 3)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: malformed format line", path, line);
            if (strcmp(tok[1], "ascii") == 0)
                h->format = FMT_ASCII;
            else if (strcmp(tok[1], "binary_little_endian") == 0)
                h->format = FMT_BINARY_LE;
            else if (strcmp(tok[1], "binary_big_endian") == 0)
                h->format = FMT_BINARY_BE;
            else
                return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: line %u: unknown format '%s'", path, line,
                                    tok[1]);
            if (strcmp(tok[2], "1.0") != 0 && strcmp(tok[2], "1") != 0)
                return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: line %u: PLY version '%s' is not 1.0",
                                    path, line, tok[2]);
            have_format = true;
        } else if (strcmp(tok[0], "element") == 0) {
            if (ntok != 3)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: malformed element line", path,
                                    line);
            if (h->elem_count == MAX_ELEMENTS)
                return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: line %u: more than %d elements", path,
                                    line, MAX_ELEMENTS);
            ply_element *e = &h->elems[h->elem_count];
            int rc = parse_count(tok[2], &e->count);
            if (rc == 2)
                return sg_error_set(err, SG_ERR_NOMEM, "%s: header: %s count %s overflows 64 bits", path, tok[1],
                                    tok[2]);
            if (rc != 0)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: %s count '%s' is not a number",
                                    path, line, tok[1], tok[2]);
            for (size_t i = 0; i < h->elem_count; i++) {
                if (strcmp(h->elems[i].name, tok[1]) == 0)
                    return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: element %s declared twice",
                                        path, line, tok[1]);
            }
            e->name = tok[1];
            e->first_prop = h->prop_count;
            e->prop_count = 0;
            h->elem_count++;
        } else if (strcmp(tok[0], "property") == 0) {
            if (h->elem_count == 0)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: property before any element", path,
                                    line);
            if (h->prop_count == MAX_PROPERTIES)
                return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: line %u: more than %d properties", path,
                                    line, MAX_PROPERTIES);
            ply_element *e = &h->elems[h->elem_count - 1];
            ply_prop *pr = &h->props[h->prop_count];
            bool list = ntok >= 2 && strcmp(tok[1], "list") == 0;
            if (ntok != (list ? 5u : 3u))
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: malformed property line in element %s",
                                    path, line, e->name);
            const char *type_name = tok[list ? 3 : 1];
            pr->name = tok[list ? 4 : 2];
            pr->type = parse_type(type_name);
            pr->count_type = list ? parse_type(tok[2]) : T_NONE;
            if (pr->type == T_NONE)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: %s %s: unknown property type '%s'",
                                    path, line, e->name, pr->name, type_name);
            if (list && pr->count_type == T_NONE)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: %s %s: unknown list count type '%s'",
                                    path, line, e->name, pr->name, tok[2]);
            if (list && !type_is_integer(pr->count_type))
                return sg_error_set(err, SG_ERR_CORRUPT,
                                    "%s: header: line %u: %s %s: list count type %s is not an integer type", path,
                                    line, e->name, pr->name, tok[2]);
            e->prop_count++;
            h->prop_count++;
        } else if (strcmp(tok[0], "end_header") == 0) {
            if (!have_format)
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: missing format line", path);
            h->body_offset = next;
            return SG_OK;
        } else {
            /* A numeric first token means the body started without an
             * end_header; say so rather than "unknown keyword '0.5'". */
            const char c = tok[0][0];
            if ((c >= '0' && c <= '9') || c == '-' || c == '.')
                return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: data before end_header", path, line);
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: line %u: unknown keyword '%.*s'", path, line,
                                TOKEN_ECHO, tok[0]);
        }
        pos = next;
    }
    /* has_end_header found one, and the loop stops at the first. */
    return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: missing end_header", path);
}

/* ---- layout ------------------------------------------------------------ */

static vertex_role role_of(const char *name)
{
    static const struct {
        const char *name;
        vertex_role role;
    } NAMES[] = {
        {"x", R_X},           {"y", R_Y},           {"z", R_Z},          {"nx", R_NX},
        {"ny", R_NY},         {"nz", R_NZ},         {"red", R_RED},      {"green", R_GREEN},
        {"blue", R_BLUE},     {"radius", R_RADIUS},
    };
    for (size_t i = 0; i < sizeof NAMES / sizeof NAMES[0]; i++) {
        if (strcmp(name, NAMES[i].name) == 0)
            return NAMES[i].role;
    }
    return R_NONE;
}

static bool color_type_ok(ply_type t) { return t == T_U8 || t == T_U16 || t == T_F32 || t == T_F64; }

/* The vertex_indices (or vertex_index) list of element e (SIZE_MAX: none)
 * into *list; an element with records but no such list, or one of a
 * non-integer type, is an error. */
static sg_status find_index_list(const char *path, const ply_header *h, size_t e, size_t *list, sg_error *err)
{
    if (e == SIZE_MAX)
        return SG_OK;
    const ply_element *f = &h->elems[e];
    for (size_t k = 0; k < f->prop_count; k++) {
        const ply_prop *pr = &h->props[f->first_prop + k];
        if (pr->count_type != T_NONE &&
            (strcmp(pr->name, "vertex_indices") == 0 || strcmp(pr->name, "vertex_index") == 0)) {
            *list = k;
            break;
        }
    }
    if (*list == SIZE_MAX && f->count > 0)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: %s: no vertex_indices list property", path,
                            f->name);
    if (*list != SIZE_MAX) {
        const ply_prop *pr = &h->props[f->first_prop + *list];
        if (!type_is_integer(pr->type))
            return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: %s: %s index type %s is not an integer type",
                                path, f->name, pr->name, TYPE_NAMES[pr->type].name);
    }
    return SG_OK;
}

/* Decides what each vertex property feeds, finds the face index list and
 * checks the declared counts against the body size (invariant 1). */
static sg_status plan_layout(const char *path, const ply_header *h, size_t file_size, ply_plan *pl, sg_error *err)
{
    pl->vertex_elem = SIZE_MAX;
    pl->face_elem = SIZE_MAX;
    pl->face_list = SIZE_MAX;
    pl->strip_elem = SIZE_MAX;
    pl->strip_list = SIZE_MAX;
    for (size_t i = 0; i < h->elem_count; i++) {
        if (strcmp(h->elems[i].name, "vertex") == 0)
            pl->vertex_elem = i;
        else if (strcmp(h->elems[i].name, "face") == 0)
            pl->face_elem = i;
        else if (strcmp(h->elems[i].name, "tristrips") == 0)
            pl->strip_elem = i;
    }

    /* Counts first: a count the file cannot hold is the most telling fault,
     * and it must be caught before any allocation. */
    const size_t body = file_size - h->body_offset;
    size_t need = 0;                 /* smallest body holding the elements so far */
    size_t too_big = SIZE_MAX;       /* first element that does not fit           */
    for (size_t i = 0; i < h->elem_count; i++) {
        const ply_element *e = &h->elems[i];
        size_t rec = 0; /* smallest record: empty lists, one-digit numbers */
        for (size_t k = 0; k < e->prop_count; k++) {
            const ply_prop *pr = &h->props[e->first_prop + k];
            if (h->format == FMT_ASCII)
                rec += 2; /* one digit and one separator */
            else
                rec += TYPE_SIZE[pr->count_type != T_NONE ? pr->count_type : pr->type];
        }
        size_t bytes;
        if (e->count > SIZE_MAX || !sg_mul_size((size_t)e->count, rec, &bytes) || need + bytes < need)
            return sg_error_set(err, SG_ERR_NOMEM, "%s: header: %s count %" PRIu64 " overflows size arithmetic",
                                path, e->name, e->count);
        need += bytes;
        /* ascii: the last number of the file needs no separator after it. */
        if (too_big == SIZE_MAX && need > body + (h->format == FMT_ASCII ? 1 : 0))
            too_big = i;
    }
    /* Reported after the loop so that an overflow further on, the more
     * fundamental fault, wins. */
    if (too_big != SIZE_MAX)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: header: %s count %" PRIu64 " exceeds what the file can hold (%zu bytes)", path,
                            h->elems[too_big].name, h->elems[too_big].count, body);

    if (pl->vertex_elem == SIZE_MAX || h->elems[pl->vertex_elem].count == 0)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: header: no vertices", path);
    const ply_element *v = &h->elems[pl->vertex_elem];
    if (v->count > UINT32_MAX)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: vertex count %" PRIu64
                            " exceeds the 32-bit index range", path, v->count);
    pl->vertex_count = (size_t)v->count;

    /* Roles: first property of a name wins; lists never carry a role. */
    size_t where[R_COUNT + 3]; /* property index per role, + the 3 diffuse_* */
    for (size_t r = 0; r < R_COUNT + 3; r++)
        where[r] = SIZE_MAX;
    enum { D_RED = R_COUNT, D_GREEN, D_BLUE };
    for (size_t k = 0; k < v->prop_count; k++) {
        const ply_prop *pr = &h->props[v->first_prop + k];
        pl->role[k] = R_NONE;
        if (pr->count_type != T_NONE)
            continue;
        size_t r = role_of(pr->name);
        if (r == R_NONE) {
            if (strcmp(pr->name, "diffuse_red") == 0)
                r = D_RED;
            else if (strcmp(pr->name, "diffuse_green") == 0)
                r = D_GREEN;
            else if (strcmp(pr->name, "diffuse_blue") == 0)
                r = D_BLUE;
        }
        if (r != R_NONE && where[r] == SIZE_MAX)
            where[r] = k;
    }
    if (where[R_X] == SIZE_MAX || where[R_Y] == SIZE_MAX || where[R_Z] == SIZE_MAX)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "%s: header: vertex: no x,y,z vertex properties", path);
    pl->has_normals = where[R_NX] != SIZE_MAX && where[R_NY] != SIZE_MAX && where[R_NZ] != SIZE_MAX;
    if (!(where[R_RED] != SIZE_MAX && where[R_GREEN] != SIZE_MAX && where[R_BLUE] != SIZE_MAX)) {
        where[R_RED] = where[D_RED];
        where[R_GREEN] = where[D_GREEN];
        where[R_BLUE] = where[D_BLUE];
    }
    pl->has_colors = where[R_RED] != SIZE_MAX && where[R_GREEN] != SIZE_MAX && where[R_BLUE] != SIZE_MAX;
    pl->has_radius = where[R_RADIUS] != SIZE_MAX;
    if (!pl->has_normals)
        where[R_NX] = where[R_NY] = where[R_NZ] = SIZE_MAX;
    if (!pl->has_colors)
        where[R_RED] = where[R_GREEN] = where[R_BLUE] = SIZE_MAX;
    for (size_t r = 1; r < R_COUNT; r++) {
        pl->role_type[r] = T_NONE;
        if (where[r] == SIZE_MAX)
            continue;
        const ply_prop *pr = &h->props[v->first_prop + where[r]];
        pl->role[where[r]] = (unsigned char)r;
        pl->role_type[r] = pr->type;
        if ((r == R_RED || r == R_GREEN || r == R_BLUE) && !color_type_ok(pr->type))
            return sg_error_set(err, SG_ERR_UNSUPPORTED,
                                "%s: header: vertex: colour %s has type %s; expected uchar, ushort, float or double",
                                path, pr->name, TYPE_NAMES[pr->type].name);
    }

    pl->face_count = 0;
    sg_status st = find_index_list(path, h, pl->face_elem, &pl->face_list, err);
    if (st == SG_OK)
        st = find_index_list(path, h, pl->strip_elem, &pl->strip_list, err);
    if (st == SG_OK && pl->face_elem != SIZE_MAX)
        pl->face_count = (size_t)h->elems[pl->face_elem].count;
    return st;
}

/* ---- body values --------------------------------------------------------- */

static uint64_t load_uint(const unsigned char *p, unsigned n, bool big_endian)
{
    uint64_t v = 0;
    if (big_endian) {
        for (unsigned i = 0; i < n; i++)
            v = (v << 8) | p[i];
    } else {
        for (unsigned i = n; i-- > 0;)
            v = (v << 8) | p[i];
    }
    return v;
}

/* Byte-wise decoding works whatever the host's byte order. */
static double decode_binary(const unsigned char *p, ply_type t, bool big_endian)
{
    switch (t) {
    case T_I8: return p[0] < 0x80 ? (double)p[0] : (double)p[0] - 256.0;
    case T_U8: return p[0];
    case T_I16: {
        uint64_t u = load_uint(p, 2, big_endian);
        return u < 0x8000 ? (double)u : (double)u - 65536.0;
    }
    case T_U16: return (double)load_uint(p, 2, big_endian);
    case T_I32: {
        uint64_t u = load_uint(p, 4, big_endian);
        return u < 0x80000000u ? (double)u : (double)u - 4294967296.0;
    }
    case T_U32: return (double)load_uint(p, 4, big_endian);
    case T_F32: {
        uint32_t u = (uint32_t)load_uint(p, 4, big_endian);
        float f;
        memcpy(&f, &u, sizeof f);
        return f;
    }
    case T_F64: {
        uint64_t u = load_uint(p, 8, big_endian);
        double d;
        memcpy(&d, &u, sizeof d);
        return d;
    }
    default: return 0.0; /* parse_type admits no other type */
    }
}

/* Reads one value of type t at the cursor. Integer types must hold an
 * integer within range (only ascii can break that). */
static read_result read_value(ply_reader *r, ply_type t, double *out)
{
    if (r->format != FMT_ASCII) {
        unsigned n = TYPE_SIZE[t];
        if ((size_t)(r->end - r->p) < n)
            return RD_EOF;
        *out = decode_binary(r->p, t, r->format == FMT_BINARY_BE);
        r->p += n;
        return RD_OK;
    }
    const unsigned char *p = r->p;
    while (p < r->end && is_space(*p))
        p++;
    r->tok = p;
    if (p == r->end) {
        r->p = p;
        return RD_EOF;
    }
    const char *q = (const char *)p;
    double v;
    if (!sg_io_parse_number(&q, (const char *)r->end, &v) || ((const unsigned char *)q < r->end && !is_space(*q)))
        return RD_MALFORMED;
    r->p = (const unsigned char *)q;
    if (type_is_integer(t) && !(v == floor(v) && v >= TYPE_MIN[t] && v <= TYPE_MAX[t]))
        return RD_RANGE;
    *out = v;
    return RD_OK;
}

/* Turns a failed read into the message "file: elem i: fault". */
static sg_status read_fail(const ply_reader *r, read_result rd, const char *elem, size_t index, const char *what,
                           ply_type t)
{
    int tok_len = 0;
    if (r->format == FMT_ASCII && r->tok) {
        while (r->tok + tok_len < r->end && tok_len < TOKEN_ECHO && !is_space(r->tok[tok_len]))
            tok_len++;
    }
    switch (rd) {
    case RD_EOF:
        return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: %s %zu: file ends while reading %s (truncated)", r->path,
                            elem, index, what);
    case RD_MALFORMED:
        return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: %s %zu: %s: '%.*s' is not a number", r->path, elem, index,
                            what, tok_len, (const char *)r->tok);
    case RD_RANGE:
        return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: %s %zu: %s: '%.*s' is not a valid %s", r->path, elem,
                            index, what, tok_len, (const char *)r->tok, TYPE_NAMES[t].name);
    case RD_OK: break;
    }
    return SG_OK;
}

/* Reads a list's length and checks that the body can still hold that many
 * items (invariant 3: a hostile length fails here, not after a long loop). */
static sg_status read_list_length(ply_reader *r, const ply_prop *pr, const char *elem, size_t index, size_t *len)
{
    double c;
    read_result rd = read_value(r, pr->count_type, &c);
    if (rd != RD_OK)
        return read_fail(r, rd, elem, index, pr->name, pr->count_type);
    if (c < 0)
        return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: %s %zu: list %s has negative length %.0f", r->path, elem,
                            index, pr->name, c);
    /* c <= 2^32 - 1 and item size <= 8: the product fits in 64 bits. */
    uint64_t n = (uint64_t)c;
    uint64_t min_bytes = r->format == FMT_ASCII ? n : n * TYPE_SIZE[pr->type];
    if (min_bytes > (uint64_t)(r->end - r->p))
        return sg_error_set(r->err, SG_ERR_CORRUPT,
                            "%s: %s %zu: list %s of %" PRIu64 " items runs past the end of the file (truncated)",
                            r->path, elem, index, pr->name, n);
    *len = (size_t)n;
    return SG_OK;
}

static sg_status skip_list(ply_reader *r, const ply_prop *pr, const char *elem, size_t index)
{
    size_t n;
    sg_status st = read_list_length(r, pr, elem, index, &n);
    if (st != SG_OK)
        return st;
    if (r->format != FMT_ASCII) {
        r->p += n * TYPE_SIZE[pr->type]; /* checked by read_list_length */
        return SG_OK;
    }
    for (size_t j = 0; j < n; j++) {
        double v;
        read_result rd = read_value(r, pr->type, &v);
        if (rd != RD_OK)
            return read_fail(r, rd, elem, index, pr->name, pr->type);
    }
    return SG_OK;
}

/* ---- body elements ----------------------------------------------------- */

static float srgb_to_linear(double c)
{
    return (float)(c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4));
}

/* One colour channel to linear [0,1]; false when the value is NaN. */
static bool decode_color(double v, ply_type t, const float *srgb8, float *out)
{
    if (t == T_U8) {
        *out = srgb8[(int)v]; /* read_value guarantees 0..255 */
        return true;
    }
    if (t == T_U16) {
        *out = srgb_to_linear(v / 65535.0);
        return true;
    }
    if (isnan(v))
        return false;
    *out = (float)(v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v);
    return true;
}

static sg_status check_coordinate(const ply_reader *r, size_t i, const char *axis, double v, float *out)
{
    if (isnan(v))
        return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: vertex %zu: %s is NaN", r->path, i, axis);
    if (isinf(v))
        return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: vertex %zu: %s is infinite", r->path, i, axis);
    float f = (float)v;
    if (isinf(f))
        return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: vertex %zu: %s %g is out of float range", r->path, i,
                            axis, v);
    *out = f;
    return SG_OK;
}

static sg_status read_vertices(ply_reader *r, const ply_header *h, const ply_plan *pl, sg_mesh *m)
{
    static const char *const AXIS[3] = {"x", "y", "z"};
    static const char *const CHANNEL[3] = {"red", "green", "blue"};
    const ply_element *e = &h->elems[pl->vertex_elem];
    const ply_prop *props = &h->props[e->first_prop];
    float srgb8[256]; /* uchar colour decode table */
    if (pl->has_colors) {
        for (int c = 0; c < 256; c++)
            srgb8[c] = srgb_to_linear(c / 255.0);
    }
    double val[R_COUNT] = {0}; /* this vertex's values by role */
    for (size_t i = 0; i < pl->vertex_count; i++) {
        for (size_t k = 0; k < e->prop_count; k++) {
            const ply_prop *pr = &props[k];
            if (pr->count_type != T_NONE) {
                sg_status st = skip_list(r, pr, "vertex", i);
                if (st != SG_OK)
                    return st;
                continue;
            }
            read_result rd = read_value(r, pr->type, &val[pl->role[k]]);
            if (rd != RD_OK)
                return read_fail(r, rd, "vertex", i, pr->name, pr->type);
        }
        for (int a = 0; a < 3; a++) {
            sg_status st = check_coordinate(r, i, AXIS[a], val[R_X + a], &m->positions[3 * i + a]);
            if (st != SG_OK)
                return st;
        }
        if (pl->has_normals) {
            double nx = val[R_NX], ny = val[R_NY], nz = val[R_NZ];
            double len = sqrt(nx * nx + ny * ny + nz * nz);
            float *n = &m->normals[3 * i];
            /* ply.h contract: an unusable normal becomes (0,0,0) = unknown. */
            if (!(len > 0.0) || !isfinite(len)) {
                n[0] = n[1] = n[2] = 0.0f;
            } else {
                n[0] = (float)(nx / len);
                n[1] = (float)(ny / len);
                n[2] = (float)(nz / len);
            }
        }
        if (pl->has_colors) {
            for (int c = 0; c < 3; c++) {
                if (!decode_color(val[R_RED + c], pl->role_type[R_RED + c], srgb8, &m->colors[3 * i + c]))
                    return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: vertex %zu: %s is NaN", r->path, i,
                                        CHANNEL[c]);
            }
        }
        if (pl->has_radius) {
            double rad = val[R_RADIUS];
            if (isnan(rad))
                return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: vertex %zu: radius is NaN", r->path, i);
            float f = (float)rad;
            if (!(f > 0.0f) || isinf(f))
                return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: vertex %zu: radius %g is not positive and finite",
                                    r->path, i, rad);
            m->radii[i] = f;
        }
    }
    return SG_OK;
}

/* Reads past one property of record index of element elem (a value or a
 * whole list). */
static sg_status skip_property(ply_reader *r, const ply_prop *pr, const char *elem, size_t index)
{
    if (pr->count_type != T_NONE)
        return skip_list(r, pr, elem, index);
    double v;
    read_result rd = read_value(r, pr->type, &v);
    return rd == RD_OK ? SG_OK : read_fail(r, rd, elem, index, pr->name, pr->type);
}

static sg_status push_triangle(ply_reader *r, tri_buf *tb, uint32_t a, uint32_t b, uint32_t c)
{
    if (tb->count == tb->cap) {
        size_t cap = 1024;
        void *grown = tb->idx;
        if (tb->idx ? !sg_mul_size(tb->cap, 2, &cap) ||
                          !sg_realloc_array(&grown, 3 * tb->count, 3 * cap, sizeof(uint32_t))
                    : !(grown = sg_alloc_array(cap, 3 * sizeof(uint32_t))))
            return sg_error_set(r->err, SG_ERR_NOMEM, "%s: face: out of memory for %zu triangles", r->path,
                                tb->count + 1);
        tb->idx = grown;
        tb->cap = cap;
    }
    uint32_t *t = &tb->idx[3 * tb->count++];
    t[0] = a;
    t[1] = b;
    t[2] = c;
    return SG_OK;
}

static sg_status read_faces(ply_reader *r, const ply_header *h, const ply_plan *pl, tri_buf *tb)
{
    const ply_element *e = &h->elems[pl->face_elem];
    const ply_prop *props = &h->props[e->first_prop];
    for (size_t i = 0; i < pl->face_count; i++) {
        for (size_t k = 0; k < e->prop_count; k++) {
            const ply_prop *pr = &props[k];
            sg_status st;
            if (k != pl->face_list) {
                if ((st = skip_property(r, pr, "face", i)) != SG_OK)
                    return st;
                continue;
            }
            size_t n;
            st = read_list_length(r, pr, "face", i, &n);
            if (st != SG_OK)
                return st;
            uint32_t first = 0, prev = 0; /* fan: (first, prev, current) */
            for (size_t j = 0; j < n; j++) {
                double v;
                read_result rd = read_value(r, pr->type, &v);
                if (rd != RD_OK)
                    return read_fail(r, rd, "face", i, pr->name, pr->type);
                if (v < 0)
                    return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: face %zu: negative vertex index %.0f", r->path,
                                        i, v);
                if (v >= (double)pl->vertex_count)
                    return sg_error_set(r->err, SG_ERR_CORRUPT,
                                        "%s: face %zu: vertex index %.0f out of range (%zu vertices)", r->path, i, v,
                                        pl->vertex_count);
                uint32_t cur = (uint32_t)v; /* invariant 4 */
                if (j == 0)
                    first = cur;
                else if (j >= 2 && (st = push_triangle(r, tb, first, prev, cur)) != SG_OK)
                    return st;
                prev = cur;
            }
            if (n < 3) /* invariant 5 */
                return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: face %zu: %zu vertex ind%s; a face needs at least 3",
                                    r->path, i, n, n == 1 ? "ex" : "ices");
        }
    }
    return SG_OK;
}

/* Element tristrips (invariant 5). */
static sg_status read_strips(ply_reader *r, const ply_header *h, const ply_plan *pl, tri_buf *tb)
{
    const ply_element *e = &h->elems[pl->strip_elem];
    const ply_prop *props = &h->props[e->first_prop];
    for (size_t i = 0; i < (size_t)e->count; i++) {
        for (size_t k = 0; k < e->prop_count; k++) {
            const ply_prop *pr = &props[k];
            sg_status st;
            if (k != pl->strip_list) {
                if ((st = skip_property(r, pr, e->name, i)) != SG_OK)
                    return st;
                continue;
            }
            size_t n;
            st = read_list_length(r, pr, e->name, i, &n);
            if (st != SG_OK)
                return st;
            uint32_t v0 = 0, v1 = 0; /* the strip's last two vertices */
            size_t in_strip = 0;     /* vertices of the current strip so far */
            for (size_t j = 0; j < n; j++) {
                double v;
                read_result rd = read_value(r, pr->type, &v);
                if (rd != RD_OK)
                    return read_fail(r, rd, e->name, i, pr->name, pr->type);
                /* -1 ends a strip; in an unsigned type it reads as the
                 * type's largest value. */
                if (v == -1.0 || (pr->type == T_U32 && v == 4294967295.0) ||
                    (pr->type == T_U16 && v == 65535.0) || (pr->type == T_U8 && v == 255.0)) {
                    in_strip = 0;
                    continue;
                }
                if (v < 0)
                    return sg_error_set(r->err, SG_ERR_CORRUPT,
                                        "%s: %s %zu: negative vertex index %.0f (only -1 may end a strip)", r->path,
                                        e->name, i, v);
                if (v >= (double)pl->vertex_count)
                    return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: %s %zu: vertex index %.0f out of range (%zu vertices)",
                                        r->path, e->name, i, v, pl->vertex_count);
                uint32_t cur = (uint32_t)v; /* invariant 4 */
                if (in_strip >= 2 && v0 != v1 && v1 != cur && v0 != cur) {
                    /* triangle k = in_strip - 2: odd k swaps its first two */
                    st = (in_strip - 2) % 2 ? push_triangle(r, tb, v1, v0, cur) : push_triangle(r, tb, v0, v1, cur);
                    if (st != SG_OK)
                        return st;
                }
                v0 = v1;
                v1 = cur;
                in_strip++;
            }
        }
    }
    return SG_OK;
}

/* Steps over an element we do not use (invariant 3). */
static sg_status skip_element(ply_reader *r, const ply_header *h, const ply_element *e)
{
    const ply_prop *props = &h->props[e->first_prop];
    bool has_list = false;
    size_t rec = 0;
    for (size_t k = 0; k < e->prop_count; k++) {
        has_list |= props[k].count_type != T_NONE;
        rec += TYPE_SIZE[props[k].type];
    }
    if (e->count == 0 || e->prop_count == 0)
        return SG_OK;
    if (r->format != FMT_ASCII && !has_list) {
        /* plan_layout bounded count * rec by the body size. */
        size_t bytes = (size_t)e->count * rec;
        if (bytes > (size_t)(r->end - r->p))
            return sg_error_set(r->err, SG_ERR_CORRUPT, "%s: %s: file ends inside this element (truncated)", r->path,
                                e->name);
        r->p += bytes;
        return SG_OK;
    }
    for (size_t i = 0; i < (size_t)e->count; i++) {
        for (size_t k = 0; k < e->prop_count; k++) {
            sg_status st = skip_property(r, &props[k], e->name, i);
            if (st != SG_OK)
                return st;
        }
    }
    return SG_OK;
}

/* ---- entry point --------------------------------------------------------- */

sg_status sg_ply_read(const char *path, sg_mesh *out, sg_error *err)
{
    if (!path || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_ply_read: path and out must not be NULL");

    char *buf = NULL;      /* whole file, '\0'-terminated               */
    size_t size = 0;       /* file bytes                                 */
    ply_header *h = NULL;  /* parsed header (big: heap, not stack)      */
    ply_plan *pl = NULL;   /* roles and counts                           */
    sg_mesh m = {0};       /* built here, copied to *out only on success */
    tri_buf tb = {0};      /* triangles as they are fanned              */
    sg_status st = sg_io_read_all(path, &buf, &size, err);
    if (st != SG_OK)
        return st;

    h = sg_calloc_array(1, sizeof *h);
    pl = sg_calloc_array(1, sizeof *pl);
    if (!h || !pl) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the header", path);
        goto fail;
    }
    if ((st = parse_header(path, buf, size, h, err)) != SG_OK)
        goto fail;
    if ((st = plan_layout(path, h, size, pl, err)) != SG_OK)
        goto fail;

    /* Invariant 1 holds here, so these sizes are bounded by the file. */
    size_t nv = pl->vertex_count;
    m.vertex_count = nv;
    m.positions = sg_alloc_array(nv, 3 * sizeof(float));
    if (pl->has_normals)
        m.normals = sg_alloc_array(nv, 3 * sizeof(float));
    if (pl->has_colors)
        m.colors = sg_alloc_array(nv, 3 * sizeof(float));
    if (pl->has_radius)
        m.radii = sg_alloc_array(nv, sizeof(float));
    if (pl->face_list != SIZE_MAX && pl->face_count > 0) {
        /* Most faces are triangles; polygons grow the buffer by doubling. */
        tb.cap = pl->face_count;
        tb.idx = sg_alloc_array(tb.cap, 3 * sizeof(uint32_t));
    }
    if (!m.positions || (pl->has_normals && !m.normals) || (pl->has_colors && !m.colors) ||
        (pl->has_radius && !m.radii) || (tb.cap && !tb.idx)) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu vertices and %zu faces", path, nv,
                          pl->face_count);
        goto fail;
    }

    ply_reader r = {
        .path = path,
        .format = h->format,
        .p = (const unsigned char *)buf + h->body_offset,
        .end = (const unsigned char *)buf + size,
        .err = err,
    };
    for (size_t i = 0; i < h->elem_count; i++) {
        if (i == pl->vertex_elem)
            st = read_vertices(&r, h, pl, &m);
        else if (i == pl->face_elem && pl->face_list != SIZE_MAX)
            st = read_faces(&r, h, pl, &tb);
        else if (i == pl->strip_elem && pl->strip_list != SIZE_MAX)
            st = read_strips(&r, h, pl, &tb);
        else
            st = skip_element(&r, h, &h->elems[i]);
        if (st != SG_OK)
            goto fail;
    }

    if (tb.count > 0) {
        m.triangles = tb.idx;
        m.triangle_count = tb.count;
    } else {
        sg_free(tb.idx);
    }
    tb.idx = NULL;
    *out = m;
    sg_free(pl);
    sg_free(h);
    sg_free(buf);
    return SG_OK;

fail:
    sg_free(tb.idx);
    sg_mesh_free(&m);
    sg_free(pl);
    sg_free(h);
    sg_free(buf);
    return st;
}

/* ---- header only ------------------------------------------------------- */

/* Headers are a few hundred bytes; 1 MiB holds any real one. */
#define HEADER_PEEK_BYTES (1u << 20)

sg_status sg_ply_read_counts(const char *path, uint64_t *vertices, uint64_t *faces, sg_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    char *buf = sg_alloc_array(HEADER_PEEK_BYTES + 1, 1);
    ply_header *h = sg_calloc_array(1, sizeof *h);
    sg_status st = SG_OK;
    if (!buf || !h) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the header", path);
        goto done;
    }
    size_t n = fread(buf, 1, HEADER_PEEK_BYTES, f);
    buf[n] = '\0';
    if ((st = parse_header(path, buf, n, h, err)) != SG_OK)
        goto done;
    uint64_t v = 0, t = 0;
    for (size_t i = 0; i < h->elem_count; i++) {
        if (strcmp(h->elems[i].name, "vertex") == 0)
            v = h->elems[i].count;
        else if (strcmp(h->elems[i].name, "face") == 0 || strcmp(h->elems[i].name, "tristrips") == 0)
            t += h->elems[i].count;
    }
    *vertices = v;
    *faces = t;
done:
    sg_free(h);
    sg_free(buf);
    fclose(f);
    return st;
}
