/* iso.h — the Implicit Surface Octree (ISO) of Kashyap 2010, ch. 4: the MLS
 * surface of a point set (mls.h) sampled at the corners of an adaptive
 * octree and ray traced as one trilinear patch per leaf, without the
 * splats.
 *
 * What it does:
 *  - Build (sg_iso_create): an octree over the cube around the splats'
 *    supports. A cell is kept while some splat's thick disk touches it
 *    (the paper's active and passive leaves, §4.3.1: the disk of radius
 *    r, thickened to SG_ISO_SLAB radii on each side because the MLS
 *    surface bends away from the splat planes); others are dropped. A
 *    kept cell is subdivided (down to max_depth) while
 *      a. its edge exceeds leaf_radii x r_min (r_min = the smallest radius
 *         among the splats whose thick disk touches it), or
 *      b. some of its corners lie outside every support and some inside,
 *         and its edge exceeds leaf_radii x r_min / 4 (the surface is
 *         followed to the edge of the supports, two levels finer), or
 *      c. the trilinear patch of its corner values departs from f at the
 *         19 test points (centre, face centres, edge midpoints: the
 *         children's corners) by more than tolerance x r_min, or one of
 *         them is invalid;
 *    rules b and c stop two levels below rule a's bound (edge <=
 *    leaf_radii x r_min / 4): f has kinks no patch fits (the kernel's
 *    support edges, opposed normals cancelling) and would otherwise be
 *    chased down to max_depth.
 *    Corners store the normalised field
 *         f(x) = F(x) / (W(x) |sum w_i n_i|) = (x - p̄(x)) . n̄(x),
 *    the signed distance to the local MLS plane (same zero set and signs
 *    as F, near-linear, bounded by the largest radius), and the normal
 *    n̄ = normalise(sum w_i n_i). A corner with W = 0 (outside every
 *    support) or a vanishing sum of normals is invalid.
 *  - A leaf is stored only if all 8 corners are valid and their values
 *    change sign (a trilinear patch is a convex combination of its corner
 *    values, so without a sign change it has no zero). A leaf with an
 *    invalid corner is not stored and never intersected: that keeps holes
 *    of the point set open (the surface stops within one leaf of the
 *    supports' edge).
 *  - Corners are keyed by their integer coordinates at max_depth and
 *    stored once; leaves index them, so neighbouring leaves of one size
 *    share their face values exactly (no cracks). Where leaves of
 *    different sizes meet, rule c bounds the mismatch by tolerance x
 *    r_min, and the traversal reports a sign change across a shared face
 *    of two consecutive leaves as a crossing at that face, so such a seam
 *    is not a hole either.
 *  - Ray casting (sg_iso_intersect, sg_iso_occluded): front-to-back
 *    octree traversal with an explicit stack; in a leaf the patch along
 *    the ray is a cubic in t, split at its critical points into monotone
 *    pieces, and the first accepted sign change is solved by safeguarded
 *    Newton/bisection to |Δσ| <= SG_ISO_ROOT_EPS of the leaf's ray span.
 *    Every inner node also bounds its leaves by a slab along their mean
 *    normal (iso_lod.c); a ray whose path through the node's cell stays
 *    off the slab skips the node (a grazing ray over a ground: half the
 *    node steps), with the rule of iso.c slab_skips for rays accepting
 *    either face.
 *
 *  - Levels of detail (iso_lod.c): every inner node also holds a coarse
 *    patch, the plane fitted to the surface of its leaves (stored where
 *    the leaves' normals agree and their surface lies within an eighth of
 *    the node's edge of the plane). A ray with a footprint (sg_ray.spread,
 *    set for camera rays) takes a node whose edge is at most lod pixels of
 *    its footprint where the ray enters the cell as that plane, clipped to
 *    the cell, instead of descending; if the plane gives no accepted
 *    crossing in the cell the ray descends as if the node were large, so
 *    level of detail never opens a hole. It can widen a silhouette by at
 *    most one such cell (under lod pixels), and moves a hit by at most the
 *    ray's path through the cell (sqrt(3) cell edges; tested). An LOD hit
 *    has the plane's normal, its material from the node's representative
 *    leaf (the leaf nearest the plane's centre: hit->splat is that leaf's
 *    splat), and names the node: hit->leaf = leaf_count + node, whose
 *    light site holds the filtered light of the node's leaves
 *    (iso_sites.h). Rays without a
 *    footprint (spread 0: the reference's, and the bake's unless it sets
 *    a ray cone, bake/transport.h) and lod = 0 always reach the leaves,
 *    bit for bit as without coarse patches. A ray spawned on the surface
 *    never takes the cell around its origin (it enters it at t0 = 0).
 *
 *  - Layered corners (iso_build.c corner_field): where the splats covering
 *    a corner carry layer keys (layers.h) of two or more layers more than
 *    60 degrees apart, f is each layer's own plane distance combined as
 *    solids (max for a convex edge or a thin wall's two sides, min for an
 *    inner corner or a fold's two walls), with the winning layer's normal;
 *    such cells refine one level further, so sharp edges stay sharp to
 *    within a leaf. Elsewhere f is the single field above, bit for bit.
 *
 * What it does not do: the keyed groups of mls.c per ray (one value per
 * corner, whichever way a ray comes) — a wall thinner than a layered leaf
 * (leaf_radii x r_min / 8) still vanishes; hit weights for interpolating splat data;
 * footprints for secondary rays (the caller sets sg_ray.spread: the
 * bake's ray cone does); updates after the build.
 *
 * Compact storage (bytes stated for the benchmark's report):
 *  - corner: f as int16, q = round(f / f_scale), f_scale = max |f| / 32767
 *    (global); normal oct-encoded in 2 x int16 (Cigolle et al. 2014).
 *    6 bytes. Quantisation error bounds (tested):
 *        |f_stored - f| <= f_scale / 2 (+ float rounding, 1e-6 relative),
 *        angle(n_stored, n) <= SG_ISO_NORMAL_EPS radians;
 *    the patch, a convex combination of corner values, inherits both.
 *  - leaf: 8 corner indices + the representative splat (uint32, the splat
 *    nearest the leaf centre): 36 bytes.
 *  - inner node: child mask, leaf-child mask, first inner child, first
 *    leaf child (children stored contiguously): 12 bytes; its coarse
 *    patch and slab (normal as 3 x int16, plane offset, slab bounds,
 *    representative leaf): 24 bytes.
 *
 * Use:
 *     sg_iso_desc d = { .tolerance = 0.05f };     zero = defaults
 *     sg_iso *iso; if (sg_iso_create(&d, &points, &iso, &err) != SG_OK) ...
 *     sg_hit h; if (sg_iso_intersect(iso, &ray, &h, &stats)) ...
 *     sg_iso_destroy(iso);
 *
 * Ownership: create reads the pointset and keeps nothing of it; the
 * pointset may be freed afterwards (hits name splats by index into it).
 * Thread-safety: queries on a built ISO are thread-safe (const); stats
 * pointers must be per-thread. Determinism: the stored arrays are the same
 * bytes for any thread count (sg_iso_checksum; tested).
 */
