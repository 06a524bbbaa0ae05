/* The fast paths of a mono caustic map: per-edge tests for a whole group of edges in one
 * vectorised loop, then narrow edges (pieces under two pixels wide) drawn four at a time in
 * vector lanes, and wide ones row by row. The same values in the same order as the general
 * path (caustics_edges.c), so the same bytes. */
#include "internal_raster.h"
#include <math.h>

/* m ? a : b per lane, m all ones or zero (a macro: a function returning a vector would
 * change the ABI between the AVX2 and the default code) */
#define vsel(m, a, b) ((v4d)(((v4l)(a) & (m)) | ((v4l)(b) & ~(m))))

/* Draws four narrow edges row by row, one per lane, each row's pieces in lane order: every
 * pixel gets the same values in the same order as from accumulate() edge after edge, so the
 * same bytes. Each lane computes the three cases of accumulate (one, two or three pixel
 * columns) and keeps the right one, and writes four pixels from i0 (zeros past the piece:
 * adding zero changes no sum). No branch depends on the geometry. */
static inline __attribute__((always_inline)) void
narrow_draw_v(double *buf, size_t rowlen, int64_t B0, const narrow_t *nw, const int SLOTS,
              const int SHIFTED)
{
    v4d ylo, yhi, x0, y0, dxdy, dir, ds, w, m;
    memcpy(&m, nw->m, sizeof m);
    memcpy(&ylo, nw->ylo, sizeof ylo);
    memcpy(&yhi, nw->yhi, sizeof yhi);
    memcpy(&x0, nw->x0, sizeof x0);
    memcpy(&y0, nw->y0, sizeof y0);
    memcpy(&dxdy, nw->dxdy, sizeof dxdy);
    memcpy(&dir, nw->dir, sizeof dir);
    memcpy(&ds, nw->ds, sizeof ds);
    memcpy(&w, nw->w, sizeof w);
    const v4d zero = {0.0, 0.0, 0.0, 0.0}, one = zero + 1.0, h = 0.5 * ds;
    double *row = buf + (size_t)(nw->rlo - B0) * rowlen, spare[4 * 4];
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
        const v4d x1f = SLOTS == 3 ? u1 - 1.0 : vsel(wide3, u1 - 2.0, u1 - 1.0);
        const v4d a0 = h * x0f * x0f, am = h * x1f * x1f;
        v4d d[4];
        d[0] = vsel(wide2, a0, dv * (1.0 - xm));
        if (SLOTS == 3) { /* no piece over three columns */
            d[1] = vsel(wide2, dv - a0 - am, dv * xm);
            d[2] = vsel(wide2, am, zero);
        } else {
            const v4d a1 = ds * (x0f + 0.5), a2 = a1 + 0.0 * ds;
            d[1] = vsel(wide3, a1 - a0, vsel(wide2, dv - a0 - am, dv * xm));
            d[2] = vsel(wide3, dv - a2 - am, vsel(wide2, am, zero));
            d[3] = vsel(wide3, am, zero);
        }
        double v[4][4], v0[4];
        int32_t at[4];
        int64_t on[4];
        for (int k = 0; k < SLOTS; ++k) {
            const v4d dk = d[k] * w;
            memcpy(v[k], &dk, sizeof dk);
        }
        if (SHIFTED) {
            const v4d d0 = -m * dv * w;
            memcpy(v0, &d0, sizeof d0);
        }
        memcpy(at, &i0, sizeof at);
        memcpy(on, &act, sizeof on);
        for (int q = 0; q < 4; ++q) {
            /* a lane without a piece writes to its own scratch: no chain through memory */
            const uintptr_t on_q = (uintptr_t)on[q]; /* all ones or zero: a mask, no branch */
            double *p = (double *)(((uintptr_t)(row + at[q]) & on_q) |
                                   ((uintptr_t)(spare + 4 * q) & ~on_q));
            if (SHIFTED) /* the period shift's constant first, as the general path adds it */
                *(double *)(((uintptr_t)row & on_q) | ((uintptr_t)(spare + 4 * q) & ~on_q)) +=
                    v0[q];
            p[0] += v[0][q];
            p[1] += v[1][q];
            p[2] += v[2][q];
            if (SLOTS == 4) p[3] += v[3][q];
        }
    }
}

/* The kernel for three or four slots, with or without shifted lanes, for AVX2 or not. */
#define NARROW_DRAW(NAME, SLOTS, SHIFTED)                                                    \
    static void NAME(double *buf, size_t rowlen, int64_t B0, const narrow_t *nw)             \
    {                                                                                        \
        narrow_draw_v(buf, rowlen, B0, nw, SLOTS, SHIFTED);                                  \
    }                                                                                        \
    __attribute__((target("avx2"))) static void NAME##_avx2(double *buf, size_t rowlen,      \
                                                            int64_t B0, const narrow_t *nw)  \
    {                                                                                        \
        narrow_draw_v(buf, rowlen, B0, nw, SLOTS, SHIFTED);                                  \
        __builtin_ia32_vzeroupper(); /* the callers are SSE code */                          \
    }
