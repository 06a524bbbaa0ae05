/* Tileable 3D gradient noise (Perlin's improved noise with the lattice wrapped modulo the
 * period) for ready-made sample textures. Gradients come from the counter-based RNG keyed by
 * (seed, octave, lattice point), so there is no permutation table and no global state. */
#include "internal_fluid.h"
#include <omp.h>

static const float k_grad[12][3] = {{1, 1, 0}, {-1, 1, 0}, {1, -1, 0}, {-1, -1, 0},
                                    {1, 0, 1}, {-1, 0, 1}, {1, 0, -1}, {-1, 0, -1},
                                    {0, 1, 1}, {0, -1, 1}, {0, 1, -1}, {0, -1, -1}};

static inline float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }

/* One octave at lattice coordinates q (period L cells). */
static float octave(const float q[3], int64_t L, uint32_t oct, uint64_t seed)
{
    int64_t c[3];
    float f[3], u[3];
    for (int a = 0; a < 3; ++a) {
        const float fl = floorf(q[a]);
        f[a] = q[a] - fl;
        c[a] = (int64_t)fl;
        u[a] = fade(f[a]);
    }
    float v[8];
    for (int k = 0; k < 8; ++k) {
        const int o[3] = {k & 1, k >> 1 & 1, k >> 2 & 1};
        uint64_t id = 0;
        for (int a = 2; a >= 0; --a) {
            int64_t w = (c[a] + o[a]) % L;
            if (w < 0) w += L;
            id = id * (uint64_t)L + (uint64_t)w;
        }
        uint32_t r[4];
        hbk_philox(seed, HBK_FLUID_STREAM_NOISE + oct, id, r);
        const float *g = k_grad[r[0] % 12u];
        v[k] = g[0] * (f[0] - (float)o[0]) + g[1] * (f[1] - (float)o[1]) + g[2] * (f[2] - (float)o[2]);
    }
    const float a = v[0] + u[0] * (v[1] - v[0]), b = v[2] + u[0] * (v[3] - v[2]);
    const float d = v[4] + u[0] * (v[5] - v[4]), e = v[6] + u[0] * (v[7] - v[6]);
    const float g = a + u[1] * (b - a), hh = d + u[1] * (e - d);
    return g + u[2] * (hh - g);
}

float hbk_noise3d_sample(float x, float y, float z, int32_t period, int32_t octaves,
                         float persistence, uint64_t seed)
{
    if (period < 1 || period > 65536 || octaves < 1 || octaves > 8 ||
        !(persistence >= 0.0f && persistence <= 1.0f) || !isfinite(x) || !isfinite(y) || !isfinite(z))
        return 0.5f;
    float sum = 0.0f, amp = 1.0f, norm = 0.0f;
    int64_t L = period;
    const float t[3] = {x - floorf(x), y - floorf(y), z - floorf(z)}; /* one tile */
    for (int32_t o = 0; o < octaves; ++o, L *= 2, amp *= persistence) {
        const float q[3] = {t[0] * (float)L, t[1] * (float)L, t[2] * (float)L};
        sum += amp * octave(q, L, (uint32_t)o, seed);
        norm += amp;
    }
    /* Improved noise stays within about +-1; map to [0, 1]. */
    float v = 0.5f + 0.5f * sum / norm;
    return v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
}

hbk_result_t hbk_noise3d_tileable(float *out, int32_t size, int32_t period, int32_t octaves,
                                  float persistence, uint64_t seed, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!out) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out: must not be NULL");
    if (size < 1 || size > 1024)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "size = %d: must be in [1, 1024]", size);
    if (period < 1 || period > size)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "period = %d: must be in [1, size = %d]",
                        period, size);
    if (octaves < 1 || octaves > 8)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "octaves = %d: must be in [1, 8]", octaves);
    if (!(persistence >= 0.0f && persistence <= 1.0f))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "persistence = %g: must be in [0, 1]",
                        (double)persistence);
    const float inv = 1.0f / (float)size;
#pragma omp parallel for schedule(static)
    for (int32_t k = 0; k < size; ++k)
        for (int32_t j = 0; j < size; ++j)
            for (int32_t i = 0; i < size; ++i)
                out[(size_t)i + (size_t)size * ((size_t)j + (size_t)size * (size_t)k)] =
                    hbk_noise3d_sample((float)i * inv, (float)j * inv, (float)k * inv, period,
                                       octaves, persistence, seed);
    return HBK_OK;
}
