/* hybrid_scene.h — the hybrid point/triangle hierarchy (hybrid.h) behind
 * the one surface interface of scene.h (SG_SURFACE_HYBRID): its hits as
 * sg_hit, its light sites as sg_sites. scene.c calls these; nothing else
 * needs to.
 *
 * Hits (sg_hit, ray.h) carry:
 *   splat  the dominant light site: the triangle's vertex with the largest
 *          barycentric weight, or vertex_count + node for a level-of-detail
 *          hit;
 *   leaf   the triangle's position in leaf order for a triangle hit;
 *          SG_INVALID_ID for a node hit (and for a site hit, t = 0, made by
 *          sg_scene_site_hit), which reads its site alone;
 *   n      the shading normal (vertex normals interpolated), or the
 *          geometric normal where the two disagree about the side the ray
 *          meets (grazing rays), so the side a bake files light under is
 *          the side the ray really met.
 *   b1, b2 the triangle test's barycentrics of p (p is their
 *          combination): sg_hybrid_scene_hit_sites weights the three
 *          vertices with them. Up to stop 24 they were recomputed from p
 *          in double; the two differ by rounding (docs/bench_view.md,
 *          stop 25), and on a shared edge both put ~0 on the vertex off
 *          it, so the weights stay continuous across edges.
 *
 * Light sites: site i < vertex_count is vertex i, with its normal and a
 * reach of its longest traced edge; site vertex_count + k is node k's disk
 * (centre, mean normal, reach its sphere radius), filled in by the bake
 * like any site (its light is then the bake's interpolation of the sample
 * points around the disk), then replaced by the area-weighted mean of its
 * triangles' vertex light (sg_hybrid_sites_filter, which the bake runs
 * through sg_scene_filter_sites), as Ye filters colours into nodes. Sites no hit
 * can read (vertices no traced triangle uses, empty node slots, nodes
 * whose normal cone is too wide to be hit as a point) stand in as copies
 * of the first real vertex site, so every site is a valid surface point
 * for the bake and none adds a sample point (a copy lies at distance 0
 * from its original).
 * Colour: the mesh's vertex colours (nodes: their area-weighted mean);
 * white when the mesh has none.
 *
 * Ownership: the caller owns the struct; the arrays behind view are its
 * own. Thread-safety: the query functions are const and reentrant.
 */
#ifndef SG_SURFACE_HYBRID_SCENE_H
#define SG_SURFACE_HYBRID_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "math/ray.h"
#include "surface/hybrid.h"
#include "surface/sites.h"

typedef struct sg_hybrid_sites {
    sg_sites view;        /* what sg_scene_sites hands out              */
    float *data;          /* the one allocation behind view's 10 arrays */
    size_t vertex_count;  /* sites below this are vertices              */
} sg_hybrid_sites;

/* Errors: SG_ERR_NOMEM. On failure *out is zeroed. */
sg_status sg_hybrid_sites_create(const sg_hybrid *h, sg_hybrid_sites *out, sg_error *err);

/* Zeroes the struct; a zeroed struct is a no-op. */
void sg_hybrid_sites_free(sg_hybrid_sites *s);

size_t sg_hybrid_sites_memory(const sg_hybrid_sites *s);

/* sg_scene_intersect / sg_scene_occluded of a hybrid scene. A ray's spread
 * (ray.h) becomes its footprint (width 0, spread per unit t) at threshold
 * lod pixels; lod <= 0 or spread 0: full detail. stats: pops as nodes,
 * triangle tests as splats, LOD disk tests as isects. */
int sg_hybrid_scene_intersect(const sg_hybrid *h, const sg_hybrid_sites *s, float lod, const sg_ray *ray,
                              sg_hit *hit, sg_ray_stats *stats);
/* sg_hybrid_scene_intersect for the rays of mask (bits 0-3) in one
 * traversal (sg_hybrid_intersect4): the same hits, bit for bit. Returns
 * the mask of rays that hit; a ray of mask that misses gets splat
 * SG_INVALID_ID. */
unsigned sg_hybrid_scene_intersect4(const sg_hybrid *h, const sg_hybrid_sites *s, float lod, const sg_ray rays[4],
                                    unsigned mask, sg_hit hits[4], sg_ray_stats *stats);
/* The same for up to sixteen rays (bits 0-15; sg_hybrid_intersect16). */
unsigned sg_hybrid_scene_intersect16(const sg_hybrid *h, const sg_hybrid_sites *s, float lod, const sg_ray *rays,
                                     unsigned mask, sg_hit *hits, sg_ray_stats *stats);
int sg_hybrid_scene_occluded(const sg_hybrid *h, float lod, const sg_ray *ray, sg_ray_stats *stats);

/* The sites around a hit and their weights (sum 1): a triangle's three
 * vertices with its barycentrics, else the hit's site alone. At most max,
 * the largest kept and renormalised. */
int sg_hybrid_scene_hit_sites(const sg_hybrid *h, const sg_hybrid_sites *s, const sg_hit *hit, uint32_t *ids,
                              float *weights, int max);

/* A ray leaving hit (hybrid.h's self-intersection rule: sides from the
 * geometric normal, self radius the scene's rounding or the node's
 * diameter; a site hit at a vertex names its vertex normal and reach). */
sg_ray sg_hybrid_scene_spawn_ray(const sg_hybrid *h, const sg_hybrid_sites *s, const sg_hit *hit, sg_vec3 dir,
                                 float tmax);

/* Ye's filtered point attributes for light: node site k's `stride`
 * values become the area-weighted mean over its triangles of each
 * triangle's vertex mean, from the vertex sites' values (the first
 * vertex_count rows of values, stride floats a site). Every non-empty
 * node is written; vertex rows are read only. stride <= 16.
 * Deterministic (one fixed-order pass, sums in double). */
void sg_hybrid_sites_filter(const sg_hybrid *h, const sg_hybrid_sites *s, float *values, size_t stride);

/* The sites' colours blended with the hit's weights; (1, 1, 1) for a miss. */
sg_vec3 sg_hybrid_scene_hit_albedo(const sg_hybrid *h, const sg_hybrid_sites *s, const sg_hit *hit);

/* The same from the n sites and weights sg_hybrid_scene_hit_sites gave
 * the hit (any max >= 3: a hit has at most 3 sites). */
sg_vec3 sg_hybrid_scene_sites_albedo(const sg_hybrid *h, const sg_hybrid_sites *s, const uint32_t *ids,
                                     const float *w, int n);

#endif
