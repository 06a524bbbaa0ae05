/* Occupancy bit grid over the mesh's bounds: one bit per cell that some triangle's box
 * touches. A flake step whose box touches only empty cells cannot hit anything, which is
 * most steps inside the mesh's bounds (around and between the surfaces). */
#include "internal_snow.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GRID_MAX_AXIS 256
#define GRID_TARGET_CELLS (1 << 18) /* 32 KB of bits: stays in cache */
#define GRID_MAX_QUERY 64           /* cells a query looks at before leaving it to the BVH */

void snow_grid_free(snow_grid_t *g)
{
    free(g->bits);
    memset(g, 0, sizeof *g);
}

/* Cells [a, b] that [lo, hi] touches along axis k; b < a if none. The mapping is monotonic,
 * so boxes that overlap always share a cell. */
static void cell_range(const snow_grid_t *g, float lo, float hi, int k, int32_t *a, int32_t *b)
{
    const float fa = (lo - g->lo[k]) * g->inv[k], fb = (hi - g->lo[k]) * g->inv[k];
    const float top = (float)(g->n[k] - 1);
    if (fb < 0.0f || fa > top + 1.0f) { *a = 1; *b = 0; return; }
    *a = (int32_t)snow_min(snow_max(fa, 0.0f), top);
    *b = (int32_t)snow_min(fb, top);
}

hbk_result_t snow_grid_build(snow_grid_t *out, const float *pos, const int32_t *tri, int32_t n,
                             const float lo[3], const float hi[3])
{
    snow_grid_t g;
    memset(&g, 0, sizeof g);
    float ext[3];
    double vol = 1.0;
    for (int k = 0; k < 3; ++k) {
        /* A margin of a cell's worth keeps triangles on the bounds inside. */
        ext[k] = snow_max(hi[k] - lo[k], 1e-6f);
        vol *= ext[k];
    }
    const float emax = snow_max(ext[0], snow_max(ext[1], ext[2]));
    const float cell = snow_max(emax / GRID_MAX_AXIS, (float)cbrt(vol / GRID_TARGET_CELLS));
    size_t cells = 1;
    for (int k = 0; k < 3; ++k) {
        g.n[k] = (int32_t)ceilf(ext[k] / cell);
        if (g.n[k] < 1) g.n[k] = 1;
        if (g.n[k] > GRID_MAX_AXIS) g.n[k] = GRID_MAX_AXIS;
        g.lo[k] = lo[k];
        g.inv[k] = (float)g.n[k] / ext[k];
        cells *= (size_t)g.n[k];
    }
    g.bits = calloc((cells + 63) / 64, sizeof *g.bits);
    if (!g.bits) return HBK_ERR_OUT_OF_MEMORY;
    for (int32_t t = 0; t < n; ++t) {
        float blo[3], bhi[3];
        for (int k = 0; k < 3; ++k) { blo[k] = INFINITY; bhi[k] = -INFINITY; }
        for (int c = 0; c < 3; ++c) {
            const float *v = pos + 3 * (size_t)tri[3 * (size_t)t + c];
            for (int k = 0; k < 3; ++k) {
                blo[k] = snow_min(blo[k], v[k]);
                bhi[k] = snow_max(bhi[k], v[k]);
            }
        }
        int32_t a[3], b[3];
        for (int k = 0; k < 3; ++k) cell_range(&g, blo[k], bhi[k], k, &a[k], &b[k]);
        for (int32_t z = a[2]; z <= b[2]; ++z)
            for (int32_t y = a[1]; y <= b[1]; ++y)
                for (int32_t x = a[0]; x <= b[0]; ++x) {
                    const size_t i = ((size_t)z * g.n[1] + y) * g.n[0] + x;
                    g.bits[i >> 6] |= UINT64_C(1) << (i & 63);
                }
    }
    *out = g;
    return HBK_OK;
}

int snow_grid_maybe(const snow_grid_t *g, const float p[3], const float e[3])
{
    int32_t a[3], b[3];
    int32_t cells = 1;
    for (int k = 0; k < 3; ++k) {
        cell_range(g, snow_min(p[k], e[k]), snow_max(p[k], e[k]), k, &a[k], &b[k]);
        if (b[k] < a[k]) return 0; /* outside the grid on this axis */
        cells *= b[k] - a[k] + 1;
    }
    if (cells > GRID_MAX_QUERY) return 1; /* a long step: let the BVH decide */
    for (int32_t z = a[2]; z <= b[2]; ++z)
        for (int32_t y = a[1]; y <= b[1]; ++y)
            for (int32_t x = a[0]; x <= b[0]; ++x) {
                const size_t i = ((size_t)z * g->n[1] + y) * g->n[0] + x;
                if (g->bits[i >> 6] >> (i & 63) & 1) return 1;
            }
    return 0;
}
