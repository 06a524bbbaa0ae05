#include "hbk_rng.h"
#include "internal_base.h"

void hbk_rng_u32x4(uint64_t seed, uint32_t stream, uint64_t counter, uint32_t out[4])
{
    hbk_philox(seed, stream, counter, out);
}

float hbk_rng_uniform(uint64_t seed, uint32_t stream, uint64_t counter, uint32_t lane)
{
    uint32_t w[4];
    hbk_philox(seed, stream, counter, w);
    return hbk_u32_to_unit(w[lane & 3u]);
}

void hbk_rng_fill_uniform(uint64_t seed, uint32_t stream, uint64_t first, float *out, size_t n)
{
    uint32_t w[4];
    for (size_t i = 0; i < n; ++i) {
        if ((i & 3u) == 0) hbk_philox(seed, stream, first + i / 4, w);
        out[i] = hbk_u32_to_unit(w[i & 3u]);
    }
}
