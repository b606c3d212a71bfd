/* refcache.h — a converged reference at pixel centres, rendered once and
 * cached on disk.
 *
 * What it does: renders the path tracer's estimator (ref/pathtrace.h,
 * sg_ref_path) with every path through its pixel's CENTRE — the point the
 * bake's lookup frame (sg_bake_render) and the direct renderers sample, so
 * that a bake is compared with the radiance it tries to show — and keeps
 * the mean and its standard error as EXR files under a cache folder named
 * by a key over the scene (every part, plus the contents of its model and
 * envmap files), the camera, the size, spp, seed and depth:
 *     <cache>/<key>.exr, <key>.se.exr, <key>.txt (seconds, paths and the
 *     hit counts, sg_ref_counts)
 * Every file is written to a temporary name and renamed; the .txt is
 * written last, so a cache entry without it is ignored.
 * What it does NOT do: progressive refinement of a cached entry.
 *
 * Ownership: *out is the caller's (sg_ref_result_free).
 */
#ifndef SG_VERIFY_REFCACHE_H
#define SG_VERIFY_REFCACHE_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "io/scene_file.h"
#include "ref/pathtrace.h"
#include "render/camera.h"
#include "render/world.h"

/* Version of the reference algorithm, part of every cache key: bump when
 * the same scene starts rendering differently, so old entries are not
 * reused. 2: bilinear envmap lookup with max-weight sampling (envmap.h);
 * files without colours give white points (no clay tint); 3: Russian
 * roulette only below throughput 1 (pathtrace.h), mesh samples on the
 * Phong-tessellated surface; 4: issue 12's leak-free surfaces (keyed
 * splats, radii per layer) and the back-hit counts in the .txt; 5: camera
 * rays without a footprint, so the ISO and hybrid surfaces' references
 * see full detail (pathtrace.c); 6: MLS passes crossings in the overhang
 * of convex keyed edges (mls.c past_back_layer); 7: the ISO's layered
 * corners (iso_build.c corner_field); 8: the ISO's self test reads the
 * surface's normal, not the one turned to the crossing's side (iso.c
 * accept); 9: MLS bridges gaps in the supports up to a sample spacing
 * (mls.c, invariant 2); 10: MLS camera rays enter a rim they meet behind
 * the splats facing them (mls.c, invariant 7); 11: and such a hit lies
 * on the front surface, not at the sample inside the part. */
#define SG_VERIFY_REF_VERSION 11u

typedef struct sg_verify_ref_desc {
    sg_camera camera;      /* required                                   */
    int width, height;     /* required, >= 1                             */
    int spp;               /* required, >= 1                             */
    int max_depth;         /* default 8                                  */
    uint64_t seed;         /* default 1                                  */
    const char *cache_dir; /* NULL: no cache                             */
    uint64_t scene_key;    /* sg_verify_scene_key of the world's scene   */
} sg_verify_ref_desc;

/* FNV-1a of key and the bytes of the file at path (path NULL or unreadable:
 * key mixed with a marker for "absent"). */
uint64_t sg_verify_hash_file(uint64_t key, const char *path);

/* sg_scene_file_hash(sf, ALL) mixed with the contents of every model and
 * envmap file the scene names. */
uint64_t sg_verify_scene_key(const sg_scene_file *sf);

/* The cache key of d (scene key, camera, size, spp, depth, seed, version). */
uint64_t sg_verify_ref_key(const sg_verify_ref_desc *d);

/* Renders (or reads from the cache) the reference. *cached says which;
 * path (may be NULL) receives the cache file's name. A failed cache write
 * is not an error (the image is returned). */
sg_status sg_verify_reference(const sg_world *w, const sg_verify_ref_desc *d, sg_ref_result *out, int *cached,
                              char *path, size_t path_cap, sg_error *err);

#endif
