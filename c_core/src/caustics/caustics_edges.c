/* The general path of the caustic map rasteriser: any edge (wrapping around a periodic map,
 * leaving a bounded one, in colour passes) and loose triangles, one row's piece at a time.
 * A mono map's edges wholly inside the map take the faster paths of caustics_lanes.c. */
#include "internal_raster.h"
#include <math.h>

/* The edge's weight: the value of the triangle on its left minus that on its right (cell (i, j)
 * has T0 = (00, 10, 11) and T1 = (00, 11, 01), both counter-clockwise). Returns 0 if all zero. */
static inline __attribute__((always_inline)) int
edge_weights(const hbk_caustics_ctx_t *c, int g, int kind, int32_t j, int32_t i, double *w,
             const int NCH)
{
    const size_t ci = (size_t)j * (size_t)c->ncx + (size_t)i;
    const float *tw = c->triw[g];
    const float *plus = NULL, *minus = NULL; /* triangles left and right of the edge */
    if (kind == IT_H) { /* +T0(i, j), -T1(i, j-1) */
        if (j < c->ncy) plus = tw + (ci * 2) * NCH;
        if (j > 0) minus = tw + ((ci - (size_t)c->ncx) * 2 + 1) * NCH;
    } else if (kind == IT_V) { /* +T0(i-1, j), -T1(i, j) */
        if (i > 0) plus = tw + ((ci - 1) * 2) * NCH;
        if (i < c->ncx) minus = tw + (ci * 2 + 1) * NCH;
    } else { /* +T1(i, j), -T0(i, j) */
        plus = tw + (ci * 2 + 1) * NCH;
        minus = tw + (ci * 2) * NCH;
    }
    int any = 0;
    for (int ch = 0; ch < NCH; ++ch) {
        w[ch] = (plus ? (double)plus[ch] : 0.0) - (minus ? (double)minus[ch] : 0.0);
        any |= w[ch] != 0.0;
    }
    return any;
}

/* Periods k whose copy of band [B0, B1) meets rows [rlo, rhi); empty when *kmin > *kmax. */
static inline void band_periods(const band_t *b, int64_t rlo, int64_t rhi, int64_t *kmin,
                                int64_t *kmax)
{
    const int64_t MH = b->c->MH;
    if (!b->c->periodic || (rlo >= 0 && rhi <= MH)) {
        const int hit = rhi > b->B0 && rlo < b->B1;
        *kmin = 0;
        *kmax = hit ? 0 : -1;
        return;
    }
    *kmin = floor_div(rlo - b->B1, MH) + 1;
    *kmax = -floor_div(b->B0 - rhi, MH) - 1;
}

/* A piece lying in period m (x in [m MW, (m+1) MW]). A tile sums the coverage over all periods;
 * per piece that is its wrapped coverage minus m times its height for every pixel of the row
 * (the terms common to all periods cancel over a closed polygon). Without wrapping, pieces left
 * of the map cover the whole row and pieces right of it nothing. */
static void region(const hbk_caustics_ctx_t *c, double *row, double xa, double xb, double dv,
                   double ds, int64_t m, const double *w, int ch0, int nch)
{
    const double MW = c->MW;
    const int NCH = nch, PS = c->ps;
    if (c->periodic) {
        if (m) {
            xa -= (double)m * MW;
            xb -= (double)m * MW;
            HBK_PUT(row, 0, -(double)m * dv);
        }
    } else if (m < 0) {
        HBK_PUT(row, 0, dv);
        return;
    } else if (m > 0) {
        return;
    }
    xa = xa < 0.0 ? 0.0 : xa > MW ? MW : xa;
    xb = xb < 0.0 ? 0.0 : xb > MW ? MW : xb;
    accumulate(row, xa, xb, dv, ds, w, ch0, NCH, PS);
}

