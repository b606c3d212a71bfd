/* world_file.c — the .sgworld file: save and load a built world. See
 * world_file.h for the format and the rules of freshness.
 *
 * Invariants:
 *  1. save writes, and load reads, the models' arrays through one list
 *     (surface/scene_store.h), so the two cannot disagree on what a
 *     surface holds;
 *  2. a loaded world's scenes borrow the file's map; w->file is closed by
 *     sg_world_destroy after every scene (world.c);
 *  3. everything load takes from the file is checked before use: the
 *     container checks structure and CRCs, this file the counts and the
 *     materials, scene_store.c the arrays.
 */
#include "render/world_file.h"

#include <assert.h>
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "bake/bake_file.h"
#include "core/alloc.h"
#include "render/world_int.h"
#include "accel/sphere_tree.h"
#include "surface/scene_store.h"

enum { MATERIAL_WORDS = 10, WORLD_WORDS = 4 };

static const char BASE62[] = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz";

/* "PX" + model m in two base-62 digits ("PX0A" for model 10). */
static void model_tag(char tag[5], const char code[3], size_t m)
{
    tag[0] = code[0];
    tag[1] = code[1];
    tag[2] = BASE62[(m / 62) % 62];
    tag[3] = BASE62[m % 62];
    tag[4] = '\0';
}

static sg_bake_type bake_type(sg_store_elem e)
{
    return e == SG_STORE_F32 ? SG_BAKE_TYPE_F32 : e == SG_STORE_U16 ? SG_BAKE_TYPE_U16 : SG_BAKE_TYPE_U32;
}

/* Nonzero (0 would skip the container's check). The sphere tree's
 * branching factor (a build option) counts: a world of another width is
 * stale, rebuilt by --if-stale, not corrupt. */
static uint64_t param_hash(void)
{
    return 0x5347574f524c4400ull | SG_WORLD_BUILDER_VERSION | (uint64_t)SG_STREE_WIDTH << 8;
}

uint64_t sg_world_file_scene_hash(const sg_scene_file *sf) { return sg_scene_file_hash(sf, SG_SCENE_HASH_MODELS); }

/* ---- input stamps ---------------------------------------------------------- */

/* The file model m reads, or NULL for a builtin made in memory. */
static const char *input_path(const sg_scene_model *m, char *buf, size_t size)
{
    if (m->kind == SG_SCENE_MODEL_FILE)
        return m->path;
    if (m->kind == SG_SCENE_MODEL_BUNNY) {
        snprintf(buf, size, "%s/bunny.ply", SG_ASSET_DIR);
        return buf;
    }
    return NULL;
}

/* The INPT text of sf's inputs as they are now, in *out (malloc'd; free). */
static sg_status stamps_now(const sg_scene_file *sf, char **out, size_t *len, sg_error *err)
{
    size_t cap = 256, n = 0;
    char *text = malloc(cap);
    if (!text)
        return sg_error_set(err, SG_ERR_NOMEM, "world file: out of memory for the input stamps");
    text[0] = '\0';
    for (size_t i = 0; i < sf->model_count; ++i) {
        char buf[4200];
        const char *path = input_path(&sf->models[i], buf, sizeof buf);
        if (!path)
            continue;
        struct stat sb;
        if (stat(path, &sb) != 0) {
            free(text);
            return sg_error_set(err, SG_ERR_IO, "$.models[%zu]: %s: %s", i, path, strerror(errno));
        }
        char line[4400];
        int k = snprintf(line, sizeof line, "%lld %lld %ld %s\n", (long long)sb.st_size, (long long)sb.st_mtim.tv_sec,
                         (long)sb.st_mtim.tv_nsec, path);
        if (k < 0 || (size_t)k >= sizeof line) {
            free(text);
            return sg_error_set(err, SG_ERR_INVALID_ARG, "$.models[%zu]: path too long", i);
        }
        if (n + (size_t)k + 1 > cap) {
            cap = sg_grown_capacity(cap, n + (size_t)k + 1);
            char *t = realloc(text, cap);
            if (!t) {
                free(text);
                return sg_error_set(err, SG_ERR_NOMEM, "world file: out of memory for the input stamps");
            }
            text = t;
        }
        memcpy(text + n, line, (size_t)k + 1);
        n += (size_t)k;
    }
    *out = text;
    *len = n;
    return SG_OK;
}

/* Compares the stored stamps with the inputs now; SG_ERR_INVALID_ARG
 * naming the first line that differs. */
