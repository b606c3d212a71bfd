/* irradiance_table.c — see irradiance_table.h.
 *
 * Invariants:
 *  1. E holds 3 rows cols floats, row j at polar angle pi (j + 0.5) / rows
 *     of the map's own (rotated) frame, column i at u = (i + 0.5) / cols;
 *     every value finite and >= 0.
 *  2. cell[] holds each cell's power, sum L dOmega over the grid points
 *     in it (the weight its centre direction gets in the sum for E0); the
 *     cells' powers add up to the map's power (exactly when the grid is
 *     the map's texel grid).
 */
#include "envmap/irradiance_table.h"

#include <assert.h>
#include <math.h>
#include <omp.h>

#include "core/alloc.h"

static const double PI = 3.14159265358979323846;

enum { MAX_BRIGHT = 1024 };
static const double BRIGHT_SHARE = 1e-4;
static const double BRIGHT_OVER_MEAN = 64.0; /* x the mean texel's power */

/* Luminance of texel (i, j) as stored. */
static double texel_lum(const sg_envmap *m, int i, int j, int W, int H)
{
    (void)W, (void)H;
    sg_vec3 L = sg_envmap_texel(m, i, j);
    return 0.2126 * L.x + 0.7152 * L.y + 0.0722 * L.z;
}

/* Cells per side of the fast table's octahedral grid: 1.4 degrees each,
 * 200 KB of vertices (fits a core's L2). */
enum { FAST = 128 };

struct sg_irradiance_table {
    int rows, cols;  /* table of normals, invariant 1      */
    float *E;        /* 3 rows cols RGB irradiances         */
    float pole[2][3];/* E0 at the +Y and -Y poles of the map's frame: the
                        first and last rows lie half a row away, at one
                        azimuth each side, so the poles need their own
                        values (a low sun changes E0 fast there)       */
    int bright;      /* texels taken out of the table: a sun  */
    float *bright_w; /* 3 per bright texel: its unit direction */
    float *bright_p; /* 3 per bright texel: its power L dOmega */
    const sg_envmap *map; /* for the uv of a normal only: sg_envmap_dir_to_uv
                             is a pure function of the rotation; the map
                             must outlive the table (bake-time use)     */
    float *fast;     /* (FAST + 1)^2 RGB: sg_irradiance_table_eval at the
                        vertices of an octahedral grid of normals        */
};

/* The octahedral map of unit normals with +Y at the centre of the square
 * [-1,1]^2 (Engelhardt & Dachsbacher 2008, here about Y): continuous, its
 * square's border folds onto itself, so a grid of values at vertices
 * interpolates bilinearly with no seam and no wrap logic. */
static sg_vec3 octahedral_decode(float a, float b)
{
    float y = 1.0f - fabsf(a) - fabsf(b), x = a, z = b;
    if (y < 0.0f) {
        x = (1.0f - fabsf(b)) * (a < 0.0f ? -1.0f : 1.0f);
        z = (1.0f - fabsf(a)) * (b < 0.0f ? -1.0f : 1.0f);
    }
    return sg_v3_normalize(sg_v3(x, y, z));
}

