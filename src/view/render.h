/* render.h — the viewer's still frame: one primary ray per pixel through
 * the world, the bake's lookup at the hit, the envmap where the ray
 * escapes; the same image as sg_bake_render (bake.h), made faster for the
 * viewer.
 *
 * What it does: sg_view_render fills a width x height scene-linear image
 * equal to sg_bake_render's for the same bake, world and camera, bit for
 * bit (tested): the hits are sg_world_intersect's, the lookup is the
 * bake's own sg_bake_lookup. It differs in how it gets there: the pixels
 * of each 16 x 16 tile are traced as 2 x 2 quads, the four camera rays
 * sharing one kd-tree traversal per model (sg_world_intersect4):
 * measured 1.02-1.13x less CPU per frame than one ray at a time
 * (bench/bench_view_split, dragon 125k and 1M, 512 x 512).
 * sg_bake_render stays the plain one-ray-at-a-time loop on purpose: it is
 * the reference this frame is tested against (as a scalar kernel beside a
 * SIMD one).
 * What it does NOT do: anti-aliasing, display transforms (display/ocio.h).
 * Glossy models look up the bake's directional bins like every lookup.
 *
 * Layout of out: sg_image (io/image.h), RGB float, row 0 top.
 * Ownership: *out is allocated here (sg_image_free); written only on SG_OK.
 * Thread-safety: reentrant; b and w are only read. Deterministic: the
 * image does not depend on the thread count.
 */
#ifndef SG_VIEW_RENDER_H
#define SG_VIEW_RENDER_H

#include "bake/bake.h"
#include "core/error.h"
#include "io/image.h"
#include "render/world.h"

/* d as sg_bake_render's (width, height default 512; threads 0 = OpenMP
 * default). *seconds (may be NULL): wall time of the pixel loop. */
sg_status sg_view_render(const sg_bake *b, const sg_world *w, const sg_bake_frame_desc *d, sg_image *out,
                         double *seconds, sg_error *err);

#endif
