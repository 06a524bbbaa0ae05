/* The advection's moving vertices sixteen at a time (AVX-512), with the bytes of advect.c.
 *
 * One vertex at a time, the samples took about 700 instructions a moving vertex (callgrind),
 * at about four a cycle. Across sixteen vertices of a row the arithmetic is one vector
 * operation per channel, but each lane's eight corners come from elsewhere, and a gather is
 * slower than the loads it replaces on this kind of CPU. The flow is smooth, though: the
 * sources of sixteen neighbouring vertices mostly lie in one or two rows of the grid (1.7 on
 * average in a 128^3 dam break), within twenty vertices of each other. So the lanes are taken
 * a source row at a time (a "pass"): the four corner rows' windows are loaded whole and each
 * lane's corners picked out by permutes. A pass whose window is too wide takes the plain
 * samplers lane by lane. Each lane's operations are the plain samplers', in the same order
 * and without FMA, so the bytes are theirs (fluid.paths_same_bytes compares them).
 * What it took to be faster than the AVX2 rows, not only in fewer instructions: whole loads
 * rather than masked ones, a field's code compiled for its channel count, and the rows ahead
 * fetched early (docs/fluid_performance.md). */
#include "internal_lanes16.h"

int hbk_fluid_lanes16_ok(void)
{
    return hbk_paths() >= HBK_PATHS_AVX512 && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl") &&
           __builtin_cpu_supports("bmi2");
}

/* hbk_fluid_lerp_at for sixteen points: x index, vertex row (y + ny z) and voxel row. */
typedef struct {
    __m512 t[3];
    __m512i ix, row, vrow;
} lerp16_t;

HBK_L16 static inline void lerp16(const hbk_fluid_t *h, const __m512 x[3], lerp16_t *l)
{
    __m512i i[3];
    for (int a = 0; a < 3; ++a) {
        const int32_t last = h->p.resolution[a] - 1;
        const __m512 top = _mm512_set1_ps((float)(last + 1));
        __m512 xa = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(x[a], _mm512_setzero_ps(), _CMP_GE_OQ),
                                        x[a]); /* also NaN */
        xa = _mm512_mask_mov_ps(xa, _mm512_cmp_ps_mask(xa, top, _CMP_GT_OQ), top);
        i[a] = _mm512_min_epi32(_mm512_cvttps_epi32(xa), _mm512_set1_epi32(last));
        l->t[a] = _mm512_sub_ps(xa, _mm512_cvtepi32_ps(i[a]));
    }
    l->ix = i[0];
    l->row = _mm512_add_epi32(i[1], _mm512_mullo_epi32(i[2], _mm512_set1_epi32(h->nv[1])));
    l->vrow =
        _mm512_add_epi32(i[1], _mm512_mullo_epi32(i[2], _mm512_set1_epi32(h->p.resolution[1])));
}

/* hbk_fluid_tri4's operations. */
HBK_L16 static inline __m512 tri16(const __m512 c[8], const __m512 t[3])
{
#define LERP(p, q, s) _mm512_add_ps(p, _mm512_mul_ps(s, _mm512_sub_ps(q, p)))
    const __m512 a = LERP(c[0], c[1], t[0]), b = LERP(c[2], c[3], t[0]);
    const __m512 d = LERP(c[4], c[5], t[0]), e = LERP(c[6], c[7], t[0]);
    const __m512 f = LERP(a, b, t[1]), g = LERP(d, e, t[1]);
    return LERP(f, g, t[2]);
#undef LERP
}

/* One field of C channels (C * (span + 2) <= HBK_WIN) for the lanes P of a pass: window at vertex
 * v0 of the four corner rows (so = sy, sz), lane offsets idx from v0. flags: the lanes' wrap
 * flags (uvw), or NULL. dst: C vectors, whose lanes P are set. */
