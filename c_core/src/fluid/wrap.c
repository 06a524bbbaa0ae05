/* V_c interpolation honouring V_r (paper Fig. 4). A voxel's flag bit a says that component a of
 * uvw is interpolated across the 1 -> 0 wrap: corner values below 0.5 count as value + 1 and
 * the result is taken modulo 1. The flags live at voxel centres, the dual of V_c's vertices. */
#include "internal_fluid.h"
#include <omp.h>

void hbk_fluid_lerp_at(const hbk_fluid_t *h, const float x[3], hbk_fluid_lerp_t *l)
{
    int32_t i[3];
    for (int a = 0; a < 3; ++a) {
        const int32_t last = h->p.resolution[a] - 1;
        float xa = x[a];
        if (!(xa >= 0.0f)) xa = 0.0f; /* also NaN */
        if (xa > (float)(last + 1)) xa = (float)(last + 1);
        int32_t k = (int32_t)xa;
        if (k > last) k = last;
        i[a] = k;
        l->t[a] = xa - (float)k;
    }
    l->base = (size_t)i[0] + (size_t)h->nv[0] * ((size_t)i[1] + (size_t)h->nv[1] * (size_t)i[2]);
    l->voxel = (size_t)i[0] + (size_t)h->p.resolution[0] *
                                  ((size_t)i[1] + (size_t)h->p.resolution[1] * (size_t)i[2]);
}

/* Offsets of the 8 corners of a voxel, in the order of the trilinear weights below. */
static inline void corners(const hbk_fluid_t *h, size_t off[8])
{
    const size_t sx = 1, sy = (size_t)h->nv[0], sz = (size_t)h->nv[0] * (size_t)h->nv[1];
    off[0] = 0; off[1] = sx; off[2] = sy; off[3] = sx + sy;
    off[4] = sz; off[5] = sz + sx; off[6] = sz + sy; off[7] = sz + sx + sy;
}

/* Nested lerps rather than the 8 weights: a uniform field stays bitwise uniform, and a
 * linear ramp is reproduced to rounding. */
static inline float tri(const float c[8], const float t[3])
{
    const float a = c[0] + t[0] * (c[1] - c[0]), b = c[2] + t[0] * (c[3] - c[2]);
    const float d = c[4] + t[0] * (c[5] - c[4]), e = c[6] + t[0] * (c[7] - c[6]);
    const float f = a + t[1] * (b - a), g = d + t[1] * (e - d);
    return f + t[2] * (g - f);
}

void hbk_fluid_sample_wrapped_l(const hbk_fluid_t *h, const float *uvw, const uint8_t *wrap,
                                const hbk_fluid_lerp_t *l, float out[3])
{
    size_t off[8];
    corners(h, off);
    const uint8_t flags = wrap[l->voxel];
    for (int a = 0; a < 3; ++a) {
        float c[8];
        for (int k = 0; k < 8; ++k) c[k] = uvw[3 * (l->base + off[k]) + (size_t)a];
        if (flags & (1u << a)) {
            for (int k = 0; k < 8; ++k)
                if (c[k] < 0.5f) c[k] += 1.0f;
            float v = tri(c, l->t);
            if (v >= 1.0f) v -= 1.0f;
            out[a] = v >= 0.0f && v < 1.0f ? v : 0.0f;
        } else {
            out[a] = tri(c, l->t);
        }
    }
}

void hbk_fluid_sample_wrapped(const hbk_fluid_t *h, const float *uvw, const uint8_t *wrap,
                              const float x[3], float out[3])
{
    hbk_fluid_lerp_t l;
    hbk_fluid_lerp_at(h, x, &l);
    hbk_fluid_sample_wrapped_l(h, uvw, wrap, &l, out);
}

void hbk_fluid_sample_field(const hbk_fluid_t *h, const float *f, int ch,
                            const hbk_fluid_lerp_t *l, float *out)
{
    size_t off[8];
    corners(h, off);
    for (int a = 0; a < ch; ++a) {
        float c[8];
        for (int k = 0; k < 8; ++k) c[k] = f[(size_t)ch * (l->base + off[k]) + (size_t)a];
        out[a] = tri(c, l->t);
    }
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
    hbk_fluid_repair_wrap(h, uvw, wrap, threads);
}

void hbk_fluid_repair_wrap(const hbk_fluid_t *h, const float *uvw, uint8_t *wrap, int threads)
{
    const int32_t rx = h->p.resolution[0], ry = h->p.resolution[1], rz = h->p.resolution[2];
    size_t off[8];
    corners(h, off);
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t k = 0; k < rz; ++k)
        for (int32_t j = 0; j < ry; ++j)
            for (int32_t i = 0; i < rx; ++i) {
                const size_t b = (size_t)i + (size_t)h->nv[0] * ((size_t)j + (size_t)h->nv[1] * (size_t)k);
                const size_t vox = (size_t)i + (size_t)rx * ((size_t)j + (size_t)ry * (size_t)k);
                uint8_t f = wrap[vox];
                for (int a = 0; a < 3; ++a) {
                    float lo = 2, hi = -1, wlo = 2, whi = -1;
                    for (int c = 0; c < 8; ++c) {
                        const float v = uvw[3 * (b + off[c]) + (size_t)a];
                        const float w = v < 0.5f ? v + 1.0f : v;
                        lo = v < lo ? v : lo; hi = v > hi ? v : hi;
                        wlo = w < wlo ? w : wlo; whi = w > whi ? w : whi;
                    }
                    /* The short way where it is clear; where both ways are long (a texture
                     * already torn apart) the advected flag decides, as in the paper. */
                    if (hi - lo <= 0.5f) f &= (uint8_t)~(1u << a);
                    else if (whi - wlo < 0.5f) f |= (uint8_t)(1u << a);
                }
                wrap[vox] = f;
            }
}
