/* render.h — the viewer's still frame: one primary ray per pixel through
 * the world, the bake's lookup at the hit, the envmap where the ray
 * escapes; the same image as sg_bake_render (bake.h), made faster for the
 * viewer.
 *
 * What it does: sg_view_render fills a width x height scene-linear image
 * equal to sg_bake_render's for the same bake, world and camera, bit for
 * bit (tested): the hits are sg_world_intersect's, the lookup is the
 * bake's own sg_bake_lookup. It differs in how it gets there: the pixels
 * of each 16 x 16 tile are traced as 4 x 4 blocks (sg_world_intersect16):
 * a hybrid model walks its tree once for the sixteen rays; the MLS and
 * ISO surfaces trace them as 2 x 2 quads sharing one traversal each
 * (measured 1.02-1.13x less CPU per frame than one ray at a time,
 * bench/bench_view_split, dragon 125k and 1M, 512 x 512).
 * sg_bake_render stays the plain one-ray-at-a-time loop on purpose: it is
 * the reference this frame is tested against (as a scalar kernel beside a
 * SIMD one).
 * sg_view_render_aa is the same frame anti-aliased for still views:
 * corner supersampling (render/corner_aa.h, Ye 2005 §4.3): the same
 * camera ray, hit and lookup per sample, at the pixels' corners and,
 * where they disagree, at finer points; with aa NULL or
 * SG_VIEW_AA_NONE it is sg_view_render, bit for bit (tested).
 * What it does NOT do: display transforms (display/ocio.h).
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
#include "render/corner_aa.h"
#include "render/world.h"

/* d as sg_bake_render's (width, height default 512; threads 0 = OpenMP
 * default). *seconds (may be NULL): wall time of the pixel loop. */
sg_status sg_view_render(const sg_bake *b, const sg_world *w, const sg_bake_frame_desc *d, sg_image *out,
                         double *seconds, sg_error *err);

typedef enum sg_view_aa_mode {
    SG_VIEW_AA_NONE = 0,   /* one ray through each pixel centre (default) */
    SG_VIEW_AA_CORNER = 1  /* corner supersampling, refined adaptively     */
} sg_view_aa_mode;

/* Anti-aliasing options; zero means the documented default. */
typedef struct sg_view_aa {
    sg_view_aa_mode mode; /* default SG_VIEW_AA_NONE                        */
    float threshold;      /* corner_aa.h; default SG_CORNER_AA_THRESHOLD    */
    int max_depth;        /* corner_aa.h; default SG_CORNER_AA_DEPTH        */
} sg_view_aa;

/* sg_view_render with anti-aliasing aa (NULL: none). The image's alpha is
 * the fraction of samples that hit (0 or 1 without anti-aliasing).
 * stats (may be NULL) receives the rays traced (width x height without
 * anti-aliasing) and the wall time. Errors: those of sg_view_render, and
 * SG_ERR_INVALID_ARG for a bad mode, threshold or depth. */
sg_status sg_view_render_aa(const sg_bake *b, const sg_world *w, const sg_bake_frame_desc *d, const sg_view_aa *aa,
                            sg_image *out, sg_corner_aa_stats *stats, sg_error *err);

#endif
