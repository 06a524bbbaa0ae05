/* Light paths: surface normals, refraction, Fresnel, and rays marched to the ground. */
#include "internal_caustics.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>

static inline int32_t wrap(int32_t i, int32_t n)
{
    if (i >= -n && i < 2 * n) return i < 0 ? i + n : i >= n ? i - n : i; /* no division */
    i %= n;
    return i < 0 ? i + n : i;
}

/* Sample index along an axis of n samples: wrapped or clamped. */
static inline int32_t sidx(const hbk_caustics_ctx_t *c, int32_t i, int32_t n)
{
    if (c->periodic) return (i >= 0 && i < n) ? i : wrap(i, n);
    return i < 0 ? 0 : i >= n ? n - 1 : i;
}

/* floor for |x| < 2^62, inline (libm's floor is a call without SSE4.1). */
static inline double ffloor(double x)
{
    const double t = (double)(int64_t)x;
    return t > x ? t - 1.0 : t;
}

static inline float gs(const hbk_caustics_ctx_t *c, int32_t i, int32_t j)
{
    return c->ground[(size_t)sidx(c, j, c->H) * c->ground_stride + (size_t)sidx(c, i, c->W)];
}

/* Wet samples, from the mask setup_ground made. */
static inline int wet_at(const hbk_caustics_ctx_t *c, int32_t i, int32_t j)
{
    return c->swet[(size_t)j * (size_t)c->W + (size_t)i];
}

int hbk_caustics_wet(const hbk_caustics_ctx_t *c, int32_t i, int32_t j) { return wet_at(c, i, j); }

static inline __attribute__((always_inline)) double
ground_bilinear(const hbk_caustics_ctx_t *c, double u, double v)
{
    const double fu = ffloor(u), fv = ffloor(v);
    const int32_t i = (int32_t)fu, j = (int32_t)fv;
    const double a = u - fu, b = v - fv;
    const double g00 = gs(c, i, j), g10 = gs(c, i + 1, j), g01 = gs(c, i, j + 1),
                 g11 = gs(c, i + 1, j + 1);
    return (g00 + a * (g10 - g00)) * (1.0 - b) + (g01 + a * (g11 - g01)) * b;
}

double hbk_caustics_ground_at(const hbk_caustics_ctx_t *c, double u, double v)
{
    return ground_bilinear(c, u, v);
}

static inline __attribute__((always_inline)) void
normal_at(const hbk_caustics_ctx_t *c, int32_t i, int32_t j, double n[3])
{
    /* Central differences over wet neighbours only: a dry neighbour's "surface" is its ground,
     * which says nothing about the water's slope. */
    double slope[2];
    const float h0 = c->water[(size_t)j * c->water_stride + (size_t)i];
    for (int axis = 0; axis < 2; ++axis) {
        double hv[2];
        int have[2];
        for (int s = 0; s < 2; ++s) {
            int32_t ii = i + (axis == 0 ? (s ? 1 : -1) : 0), jj = j + (axis == 1 ? (s ? 1 : -1) : 0);
            if (c->periodic) { /* one step out at most: no division */
                ii = ii < 0 ? ii + c->W : ii >= c->W ? ii - c->W : ii;
                jj = jj < 0 ? jj + c->H : jj >= c->H ? jj - c->H : jj;
            }
            have[s] = ii >= 0 && jj >= 0 && ii < c->W && jj < c->H && wet_at(c, ii, jj);
            hv[s] = have[s] ? c->water[(size_t)jj * c->water_stride + (size_t)ii] : 0.0;
        }
        slope[axis] = have[0] && have[1] ? (hv[1] - hv[0]) * (0.5 * c->inv_dx)
                    : have[1]            ? (hv[1] - h0) * c->inv_dx
                    : have[0]            ? (h0 - hv[0]) * c->inv_dx
                                         : 0.0;
    }
    const double inv = 1.0 / sqrt(slope[0] * slope[0] + slope[1] * slope[1] + 1.0);
    n[0] = -slope[0] * inv;
    n[1] = -slope[1] * inv;
    n[2] = inv;
}

