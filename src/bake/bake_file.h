/* bake_file.h — the .sgbake container: versioned, self-describing, checksummed
 * sections written atomically.
 *
 * What it does: stores a list of named, typed sections (point positions,
 * irradiance, directions, metadata, ...) in one file whose header records
 * which scene (models + envmap) and which bake parameters it was made from.
 * The writer streams each payload straight into a temporary file beside the
 * destination and renames it over the destination only on commit, so a crash,
 * an error or a destroy without commit never leaves a partial file at the
 * destination and never touches a file already there. The reader validates
 * every structural byte when it opens the file and each payload's CRC-32
 * when the payload is read, so a bake for another scene, a truncated or
 * corrupted file or a file from a newer build gives a clear error instead of
 * wrong data.
 *
 * What it does NOT do: compute the hashes (the caller hashes its models,
 * envmap and parameters however it likes and passes two u64), interpret
 * section contents, compress, convert byte order (payloads are written and
 * read as the host's bytes; this build accepts little-endian hosts only, see
 * bake_file.c), or lock the file against concurrent writers (the last commit
 * wins; each one is whole). A process killed mid-write (SIGKILL, power loss;
 * the library installs no signal handlers) may leave a stray
 * "<path>.tmp.XXXXXX" beside the destination; it never replaces the
 * destination and may be deleted.
 *
 * Walkthrough:
 *     sg_bake_writer *w;
 *     sg_bake_writer_desc d = {.path = "bunny.sgbake", .scene_hash = sh,
 *                              .param_hash = ph};
 *     sg_bake_writer_create(&d, &w, &err);
 *     sg_bake_writer_add_section(w, "PNTS", SG_BAKE_TYPE_F32, 3 * n, xyz, &err);
 *     sg_bake_writer_begin_section(w, "IRRD", SG_BAKE_TYPE_F32, 3 * n, &err);
 *     for each chunk: sg_bake_writer_append(w, chunk, bytes, &err);
 *     sg_bake_writer_end_section(w, &err);
 *     sg_bake_writer_commit(w, &err);         (the file appears only here)
 *     sg_bake_writer_destroy(w);
 *
 *     sg_bake_file *f;
 *     sg_bake_file_open("bunny.sgbake", sh, ph, &f, &err);
 *     const sg_bake_section *s = sg_bake_file_find(f, "IRRD");
 *     float *irr = sg_alloc_array(s->count, sizeof(float));
 *     sg_bake_file_read(f, "IRRD", irr, s->size, &err);  (CRC checked here)
 *     sg_bake_file_close(f);
 *
 * World files (render/world_file.h) use the same container with their own
 * magic: a writer with .kind = SG_BAKE_KIND_WORLD, read with
 * sg_bake_file_open_desc (.kind the same, .map = 1 to take payloads in
 * place with sg_bake_file_view instead of copying them). A file of one
 * kind opened as the other is SG_ERR_INVALID_ARG ("x.sgworld: a splatgi
 * bake file, not a world file").
 *
 * Checkpoints (resume after Ctrl-C) use the same container: a writer with
 * .flags = SG_BAKE_FLAG_CHECKPOINT, the same scene and parameter hashes and
 * the tags of the partial state, committed to e.g. "bunny.sgbake.ckpt"; the
 * reader checks the hashes as for a finished bake, and the caller checks
 * sg_bake_file_info(f)->flags to tell the two apart.
 *
 * ---------------------------------------------------------------------------
 * File format, version 1. All integers little-endian; offsets are from the
 * start of the file. Every byte of a valid file is either covered by a
 * CRC-32 or required to be zero (invariant 4 in bake_file.c), so no single
 * changed byte can go unnoticed.
 *
 * Header, 48 bytes at offset 0 (this layout of bytes 0..47, CRC included, is
 * kept by every later version, so the reader can tell "newer" from "corrupt"):
 *   off size  meaning
 *     0    8  magic "SGBAKE\0\n" (53 47 42 41 4B 45 00 0A); a world file
 *             (SG_BAKE_KIND_WORLD) has "SGWRLD\0\n" here, all else the same
 *     8    4  format version; 1 (SG_BAKE_FORMAT_VERSION). 0 is corrupt, a
 *             larger value is SG_ERR_UNSUPPORTED.
 *    12    4  flags: bit 0 SG_BAKE_FLAG_CHECKPOINT; other bits must be 0
 *             (set bits unknown to this build are SG_ERR_UNSUPPORTED).
 *    16    8  scene hash (the caller's hash of models + envmap)
 *    24    8  parameter hash (the caller's hash of the bake parameters)
 *    32    4  section count n, n <= capacity
 *    36    4  table capacity c, 1 <= c <= SG_BAKE_MAX_SECTIONS: the number of
 *             table entries reserved (the writer reserves them up front so
 *             that payloads can stream to the file as they come).
 *    40    4  reserved, 0
 *    44    4  CRC-32 (zlib/ISO-HDLC polynomial) of bytes 0..43
 *
 * Section table, 40 * c bytes at offset 48; entry i at 48 + 40 i:
 *     0    4  tag: 4 ASCII bytes in 0x21..0x7E ("PNTS", "IRRD", "DIRS",
 *             "META"); tags are unique within a file
 *     4    4  element type (sg_bake_type: 1..8)
 *     8    8  element count
 *    16    8  payload offset: a multiple of 64 (SG_BAKE_ALIGN)
 *    24    8  payload size in bytes = element count * element size
 *    32    4  CRC-32 of the payload bytes (0 for an empty payload)
 *    36    4  reserved, 0
 *   Entries n..c-1 are unused and all zero.
 * Table CRC, 4 bytes at offset 48 + 40 c: CRC-32 of the 40 c table bytes.
 *
 * Payloads: let T = 52 + 40 c (the end of the table CRC). Section 0 starts at
 * align64(T), section i > 0 at align64(end of section i-1), where the end of
 * a section is offset + size; the bytes between are zero. Sections are thus
 * in table order, 64-byte aligned (a reader could mmap them), never overlap
 * and leave no gaps beyond alignment. The file ends exactly at the end of
 * the last section (at T when n = 0); any further byte is corrupt. An empty
 * section has size 0 and the offset its successor would have.
 * ---------------------------------------------------------------------------
 *
 * Errors (messages name the file, and the section tag where one applies):
 *  SG_ERR_IO           open, create, write, fsync or rename failed (errno
 *                      text in the message), e.g. writing into a missing
 *                      folder; nothing is left behind;
 *  SG_ERR_CORRUPT      not a bake file ("x.sgbake: not a splatgi bake
 *                      file"), truncated (names the section and the byte
 *                      counts), header/table/payload CRC mismatch, a bad tag,
 *                      type, size, offset, overlap, gap, duplicate tag,
 *                      non-zero padding or trailing bytes, a missing section
 *                      on read;
 *  SG_ERR_UNSUPPORTED  format version newer than this build reads, or
 *                      unknown flags;
 *  SG_ERR_INVALID_ARG  made for another scene or other parameters (both
 *                      hashes printed), or a call out of contract (bad tag,
 *                      wrong byte count, table full, buffer of the wrong
 *                      size, call in the wrong state);
 *  SG_ERR_NOMEM        allocation failed.
 *
 * Thread-safety: a writer is used by one thread at a time. After a
 * successful open, every sg_bake_file query and read may run concurrently
 * (reads use pread on a shared descriptor and change no state).
 */
