/* Features per vertex (paper §3.2): density, its rate, the angle between flow and surface
 * normal, the acceleration of the flow, and (beyond the paper, as it suggests) divergence and
 * the surface's mean curvature.
 * Rates are finite differences against the previous frame's fields on the same grid, so they
 * work for every source, including particle systems whose particles come and go. */
#include "internal_fluid.h"
#include <omp.h>
#include <stdlib.h>

typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));

/* What the passes share. V_m and the normal are read as three planes (one per axis), so that
 * eight vertices of a row are eight floats in a row for the AVX2 path. */
typedef struct feat {
    const hbk_fluid_t *h;
    const float *mp[3]; /* V_m (g_mp, hbk_fluid_put_motion) */
    float *np[3];       /* the outward unit normal (g_normal) */
    size_t st[3];       /* vertex strides */
    float inv_dt, gmin2;
    int prev;           /* last frame's fields are there (the rates) */
} feat_t;

/* Central difference per metre of plane p along axis a at vertex vi = (i, j, k) (ijk[a] is
 * the coordinate along a); one-sided at the borders. */
static inline float diff(const feat_t *f, const float *p, size_t vi, const int32_t ijk[3], int a)
{
    const int lo = ijk[a] > 0, hi = ijk[a] < f->h->nv[a] - 1;
    const float fl = p[vi - (lo ? f->st[a] : 0)], fh = p[vi + (hi ? f->st[a] : 0)];
    const int span = lo + hi;
    /* / span, as a product: x / 2 and x * 0.5 are the same float (both the exact half,
     * rounded), and a division costs several products */
    return span ? (fh - fl) * f->h->inv_cell[a] * (span == 2 ? 0.5f : 1.0f) : 0.0f;
}

/* The features of vertex (i, j, k) but the curvature, and its normal. */
static void vertex_features(const feat_t *f, int32_t i, int32_t j, int32_t k)
{
    const hbk_fluid_t *h = f->h;
    const int32_t ijk[3] = {i, j, k};
    const size_t vi = (size_t)i + f->st[1] * (size_t)j + f->st[2] * (size_t)k;
    float *o = h->g_features + (size_t)HBK_FLUID_FEATURE_COUNT * vi;
    const float d = h->g_density[vi];
    const float v[3] = {f->mp[0][vi], f->mp[1][vi], f->mp[2][vi]};
    o[HBK_FLUID_FEATURE_DENSITY] = d;
    o[HBK_FLUID_FEATURE_DENSITY_RATE] = f->prev ? (d - h->density[vi]) * f->inv_dt : 0.0f;
    float g[3], gg = 0.0f, vv = 0.0f, gv = 0.0f, div = 0.0f;
    for (int a = 0; a < 3; ++a) {
        g[a] = -diff(f, h->g_density, vi, ijk, a); /* outward */
        gg += g[a] * g[a];
        vv += v[a] * v[a];
        gv += g[a] * v[a];
        div += diff(f, f->mp[a], vi, ijk, a);
    }
    float ang = (float)(0.5 * M_PI);
    if (gg > 0.0f && vv > 0.0f) {
        float cs = gv / sqrtf(gg * vv);
        cs = cs > 1.0f ? 1.0f : cs < -1.0f ? -1.0f : cs;
        ang = hbk_fluid_acos(cs);
    }
    o[HBK_FLUID_FEATURE_FLOW_ANGLE] = ang;
    float acc = 0.0f;
    if (f->prev) {
        const float *pv = h->motion + 3 * vi;
        const float ax = v[0] - pv[0], ay = v[1] - pv[1], az = v[2] - pv[2];
        acc = sqrtf(ax * ax + ay * ay + az * az) * f->inv_dt;
    }
    o[HBK_FLUID_FEATURE_ACCELERATION] = acc;
    o[HBK_FLUID_FEATURE_DIVERGENCE] = div;
    /* The outward unit normal, where the density changes enough to have one: a uniform
     * interior's tiny gradients would point anywhere. */
    const int has = gg > f->gmin2;
    const float inv = has ? 1.0f / sqrtf(gg) : 0.0f;
    for (int a = 0; a < 3; ++a) f->np[a][vi] = g[a] * inv;
}

