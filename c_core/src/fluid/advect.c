/* Semi-Lagrangian advection of V_c (both uvw fields), V_r, the base blend and the paint by V_m
 * (paper: "offset V_c, V_b and V_r by V_m"). Back-traces use the midpoint rule, which is exact
 * for uniform flow; out-of-box sources take the border values (inflow repeats the edge). */
#include "internal_fluid.h"
#include <omp.h>
#include <string.h>

/* Back-traces by the midpoint rule from the point x (voxel units) where the flow is v0, in two
 * halves: the midpoint (l), then the source from the flow there (l again). The rows below run
 * each half over many points before the next: one point's halves are a chain of dependent
 * loads, and many points' chains then overlap. */
static inline void trace_mid(const hbk_fluid_t *h, const float x[3], float dt, const float v0[3],
                             hbk_fluid_lerp_t *l)
{
    float mid[3];
    for (int a = 0; a < 3; ++a) mid[a] = x[a] - 0.5f * dt * v0[a] * h->inv_cell[a];
    hbk_fluid_lerp_at(h, mid, l);
}

static inline void trace_src(const hbk_fluid_t *h, const float *motion, const size_t off[8],
                             const float x[3], float dt, hbk_fluid_lerp_t *l, float src[3])
{
    float vm[3];
    hbk_fluid_sample3_o(motion, off, l, vm);
    for (int a = 0; a < 3; ++a) src[a] = x[a] - dt * vm[a] * h->inv_cell[a];
    hbk_fluid_lerp_at(h, src, l);
}

/* The AVX2 path: the two uvw fields (or the base blend and the paint) of a corner side by side
 * in one 8-float vector, A in lanes 0-3 and B in 4-7, so one set of operations samples both.
 * Each lane's operations are the 4-float samplers', so the bytes are theirs. */
typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));

__attribute__((target("avx2"))) static inline __attribute__((always_inline)) void
corners_pair(const float *a, const float *b, size_t ch, const size_t off[8],
             const hbk_fluid_lerp_t *l, v8f c[8])
{
    HBK_UNROLL8 for (int k = 0; k < 8; ++k) {
        hbk_v4f va, vb;
        memcpy(&va, a + ch * (l->base + off[k]), sizeof va);
        memcpy(&vb, b + ch * (l->base + off[k]), sizeof vb);
        c[k] = __builtin_shufflevector(va, vb, 0, 1, 2, 3, 4, 5, 6, 7);
    }
}

__attribute__((target("avx2"))) static inline __attribute__((always_inline)) void
tri_pair(const v8f c[8], const float t[3], v8f *r)
{
    const v8f a = c[0] + t[0] * (c[1] - c[0]), b = c[2] + t[0] * (c[3] - c[2]);
    const v8f d = c[4] + t[0] * (c[5] - c[4]), e = c[6] + t[0] * (c[7] - c[6]);
    const v8f f = a + t[1] * (b - a), g = d + t[1] * (e - d);
    *r = f + t[2] * (g - f);
}

/* hbk_fluid_sample_wrapped3_o of both fields. */
__attribute__((target("avx2"))) static inline __attribute__((always_inline)) void
sample_wrapped_pair(const float *ua, const float *ub, uint8_t fa, uint8_t fb,
                    const size_t off[8], const hbk_fluid_lerp_t *l, float *oa, float *ob)
{
    const v8i m = {-(fa & 1), -(fa >> 1 & 1), -(fa >> 2 & 1), 0,
                   -(fb & 1), -(fb >> 1 & 1), -(fb >> 2 & 1), 0};
    const v8f zero = {0}, half = zero + 0.5f, one = zero + 1.0f;
    v8f c[8], r;
    corners_pair(ua, ub, 3, off, l, c);
    HBK_UNROLL8 for (int k = 0; k < 8; ++k) {
        const v8i up = m & (c[k] < half);
        c[k] = (v8f)(((v8i)(c[k] + one) & up) | ((v8i)c[k] & ~up));
    }
    tri_pair(c, l->t, &r);
    const v8i over = m & (r >= one);
    r = (v8f)(((v8i)(r - one) & over) | ((v8i)r & ~over));
    const v8i bad = m & ~((r >= zero) & (r < one));
    r = (v8f)((v8i)r & ~bad);
    for (int q = 0; q < 3; ++q) {
        oa[q] = r[q];
        ob[q] = r[4 + q];
    }
}