void hbk_caustics_normal(const hbk_caustics_ctx_t *c, int32_t i, int32_t j, double n[3])
{
    normal_at(c, i, j, n);
}

static inline __attribute__((always_inline)) void
refract_dir(const double l[3], const double n[3], double eta, double r[3])
{
    static const double up[3] = {0.0, 0.0, 1.0};
    double cos_i = l[0] * n[0] + l[1] * n[1] + l[2] * n[2];
    if (cos_i <= 1e-6) { /* light from behind the local tangent plane: refract at the mean level */
        n = up;
        cos_i = l[2];
    }
    const double k = 1.0 - eta * eta * (1.0 - cos_i * cos_i); /* > 0: air into water */
    const double f = eta * cos_i - sqrt(k);
    for (int a = 0; a < 3; ++a) r[a] = -eta * l[a] + f * n[a];
    if (r[2] > -HBK_CAUSTICS_MIN_DOWN) {
        const double hl = sqrt(r[0] * r[0] + r[1] * r[1]);
        const double keep = sqrt(1.0 - HBK_CAUSTICS_MIN_DOWN * HBK_CAUSTICS_MIN_DOWN);
        r[0] = hl > 0.0 ? r[0] / hl * keep : 0.0;
        r[1] = hl > 0.0 ? r[1] / hl * keep : 0.0;
        r[2] = -HBK_CAUSTICS_MIN_DOWN;
    }
}

void hbk_caustics_refract(const double l[3], const double n[3], double eta, double r[3])
{
    refract_dir(l, n, eta, r);
}

double hbk_caustics_fresnel_t(double cos_i, double ior)
{
    if (cos_i <= 0.0) return 0.0;
    if (cos_i > 1.0) cos_i = 1.0;
    const double sin_t2 = (1.0 - cos_i * cos_i) / (ior * ior);
    const double cos_t = sqrt(1.0 - sin_t2);
    const double rs = (cos_i - ior * cos_t) / (cos_i + ior * cos_t);
    const double rp = (ior * cos_i - cos_t) / (ior * cos_i + cos_t);
    return 1.0 - 0.5 * (rs * rs + rp * rp);
}

hbk_result_t hbk_caustics_setup_ground(hbk_caustics_ctx_t *c)
{
    /* Bilinear cells span neighbouring samples; the periodic grid has one more (the wrap). */
    c->ncu = c->periodic ? c->W : c->W - 1;
    c->ncv = c->periodic ? c->H : c->H - 1;
    c->nbu = (c->ncu + 7) / 8;
    c->nbv = (c->ncv + 7) / 8;
    c->bmax = hbk_cs_get(c->ws, CS_BMAX, (size_t)c->nbu * (size_t)c->nbv * sizeof *c->bmax, 0);
    if (!c->bmax) return HBK_ERR_OUT_OF_MEMORY;
    float gmax = -INFINITY, gmin = INFINITY;
    for (int32_t bv = 0; bv < c->nbv; ++bv)
        for (int32_t bu = 0; bu < c->nbu; ++bu) {
            float m = -INFINITY;
            const int32_t i1 = 8 * bu + 8 < c->ncu ? 8 * bu + 8 : c->ncu;
            const int32_t j1 = 8 * bv + 8 < c->ncv ? 8 * bv + 8 : c->ncv;
            for (int32_t j = 8 * bv; j <= j1; ++j)
                for (int32_t i = 8 * bu; i <= i1; ++i) {
                    const float g = gs(c, i, j);
                    m = g > m ? g : m; /* heights are finite (checked): no fmaxf call */
                }
            c->bmax[(size_t)bv * (size_t)c->nbu + (size_t)bu] = m;
            gmax = m > gmax ? m : gmax;
        }
    /* Which samples are wet: read by every normal (four neighbours each) and vertex. */
    c->swet = hbk_cs_get(c->ws, CS_SWET, (size_t)c->W * (size_t)c->H, 0);
    if (!c->swet) return HBK_ERR_OUT_OF_MEMORY;
    for (int32_t j = 0; j < c->H; ++j)
        for (int32_t i = 0; i < c->W; ++i) {
            const float g = c->ground[(size_t)j * c->ground_stride + (size_t)i];
            const float h = c->water[(size_t)j * c->water_stride + (size_t)i];
            gmin = g < gmin ? g : gmin;
            c->swet[(size_t)j * (size_t)c->W + (size_t)i] = (double)h - (double)g > c->wet_depth;
        }
    c->gmax = gmax;
    c->gflat = gmin == gmax;
    return HBK_OK;
}

