/* scene.h — a ray-traceable surface over a point set (or a triangle mesh).
 *
 * What it does: builds a SAH kd-tree over the splats' boxes (or, for the
 * ISO, an octree) and intersects rays with one of three surface models
 * through one interface:
 *   SG_SURFACE_MLS   the implicit surface of Adamson & Alexa as used by Wald &
 *                    Seidel 2005: F(x) = (W(x) x - sum w_i p_i) . sum w_i n_i,
 *                    found by k regular samples per leaf cell with sign change
 *                    and linear interpolation; smooth normal sum w_i n_i.
 *   SG_SURFACE_DISK  flat disk splats; the hits within a small depth window
 *                    around the nearest one are blended (Kashyap 2010, §3.5
 *                    "deep blending") for position and normal.
 *   SG_SURFACE_ISO   the MLS surface sampled into an implicit surface
 *                    octree (Kashyap 2010 ch. 4, iso.h): no kd-tree, one
 *                    trilinear patch per leaf; its light sites are the
 *                    octree's corners (iso_sites.h), not the splats.
 *   SG_SURFACE_HYBRID a triangle mesh in Ye's bounding-sphere hierarchy
 *                    (Ye 2005, hybrid.h), made by sg_scene_create_mesh:
 *                    exact watertight triangles, inner nodes hit as disks
 *                    when under desc.hybrid_lod ray footprints (ray.spread);
 *                    light sites at its vertices and nodes (hybrid_scene.h).
 * No leaks (issue 12): a hit's normal faces the ray the way its crossing
 * says (entry: dot(dir, n) < 0, exit: > 0); near folds and thin walls the
 * MLS field is taken per group of splats facing the ray the same way, so
 * a wall thinner than a splat radius stops rays from either side
 * (mls.h); a ray that accepts either face (a camera ray) meets a surface
 * from behind only from inside the model (mls.c front_out; for disks,
 * nearest() in scene.c). Measured in docs/surfaces.md (bench_leaks).
 * What it does not do: shading, materials, instancing, dynamic updates.
 *
 * Use:
 *     sg_scene_desc d = { .model = SG_SURFACE_MLS };   zero = defaults
 *     sg_scene *s; if (sg_scene_create(&d, &points, &s, &err) != SG_OK) ...
 *     sg_hit h; sg_scene_intersect(s, &ray, &h, &stats);
 *     sg_scene_destroy(s);
 *
 * Ownership: create copies what it needs from the pointset; the pointset may
 * be freed afterwards. Thread-safety: queries on a built scene are
 * thread-safe (const); stats pointers must be per-thread.
 */
#ifndef SG_SURFACE_SCENE_H
#define SG_SURFACE_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "math/ray.h"
#include "points/pointset.h"
#include "surface/sites.h"

typedef struct sg_scene sg_scene; /* opaque */

typedef enum sg_surface_model {
    SG_SURFACE_MLS = 0,  /* implicit moving-least-squares surface (default) */
    SG_SURFACE_DISK = 1, /* disk splats with deep blending                  */
    SG_SURFACE_ISO = 2,  /* the MLS surface sampled into an implicit surface
                            octree (iso.h); light sites at its corners     */
    SG_SURFACE_HYBRID = 3 /* a triangle mesh in Ye's sphere hierarchy with
                            level of detail (hybrid.h); built from a mesh
                            by sg_scene_create_mesh; light sites at its
                            vertices and nodes (hybrid_scene.h)           */
} sg_surface_model;

typedef enum sg_kernel {
    SG_KERNEL_HAT = 0,      /* W(r) = 1 - r on [0,1) (Wald & Seidel)          */
    SG_KERNEL_GAUSSIAN = 1  /* W(r) = exp(-4 r^2) - exp(-4), truncated at 1   */
} sg_kernel;

/* kd-tree refinements of Wald & Seidel 2005 §3.4, as flags to turn OFF, so
 * that a zeroed desc uses all of them. Shrinking samples the MLS field, so
 * it applies to SG_SURFACE_MLS only; encouraged splits only pay off when
 * the small cells they make are shrunk, so they are used only with it. */
enum sg_kd_disable {
    SG_KD_NO_SHRINK = 1u << 0,    /* §3.4.1 cell shrinking by sampled F      */
    SG_KD_NO_ENCOURAGE = 1u << 1, /* §3.4.2 encouraged splits E(n)           */
    SG_KD_NO_COLLAPSE = 1u << 2,  /* §3.4.3 post-collapse of empty siblings  */
    SG_KD_NO_REFINEMENTS = 7u
};