HBK_L16 static inline __attribute__((always_inline)) void
field16(const float *f, const float *end, int C, size_t v0, size_t sy, size_t sz, int span,
        __m512i idx, const __m512i *flags, const __m512 t[3], __mmask16 P, __m512 *dst)
{
    const size_t rows[4] = {v0, v0 + sy, v0 + sz, v0 + sy + sz};
    hbk_win_t tab[4];
    const int n = C * (span + 2);
    for (int r = 0; r < 4; ++r) hbk_win_load(&tab[r], f + (size_t)C * rows[r], n, end);
    const __m512i cidx = _mm512_mullo_epi32(idx, _mm512_set1_epi32(C));
    const __m512 zero = _mm512_setzero_ps(), half = _mm512_set1_ps(0.5f),
                 one = _mm512_set1_ps(1.0f);
    for (int c = 0; c < C; ++c) {
        const __m512i i0 = _mm512_add_epi32(cidx, _mm512_set1_epi32(c));
        const __m512i i1 = _mm512_add_epi32(i0, _mm512_set1_epi32(C));
        const __mmask16 h0 = _mm512_test_epi32_mask(i0, _mm512_set1_epi32(32));
        const __mmask16 h1 = _mm512_test_epi32_mask(i1, _mm512_set1_epi32(32));
        __m512 cr[8];
        for (int r = 0; r < 4; ++r) {
            cr[2 * r] = hbk_win_get(&tab[r], i0, h0);
            cr[2 * r + 1] = hbk_win_get(&tab[r], i1, h1);
        }
        if (!flags) {
            dst[c] = tri16(cr, t);
            continue;
        }
        /* hbk_fluid_sample_wrapped3_o: a wrapped component's corners below 0.5 count + 1 */
        const __mmask16 m = _mm512_test_epi32_mask(*flags, _mm512_set1_epi32(1 << c));
        for (int q = 0; q < 8; ++q)
            cr[q] = _mm512_mask_add_ps(cr[q], m & _mm512_cmp_ps_mask(cr[q], half, _CMP_LT_OQ),
                                       cr[q], one);
        __m512 r = tri16(cr, t);
        r = _mm512_mask_sub_ps(r, m & _mm512_cmp_ps_mask(r, one, _CMP_GE_OQ), r, one);
        const __mmask16 ok =
            _mm512_cmp_ps_mask(r, zero, _CMP_GE_OQ) & _mm512_cmp_ps_mask(r, one, _CMP_LT_OQ);
        r = _mm512_mask_mov_ps(r, m & (__mmask16)~ok, zero); /* rounding or NaN: 0 */
        dst[c] = r;
    }
}

/* The lanes' weights, x index and rows in arrays, for the plain samplers. */
typedef struct {
    float t[3][16];
    int32_t ix[16], row[16], vrow[16];
} lerp_lanes_t;

HBK_L16 static void lanes_spill(const lerp16_t *l, lerp_lanes_t *s)
{
    for (int a = 0; a < 3; ++a) _mm512_storeu_ps(s->t[a], l->t[a]);
    _mm512_storeu_si512(s->ix, l->ix);
    _mm512_storeu_si512(s->row, l->row);
    _mm512_storeu_si512(s->vrow, l->vrow);
}

static hbk_fluid_lerp_t lane_lerp(const hbk_fluid_t *h, const lerp_lanes_t *s, int q)
{
    hbk_fluid_lerp_t l;
    l.base = (size_t)s->ix[q] + (size_t)h->nv[0] * (size_t)s->row[q];
    l.voxel = (size_t)s->ix[q] + (size_t)h->p.resolution[0] * (size_t)s->vrow[q];
    for (int a = 0; a < 3; ++a) l.t[a] = s->t[a][q];
    return l;
}

/* A pass: the lanes P of group g whose sources lie in vertex row `row` (voxel row vrow), x
 * indices x0 .. x0 + span. */
typedef struct {
    int32_t x0, span, row, vrow;
    uint16_t P;
    uint8_t g;
} pass_t;

/* Appends the passes of group g's lanes M at l to ps; returns the new count. */
HBK_L16 static inline int split_passes(const lerp16_t *l, __mmask16 M, int g, pass_t *ps, int n)
{
    for (__mmask16 rem = M; rem; ++n) {
        const __m512i q = _mm512_set1_epi32(__builtin_ctz(rem));
        pass_t *p = &ps[n];
        p->row = _mm_cvtsi128_si32(_mm512_castsi512_si128(_mm512_permutexvar_epi32(q, l->row)));
        p->vrow = _mm_cvtsi128_si32(_mm512_castsi512_si128(_mm512_permutexvar_epi32(q, l->vrow)));
        const __mmask16 P = rem & _mm512_cmpeq_epi32_mask(l->row, _mm512_set1_epi32(p->row));
        p->x0 = _mm512_mask_reduce_min_epi32(P, l->ix);
        p->span = _mm512_mask_reduce_max_epi32(P, l->ix) - p->x0;
        p->P = P;
        p->g = (uint8_t)g;
        rem &= (__mmask16)~P;
    }
    return n;
}