#ifndef SG_BAKE_BAKE_FILE_H
#define SG_BAKE_BAKE_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"

#define SG_BAKE_FORMAT_VERSION 1u  /* the version this build writes and reads */
#define SG_BAKE_HEADER_SIZE 48u    /* bytes before the section table          */
#define SG_BAKE_ENTRY_SIZE 40u     /* bytes per section table entry           */
#define SG_BAKE_ALIGN 64u          /* payload alignment in the file           */
#define SG_BAKE_MAX_SECTIONS 4096u /* largest table capacity read or written  */
#define SG_BAKE_DEFAULT_SECTIONS 32u /* capacity when the desc leaves it 0    */

/* Element type of a section; fixes the element size. */
typedef enum sg_bake_type {
    SG_BAKE_TYPE_BYTES = 1, /* opaque bytes (e.g. UTF-8 JSON), size 1 */
    SG_BAKE_TYPE_U8 = 2,    /* size 1 */
    SG_BAKE_TYPE_U16 = 3,   /* size 2 */
    SG_BAKE_TYPE_U32 = 4,   /* size 4 */
    SG_BAKE_TYPE_U64 = 5,   /* size 8 */
    SG_BAKE_TYPE_F16 = 6,   /* IEEE 754 binary16, size 2 */
    SG_BAKE_TYPE_F32 = 7,   /* size 4 */
    SG_BAKE_TYPE_F64 = 8    /* size 8 */
} sg_bake_type;

