/* bake_file.c — the .sgbake container (format in bake_file.h).
 *
 * The writer follows the write-temporary-then-rename protocol (as SQLite's
 * journal and most editors do): payloads stream into path.tmp.XXXXXX as they
 * come, the header and table (reserved up front, so the writer never holds a
 * payload) are written last, then fsync, rename over the destination, fsync
 * of the folder. rename(2) is atomic within one file system, which is why the
 * temporary file lives in the destination's folder.
 *
 * Writer states and the function behind each transition:
 *     OPEN --begin_section/add_section--> IN_SECTION --end_section--> OPEN
 *     OPEN --commit--> COMMITTED
 *     any --I/O error (write_bytes, commit)--> FAILED (temporary removed)
 *     any --destroy--> freed (temporary removed unless COMMITTED)
 *
 * Invariants:
 *  1. While OPEN or IN_SECTION, w->pos is the size of the temporary file and
 *     every byte in [0, w->pos) is final except the header and table region,
 *     which holds zeros until commit rewrites it.
 *  2. sections[0..count) describe finished sections in file order with the
 *     canonical offsets of the format (section i at align64(end of i-1));
 *     while IN_SECTION, sections[count] is the open one and sec_written <=
 *     its size.
 *  3. The destination path is touched only by the rename in commit; every
 *     path out of the writer other than a successful commit unlinks the
 *     temporary file.
 *  4. Reader: every byte of an accepted file is covered by a check: header
 *     and table by their CRCs (checked at open), padding and unused table
 *     entries by zero checks, trailing bytes by the exact-size check, and
 *     payloads by their CRCs (checked in sg_bake_file_read). CRC-32 detects
 *     every burst of up to 32 bits, hence every single changed byte.
 *  5. Reader: bytes from the file reach no assert; each check returns
 *     SG_ERR_CORRUPT naming the file, the section and the offending values.
 *     Nothing is allocated from a file value before it was bounded: the
 *     table is at most SG_BAKE_MAX_SECTIONS entries and must fit in the file;
 *     payload sizes must fit in the file before the caller sees them.
 *  6. Reader with a map (open_desc .map): f->map holds the whole file from
 *     open to close, so views (sg_bake_file_view) stay valid that long;
 *     each view checks its payload's CRC before handing it out.
 */
#include "bake/bake_file.h"

#include <assert.h>
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>
#include <zlib.h>

#include "core/alloc.h"
#include "core/file_mode.h"

/* Payloads are the host's bytes and the format is little-endian. */
#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__) && \
    __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "bake_file.c: .sgbake payloads are little-endian; big-endian hosts need byte swapping here"
#endif

/* Magic and noun per sg_bake_kind (bake_file.h): the same container holds
 * bakes and worlds, and a file of one kind opened as the other says so. */
static const uint8_t MAGIC[2][8] = {{'S', 'G', 'B', 'A', 'K', 'E', 0, '\n'},
                                    {'S', 'G', 'W', 'R', 'L', 'D', 0, '\n'}};
static const char *const NOUN[2] = {"bake", "world"};

static bool kind_ok(sg_bake_kind k) { return k == SG_BAKE_KIND_BAKE || k == SG_BAKE_KIND_WORLD; }

/* Largest piece handed to one write/pread/crc32 call: Linux moves at most
 * 0x7ffff000 bytes per call and zlib's crc32 takes a uInt length. */
#define IO_CHUNK ((size_t)1 << 30)

static const uint8_t ZEROS[SG_BAKE_ALIGN]; /* padding source */

/* ---- little helpers ----------------------------------------------------- */

static void put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}
static void put_u64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}
static uint32_t get_u32(const uint8_t *p)
{
    uint32_t v = 0;
    for (int i = 3; i >= 0; i--)
        v = (v << 8) | p[i];
    return v;
}
static uint64_t get_u64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = (v << 8) | p[i];
    return v;
}

static uint64_t align64(uint64_t x) { return (x + (SG_BAKE_ALIGN - 1)) & ~(uint64_t)(SG_BAKE_ALIGN - 1); }

static uint32_t crc_update(uint32_t crc, const void *data, uint64_t size)
{
    const uint8_t *p = data;
    while (size > 0) {
        size_t n = size < IO_CHUNK ? (size_t)size : IO_CHUNK;
        crc = (uint32_t)crc32(crc, p, (uInt)n);
        p += n;
        size -= n;
    }
    return crc;
}

/* End of the table CRC for a table of cap entries (T in bake_file.h). */
static uint64_t table_end(uint32_t cap) { return SG_BAKE_HEADER_SIZE + (uint64_t)SG_BAKE_ENTRY_SIZE * cap + 4; }

size_t sg_bake_type_size(sg_bake_type t)
{
    switch (t) {
    case SG_BAKE_TYPE_BYTES:
    case SG_BAKE_TYPE_U8: return 1;
    case SG_BAKE_TYPE_U16:
    case SG_BAKE_TYPE_F16: return 2;
    case SG_BAKE_TYPE_U32:
    case SG_BAKE_TYPE_F32: return 4;
    case SG_BAKE_TYPE_U64:
    case SG_BAKE_TYPE_F64: return 8;
    }
    return 0;
}