/* One row's piece of an edge that leaves the map: split where it crosses period boundaries. */
static void row_piece(const hbk_caustics_ctx_t *c, double *row, double xa, double xb, double dv,
                      double ds, const double *w, int ch0, int nch)
{
    const double MW = c->MW;
    const double lo = xa < xb ? xa : xb, hi = xa < xb ? xb : xa;
    const int64_t m0 = (int64_t)ffloor(lo / MW);
    int64_t m1 = (int64_t)ffloor(hi / MW);
    if (m1 > m0 && hi == (double)m1 * MW) --m1; /* ends exactly on a boundary */
    if (m0 == m1) {
        region(c, row, xa, xb, dv, ds, m0, w, ch0, nch);
        return;
    }
    /* Walk from xa to xb; each sub-piece carries its share of the height (linear in x). */
    const int up = xb > xa;
    const double span = xb - xa;
    double prev = xa;
    for (int64_t k = up ? m0 + 1 : m1; up ? k <= m1 : k > m0; k += up ? 1 : -1) {
        const double X = (double)k * MW;
        if (X == prev) continue;
        region(c, row, prev, X, dv * (X - prev) / span, ds, up ? k - 1 : k, w, ch0, nch);
        prev = X;
    }
    if (xb != prev) region(c, row, prev, xb, dv * (xb - prev) / span, ds, up ? m1 : m0, w, ch0, nch);
}

/* Draws the rows of edge (x0, y0) -> (x1, y1) that fall in the band (rows [rlo, rhi), periods
 * kmin..kmax, from band_periods). A downward edge adds coverage to its right, so counter-
 * clockwise polygons come out positive. Every row's piece is computed from the edge alone,
 * never carried over from the previous row, so a row gets the same bytes whichever band (and
 * thread) draws it. */
static inline __attribute__((always_inline)) void
edge_n(const band_t *b, double x0, double y0, double x1, double y1, double dxdy, double ds,
       int64_t rlo, int64_t rhi, int64_t kmin, int64_t kmax, const double *w, int ch0,
       const int NCH, const int PS)
{
    const hbk_caustics_ctx_t *c = b->c;
    const double dir = y0 > y1 ? 1.0 : -1.0;
    const double ylo = y0 < y1 ? y0 : y1, yhi = y0 < y1 ? y1 : y0;
    const double MW = c->MW;
    /* Periodic: move the edge by whole periods so it starts in the map; each row then gets the
     * constant of that shift at pixel 0 (see `region`) and usually needs no splitting. */
    double m = 0.0;
    if (c->periodic && ((x0 < x1 ? x0 : x1) < 0.0 || (x0 < x1 ? x0 : x1) >= MW)) {
        m = ffloor((x0 < x1 ? x0 : x1) * c->inv_mw);
        x0 -= m * MW;
        x1 -= m * MW;
    }
    const int inside = (x0 < x1 ? x0 : x1) >= 0.0 && (x0 < x1 ? x1 : x0) <= MW;
    const int64_t MH = c->MH;
    if (inside && m == 0.0 && kmin == 0 && kmax == 0) {
        /* Most edges: in the map, no shift, no other period: the loop below without its
         * per-row tests (the same arithmetic, so the same bytes). */
        const int64_t r0 = rlo > b->B0 ? rlo : b->B0, r1 = rhi < b->B1 ? rhi : b->B1;
        if (NCH == 1 && PS == 1 && b->nw && fabs(dxdy) <= 1.75) {
            /* pieces under two pixels wide (1.75: a margin for rounding) */
            hbk_cr_narrow_add(b, 0, 0, r0, r1, ylo, yhi, x0, y0, dxdy, dir, ds, w[0], 0.0);
            return;
        }
        hbk_cr_narrow_flush(b); /* drawn first, as they come first */
        double *row = b->buf + (size_t)(r0 - b->B0) * b->rowlen;
        double fr = (double)r0; /* r as a double, counted exactly */
        double ya = ylo > fr ? ylo : fr, xa = x0 + (ya - y0) * dxdy;
        for (int64_t r = r0; r < r1; ++r, row += b->rowlen) {
            fr += 1.0;
            const double yb = yhi < fr ? yhi : fr;
            const double xb = x0 + (yb - y0) * dxdy;
            if (yb > ya) accumulate(row, xa, xb, dir * (yb - ya), ds, w, ch0, NCH, PS);
            ya = yb;
            xa = xb;
        }
        return;
    }
    hbk_cr_narrow_flush(b);
    for (int64_t k = kmin; k <= kmax; ++k) {
        const int64_t r0 = rlo > b->B0 + k * MH ? rlo : b->B0 + k * MH;
        const int64_t r1 = rhi < b->B1 + k * MH ? rhi : b->B1 + k * MH;
        double *row = b->buf + (size_t)(r0 - k * MH - b->B0) * b->rowlen;
        /* x where the edge enters each row; the exit of one row is the entry of the next (the
         * same expression, so the same bits as when a band starts at that row). */
        double ya = ylo > (double)r0 ? ylo : (double)r0, xa = x0 + (ya - y0) * dxdy;
        for (int64_t r = r0; r < r1; ++r, row += b->rowlen) {
            const double yb = yhi < (double)(r + 1) ? yhi : (double)(r + 1);
            const double xb = x0 + (yb - y0) * dxdy;
            if (yb > ya) {
                const double dv = dir * (yb - ya);
                if (m != 0.0) HBK_PUT(row, 0, -m * dv);
                if (inside) accumulate(row, xa, xb, dv, ds, w, ch0, NCH, PS);
                else row_piece(c, row, xa, xb, dv, ds, w, ch0, NCH);
            }
            ya = yb;
            xa = xb;
        }
    }
}

