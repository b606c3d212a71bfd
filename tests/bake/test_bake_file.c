/* test_bake_file.c — the .sgbake container (bake/bake_file.h).
 *
 *  1. bake_file::roundtrip          eight sections of every element type and
 *                                   sizes 0..4000 bytes read back bit-exact,
 *                                   with canonical 64-aligned offsets.
 *  2. bake_file::zero_sections      a file with no sections opens; a read of
 *                                   any tag is SG_ERR_CORRUPT "no section".
 *  3. bake_file::large_section      a 50 MB section streamed in odd pieces
 *                                   reads back bit-exact.
 *  4. bake_file::destroy_keeps_old  a writer destroyed without commit leaves
 *                                   no temporary file and the old file
 *                                   byte-identical.
 *  5. bake_file::commit_replaces    commit swaps the new file in whole.
 *  6. bake_file::every_truncation   every prefix of a small file is
 *                                   SG_ERR_CORRUPT naming the file (and the
 *                                   section whose payload is cut).
 *  7. bake_file::every_byte_damage  every single-byte change (3 masks) fails
 *                                   at open or at a section read: never wrong
 *                                   data.
 *  8. bake_file::wrong_hashes       another scene / other parameters:
 *                                   SG_ERR_INVALID_ARG with both hashes; 0
 *                                   skips the check.
 *  9. bake_file::newer_version      version 7 / unknown flags with valid CRC:
 *                                   SG_ERR_UNSUPPORTED.
 * 10. bake_file::not_a_bake_file    PNG header, text, empty file.
 * 11. bake_file::malformed_fixtures structurally bad files with valid CRCs
 *                                   (absurd sizes, overlap, gap, duplicate
 *                                   tag, ...): the exact fault in the message.
 * 12. bake_file::missing_folder     SG_ERR_IO naming the path; nothing left.
 * 13. bake_file::writer_misuse      bad tags, duplicates, full table, byte
 *                                   counts, state errors: SG_ERR_INVALID_ARG.
 * 14. bake_file::write_failure      a write failing mid-section (RLIMIT_FSIZE)
 *                                   is SG_ERR_IO; temporary removed, old file
 *                                   untouched, later calls refused.
 * 15. bake_file::read_misuse        wrong buffer size, bad tag.
 * 16. bake_file::kinds_and_views    a world-kind file has its own magic; each
 *                                   kind opened as the other is refused by
 *                                   name; views of a mapped file are the
 *                                   payloads, 64-aligned, CRC-checked (a
 *                                   damaged one refused); no view unmapped.
 */
#include "test_support.h"

#include <dirent.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <zlib.h>

#include "bake/bake_file.h"

#define SCENE_HASH 0x0123456789abcdefull
#define PARAM_HASH 0xfedcba9876543210ull

/* ---- helpers ----------------------------------------------------------- */

/* Whole file into a malloc'd buffer; *size its length. */
static unsigned char *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        fail_msg("cannot open %s", path);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc(n > 0 ? (size_t)n : 1);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *size = (size_t)n;
    return b;
}

static void spit(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        fail_msg("cannot create %s", path);
    assert_int_equal(fwrite(data, 1, size, f), size);
    assert_int_equal(fclose(f), 0);
}

/* Entries in the temp folder whose name contains ".tmp.". */
static int count_temp_files(void)
{
    DIR *d = opendir(sg_test_tmpdir());
    assert_non_null(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strstr(e->d_name, ".tmp."))
            n++;
    closedir(d);
    return n;
}

static void expect_ok(sg_status st, const sg_error *err, const char *what)
{
    if (st != SG_OK)
        fail_msg("%s: %s: %s", what, sg_status_name(st), err->message);
}

/* Opening path must fail with want and a message naming the file and
 * containing needle; *out must stay untouched. */
static void open_fails(const char *path, uint64_t sh, uint64_t ph, sg_status want, const char *needle,
                       const char *what)
{
    sg_bake_file *f = (sg_bake_file *)&f; /* sentinel */
    sg_error err = {0};
    sg_status st = sg_bake_file_open(path, sh, ph, &f, &err);
    if (st != want)
        fail_msg("%s: got %s (%s), want %s", what, sg_status_name(st), err.message, sg_status_name(want));
    if (!strstr(err.message, path))
        fail_msg("%s: message does not name the file: \"%s\"", what, err.message);
    if (needle && !strstr(err.message, needle))
        fail_msg("%s: message lacks \"%s\": \"%s\"", what, needle, err.message);
    if (f != (sg_bake_file *)&f)
        fail_msg("%s: *out was written on failure", what);
}

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static void set32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}
static void set64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

/* Recomputes the header and table CRCs of a v1 image after a patch, so that
 * the structural checks behind them are what the test reaches. */
static void fix_crcs(unsigned char *b)
{
    set32(b + 44, (uint32_t)crc32(0, b, 44));
    uint32_t cap = le32(b + 36);
    if (cap > 0 && cap <= SG_BAKE_MAX_SECTIONS) {
        size_t tsize = (size_t)SG_BAKE_ENTRY_SIZE * cap;
        set32(b + 48 + tsize, (uint32_t)crc32(0, b + 48, (uInt)tsize));
    }
}

/* The small fixture: capacity 5 (one entry unused), sections PNTS f32x6,
 * EMPT u8x0, IDXS u32x5, META bytes. T = 52 + 200 = 252; PNTS at 256 (24 bytes), EMPT and IDXS at
 * 320 (0 and 20 bytes), META at 384 (7 bytes); 391 bytes in all. */
static const float SMALL_PNTS[6] = {0.0f, 1.5f, -2.25f, 3e8f, -0.0f, 1e-30f};
static const uint32_t SMALL_IDXS[5] = {0, 1, 0xffffffffu, 42, 7};
static const char SMALL_META[] = "{\"k\":1}";

