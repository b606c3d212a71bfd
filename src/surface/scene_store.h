/* scene_store.h — a built scene as flat arrays and back, for the world file
 * (render/world_file.h).
 *
 * What it does: sg_scene_store_of lists what sg_scene_create computed — the
 * point set, the kd-tree and its per-leaf splat arrays (MLS, disks), or the
 * implicit surface octree (ISO) — as named arrays plus a block of scalars
 * (the desc with its defaults, counts, build facts). sg_scene_from_store
 * puts a scene together again over such arrays WITHOUT copying them: the
 * scene borrows them (a read-only map of the world file), so a loaded scene
 * holds the very bytes the built one held and answers every query with the
 * same bits. Or the hybrid point/triangle hierarchy (hybrid.h): its node
 * bundles and node colours, the triangles in leaf order with their input
 * indices, the vertex positions, normals and colours. Only light sites
 * are recomputed, not stored: the ISO's (a pass over the leaves,
 * sg_iso_sites_create) and the hybrid's (a pass over vertices and nodes,
 * sg_hybrid_sites_create); both deterministic, so the same bits.
 * The build's wall time is stored as 0 (a loaded scene's info says 0 s):
 * it is the one value two builds of a scene differ in, so the store, and
 * the world file, are a function of the scene.
 *
 * What it does NOT do: files, checksums, hashes (world_file.c does those);
 * byte order (host bytes, like the container: little-endian hosts).
 *
 * Validation: bytes from a file never reach an assert. sg_scene_from_store
 * checks every count against the scalars, the desc's enums and ranges, the
 * point set (sg_pointset_validate: finite, radius > 0, unit normals; and
 * finite colours), every kd-tree node (children after their parent, each
 * reached once, depth within SG_SCENE_MAX_KD_DEPTH, leaf numbers in range,
 * split planes not NaN), leaf_first (from 0, non-decreasing, ending at the
 * reference count), every reference (< splat count), that the per-leaf
 * splat arrays are exactly the gather of the point set by the references
 * (bit for bit, so they hold no NaN either), leaf boxes without NaN, and
 * for the ISO every node (masks consistent, children after their parent,
 * each reached once, within max_depth, ranges inside the arrays) and leaf
 * (corners and splat in range) and its scalars (finite, unit = edge /
 * 2^max_depth); for the hybrid (no point set) the branching factor
 * (equal to this build's SG_STREE_WIDTH), every bundle (the root bundle's
 * lanes past 0 empty; each other bundle reached from exactly one inner
 * lane of an earlier bundle, within SG_STREE_MAX_DEPTH; empty lanes with
 * NaN radius and the empty child word, others with a finite centre, a
 * finite radius > 0 and a child word that is an earlier-reached bundle or
 * a leaf range inside the triangles), the node, leaf and depth counts
 * against the bundles, every triangle's vertex ids (< vertex count) and
 * non-zero area, its input index (< input triangles), positions and
 * colours finite, and its scalars (self epsilon, counts, info). Not
 * checked: that each sphere really holds its triangles (a wrong one misses
 * hits, never reads out of bounds). Any failure is SG_ERR_CORRUPT naming
 * label, the array and
 * the element: "w.sgworld: model 0: kd-tree node 17: child 9 is not after
 * its parent".
 *
 * Lifetime: the arrays passed to sg_scene_from_store must outlive the
 * scene; sg_scene_destroy frees only what the scene allocated itself.
 */
#ifndef SG_SURFACE_SCENE_STORE_H
#define SG_SURFACE_SCENE_STORE_H

#include <stdint.h>

#include "core/error.h"
#include "surface/scene.h"

/* Every array a scene may hold; which ones a surface uses: MLS all of
 * POINTS..SOA_KEY but the ISO's, DISK the same without SOA_KEY, ISO the
 * point set and ISO_*, HYBRID only HY_* (HY_NODE_COLOR and HY_COLOR when
 * the mesh had colours, HY_NORMAL unless flat shaded, HY_LATTICE when a
 * triangle has a lattice of light sites). */
typedef enum sg_scene_array_id {
    SG_SA_PX, SG_SA_PY, SG_SA_PZ, SG_SA_NX, SG_SA_NY, SG_SA_NZ, SG_SA_RADIUS, SG_SA_AR, SG_SA_AG,
    SG_SA_AB,                                                         /* point set, count = splats  */
    SG_SA_KD_NODES, SG_SA_KD_LEAF_FIRST, SG_SA_KD_REFS, SG_SA_KD_LEAF_BOUNDS, /* sg_kdtree          */
    SG_SA_SOA_PX, SG_SA_SOA_PY, SG_SA_SOA_PZ, SG_SA_SOA_NX, SG_SA_SOA_NY, SG_SA_SOA_NZ, SG_SA_SOA_R,
    SG_SA_SOA_INV_R, SG_SA_SOA_ID, SG_SA_SOA_KEY,                     /* sg_splat_soa, count = refs */
    SG_SA_ISO_NODES, SG_SA_ISO_LEAVES, SG_SA_ISO_CF, SG_SA_ISO_CN,   /* the octree (iso_int.h)     */
    SG_SA_HY_BUNDLES, SG_SA_HY_NODE_COLOR,                           /* sg_stree (sphere_tree.h)   */
    SG_SA_HY_TRI, SG_SA_HY_TRI_ID, SG_SA_HY_POS, SG_SA_HY_NORMAL, SG_SA_HY_COLOR, /* hybrid_int.h */
    SG_SA_HY_LATTICE,                                                /* hybrid_int.h invariant 4 */
    SG_SA_COUNT
} sg_scene_array_id;

/* Scalar type of an array's elements (each item is `per` of them). */
typedef enum sg_store_elem {
    SG_STORE_F32 = 0,
    SG_STORE_U32 = 1,
    SG_STORE_U16 = 2 /* also int16 */
} sg_store_elem;

typedef struct sg_scene_array_spec {
    char code[3];       /* 2 printable characters naming the array ("PX") */
    sg_store_elem elem; /* element type                                    */
    uint32_t per;       /* elements per item (kd node: 2 x u32, box: 6 x f32) */
} sg_scene_array_spec;

/* Spec of array id (id < SG_SA_COUNT). */
const sg_scene_array_spec *sg_scene_array_spec_of(sg_scene_array_id id);

/* Bytes of one element of type e (4 or 2). */
uint32_t sg_store_elem_size(sg_store_elem e);

#define SG_SCENE_SCALARS 128 /* u64 slots; floats as their bits (scene_store.c) */

typedef struct sg_scene_store {
    uint64_t scalars[SG_SCENE_SCALARS];     /* desc, counts, build facts      */
    const void *data[SG_SA_COUNT];          /* NULL: not held by this surface */
    uint64_t items[SG_SA_COUNT];            /* items (x per elements) each    */
} sg_scene_store;

/* Views of sc's arrays (valid while sc lives) and its scalars in *out. */
void sg_scene_store_of(const sg_scene *sc, sg_scene_store *out);

/* A scene over in's arrays (borrowed, see Lifetime), after the checks of
 * Validation; label starts every message. query (may be NULL: as stored)
 * gives the settings that steer queries, not the build, and are no part of
 * a scene's hash: its iso_lod replaces the stored one, so a loaded scene
 * traces as one built with query's desc. Arrays must be 64-byte aligned
 * (asserted: the caller's, not the file's). SG_ERR_CORRUPT,
 * SG_ERR_NOMEM; *out only on SG_OK. */
sg_status sg_scene_from_store(const sg_scene_store *in, const char *label, const sg_scene_desc *query,
                              sg_scene **out, sg_error *err);

#endif
