/* scene_file.c — JSON scene files into sg_scene_file (see scene_file.h for
 * the schema).
 *
 * Flow: read bytes -> cJSON tree (cJSON_ParseWithLengthOpts, so the error
 * position comes back through an argument instead of cJSON's global) ->
 * walk the tree with the JSON path of each node in hand -> plain structs.
 * The walk is strict on purpose: a scene file steers hours of baking, and a
 * misspelt key that silently falls back to a default costs more than an
 * error message.
 *
 * Invariants:
 *  1. Every message is "<name>: <JSON path>: <what was expected>, got <what
 *     was there>" (or "<name>:<line>:<col>: ..." for syntax errors).
 *  2. The output struct is assembled in a local and copied to *out only on
 *     SG_OK; on failure everything allocated so far is freed (one exit path
 *     per function through sg_scene_file_free of the local).
 *  3. Every field of the result is set: absent keys take the documented
 *     defaults before the key is looked at.
 *  4. The hash sees only parsed values, in a fixed order, with fixed-width
 *     little-endian encoding, never struct bytes (padding is undefined).
 */
#include "io/scene_file.h"

#include <assert.h>
#include <cjson/cJSON.h>
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"

/* Scene files are hand-written text; anything this large is a mistake
 * (a model passed as the scene), and refusing it keeps cJSON's memory
 * bounded. */
#define SCENE_FILE_MAX_BYTES (16u << 20)

/* Longest JSON path we build; ours are at most ~60 bytes. */
#define JP_MAX 160

/* Largest integer a JSON number (a double) holds exactly. */
#define MAX_EXACT_INT 9007199254740992.0

typedef struct ctx {
    const char *name;     /* file name at the start of every message */
    const char *base_dir; /* folder for relative paths, or NULL       */
    sg_error *err;
} ctx;

/* ---- messages ---------------------------------------------------------- */

static sg_status fail(const ctx *c, const char *jp, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static sg_status fail(const ctx *c, const char *jp, const char *fmt, ...)
{
    char what[SG_ERROR_MESSAGE_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return sg_error_set(c->err, SG_ERR_CORRUPT, "%s: %s: %s", c->name, jp, what);
}

/* Copies s for a message: printable ASCII kept, the rest as '?'. A string
 * longer than max bytes keeps its first half and its end around "...": the
 * end is where a path's extension (often the fault) is. */
static void sanitize(const char *s, char *out, size_t out_size, size_t max)
{
    size_t n = strlen(s), j = 0;
    if (max + 1 > out_size)
        max = out_size - 1;
    size_t head = n <= max ? n : max / 2, from = n <= max ? n : n - (max - max / 2 - 3);
    for (size_t i = 0; i < head; ++i)
        out[j++] = (s[i] >= 32 && s[i] < 127) ? s[i] : '?';
    if (from < n) {
        memcpy(out + j, "...", 3);
        j += 3;
        for (size_t i = from; i < n; ++i)
            out[j++] = (s[i] >= 32 && s[i] < 127) ? s[i] : '?';
    }
    out[j] = '\0';
}

/* What a JSON value is, for "got ...". */
static void describe(const cJSON *v, char *out, size_t out_size)
{
    if (cJSON_IsString(v)) {
        char s[64];
        sanitize(v->valuestring, s, sizeof s, 40);
        snprintf(out, out_size, "\"%s\"", s);
    } else if (cJSON_IsNumber(v)) {
        snprintf(out, out_size, "%.10g", v->valuedouble);
    } else if (cJSON_IsTrue(v)) {
        snprintf(out, out_size, "true");
    } else if (cJSON_IsFalse(v)) {
        snprintf(out, out_size, "false");
    } else if (cJSON_IsNull(v)) {
        snprintf(out, out_size, "null");
    } else if (cJSON_IsArray(v)) {
        snprintf(out, out_size, "an array of %d", cJSON_GetArraySize(v));
    } else if (cJSON_IsObject(v)) {
        snprintf(out, out_size, "an object");
    } else {
        snprintf(out, out_size, "an unknown value");
    }
}

static sg_status fail_got(const ctx *c, const char *jp, const char *expected, const cJSON *v)
{
    char got[96];
    describe(v, got, sizeof got);
    return fail(c, jp, "expected %s, got %s", expected, got);
}

/* out = jp + sep + tail, cut at JP_MAX - 1 bytes (never reached by our
 * schema; a cut path still names the place). */
static void join_path(char *out, const char *jp, const char *sep, const char *tail)
{
    size_t i = 0;
    for (const char *parts[3] = {jp, sep, tail}, **p = parts; p < parts + 3; ++p)
        for (const char *s = *p; *s && i + 1 < JP_MAX; ++s)
            out[i++] = *s;
    out[i] = '\0';
}

static void child_path(char *out, const char *jp, const char *key) { join_path(out, jp, ".", key); }

static void index_path(char *out, const char *jp, size_t i)
{
    char idx[32];
    snprintf(idx, sizeof idx, "[%zu]", i);
    join_path(out, jp, "", idx);
}

/* ---- object shape ------------------------------------------------------ */

/* The member called key (case-sensitive; cJSON_GetObjectItem is not), or
 * NULL. Repeats were rejected by check_object. */
static const cJSON *member(const cJSON *obj, const char *key)
{
    for (const cJSON *it = obj->child; it; it = it->next)
        if (it->string && strcmp(it->string, key) == 0)
            return it;
    return NULL;
}

/* obj must be an object whose keys are all in keys[] and none repeated. */
static sg_status check_object(const ctx *c, const cJSON *obj, const char *jp, const char *const *keys, size_t nkeys)
{
    if (!cJSON_IsObject(obj))
        return fail_got(c, jp, "an object", obj);
    for (const cJSON *it = obj->child; it; it = it->next) {
        char key[64], cp[JP_MAX];
        sanitize(it->string ? it->string : "", key, sizeof key, 40);
        child_path(cp, jp, key);
        size_t k = 0;
        while (k < nkeys && strcmp(it->string, keys[k]) != 0)
            ++k;
        if (k == nkeys) {
            char list[320] = "";
            size_t used = 0;
            for (size_t j = 0; j < nkeys && used < sizeof list; ++j)
                used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", j ? ", " : "", keys[j]);
            return fail(c, cp, "unknown key (expected one of: %s)", list);
        }
        for (const cJSON *prev = obj->child; prev != it; prev = prev->next)
            if (strcmp(prev->string, it->string) == 0)
                return fail(c, cp, "key appears more than once");
    }
    return SG_OK;
}

#define COUNT(a) (sizeof(a) / sizeof((a)[0]))

/* ---- values ------------------------------------------------------------ */

/* A closed/open interval of allowed numbers, and how to say it. */
typedef struct range {
    double lo, hi;
    int lo_open, hi_open;
} range;

static const range ANY = {-INFINITY, INFINITY, 0, 0};
static const range UNIT = {0.0, 1.0, 0, 0};
static const range NONNEG = {0.0, INFINITY, 0, 0};

static int in_range(double v, range r)
{
    if (!isfinite(v))
        return 0;
    if (r.lo_open ? !(v > r.lo) : !(v >= r.lo))
        return 0;
    return r.hi_open ? v < r.hi : v <= r.hi;
}

/* The range as a phrase after "a number": " in [0,1]", " >= 0", "". */
static void say_range(range r, char *out, size_t n)
{
    if (isinf(r.lo) && isinf(r.hi))
        out[0] = '\0';
    else if (isinf(r.hi))
        snprintf(out, n, " %s %.10g", r.lo_open ? ">" : ">=", r.lo);
    else
        snprintf(out, n, " in %c%.10g,%.10g%c", r.lo_open ? '(' : '[', r.lo, r.hi, r.hi_open ? ')' : ']');
}

/* Number v at jp must lie in r. */
static sg_status number_at(const ctx *c, const cJSON *v, const char *jp, range r, double *out)
{
    if (!cJSON_IsNumber(v) || !in_range(v->valuedouble, r)) {
        char rs[64], e[96];
        say_range(r, rs, sizeof rs);
        snprintf(e, sizeof e, "a %snumber%s", rs[0] ? "" : "finite ", rs);
        return fail_got(c, jp, e, v);
    }
    *out = v->valuedouble;
    return SG_OK;
}

/* Optional member key: a number in r; *out keeps its default when absent. */
static sg_status get_float(const ctx *c, const cJSON *obj, const char *jp, const char *key, range r, float *out)
{
    const cJSON *v = member(obj, key);
    if (!v)
        return SG_OK;
    char cp[JP_MAX];
    child_path(cp, jp, key);
    double d = 0.0;
    sg_status st = number_at(c, v, cp, r, &d);
    if (st == SG_OK) {
        /* A double in range can still overflow float (1e300 in "[0,inf)"). */
        if (!isfinite((float)d))
            return fail_got(c, cp, "a number within float range", v);
        *out = (float)d;
    }
    return st;
}

/* Optional integer member in [lo, hi] (hi <= 2^53). */
static sg_status get_integer(const ctx *c, const cJSON *obj, const char *jp, const char *key, double lo, double hi,
                             double *out)
{
    const cJSON *v = member(obj, key);
    if (!v)
        return SG_OK;
    char cp[JP_MAX];
    child_path(cp, jp, key);
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= lo && v->valuedouble <= hi) ||
        floor(v->valuedouble) != v->valuedouble) {
        char e[96];
        snprintf(e, sizeof e, "an integer in [%.17g,%.17g]", lo, hi);
        return fail_got(c, cp, e, v);
    }
    *out = v->valuedouble;
    return SG_OK;
}