/* Half the divergence of the normal field at vertex (i, j, k): the mean curvature. */
static void vertex_curvature(const feat_t *f, int32_t i, int32_t j, int32_t k)
{
    const int32_t ijk[3] = {i, j, k};
    const size_t vi = (size_t)i + f->st[1] * (size_t)j + f->st[2] * (size_t)k;
    float dn = 0.0f;
    if (f->np[0][vi] != 0.0f || f->np[1][vi] != 0.0f || f->np[2][vi] != 0.0f)
        for (int a = 0; a < 3; ++a) dn += diff(f, f->np[a], vi, ijk, a);
    f->h->g_features[(size_t)HBK_FLUID_FEATURE_COUNT * vi + HBK_FLUID_FEATURE_CURVATURE] = 0.5f * dn;
}

/* The AVX2 path: eight vertices of a row away from every border (each difference central), in
 * lanes, with vertex_features' and vertex_curvature's operations per lane: the same bytes. */
#define L8(p)                                                                                \
    ({                                                                                       \
        v8f v_;                                                                              \
        __builtin_memcpy(&v_, (p), sizeof v_);                                               \
        v_;                                                                                  \
    })
#define SEL8(m, a, b) ((v8f)(((v8i)(a) & (m)) | ((v8i)(b) & ~(m))))

typedef double v4d __attribute__((vector_size(32)));

/* The eight records of six features at o, from the first five in lanes (the sixth, the
 * curvature, is +0 until its pass): the pairs (d, rate), (ang, acc) and (div, 0) of a lane are
 * three 64-bit units, put in record order by permutes, not forty scalar stores. */
__attribute__((target("avx2"))) static inline __attribute__((always_inline)) void
store_records8(float *o, v8f d, v8f rate, v8f ang, v8f acc, v8f div)
{
    const v8f zero = {0};
    /* 64-bit units: A (d, rate), B (ang, acc) and C (div, 0) of lanes 0 1 4 5 (A0, B0, C0)
     * and 2 3 6 7 (A1, B1, C1), as the 128-bit halves hold them */
    const v4d A0 = (v4d)__builtin_shufflevector(d, rate, 0, 8, 1, 9, 4, 12, 5, 13);
    const v4d A1 = (v4d)__builtin_shufflevector(d, rate, 2, 10, 3, 11, 6, 14, 7, 15);
    const v4d B0 = (v4d)__builtin_shufflevector(ang, acc, 0, 8, 1, 9, 4, 12, 5, 13);
    const v4d B1 = (v4d)__builtin_shufflevector(ang, acc, 2, 10, 3, 11, 6, 14, 7, 15);
    const v4d C0 = (v4d)__builtin_shufflevector(div, zero, 0, 8, 1, 9, 4, 12, 5, 13);
    const v4d C1 = (v4d)__builtin_shufflevector(div, zero, 2, 10, 3, 11, 6, 14, 7, 15);
    /* in record order; two of the six are finished below (the same shuffles arranged as six
     * named vectors compiled 1-1.5 ms slower over the pass) */
    const v4d AB0 = __builtin_shufflevector(A0, B0, 0, 4, 1, 5); /* A0 B0 A1 B1 */
    const v4d AB1 = __builtin_shufflevector(A1, B1, 0, 4, 1, 5); /* A2 B2 A3 B3 */
    const v4d AB4 = __builtin_shufflevector(A0, B0, 2, 6, 3, 7); /* A4 B4 A5 B5 */
    const v4d AB6 = __builtin_shufflevector(A1, B1, 2, 6, 3, 7); /* A6 B6 A7 B7 */
    const v4d out[6] = {
        __builtin_shufflevector(AB0, C0, 0, 1, 4, 2),  /* A0 B0 C0 A1 */
        __builtin_shufflevector(AB0, C0, 3, 5, 0, 0),  /* B1 C1 (A2 B2 next) */
        __builtin_shufflevector(AB1, C1, 4, 2, 3, 5),  /* C2 A3 B3 C3 */
        __builtin_shufflevector(AB4, C0, 0, 1, 6, 2),  /* A4 B4 C4 A5 */
        __builtin_shufflevector(AB4, C0, 3, 7, 0, 0),  /* B5 C5 (A6 B6 next) */
        __builtin_shufflevector(AB6, C1, 6, 2, 3, 7),  /* C6 A7 B7 C7 */
    };
    v4d o1 = out[1], o4 = out[4];
    o1 = __builtin_shufflevector(o1, AB1, 0, 1, 4, 5); /* B1 C1 A2 B2 */
    o4 = __builtin_shufflevector(o4, AB6, 0, 1, 4, 5); /* B5 C5 A6 B6 */
    __builtin_memcpy(o, &out[0], 32);
    __builtin_memcpy(o + 8, &o1, 32);
    __builtin_memcpy(o + 16, &out[2], 32);
    __builtin_memcpy(o + 24, &out[3], 32);
    __builtin_memcpy(o + 32, &o4, 32);
    __builtin_memcpy(o + 40, &out[5], 32);
}