/* hbk_fluid_repair_masks of both fields: A's in bits 0-2, B's in bits 4-6. */
__attribute__((target("avx2"))) static inline __attribute__((always_inline)) void
masks_pair(const float *ua, const float *ub, const size_t off[8], size_t b, unsigned *d,
           unsigned *x)
{
    const v8f half = {0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f}, one = half + half;
    const hbk_fluid_lerp_t l = {b, 0, {0, 0, 0}};
    v8f c[8], lo = one + one, hi = -one, wlo = lo, whi = hi;
    corners_pair(ua, ub, 3, off, &l, c);
    HBK_UNROLL8 for (int k = 0; k < 8; ++k) {
        const v8f w = c[k] + (v8f)((v8i)one & (c[k] < half));
        lo = __builtin_ia32_minps256(c[k], lo);
        hi = __builtin_ia32_maxps256(c[k], hi);
        wlo = __builtin_ia32_minps256(w, wlo);
        whi = __builtin_ia32_maxps256(w, whi);
    }
    *d = (unsigned)__builtin_ia32_movmskps256((v8f)(hi - lo <= half)) & 0x77u;
    *x = (unsigned)__builtin_ia32_movmskps256((v8f)(whi - wlo < half)) & 0x77u & ~*d;
}

/* Row r's paint and life are known +0 in both buffers: a still row has none to copy. */
static inline int both_unpainted(const hbk_fluid_vols_t *in, const hbk_fluid_vols_t *out, size_t r)
{
    return in->unpainted[r] && out->unpainted[r];
}

/* The per-vertex samples of the moving vertices of row (j, k), and the plain copies of the
 * still ones; UVW samples both uvw fields, BP the base blend and the paint. Each step of the
 * back-trace, then each field's samples, runs over the whole row before the next (see
 * trace_mid): short loops keep more vertices' loads in flight. The moving vertices'
 * displacements (source - vertex, voxel units) go to h->disp for V_r. */
#define STILL_ROW                                                                            \
    const size_t row = (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);                    \
    const size_t jk = (size_t)j + (size_t)ny * (size_t)k;                                    \
    if (h->g_fz[jk]) { /* V_m all +0 */                                                      \
        memset(h->moving + row, 0, (size_t)nx);                                              \
        if (!h->same_rows[jk]) {                                                             \
            copy_still(h, in, out, row, paint);                                              \
            h->rows_hot[jk] = 0xff; /* same again, but perhaps not one-hot */                \
        }                                                                                    \
        else if (paint && !both_unpainted(in, out, jk))                                      \
            /* the life fades in both buffers: not part of "same" */                         \
            memcpy(out->life + row, in->life + row, (size_t)nx * sizeof(float));             \
        h->same_rows[jk] = 1;                                                                \
        return;                                                                              \
    }                                                                                        \
    h->same_rows[jk] = 0;