static bool tag_byte_ok(uint8_t c) { return c >= 0x21 && c <= 0x7E; }

/* A caller's tag: exactly 4 characters in 0x21..0x7E. */
static bool tag_arg_ok(const char *tag)
{
    if (!tag)
        return false;
    for (int i = 0; i < 4; i++)
        if (!tag_byte_ok((uint8_t)tag[i]))
            return false;
    return tag[4] == '\0';
}

static char *dup_string(const char *s, size_t extra)
{
    size_t n = strlen(s);
    char *d = malloc(n + extra + 1);
    if (d)
        memcpy(d, s, n + 1);
    return d;
}

/* Writes all n bytes at the descriptor's position; false with errno set. */
static bool write_all(int fd, const void *data, uint64_t n)
{
    const uint8_t *p = data;
    while (n > 0) {
        size_t want = n < IO_CHUNK ? (size_t)n : IO_CHUNK;
        ssize_t r = write(fd, p, want);
        if (r < 0) {
            if (errno == EINTR)
                continue;
            return false;
        }
        if (r == 0) {
            errno = EIO;
            return false;
        }
        p += r;
        n -= (uint64_t)r;
    }
    return true;
}

static bool pwrite_all(int fd, const void *data, size_t n, off_t off)
{
    const uint8_t *p = data;
    while (n > 0) {
        ssize_t r = pwrite(fd, p, n, off);
        if (r < 0) {
            if (errno == EINTR)
                continue;
            return false;
        }
        if (r == 0) {
            errno = EIO;
            return false;
        }
        p += r;
        n -= (size_t)r;
        off += r;
    }
    return true;
}

/* Reads up to n bytes at off; returns the bytes read (short only at the end
 * of the file) or -1 with errno set. */
static int64_t pread_all(int fd, void *data, uint64_t n, uint64_t off)
{
    uint8_t *p = data;
    uint64_t got = 0;
    while (got < n) {
        uint64_t left = n - got;
        size_t want = left < IO_CHUNK ? (size_t)left : IO_CHUNK;
        ssize_t r = pread(fd, p + got, want, (off_t)(off + got));
        if (r < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        if (r == 0)
            break;
        got += (uint64_t)r;
    }
    return (int64_t)got;
}

/* ---- writer -------------------------------------------------------------- */

typedef enum wstate { W_OPEN, W_IN_SECTION, W_COMMITTED, W_FAILED } wstate;

struct sg_bake_writer {
    char *path;                /* destination                                 */
    char *tmp_path;            /* path.tmp.XXXXXX, the file being written     */
    int fd;                    /* descriptor of tmp_path; -1 once closed      */
    uint64_t scene_hash;       /* header offset 16                            */
    uint64_t param_hash;       /* header offset 24                            */
    uint32_t flags;            /* header offset 12                            */
    sg_bake_kind kind;         /* picks the magic at offset 0                 */
    uint32_t capacity;         /* table entries reserved                      */
    uint32_t count;            /* finished sections (invariant 2)             */
    sg_bake_section *sections; /* capacity entries                            */
    uint64_t pos;              /* bytes in the temporary file (invariant 1)   */
    uint64_t sec_written;      /* payload bytes of the open section so far    */
    uint32_t sec_crc;          /* running CRC of the open section             */
    wstate state;              /* see the diagram above                       */
    sg_status failed;          /* status of the error that made it FAILED     */
};

/* Closes and removes the temporary file (invariant 3). Keeps errno. */
static void drop_temp(sg_bake_writer *w)
{
    int saved = errno;
    if (w->fd >= 0) {
        close(w->fd);
        w->fd = -1;
    }
    if (w->tmp_path && w->state != W_COMMITTED)
        unlink(w->tmp_path);
    errno = saved;
}

/* Enters FAILED after an I/O error on the temporary file. */
static sg_status fail_io(sg_bake_writer *w, sg_error *err, const char *what)
{
    int e = errno;
    drop_temp(w);
    w->state = W_FAILED;
    w->failed = SG_ERR_IO;
    return sg_error_set(err, SG_ERR_IO, "%s: %s (temporary file %s, now removed): %s", w->path, what,
                        w->tmp_path, strerror(e));
}

static sg_status check_usable(const sg_bake_writer *w, sg_error *err)
{
    if (w->state == W_FAILED)
        return sg_error_set(err, w->failed, "%s: an earlier write failed; nothing was committed", w->path);
    if (w->state == W_COMMITTED)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: the bake writer was already committed", w->path);
    return SG_OK;
}

sg_status sg_bake_writer_create(const sg_bake_writer_desc *d, sg_bake_writer **out, sg_error *err)
{
    assert(out);
    if (!d || !d->path || !d->path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "bake writer: path is empty");
    if (d->max_sections > SG_BAKE_MAX_SECTIONS)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: max_sections %" PRIu32 " exceeds %u", d->path,
                            d->max_sections, SG_BAKE_MAX_SECTIONS);
    if (d->flags & ~(uint32_t)SG_BAKE_KNOWN_FLAGS)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: unknown bake flags 0x%" PRIx32, d->path, d->flags);
    if (!kind_ok(d->kind))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: unknown file kind %d", d->path, (int)d->kind);

    sg_status st = SG_OK;
    sg_bake_writer *w = calloc(1, sizeof *w);
    if (!w)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the bake writer", d->path);
    w->fd = -1;
    w->state = W_OPEN;
    w->scene_hash = d->scene_hash;
    w->param_hash = d->param_hash;
    w->flags = d->flags;
    w->kind = d->kind;
    w->capacity = d->max_sections ? d->max_sections : SG_BAKE_DEFAULT_SECTIONS;
    w->path = dup_string(d->path, 0);
    w->tmp_path = dup_string(d->path, strlen(".tmp.XXXXXX"));
    w->sections = calloc(w->capacity, sizeof *w->sections);
    if (!w->path || !w->tmp_path || !w->sections) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the bake writer", d->path);
        goto fail;
    }
    strcat(w->tmp_path, ".tmp.XXXXXX");
    w->fd = mkstemp(w->tmp_path);
    if (w->fd < 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: cannot create a temporary file in its folder: %s", d->path,
                          strerror(errno));
        free(w->tmp_path); /* mkstemp created nothing: nothing to unlink */
        w->tmp_path = NULL;
        goto fail;
    }
    /* Reserve header, table and table CRC as zeros; commit overwrites them. */
    w->pos = table_end(w->capacity);
    for (uint64_t left = w->pos; left > 0;) {
        uint64_t n = left < sizeof ZEROS ? left : sizeof ZEROS;
        if (!write_all(w->fd, ZEROS, n)) {
            st = fail_io(w, err, "cannot write the reserved header");
            goto fail;
        }
        left -= n;
    }
    *out = w;
    return SG_OK;