NARROW_DRAW(narrow_draw_3, 3, 0)
NARROW_DRAW(narrow_draw_3s, 3, 1)
NARROW_DRAW(narrow_draw_4, 4, 0)
NARROW_DRAW(narrow_draw_4s, 4, 1)
#undef NARROW_DRAW

/* Draws the waiting edges (the unused lanes draw nothing) and empties the batch. */
void hbk_cr_narrow_flush(const band_t *b)
{
    narrow_t *nw = b->nw;
    if (!nw || !nw->n) return;
    for (int q = nw->n; q < 4; ++q) { /* no piece in any row: yb <= ya */
        nw->ylo[q] = nw->yhi[q] = nw->x0[q] = nw->y0[q] = nw->dxdy[q] = 0.0;
        nw->dir[q] = nw->ds[q] = nw->w[q] = nw->m[q] = 0.0;
    }
    static void (*const draw[2][2][2])(double *, size_t, int64_t, const narrow_t *) = {
        {{narrow_draw_4, narrow_draw_4s}, {narrow_draw_3, narrow_draw_3s}},
        {{narrow_draw_4_avx2, narrow_draw_4s_avx2}, {narrow_draw_3_avx2, narrow_draw_3s_avx2}}};
    draw[nw->avx2 != 0][nw->thin][nw->shifted](b->buf, b->rowlen, b->B0 + nw->K, nw);
    nw->n = 0;
    nw->shifted = 0;
    nw->rlo = INT64_MAX;
    nw->rhi = INT64_MIN;
}

/* Queues an edge whose rows [r0, r1) lie in the band and whose pieces are at most 1.75
 * pixels wide (thin: 0.75, so over at most two pixel columns); draws the batch when full. */
void hbk_cr_narrow_add(const band_t *b, int thin, int64_t K, int64_t r0, int64_t r1,
                       double ylo, double yhi, double x0, double y0, double dxdy, double dir,
                       double ds, double w, double m)
{
    narrow_t *nw = b->nw;
    if (nw->n && (nw->thin != thin || nw->K != K)) hbk_cr_narrow_flush(b);
    const int q = nw->n;
    nw->thin = thin;
    nw->K = K;
    nw->m[q] = m;
    nw->shifted |= m != 0.0;
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
    if (++nw->n == 4) hbk_cr_narrow_flush(b);
}

enum { CL_SKIP, CL_THIN, CL_NARROW, CL_WIDE, CL_OTHER };

/* What a mono map's edge group needs per edge, from one loop over the group without
 * branches (vectorised): its weight, rows, direction, its shift to the period it is drawn in
 * (m periods left, and K rows up, as the general path shifts it), and its class: nothing to
 * draw here (horizontal, zero weight, not in this band), an edge wholly in one period with
 * thin or narrow pieces (drawn in lanes) or wider ones (wide_rows), or anything else, such
 * as an edge across a period's border (the general path). */
typedef struct {
    double w[HBK_GROUP], ylo[HBK_GROUP], yhi[HBK_GROUP], dir[HBK_GROUP];
    double x0[HBK_GROUP], m[HBK_GROUP], K[HBK_GROUP]; /* x0 shifted by m periods */
    int64_t cls[HBK_GROUP];
} prelude_t;

/* v where mask is set, else +0 (a mask, not a select: the vectoriser keeps it) */
static inline double keep(double v, int64_t mask)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    bits &= -(uint64_t)(mask != 0);
    memcpy(&v, &bits, sizeof v);
    return v;
}

/* floor for |x| < 2^51 in operations the compiler vectorises: x + 1.5 * 2^52 lies where the
 * doubles are the integers, so the sum rounds x to one. */
static inline double vfloor(double x)
{
    const double big = 6755399441055744.0, t = (x + big) - big;
    return t - keep(1.0, t > x);
}

