/* Exact-coverage rasterisation of the ground images into the caustic map.
 *
 * Every ground triangle is a polygon of constant value w (its power over its area). Instead of
 * clipping triangles against pixels, each polygon edge deposits, per scanline it crosses, the
 * signed coverage it adds to all pixels on its right (the accumulation scheme of font
 * rasterisers such as font-rs); a prefix sum along each row then yields, for every pixel, the
 * exact area-weighted sum of all polygons over it. Because the scheme is linear, an edge shared
 * by two mesh triangles is drawn once with the difference of their values, and a folded
 * triangle (negative signed area) with negative coverage times negative value adds like any
 * other. Periodic maps wrap: a piece of edge one period to the right is drawn at its wrapped
 * position plus a constant for the whole row (derivation: the tile sums coverage over all
 * periods, see `region`).
 *
 * Determinism: the map is cut into bands of rows, each with a double accumulator of about
 * HBK_CAUSTICS_BAND_BYTES (in cache; double so that bright tiny triangles leave no rounding
 * streaks along their rows). Items (edges and loose triangles) come in a fixed order, in groups
 * of HBK_GROUP neighbours binned to the bands their rows touch; every row's contribution is
 * computed from the item alone, so the per-pixel summation order is the item order whatever
 * thread runs the band. */
#include "internal_raster.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>

static void kind_dims(const hbk_caustics_ctx_t *c, int kind, int32_t *cols, int32_t *rows)
{
    *cols = kind == IT_V ? c->nvx : kind == IT_LOOSE ? (int32_t)c->nloose : c->ncx;
    *rows = kind == IT_H ? c->nvy : kind == IT_LOOSE ? 1 : c->ncy;
}

/* Rows [lo, hi) of a loose triangle (one row for a splat). */
static void loose_rows(const hbk_loose_tri_t *lt, int g, double *lo, double *hi)
{
    if (lt->splat[g]) {
        *lo = ffloor((lt->py[g][0] + lt->py[g][1] + lt->py[g][2]) / 3.0);
        *hi = *lo + 1.0;
        return;
    }
    double a = lt->py[g][0], b = a;
    for (int k = 1; k < 3; ++k) {
        a = lt->py[g][k] < a ? lt->py[g][k] : a;
        b = lt->py[g][k] > b ? lt->py[g][k] : b;
    }
    *lo = ffloor(a);
    *hi = -ffloor(-b);
}

/* Band ranges [r[k][0], r[k][1]] covering rows [lo, hi); returns how many (0..2). */
static int row_bands(const hbk_caustics_ctx_t *c, int32_t BH, int32_t nb, int64_t lo, int64_t hi,
                     int32_t r[2][2])
{
    const int64_t MH = c->MH;
    if (!(hi > lo)) return 0;
    if (!c->periodic) {
        if (lo < 0) lo = 0;
        if (hi > MH) hi = MH;
        if (!(hi > lo)) return 0;
        r[0][0] = (int32_t)(lo / BH);
        r[0][1] = (int32_t)((hi - 1) / BH);
        return 1;
    }
    const int64_t n = hi - lo;
    if (n >= MH) {
        r[0][0] = 0;
        r[0][1] = nb - 1;
        return 1;
    }
    const int64_t a = lo - floor_div(lo, MH) * MH, e = a + n - 1;
    r[0][0] = (int32_t)(a / BH);
    if (e < MH) {
        r[0][1] = (int32_t)(e / BH);
        return 1;
    }
    r[0][1] = nb - 1;
    r[1][0] = 0;
    r[1][1] = (int32_t)((e - MH) / BH);
    if (r[1][1] >= r[0][0]) { /* the two ends meet in one band: every band, once */
        r[0][0] = 0;
        return 1;
    }
    return 2;
}

/* Rows [lo, hi) every edge of the group may touch: the span of its endpoints' rows, over the
 * edges with sane coordinates (a horizontal edge, which draws nothing, may widen it: the group
 * is then visited in a band where it draws nothing). One loop without branches. */
static void
edge_group_rows(int32_t n, const double *y0, const double *y1, double *lo, double *hi)
{
    double a = INFINITY, b = -INFINITY;
    for (int32_t q = 0; q < n; ++q) {
        const double l = y0[q] < y1[q] ? y0[q] : y1[q], h = y0[q] < y1[q] ? y1[q] : y0[q];
        const int sane = l > -1e9 && h < 1e9; /* as edge_item skips the others */
        a = sane && l < a ? l : a;
        b = sane && h > b ? h : b;
    }
    *lo = a;
    *hi = b;
}

/* Rows of every item of the group, unwrapped. */
static void group_rows(const hbk_caustics_ctx_t *c, group_t *gr)
{
    double lo = INFINITY, hi = -INFINITY;
    const int g = gr->g;
    if (gr->kind != IT_LOOSE) {
        size_t v0, v1;
        edge_verts(c, gr->kind, gr->j, gr->i0, &v0, &v1);
        double a, b;
        edge_group_rows(gr->n, c->ipy[g] + v0, c->ipy[g] + v1, &a, &b);
        if (!(a <= b)) a = b = 0.0; /* no edge with sane coordinates: drawn nowhere */
        gr->lo = (int64_t)ffloor(a);
        gr->hi = (int64_t)-ffloor(-b);
        return;
    }
    for (int32_t i = gr->i0; i < gr->i0 + gr->n; ++i) {
        if (!c->loose[i].used[g]) continue;
        double a, b;
        loose_rows(&c->loose[i], g, &a, &b);
        lo = a < lo ? a : lo;
        hi = b > hi ? b : hi;
    }
    /* Empty (no triangle used in this pass: lo stays +inf, which no cast may take), or
     * absurd coordinates: drawn nowhere. */
    if (!(lo <= hi && lo > -1e9 && hi < 1e9)) lo = hi = 0.0;
    gr->lo = (int64_t)lo;
    gr->hi = (int64_t)hi;
}