fail:
    sg_bake_writer_destroy(w);
    return st;
}

/* Appends raw bytes to the temporary file (padding or payload). */
static sg_status write_bytes(sg_bake_writer *w, const void *data, uint64_t n, sg_error *err)
{
    if (!write_all(w->fd, data, n))
        return fail_io(w, err, "write failed");
    w->pos += n;
    return SG_OK;
}

sg_status sg_bake_writer_begin_section(sg_bake_writer *w, const char *tag, sg_bake_type type,
                                       uint64_t count, sg_error *err)
{
    assert(w);
    sg_status st = check_usable(w, err);
    if (st != SG_OK)
        return st;
    if (w->state == W_IN_SECTION)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: section %s is still open", w->path,
                            w->sections[w->count].tag);
    if (!tag_arg_ok(tag))
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: section tag \"%s\" is not 4 printable ASCII characters", w->path,
                            tag ? tag : "(null)");
    size_t esize = sg_bake_type_size(type);
    if (esize == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: section %s: unknown element type %d", w->path, tag,
                            (int)type);
    if (count > UINT64_MAX / esize)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: section %s: %" PRIu64 " elements of %zu bytes overflow 64 bits", w->path, tag,
                            count, esize);
    for (uint32_t i = 0; i < w->count; i++)
        if (memcmp(w->sections[i].tag, tag, 4) == 0)
            return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: section %s is already in the file", w->path,
                                tag);
    if (w->count == w->capacity)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: section table full (%" PRIu32 " sections reserved; raise max_sections)",
                            w->path, w->capacity);

    uint64_t offset = align64(w->pos);
    st = write_bytes(w, ZEROS, offset - w->pos, err);
    if (st != SG_OK)
        return st;
    sg_bake_section *s = &w->sections[w->count];
    memcpy(s->tag, tag, 5);
    s->type = type;
    s->count = count;
    s->offset = offset;
    s->size = count * esize;
    s->crc = 0;
    w->sec_written = 0;
    w->sec_crc = (uint32_t)crc32(0, Z_NULL, 0);
    w->state = W_IN_SECTION;
    return SG_OK;
}

sg_status sg_bake_writer_append(sg_bake_writer *w, const void *data, size_t size, sg_error *err)
{
    assert(w);
    sg_status st = check_usable(w, err);
    if (st != SG_OK)
        return st;
    if (w->state != W_IN_SECTION)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: append without an open section", w->path);
    sg_bake_section *s = &w->sections[w->count];
    if (size > s->size - w->sec_written)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: section %s: appending %zu bytes after %" PRIu64 " exceeds its %" PRIu64
                            " bytes",
                            w->path, s->tag, size, w->sec_written, s->size);
    if (size == 0)
        return SG_OK;
    if (!data)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: section %s: data is NULL", w->path, s->tag);
    st = write_bytes(w, data, size, err);
    if (st != SG_OK)
        return st;
    w->sec_crc = crc_update(w->sec_crc, data, size);
    w->sec_written += size;
    return SG_OK;
}