/* dx/dy of edges, and ds = dir |dy/dx| (0 for a vertical edge), as edge_n wants them: one
 * loop the compiler vectorises (an AVX2 clone where the CPU has it) for a group's edges. */
__attribute__((target_clones("avx2", "default"))) static void
edge_slopes(int32_t n, const double *x0, const double *y0, const double *x1, const double *y1,
            double *dxdy, double *ds)
{
    for (int32_t q = 0; q < n; ++q) {
        const double dx = x1[q] - x0[q], dy = y1[q] - y0[q];
        dxdy[q] = dx / dy; /* inf or NaN for a horizontal edge, which is never drawn */
        const double s = (y0[q] > y1[q] ? 1.0 : -1.0) * fabs(dy / dx);
        ds[q] = x1[q] != x0[q] ? s : 0.0;
    }
}

/* Draws an edge if it meets the band and has weight; w is computed only then. */
static inline __attribute__((always_inline)) void
edge_item(const band_t *b, double x0, double y0, double x1, double y1, double dxdy, double ds,
          const double *w_in, int g, int kind, int32_t j, int32_t i, int ch0, const int NCH,
          const int PS)
{
    if (y0 == y1) return; /* horizontal: covers nothing */
    const double ylo = y0 < y1 ? y0 : y1, yhi = y0 < y1 ? y1 : y0;
    if (!(ylo > -1e9 && yhi < 1e9 && fabs(x0) < 1e9 && fabs(x1) < 1e9)) return;
    const int64_t rlo = (int64_t)ffloor(ylo), rhi = (int64_t)-ffloor(-yhi);
    int64_t kmin, kmax;
    band_periods(b, rlo, rhi, &kmin, &kmax);
    if (kmin > kmax) return;
    double wv[3];
    const double *w = w_in;
    if (!w) {
        if (!edge_weights(b->c, g, kind, j, i, wv, NCH)) return;
        w = wv;
    }
    edge_n(b, x0, y0, x1, y1, dxdy, ds, rlo, rhi, kmin, kmax, w, ch0, NCH, PS);
}