__attribute__((target("avx2"))) static void features8(const feat_t *f, size_t vi)
{
    const hbk_fluid_t *h = f->h;
    const v8f zero = {0}, one = zero + 1.0f, half = zero + 0.5f;
    const float *D = h->g_density;
    const v8f d = L8(D + vi);
    const v8f rate = f->prev ? (d - L8(h->density + vi)) * f->inv_dt : zero;
    v8f g[3], v[3], gg = zero, vv = zero, gv = zero, div = zero;
    for (int a = 0; a < 3; ++a) {
        const size_t s = f->st[a];
        const float sc = h->inv_cell[a];
        v[a] = L8(f->mp[a] + vi);
        g[a] = -((L8(D + vi + s) - L8(D + vi - s)) * sc * half);
        gg += g[a] * g[a];
        vv += v[a] * v[a];
        gv += g[a] * v[a];
        div += (L8(f->mp[a] + vi + s) - L8(f->mp[a] + vi - s)) * sc * half;
    }
    /* the flow angle, hbk_fluid_acos in lanes (both of its branches, then the right one) */
    v8f cs = gv / __builtin_ia32_sqrtps256(gg * vv);
    cs = SEL8(cs > one, one, cs);
    cs = SEL8(cs < -one, -one, cs);
    const v8i nosign = (v8i){0} + 0x7fffffff;
    const v8f a = (v8f)((v8i)cs & nosign), twice = zero + 2.0f;
    const v8i wide = a > half;
    const v8f z = SEL8(wide, half * (one - a), a * a);
    const v8f sq = SEL8(wide, __builtin_ia32_sqrtps256(z), a);
    const v8f p = ((((4.2163199048e-2f * z + 2.4181311049e-2f) * z + 4.5470025998e-2f) * z +
                    7.4953002686e-2f) * z + 1.6666752422e-1f) * z * sq + sq;
    const v8i neg = cs < zero;
    const v8f pi = zero + 3.14159265f, pi2 = zero + 1.57079633f;
    const v8f acw = SEL8(neg, pi - twice * p, twice * p), acn = SEL8(neg, pi2 + p, pi2 - p);
    const v8f ang = SEL8((gg > zero) & (vv > zero), SEL8(wide, acw, acn), zero + (float)(0.5 * M_PI));
    v8f acc = zero;
    if (f->prev) {
        /* last frame's V_m, interleaved: three loads and shuffles (a gather is slower) */
        const float *pv = h->motion + 3 * vi;
        const v8f a0 = L8(pv), a1 = L8(pv + 8), a2 = L8(pv + 16);
        const v8f x01 = __builtin_shufflevector(a0, a1, 0, 3, 6, 9, 12, 15, 1, 4);
        const v8f y01 = __builtin_shufflevector(a0, a1, 1, 4, 7, 10, 13, 2, 5, 8);
        const v8f z01 = __builtin_shufflevector(a0, a1, 2, 5, 8, 11, 14, 0, 3, 6);
        const v8f px = __builtin_shufflevector(x01, a2, 0, 1, 2, 3, 4, 5, 10, 13);
        const v8f py = __builtin_shufflevector(y01, a2, 0, 1, 2, 3, 4, 8, 11, 14);
        const v8f pz = __builtin_shufflevector(z01, a2, 0, 1, 2, 3, 4, 9, 12, 15);
        const v8f dv[3] = {v[0] - px, v[1] - py, v[2] - pz};
        acc = __builtin_ia32_sqrtps256(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]) * f->inv_dt;
    }
    const v8f inv = SEL8(gg > f->gmin2, one / __builtin_ia32_sqrtps256(gg), zero);
    for (int q = 0; q < 3; ++q) {
        const v8f n = g[q] * inv;
        __builtin_memcpy(f->np[q] + vi, &n, sizeof n);
    }
    store_records8(h->g_features + (size_t)HBK_FLUID_FEATURE_COUNT * vi, d, rate, ang, acc, div);
    __builtin_ia32_vzeroupper(); /* the caller is SSE code */
}