static const char *write_small(const char *name, uint32_t flags)
{
    const char *path = sg_test_tmp_path(name);
    sg_bake_writer *w = NULL;
    sg_error err = {0};
    sg_bake_writer_desc d = {
        .path = path, .scene_hash = SCENE_HASH, .param_hash = PARAM_HASH, .flags = flags, .max_sections = 5};
    expect_ok(sg_bake_writer_create(&d, &w, &err), &err, "create");
    expect_ok(sg_bake_writer_add_section(w, "PNTS", SG_BAKE_TYPE_F32, 6, SMALL_PNTS, &err), &err, "PNTS");
    expect_ok(sg_bake_writer_add_section(w, "EMPT", SG_BAKE_TYPE_U8, 0, NULL, &err), &err, "EMPT");
    expect_ok(sg_bake_writer_add_section(w, "IDXS", SG_BAKE_TYPE_U32, 5, SMALL_IDXS, &err), &err, "IDXS");
    expect_ok(sg_bake_writer_add_section(w, "META", SG_BAKE_TYPE_BYTES, 7, SMALL_META, &err), &err, "META");
    expect_ok(sg_bake_writer_commit(w, &err), &err, "commit");
    sg_bake_writer_destroy(w);
    return path;
}

/* Opens path and reads every section; returns the first failing status
 * (SG_OK if all passed) with its message in err. *opened tells whether the
 * failure, if any, came after open. */
static sg_status open_and_read_all(const char *path, sg_error *err, int *opened)
{
    sg_bake_file *f = NULL;
    *opened = 0;
    sg_status st = sg_bake_file_open(path, SCENE_HASH, PARAM_HASH, &f, err);
    if (st != SG_OK)
        return st;
    *opened = 1;
    for (uint32_t i = 0; st == SG_OK && i < sg_bake_file_info(f)->section_count; i++) {
        const sg_bake_section *s = sg_bake_file_section(f, i);
        void *buf = malloc(s->size ? (size_t)s->size : 1);
        assert_non_null(buf);
        st = sg_bake_file_read(f, s->tag, buf, s->size, err);
        free(buf);
    }
    sg_bake_file_close(f);
    return st;
}

/* ---- 1. round trip --------------------------------------------------------- */

static void test_bake_file_roundtrip(void **state)
{
    (void)state;
    enum { N = 1000 };
    float *pts = malloc(N * sizeof *pts);
    uint8_t u8[37];
    uint16_t u16[501], f16[3];
    uint32_t u32[N];
    uint64_t u64[17];
    double f64[9];
    uint64_t rng = 99;
    for (int i = 0; i < N; i++) {
        pts[i] = sg_test_rand01(&rng) * 100.0f - 50.0f;
        u32[i] = (uint32_t)i * 2654435761u;
    }
    for (int i = 0; i < 37; i++)
        u8[i] = (uint8_t)(i * 7);
    for (int i = 0; i < 501; i++)
        u16[i] = (uint16_t)(i * 131);
    f16[0] = 0x3c00; f16[1] = 0xc000; f16[2] = 0x7bff;
    for (int i = 0; i < 17; i++)
        u64[i] = 0x8000000000000001ull * (uint64_t)(i + 1);
    for (int i = 0; i < 9; i++)
        f64[i] = 1.0 / (i + 1);
    const char meta[] = "{\"samples\": 256, \"envmap\": \"studio.hdr\"}";

    struct {
        const char *tag;
        sg_bake_type type;
        uint64_t count;
        const void *data;
    } secs[] = {
        {"PNTS", SG_BAKE_TYPE_F32, N, pts},    {"U8__", SG_BAKE_TYPE_U8, 37, u8},
        {"EMPT", SG_BAKE_TYPE_F32, 0, NULL},   {"U16_", SG_BAKE_TYPE_U16, 501, u16},
        {"IRRD", SG_BAKE_TYPE_U32, N, u32},    {"F16_", SG_BAKE_TYPE_F16, 3, f16},
        {"U64_", SG_BAKE_TYPE_U64, 17, u64},   {"F64_", SG_BAKE_TYPE_F64, 9, f64},
        {"META", SG_BAKE_TYPE_BYTES, sizeof meta - 1, meta},
    };
    const int nsec = (int)(sizeof secs / sizeof secs[0]);

    const char *path = sg_test_tmp_path("roundtrip.sgbake");
    sg_error err = {0};
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc d = {.path = path, .scene_hash = SCENE_HASH, .param_hash = PARAM_HASH};
    expect_ok(sg_bake_writer_create(&d, &w, &err), &err, "create");
    for (int i = 0; i < nsec; i++)
        expect_ok(sg_bake_writer_add_section(w, secs[i].tag, secs[i].type, secs[i].count, secs[i].data, &err),
                  &err, secs[i].tag);
    expect_ok(sg_bake_writer_commit(w, &err), &err, "commit");
    sg_bake_writer_destroy(w);
    assert_int_equal(count_temp_files(), 0);

    sg_bake_file *f = NULL;
    expect_ok(sg_bake_file_open(path, SCENE_HASH, PARAM_HASH, &f, &err), &err, "open");
    const sg_bake_info *info = sg_bake_file_info(f);
    assert_int_equal(info->version, SG_BAKE_FORMAT_VERSION);
    assert_int_equal(info->flags, 0);
    assert_true(info->scene_hash == SCENE_HASH && info->param_hash == PARAM_HASH);
    assert_int_equal(info->section_count, nsec);
    for (int i = 0; i < nsec; i++) {
        const sg_bake_section *s = sg_bake_file_section(f, (uint32_t)i);
        assert_non_null(s);
        size_t esize = sg_bake_type_size(secs[i].type);
        if (strcmp(s->tag, secs[i].tag) != 0 || s->type != secs[i].type || s->count != secs[i].count ||
            s->size != secs[i].count * esize || s->offset % 64 != 0)
            fail_msg("section %d: got %s type %d count %llu size %llu offset %llu; want %s type %d count %llu",
                     i, s->tag, (int)s->type, (unsigned long long)s->count, (unsigned long long)s->size,
                     (unsigned long long)s->offset, secs[i].tag, (int)secs[i].type,
                     (unsigned long long)secs[i].count);
        assert_ptr_equal(sg_bake_file_find(f, secs[i].tag), s);
        unsigned char *buf = malloc(s->size + 1);
        expect_ok(sg_bake_file_read(f, secs[i].tag, buf, s->size, &err), &err, secs[i].tag);
        if (s->size && memcmp(buf, secs[i].data, (size_t)s->size) != 0)
            fail_msg("section %s: payload differs after the round trip", secs[i].tag);
        free(buf);
    }
    assert_null(sg_bake_file_section(f, (uint32_t)nsec));
    assert_null(sg_bake_file_find(f, "NONE"));
    sg_bake_file_close(f);
    sg_bake_file_close(NULL);
    sg_bake_writer_destroy(NULL);
    free(pts);
}

