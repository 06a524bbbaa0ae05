/* Features per vertex (paper §3.2): density, its rate, the angle between flow and surface
 * normal, the acceleration of the flow, and (beyond the paper, as it suggests) divergence and
 * the surface's mean curvature.
 * Rates are finite differences against the previous frame's fields on the same grid, so they
 * work for every source, including particle systems whose particles come and go. */
#include "internal_fluid.h"
#include <omp.h>
#include <stdlib.h>

/* Central difference of channel c of an nv x ch field along axis a at vertex (i, j, k), per
 * metre; one-sided at the borders. */
static inline float diff(const hbk_fluid_t *h, const float *f, int ch, int c, const int32_t ijk[3],
                         int a)
{
    static const size_t one = 1;
    const size_t stride[3] = {one, (size_t)h->nv[0], (size_t)h->nv[0] * (size_t)h->nv[1]};
    const size_t vi = (size_t)ijk[0] + stride[1] * (size_t)ijk[1] + stride[2] * (size_t)ijk[2];
    const int lo = ijk[a] > 0, hi = ijk[a] < h->nv[a] - 1;
    const float fl = f[(size_t)ch * (vi - (lo ? stride[a] : 0)) + (size_t)c];
    const float fh = f[(size_t)ch * (vi + (hi ? stride[a] : 0)) + (size_t)c];
    const int span = lo + hi;
    /* / span, as a product: x / 2 and x * 0.5 are the same float (both the exact half,
     * rounded), and a division costs several products */
    return span ? (fh - fl) * h->inv_cell[a] * (span == 2 ? 0.5f : 1.0f) : 0.0f;
}

/* Every float of f[0 .. n) is +0, bit for bit. */
static int all_zero(const float *f, size_t n)
{
    uint32_t any = 0;
    for (size_t i = 0; i < n; ++i) {
        uint32_t b;
        memcpy(&b, f + i, sizeof b);
        any |= b;
    }
    return any == 0;
}

/* Row (j, k) and the rows its differences read (j +- 1, k +- 1) are all zero now, and the row
 * itself last frame too (when there is a last frame). */
static int quiet(const uint8_t *zc, const uint8_t *zp, int prev, int32_t j, int32_t k,
                 int32_t ny, int32_t nz)
{
    const size_t r = (size_t)j + (size_t)ny * (size_t)k;
    if (!zc[r] || (prev && !zp[r])) return 0;
    if (j > 0 && !zc[r - 1]) return 0;
    if (j < ny - 1 && !zc[r + 1]) return 0;
    if (k > 0 && !zc[r - (size_t)ny]) return 0;
    if (k < nz - 1 && !zc[r + (size_t)ny]) return 0;
    return 1;
}

