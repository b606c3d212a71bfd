/* test_support.c — see test_support.h. */
#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/scene_file.h"
#include "points/pointset.h"
#include "render/world.h"

const char *sg_test_tmpdir(void)
{
    static char dir[512];
    if (!dir[0]) {
        snprintf(dir, sizeof dir, "%s/tmp-%ld", SG_TEST_BINARY_DIR, (long)getpid());
        mkdir(dir, 0777);
    }
    return dir;
}

const char *sg_test_tmp_path(const char *name)
{
    static char ring[8][1024];
    static int next;
    char *p = ring[next++ % 8];
    snprintf(p, sizeof ring[0], "%s/%s", sg_test_tmpdir(), name);
    return p;
}

const char *sg_test_write_file(const char *name, const void *data, size_t size)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", sg_test_tmpdir(), name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, size, f), size);
    assert_int_equal(fclose(f), 0);
    return path;
}

void *sg_test_read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    void *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *size = (size_t)n;
    return buf;
}

const char *sg_test_shared_data(const char *relpath)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", SG_SHARED_DATA_DIR, relpath);
    if (access(path, R_OK) != 0) {
        fprintf(stderr, "skipping: %s not present (../shared/data absent)\n", path);
        return NULL;
    }
    return path;
}

float sg_test_rand01(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (float)(z >> 40) * (1.0f / 16777216.0f);
}

sg_vec3 sg_test_random_dir(uint64_t *state)
{
    const float pi = 3.14159265358979f;
    float z = 1.0f - 2.0f * sg_test_rand01(state), phi = 2.0f * pi * sg_test_rand01(state);
    float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    return sg_v3(r * cosf(phi), r * sinf(phi), z);
}

sg_vec3 sg_test_random_dir_facing(uint64_t *state, sg_vec3 n)
{
    sg_vec3 d = sg_test_random_dir(state);
    return sg_v3_dot(d, n) < 0.0f ? sg_v3_scale(d, -1.0f) : d;
}

struct sg_world *sg_test_world_from_json(const char *json)
{
    sg_scene_file sf;
    sg_error err = {0};
    if (sg_scene_file_parse(json, strlen(json), "test.json", NULL, &sf, &err) != SG_OK)
        fail_msg("scene: %s", err.message);
    sg_world *w = NULL;
    if (sg_world_create(&sf, &w, &err) != SG_OK)
        fail_msg("world: %s", err.message);
    sg_scene_file_free(&sf);
    return w;
}

double sg_test_half_plane_area(double a, double b, double c, int i, int j)
{
    double px[8], py[8];
    const double sx[4] = {i, i + 1, i + 1, i}, sy[4] = {j, j, j + 1, j + 1};
    int n = 0;
    for (int k = 0; k < 4; ++k) {
        int k1 = (k + 1) % 4;
        double f0 = a * sx[k] + b * sy[k] - c, f1 = a * sx[k1] + b * sy[k1] - c;
        if (f0 < 0.0) {
            px[n] = sx[k];
            py[n++] = sy[k];
        }
        if ((f0 < 0.0) != (f1 < 0.0)) {
            double s = f0 / (f0 - f1);
            px[n] = sx[k] + s * (sx[k1] - sx[k]);
            py[n++] = sy[k] + s * (sy[k1] - sy[k]);
        }
    }
    double a2 = 0.0;
    for (int k = 0; k < n; ++k)
        a2 += px[k] * py[(k + 1) % n] - px[(k + 1) % n] * py[k];
    return fabs(a2) * 0.5;
}

/* Points on the six faces of the cube [-1,1]^3 on a regular grid (grid
 * points on edges belong to each face that shares them), face normals. */
void sg_test_make_cube(sg_pointset *ps, int g, float *spacing)
{
    size_t n = (size_t)6 * g * g;
    assert_int_equal(sg_pointset_alloc(ps, n, NULL), SG_OK);
    float h = 2.0f / (float)(g - 1);
    size_t k = 0;
    for (int f = 0; f < 6; ++f) {
        int axis = f / 2;
        float side = (f & 1) ? 1.0f : -1.0f;
        for (int i = 0; i < g; ++i)
            for (int j = 0; j < g; ++j, ++k) {
                float c[3], nn[3] = {0, 0, 0};
                c[axis] = side;
                c[(axis + 1) % 3] = -1.0f + h * (float)i;
                c[(axis + 2) % 3] = -1.0f + h * (float)j;
                nn[axis] = side;
                ps->px[k] = c[0]; ps->py[k] = c[1]; ps->pz[k] = c[2];
                ps->nx[k] = nn[0]; ps->ny[k] = nn[1]; ps->nz[k] = nn[2];
                ps->radius[k] = 2.0f * h;
            }
    }
    *spacing = h;
}

/* A two-sided square sheet of thickness `thick` in the xz-plane: the top
 * layer (y = +thick/2) faces +y, the bottom faces -y. */
void sg_test_make_sheet(sg_pointset *ps, int g, float thick, float *spacing)
{
    size_t n = (size_t)2 * g * g;
    assert_int_equal(sg_pointset_alloc(ps, n, NULL), SG_OK);
    float h = 2.0f / (float)(g - 1);
    size_t k = 0;
    for (int s = 0; s < 2; ++s)
        for (int i = 0; i < g; ++i)
            for (int j = 0; j < g; ++j, ++k) {
                float side = s ? -1.0f : 1.0f;
                ps->px[k] = -1.0f + h * (float)i;
                ps->py[k] = side * 0.5f * thick;
                ps->pz[k] = -1.0f + h * (float)j;
                ps->nx[k] = 0; ps->ny[k] = side; ps->nz[k] = 0;
                ps->radius[k] = 2.0f * h;
            }
    *spacing = h;
}