sg_status sg_irradiance_table_create(const sg_envmap *m, const sg_irradiance_table_desc *desc,
                                     sg_irradiance_table **out, sg_error *err)
{
    sg_irradiance_table_desc d = desc ? *desc : (sg_irradiance_table_desc){0};
    if (d.rows == 0) d.rows = 64;
    if (d.cell_rows == 0) d.cell_rows = 128;
    if (d.rows < 4 || d.rows > 512 || d.cell_rows < 4 || d.cell_rows > 1024)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "irradiance table: %d rows, %d cell rows (each in [4, 512] / [4, 1024])",
                            d.rows, d.cell_rows);
    int threads = d.threads > 0 ? d.threads : omp_get_max_threads();
    sg_envmap_info info;
    sg_envmap_get_info(m, &info);
    const int W = info.width, H = info.height, CR = d.cell_rows, CC = 2 * d.cell_rows;
    assert(W > 0 && H > 0);
    sg_irradiance_table *t = sg_calloc_array(1, sizeof *t);
    double *cell = sg_calloc_array((size_t)3 * CR * CC, sizeof *cell);  /* sum L dOmega per cell */
    float *dir = sg_alloc_array((size_t)3 * CR * CC, sizeof *dir);       /* world direction       */
    if (!t || !cell || !dir ||
        !(t->E = sg_alloc_array((size_t)3 * d.rows * 2 * d.rows, sizeof *t->E))) {
        sg_irradiance_table_destroy(t);
        t = NULL;
        sg_free(cell);
        sg_free(dir);
        return sg_error_set(err, SG_ERR_NOMEM, "irradiance table: out of memory");
    }
    t->rows = d.rows;
    t->cols = 2 * d.rows;
    t->map = m;
    /* The brightest texels (a sun) are kept apart as exact directional
     * lights: in a cell their direction would move by up to a degree, and
     * interpolating between normals would round the kink of their clamped
     * cosine, errors of several percent near a low sun. A texel is bright
     * when its power exceeds BRIGHT_SHARE of the map's and BRIGHT_OVER_MEAN
     * times the mean texel's, at most
     * MAX_BRIGHT of them (the threshold doubles until they fit). */
    double total = 0.0;
    for (int j = 0; j < H; ++j) {
        double dom = (cos(PI * j / H) - cos(PI * (j + 1) / H)) * 2.0 * PI / W;
        for (int i = 0; i < W; ++i)
            total += texel_lum(m, i, j, W, H) * dom;
    }
    /* Bright means an outlier as well: on a small smooth map every texel
     * may hold 1e-4 of the power, and summing them all exactly would only
     * slow eval down. */
    double threshold = fmax(BRIGHT_SHARE * total, BRIGHT_OVER_MEAN * total / ((double)W * (double)H));
    int bright_cap = 0; /* entries allocated in bright_w, bright_p */
    for (;;) {
        int count = 0;
        for (int j = 0; j < H && count <= MAX_BRIGHT; ++j) {
            double dom = (cos(PI * j / H) - cos(PI * (j + 1) / H)) * 2.0 * PI / W;
            for (int i = 0; i < W && count <= MAX_BRIGHT; ++i)
                count += texel_lum(m, i, j, W, H) * dom > threshold;
        }
        if (count <= MAX_BRIGHT && count > 0 &&
            !(t->bright_w = sg_alloc_array((size_t)3 * count, sizeof *t->bright_w),
              t->bright_p = sg_alloc_array((size_t)3 * count, sizeof *t->bright_p), t->bright_w && t->bright_p)) {
            sg_irradiance_table_destroy(t);
            sg_free(cell);
            sg_free(dir);
            return sg_error_set(err, SG_ERR_NOMEM, "irradiance table: out of memory");
        }
        if (count <= MAX_BRIGHT) {
            bright_cap = count;
            break;
        }
        threshold *= 2.0;
    }
    /* Box filter (invariant 2) on a grid of at least the map's texels and
     * at least 4 x 4 points per cell: a fine map is read once per texel
     * centre (its exact power), a coarse one (a uniform map of one texel)
     * is spread over every cell instead of landing in the first. Grid
     * point (i, j) spans polar angles [pi j / GH, pi (j + 1) / GH]:
     * dOmega = (cos a - cos b) 2 pi / GW. A grid point of a bright texel
     * (fine maps only: the grid is then the texel grid) goes to the
     * bright list instead of its cell. */
    const int GW = W > 4 * CC ? W : 4 * CC, GH = H > 4 * CR ? H : 4 * CR;
    const int fine = GW == W && GH == H;
    for (int j = 0; j < GH; ++j) {
        double dom = (cos(PI * j / GH) - cos(PI * (j + 1) / GH)) * 2.0 * PI / GW;
        int cj = (int)((size_t)j * CR / GH);
        for (int i = 0; i < GW; ++i) {
            float u = ((float)i + 0.5f) / (float)GW, v = ((float)j + 0.5f) / (float)GH;
            sg_vec3 w = sg_envmap_uv_to_dir(m, u, v);
            /* The texel grid reads the texels themselves; a finer grid
             * reads the bilinear lookup between them. */
            sg_vec3 L = fine ? sg_envmap_texel(m, i, j) : sg_envmap_eval(m, w);
            if (fine && t->bright < bright_cap && (0.2126 * L.x + 0.7152 * L.y + 0.0722 * L.z) * dom > threshold) {
                float *bw = t->bright_w + 3 * t->bright, *bp = t->bright_p + 3 * t->bright;
                bw[0] = w.x; bw[1] = w.y; bw[2] = w.z;
                bp[0] = (float)(L.x * dom); bp[1] = (float)(L.y * dom); bp[2] = (float)(L.z * dom);
                t->bright++;
                continue;
            }
            size_t c = (size_t)cj * CC + (size_t)((size_t)i * CC / GW);
            cell[3 * c] += L.x * dom;
            cell[3 * c + 1] += L.y * dom;
            cell[3 * c + 2] += L.z * dom;
        }
    }
    for (int cj = 0; cj < CR; ++cj)
        for (int ci = 0; ci < CC; ++ci) {
            size_t c = (size_t)cj * CC + ci;
            sg_vec3 w = sg_envmap_uv_to_dir(m, ((float)ci + 0.5f) / CC, ((float)cj + 0.5f) / CR);
            dir[3 * c] = w.x;
            dir[3 * c + 1] = w.y;
            dir[3 * c + 2] = w.z;
        }
    int n = t->rows * t->cols;
