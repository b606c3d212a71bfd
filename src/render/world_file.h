/* world_file.h — the built world saved once and loaded by every program
 * (issue 16): the .sgworld file.
 *
 * What it does: sg_world_save writes what sg_world_create built for each
 * model — the point set (positions, normals, radii, colours), the surface
 * with its hierarchy (MLS and disks: the SAH kd-tree and its per-leaf
 * splat arrays with the MLS layer keys; ISO: the octree with its corners;
 * hybrid: no point set, but the sphere tree's node bundles and node
 * colours, the triangles in leaf order, the vertices, vertex normals and
 * colours),
 * the surface options and build facts, and the material — into the
 * .sgbake container (bake/bake_file.h, kind SG_BAKE_KIND_WORLD: versioned
 * header, CRC-32 per section, written to a temporary file and renamed).
 * sg_world_load maps the file read-only and builds scenes that use the
 * mapped arrays in place (surface/scene_store.h), so a loaded world holds
 * the very bytes a built one holds: the same hits, renders and bakes, bit
 * for bit (tested with cmp on renders).
 *
 * What it does NOT do: store the environment map (loading an EXR and its
 * sampling tables is the scene's quick part, and a world stays valid for
 * any envmap): sg_world_load makes it from the scene file as
 * sg_world_create does. Nor does it hash the inputs' contents (see Fresh).
 *
 * Which world fits which scene:
 *  - scene hash = sg_scene_file_hash(sf, SG_SCENE_HASH_MODELS): model
 *    paths, transforms, point options, surface options, materials; the
 *    envmap, cameras and render settings do not count;
 *  - parameter hash = SG_WORLD_BUILDER_VERSION and the sphere tree's
 *    width (SG_STREE_WIDTH) hashed: the version is raised whenever a
 *    build (sampling, kd-tree, ISO, sphere tree, layer keys) or the
 *    layout of the stored arrays changes, so an old file is rebuilt
 *    instead of silently differing from a build (version 2: hybrid models
 *    stored, 128 scalars per model; 3: the ISO's layered corners);
 *  - input stamps: size and modification time (ns) of every file the
 *    models read (model files, the bunny asset), kept in the file. Not
 *    content hashes: hashing a 24M-point model costs as much as reading
 *    it, which is what the world file saves. A file rewritten with the
 *    same size within the file system's time resolution goes unnoticed;
 *    touch(1) it or delete the world.
 *
 * File layout (sections of the container, all in host = little-endian
 * bytes): "WRLD" u64[4] = {model count, SG_WORLD_BUILDER_VERSION, 0, 0};
 * "MATL" u32[10 x models] = per model type, albedo rgb, roughness,
 * specular, emission rgb (f32 bits), use_point_colors; "INPT" bytes = one
 * line per input "<size> <mtime s> <mtime ns> <path>\n"; per model m two
 * characters of array code + m in two base-62 digits ("PX00", "KN01"):
 * "HD" the scene's scalars (u64[SG_SCENE_SCALARS]) and each array of
 * scene_store.h its surface holds. At most SG_WORLD_MAX_MODELS models.
 *
 * Errors (messages name the file, and the model or section):
 *  SG_ERR_IO        cannot create, write, rename, open or read;
 *  SG_ERR_CORRUPT   truncated, a CRC mismatch, a missing section, arrays
 *                   inconsistent with each other, NaN or out-of-range
 *                   values (scene_store.h Validation);
 *  SG_ERR_UNSUPPORTED  a container version newer than this build;
 *  SG_ERR_INVALID_ARG  made for another scene (both hashes printed), by
 *                   another builder version, with inputs changed since
 *                   ("scan.ply changed: 1200 bytes, modified ... ; was
 *                   ..."), a bake file instead of a world file;
 *  SG_ERR_NOMEM.
 * A failed save leaves a file already at path as it was.
 *
 * Lifetime: a loaded world keeps the file open and mapped until
 * sg_world_destroy; replacing the file meanwhile (rename, as every writer
 * here does) is safe, truncating it in place is not.
 */
#ifndef SG_RENDER_WORLD_FILE_H
#define SG_RENDER_WORLD_FILE_H

#include <stddef.h>

#include "core/error.h"
#include "io/scene_file.h"
#include "render/world.h"

#define SG_WORLD_BUILDER_VERSION 4u /* raise when a build changes its output */
#define SG_WORLD_MAX_MODELS 160u    /* 25 sections per model (MLS) in 4096   */

/* The scene hash a world file of sf carries (see above). */
uint64_t sg_world_file_scene_hash(const sg_scene_file *sf);

/* Writes world w, built from sf, to path (atomically). */
sg_status sg_world_save(const sg_world *w, const sg_scene_file *sf, const char *path, sg_error *err);

/* Loads the world of sf from path, checking scene hash, builder version
 * and input stamps, then every section (CRC) and array (scene_store.h);
 * makes the envmap from sf. d may be NULL (progress and notes as
 * sg_world_create_desc). *out only on SG_OK. */
sg_status sg_world_load(const char *path, const sg_scene_file *sf, const sg_world_desc *d, sg_world **out,
                        sg_error *err);

/* Fresh: path holds a world file of sf (header, hashes and input stamps;
 * payloads are not read, so a damaged payload still counts as fresh and
 * fails in sg_world_load). Returns 1, or 0 with why filled (missing, other
 * scene, changed input, ...; why may be NULL). */
int sg_world_file_fresh(const char *path, const sg_scene_file *sf, char *why, size_t why_size);

/* Whether a world may be written to path: SG_OK when nothing is there or
 * the file there starts with the world file's magic (a world, maybe
 * damaged); SG_ERR_INVALID_ARG naming it otherwise (a bake, an image, a
 * scene: never replaced by a world, whatever --if-stale says). */
sg_status sg_world_file_replaceable(const char *path, sg_error *err);

#endif