/* Lanes P of v from the plain samplers' values (sixteen floats a channel). */
HBK_L16 static inline void merge_lanes(__m512 *v, int C, const float (*tmp)[16], __mmask16 P)
{
    for (int c = 0; c < C; ++c) v[c] = _mm512_mask_loadu_ps(v[c], P, tmp[c]);
}

/* V_m at the midpoints of a pass's lanes, into vm. */
HBK_L16 static inline __attribute__((always_inline)) void motion_pass(const hbk_fluid_t *h,
                                                                      const size_t off[8],
                                                                      const lerp16_t *l,
                                                                      const pass_t *p, __m512 vm[3])
{
    const size_t nx = (size_t)h->nv[0], sy = nx, sz = nx * (size_t)h->nv[1];
    if (3 * (p->span + 2) <= HBK_WIN) {
        const __m512i idx = _mm512_sub_epi32(l->ix, _mm512_set1_epi32(p->x0));
        field16(h->motion, h->motion + 3 * h->n_vert + 4, 3, (size_t)p->x0 + nx * (size_t)p->row,
                sy, sz, p->span, idx, NULL, l->t, p->P, vm);
        return;
    }
    lerp_lanes_t s;
    float tmp[3][16];
    lanes_spill(l, &s);
    for (unsigned b = p->P; b; b &= b - 1) {
        const int q = __builtin_ctz(b);
        const hbk_fluid_lerp_t lq = lane_lerp(h, &s, q);
        float v[3];
        hbk_fluid_sample3_o(h->motion, off, &lq, v);
        for (int a = 0; a < 3; ++a) tmp[a][q] = v[a];
    }
    merge_lanes(vm, 3, tmp, p->P);
}

/* The fields one at a time over all the passes (as advect.c's rows sample one field over the
 * whole row before the next: fewer lines in use at once). */
enum { F_UVW_A, F_UVW_B, F_BASE, F_PAINT, F_LIFE };

/* Field f at the sources of a pass's lanes, into v (C channel vectors, lanes P set). */
HBK_L16 static inline __attribute__((always_inline)) void
field_pass(const hbk_fluid_t *h, const hbk_fluid_vols_t *in, const size_t off[8], const lerp16_t *l,
           const pass_t *p, int f, int C, __m512 *v)
{
    const size_t nx = (size_t)h->nv[0], sy = nx, sz = nx * (size_t)h->nv[1];
    const int K = h->K, wide = K > 3 ? K : 3, span = p->span;
    const __mmask16 P = p->P;
    const float *src = f == F_UVW_A   ? in->uvw[0]
                       : f == F_UVW_B ? in->uvw[1]
                       : f == F_BASE  ? in->base
                       : f == F_PAINT ? in->paint
                                      : in->life;
    if (wide * (span + 2) <= HBK_WIN) {
        const __m512i idx = _mm512_sub_epi32(l->ix, _mm512_set1_epi32(p->x0));
        const size_t v0 = (size_t)p->x0 + nx * (size_t)p->row;
        if (f > F_UVW_B) {
            field16(src, src + (size_t)C * h->n_vert + 4, C, v0, sy, sz, span, idx, NULL, l->t, P,
                    v);
            return;
        }
        /* the lanes' wrap flags: their voxels lie in one voxel row (span < 20) */
        const size_t w0 = (size_t)p->x0 + (size_t)h->p.resolution[0] * (size_t)p->vrow;
        const __m256i b =
            w0 + 32 <= h->n_vox
                ? _mm256_loadu_si256((const __m256i *)(in->wrap[f] + w0))
                : _mm256_maskz_loadu_epi8((__mmask32)_bzhi_u32(~0u, (unsigned)span + 1u),
                                          in->wrap[f] + w0);
        const __m512i fl =
            _mm512_permutex2var_epi32(_mm512_cvtepu8_epi32(_mm256_castsi256_si128(b)), idx,
                                      _mm512_cvtepu8_epi32(_mm256_extracti128_si256(b, 1)));
        field16(src, src + 3 * h->n_vert + 4, 3, v0, sy, sz, span, idx, &fl, l->t, P, v);
        return;
    }
    lerp_lanes_t s;
    float tmp[HBK_FLUID_MAX_TEXTURES][16];
    lanes_spill(l, &s);
    for (unsigned b = P; b; b &= b - 1) {
        const int q = __builtin_ctz(b);
        const hbk_fluid_lerp_t lq = lane_lerp(h, &s, q);
        float r[HBK_FLUID_MAX_TEXTURES];
        if (f <= F_UVW_B)
            hbk_fluid_sample_wrapped3_o(src, in->wrap[f], off, &lq, r);
        else
            hbk_fluid_sample_n_o(src, C, off, &lq, r);
        for (int c = 0; c < C; ++c) tmp[c][q] = r[c];
    }
    merge_lanes(v, C, tmp, P);
}

