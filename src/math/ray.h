/* ray.h — rays, hits and per-ray traversal statistics (plain values).
 *
 * "No hit" is hit.splat == SG_INVALID_ID. Rays carry Kashyap's (2010, §3.6)
 * "seamless ray tracing" expectation instead of a minimum-distance epsilon:
 * a ray leaving a surface outward sets SG_RAY_FRONT_ONLY, so the surface it
 * starts on (seen from behind, dot(dir, n) > 0) is ignored while a real
 * front-facing surface, however close (a corner), is hit.
 *
 * The facing test alone lets a ray leaving at a grazing angle (within about
 * r/R of the tangent plane) re-enter the bumps of the surface it leaves.
 * A spawned ray therefore also names that surface (self_n, self_r):
 * crossings nearer than self_r whose normal lies within SG_SELF_COS of
 * self_n and which stay within SG_SELF_RISE radii of the tangent plane the
 * ray leaves are the same smooth patch and are ignored. A real occluder
 * that close must turn by more than that angle within one splat radius (a
 * corner or crease) or rise above the tangent plane (a fold), and is
 * still hit.
 */
#ifndef SG_MATH_RAY_H
#define SG_MATH_RAY_H

#include <stdint.h>

#include "math/vec3.h"

#define SG_INVALID_ID 0xFFFFFFFFu

/* cos(25 degrees): normals closer than this belong to the ray's own patch. */
#define SG_SELF_COS 0.9063078f

/* ...and so does a crossing only while it lies within this many radii of
 * the tangent plane the ray leaves (height t dot(dir, self_n)). The
 * reconstruction of a convex patch rises above its tangent plane by far
 * less (measured: the grazing self-crossings on a sampled sphere lie
 * within 1.1 degrees, so below 0.02 r); a concave surface within one
 * radius that the ray meets at an angle above asin(0.1) = 5.7 degrees is
 * a real occluder (a fold), and no longer skipped (bench_leaks: 1/3 of
 * the rays that slipped through Lucy's folds did so here). */
#define SG_SELF_RISE 0.1f

enum sg_ray_flags {
    SG_RAY_ANY_FACE = 0,        /* accept the first surface crossing          */
    SG_RAY_FRONT_ONLY = 1u << 0, /* accept only crossings with dot(dir,n) < 0 */
    SG_RAY_BACK_ONLY = 1u << 1,  /* accept only crossings with dot(dir,n) > 0 */
    SG_RAY_PRIMARY = 1u << 2     /* a camera ray (sg_camera_ray sets it, nothing
                                    else): the MLS surface closes a rim it
                                    enters behind the splats facing it (mls.c
                                    invariant 7)                              */
};

typedef struct sg_ray {
    sg_vec3 org;    /* origin, world space                               */
    sg_vec3 dir;    /* direction, unit length                            */
    float tmin;     /* search interval [tmin, tmax] along dir             */
    float tmax;
    uint32_t flags; /* sg_ray_flags                                       */
    sg_vec3 self_n; /* normal of the surface the ray leaves (spawned rays) */
    float self_r;   /* its splat radius; 0: no self test (primary rays)    */
    float spread;   /* footprint: the ray's cone is spread * t wide at t
                       (a camera ray: its pixel's angle); 0: a thin ray.
                       A surface with levels of detail may stop at the
                       level whose cells are below that width; MLS and
                       disks ignore it (DESIGN.md, "one interface")     */
} sg_ray;

/* Whether a crossing at t with unit normal n is the ray's own surface. */
static inline int sg_ray_is_self(const sg_ray *r, float t, sg_vec3 n)
{
    return r->self_r > 0.0f && t < r->self_r &&
           n.x * r->self_n.x + n.y * r->self_n.y + n.z * r->self_n.z > SG_SELF_COS &&
           t * (r->dir.x * r->self_n.x + r->dir.y * r->self_n.y + r->dir.z * r->self_n.z) < SG_SELF_RISE * r->self_r;
}

typedef struct sg_hit {
    float t;        /* distance along the ray                            */
    sg_vec3 p;      /* hit position, world space                         */
    sg_vec3 n;      /* smooth unit surface normal (the model's outward side) */
    uint32_t splat; /* splat with the largest weight at p; SG_INVALID_ID = miss */
    uint32_t leaf;  /* kd-tree leaf holding p (for sg_scene_hit_sites)  */
    float b1, b2;   /* a hybrid triangle hit's barycentric weights of its
                       2nd and 3rd vertex, as the triangle test found them
                       (p is their combination); set and read for such
                       hits only (hybrid_scene.h)                        */
} sg_hit;

/* Counters a traversal adds to (once per ray, not per step). The paper's
 * table (Wald & Seidel 2005, §4.3) reports these per ray. */
typedef struct sg_ray_stats {
    uint64_t rays;          /* rays traced                                   */
    uint64_t nodes;         /* kd-tree node traversal steps (inner + leaf)   */
    uint64_t leaves;        /* leaf cells visited, empty ones included       */
    uint64_t isects;        /* surface intersection tests run (non-empty leaves) */
    uint64_t splats;        /* splats evaluated in those tests               */
    uint64_t hits;          /* rays that found a surface                     */
} sg_ray_stats;

static inline void sg_ray_stats_add(sg_ray_stats *a, const sg_ray_stats *b)
{
    a->rays += b->rays;
    a->nodes += b->nodes;
    a->leaves += b->leaves;
    a->isects += b->isects;
    a->splats += b->splats;
    a->hits += b->hits;
}

#endif
