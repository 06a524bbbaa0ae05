/* The SPH gathers of a particle, eight at a time in AVX2 lanes (sixteen away from walls with
 * AVX-512, see density_free16). Each pair's terms are the
 * scalar code's operations (no FMA, IEEE sqrt and division in every lane) and each lane keeps
 * its own partial sums, which hbk_fluid_lane_sum adds at the end; the scalar code sums in the
 * same lanes, so the bytes are the same. (Adding each neighbour's terms one by one in order,
 * as before, cost a mispredicted branch or two per eight candidates.)
 * - Density: eight candidates of a row of cells at a time (lane hbk_fluid_lane_of), read from
 *   the structure-of-arrays copy of the sorted particles (h->soa: x, y, z, vx, vy, vz,
 *   density, p / density^2, each padded by 8), each candidate as itself and, near walls, as
 *   its mirror images. It also packs the (candidate, image) pairs in reach into a list for the
 *   forces.
 * - Forces: eight of that list at a time (the k-th in lane k mod 8), each one's record of
 *   h->sorted loaded whole and mirrored by its lane's image. A sixth of the candidates are in
 *   reach, so this takes a sixth of the square roots and divisions. (Near walls the forces
 *   used to go by candidate and image, as the density does: a quarter of a dam break's
 *   particles, and a quarter of its SPH time.) */
#include "internal_fluid.h"

typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));

int hbk_fluid_sph_lanes(void)
{
    const int paths = hbk_paths();
    return paths >= HBK_PATHS_AVX512 ? 16 : paths >= HBK_PATHS_AVX2 ? 8 : 0;
}

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

/* A list entry: the sorted index of the neighbour, and in the top bits which of its images
 * (0: itself, 1 .. nim: the mirror images) is in reach. max_particles <= 4M < 2^24. */
#define IMG_SHIFT 24
#define IDX_MASK ((1 << IMG_SHIFT) - 1)

/* Packs the (candidate, image) pairs in reach of candidates j .. j + 7 of a row ending at e
 * into list[n ..], n += their count: images in order, each one's candidates in order. i is
 * not its own neighbour, but its images are. CAPPED: packing stops at the cap and n becomes
 * HBK_FLUID_NBR_CAP; else FLUSH runs whenever n reaches 8. PART (or NULL): the density's
 * q^3 added in the candidates' lanes. */
#define SCAN8(j, e, list, n, CAPPED, FLUSH, PART)                                            \
    do {                                                                                     \
        const v8f xj_ = load8(X + (j)), yj_ = load8(Y + (j)), zj_ = load8(Z + (j));          \
        const v8i in_ = lane + (j) < (e);                                                    \
        for (int im_ = 0; im_ <= nim; ++im_) {                                               \
            v8f dx_, dy_, dz_;                                                               \
            if (im_ == 0) {                                                                  \
                dx_ = x - xj_, dy_ = y - yj_, dz_ = z - zj_;                                 \
            } else {                                                                         \
                const float *sg_ = sgn[im_ - 1], *of_ = off[im_ - 1];                        \
                dx_ = x - (sg_[0] * xj_ + of_[0]);                                           \
                dy_ = y - (sg_[1] * yj_ + of_[1]);                                           \
                dz_ = z - (sg_[2] * zj_ + of_[2]);                                           \
            }                                                                                \
            const v8f r2_ = dx_ * dx_ + dy_ * dy_ + dz_ * dz_;                               \
            const v8i near_ = in_ & (r2_ < h2);                                              \
            /* an image is seldom in reach; the neighbour itself often (no branch to miss) */ \
            if (im_ && !__builtin_ia32_movmskps256((v8f)near_)) continue;                    \
            if (PART) {                                                                      \
                const v8f q_ = h - __builtin_ia32_sqrtps256(r2_), q3_ = q_ * q_ * q_;        \
                *(PART) += (v8f)((v8i)q3_ & near_); /* + 0 out of reach: the same bits */    \
            }                                                                                \
            if (!(CAPPED) || (n) <= HBK_FLUID_NBR_CAP - 8) {                                 \
                PACK(list, n, (j) + (im_ << IMG_SHIFT),                                      \
                     near_ & (im_ ? in_ : lane + (j) != i));                                 \
                if (!(CAPPED) && (n) >= 8) FLUSH;                                            \
            } else (n) = HBK_FLUID_NBR_CAP;                                                  \
        }                                                                                    \
    } while (0)