static sg_status get_int(const ctx *c, const cJSON *obj, const char *jp, const char *key, int lo, int hi, int *out)
{
    double d = *out;
    sg_status st = get_integer(c, obj, jp, key, lo, hi, &d);
    if (st == SG_OK)
        *out = (int)d;
    return st;
}

static sg_status get_bool(const ctx *c, const cJSON *obj, const char *jp, const char *key, bool *out)
{
    const cJSON *v = member(obj, key);
    if (!v)
        return SG_OK;
    if (!cJSON_IsBool(v)) {
        char cp[JP_MAX];
        child_path(cp, jp, key);
        return fail_got(c, cp, "true or false", v);
    }
    *out = cJSON_IsTrue(v);
    return SG_OK;
}

/* Optional member key, one of names[]; *out = values[i] of the match. */
static sg_status get_enum(const ctx *c, const cJSON *obj, const char *jp, const char *key, const char *const *names,
                          const int *values, size_t n, int *out)
{
    const cJSON *v = member(obj, key);
    if (!v)
        return SG_OK;
    for (size_t i = 0; cJSON_IsString(v) && i < n; ++i)
        if (strcmp(v->valuestring, names[i]) == 0) {
            *out = values[i];
            return SG_OK;
        }
    char cp[JP_MAX], e[160] = "one of";
    size_t used = strlen(e);
    for (size_t i = 0; i < n && used < sizeof e; ++i)
        used += (size_t)snprintf(e + used, sizeof e - used, "%s \"%s\"", i ? "," : "", names[i]);
    child_path(cp, jp, key);
    return fail_got(c, cp, e, v);
}

/* Optional member: an array of 3 numbers in r. */
static sg_status get_vec3(const ctx *c, const cJSON *obj, const char *jp, const char *key, range r, sg_vec3 *out)
{
    const cJSON *v = member(obj, key);
    if (!v)
        return SG_OK;
    char cp[JP_MAX];
    child_path(cp, jp, key);
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3) {
        char rs[64], e[96];
        say_range(r, rs, sizeof rs);
        snprintf(e, sizeof e, "an array of 3 %snumbers%s", rs[0] ? "" : "finite ", rs);
        return fail_got(c, cp, e, v);
    }
    float f[3];
    size_t i = 0;
    for (const cJSON *it = v->child; it; it = it->next, ++i) {
        char ip[JP_MAX];
        double d = 0.0;
        index_path(ip, cp, i);
        sg_status st = number_at(c, it, ip, r, &d);
        if (st != SG_OK)
            return st;
        if (!isfinite((float)d))
            return fail_got(c, ip, "a number within float range", it);
        f[i] = (float)d;
    }
    *out = sg_v3(f[0], f[1], f[2]);
    return SG_OK;
}

/* ---- paths ------------------------------------------------------------- */

static char *dup_string(const char *s, size_t n)
{
    char *r = sg_alloc_array(n + 1, 1);
    if (r) {
        memcpy(r, s, n);
        r[n] = '\0';
    }
    return r;
}