/* ---- 2. zero sections -------------------------------------------------- */

static void test_bake_file_zero_sections(void **state)
{
    (void)state;
    const char *path = sg_test_tmp_path("empty.sgbake");
    sg_error err = {0};
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc d = {.path = path, .scene_hash = 5, .param_hash = 6, .max_sections = 1};
    expect_ok(sg_bake_writer_create(&d, &w, &err), &err, "create");
    expect_ok(sg_bake_writer_commit(w, &err), &err, "commit");
    sg_bake_writer_destroy(w);

    struct stat sb;
    assert_int_equal(stat(path, &sb), 0);
    assert_int_equal(sb.st_size, 48 + 40 + 4); /* header, one entry, table CRC */

    sg_bake_file *f = NULL;
    expect_ok(sg_bake_file_open(path, 5, 6, &f, &err), &err, "open");
    assert_int_equal(sg_bake_file_info(f)->section_count, 0);
    assert_null(sg_bake_file_find(f, "PNTS"));
    char c;
    sg_status st = sg_bake_file_read(f, "PNTS", &c, 1, &err);
    assert_int_equal(st, SG_ERR_CORRUPT);
    if (!strstr(err.message, "no section PNTS"))
        fail_msg("message: %s", err.message);
    sg_bake_file_close(f);
}

/* ---- 3. 50 MB section ------------------------------------------------------ */

static void test_bake_file_large_section(void **state)
{
    (void)state;
    const size_t n = 50u * 1000u * 1000u; /* bytes */
    unsigned char *src = malloc(n), *dst = malloc(n);
    assert_non_null(src);
    assert_non_null(dst);
    uint32_t x = 1;
    for (size_t i = 0; i < n; i++) {
        x = x * 1664525u + 1013904223u;
        src[i] = (unsigned char)(x >> 24);
    }
    const char *path = sg_test_tmp_path("large.sgbake");
    sg_error err = {0};
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc d = {.path = path, .scene_hash = SCENE_HASH};
    expect_ok(sg_bake_writer_create(&d, &w, &err), &err, "create");
    expect_ok(sg_bake_writer_add_section(w, "HEAD", SG_BAKE_TYPE_U8, 3, "abc", &err), &err, "HEAD");
    /* n/4 f32 elements, appended in pieces that split elements. */
    expect_ok(sg_bake_writer_begin_section(w, "IRRD", SG_BAKE_TYPE_F32, n / 4, &err), &err, "begin");
    for (size_t at = 0; at < n;) {
        size_t piece = n - at < 1000003 ? n - at : 1000003;
        expect_ok(sg_bake_writer_append(w, src + at, piece, &err), &err, "append");
        at += piece;
    }
    expect_ok(sg_bake_writer_end_section(w, &err), &err, "end");
    expect_ok(sg_bake_writer_commit(w, &err), &err, "commit");
    sg_bake_writer_destroy(w);

    sg_bake_file *f = NULL;
    expect_ok(sg_bake_file_open(path, SCENE_HASH, 0, &f, &err), &err, "open");
    const sg_bake_section *s = sg_bake_file_find(f, "IRRD");
    assert_non_null(s);
    assert_int_equal(s->size, n);
    assert_int_equal(s->count, n / 4);
    expect_ok(sg_bake_file_read(f, "IRRD", dst, n, &err), &err, "read");
    for (size_t i = 0; i < n; i++)
        if (src[i] != dst[i])
            fail_msg("byte %zu: got %d, want %d", i, dst[i], src[i]);
    sg_bake_file_close(f);
    remove(path);
    free(src);
    free(dst);
}

/* ---- 4, 5. atomicity ------------------------------------------------------- */

static void test_bake_file_destroy_keeps_old(void **state)
{
    (void)state;
    const char *path = sg_test_tmp_path("keep.sgbake");
    const char old[] = "the previous bake, whatever its bytes";
    spit(path, old, sizeof old);

    sg_error err = {0};
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc d = {.path = path, .scene_hash = 1};
    expect_ok(sg_bake_writer_create(&d, &w, &err), &err, "create");
    assert_int_equal(count_temp_files(), 1); /* the writer is working */
    float v[256] = {0};
    expect_ok(sg_bake_writer_add_section(w, "PNTS", SG_BAKE_TYPE_F32, 256, v, &err), &err, "PNTS");
    expect_ok(sg_bake_writer_begin_section(w, "IRRD", SG_BAKE_TYPE_F32, 256, &err), &err, "begin");
    expect_ok(sg_bake_writer_append(w, v, 100, &err), &err, "append");
    sg_bake_writer_destroy(w); /* mid-section, never committed */

    assert_int_equal(count_temp_files(), 0);
    size_t n;
    unsigned char *now = slurp(path, &n);
    if (n != sizeof old || memcmp(now, old, n) != 0)
        fail_msg("%s changed: %zu bytes, want %zu", path, n, sizeof old);
    free(now);
}

