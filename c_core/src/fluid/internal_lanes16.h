/* Private: what the fluid's sixteen-lane kernels (AVX-512: advect_lanes.c, advect_flags16.c)
 * share: their target, and a window of a row's records from which each lane's values are
 * picked by permutes. */
#ifndef HBK_INTERNAL_LANES16_H
#define HBK_INTERNAL_LANES16_H
#include "internal_fluid.h"
#include <immintrin.h>

/* No FMA: each lane does the plain code's operations, so the bytes are the same. */
#define HBK_L16                                                                                    \
    __attribute__((target("avx512f,avx512bw,avx512dq,avx512vl,bmi,bmi2"),                          \
                   optimize("fp-contract=off")))

enum { HBK_WIN = 64 }; /* floats in a window: four vectors */

typedef struct {
    __m512 z[4];
} hbk_win_t;

/* The floats p[0 .. n), n <= HBK_WIN (end: one past the array's last float). Unaligned masked
 * loads are slow on the build machine's CPU (the wrap-flag pass took twice as long with
 * them), so the window is loaded whole where the array has room, masked only near its end. */
HBK_L16 static inline void hbk_win_load(hbk_win_t *w, const float *p, int n, const float *end)
{
    if (end - p >= HBK_WIN) {
        for (int q = 0; q < 4; ++q) w->z[q] = _mm512_loadu_ps(p + 16 * q);
        return;
    }
    if (end - p < n) n = (int)(end - p);
    for (int q = 0; q < 4; ++q) {
        int c = n - 16 * q;
        c = c < 0 ? 0 : c > 16 ? 16 : c;
        w->z[q] = _mm512_maskz_loadu_ps((__mmask16)_bzhi_u32(0xffffu, (unsigned)c), p + 16 * q);
    }
}

/* Float idx of the window, per lane (idx < HBK_WIN; high: the lanes whose idx >= 32). */
HBK_L16 static inline __m512 hbk_win_get(const hbk_win_t *w, __m512i idx, __mmask16 high)
{
    const __m512 lo = _mm512_permutex2var_ps(w->z[0], idx, w->z[1]);
    const __m512 hi = _mm512_permutex2var_ps(w->z[2], idx, w->z[3]);
    return _mm512_mask_mov_ps(lo, high, hi);
}

#endif