static int has_suffix_ci(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    if (n < m)
        return 0;
    for (size_t i = 0; i < m; ++i)
        if (tolower((unsigned char)s[n - m + i]) != tolower((unsigned char)suffix[i]))
            return 0;
    return 1;
}

/* Member key must be a non-empty string ending in one of exts (NULL
 * terminated); *out gets it joined to the base folder when relative. */
static sg_status get_path(const ctx *c, const cJSON *v, const char *jp, const char *const *exts, char **out)
{
    char e[96] = "a ";
    size_t used = 2, n = 0;
    int ok = 0;
    while (exts[n])
        ++n;
    for (size_t i = 0; i < n; ++i) {
        used += (size_t)snprintf(e + used, sizeof e - used, "%s%s", i == 0 ? "" : i + 1 == n ? " or " : ", ",
                                 exts[i]);
        ok |= cJSON_IsString(v) && has_suffix_ci(v->valuestring, exts[i]);
    }
    snprintf(e + used, sizeof e - used, " file path");
    if (!cJSON_IsString(v) || !v->valuestring[0] || !ok)
        return fail_got(c, jp, e, v);
    const char *rel = v->valuestring;
    size_t nr = strlen(rel);
    char *p;
    if (rel[0] == '/' || !c->base_dir || !c->base_dir[0]) {
        p = dup_string(rel, nr);
    } else {
        size_t nb = strlen(c->base_dir);
        int slash = c->base_dir[nb - 1] != '/';
        p = nr < SIZE_MAX - nb - 2 ? sg_alloc_array(nb + (size_t)slash + nr + 1, 1) : NULL;
        if (p) {
            memcpy(p, c->base_dir, nb);
            if (slash)
                p[nb] = '/';
            memcpy(p + nb + slash, rel, nr + 1);
        }
    }
    if (!p)
        return sg_error_set(c->err, SG_ERR_NOMEM, "%s: %s: out of memory", c->name, jp);
    *out = p;
    return SG_OK;
}

/* ---- sections ---------------------------------------------------------- */

static sg_status parse_transform(const ctx *c, const cJSON *obj, const char *jp, sg_scene_transform *t)
{
    static const char *const keys[] = {"up", "translate", "rotate_deg", "scale"};
    static const range SCALE = {0.0, 1e6, 1, 0};
    sg_status st = check_object(c, obj, jp, keys, COUNT(keys));
    const cJSON *up = member(obj, "up");
    if (st == SG_OK && up && (!cJSON_IsString(up) || sg_scene_up_parse(up->valuestring, &t->up) != SG_OK)) {
        char cp[JP_MAX];
        child_path(cp, jp, "up");
        st = fail_got(c, cp, "one of \"+y\", \"-y\", \"+z\", \"-z\", \"+x\", \"-x\" (the sign may be left out)", up);
    }
    if (st == SG_OK)
        st = get_vec3(c, obj, jp, "translate", ANY, &t->translate);
    if (st == SG_OK)
        st = get_vec3(c, obj, jp, "rotate_deg", ANY, &t->rotate_deg);
    if (st != SG_OK)
        return st;
    const cJSON *s = member(obj, "scale");
    if (cJSON_IsNumber(s)) {
        float f = 1.0f;
        st = get_float(c, obj, jp, "scale", SCALE, &f);
        t->scale = sg_v3(f, f, f);
    } else if (cJSON_IsArray(s)) {
        st = get_vec3(c, obj, jp, "scale", SCALE, &t->scale);
    } else if (s) {
        char cp[JP_MAX];
        child_path(cp, jp, "scale");
        st = fail_got(c, cp, "a number in (0,1000000] or an array of 3 of them", s);
    }
    return st;
}

static sg_status parse_material(const ctx *c, const cJSON *obj, const char *jp, sg_material *m)
{
    static const char *const keys[] = {"type", "albedo", "roughness", "specular", "emission", "use_point_colors"};
    static const char *const types[] = {"lambert", "ggx"};
    static const int type_values[] = {SG_MATERIAL_LAMBERT, SG_MATERIAL_GGX};
    sg_status st = check_object(c, obj, jp, keys, COUNT(keys));
    int type = (int)m->type;
    if (st == SG_OK)
        st = get_enum(c, obj, jp, "type", types, type_values, COUNT(types), &type);
    m->type = (sg_material_type)type;
    if (st == SG_OK)
        st = get_vec3(c, obj, jp, "albedo", UNIT, &m->albedo);
    if (st == SG_OK)
        st = get_float(c, obj, jp, "roughness", UNIT, &m->roughness);
    if (st == SG_OK)
        st = get_float(c, obj, jp, "specular", UNIT, &m->specular);
    if (st == SG_OK)
        st = get_vec3(c, obj, jp, "emission", NONNEG, &m->emission);
    if (st == SG_OK)
        st = get_bool(c, obj, jp, "use_point_colors", &m->use_point_colors);
    return st;
}