#ifndef SG_SURFACE_ISO_H
#define SG_SURFACE_ISO_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "math/ray.h"
#include "points/pointset.h"
#include "surface/scene.h"

typedef struct sg_iso sg_iso; /* opaque */

/* Half thickness of a splat's disk, in radii, for keeping cells. The MLS
 * surface of a sphere lies within r^2/(2R) of each splat plane in its
 * support, and a 90-degree edge of a cube is rounded off by about 0.2 r:
 * 0.5 r keeps both with margin. */
#define SG_ISO_SLAB 0.5f

/* Root accuracy: the root's parameter within this fraction of the leaf's
 * ray span (<= sqrt(3) x the leaf edge) of the patch's exact zero. */
#define SG_ISO_ROOT_EPS 1e-6f

/* Angle (radians) between a stored normal and the normal before
 * quantisation: 2 x int16 oct encoding, step 2/65534 in the octahedron's
 * square; the map stretches by at most about 2.2, so about 6.8e-5 worst
 * case (measured 4e-5); stated with margin. */
#define SG_ISO_NORMAL_EPS 1e-4f

/* Level-of-detail threshold, in pixels of a camera ray's footprint: a node
 * whose cell edge is below this many footprints is hit as its coarse
 * patch (Kashyap 2010 §4.6 stops at about one pixel). */
