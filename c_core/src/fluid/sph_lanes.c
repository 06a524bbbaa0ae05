/* The SPH gathers of a particle, eight at a time in AVX2 lanes. Each pair's terms are the
 * scalar code's operations (no FMA, IEEE sqrt and division in every lane) and each lane keeps
 * its own partial sums, which hbk_fluid_lane_sum adds at the end; the scalar code sums in the
 * same lanes, so the bytes are the same. (Adding each neighbour's terms one by one in order,
 * as before, cost a mispredicted branch or two per eight candidates.)
 * - Density: eight candidates of a row of cells at a time (lane hbk_fluid_lane_of), read from
 *   the structure-of-arrays copy of the sorted particles (h->soa: x, y, z, vx, vy, vz,
 *   density, p / density^2, each padded by 8). It also packs the candidates in reach into a
 *   list for the forces.
 * - Forces: away from the walls, eight of that list at a time (the k-th in lane k mod 8), each
 *   one's record of h->sorted loaded whole. A sixth of the candidates are in reach, so this
 *   takes a sixth of the square roots and divisions. Near walls, with the mirror images, by
 *   candidate as the density. */
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


typedef int32_t hbk_v4i __attribute__((vector_size(16)));
/* Left-packing of 4 lanes: the set lanes of a 4-bit mask first, in order. */
static const hbk_v4i pack4[16] = {
    {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0},
    {1, 2, 0, 0}, {0, 1, 2, 0}, {3, 0, 0, 0}, {0, 3, 0, 0}, {1, 3, 0, 0}, {0, 1, 3, 0},
    {2, 3, 0, 0}, {0, 2, 3, 0}, {1, 2, 3, 0}, {0, 1, 2, 3}};

/* Appends the candidates j + lane of the lanes set in `near` to list[n ..] in order (it
 * stores 8 slots), n += their count. */
#define PACK(list, n, j, near)                                                               \
    do {                                                                                     \
        const unsigned mk_ = (unsigned)__builtin_ia32_movmskps256((v8f)(near));              \
        const hbk_v4i lo_ = {(j), (j) + 1, (j) + 2, (j) + 3}, hi_ = lo_ + 4;                  \
        const hbk_v4i pl_ = (hbk_v4i)__builtin_ia32_vpermilvarps((hbk_v4f)lo_, pack4[mk_ & 15]); \
        const hbk_v4i ph_ = (hbk_v4i)__builtin_ia32_vpermilvarps((hbk_v4f)hi_, pack4[mk_ >> 4]); \
        __builtin_memcpy((list) + (n), &pl_, sizeof pl_);                                    \
        (n) += __builtin_popcount(mk_ & 15);                                                 \
        __builtin_memcpy((list) + (n), &ph_, sizeof ph_);                                    \
        (n) += __builtin_popcount(mk_ >> 4);                                                 \
    } while (0)

/* Runs BODY(idx, n) over the neighbours of i away from the walls (candidates within reach,
 * i excluded) eight at a time in order, idx[0 .. n - 1] real (n <= 8): from `list` when the
 * density kept them (nlist >= 0), else found again from the cells. */
#define FOR_PACKED(list, nlist, BODY)                                                        \
    do {                                                                                     \
        if ((nlist) >= 0)                                                                    \
            for (int32_t k_ = 0; k_ < (nlist); k_ += 8) BODY((list) + k_, (nlist) - k_);     \
        else {                                                                               \
            int32_t buf_[16], n_ = 0;                                                        \
            HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a, e, {                                        \
                for (int32_t j = a; j < e; j += 8) {                                         \
                    const v8f dx_ = x - load8(X + j), dy_ = y - load8(Y + j),                \
                              dz_ = z - load8(Z + j);                                        \
                    const v8f r2_ = dx_ * dx_ + dy_ * dy_ + dz_ * dz_;                       \
                    PACK(buf_, n_, j, (lane + j < e) & (r2_ < h2) & (lane + j != i));        \
                    if (n_ >= 8) {                                                           \
                        BODY(buf_, 8);                                                       \
                        __builtin_memcpy(buf_, buf_ + 8, 8 * sizeof *buf_);                  \
                        n_ -= 8;                                                             \
                    }                                                                        \
                }                                                                            \
            })                                                                               \
            if (n_) BODY(buf_, n_);                                                          \
        }                                                                                    \
    } while (0)

/* The records rec8 + 8 idx[q] (x, y, z, vx, vy, vz, density, p / density^2) of lanes q < n
 * (the others read i's own), transposed to one vector per field, F[0 .. 7]. */
