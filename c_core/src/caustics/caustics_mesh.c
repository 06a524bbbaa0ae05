/* Surface triangles: the power each one lets through and the weight its ground image gets, and
 * the shoreline cells cut along the waterline (the paper's Figs. 2 and 3). */
#include "internal_caustics.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* One corner of a triangle: its surface point and, per pass, its ground image. */
typedef struct {
    double s[3];
    double px[3], py[3]; /* [pass], map pixels */
    double hz[3];        /* [pass], ground z of the image */
    float att[3][3];     /* [pass][channel of the pass] */
} corner_t;

/* Result of one triangle in one pass. */
typedef struct {
    float w[3];          /* weight per channel of the pass (or the splat's pixel value) */
    int splat;
} tri_out_t;

/* Power through the surface triangle (a, b, c) and its weight on the ground image, for pass g.
 * `wet`: refracted (Fresnel, absorption) or dry ground lit directly. Adds to stats[9]. */
static inline void triangle(const hbk_caustics_ctx_t *c, int g, int wet, const corner_t *a,
                            const corner_t *b, const corner_t *d, tri_out_t *out, double *stats)
{
    memset(out, 0, sizeof *out);
    double e1[3], e2[3], n2[3];
    for (int k = 0; k < 3; ++k) {
        e1[k] = b->s[k] - a->s[k];
        e2[k] = d->s[k] - a->s[k];
    }
    n2[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n2[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n2[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double L[3], scale = 1.0;
    if (c->point) {
        double r2 = 0.0;
        for (int k = 0; k < 3; ++k) {
            L[k] = c->lpos[k] - (a->s[k] + b->s[k] + d->s[k]) / 3.0;
            r2 += L[k] * L[k];
        }
        const double r = sqrt(r2);
        for (int k = 0; k < 3; ++k) L[k] /= r;
        scale = 1.0 / r2;
    } else {
        for (int k = 0; k < 3; ++k) L[k] = c->L[k];
    }
    const double proj2 = n2[0] * L[0] + n2[1] * L[1] + n2[2] * L[2]; /* 2 S (L . N) */
    if (!(proj2 > 0.0)) return; /* faces away from the light */
    double T = 1.0;
    if (wet && c->p->fresnel) {
        const double len = sqrt(n2[0] * n2[0] + n2[1] * n2[1] + n2[2] * n2[2]);
        T = hbk_caustics_fresnel_t(proj2 / len, c->ior[g]);
    }
    const double through = 0.5 * proj2 * T * scale; /* m^2 of light entering */
    /* The image on the ground, in metres: S' (exact area) and its signed horizontal area. */
    const double f1[3] = {(b->px[g] - a->px[g]) * c->inv_sx, (b->py[g] - a->py[g]) * c->inv_sy,
                          b->hz[g] - a->hz[g]};
    const double f2[3] = {(d->px[g] - a->px[g]) * c->inv_sx, (d->py[g] - a->py[g]) * c->inv_sy,
                          d->hz[g] - a->hz[g]};
    const double m2[3] = {f1[1] * f2[2] - f1[2] * f2[1], f1[2] * f2[0] - f1[0] * f2[2],
                          f1[0] * f2[1] - f1[1] * f2[0]};
    const double s2 = f1[2] == 0.0 && f2[2] == 0.0 /* 2 S'; flat ground needs no root */
                          ? fabs(m2[2]) : sqrt(m2[0] * m2[0] + m2[1] * m2[1] + m2[2] * m2[2]);
    const double area_px = 0.5 * fabs(m2[2]) * c->sx * c->sy;
    out->splat = !(area_px >= HBK_CAUSTICS_TINY_PX2);
    for (int ch = 0; ch < c->nch; ++ch) {
        const int gc = c->ng == 1 ? ch : g; /* channel of the map (0 when mono) */
        const double att = wet ? (a->att[g][ch] + b->att[g][ch] + d->att[g][ch]) / 3.0 : 1.0;
        const double P = c->Ew[gc] * through * att;
        if (wet) {
            stats[gc] += c->Ew[gc] * through;
            stats[3 + gc] += c->Ew[gc] * through * (1.0 - att);
        } else {
            stats[6 + gc] += P;
        }
        if (out->splat) /* all of P into one pixel, as irradiance on the ground */
            out->w[ch] = (float)(P * (s2 > 0.0 ? fabs(m2[2]) / s2 : 1.0) / c->pixel_area);
        else
            out->w[ch] = (float)(P / (0.5 * s2) * (m2[2] > 0.0 ? 1.0 : -1.0));
    }
}

/* Corner of the mesh at vertex v. */
static inline void corner_vertex(const hbk_caustics_ctx_t *c, int32_t k, int32_t l, corner_t *o)
{
    const size_t v = (size_t)l * (size_t)c->nvx + (size_t)k;
    o->s[0] = c->vxs[k];
    o->s[1] = c->vys[l];
    o->s[2] = c->vz[v];
    for (int g = 0; g < c->ng; ++g) {
        o->px[g] = c->ipx[g][v];
        o->py[g] = c->ipy[g][v];
        o->hz[g] = c->ihz[g][v];
        if (c->nch == 1) o->att[g][0] = c->iatt[g][v];
        else
            for (int ch = 0; ch < c->nch; ++ch) o->att[g][ch] = c->iatt[g][v * (size_t)c->nch + (size_t)ch];
    }
}

/* A point on the ground lit where it is: its image is itself. */
static void corner_ground(const hbk_caustics_ctx_t *c, const double s[3], corner_t *o)
{
    memcpy(o->s, s, sizeof o->s);
    for (int g = 0; g < c->ng; ++g) {
        o->px[g] = (s[0] - c->ex0) * c->sx;
        o->py[g] = (s[1] - c->ey0) * c->sy;
        o->hz[g] = s[2];
        for (int ch = 0; ch < 3; ++ch) o->att[g][ch] = 1.0f;
    }
}

/* Fraction t along the ground from wet corner a towards dry corner b where the water ends, and
 * the point there (Fig. 2). If b's ground rises above a's surface, the water plane meets the
 * ground: t = depth / rise, at the water's height (cases 2 and 4). Otherwise the water runs on
 * as a film and ends its own depth further on, measured along the steeper of the horizontal
 * and the vertical (cases 1 and 3: slope > 1 "lower by the depth", else "moved by the depth"). */
static double waterline_t(double ha, double ba, double bb, double len)
{
    const double depth = ha - ba;
    if (bb >= ha) return depth / (bb - ba);
    const double slope = fabs(bb - ba) / len;
    const double t = depth / (len * (slope > 1.0 ? slope : 1.0));
    return t < 1.0 ? t : 1.0;
}

static void waterline_point(const corner_t *a, const corner_t *b, double ba, double bb,
                            double out[3])
{
    const double len = hypot(b->s[0] - a->s[0], b->s[1] - a->s[1]);
    const double t = waterline_t(a->s[2], ba, bb, len);
    out[0] = a->s[0] + t * (b->s[0] - a->s[0]);
    out[1] = a->s[1] + t * (b->s[1] - a->s[1]);
    out[2] = bb >= a->s[2] ? a->s[2] : ba + t * (bb - ba);
}

/* A polygon of a shoreline cell: up to 8 corners, all wet (refracted) or all dry. */
typedef struct {
    corner_t v[8];
    int n, wet;
} poly_t;

/* Cuts shoreline cell (i, j) along the waterline into convex wet and dry polygons, in
 * counter-clockwise order. Returns the number of polygons (<= 3). */
static int shoreline_cell(const hbk_caustics_ctx_t *c, int32_t i, int32_t j, poly_t *polys)
{
    static const int dk[4] = {0, 1, 1, 0}, dl[4] = {0, 0, 1, 1};
    corner_t q[4];
    double b[4];
    int wet[4], nwet = 0;
    for (int k = 0; k < 4; ++k) {
        const int32_t vk = i + dk[k], vl = j + dl[k];
        const size_t v = (size_t)vl * (size_t)c->nvx + (size_t)vk;
        corner_vertex(c, vk, vl, &q[k]);
        b[k] = c->vb[v];
        wet[k] = c->vwet[v];
        if (!wet[k]) corner_ground(c, q[k].s, &q[k]); /* dry: its own ground */
        nwet += wet[k];
    }
    /* Waterline points on the four edges, where they exist. */
    corner_t e[4];
    int has[4];
    for (int k = 0; k < 4; ++k) {
        const int k1 = (k + 1) & 3;
        has[k] = wet[k] != wet[k1];
        if (!has[k]) continue;
        double pt[3];
        if (wet[k]) waterline_point(&q[k], &q[k1], b[k], b[k1], pt);
        else waterline_point(&q[k1], &q[k], b[k1], b[k], pt);
        corner_ground(c, pt, &e[k]);
    }
    /* Fig. 3: wet corners on one diagonal. Their water connects across the cell when the
     * waterline points each would make along that diagonal cross (t_a + t_c >= 1). */
    int connect_wet = 1;
    if (nwet == 2 && wet[0] == wet[2]) {
        const int a = wet[0] ? 0 : 1, d = a + 2;
        const double len = hypot(q[d].s[0] - q[a].s[0], q[d].s[1] - q[a].s[1]);
        connect_wet = waterline_t(q[a].s[2], b[a], b[d], len) +
                          waterline_t(q[d].s[2], b[d], b[a], len) >= 1.0;
    }
    int np = 0;
    for (int phase = 1; phase >= 0; --phase) { /* wet polygons, then dry */
        const int connected = nwet == 2 && wet[0] == wet[2] ? (phase ? connect_wet : !connect_wet) : 1;
        if (connected) { /* one polygon: this phase's corners and every waterline point */
            poly_t *p = &polys[np];
            p->n = 0;
            p->wet = phase;
            for (int k = 0; k < 4; ++k) {
                if (wet[k] == phase) p->v[p->n++] = q[k];
                if (has[k]) p->v[p->n++] = e[k];
            }
            if (p->n >= 3) ++np;
        } else { /* each corner of this phase with its two waterline points */
            for (int k = 0; k < 4; ++k) {
                if (wet[k] != phase) continue;
                poly_t *p = &polys[np++];
                p->wet = phase;
                p->n = 3;
                p->v[0] = e[(k + 3) & 3];
                p->v[1] = q[k];
                p->v[2] = e[k];
            }
        }
    }
    return np;
}

/* Weight of triangle t (0 or 1) of cell `cell` in pass g, channel ch. */
#define TRIW(c, g, cell, t, ch) ((c)->triw[g][((size_t)(cell) * 2 + (t)) * (size_t)(c)->nch + (ch)])

/* triangle() for one pass of one weight under a sun, with the corners read in place from the
 * vertex arrays (no corner copies): the regular cells of a one-index map. The same operations
 * in the same order, so the same bytes. Returns 0 (and writes nothing) when the image is
 * degenerate: the caller then takes the general path. */
static inline int fast_triangle(const hbk_caustics_ctx_t *c, int wet, int32_t ka, int32_t la,
                                int32_t kb, int32_t lb, int32_t kd, int32_t ld, float *w,
                                double st[3])
{
    const size_t va = (size_t)la * (size_t)c->nvx + (size_t)ka;
    const size_t vb = (size_t)lb * (size_t)c->nvx + (size_t)kb;
    const size_t vd = (size_t)ld * (size_t)c->nvx + (size_t)kd;
    const double as[3] = {c->vxs[ka], c->vys[la], c->vz[va]};
    const double e1[3] = {c->vxs[kb] - as[0], c->vys[lb] - as[1], c->vz[vb] - as[2]};
    const double e2[3] = {c->vxs[kd] - as[0], c->vys[ld] - as[1], c->vz[vd] - as[2]};
    const double n2[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                          e1[0] * e2[1] - e1[1] * e2[0]};
    const double proj2 = n2[0] * c->L[0] + n2[1] * c->L[1] + n2[2] * c->L[2];
    if (!(proj2 > 0.0)) {
        *w = 0.0f;
        return 1;
    }
    double T = 1.0;
    if (wet && c->p->fresnel) {
        const double len = sqrt(n2[0] * n2[0] + n2[1] * n2[1] + n2[2] * n2[2]);
        T = hbk_caustics_fresnel_t(proj2 / len, c->ior[0]);
    }
    const double through = 0.5 * proj2 * T * 1.0;
    const double *px = c->ipx[0], *py = c->ipy[0];
    const float *hz = c->ihz[0];
    const double f1[3] = {(px[vb] - px[va]) * c->inv_sx, (py[vb] - py[va]) * c->inv_sy,
                          (double)hz[vb] - (double)hz[va]};
    const double f2[3] = {(px[vd] - px[va]) * c->inv_sx, (py[vd] - py[va]) * c->inv_sy,
                          (double)hz[vd] - (double)hz[va]};
    const double m2[3] = {f1[1] * f2[2] - f1[2] * f2[1], f1[2] * f2[0] - f1[0] * f2[2],
                          f1[0] * f2[1] - f1[1] * f2[0]};
    const double s2 = f1[2] == 0.0 && f2[2] == 0.0
                          ? fabs(m2[2]) : sqrt(m2[0] * m2[0] + m2[1] * m2[1] + m2[2] * m2[2]);
    if (!(0.5 * fabs(m2[2]) * c->sx * c->sy >= HBK_CAUSTICS_TINY_PX2)) return 0; /* a splat */
    const float *at = c->iatt[0];
    const double att = wet ? (at[va] + at[vb] + at[vd]) / 3.0 : 1.0;
    const double P = c->Ew[0] * through * att;
    if (wet) {
        st[0] += c->Ew[0] * through;
        st[1] += c->Ew[0] * through * (1.0 - att);
    } else {
        st[2] += P;
    }
    *w = (float)(P / (0.5 * s2) * (m2[2] > 0.0 ? 1.0 : -1.0));
    return 1;
}

/* Processes cell (i, j): regular cells write their two triangle weights; shoreline cells and
 * degenerate images produce loose triangles, written to `loose` when it is not NULL. Returns
 * the number of loose triangles. */
static int cell(hbk_caustics_ctx_t *c, int32_t i, int32_t j, hbk_loose_tri_t *loose,
                double *stats)
{
    const size_t ci = (size_t)j * (size_t)c->ncx + (size_t)i;
    const size_t v00 = (size_t)j * (size_t)c->nvx + (size_t)i, v01 = v00 + (size_t)c->nvx;
    const int w0 = c->vwet[v00], mixed = w0 != c->vwet[v00 + 1] || w0 != c->vwet[v01] ||
                                         w0 != c->vwet[v01 + 1];
    int nl = 0;
    if (!mixed && !w0 && !c->p->lit_dry) {
        for (int g = 0; g < c->ng; ++g)
            for (int t = 0; t < 2; ++t)
                for (int ch = 0; ch < c->nch; ++ch) TRIW(c, g, ci, t, ch) = 0.0f;
        return 0;
    }
    if (!mixed && c->ng == 1 && c->nch == 1 && !c->point) {
        /* T0 = (00, 10, 11), T1 = (00, 11, 01); the stats are committed only when both are
         * regular (else the general path below redoes the cell). */
        double st[3] = {stats[0], stats[3], stats[6]};
        float w0f, w1f;
        if (fast_triangle(c, w0, i, j, i + 1, j, i + 1, j + 1, &w0f, st) &&
            fast_triangle(c, w0, i, j, i + 1, j + 1, i, j + 1, &w1f, st)) {
            TRIW(c, 0, ci, 0, 0) = w0f;
            TRIW(c, 0, ci, 1, 0) = w1f;
            stats[0] = st[0]; /* added in triangle()'s order: T0's, then T1's */
            stats[3] = st[1];
            stats[6] = st[2];
            return 0;
        }
    }
    if (!mixed) {
        corner_t q[4];
        corner_vertex(c, i, j, &q[0]);
        corner_vertex(c, i + 1, j, &q[1]);
        corner_vertex(c, i + 1, j + 1, &q[2]);
        corner_vertex(c, i, j + 1, &q[3]);
        const corner_t *tri[2][3] = {{&q[0], &q[1], &q[2]}, {&q[0], &q[2], &q[3]}};
        for (int t = 0; t < 2; ++t) {
            tri_out_t o[3];
            int splat = 0;
            for (int g = 0; g < c->ng; ++g) {
                triangle(c, g, w0, tri[t][0], tri[t][1], tri[t][2], &o[g], stats);
                splat |= o[g].splat;
                for (int ch = 0; ch < c->nch; ++ch)
                    TRIW(c, g, ci, t, ch) = o[g].splat ? 0.0f : o[g].w[ch];
            }
            if (!splat) continue;
            if (loose) {
                hbk_loose_tri_t *lt = &loose[nl];
                memset(lt, 0, sizeof *lt);
                for (int g = 0; g < c->ng; ++g) {
                    if (!o[g].splat) continue;
                    for (int k = 0; k < 3; ++k) {
                        lt->px[g][k] = tri[t][k]->px[g];
                        lt->py[g][k] = tri[t][k]->py[g];
                    }
                    for (int ch = 0; ch < c->nch; ++ch) lt->w[g][ch] = o[g].w[ch];
                    lt->splat[g] = 1;
                    lt->used[g] = 1;
                }
            }
            ++nl;
        }
        return nl;
    }
    for (int g = 0; g < c->ng; ++g)
        for (int t = 0; t < 2; ++t)
            for (int ch = 0; ch < c->nch; ++ch) TRIW(c, g, ci, t, ch) = 0.0f;
    poly_t polys[3];
    const int np = shoreline_cell(c, i, j, polys);
    for (int pi = 0; pi < np; ++pi) {
        const poly_t *p = &polys[pi];
        if (!p->wet && !c->p->lit_dry) continue;
        for (int k = 1; k + 1 < p->n; ++k) { /* fan: the polygons are convex */
            hbk_loose_tri_t *lt = loose ? &loose[nl] : NULL;
            if (lt) memset(lt, 0, sizeof *lt);
            for (int g = 0; g < c->ng; ++g) {
                tri_out_t o;
                triangle(c, g, p->wet, &p->v[0], &p->v[k], &p->v[k + 1], &o, stats);
                if (!lt) continue;
                const corner_t *tv[3] = {&p->v[0], &p->v[k], &p->v[k + 1]};
                for (int m = 0; m < 3; ++m) {
                    lt->px[g][m] = tv[m]->px[g];
                    lt->py[g][m] = tv[m]->py[g];
                }
                for (int ch = 0; ch < c->nch; ++ch) {
                    lt->w[g][ch] = o.w[ch];
                    lt->used[g] |= o.w[ch] != 0.0f;
                }
                lt->splat[g] = (uint8_t)o.splat;
            }
            ++nl;
        }
    }
    return nl;
}

enum { CB = 128 };

/* fast_triangle for a block of up to CB cells of row j from column i0, in loops without
 * branches, calls or copies, whose cells the CPU overlaps (GCC 12 does not vectorise them: its
 * if-conversion stops at the selects). The same operations, so the same bytes. Writes both
 * weights of every cell whose triangles are regular and sets done[q]; the stats are added
 * after, in cell order, as cell() adds them. */
__attribute__((target_clones("avx2", "default"), optimize("no-trapping-math"))) static void
fast_cells(const hbk_caustics_ctx_t *c, int32_t j, int32_t i0, int32_t n, uint8_t *done,
           float *w, double *add)
{
    const size_t a0 = (size_t)j * (size_t)c->nvx + (size_t)i0, u0 = a0 + (size_t)c->nvx;
    const double *vx = c->vxs + i0, y0 = c->vys[j], y1 = c->vys[j + 1];
    const float *za = c->vz + a0, *zu = c->vz + u0;
    const double *pxa = c->ipx[0] + a0, *pxu = c->ipx[0] + u0;
    const double *pya = c->ipy[0] + a0, *pyu = c->ipy[0] + u0;
    const float *ha = c->ihz[0] + a0, *hu = c->ihz[0] + u0;
    const float *ta = c->iatt[0] + a0, *tu = c->iatt[0] + u0;
    const double L0 = c->L[0], L1 = c->L[1], L2 = c->L[2], E = c->Ew[0];
    const double isx = c->inv_sx, isy = c->inv_sy, area = c->sx * c->sy;
    for (int t = 0; t < 2; ++t) {
        /* T0 = (00, 10, 11), T1 = (00, 11, 01): corner b is (q + 1) of this row (T0) or the
         * row above (T1), corner d is (q + dq) of the row above: chosen here, not per cell. */
        const int32_t dq = t ? 0 : 1;
        const float *zb = t ? zu : za, *hb = t ? hu : ha, *tb = t ? tu : ta;
        const double *pxb = t ? pxu : pxa, *pyb = t ? pyu : pya;
        const double by = t ? y1 : y0;
#pragma omp simd
        for (int32_t q = 0; q < n; ++q) {
            const double ax = vx[q], az = za[q];
            const double bx = vx[q + 1], bz = zb[q + 1];
            const double dx = vx[q + dq], dz = zu[q + dq];
            const double e1[3] = {bx - ax, by - y0, bz - az};
            const double e2[3] = {dx - ax, y1 - y0, dz - az};
            const double n2[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                                  e1[0] * e2[1] - e1[1] * e2[0]};
            const double proj2 = n2[0] * L0 + n2[1] * L1 + n2[2] * L2;
            const double through = 0.5 * proj2 * 1.0 * 1.0;
            const double bpx = pxb[q + 1], dpx = pxu[q + dq];
            const double bpy = pyb[q + 1], dpy = pyu[q + dq];
            const float bh = hb[q + 1], dh = hu[q + dq];
            const double f1[3] = {(bpx - pxa[q]) * isx, (bpy - pya[q]) * isy,
                                  (double)bh - (double)ha[q]};
            const double f2[3] = {(dpx - pxa[q]) * isx, (dpy - pya[q]) * isy,
                                  (double)dh - (double)ha[q]};
            const double m2[3] = {f1[1] * f2[2] - f1[2] * f2[1], f1[2] * f2[0] - f1[0] * f2[2],
                                  f1[0] * f2[1] - f1[1] * f2[0]};
            const double flat = fabs(m2[2]);
            /* = flat when f1, f2 have no z (m2 then has no x or y, and sqrt(x^2) = |x|) */
            const double s2 = sqrt(m2[0] * m2[0] + m2[1] * m2[1] + m2[2] * m2[2]);
            const int lit = proj2 > 0.0, big = 0.5 * flat * area >= HBK_CAUSTICS_TINY_PX2;
            const float bt = tb[q + 1], dt = tu[q + dq];
            const double att = (ta[q] + bt + dt) / 3.0;
            const double Et = E * through, P = Et * att, lost = Et * (1.0 - att);
            const float wv = (float)(P / (0.5 * s2) * (m2[2] > 0.0 ? 1.0 : -1.0));
            /* Every value computed, then selected: no branch, so the loop vectorises. */
            w[2 * q + t] = lit & big ? wv : 0.0f;
            done[q] = (uint8_t)((t ? done[q] : 1) & ((!lit) | big));
            add[6 * q + 3 * t] = lit ? Et : 0.0;
            add[6 * q + 3 * t + 1] = lit ? lost : 0.0;
            add[6 * q + 3 * t + 2] = lit ? P : 0.0;
        }
    }
}

hbk_result_t hbk_caustics_build_triangles(hbk_caustics_ctx_t *c)
{
    const size_t ncells = (size_t)c->ncx * (size_t)c->ncy;
    for (int g = 0; g < c->ng; ++g)
        if (!(c->triw[g] = hbk_cs_get(c->ws, CS_TRIW + g,
                                      ncells * 2 * (size_t)c->nch * sizeof *c->triw[g], 0)))
            return HBK_ERR_OUT_OF_MEMORY;
    size_t *row_loose =
        hbk_cs_get(c->ws, CS_ROW_LOOSE, ((size_t)c->ncy + 1) * sizeof *row_loose, 1);
    uint8_t *cell_loose = hbk_cs_get(c->ws, CS_CELL_LOOSE, ncells, 0);
    c->row_stats = hbk_cs_get(c->ws, CS_ROW_STATS, (size_t)c->ncy * 9 * sizeof *c->row_stats, 1);
    hbk_result_t r = HBK_OK;
    if (!row_loose || !cell_loose || !c->row_stats) {
        r = HBK_ERR_OUT_OF_MEMORY;
        goto done;
    }
    /* Pass 1 writes the regular weights and counts loose triangles per cell; pass 2 fills them
     * in at fixed offsets, so their order (and the bytes) never depend on the threads. */
    const int block = c->ng == 1 && c->nch == 1 && !c->point && !c->p->fresnel;
#pragma omp parallel for num_threads(c->threads) schedule(dynamic, 4)
    for (int32_t j = 0; j < c->ncy; ++j) {
        size_t n = 0;
        if (hbk_cancelled(c->progress)) continue; /* the caller sees it after the stage */
        double *stats = c->row_stats + 9 * (size_t)j;
        if (block) {
            for (int32_t i0 = 0; i0 < c->ncx; i0 += CB) {
                const int32_t m = c->ncx - i0 < CB ? c->ncx - i0 : CB;
                uint8_t done[CB];
                float w[2 * CB];
                double add[6 * CB];
                fast_cells(c, j, i0, m, done, w, add);
                for (int32_t q = 0; q < m; ++q) {
                    const int32_t i = i0 + q;
                    const size_t ci = (size_t)j * (size_t)c->ncx + (size_t)i;
                    const size_t v00 = (size_t)j * (size_t)c->nvx + (size_t)i,
                                 v01 = v00 + (size_t)c->nvx;
                    const uint8_t w0 = c->vwet[v00];
                    const int regular = w0 == c->vwet[v00 + 1] && w0 == c->vwet[v01] &&
                                        w0 == c->vwet[v01 + 1] && (w0 || c->p->lit_dry);
                    if (!regular || !done[q]) { /* shorelines, dark dry cells, splats */
                        const int k = cell(c, i, j, NULL, stats);
                        cell_loose[ci] = (uint8_t)k;
                        n += (size_t)k;
                        continue;
                    }
                    c->triw[0][ci * 2] = w[2 * q];
                    c->triw[0][ci * 2 + 1] = w[2 * q + 1];
                    for (int t = 0; t < 2; ++t) { /* cell()'s order: T0's, then T1's */
                        if (w0) {
                            stats[0] += add[6 * q + 3 * t];
                            stats[3] += add[6 * q + 3 * t + 1];
                        } else {
                            stats[6] += add[6 * q + 3 * t + 2];
                        }
                    }
                    cell_loose[ci] = 0;
                }
            }
            row_loose[j + 1] = n;
            continue;
        }
        for (int32_t i = 0; i < c->ncx; ++i) {
            const int k = cell(c, i, j, NULL, stats);
            cell_loose[(size_t)j * (size_t)c->ncx + (size_t)i] = (uint8_t)k;
            n += (size_t)k;
        }
        row_loose[j + 1] = n;
    }
    for (int32_t j = 0; j < c->ncy; ++j) row_loose[j + 1] += row_loose[j];
    c->nloose = row_loose[c->ncy];
    if (!c->nloose) goto done;
    if (!(c->loose = hbk_cs_get(c->ws, CS_LOOSE, c->nloose * sizeof *c->loose, 0))) {
        r = HBK_ERR_OUT_OF_MEMORY;
        goto done;
    }
#pragma omp parallel for num_threads(c->threads) schedule(dynamic, 4)
    for (int32_t j = 0; j < c->ncy; ++j) {
        if (row_loose[j + 1] == row_loose[j]) continue;
        double unused[9];
        size_t at = row_loose[j];
        for (int32_t i = 0; i < c->ncx; ++i)
            if (cell_loose[(size_t)j * (size_t)c->ncx + (size_t)i])
                at += (size_t)cell(c, i, j, c->loose + at, unused);
    }
done:
    return r;
}
