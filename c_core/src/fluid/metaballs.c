/* Particles to grid: SPH density, Shepard-averaged velocity (V_m before clamping) and the
 * metaball sum of the surface, at the grid vertices. The density is the Shepard weight sum
 * times a constant (both use poly6), and when the metaball radius is the smoothing length so
 * is the metaball sum ((1 - r^2/R^2)^3 = (R^2 - r^2)^3 / R^6): the splat then adds four sums
 * per vertex, not six, and the normalisation derives the others. */
#include "internal_fluid.h"
#include <omp.h>
#include <string.h>

typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));

typedef struct {
    float *wsum, *surf, *mot[3]; /* vertex sums; motion as three planes */
    float H2, R2, inv_R2;
    int own_surf;                /* the metaball sum is splatted (R != H), not derived */
    int32_t *ylo, *yhi;          /* per vertex layer: the rows the sums may be non-zero in */
    const float *xv;             /* particles in cell order: x, y, z, vx, vy, vz (8 floats) */
} splat_t;

/* Adds particle (x, v) to vertices [a0, a1] of one row (at `row`), whose offsets from the
 * particle are dx = lo + kx cl - x and ryz. */
static inline __attribute__((always_inline)) void
splat_row(const splat_t *s, size_t row, int32_t a0, int32_t a1, float lo, float cl,
          const float *x, const float *v, float ryz)
{
    for (int32_t kx = a0; kx <= a1; ++kx) {
        const float dx = lo + (float)kx * cl - x[0];
        const float r2 = dx * dx + ryz;
        const size_t vi = row + (size_t)kx;
        if (r2 < s->H2) {
            const float d = s->H2 - r2, w = d * d * d;
            s->wsum[vi] += w;
            s->mot[0][vi] += w * v[0];
            s->mot[1][vi] += w * v[1];
            s->mot[2][vi] += w * v[2];
        }
        if (s->own_surf && r2 < s->R2) {
            const float t = 1.0f - r2 * s->inv_R2;
            s->surf[vi] += t * t * t;
        }
    }
}

/* The vertices [a0, a1] per axis within S of the particle at x, z clipped to the chunk's slab
 * [z0, z1). */
static inline void reach(const hbk_fluid_t *h, const float *x, float S, int32_t z0, int32_t z1,
                         int32_t a0[3], int32_t a1[3])
{
    const float *lo = h->p.box_min, *ic = h->inv_cell;
    for (int a = 0; a < 3; ++a) {
        a0[a] = (int32_t)ceilf((x[a] - S - lo[a]) * ic[a]);
        a1[a] = (int32_t)floorf((x[a] + S - lo[a]) * ic[a]);
        if (a0[a] < 0) a0[a] = 0;
        if (a1[a] > h->nv[a] - 1) a1[a] = h->nv[a] - 1;
    }
    if (a0[2] < z0) a0[2] = z0;
    if (a1[2] > z1 - 1) a1[2] = z1 - 1;
}

/* Widens the layers' row ranges to the particle's reach (a0, a1). */
static inline void mark_rows(const splat_t *s, const int32_t a0[3], const int32_t a1[3])
{
    for (int32_t kz = a0[2]; kz <= a1[2]; ++kz) {
        if (a0[1] < s->ylo[kz]) s->ylo[kz] = a0[1];
        if (a1[1] > s->yhi[kz]) s->yhi[kz] = a1[1];
    }
}

