/* irradiance_table.h — unshadowed irradiance from the environment map as a
 * function of the surface normal, tabulated.
 *
 * What it does: E0(n) = int L(w) max(0, n.w) dw, the irradiance a plane
 * with normal n receives when nothing blocks the map, on a lat-long grid of
 * normals (res rows x 2 res columns, laid out like the map itself, rotation
 * included) with bilinear interpolation. The map is first box-filtered to
 * a 2 res' x res' grid of cells (solid-angle weighted means of its texels,
 * so a tiny sun keeps its power and lands in the cell that holds it);
 * each table entry is the sum over cells of L_cell max(0, n.w_cell)
 * dOmega_cell.
 *
 * Why: the bake computes direct light at sparse sample points and spreads
 * it to the splats between them. Interpolating E itself on a curved
 * surface averages cosines from other normals and darkens the result (a
 * chord lies under the arc); interpolating the ratio E / E0 (the
 * visibility of the light, weighted by where it comes from) and multiplying
 * by E0 at the splat's own normal removes that error; E0 must then be
 * accurate, since it scales the result directly.
 *
 * Bright texels: those holding more than 1e-4 of the map's power and 64
 * times a mean texel's (at most 1024: a sun) are left out of the cells and summed exactly at eval, as
 * directional lights: in a cell a sun's direction would move by up to a
 * degree, and interpolating between normals would round the kink of its
 * clamped cosine (errors of several percent at a ground plane's normal
 * under a low sun).
 *
 * Accuracy (tested against sg_envmap_irradiance, defaults): about 1e-4 of
 * the largest E0, suns included. Cost: 8192 entries x 32768 cells at
 * creation (~0.3 s), eval a bilinear fetch plus the bright texels.
 *
 * Thread-safety: create once; eval is pure.
 */
#ifndef SG_ENVMAP_IRRADIANCE_TABLE_H
#define SG_ENVMAP_IRRADIANCE_TABLE_H

#include "core/error.h"
#include "envmap/envmap.h"
#include "math/vec3.h"

typedef struct sg_irradiance_table sg_irradiance_table; /* opaque */

typedef struct sg_irradiance_table_desc {
    int rows;       /* normals per column of the table; default 64; [4, 512] */
    int cell_rows;  /* rows of the filtered map; default 128; [4, 1024]      */
    int threads;    /* 0 = OpenMP default                                    */
} sg_irradiance_table_desc;

/* Builds the table for m (d may be NULL: defaults). SG_ERR_INVALID_ARG for
 * sizes out of range, SG_ERR_NOMEM. On failure *out is untouched. */
sg_status sg_irradiance_table_create(const sg_envmap *m, const sg_irradiance_table_desc *d,
                                     sg_irradiance_table **out, sg_error *err);

void sg_irradiance_table_destroy(sg_irradiance_table *t);

/* E0 at world normal n (need not be unit; zero gives the +Y pole's value);
 * RGB, >= 0, finite. */
sg_vec3 sg_irradiance_table_eval(const sg_irradiance_table *t, sg_vec3 n);

/* E0 at world normal n from a second, fast table: sg_irradiance_table_eval
 * at the vertices of a 128 x 128 octahedral grid of normals (+Y at its
 * centre), bilinear between them: a dozen loads and no trigonometry, for
 * per-pixel use. Exact at the vertices; between them the interpolation
 * rounds a sun's terminator over one cell (1.4 degrees) and is otherwise
 * smooth: its error is measured in tests/envmap/test_irradiance_table.c.
 * RGB, >= 0, finite. */
sg_vec3 sg_irradiance_table_eval_fast(const sg_irradiance_table *t, sg_vec3 n);

#endif