/* Cell index of coordinate x for a ray moving with dx: on a boundary, the cell it enters. */
static inline int32_t cell_of(double x, double d)
{
    double f = ffloor(x);
    if (x == f && d < 0.0) f -= 1.0;
    return (int32_t)f;
}

/* Smallest s in [0, T] where the ray, at local position (a0, b0) in bilinear cell (i, j) with
 * height z0, meets the ground; -1 if it does not within the cell. */
static double cell_hit(const hbk_caustics_ctx_t *c, int32_t i, int32_t j, double a0, double b0,
                       double z0, double du, double dv, double dz, double T)
{
    const double g00 = gs(c, i, j), g10 = gs(c, i + 1, j), g01 = gs(c, i, j + 1),
                 g11 = gs(c, i + 1, j + 1);
    const double gx = g10 - g00, gy = g01 - g00, gxy = g11 - g10 - g01 + g00;
    /* f(s) = z(s) - ground(s) = f0 + f1 s + f2 s^2 along the segment. */
    const double f0 = z0 - (g00 + a0 * gx + b0 * gy + a0 * b0 * gxy);
    if (f0 <= 0.0) return 0.0;
    const double f1 = dz - (du * (gx + b0 * gxy) + dv * (gy + a0 * gxy));
    const double f2 = -du * dv * gxy;
    if (fabs(f2) * (T < 1e30 ? T : 1e30) <= 1e-12 * fabs(f1)) {
        if (f1 >= 0.0) return -1.0;
        const double s = -f0 / f1;
        return s <= T ? s : -1.0;
    }
    const double disc = f1 * f1 - 4.0 * f2 * f0;
    if (disc < 0.0) return -1.0;
    const double q = -0.5 * (f1 + (f1 >= 0.0 ? sqrt(disc) : -sqrt(disc)));
    double best = -1.0;
    const double r1 = q / f2, r2 = q != 0.0 ? f0 / q : -1.0;
    if (r1 > 0.0 && r1 <= T) best = r1;
    if (r2 > 0.0 && r2 <= T && (best < 0.0 || r2 < best)) best = r2;
    return best;
}

/* Where the ray reaches a horizontal plane at the ground height under its position at t. */
static double plane_hit(const hbk_caustics_ctx_t *c, double u0, double v0, double z0, double du,
                        double dv, double dz, double t)
{
    const double z = z0 + t * dz, g = ground_bilinear(c, u0 + t * du, v0 + t * dv);
    return z > g ? t + (z - g) / -dz : t;
}