__attribute__((target_clones("avx2", "default"))) static void
edge_prelude(int32_t n, const double *restrict x0, const double *restrict y0,
             const double *restrict x1, const double *restrict y1, double *restrict dxdy,
             double *restrict ds, const double *restrict P, const double *restrict M, double B0,
             double B1, const hbk_caustics_ctx_t *c, prelude_t *restrict o)
{
    const double MW = c->MW, MH = c->MH, inv_mw = c->inv_mw, inv_mh = 1.0 / MH;
    const int64_t periodic = c->periodic != 0;
    for (int32_t q = 0; q < n; ++q) {
        const double dx = x1[q] - x0[q], dy = y1[q] - y0[q];
        /* edge_slopes; ds is 0 for a vertical edge */
        dxdy[q] = dx / dy;
        ds[q] = keep((y0[q] > y1[q] ? 1.0 : -1.0) * fabs(dy / dx), x1[q] != x0[q]);
        const double w = P[q] - M[q]; /* as edge_weights */
        const double ylo = y0[q] < y1[q] ? y0[q] : y1[q], yhi = y0[q] < y1[q] ? y1[q] : y0[q];
        const double xlo = x0[q] < x1[q] ? x0[q] : x1[q];
        const int64_t sane = (ylo > -1e9) & (yhi < 1e9) & (xlo > -1e9) &
                             (fabs(x0[q]) < 1e9) & (fabs(x1[q]) < 1e9);
        /* edge_n's shift to the period where the edge starts, and its test of the result */
        const double m = keep(vfloor(xlo * inv_mw), periodic & ((xlo < 0.0) | (xlo >= MW)));
        const double sx0 = x0[q] - m * MW, sx1 = x1[q] - m * MW;
        const int64_t in_x = (sx0 >= 0.0) & (sx1 >= 0.0) & (sx0 <= MW) & (sx1 <= MW);
        /* rows: one period's, K = k MH (floor(ylo) >= K and ceil(yhi) <= K + MH: integers) */
        const double K = keep(vfloor(ylo * inv_mh), periodic) * MH;
        const int64_t in_y = (ylo >= K) & (yhi <= K + MH);
        const int64_t in = in_x & ((!periodic) | in_y);
        const int64_t draw = (y0[q] != y1[q]) & sane & (w != 0.0);
        /* a row's piece is no wider than the edge nor than |dx/dy|: narrow pieces span at
         * most 3 pixel columns, thin ones 2 (the margins of 0.25 are for rounding) */
        const double span = fabs(dx) < fabs(dxdy[q]) ? fabs(dx) : fabs(dxdy[q]);
        const int64_t narrow = span <= 1.75, thin = span <= 0.75;
        const int64_t hit = (ylo < B1 + K) & (yhi > B0 + K); /* rows meet the band's copy */
        o->w[q] = w;
        o->ylo[q] = ylo;
        o->yhi[q] = yhi;
        o->dir[q] = y0[q] > y1[q] ? 1.0 : -1.0;
        o->x0[q] = sx0;
        o->m[q] = m;
        o->K[q] = K;
        /* skip, other, thin, narrow or wide, as numbers: no branch */
        o->cls[q] = draw * (in * hit * (CL_WIDE - narrow - thin) + (1 - in) * CL_OTHER);
    }
}

/* The general path's loop for a mono map's edge in one period: rows [r0, r1) (unwrapped;
 * the band holds them K rows up), x shifted by m periods, whose rows then each get -m times
 * their height at pixel 0 (see `region`). */
static void wide_rows(const band_t *b, int64_t r0, int64_t r1, int64_t K, double ylo,
                      double yhi, double x0, double y0, double dxdy, double dir, double ds,
                      double w, double m)
{
    const double wv[1] = {w};
    double *row = b->buf + (size_t)(r0 - K - b->B0) * b->rowlen;
    double ya = ylo > (double)r0 ? ylo : (double)r0, xa = x0 + (ya - y0) * dxdy;
    for (int64_t r = r0; r < r1; ++r, row += b->rowlen) {
        const double yb = yhi < (double)(r + 1) ? yhi : (double)(r + 1);
        const double xb = x0 + (yb - y0) * dxdy;
        if (yb > ya) {
            const double dv = dir * (yb - ya);
            if (m != 0.0) row[0] += -m * dv * w;
            accumulate(row, xa, xb, dv, ds, wv, 0, 1, 1);
        }
        ya = yb;
        xa = xb;
    }
}

static const float k_zeros[HBK_GROUP];

/* The edges of a group of a mono map: edge_item's work, with the per-edge tests done for the
 * whole group by edge_prelude. The same values in the same order: the same bytes. */
void hbk_cr_draw_edges_mono(const band_t *b, const group_t *gr)
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
    edge_prelude(n, x0, y0, x1, y1, dxdy, ds, P, M, (double)b->B0, (double)b->B1, c, &pr);
    for (int32_t q = 0; q < n; ++q) {
        const int64_t cls = pr.cls[q];
        if (cls == CL_SKIP) continue;
        if (cls != CL_OTHER) {
            const int64_t K = (int64_t)pr.K[q];
            const int64_t rlo = (int64_t)ffloor(pr.ylo[q]), rhi = (int64_t)-ffloor(-pr.yhi[q]);
            const int64_t r0 = rlo > b->B0 + K ? rlo : b->B0 + K;
            const int64_t r1 = rhi < b->B1 + K ? rhi : b->B1 + K;
            if (cls != CL_WIDE) {
                hbk_cr_narrow_add(b, cls == CL_THIN, K, r0, r1, pr.ylo[q], pr.yhi[q], pr.x0[q],
                                  y0[q], dxdy[q], pr.dir[q], ds[q], pr.w[q], pr.m[q]);
                continue;
            }
            hbk_cr_narrow_flush(b);
            wide_rows(b, r0, r1, K, pr.ylo[q], pr.yhi[q], pr.x0[q], y0[q], dxdy[q], pr.dir[q],
                      ds[q], pr.w[q], pr.m[q]);
            continue;
        }
        hbk_cr_narrow_flush(b);
        hbk_cr_edge_item_mono(b, x0[q], y0[q], x1[q], y1[q], dxdy[q], ds[q], kind, j, i0 + q);
    }
    hbk_cr_narrow_flush(b);
}