#define ADVECT_ROW(UVW, BP)                                                                  \
    STILL_ROW                                                                                \
    hbk_fluid_lerp_t ls[257]; /* resolution <= 256 */                                        \
    int32_t at[257], nmov = 0;                                                               \
    for (int32_t i = 0; i < nx; ++i) {                                                       \
        const size_t vi = row + (size_t)i;                                                   \
        const float *v0 = m + 3 * vi;                                                        \
        const float x[3] = {(float)i, (float)j, (float)k};                                   \
        if ((i & 3) == 0) { /* the rows ahead that the next samples will read */             \
            const size_t sy = (size_t)nx, sz = (size_t)nx * (size_t)ny, ahead = vi + 16;     \
            for (int q = 0; q < 2; ++q) {                                                    \
                const size_t p = ahead + sy + (q ? sz : 0);                                  \
                if (p >= h->n_vert) break;                                                   \
                __builtin_prefetch(in->uvw[0] + 3 * p);                                      \
                __builtin_prefetch(in->uvw[1] + 3 * p);                                      \
                __builtin_prefetch(m + 3 * p);                                               \
                __builtin_prefetch(in->base + (size_t)K * p);                                \
                if (paint) __builtin_prefetch(in->paint + (size_t)K * p);                    \
                if (paint) __builtin_prefetch(in->life + p);                                 \
            }                                                                                \
        }                                                                                    \
        const int still = v0[0] == 0.0f && v0[1] == 0.0f && v0[2] == 0.0f;                  \
        h->moving[vi] = (uint8_t)!still;                                                     \
        if (still) continue; /* copied with its run, below */                                \
        trace_mid(h, x, dt, v0, &ls[nmov]);                                                  \
        at[nmov++] = i;                                                                      \
    }                                                                                        \
    for (int32_t q = 0; q < nmov; ++q) {                                                     \
        const float x[3] = {(float)at[q], (float)j, (float)k};                               \
        float src[3];                                                                        \
        trace_src(h, m, off, x, dt, &ls[q], src);                                            \
        float *d = h->disp + 3 * (row + (size_t)at[q]);                                      \
        for (int a = 0; a < 3; ++a) d[a] = src[a] - x[a];                                    \
    }                                                                                        \
    for (int32_t q = 0; q < nmov; ++q) {                                                     \
        const hbk_fluid_lerp_t l = ls[q];                                                    \
        const size_t vi = row + (size_t)at[q];                                               \
        UVW;                                                                                 \
    }                                                                                        \
    for (int32_t q = 0; q < nmov; ++q) {                                                     \
        const hbk_fluid_lerp_t l = ls[q];                                                    \
        const size_t vi = row + (size_t)at[q];                                               \
        float *b = out->base + (size_t)K * vi;                                               \
        BP;                                                                                  \
    }                                                                                        \
    for (int32_t q = 0; q < nmov; ++q) {                                                     \
        float *b = out->base + (size_t)K * (row + (size_t)at[q]);                            \
        /* Interpolation is a convex combination; renormalise only the rounding. */          \
        float s = 0.0f;                                                                      \
        for (int t = 0; t < K; ++t) s += b[t];                                               \
        if (s > 0.0f) for (int t = 0; t < K; ++t) b[t] /= s;                                 \
        else { for (int t = 0; t < K; ++t) b[t] = 0.0f; b[h->p.default_texture] = 1.0f; }    \
    }                                                                                        \
    for (int32_t q = 0; paint && q < nmov; ++q) {                                            \
        const size_t vi = row + (size_t)at[q];                                               \
        hbk_fluid_sample_n_o(in->life, 1, off, &ls[q], out->life + vi);                      \
    }                                                                                        \
    copy_still(h, in, out, row, paint);

/* Still vertices: a plain copy, so zero flow changes nothing bit for bit; a run at a time. */
static void copy_still(const hbk_fluid_t *h, const hbk_fluid_vols_t *in, hbk_fluid_vols_t *out,
                       size_t row, int paint)
{
    /* out's flag is rewritten after the row */
    paint = paint && !both_unpainted(in, out, row / (size_t)h->nv[0]);
    const int32_t nx = h->nv[0];
    for (int32_t i = 0; i < nx;) {
        if (h->moving[row + (size_t)i]) {
            ++i;
            continue;
        }
        int32_t e = i + 1;
        while (e < nx && !h->moving[row + (size_t)e]) ++e;
        const size_t s = row + (size_t)i, n = (size_t)(e - i), kk = (size_t)h->K;
        memcpy(out->uvw[0] + 3 * s, in->uvw[0] + 3 * s, 3 * n * sizeof(float));
        memcpy(out->uvw[1] + 3 * s, in->uvw[1] + 3 * s, 3 * n * sizeof(float));
        memcpy(out->base + kk * s, in->base + kk * s, kk * n * sizeof(float));
        if (paint) {
            memcpy(out->paint + kk * s, in->paint + kk * s, kk * n * sizeof(float));
            memcpy(out->life + s, in->life + s, n * sizeof(float));
        }
        i = e;
    }
}