/* Runs BODY(idx, n) over the pairs in reach of i (see SCAN8) eight at a time in order,
 * idx[0 .. n - 1] real (n <= 8): from `list` when the density kept them (nlist >= 0), else
 * found again from the cells. */
#define FOR_PACKED(list, nlist, BODY)                                                        \
    do {                                                                                     \
        if ((nlist) >= 0)                                                                    \
            for (int32_t k_ = 0; k_ < (nlist); k_ += 8) BODY((list) + k_, (nlist) - k_);     \
        else {                                                                               \
            int32_t buf_[16], n_ = 0;                                                        \
            HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a, e, {                                        \
                for (int32_t j = a; j < e; j += 8)                                           \
                    SCAN8(j, e, buf_, n_, 0, { BODY(buf_, 8);                                \
                        __builtin_memcpy(buf_, buf_ + 8, 8 * sizeof *buf_);                  \
                        n_ -= 8; }, (v8f *)0);                                               \
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
            rec_[q_] = rec8 + 8 * (size_t)(q_ < (n) ? (idx)[q_] & IDX_MASK : i);             \
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

/* Sixteen lanes where AVX-512 is there, away from the walls: each group of sixteen is the
 * AVX2 code's two groups of eight, its low half added to the eight lane sums before its high
 * half and packed before it, so the bytes are the same (a high half past the row's end adds
 * +0, which leaves a sum's bits alone: a sum is never -0). AVX-512 brings FMA, which GCC
 * would fuse a * b + c into (one rounding, not two): not here. */
typedef float v16f __attribute__((vector_size(64)));
typedef int32_t v16i __attribute__((vector_size(64)));
#define load16(p)                                                                            \
    ({                                                                                       \
        v16f v_;                                                                             \
        __builtin_memcpy(&v_, (p), sizeof v_);                                               \
        v_;                                                                                  \
    })
#define SQRT16(v) __builtin_ia32_sqrtps512_mask((v), (v), (unsigned short)-1, 4)
#define MASK16(v) ((unsigned)__builtin_ia32_ptestmd512((v), (v), (unsigned short)-1))
#define LO8(v) __builtin_shufflevector((v), (v), 0, 1, 2, 3, 4, 5, 6, 7)
#define HI8(v) __builtin_shufflevector((v), (v), 8, 9, 10, 11, 12, 13, 14, 15)

__attribute__((target("avx512f"), optimize("fp-contract=off"))) static float
density_free16(const hbk_fluid_cells_t *c, const float *soa, size_t stride, int32_t cx,
               int32_t cy, int32_t cz, int32_t i, const float xi[3], float H, int32_t *list,
               int32_t *nlist)
{
    const float *X = soa, *Y = soa + stride, *Z = soa + 2 * stride;
    const v16f zero = {0}, x = zero + xi[0], y = zero + xi[1], z = zero + xi[2];
    const v16f h = zero + H, h2 = zero + H * H;
    const v16i lane = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
    v8f part = {0, 0, 0, 0, 0, 0, 0, 0};
    int32_t n = 0;
    HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a, e, {
        for (int32_t j = a; j < e; j += 16) { /* reads up to 15 past the row: in the padding
                                                * or the next array, and masked */
            const v16f dx = x - load16(X + j), dy = y - load16(Y + j), dz = z - load16(Z + j);
            const v16f r2 = dx * dx + dy * dy + dz * dz;
            const v16i near = (lane + j < e) & (r2 < h2);
            const v16f q = h - SQRT16(r2), q3 = q * q * q;
            const v16f add = (v16f)((v16i)q3 & near);
            part += LO8(add);
            part += HI8(add);
            if (n <= HBK_FLUID_NBR_CAP - 16) {
                const unsigned mk = MASK16(near & (lane + j != i));
                /* packed in a register and stored whole (n <= CAP - 16: in the list's room);
                 * the masked compress to memory made this function 4% slower */
                const v16i packed = __builtin_ia32_compresssi512_mask(lane + j, lane + j,
                                                                      (unsigned short)mk);
                __builtin_memcpy(list + n, &packed, sizeof packed);
                n += __builtin_popcount(mk);
            } else n = HBK_FLUID_NBR_CAP; /* too many: the forces find them again */
        }
    })
    *nlist = n < HBK_FLUID_NBR_CAP ? n : -1;
    float p[8];
    __builtin_memcpy(p, &part, sizeof p);
    const float sum = hbk_fluid_lane_sum(p);
    __builtin_ia32_vzeroupper();
    return sum;
}

/* TERMS8 on sixteen pairs: two transposed groups of eight records, each mirrored by its
 * lane's image (WALLS: a permutation of a 16-entry table, so up to 15 images). */
__attribute__((target("avx512f"), optimize("fp-contract=off"))) static inline
__attribute__((always_inline)) void
forces16_body(const float *rec8, const int32_t *list, int32_t nlist, int32_t i,
              const float xi[8], float H, float m, float spiky, float visc, const int WALLS,
              int nim, const float (*sgn)[3], const float (*off)[3], float ap[3], float fv[3])
{
    const v16f zero = {0}, x = zero + xi[0], y = zero + xi[1], z = zero + xi[2];
    const v16f vx = zero + xi[3], vy = zero + xi[4], vz = zero + xi[5], pi = zero + xi[7];
    const v16f h = zero + H, tiny = zero + 1e-9f * H;
    const v16f vm = zero + m, vs = zero + spiky, vv = zero + visc, one = zero + 1.0f;
    const v16i lane = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
    v16f tsg[3] = {one, one, one}, tof[3] = {zero, zero, zero}; /* per image (0: itself) */
    if (WALLS)
        for (int a = 0; a < 3; ++a)
            for (int im = 1; im <= nim; ++im) {
                tsg[a][im] = sgn[im - 1][a];
                tof[a][im] = off[im - 1][a];
            }
    v8f part[6];
    for (int q6 = 0; q6 < 6; ++q6) part[q6] = (v8f){0, 0, 0, 0, 0, 0, 0, 0};
    for (int32_t k = 0; k < nlist; k += 16) {
        const int32_t n = nlist - k;
        v8f A[8], B[8];
        v16f F[8], sg[3] = {one, one, one}, of[3] = {zero, zero, zero};
        RECORDS(A, list + k, n);
        RECORDS(B, list + k + 8, n - 8);
        for (int f = 0; f < 8; ++f)
            F[f] = __builtin_shufflevector(A[f], B[f], 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12,
                                           13, 14, 15);
        if (WALLS) {
            v16i im;
            for (int q = 0; q < 16; ++q) im[q] = q < n ? list[k + q] >> IMG_SHIFT : 0;
            for (int a = 0; a < 3; ++a) {
                sg[a] = __builtin_ia32_permvarsf512_mask(tsg[a], im, zero, (unsigned short)-1);
                of[a] = __builtin_ia32_permvarsf512_mask(tof[a], im, zero, (unsigned short)-1);
            }
        }
        const v16i act = lane < n;
        const v16f dx = x - (sg[0] * F[0] + of[0]), dy = y - (sg[1] * F[1] + of[1]),
                   dz = z - (sg[2] * F[2] + of[2]);
        const v16f r2 = dx * dx + dy * dy + dz * dz;
        const v16f rr = SQRT16(r2), q = h - rr;
        const v16i push = act & (rr > tiny);
        const v16f f = vm * (pi + F[7]) * vs * q * q / rr;
        const v16f w = vm / F[6] * vv * q;
        const v16f t6[6] = {f * dx, f * dy, f * dz, w * (sg[0] * F[3] - vx),
                            w * (sg[1] * F[4] - vy), w * (sg[2] * F[5] - vz)};
        for (int q6 = 0; q6 < 6; ++q6) {
            const v16f t = (v16f)((v16i)t6[q6] & (q6 < 3 ? push : act));
            part[q6] += LO8(t);
            part[q6] += HI8(t);
        }
    }
    for (int q6 = 0; q6 < 6; ++q6) {
        float p[8];
        __builtin_memcpy(p, &part[q6], sizeof p);
        (q6 < 3 ? ap : fv)[q6 % 3] = hbk_fluid_lane_sum(p);
    }
    __builtin_ia32_vzeroupper();
}

__attribute__((target("avx512f"), optimize("fp-contract=off"))) static void
forces16(const float *rec8, const int32_t *list, int32_t nlist, int32_t i, const float xi[8],
         float H, float m, float spiky, float visc, int nim, const float (*sgn)[3],
         const float (*off)[3], float ap[3], float fv[3])
{
    if (nim) forces16_body(rec8, list, nlist, i, xi, H, m, spiky, visc, 1, nim, sgn, off, ap, fv);
    else forces16_body(rec8, list, nlist, i, xi, H, m, spiky, visc, 0, 0, sgn, off, ap, fv);
}

/* Images: 0 is the neighbour itself; 1 .. nim its mirror images across the walls (sgn * x +
 * off per axis), in the scalar loop's order. */

__attribute__((target("avx2"))) float
hbk_fluid_density_lanes(int lanes, const hbk_fluid_cells_t *c, const float *soa,
                        const float *rec8, size_t stride, int32_t cx, int32_t cy, int32_t cz,
                        int32_t i, const float xi[3], float H,
                        int nim, const float (*sgn)[3], const float (*off)[3], int32_t *list,
                        int32_t *nlist)
{
    if (lanes == 16 && !nim)
        return density_free16(c, soa, stride, cx, cy, cz, i, xi, H, list, nlist);
    const float *X = soa, *Y = soa + stride, *Z = soa + 2 * stride;
    const v8f zero = {0}, x = zero + xi[0], y = zero + xi[1], z = zero + xi[2];
    const v8f h = zero + H, h2 = zero + H * H;
    const v8i lane = {0, 1, 2, 3, 4, 5, 6, 7};
    v8f part = zero, *const sum8 = &part;
    int32_t n = 0;
    if (!nim) { /* away from the walls: no branch on empty groups (a mispredicted one cost more
                 * than the square roots) */
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
    } else
        HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a, e, {
            for (int32_t j = a; j < e; j += 8) SCAN8(j, e, list, n, 1, (void)0, sum8);
        })
    *nlist = n < HBK_FLUID_NBR_CAP ? n : -1;
    float p[8];
    __builtin_memcpy(p, &part, sizeof p);
    const float sum = hbk_fluid_lane_sum(p);
    __builtin_ia32_vzeroupper(); /* the caller is SSE code */
    return sum;
}

/* Per lane, table T's entry for axis a of the lane's image: a permutation within one vector
 * for up to 7 images (one or two walls near, or three), a gather for more (a box narrower
 * than two smoothing lengths). */
#define PICK(T, a, ID, W)                                                                    \
    (!(W) ? (ID)                                                                             \
     : nim < 8 ? __builtin_ia32_permvarsf256(load8(T[a]), im_)                               \
               : __builtin_ia32_gathersiv8sf(zero, T[a], im_, (v8f)(lane == lane), 4))

/* The forces' terms of pairs idx[0 .. n - 1], lane by lane, with the scalar code's
 * operations: each record mirrored by its lane's image, sg * x + of (1 * x + 0 for the
 * neighbour itself, signed zeros included). */
#define TERMS8(idx, n, WALLS)                                                                \
    do {                                                                                     \
        v8f F[8];                                                                            \
        RECORDS(F, idx, n);                                                                  \
        v8i im_;                                                                             \
        HBK_UNROLL8 for (int q_ = 0; q_ < 8; ++q_)                                           \
            im_[q_] = q_ < (n) ? (idx)[q_] >> IMG_SHIFT : 0;                                 \
        const v8f sx = PICK(tsg, 0, one, WALLS), sy = PICK(tsg, 1, one, WALLS),              \
                  sz = PICK(tsg, 2, one, WALLS);                                             \
        const v8i act = lane < (n);                                                          \
        const v8f dx = x - (sx * F[0] + PICK(tof, 0, zero, WALLS)),                          \
                  dy = y - (sy * F[1] + PICK(tof, 1, zero, WALLS)),                          \
                  dz = z - (sz * F[2] + PICK(tof, 2, zero, WALLS));                          \
        const v8f r2 = dx * dx + dy * dy + dz * dz;                                          \
        const v8f rr = __builtin_ia32_sqrtps256(r2), q = h - rr;                             \
        const v8i push = act & (rr > tiny);                                                  \
        const v8f f = vm * (pi + F[7]) * vs * q * q / rr;                                    \
        const v8f w = vm / F[6] * vv * q;                                                    \
        const v8f t6[6] = {f * dx, f * dy, f * dz, w * (sx * F[3] - vx),                     \
                           w * (sy * F[4] - vy), w * (sz * F[5] - vz)};                      \
        HBK_UNROLL8 for (int q6 = 0; q6 < 6; ++q6)                                           \
            part[q6] += (v8f)((v8i)t6[q6] & (q6 < 3 ? push : act));                          \
    } while (0)
#define TERMS8_FREE(idx, n) TERMS8(idx, n, 0)
#define TERMS8_WALLS(idx, n) TERMS8(idx, n, 1)

__attribute__((target("avx2"))) void
hbk_fluid_forces_lanes(int lanes, const hbk_fluid_cells_t *c, const float *soa,
                       const float *rec8, const int32_t *list, int32_t nlist, size_t stride,
                       int32_t cx, int32_t cy, int32_t cz, int32_t i, const float xi[8],
                       float H, float m, float spiky, float visc, int nim,
                       const float (*sgn)[3], const float (*off)[3], float ap[3], float fv[3])
{
    if (lanes == 16 && nim < 16 && nlist >= 0) {
        forces16(rec8, list, nlist, i, xi, H, m, spiky, visc, nim, sgn, off, ap, fv);
        return;
    }
    const float *X = soa, *Y = soa + stride, *Z = soa + 2 * stride;
    const v8f zero = {0}, x = zero + xi[0], y = zero + xi[1], z = zero + xi[2];
    const v8f vx = zero + xi[3], vy = zero + xi[4], vz = zero + xi[5], pi = zero + xi[7];
    const v8f h = zero + H, h2 = zero + H * H, tiny = zero + 1e-9f * H;
    const v8f vm = zero + m, vs = zero + spiky, vv = zero + visc, one = zero + 1.0f;
    const v8i lane = {0, 1, 2, 3, 4, 5, 6, 7};
    v8f part[6] = {zero, zero, zero, zero, zero, zero};
    float tsg[3][27], tof[3][27]; /* per axis, per image (0: the neighbour itself): sg, of */
    if (!nim) {
        FOR_PACKED(list, nlist, TERMS8_FREE);
    } else {
        const int nt = nim < 8 ? 8 : 27;
        for (int a = 0; a < 3; ++a)
            for (int im = 0; im < nt; ++im) {
                tsg[a][im] = im == 0 ? 1.0f : im <= nim ? sgn[im - 1][a] : 0.0f;
                tof[a][im] = im == 0 || im > nim ? 0.0f : off[im - 1][a];
            }
        FOR_PACKED(list, nlist, TERMS8_WALLS);
    }
    for (int q6 = 0; q6 < 6; ++q6) {
        float p[8];
        __builtin_memcpy(p, &part[q6], sizeof p);
        (q6 < 3 ? ap : fv)[q6 % 3] = hbk_fluid_lane_sum(p);
    }
    __builtin_ia32_vzeroupper();
}
