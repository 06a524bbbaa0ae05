/* Private helpers shared by all kernels. */
#ifndef HBK_INTERNAL_BASE_H
#define HBK_INTERNAL_BASE_H
#include "hbk_base.h"
#include <omp.h>
#include <stdarg.h>

/* printf into a message buffer (NULL is allowed); returns `code` so callers can
 * `return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "...")`. */
hbk_result_t hbk_fail(hbk_message_t *msg, hbk_result_t code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
void hbk_message_clear(hbk_message_t *msg);

/* Every value of a checked image (hbk_image_check) in [lo, hi], NaN refused: else an error
 * naming the first bad pixel, the range and `unit` (image.c). */
struct hbk_image;
hbk_result_t hbk_image_check_values(const struct hbk_image *img, const char *name, double lo,
                                    double hi, const char *unit, hbk_message_t *msg);

/* The widest hand-dispatched code the CPU and HBK_PATHS allow (paths.c); read it once per
 * call of a kernel, not per item (it reads the environment). */
enum { HBK_PATHS_SCALAR, HBK_PATHS_SSE, HBK_PATHS_AVX2, HBK_PATHS_AVX512 };
int hbk_paths(void);

/* The OpenMP team for a `threads` parameter (0 = all): at most four per processor. More only
 * cost stacks, and libgomp ends the process when it cannot make them. Results never depend on
 * the team. */
static inline int hbk_threads(int32_t requested)
{
    const int cap = 4 * omp_get_num_procs();
    return requested <= 0 ? omp_get_max_threads() : requested < cap ? requested : cap;
}

static inline int hbk_cancelled(const hbk_progress_t *p)
{
    return p && __atomic_load_n(&p->cancel, __ATOMIC_RELAXED) != 0;
}
static inline void hbk_report(hbk_progress_t *p, float fraction)
{
    if (p) p->fraction = fraction;
}

/* Philox4x32-10 (Salmon et al. 2011), the full block function. */
static inline void hbk_philox4x32(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4])
{
    uint32_t c0 = ctr[0], c1 = ctr[1], c2 = ctr[2], c3 = ctr[3], k0 = key[0], k1 = key[1];
    for (int r = 0; r < 10; ++r) {
        uint64_t p0 = (uint64_t)0xD2511F53u * c0, p1 = (uint64_t)0xCD9E8D57u * c2;
        uint32_t n0 = (uint32_t)(p1 >> 32) ^ c1 ^ k0, n2 = (uint32_t)(p0 >> 32) ^ c3 ^ k1;
        c0 = n0; c1 = (uint32_t)p1; c2 = n2; c3 = (uint32_t)p0;
        k0 += 0x9E3779B9u; k1 += 0xBB67AE85u;
    }
    out[0] = c0; out[1] = c1; out[2] = c2; out[3] = c3;
}
/* The block for (seed, stream, counter): counter in words 0-1, stream in word 2. */
static inline void hbk_philox(uint64_t seed, uint32_t stream, uint64_t counter, uint32_t out[4])
{
    const uint32_t ctr[4] = {(uint32_t)counter, (uint32_t)(counter >> 32), stream, 0};
    const uint32_t key[2] = {(uint32_t)seed, (uint32_t)(seed >> 32)};
    hbk_philox4x32(ctr, key, out);
}
/* 24 random bits to a float in [0, 1): exact, never rounds up to 1. */
static inline float hbk_u32_to_unit(uint32_t x) { return (float)(x >> 8) * (1.0f / 16777216.0f); }

#endif