#define ROW_ARGS                                                                             \
    const hbk_fluid_t *h, const hbk_fluid_vols_t *in, hbk_fluid_vols_t *out,                 \
        const size_t off[8], float dt, int32_t j, int32_t k
#define ROW_SETUP                                                                            \
    const int32_t nx = h->nv[0], ny = h->nv[1], K = h->K;                                    \
    const float *m = h->motion;                                                              \
    const int paint = h->paint_active;

static void advect_row(ROW_ARGS)
{
    ROW_SETUP
    ADVECT_ROW((hbk_fluid_sample_wrapped3_o(in->uvw[0], in->wrap[0], off, &l, out->uvw[0] + 3 * vi),
                hbk_fluid_sample_wrapped3_o(in->uvw[1], in->wrap[1], off, &l, out->uvw[1] + 3 * vi)),
               (hbk_fluid_sample_n_o(in->base, K, off, &l, b),
                paint ? hbk_fluid_sample_n_o(in->paint, K, off, &l, out->paint + (size_t)K * vi)
                      : (void)0))
}

/* The base blend and the paint side by side when K <= 4 (one vector each). */
__attribute__((target("avx2"))) static inline __attribute__((always_inline)) void
sample_bp(const hbk_fluid_vols_t *in, int K, int paint, const size_t off[8],
          const hbk_fluid_lerp_t *l, float *b, float *p)
{
    if (!paint || K > 4) {
        hbk_fluid_sample_n_o(in->base, K, off, l, b);
        if (paint) hbk_fluid_sample_n_o(in->paint, K, off, l, p);
        return;
    }
    v8f c[8], r;
    corners_pair(in->base, in->paint, (size_t)K, off, l, c);
    tri_pair(c, l->t, &r);
    for (int q = 0; q < K; ++q) {
        b[q] = r[q];
        p[q] = r[4 + q];
    }
}

__attribute__((target("avx2"))) static inline __attribute__((always_inline)) void
advect_row_avx2_body(ROW_ARGS)
{
    ROW_SETUP
    ADVECT_ROW(sample_wrapped_pair(in->uvw[0], in->uvw[1], in->wrap[0][l.voxel],
                                   in->wrap[1][l.voxel], off, &l, out->uvw[0] + 3 * vi,
                                   out->uvw[1] + 3 * vi),
               sample_bp(in, K, paint, off, &l, b, out->paint + (size_t)K * vi))
}

__attribute__((target("avx2"))) static void advect_row_avx2(ROW_ARGS)
{
    advect_row_avx2_body(h, in, out, off, dt, j, k);
    __builtin_ia32_vzeroupper(); /* the caller is SSE code */
}

/* The AVX-512 path: sixteen vertices at a time (advect_lanes.c). */
static void advect_row_lanes(ROW_ARGS)
{
    const int32_t nx = h->nv[0], ny = h->nv[1];
    const int paint = h->paint_active;
    STILL_ROW
    hbk_fluid_advect_row16(h, in, out, off, dt, j, k);
    copy_still(h, in, out, row, paint);
}

/* The voxel a moving voxel's centre came from: the centre plus the mean of its corners'
 * displacements (the back-trace map, trilinear, at the centre: exact for uniform and for
 * linear flow). b is its corner 0, (i, j, k) its voxel. */
