/* V_r after the advection, sixteen voxels at a time (AVX-512), with the bytes of advect.c's
 * flags_row. A voxel's eight corners are vertices i and i + 1 of four vertex rows, so sixteen
 * neighbouring voxels read one window of 17 vertices per row and field: each corner is picked
 * out of it by a permute, and the ranges of the corners' values are taken for all sixteen at
 * once. The AVX2 flags took about 30% of the advection's instructions (callgrind); this pass
 * takes 9 ms against 13.4 on one core at 128^3 (docs/fluid_performance.md). */
#include "internal_lanes16.h"

/* hbk_fluid_repair_masks of sixteen voxels whose corner 0 are vertices v .. v + 15 (n of them
 * in the row), one field: per lane, bit a of *d and *x as there. */
/* Inlined: called, the windows went through memory and the pass took 15 ms instead of 9. */
HBK_L16 static inline __attribute__((always_inline)) void masks16(const float *uvw,
                                                                  const float *end,
                                                                  const size_t off[8], size_t v,
                                                                  int n, __m128i *d, __m128i *x)
{
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const __m512 half = _mm512_set1_ps(0.5f), one = _mm512_set1_ps(1.0f),
                 two = _mm512_set1_ps(2.0f);
    hbk_win_t w[4]; /* rows of corners 0-1, 2-3, 4-5, 6-7 */
    for (int r = 0; r < 4; ++r) hbk_win_load(&w[r], uvw + 3 * (v + off[2 * r]), 3 * (n + 1), end);
    *d = *x = _mm_setzero_si128();
    for (int a = 0; a < 3; ++a) {
        const __m512i i0 =
            _mm512_add_epi32(_mm512_mullo_epi32(lane, _mm512_set1_epi32(3)), _mm512_set1_epi32(a));
        const __m512i i1 = _mm512_add_epi32(i0, _mm512_set1_epi32(3));
        const __mmask16 h0 = _mm512_test_epi32_mask(i0, _mm512_set1_epi32(32));
        const __mmask16 h1 = _mm512_test_epi32_mask(i1, _mm512_set1_epi32(32));
        __m512 lo = two, hi = -one, wlo = two, whi = -one;
        for (int c = 0; c < 8; ++c) { /* the corners in hbk_fluid_repair_masks' order */
            const __m512 v = hbk_win_get(&w[c >> 1], c & 1 ? i1 : i0, c & 1 ? h1 : h0);
            /* v + 1 below 0.5, else v + 0 */
            const __m512 wv =
                _mm512_add_ps(v, _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(v, half, _CMP_LT_OQ), one));
            lo = _mm512_min_ps(v, lo); /* minps: v < lo ? v : lo, as there */
            hi = _mm512_max_ps(v, hi);
            wlo = _mm512_min_ps(wv, wlo);
            whi = _mm512_max_ps(wv, whi);
        }
        const __mmask16 direct = _mm512_cmp_ps_mask(_mm512_sub_ps(hi, lo), half, _CMP_LE_OQ);
        const __mmask16 across =
            _mm512_cmp_ps_mask(_mm512_sub_ps(whi, wlo), half, _CMP_LT_OQ) & (__mmask16)~direct;
        *d = _mm_or_si128(*d, _mm_maskz_mov_epi8(direct, _mm_set1_epi8((char)(1 << a))));
        *x = _mm_or_si128(*x, _mm_maskz_mov_epi8(across, _mm_set1_epi8((char)(1 << a))));
    }
}

HBK_L16 void hbk_fluid_flags_row16(const hbk_fluid_t *h, const hbk_fluid_vols_t *in,
                                   hbk_fluid_vols_t *out, const size_t off[8], int32_t j, int32_t k,
                                   size_t b0, size_t v0i, const uint8_t *col, int checked)
{
    const int32_t rx = h->p.resolution[0];
    for (int32_t i0 = 0; i0 < rx; i0 += 16) {
        const int n = rx - i0 < 16 ? rx - i0 : 16;
        const __mmask16 valid = (__mmask16)_bzhi_u32(0xffffu, (unsigned)n);
        const size_t vox = v0i + (size_t)i0, b = b0 + (size_t)i0;
        /* a voxel moves if either of its vertex columns does */
        const __m128i c0 = _mm_maskz_loadu_epi8(valid, col + i0);
        const __m128i c1 = _mm_maskz_loadu_epi8(valid, col + i0 + 1);
        const __mmask16 mv = _mm_test_epi8_mask(_mm_or_si128(c0, c1), _mm_set1_epi8(-1));
        const __mmask16 fix = checked ? mv : valid; /* the others keep their flags */
        __m128i f[2] = {_mm_maskz_loadu_epi8(valid, in->wrap[0] + vox),
                        _mm_maskz_loadu_epi8(valid, in->wrap[1] + vox)};
        if (fix) {
            __m128i d[2], x[2];
            const size_t len = 3 * h->n_vert + 4; /* floats in a uvw array (padded) */
            masks16(out->uvw[0], out->uvw[0] + len, off, b, n, &d[0], &x[0]);
            masks16(out->uvw[1], out->uvw[1] + len, off, b, n, &d[1], &x[1]);
            /* components both ways leave undecided: the flags of where the centre came from */
            const __m128i known = _mm_and_si128(_mm_or_si128(d[0], x[0]), _mm_or_si128(d[1], x[1]));
            const __mmask16 undecided =
                mv & _mm_cmpneq_epi8_mask(_mm_and_si128(known, _mm_set1_epi8(7)), _mm_set1_epi8(7));
            if (undecided) {
                uint8_t fa[16], fb[16];
                _mm_storeu_si128((__m128i *)fa, f[0]);
                _mm_storeu_si128((__m128i *)fb, f[1]);
                for (unsigned u = undecided; u; u &= u - 1) {
                    const int q = __builtin_ctz(u);
                    const size_t from = hbk_fluid_traced_from(h, off, b + (size_t)q, i0 + q, j, k);
                    fa[q] = in->wrap[0][from];
                    fb[q] = in->wrap[1][from];
                }
                f[0] = _mm_loadu_si128((const __m128i *)fa);
                f[1] = _mm_loadu_si128((const __m128i *)fb);
            }
            for (int u = 0; u < 2; ++u) /* hbk_fluid_repair_apply */
                f[u] =
                    _mm_mask_mov_epi8(f[u], fix, _mm_or_si128(_mm_andnot_si128(d[u], f[u]), x[u]));
        }
        _mm_mask_storeu_epi8(out->wrap[0] + vox, valid, f[0]);
        _mm_mask_storeu_epi8(out->wrap[1] + vox, valid, f[1]);
    }
    _mm256_zeroupper(); /* the caller is SSE code */
}