__attribute__((target("avx2"))) static void curvature8(const feat_t *f, size_t vi)
{
    const v8f zero = {0}, half = zero + 0.5f;
    const v8i has = (L8(f->np[0] + vi) != zero) | (L8(f->np[1] + vi) != zero) |
                    (L8(f->np[2] + vi) != zero);
    v8f dn = zero;
    for (int a = 0; a < 3; ++a)
        dn += (L8(f->np[a] + vi + f->st[a]) - L8(f->np[a] + vi - f->st[a])) *
              f->h->inv_cell[a] * half;
    dn = half * SEL8(has, dn, zero);
    float *o = f->h->g_features + (size_t)HBK_FLUID_FEATURE_COUNT * vi + HBK_FLUID_FEATURE_CURVATURE;
    for (int l = 0; l < 8; ++l) o[(size_t)HBK_FLUID_FEATURE_COUNT * (size_t)l] = dn[l];
    __builtin_ia32_vzeroupper();
}

/* Row (j, k) by PER (vertex_features or vertex_curvature), eight interior vertices at a time
 * by PER8 when avx2 and the row is away from the y and z borders. */
#define ROW(PER, PER8)                                                                       \
    do {                                                                                     \
        const int32_t nx = h->nv[0];                                                         \
        int32_t i = 0;                                                                       \
        if (avx2 && j > 0 && j < h->nv[1] - 1 && k > 0 && k < h->nv[2] - 1) {                \
            PER(&f, 0, j, k);                                                                \
            for (i = 1; i + 8 <= nx - 1; i += 8)                                             \
                PER8(&f, (size_t)i + f.st[1] * (size_t)j + f.st[2] * (size_t)k);             \
            if (i < nx - 1 && nx >= 10) { /* the last eight, again in part: the same values */ \
                i = nx - 9;                                                                  \
                PER8(&f, (size_t)i + f.st[1] * (size_t)j + f.st[2] * (size_t)k);             \
                i = nx - 1;                                                                  \
            }                                                                                \
        }                                                                                    \
        for (; i < nx; ++i) PER(&f, i, j, k);                                                \
    } while (0)

/* Row (j, k) and the rows its differences read (j +- 1, k +- 1) are all zero now, and the row
 * itself last frame too (when there is a last frame). */
static int quiet(const uint8_t *zc, const uint8_t *zp, int prev, int32_t j, int32_t k,
                 int32_t ny, int32_t nz)
{
    const size_t r = (size_t)j + (size_t)ny * (size_t)k;
    if (!zc[r] || (prev && !zp[r])) return 0;
    if (j > 0 && !zc[r - 1]) return 0;
    if (j < ny - 1 && !zc[r + 1]) return 0;
    if (k > 0 && !zc[r - (size_t)ny]) return 0;
    if (k < nz - 1 && !zc[r + (size_t)ny]) return 0;
    return 1;
}