static sg_status parse_surface(const ctx *c, const cJSON *obj, const char *jp, sg_scene_desc *d)
{
    static const char *const keys[] = {"model", "kernel", "samples_per_cell", "refinements", "iso_tolerance",
                                       "iso_max_depth", "iso_leaf_radii", "iso_lod", "hybrid_lod",
                                       "hybrid_site_spacing"};
    static const char *const models[] = {"mls", "disk", "iso", "hybrid"};
    static const int model_values[] = {SG_SURFACE_MLS, SG_SURFACE_DISK, SG_SURFACE_ISO, SG_SURFACE_HYBRID};
    static const range TOLERANCE = {0.0, 10.0, 1, 0};
    static const range LOD_PIXELS = {0.0, 64.0, 0, 0};
    static const range LEAF_RADII = {0.0, 16.0, 1, 0};
    static const char *const kernels[] = {"hat", "gaussian"};
    static const int kernel_values[] = {SG_KERNEL_HAT, SG_KERNEL_GAUSSIAN};
    static const char *const refs[] = {"shrink", "encourage", "collapse"};
    static const uint32_t ref_flags[] = {SG_KD_NO_SHRINK, SG_KD_NO_ENCOURAGE, SG_KD_NO_COLLAPSE};
    sg_status st = check_object(c, obj, jp, keys, COUNT(keys));
    int model = (int)d->model, kernel = (int)d->kernel;
    if (st == SG_OK)
        st = get_enum(c, obj, jp, "model", models, model_values, COUNT(models), &model);
    if (st == SG_OK)
        st = get_enum(c, obj, jp, "kernel", kernels, kernel_values, COUNT(kernels), &kernel);
    d->model = (sg_surface_model)model;
    d->kernel = (sg_kernel)kernel;
    if (st == SG_OK)
        st = get_int(c, obj, jp, "samples_per_cell", 1, 1024, &d->samples_per_cell);
    if (st == SG_OK)
        st = get_float(c, obj, jp, "iso_tolerance", TOLERANCE, &d->iso_tolerance);
    if (st == SG_OK)
        st = get_int(c, obj, jp, "iso_max_depth", 2, 20, &d->iso_max_depth);
    if (st == SG_OK)
        st = get_float(c, obj, jp, "iso_leaf_radii", LEAF_RADII, &d->iso_leaf_radii);
    if (st == SG_OK && member(obj, "iso_lod")) { /* 0 in the file: off */
        float lod = 0.0f;
        st = get_float(c, obj, jp, "iso_lod", LOD_PIXELS, &lod);
        d->iso_lod = lod > 0.0f ? lod : -1.0f;
    }
    if (st == SG_OK && member(obj, "hybrid_lod")) { /* 0 in the file: full detail */
        float lod = 0.0f;
        st = get_float(c, obj, jp, "hybrid_lod", LOD_PIXELS, &lod);
        d->hybrid_lod = lod > 0.0f ? lod : -1.0f;
    }
    if (st == SG_OK && member(obj, "hybrid_site_spacing")) { /* 0 in the file: at vertices only */
        static const range SPACING = {0.0, 1e6, 0, 0};
        float s = 0.0f;
        st = get_float(c, obj, jp, "hybrid_site_spacing", SPACING, &s);
        d->hybrid_site_spacing = s > 0.0f ? s : -1.0f;
    }
    const cJSON *r = member(obj, "refinements");
    if (st == SG_OK && r) {
        char rp[JP_MAX];
        child_path(rp, jp, "refinements");
        st = check_object(c, r, rp, refs, COUNT(refs));
        for (size_t i = 0; st == SG_OK && i < COUNT(refs); ++i) {
            bool on = true;
            st = get_bool(c, r, rp, refs[i], &on);
            if (!on)
                d->kd_disable |= ref_flags[i];
        }
    }
    return st;
}

static sg_status parse_model(const ctx *c, const cJSON *obj, const char *jp, sg_scene_model *m)
{
    static const char *const keys[] = {"path", "builtin", "points", "radius_k", "radius_scale", "radius_cap",
                                       "drop_outliers", "transform", "material", "surface"};
    static const char *const builtins[] = {"bunny", "ground", "sphere", "room"};
    static const int builtin_values[] = {SG_SCENE_MODEL_BUNNY, SG_SCENE_MODEL_GROUND, SG_SCENE_MODEL_SPHERE,
                                         SG_SCENE_MODEL_ROOM};
    static const range RADIUS_SCALE = {0.0, 100.0, 1, 0};
    static const range RADIUS_CAP = {0.0, 1e6, 0, 0};

    /* Defaults (invariant 3). */
    m->kind = SG_SCENE_MODEL_FILE;
    m->path = NULL;
    m->points = (sg_model_points_desc){.points = 0, .radius_k = 8, .radius_scale = 1.0f, .seed = 0,
                                       .radius_cap = SG_RADIUS_CAP_DEFAULT, .drop_outliers = false};
    float cap = SG_RADIUS_CAP_DEFAULT;
    m->transform = (sg_scene_transform){.up = SG_SCENE_UP_POS_Y, .scale = {1, 1, 1}};
    m->material = sg_material_default();
    m->surface = (sg_scene_desc){.model = SG_SURFACE_MLS, .kernel = SG_KERNEL_HAT, .samples_per_cell = 8};

    sg_status st = check_object(c, obj, jp, keys, COUNT(keys));
    if (st != SG_OK)
        return st;
    const cJSON *path = member(obj, "path"), *builtin = member(obj, "builtin");
    if (path && builtin)
        return fail(c, jp, "give either \"path\" or \"builtin\", not both");
    if (!path && !builtin)
        return fail(c, jp, "missing required key \"path\" or \"builtin\"");
    char cp[JP_MAX];
    static const char *const model_exts[] = {".ply", ".obj", ".xyz", ".txt", ".pcd", NULL};
    if (path) {
        child_path(cp, jp, "path");
        st = get_path(c, path, cp, model_exts, &m->path);
    } else {
        int kind = 0;
        st = get_enum(c, obj, jp, "builtin", builtins, builtin_values, COUNT(builtins), &kind);
        m->kind = (sg_scene_model_kind)kind;
    }
    double points = 0.0, k = 8.0;
    if (st == SG_OK)
        st = get_integer(c, obj, jp, "points", 1, 1e9, &points);
    if (st == SG_OK)
        st = get_integer(c, obj, jp, "radius_k", 1, 64, &k);
    m->points.points = (size_t)points;
    m->points.radius_k = (unsigned)k;
    if (st == SG_OK)
        st = get_float(c, obj, jp, "radius_scale", RADIUS_SCALE, &m->points.radius_scale);
    if (st == SG_OK)
        st = get_float(c, obj, jp, "radius_cap", RADIUS_CAP, &cap);
    if (st == SG_OK && cap > 0.0f && cap < 1.0f) {
        child_path(cp, jp, "radius_cap");
        st = fail_got(c, cp, "0 (no cap) or a number in [1,1000000]", member(obj, "radius_cap"));
    }
    m->points.radius_cap = cap == 0.0f ? -1.0f : cap; /* the desc's "no cap" */
    if (st == SG_OK)
        st = get_bool(c, obj, jp, "drop_outliers", &m->points.drop_outliers);
    const cJSON *sub;
    if (st == SG_OK && (sub = member(obj, "transform"))) {
        child_path(cp, jp, "transform");
        st = parse_transform(c, sub, cp, &m->transform);
    }
    if (st == SG_OK && (sub = member(obj, "material"))) {
        child_path(cp, jp, "material");
        st = parse_material(c, sub, cp, &m->material);
    }
    if (st == SG_OK && (sub = member(obj, "surface"))) {
        child_path(cp, jp, "surface");
        st = parse_surface(c, sub, cp, &m->surface);
    }
    return st;
}

