/* sample.c — mesh vertices or area-uniform surface samples as splats.
 *
 * Job: the two mesh -> pointset paths of sample.h. Sampling follows pbrt-v4
 * (Pharr, Jakob & Humphreys, §A.5 "sampling a triangle": the square-root
 * warp) with a stratified 1D pass through the area CDF (pbrt §7.3
 * stratification applied to the triangle choice), so each triangle's point
 * count is within +-2 of its area share instead of Poisson-noisy.
 *
 * Invariants:
 *  1. sample i is a pure function of (mesh, seed, i, count): it reads the
 *     shared CDF and vertex arrays and draws from sg_rng keyed by
 *     (seed, i, 0, dim) — bit-identical for any thread count or schedule;
 *  2. the CDF is a sequential double prefix sum (fixed order), strictly
 *     increasing across each positive-area triangle; the triangle of x is
 *     the first t with cdf[t+1] > x, so a zero-area triangle is never
 *     chosen (its cdf[t+1] == cdf[t] would have selected t-1 already);
 *  3. area-weighted vertex normals are accumulated sequentially in double
 *     in triangle order (a scatter: parallelising it would need atomics and
 *     lose the fixed summation order);
 *  4. *out is written only on SG_OK;
 *  5. x_i = (i + xi_i) / count * A is non-decreasing in i (float rounding
 *     is monotone), so the first t with cdf[t+1] > x_i never moves back:
 *     walking forward from sample i-1's triangle finds exactly what a
 *     binary search would, in O(1) amortised, and any chunking gives the
 *     same triangles.
 */
#include "points/sample.h"

#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "math/rng.h"

/* Rank of the neighbour the analytic radius imitates (radius.c default). */
#define ANALYTIC_RADIUS_K 8.0
#define PI_D 3.14159265358979323846
/* Samples per unit of parallel work: the first of a chunk binary-searches
 * the CDF, the rest walk forward from it (invariant 5). */
enum { SAMPLE_CHUNK = 4096 };

static sg_status check_mesh(const sg_mesh *m, sg_error *err)
{
    if (!m)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "mesh is NULL");
    if (m->vertex_count > 0 && !m->positions)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "mesh: %zu vertices but no positions",
                            m->vertex_count);
    if (m->vertex_count >= UINT32_MAX)
        return sg_error_set(err, SG_ERR_UNSUPPORTED, "mesh: %zu vertices is too many",
                            m->vertex_count);
    if (m->triangle_count > 0 && !m->triangles)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "mesh: %zu triangles but no index array",
                            m->triangle_count);
    for (size_t v = 0; v < m->vertex_count; ++v) {
        const float *p = m->positions + 3 * v;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
            return sg_error_set(err, SG_ERR_INVALID_ARG,
                                "mesh: vertex %zu: position (%g, %g, %g) is not finite", v,
                                (double)p[0], (double)p[1], (double)p[2]);
    }
    for (size_t t = 0; t < m->triangle_count; ++t)
        for (int c = 0; c < 3; ++c)
            if (m->triangles[3 * t + c] >= m->vertex_count)
                return sg_error_set(err, SG_ERR_INVALID_ARG,
                                    "mesh: triangle %zu: vertex index %u out of range (%zu vertices)",
                                    t, m->triangles[3 * t + c], m->vertex_count);
    return SG_OK;
}

static sg_vec3 vertex(const sg_mesh *m, uint32_t v)
{
    const float *p = m->positions + 3 * (size_t)v;
    return sg_v3(p[0], p[1], p[2]);
}