sg_status sg_bake_writer_end_section(sg_bake_writer *w, sg_error *err)
{
    assert(w);
    sg_status st = check_usable(w, err);
    if (st != SG_OK)
        return st;
    if (w->state != W_IN_SECTION)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: end_section without an open section", w->path);
    sg_bake_section *s = &w->sections[w->count];
    if (w->sec_written != s->size)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: section %s: %" PRIu64 " of its %" PRIu64 " bytes were written", w->path,
                            s->tag, w->sec_written, s->size);
    assert(w->pos == s->offset + s->size); /* invariant 1 */
    s->crc = w->sec_crc;
    w->count++;
    w->state = W_OPEN;
    return SG_OK;
}

sg_status sg_bake_writer_add_section(sg_bake_writer *w, const char *tag, sg_bake_type type,
                                     uint64_t count, const void *data, sg_error *err)
{
    sg_status st = sg_bake_writer_begin_section(w, tag, type, count, err);
    if (st != SG_OK)
        return st;
    const sg_bake_section *s = &w->sections[w->count];
    if (s->size > SIZE_MAX) { /* cannot be in memory on this host */
        w->state = W_OPEN;
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: section %s: %" PRIu64 " bytes exceed memory",
                            w->path, tag, s->size);
    }
    if (s->size > 0 && !data) {
        w->state = W_OPEN; /* nothing written: the section is dropped */
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: section %s: data is NULL", w->path, tag);
    }
    st = sg_bake_writer_append(w, data, (size_t)s->size, err);
    if (st != SG_OK)
        return st;
    return sg_bake_writer_end_section(w, err);
}

/* Header and table as laid out in bake_file.h; buf holds table_end(cap). */
static void encode_front(const sg_bake_writer *w, uint8_t *buf)
{
    size_t tsize = (size_t)SG_BAKE_ENTRY_SIZE * w->capacity;
    memset(buf, 0, (size_t)table_end(w->capacity));
    memcpy(buf, MAGIC[w->kind], 8);
    put_u32(buf + 8, SG_BAKE_FORMAT_VERSION);
    put_u32(buf + 12, w->flags);
    put_u64(buf + 16, w->scene_hash);
    put_u64(buf + 24, w->param_hash);
    put_u32(buf + 32, w->count);
    put_u32(buf + 36, w->capacity);
    put_u32(buf + 40, 0);
    put_u32(buf + 44, (uint32_t)crc32(0, buf, 44));
    uint8_t *t = buf + SG_BAKE_HEADER_SIZE;
    for (uint32_t i = 0; i < w->count; i++) {
        const sg_bake_section *s = &w->sections[i];
        uint8_t *e = t + (size_t)SG_BAKE_ENTRY_SIZE * i;
        memcpy(e, s->tag, 4);
        put_u32(e + 4, (uint32_t)s->type);
        put_u64(e + 8, s->count);
        put_u64(e + 16, s->offset);
        put_u64(e + 24, s->size);
        put_u32(e + 32, s->crc);
        put_u32(e + 36, 0);
    }
    put_u32(t + tsize, crc_update(0, t, tsize));
}

/* fsync of the folder holding path, so the rename itself is durable. Best
 * effort: some file systems refuse fsync on a directory, and the new file is
 * complete either way. */
static void sync_folder(const char *path)
{
    const char *slash = strrchr(path, '/');
    char *dir = NULL;
    if (!slash)
        dir = dup_string(".", 0);
    else if (slash == path)
        dir = dup_string("/", 0);
    else if ((dir = dup_string(path, 0)) != NULL)
        dir[slash - path] = '\0';
    if (!dir)
        return;
    int fd = open(dir, O_RDONLY);
    if (fd >= 0) {
        fsync(fd);
        close(fd);
    }
    free(dir);
}

sg_status sg_bake_writer_commit(sg_bake_writer *w, sg_error *err)
{
    assert(w);
    sg_status st = check_usable(w, err);
    if (st != SG_OK)
        return st;
    if (w->state == W_IN_SECTION)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: section %s is still open at commit", w->path,
                            w->sections[w->count].tag);

    size_t front = (size_t)table_end(w->capacity);
    uint8_t *buf = malloc(front);
    if (!buf)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the section table", w->path);
    encode_front(w, buf);
    bool ok = pwrite_all(w->fd, buf, front, 0);
    free(buf);
    if (!ok)
        return fail_io(w, err, "cannot write the header");
    /* A replaced file keeps its mode; a new one gets 0666 & ~umask like
     * every output (core/file_mode.h; mkstemp made it 0600). */
    if (fchmod(w->fd, sg_output_file_mode(w->path)) != 0)
        return fail_io(w, err, "cannot set the file mode");
    if (fsync(w->fd) != 0)
        return fail_io(w, err, "fsync failed");
    int fd = w->fd;
    w->fd = -1;
    if (close(fd) != 0)
        return fail_io(w, err, "close failed");
    if (rename(w->tmp_path, w->path) != 0)
        return fail_io(w, err, "cannot rename the temporary file over it");
    w->state = W_COMMITTED;
    sync_folder(w->path);
    return SG_OK;
}