size_t hbk_fluid_traced_from(const hbk_fluid_t *h, const size_t off[8], size_t b, int32_t i,
                             int32_t j, int32_t k)
{
    float d[3] = {0.0f, 0.0f, 0.0f};
    for (int c = 0; c < 8; ++c) {
        if (!h->moving[b + off[c]]) continue; /* displacement 0 */
        const float *dc = h->disp + 3 * (b + off[c]);
        d[0] += dc[0];
        d[1] += dc[1];
        d[2] += dc[2];
    }
    const float x[3] = {(float)i + 0.5f + 0.125f * d[0], (float)j + 0.5f + 0.125f * d[1],
                        (float)k + 0.5f + 0.125f * d[2]};
    hbk_fluid_lerp_t l;
    hbk_fluid_lerp_at(h, x, &l);
    return l.voxel;
}

/* V_r of the voxels of row (j, k) of voxels. A voxel with a moving corner is repaired from
 * its new corners (MASKS sets d0, x0 and d1, x1 of the two fields); only components that
 * both ways leave undecided take the flag of the voxel its centre came from (traced_from).
 * That is seldom (3% of the moving voxels of a 128³ dam break), so the trace is made only
 * then. */
#define FLAGS_PROLOGUE                                                                       \
    const int32_t nx = h->nv[0], ny = h->nv[1];                                              \
    const int32_t rx = h->p.resolution[0], ry = h->p.resolution[1];                          \
    /* Which vertices of the row's four vertex rows move, per column: a voxel moves if its  \
     * two columns do. A still row copies its flags whole. */                                \
    const size_t b0 = (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);                     \
    const size_t v0i = (size_t)rx * ((size_t)j + (size_t)ry * (size_t)k);                    \
    uint8_t col[257], rowany = 0; /* resolution <= 256 */                                    \
    for (int32_t i = 0; i < nx; ++i) {                                                       \
        col[i] = h->moving[b0 + off[0] + (size_t)i] | h->moving[b0 + off[2] + (size_t)i] |   \
                 h->moving[b0 + off[4] + (size_t)i] | h->moving[b0 + off[6] + (size_t)i];    \
        rowany |= col[i];                                                                    \
    }                                                                                        \
    const size_t vjk = (size_t)j + (size_t)ry * (size_t)k;                                   \
    if (!rowany && checked) {                                                                \
        if (!h->same_vox[vjk]) {                                                             \
            memcpy(out->wrap[0] + v0i, in->wrap[0] + v0i, (size_t)rx);                       \
            memcpy(out->wrap[1] + v0i, in->wrap[1] + v0i, (size_t)rx);                       \
        }                                                                                    \
        h->same_vox[vjk] = 1;                                                                \
        return;                                                                              \
    }                                                                                        \
    h->same_vox[vjk] = 0;

#define FLAGS_ROW(MASKS)                                                                     \
    FLAGS_PROLOGUE                                                                           \
    for (int32_t i = 0; i < rx; ++i) {                                                       \
        const size_t vox = v0i + (size_t)i, b = b0 + (size_t)i;                              \
        const int mv = col[i] | col[i + 1];                                                  \
        if (!mv && checked) {                                                                \
            out->wrap[0][vox] = in->wrap[0][vox];                                            \
            out->wrap[1][vox] = in->wrap[1][vox];                                            \
            continue;                                                                        \
        }                                                                                    \
        unsigned d0, x0, d1, x1;                                                             \
        MASKS;                                                                               \
        size_t from = vox;                                                                   \
        if (mv && ((d0 | x0) & (d1 | x1) & 7u) != 7u)                                        \
            from = hbk_fluid_traced_from(h, off, b, i, j, k);                                \
        out->wrap[0][vox] = hbk_fluid_repair_apply(in->wrap[0][from], d0, x0);               \
        out->wrap[1][vox] = hbk_fluid_repair_apply(in->wrap[1][from], d1, x1);               \
    }

#define FLAGS_ARGS ROW_ARGS, int checked

/* The AVX-512 path: sixteen voxels at a time (advect_flags16.c). */
static void flags_row_lanes(FLAGS_ARGS)
{
    FLAGS_PROLOGUE
    hbk_fluid_flags_row16(h, in, out, off, j, k, b0, v0i, col, checked);
}