void hbk_fluid_features(hbk_fluid_t *h, int threads)
{
    const int32_t nx = h->nv[0], ny = h->nv[1], nz = h->nv[2];
    const size_t nv = h->n_vert;
    const int F = HBK_FLUID_FEATURE_COUNT;
    /* A gradient counts as a surface's when the density changes by at least 2 % of its scale
     * (the rest density; 1 for a grid source's surface field) over one cell. */
    float cmin = h->cell[0] < h->cell[1] ? h->cell[0] : h->cell[1];
    cmin = cmin < h->cell[2] ? cmin : h->cell[2];
    const float scale = h->p.source == HBK_FLUID_VELOCITY_GRID ? 1.0f : h->p.rest_density;
    const float gmin = 0.02f * scale / cmin;
    const feat_t f = {h,
                      {h->g_mp[0], h->g_mp[1], h->g_mp[2]},
                      {h->g_normal, h->g_normal + nv, h->g_normal + 2 * nv},
                      {1, (size_t)nx, (size_t)nx * (size_t)ny},
                      1.0f / h->p.dt,
                      gmin * gmin,
                      h->have_fields};
    const int avx2 = hbk_paths() >= HBK_PATHS_AVX2;
    /* Rows whose density and velocity are all +0 (bit for bit), now (zc, which the advection
     * then reads) and (zp) last frame: far from the fluid, a vertex's features are then
     * constants (below), computed without it. A row written blank is zero without a look. */
    const size_t rows = h->n_rows;
    uint8_t *zc = h->g_fz, *qr = h->quiet;
    const uint8_t *zp = h->fz;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (size_t r = 0; r < rows; ++r) {
        const size_t v0 = r * (size_t)nx;
        zc[r] = h->g_blank[r] || (hbk_fluid_all_zero(h->g_density + v0, (size_t)nx) &&
                                  hbk_fluid_all_zero(h->g_motion + 3 * v0, 3 * (size_t)nx));
    }
/* Slabs dealt out in turn: the fluid (the work) sits low in the box. */
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j) {
            const size_t r = (size_t)j + (size_t)ny * (size_t)k;
            qr[r] = (uint8_t)quiet(zc, zp, f.prev, j, k, ny, nz);
            if (qr[r]) {
                /* What vertex_features gives for zero fields: a rate and acceleration of +0,
                 * the gradient -0 (so a -0 normal), no flow angle (pi / 2); and then what
                 * vertex_curvature gives for a -0 normal, +0. Rows that hold them already
                 * (from the frame before last) are not written again. */
                const size_t v0 = (size_t)nx * r;
                if (!h->g_fq[r])
                    for (int32_t i = 0; i < nx; ++i) {
                        float *o = h->g_features + (size_t)F * (v0 + (size_t)i);
                        o[HBK_FLUID_FEATURE_DENSITY] = 0.0f;
                        o[HBK_FLUID_FEATURE_DENSITY_RATE] = 0.0f;
                        o[HBK_FLUID_FEATURE_FLOW_ANGLE] = (float)(0.5 * M_PI);
                        o[HBK_FLUID_FEATURE_ACCELERATION] = 0.0f;
                        o[HBK_FLUID_FEATURE_DIVERGENCE] = 0.0f;
                        o[HBK_FLUID_FEATURE_CURVATURE] = 0.0f;
                    }
                for (int32_t i = 0; i < nx; ++i) /* g_normal is the advection's scratch too */
                    for (int a = 0; a < 3; ++a) f.np[a][v0 + (size_t)i] = -0.0f;
                h->g_fq[r] = 1;
                continue;
            }
            h->g_fq[r] = 0;
            ROW(vertex_features, features8);
        }
    /* Mean curvature: half the divergence of that normal field, where it is defined around.
     * Its row complete, the row's features are in cache: the feature rules are matched there
     * (a pass of their own read 52 MB of features back from memory at 128^3). */
    hbk_fluid_rules_t rules;
    hbk_fluid_rules_compile(h, &rules);
/* Slabs dealt out in turn: the fluid (the work) sits low in the box. */
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j) {
            const size_t r = (size_t)j + (size_t)ny * (size_t)k;
            if (qr[r]) continue;
            ROW(vertex_curvature, curvature8);
            if (rules.n)
                hbk_fluid_rules_match_row(h, &rules, h->g_features + (size_t)F * (size_t)nx * r,
                                          (size_t)nx * r);
        }
}
