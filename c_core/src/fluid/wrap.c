/* V_c interpolation honouring V_r (paper Fig. 4). A voxel's flag bit a says that component a of
 * uvw is interpolated across the 1 -> 0 wrap: corner values below 0.5 count as value + 1 and
 * the result is taken modulo 1. The flags live at voxel centres, the dual of V_c's vertices. */
#include "internal_fluid.h"
#include <omp.h>


void hbk_fluid_sample_wrapped(const hbk_fluid_t *h, const float *uvw, const uint8_t *wrap,
                              const float x[3], float out[3])
{
    hbk_fluid_lerp_t l;
    hbk_fluid_lerp_at(h, x, &l);
    hbk_fluid_sample_wrapped3(h, uvw, wrap, &l, out);
}

static inline float frac1(double v)
{
    float f = (float)(v - floor(v));
    return f < 1.0f ? f : 0.0f; /* 0.99999999 rounds to 1.0f */
}

void hbk_fluid_reset_uvw(const hbk_fluid_t *h, float *uvw, uint8_t *wrap, int threads)
{
    const int32_t nx = h->nv[0], ny = h->nv[1], nz = h->nv[2];
    const double tile = h->p.uvw_tile;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j)
            for (int32_t i = 0; i < nx; ++i) {
                float *o = uvw + 3 * ((size_t)i + (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k));
                o[0] = frac1((double)i * h->cell[0] / tile);
                o[1] = frac1((double)j * h->cell[1] / tile);
                o[2] = frac1((double)k * h->cell[2] / tile);
            }
    const size_t nvox = h->n_vox;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (size_t i = 0; i < nvox; ++i) wrap[i] = 0;
    hbk_fluid_repair_wrap(h, uvw, wrap, NULL, threads);
}

void hbk_fluid_uvw_unwrapped(const hbk_fluid_t *h, const float *uvw, float *out, int threads)
{
    const int32_t nx = h->nv[0], ny = h->nv[1], nz = h->nv[2];
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j)
            for (int32_t i = 0; i < nx; ++i) {
                const int32_t ijk[3] = {i, j, k};
                const size_t v =
                    3 * ((size_t)i + (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k));
                for (int c = 0; c < 3; ++c)
                    out[v + (size_t)c] = hbk_fluid_unwrap(
                        uvw[v + (size_t)c], (float)ijk[c] * h->cell[c] / h->p.uvw_tile);
            }
}

void hbk_fluid_repair_wrap(const hbk_fluid_t *h, const float *uvw, uint8_t *wrap,
                           const uint8_t *moving, int threads)
{
    const int32_t rx = h->p.resolution[0], ry = h->p.resolution[1], rz = h->p.resolution[2];
    size_t off[8];
    hbk_fluid_corners(h, off);
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t k = 0; k < rz; ++k)
        for (int32_t j = 0; j < ry; ++j)
            for (int32_t i = 0; i < rx; ++i) {
                const size_t b = (size_t)i + (size_t)h->nv[0] * ((size_t)j + (size_t)h->nv[1] * (size_t)k);
                const size_t vox = (size_t)i + (size_t)rx * ((size_t)j + (size_t)ry * (size_t)k);
                if (moving) { /* unmoved corners: the same uvw and flag as repaired last */
                    uint8_t any = 0;
                    for (int c = 0; c < 8; ++c) any |= moving[b + off[c]];
                    if (!any) continue;
                }
                wrap[vox] = hbk_fluid_repair_voxel(uvw, off, b, wrap[vox]);
            }
}