static void flags_row(FLAGS_ARGS)
{
    FLAGS_ROW((hbk_fluid_repair_masks(out->uvw[0], off, b, &d0, &x0),
               hbk_fluid_repair_masks(out->uvw[1], off, b, &d1, &x1)))
}

__attribute__((target("avx2"))) static void flags_row_avx2_body(FLAGS_ARGS)
{
    FLAGS_ROW((masks_pair(out->uvw[0], out->uvw[1], off, b, &d0, &x0),
               d1 = d0 >> 4, x1 = x0 >> 4, d0 &= 7u, x0 &= 7u))
}

__attribute__((target("avx2"))) static void flags_row_avx2(FLAGS_ARGS)
{
    flags_row_avx2_body(h, in, out, off, dt, j, k, checked);
    __builtin_ia32_vzeroupper(); /* the caller is SSE code */
}

void hbk_fluid_advect(hbk_fluid_t *h, float dt, int threads)
{
    const hbk_fluid_vols_t *in = &h->v;
    hbk_fluid_vols_t *out = &h->scratch;
    size_t off[8]; /* a voxel's corners from its vertex (i, j, k) */
    hbk_fluid_corners(h, off);
    const int avx2 = hbk_paths() >= HBK_PATHS_AVX2, lanes16 = hbk_fluid_lanes16_ok();
    const int paint = h->paint_active;
    const size_t nx = (size_t)h->nv[0], K = (size_t)h->K;
    void (*row_fn)(ROW_ARGS) = lanes16 ? advect_row_lanes : avx2 ? advect_row_avx2 : advect_row;
    const int32_t ny = h->nv[1], nz = h->nv[2];
    hbk_fluid_rules_t rules;
    hbk_fluid_rules_compile(h, &rules);
    h->rules_matched = rules.n > 0; /* the features pass just matched them */
/* Slabs to whichever thread is free: the work is where the fluid is (each row writes only
 * its own outputs, so the bytes do not depend on who runs it). */
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j) {
            row_fn(h, in, out, off, dt, j, k);
            const size_t r = (size_t)j + (size_t)ny * (size_t)k;
            /* The rules (matched by the features pass) while the row's base is in cache: a
             * pass of their own read it and the features back from memory (4-7 ms of a 128^3
             * frame on two cores). */
            if (rules.n) hbk_fluid_rules_row(h, &rules, out->base, h->g_features, r);
            /* Which rows hold no paint, for the sixteen-lane path to skip sampling them: a
             * still row copied a known one, the sixteen-lane path knows it left a clean one
             * (2), else the row is looked at while in cache. */
            if (paint)
                out->unpainted[r] = out->unpainted[r] == 2 || (h->g_fz[r] && in->unpainted[r]) ||
                                    (hbk_fluid_all_zero(out->life + nx * r, nx) &&
                                     hbk_fluid_all_zero(out->paint + K * nx * r, K * nx));
        }
    /* V_r: the flag of the voxel the centre came from (binary, so nearest), then repaired from
     * the new corners where the short way is unambiguous. A voxel whose corners all stand
     * still keeps its flag: its centre traces back to itself, and its corners' uvw are the
     * ones its flags were repaired from last frame (but the first frame after create or
     * load_state repairs every voxel). */
    const int32_t ry = h->p.resolution[1], rz = h->p.resolution[2];
    const int checked = h->wrap_checked;
    void (*flags_fn)(FLAGS_ARGS) = lanes16 ? flags_row_lanes : avx2 ? flags_row_avx2 : flags_row;
/* Slabs to whichever thread is free: the work is where the fluid is (each row writes only
 * its own outputs, so the bytes do not depend on who runs it). */
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (int32_t k = 0; k < rz; ++k)
        for (int32_t j = 0; j < ry; ++j)
            flags_fn(h, in, out, off, dt, j, k, checked);
    h->wrap_checked = 1;
    h->rules_matched = 0;
}
