/* Semi-Lagrangian advection of V_c (both uvw fields), V_r, the base blend and the paint by V_m
 * (paper: "offset V_c, V_b and V_r by V_m"). Back-traces use the midpoint rule, which is exact
 * for uniform flow; out-of-box sources take the border values (inflow repeats the edge). */
#include "internal_fluid.h"
#include <omp.h>
#include <string.h>

/* Source point in voxel units of the point x (voxel units), midpoint rule. */
static inline void trace(const hbk_fluid_t *h, const float *motion, const size_t off[8],
                         const float x[3], float dt, const float v0[3], float src[3])
{
    float mid[3], vm[3];
    for (int a = 0; a < 3; ++a) mid[a] = x[a] - 0.5f * dt * v0[a] * h->inv_cell[a];
    hbk_fluid_lerp_t l;
    hbk_fluid_lerp_at(h, mid, &l);
    hbk_fluid_sample3_o(motion, off, &l, vm);
    for (int a = 0; a < 3; ++a) src[a] = x[a] - dt * vm[a] * h->inv_cell[a];
}

void hbk_fluid_advect(hbk_fluid_t *h, float dt, int threads)
{
    const int32_t nx = h->nv[0], ny = h->nv[1], nz = h->nv[2], K = h->K;
    const float *m = h->motion;
    const hbk_fluid_vols_t *in = &h->v;
    hbk_fluid_vols_t *out = &h->scratch;
    const int paint = h->paint_active;
    size_t off[8]; /* a voxel's corners from its vertex (i, j, k) */
    hbk_fluid_corners(h, off);
/* Slabs dealt out in turn: the fluid (the work) sits low in the box. */
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j) {
            const size_t row = (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
            for (int32_t i = 0; i < nx; ++i) {
                const size_t vi = (size_t)i + (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
                const float *v0 = m + 3 * vi;
                const float x[3] = {(float)i, (float)j, (float)k};
                float src[3];
                if ((i & 3) == 0) { /* the rows ahead that the next samples will read */
                    const size_t sy = (size_t)nx, sz = (size_t)nx * (size_t)ny, ahead = vi + 16;
                    for (int q = 0; q < 2; ++q) {
                        const size_t p = ahead + sy + (q ? sz : 0);
                        if (p >= h->n_vert) break;
                        __builtin_prefetch(in->uvw[0] + 3 * p);
                        __builtin_prefetch(in->uvw[1] + 3 * p);
                        __builtin_prefetch(m + 3 * p);
                        __builtin_prefetch(in->base + (size_t)K * p);
                        if (paint) __builtin_prefetch(in->paint + (size_t)K * p);
                    }
                }
                const int still = v0[0] == 0.0f && v0[1] == 0.0f && v0[2] == 0.0f;
                h->moving[vi] = (uint8_t)!still;
                if (still) continue; /* copied with its run, below */
                trace(h, m, off, x, dt, v0, src);
                hbk_fluid_lerp_t l;
                hbk_fluid_lerp_at(h, src, &l);
                hbk_fluid_sample_wrapped3_o(in->uvw[0], in->wrap[0], off, &l, out->uvw[0] + 3 * vi);
                hbk_fluid_sample_wrapped3_o(in->uvw[1], in->wrap[1], off, &l, out->uvw[1] + 3 * vi);
                float *b = out->base + (size_t)K * vi;
                hbk_fluid_sample_n_o(in->base, K, off, &l, b);
                /* Interpolation is a convex combination; renormalise only the rounding. */
                float s = 0.0f;
                for (int t = 0; t < K; ++t) s += b[t];
                if (s > 0.0f) for (int t = 0; t < K; ++t) b[t] /= s;
                else { for (int t = 0; t < K; ++t) b[t] = 0.0f; b[h->p.default_texture] = 1.0f; }
                if (paint) {
                    hbk_fluid_sample_n_o(in->paint, K, off, &l, out->paint + (size_t)K * vi);
                    hbk_fluid_sample_n_o(in->life, 1, off, &l, out->life + vi);
                }
            }
            /* Still vertices: a plain copy, so zero flow changes nothing bit for bit; a run
             * of them at a time. */
            for (int32_t i = 0; i < nx;) {
                if (h->moving[row + (size_t)i]) {
                    ++i;
                    continue;
                }
                int32_t e = i + 1;
                while (e < nx && !h->moving[row + (size_t)e]) ++e;
                const size_t s = row + (size_t)i, n = (size_t)(e - i), kk = (size_t)K;
                memcpy(out->uvw[0] + 3 * s, in->uvw[0] + 3 * s, 3 * n * sizeof(float));
                memcpy(out->uvw[1] + 3 * s, in->uvw[1] + 3 * s, 3 * n * sizeof(float));
                memcpy(out->base + kk * s, in->base + kk * s, kk * n * sizeof(float));
                if (paint) {
                    memcpy(out->paint + kk * s, in->paint + kk * s, kk * n * sizeof(float));
                    memcpy(out->life + s, in->life + s, n * sizeof(float));
                }
                i = e;
            }
        }
    /* V_r: the flag of the voxel the centre came from (binary, so nearest), then repaired from
     * the new corners where the short way is unambiguous. A voxel whose corners all stand
     * still keeps its flag: its centre traces back to itself, and its corners' uvw are the
     * ones its flags were repaired from last frame (but the first frame after create or
     * load_state repairs every voxel). */
    const int32_t rx = h->p.resolution[0], ry = h->p.resolution[1], rz = h->p.resolution[2];
    const int checked = h->wrap_checked;
/* Slabs dealt out in turn: the fluid (the work) sits low in the box. */
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < rz; ++k)
        for (int32_t j = 0; j < ry; ++j) {
            /* Which vertices of the row's four vertex rows move, per column: a voxel moves
             * if its two columns do. A still row copies its flags whole. */
            const size_t b0 = (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
            const size_t v0i = (size_t)rx * ((size_t)j + (size_t)ry * (size_t)k);
            uint8_t col[257], rowany = 0; /* resolution <= 256 */
            for (int32_t i = 0; i < nx; ++i) {
                col[i] = h->moving[b0 + off[0] + (size_t)i] | h->moving[b0 + off[2] + (size_t)i] |
                         h->moving[b0 + off[4] + (size_t)i] | h->moving[b0 + off[6] + (size_t)i];
                rowany |= col[i];
            }
            if (!rowany && checked) {
                memcpy(out->wrap[0] + v0i, in->wrap[0] + v0i, (size_t)rx);
                memcpy(out->wrap[1] + v0i, in->wrap[1] + v0i, (size_t)rx);
                continue;
            }
            for (int32_t i = 0; i < rx; ++i) {
                const size_t vox = v0i + (size_t)i, b = b0 + (size_t)i;
                const uint8_t any = col[i] | col[i + 1];
                uint8_t f0 = in->wrap[0][vox], f1 = in->wrap[1][vox];
                if (any) {
                    const float x[3] = {(float)i + 0.5f, (float)j + 0.5f, (float)k + 0.5f};
                    /* hbk_fluid_lerp_at of the centre, without its clamps */
                    hbk_fluid_lerp_t l = {b, vox, {0.5f, 0.5f, 0.5f}};
                    float v0[3], src[3];
                    hbk_fluid_sample3_o(m, off, &l, v0);
                    trace(h, m, off, x, dt, v0, src);
                    hbk_fluid_lerp_at(h, src, &l);
                    f0 = in->wrap[0][l.voxel];
                    f1 = in->wrap[1][l.voxel];
                }
                if (any || !checked) {
                    f0 = hbk_fluid_repair_voxel(out->uvw[0], off, b, f0);
                    f1 = hbk_fluid_repair_voxel(out->uvw[1], off, b, f1);
                }
                out->wrap[0][vox] = f0;
                out->wrap[1][vox] = f1;
            }
        }
    h->wrap_checked = 1;
}
