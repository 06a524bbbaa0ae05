/* The SPH gathers of a particle away from the walls, eight candidate neighbours at a time in
 * AVX2 lanes. Each pair's terms are the scalar code's operations (no FMA, IEEE sqrt and
 * division in every lane), and the terms of the neighbours within reach are then added one by
 * one in the candidates' order, as the scalar loop adds them: the same bytes, several times
 * faster. The candidates are read from the structure-of-arrays copy of the sorted particles
 * (h->soa: x, y, z, vx, vy, vz, density, p / density^2, each padded by 8). */
#include "internal_fluid.h"

typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));

int hbk_fluid_sph_lanes(void) { return __builtin_cpu_supports("avx2") != 0; }

/* Eight floats from p, unaligned (a macro: a function returning a vector would change the
 * ABI between AVX2 and default code). */
#define load8(p)                                                                             \
    ({                                                                                       \
        v8f v_;                                                                              \
        __builtin_memcpy(&v_, (p), sizeof v_);                                               \
        v_;                                                                                  \
    })

/* Bit l set when lane l holds a candidate below `end` and mask lane l is set. */
static inline __attribute__((always_inline)) unsigned bits_of(v8i mask, int32_t j, int32_t end)
{
    int32_t m[8];
    __builtin_memcpy(m, &mask, sizeof m);
    unsigned b = 0;
    for (int l = 0; l < 8; ++l) b |= (unsigned)(m[l] != 0 && j + l < end) << l;
    return b;
}

/* The rows of cells around (cx, cy, cz): each a contiguous range of sorted particles. */
#define FOR_ROWS(c, cx, cy, cz, a_, e_, ...)                                                 \
    for (int32_t nz_ = (cz) - 1; nz_ <= (cz) + 1; ++nz_) {                                   \
        if (nz_ < 0 || nz_ >= (c)->dims[2]) continue;                                        \
        for (int32_t ny_ = (cy) - 1; ny_ <= (cy) + 1; ++ny_) {                               \
            if (ny_ < 0 || ny_ >= (c)->dims[1]) continue;                                    \
            const size_t row_ = (size_t)(c)->dims[0] * ((size_t)ny_ + (size_t)(c)->dims[1] * \
                                                        (size_t)nz_);                        \
            const int32_t x0_ = (cx) > 0 ? (cx) - 1 : 0;                                     \
            const int32_t x1_ = (cx) + 1 < (c)->dims[0] ? (cx) + 1 : (c)->dims[0] - 1;       \
            const int32_t a_ = (c)->start[row_ + (size_t)x0_];                               \
            const int32_t e_ = (c)->start[row_ + (size_t)x1_ + 1];                           \
            __VA_ARGS__                                                                      \
        }                                                                                    \
    }

__attribute__((target("avx2"))) float
hbk_fluid_density_lanes(const hbk_fluid_cells_t *c, const float *soa, size_t stride,
                        int32_t cx, int32_t cy, int32_t cz, const float xi[3], float H)
{
    const float *X = soa, *Y = soa + stride, *Z = soa + 2 * stride;
    const v8f zero = {0}, x = zero + xi[0], y = zero + xi[1], z = zero + xi[2];
    const v8f h = zero + H, h2 = zero + H * H;
    float sum = 0.0f;
    FOR_ROWS(c, cx, cy, cz, a, e, {
        for (int32_t j = a; j < e; j += 8) {
            const v8f dx = x - load8(X + j), dy = y - load8(Y + j), dz = z - load8(Z + j);
            const v8f r2 = dx * dx + dy * dy + dz * dz;
            unsigned b = bits_of(r2 < h2, j, e);
            if (!b) continue;
            const v8f q = h - __builtin_ia32_sqrtps256(r2), q3 = q * q * q;
            float t[8];
            __builtin_memcpy(t, &q3, sizeof t);
            for (; b; b &= b - 1) sum += t[__builtin_ctz(b)];
        }
    })
    __builtin_ia32_vzeroupper(); /* the caller is SSE code */
    return sum;
}

__attribute__((target("avx2"))) void
hbk_fluid_forces_lanes(const hbk_fluid_cells_t *c, const float *soa, size_t stride,
                       int32_t cx, int32_t cy, int32_t cz, int32_t i, const float xi[8],
                       float H, float m, float spiky, float visc, float ap[3], float fv[3])
{
    const float *X = soa, *Y = soa + stride, *Z = soa + 2 * stride;
    const float *VX = soa + 3 * stride, *VY = soa + 4 * stride, *VZ = soa + 5 * stride;
    const float *R = soa + 6 * stride, *P = soa + 7 * stride;
    const v8f zero = {0}, x = zero + xi[0], y = zero + xi[1], z = zero + xi[2];
    const v8f vx = zero + xi[3], vy = zero + xi[4], vz = zero + xi[5], pi = zero + xi[7];
    const v8f h = zero + H, h2 = zero + H * H, tiny = zero + 1e-9f * H;
    const v8f vm = zero + m, vs = zero + spiky, vv = zero + visc;
    const v8i lane = {0, 1, 2, 3, 4, 5, 6, 7};
    FOR_ROWS(c, cx, cy, cz, a, e, {
        for (int32_t j = a; j < e; j += 8) {
            const v8f dx = x - load8(X + j), dy = y - load8(Y + j), dz = z - load8(Z + j);
            const v8f r2 = dx * dx + dy * dy + dz * dz;
            /* j itself is not its own neighbour (the walls' images are the scalar path's) */
            unsigned b = bits_of((r2 < h2) & (lane + j != i), j, e);
            if (!b) continue;
            const v8f rr = __builtin_ia32_sqrtps256(r2), q = h - rr;
            const unsigned bp = bits_of(rr > tiny, j, e);
            const v8f f = vm * (pi + load8(P + j)) * vs * q * q / rr;
            const v8f w = vm / load8(R + j) * vv * q;
            const v8f t[6] = {f * dx, f * dy, f * dz, w * (load8(VX + j) - vx),
                              w * (load8(VY + j) - vy), w * (load8(VZ + j) - vz)};
            float u[6][8];
            __builtin_memcpy(u, t, sizeof u);
            for (; b; b &= b - 1) {
                const int l = __builtin_ctz(b);
                if (bp >> l & 1u) {
                    ap[0] += u[0][l];
                    ap[1] += u[1][l];
                    ap[2] += u[2][l];
                }
                fv[0] += u[3][l];
                fv[1] += u[4][l];
                fv[2] += u[5][l];
            }
        }
    })
    __builtin_ia32_vzeroupper();
}