static sg_status parse_env(const ctx *c, const cJSON *obj, const char *jp, sg_scene_env *e)
{
    static const char *const keys[] = {"path", "builtin", "rotation_deg", "intensity", "radiance"};
    static const char *const builtins[] = {"uniform", "sky", "sunsky", "studio"};
    static const int builtin_values[] = {SG_SCENE_ENV_UNIFORM, SG_SCENE_ENV_SKY, SG_SCENE_ENV_SUNSKY,
                                         SG_SCENE_ENV_STUDIO};
    sg_status st = check_object(c, obj, jp, keys, COUNT(keys));
    if (st != SG_OK)
        return st;
    const cJSON *path = member(obj, "path"), *builtin = member(obj, "builtin");
    char cp[JP_MAX];
    if (path && builtin)
        return fail(c, jp, "give either \"path\" or \"builtin\", not both");
    if (path) {
        child_path(cp, jp, "path");
        static const char *const env_exts[] = {".exr", ".hdr", NULL};
        st = get_path(c, path, cp, env_exts, &e->path);
        e->kind = SG_SCENE_ENV_FILE;
    } else {
        int kind = (int)e->kind;
        st = get_enum(c, obj, jp, "builtin", builtins, builtin_values, COUNT(builtins), &kind);
        e->kind = (sg_scene_env_kind)kind;
    }
    if (st == SG_OK)
        st = get_float(c, obj, jp, "rotation_deg", ANY, &e->rotation_deg);
    if (st == SG_OK)
        st = get_float(c, obj, jp, "intensity", NONNEG, &e->intensity);
    if (st == SG_OK && member(obj, "radiance") && e->kind != SG_SCENE_ENV_UNIFORM) {
        child_path(cp, jp, "radiance");
        return fail(c, cp, "only allowed with \"builtin\": \"uniform\"");
    }
    if (st == SG_OK)
        st = get_vec3(c, obj, jp, "radiance", NONNEG, &e->radiance);
    return st;
}

/* Parallel when |a x b| is below ~1e-6 of |a| |b| (about 0.06 degrees). */
static int nearly_parallel(sg_vec3 a, sg_vec3 b)
{
    float cr = sg_v3_length(sg_v3_cross(a, b));
    return !(cr > 1e-6f * sg_v3_length(a) * sg_v3_length(b));
}

static sg_status parse_camera(const ctx *c, const cJSON *obj, const char *jp, size_t index, sg_scene_camera *cam)
{
    static const char *const keys[] = {"name", "eye", "look", "up", "fov_deg"};
    static const range FOV = {0.0, 180.0, 1, 1};
    snprintf(cam->name, sizeof cam->name, "camera%zu", index);
    cam->up = sg_v3(0.0f, 1.0f, 0.0f);
    cam->fov_deg = 40.0f;
    sg_status st = check_object(c, obj, jp, keys, COUNT(keys));
    if (st != SG_OK)
        return st;
    char cp[JP_MAX];
    const cJSON *name = member(obj, "name");
    if (name) {
        child_path(cp, jp, "name");
        if (!cJSON_IsString(name) || !name->valuestring[0] || strlen(name->valuestring) >= SG_SCENE_NAME_MAX)
            return fail_got(c, cp, "a string of 1 to 63 bytes", name);
        memcpy(cam->name, name->valuestring, strlen(name->valuestring) + 1);
    }
    static const char *const required[] = {"eye", "look"};
    for (size_t i = 0; i < COUNT(required); ++i)
        if (!member(obj, required[i]))
            return fail(c, jp, "missing required key \"%s\"", required[i]);
    st = get_vec3(c, obj, jp, "eye", ANY, &cam->eye);
    if (st == SG_OK)
        st = get_vec3(c, obj, jp, "look", ANY, &cam->look);
    if (st == SG_OK)
        st = get_vec3(c, obj, jp, "up", ANY, &cam->up);
    if (st == SG_OK)
        st = get_float(c, obj, jp, "fov_deg", FOV, &cam->fov_deg);
    if (st != SG_OK)
        return st;
    sg_vec3 view = sg_v3_sub(cam->look, cam->eye);
    if (!(sg_v3_length(view) > 0.0f) || !sg_v3_isfinite(view)) {
        child_path(cp, jp, "look");
        return fail(c, cp, "expected a point other than eye");
    }
    if (nearly_parallel(view, cam->up)) {
        child_path(cp, jp, "up");
        return fail(c, cp, "expected a direction not parallel to look - eye");
    }
    return SG_OK;
}

static sg_status parse_render(const ctx *c, const cJSON *obj, const char *jp, sg_scene_render *r)
{
    static const char *const keys[] = {"width", "height", "spp", "max_depth", "seed", "threads"};
    sg_status st = check_object(c, obj, jp, keys, COUNT(keys));
    if (st == SG_OK)
        st = get_int(c, obj, jp, "width", 1, 16384, &r->width);
    if (st == SG_OK)
        st = get_int(c, obj, jp, "height", 1, 16384, &r->height);
    if (st == SG_OK)
        st = get_int(c, obj, jp, "spp", 1, 1 << 20, &r->spp);
    if (st == SG_OK)
        st = get_int(c, obj, jp, "max_depth", 0, 1024, &r->max_depth);
    if (st == SG_OK)
        st = get_int(c, obj, jp, "threads", 0, 4096, &r->threads);
    double seed = (double)r->seed;
    if (st == SG_OK)
        st = get_integer(c, obj, jp, "seed", 0, MAX_EXACT_INT, &seed);
    r->seed = (uint64_t)seed;
    return st;
}

/* "bake": {"ray_cone": x}. The range's top is bake.h's
 * SG_BAKE_RAY_CONE_MAX (io does not include the bake). */
static sg_status parse_bake(const ctx *c, const cJSON *obj, const char *jp, sg_scene_bake *b)
{
    static const char *const keys[] = {"ray_cone"};
    static const range RAY_CONE = {0.0, 16.0, 0, 0};
    sg_status st = check_object(c, obj, jp, keys, COUNT(keys));
    if (st == SG_OK)
        st = get_float(c, obj, jp, "ray_cone", RAY_CONE, &b->ray_cone);
    return st;
}

/* Parses the tree into *sf (zeroed by the caller); on failure *sf holds
 * whatever was allocated, for the caller to free (invariant 2). */