void sg_bake_writer_destroy(sg_bake_writer *w)
{
    if (!w)
        return;
    drop_temp(w);
    free(w->sections);
    free(w->tmp_path);
    free(w->path);
    free(w);
}

/* ---- reader -------------------------------------------------------------- */

struct sg_bake_file {
    int fd;                    /* open read-only descriptor                 */
    char *path;                /* for messages                              */
    sg_bake_info info;         /* header fields                             */
    sg_bake_section *sections; /* info.section_count validated entries      */
    const uint8_t *map;        /* the whole file (open_desc .map), or NULL  */
    bool map_read;             /* map is a read copy (sg_alloc_array), not
                                  an mmap                                   */
};

/* Checks the 48 header bytes h of a file of size bytes (size >= 48). */
static sg_status check_header(const char *path, const uint8_t *h, uint64_t size, uint64_t scene_hash,
                              uint64_t param_hash, sg_bake_kind kind, sg_bake_info *info, uint32_t *cap,
                              sg_error *err)
{
    uint32_t stored = get_u32(h + 44);
    uint32_t computed = (uint32_t)crc32(0, h, 44);
    /* CRC before version: bytes 0..47 keep their layout in later versions
     * (bake_file.h), so a bad CRC means damage, not a newer file. */
    if (stored != computed)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: header checksum mismatch (stored %08" PRIx32
                                                 ", computed %08" PRIx32 ")",
                            path, stored, computed);
    info->version = get_u32(h + 8);
    if (info->version == 0)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: format version 0 is invalid", path);
    if (info->version > SG_BAKE_FORMAT_VERSION)
        return sg_error_set(err, SG_ERR_UNSUPPORTED,
                            "%s: format version %" PRIu32 " is newer than this build reads (%u)", path,
                            info->version, SG_BAKE_FORMAT_VERSION);
    info->flags = get_u32(h + 12);
    if (info->flags & ~(uint32_t)SG_BAKE_KNOWN_FLAGS)
        return sg_error_set(err, SG_ERR_UNSUPPORTED,
                            "%s: flags 0x%08" PRIx32 " include bits unknown to this build (it knows 0x%08x)",
                            path, info->flags, SG_BAKE_KNOWN_FLAGS);
    uint32_t reserved = get_u32(h + 40);
    if (reserved != 0)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: header reserved field is %" PRIu32 ", expected 0",
                            path, reserved);
    info->scene_hash = get_u64(h + 16);
    info->param_hash = get_u64(h + 24);
    info->section_count = get_u32(h + 32);
    info->file_size = size;
    *cap = get_u32(h + 36);
    if (*cap == 0 || *cap > SG_BAKE_MAX_SECTIONS)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section table capacity %" PRIu32 " outside 1..%u", path,
                            *cap, SG_BAKE_MAX_SECTIONS);
    if (info->section_count > *cap)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section count %" PRIu32 " exceeds the table capacity %" PRIu32, path,
                            info->section_count, *cap);
    if (scene_hash != 0 && info->scene_hash != scene_hash)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: made for another scene (scene hash %016" PRIx64 ", this scene %016" PRIx64
                            ")",
                            path, info->scene_hash, scene_hash);
    if (param_hash != 0 && info->param_hash != param_hash)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: made with other %s parameters (parameter hash %016" PRIx64
                            ", these parameters %016" PRIx64 ")",
                            path, NOUN[kind], info->param_hash, param_hash);
    return SG_OK;
}

/* Decodes and checks table entry i (i < section count) against the entries
 * before it; prev_end is where the previous section (or the table) ends. */