/* One chunk: vertex z-slab [z0, z1), from the particles (sorted) p0 .. p1 - 1. */
static void splat_chunk_sse(const hbk_fluid_t *h, const splat_t *s, int32_t z0, int32_t z1,
                            int32_t p0, int32_t p1, float S)
{
    const hbk_fluid_cells_t *c = &h->cells;
    const int32_t nx = h->nv[0], ny = h->nv[1];
    const float *lo = h->p.box_min, *cl = h->cell;
    for (int32_t k = p0; k < p1; ++k) {
        const int32_t id = c->order[k];
        const float *x = h->pos + 3 * (size_t)id, *v = h->vel + 3 * (size_t)id;
        int32_t a0[3], a1[3];
        reach(h, x, S, z0, z1, a0, a1);
        mark_rows(s, a0, a1);
        for (int32_t kz = a0[2]; kz <= a1[2]; ++kz) {
            const float dz = lo[2] + (float)kz * cl[2] - x[2];
            for (int32_t ky = a0[1]; ky <= a1[1]; ++ky) {
                const float dy = lo[1] + (float)ky * cl[1] - x[1];
                const float ryz = dy * dy + dz * dz;
                if (ryz >= s->H2 && (!s->own_surf || ryz >= s->R2)) continue;
                const size_t row = (size_t)nx * ((size_t)ky + (size_t)ny * (size_t)kz);
                splat_row(s, row, a0[0], a1[0], lo[0], cl[0], x, v, ryz);
            }
        }
    }
}

enum { SLAB = 4 }; /* vertex layers a chunk of the splat owns */

/* One particle's rows in reach within a slab, for the vector splats: its x offsets squared
 * (eight lanes a block, nb blocks), which lanes are in reach, and the rows listed (vertex
 * offset of the first lane, dy^2 + dz^2). Listed first, so that the loop over them has no
 * branch: tested row by row, which rows are out of reach changes with every particle. */
typedef struct {
    v8f dx2[2];
    v8i inx[2];
    int full[2], nb, n;
    int32_t at[SLAB * 16 + 16];
    float ryz[SLAB * 16 + 16];
} rows_t;

/* What list_rows found: the particle is out of reach of the slab in x; its rows are listed;
 * or the plain splat must take it (a reach over 16 vertices, coarse particles on a fine grid,
 * or a NaN position). */
enum { ROWS_NONE, ROWS_LISTED, ROWS_PLAIN };

/* Lists particle x's rows (splat_row's operations, eight lanes at a time; T: the larger radius
 * squared). */
__attribute__((target("avx2"))) static inline __attribute__((always_inline)) int
list_rows(const hbk_fluid_t *h, const splat_t *s, const float *x, int32_t z0, int32_t z1,
          float S, float T, rows_t *r)
{
    const int32_t nx = h->nv[0], ny = h->nv[1];
    const float *lo = h->p.box_min, *cl = h->cell;
    const v8f zero = {0}, inf = zero + __builtin_inff(), Tv = zero + T;
    const v8i lane = {0, 1, 2, 3, 4, 5, 6, 7};
    int32_t a0[3], a1[3];
    reach(h, x, S, z0, z1, a0, a1);
    if (a0[0] > a1[0]) return ROWS_NONE;
    mark_rows(s, a0, a1);
    const int nb = r->nb = (a1[0] - a0[0]) / 8 + 1;
    if (nb > 2 || a1[1] - a0[1] >= 16) return ROWS_PLAIN;
    for (int b = 0; b < nb; ++b) {
        const int32_t kx = a0[0] + 8 * b;
        const v8f kk = __builtin_convertvector(lane + kx, v8f);
        const v8f dx = (zero + lo[0]) + kk * cl[0] - x[0];
        r->dx2[b] = dx * dx;
        r->inx[b] = lane + kx <= a1[0];
        r->full[b] = kx + 8 <= nx;
    }
    /* dy^2 per row of the reach; +inf past it (and past the sixteen a reach may have), so
     * that those rows are never in reach */
    v8f dy2[4];
    for (int q = 0; q < 2; ++q) {
        const v8i ky = lane + (a0[1] + 8 * q);
        const v8f dy = (zero + lo[1]) + __builtin_convertvector(ky, v8f) * cl[1] - x[1];
        const v8i in = ky <= a1[1];
        dy2[q] = (v8f)(((v8i)(dy * dy) & in) | ((v8i)inf & ~in));
        dy2[q + 2] = inf;
    }
    /* A layer's rows within reach are one run (dy^2 falls, then rises, also when rounded),
     * found by two compares; a NaN breaks the run. */
    const float *d2 = (const float *)dy2;
    int n = 0, runs = 1;
    for (int32_t kz = a0[2]; kz <= a1[2]; ++kz) {
        const float dz = lo[2] + (float)kz * cl[2] - x[2], dz2 = dz * dz;
        const unsigned out = (unsigned)__builtin_ia32_movmskps256((v8f)(dy2[0] + dz2 >= Tv)) |
                             (unsigned)__builtin_ia32_movmskps256((v8f)(dy2[1] + dz2 >= Tv)) << 8;
        const unsigned in = ~out & 0xffffu, first = in ? (unsigned)__builtin_ctz(in) : 0u;
        runs &= ((in >> first) & ((in >> first) + 1u)) == 0u;
        v8f q0, q1;
        memcpy(&q0, d2 + first, sizeof q0);
        memcpy(&q1, d2 + first + 8, sizeof q1);
        q0 += dz2;
        q1 += dz2;
        memcpy(r->ryz + n, &q0, sizeof q0);
        memcpy(r->ryz + n + 8, &q1, sizeof q1);
        const v8i o0 = nx * (a0[1] + (int32_t)first + ny * kz) + a0[0] + lane * nx;
        const v8i o1 = o0 + 8 * nx;
        memcpy(r->at + n, &o0, sizeof o0);
        memcpy(r->at + n + 8, &o1, sizeof o1);
        n += __builtin_popcount(in);
    }
    r->n = n;
    return runs ? ROWS_LISTED : ROWS_PLAIN;
}