static void test_bake_file_commit_replaces(void **state)
{
    (void)state;
    const char *path = sg_test_tmp_path("replace.sgbake");
    spit(path, "old", 3);
    chmod(path, 0640);
    write_small("replace.sgbake", 0);
    assert_int_equal(count_temp_files(), 0);
    struct stat sb;
    assert_int_equal(stat(path, &sb), 0);
    assert_int_equal(sb.st_size, 391);
    assert_int_equal(sb.st_mode & 0777, 0640); /* the replaced file's mode */
    sg_error err = {0};
    int opened;
    expect_ok(open_and_read_all(path, &err, &opened), &err, "replaced file");

    /* A new file (nothing replaced) gets 0644, not mkstemp's 0600. */
    const char *fresh = write_small("fresh.sgbake", 0);
    assert_int_equal(stat(fresh, &sb), 0);
    assert_int_equal(sb.st_mode & 0777, 0644);
}

/* ---- 6, 7. truncation and damage -------------------------------------------- */

static void test_bake_file_every_truncation(void **state)
{
    (void)state;
    const char *path = write_small("trunc_src.sgbake", 0);
    size_t n;
    unsigned char *full = slurp(path, &n);
    assert_int_equal(n, 391);
    sg_error err = {0};
    sg_bake_file *f = NULL;
    expect_ok(sg_bake_file_open(path, SCENE_HASH, PARAM_HASH, &f, &err), &err, "open");

    const char *cut = sg_test_tmp_path("trunc.sgbake");
    char what[64];
    for (size_t len = 0; len < n; len++) {
        spit(cut, full, len);
        snprintf(what, sizeof what, "prefix of %zu of %zu bytes", len, n);
        /* Which payload the cut falls in (for len >= T = 252). */
        const sg_bake_section *hit = NULL;
        for (uint32_t i = 0; !hit && i < sg_bake_file_info(f)->section_count; i++) {
            const sg_bake_section *s = sg_bake_file_section(f, i);
            if (s->offset + s->size > len)
                hit = s;
        }
        char needle[64];
        if (len == 0)
            snprintf(needle, sizeof needle, "not a splatgi bake file");
        else if (len >= 252 && hit)
            snprintf(needle, sizeof needle, "section %s: truncated", hit->tag);
        else
            snprintf(needle, sizeof needle, "truncated");
        open_fails(cut, SCENE_HASH, PARAM_HASH, SG_ERR_CORRUPT, needle, what);
    }
    sg_bake_file_close(f);
    free(full);
}

static void test_bake_file_every_byte_damage(void **state)
{
    (void)state;
    const char *path = write_small("damage_src.sgbake", 0);
    size_t n;
    unsigned char *full = slurp(path, &n);
    unsigned char *bad = malloc(n);
    const char *dpath = sg_test_tmp_path("damage.sgbake");
    static const unsigned char masks[3] = {0x01, 0x80, 0xff};
    int at_open = 0, at_read = 0;
    for (size_t off = 0; off < n; off++)
        for (int m = 0; m < 3; m++) {
            memcpy(bad, full, n);
            bad[off] ^= masks[m];
            spit(dpath, bad, n);
            sg_error err = {0};
            int opened;
            sg_status st = open_and_read_all(dpath, &err, &opened);
            if (st != SG_ERR_CORRUPT)
                fail_msg("byte %zu ^ 0x%02x: got %s (%s), want SG_ERR_CORRUPT at open or read", off, masks[m],
                         sg_status_name(st), err.message);
            if (!strstr(err.message, dpath))
                fail_msg("byte %zu ^ 0x%02x: message does not name the file: %s", off, masks[m], err.message);
            /* Payload bytes can only be caught by their section CRC. */
            if (opened && !strstr(err.message, "checksum mismatch"))
                fail_msg("byte %zu ^ 0x%02x: read failed without a checksum error: %s", off, masks[m],
                         err.message);
            at_open += !opened;
            at_read += opened;
        }
    /* Payload bytes: PNTS 24, IDXS 20, META 7 -> 51 offsets x 3 masks. */
    if (at_read != 51 * 3)
        fail_msg("%d damages found at read, want %d (open: %d)", at_read, 51 * 3, at_open);
    free(bad);
    free(full);
}

/* ---- 8, 9, 10. identity, version, magic ------------------------------------ */

static void test_bake_file_wrong_hashes(void **state)
{
    (void)state;
    const char *path = write_small("hash.sgbake", 0);
    open_fails(path, 0x4567456745674567ull, PARAM_HASH, SG_ERR_INVALID_ARG,
               "made for another scene (scene hash 0123456789abcdef, this scene 4567456745674567)",
               "wrong scene hash");
    open_fails(path, SCENE_HASH, 0x1111ull, SG_ERR_INVALID_ARG,
               "made with other bake parameters (parameter hash fedcba9876543210, these parameters "
               "0000000000001111)",
               "wrong parameter hash");
    sg_error err = {0};
    sg_bake_file *f = NULL;
    expect_ok(sg_bake_file_open(path, 0, 0, &f, &err), &err, "hashes unchecked");
    sg_bake_file_close(f);
    expect_ok(sg_bake_file_open(path, SCENE_HASH, 0, &f, &err), &err, "parameter hash unchecked");
    sg_bake_file_close(f);
}