static sg_status check_entry(const char *path, const uint8_t *e, uint32_t i, const sg_bake_section *prev,
                             uint64_t prev_end, uint64_t size, sg_bake_section *s, sg_error *err)
{
    for (int k = 0; k < 4; k++)
        if (!tag_byte_ok(e[k]))
            return sg_error_set(err, SG_ERR_CORRUPT,
                                "%s: section %" PRIu32 ": tag bytes %02x %02x %02x %02x are not 4 printable "
                                "ASCII characters",
                                path, i, e[0], e[1], e[2], e[3]);
    memcpy(s->tag, e, 4);
    s->tag[4] = '\0';
    uint32_t type = get_u32(e + 4);
    size_t esize = type <= SG_BAKE_TYPE_F64 ? sg_bake_type_size((sg_bake_type)type) : 0;
    if (esize == 0)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s: unknown element type %" PRIu32, path, s->tag,
                            type);
    s->type = (sg_bake_type)type;
    s->count = get_u64(e + 8);
    s->offset = get_u64(e + 16);
    s->size = get_u64(e + 24);
    s->crc = get_u32(e + 32);
    uint32_t reserved = get_u32(e + 36);
    /* Division, not count * esize: a count near 2^64 must not wrap. */
    if (s->size % esize != 0 || s->size / esize != s->count)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section %s: %" PRIu64 " bytes do not hold %" PRIu64 " elements of %zu bytes",
                            path, s->tag, s->size, s->count, esize);
    if (reserved != 0)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s: reserved field is %" PRIu32 ", expected 0",
                            path, s->tag, reserved);
    if (s->offset % SG_BAKE_ALIGN != 0)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s: offset %" PRIu64 " is not a multiple of %u",
                            path, s->tag, s->offset, SG_BAKE_ALIGN);
    uint64_t want = align64(prev_end);
    if (s->offset < want) {
        if (prev)
            return sg_error_set(err, SG_ERR_CORRUPT,
                                "%s: section %s: offset %" PRIu64 " overlaps section %s (which ends at byte %" PRIu64
                                ")",
                                path, s->tag, s->offset, prev->tag, prev_end);
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section %s: offset %" PRIu64 " overlaps the section table (which ends at byte %" PRIu64
                            ")",
                            path, s->tag, s->offset, prev_end);
    }
    if (s->offset > want)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section %s: starts at byte %" PRIu64 ", expected %" PRIu64
                            " (sections are contiguous)",
                            path, s->tag, s->offset, want);
    if (s->offset > size || s->size > size - s->offset)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section %s: truncated: its %" PRIu64 " bytes at byte %" PRIu64
                            " run past the end of the file (%" PRIu64 " bytes)",
                            path, s->tag, s->size, s->offset, size);
    return SG_OK;
}

/* The bytes [from, to) (fewer than 64) must be zero. */
static sg_status check_padding(int fd, const char *path, uint64_t from, uint64_t to, const char *before,
                               sg_error *err)
{
    uint8_t pad[SG_BAKE_ALIGN];
    uint64_t n = to - from;
    assert(to >= from && n < SG_BAKE_ALIGN);
    if (n == 0)
        return SG_OK;
    int64_t got = pread_all(fd, pad, n, from);
    if (got < 0)
        return sg_error_set(err, SG_ERR_IO, "%s: read failed: %s", path, strerror(errno));
    if ((uint64_t)got != n)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: truncated while reading the padding at byte %" PRIu64,
                            path, from);
    for (uint64_t k = 0; k < n; k++)
        if (pad[k] != 0)
            return sg_error_set(err, SG_ERR_CORRUPT,
                                "%s: padding byte %" PRIu64 " before section %s is 0x%02x, expected 0", path,
                                from + k, before, pad[k]);
    return SG_OK;
}

sg_status sg_bake_file_open(const char *path, uint64_t scene_hash, uint64_t param_hash,
                            sg_bake_file **out, sg_error *err)
{
    sg_bake_open_desc d = {.scene_hash = scene_hash, .param_hash = param_hash};
    return sg_bake_file_open_desc(path, &d, out, err);
}

/* The whole file in memory for sg_bake_file_view: mapped read-only, or read
 * into one aligned buffer where mmap fails (a file system without it). */
static sg_status map_file(sg_bake_file *f, uint64_t size, sg_error *err)
{
    if (size > SIZE_MAX)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: %" PRIu64 " bytes exceed the address space", f->path, size);
    void *p = mmap(NULL, (size_t)size, PROT_READ, MAP_PRIVATE, f->fd, 0);
    if (p != MAP_FAILED) {
        f->map = p;
        return SG_OK;
    }
    uint8_t *buf = sg_alloc_array((size_t)size, 1);
    if (!buf)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: cannot map the file (%s) nor read its %" PRIu64 " bytes",
                            f->path, strerror(errno), size);
    int64_t got = pread_all(f->fd, buf, size, 0);
    if (got < 0 || (uint64_t)got != size) {
        sg_free(buf);
        return got < 0 ? sg_error_set(err, SG_ERR_IO, "%s: read failed: %s", f->path, strerror(errno))
                       : sg_error_set(err, SG_ERR_CORRUPT, "%s: truncated while reading it whole", f->path);
    }
    f->map = buf;
    f->map_read = true;
    return SG_OK;
}