void hbk_cr_edge_item_mono(const band_t *b, double x0, double y0, double x1, double y1,
                           double dxdy, double ds, int kind, int32_t j, int32_t i)
{
    edge_item(b, x0, y0, x1, y1, dxdy, ds, NULL, 0, kind, j, i, 0, 1, 1);
}

/* Draws the items of group `gr` that meet band b. */
static inline __attribute__((always_inline)) void
draw_group_n(const band_t *b, const group_t *gr, const int NCH, const int PS)
{
    const hbk_caustics_ctx_t *c = b->c;
    const int g = gr->g, ch0 = c->ng == 1 ? 0 : g;
    if (gr->kind != IT_LOOSE && NCH == 1 && PS == 1 && b->nw) {
        hbk_cr_draw_edges_mono(b, gr);
        return;
    }
    if (gr->kind != IT_LOOSE) {
        size_t v0, v1;
        edge_verts(c, gr->kind, gr->j, gr->i0, &v0, &v1);
        const double *x0 = c->ipx[g] + v0, *y0 = c->ipy[g] + v0;
        const double *x1 = c->ipx[g] + v1, *y1 = c->ipy[g] + v1;
        double dxdy[HBK_GROUP], ds[HBK_GROUP];
        edge_slopes(gr->n, x0, y0, x1, y1, dxdy, ds);
        for (int32_t q = 0; q < gr->n; ++q)
            edge_item(b, x0[q], y0[q], x1[q], y1[q], dxdy[q], ds[q], NULL, g, gr->kind, gr->j,
                      gr->i0 + q, ch0, NCH, PS);
        hbk_cr_narrow_flush(b);
        return;
    }
    for (int32_t i = gr->i0; i < gr->i0 + gr->n; ++i) {
        const hbk_loose_tri_t *lt = &c->loose[i];
        if (!lt->used[g]) continue;
        double w[3];
        for (int ch = 0; ch < NCH; ++ch) w[ch] = lt->w[g][ch];
        if (!lt->splat[g]) {
            for (int k = 0; k < 3; ++k) {
                const double x0 = lt->px[g][k], y0 = lt->py[g][k];
                const double x1 = lt->px[g][(k + 1) % 3], y1 = lt->py[g][(k + 1) % 3];
                double dxdy, ds;
                edge_slopes(1, &x0, &y0, &x1, &y1, &dxdy, &ds);
                edge_item(b, x0, y0, x1, y1, dxdy, ds, w, g, IT_LOOSE, 0, 0, ch0, NCH, PS);
            }
            continue;
        }
        /* A degenerate image: all its light into the pixel of its centroid. */
        double cx = ffloor((lt->px[g][0] + lt->px[g][1] + lt->px[g][2]) / 3.0);
        double cy = ffloor((lt->py[g][0] + lt->py[g][1] + lt->py[g][2]) / 3.0);
        if (!(fabs(cx) < 1e9 && fabs(cy) < 1e9)) continue;
        if (c->periodic) {
            cx -= ffloor(cx / c->MW) * c->MW;
            cy -= ffloor(cy / c->MH) * c->MH;
        } else if (cx < 0 || cy < 0 || cx >= c->MW || cy >= c->MH) {
            continue;
        }
        if (cy < b->B0 || cy >= b->B1) continue;
        hbk_cr_narrow_flush(b);
        double *row = b->buf + (size_t)((int32_t)cy - b->B0) * b->rowlen;
        HBK_PUT(row, (int32_t)cx, 1.0);
        HBK_PUT(row, (int32_t)cx + 1, -1.0);
    }
    hbk_cr_narrow_flush(b);
}

void hbk_cr_draw_group(const band_t *b, const group_t *gr)
{
    if (b->c->nch == 3) draw_group_n(b, gr, 3, 3);
    else if (b->c->ps == 3) draw_group_n(b, gr, 1, 3);
    else draw_group_n(b, gr, 1, 1);
}