hbk_result_t hbk_caustics_rasterise(hbk_caustics_ctx_t *c, hbk_image_t *out,
                                    hbk_progress_t *progress)
{
    const size_t rowlen = (size_t)c->ps * ((size_t)c->MW + HBK_PAD);
    int32_t BH = (int32_t)(HBK_CAUSTICS_BAND_BYTES / (rowlen * sizeof(double)));
    BH = BH < 8 ? 8 : BH > 256 ? 256 : BH;
    const int32_t nb = (c->MH + BH - 1) / BH;
    const int T = c->threads;
    /* The groups, in drawing order: per pass, H edges, V edges, D edges, loose triangles. */
    size_t ngroups = 0;
    for (int kind = 0; kind < 4; ++kind) {
        int32_t cols, rows;
        kind_dims(c, kind, &cols, &rows);
        ngroups += (size_t)rows * (size_t)((cols + HBK_GROUP - 1) / HBK_GROUP);
    }
    ngroups *= (size_t)c->ng;
    group_t *groups = hbk_cs_get(c->ws, CS_GROUPS, (ngroups ? ngroups : 1) * sizeof *groups, 0);
    size_t *start = hbk_cs_get(c->ws, CS_BAND_START, ((size_t)nb + 1) * sizeof *start, 1);
    size_t *fillat = hbk_cs_get(c->ws, CS_BAND_FILL, (size_t)nb * sizeof *fillat, 1);
    uint32_t *list = NULL;
    double *bufs = NULL;
    hbk_result_t res = HBK_OK;
    if (!groups || !start || !fillat) {
        res = HBK_ERR_OUT_OF_MEMORY;
        goto done;
    }
    size_t n = 0;
    for (int g = 0; g < c->ng; ++g)
        for (int kind = 0; kind < 4; ++kind) {
            int32_t cols, rows;
            kind_dims(c, kind, &cols, &rows);
            for (int32_t j = 0; j < rows; ++j)
                for (int32_t i = 0; i < cols; i += HBK_GROUP)
                    groups[n++] = (group_t){g, kind, j, i, cols - i < HBK_GROUP ? cols - i : HBK_GROUP, 0, 0};
        }
#pragma omp parallel for num_threads(T) schedule(static)
    for (size_t k = 0; k < ngroups; ++k) group_rows(c, &groups[k]);
    /* Bin the groups to bands, keeping their order within every band. */
    for (int fill = 0; fill < 2; ++fill) {
        for (size_t k = 0; k < ngroups; ++k) {
            int32_t r[2][2];
            const int m = row_bands(c, BH, nb, groups[k].lo, groups[k].hi, r);
            for (int q = 0; q < m; ++q)
                for (int32_t bb = r[q][0]; bb <= r[q][1]; ++bb) {
                    if (fill) list[fillat[bb]++] = (uint32_t)k;
                    else start[bb + 1]++;
                }
        }
        if (fill) break;
        for (int32_t bb = 0; bb < nb; ++bb) {
            start[bb + 1] += start[bb];
            fillat[bb] = start[bb];
        }
        const size_t nlist = start[nb] ? start[nb] : 1;
        if (ngroups > UINT32_MAX ||
            !(list = hbk_cs_get(c->ws, CS_BAND_LIST, nlist * sizeof *list, 0))) {
            res = HBK_ERR_OUT_OF_MEMORY;
            goto done;
        }
    }
    if (hbk_cancelled(progress)) {
        res = HBK_ERR_CANCELLED;
        goto done;
    }
    /* Zeroed here (a cancelled render may have left a band dirty); the prefix pass below
     * zeroes what it reads. */
    bufs = hbk_cs_get(c->ws, CS_BAND_BUFS, (size_t)T * (size_t)BH * rowlen * sizeof *bufs, 1);
    if (!bufs) {
        res = HBK_ERR_OUT_OF_MEMORY;
        goto done;
    }
    int cancelled = 0;
    const int paths = hbk_paths(); /* plain: the general path only; SSE: lanes of 4 doubles */
    const int lanes = paths >= HBK_PATHS_SSE, avx2 = paths >= HBK_PATHS_AVX2;
#pragma omp parallel for num_threads(T) schedule(dynamic, 1)
    for (int32_t bb = 0; bb < nb; ++bb) {
        if (__atomic_load_n(&cancelled, __ATOMIC_RELAXED) || hbk_cancelled(progress)) {
            __atomic_store_n(&cancelled, 1, __ATOMIC_RELAXED);
            continue;
        }
        narrow_t nw = {.n = 0, .rlo = INT64_MAX, .rhi = INT64_MIN, .K = 0, .avx2 = avx2};
        band_t b = {c, bufs + (size_t)omp_get_thread_num() * (size_t)BH * rowlen, rowlen,
                    bb * BH, bb * BH + BH < c->MH ? bb * BH + BH : c->MH, lanes ? &nw : NULL};
        for (size_t k = start[bb]; k < start[bb + 1]; ++k) hbk_cr_draw_group(&b, &groups[list[k]]);
        for (int32_t y = b.B0; y < b.B1; y += 4)
            hbk_cr_prefix_rows(c, &b, y, b.B1 - y < 4 ? b.B1 - y : 4, out);
        if (omp_get_thread_num() == 0) hbk_report(progress, 0.5f + 0.5f * (float)(bb + 1) / (float)nb);
    }
    if (cancelled) res = HBK_ERR_CANCELLED;
done:
    return res;
}
