/* hybrid.h — a ray-traceable triangle mesh with level of detail: the hybrid
 * point/polygon hierarchy of Ye 2005 (PPRT).
 *
 * What it does: builds a bounding-sphere hierarchy over a mesh's triangles
 * (accel/sphere_tree.h) in which every node is also a point primitive
 * (centre, radius, mean normal and colour), and traces rays through it
 * nearest-first. A ray that carries a footprint (pixel cone: width at the
 * origin plus spread per unit distance) stops at a node whose diameter is
 * below `lod` footprints and hits it as a flat disk (the node's mean
 * normal, through its area-weighted centroid, clipped by its sphere)
 * instead of descending to its triangles. Only a node whose triangles all
 * face the same way along the ray is hit as a disk (no silhouette runs
 * through it, so level of detail never adds or removes outline), and a ray
 * that passes the disk descends as if the node were large, so level of
 * detail never opens holes. Without a footprint, or with lod = 0, every
 * hit is exact: watertight triangle intersection (math/triangle.h), the
 * nearest crossing in [tmin, tmax].
 * What it does not do: shading, materials, textures, instancing, updates
 * after create, quad or polygon input (triangulate first).
 *
 * Use:
 *     sg_hybrid_desc d = {0};                       zero = defaults
 *     sg_hybrid *h;
 *     if (sg_hybrid_create(&d, &mesh, &h, &err) != SG_OK) report(err.message);
 *     sg_footprint fp = sg_footprint_pinhole(cam.tan_half_fov, height, SG_HYBRID_LOD_DEFAULT);
 *     sg_hybrid_hit hit;
 *     if (sg_hybrid_intersect(h, &ray, &fp, &hit, &stats)) ... hit.p, hit.ns
 *     sg_ray shadow = sg_hybrid_spawn_ray(h, &hit, to_light, INFINITY);
 *     sg_footprint sfp = sg_hybrid_spawn_footprint(&fp, &hit, 0.0f);
 *     int dark = sg_hybrid_occluded(h, &shadow, &sfp, &stats);
 *     sg_hybrid_destroy(h);
 *
 * Rays: ray.h. dir must be unit length; flags SG_RAY_FRONT_ONLY /
 * SG_RAY_BACK_ONLY keep only crossings that meet the counter-clockwise
 * side / the other side (the mesh's triangle winding decides the side,
 * never a stored normal); self_n / self_r name the surface a spawned ray
 * leaves (sg_hybrid_spawn_ray sets all three).
 *
 * Self-intersection rule (documented, tested): a ray spawned from a hit
 * gets the seamless front/back expectation of ray.h from the side its
 * direction takes of the hit's geometric normal, so the triangle it
 * leaves, which it can only meet from behind, is ignored without any
 * offset; and it names that surface with self_r = 8 FLT_EPSILON times the
 * scene's extent (the rounding of a hit point, relative to the scene:
 * DESIGN.md) for a triangle hit, or the node's diameter for a level-of-detail
 * hit, so that crossings nearer than that whose normal is within 25
 * degrees of the hit's (the same patch; a disk lies up to a diameter off
 * its triangles) are ignored. A real occluder that close, at a crease or a
 * concave corner, turns by more than 25 degrees and is still hit.
 *
 * Light sites (for a bake): the mesh's vertices, then the lattice sites,
 * ids 0 .. vertex_count - 1 (sg_hybrid_info.vertex_count counts both),
 * followed by the hierarchy's node slots, ids vertex_count + node id. A
 * triangle hit interpolates its three vertices with its barycentrics
 * (continuous across shared edges, so no seams); a level-of-detail hit
 * reads its node alone. With desc.site_spacing s > 0 a triangle whose
 * second-longest edge e exceeds s carries its own lattice of sites
 * instead of its vertices: the points of barycentrics (i / n, j / n),
 * i + j <= n, n = ceil(e / s) (so the small triangles' edges are within s
 * but the one along the longest edge, which is within 2 s; a right
 * triangle of legs e gets cells of e / n exactly), each cell split in two
 * as a gridded plane's cells are; a hit there interpolates the three sites of its small triangle.
 * So a big flat triangle (a ground, a wall: a few triangles to trace)
 * holds its light at the resolution the bake needs, and a plane made of
 * two such triangles reads its light as the same plane made of n x n
 * cells would (its sites sit 3e-3 of a cell inside their triangle, so
 * that a site on an edge where two walls meet does not start the bake's
 * rays on the other wall's plane). Lattice sites on an edge two triangles share are computed
 * from that edge on each side (equal positions to rounding). sg_hybrid_hit_sites gives ids and weights summing
 * to 1. Node ids are dense in [0, node_slots); a few slots are empty
 * (sg_hybrid_site returns 0 for them) so that ids stay a plain index.
 *
 * Ownership: create copies what it needs from the mesh, which may be freed
 * afterwards; destroy frees everything. Thread-safety: queries on a built
 * hierarchy are thread-safe (const); stats pointers must be per-thread.
 * Determinism: the same mesh and desc give the same hierarchy, bit for
 * bit, whatever the thread count (sg_hybrid_layout_hash), and a query is a
 * pure function of the hierarchy and its arguments.
 */