#define RECORDS(F, idx, n)                                                             \
    do {                                                                                     \
        const float *rec_[8];                                                                \
        HBK_UNROLL8 for (int q_ = 0; q_ < 8; ++q_)                                           \
            rec_[q_] = rec8 + 8 * (size_t)(q_ < (n) ? (idx)[q_] : i);                        \
        for (int hb_ = 0; hb_ < 2; ++hb_) {                                                    \
            v8f S_[4], T_[4];                                                                \
            for (int q_ = 0; q_ < 4; ++q_) {                                                 \
                hbk_v4f l0_, l1_;                                                            \
                __builtin_memcpy(&l0_, rec_[q_] + 4 * hb_, sizeof l0_);                      \
                __builtin_memcpy(&l1_, rec_[q_ + 4] + 4 * hb_, sizeof l1_);                  \
                S_[q_] = __builtin_shufflevector(l0_, l1_, 0, 1, 2, 3, 4, 5, 6, 7);          \
            }                                                                                \
            T_[0] = __builtin_shufflevector(S_[0], S_[1], 0, 8, 1, 9, 4, 12, 5, 13);         \
            T_[1] = __builtin_shufflevector(S_[0], S_[1], 2, 10, 3, 11, 6, 14, 7, 15);       \
            T_[2] = __builtin_shufflevector(S_[2], S_[3], 0, 8, 1, 9, 4, 12, 5, 13);         \
            T_[3] = __builtin_shufflevector(S_[2], S_[3], 2, 10, 3, 11, 6, 14, 7, 15);       \
            F[4 * hb_ + 0] = __builtin_shufflevector(T_[0], T_[2], 0, 1, 8, 9, 4, 5, 12, 13); \
            F[4 * hb_ + 1] = __builtin_shufflevector(T_[0], T_[2], 2, 3, 10, 11, 6, 7, 14, 15); \
            F[4 * hb_ + 2] = __builtin_shufflevector(T_[1], T_[3], 0, 1, 8, 9, 4, 5, 12, 13); \
            F[4 * hb_ + 3] = __builtin_shufflevector(T_[1], T_[3], 2, 3, 10, 11, 6, 7, 14, 15); \
        }                                                                                    \
    } while (0)

/* Images: 0 is the neighbour itself; 1 .. nim its mirror images across the walls (sgn * x +
 * off per axis), in the scalar loop's order. */

__attribute__((target("avx2"))) float
hbk_fluid_density_lanes(const hbk_fluid_cells_t *c, const float *soa, const float *rec8,
                        size_t stride, int32_t cx, int32_t cy, int32_t cz, int32_t i,
                        const float xi[3], float H,
                        int nim, const float (*sgn)[3], const float (*off)[3], int32_t *list,
                        int32_t *nlist)
{
    const float *X = soa, *Y = soa + stride, *Z = soa + 2 * stride;
    const v8f zero = {0}, x = zero + xi[0], y = zero + xi[1], z = zero + xi[2];
    const v8f h = zero + H, h2 = zero + H * H;
    const v8i lane = {0, 1, 2, 3, 4, 5, 6, 7};
    v8f part = zero;
    int32_t n = 0;
    if (!nim) { /* away from the walls: no branch on empty groups (a mispredicted one cost more
                 * than the square roots); the neighbours packed for the forces */
        HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a, e, {
            for (int32_t j = a; j < e; j += 8) {
                const v8f dx = x - load8(X + j), dy = y - load8(Y + j), dz = z - load8(Z + j);
                const v8f r2 = dx * dx + dy * dy + dz * dz;
                const v8i near = (lane + j < e) & (r2 < h2);
                const v8f q = h - __builtin_ia32_sqrtps256(r2), q3 = q * q * q;
                part += (v8f)((v8i)q3 & near); /* + 0 where out of reach: the same bits */
                if (n <= HBK_FLUID_NBR_CAP - 8) PACK(list, n, j, near & (lane + j != i));
                else n = HBK_FLUID_NBR_CAP; /* too many: the forces find them again */
            }
        })
        *nlist = n < HBK_FLUID_NBR_CAP ? n : -1;
    } else
    HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a, e, {
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
    if (nim) *nlist = -1;
    float p[8];
    __builtin_memcpy(p, &part, sizeof p);
    const float sum = hbk_fluid_lane_sum(p);
    __builtin_ia32_vzeroupper(); /* the caller is SSE code */
    return sum;
}

/* The forces' terms of neighbours idx[0 .. n - 1], lane by lane, with the scalar code's
 * operations (1 * x + 0 included: signed zeros). */
#define TERMS8(idx, n)                                                                       \
    do {                                                                                     \
        v8f F[8];                                                                            \
        RECORDS(F, idx, n);                                                               \
        const v8i act = lane < (n);                                                          \
        const v8f dx = x - (1.0f * F[0] + 0.0f), dy = y - (1.0f * F[1] + 0.0f),             \
                  dz = z - (1.0f * F[2] + 0.0f);                                             \
        const v8f r2 = dx * dx + dy * dy + dz * dz;                                          \
        const v8f rr = __builtin_ia32_sqrtps256(r2), q = h - rr;                             \
        const v8i push = act & (rr > tiny);                                                  \
        const v8f f = vm * (pi + F[7]) * vs * q * q / rr;                                    \
        const v8f w = vm / F[6] * vv * q;                                                    \
        const v8f t6[6] = {f * dx, f * dy, f * dz, w * (1.0f * F[3] - vx),                   \
                           w * (1.0f * F[4] - vy), w * (1.0f * F[5] - vz)};                  \
        HBK_UNROLL8 for (int q6 = 0; q6 < 6; ++q6)                                           \
            part[q6] += (v8f)((v8i)t6[q6] & (q6 < 3 ? push : act));                          \
    } while (0)

__attribute__((target("avx2"))) void
hbk_fluid_forces_lanes(const hbk_fluid_cells_t *c, const float *soa, const float *rec8,
                       const int32_t *list, int32_t nlist, size_t stride,
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
    if (!nim) { /* away from the walls: the density's list, the k-th in lane k mod 8 */
        FOR_PACKED(list, nlist, TERMS8);
    } else
    HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a, e, {
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
