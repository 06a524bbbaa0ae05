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
#include "internal_caustics.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

enum { IT_H, IT_V, IT_D, IT_LOOSE };
enum { HBK_GROUP = 32 };
/* Pixels past the right edge of an accumulator row: a narrow piece writes four pixels from
 * its first (zeros past the piece), which may reach three past the map. */
enum { HBK_PAD = 4 };

typedef double v4d __attribute__((vector_size(32)));
typedef int64_t v4l __attribute__((vector_size(32)));
typedef int32_t v4i __attribute__((vector_size(16)));
typedef float v4f __attribute__((vector_size(16)));

/* HBK_GROUP consecutive items (pass g, kind, mesh row j, columns i0 .. i0 + n - 1; loose
 * triangles i0 .. i0 + n - 1) and the map rows [lo, hi) they touch, unwrapped. */
typedef struct {
    int32_t g, kind, j, i0, n;
    int64_t lo, hi;
} group_t;

/* Narrow edges of a mono map (pieces under two pixels wide) waiting to be drawn four at a
 * time, one per vector lane. */
typedef struct {
    double ylo[4], yhi[4], x0[4], y0[4], dxdy[4], dir[4], ds[4], w[4];
    int64_t rlo, rhi; /* rows of all of them, within the band */
    int n;
} narrow_t;

typedef struct {
    const hbk_caustics_ctx_t *c;
    double *buf;      /* BAND rows of (MW + HBK_PAD) pixels x ps channels */
    size_t rowlen;
    int32_t B0, B1;   /* rows of this band */
    narrow_t *nw;
} band_t;

#define TRIW(c, g, cell, t, ch) \
    ((double)(c)->triw[g][((size_t)(cell) * 2 + (t)) * (size_t)(c)->nch + (size_t)(ch)])

static void kind_dims(const hbk_caustics_ctx_t *c, int kind, int32_t *cols, int32_t *rows)
{
    *cols = kind == IT_V ? c->nvx : kind == IT_LOOSE ? (int32_t)c->nloose : c->ncx;
    *rows = kind == IT_H ? c->nvy : kind == IT_LOOSE ? 1 : c->ncy;
}

/* The two vertices of edge (kind, j, i): H (i, j) -> (i+1, j), V (i, j) -> (i, j+1),
 * D (i, j) -> (i+1, j+1). */
static inline void edge_verts(const hbk_caustics_ctx_t *c, int kind, int32_t j, int32_t i,
                              size_t *v0, size_t *v1)
{
    *v0 = (size_t)j * (size_t)c->nvx + (size_t)i;
    *v1 = *v0 + (kind == IT_H ? 1 : kind == IT_V ? (size_t)c->nvx : (size_t)c->nvx + 1);
}

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

/* floor for |x| < 2^62, inline (libm's floor is a call without SSE4.1). */
static inline double ffloor(double x)
{
    const double t = (double)(int64_t)x;
    return t > x ? t - 1.0 : t;
}

static inline int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

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

/* Adds v * w to pixel x of a row (NCH channels from ch0, PS accumulator channels per pixel).
 * NCH and PS are constants where inlined. */
#define HBK_PUT(row, x, v)                                                   \
    do {                                                                     \
        double *px_ = (row) + (size_t)PS * (size_t)(x) + (size_t)ch0;        \
        const double v_ = (v);                                               \
        for (int k_ = 0; k_ < NCH; ++k_) px_[k_] += v_ * w[k_];              \
    } while (0)

/* Coverage of a piece of edge within one row, x in [0, MW], signed height dv: pixel k gets
 * dv * c_k, c_k = E[clamp(k + 1 - x, 0, 1)] with x uniform over the piece (0 left of it, 1 right
 * of it), stored as differences c_k - c_(k-1) for the prefix sum. `ds` is dv / (x1 - x0), the
 * same for every row piece of an edge (dir * |dy/dx|), so no row divides. */
