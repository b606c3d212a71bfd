/* room.h — a closed room with one window, as a triangle mesh: the
 * built-in "room" model of scene files (issue 12: light that enters
 * through a small opening and reaches the room by bounces).
 *
 * What it does: builds the boundary of the room's walls as one closed,
 * consistently oriented triangle mesh (outward = away from the wall
 * material: into the room on the inner faces, to the outside on the outer
 * ones), with per-face vertices and exact face normals, so that
 * sg_model_points_from_mesh samples it like any mesh (area-weighted,
 * normals exact up to the faces' edges). In the room's own frame:
 *   inside:   x, z in [-2, 2], y in [0, 2.5] (a 4 x 4 room, 2.5 high,
 *             standing on y = 0);
 *   walls:    floor, ceiling and four walls `wall` thick (default 0.2; the
 *             +X wall `window_wall`, default the same), outside x in
 *             [-2 - wall, 2 + window_wall], z in [-2 - wall, 2 + wall],
 *             y in [-wall, 2.5 + wall];
 *   window:   a 1.2 x 1.0 opening through the +X wall, z in [-0.6, 0.6],
 *             y in [0.9, 1.9], with its four reveals closing the wall.
 * The default sun of the analytic "sunsky" map (azimuth 30 degrees from +X
 * towards +Z, elevation 40) shines through the window onto the floor.
 * What it does NOT do: doors, furniture, more windows.
 *
 * Ownership: *out is allocated with sg_alloc_array (free with
 * sg_mesh_free). Errors: SG_ERR_INVALID_ARG (a wall thickness that is not
 * finite and in (0, 1], a cell size that is negative or not finite),
 * SG_ERR_NOMEM. *out is written only on SG_OK.
 * (A window wall as thick as the room's while the others are thin gives
 * a room lit exactly as the thick one through the same window: the
 * stability map's thin_wall case.)
 */
#ifndef SG_POINTS_ROOM_H
#define SG_POINTS_ROOM_H

#include "core/error.h"
#include "io/mesh.h"

#define SG_ROOM_HALF 2.0f         /* inside: x, z in [-HALF, HALF]  */
#define SG_ROOM_HEIGHT 2.5f       /* inside: y in [0, HEIGHT]       */
#define SG_ROOM_WALL 0.2f         /* default wall thickness         */
#define SG_ROOM_WINDOW_Z 0.6f     /* window: z in [-Z, Z] ...       */
#define SG_ROOM_WINDOW_Y0 0.9f    /* ... and y in [Y0, Y1]          */
#define SG_ROOM_WINDOW_Y1 1.9f

typedef struct sg_room_desc {
    float wall;         /* thickness of floor, ceiling and walls; default
                           SG_ROOM_WALL                                   */
    float window_wall;  /* thickness of the +X wall (the window's depth);
                           default: wall                                  */
    float cell;         /* each rectangle as a grid of cells no larger than
                           this (world units), two triangles a cell, so
                           light stored at vertices (the hybrid surface)
                           has that resolution; default 0: two triangles
                           a rectangle (what sampling to points needs)    */
} sg_room_desc;

/* d may be NULL (defaults). */
sg_status sg_room_mesh(const sg_room_desc *d, sg_mesh *out, sg_error *err);

#endif
