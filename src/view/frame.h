/* frame.h — one viewer frame: the bake rendered at a resolution scale,
 * upscaled to the window and put through the display transform.
 *
 * What it does: renders width/scale x height/scale pixels (rounded up) with
 * sg_view_render (one primary ray per pixel, the bake's lookup: the image
 * of sg_bake_render, bit for bit, traced in 2 x 2 quads), turns them
 * into display-referred RGBA8 with sg_display_apply, and upscales the RGBA
 * to width x height by nearest neighbour: window pixel (x, y) shows low-res
 * pixel (x / scale, y / scale). The camera is the same at every scale (its
 * aspect is the window's), so a reduced frame is a blockier version of the
 * full one; at scale 1 the frame is exactly sg_bake_render's image.
 * The viewer uses scale 2, 4 or 8 while the camera moves (sg_view_move_scale
 * picks it from the last frame's time) and 1 when it stops; a scale-1
 * frame is anti-aliased when f->aa asks (sg_view_render_aa).
 * What it does NOT do: windows or GL (the program does), temporal
 * accumulation, filtering.
 *
 * Layout: linear is the scene-linear frame at the rendered (reduced)
 * resolution (sg_image layout); rgba is width * height * 4 bytes, R, G, B,
 * A, row 0 top, stride 4 * width (sg_display_apply's layout).
 *
 * Ownership: the frame owns linear and rgba; sg_view_frame_free releases
 * them. A zeroed sg_view_frame is empty; sg_view_frame_resize (re)allocates.
 */
#ifndef SG_VIEW_FRAME_H
#define SG_VIEW_FRAME_H

#include <stdint.h>

#include "bake/bake.h"
#include "core/error.h"
#include "display/ocio.h"
#include "io/image.h"
#include "render/camera.h"
#include "render/world.h"
#include "view/render.h"

#define SG_VIEW_MAX_SCALE 16

typedef struct sg_view_frame {
    int width, height;  /* output size, pixels                              */
    int scale;          /* scale of the last render (0: nothing rendered)   */
    sg_image linear;    /* last render, (width/scale) x (height/scale)       */
    uint8_t *rgba;      /* width x height RGBA8, display-referred            */
    uint8_t *rgba_low;  /* the render's RGBA8 before upscaling (scale > 1)   */
    double render_seconds;  /* sg_view_render of the last frame              */
    double display_seconds; /* display transform + upscale of the last frame */
    size_t rays;        /* primary rays of the last frame                    */
    sg_view_aa aa;      /* anti-aliasing of full-resolution (scale 1) frames:
                           set by the caller, zero = none; reduced frames are
                           never anti-aliased (view/render.h)               */
} sg_view_frame;

/* Sets the output size (each in [1, SG_IMAGE_MAX_DIM]) and allocates rgba;
 * keeps the buffers when the size is unchanged. Forgets the last render. */
sg_status sg_view_frame_resize(sg_view_frame *f, int width, int height, sg_error *err);

/* Renders cam at 1/scale resolution (scale in [1, SG_VIEW_MAX_SCALE]) into
 * f->linear and f->rgba. threads: 0 = OpenMP default. */
sg_status sg_view_frame_render(sg_view_frame *f, const sg_bake *b, const sg_world *w, const sg_camera *cam,
                               int scale, int threads, const sg_display *d, sg_error *err);

/* While the camera moves the viewer shows reduced frames aimed at this
 * frame time (sg_view_move_scale's budget), and returns to full
 * resolution once the camera has been still for SG_VIEW_MOVE_HOLD_SECONDS.
 * bench_view measures the moving frames with the same budget. */
#define SG_VIEW_MOVE_BUDGET_SECONDS (1.0 / 30.0)
#define SG_VIEW_MOVE_HOLD_SECONDS 0.2

/* Frame time against traced pixels, t ~ P^0.75: bench_view measured 2.9x
 * and 3.0x the time for 4x the pixels (1M-point dragon, scale 1 against 2,
 * at 512x512 and 1024x768). With t ~ P the coarse frames, dearer per
 * pixel, predicted too much for the finer scales: the 1M walk at 1024x768
 * ran at a mean scale of 6.3 (64 fps); with P^0.75 at 4.5 (42 fps, p95
 * 33 ms, within the 1/30 s budget). */
#define SG_VIEW_MOVE_COST_EXPONENT 0.75

/* The resolution scale for the frames shown while the camera moves: the
 * smallest of 2, 4 and 8 whose frame is predicted to take at most budget
 * seconds, else 8. The prediction scales the last frame's time
 * (last_seconds, render and display, for last_pixels traced pixels) by
 * (P / last_pixels)^SG_VIEW_MOVE_COST_EXPONENT, P = ceil(width / s) x
 * ceil(height / s) the pixels scale s traces: a frame costs less than its
 * pixel count says as the pixels get denser, because neighbouring rays
 * share traversal and caches. Going finer than
 * `current` (the scale in use) needs the prediction to fit 0.8 x budget,
 * so that a frame time near the budget does not flip the scale back and
 * forth. Without a usable measurement (last_pixels 0, last_seconds not
 * finite or <= 0) the answer is 2. */
int sg_view_move_scale(int current, double last_seconds, size_t last_pixels, int width, int height, double budget);

/* Re-applies the display (after an exposure change) to the last render. */
sg_status sg_view_frame_redisplay(sg_view_frame *f, const sg_display *d, sg_error *err);

void sg_view_frame_free(sg_view_frame *f);

/* Writes width x height RGBA8 pixels (layout above; alpha dropped) as an
 * 8-bit RGB PNG with no colour conversion: the bytes are display-referred
 * already. Atomic (temporary file + rename). */
sg_status sg_view_write_png_rgba8(const uint8_t *rgba, int width, int height, const char *path, sg_error *err);

/* Reads an 8-bit RGB or RGBA PNG into RGBA8 (alpha 255 where absent);
 * *out from malloc (free()). For tests and tools. */
sg_status sg_view_read_png_rgba8(const char *path, uint8_t **out, int *width, int *height, sg_error *err);

#endif