/* Record float q of sixteen 3-float records is channel q % 3 of lane q / 3: per vector of
 * records, the lane from channels 0 and 1 (index + 16 for channel 1), and which floats come
 * from channel 2. */
static const int32_t rec3_ab[3][16] = {{0, 16, 0, 1, 17, 0, 2, 18, 0, 3, 19, 0, 4, 20, 0, 5},
                                       {21, 0, 6, 22, 0, 7, 23, 0, 8, 24, 0, 9, 25, 0, 10, 26},
                                       {0, 11, 27, 0, 12, 28, 0, 13, 29, 0, 14, 30, 0, 15, 31, 0}};
static const int32_t rec3_c[3][16] = {
    {0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4, 5},
    {5, 5, 6, 6, 6, 7, 7, 7, 8, 8, 8, 9, 9, 9, 10, 10},
    {10, 11, 11, 11, 12, 12, 12, 13, 13, 13, 14, 14, 14, 15, 15, 15}};
static const uint16_t rec3_from_c[3] = {0x4924, 0x2492, 0x9249};

/* Lanes M of C channel vectors into the C-float records at dst (lane 0's). */
HBK_L16 static inline void store_records(float *dst, int C, const __m512 *ch, __mmask16 M)
{
    if (C == 1) {
        _mm512_mask_storeu_ps(dst, M, ch[0]);
        return;
    }
    if (C == 3) {
        const uint64_t m = _pdep_u64(M, 0x249249249249ull) * 7u; /* 3 bits a lane */
        for (int z = 0; z < 3; ++z) {
            __m512 r = _mm512_permutex2var_ps(ch[0], _mm512_loadu_si512(rec3_ab[z]), ch[1]);
            r = _mm512_mask_permutexvar_ps(r, rec3_from_c[z], _mm512_loadu_si512(rec3_c[z]), ch[2]);
            _mm512_mask_storeu_ps(dst + 16 * z, (__mmask16)(m >> (16 * z)), r);
        }
        return;
    }
    float tmp[HBK_FLUID_MAX_TEXTURES][16];
    for (int c = 0; c < C; ++c) _mm512_storeu_ps(tmp[c], ch[c]);
    for (unsigned b = M; b; b &= b - 1) {
        const int q = __builtin_ctz(b);
        for (int c = 0; c < C; ++c) dst[(size_t)C * (size_t)q + (size_t)c] = tmp[c][q];
    }
}

/* Zeros in lanes M of the C-float records at dst (lane 0's), eight lanes at a time: C <= 8
 * floats each, so their floats' mask fits 64 bits. */
HBK_L16 static inline void zero_records(float *dst, int C, __mmask16 M)
{
    static const uint64_t every[HBK_FLUID_MAX_TEXTURES + 1] = {
        0, 0xff, 0x5555, 0x249249, 0x11111111, 0x0842108421ull, 0x041041041041ull,
        0x02040810204081ull, 0x0101010101010101ull}; /* bit C q for lane q < 8 */
    const uint64_t ones = (1ull << C) - 1;
    for (int half = 0; half < 2; ++half) {
        const uint64_t m = _pdep_u64((M >> (8 * half)) & 0xffu, every[C]) * ones;
        float *d = dst + 8 * C * half;
        for (int z = 0; z < C; z += 2) /* 16 floats a store, C * 8 in all */
            _mm512_mask_storeu_ps(d + 8 * z, (__mmask16)(m >> (8 * z)), _mm512_setzero_ps());
    }
}