static sg_status parse_root(const ctx *c, const cJSON *root, sg_scene_file *sf)
{
    static const char *const keys[] = {"models", "envmap", "cameras", "render", "bake"};
    sf->env = (sg_scene_env){.kind = SG_SCENE_ENV_UNIFORM, .path = NULL, .rotation_deg = 0.0f,
                             .intensity = 1.0f, .radiance = {1.0f, 1.0f, 1.0f}};
    sf->render = (sg_scene_render){.width = 512, .height = 512, .spp = 64, .max_depth = 8, .seed = 1,
                                   .threads = 0};
    sf->bake = (sg_scene_bake){.ray_cone = -1.0f};
    sg_status st = check_object(c, root, "$", keys, COUNT(keys));
    if (st != SG_OK)
        return st;

    const cJSON *models = member(root, "models");
    if (!models)
        return fail(c, "$", "missing required key \"models\"");
    if (!cJSON_IsArray(models) || cJSON_GetArraySize(models) < 1)
        return fail_got(c, "$.models", "a non-empty array of models", models);
    size_t n = (size_t)cJSON_GetArraySize(models);
    sf->models = sg_calloc_array(n, sizeof *sf->models);
    if (!sf->models)
        return sg_error_set(c->err, SG_ERR_NOMEM, "%s: $.models: out of memory for %zu models", c->name, n);
    size_t i = 0;
    for (const cJSON *it = models->child; it; it = it->next, ++i) {
        char jp[JP_MAX];
        index_path(jp, "$.models", i);
        sf->model_count = i + 1; /* so that free sees this model's path */
        st = parse_model(c, it, jp, &sf->models[i]);
        if (st != SG_OK)
            return st;
    }

    const cJSON *env = member(root, "envmap");
    if (env && (st = parse_env(c, env, "$.envmap", &sf->env)) != SG_OK)
        return st;

    const cJSON *cams = member(root, "cameras");
    if (cams) {
        if (!cJSON_IsArray(cams))
            return fail_got(c, "$.cameras", "an array of cameras", cams);
        n = (size_t)cJSON_GetArraySize(cams);
        if (n) {
            sf->cameras = sg_calloc_array(n, sizeof *sf->cameras);
            if (!sf->cameras)
                return sg_error_set(c->err, SG_ERR_NOMEM, "%s: $.cameras: out of memory", c->name);
        }
        i = 0;
        for (const cJSON *it = cams->child; it; it = it->next, ++i) {
            char jp[JP_MAX];
            index_path(jp, "$.cameras", i);
            sf->camera_count = i + 1;
            if ((st = parse_camera(c, it, jp, i, &sf->cameras[i])) != SG_OK)
                return st;
            for (size_t j = 0; j < i; ++j)
                if (strcmp(sf->cameras[j].name, sf->cameras[i].name) == 0) {
                    char np[JP_MAX];
                    child_path(np, jp, "name");
                    return fail(c, np, "\"%s\" is already the name of $.cameras[%zu]", sf->cameras[i].name, j);
                }
        }
    }

    const cJSON *render = member(root, "render");
    if (render && (st = parse_render(c, render, "$.render", &sf->render)) != SG_OK)
        return st;
    const cJSON *bake = member(root, "bake");
    if (bake && (st = parse_bake(c, bake, "$.bake", &sf->bake)) != SG_OK)
        return st;
    return SG_OK;
}

/* line:column (1-based, column in bytes) of byte offset pos. */
static void line_col(const char *text, size_t pos, size_t *line, size_t *col)
{
    *line = 1;
    size_t start = 0;
    for (size_t i = 0; i < pos; ++i)
        if (text[i] == '\n') {
            ++*line;
            start = i + 1;
        }
    *col = pos - start + 1;
}

sg_status sg_scene_file_parse(const char *text, size_t len, const char *name, const char *base_dir,
                              sg_scene_file *out, sg_error *err)
{
    assert(out);
    ctx c = {name && name[0] ? name : "scene", base_dir, err};
    sg_scene_file sf = {0};
    cJSON *root = NULL;
    sg_status st = SG_OK;
    if (!text && len)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: no text", c.name);
    /* cJSON wants a NUL-terminated copy whose length counts the NUL: with
     * require_null_terminated it then rejects trailing garbage. */
    char *buf = sg_alloc_array(len + 1, 1);
    if (!buf)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu bytes", c.name, len);
    if (len)
        memcpy(buf, text, len);
    buf[len] = '\0';
    const char *nul = memchr(buf, '\0', len);
    if (nul) {
        size_t line, col;
        line_col(buf, (size_t)(nul - buf), &line, &col);
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s:%zu:%zu: invalid JSON: NUL byte", c.name, line, col);
        goto done;
    }
    const char *end = NULL;
    root = cJSON_ParseWithLengthOpts(buf, len + 1, &end, 1);
    if (!root) {
        size_t pos = end && end >= buf && end <= buf + len ? (size_t)(end - buf) : len;
        size_t line, col;
        line_col(buf, pos, &line, &col);
        /* Context: up to 30 bytes of the line before the position (cJSON
         * often stops just past the offending token) and 10 after. */
        size_t a = pos - (col - 1), b = pos;
        if (pos - a > 30)
            a = pos - 30;
        while (b < len && b < pos + 10 && buf[b] != '\n' && buf[b] != '\r')
            ++b;
        while (a < b && (buf[a] == ' ' || buf[a] == '\t'))
            ++a;
        char near[48];
        char line_text[48];
        size_t n = b - a < sizeof line_text - 1 ? b - a : sizeof line_text - 1;
        memcpy(line_text, buf + a, n);
        line_text[n] = '\0';
        sanitize(line_text, near, sizeof near, 40);
        if (pos >= len && len > 0 && !near[0])
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s:%zu:%zu: invalid JSON: unexpected end of file", c.name,
                              line, col);
        else if (pos >= len)
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s:%zu:%zu: invalid JSON: unexpected end of file after \"%s\"",
                              c.name, line, col, near);
        else
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s:%zu:%zu: invalid JSON near \"%s\"", c.name, line, col,
                              near);
        goto done;
    }
    st = parse_root(&c, root, &sf);
done:
    cJSON_Delete(root);
    sg_free(buf);
    if (st != SG_OK) {
        sg_scene_file_free(&sf);
        return st;
    }
    *out = sf;
    return SG_OK;
}

