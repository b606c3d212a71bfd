/* mesh.h — what a model file holds: vertices (with optional normals, colours
 * and radii) and, for meshes, triangles. A point cloud is a mesh with no
 * triangles. Plain struct; the loaders allocate every array with
 * sg_alloc_array and sg_mesh_free releases them.
 *
 * Layout: positions, normals and colors are interleaved xyz / rgb,
 * 3 floats per vertex, vertex i at [3*i]. radii has one float per vertex.
 * Colours are linear [0,1] floats (8-bit file colours are decoded from sRGB).
 * triangles holds 3 uint32 vertex indices per triangle, counter-clockwise
 * seen from the side the normals point to; every index < vertex_count.
 */
#ifndef SG_IO_MESH_H
#define SG_IO_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "math/vec3.h"

typedef struct sg_mesh {
    size_t vertex_count;   /* number of vertices                          */
    float *positions;      /* 3*vertex_count, never NULL when count > 0   */
    float *normals;        /* 3*vertex_count unit vectors, or NULL        */
    float *colors;         /* 3*vertex_count linear RGB in [0,1], or NULL */
    float *radii;          /* vertex_count splat radii (> 0), or NULL     */
    size_t triangle_count; /* number of triangles (0 for a point cloud)   */
    uint32_t *triangles;   /* 3*triangle_count vertex indices, or NULL    */
} sg_mesh;

/* Reads a .ply (ply.h), .obj (obj.h), .xyz or .txt (xyz.h) or .pcd (pcd.h)
 * file, chosen by extension (case-insensitive), into *out. On failure *out is untouched and err names the file, the element
 * and the fault. */
sg_status sg_mesh_read(const char *path, sg_mesh *out, sg_error *err);

/* Frees every array and zeroes the struct; NULL and zeroed meshes are fine. */
void sg_mesh_free(sg_mesh *mesh);

/* Box of a model file's vertex positions (read, then freed): what the
 * benchmarks and the verifier need to place and frame a scan. */
/* The box of m's vertices (empty for none). */
sg_aabb sg_mesh_bounds(const sg_mesh *m);

sg_status sg_mesh_read_bounds(const char *path, sg_aabb *out, sg_error *err);

/* The uniform scale and translation that make box `b` `length` long on its
 * longest side, centred on x = z = 0 and standing on y = 0 (a scan put on
 * the builtin ground); *placed is the box after them. Fails on an empty or
 * point-sized box. */
typedef struct sg_ground_placement {
    float scale;
    sg_vec3 translate;
    sg_aabb placed;
} sg_ground_placement;
sg_status sg_mesh_ground_placement(sg_aabb b, float length, sg_ground_placement *out, sg_error *err);

#endif