/* splat_chunk_sse eight vertices of a row at a time, each lane with splat_row's operations
 * (a vertex out of reach is not changed: the same bytes). Away from a row's end, lanes out of
 * reach add +0 (a sum is never -0, so adding +0 keeps its bits) with plain loads and stores,
 * far cheaper than masked stores; within 8 of the end, where lanes would reach the next row
 * (perhaps another thread's slab), the stores are masked. OWN: the metaball sum is splatted
 * too. */
#define SPLAT_ADD(p, add, m)                                                                 \
    do {                                                                                     \
        if (r->full[b]) {                                                                    \
            v8f o_;                                                                          \
            memcpy(&o_, (p), sizeof o_);                                                     \
            o_ += (v8f)((v8i)(add) & (m));                                                   \
            memcpy((p), &o_, sizeof o_);                                                     \
        } else {                                                                             \
            const v8f o_ = __builtin_ia32_maskloadps256((const v8f *)(p), (m));              \
            __builtin_ia32_maskstoreps256((v8f *)(p), (m), o_ + (add));                      \
        }                                                                                    \
    } while (0)

/* The listed rows of a particle (v: its velocity), eight lanes at a time. */
__attribute__((target("avx2"))) static inline __attribute__((always_inline)) void
rows8(const splat_t *s, const rows_t *r, const float *v, const int OWN)
{
    const v8f zero = {0}, H2 = zero + s->H2, R2 = zero + s->R2, one = zero + 1.0f;
    const v8f iR2 = zero + s->inv_R2, v0 = zero + v[0], v1 = zero + v[1], v2 = zero + v[2];
    /* locals: through s the compiler would reload every pointer per row */
    float *const ws = s->wsum, *const m0 = s->mot[0], *const m1 = s->mot[1];
    float *const m2 = s->mot[2], *const sf = s->surf;
    for (int e = 0; e < r->n; ++e)
        for (int b = 0; b < r->nb; ++b) {
            const size_t at = (size_t)r->at[e] + 8 * (size_t)b;
            const v8f r2 = r->dx2[b] + r->ryz[e];
            const v8i mh = r->inx[b] & (r2 < H2);
            const v8f d = H2 - r2, w = d * d * d;
            SPLAT_ADD(ws + at, w, mh);
            SPLAT_ADD(m0 + at, w * v0, mh);
            SPLAT_ADD(m1 + at, w * v1, mh);
            SPLAT_ADD(m2 + at, w * v2, mh);
            if (OWN) {
                const v8i mr = r->inx[b] & (r2 < R2);
                const v8f t = one - r2 * iR2;
                SPLAT_ADD(sf + at, t * t * t, mr);
            }
        }
}
#undef SPLAT_ADD

