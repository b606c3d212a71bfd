/* pointset.c — allocation, validation and concatenation of splat sets.
 *
 * Job: own the ten SoA arrays of an sg_pointset (see pointset.h) and check
 * the three invariants every consumer relies on.
 *
 * Invariants kept here (numbers as in pointset.h):
 *  1. after sg_pointset_alloc/append every array holds `count` elements from
 *     sg_alloc_array (64-byte aligned), or the struct is zeroed;
 *  2./3. are only checked (sg_pointset_validate), never repaired: repairing
 *     is the job of points/radius.c and points/normals.c.
 * Failure never leaves a half-grown set: append builds the new arrays aside
 * and swaps them in only when every allocation succeeded.
 */
#include "points/pointset.h"

#include <math.h>
#include <string.h>

#include "core/alloc.h"

enum { NARRAYS = 10 };

/* The ten arrays in a fixed order, so alloc/free/append loop over them. */
static void arrays_of(sg_pointset *ps, float **out[NARRAYS])
{
    out[0] = &ps->px; out[1] = &ps->py; out[2] = &ps->pz;
    out[3] = &ps->nx; out[4] = &ps->ny; out[5] = &ps->nz;
    out[6] = &ps->radius;
    out[7] = &ps->ar; out[8] = &ps->ag; out[9] = &ps->ab;
}

static const float *carray(const sg_pointset *ps, int a)
{
    switch (a) {
    case 0: return ps->px;
    case 1: return ps->py;
    case 2: return ps->pz;
    case 3: return ps->nx;
    case 4: return ps->ny;
    case 5: return ps->nz;
    case 6: return ps->radius;
    case 7: return ps->ar;
    case 8: return ps->ag;
    default: return ps->ab;
    }
}

/* Allocates NARRAYS arrays of n floats into a[]; all or none. */
static int alloc_all(float *a[NARRAYS], size_t n)
{
    for (int i = 0; i < NARRAYS; ++i) {
        a[i] = sg_alloc_array(n, sizeof(float));
        if (!a[i]) {
            for (int j = 0; j < i; ++j)
                sg_free(a[j]);
            return 0;
        }
    }
    return 1;
}

sg_status sg_pointset_alloc(sg_pointset *ps, size_t count, sg_error *err)
{
    if (!ps)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_pointset_alloc: pointset is NULL");
    float *a[NARRAYS];     /* fresh arrays in arrays_of() order */
    if (!alloc_all(a, count))
        return sg_error_set(err, SG_ERR_NOMEM, "pointset: cannot allocate %zu splats", count);
    /* Parallel for large sets: this loop is the first touch of 3 of the
     * 10 arrays, and page faults dominate filling fresh memory. */
#pragma omp parallel for schedule(static) if (count > 65536)
    for (size_t i = 0; i < count; ++i) {
        a[7][i] = 0.8f;
        a[8][i] = 0.8f;
        a[9][i] = 0.8f;
    }
    float **dst[NARRAYS];
    arrays_of(ps, dst);
    for (int i = 0; i < NARRAYS; ++i)
        *dst[i] = a[i];
    ps->count = count;
    return SG_OK;
}

void sg_pointset_free(sg_pointset *ps)
{
    if (!ps)
        return;
    float **a[NARRAYS];
    arrays_of(ps, a);
    for (int i = 0; i < NARRAYS; ++i)
        sg_free(*a[i]);
    memset(ps, 0, sizeof *ps);
}

sg_status sg_pointset_validate(const sg_pointset *ps, sg_error *err)
{
    if (!ps)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "pointset is NULL");
    if (ps->count == 0)
        return SG_OK;
    for (int a = 0; a < NARRAYS; ++a)
        if (!carray(ps, a))
            return sg_error_set(err, SG_ERR_INVALID_ARG,
                                "pointset: %zu splats but array %d is NULL", ps->count, a);
    for (size_t i = 0; i < ps->count; ++i) {
        float x = ps->px[i], y = ps->py[i], z = ps->pz[i];
        if (!isfinite(x) || !isfinite(y) || !isfinite(z))
            return sg_error_set(err, SG_ERR_INVALID_ARG,
                                "pointset: splat %zu: position (%g, %g, %g) is not finite",
                                i, (double)x, (double)y, (double)z);
        float r = ps->radius[i];
        if (!isfinite(r) || !(r > 0.0f))
            return sg_error_set(err, SG_ERR_INVALID_ARG,
                                "pointset: splat %zu: radius %g is not finite and positive",
                                i, (double)r);
        /* Length from doubles so that a sum of three float squares cannot
         * push a good normal past the 1e-3 tolerance. */
        double nx = ps->nx[i], ny = ps->ny[i], nz = ps->nz[i];
        double len = sqrt(nx * nx + ny * ny + nz * nz);
        if (!(fabs(len - 1.0) <= 1e-3))
            return sg_error_set(err, SG_ERR_INVALID_ARG,
                                "pointset: splat %zu: normal (%g, %g, %g) has length %g, not 1",
                                i, nx, ny, nz, len);
    }
    return SG_OK;
}

sg_aabb sg_pointset_bounds(const sg_pointset *ps)
{
    sg_aabb b = sg_aabb_empty();
    if (!ps)
        return b;
    for (size_t i = 0; i < ps->count; ++i)
        b = sg_aabb_grow(b, sg_pointset_position(ps, i));
    return b;
}

sg_status sg_pointset_append(sg_pointset *dst, const sg_pointset *src, sg_error *err)
{
    if (!dst || !src)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_pointset_append: NULL pointset");
    if (src->count == 0)
        return SG_OK;
    size_t n = dst->count + src->count; /* new count */
    if (n < dst->count)
        return sg_error_set(err, SG_ERR_NOMEM, "pointset: %zu + %zu splats overflow",
                            dst->count, src->count);
    float *a[NARRAYS];
    if (!alloc_all(a, n))
        return sg_error_set(err, SG_ERR_NOMEM, "pointset: cannot allocate %zu splats", n);
    for (int i = 0; i < NARRAYS; ++i) {
        const float *d = carray(dst, i), *s = carray(src, i);
        if (dst->count)
            memcpy(a[i], d, dst->count * sizeof(float));
        memcpy(a[i] + dst->count, s, src->count * sizeof(float));
    }
    float **slot[NARRAYS];
    arrays_of(dst, slot);
    for (int i = 0; i < NARRAYS; ++i) {
        sg_free(*slot[i]);
        *slot[i] = a[i];
    }
    dst->count = n;
    return SG_OK;
}