static sg_status check_stamps(const char *path, const char *stored, size_t stored_len, const sg_scene_file *sf,
                              sg_error *err)
{
    char *now = NULL;
    size_t len = 0;
    sg_status st = stamps_now(sf, &now, &len, err);
    if (st != SG_OK)
        return st;
    if (len != stored_len || memcmp(now, stored, len) != 0) {
        /* first differing line of each, for the message */
        size_t at = 0;
        while (at < len && at < stored_len && now[at] == stored[at])
            ++at;
        while (at > 0 && now[at - 1] != '\n')
            --at;
        /* stored is not NUL-terminated: bound its line by hand */
        size_t b = at;
        while (b < stored_len && stored[b] != '\n')
            ++b;
        int na = (int)strcspn(now + at, "\n"), nb = (int)(b - at);
        st = sg_error_set(err, SG_ERR_INVALID_ARG,
                          "%s: an input changed since the world was built (now \"%.*s\", when built \"%.*s\"; "
                          "fields: size, modified s, ns, path)",
                          path, na, now + at, nb, stored + at);
    }
    free(now);
    return st;
}

/* ---- save ------------------------------------------------------------------ */

static void encode_material(const sg_material *m, uint32_t *w)
{
    float f[8] = {m->albedo.x, m->albedo.y, m->albedo.z, m->roughness, m->specular,
                  m->emission.x, m->emission.y, m->emission.z};
    w[0] = (uint32_t)m->type;
    memcpy(w + 1, f, sizeof f);
    w[9] = m->use_point_colors ? 1u : 0u;
}

static sg_status decode_material(const uint32_t *w, const char *path, size_t i, sg_material *m, sg_error *err)
{
    float f[8];
    memcpy(f, w + 1, sizeof f);
    *m = (sg_material){.type = (sg_material_type)w[0], .albedo = {f[0], f[1], f[2]}, .roughness = f[3],
                       .specular = f[4], .emission = {f[5], f[6], f[7]}, .use_point_colors = w[9] != 0};
    sg_error e2 = {0};
    if (w[9] > 1 || sg_material_validate(m, &e2) != SG_OK)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: model %zu: material: %s", path, i,
                            w[9] > 1 ? "use_point_colors is not 0 or 1" : e2.message);
    return SG_OK;
}

sg_status sg_world_save(const sg_world *w, const sg_scene_file *sf, const char *path, sg_error *err)
{
    if (!w || !sf || !path)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "world file: NULL argument");
    if (w->count != sf->model_count)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: the world has %zu models, the scene %zu", path, w->count,
                            sf->model_count);
    if (w->count > SG_WORLD_MAX_MODELS)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: %zu models; a world file holds at most %u", path, w->count,
                            SG_WORLD_MAX_MODELS);
    sg_status st = SG_OK;
    char *stamps = NULL;
    size_t stamps_len = 0;
    uint32_t *mat = sg_alloc_array(w->count, MATERIAL_WORDS * sizeof(uint32_t));
    sg_scene_store *store = sg_alloc_array(1, sizeof *store);
    sg_bake_writer *wr = NULL;
    if (!mat || !store) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    if ((st = stamps_now(sf, &stamps, &stamps_len, err)) != SG_OK)
        goto done;
    for (size_t i = 0; i < w->count; ++i)
        encode_material(&w->materials[i], mat + MATERIAL_WORDS * i);
    /* The table holds the sections written, not every array a surface
     * might hold: 3 + models x (1 + the arrays each holds), at most
     * 3 + SG_WORLD_MAX_MODELS x 25 (MLS). */
    size_t sections = 3;
    for (size_t i = 0; i < w->count; ++i) {
        sg_scene_store_of(w->scenes[i], store);
        sections++;
        for (int a = 0; a < SG_SA_COUNT; ++a)
            sections += store->data[a] != NULL;
    }
    assert(sections <= SG_BAKE_MAX_SECTIONS);
    uint64_t head[WORLD_WORDS] = {w->count, SG_WORLD_BUILDER_VERSION, 0, 0};
    sg_bake_writer_desc wd = {.path = path, .scene_hash = sg_world_file_scene_hash(sf), .param_hash = param_hash(),
                              .max_sections = (uint32_t)sections, .kind = SG_BAKE_KIND_WORLD};
    if ((st = sg_bake_writer_create(&wd, &wr, err)) != SG_OK ||
        (st = sg_bake_writer_add_section(wr, "WRLD", SG_BAKE_TYPE_U64, WORLD_WORDS, head, err)) != SG_OK ||
        (st = sg_bake_writer_add_section(wr, "MATL", SG_BAKE_TYPE_U32, MATERIAL_WORDS * w->count, mat, err)) !=
            SG_OK ||
        (st = sg_bake_writer_add_section(wr, "INPT", SG_BAKE_TYPE_BYTES, stamps_len, stamps, err)) != SG_OK)
        goto done;
    for (size_t i = 0; i < w->count; ++i) {
        char tag[5];
        sg_scene_store_of(w->scenes[i], store);
        model_tag(tag, "HD", i);
        if ((st = sg_bake_writer_add_section(wr, tag, SG_BAKE_TYPE_U64, SG_SCENE_SCALARS, store->scalars, err)) !=
            SG_OK)
            goto done;
        for (int a = 0; a < SG_SA_COUNT; ++a) {
            const sg_scene_array_spec *sp = sg_scene_array_spec_of((sg_scene_array_id)a);
            if (!store->data[a])
                continue;
            model_tag(tag, sp->code, i);
            if ((st = sg_bake_writer_add_section(wr, tag, bake_type(sp->elem), store->items[a] * sp->per,
                                                 store->data[a], err)) != SG_OK)
                goto done;
        }
    }
    st = sg_bake_writer_commit(wr, err);