typedef struct sg_scene_desc {
    sg_surface_model model;    /* default SG_SURFACE_MLS                        */
    sg_kernel kernel;          /* MLS weight; default SG_KERNEL_HAT             */
    uint32_t kd_disable;       /* sg_kd_disable flags; default 0 (all on)       */
    int samples_per_cell;      /* MLS k samples per leaf interval; default 8    */
    float max_sample_spacing;  /* MLS: more samples when the spacing would exceed
                                  this many smallest-radii; default 0.5;
                                  negative: exactly samples_per_cell (paper)    */
    int max_depth;             /* kd-tree depth limit; default 48               */
    float blend_depth;         /* DISK: blending window, in units of the hit
                                  splat's radius; default 0.5                  */
    int threads;               /* build threads; 0 = OpenMP default             */
    float iso_tolerance;       /* ISO: patch error allowed, in smallest radii;
                                  default 0.05 (iso.h)                         */
    int iso_max_depth;         /* ISO: deepest leaf level; default 16           */
    float iso_leaf_radii;      /* ISO: largest leaf edge in smallest radii
                                  (rule a, iso.h); default 2                   */
    float iso_lod;             /* ISO: level-of-detail threshold of camera rays,
                                  pixels; default 1; negative: off (iso.h)     */
    float hybrid_lod;          /* HYBRID: a node whose diameter is below this
                                  many ray footprints (sg_ray.spread) is hit
                                  as a point; default SG_HYBRID_LOD_DEFAULT
                                  (1 pixel); negative: full detail always    */
    float hybrid_site_spacing; /* HYBRID: light sites about this far apart
                                  (world units): triangles larger than this
                                  carry a lattice of sites (hybrid.h
                                  site_spacing); 0 = the default: at the
                                  vertices only, but the builtin ground and
                                  room as 2 triangles a rectangle with
                                  lattices at the spacing their "points"
                                  give (world.c); negative: vertices only,
                                  the ground and room gridded as before
                                  stops 30 and 31                          */
} sg_scene_desc;

/* Build-time facts, for reports and benchmarks. */
typedef struct sg_scene_info {
    size_t splat_count;     /* splats in the scene                         */
    size_t node_count;      /* kd-tree nodes (inner + leaf)                */
    size_t leaf_count;      /* leaves, empty ones included                 */
    size_t empty_leaf_count;
    size_t splat_refs;      /* splat references over all leaves            */
    size_t keyed_count;     /* MLS: splats with a layer key (an opposed
                               layer within reach: thin walls, folds)     */
    size_t memory_bytes;    /* everything the scene holds                  */
    int depth;              /* deepest leaf                                */
    double build_seconds;   /* wall time of sg_scene_create                */
    sg_aabb bounds;         /* box of all splat supports                   */
    float diagonal;         /* bounds diagonal: the unit of every epsilon  */
} sg_scene_info;

sg_status sg_scene_create(const sg_scene_desc *desc, const sg_pointset *points,
                          sg_scene **out, sg_error *err);

/* A scene over a triangle mesh: SG_SURFACE_HYBRID (the only model that
 * takes one; desc->model must say so). name labels the mesh in messages
 * (a path; NULL: "mesh"). Errors as sg_hybrid_create (no triangles, an
 * index out of range, a position that is not finite, ...). The mesh may
 * be freed afterwards. sg_scene_points of such a scene is empty; its
 * info's splat_count is the vertex count. */
struct sg_mesh;
sg_status sg_scene_create_mesh(const sg_scene_desc *desc, const struct sg_mesh *mesh, const char *name,
                               sg_scene **out, sg_error *err);

/* NULL is a no-op. */
void sg_scene_destroy(sg_scene *scene);

/* Nearest accepted surface crossing in [ray->tmin, ray->tmax]. Returns 1 and
 * fills *hit on a hit; returns 0 and sets hit->splat = SG_INVALID_ID on a
 * miss. stats may be NULL. */
int sg_scene_intersect(const sg_scene *scene, const sg_ray *ray, sg_hit *hit,
                       sg_ray_stats *stats);

/* Up to four rays at once, for coherent rays such as a 2 x 2 quad of
 * camera rays: ray r (bit r of mask set) gets exactly the hit
 * sg_scene_intersect would give it, bit for bit (tested). Rays with the
 * same origin and the same direction signs share one kd-tree traversal
 * (MLS surface; each ray still decides at each node as it would alone);
 * on the ISO rays with the same direction signs share one octree
 * traversal (sg_iso_intersect4); others, and disk surfaces, are traced one
 * by one. Returns the mask of
 * the rays that hit; a ray of mask that misses gets splat = SG_INVALID_ID;
 * hits[r] of rays outside mask is left alone. stats counts per ray. */
unsigned sg_scene_intersect4(const sg_scene *scene, const sg_ray rays[4], unsigned mask, sg_hit hits[4],
                             sg_ray_stats *stats);