sg_status sg_scene_file_load(const char *path, sg_scene_file *out, sg_error *err)
{
    assert(path && out);
    sg_status st = SG_OK;
    char *text = NULL, *dir = NULL;
    size_t len = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    /* Read in chunks rather than trusting ftell (pipes, /proc files). */
    size_t cap = 0;
    for (;;) {
        if (len == cap) {
            size_t ncap = cap ? 2 * cap : 4096;
            if (cap >= SCENE_FILE_MAX_BYTES) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: larger than %u bytes: not a scene file", path,
                                  (unsigned)SCENE_FILE_MAX_BYTES);
                goto done;
            }
            void *p = text;
            bool ok;
            if (p) {
                ok = sg_realloc_array(&p, len, ncap, 1);
            } else {
                p = sg_alloc_array(ncap, 1);
                ok = p != NULL;
            }
            if (!ok) {
                st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory reading the file", path);
                goto done;
            }
            text = p;
            cap = ncap;
        }
        size_t got = fread(text + len, 1, cap - len, f);
        len += got;
        if (got == 0) {
            if (ferror(f)) {
                st = sg_error_set(err, SG_ERR_IO, "%s: read failed", path);
                goto done;
            }
            break;
        }
    }
    /* The scene's folder: everything up to the last '/', kept for "/x". */
    const char *slash = strrchr(path, '/');
    if (slash) {
        dir = dup_string(path, slash == path ? 1 : (size_t)(slash - path));
        if (!dir) {
            st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
            goto done;
        }
    }
    st = sg_scene_file_parse(text, len, path, dir, out, err);
done:
    sg_free(dir);
    sg_free(text);
    fclose(f);
    return st;
}

void sg_scene_file_free(sg_scene_file *sf)
{
    if (!sf)
        return;
    for (size_t i = 0; sf->models && i < sf->model_count; ++i)
        sg_free(sf->models[i].path);
    sg_free(sf->models);
    sg_free(sf->cameras);
    sg_free(sf->env.path);
    memset(sf, 0, sizeof *sf);
}

const sg_scene_camera *sg_scene_file_find_camera(const sg_scene_file *sf, const char *name)
{
    for (size_t i = 0; i < sf->camera_count; ++i)
        if (strcmp(sf->cameras[i].name, name) == 0)
            return &sf->cameras[i];
    return NULL;
}

/* ---- hash -------------------------------------------------------------- */

#define FNV_OFFSET 0xcbf29ce484222325ull
#define FNV_PRIME 0x100000001b3ull

static void h_bytes(uint64_t *h, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; ++i)
        *h = (*h ^ b[i]) * FNV_PRIME;
}

static void h_u64(uint64_t *h, uint64_t v)
{
    unsigned char b[8];
    for (int i = 0; i < 8; ++i)
        b[i] = (unsigned char)(v >> (8 * i));
    h_bytes(h, b, 8);
}

static void h_f32(uint64_t *h, float f)
{
    uint32_t u;
    if (f == 0.0f)
        f = 0.0f; /* -0 and +0 are the same setting */
    memcpy(&u, &f, 4);
    h_u64(h, u);
}

static void h_v3(uint64_t *h, sg_vec3 v)
{
    h_f32(h, v.x);
    h_f32(h, v.y);
    h_f32(h, v.z);
}

/* Length first, so that "ab"+"c" and "a"+"bc" differ; NULL differs from "". */
static void h_str(uint64_t *h, const char *s)
{
    if (!s) {
        h_u64(h, UINT64_MAX);
        return;
    }
    size_t n = strlen(s);
    h_u64(h, n);
    h_bytes(h, s, n);
}

uint64_t sg_scene_file_hash(const sg_scene_file *sf, uint32_t parts)
{
    uint64_t h = FNV_OFFSET;
    h_u64(&h, 2); /* serialisation version: bump when the encoding changes (2: up axis, radius cap,
                     outlier drop) */
    h_u64(&h, parts & SG_SCENE_HASH_ALL);
    if (parts & SG_SCENE_HASH_MODELS) {
        h_u64(&h, sf->model_count);
        for (size_t i = 0; i < sf->model_count; ++i) {
            const sg_scene_model *m = &sf->models[i];
            h_u64(&h, (uint64_t)m->kind);
            h_str(&h, m->path);
            h_u64(&h, m->points.points);
            h_u64(&h, m->points.radius_k);
            h_f32(&h, m->points.radius_scale);
            h_u64(&h, m->points.seed);
            h_f32(&h, m->points.radius_cap);
            h_u64(&h, m->points.drop_outliers);
            h_u64(&h, (uint64_t)m->transform.up);
            h_v3(&h, m->transform.translate);
            h_v3(&h, m->transform.rotate_deg);
            h_v3(&h, m->transform.scale);
            h_u64(&h, (uint64_t)m->material.type);
            h_v3(&h, m->material.albedo);
            h_f32(&h, m->material.roughness);
            h_f32(&h, m->material.specular);
            h_v3(&h, m->material.emission);
            h_u64(&h, m->material.use_point_colors);
            h_u64(&h, (uint64_t)m->surface.model);
            h_u64(&h, (uint64_t)m->surface.kernel);
            h_u64(&h, m->surface.kd_disable);
            h_u64(&h, (uint64_t)(int64_t)m->surface.samples_per_cell);
            h_f32(&h, m->surface.max_sample_spacing);
            h_u64(&h, (uint64_t)(int64_t)m->surface.max_depth);
            h_f32(&h, m->surface.blend_depth);
            if (m->surface.model == SG_SURFACE_ISO) { /* MLS and disk scenes keep their hashes */
                h_f32(&h, m->surface.iso_tolerance);
                h_u64(&h, (uint64_t)(int64_t)m->surface.iso_max_depth);
                if (m->surface.iso_leaf_radii != 0.0f) /* earlier ISO bakes keep their hashes */
                    h_f32(&h, m->surface.iso_leaf_radii);
                /* Since stop 31 an ISO's light sites include its inner
                 * nodes' (iso_sites.h), so a bake (keyed with the map:
                 * SG_SCENE_HASH_BAKE) of before has too few; the octree, and
                 * a world file's key (the models alone), are unchanged. */
                if (parts & SG_SCENE_HASH_ENV)
                    h_u64(&h, 0x4e4f4445u); /* "NODE" */
            }
            /* Light sites on lattices (hybrid.h): the builtin ground (stop
             * 30) and room (stop 31) changed from gridded meshes to two
             * triangles a rectangle with lattices, and their bakes' sites
             * with them; other hybrid models without a spacing keep their
             * hashes. */
            if (m->surface.model == SG_SURFACE_HYBRID &&
                (m->kind == SG_SCENE_MODEL_GROUND || m->kind == SG_SCENE_MODEL_ROOM ||
                 m->surface.hybrid_site_spacing != 0.0f)) {
                h_u64(&h, 0x4c415454u); /* "LATT" */
                h_f32(&h, m->surface.hybrid_site_spacing);
            }
            /* Since stop 32 a hybrid's vertices, and so its light sites,
             * are numbered in leaf order (hybrid_int.h invariant 5): a
             * bake or a world file of before names them in the mesh's
             * order, with the same count. */
            if (m->surface.model == SG_SURFACE_HYBRID)
                h_u64(&h, 0x564f5244u); /* "VORD" */
        }
    }
    if (parts & SG_SCENE_HASH_ENV) {
        h_u64(&h, (uint64_t)sf->env.kind);
        h_str(&h, sf->env.path);
        h_f32(&h, sf->env.rotation_deg);
        h_f32(&h, sf->env.intensity);
        h_v3(&h, sf->env.radiance);
    }
    if (parts & SG_SCENE_HASH_CAMERAS) {
        h_u64(&h, sf->camera_count);
        for (size_t i = 0; i < sf->camera_count; ++i) {
            const sg_scene_camera *cam = &sf->cameras[i];
            h_str(&h, cam->name);
            h_v3(&h, cam->eye);
            h_v3(&h, cam->look);
            h_v3(&h, cam->up);
            h_f32(&h, cam->fov_deg);
        }
    }
    if (parts & SG_SCENE_HASH_RENDER) {
        h_u64(&h, (uint64_t)sf->render.width);
        h_u64(&h, (uint64_t)sf->render.height);
        h_u64(&h, (uint64_t)sf->render.spp);
        h_u64(&h, (uint64_t)sf->render.max_depth);
        h_u64(&h, sf->render.seed);
    }
    return h;
}