/* The lines of n floats from f. */
HBK_L16 static inline void prefetch_span(const float *f, size_t n)
{
    const char *a = (const char *)f, *e = (const char *)(f + n);
    for (; a < e; a += 64) __builtin_prefetch(a);
    __builtin_prefetch(e - 1);
}

/* As advect.c's rows: the vertex rows one up and one layer up, a group ahead, of every field
 * the samples read, and the voxel rows of their flags. */
HBK_L16 static inline __attribute__((always_inline)) void
prefetch_ahead(const hbk_fluid_t *h, const hbk_fluid_vols_t *in, int32_t i0, int32_t j, int32_t k,
               size_t v, int paint)
{
    const size_t sy = (size_t)h->nv[0], sz = sy * (size_t)h->nv[1], K = (size_t)h->K;
    const size_t rx = (size_t)h->p.resolution[0], ry = (size_t)h->p.resolution[1];
    for (int q = 0; q < 2; ++q) {
        const size_t pv = v + 16 + (q ? sz : sy);
        if (pv + 16 > h->n_vert) break;
        prefetch_span(in->uvw[0] + 3 * pv, 48);
        prefetch_span(in->uvw[1] + 3 * pv, 48);
        prefetch_span(h->motion + 3 * pv, 48);
        prefetch_span(in->base + K * pv, 16 * K);
        if (!q) __builtin_prefetch(h->rule_tex + pv); /* the next row's base list reads it */
        if (paint && !in->unpainted[pv / sy]) {
            prefetch_span(in->paint + K * pv, 16 * K);
            prefetch_span(in->life + pv, 16);
        }
        const size_t wy = (size_t)j + (q ? 0u : 1u), wz = (size_t)k + (q ? 1u : 0u);
        if (wy < ry && wz < (size_t)h->p.resolution[2]) {
            const size_t w = (size_t)i0 + 16 + rx * (wy + ry * wz);
            __builtin_prefetch(in->wrap[0] + w);
            __builtin_prefetch(in->wrap[1] + w);
        }
    }
}

/* Field f (C channels) over all the passes ps of a row, into out: each an instance of its own,
 * with C known, so the windows stay in registers. */
HBK_L16 static inline __attribute__((always_inline)) void
field_all(const hbk_fluid_t *h, const hbk_fluid_vols_t *in, hbk_fluid_vols_t *out,
          const size_t off[8], const lerp16_t *ls, const pass_t *ps, int np, size_t row, int f,
          int C)
{
    const int K = h->K;
    float *dst = f == F_UVW_A   ? out->uvw[0]
                 : f == F_UVW_B ? out->uvw[1]
                 : f == F_BASE  ? out->base
                 : f == F_PAINT ? out->paint
                                : out->life;
    for (int q = 0; q < np; ++q) {
        const pass_t *p = &ps[q];
        __m512 v[HBK_FLUID_MAX_TEXTURES];
        for (int c = 0; c < HBK_FLUID_MAX_TEXTURES; ++c) v[c] = _mm512_setzero_ps();
        field_pass(h, in, off, &ls[p->g], p, f, C, v);
        if (f == F_BASE) { /* a convex combination: renormalise only the rounding */
            __m512 s = _mm512_setzero_ps();
            for (int t = 0; t < K; ++t) s = _mm512_add_ps(s, v[t]);
            const __mmask16 pos = _mm512_cmp_ps_mask(s, _mm512_setzero_ps(), _CMP_GT_OQ);
            for (int t = 0; t < K; ++t)
                v[t] = _mm512_mask_div_ps(_mm512_set1_ps(t == h->p.default_texture ? 1.0f : 0.0f),
                                          pos, v[t], s);
        }
        store_records(dst + (size_t)C * (row + (size_t)(16 * p->g)), C, v, p->P);
    }
}

#define FIELD_ALL_ARGS                                                                             \
    const hbk_fluid_t *h, const hbk_fluid_vols_t *in, hbk_fluid_vols_t *out, const size_t off[8],  \
        const lerp16_t *ls, const pass_t *ps, int np, size_t row, int f