__attribute__((target("avx2"))) static inline __attribute__((always_inline)) void
splat_avx2(const hbk_fluid_t *h, const splat_t *s, int32_t z0, int32_t z1, int32_t p0,
           int32_t p1, float S, const int OWN)
{
    const float T = OWN && s->R2 > s->H2 ? s->R2 : s->H2;
    rows_t r;
    for (int32_t k = p0; k < p1; ++k) {
        const float *x = s->xv + 8 * (size_t)k; /* read in order, not by id */
        const int how = list_rows(h, s, x, z0, z1, S, T, &r);
        if (how == ROWS_LISTED) rows8(s, &r, x + 3, OWN);
        else if (how == ROWS_PLAIN) splat_chunk_sse(h, s, z0, z1, k, k + 1, S);
    }
}

__attribute__((target("avx2"))) static void
splat_chunk_avx2(const hbk_fluid_t *h, const splat_t *s, int32_t z0, int32_t z1, int32_t p0,
                 int32_t p1, float S)
{
    if (s->own_surf) splat_avx2(h, s, z0, z1, p0, p1, S, 1);
    else splat_avx2(h, s, z0, z1, p0, p1, S, 0);
    __builtin_ia32_vzeroupper(); /* the caller is SSE code */
}

/* The Shepard normalisation's four-vertex loop below, eight vertices at a time from i0 while
 * they fit before i1 (returns where it stopped): the same operations per lane, V_m written
 * interleaved by permutes instead of 24 scalar stores, and the pointers in locals (through h
 * every store made the compiler load them again). */
__attribute__((target("avx2"))) static size_t normalise8(const hbk_fluid_t *h, size_t i0, size_t i1,
                                                         float dens_k, float surf_k, float vmax,
                                                         int own_surf)
{
    const float *const ws = h->g_wsum;
    float *const dn = h->g_density, *const sf = h->g_surface, *const gm = h->g_motion;
    float *const mp[3] = {h->g_mp[0], h->g_mp[1], h->g_mp[2]};
    const v8f zero = {0}, vm = zero + vmax, vm2 = zero + vmax * vmax;
    size_t i = i0;
    for (; i + 8 <= i1; i += 8) {
        v8f w, v[3];
        memcpy(&w, ws + i, sizeof w);
        const v8f dens = dens_k * w, surf = surf_k * w;
        memcpy(dn + i, &dens, sizeof dens);
        if (!own_surf) memcpy(sf + i, &surf, sizeof surf);
        const v8i pos = w > zero;
        for (int a = 0; a < 3; ++a) {
            v8f sum;
            memcpy(&sum, mp[a] + i, sizeof sum);
            v[a] = (v8f)(((v8i)(sum / w) & pos) | ((v8i)sum & ~pos));
        }
        const v8f s2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        const v8i over = s2 > vm2;
        if (__builtin_ia32_movmskps256((v8f)over)) {
            const v8f f = vm / __builtin_ia32_sqrtps256(s2);
            for (int a = 0; a < 3; ++a)
                v[a] = (v8f)(((v8i)(v[a] * f) & over) | ((v8i)v[a] & ~over));
        }
        for (int a = 0; a < 3; ++a) memcpy(mp[a] + i, &v[a], sizeof v[a]);
        /* x y z of eight vertices into 24 interleaved floats */
        const v8f lo = __builtin_shufflevector(v[0], v[1], 0, 8, 1, 9, 2, 10, 3, 11);
        const v8f hi = __builtin_shufflevector(v[0], v[1], 4, 12, 5, 13, 6, 14, 7, 15);
        const v8f mid = __builtin_shufflevector(lo, hi, 6, 7, 8, 9, 10, 11, 12, 13);
        const v8f o0 = __builtin_shufflevector(lo, v[2], 0, 1, 8, 2, 3, 9, 4, 5);
        const v8f o1 = __builtin_shufflevector(mid, v[2], 10, 0, 1, 11, 2, 3, 12, 4);
        const v8f o2 = __builtin_shufflevector(hi, v[2], 3, 13, 4, 5, 14, 6, 7, 15);
        memcpy(gm + 3 * i, &o0, sizeof o0);
        memcpy(gm + 3 * i + 8, &o1, sizeof o1);
        memcpy(gm + 3 * i + 16, &o2, sizeof o2);
    }
    __builtin_ia32_vzeroupper(); /* the caller is SSE code */
    return i;
}