#ifndef SG_SURFACE_HYBRID_H
#define SG_SURFACE_HYBRID_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "io/mesh.h"
#include "math/ray.h"

typedef struct sg_hybrid sg_hybrid; /* opaque */

enum sg_hybrid_flags {
    SG_HYBRID_CULL_BACKFACES = 1u << 0, /* rays with SG_RAY_ANY_FACE see front faces only
                                           (Ye §4.4); nodes whose triangles all face away
                                           are skipped whole (normal cones)          */
    SG_HYBRID_FLAT_SHADING = 1u << 1    /* shading normal = geometric normal; vertex
                                           normals are neither kept nor computed      */
};

typedef enum sg_hybrid_traversal {
    SG_HYBRID_TRAVERSE_STACK = 0, /* ordered stack, nearest child on top (default:
                                     measured faster, docs/hybrid.md)            */
    SG_HYBRID_TRAVERSE_HEAP = 1   /* Ye's heap ordered by ray-sphere distance (§3.3) */
} sg_hybrid_traversal;

/* Creation options; zero means the documented default. */
typedef struct sg_hybrid_desc {
    uint32_t flags;                /* sg_hybrid_flags; default 0                    */
    sg_hybrid_traversal traversal; /* default SG_HYBRID_TRAVERSE_STACK              */
    int leaf_max;                  /* triangles per leaf, 1..8; default 8           */
    int threads;                   /* build threads; 0 = OpenMP default             */
    float site_spacing;            /* light sites about this far apart: a triangle
                                      whose second-longest edge is longer gets a
                                      lattice of light sites (header); 0 = the
                                      vertices are the only point sites (default) */
    const char *name;              /* names the mesh in messages (a file path);
                                      default "mesh"                              */
} sg_hybrid_desc;

/* A ray's footprint: the width, in world units, that one pixel (or sample)
 * covers at distance t along the ray is width + spread * t. A pinhole
 * camera's primary rays have width 0 and spread = the pixel's angle; a ray
 * differential or cone gives the same two numbers. lod is the threshold in
 * pixels: a node of radius R at distance t (its centre projected on the
 * ray) is hit as a point when 2 R < lod * (width + spread * t). lod <= 0,
 * or any field not finite or negative: full detail. */
typedef struct sg_footprint {
    float width;  /* world units, >= 0                              */
    float spread; /* world units per unit t (radians), >= 0         */
    float lod;    /* pixels; SG_HYBRID_LOD_DEFAULT; 0 = full detail  */
} sg_footprint;

#define SG_HYBRID_LOD_DEFAULT 1.0f

/* The footprint of a pinhole camera's primary rays through an image
 * `height` pixels tall whose vertical field of view has tangent of half
 * angle `tan_half_fov` (sg_camera.tan_half_fov): one pixel spans
 * 2 tan_half_fov / height per unit distance (at the image centre; the
 * edges of a 40-degree view are 6% further, which only makes the edge a
 * little more detailed). */
static inline sg_footprint sg_footprint_pinhole(float tan_half_fov, int height, float lod)
{
    sg_footprint f = {0.0f, height > 0 ? 2.0f * tan_half_fov / (float)height : 0.0f, lod};
    return f;
}

typedef struct sg_hybrid_hit {
    float t;           /* distance along the ray                              */
    sg_vec3 p;         /* hit point, world space: on the triangle (barycentric
                          combination of its vertices) or on the node's disk  */
    sg_vec3 ng;        /* unit geometric normal: the triangle's counter-clockwise
                          side, or the node's mean normal                      */
    sg_vec3 ns;        /* unit shading normal: the vertex normals interpolated
                          (ng with SG_HYBRID_FLAT_SHADING), or the node's mean
                          normal                                              */
    uint32_t triangle; /* input index of the triangle hit; SG_INVALID_ID for a
                          node hit or a miss                                   */
    uint32_t node;     /* node id of a level-of-detail hit; else SG_INVALID_ID */
    uint32_t vertex[3]; /* the triangle's vertex ids (leaf hit); else SG_INVALID_ID */
    uint32_t slot;     /* the triangle's position in leaf order (what
                          hybrid_int.h's tri[] is indexed by); else
                          SG_INVALID_ID                                      */
    float b1, b2;      /* barycentric weights of the triangle's 2nd and 3rd
                          vertex (the 1st has 1 - b1 - b2); 0 for a node hit   */
    int back;          /* 1 when the ray met the side ng points away from      */
} sg_hybrid_hit;