static void test_bake_file_newer_version(void **state)
{
    (void)state;
    const char *path = write_small("version_src.sgbake", SG_BAKE_FLAG_CHECKPOINT);
    sg_error err = {0};
    sg_bake_file *f = NULL;
    expect_ok(sg_bake_file_open(path, SCENE_HASH, PARAM_HASH, &f, &err), &err, "checkpoint");
    assert_int_equal(sg_bake_file_info(f)->flags, SG_BAKE_FLAG_CHECKPOINT);
    sg_bake_file_close(f);

    size_t n;
    unsigned char *b = slurp(path, &n);
    set32(b + 8, 7);
    fix_crcs(b);
    const char *p = sg_test_tmp_path("version7.sgbake");
    spit(p, b, n);
    open_fails(p, SCENE_HASH, PARAM_HASH, SG_ERR_UNSUPPORTED,
               "format version 7 is newer than this build reads (1)", "version 7");
    /* The same change without a matching CRC is damage, not a new version. */
    unsigned char *c = slurp(path, &n);
    set32(c + 8, 7);
    spit(p, c, n);
    open_fails(p, SCENE_HASH, PARAM_HASH, SG_ERR_CORRUPT, "header checksum mismatch", "version 7, stale CRC");
    set32(b + 8, 0);
    fix_crcs(b);
    spit(p, b, n);
    open_fails(p, SCENE_HASH, PARAM_HASH, SG_ERR_CORRUPT, "format version 0 is invalid", "version 0");
    set32(b + 8, 1);
    set32(b + 12, 0x5);
    fix_crcs(b);
    spit(p, b, n);
    open_fails(p, SCENE_HASH, PARAM_HASH, SG_ERR_UNSUPPORTED, "flags 0x00000005", "unknown flags");
    free(b);
    free(c);
}

static void test_bake_file_not_a_bake_file(void **state)
{
    (void)state;
    static const unsigned char png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13,
                                        'I',  'H', 'D', 'R', 0,    0,    0,    1,    0, 0, 0, 1};
    spit(sg_test_tmp_path("image.sgbake"), png, sizeof png);
    open_fails(sg_test_tmp_path("image.sgbake"), 0, 0, SG_ERR_CORRUPT, "not a splatgi bake file", "PNG header");
    const char text[] = "ply\nformat ascii 1.0\nelement vertex 3\nend_header\n";
    spit(sg_test_tmp_path("text.sgbake"), text, sizeof text - 1);
    open_fails(sg_test_tmp_path("text.sgbake"), 0, 0, SG_ERR_CORRUPT, "not a splatgi bake file", "PLY text");
    spit(sg_test_tmp_path("zero.sgbake"), "", 0);
    open_fails(sg_test_tmp_path("zero.sgbake"), 0, 0, SG_ERR_CORRUPT, "not a splatgi bake file (it is empty)",
               "empty file");
    open_fails(sg_test_tmp_path("absent.sgbake"), 0, 0, SG_ERR_IO, "cannot open", "absent file");
    open_fails(sg_test_tmpdir(), 0, 0, SG_ERR_IO, "not a regular file", "a folder");
}

/* ---- 11. malformed fixtures with valid CRCs -------------------------------- */

/* Entry i of the small fixture starts at 48 + 40 i. */
#define ENTRY(b, i) ((b) + 48 + 40 * (i))

