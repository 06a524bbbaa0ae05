/* The SPH gathers of a particle, eight candidate neighbours at a time in AVX2 lanes. Each
 * pair's terms are the scalar code's operations (no FMA, IEEE sqrt and division in every lane)
 * and each lane keeps its own partial sums, which hbk_fluid_lane_sum adds at the end: the
 * scalar code sums in the same lanes (hbk_fluid_lane_of), so the bytes are the same. (Adding
 * each neighbour's terms one by one in order, as before, cost a mispredicted branch or two per
 * eight candidates.) The candidates are read from the structure-of-arrays copy of the sorted particles
 * (h->soa: x, y, z, vx, vy, vz, density, p / density^2, each padded by 8). */
#include "internal_fluid.h"

typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));

int hbk_fluid_sph_lanes(void) { return hbk_paths() >= HBK_PATHS_AVX2; }

/* Eight floats from p, unaligned (a macro: a function returning a vector would change the
 * ABI between AVX2 and default code). */
#define load8(p)                                                                             \
    ({                                                                                       \
        v8f v_;                                                                              \
        __builtin_memcpy(&v_, (p), sizeof v_);                                               \
        v_;                                                                                  \
    })

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

/* Images: 0 is the neighbour itself; 1 .. nim its mirror images across the walls (sgn * x +
 * off per axis), in the scalar loop's order. */

__attribute__((target("avx2"))) float
hbk_fluid_density_lanes(const hbk_fluid_cells_t *c, const float *soa, size_t stride,
                        int32_t cx, int32_t cy, int32_t cz, const float xi[3], float H, int nim,
                        const float (*sgn)[3], const float (*off)[3])
{
    const float *X = soa, *Y = soa + stride, *Z = soa + 2 * stride;
    const v8f zero = {0}, x = zero + xi[0], y = zero + xi[1], z = zero + xi[2];
    const v8f h = zero + H, h2 = zero + H * H;
    const v8i lane = {0, 1, 2, 3, 4, 5, 6, 7};
    v8f part = zero;
    if (!nim) /* away from the walls: no branch on empty groups (a mispredicted one cost more
               * than the square roots) */
        FOR_ROWS(c, cx, cy, cz, a, e, {
            for (int32_t j = a; j < e; j += 8) {
                const v8f dx = x - load8(X + j), dy = y - load8(Y + j), dz = z - load8(Z + j);
                const v8f r2 = dx * dx + dy * dy + dz * dz;
                const v8i near = (lane + j < e) & (r2 < h2);
                const v8f q = h - __builtin_ia32_sqrtps256(r2), q3 = q * q * q;
                part += (v8f)((v8i)q3 & near); /* + 0 where out of reach: the same bits */
            }
        })
    else
    FOR_ROWS(c, cx, cy, cz, a, e, {
        for (int32_t j = a; j < e; j += 8) {
            const v8f xj = load8(X + j), yj = load8(Y + j), zj = load8(Z + j);
            const v8i in = lane + j < e;
            for (int im = 0; im <= nim; ++im) {
                v8f dx, dy, dz;
                if (im == 0) {
                    dx = x - xj, dy = y - yj, dz = z - zj;
                } else {
                    const float *sg = sgn[im - 1], *of = off[im - 1];
                    dx = x - (sg[0] * xj + of[0]);
                    dy = y - (sg[1] * yj + of[1]);
                    dz = z - (sg[2] * zj + of[2]);
                }
                const v8f r2 = dx * dx + dy * dy + dz * dz;
                const v8i near = in & (r2 < h2);
                if (!__builtin_ia32_movmskps256((v8f)near)) continue;
                const v8f q = h - __builtin_ia32_sqrtps256(r2), q3 = q * q * q;
                part += (v8f)((v8i)q3 & near); /* + 0 where out of reach: the same bits */
            }
        }
    })
    float p[8];
    __builtin_memcpy(p, &part, sizeof p);
    const float sum = hbk_fluid_lane_sum(p);
    __builtin_ia32_vzeroupper(); /* the caller is SSE code */
    return sum;
}

