/* Particles to grid: SPH density, Shepard-averaged velocity (V_m before clamping) and the
 * metaball sum of the surface, at the grid vertices. */
#include "internal_fluid.h"
#include <omp.h>
#include <string.h>

/* Scatter by owner: vertex z-slabs are chunks of the loop; each chunk walks the particles
 * (in sorted order) whose support reaches it and adds to its own vertices only, so every
 * vertex sums its particles in one fixed order, whatever thread runs the chunk. */
hbk_result_t hbk_fluid_particles_to_grid(hbk_fluid_t *h, int threads)
{
    const size_t nv = h->n_vert;
    memset(h->g_density, 0, nv * sizeof(float));
    memset(h->g_surface, 0, nv * sizeof(float));
    memset(h->g_motion, 0, 3 * nv * sizeof(float));
    memset(h->g_wsum, 0, nv * sizeof(float));
    const int32_t n = h->count;
    if (n == 0) return HBK_OK;
    const float H = h->p.smoothing_length, R = h->p.metaball_radius;
    const float S = H > R ? H : R;
    hbk_fluid_cells_t *c = &h->cells;
    hbk_result_t r = hbk_fluid_cells_build(c, h->pos, n, h->p.box_min, h->p.box_max, S, threads);
    if (r) return r;
    const float H2 = H * H, R2 = R * R, inv_R2 = 1.0f / R2;
    const float dens = (float)(h->mass * 315.0 / (64.0 * M_PI * pow(H, 9)));
    const int32_t nx = h->nv[0], ny = h->nv[1], nz = h->nv[2];
    const float *lo = h->p.box_min, *cl = h->cell, *ic = h->inv_cell;
    const int32_t slab = 8, chunks = (nz + slab - 1) / slab;
    const size_t layer = (size_t)c->dims[0] * (size_t)c->dims[1];
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (int32_t ch = 0; ch < chunks; ++ch) {
        const int32_t z0 = ch * slab, z1 = z0 + slab < nz ? z0 + slab : nz; /* [z0, z1) */
        const float wz0 = lo[2] + (float)z0 * cl[2] - S, wz1 = lo[2] + (float)(z1 - 1) * cl[2] + S;
        const int32_t c0 = hbk_fluid_cell_coord(c, wz0, 2), c1 = hbk_fluid_cell_coord(c, wz1, 2);
        const int32_t p0 = c->start[(size_t)c0 * layer], p1 = c->start[(size_t)(c1 + 1) * layer];
        for (int32_t k = p0; k < p1; ++k) {
            const int32_t id = c->order[k];
            const float *x = h->pos + 3 * (size_t)id, *v = h->vel + 3 * (size_t)id;
            int32_t a0[3], a1[3];
            for (int a = 0; a < 3; ++a) {
                a0[a] = (int32_t)ceilf((x[a] - S - lo[a]) * ic[a]);
                a1[a] = (int32_t)floorf((x[a] + S - lo[a]) * ic[a]);
                if (a0[a] < 0) a0[a] = 0;
                if (a1[a] > h->nv[a] - 1) a1[a] = h->nv[a] - 1;
            }
            if (a0[2] < z0) a0[2] = z0;
            if (a1[2] > z1 - 1) a1[2] = z1 - 1;
            for (int32_t kz = a0[2]; kz <= a1[2]; ++kz) {
                const float dz = lo[2] + (float)kz * cl[2] - x[2];
                for (int32_t ky = a0[1]; ky <= a1[1]; ++ky) {
                    const float dy = lo[1] + (float)ky * cl[1] - x[1];
                    const float ryz = dy * dy + dz * dz;
                    if (ryz >= H2 && ryz >= R2) continue;
                    const size_t row = (size_t)nx * ((size_t)ky + (size_t)ny * (size_t)kz);
                    for (int32_t kx = a0[0]; kx <= a1[0]; ++kx) {
                        const float dx = lo[0] + (float)kx * cl[0] - x[0];
                        const float r2 = dx * dx + ryz;
                        const size_t vi = row + (size_t)kx;
                        if (r2 < H2) {
                            const float d = H2 - r2, w = d * d * d;
                            h->g_density[vi] += dens * w;
                            h->g_wsum[vi] += w;
                            h->g_motion[3 * vi] += w * v[0];
                            h->g_motion[3 * vi + 1] += w * v[1];
                            h->g_motion[3 * vi + 2] += w * v[2];
                        }
                        if (r2 < R2) {
                            const float t = 1.0f - r2 * inv_R2;
                            h->g_surface[vi] += t * t * t;
                        }
                    }
                }
            }
        }
    }
    /* Shepard-normalised velocity. */
#pragma omp parallel for num_threads(threads) schedule(static)
    for (size_t i = 0; i < nv; ++i) {
        const float w = h->g_wsum[i];
        if (w > 0.0f)
            for (int a = 0; a < 3; ++a) h->g_motion[3 * i + a] /= w;
    }
    return HBK_OK;
}