#define SG_ISO_LOD_DEFAULT 1.0f

typedef struct sg_iso_desc {
    sg_kernel kernel;   /* MLS weight (as sg_scene_desc); default SG_KERNEL_HAT */
    int max_depth;      /* deepest leaf level, 2..20; default 16                 */
    float tolerance;    /* rule c: patch error allowed, in units of r_min;
                           default 0.05                                        */
    float leaf_radii;   /* rule a: largest leaf edge in units of r_min;
                           default 2: measured on the 1M dragon
                           (bench_iso --leaf-radii), 2 against 1 keeps
                           the agreement with MLS (99.98% hit/miss, median
                           |dt| 0.006 of a leaf) at 1.43 instead of 2.61
                           leaves per point: 84 instead of 137 MB, build
                           CPU 32 s instead of 67 s, tracing 5-10% faster;
                           rule c still refines where the patch misses f */
    int threads;        /* build threads; 0 = OpenMP default                    */
    float lod;          /* level of detail for rays with a footprint, in pixels
                           (see above); 0 = SG_ISO_LOD_DEFAULT, negative = off
                           (every ray to the leaves); a query setting, not a
                           property of the octree (sg_iso_set_lod)            */
} sg_iso_desc;

typedef struct sg_iso_info {
    size_t point_count;    /* splats the ISO was built from                    */
    size_t node_count;     /* inner nodes                                      */
    size_t leaf_count;     /* stored leaves (with a surface patch)             */
    size_t corner_count;   /* distinct corners                                 */
    size_t memory_bytes;   /* everything the ISO holds                         */
    double bytes_per_leaf; /* memory_bytes / leaf_count                        */
    double bytes_per_point;/* memory_bytes / point_count                       */
    int depth;             /* deepest stored leaf                              */
    double build_seconds;  /* wall time of sg_iso_create                       */
    sg_aabb bounds;        /* the root cube                                    */
    float f_scale;         /* quantisation step of f (world units)             */
    float r_min, r_max;    /* smallest and largest splat radius                */
} sg_iso_info;

/* Errors: SG_ERR_INVALID_ARG (NULL arguments, an empty or invalid
 * pointset, max_depth outside 2..20, a negative or non-finite tolerance or
 * leaf_radii, more than 2^32 - 2 splats), SG_ERR_NOMEM. */
sg_status sg_iso_create(const sg_iso_desc *desc, const sg_pointset *points, sg_iso **out, sg_error *err);

/* NULL is a no-op. */
void sg_iso_destroy(sg_iso *iso);

/* Nearest accepted crossing of the patches in [ray->tmin, ray->tmax]:
 * entry (f from > 0 to <= 0) is a front face, exit a back face; the ray's
 * face flags choose which are accepted, crossings sg_ray_is_self names are
 * skipped, and a ray accepting either face takes a back face only while
 * no patch on it so far was positive (it started inside), as
 * sg_scene_intersect does. Fills t, p, n (trilinear interpolation of the
 * corner normals, turned to the crossing's side), splat (the leaf's
 * representative splat) and leaf (its index; leaf_count + node for a hit
 * on an inner node's coarse patch, "Levels of detail" above). Returns 1
 * on a hit, else 0
 * with hit->splat = SG_INVALID_ID. stats may be NULL; for the ISO,
 * stats->isects counts leaves whose cubic was examined and
 * stats->splats the candidate roots solved for. */
int sg_iso_intersect(const sg_iso *iso, const sg_ray *ray, sg_hit *hit, sg_ray_stats *stats);