done:
    sg_bake_writer_destroy(wr);
    free(stamps);
    sg_free(store);
    sg_free(mat);
    return st;
}

/* ---- load ------------------------------------------------------------------ */

/* A view of section tag, which must have type t and count elements (count
 * 0: any multiple of per, returned in *items). */
static sg_status view(const sg_bake_file *f, const char *path, const char *tag, sg_bake_type t, uint64_t per,
                      uint64_t *items, const void **data, sg_error *err)
{
    const sg_bake_section *s = sg_bake_file_find(f, tag);
    if (!s)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: no section %s", path, tag);
    if (s->type != t || s->count % per != 0)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s: type %d with %" PRIu64 " elements, expected type %d in "
                            "items of %" PRIu64, path, tag, (int)s->type, s->count, (int)t, per);
    *items = s->count / per;
    return sg_bake_file_view(f, tag, data, err);
}

static sg_status load_model(const sg_bake_file *f, const char *path, size_t i, const sg_scene_desc *query,
                            sg_scene_store *store, sg_scene **out, sg_error *err)
{
    memset(store, 0, sizeof *store);
    char tag[5];
    const void *data;
    uint64_t items;
    model_tag(tag, "HD", i);
    sg_status st = view(f, path, tag, SG_BAKE_TYPE_U64, 1, &items, &data, err);
    if (st != SG_OK)
        return st;
    if (items != SG_SCENE_SCALARS)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s: %" PRIu64 " scalars, expected %d", path, tag, items,
                            SG_SCENE_SCALARS);
    memcpy(store->scalars, data, sizeof store->scalars);
    /* The arrays' CRCs are most of a load's time and independent: checked
     * in parallel; the first failure in array order is reported, so the
     * message does not depend on the thread count. */
    sg_status ast[SG_SA_COUNT];
    sg_error aerr[SG_SA_COUNT];
#pragma omp parallel for schedule(dynamic, 1)
    for (int a = 0; a < SG_SA_COUNT; ++a) {
        const sg_scene_array_spec *sp = sg_scene_array_spec_of((sg_scene_array_id)a);
        char atag[5];
        model_tag(atag, sp->code, i);
        ast[a] = SG_OK;
        if (sg_bake_file_find(f, atag)) /* else scene_store says whether this surface needs it */
            ast[a] = view(f, path, atag, bake_type(sp->elem), sp->per, &store->items[a], &store->data[a], &aerr[a]);
    }
    for (int a = 0; a < SG_SA_COUNT; ++a)
        if (ast[a] != SG_OK) {
            if (err)
                *err = aerr[a];
            return ast[a];
        }
    char label[4300];
    snprintf(label, sizeof label, "%s: model %zu", path, i);
    return sg_scene_from_store(store, label, query, out, err);
}

static sg_status open_world(const char *path, const sg_scene_file *sf, int map, sg_bake_file **out, sg_error *err)
{
    sg_bake_open_desc od = {.kind = SG_BAKE_KIND_WORLD, .scene_hash = sg_world_file_scene_hash(sf),
                            .param_hash = param_hash(), .map = map};
    sg_bake_file *f = NULL;
    sg_status st = sg_bake_file_open_desc(path, &od, &f, err);
    if (st != SG_OK)
        return st;
    /* stamps before anything large is read */
    const sg_bake_section *s = sg_bake_file_find(f, "INPT");
    char *text = NULL;
    if (!s) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: no section INPT", path);
    } else if (s->size > (1u << 24)) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section INPT: %" PRIu64 " bytes of input stamps", path, s->size);
    } else if (!(text = malloc(s->size ? s->size : 1))) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    } else if ((st = sg_bake_file_read(f, "INPT", text, s->size, err)) == SG_OK) {
        st = check_stamps(path, text, s->size, sf, err);
    }
    free(text);
    if (st != SG_OK) {
        sg_bake_file_close(f);
        return st;
    }
    *out = f;
    return SG_OK;
}