static void test_bake_file_malformed_fixtures(void **state)
{
    (void)state;
    const char *src = write_small("malformed_src.sgbake", 0);
    size_t n;
    unsigned char *orig = slurp(src, &n);
    unsigned char *b = malloc(n + 64);
    const char *p = sg_test_tmp_path("malformed.sgbake");
    struct {
        const char *name;
        int field;       /* what to patch, see the switch */
        uint64_t value;
        const char *needle;
    } cases[] = {
        {"absurd size", 1, 1ull << 62, "section PNTS: 24 bytes do not hold 4611686018427387904 elements"},
        {"absurd size+count", 2, 1ull << 62, "section PNTS: truncated: its 4611686018427387904 bytes at byte 256"},
        {"size wraps 64 bits", 2, UINT64_MAX - 3, "section PNTS: truncated"},
        {"count*size wraps", 3, (1ull << 62) + 6, "do not hold"},
        {"capacity 2^32-1", 4, 0xffffffffu, "section table capacity 4294967295 outside 1..4096"},
        {"capacity 0", 4, 0, "section table capacity 0 outside 1..4096"},
        {"count > capacity", 5, 6, "section count 6 exceeds the table capacity 5"},
        {"unknown type", 6, 99, "section PNTS: unknown element type 99"},
        {"bad tag", 7, 0x00535450, "section 0: tag bytes 50 54 53 00"},
        {"duplicate tag", 8, 0, "section PNTS: tag appears twice (sections 0 and 2)"},
        {"overlap", 9, 256, "section EMPT: offset 256 overlaps section PNTS (which ends at byte 280)"},
        {"overlaps table", 10, 192, "section PNTS: offset 192 overlaps the section table (which ends at byte 252)"},
        {"gap", 9, 384, "section EMPT: starts at byte 384, expected 320"},
        {"unaligned", 10, 260, "section PNTS: offset 260 is not a multiple of 64"},
        {"entry reserved", 11, 1, "section PNTS: reserved field is 1"},
        {"header reserved", 12, 1, "header reserved field is 1"},
        {"unused entry", 13, 1, "unused section table entry 4 is not zero"},
        {"padding", 14, 0, "padding byte 300 before section EMPT is 0x2a"},
        {"trailing bytes", 15, 0, "5 unexpected bytes after the last section (which ends at byte 391)"},
        {"table crc", 16, 0, "section table checksum mismatch"},
        {"payload crc", 17, 0, "section IDXS: checksum mismatch"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        memcpy(b, orig, n);
        size_t len = n;
        int fix = 1;
        switch (cases[k].field) {
        case 1: set64(ENTRY(b, 0) + 8, cases[k].value); break;  /* count only */
        case 2:                                                  /* count and size agree */
            set64(ENTRY(b, 0) + 8, cases[k].value / 4);
            set64(ENTRY(b, 0) + 24, cases[k].value / 4 * 4);
            break;
        case 3: set64(ENTRY(b, 0) + 8, cases[k].value); set64(ENTRY(b, 0) + 24, 24); break;
        case 4: set32(b + 36, (uint32_t)cases[k].value); break;
        case 5: set32(b + 32, (uint32_t)cases[k].value); break;
        case 6: set32(ENTRY(b, 0) + 4, (uint32_t)cases[k].value); break;
        case 7: memcpy(ENTRY(b, 0), "PTS\0", 4); break;
        case 8: memcpy(ENTRY(b, 2), "PNTS", 4); break;
        case 9: set64(ENTRY(b, 1) + 16, cases[k].value); break;
        case 10: set64(ENTRY(b, 0) + 16, cases[k].value); break;
        case 11: set32(ENTRY(b, 0) + 36, (uint32_t)cases[k].value); break;
        case 12: set32(b + 40, (uint32_t)cases[k].value); break;
        case 13: ENTRY(b, 4)[39] = 1; break;
        case 14: b[300] = 0x2a; fix = 0; break;
        case 15: memset(b + n, 0, 5); len = n + 5; fix = 0; break;
        case 16: set32(ENTRY(b, 0) + 32, 0x12345678); fix = 0; break; /* entry CRC changed, table CRC stale */
        case 17: b[330] ^= 0x10; fix = 0; break;
        }
        if (fix)
            fix_crcs(b);
        spit(p, b, len);
        sg_error err = {0};
        int opened;
        sg_status st = open_and_read_all(p, &err, &opened);
        if (st != SG_ERR_CORRUPT || !strstr(err.message, cases[k].needle) || !strstr(err.message, p))
            fail_msg("%s: got %s \"%s\", want SG_ERR_CORRUPT with \"%s\"", cases[k].name, sg_status_name(st),
                     err.message, cases[k].needle);
        if (opened != (cases[k].field == 17))
            fail_msg("%s: failed %s, want %s", cases[k].name, opened ? "at read" : "at open",
                     cases[k].field == 17 ? "at read" : "at open");
    }
    free(b);
    free(orig);
}

/* ---- 12, 13, 14, 15. writer and reader errors ------------------------------- */

static void test_bake_file_missing_folder(void **state)
{
    (void)state;
    const char *path = sg_test_tmp_path("no_such_folder/bunny.sgbake");
    sg_error err = {0};
    sg_bake_writer *w = (sg_bake_writer *)&w;
    sg_bake_writer_desc d = {.path = path};
    sg_status st = sg_bake_writer_create(&d, &w, &err);
    if (st != SG_ERR_IO || !strstr(err.message, path) || !strstr(err.message, "No such file"))
        fail_msg("got %s \"%s\", want SG_ERR_IO naming %s", sg_status_name(st), err.message, path);
    assert_ptr_equal(w, (sg_bake_writer *)&w);
    struct stat sb;
    assert_int_not_equal(stat(sg_test_tmp_path("no_such_folder"), &sb), 0);
    assert_int_equal(count_temp_files(), 0);

    d.path = "";
    assert_int_equal(sg_bake_writer_create(&d, &w, &err), SG_ERR_INVALID_ARG);
}

static void expect_status(sg_status st, const sg_error *err, sg_status want, const char *needle,
                          const char *what)
{
    if (st != want || (needle && !strstr(err->message, needle)))
        fail_msg("%s: got %s \"%s\", want %s with \"%s\"", what, sg_status_name(st), err->message,
                 sg_status_name(want), needle ? needle : "");
}

static void test_bake_file_writer_misuse(void **state)
{
    (void)state;
    const char *path = sg_test_tmp_path("misuse.sgbake");
    sg_error err = {0};
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc d = {.path = path, .max_sections = 2};
    expect_ok(sg_bake_writer_create(&d, &w, &err), &err, "create");
    uint32_t v[4] = {1, 2, 3, 4};
    const sg_status IA = SG_ERR_INVALID_ARG;
    expect_status(sg_bake_writer_add_section(w, "PNT", SG_BAKE_TYPE_U32, 4, v, &err), &err, IA, "\"PNT\"",
                  "3-char tag");
    expect_status(sg_bake_writer_add_section(w, "PNTSX", SG_BAKE_TYPE_U32, 4, v, &err), &err, IA, "PNTSX",
                  "5-char tag");
    expect_status(sg_bake_writer_add_section(w, "PN S", SG_BAKE_TYPE_U32, 4, v, &err), &err, IA, "PN S",
                  "space in tag");
    expect_status(sg_bake_writer_add_section(w, NULL, SG_BAKE_TYPE_U32, 4, v, &err), &err, IA, "(null)",
                  "NULL tag");
    expect_status(sg_bake_writer_add_section(w, "PNTS", (sg_bake_type)0, 4, v, &err), &err, IA,
                  "unknown element type 0", "type 0");
    expect_status(sg_bake_writer_add_section(w, "PNTS", SG_BAKE_TYPE_U32, 1ull << 62, v, &err), &err, IA,
                  "overflow 64 bits", "count overflow");
    expect_status(sg_bake_writer_add_section(w, "PNTS", SG_BAKE_TYPE_U32, 4, NULL, &err), &err, IA,
                  "data is NULL", "NULL data");
    expect_ok(sg_bake_writer_add_section(w, "PNTS", SG_BAKE_TYPE_U32, 4, v, &err), &err, "PNTS");
    expect_status(sg_bake_writer_add_section(w, "PNTS", SG_BAKE_TYPE_U32, 4, v, &err), &err, IA,
                  "section PNTS is already in the file", "duplicate");
    expect_status(sg_bake_writer_append(w, v, 4, &err), &err, IA, "without an open section", "stray append");
    expect_status(sg_bake_writer_end_section(w, &err), &err, IA, "without an open section", "stray end");
    expect_ok(sg_bake_writer_begin_section(w, "IRRD", SG_BAKE_TYPE_U32, 4, &err), &err, "begin");
    expect_status(sg_bake_writer_begin_section(w, "DIRS", SG_BAKE_TYPE_U32, 4, &err), &err, IA,
                  "section IRRD is still open", "nested begin");
    expect_ok(sg_bake_writer_append(w, v, 10, &err), &err, "append 10");
    expect_status(sg_bake_writer_append(w, v, 7, &err), &err, IA, "appending 7 bytes after 10 exceeds its 16",
                  "append past the end");
    expect_status(sg_bake_writer_end_section(w, &err), &err, IA, "10 of its 16 bytes", "short end");
    expect_status(sg_bake_writer_commit(w, &err), &err, IA, "still open at commit", "commit mid-section");
    expect_ok(sg_bake_writer_append(w, (const char *)v + 10, 6, &err), &err, "append 6");
    expect_ok(sg_bake_writer_end_section(w, &err), &err, "end");
    expect_status(sg_bake_writer_add_section(w, "DIRS", SG_BAKE_TYPE_U32, 4, v, &err), &err, IA,
                  "section table full (2 sections reserved", "full table");
    expect_ok(sg_bake_writer_commit(w, &err), &err, "commit");
    expect_status(sg_bake_writer_commit(w, &err), &err, IA, "already committed", "second commit");
    expect_status(sg_bake_writer_add_section(w, "DIRS", SG_BAKE_TYPE_U32, 4, v, &err), &err, IA,
                  "already committed", "add after commit");
    sg_bake_writer_destroy(w); /* after commit: the file stays */
    assert_int_equal(count_temp_files(), 0);

    sg_bake_file *f = NULL;
    expect_ok(sg_bake_file_open(path, 0, 0, &f, &err), &err, "open");
    uint32_t r[4] = {0};
    expect_ok(sg_bake_file_read(f, "IRRD", r, sizeof r, &err), &err, "IRRD");
    assert_memory_equal(r, v, sizeof v);
    sg_bake_file_close(f);

    d.max_sections = SG_BAKE_MAX_SECTIONS + 1;
    expect_status(sg_bake_writer_create(&d, &w, &err), &err, IA, "max_sections 4097", "capacity");
    d.max_sections = 0;
    d.flags = 0x80;
    expect_status(sg_bake_writer_create(&d, &w, &err), &err, IA, "unknown bake flags 0x80", "flags");
}

static void test_bake_file_write_failure(void **state)
{
    (void)state;
    const char *path = sg_test_tmp_path("efbig.sgbake");
    const char old[] = "previous complete bake";
    spit(path, old, sizeof old);

    struct rlimit saved;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &saved), 0);
    void (*prev)(int) = signal(SIGXFSZ, SIG_IGN); /* EFBIG instead of a signal */
    struct rlimit lim = saved;
    lim.rlim_cur = 64 * 1024;
    if (saved.rlim_cur != RLIM_INFINITY && saved.rlim_cur < lim.rlim_cur)
        lim.rlim_cur = saved.rlim_cur;
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &lim), 0);

    sg_error err = {0};
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc d = {.path = path};
    sg_status st = sg_bake_writer_create(&d, &w, &err);
    static unsigned char big[256 * 1024];
    sg_status st2 = SG_OK, st3 = SG_OK;
    if (st == SG_OK) {
        st2 = sg_bake_writer_add_section(w, "IRRD", SG_BAKE_TYPE_U8, sizeof big, big, &err);
        sg_error err3 = {0};
        st3 = sg_bake_writer_commit(w, &err3);
    }
    setrlimit(RLIMIT_FSIZE, &saved); /* restore before any assertion can return */
    signal(SIGXFSZ, prev);

    expect_ok(st, &err, "create");
    if (st2 != SG_ERR_IO || !strstr(err.message, path) || !strstr(err.message, "now removed"))
        fail_msg("oversized write: got %s \"%s\", want SG_ERR_IO naming %s", sg_status_name(st2), err.message,
                 path);
    assert_int_equal(st3, SG_ERR_IO); /* refused after the failure */
    assert_int_equal(count_temp_files(), 0);
    sg_bake_writer_destroy(w);
    size_t n;
    unsigned char *now = slurp(path, &n);
    if (n != sizeof old || memcmp(now, old, n) != 0)
        fail_msg("%s changed after a failed write", path);
    free(now);
}

