/* iso_sites.c — the corners of an ISO as light sites (iso_sites.h).
 *
 * Invariants:
 *  1. every corner is used by some stored leaf (iso_build.c creates corners
 *     for stored leaves only), so every site gets a position, a reach and a
 *     colour from the leaves;
 *  2. a leaf's corner 0 and corner 7 are its box's low and high corners, at
 *     the same floats as sg_iso_leaf_boxes (both come from iso_coord).
 */
#include "surface/iso_sites.h"

#include <assert.h>
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "surface/iso_int.h"

enum { SITE_ARRAYS = 10 };

sg_status sg_iso_sites_create(const sg_iso *iso, const sg_pointset *points, sg_iso_sites *out, sg_error *err)
{
    assert(iso && points && out);
    memset(out, 0, sizeof *out);
    size_t n = iso->corner_count, leaves = iso->leaf_count;
    float *data = sg_alloc_array(SITE_ARRAYS * (n ? n : 1), sizeof(float));
    uint32_t *splat = sg_alloc_array(n ? n : 1, sizeof *splat);
    sg_aabb *box = sg_alloc_array(leaves ? leaves : 1, sizeof *box);
    if (!data || !splat || !box) {
        sg_free(data);
        sg_free(splat);
        sg_free(box);
        return sg_error_set(err, SG_ERR_NOMEM, "iso: out of memory for %zu light sites", n);
    }
    float *a[SITE_ARRAYS];
    for (int k = 0; k < SITE_ARRAYS; ++k)
        a[k] = data + (size_t)k * n;
    float *px = a[0], *py = a[1], *pz = a[2], *radius = a[6], *ar = a[7], *ag = a[8], *ab = a[9];
    for (size_t c = 0; c < n; ++c) {
        sg_vec3 nrm = sg_iso_decode_normal(iso->cn[c]);
        a[3][c] = nrm.x, a[4][c] = nrm.y, a[5][c] = nrm.z;
        radius[c] = 0.0f; /* no leaf yet (invariant 1 fills it) */
    }
    sg_iso_leaf_boxes(iso, box);
    for (size_t l = 0; l < leaves; ++l) {
        const iso_leaf *L = &iso->leaves[l];
        uint32_t sp = L->splat;
        assert(sp < points->count);
        for (int c = 0; c < 8; ++c) {
            uint32_t id = L->corner[c];
            assert(id < n);
            if (radius[id] == 0.0f) { /* first leaf to use it: position, reach and colour */
                px[id] = c & 1 ? box[l].hi.x : box[l].lo.x;
                py[id] = c & 2 ? box[l].hi.y : box[l].lo.y;
                pz[id] = c & 4 ? box[l].hi.z : box[l].lo.z;
                ar[id] = points->ar[sp], ag[id] = points->ag[sp], ab[id] = points->ab[sp];
                splat[id] = sp;
                radius[id] = points->radius[sp];
            }
        }
    }
    sg_free(box);
    out->data = data;
    out->splat = splat;
    out->view = (sg_sites){.count = n, .px = px, .py = py, .pz = pz, .nx = a[3], .ny = a[4], .nz = a[5],
                           .radius = radius, .ar = ar, .ag = ag, .ab = ab};
    return SG_OK;
}

void sg_iso_sites_free(sg_iso_sites *s)
{
    if (!s)
        return;
    sg_free(s->data);
    sg_free(s->splat);
    memset(s, 0, sizeof *s);
}

size_t sg_iso_sites_memory(const sg_iso_sites *s)
{
    return s->view.count * (SITE_ARRAYS * sizeof(float) + sizeof(uint32_t));
}

/* The trilinear weights of the hit's leaf, corner c at bit 0 +x, 1 +y, 2 +z. */
static int trilinear(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit, float w[8])
{
    if (hit->leaf >= iso->leaf_count)
        return 0;
    const iso_leaf *L = &iso->leaves[hit->leaf];
    const sg_sites *v = &s->view;
    uint32_t lo = L->corner[0], hi = L->corner[7]; /* invariant 2 */
    float p[3] = {hit->p.x, hit->p.y, hit->p.z};
    float l3[3] = {v->px[lo], v->py[lo], v->pz[lo]}, h3[3] = {v->px[hi], v->py[hi], v->pz[hi]};
    float u[3];
    for (int a = 0; a < 3; ++a) {
        float t = (p[a] - l3[a]) / (h3[a] - l3[a]);
        u[a] = t > 0.0f ? (t < 1.0f ? t : 1.0f) : 0.0f; /* NaN -> 0 */
    }
    for (int c = 0; c < 8; ++c)
        w[c] = (c & 1 ? u[0] : 1.0f - u[0]) * (c & 2 ? u[1] : 1.0f - u[1]) * (c & 4 ? u[2] : 1.0f - u[2]);
    return 1;
}

int sg_iso_hit_sites(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit, uint32_t *ids, float *weights,
                     int max)
{
    float w[8];
    if (max <= 0 || !trilinear(iso, s, hit, w))
        return 0;
    const iso_leaf *L = &iso->leaves[hit->leaf];
    if (max >= 8) {
        for (int c = 0; c < 8; ++c)
            ids[c] = L->corner[c], weights[c] = w[c];
        return 8;
    }
    /* Keep the max largest (selection: at most 8 x 8 steps) and renormalise. */
    int used = 0;
    float kept = 0.0f;
    unsigned taken = 0;
    for (; used < max; ++used) {
        int best = -1;
        for (int c = 0; c < 8; ++c)
            if (!(taken >> c & 1u) && (best < 0 || w[c] > w[best]))
                best = c;
        taken |= 1u << best;
        ids[used] = L->corner[best];
        weights[used] = w[best];
        kept += w[best];
    }
    for (int j = 0; j < used; ++j)
        weights[j] = kept > 0.0f ? weights[j] / kept : 1.0f / (float)used;
    return used;
}

uint32_t sg_iso_hit_site(const sg_iso *iso, const sg_iso_sites *s, const sg_hit *hit)
{
    uint32_t id;
    float w;
    return sg_iso_hit_sites(iso, s, hit, &id, &w, 1) ? id : SG_INVALID_ID;
}