double hbk_caustics_march(const hbk_caustics_ctx_t *c, const double o[3], const double r[3])
{
    const double inv = c->inv_dx;
    const double u0 = o[0] * inv - 0.5, v0 = o[1] * inv - 0.5, z0 = o[2];
    const double du = r[0] * inv, dv = r[1] * inv, dz = r[2];
    double t = 0.0;
    if (c->gflat) return z0 > c->gmax ? (z0 - c->gmax) / -dz : 0.0; /* a flat floor: a plane */
    if (z0 > c->gmax) { /* nothing to hit above the highest ground */
        t = (z0 - c->gmax) / -dz;
        if (c->gmax <= ground_bilinear(c, u0 + t * du, v0 + t * dv)) return t; /* flat floors */
    } else if (z0 <= ground_bilinear(c, u0, v0)) {
        return 0.0;
    }
    const int32_t su = du > 0.0 ? 1 : -1, sv = dv > 0.0 ? 1 : -1;
    const double tdu = du != 0.0 ? fabs(1.0 / du) : INFINITY, tdv = dv != 0.0 ? fabs(1.0 / dv) : INFINITY;
    int32_t blo_u = INT32_MIN, blo_v = INT32_MIN; /* lower corner of the block last tested */
    int32_t steps = 0;
    const int32_t max_steps = 4 * (c->W + c->H) + 64;
    while (steps < max_steps) {
        const double u = u0 + t * du, v = v0 + t * dv;
        int32_t iu = cell_of(u, du), iv = cell_of(v, dv);
        double tmu = du > 0.0 ? (iu + 1 - u0) / du : du < 0.0 ? (iu - u0) / du : INFINITY;
        double tmv = dv > 0.0 ? (iv + 1 - v0) / dv : dv < 0.0 ? (iv - v0) / dv : INFINITY;
        int restart = 0;
        for (; steps < max_steps && !restart; ++steps) {
            int inside = 1;
            if (!c->periodic) {
                const int out_u = iu < 0 || iu > c->W - 2, out_v = iv < 0 || iv > c->H - 2;
                /* Beyond the field the ground is the clamped edge; leaving it for good, take the
                 * plane under the ray (exact for the clamped extension when it is flat). */
                if ((iu < 0 && du <= 0.0) || (iu > c->W - 2 && du >= 0.0) ||
                    (iv < 0 && dv <= 0.0) || (iv > c->H - 2 && dv >= 0.0))
                    return plane_hit(c, u0, v0, z0, du, dv, dz, t);
                inside = !out_u && !out_v;
            }
            if (inside) { /* skip whole blocks of 8 x 8 cells the ray passes above */
                const int32_t lu = c->periodic ? wrap(iu, c->ncu) : iu;
                const int32_t lv = c->periodic ? wrap(iv, c->ncv) : iv;
                const int32_t bu = lu >> 3, bv = lv >> 3;
                const int32_t lo_u = iu - (lu - 8 * bu), lo_v = iv - (lv - 8 * bv);
                if (lo_u != blo_u || lo_v != blo_v) {
                    blo_u = lo_u;
                    blo_v = lo_v;
                    const int32_t hi_u = lo_u + (c->ncu - 8 * bu < 8 ? c->ncu - 8 * bu : 8);
                    const int32_t hi_v = lo_v + (c->ncv - 8 * bv < 8 ? c->ncv - 8 * bv : 8);
                    const double tbu = du > 0.0 ? (hi_u - u0) / du : du < 0.0 ? (lo_u - u0) / du : INFINITY;
                    const double tbv = dv > 0.0 ? (hi_v - v0) / dv : dv < 0.0 ? (lo_v - v0) / dv : INFINITY;
                    const double tb = tbu < tbv ? tbu : tbv;
                    const double bm = c->bmax[(size_t)bv * (size_t)c->nbu + (size_t)bu];
                    if (tb < INFINITY && z0 + tb * dz > bm) {
                        t = tb;
                        restart = 1;
                        continue;
                    }
                    if (z0 + t * dz > bm) {
                        t = (z0 - bm) / -dz;
                        restart = 1;
                        continue;
                    }
                }
            }
            const double te = tmu < tmv ? tmu : tmv;
            const double s = cell_hit(c, iu, iv, u0 + t * du - iu, v0 + t * dv - iv, z0 + t * dz,
                                      du, dv, dz, te - t);
            if (s >= 0.0) return t + s;
            t = te;
            if (tmu < tmv) {
                iu += su;
                tmu += tdu;
            } else {
                iv += sv;
                tmv += tdv;
            }
        }
    }
    return plane_hit(c, u0, v0, z0, du, dv, dz, t);
}

