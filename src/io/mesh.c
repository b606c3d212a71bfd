/* mesh.c — model file entry point: picks the loader by file extension
 * (.ply -> ply.c, .obj -> obj.c, .xyz/.txt -> xyz.c, .pcd -> pcd.c,
 * case-insensitive), frees meshes, and holds
 * the two helpers both text formats share: reading a whole file and a
 * locale-independent number parser.
 *
 * Invariants:
 *  1. sg_io_read_all's buffer always ends in '\0' one byte past *size, so a
 *     scanner may look at buf[size] but never further.
 *  2. sg_io_parse_number never reads at or past `end` (it may stop at the
 *     '\0' of invariant 1 when end points there).
 */
#include "io/mesh.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "core/alloc.h"
#include "io/obj.h"
#include "io/pcd.h"
#include "io/ply.h"
#include "io/xyz.h"

/* Lower-cases ASCII only: extensions are ASCII and tolower() would consult
 * the caller's locale. */
static char ascii_lower(char c)
{
    return (c >= 'A' && c <= 'Z') ? (char)(c - 'A' + 'a') : c;
}

static bool ext_is(const char *ext, const char *want)
{
    while (*ext && *want) {
        if (ascii_lower(*ext) != *want)
            return false;
        ext++;
        want++;
    }
    return *ext == '\0' && *want == '\0';
}