static void test_bake_file_read_misuse(void **state)
{
    (void)state;
    const char *path = write_small("readmisuse.sgbake", 0);
    sg_error err = {0};
    sg_bake_file *f = NULL;
    expect_ok(sg_bake_file_open(path, SCENE_HASH, PARAM_HASH, &f, &err), &err, "open");
    float buf[8];
    expect_status(sg_bake_file_read(f, "PNTS", buf, sizeof buf, &err), &err, SG_ERR_INVALID_ARG,
                  "section PNTS: buffer of 32 bytes for a section of 24 bytes", "wrong size");
    expect_status(sg_bake_file_read(f, "PN", buf, 24, &err), &err, SG_ERR_INVALID_ARG, "\"PN\"", "bad tag");
    expect_status(sg_bake_file_read(f, "NONE", buf, 24, &err), &err, SG_ERR_CORRUPT, "no section NONE",
                  "missing");
    expect_ok(sg_bake_file_read(f, "EMPT", NULL, 0, &err), &err, "empty section into NULL");
    expect_ok(sg_bake_file_read(f, "PNTS", buf, 24, &err), &err, "PNTS");
    assert_memory_equal(buf, SMALL_PNTS, sizeof SMALL_PNTS);
    assert_null(sg_bake_file_find(f, "PNTSX"));
    sg_bake_file_close(f);
}