/* sg_scene_intersect4 for up to sixteen rays (bits 0-15 of mask), e.g. a
 * 4 x 4 block of camera rays: the same hits, bit for bit. The hybrid
 * traces them in one walk (sg_hybrid_intersect16), the ISO in one
 * traversal per direction octant (sg_iso_intersect16); the others as four
 * quads (sg_scene_intersect4). Only the entries of rays and hits whose
 * bit is set are read or written. */
unsigned sg_scene_intersect16(const sg_scene *scene, const sg_ray *rays, unsigned mask, sg_hit *hits,
                              sg_ray_stats *stats);

/* 1 if any accepted crossing lies in [tmin, tmax] (shadow rays). */
int sg_scene_occluded(const sg_scene *scene, const sg_ray *ray, sg_ray_stats *stats);

/* Light sites (sites.h): where a bake stores light on this surface. For
 * MLS and disk surfaces they are the splats, site i = splat i. The view
 * lives as long as the scene. */
const sg_sites *sg_scene_sites(const sg_scene *scene);

/* The sites around a hit and their normalised interpolation weights,
 * summing to 1 and continuous across neighbouring hits, so per-site data
 * (baked light) interpolates without seams. MLS and disks: the splats with
 * w_i = K(|p - p_i| / r_i) / sum (the scene's MLS kernel), from the leaf
 * the hit was found in: that leaf holds every splat whose support covers
 * p, so the weights are those of the smooth surface. Writes at most max
 * entries (the largest weights) and returns the count; falls back to the
 * hit's dominant splat with weight 1. */
int sg_scene_hit_sites(const sg_scene *scene, const sg_hit *hit, uint32_t *ids, float *weights, int max);

/* A hit at site `site` (t = 0, its position and normal, no leaf), naming
 * the splat that gives the site its colour and its self-test radius: the
 * hit a bake spawns a site's rays from. MLS and disks: splat = site. */
sg_hit sg_scene_site_hit(const sg_scene *scene, uint32_t site);

/* The hit's dominant site: the one with the largest weight (MLS and
 * disks: hit->splat). Per-site data of what a ray hit (a bake's transport
 * rows) is indexed by it. */
uint32_t sg_scene_hit_site(const sg_scene *scene, const sg_hit *hit);

/* Sites whose light derives from other sites' get it recomputed from
 * theirs: values holds `stride` floats per site (sites.h order; stride <=
 * 16). The hybrid's node sites become the area-weighted mean of their
 * triangles' vertex values (hybrid_scene.h), Ye's filtered attributes
 * for level-of-detail hits; the ISO's node sites the area-weighted mean
 * of their leaves' corner values (iso_sites.h); the point models have
 * none (no-op). The bake runs it on its final light. */
void sg_scene_filter_sites(const sg_scene *scene, float *values, size_t stride);

/* The scalar reference of sg_scene_hit_sites: every splat of the leaf
 * weighed, where sg_scene_hit_sites first drops, 8 at a time, the splats
 * whose squared distance ratio is clearly >= 1. Same result bit for bit
 * (tested); for tests. */
int sg_scene_hit_sites_reference(const sg_scene *scene, const sg_hit *hit, uint32_t *ids, float *weights,
                                 int max);

/* The albedo the model's points give a hit (its splat's, linear RGB);
 * (1, 1, 1) for a hit that names no splat. Material inputs come from here,
 * never from the point set directly. */
sg_vec3 sg_scene_hit_albedo(const sg_scene *scene, const sg_hit *hit);

/* sg_scene_hit_albedo(scene, hit), bit for bit, given what
 * sg_scene_hit_sites(scene, hit, ids, weights, max) returned with any max
 * >= 3 (n sites): a hybrid hit's albedo is the blend of those sites'
 * colours, so a caller that has them (the lookup) need not find them
 * twice. */
sg_vec3 sg_scene_hit_albedo_sites(const sg_scene *scene, const sg_hit *hit, const uint32_t *ids,
                                  const float *weights, int n);

/* The point set the scene was built from (its own copy): for tools that
 * measure the reconstruction against its input (tests, benchmarks, the
 * stability map). The bake, the viewer and the reference use sites and
 * hits only. */
const sg_pointset *sg_scene_points(const sg_scene *scene);

void sg_scene_get_info(const sg_scene *scene, sg_scene_info *info);

/* A ray that leaves hit h in direction dir (unit): origin at the hit, the
 * seamless front/back expectation set from the side dir points to, the
 * surface it leaves named (ray.h), tmin 0, tmax as given. Use for shadow
 * and secondary rays. */
sg_ray sg_scene_spawn_ray(const sg_scene *scene, const sg_hit *h, sg_vec3 dir, float tmax);

#endif