sg_status sg_mesh_read(const char *path, sg_mesh *out, sg_error *err)
{
    if (!path || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_mesh_read: path and out must not be NULL");
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(path, '.');
    /* A dot in a folder name ("v1.2/model") is not an extension. */
    if (dot && (!slash || dot > slash)) {
        if (ext_is(dot + 1, "ply"))
            return sg_ply_read(path, out, err);
        if (ext_is(dot + 1, "obj"))
            return sg_obj_read(path, out, err);
        if (ext_is(dot + 1, "xyz") || ext_is(dot + 1, "txt"))
            return sg_xyz_read(path, out, err);
        if (ext_is(dot + 1, "pcd"))
            return sg_pcd_read(path, out, err);
    }
    return sg_error_set(err, SG_ERR_UNSUPPORTED,
                        "%s: unsupported model format (expected a .ply, .obj, .xyz, .txt or .pcd extension)", path);
}

void sg_mesh_free(sg_mesh *mesh)
{
    if (!mesh)
        return;
    sg_free(mesh->positions);
    sg_free(mesh->normals);
    sg_free(mesh->colors);
    sg_free(mesh->radii);
    sg_free(mesh->triangles);
    memset(mesh, 0, sizeof *mesh);
}

sg_status sg_io_read_all(const char *path, char **data, size_t *size, sg_error *err)
{
    sg_status status = SG_OK;
    char *buf = NULL;
    FILE *f = fopen(path, "rb");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", path, strerror(errno));

    struct stat sb;
    if (fstat(fileno(f), &sb) != 0) {
        status = sg_error_set(err, SG_ERR_IO, "%s: cannot stat: %s", path, strerror(errno));
        goto done;
    }
    /* A FIFO or device would make "the file size" meaningless and could
     * block forever; models are regular files. */
    if (!S_ISREG(sb.st_mode)) {
        status = sg_error_set(err, SG_ERR_IO, "%s: not a regular file", path);
        goto done;
    }
    if (sb.st_size < 0 || (uint64_t)sb.st_size >= (uint64_t)SIZE_MAX) {
        status = sg_error_set(err, SG_ERR_NOMEM, "%s: file too large to read", path);
        goto done;
    }
    size_t n = (size_t)sb.st_size;
    buf = sg_alloc_array(n + 1, 1);
    if (!buf) {
        status = sg_error_set(err, SG_ERR_NOMEM, "%s: cannot allocate %zu bytes to read the file", path,
                              n + 1);
        goto done;
    }
    if (fread(buf, 1, n, f) != n) {
        status = sg_error_set(err, SG_ERR_IO, "%s: read failed%s%s", path, ferror(f) ? ": " : " (file shrank)",
                              ferror(f) ? strerror(errno) : "");
        goto free_buf;
    }
    buf[n] = '\0'; /* invariant 1 */
    *data = buf;
    *size = n;
    goto done;

free_buf:
    sg_free(buf);
done:
    fclose(f);
    return status;
}

static bool match_word(const char **pp, const char *end, const char *word)
{
    const char *p = *pp;
    for (; *word; word++, p++) {
        if (p >= end || ascii_lower(*p) != *word)
            return false;
    }
    *pp = p;
    return true;
}

/* Powers of ten a double holds exactly. A mantissa below 2^53 times or
 * divided by one of them is one correctly rounded operation, i.e. the
 * exact decimal value rounded once (the fast path of Clinger 1990). */
static const double EXACT_POW10[] = {
    1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
};

enum {
    MAX_MANTISSA_DIGITS = 19, /* 10^19 - 1 still fits in uint64          */
    EXPONENT_CAP = 100000     /* beyond this every double is 0 or inf   */
};

bool sg_io_parse_number(const char **pp, const char *end, double *out)
{
    const char *p = *pp;
    bool neg = false;
    if (p < end && (*p == '+' || *p == '-')) {
        neg = *p == '-';
        p++;
    }
    if (p < end && (ascii_lower(*p) == 'n' || ascii_lower(*p) == 'i')) {
        double v;
        if (match_word(&p, end, "nan"))
            v = NAN;
        else if (match_word(&p, end, "infinity") || match_word(&p, end, "inf"))
            v = INFINITY;
        else
            return false;
        *out = neg ? -v : v;
        *pp = p;
        return true;
    }

    uint64_t mant = 0; /* first significant digits                      */
    int kept = 0;      /* how many digits mant holds                    */
    long exp10 = 0;    /* power of ten to apply to mant                 */
    bool any = false;  /* saw at least one digit                        */
    for (; p < end && *p >= '0' && *p <= '9'; p++) {
        any = true;
        if (kept < MAX_MANTISSA_DIGITS) {
            mant = mant * 10 + (uint64_t)(*p - '0');
            kept += mant != 0; /* leading zeros are not significant */
        } else {
            exp10++;
        }
    }
    if (p < end && *p == '.') {
        p++;
        for (; p < end && *p >= '0' && *p <= '9'; p++) {
            any = true;
            if (kept < MAX_MANTISSA_DIGITS) {
                mant = mant * 10 + (uint64_t)(*p - '0');
                kept += mant != 0;
                exp10--;
            }
        }
    }
    if (!any)
        return false;
    if (p < end && (*p == 'e' || *p == 'E')) {
        const char *q = p + 1;
        bool eneg = false;
        if (q < end && (*q == '+' || *q == '-')) {
            eneg = *q == '-';
            q++;
        }
        if (q >= end || *q < '0' || *q > '9')
            return false; /* "1e" or "1e+" is not a number */
        long e = 0;
        for (; q < end && *q >= '0' && *q <= '9'; q++) {
            if (e < EXPONENT_CAP)
                e = e * 10 + (*q - '0');
        }
        exp10 += eneg ? -e : e;
        p = q;
    }

    double v;
    if (mant == 0) {
        v = 0.0;
    } else if (mant <= (UINT64_C(1) << 53) && exp10 >= 0 && exp10 <= 22) {
        v = (double)mant * EXACT_POW10[exp10];
    } else if (mant <= (UINT64_C(1) << 53) && exp10 < 0 && exp10 >= -22) {
        v = (double)mant / EXACT_POW10[-exp10];
    } else if (exp10 > 400) {
        v = INFINITY;
    } else if (exp10 < -400) {
        v = 0.0;
    } else if (exp10 < -300) {
        /* Split the scale so 10^exp10 does not underflow before the
         * multiplication brings it back into range. */
        v = (double)mant * pow(10.0, (double)(exp10 + 40)) * 1e-40;
    } else {
        v = (double)mant * pow(10.0, (double)exp10);
    }
    *out = neg ? -v : v;
    *pp = p;
    return true;
}

sg_aabb sg_mesh_bounds(const sg_mesh *m)
{
    sg_aabb b = sg_aabb_empty();
    for (size_t i = 0; i < m->vertex_count; i++)
        b = sg_aabb_grow(b, sg_v3(m->positions[3 * i], m->positions[3 * i + 1], m->positions[3 * i + 2]));
    return b;
}

sg_status sg_mesh_read_bounds(const char *path, sg_aabb *out, sg_error *err)
{
    sg_mesh m = {0};
    sg_status st = sg_mesh_read(path, &m, err);
    if (st != SG_OK)
        return st;
    *out = sg_mesh_bounds(&m);
    sg_mesh_free(&m);
    return SG_OK;
}

sg_status sg_mesh_ground_placement(sg_aabb b, float length, sg_ground_placement *out, sg_error *err)
{
    sg_vec3 ext = sg_v3_sub(b.hi, b.lo);
    float longest = fmaxf(ext.x, fmaxf(ext.y, ext.z));
    if (!(longest > 0.0f) || !(length > 0.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "ground placement: empty or degenerate bounds, or length %g",
                            (double)length);
    sg_ground_placement p;
    p.scale = length / longest;
    p.translate = sg_v3(-p.scale * 0.5f * (b.lo.x + b.hi.x), -p.scale * b.lo.y, -p.scale * 0.5f * (b.lo.z + b.hi.z));
    p.placed.lo = sg_v3_add(sg_v3_scale(b.lo, p.scale), p.translate);
    p.placed.hi = sg_v3_add(sg_v3_scale(b.hi, p.scale), p.translate);
    *out = p;
    return SG_OK;
}