/* What the container holds; picks the magic (file offset 0). */
typedef enum sg_bake_kind {
    SG_BAKE_KIND_BAKE = 0, /* "SGBAKE\0\n": a bake or checkpoint (bake_io.h) */
    SG_BAKE_KIND_WORLD = 1 /* "SGWRLD\0\n": a built world (world_file.h)     */
} sg_bake_kind;

/* Header flags (file offset 12). */
#define SG_BAKE_FLAG_CHECKPOINT (1u << 0) /* partial bake state, not a result */
#define SG_BAKE_KNOWN_FLAGS SG_BAKE_FLAG_CHECKPOINT

/* Bytes per element of type t; 0 for a value outside sg_bake_type. */
size_t sg_bake_type_size(sg_bake_type t);

/* ---- Writer ------------------------------------------------------------ */

typedef struct sg_bake_writer sg_bake_writer;

typedef struct sg_bake_writer_desc {
    const char *path;      /* REQUIRED: destination; copied                   */
    uint64_t scene_hash;   /* hash of models + envmap; default 0              */
    uint64_t param_hash;   /* hash of the bake parameters; default 0          */
    uint32_t flags;        /* SG_BAKE_FLAG_*; default 0 (a finished bake)     */
    uint32_t max_sections; /* table capacity, 1..SG_BAKE_MAX_SECTIONS;
                              0 = SG_BAKE_DEFAULT_SECTIONS                    */
    sg_bake_kind kind;     /* default SG_BAKE_KIND_BAKE                       */
} sg_bake_writer_desc;

/* Creates the temporary file path + ".tmp.XXXXXX" (mkstemp) in the
 * destination's folder and reserves the header and table. SG_ERR_IO (naming
 * the path) if the folder is missing or not writable; nothing is created
 * then. The destination is not touched until commit. */
sg_status sg_bake_writer_create(const sg_bake_writer_desc *d, sg_bake_writer **out, sg_error *err);

/* Writes one whole section: tag is a NUL-terminated 4-character string in
 * 0x21..0x7E, unique in this file; data holds count elements of type (may
 * be NULL when count is 0). The bytes go straight to the temporary file;
 * nothing is copied or kept. */
sg_status sg_bake_writer_add_section(sg_bake_writer *w, const char *tag, sg_bake_type type,
                                     uint64_t count, const void *data, sg_error *err);

/* Streaming form of add_section for payloads produced in pieces: begin
 * declares the section; append writes the next size bytes (any split, also
 * mid-element); end checks that exactly count * element size bytes came.
 * An append past the declared size or an end before it is SG_ERR_INVALID_ARG
 * and writes nothing. */
sg_status sg_bake_writer_begin_section(sg_bake_writer *w, const char *tag, sg_bake_type type,
                                       uint64_t count, sg_error *err);
sg_status sg_bake_writer_append(sg_bake_writer *w, const void *data, size_t size, sg_error *err);
sg_status sg_bake_writer_end_section(sg_bake_writer *w, sg_error *err);

/* Writes header and table, fsyncs the temporary file, sets its mode (the
 * replaced file's mode, else 0644), renames it over path atomically and
 * fsyncs the folder (best effort). On any failure the temporary file is
 * removed and a file already at path is left as it was. After an I/O error
 * in any writer call the writer refuses further calls with that status. */
sg_status sg_bake_writer_commit(sg_bake_writer *w, sg_error *err);

/* Frees w; without a successful commit it also removes the temporary file
 * (a file already at path is untouched). NULL is a no-op. */
void sg_bake_writer_destroy(sg_bake_writer *w);

/* ---- Reader ------------------------------------------------------------ */

typedef struct sg_bake_file sg_bake_file;