static inline __attribute__((always_inline)) void
accumulate(double *row, double xa, double xb, double dv, double ds, const double *w, int ch0,
           const int NCH, const int PS)
{
    const double x0 = xa < xb ? xa : xb, x1 = xa < xb ? xb : xa;
    const int32_t i0 = (int32_t)x0, j1 = (int32_t)x1; /* x >= 0: truncation is floor */
    const int32_t i1 = x1 == (double)j1 ? j1 : j1 + 1; /* ceil: x1 in (i1 - 1, i1] */
    const double f0 = (double)i0;
    if (i1 <= i0 + 1) { /* within one pixel column */
        const double xm = 0.5 * (x0 + x1) - f0;
        HBK_PUT(row, i0, dv * (1.0 - xm));
        HBK_PUT(row, i0 + 1, dv * xm);
        return;
    }
    const double x0f = 1.0 - (x0 - f0);
    const double h = 0.5 * ds;
    if (i1 == i0 + 2) { /* pixels i0 and i0 + 1 */
        const double x1f = x1 - f0 - 1.0, a0 = h * x0f * x0f, am = h * x1f * x1f;
        HBK_PUT(row, i0, a0);
        HBK_PUT(row, i0 + 1, dv - a0 - am);
        HBK_PUT(row, i0 + 2, am);
        return;
    }
    const double x1f = x1 - (double)(i1 - 1);
    const double a0 = h * x0f * x0f;        /* dv x coverage of pixel i0 */
    const double am = h * x1f * x1f;        /* dv x (1 - coverage of pixel i1-1) */
    const double a1 = ds * (x0f + 0.5);     /* dv x coverage of pixel i0+1 */
    HBK_PUT(row, i0, a0);
    HBK_PUT(row, i0 + 1, a1 - a0);
    for (int32_t k = i0 + 2; k < i1 - 1; ++k) HBK_PUT(row, k, ds);
    const double a2 = a1 + (double)(i1 - i0 - 3) * ds; /* dv x coverage of pixel i1-2 */
    HBK_PUT(row, i1 - 1, dv - a2 - am);
    HBK_PUT(row, i1, am);
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

static inline __attribute__((always_inline)) v4d vsel(v4l m, v4d a, v4d b) { return (v4d)(((v4l)a & m) | ((v4l)b & ~m)); }

/* Draws four narrow edges row by row, one per lane, each row's pieces in lane order: every
 * pixel gets the same values in the same order as from accumulate() edge after edge, so the
 * same bytes. Each lane computes the three cases of accumulate (one, two or three pixel
 * columns) and keeps the right one, and writes four pixels from i0 (zeros past the piece:
 * adding zero changes no sum). No branch depends on the geometry. */
static inline __attribute__((always_inline)) void
narrow_draw_v(double *buf, size_t rowlen, int64_t B0, const narrow_t *nw)
{
    v4d ylo, yhi, x0, y0, dxdy, dir, ds, w;
    memcpy(&ylo, nw->ylo, sizeof ylo);
    memcpy(&yhi, nw->yhi, sizeof yhi);
    memcpy(&x0, nw->x0, sizeof x0);
    memcpy(&y0, nw->y0, sizeof y0);
    memcpy(&dxdy, nw->dxdy, sizeof dxdy);
    memcpy(&dir, nw->dir, sizeof dir);
    memcpy(&ds, nw->ds, sizeof ds);
    memcpy(&w, nw->w, sizeof w);
    const v4d zero = {0.0, 0.0, 0.0, 0.0}, one = zero + 1.0, h = 0.5 * ds;
    double *row = buf + (size_t)(nw->rlo - B0) * rowlen, spare[16];
    for (int64_t r = nw->rlo; r < nw->rhi; ++r, row += rowlen) {
        const v4d top = zero + (double)r, bot = top + 1.0;
        const v4d ya = vsel(ylo > top, ylo, top), yb = vsel(yhi < bot, yhi, bot);
        const v4l act = yb > ya;
        const v4d xa = x0 + (ya - y0) * dxdy, xb = x0 + (yb - y0) * dxdy;
        const v4d dv = dir * (yb - ya);
        const v4l lt = xa < xb;
        const v4d xl = vsel(act, vsel(lt, xa, xb), zero), xr = vsel(act, vsel(lt, xb, xa), zero);
        const v4i i0 = __builtin_convertvector(xl, v4i); /* x >= 0: truncation is floor */
        const v4d f0 = __builtin_convertvector(i0, v4d), u1 = xr - f0;
        const v4l wide2 = u1 > one, wide3 = u1 > one + 1.0;
        const v4d xm = 0.5 * (xl + xr) - f0;
        const v4d x0f = 1.0 - (xl - f0);
        const v4d x1f = vsel(wide3, u1 - 2.0, u1 - 1.0);
        const v4d a0 = h * x0f * x0f, am = h * x1f * x1f, a1 = ds * (x0f + 0.5);
        const v4d a2 = a1 + 0.0 * ds;
        v4d d[4];
        d[0] = vsel(wide2, a0, dv * (1.0 - xm));
        d[1] = vsel(wide3, a1 - a0, vsel(wide2, dv - a0 - am, dv * xm));
        d[2] = vsel(wide3, dv - a2 - am, vsel(wide2, am, zero));
        d[3] = vsel(wide3, am, zero);
        double v[4][4];
        int32_t at[4];
        int64_t on[4];
        for (int k = 0; k < 4; ++k) {
            const v4d dk = d[k] * w;
            memcpy(v[k], &dk, sizeof dk);
        }
        memcpy(at, &i0, sizeof at);
        memcpy(on, &act, sizeof on);
        for (int q = 0; q < 4; ++q) {
            /* a lane without a piece writes to its own scratch: no chain through memory */
            const uintptr_t m = (uintptr_t)on[q]; /* all ones or zero: a mask, not a branch */
            double *p = (double *)(((uintptr_t)(row + at[q]) & m) |
                                   ((uintptr_t)(spare + 4 * q) & ~m));
            p[0] += v[0][q];
            p[1] += v[1][q];
            p[2] += v[2][q];
            p[3] += v[3][q];
        }
    }
}

__attribute__((target("avx2"))) static void
narrow_draw_avx2(double *buf, size_t rowlen, int64_t B0, const narrow_t *nw)
{
    narrow_draw_v(buf, rowlen, B0, nw);
    __builtin_ia32_vzeroupper(); /* the callers are SSE code */
}

static int narrow_avx2 = -1;

/* Draws the waiting edges (the unused lanes draw nothing) and empties the batch. */
static void narrow_flush(const band_t *b)
{
    narrow_t *nw = b->nw;
    if (!nw || !nw->n) return;
    for (int q = nw->n; q < 4; ++q) { /* no piece in any row: yb <= ya */
        nw->ylo[q] = nw->yhi[q] = nw->x0[q] = nw->y0[q] = nw->dxdy[q] = 0.0;
        nw->dir[q] = nw->ds[q] = nw->w[q] = 0.0;
    }
    if (narrow_avx2 < 0) narrow_avx2 = __builtin_cpu_supports("avx2") ? 1 : 0;
    if (narrow_avx2) narrow_draw_avx2(b->buf, b->rowlen, b->B0, nw);
    else narrow_draw_v(b->buf, b->rowlen, b->B0, nw);
    nw->n = 0;
    nw->rlo = INT64_MAX;
    nw->rhi = INT64_MIN;
}

/* Queues an edge whose rows [r0, r1) lie in the band and whose pieces are at most 1.75
 * pixels wide; draws the batch when full. */
static void narrow_add(const band_t *b, int64_t r0, int64_t r1, double ylo, double yhi,
                       double x0, double y0, double dxdy, double dir, double ds, double w)
{
    narrow_t *nw = b->nw;
    const int q = nw->n;
    nw->rlo = nw->rlo < r0 ? nw->rlo : r0;
    nw->rhi = nw->rhi > r1 ? nw->rhi : r1;
    nw->ylo[q] = ylo;
    nw->yhi[q] = yhi;
    nw->x0[q] = x0;
    nw->y0[q] = y0;
    nw->dxdy[q] = dxdy;
    nw->dir[q] = dir;
    nw->ds[q] = ds;
    nw->w[q] = w;
    if (++nw->n == 4) narrow_flush(b);
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
            narrow_add(b, r0, r1, ylo, yhi, x0, y0, dxdy, dir, ds, w[0]);
            return;
        }
        narrow_flush(b); /* drawn first, as they come first */
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
    narrow_flush(b);
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

enum { CL_SKIP, CL_NARROW, CL_WIDE, CL_OTHER };

/* What a mono map's edge group needs per edge, from one loop over the group without
 * branches (vectorised): its weight, rows, direction, and its class: nothing to draw here
 * (horizontal, zero weight, not in this band), an edge wholly in the map with narrow, wide
 * or long pieces (drawn in lanes by narrow_add, or by wide_rows), or anything else
 * (edge_item). */
typedef struct {
    double w[HBK_GROUP], ylo[HBK_GROUP], yhi[HBK_GROUP], dir[HBK_GROUP];
    int64_t cls[HBK_GROUP];
} prelude_t;

__attribute__((target_clones("avx2", "default"))) static void
edge_prelude(int32_t n, const double *restrict x0, const double *restrict y0,
             const double *restrict x1, const double *restrict y1, double *restrict dxdy,
             double *restrict ds, const double *restrict P, const double *restrict M, double B0,
             double B1, double MW, double MH, int periodic, prelude_t *restrict o)
{
    for (int32_t q = 0; q < n; ++q) {
        const double dx = x1[q] - x0[q], dy = y1[q] - y0[q];
        { /* edge_slopes */
            dxdy[q] = dx / dy;
            const double sl = (y0[q] > y1[q] ? 1.0 : -1.0) * fabs(dy / dx);
            /* 0 for a vertical edge, by a mask: a select here would become a branch around
             * the division, which stops the vectoriser */
            uint64_t bits;
            memcpy(&bits, &sl, sizeof bits);
            bits &= -(uint64_t)(x1[q] != x0[q]);
            memcpy(&ds[q], &bits, sizeof bits);
        }
        const double w = P[q] - M[q]; /* as edge_weights */
        const double ylo = y0[q] < y1[q] ? y0[q] : y1[q], yhi = y0[q] < y1[q] ? y1[q] : y0[q];
        const double xlo = x0[q] < x1[q] ? x0[q] : x1[q], xhi = x0[q] < x1[q] ? x1[q] : x0[q];
        const int64_t sane = (ylo > -1e9) & (yhi < 1e9) & (xlo > -1e9) & (xhi < 1e9);
        /* edge_n's fast case: in the map, no period shift, rows in the map if periodic
         * (floor(ylo) >= 0 and ceil(yhi) <= MH: MH is an integer) */
        const int64_t in = (xlo >= 0.0) & (xhi <= MW) &
                           ((!periodic) | ((xlo < MW) & (ylo >= 0.0) & (yhi <= MH)));
        const int64_t draw = (y0[q] != y1[q]) & sane & (w != 0.0);
        /* a row's piece is no wider than the edge nor than |dx/dy|: narrow pieces span at
         * most 3 pixel columns (the margin of 0.25 is for rounding) */
        const double span = fabs(dx) < fabs(dxdy[q]) ? fabs(dx) : fabs(dxdy[q]);
        const int64_t narrow = span <= 1.75;
        const int64_t hit = (ylo < B1) & (yhi > B0); /* rows [floor, ceil) meet [B0, B1) */
        o->w[q] = w;
        o->ylo[q] = ylo;
        o->yhi[q] = yhi;
        o->dir[q] = y0[q] > y1[q] ? 1.0 : -1.0;
        /* skip, other, narrow or wide, as numbers: no branch */
        o->cls[q] = draw * (in * hit * (CL_WIDE - narrow) + (1 - in) * CL_OTHER);
    }
}

/* edge_n's fast case for a mono map: rows [r0, r1) of an edge in the map. */
static void wide_rows(const band_t *b, int64_t r0, int64_t r1, double ylo, double yhi,
                      double x0, double y0, double dxdy, double dir, double ds, double w)
{
    const double wv[1] = {w};
    double *row = b->buf + (size_t)(r0 - b->B0) * b->rowlen;
    double fr = (double)r0; /* r as a double, counted exactly */
    double ya = ylo > fr ? ylo : fr, xa = x0 + (ya - y0) * dxdy;
    for (int64_t r = r0; r < r1; ++r, row += b->rowlen) {
        fr += 1.0;
        const double yb = yhi < fr ? yhi : fr;
        const double xb = x0 + (yb - y0) * dxdy;
        if (yb > ya) accumulate(row, xa, xb, dir * (yb - ya), ds, wv, 0, 1, 1);
        ya = yb;
        xa = xb;
    }
}

static const float k_zeros[HBK_GROUP];

/* The edges of a group of a mono map: edge_item's work, with the per-edge tests done for the
 * whole group by edge_prelude. The same values in the same order: the same bytes. */
static void draw_edges_mono(const band_t *b, const group_t *gr)
{
    const hbk_caustics_ctx_t *c = b->c;
    const int kind = gr->kind;
    const int32_t j = gr->j, i0 = gr->i0, n = gr->n;
    size_t v0, v1;
    edge_verts(c, kind, j, i0, &v0, &v1);
    const double *x0 = c->ipx[0] + v0, *y0 = c->ipy[0] + v0;
    const double *x1 = c->ipx[0] + v1, *y1 = c->ipy[0] + v1;
    double dxdy[HBK_GROUP], ds[HBK_GROUP];
    /* The weights of the triangles left (P) and right (M) of each edge (edge_weights). */
    double P[HBK_GROUP], M[HBK_GROUP];
    const float *tw = c->triw[0];
    const size_t ci = (size_t)j * (size_t)c->ncx + (size_t)i0;
    const float *pp = k_zeros, *mp = k_zeros;
    int32_t ps = 0, ms = 0, pq0 = 0, mq1 = n; /* strides; the edges with the triangle */
    if (kind == IT_H) {
        if (j < c->ncy) pp = tw + ci * 2, ps = 2;
        if (j > 0) mp = tw + (ci - (size_t)c->ncx) * 2 + 1, ms = 2;
    } else if (kind == IT_V) {
        pp = tw + ci * 2 - 2, ps = 2, pq0 = i0 == 0;              /* T0(i-1, j), none at i = 0 */
        mp = tw + ci * 2 + 1, ms = 2, mq1 = i0 + n > c->ncx ? n - 1 : n; /* none at i = ncx */
    } else {
        pp = tw + ci * 2 + 1, ps = 2;
        mp = tw + ci * 2, ms = 2;
    }
    for (int32_t q = pq0; q < n; ++q) P[q] = (double)pp[(size_t)q * (size_t)ps];
    for (int32_t q = 0; q < mq1; ++q) M[q] = (double)mp[(size_t)q * (size_t)ms];
    if (pq0) P[0] = 0.0;
    if (mq1 < n) M[n - 1] = 0.0;
    prelude_t pr;
    edge_prelude(n, x0, y0, x1, y1, dxdy, ds, P, M, (double)b->B0, (double)b->B1, c->MW,
                 (double)c->MH, c->periodic, &pr);
    for (int32_t q = 0; q < n; ++q) {
        const int64_t cls = pr.cls[q];
        if (cls == CL_SKIP) continue;
        if (cls != CL_OTHER) {
            const int64_t rlo = (int64_t)ffloor(pr.ylo[q]), rhi = (int64_t)-ffloor(-pr.yhi[q]);
            const int64_t r0 = rlo > b->B0 ? rlo : b->B0, r1 = rhi < b->B1 ? rhi : b->B1;
            if (cls == CL_NARROW) {
                narrow_add(b, r0, r1, pr.ylo[q], pr.yhi[q], x0[q], y0[q], dxdy[q], pr.dir[q],
                           ds[q], pr.w[q]);
                continue;
            }
            narrow_flush(b);
            wide_rows(b, r0, r1, pr.ylo[q], pr.yhi[q], x0[q], y0[q], dxdy[q], pr.dir[q], ds[q],
                      pr.w[q]);
            continue;
        }
        narrow_flush(b);
        edge_item(b, x0[q], y0[q], x1[q], y1[q], dxdy[q], ds[q], NULL, 0, kind, j, i0 + q, 0, 1,
                  1);
    }
    narrow_flush(b);
}

/* Draws the items of group `gr` that meet band b. */
static inline __attribute__((always_inline)) void
draw_group_n(const band_t *b, const group_t *gr, const int NCH, const int PS)
{
    const hbk_caustics_ctx_t *c = b->c;
    const int g = gr->g, ch0 = c->ng == 1 ? 0 : g;
    if (gr->kind != IT_LOOSE && NCH == 1 && PS == 1) {
        draw_edges_mono(b, gr);
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
        narrow_flush(b);
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
        narrow_flush(b);
        double *row = b->buf + (size_t)((int32_t)cy - b->B0) * b->rowlen;
        HBK_PUT(row, (int32_t)cx, 1.0);
        HBK_PUT(row, (int32_t)cx + 1, -1.0);
    }
    narrow_flush(b);
}

static void draw_group(const band_t *b, const group_t *gr)
{
    if (b->c->nch == 3) draw_group_n(b, gr, 3, 3);
    else if (b->c->ps == 3) draw_group_n(b, gr, 1, 3);
    else draw_group_n(b, gr, 1, 1);
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
        double a, b;
        if (gr->kind == IT_LOOSE) {
            if (!c->loose[i].used[g]) continue;
            loose_rows(&c->loose[i], g, &a, &b);
        } else {
            size_t v0, v1;
            edge_verts(c, gr->kind, gr->j, i, &v0, &v1);
            const double y0 = c->ipy[g][v0], y1 = c->ipy[g][v1];
            if (y0 == y1) continue;
            a = ffloor(y0 < y1 ? y0 : y1);
            b = -ffloor(-(y0 < y1 ? y1 : y0));
        }
        lo = a < lo ? a : lo;
        hi = b > hi ? b : hi;
    }
    if (!(lo > -1e9 && hi < 1e9)) lo = hi = 0.0; /* empty, or absurd coordinates */
    gr->lo = (int64_t)lo;
    gr->hi = (int64_t)hi;
}

