/* campath.h — camera paths: a list of timed views, recorded by the viewer
 * and played back (in the window or headless, one frame per key).
 *
 * File format (text, UTF-8/ASCII): one key per line,
 *     time eye.x eye.y eye.z look.x look.y look.z up.x up.y up.z fov
 * eleven numbers separated by spaces or tabs; time in seconds from the
 * start of the path, non-decreasing; fov the vertical field of view in
 * degrees, in (0, 180); look != eye; up not parallel to look - eye; every
 * number finite. Lines that are empty, blank or begin with '#' (after
 * blanks) are comments. Writers put one '#' header line first and print
 * floats with %.9g and times with %.17g, so a write/read round trip gives
 * back the same values bit for bit.
 *
 * What it does NOT do: interpolate between keys (playback shows each key
 * as one frame), or store the resolution or exposure.
 *
 * Errors: SG_ERR_IO (open/read/write/rename; the message names the path
 * and the OS's reason), SG_ERR_CORRUPT (a malformed line: the message is
 * "PATH:LINE: what is wrong", e.g. "walk.txt:3: expected 11 numbers (time
 * eye.xyz look.xyz up.xyz fov), got 7"; an empty path: "walk.txt: no
 * camera keys"), SG_ERR_INVALID_ARG, SG_ERR_NOMEM. Out-parameters are
 * written only on SG_OK. Writes go to "<path>.XXXXXX" and are renamed over
 * path when complete.
 *
 * Ownership: a path owns its keys (sg_alloc_array); sg_campath_free frees
 * them. A zeroed sg_campath is an empty path.
 */
#ifndef SG_VIEW_CAMPATH_H
#define SG_VIEW_CAMPATH_H

#include <stddef.h>

#include "core/error.h"
#include "render/camera.h"
#include "view/navigator.h"

typedef struct sg_campath_key {
    double time;       /* seconds from the start of the path            */
    sg_nav_view view;  /* eye, look, up, fov_deg                         */
} sg_campath_key;

typedef struct sg_campath {
    sg_campath_key *keys; /* count entries, time non-decreasing           */
    size_t count;         /* keys in use                                  */
    size_t capacity;      /* keys allocated                               */
} sg_campath;

/* Appends a key (checked as a file line would be; a time before the last
 * key's is SG_ERR_INVALID_ARG). */
sg_status sg_campath_append(sg_campath *p, const sg_campath_key *k, sg_error *err);

/* Writes p to path (atomically, format above). */
sg_status sg_campath_write(const sg_campath *p, const char *path, sg_error *err);

/* Reads the file at path into *out (at least one key). */
sg_status sg_campath_read(const char *path, sg_campath *out, sg_error *err);

/* Parses len bytes of text; name starts every message. */
sg_status sg_campath_parse(const char *text, size_t len, const char *name, sg_campath *out, sg_error *err);

/* Frees the keys and zeroes *p; NULL is fine. */
void sg_campath_free(sg_campath *p);

/* The key's camera with aspect (width / height). */
sg_status sg_campath_camera(const sg_campath_key *k, float aspect, sg_camera *out, sg_error *err);

/* Index of the key to show at time t during playback: the last key with
 * time <= t (0 before the first). p non-empty. */
size_t sg_campath_index_at(const sg_campath *p, double t);

#endif
