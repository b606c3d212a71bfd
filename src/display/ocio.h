/* ocio.h — the display transform: scene-linear frames to screen pixels
 * through OpenColorIO (C interface to OCIO's C++ library).
 *
 * What it does: loads an OCIO config, picks a display and a view of it and
 * turns a scene-linear image (sg_image: linear Rec.709, the config's
 * scene_linear role) into display-referred pixels:
 *     linear * 2^exposure_stops -> OCIO DisplayViewTransform (scene_linear
 *     -> display, view) -> clip to [0, 1] -> ^(1 / gamma) -> screen
 * as 8-bit RGBA (sg_display_apply) or float RGB (sg_display_apply_float).
 * The OCIO CPU processor is built once, at create, and applied to rows in
 * parallel.
 *
 * Which config (DESIGN.md "respect the OCIO environment variable, and ship
 * a small default config"), first that applies:
 *   1. desc.config_path, when non-NULL and non-empty;
 *   2. the OCIO environment variable, when set and non-empty;
 *   3. SG_OCIO_DEFAULT_CONFIG, the config splatgi ships (display/config.ocio:
 *      display "sRGB" with views "Standard", "Filmic-like" and "Raw"; see
 *      display/README.md).
 * OCIO's own environment variables (OCIO_ACTIVE_DISPLAYS, OCIO_ACTIVE_VIEWS,
 * context variables) apply as OCIO defines them.
 *
 * What it does NOT do: looks, GPU shaders, input colour spaces other than
 * scene_linear, alpha (the RGBA output's alpha is 255), dithering. OCIO's
 * own log messages (e.g. warnings about a user's config) go through OCIO's
 * global logging function, which this module leaves as the application set
 * it.
 *
 * Walkthrough:
 *     sg_display *d;
 *     sg_display_desc desc = {.view = "Filmic-like", .exposure_stops = 1.0f};
 *     if (sg_display_create(&desc, &d, &err) != SG_OK) ... err.message ...
 *     sg_display_apply(d, &frame, rgba, &err);   // each frame
 *     sg_display_set_exposure(d, -0.5f, &err);    // UI slider
 *     sg_display_destroy(d);
 *
 * Layout: the input is an sg_image (image.h): RGB floats, row 0 top. The
 * 8-bit output is width * height * 4 bytes, R, G, B, A per pixel, row 0 top,
 * rows tightly packed (stride 4 * width); each channel is
 * round(255 * v), v the display-referred value in [0, 1] (with gamma 1,
 * OCIO's own 8-bit output from the input rounded to half floats: within 1
 * of that, see ocio.cpp invariant 5). The float output
 * is width * height * 3 floats in the sg_image layout, each in [0, 1].
 *
 * Input sanitising, before the view: NaN and negative values become 0,
 * values over SG_DISPLAY_MAX_INPUT (including +Inf) become it; after the
 * view, NaN becomes 0 and the result is clipped to [0, 1]. So no input
 * gives garbage, whatever the config does.
 *
 * Errors (messages name the config path):
 *  SG_ERR_IO          the config file, or a LUT file it names, cannot be
 *                     opened (the OS's or OCIO's reason follows);
 *  SG_ERR_CORRUPT     OCIO rejects the config (parse or validation error,
 *                     or a transform it cannot build): OCIO's message;
 *  SG_ERR_INVALID_ARG an unknown display or view (the message lists the
 *                     available ones), a non-finite exposure or a negative
 *                     or non-finite gamma, NULL or mismatched arguments;
 *  SG_ERR_NOMEM.
 * No C++ exception leaves this interface.
 *
 * Thread-safety: after create, sg_display_apply, sg_display_apply_float,
 * sg_display_list and sg_display_get_info may run concurrently on one
 * handle. sg_display_set_exposure must not run concurrently with anything
 * else on the same handle. Creating handles from several threads is safe;
 * create reads the OCIO environment variable (getenv), so no other thread
 * may setenv meanwhile.
 */
#ifndef SG_DISPLAY_OCIO_H
#define SG_DISPLAY_OCIO_H

#ifdef __cplusplus
extern "C" {
#endif

#include <stdint.h>

#include "core/error.h"
#include "io/image.h"

/* Scene-linear values are clamped to this before the view (after
 * exposure): finite, and 2^32 times middle grey, beyond any view's range. */
#define SG_DISPLAY_MAX_INPUT 1.0e9f

typedef struct sg_display sg_display;

/* Create options; zero means the documented default. Strings are copied. */
typedef struct sg_display_desc {
    const char *config_path; /* NULL or "": $OCIO if set and non-empty,
                                else SG_OCIO_DEFAULT_CONFIG             */
    const char *display;     /* NULL or "": the config's default display */
    const char *view;        /* NULL or "": the display's default view   */
    float exposure_stops;    /* scene-linear scale 2^stops before the
                                view; finite; default 0                 */
    float gamma;             /* display gamma after the view, out =
                                v^(1/gamma); 0 means 1; else > 0 finite */
    int threads;             /* worker threads for apply; 0: all cores  */
} sg_display_desc;

/* What a handle uses; strings are owned by the handle and live until
 * sg_display_destroy. */
typedef struct sg_display_info {
    const char *config_path; /* the config file actually loaded          */
    const char *config_from; /* "desc", "$OCIO" or "default"             */
    const char *display;     /* the display in use                       */
    const char *view;        /* the view in use                          */
    float exposure_stops;    /* current exposure                         */
    float gamma;             /* display gamma (1 when the desc said 0)   */
} sg_display_info;

/* A list of names owned by the handle (valid until sg_display_destroy). */
typedef struct sg_display_names {
    int count;                 /* number of names                          */
    const char *const *names;  /* names[0 .. count-1], config order       */
} sg_display_names;

/* Loads the config, checks display and view, builds the CPU processor.
 * desc may be NULL (all defaults). On failure *out is untouched. */
sg_status sg_display_create(const sg_display_desc *desc, sg_display **out, sg_error *err);

/* Frees the handle; NULL is a no-op. */
void sg_display_destroy(sg_display *d);

/* Writes linear->width * linear->height * 4 bytes of RGBA to rgba8_out
 * (layout above). On failure rgba8_out may be partly written. */
sg_status sg_display_apply(const sg_display *d, const sg_image *linear, uint8_t *rgba8_out,
                           sg_error *err);

/* Writes linear->width * linear->height * 3 display-referred floats in
 * [0, 1] to rgb_out (sg_image layout). rgb_out may equal linear->data (in
 * place); any other overlap is SG_ERR_INVALID_ARG. */
sg_status sg_display_apply_float(const sg_display *d, const sg_image *linear, float *rgb_out,
                                 sg_error *err);

/* display NULL: lists the config's (active) displays. display a name: lists
 * its (active) views; an unknown name is SG_ERR_INVALID_ARG listing the
 * displays. On failure *out is untouched. */
sg_status sg_display_list(const sg_display *d, const char *display, sg_display_names *out,
                          sg_error *err);

/* Fills *out with what d uses. */
void sg_display_get_info(const sg_display *d, sg_display_info *out);

/* Changes the exposure (stops, finite) for later applies; the processor is
 * kept. Not thread-safe with other calls on d (see above). */
sg_status sg_display_set_exposure(sg_display *d, float stops, sg_error *err);

#ifdef __cplusplus
}
#endif

#endif