/* Header fields of an open file. */
typedef struct sg_bake_info {
    uint32_t version;       /* format version (SG_BAKE_FORMAT_VERSION)  */
    uint32_t flags;         /* SG_BAKE_FLAG_*                           */
    uint64_t scene_hash;    /* as written                               */
    uint64_t param_hash;    /* as written                               */
    uint32_t section_count; /* sections in the file                     */
    uint64_t file_size;     /* bytes                                    */
    sg_bake_kind kind;      /* as opened (the magic matched it)         */
} sg_bake_info;

/* One validated table entry. */
typedef struct sg_bake_section {
    char tag[5];       /* 4 characters + NUL                        */
    sg_bake_type type; /* element type                              */
    uint64_t count;    /* elements                                  */
    uint64_t offset;   /* payload offset in the file, 64-aligned    */
    uint64_t size;     /* payload bytes = count * type size         */
    uint32_t crc;      /* stored CRC-32 of the payload              */
} sg_bake_section;

/* Opens path and validates magic, header CRC, version, flags, the hashes,
 * the table CRC and every entry (tag, type, size, offset, order, padding,
 * bounds against the file size), all before allocating anything sized by
 * the file beyond the table. scene_hash / param_hash: the values this scene
 * and these parameters hash to; 0 skips that check (tools that only list a
 * file). Payload CRCs are checked by sg_bake_file_read. *out only on SG_OK;
 * release it with sg_bake_file_close. */
sg_status sg_bake_file_open(const char *path, uint64_t scene_hash, uint64_t param_hash,
                            sg_bake_file **out, sg_error *err);

/* How sg_bake_file_open_desc opens a file; zero = a bake, no hash checks,
 * no map. */
typedef struct sg_bake_open_desc {
    sg_bake_kind kind;   /* the magic expected; default SG_BAKE_KIND_BAKE */
    uint64_t scene_hash; /* 0 skips the check (as sg_bake_file_open)      */
    uint64_t param_hash; /* 0 skips the check                             */
    int map;             /* 1: map the whole file read-only at open (or,
                            where mmap fails, read it into memory) for
                            sg_bake_file_view; the mapping lives until
                            close. SG_ERR_NOMEM if neither works.       */
} sg_bake_open_desc;

/* sg_bake_file_open with a kind and an optional map. */
sg_status sg_bake_file_open_desc(const char *path, const sg_bake_open_desc *d, sg_bake_file **out, sg_error *err);

/* Header fields; never NULL. */
const sg_bake_info *sg_bake_file_info(const sg_bake_file *f);

/* Section i (0..section_count-1, in file order), or NULL past the end. */
const sg_bake_section *sg_bake_file_section(const sg_bake_file *f, uint32_t i);

/* The section with this tag, or NULL if the file has none. */
const sg_bake_section *sg_bake_file_find(const sg_bake_file *f, const char *tag);

/* Reads the whole payload of section tag into dst (dst_size must equal its
 * size) and checks its CRC: "x.sgbake: section IRRD: checksum mismatch
 * (stored 1a2b3c4d, computed 5e6f7a8b)". A missing section is
 * SG_ERR_CORRUPT; a wrong dst_size SG_ERR_INVALID_ARG. Unlike other
 * out-parameters, dst holds unspecified bytes after a failure (the check
 * needs the bytes read into it; a second buffer would double the memory of
 * a large bake). */
sg_status sg_bake_file_read(const sg_bake_file *f, const char *tag, void *dst, uint64_t dst_size,
                            sg_error *err);

/* The payload of section tag in place, after checking its CRC as
 * sg_bake_file_read does: *data points into the map (64-byte aligned: the
 * map starts on a page) and stays valid until sg_bake_file_close; the
 * bytes are read-only. Only for a file opened with .map = 1 (else
 * SG_ERR_INVALID_ARG). A mapped file cut short in place (not replaced by
 * rename, as our writers do) would fault on access: a view first checks
 * that the file still has its size. *data only on SG_OK. */
sg_status sg_bake_file_view(const sg_bake_file *f, const char *tag, const void **data, sg_error *err);

/* 1 if the file at path begins with the magic of kind (a file of that
 * kind, maybe damaged past its first 8 bytes); 0 if it does not, cannot
 * be read, or is missing. Reads 8 bytes, checks nothing else. */
int sg_bake_file_has_magic(const char *path, sg_bake_kind kind);

/* Closes the file (and unmaps it); NULL is a no-op. */
void sg_bake_file_close(sg_bake_file *f);

#endif