/* Unnormalised face normal, in double: its length is twice the area. */
static void face_cross(const sg_mesh *m, size_t t, double c[3])
{
    const uint32_t *tri = m->triangles + 3 * t;
    const float *a = m->positions + 3 * (size_t)tri[0];
    const float *b = m->positions + 3 * (size_t)tri[1];
    const float *d = m->positions + 3 * (size_t)tri[2];
    double e1[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
    double e2[3] = {(double)d[0] - a[0], (double)d[1] - a[1], (double)d[2] - a[2]};
    c[0] = e1[1] * e2[2] - e1[2] * e2[1];
    c[1] = e1[2] * e2[0] - e1[0] * e2[2];
    c[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

/* Per-vertex unit normals into nrm[3*V] (zero = unknown): file normals,
 * and where those are absent or zero, area-weighted face normals
 * (invariant 3). */
static sg_status vertex_normals(const sg_mesh *m, float *nrm, sg_error *err)
{
    size_t nv = m->vertex_count;
    int need_faces = 0;
    for (size_t v = 0; v < nv; ++v) {
        sg_vec3 n = m->normals ? sg_v3(m->normals[3 * v], m->normals[3 * v + 1], m->normals[3 * v + 2])
                               : sg_v3(0, 0, 0);
        n = sg_v3_isfinite(n) ? sg_v3_normalize(n) : sg_v3(0, 0, 0);
        nrm[3 * v] = n.x;
        nrm[3 * v + 1] = n.y;
        nrm[3 * v + 2] = n.z;
        need_faces |= n.x == 0.0f && n.y == 0.0f && n.z == 0.0f;
    }
    if (!need_faces || m->triangle_count == 0)
        return SG_OK;
    double *acc = sg_calloc_array(nv, 3 * sizeof(double));
    if (!acc)
        return sg_error_set(err, SG_ERR_NOMEM, "mesh: cannot allocate %zu vertex normals", nv);
    for (size_t t = 0; t < m->triangle_count; ++t) {
        double c[3];
        face_cross(m, t, c);
        for (int k = 0; k < 3; ++k) {
            double *a = acc + 3 * (size_t)m->triangles[3 * t + k];
            a[0] += c[0];
            a[1] += c[1];
            a[2] += c[2];
        }
    }
    for (size_t v = 0; v < nv; ++v) {
        float *n = nrm + 3 * v;
        if (n[0] != 0.0f || n[1] != 0.0f || n[2] != 0.0f)
            continue;
        const double *a = acc + 3 * v;
        double len = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        if (len > 0.0 && isfinite(len)) {
            n[0] = (float)(a[0] / len);
            n[1] = (float)(a[1] / len);
            n[2] = (float)(a[2] / len);
        }
    }
    sg_free(acc);
    return SG_OK;
}

sg_status sg_points_from_vertices(const sg_mesh *m, sg_pointset *out, sg_error *err)
{
    if (!out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "from_vertices: output pointset is NULL");
    sg_status st = check_mesh(m, err);
    if (st != SG_OK)
        return st;
    size_t nv = m->vertex_count;
    sg_pointset ps = {0};
    float *nrm = sg_alloc_array(nv, 3 * sizeof(float));
    if (!nrm)
        return sg_error_set(err, SG_ERR_NOMEM, "from_vertices: cannot allocate %zu normals", nv);
    st = vertex_normals(m, nrm, err);
    if (st == SG_OK)
        st = sg_pointset_alloc(&ps, nv, err);
    if (st != SG_OK) {
        sg_free(nrm);
        return st;
    }
    for (size_t v = 0; v < nv; ++v) {
        ps.px[v] = m->positions[3 * v];
        ps.py[v] = m->positions[3 * v + 1];
        ps.pz[v] = m->positions[3 * v + 2];
        ps.nx[v] = nrm[3 * v];
        ps.ny[v] = nrm[3 * v + 1];
        ps.nz[v] = nrm[3 * v + 2];
        ps.radius[v] = m->radii ? m->radii[v] : 0.0f;
        if (m->colors) {
            ps.ar[v] = m->colors[3 * v];
            ps.ag[v] = m->colors[3 * v + 1];
            ps.ab[v] = m->colors[3 * v + 2];
        }
    }
    sg_free(nrm);
    *out = ps;
    return SG_OK;
}

/* What every sample reads, and where it writes. */
typedef struct sampler {
    const sg_mesh *m;  /* the mesh                          */
    const float *nrm;  /* per-vertex unit normals, 3 per v   */
    uint64_t seed;     /* random stream                      */
    float radius;      /* analytic radius for every sample   */
    sg_pointset *ps;   /* output, count samples              */
} sampler;

/* First t in [0, nt) with cdf[t+1] > x, or nt. */
static size_t cdf_search(const double *cdf, size_t nt, double x)
{
    size_t lo = 0, hi = nt;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (cdf[mid + 1] > x)
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

/* Sample i on triangle t: position, smooth normal, colour, radius. */
static void sample_one(const sampler *s, size_t i, size_t t)
{
    const sg_mesh *m = s->m;
    const uint32_t *tri = m->triangles + 3 * t;
    float a = sg_rng_float(s->seed, i, 0, 1), b = sg_rng_float(s->seed, i, 0, 2);
    float sa = sqrtf(a);
    float b1 = sa * (1.0f - b), b2 = sa * b, b0 = 1.0f - sa;
    sg_vec3 p0 = vertex(m, tri[0]), p1 = vertex(m, tri[1]), p2 = vertex(m, tri[2]);
    sg_vec3 p = sg_v3_madd(sg_v3_madd(p0, sg_v3_sub(p1, p0), b1), sg_v3_sub(p2, p0), b2);
    const float *n0 = s->nrm + 3 * (size_t)tri[0], *n1 = s->nrm + 3 * (size_t)tri[1],
                *n2 = s->nrm + 3 * (size_t)tri[2];
    sg_vec3 nv = sg_v3(b0 * n0[0] + b1 * n1[0] + b2 * n2[0], b0 * n0[1] + b1 * n1[1] + b2 * n2[1],
                       b0 * n0[2] + b1 * n1[2] + b2 * n2[2]);
    nv = sg_v3_normalize(nv);
    if (nv.x == 0.0f && nv.y == 0.0f && nv.z == 0.0f) {
        double fc[3]; /* face normal in double: nonzero for positive area */
        face_cross(m, t, fc);
        double len = sqrt(fc[0] * fc[0] + fc[1] * fc[1] + fc[2] * fc[2]);
        nv = sg_v3((float)(fc[0] / len), (float)(fc[1] / len), (float)(fc[2] / len));
    }
    sg_pointset *ps = s->ps;
    ps->px[i] = p.x;
    ps->py[i] = p.y;
    ps->pz[i] = p.z;
    ps->nx[i] = nv.x;
    ps->ny[i] = nv.y;
    ps->nz[i] = nv.z;
    ps->radius[i] = s->radius;
    if (m->colors) {
        const float *c0 = m->colors + 3 * (size_t)tri[0], *c1 = m->colors + 3 * (size_t)tri[1],
                    *c2 = m->colors + 3 * (size_t)tri[2];
        ps->ar[i] = b0 * c0[0] + b1 * c1[0] + b2 * c2[0];
        ps->ag[i] = b0 * c0[1] + b1 * c1[1] + b2 * c2[1];
        ps->ab[i] = b0 * c0[2] + b1 * c1[2] + b2 * c2[2];
    }
}

sg_status sg_points_sample_mesh(const sg_mesh *m, const sg_sample_desc *d, sg_pointset *out,
                                sg_error *err)
{
    if (!out || !d)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sample_mesh: NULL desc or output pointset");
    sg_status st = check_mesh(m, err);
    if (st != SG_OK)
        return st;
    size_t n = d->count;
    float scale = d->radius_scale != 0.0f ? d->radius_scale : 1.0f;
    if (n == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sample_mesh: desc.count is 0 (required)");
    if (!isfinite(scale) || !(scale > 0.0f))
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "sample_mesh: radius_scale %g is not finite and positive", (double)scale);
    size_t nt = m->triangle_count;
    if (nt == 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "sample_mesh: mesh has no triangles (a point cloud); use sg_points_from_vertices");

    sg_pointset ps = {0};
    float *nrm = NULL;
    double *cdf = sg_alloc_array(nt + 1, sizeof(double)); /* invariant 2 */
    if (!cdf) {
        st = sg_error_set(err, SG_ERR_NOMEM, "sample_mesh: cannot allocate the CDF of %zu triangles", nt);
        goto done;
    }
    cdf[0] = 0.0;
    size_t last = nt; /* last triangle of positive area */
    for (size_t t = 0; t < nt; ++t) {
        double c[3];
        face_cross(m, t, c);
        double area = 0.5 * sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        if (!isfinite(area)) {
            st = sg_error_set(err, SG_ERR_INVALID_ARG, "sample_mesh: triangle %zu: area is not finite", t);
            goto done;
        }
        cdf[t + 1] = cdf[t] + area;
        if (area > 0.0)
            last = t;
    }
    double total = cdf[nt];
    if (!(total > 0.0) || last == nt) {
        st = sg_error_set(err, SG_ERR_INVALID_ARG,
                          "sample_mesh: none of the %zu triangles has positive area", nt);
        goto done;
    }
    float radius = (float)((double)scale * sqrt(ANALYTIC_RADIUS_K * total / (PI_D * (double)n)));
    if (!isfinite(radius) || !(radius > 0.0f)) {
        st = sg_error_set(err, SG_ERR_INVALID_ARG,
                          "sample_mesh: analytic radius %g (area %g, %zu points) is not usable",
                          (double)radius, total, n);
        goto done;
    }
    nrm = sg_alloc_array(m->vertex_count, 3 * sizeof(float));
    if (!nrm) {
        st = sg_error_set(err, SG_ERR_NOMEM, "sample_mesh: cannot allocate %zu normals", m->vertex_count);
        goto done;
    }
    st = vertex_normals(m, nrm, err);
    if (st != SG_OK)
        goto done;
    st = sg_pointset_alloc(&ps, n, err);
    if (st != SG_OK)
        goto done;

    sampler sm = {m, nrm, d->seed, radius, &ps};
    const double inv_n = 1.0 / (double)n;
    const size_t chunks = (n + SAMPLE_CHUNK - 1) / SAMPLE_CHUNK;
#pragma omp parallel for schedule(static)
    for (size_t c = 0; c < chunks; ++c) {
        size_t begin = c * SAMPLE_CHUNK, end = begin + SAMPLE_CHUNK < n ? begin + SAMPLE_CHUNK : n;
        size_t cur = 0; /* first t with cdf[t+1] > x, or nt (invariant 5) */
        for (size_t i = begin; i < end; ++i) {
            /* Stratum i of [0,1), jittered with 53 bits, scaled to the area. */
            double xi = (double)(sg_rng_bits(d->seed, i, 0, 0) >> 11) * 0x1p-53;
            double x = ((double)i + xi) * inv_n * total;
            if (i == begin)
                cur = cdf_search(cdf, nt, x);
            else
                while (cur < nt && !(cdf[cur + 1] > x))
                    ++cur;
            sample_one(&sm, i, cur < nt ? cur : last); /* nt: x rounded up to A */
        }
    }
    *out = ps;
    ps = (sg_pointset){0};

done:
    sg_pointset_free(&ps);
    sg_free(nrm);
    sg_free(cdf);
    return st;
}