/* Up to four rays at once (bit r of mask: rays[r]), e.g. a 2 x 2 quad of
 * camera rays: each gets exactly the hit sg_iso_intersect gives it, bit
 * for bit (tested). It is sg_iso_intersect16 on four rays: the rays of
 * each direction octant go down one traversal, each with its own
 * intervals. Returns the mask of the rays that hit; a ray of mask that
 * misses gets splat = SG_INVALID_ID; hits[r] outside mask is left alone.
 * stats counts per ray. */
unsigned sg_iso_intersect4(const sg_iso *iso, const sg_ray rays[4], unsigned mask, sg_hit hits[4],
                           sg_ray_stats *stats);

/* sg_iso_intersect4 for up to sixteen rays (bit r of mask: rays[r]), e.g.
 * a 4 x 4 block of camera rays: the rays of each direction octant go down
 * one traversal (one read of a node's record for all of them), each with
 * its own intervals, and get exactly their single-ray hits, bit for bit
 * (tested); a ray with a zero direction component is traced alone. Returns
 * the mask of the rays that hit; a ray of mask that misses gets splat =
 * SG_INVALID_ID; entries outside mask are neither read nor written. */
unsigned sg_iso_intersect16(const sg_iso *iso, const sg_ray *rays, unsigned mask, sg_hit *hits,
                            sg_ray_stats *stats);

/* 1 if any accepted crossing lies in [tmin, tmax] (shadow rays). */
int sg_iso_occluded(const sg_iso *iso, const sg_ray *ray, sg_ray_stats *stats);

void sg_iso_get_info(const sg_iso *iso, sg_iso_info *info);

/* Changes the level-of-detail threshold (pixels, >= 0; 0: off) of a built
 * ISO, e.g. for a speed-against-error sweep. Not while queries run on it. */
void sg_iso_set_lod(sg_iso *iso, float lod_px);

/* The box of every stored leaf, boxes[leaf] for leaf < leaf_count (the
 * caller's array), e.g. to relate a hit's error to its leaf's size. */
void sg_iso_leaf_boxes(const sg_iso *iso, sg_aabb *boxes);

/* A leaf's 8 corner values as stored (dequantised), corner c at
 * (bit 0: +x, bit 1: +y, bit 2: +z) of its box. */
void sg_iso_leaf_corners(const sg_iso *iso, uint32_t leaf, float f[8], sg_vec3 n[8]);

/* The shading normal of leaf `leaf` at local coordinates uvw ([0,1]^3 of
 * its box, corner c at bit 0: +x, 1: +y, 2: +z) as a hit there gets it
 * before it is turned to its crossing's side: the trilinear interpolation
 * of the decoded corner normals, normalised. sg_iso_leaf_normal is the
 * kernel the traversal uses (8 corners in AVX lanes where built with
 * AVX2), _reference the scalar one, corner by corner; they agree bit for
 * bit (exposed for that test). */
sg_vec3 sg_iso_leaf_normal(const sg_iso *iso, uint32_t leaf, sg_vec3 uvw);
sg_vec3 sg_iso_leaf_normal_reference(const sg_iso *iso, uint32_t leaf, sg_vec3 uvw);

/* FNV-1a over the stored arrays and scalars: equal for equal ISOs. */
uint64_t sg_iso_checksum(const sg_iso *iso);

/* The corner value f at x as the build computes it (before quantisation)
 * from splats idx[0..count) (every splat whose support contains x must be
 * among them, in increasing index order, for the build's bits); returns
 * NAN where x is invalid. *n (may be NULL) gets n̄. For tests. */
float sg_iso_field(const sg_pointset *ps, const uint32_t *idx, size_t count, sg_kernel kernel, sg_vec3 x,
                   sg_vec3 *n);

/* The normal codec of the stored corners (exposed for its test). */
uint32_t sg_iso_encode_normal(sg_vec3 n);
sg_vec3 sg_iso_decode_normal(uint32_t code);

#endif
