/* Private to the caustic map rasteriser (caustics_raster.c, caustics_edges.c,
 * caustics_lanes.c, caustics_prefix.c): its bands, item groups, and the coverage of one row's
 * piece of edge, which every drawing path shares. */
#ifndef HBK_INTERNAL_RASTER_H
#define HBK_INTERNAL_RASTER_H

#include "internal_caustics.h"
#include <math.h>
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
    double m[4];      /* periods the edge's x was shifted by (0: none) */
    int64_t rlo, rhi; /* rows of all of them, unwrapped, within the band's copy K rows up */
    int64_t K;
    int n, thin;      /* how many; thin: pieces over at most two pixel columns */
    int shifted;      /* some m is not 0 */
    int avx2;         /* the AVX2 kernels may run */
} narrow_t;

typedef struct {
    const hbk_caustics_ctx_t *c;
    double *buf;      /* BAND rows of (MW + HBK_PAD) pixels x ps channels */
    size_t rowlen;
    int32_t B0, B1;   /* rows of this band */
    narrow_t *nw;     /* NULL: no lanes, the general path for everything (HBK_PATHS) */
} band_t;

/* The two vertices of edge (kind, j, i): H (i, j) -> (i+1, j), V (i, j) -> (i, j+1),
 * D (i, j) -> (i+1, j+1). */
static inline void edge_verts(const hbk_caustics_ctx_t *c, int kind, int32_t j, int32_t i,
                              size_t *v0, size_t *v1)
{
    *v0 = (size_t)j * (size_t)c->nvx + (size_t)i;
    *v1 = *v0 + (kind == IT_H ? 1 : kind == IT_V ? (size_t)c->nvx : (size_t)c->nvx + 1);
}

/* floor, inline (libm's floor is a call without SSE4.1). From 2^52 on every double is a whole
 * number: x itself, as for NaN and inf, which the callers' range checks then drop (a degenerate
 * triangle's image far off the map reached the int64 conversion: undefined). */
static inline double ffloor(double x)
{
    if (!(fabs(x) < 4503599627370496.0)) return x;
    const double t = (double)(int64_t)x;
    return t > x ? t - 1.0 : t;
}

static inline int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

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

/* caustics_edges.c: any item group, by the general path. */
void hbk_cr_draw_group(const band_t *b, const group_t *gr);
/* caustics_edges.c: one edge of a mono map by the general path (edge_item). */
void hbk_cr_edge_item_mono(const band_t *b, double x0, double y0, double x1, double y1,
                           double dxdy, double ds, int kind, int32_t j, int32_t i);
/* caustics_lanes.c: narrow edges in vector lanes, and a mono map's edge groups. */
void hbk_cr_narrow_add(const band_t *b, int thin, int64_t K, int64_t r0, int64_t r1,
                       double ylo, double yhi, double x0, double y0, double dxdy, double dir,
                       double ds, double w, double m);
void hbk_cr_narrow_flush(const band_t *b);
void hbk_cr_draw_edges_mono(const band_t *b, const group_t *gr);
/* caustics_prefix.c: rows [y, y + n) of the map from the band's accumulator. */
void hbk_cr_prefix_rows(const hbk_caustics_ctx_t *c, const band_t *b, int32_t y, int32_t n,
                        hbk_image_t *out);

#endif