/* Counters a traversal adds to (once per ray). */
typedef struct sg_hybrid_stats {
    uint64_t rays;       /* rays traced                                        */
    uint64_t pops;       /* nodes taken from the stack or heap and processed   */
    uint64_t spheres;    /* ray-sphere tests (bundle lanes, empty ones included) */
    uint64_t triangles;  /* ray-triangle tests                                 */
    uint64_t lod_tests;  /* level-of-detail disk tests                         */
    uint64_t lod_hits;   /* rays whose nearest hit is a node                   */
    uint64_t culled;     /* nodes skipped whole: all their triangles face away  */
    uint64_t hits;       /* rays that hit                                      */
    uint64_t heap_overflows; /* heap traversals redone with the stack (heap full) */
} sg_hybrid_stats;

static inline void sg_hybrid_stats_add(sg_hybrid_stats *a, const sg_hybrid_stats *b)
{
    a->rays += b->rays;
    a->pops += b->pops;
    a->spheres += b->spheres;
    a->triangles += b->triangles;
    a->lod_tests += b->lod_tests;
    a->lod_hits += b->lod_hits;
    a->culled += b->culled;
    a->hits += b->hits;
    a->heap_overflows += b->heap_overflows;
}

/* Build-time facts, for reports and benchmarks. */
typedef struct sg_hybrid_info {
    size_t input_triangles;    /* triangles in the mesh                          */
    size_t triangle_count;     /* triangles traced (input minus degenerate)      */
    size_t degenerate_count;   /* zero-area triangles left out (never hit)       */
    size_t vertex_count;       /* mesh vertices + lattice sites                  */
    size_t lattice_triangles;  /* triangles with a lattice of light sites        */
    size_t lattice_sites;      /* their sites (counted in vertex_count)          */
    size_t node_count;         /* hierarchy nodes (inner + leaf)                 */
    size_t leaf_count;
    size_t node_slots;         /* node ids are < node_slots                      */
    int width;                 /* branching factor (children per node)           */
    int leaf_max;              /* triangles per leaf at most                     */
    int depth;                 /* nodes on the longest root-to-leaf path         */
    size_t memory_bytes;       /* everything the hierarchy holds                 */
    size_t memory_nodes;       /* node bundles (spheres, children, point attributes) */
    size_t memory_triangles;   /* vertex ids in leaf order + input triangle index */
    size_t memory_vertices;    /* positions                                      */
    size_t memory_normals;     /* vertex normals (oct, 4 bytes each)             */
    size_t memory_colors;      /* vertex and node colours                        */
    size_t memory_lattice;     /* lattice first site and size per triangle       */
    double bytes_per_triangle; /* memory_bytes / triangle_count                  */
    double build_seconds;      /* wall time of sg_hybrid_create                  */
    sg_aabb bounds;            /* box of the traced triangles' vertices          */
    float diagonal;            /* bounds diagonal: the unit of every epsilon     */
} sg_hybrid_info;

/* Builds the hierarchy over mesh's triangles (positions required; normals
 * and colours used when present; radii ignored). Errors, each naming the
 * mesh (desc->name) and the element: SG_ERR_INVALID_ARG for no triangles,
 * a vertex index out of range, a position or colour that is not finite, a
 * vertex normal that is not finite or zero, a mesh whose every triangle
 * has zero area, a bad desc field; SG_ERR_UNSUPPORTED above 2^28
 * triangles; SG_ERR_NOMEM. Documented behaviour, not errors: zero-area
 * triangles (collinear or repeated vertices) are left out and counted
 * (info.degenerate_count); non-manifold edges (three or more triangles on
 * one edge), open boundaries, duplicated triangles and inconsistent
 * windings are traced as given: each triangle is hit on its own, and a
 * ray through an edge hits one of the triangles on it. Missing vertex
 * normals are computed as the area-weighted mean of the vertex's
 * triangles' normals. *out is written only on SG_OK. */
sg_status sg_hybrid_create(const sg_hybrid_desc *desc, const sg_mesh *mesh, sg_hybrid **out, sg_error *err);

/* NULL is a no-op. */
void sg_hybrid_destroy(sg_hybrid *h);