sg_status sg_bake_file_open_desc(const char *path, const sg_bake_open_desc *d, sg_bake_file **out, sg_error *err)
{
    assert(out && d);
    sg_bake_kind kind = d->kind;
    if (!kind_ok(kind))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: unknown file kind %d", path ? path : "(null)", (int)kind);
    if (!path || !path[0])
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s file path is empty", NOUN[kind]);

    sg_status st = SG_OK;
    uint8_t *table = NULL;     /* capacity entries + table CRC, from the file */
    sg_bake_file *f = calloc(1, sizeof *f);
    if (!f)
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
    f->fd = -1;
    f->path = dup_string(path, 0);
    if (!f->path) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    f->fd = open(path, O_RDONLY | O_CLOEXEC);
    if (f->fd < 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
        goto done;
    }
    struct stat sb;
    if (fstat(f->fd, &sb) != 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: cannot determine the file size: %s", path, strerror(errno));
        goto done;
    }
    if (!S_ISREG(sb.st_mode)) {
        st = sg_error_set(err, SG_ERR_IO, "%s: not a regular file", path);
        goto done;
    }
    uint64_t size = (uint64_t)sb.st_size; /* file bytes */

    /* Magic and header. */
    uint8_t h[SG_BAKE_HEADER_SIZE];
    uint64_t hn = size < sizeof h ? size : sizeof h;
    int64_t got = pread_all(f->fd, h, hn, 0);
    if (got < 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: read failed: %s", path, strerror(errno));
        goto done;
    }
    if ((uint64_t)got != hn) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: truncated while reading the header", path);
        goto done;
    }
    if (size == 0) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: not a splatgi %s file (it is empty)", path, NOUN[kind]);
        goto done;
    }
    if (memcmp(h, MAGIC[kind], hn < 8 ? (size_t)hn : 8) != 0) {
        sg_bake_kind other = kind == SG_BAKE_KIND_BAKE ? SG_BAKE_KIND_WORLD : SG_BAKE_KIND_BAKE;
        if (hn >= 8 && memcmp(h, MAGIC[other], 8) == 0)
            st = sg_error_set(err, SG_ERR_INVALID_ARG, "%s: a splatgi %s file, not a %s file", path, NOUN[other],
                              NOUN[kind]);
        else
            st = sg_error_set(err, SG_ERR_CORRUPT, "%s: not a splatgi %s file", path, NOUN[kind]);
        goto done;
    }
    if (size < SG_BAKE_HEADER_SIZE) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: truncated: %" PRIu64 " bytes, the header needs %u", path,
                          size, SG_BAKE_HEADER_SIZE);
        goto done;
    }
    uint32_t cap = 0; /* table capacity */
    st = check_header(path, h, size, d->scene_hash, d->param_hash, kind, &f->info, &cap, err);
    if (st != SG_OK)
        goto done;

    /* Section table: bounded by SG_BAKE_MAX_SECTIONS and the file size
     * before it is allocated (invariant 5). */
    uint64_t tend = table_end(cap);
    if (tend > size) {
        st = sg_error_set(err, SG_ERR_CORRUPT,
                          "%s: truncated: the section table ends at byte %" PRIu64 ", the file has %" PRIu64
                          " bytes",
                          path, tend, size);
        goto done;
    }
    size_t tsize = (size_t)SG_BAKE_ENTRY_SIZE * cap;
    table = malloc(tsize + 4);
    f->sections = calloc(f->info.section_count ? f->info.section_count : 1, sizeof *f->sections);
    if (!table || !f->sections) {
        st = sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory for the section table", path);
        goto done;
    }
    got = pread_all(f->fd, table, tsize + 4, SG_BAKE_HEADER_SIZE);
    if (got < 0) {
        st = sg_error_set(err, SG_ERR_IO, "%s: read failed: %s", path, strerror(errno));
        goto done;
    }
    if ((uint64_t)got != tsize + 4) {
        st = sg_error_set(err, SG_ERR_CORRUPT, "%s: truncated while reading the section table", path);
        goto done;
    }
    uint32_t stored = get_u32(table + tsize);
    uint32_t computed = crc_update(0, table, tsize);
    if (stored != computed) {
        st = sg_error_set(err, SG_ERR_CORRUPT,
                          "%s: section table checksum mismatch (stored %08" PRIx32 ", computed %08" PRIx32 ")",
                          path, stored, computed);
        goto done;
    }

    uint64_t end = tend; /* end of the previous section (or the table) */
    for (uint32_t i = 0; i < f->info.section_count; i++) {
        sg_bake_section *s = &f->sections[i];
        const sg_bake_section *prev = i > 0 ? &f->sections[i - 1] : NULL;
        st = check_entry(path, table + (size_t)SG_BAKE_ENTRY_SIZE * i, i, prev, end, size, s, err);
        if (st != SG_OK)
            goto done;
        for (uint32_t j = 0; j < i; j++)
            if (memcmp(f->sections[j].tag, s->tag, 4) == 0) {
                st = sg_error_set(err, SG_ERR_CORRUPT,
                                  "%s: section %s: tag appears twice (sections %" PRIu32 " and %" PRIu32 ")",
                                  path, s->tag, j, i);
                goto done;
            }
        st = check_padding(f->fd, path, end, s->offset, s->tag, err);
        if (st != SG_OK)
            goto done;
        end = s->offset + s->size;
    }
    for (uint32_t i = f->info.section_count; i < cap; i++) {
        const uint8_t *e = table + (size_t)SG_BAKE_ENTRY_SIZE * i;
        for (uint32_t k = 0; k < SG_BAKE_ENTRY_SIZE; k++)
            if (e[k] != 0) {
                st = sg_error_set(err, SG_ERR_CORRUPT, "%s: unused section table entry %" PRIu32 " is not zero",
                                  path, i);
                goto done;
            }
    }
    if (size != end) {
        st = sg_error_set(err, SG_ERR_CORRUPT,
                          "%s: %" PRIu64 " unexpected bytes after the last section (which ends at byte %" PRIu64
                          ")",
                          path, size - end, end);
        goto done;
    }
    f->info.kind = kind;
    if (d->map && size > 0 && (st = map_file(f, size, err)) != SG_OK)
        goto done;
    *out = f;
    f = NULL;