hbk_result_t hbk_caustics_setup_mesh(hbk_caustics_ctx_t *c)
{
    const int32_t W = c->W, H = c->H;
    /* Periodic: one vertex per sample plus the wrap; else a border vertex on each edge so the
     * mesh covers the whole field, [0, W dx] x [0, H dx]. */
    c->nvx = c->periodic ? W + 1 : W + 2;
    c->nvy = c->periodic ? H + 1 : H + 2;
    c->ncx = c->nvx - 1;
    c->ncy = c->nvy - 1;
    const size_t nv = (size_t)c->nvx * (size_t)c->nvy;
    c->vxs = hbk_cs_get(c->ws, CS_VXS, (size_t)c->nvx * sizeof *c->vxs, 0);
    c->vys = hbk_cs_get(c->ws, CS_VYS, (size_t)c->nvy * sizeof *c->vys, 0);
    c->vsi = hbk_cs_get(c->ws, CS_VSI, (size_t)c->nvx * sizeof *c->vsi, 0);
    c->vsj = hbk_cs_get(c->ws, CS_VSJ, (size_t)c->nvy * sizeof *c->vsj, 0);
    c->vz = hbk_cs_get(c->ws, CS_VZ, nv * sizeof *c->vz, 0);
    c->vb = hbk_cs_get(c->ws, CS_VB, nv * sizeof *c->vb, 0);
    c->vwet = hbk_cs_get(c->ws, CS_VWET, nv, 0);
    if (!c->vxs || !c->vys || !c->vsi || !c->vsj || !c->vz || !c->vb || !c->vwet)
        return HBK_ERR_OUT_OF_MEMORY;
    for (int axis = 0; axis < 2; ++axis) {
        const int32_t n = axis ? H : W, nv_axis = axis ? c->nvy : c->nvx;
        double *pos = axis ? c->vys : c->vxs;
        int32_t *si = axis ? c->vsj : c->vsi;
        for (int32_t k = 0; k < nv_axis; ++k) {
            if (c->periodic) {
                pos[k] = (k + 0.5) * c->dx;
                si[k] = k % n;
            } else {
                pos[k] = k == 0 ? 0.0 : k == n + 1 ? n * c->dx : (k - 0.5) * c->dx;
                si[k] = k == 0 ? 0 : k == n + 1 ? n - 1 : k - 1;
            }
        }
    }
    for (int32_t l = 0; l < c->nvy; ++l)
        for (int32_t k = 0; k < c->nvx; ++k) {
            const size_t v = (size_t)l * (size_t)c->nvx + (size_t)k;
            const int32_t i = c->vsi[k], j = c->vsj[l];
            const int wet = hbk_caustics_wet(c, i, j);
            c->vwet[v] = (uint8_t)wet;
            c->vb[v] = c->ground[(size_t)j * c->ground_stride + (size_t)i];
            c->vz[v] = wet ? c->water[(size_t)j * c->water_stride + (size_t)i] : c->vb[v];
        }
    for (int g = 0; g < c->ng; ++g) {
        c->ipx[g] = hbk_cs_get(c->ws, CS_IPX + g, nv * sizeof *c->ipx[g], 0);
        c->ipy[g] = hbk_cs_get(c->ws, CS_IPY + g, nv * sizeof *c->ipy[g], 0);
        c->ihz[g] = hbk_cs_get(c->ws, CS_IHZ + g, nv * sizeof *c->ihz[g], 0);
        c->iatt[g] = hbk_cs_get(c->ws, CS_IATT + g, nv * (size_t)c->nch * sizeof *c->iatt[g], 0);
        if (!c->ipx[g] || !c->ipy[g] || !c->ihz[g] || !c->iatt[g]) return HBK_ERR_OUT_OF_MEMORY;
    }
    return HBK_OK;
}