/* Nearest accepted crossing in [ray->tmin, ray->tmax]: a triangle, or, when
 * fp asks for level of detail, a node disk (header). fp may be NULL (full
 * detail). Returns 1 and fills *hit; returns 0 on a miss, with
 * hit->triangle = hit->node = SG_INVALID_ID. Ties at equal t go to the
 * triangle first in leaf order (so the two traversals agree bit for bit).
 * stats may be NULL. */
int sg_hybrid_intersect(const sg_hybrid *h, const sg_ray *ray, const sg_footprint *fp, sg_hybrid_hit *hit,
                        sg_hybrid_stats *stats);

/* sg_hybrid_intersect for the rays of `mask` (bit r: rays[r]; bits above 3
 * ignored) in one traversal: hits[r] is what sg_hybrid_intersect(h,
 * &rays[r], fp ? &fp[r] : NULL, ...) writes, bit for bit (any rays; a
 * quad of neighbouring camera rays shares most of the walk). Returns the
 * mask of rays that hit; hits outside mask are not written. fp: NULL or
 * one footprint a ray. stats (may be NULL) count the packet's work: pops
 * and sphere tests once per packet, triangle tests once per ray. */
unsigned sg_hybrid_intersect4(const sg_hybrid *h, const sg_ray rays[4], unsigned mask, const sg_footprint *fp,
                              sg_hybrid_hit hits[4], sg_hybrid_stats *stats);

/* sg_hybrid_intersect4 for up to sixteen rays (bit r of mask: rays[r]; a
 * 4x4 block of camera rays shares more of the walk than a quad): the
 * same hits, bit for bit. Only the entries of rays, fp and hits whose bit
 * is set are read or written, so shorter arrays may be passed with a
 * mask that fits them. */
unsigned sg_hybrid_intersect16(const sg_hybrid *h, const sg_ray *rays, unsigned mask, const sg_footprint *fp,
                               sg_hybrid_hit *hits, sg_hybrid_stats *stats);

/* 1 if any accepted crossing lies in [tmin, tmax] (shadow rays); the same
 * acceptance as sg_hybrid_intersect, in no particular order. */
int sg_hybrid_occluded(const sg_hybrid *h, const sg_ray *ray, const sg_footprint *fp, sg_hybrid_stats *stats);

void sg_hybrid_get_info(const sg_hybrid *h, sg_hybrid_info *info);

/* A ray leaving hit in direction dir (unit), by the self-intersection rule
 * of the header: origin hit->p, tmin 0, tmax as given. */
sg_ray sg_hybrid_spawn_ray(const sg_hybrid *h, const sg_hybrid_hit *hit, sg_vec3 dir, float tmax);

/* The footprint of a ray spawned at hit by a ray with footprint fp (NULL:
 * full detail): the width fp reached at hit->t, growing by `spread` per
 * unit distance (0 for a shadow ray towards a point; a glossy lobe's or a
 * photon's angle otherwise), the same lod. */
sg_footprint sg_hybrid_spawn_footprint(const sg_footprint *fp, const sg_hybrid_hit *hit, float spread);

/* Light sites of a hit (header): writes at most max ids and weights and
 * returns the count (3 for a triangle, 1 for a node, 0 for a miss). The
 * weights are >= 0 and sum to 1 within rounding (barycentrics clamped to
 * [0, 1] and renormalised); with max < 3 the largest are kept and
 * renormalised. */
int sg_hybrid_hit_sites(const sg_hybrid *h, const sg_hybrid_hit *hit, uint32_t *ids, float *weights, int max);

/* vertex_count + node_slots. */
size_t sg_hybrid_site_count(const sg_hybrid *h);

/* Position and unit normal of site id: a vertex's position and normal (its
 * own or the computed mean; zero for a vertex no traced triangle uses, or
 * with SG_HYBRID_FLAT_SHADING), or a node's disk centre and mean normal.
 * Returns 0 for an id out of range or an empty node slot. */
int sg_hybrid_site(const sg_hybrid *h, uint32_t id, sg_vec3 *pos, sg_vec3 *normal);

/* Radius of node `node`'s bounding sphere (its disk's radius as a point,
 * and its reach as a light site); 0 for an id out of range or an empty
 * slot. */
float sg_hybrid_node_radius(const sg_hybrid *h, uint32_t node);

/* Colour at a hit: the vertex colours interpolated, or the node's
 * area-weighted mean. Returns 0 (and leaves *rgb) when the mesh had no
 * colours or the hit is a miss. */
int sg_hybrid_hit_color(const sg_hybrid *h, const sg_hybrid_hit *hit, sg_vec3 *rgb);

/* FNV-1a over every array of the hierarchy: equal for bit-identical
 * builds (tests, and checks across thread counts). */
uint64_t sg_hybrid_layout_hash(const sg_hybrid *h);

#endif