#pragma omp parallel for schedule(dynamic, 8) num_threads(threads)
    for (int e = 0; e < n + 2; ++e) {
        /* Entries [0, n) the grid, n and n + 1 the two poles. */
        int j = e / t->cols, i = e % t->cols;
        sg_vec3 nrm = e < n ? sg_envmap_uv_to_dir(m, ((float)i + 0.5f) / t->cols, ((float)j + 0.5f) / t->rows)
                            : sg_envmap_uv_to_dir(m, 0.5f, e == n ? 0.0f : 1.0f);
        double s[3] = {0, 0, 0};
        for (size_t c = 0; c < (size_t)CR * CC; ++c) {
            double dot = nrm.x * dir[3 * c] + nrm.y * dir[3 * c + 1] + nrm.z * dir[3 * c + 2];
            if (dot > 0.0) {
                s[0] += cell[3 * c] * dot;
                s[1] += cell[3 * c + 1] * dot;
                s[2] += cell[3 * c + 2] * dot;
            }
        }
        float *dst = e < n ? t->E + 3 * (size_t)e : t->pole[e - n];
        for (int k = 0; k < 3; ++k)
            dst[k] = isfinite(s[k]) && s[k] > 0.0 ? (float)s[k] : 0.0f;
    }
    sg_free(cell);
    sg_free(dir);
    /* The fast table: the exact eval at every vertex of the octahedral grid. */
    size_t nv = (size_t)(FAST + 1) * (FAST + 1);
    if (!(t->fast = sg_alloc_array(3 * nv, sizeof *t->fast))) {
        sg_irradiance_table_destroy(t);
        return sg_error_set(err, SG_ERR_NOMEM, "irradiance table: out of memory");
    }
#pragma omp parallel for schedule(static) num_threads(threads)
    for (size_t v = 0; v < nv; ++v) {
        float a = -1.0f + 2.0f * (float)(v % (FAST + 1)) / FAST, b = -1.0f + 2.0f * (float)(v / (FAST + 1)) / FAST;
        sg_vec3 e = sg_irradiance_table_eval(t, octahedral_decode(a, b));
        t->fast[3 * v] = e.x, t->fast[3 * v + 1] = e.y, t->fast[3 * v + 2] = e.z;
    }
    *out = t;
    return SG_OK;
}

void sg_irradiance_table_destroy(sg_irradiance_table *t)
{
    if (!t)
        return;
    sg_free(t->fast);
    sg_free(t->E);
    sg_free(t->bright_w);
    sg_free(t->bright_p);
    sg_free(t);
}