/* Traces vertex (k, l): its image per pass, ground z and attenuation. */
static void trace_vertex(hbk_caustics_ctx_t *c, int32_t k, int32_t l)
{
    const size_t v = (size_t)l * (size_t)c->nvx + (size_t)k;
    const double s[3] = {c->vxs[k], c->vys[l], c->vz[v]};
    double n[3], L[3];
    if (c->vwet[v]) {
        normal_at(c, c->vsi[k], c->vsj[l], n);
        if (c->point) {
            double len = 0.0;
            for (int a = 0; a < 3; ++a) len += (c->lpos[a] - s[a]) * (c->lpos[a] - s[a]);
            len = sqrt(len);
            for (int a = 0; a < 3; ++a) L[a] = (c->lpos[a] - s[a]) / len;
        } else {
            for (int a = 0; a < 3; ++a) L[a] = c->L[a];
        }
    }
    for (int g = 0; g < c->ng; ++g) {
        double hit[3] = {s[0], s[1], c->vb[v]}, t = 0.0;
        if (c->vwet[v]) {
            double r[3];
            refract_dir(L, n, c->eta[g], r);
            t = hbk_caustics_march(c, s, r);
            for (int a = 0; a < 3; ++a) hit[a] = s[a] + t * r[a];
        }
        c->ipx[g][v] = (hit[0] - c->ex0) * c->sx;
        c->ipy[g][v] = (hit[1] - c->ey0) * c->sy;
        c->ihz[g][v] = (float)hit[2];
        for (int ch = 0; ch < c->nch; ++ch)
            c->iatt[g][v * (size_t)c->nch + (size_t)ch] =
                c->absorb ? (float)exp(-c->sigma[g][ch] * t) : 1.0f;
    }
}

enum { TB = 128 };

/* Under a sun over a flat floor, open water takes the same path at every vertex: a block of
 * up to TB vertices of row l from column k0 is traced in loops without branches or calls,
 * which the compiler vectorises (an AVX2 clone where the CPU has it). Each lane does
 * trace_vertex's operations in the same order (no FMA), so the bytes are the same; vertices
 * off that path (dry, a dry or missing neighbour, a ray too flat) go through trace_vertex. */
__attribute__((target_clones("avx2", "default"))) static void
trace_block(hbk_caustics_ctx_t *c, int32_t l, int32_t k0, int32_t n)
{
    double hl[TB], hr[TB], hd[TB], hu[TB], z0[TB], x[TB], n0[TB], n1[TB], n2[TB];
    double px[TB], py[TB], hz[TB], tt[TB];
    uint8_t ok[TB], steep[TB];
    const int32_t W = c->W, H = c->H, j = c->vsj[l];
    const int32_t jd = c->periodic ? (j == 0 ? H - 1 : j - 1) : j - 1;
    const int32_t ju = c->periodic ? (j == H - 1 ? 0 : j + 1) : j + 1;
    const int rows_in = jd >= 0 && ju < H;
    const float *wat = c->water;
    const size_t ws = c->water_stride;
    for (int32_t q = 0; q < n; ++q) {
        const int32_t k = k0 + q, i = c->vsi[k];
        const size_t v = (size_t)l * (size_t)c->nvx + (size_t)k;
        const int32_t il = c->periodic ? (i == 0 ? W - 1 : i - 1) : i - 1;
        const int32_t ir = c->periodic ? (i == W - 1 ? 0 : i + 1) : i + 1;
        int good = c->vwet[v] && rows_in && il >= 0 && ir < W &&
                   (c->periodic || (k >= 1 && k <= W)); /* not a border vertex */
        good = good && c->swet[(size_t)j * (size_t)W + (size_t)il] &&
               c->swet[(size_t)j * (size_t)W + (size_t)ir] &&
               c->swet[(size_t)jd * (size_t)W + (size_t)i] &&
               c->swet[(size_t)ju * (size_t)W + (size_t)i];
        ok[q] = (uint8_t)good;
        hl[q] = good ? wat[(size_t)j * ws + (size_t)il] : 0.0f;
        hr[q] = good ? wat[(size_t)j * ws + (size_t)ir] : 0.0f;
        hd[q] = good ? wat[(size_t)jd * ws + (size_t)i] : 0.0f;
        hu[q] = good ? wat[(size_t)ju * ws + (size_t)i] : 0.0f;
        z0[q] = c->vz[v];
        x[q] = c->vxs[k];
    }
    const double hx = 0.5 * c->inv_dx, L0 = c->L[0], L1 = c->L[1], L2 = c->L[2];
    for (int32_t q = 0; q < n; ++q) { /* normal_at with both neighbours wet on each axis */
        const double s0 = (hr[q] - hl[q]) * hx, s1 = (hu[q] - hd[q]) * hx;
        const double inv = 1.0 / sqrt(s0 * s0 + s1 * s1 + 1.0);
        n0[q] = -s0 * inv;
        n1[q] = -s1 * inv;
        n2[q] = inv;
    }
    const double y = c->vys[l], g = c->gmax;
    for (int gp = 0; gp < c->ng; ++gp) {
        const double eta = c->eta[gp];
        for (int32_t q = 0; q < n; ++q) { /* refract_dir, then the flat floor's plane */
            double cos_i = L0 * n0[q] + L1 * n1[q] + L2 * n2[q];
            const int back = cos_i <= 1e-6;
            const double m0 = back ? 0.0 : n0[q], m1 = back ? 0.0 : n1[q],
                         m2 = back ? 1.0 : n2[q];
            cos_i = back ? L2 : cos_i;
            const double kk = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
            const double f = eta * cos_i - sqrt(kk);
            const double r0 = -eta * L0 + f * m0, r1 = -eta * L1 + f * m1,
                         r2 = -eta * L2 + f * m2;
            steep[q] = !(r2 > -HBK_CAUSTICS_MIN_DOWN);
            const double t = z0[q] > g ? (z0[q] - g) / -r2 : 0.0;
            tt[q] = t;
            px[q] = (x[q] + t * r0 - c->ex0) * c->sx;
            py[q] = (y + t * r1 - c->ey0) * c->sy;
            hz[q] = z0[q] + t * r2;
        }
        const size_t v0 = (size_t)l * (size_t)c->nvx + (size_t)k0;
        for (int32_t q = 0; q < n; ++q) {
            if (!ok[q] || !steep[q]) continue; /* done below */
            c->ipx[gp][v0 + (size_t)q] = px[q];
            c->ipy[gp][v0 + (size_t)q] = py[q];
            c->ihz[gp][v0 + (size_t)q] = (float)hz[q];
            for (int ch = 0; ch < c->nch; ++ch)
                c->iatt[gp][(v0 + (size_t)q) * (size_t)c->nch + (size_t)ch] =
                    c->absorb ? (float)exp(-c->sigma[gp][ch] * tt[q]) : 1.0f;
        }
        for (int32_t q = 0; q < n; ++q) ok[q] = ok[q] && steep[q];
    }
    for (int32_t q = 0; q < n; ++q)
        if (!ok[q]) trace_vertex(c, k0 + q, l);
}

