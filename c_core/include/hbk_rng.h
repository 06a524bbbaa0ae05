/* Counter-based random numbers (Philox4x32-10). A value depends only on (seed, stream,
 * counter), never on call order, so results are identical for any thread count and schedule. */
#ifndef HBK_RNG_H
#define HBK_RNG_H
#include "hbk_base.h"
#ifdef __cplusplus
extern "C" {
#endif

/* Four independent 32-bit words for (seed, stream, counter). Never fails. */
HBK_EXPORT void hbk_rng_u32x4(uint64_t seed, uint32_t stream, uint64_t counter, uint32_t out[4]);

/* Uniform float in [0, 1) from word `lane` (0..3) of the block for (seed, stream, counter). */
HBK_EXPORT float hbk_rng_uniform(uint64_t seed, uint32_t stream, uint64_t counter, uint32_t lane);

/* Fills `out[0..n)` with uniforms in [0, 1): out[i] uses counter (first + i/4), lane i%4. */
HBK_EXPORT void hbk_rng_fill_uniform(uint64_t seed, uint32_t stream, uint64_t first, float *out,
                                     size_t n);

#ifdef __cplusplus
}
#endif
#endif
