/* The cross-fade weight of uvw field A per vertex, adapted to stretch (beyond the paper, as the
 * issue suggests: "consider resetting where the local deformation is large"). The reset
 * schedule gives one weight w for the frame (0 when A is reset, 1 when B is). Where the fluid
 * has stretched a field, its texture is stretched too: there the weight moves towards the
 * other field, as if the stretched one had been reset early, and back as the other ages:
 *
 *   w(x) = w fA / (w fA + (1 - w) fB),   f = exp(-stretch / stretch_fade),
 *
 * stretch = |tr(M^T M) / 3 - 1| with M = uvw_tile x the gradient of uvw (the identity at a
 * reset, a rotation under rigid motion: 0 then). w(x) is w where both fields are as stretched,
 * and still exactly 0 and 1 at the resets, so a field being reset is never seen. */
#include "internal_fluid.h"
#include <omp.h>
#include <stdlib.h>

/* Difference of two uvw components across the 1 -> 0 wrap: the short way, |d| <= 0.5. */
static inline float wrapped(float d) { return d - floorf(d + 0.5f); }

/* |tr(M^T M) / 3 - 1| of field f at vertex (i, j, k): central differences (one-sided at the
 * borders) per metre, times the tile, each the sum of the two one-cell differences taken the
 * short way (a two-cell difference is ambiguous once a tile spans only four cells). */
static float stretch(const hbk_fluid_t *h, const float *f, int32_t i, int32_t j, int32_t k)
{
    const int32_t ijk[3] = {i, j, k};
    const size_t st[3] = {1, (size_t)h->nv[0], (size_t)h->nv[0] * (size_t)h->nv[1]};
    const size_t v = (size_t)i + st[1] * (size_t)j + st[2] * (size_t)k;
    float tr = 0.0f;
    for (int a = 0; a < 3; ++a) {
        const int lo = ijk[a] > 0, hi = ijk[a] < h->nv[a] - 1;
        if (!(lo + hi)) continue;
        const size_t vl = v - (lo ? st[a] : 0), vh = v + (hi ? st[a] : 0);
        const float s = h->p.uvw_tile * h->inv_cell[a] / (float)(lo + hi);
        for (int c = 0; c < 3; ++c) {
            const float fl = f[3 * vl + (size_t)c], fv = f[3 * v + (size_t)c],
                        fh = f[3 * vh + (size_t)c];
            const float m = (wrapped(fh - fv) + wrapped(fv - fl)) * s;
            tr += m * m;
        }
    }
    return fabsf(tr / 3.0f - 1.0f);
}

void hbk_fluid_weights(const hbk_fluid_t *h, float *out, int threads)
{
    const float w = hbk_fluid_weight_at(&h->p, h->frame), fade = h->p.stretch_fade;
    const int32_t nx = h->nv[0], ny = h->nv[1], nz = h->nv[2];
    const int adapt = fade > 0.0f && w > 0.0f && w < 1.0f;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j)
            for (int32_t i = 0; i < nx; ++i) {
                const size_t v = (size_t)i + (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
                float o = w;
                /* Only in the fluid: elsewhere nothing is drawn, and the fields stand still. */
                if (adapt && h->density[v] > 0.0f) {
                    const float fa = expf(-stretch(h, h->v.uvw[0], i, j, k) / fade);
                    const float fb = expf(-stretch(h, h->v.uvw[1], i, j, k) / fade);
                    const float num = w * fa, den = num + (1.0f - w) * fb;
                    if (den > 0.0f) o = num / den;
                }
                out[v] = o;
            }
}

hbk_result_t hbk_fluid_get_mesh_weight(hbk_fluid_t *h, float *weight)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    if (!weight) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "weight: must not be NULL");
    const int32_t nv = h->mesh_nv;
    if (!(h->p.stretch_fade > 0.0f)) { /* the frame's weight everywhere: no field needed */
        const float w = hbk_fluid_weight_at(&h->p, h->frame);
        for (int32_t v = 0; v < nv; ++v) weight[v] = w;
        return HBK_OK;
    }
    float *field = malloc((h->n_vert + 4) * sizeof *field);
    if (!field) return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "mesh weight: out of memory");
    const int threads = HBK_OMP_THREADS(h);
    hbk_fluid_weights(h, field, threads);
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t v = 0; v < nv; ++v) {
        hbk_fluid_lerp_t l;
        hbk_fluid_lerp_at_mesh(h, v, &l);
        hbk_fluid_sample_field(h, field, 1, &l, weight + v);
    }
    free(field);
    return HBK_OK;
}