void hbk_caustics_trace_vertices(hbk_caustics_ctx_t *c)
{
    const int32_t nx = c->periodic ? c->W : c->nvx, ny = c->periodic ? c->H : c->nvy;
    const int fast = !c->point && c->gflat;
#pragma omp parallel for num_threads(c->threads) schedule(dynamic, 4)
    for (int32_t l = 0; l < ny; ++l) {
        if (hbk_cancelled(c->progress)) continue; /* the caller sees it after the stage */
        if (fast)
            for (int32_t k = 0; k < nx; k += TB) trace_block(c, l, k, nx - k < TB ? nx - k : TB);
        else
            for (int32_t k = 0; k < nx; ++k) trace_vertex(c, k, l);
    }
    if (!c->periodic) return;
    /* The wrap vertices are their originals one period on. */
    for (int32_t l = 0; l < c->nvy; ++l)
        for (int32_t k = 0; k < c->nvx; ++k) {
            if (k < c->W && l < c->H) continue;
            const size_t v = (size_t)l * (size_t)c->nvx + (size_t)k;
            const size_t o = (size_t)(l % c->H) * (size_t)c->nvx + (size_t)(k % c->W);
            for (int g = 0; g < c->ng; ++g) {
                c->ipx[g][v] = c->ipx[g][o] + (k >= c->W ? c->MW : 0);
                c->ipy[g][v] = c->ipy[g][o] + (l >= c->H ? c->MH : 0);
                c->ihz[g][v] = c->ihz[g][o];
                for (int ch = 0; ch < c->nch; ++ch)
                    c->iatt[g][v * (size_t)c->nch + (size_t)ch] =
                        c->iatt[g][o * (size_t)c->nch + (size_t)ch];
            }
        }
}