/* One row's prefix sum, x from 0: the pixel values; also clears the accumulator. */
#define PREFIX_MONO(R)                                                                       \
    do {                                                                                     \
        s[R] += a[R][x];                                                                     \
        a[R][x] = 0.0;                                                                       \
        const double v = s[R] > 0.0 ? s[R] : 0.0; /* below 0 only by rounding */            \
        float *q = px[R] + (size_t)x * (size_t)nc;                                           \
        q[0] = (float)(v * e0);                                                              \
        q[1] = (float)(v * e1);                                                              \
        q[2] = (float)(v * e2);                                                              \
        if (nc == 4) q[3] = 1.0f;                                                            \
    } while (0)

static inline void store4(float *q, v4d v) /* v to floats, rounded as (float) does */
{
    const v4f f = __builtin_convertvector(v, v4f);
    memcpy(q, &f, sizeof f);
}

/* Pixels [x, MW) of a mono row r from sum s (PREFIX_MONO for one row). */
static void prefix_mono_tail(double *a, float *px, int32_t x, int32_t MW, int nc, double s,
                             const double e[3])
{
    for (; x < MW; ++x) {
        s += a[x];
        a[x] = 0.0;
        const double v = s > 0.0 ? s : 0.0;
        float *q = px + (size_t)x * (size_t)nc;
        for (int k = 0; k < 3; ++k) q[k] = (float)(v * e[k]);
        if (nc == 4) q[3] = 1.0f;
    }
}