static sg_vec3 table_part(const sg_irradiance_table *t, sg_vec3 n)
{
    float u, v;
    sg_envmap_dir_to_uv(t->map, n, &u, &v);
    /* Bilinear between entry centres, wrapping in u; between the first
     * (last) row and the pole above (below) it, linear in v. */
    float x = u * t->cols - 0.5f, y = v * t->rows - 0.5f;
    float fx = floorf(x);
    float ax = x - fx;
    int x0 = (int)fx, x1 = x0 + 1;
    x0 = ((x0 % t->cols) + t->cols) % t->cols;
    x1 = ((x1 % t->cols) + t->cols) % t->cols;
    float r[3];
    if (y < 0.0f || y > (float)(t->rows - 1)) {
        int top = y < 0.0f;
        const float *row = t->E + 3 * ((size_t)(top ? 0 : t->rows - 1) * t->cols);
        float ap = top ? -2.0f * y : 2.0f * (y - (float)(t->rows - 1)); /* 0 at the row, 1 at the pole */
        ap = ap > 1.0f ? 1.0f : ap;
        for (int k = 0; k < 3; ++k) {
            float row_k = (1 - ax) * row[3 * x0 + k] + ax * row[3 * x1 + k];
            r[k] = (1 - ap) * row_k + ap * t->pole[top ? 0 : 1][k];
        }
        return sg_v3(r[0], r[1], r[2]);
    }
    float fy = floorf(y), ay = y - fy;
    int y0 = (int)fy, y1 = y0 + 1 < t->rows ? y0 + 1 : y0;
    const float *a = t->E + 3 * ((size_t)y0 * t->cols + x0), *b = t->E + 3 * ((size_t)y0 * t->cols + x1);
    const float *c = t->E + 3 * ((size_t)y1 * t->cols + x0), *e = t->E + 3 * ((size_t)y1 * t->cols + x1);
    for (int k = 0; k < 3; ++k)
        r[k] = (1 - ay) * ((1 - ax) * a[k] + ax * b[k]) + ay * ((1 - ax) * c[k] + ax * e[k]);
    return sg_v3(r[0], r[1], r[2]);
}

sg_vec3 sg_irradiance_table_eval(const sg_irradiance_table *t, sg_vec3 n)
{
    sg_vec3 e = table_part(t, n);
    float len = sqrtf(sg_v3_dot(n, n));
    if (!(len > 0.0f) || t->bright == 0)
        return e;
    sg_vec3 u = sg_v3_scale(n, 1.0f / len);
    for (int b = 0; b < t->bright; ++b) {
        const float *w = t->bright_w + 3 * b, *p = t->bright_p + 3 * b;
        float c = u.x * w[0] + u.y * w[1] + u.z * w[2];
        if (c > 0.0f) {
            e.x += p[0] * c;
            e.y += p[1] * c;
            e.z += p[2] * c;
        }
    }
    return e;
}

sg_vec3 sg_irradiance_table_eval_fast(const sg_irradiance_table *t, sg_vec3 n)
{
    float s = fabsf(n.x) + fabsf(n.y) + fabsf(n.z);
    if (!(s > 0.0f))
        return sg_irradiance_table_eval(t, n);
    float a = n.x / s, b = n.z / s;
    if (n.y < 0.0f) {
        float a0 = a;
        a = (1.0f - fabsf(b)) * (a0 < 0.0f ? -1.0f : 1.0f);
        b = (1.0f - fabsf(a0)) * (b < 0.0f ? -1.0f : 1.0f);
    }
    float x = (a + 1.0f) * (0.5f * FAST), y = (b + 1.0f) * (0.5f * FAST);
    x = x < 0.0f ? 0.0f : (x > (float)FAST ? (float)FAST : x);
    y = y < 0.0f ? 0.0f : (y > (float)FAST ? (float)FAST : y);
    int i = (int)x, j = (int)y;
    i = i < FAST ? i : FAST - 1;
    j = j < FAST ? j : FAST - 1;
    float fx = x - (float)i, fy = y - (float)j;
    const float *p = t->fast + 3 * ((size_t)j * (FAST + 1) + (size_t)i), *q = p + 3 * (FAST + 1);
    float w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy, w11 = fx * fy;
    return sg_v3(w00 * p[0] + w10 * p[3] + w01 * q[0] + w11 * q[3], w00 * p[1] + w10 * p[4] + w01 * q[1] + w11 * q[4],
                 w00 * p[2] + w10 * p[5] + w01 * q[2] + w11 * q[5]);
}