__attribute__((target("avx2"))) void
hbk_fluid_forces_lanes(const hbk_fluid_cells_t *c, const float *soa, size_t stride,
                       int32_t cx, int32_t cy, int32_t cz, int32_t i, const float xi[8],
                       float H, float m, float spiky, float visc, int nim,
                       const float (*sgn)[3], const float (*off)[3], float ap[3], float fv[3])
{
    const float *X = soa, *Y = soa + stride, *Z = soa + 2 * stride;
    const float *VX = soa + 3 * stride, *VY = soa + 4 * stride, *VZ = soa + 5 * stride;
    const float *R = soa + 6 * stride, *P = soa + 7 * stride;
    const v8f zero = {0}, x = zero + xi[0], y = zero + xi[1], z = zero + xi[2];
    const v8f vx = zero + xi[3], vy = zero + xi[4], vz = zero + xi[5], pi = zero + xi[7];
    const v8f h = zero + H, h2 = zero + H * H, tiny = zero + 1e-9f * H;
    const v8f vm = zero + m, vs = zero + spiky, vv = zero + visc;
    const v8i lane = {0, 1, 2, 3, 4, 5, 6, 7};
    v8f part[6] = {zero, zero, zero, zero, zero, zero};
    if (!nim) { /* away from the walls: a row's distances and square roots first, then the
                 * terms, so that the square roots of several groups overlap */
        FOR_ROWS(c, cx, cy, cz, a, e, {
            for (int32_t j0 = a; j0 < e; j0 += 64) {
                v8f D[8][3], RR[8];
                v8i N[8];
                const int ng = (e - j0 + 7) / 8 < 8 ? (e - j0 + 7) / 8 : 8;
                for (int g = 0; g < ng; ++g) { /* the scalar code's 1 * x + 0 (signed zeros) */
                    const int32_t j = j0 + 8 * g;
                    D[g][0] = x - (1.0f * load8(X + j) + 0.0f);
                    D[g][1] = y - (1.0f * load8(Y + j) + 0.0f);
                    D[g][2] = z - (1.0f * load8(Z + j) + 0.0f);
                    const v8f r2 = D[g][0] * D[g][0] + D[g][1] * D[g][1] + D[g][2] * D[g][2];
                    N[g] = (lane + j < e) & (r2 < h2) & (lane + j != i);
                    RR[g] = __builtin_ia32_sqrtps256(r2);
                }
                for (int g = 0; g < ng; ++g) {
                    if (!__builtin_ia32_movmskps256((v8f)N[g])) continue;
                    const int32_t j = j0 + 8 * g;
                    const v8f rr = RR[g], q = h - rr;
                    const v8i near = N[g], push = near & (rr > tiny);
                    const v8f f = vm * (pi + load8(P + j)) * vs * q * q / rr;
                    const v8f w = vm / load8(R + j) * vv * q;
                    const v8f t[6] = {f * D[g][0], f * D[g][1], f * D[g][2],
                                      w * (1.0f * load8(VX + j) - vx),
                                      w * (1.0f * load8(VY + j) - vy),
                                      w * (1.0f * load8(VZ + j) - vz)};
                    HBK_UNROLL8 for (int q6 = 0; q6 < 6; ++q6)
                        part[q6] += (v8f)((v8i)t[q6] & (q6 < 3 ? push : near));
                }
            }
        })
    } else
    FOR_ROWS(c, cx, cy, cz, a, e, {
        for (int32_t j = a; j < e; j += 8) {
            const v8f xj = load8(X + j), yj = load8(Y + j), zj = load8(Z + j);
            const v8i in = lane + j < e;
            for (int im = 0; im <= nim; ++im) {
                /* the scalar code's sg * x + of, with sg = 1 and of = 0 for j itself */
                const float one[3] = {1.0f, 1.0f, 1.0f}, nil[3] = {0.0f, 0.0f, 0.0f};
                const float *sg = im ? sgn[im - 1] : one, *of = im ? off[im - 1] : nil;
                const v8f dx = x - (sg[0] * xj + of[0]), dy = y - (sg[1] * yj + of[1]),
                          dz = z - (sg[2] * zj + of[2]);
                const v8f r2 = dx * dx + dy * dy + dz * dz;
                /* j itself is not its own neighbour, but its images are */
                const v8i near = in & (r2 < h2) & (im ? lane == lane : lane + j != i);
                if (!__builtin_ia32_movmskps256((v8f)near)) continue;
                const v8f rr = __builtin_ia32_sqrtps256(r2), q = h - rr;
                const v8i push = near & (rr > tiny);
                const v8f f = vm * (pi + load8(P + j)) * vs * q * q / rr;
                const v8f w = vm / load8(R + j) * vv * q;
                const v8f t[6] = {f * dx, f * dy, f * dz, w * (sg[0] * load8(VX + j) - vx),
                                  w * (sg[1] * load8(VY + j) - vy),
                                  w * (sg[2] * load8(VZ + j) - vz)};
                HBK_UNROLL8 for (int q6 = 0; q6 < 6; ++q6) /* + 0 out of reach: the same bits */
                    part[q6] += (v8f)((v8i)t[q6] & (q6 < 3 ? push : near));
            }
        }
    })
    for (int q6 = 0; q6 < 6; ++q6) {
        float p[8];
        __builtin_memcpy(p, &part[q6], sizeof p);
        (q6 < 3 ? ap : fv)[q6 % 3] = hbk_fluid_lane_sum(p);
    }
    __builtin_ia32_vzeroupper();
}