/* Scatter by owner: vertex z-slabs are chunks of the loop; each chunk walks the particles
 * whose support reaches it (by rows of cells: y, then z, then x) and adds to its own vertices
 * only, so every vertex sums its particles in one fixed order, whatever thread runs the chunk
 * and however thick the slabs. The motion sums go to three planes (g_mp), so that eight
 * vertices of a row are eight floats in a row; the Shepard normalisation writes them back
 * interleaved. */
hbk_result_t hbk_fluid_particles_to_grid(hbk_fluid_t *h, int threads)
{
    const size_t nv = h->n_vert;
    const float H = h->p.smoothing_length, R = h->p.metaball_radius;
    const int own_surf = R != H;
    const int32_t n = h->count;
    const int32_t nx = h->nv[0], ny = h->nv[1], nz = h->nv[2];
    if (n == 0 || own_surf) memset(h->g_surface, 0, nv * sizeof(float));
    if (n == 0) {
        for (int a = 0; a < 3; ++a) memset(h->g_mp[a], 0, nv * sizeof(float));
        memset(h->g_wsum, 0, nv * sizeof(float));
        memset(h->g_density, 0, nv * sizeof(float));
        memset(h->g_motion, 0, 3 * nv * sizeof(float));
        hbk_fluid_splat_rows(h, 0);
        memset(h->g_blank, 1, h->n_rows);
        return HBK_OK;
    }
    const float S = H > R ? H : R;
    hbk_fluid_cells_t *c = &h->cells;
    hbk_result_t r = hbk_fluid_cells_build(c, h->pos, n, h->p.box_min, h->p.box_max, S, threads);
    if (r) return r;
    /* The particles in cell order, for the splat to read them in turn: through the order a
     * particle's position was a cache miss, a tenth of the splat, and each is read by about
     * three slabs. */
    float *const xv = h->sorted;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t k = 0; k < n; ++k) {
        const int32_t id = c->order[k];
        memcpy(xv + 8 * (size_t)k, h->pos + 3 * (size_t)id, 3 * sizeof(float));
        memcpy(xv + 8 * (size_t)k + 3, h->vel + 3 * (size_t)id, 3 * sizeof(float));
    }
    const splat_t s = {h->g_wsum, h->g_surface,
                       {h->g_mp[0], h->g_mp[1], h->g_mp[2]},
                       H * H, R * R, 1.0f / (R * R), own_surf,
                       h->splat_ylo, h->splat_yhi, xv};
    const float dens_k = (float)(h->mass * 315.0 / (64.0 * M_PI * pow(H, 9)));
    const float surf_k = (float)(1.0 / pow(R, 6));
    const float *lo = h->p.box_min, *cl = h->cell;
    const int32_t chunks = (nz + SLAB - 1) / SLAB;
    const int avx2 = hbk_paths() >= HBK_PATHS_AVX2;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (int32_t ch = 0; ch < chunks; ++ch) {
        const int32_t z0 = ch * SLAB, z1 = z0 + SLAB < nz ? z0 + SLAB : nz; /* [z0, z1) */
        const float wz0 = lo[2] + (float)z0 * cl[2] - S, wz1 = lo[2] + (float)(z1 - 1) * cl[2] + S;
        const int32_t c0 = hbk_fluid_cell_coord(c, wz0, 2), c1 = hbk_fluid_cell_coord(c, wz1, 2);
        /* Zero the sums where last frame's splat left them (not the whole grid, most of which
         * no particle reaches), then forget the rows. */
        for (int32_t kz = z0; kz < z1; ++kz) {
            const int32_t y0 = s.ylo[kz], y1 = s.yhi[kz];
            if (y0 > y1) continue;
            const size_t at = (size_t)nx * ((size_t)y0 + (size_t)ny * (size_t)kz);
            const size_t len = (size_t)nx * (size_t)(y1 - y0 + 1) * sizeof(float);
            memset(s.wsum + at, 0, len);
            for (int a = 0; a < 3; ++a) memset(s.mot[a] + at, 0, len);
            s.ylo[kz] = INT32_MAX;
            s.yhi[kz] = -1;
        }
        /* The particles a row of cells at a time (the rows of one y across the slab's cell
         * layers, then the next y): what they touch then fits in L2. Cell layer by cell layer,
         * each layer swept the slab's whole 1 MB of sums, from L3 (15% of the fields on two
         * cores). */
        for (int32_t cy = 0; cy < c->dims[1]; ++cy)
            for (int32_t cz = c0; cz <= c1; ++cz) {
                const size_t r0 = (size_t)c->dims[0] * ((size_t)cy + (size_t)c->dims[1] * (size_t)cz);
                const int32_t p0 = c->start[r0], p1 = c->start[r0 + (size_t)c->dims[0]];
                if (p0 < p1) (avx2 ? splat_chunk_avx2 : splat_chunk_sse)(h, &s, z0, z1, p0, p1, S);
            }
    }
    /* Shepard-normalised velocity, clamped (hbk_fluid_put_motion's operations, four vertices
     * at a time: a scalar loop with its divisions and the clamp's branch cost a fifth of the
     * fields); the density and (R = H) the metaball sum. By rows: a row no particle reached
     * is all +0, and is not written again where these buffers hold it so already. */
    const float vmax = hbk_fluid_vmax(h);
    const int32_t rows = ny * nz;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t r = 0; r < rows; ++r) {
        const int32_t j = r % ny, k = r / ny;
        const size_t i0 = (size_t)r * (size_t)nx, i1 = i0 + (size_t)nx;
        if (j < s.ylo[k] || j > s.yhi[k]) {
            if (h->g_blank[r]) continue;
            memset(h->g_density + i0, 0, (size_t)nx * sizeof(float));
            if (!own_surf) memset(h->g_surface + i0, 0, (size_t)nx * sizeof(float));
            memset(h->g_motion + 3 * i0, 0, 3 * (size_t)nx * sizeof(float));
            h->g_blank[r] = 1;
            continue;
        }
        h->g_blank[r] = 0;
        size_t i = avx2 ? normalise8(h, i0, i1, dens_k, surf_k, vmax, own_surf) : i0;
        for (; i + 4 <= i1; i += 4) {
            hbk_v4f w, v[3];
            memcpy(&w, h->g_wsum + i, sizeof w);
            const hbk_v4f zero = {0}, dens = dens_k * w, surf = surf_k * w;
            memcpy(h->g_density + i, &dens, sizeof dens);
            if (!own_surf) memcpy(h->g_surface + i, &surf, sizeof surf);
            const hbk_v4i pos = w > zero;
            for (int a = 0; a < 3; ++a) {
                hbk_v4f sum;
                memcpy(&sum, h->g_mp[a] + i, sizeof sum);
                v[a] = (hbk_v4f)(((hbk_v4i)(sum / w) & pos) | ((hbk_v4i)sum & ~pos));
            }
            const hbk_v4f s2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            const hbk_v4i over = s2 > vmax * vmax;
            if (__builtin_ia32_movmskps((hbk_v4f)over)) {
                const hbk_v4f f = vmax / __builtin_ia32_sqrtps(s2);
                for (int a = 0; a < 3; ++a)
                    v[a] = (hbk_v4f)(((hbk_v4i)(v[a] * f) & over) | ((hbk_v4i)v[a] & ~over));
            }
            for (int a = 0; a < 3; ++a) {
                memcpy(h->g_mp[a] + i, &v[a], sizeof v[a]);
                for (int l = 0; l < 4; ++l) h->g_motion[3 * (i + (size_t)l) + (size_t)a] = v[a][l];
            }
        }
        for (; i < i1; ++i) {
            const float w = h->g_wsum[i];
            h->g_density[i] = dens_k * w;
            if (!own_surf) h->g_surface[i] = surf_k * w;
            float v[3];
            for (int a = 0; a < 3; ++a) {
                const float sum = h->g_mp[a][i];
                v[a] = w > 0.0f ? sum / w : sum;
            }
            hbk_fluid_put_motion(h, i, v, vmax);
        }
    }
    return HBK_OK;
}