sg_status sg_world_load(const char *path, const sg_scene_file *sf, const sg_world_desc *d, sg_world **out,
                        sg_error *err)
{
    if (!path || !sf || !out || sf->model_count == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "world file: no path or no models");
    sg_status st = SG_OK;
    sg_scene_store *store = NULL;
    sg_world *w = sg_calloc_array(1, sizeof *w);
    if (!w)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    sg_world__say(d, SG_WORLD_STAGE, "loading the world file %s", path);
    if ((st = open_world(path, sf, 1, &w->file, err)) != SG_OK)
        goto fail;
    const void *data;
    uint64_t items;
    if ((st = view(w->file, path, "WRLD", SG_BAKE_TYPE_U64, WORLD_WORDS, &items, &data, err)) != SG_OK)
        goto fail;
    uint64_t head[WORLD_WORDS];
    memcpy(head, data, sizeof head);
    if (items != 1 || head[0] != sf->model_count || head[1] != SG_WORLD_BUILDER_VERSION || head[2] || head[3]) {
        st = sg_error_set(err, SG_ERR_CORRUPT,
                          "%s: section WRLD: %" PRIu64 " models, builder %" PRIu64 " (the scene has %zu models, this "
                          "build is builder %u)",
                          path, head[0], head[1], sf->model_count, SG_WORLD_BUILDER_VERSION);
        goto fail;
    }
    size_t n = sf->model_count;
    w->scenes = sg_calloc_array(n, sizeof *w->scenes);
    w->materials = sg_calloc_array(n, sizeof *w->materials);
    w->model_bounds = sg_calloc_array(n, sizeof *w->model_bounds);
    store = sg_alloc_array(1, sizeof *store);
    if (!w->scenes || !w->materials || !w->model_bounds || !store) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for %zu models", path, n);
        goto fail;
    }
    w->count = n;
    w->bounds = sg_aabb_empty();
    if ((st = view(w->file, path, "MATL", SG_BAKE_TYPE_U32, MATERIAL_WORDS, &items, &data, err)) != SG_OK)
        goto fail;
    if (items != n) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: section MATL: %" PRIu64 " materials for %zu models", path, items, n);
        goto fail;
    }
    for (size_t i = 0; i < n; ++i)
        if ((st = decode_material((const uint32_t *)data + MATERIAL_WORDS * i, path, i, &w->materials[i], err)) !=
            SG_OK)
            goto fail;
    for (size_t i = 0; i < n; ++i) {
        if ((st = load_model(w->file, path, i, &sf->models[i].surface, store, &w->scenes[i], err)) != SG_OK)
            goto fail;
        sg_world__add_bounds(w, i);
    }
    sg_world__say(d, SG_WORLD_STAGE, "environment map%s%s", sf->env.path ? " " : "", sf->env.path ? sf->env.path : "");
    if ((st = sg_world__make_envmap(&sf->env, &w->env, err)) != SG_OK)
        goto fail;
    sg_world__note_envmap(d, &sf->env, w->env);
    sg_free(store);
    *out = w;
    return SG_OK;
fail:
    sg_free(store);
    sg_world_destroy(w);
    return st;
}

sg_status sg_world_file_replaceable(const char *path, sg_error *err)
{
    struct stat sb;
    if (stat(path, &sb) != 0)
        return errno == ENOENT ? SG_OK : sg_error_set(err, SG_ERR_IO, "%s: %s", path, strerror(errno));
    if (sg_bake_file_has_magic(path, SG_BAKE_KIND_WORLD))
        return SG_OK;
    return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: not a world file; it is left alone (give another path)", path);
}

int sg_world_file_fresh(const char *path, const sg_scene_file *sf, char *why, size_t why_size)
{
    sg_error e = {0};
    sg_bake_file *f = NULL;
    struct stat sb;
    if (stat(path, &sb) != 0) {
        if (why)
            snprintf(why, why_size, "%s: %s", path, strerror(errno));
        return 0;
    }
    if (open_world(path, sf, 0, &f, &e) != SG_OK) {
        if (why)
            snprintf(why, why_size, "%s", e.message);
        return 0;
    }
    sg_bake_file_close(f);
    return 1;
}