void hbk_fluid_features(hbk_fluid_t *h, int threads)
{
    const int32_t nx = h->nv[0], ny = h->nv[1], nz = h->nv[2];
    const float inv_dt = 1.0f / h->p.dt;
    const int prev = h->have_fields;
    const int F = HBK_FLUID_FEATURE_COUNT;
    /* A gradient counts as a surface's when the density changes by at least 2 % of its scale
     * (the rest density; 1 for a grid source's surface field) over one cell. */
    float cmin = h->cell[0] < h->cell[1] ? h->cell[0] : h->cell[1];
    cmin = cmin < h->cell[2] ? cmin : h->cell[2];
    const float scale = h->p.source == HBK_FLUID_VELOCITY_GRID ? 1.0f : h->p.rest_density;
    const float gmin = 0.02f * scale / cmin, gmin2 = gmin * gmin;
    const size_t st[3] = {1, (size_t)nx, (size_t)nx * (size_t)ny};
    /* Rows whose density and velocity are all +0 (bit for bit), now and (zp) last frame: far
     * from the fluid, a vertex's features are then constants (below), computed without it. */
    const size_t rows = (size_t)ny * (size_t)nz;
    uint8_t *zc = malloc(2 * rows), *zp = zc ? zc + rows : NULL;
    if (zc) {
#pragma omp parallel for num_threads(threads) schedule(static)
        for (size_t r = 0; r < rows; ++r) {
            const size_t v0 = r * (size_t)nx;
            zc[r] = all_zero(h->g_density + v0, (size_t)nx) &&
                    all_zero(h->g_motion + 3 * v0, 3 * (size_t)nx);
            zp[r] = all_zero(h->density + v0, (size_t)nx) &&
                    all_zero(h->motion + 3 * v0, 3 * (size_t)nx);
        }
    }
/* Slabs dealt out in turn: the fluid (the work) sits low in the box. */
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j) {
            if (zc && quiet(zc, zp, prev, j, k, ny, nz)) {
                /* What the loop below gives for zero fields: a rate and acceleration of +0,
                 * the gradient -0 (so a -0 normal), no flow angle (pi / 2). */
                const size_t v0 = (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
                for (int32_t i = 0; i < nx; ++i) {
                    float *o = h->g_features + (size_t)F * (v0 + (size_t)i);
                    o[HBK_FLUID_FEATURE_DENSITY] = 0.0f;
                    o[HBK_FLUID_FEATURE_DENSITY_RATE] = 0.0f;
                    o[HBK_FLUID_FEATURE_FLOW_ANGLE] = (float)(0.5 * M_PI);
                    o[HBK_FLUID_FEATURE_ACCELERATION] = 0.0f;
                    o[HBK_FLUID_FEATURE_DIVERGENCE] = 0.0f;
                    float *nrm = h->g_normal + 3 * (v0 + (size_t)i);
                    nrm[0] = nrm[1] = nrm[2] = -0.0f;
                }
                continue;
            }
            for (int32_t i = 0; i < nx; ++i) {
                const int32_t ijk[3] = {i, j, k};
                const size_t vi = (size_t)i + (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
                float *o = h->g_features + (size_t)F * vi;
                const float d = h->g_density[vi], *v = h->g_motion + 3 * vi;
                o[HBK_FLUID_FEATURE_DENSITY] = d;
                o[HBK_FLUID_FEATURE_DENSITY_RATE] = prev ? (d - h->density[vi]) * inv_dt : 0.0f;
                float g[3], gg = 0.0f, vv = 0.0f, gv = 0.0f, div = 0.0f;
                for (int a = 0; a < 3; ++a) {
                    /* diff() for both fields, its neighbours found once */
                    const int lo = ijk[a] > 0, hi = ijk[a] < h->nv[a] - 1;
                    const size_t il = vi - (lo ? st[a] : 0), ih = vi + (hi ? st[a] : 0);
                    const float sc = h->inv_cell[a], half = lo + hi == 2 ? 0.5f : 1.0f;
                    g[a] = -((h->g_density[ih] - h->g_density[il]) * sc * half); /* outward */
                    gg += g[a] * g[a];
                    vv += v[a] * v[a];
                    gv += g[a] * v[a];
                    div += (h->g_motion[3 * ih + (size_t)a] - h->g_motion[3 * il + (size_t)a]) *
                           sc * half;
                }
                float ang = (float)(0.5 * M_PI);
                if (gg > 0.0f && vv > 0.0f) {
                    float cs = gv / sqrtf(gg * vv);
                    cs = cs > 1.0f ? 1.0f : cs < -1.0f ? -1.0f : cs;
                    ang = hbk_fluid_acos(cs);
                }
                o[HBK_FLUID_FEATURE_FLOW_ANGLE] = ang;
                float acc = 0.0f;
                if (prev) {
                    const float *pv = h->motion + 3 * vi;
                    const float ax = v[0] - pv[0], ay = v[1] - pv[1], az = v[2] - pv[2];
                    acc = sqrtf(ax * ax + ay * ay + az * az) * inv_dt;
                }
                o[HBK_FLUID_FEATURE_ACCELERATION] = acc;
                o[HBK_FLUID_FEATURE_DIVERGENCE] = div;
                /* The outward unit normal, where the density changes enough to have one: a
                 * uniform interior's tiny gradients would point anywhere. */
                float *nrm = h->g_normal + 3 * vi;
                const int has = gg > gmin2;
                const float inv = has ? 1.0f / sqrtf(gg) : 0.0f;
                for (int a = 0; a < 3; ++a) nrm[a] = g[a] * inv;
            }
        }
    free(zc);
    /* Mean curvature: half the divergence of that normal field, where it is defined around. */
/* Slabs dealt out in turn: the fluid (the work) sits low in the box. */
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j)
            for (int32_t i = 0; i < nx; ++i) {
                const int32_t ijk[3] = {i, j, k};
                const size_t vi = (size_t)i + (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
                const float *nrm = h->g_normal + 3 * vi;
                float dn = 0.0f;
                if (nrm[0] != 0.0f || nrm[1] != 0.0f || nrm[2] != 0.0f)
                    for (int a = 0; a < 3; ++a) dn += diff(h, h->g_normal, 3, a, ijk, a);
                h->g_features[(size_t)F * vi + HBK_FLUID_FEATURE_CURVATURE] = 0.5f * dn;
            }
}
