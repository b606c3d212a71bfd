/* test_support.h — small helpers shared by the cmocka suites.
 * cmocka needs these includes in this order. */
#ifndef SG_TEST_SUPPORT_H
#define SG_TEST_SUPPORT_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdbool.h>

#include "math/vec3.h"

/* Writes `size` bytes to a fresh file under the test's temp folder and
 * returns its path (static storage, overwritten by the next call with the
 * same name). Fails the test on I/O errors. */
const char *sg_test_write_file(const char *name, const void *data, size_t size);

/* The whole file at path in a malloc'd buffer (free it), its length in
 * *size. Fails the test on I/O errors. */
void *sg_test_read_file(const char *path, size_t *size);

/* Path of a fresh, empty temporary folder for this test binary. */
const char *sg_test_tmpdir(void);

/* sg_test_tmpdir()/name in one of 8 rotating buffers (so a call can name
 * several paths at once). */
const char *sg_test_tmp_path(const char *name);

/* Path of a file under ../shared/data, or NULL (with a message on stderr
 * saying the test is skipped) when the folder or file is absent. */
const char *sg_test_shared_data(const char *relpath);

/* The world of a scene given as JSON text (relative paths against the
 * working directory); fails the test with the library's message when the
 * scene or the world cannot be made. Free with sg_world_destroy. */
struct sg_world;
struct sg_world *sg_test_world_from_json(const char *json);

/* Area of the unit pixel square at (i, j) where a x + b y < c: the square
 * clipped by the half-plane (Sutherland-Hodgman), shoelace, in double.
 * The exact coverage anti-aliasing tests compare against. */
double sg_test_half_plane_area(double a, double b, double c, int i, int j);

/* Points on the six faces of the cube [-1,1]^3 on a g x g grid per face,
 * spacing h = 2 / (g - 1) into *spacing (grid points on edges belong to
 * each face that shares them), face normals, radius 2 h. */
struct sg_pointset;
void sg_test_make_cube(struct sg_pointset *ps, int g, float *spacing);

/* A two-sided square sheet [-1,1]^2 of thickness `thick` in the xz-plane,
 * g x g points a side: the top layer (y = +thick/2) faces +y, the bottom
 * faces -y; spacing as above, radius 2 h. */
void sg_test_make_sheet(struct sg_pointset *ps, int g, float thick, float *spacing);

/* Deterministic uniform float in [0,1) from a 64-bit state (splitmix64). */
float sg_test_rand01(uint64_t *state);

/* A unit vector uniform on the sphere, from two sg_test_rand01 draws. */
sg_vec3 sg_test_random_dir(uint64_t *state);

/* The same, mirrored into n's hemisphere where it points away from n (the
 * direction of a ray spawned off a surface of normal n). */
sg_vec3 sg_test_random_dir_facing(uint64_t *state, sg_vec3 n);

#endif