done:
    free(table);
    sg_bake_file_close(f);
    return st;
}

const sg_bake_info *sg_bake_file_info(const sg_bake_file *f)
{
    assert(f);
    return &f->info;
}

const sg_bake_section *sg_bake_file_section(const sg_bake_file *f, uint32_t i)
{
    assert(f);
    return i < f->info.section_count ? &f->sections[i] : NULL;
}

const sg_bake_section *sg_bake_file_find(const sg_bake_file *f, const char *tag)
{
    assert(f);
    if (!tag_arg_ok(tag))
        return NULL;
    for (uint32_t i = 0; i < f->info.section_count; i++)
        if (memcmp(f->sections[i].tag, tag, 4) == 0)
            return &f->sections[i];
    return NULL;
}

sg_status sg_bake_file_read(const sg_bake_file *f, const char *tag, void *dst, uint64_t dst_size,
                            sg_error *err)
{
    assert(f);
    if (!tag_arg_ok(tag))
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: section tag \"%s\" is not 4 printable ASCII characters", f->path,
                            tag ? tag : "(null)");
    const sg_bake_section *s = sg_bake_file_find(f, tag);
    if (!s)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: no section %s", f->path, tag);
    if (dst_size != s->size)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: section %s: buffer of %" PRIu64 " bytes for a section of %" PRIu64 " bytes",
                            f->path, s->tag, dst_size, s->size);
    if (s->size > 0 && !dst)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: section %s: dst is NULL", f->path, s->tag);
    uint32_t crc = (uint32_t)crc32(0, Z_NULL, 0);
    if (s->size > 0) {
        int64_t got = pread_all(f->fd, dst, s->size, s->offset);
        if (got < 0)
            return sg_error_set(err, SG_ERR_IO, "%s: section %s: read failed: %s", f->path, s->tag,
                                strerror(errno));
        if ((uint64_t)got != s->size) /* the file shrank after open */
            return sg_error_set(err, SG_ERR_CORRUPT,
                                "%s: section %s: truncated: read %" PRId64 " of its %" PRIu64 " bytes", f->path,
                                s->tag, got, s->size);
        crc = crc_update(crc, dst, s->size);
    }
    if (crc != s->crc)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section %s: checksum mismatch (stored %08" PRIx32 ", computed %08" PRIx32 ")",
                            f->path, s->tag, s->crc, crc);
    return SG_OK;
}

sg_status sg_bake_file_view(const sg_bake_file *f, const char *tag, const void **data, sg_error *err)
{
    assert(f && data);
    if (!f->map)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: opened without .map: no views", f->path);
    const sg_bake_section *s = sg_bake_file_find(f, tag);
    if (!s)
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: no section %s", f->path, tag_arg_ok(tag) ? tag : "(bad tag)");
    /* A file cut short in place after open would fault on access (SIGBUS);
     * our writers never do that (they rename), but another tool might. */
    struct stat sb;
    if (!f->map_read && (fstat(f->fd, &sb) != 0 || (uint64_t)sb.st_size < f->info.file_size))
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: section %s: the file shrank after it was opened", f->path,
                            s->tag);
    uint32_t crc = crc_update((uint32_t)crc32(0, Z_NULL, 0), f->map + s->offset, s->size);
    if (crc != s->crc)
        return sg_error_set(err, SG_ERR_CORRUPT,
                            "%s: section %s: checksum mismatch (stored %08" PRIx32 ", computed %08" PRIx32 ")",
                            f->path, s->tag, s->crc, crc);
    *data = f->map + s->offset;
    return SG_OK;
}

int sg_bake_file_has_magic(const char *path, sg_bake_kind kind)
{
    if (!path || !kind_ok(kind))
        return 0;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return 0;
    uint8_t h[8];
    int64_t got = pread_all(fd, h, sizeof h, 0);
    close(fd);
    return got == (int64_t)sizeof h && memcmp(h, MAGIC[kind], sizeof h) == 0;
}

void sg_bake_file_close(sg_bake_file *f)
{
    if (!f)
        return;
    if (f->map && f->map_read)
        sg_free((void *)f->map);
    else if (f->map)
        munmap((void *)f->map, (size_t)f->info.file_size);
    if (f->fd >= 0)
        close(f->fd);
    free(f->sections);
    free(f->path);
    free(f);
}