/* ---- transforms -------------------------------------------------------- */

/* Rz Ry Rx v: X first, then Y, then Z, about the world axes. */
static sg_vec3 rotate_xyz(sg_vec3 deg, sg_vec3 v)
{
    const double k = 3.14159265358979323846 / 180.0;
    double cx = cos(deg.x * k), sx = sin(deg.x * k);
    double cy = cos(deg.y * k), sy = sin(deg.y * k);
    double cz = cos(deg.z * k), sz = sin(deg.z * k);
    double x = v.x, y = cx * v.y - sx * v.z, z = sx * v.y + cx * v.z;   /* Rx */
    double x2 = cy * x + sy * z, z2 = -sy * x + cy * z;                /* Ry */
    double x3 = cz * x2 - sz * y, y3 = sz * x2 + cz * y;               /* Rz */
    return sg_v3((float)x3, (float)y3, (float)z2);
}

/* ---- up axis ------------------------------------------------------------ */

static const struct {
    const char *name; /* canonical spelling */
    sg_scene_up up;
} UP_NAMES[] = {{"+y", SG_SCENE_UP_POS_Y}, {"-y", SG_SCENE_UP_NEG_Y}, {"+z", SG_SCENE_UP_POS_Z},
                {"-z", SG_SCENE_UP_NEG_Z}, {"+x", SG_SCENE_UP_POS_X}, {"-x", SG_SCENE_UP_NEG_X}};

sg_status sg_scene_up_parse(const char *s, sg_scene_up *out)
{
    if (!s)
        return SG_ERR_INVALID_ARG;
    char sign = '+', axis;
    if (s[0] == '+' || s[0] == '-')
        sign = *s++;
    axis = (char)tolower((unsigned char)s[0]);
    if (!axis || s[1])
        return SG_ERR_INVALID_ARG;
    for (size_t i = 0; i < COUNT(UP_NAMES); ++i)
        if (UP_NAMES[i].name[0] == sign && UP_NAMES[i].name[1] == axis) {
            *out = UP_NAMES[i].up;
            return SG_OK;
        }
    return SG_ERR_INVALID_ARG;
}

const char *sg_scene_up_name(sg_scene_up up)
{
    for (size_t i = 0; i < COUNT(UP_NAMES); ++i)
        if (UP_NAMES[i].up == up)
            return UP_NAMES[i].name;
    return "?";
}

/* The quarter or half turn that takes the model's up axis to +Y (a proper
 * rotation, so handedness and winding are kept): +Z up turns -90 degrees
 * about X, +X up +90 about Z, -Y up 180 about X. */
sg_vec3 sg_scene_up_apply(sg_scene_up up, sg_vec3 v)
{
    switch (up) {
    case SG_SCENE_UP_POS_Z: return sg_v3(v.x, v.z, -v.y);
    case SG_SCENE_UP_NEG_Z: return sg_v3(v.x, -v.z, v.y);
    case SG_SCENE_UP_POS_X: return sg_v3(-v.y, v.x, v.z);
    case SG_SCENE_UP_NEG_X: return sg_v3(v.y, -v.x, v.z);
    case SG_SCENE_UP_NEG_Y: return sg_v3(v.x, -v.y, -v.z);
    case SG_SCENE_UP_POS_Y: break;
    }
    return v;
}

sg_vec3 sg_scene_transform_point(const sg_scene_transform *t, sg_vec3 p)
{
    p = sg_scene_up_apply(t->up, p);
    return sg_v3_add(t->translate, rotate_xyz(t->rotate_deg, sg_v3_mul(t->scale, p)));
}

sg_vec3 sg_scene_transform_normal(const sg_scene_transform *t, sg_vec3 n)
{
    n = sg_scene_up_apply(t->up, n);
    sg_vec3 s = sg_v3(n.x / t->scale.x, n.y / t->scale.y, n.z / t->scale.z);
    return sg_v3_normalize(rotate_xyz(t->rotate_deg, s));
}

float sg_scene_transform_radius(const sg_scene_transform *t, float r)
{
    float s = fmaxf(t->scale.x, fmaxf(t->scale.y, t->scale.z));
    return r * s;
}