HBK_L16 static __attribute__((noinline)) void field_all3(FIELD_ALL_ARGS)
{
    field_all(h, in, out, off, ls, ps, np, row, f, 3);
}
HBK_L16 static __attribute__((noinline)) void field_all1(FIELD_ALL_ARGS)
{
    field_all(h, in, out, off, ls, ps, np, row, f, 1);
}
HBK_L16 static __attribute__((noinline)) void field_allk(FIELD_ALL_ARGS)
{
    field_all(h, in, out, off, ls, ps, np, row, f, h->K);
}

enum { GROUPS = 17 }; /* sixteen-vertex groups in a row of at most 257 vertices */

/* Row (j, k) in phases, each over the whole row before the next (as advect.c does per vertex):
 * a pass's loads then depend on a list made earlier, not on the reductions just before them,
 * and one field's lines are in use at a time. */
typedef struct {
    __mmask16 M[GROUPS];
    __m512 vm[GROUPS][3];
    lerp16_t l[GROUPS];
    pass_t ps[GROUPS * 16];
    pass_t bps[GROUPS * 16]; /* the passes whose base is sampled */
    pass_t pps[GROUPS * 16]; /* the passes whose paint and life are sampled */
} row16_t;

HBK_L16 void hbk_fluid_advect_row16(const hbk_fluid_t *h, const hbk_fluid_vols_t *in,
                                    hbk_fluid_vols_t *out, const size_t off[8], float dt, int32_t j,
                                    int32_t k)
{
    const int32_t nx = h->nv[0], ng = (nx + 15) / 16;
    const size_t row = (size_t)nx * ((size_t)j + (size_t)h->nv[1] * (size_t)k);
    const int K = h->K, paint = h->paint_active;
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const __m512 y = _mm512_set1_ps((float)j), z = _mm512_set1_ps((float)k);
    row16_t r;
    int np = 0;
    /* the moving lanes, and their midpoints' passes (trace_mid) */
    for (int g = 0; g < ng; ++g) {
        const int32_t i0 = 16 * g, n = nx - i0 < 16 ? nx - i0 : 16;
        const __mmask16 valid = (__mmask16)((1u << n) - 1);
        const size_t v = row + (size_t)i0;
        hbk_win_t mt;
        hbk_win_load(&mt, h->motion + 3 * v, 3 * n, h->motion + 3 * h->n_vert + 4);
        __mmask16 still = valid;
        __m512 v0[3];
        for (int a = 0; a < 3; ++a) {
            const __m512i id = _mm512_add_epi32(_mm512_mullo_epi32(lane, _mm512_set1_epi32(3)),
                                                _mm512_set1_epi32(a));
            v0[a] = hbk_win_get(&mt, id, _mm512_test_epi32_mask(id, _mm512_set1_epi32(32)));
            still &= _mm512_cmp_ps_mask(v0[a], _mm512_setzero_ps(), _CMP_EQ_OQ);
        }
        const __mmask16 M = r.M[g] = valid & (__mmask16)~still;
        prefetch_ahead(h, in, i0, j, k, v, paint);
        _mm_mask_storeu_epi8(h->moving + v, valid,
                             _mm_and_si128(_mm_movm_epi8(M), _mm_set1_epi8(1)));
        if (!M) continue;
        const float hd = 0.5f * dt;
        const __m512 x[3] = {_mm512_cvtepi32_ps(_mm512_add_epi32(lane, _mm512_set1_epi32(i0))), y,
                             z};
        __m512 p[3];
        for (int a = 0; a < 3; ++a) {
            p[a] = _mm512_sub_ps(x[a], _mm512_mul_ps(_mm512_mul_ps(_mm512_set1_ps(hd), v0[a]),
                                                     _mm512_set1_ps(h->inv_cell[a])));
        }
        lerp16(h, p, &r.l[g]);
        np = split_passes(&r.l[g], M, g, r.ps, np);
    }
    if (np) {
        /* a group's passes are consecutive: its V_m gathers in registers */
        for (int q = 0; q < np;) {
            const int g = r.ps[q].g;
            __m512 acc[3] = {_mm512_setzero_ps(), _mm512_setzero_ps(), _mm512_setzero_ps()};
            for (; q < np && r.ps[q].g == g; ++q) {
                __m512 v[3] = {acc[0], acc[1], acc[2]};
                motion_pass(h, off, &r.l[g], &r.ps[q], v);
                for (int a = 0; a < 3; ++a) acc[a] = _mm512_mask_blend_ps(r.ps[q].P, acc[a], v[a]);
            }
            for (int a = 0; a < 3; ++a) r.vm[g][a] = acc[a];
        }
        /* the sources (trace_src) and their passes */
        np = 0;
        for (int g = 0; g < ng; ++g) {
            const __mmask16 M = r.M[g];
            if (!M) continue;
            const int32_t i0 = 16 * g;
            const __m512 x[3] = {_mm512_cvtepi32_ps(_mm512_add_epi32(lane, _mm512_set1_epi32(i0))),
                                 y, z};
            __m512 p[3], d[3];
            for (int a = 0; a < 3; ++a) {
                p[a] =
                    _mm512_sub_ps(x[a], _mm512_mul_ps(_mm512_mul_ps(_mm512_set1_ps(dt), r.vm[g][a]),
                                                      _mm512_set1_ps(h->inv_cell[a])));
                d[a] = _mm512_sub_ps(p[a], x[a]);
            }
            store_records(h->disp + 3 * (row + (size_t)i0), 3, d, M);
            lerp16(h, p, &r.l[g]);
            np = split_passes(&r.l[g], M, g, r.ps, np);
        }
    }
    /* Both uvw fields first: by the time the lists below copy the passes, the stores that
     * wrote them have retired (read at once, a pass's 16-byte copy waited for them). */
    for (int f = F_UVW_A; np && f <= F_UVW_B; ++f)
        field_all3(h, in, out, off, r.l, r.ps, np, row, f);
    /* The base of a pass whose every lane a feature rule sets (hbk_fluid_rules_row, right
     * after this row) is not sampled: it would be overwritten. */
    pass_t *bps = r.ps;
    int nb = np;
    if (np && h->rules_matched) {
        bps = r.bps;
        nb = 0;
        for (int q = 0; q < np; ++q) {
            const pass_t *p = &r.ps[q];
            /* rule_tex has 16 bytes of padding: a plain load (a masked one is slow here) */
            const __m128i tex =
                _mm_loadu_si128((const __m128i *)(h->rule_tex + row + 16 * (size_t)p->g));
            bps[nb] = *p;
            nb += _mm_mask_cmpneq_epi8_mask(p->P, tex, _mm_set1_epi8((char)0xff)) != p->P;
        }
    }
    /* The paint and life of a pass whose four source rows hold none are +0 (every corner
     * +0, every weight finite and >= 0): written, not sampled. Most of the fluid is not
     * painted. */
    int npp = 0;
    /* this row of out (the buffer of the frame before) held no paint either: its flag is
     * rewritten after this row */
    const size_t jk = row / (size_t)nx;
    const int out_zero = paint && out->unpainted[jk];
    if (np && paint) {
        const size_t ny = (size_t)h->nv[1];
        for (int q = 0; q < np; ++q) {
            const pass_t *p = &r.ps[q];
            const uint8_t *u = in->unpainted + p->row;
            if (u[0] & u[1] & u[ny] & u[ny + 1]) {
                if (out_zero) continue; /* +0 there already */
                zero_records(out->paint + (size_t)K * (row + (size_t)(16 * p->g)), K, p->P);
                _mm512_mask_storeu_ps(out->life + row + (size_t)(16 * p->g), p->P,
                                      _mm512_setzero_ps());
            } else
                r.pps[npp++] = *p;
        }
    }
    for (int f = F_BASE; np && f <= (paint ? F_LIFE : F_BASE); ++f) {
        const pass_t *fps = f == F_BASE ? bps : r.pps;
        const int fn = f == F_BASE ? nb : npp;
        (f != F_LIFE && K == 3 ? field_all3 : f == F_LIFE ? field_all1 : field_allk)(
            h, in, out, off, r.l, fps, fn, row, f);
    }
    /* Nothing sampled here, the out row clean, and its still vertices to copy from a clean
     * row: the row stays clean, known without a look (2, for hbk_fluid_advect: a look would
     * read the row back from memory, since nothing wrote it) */
    if (out_zero && npp == 0 && in->unpainted[jk]) out->unpainted[jk] = 2;
    _mm256_zeroupper(); /* the caller is SSE code */
}