/* Four mono rows of an RGB or RGBA map, four pixels at a time: each row's sum is still one
 * chain of additions in x order (the bytes of PREFIX_MONO), but the pixels leave in 16-byte
 * stores, three (RGB) or four (RGBA) per four pixels instead of twelve or sixteen. */
/* Row R's next four pixels from its running sum sR. */
#define PREFIX_MONO4(R)                                                                      \
    do {                                                                                     \
        double *const p_ = a[R] + x;                                                         \
        const double v0 = (s##R += p_[0]) > 0.0 ? s##R : 0.0; /* < 0 only by rounding */    \
        const double v1 = (s##R += p_[1]) > 0.0 ? s##R : 0.0;                                \
        const double v2 = (s##R += p_[2]) > 0.0 ? s##R : 0.0;                                \
        const double v3 = (s##R += p_[3]) > 0.0 ? s##R : 0.0;                                \
        memset(p_, 0, 4 * sizeof(double));                                                  \
        float *const q = px[R] + (size_t)x * (size_t)nc;                                     \
        if (nc == 3) {                                                                       \
            store4(q, (v4d){v0, v0, v0, v1} * e3a);                                          \
            store4(q + 4, (v4d){v1, v1, v2, v2} * e3b);                                      \
            store4(q + 8, (v4d){v2, v3, v3, v3} * e3c);                                      \
        } else {                                                                             \
            store4(q, (v4d){v0, v0, v0, 1.0} * e4);                                          \
            store4(q + 4, (v4d){v1, v1, v1, 1.0} * e4);                                      \
            store4(q + 8, (v4d){v2, v2, v2, 1.0} * e4);                                      \
            store4(q + 12, (v4d){v3, v3, v3, 1.0} * e4);                                     \
        }                                                                                    \
    } while (0)

/* Four mono rows of an RGB or RGBA map, four pixels at a time: each row's sum is still one
 * chain of additions in x order (the bytes of PREFIX_MONO), but the pixels leave in 16-byte
 * stores, three (RGB) or four (RGBA) per four pixels instead of twelve or sixteen. */
static void prefix_mono4(double *const a[4], float *const px[4], int32_t MW, int nc,
                         const double e[3])
{
    const v4d e3a = {e[0], e[1], e[2], e[0]}, e3b = {e[1], e[2], e[0], e[1]},
              e3c = {e[2], e[0], e[1], e[2]}, e4 = {e[0], e[1], e[2], 1.0};
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int32_t x = 0;
    for (; x + 4 <= MW; x += 4) {
        PREFIX_MONO4(0);
        PREFIX_MONO4(1);
        PREFIX_MONO4(2);
        PREFIX_MONO4(3);
    }
    prefix_mono_tail(a[0], px[0], x, MW, nc, s0, e);
    prefix_mono_tail(a[1], px[1], x, MW, nc, s1, e);
    prefix_mono_tail(a[2], px[2], x, MW, nc, s2, e);
    prefix_mono_tail(a[3], px[3], x, MW, nc, s3, e);
}
#undef PREFIX_MONO4

/* Writes rows [y, y + n) of the map (n <= 4) from the band's accumulator by prefix sums along
 * each row, and clears the accumulator for the next band. A row's sum is one chain of
 * dependent additions; a mono map runs four rows side by side so four chains overlap (each
 * row still adds in x order: the same bytes). */
static void prefix_rows(const hbk_caustics_ctx_t *c, const band_t *b, int32_t y, int32_t n,
                        hbk_image_t *out)
{
    const int nc = out->channels;
    const double e0 = c->escale[0], e1 = c->escale[1], e2 = c->escale[2];
    double *a[4];
    float *px[4];
    for (int r = 0; r < 4; ++r) {
        const int32_t yy = y + (r < n ? r : n - 1);
        a[r] = b->buf + (size_t)(yy - b->B0) * b->rowlen;
        px[r] = out->data + (size_t)yy * out->row_stride;
    }
    if (c->ps == 1 && n == 4 && (nc == 3 || nc == 4)) {
        prefix_mono4(a, px, c->MW, nc, c->escale);
    } else if (c->ps == 1 && n == 4) {
        double s[4] = {0.0, 0.0, 0.0, 0.0};
        for (int32_t x = 0; x < c->MW; ++x) {
            PREFIX_MONO(0);
            PREFIX_MONO(1);
            PREFIX_MONO(2);
            PREFIX_MONO(3);
        }
    } else if (c->ps == 1) {
        for (int32_t r = 0; r < n; ++r) {
            double s[1] = {0.0};
            double *const a0 = a[r];
            float *const p0 = px[r];
            a[0] = a0;
            px[0] = p0;
            for (int32_t x = 0; x < c->MW; ++x) PREFIX_MONO(0);
        }
    } else {
        for (int32_t r = 0; r < n; ++r) {
            double s0 = 0.0, s1 = 0.0, s2 = 0.0, *q = a[r];
            float *o = px[r];
            for (int32_t x = 0; x < c->MW; ++x, q += 3, o += nc) {
                s0 += q[0];
                s1 += q[1];
                s2 += q[2];
                q[0] = q[1] = q[2] = 0.0;
                o[0] = s0 > 0.0 ? (float)s0 : 0.0f;
                o[1] = s1 > 0.0 ? (float)s1 : 0.0f;
                o[2] = s2 > 0.0 ? (float)s2 : 0.0f;
                if (nc == 4) o[3] = 1.0f;
            }
        }
    }
    /* The pixels past the edge take writes that affect no pixel: clear them too. */
    for (int32_t r = 0; r < n; ++r)
        memset(b->buf + (size_t)(y + r - b->B0) * b->rowlen + (size_t)c->ps * (size_t)c->MW, 0,
               (size_t)c->ps * HBK_PAD * sizeof(double));
}
#undef PREFIX_MONO

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
#pragma omp parallel for num_threads(T) schedule(dynamic, 1)
    for (int32_t bb = 0; bb < nb; ++bb) {
        if (__atomic_load_n(&cancelled, __ATOMIC_RELAXED) || hbk_cancelled(progress)) {
            __atomic_store_n(&cancelled, 1, __ATOMIC_RELAXED);
            continue;
        }
        narrow_t nw = {.n = 0, .rlo = INT64_MAX, .rhi = INT64_MIN};
        band_t b = {c, bufs + (size_t)omp_get_thread_num() * (size_t)BH * rowlen, rowlen,
                    bb * BH, bb * BH + BH < c->MH ? bb * BH + BH : c->MH, &nw};
        for (size_t k = start[bb]; k < start[bb + 1]; ++k) draw_group(&b, &groups[list[k]]);
        for (int32_t y = b.B0; y < b.B1; y += 4)
            prefix_rows(c, &b, y, b.B1 - y < 4 ? b.B1 - y : 4, out);
        if (omp_get_thread_num() == 0) hbk_report(progress, 0.5f + 0.5f * (float)(bb + 1) / (float)nb);
    }
    if (cancelled) res = HBK_ERR_CANCELLED;
done:
    return res;
}