static void test_bake_file_kinds_and_views(void **state)
{
    (void)state;
    const char *path = sg_test_tmp_path("kind.sgworld");
    sg_error err = {0};
    sg_bake_writer *w = NULL;
    sg_bake_writer_desc wd = {.path = path, .scene_hash = SCENE_HASH, .param_hash = PARAM_HASH,
                              .kind = SG_BAKE_KIND_WORLD};
    const float pnts[6] = {1, 2, 3, 4, 5, 6};
    const uint32_t ids[3] = {7, 8, 9};
    expect_ok(sg_bake_writer_create(&wd, &w, &err), &err, "create");
    expect_ok(sg_bake_writer_add_section(w, "PNTS", SG_BAKE_TYPE_F32, 6, pnts, &err), &err, "PNTS");
    expect_ok(sg_bake_writer_add_section(w, "IDS_", SG_BAKE_TYPE_U32, 3, ids, &err), &err, "IDS_");
    expect_ok(sg_bake_writer_commit(w, &err), &err, "commit");
    sg_bake_writer_destroy(w);
    size_t n;
    unsigned char *bytes = slurp(path, &n);
    assert_memory_equal(bytes, "SGWRLD\0\n", 8);

    /* as a bake: refused by name; as a world: opens */
    sg_bake_file *f = NULL;
    open_fails(path, SCENE_HASH, PARAM_HASH, SG_ERR_INVALID_ARG, "a splatgi world file, not a bake file",
               "world as bake");
    sg_bake_open_desc od = {.kind = SG_BAKE_KIND_WORLD, .scene_hash = SCENE_HASH, .param_hash = PARAM_HASH};
    expect_ok(sg_bake_file_open_desc(path, &od, &f, &err), &err, "open world");
    assert_int_equal(sg_bake_file_info(f)->kind, SG_BAKE_KIND_WORLD);
    const void *v = NULL;
    expect_status(sg_bake_file_view(f, "PNTS", &v, &err), &err, SG_ERR_INVALID_ARG, "opened without .map",
                  "view unmapped");
    assert_null(v);
    sg_bake_file_close(f);
    od.map = 1;
    expect_ok(sg_bake_file_open_desc(path, &od, &f, &err), &err, "open mapped");
    expect_ok(sg_bake_file_view(f, "PNTS", &v, &err), &err, "view PNTS");
    assert_int_equal((uintptr_t)v % SG_BAKE_ALIGN, 0);
    assert_memory_equal(v, pnts, sizeof pnts);
    expect_ok(sg_bake_file_view(f, "IDS_", &v, &err), &err, "view IDS_");
    assert_memory_equal(v, ids, sizeof ids);
    expect_status(sg_bake_file_view(f, "NONE", &v, &err), &err, SG_ERR_CORRUPT, "no section NONE", "missing");
    sg_bake_file_close(f);

    /* a bake opened as a world: refused by name */
    const char *bake = write_small("kind.sgbake", 0);
    sg_bake_open_desc ob = {.kind = SG_BAKE_KIND_WORLD};
    expect_status(sg_bake_file_open_desc(bake, &ob, &f, &err), &err, SG_ERR_INVALID_ARG,
                  "a splatgi bake file, not a world file", "bake as world");

    /* a damaged payload: the view's CRC check refuses it */
    const sg_bake_section *s = NULL;
    expect_ok(sg_bake_file_open_desc(path, &od, &f, &err), &err, "open for offsets");
    s = sg_bake_file_find(f, "IDS_");
    assert_non_null(s);
    size_t at = (size_t)s->offset + 5;
    sg_bake_file_close(f);
    bytes[at] ^= 0x40;
    spit(path, bytes, n);
    expect_ok(sg_bake_file_open_desc(path, &od, &f, &err), &err, "open damaged (payloads unread)");
    expect_ok(sg_bake_file_view(f, "PNTS", &v, &err), &err, "the other section");
    expect_status(sg_bake_file_view(f, "IDS_", &v, &err), &err, SG_ERR_CORRUPT, "section IDS_: checksum mismatch",
                  "damaged view");
    sg_bake_file_close(f);
    free(bytes);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bake_file_kinds_and_views),
        cmocka_unit_test(test_bake_file_roundtrip),
        cmocka_unit_test(test_bake_file_zero_sections),
        cmocka_unit_test(test_bake_file_large_section),
        cmocka_unit_test(test_bake_file_destroy_keeps_old),
        cmocka_unit_test(test_bake_file_commit_replaces),
        cmocka_unit_test(test_bake_file_every_truncation),
        cmocka_unit_test(test_bake_file_every_byte_damage),
        cmocka_unit_test(test_bake_file_wrong_hashes),
        cmocka_unit_test(test_bake_file_newer_version),
        cmocka_unit_test(test_bake_file_not_a_bake_file),
        cmocka_unit_test(test_bake_file_malformed_fixtures),
        cmocka_unit_test(test_bake_file_missing_folder),
        cmocka_unit_test(test_bake_file_writer_misuse),
        cmocka_unit_test(test_bake_file_write_failure),
        cmocka_unit_test(test_bake_file_read_misuse),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
