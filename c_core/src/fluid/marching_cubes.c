/* Surface extraction: marching cubes, with a table built from the cube faces so that an
 * ambiguous face is cut alike from both of its cubes and the mesh is closed. The grid is padded
 * with one layer of empty vertices all round, so blobs touching the box are capped.
 *
 * Three passes, each parallel over z layers and each writing only its own slots, so the mesh
 * is the same bytes for any thread count: (1) mark crossing axis edges per padded vertex and
 * keep each cube's configuration, (2) number and place the edge vertices, (3) count, number
 * and write the triangles. */
#include "internal_fluid.h"
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* Edge direction d (1, 2, 4) is the offset (d & 1, d >> 1 & 1, d >> 2 & 1); bit d-1 of a mask. */
typedef struct mc {
    const hbk_fluid_t *h;
    int32_t e[3];      /* padded vertices per axis */
    float iso;
} mc_t;

static inline float val(const mc_t *m, int32_t i, int32_t j, int32_t k)
{
    if (i <= 0 || j <= 0 || k <= 0 || i >= m->e[0] - 1 || j >= m->e[1] - 1 || k >= m->e[2] - 1)
        return 0.0f;
    const hbk_fluid_t *h = m->h;
    return h->surface[(size_t)(i - 1) + (size_t)h->nv[0] * ((size_t)(j - 1) + (size_t)h->nv[1] * (size_t)(k - 1))];
}
static inline int inside(const mc_t *m, int32_t i, int32_t j, int32_t k)
{
    return val(m, i, j, k) > m->iso;
}
typedef uint8_t v16u __attribute__((vector_size(16)));

/* Bits set in an 8-bit mask (__builtin_popcount is a library call without -mpopcnt). */
static inline int pop8(unsigned x)
{
    x = x - ((x >> 1) & 0x55u);
    x = (x & 0x33u) + ((x >> 2) & 0x33u);
    return (int)((x + (x >> 4)) & 0x0fu);
}

static inline size_t pidx(const mc_t *m, int32_t i, int32_t j, int32_t k)
{
    return (size_t)i + (size_t)m->e[0] * ((size_t)j + (size_t)m->e[1] * (size_t)k);
}

/* Gradient of the field (per voxel unit) at padded vertex (i, j, k), central differences. */
static void grad(const mc_t *m, int32_t i, int32_t j, int32_t k, float g[3])
{
    g[0] = 0.5f * (val(m, i + 1, j, k) - val(m, i - 1, j, k)) * m->h->inv_cell[0];
    g[1] = 0.5f * (val(m, i, j + 1, k) - val(m, i, j - 1, k)) * m->h->inv_cell[1];
    g[2] = 0.5f * (val(m, i, j, k + 1) - val(m, i, j, k - 1)) * m->h->inv_cell[2];
}

/* grad at the field value f of a vertex whose six neighbours are all in the grid (strides s):
 * the same floats, without val's border tests. */
static inline void grad_in(const mc_t *m, const float *f, const size_t s[3], float g[3])
{
    for (int a = 0; a < 3; ++a) g[a] = 0.5f * (f[s[a]] - f[-(ptrdiff_t)s[a]]) * m->h->inv_cell[a];
}

/* Crossing point of edge (p, p + d), field values f0 and f1, in world units, unclamped. */
static inline void crossing_f(const mc_t *m, int32_t i, int32_t j, int32_t k, int d, float f0,
                              float f1, float out[3], float *t_out)
{
    float t = (m->iso - f0) / (f1 - f0);
    t = t < 0.0f ? 0.0f : t > 1.0f ? 1.0f : t;
    /* scalars, not arrays of the corners: the compiler stored those as two ints and read them
     * back as one 8-byte load, a failed store forward every call */
    const float *lo = m->h->p.box_min, *cell = m->h->cell;
    out[0] = lo[0] + ((float)(i - 1) + t * (float)(d & 1)) * cell[0];
    out[1] = lo[1] + ((float)(j - 1) + t * (float)(d >> 1 & 1)) * cell[1];
    out[2] = lo[2] + ((float)(k - 1) + t * (float)(d >> 2 & 1)) * cell[2];
    *t_out = t;
}

/* The cache lines of the n bytes at p. */
static inline void prefetch_bytes(const void *p, size_t n)
{
    const char *a = p;
    for (size_t q = 0; q < n; q += 64) __builtin_prefetch(a + q);
    __builtin_prefetch(a + n - 1);
}

/* Every cube's triangles by its corners' inside bits: each vertex is the axis edge from corner
 * `corner` (bits) in direction `dir` (1, 2 or 4), wound so that the normal points outwards. */
typedef struct mc_tri {
    uint8_t corner[3], dir[3];
} mc_tri_t;
typedef struct mc_table {
    int16_t first[257];     /* triangles of cube config b: tri[first[b] .. first[b + 1]) */
    uint8_t rank[256][8];   /* edges of mask m before direction d: pop8(m & (bit d-1 - 1)) */
    uint32_t count[256];    /* a whole cube of config b: its crossing axis edges + triangles << 16 */
    mc_tri_t tri[256 * 10]; /* at most 12 crossings: 10 triangles a cube */
} mc_table_t;

/* Whether edges e and f (keys corner | dir << 3) lie in a common face of the cube. */
static int same_face(int e, int f)
{
    for (int a = 0; a < 3; ++a)
        if (!(e >> 3 >> a & 1) && !(f >> 3 >> a & 1) && (e >> a & 1) == (f >> a & 1)) return 1;
    return 0;
}

/* The table is built from the cube's faces, not typed in. Each face, walked anticlockwise as
 * seen from outside the cube, is cut by segments from an edge where the walk enters the inside
 * to the next edge where it leaves. On a face whose inside corners are diagonally opposite,
 * the inside corners are joined (a thin sheet keeps no holes). The decision depends on the
 * face's four corners only, so the two cubes sharing a face cut it alike and the surface is
 * closed. Each crossing edge ends a segment on one face and starts one on the other: the
 * segments chain into loops, fanned into triangles. */
static void build_table(mc_table_t *tb)
{
    int n = 0;
    for (int bits = 0; bits < 256; ++bits) {
        tb->first[bits] = (int16_t)n;
        int succ[64]; /* edge key (corner | dir << 3) -> next edge of its loop, or -1 */
        for (int e = 0; e < 64; ++e) succ[e] = -1;
        for (int a = 0; a < 3; ++a)
            for (int side = 0; side < 2; ++side) {
                const int u = (a + 1) % 3, v = (a + 2) % 3, c0 = side << a;
                int c[4] = {c0, c0 | 1 << u, c0 | 1 << u | 1 << v, c0 | 1 << v};
                if (!side) { const int sw = c[1]; c[1] = c[3]; c[3] = sw; } /* seen from -a */
                int in[4], key[4];
                for (int q = 0; q < 4; ++q) in[q] = bits >> c[q] & 1;
                for (int q = 0; q < 4; ++q) {
                    const int x = c[q], y = c[(q + 1) & 3];
                    key[q] = (x & y) | (x ^ y) << 3;
                }
                for (int q = 0; q < 4; ++q) {
                    if (in[q] || !in[(q + 1) & 3]) continue; /* edge q enters the inside */
                    int exit = (q + 1) & 3;
                    while (!(in[exit] && !in[(exit + 1) & 3])) exit = (exit + 1) & 3;
                    if (!in[(q + 2) & 3] && in[(q + 3) & 3]) exit = (q + 3) & 3; /* ambiguous: join */
                    succ[key[q]] = key[exit];
                }
            }
        for (int e0 = 0; e0 < 64; ++e0) {
            if (succ[e0] < 0) continue;
            int loop[12], len = 0;
            for (int e = e0; succ[e] >= 0;) {
                const int next = succ[e];
                loop[len++] = e;
                succ[e] = -1;
                e = next;
            }
            /* Fan from a vertex none of whose chords lies in a face: a chord in a face could
             * meet the neighbouring cube's, and an edge would then have three triangles. */
            int s0 = -1; /* every loop of the 256 configurations has one */
            for (int s = 0; s < len && s0 < 0; ++s) {
                int ok = 1;
                for (int j = 2; j + 1 < len && ok; ++j) ok = !same_face(loop[s], loop[(s + j) % len]);
                if (ok) s0 = s;
            }
            if (s0 < 0) s0 = 0;
            for (int t = 1; t + 1 < len; ++t, ++n) {
                const int vtx[3] = {loop[s0], loop[(s0 + t) % len], loop[(s0 + t + 1) % len]};
                for (int k = 0; k < 3; ++k) {
                    tb->tri[n].corner[k] = (uint8_t)(vtx[k] & 7);
                    tb->tri[n].dir[k] = (uint8_t)(vtx[k] >> 3);
                }
            }
        }
    }
    tb->first[256] = (int16_t)n;
    for (int b = 0; b < 256; ++b) { /* the axis edges from corner 0 that cross */
        const unsigned e = (unsigned)((b ^ b >> 1) & 1) | (unsigned)((b ^ b >> 2) & 1) << 1 |
                           (unsigned)((b ^ b >> 4) & 1) << 2;
        tb->count[b] = (uint32_t)pop8(e) | (uint32_t)(tb->first[b + 1] - tb->first[b]) << 16;
    }
    for (int m = 0; m < 256; ++m)
        for (int d = 1; d < 8; ++d) tb->rank[m][d] = (uint8_t)pop8((unsigned)m & ((1u << (d - 1)) - 1u));
}

hbk_result_t hbk_fluid_update_surface(hbk_fluid_t *h, hbk_progress_t *progress)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    const double t0 = omp_get_wtime();
    const int threads = HBK_OMP_THREADS(h);
    mc_t m = {h, {h->nv[0] + 2, h->nv[1] + 2, h->nv[2] + 2}, h->p.surface_threshold};
    const int32_t ex = m.e[0], ey = m.e[1], ez = m.e[2];
    const size_t npad = (size_t)ex * (size_t)ey * (size_t)ez, rows = (size_t)ey * (size_t)ez;
    /* The grid never changes size: the tables are allocated once. */
    if (!h->mc_mask) h->mc_mask = malloc(npad);
    if (!h->mc_first) h->mc_first = malloc(npad * sizeof *h->mc_first);
    if (!h->mc_row_v) h->mc_row_v = malloc((rows + 1) * sizeof *h->mc_row_v);
    if (!h->mc_row_t) h->mc_row_t = malloc((rows + 1) * sizeof *h->mc_row_t);
    if (!h->mc_in) h->mc_in = malloc(npad);
    if (!h->mc_cfg) h->mc_cfg = malloc(npad);
    if (!h->mc_row_in) h->mc_row_in = malloc(rows);
    uint8_t *mask = h->mc_mask, *in_at = h->mc_in, *row_in = h->mc_row_in, *cfg = h->mc_cfg;
    int32_t *first = h->mc_first;
    int64_t *row_v = h->mc_row_v, *row_t = h->mc_row_t;
    float *pos = NULL, *nrm = NULL;
    int32_t *tri = NULL;
    hbk_result_t r = HBK_OK;
    if (!mask || !in_at || !row_in || !cfg || !first || !row_v || !row_t) {
        r = HBK_ERR_OUT_OF_MEMORY;
        goto done;
    }
    /* (0) Inside or not, per padded vertex, once (each is read by 15 edges and 8 cubes). */
/* Slabs dealt out in turn: the fluid (the work) sits low in the box. */
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < ez; ++k)
        for (int32_t j = 0; j < ey; ++j) {
            uint8_t any = 0, all = 1;
            uint8_t *at = in_at + pidx(&m, 0, j, k);
            if (j > 0 && k > 0 && j < ey - 1 && k < ez - 1) { /* the pad, then a field row */
                const float *f = h->surface + (size_t)h->nv[0] * ((size_t)(j - 1) + (size_t)h->nv[1] * (size_t)(k - 1));
                at[0] = at[ex - 1] = 0;
                all = 0;
                for (int32_t i = 1; i < ex - 1; ++i) {
                    const uint8_t v = f[i - 1] > m.iso;
                    at[i] = v;
                    any |= v;
                }
            } else
                for (int32_t i = 0; i < ex; ++i) {
                    const uint8_t v = (uint8_t)inside(&m, i, j, k);
                    at[i] = v;
                    any |= v;
                    all &= v;
                }
            /* 0 or 1: the whole row outside or inside; 2: both */
            row_in[(size_t)j + (size_t)ey * (size_t)k] = any == all ? any : 2;
        }
    mc_table_t *tb = h->mc_table;
    if (!tb) { /* the table depends on nothing: built once, with its memory */
        if (!(tb = h->mc_table = malloc(sizeof *tb))) {
            r = HBK_ERR_OUT_OF_MEMORY;
            goto done;
        }
        build_table(tb);
    }
    /* Offset of padded vertex (i, j, k) + corner/direction bits c. */
    size_t step[8];
    for (int c = 0; c < 8; ++c) step[c] = pidx(&m, c & 1, c >> 1 & 1, c >> 2 & 1);
    /* (1) Crossing edges and triangle counts per row. */
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < ez; ++k)
        for (int32_t j = 0; j < ey; ++j) {
            int64_t nvr = 0, ntr = 0;
            /* The edges and cubes of this row reach vertex rows j..j+1 of layers k..k+1: all
             * outside or all inside, it has neither crossings nor triangles (and no pass reads
             * its marks: every crossing edge lies in rows that are not skipped). */
            const uint8_t s0 = row_in[(size_t)j + (size_t)ey * (size_t)k];
            int same = s0 != 2;
            for (int q = 1; q < 4 && same; ++q) {
                const int32_t jj = j + (q & 1), kk = k + (q >> 1);
                if (jj < ey && kk < ez) same = row_in[(size_t)jj + (size_t)ey * (size_t)kk] == s0;
            }
            if (same) {
                memset(mask + pidx(&m, 0, j, k), 0, (size_t)ex);
                row_v[1 + (size_t)j + (size_t)ey * (size_t)k] = 0;
                row_t[1 + (size_t)j + (size_t)ey * (size_t)k] = 0;
                continue;
            }
            int32_t i = 0;
            if (j + 1 < ey && k + 1 < ez) /* 16 whole cubes at a time, a byte each */
                for (; i + 16 <= ex - 1; i += 16) {
                    const size_t p = pidx(&m, i, j, k);
                    v16u c[8];
                    for (int q = 0; q < 8; ++q) memcpy(&c[q], in_at + p + step[q], sizeof c[q]);
                    v16u bits = c[0];
                    for (int q = 1; q < 8; ++q) bits |= c[q] << q;
                    const v16u b = (c[1] ^ c[0]) | (c[2] ^ c[0]) << 1 | (c[4] ^ c[0]) << 3;
                    memcpy(mask + p, &b, sizeof b);
                    const v16u cf = bits & ~(v16u)(bits == 255); /* all inside: none */
                    memcpy(cfg + p, &cf, sizeof cf);
                    /* both counts from one entry (config 0 stands for 255: neither has any);
                     * a row's sums fit the entry's halves */
                    uint32_t both = 0;
                    for (int l = 0; l < 16; ++l) both += tb->count[cfg[p + (size_t)l]];
                    nvr += both & 0xffffu;
                    ntr += both >> 16;
                }
            for (; i < ex; ++i) {
                const size_t p = pidx(&m, i, j, k);
                const int a = in_at[p];
                uint8_t b = 0;
                if (i + 1 < ex && j + 1 < ey && k + 1 < ez) {
                    int bits = a;
                    for (int c = 1; c < 8; ++c) {
                        const int q = in_at[p + step[c]];
                        if (!(c & (c - 1))) b |= (uint8_t)((q != a) << (c - 1)); /* axis edges */
                        bits |= q << c;
                    }
                    ntr += tb->first[bits + 1] - tb->first[bits];
                    cfg[p] = (uint8_t)(bits == 255 ? 0 : bits);
                } else {
                    for (int d = 1; d < 8; d <<= 1) {
                        const int32_t i1 = i + (d & 1), j1 = j + (d >> 1 & 1), k1 = k + (d >> 2 & 1);
                        if (i1 >= ex || j1 >= ey || k1 >= ez) continue;
                        if (in_at[p + step[d]] != a) b |= (uint8_t)(1u << (d - 1));
                    }
                }
                mask[p] = b;
                nvr += pop8(b);
            }
            row_v[1 + (size_t)j + (size_t)ey * (size_t)k] = nvr;
            row_t[1 + (size_t)j + (size_t)ey * (size_t)k] = ntr;
        }
    if (hbk_cancelled(progress)) { r = HBK_ERR_CANCELLED; goto done; }
    row_v[0] = row_t[0] = 0;
    for (size_t q = 0; q < rows; ++q) { row_v[q + 1] += row_v[q]; row_t[q + 1] += row_t[q]; }
    if (row_v[rows] > INT32_MAX / 3 || row_t[rows] > INT32_MAX / 3) {
        r = hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "surface: more than 700 million triangles");
        goto done;
    }
    const int32_t NV = (int32_t)row_v[rows], NT = (int32_t)row_t[rows];
    /* The next mesh goes to the spare buffers, doubled when too small. A buffer of a few MB
     * lives in the heap, where realloc copies it into fresh pages, and a first touch of a page
     * is dear (1.4 us, 5 us with two threads faulting): a splash that grows 10% a frame would
     * pay for its whole mesh each frame if the buffers grew by a quarter. */
    if ((size_t)NV + 1 > h->next_cap_v) {
        const size_t cap = 2 * ((size_t)NV + 1);
        float *p2 = realloc(h->next_pos, 3 * cap * sizeof *p2);
        if (p2) h->next_pos = p2;
        float *n2 = realloc(h->next_nrm, 3 * cap * sizeof *n2);
        if (n2) h->next_nrm = n2;
        if (!p2 || !n2) { r = HBK_ERR_OUT_OF_MEMORY; goto done; }
        h->next_cap_v = cap;
    }
    if ((size_t)NT + 1 > h->next_cap_t) {
        const size_t cap = 2 * ((size_t)NT + 1);
        int32_t *t2 = realloc(h->next_tri, 3 * cap * sizeof *t2);
        if (!t2) { r = HBK_ERR_OUT_OF_MEMORY; goto done; }
        h->next_tri = t2;
        h->next_cap_t = cap;
    }
    pos = h->next_pos;
    nrm = h->next_nrm;
    tri = h->next_tri;
    /* (2) Edge vertices: position clamped into the box (caps on the walls), normal from the
     * interpolated field gradient. */
    const size_t fs[3] = {1, (size_t)h->nv[0], (size_t)h->nv[0] * (size_t)h->nv[1]};
    size_t fstep[8]; /* field offset of corner/direction bits c */
    for (int c = 0; c < 8; ++c) fstep[c] = (c & 1) * fs[0] + (c >> 1 & 1) * fs[1] + (c >> 2 & 1) * fs[2];
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < ez; ++k)
        for (int32_t j = 0; j < ey; ++j) {
            const size_t q = (size_t)j + (size_t)ey * (size_t)k;
            if (row_v[q + 1] == row_v[q]) continue; /* no vertex */
            int32_t id = (int32_t)row_v[q];
            /* The field rows the next row's gradients read first (a row's vertices are too few
             * and far apart for the hardware to fetch them ahead): rows j + 3 of this layer,
             * j + 2 of the layers either side, j + 1 two layers up (field rows are one less). */
            const int32_t fj = j - 1, fk = k - 1;
            const int32_t ahead[4][2] = {{fj + 3, fk}, {fj + 2, fk - 1}, {fj + 2, fk + 1},
                                         {fj + 1, fk + 2}};
            for (int a = 0; a < 4; ++a)
                if (ahead[a][0] >= 0 && ahead[a][0] < h->nv[1] && ahead[a][1] >= 0 &&
                    ahead[a][1] < h->nv[2])
                    prefetch_bytes(h->surface + fs[1] * (size_t)ahead[a][0] +
                                       fs[2] * (size_t)ahead[a][1],
                                   (size_t)h->nv[0] * sizeof(float));
            /* Edges whose ends and their neighbours lie in the grid (padded 2 .. e - 4) read
             * the field directly. */
            const int yz_in = j >= 2 && j <= ey - 4 && k >= 2 && k <= ez - 4;
            const size_t p0 = pidx(&m, 0, j, k);
            for (int32_t i = 0; i < ex; ++i) {
                const size_t pi = p0 + (size_t)i;
                if (i + 8 <= ex) { /* eight vertices without crossings at once */
                    uint64_t eight;
                    memcpy(&eight, mask + pi, sizeof eight);
                    if (!eight) {
                        i += 7;
                        continue;
                    }
                }
                if (!mask[pi]) continue; /* pass (3) reads `first` only where there are edges */
                first[pi] = id;
                const int in = yz_in && i >= 2 && i <= ex - 4;
                const float *f = in ? h->surface + ((size_t)(i - 1) + fs[1] * (size_t)(j - 1) +
                                                     fs[2] * (size_t)(k - 1))
                                    : NULL;
                for (int d = 1; d < 8; d <<= 1) {
                    if (!(mask[pi] >> (d - 1) & 1)) continue;
                    float x[3], t, g0[3], g1[3];
                    if (in) {
                        crossing_f(&m, i, j, k, d, f[0], f[fstep[d]], x, &t);
                        grad_in(&m, f, fs, g0);
                        grad_in(&m, f + fstep[d], fs, g1);
                    } else {
                        const int32_t i1 = i + (d & 1), j1 = j + (d >> 1 & 1), k1 = k + (d >> 2 & 1);
                        crossing_f(&m, i, j, k, d, val(&m, i, j, k), val(&m, i1, j1, k1), x, &t);
                        grad(&m, i, j, k, g0);
                        grad(&m, i1, j1, k1, g1);
                    }
                    float n[3], nn = 0.0f;
                    for (int c = 0; c < 3; ++c) {
                        const float lo = h->p.box_min[c], hi = h->p.box_max[c];
                        x[c] = x[c] < lo ? lo : x[c] > hi ? hi : x[c];
                        n[c] = -(g0[c] + t * (g1[c] - g0[c]));
                        nn += n[c] * n[c];
                    }
                    nn = nn > 0.0f ? 1.0f / sqrtf(nn) : 0.0f;
                    for (int c = 0; c < 3; ++c) {
                        pos[3 * (size_t)id + (size_t)c] = x[c];
                        nrm[3 * (size_t)id + (size_t)c] = n[c] * nn;
                    }
                    ++id;
                }
            }
        }
    if (hbk_cancelled(progress)) { r = HBK_ERR_CANCELLED; goto done; }
    /* (3) Triangles, wound so that the normal points from inside to outside. The cube
     * configurations are pass (1)'s (0: none), set in every row that has triangles. */
#pragma omp parallel for num_threads(threads) schedule(static, 1)
    for (int32_t k = 0; k < ez - 1; ++k)
        for (int32_t j = 0; j < ey - 1; ++j) {
            const size_t q = (size_t)j + (size_t)ey * (size_t)k;
            if (row_t[q + 1] == row_t[q]) continue; /* no triangle in this row */
            size_t out = (size_t)row_t[q];
            const size_t p0 = pidx(&m, 0, j, k);
            /* The vertex numbers and edge masks the next row reads first: rows j + 2 of layers
             * k and k + 1 (pass 2 wrote them a whole grid ago). */
            for (int a = 0; a < 2 && j + 2 < ey && k + a < ez; ++a) {
                const size_t pa = pidx(&m, 0, j + 2, k + a);
                prefetch_bytes(first + pa, (size_t)ex * sizeof *first);
                prefetch_bytes(mask + pa, (size_t)ex);
            }
            for (int32_t i = 0; i < ex - 1; ++i) {
                const size_t p = p0 + (size_t)i;
                if (i + 8 <= ex - 1) { /* eight empty cubes at once */
                    uint64_t eight;
                    memcpy(&eight, cfg + p, sizeof eight);
                    if (!eight) {
                        i += 7;
                        continue;
                    }
                }
                const int bits = cfg[p];
                if (!bits) continue;
                for (int n = tb->first[bits]; n < tb->first[bits + 1]; ++n) {
                    const mc_tri_t *tr = &tb->tri[n];
                    for (int v = 0; v < 3; ++v) {
                        const size_t pc = p + step[tr->corner[v]];
                        tri[3 * out + v] = first[pc] + tb->rank[mask[pc]][tr->dir[v]];
                    }
                    ++out;
                }
            }
        }
    if (hbk_cancelled(progress)) { r = HBK_ERR_CANCELLED; goto done; }
    { /* the new mesh becomes current; the old buffers are the next spare */
        float *p0 = h->mesh_pos, *n0 = h->mesh_nrm;
        int32_t *t0b = h->mesh_tri;
        const size_t cv = h->mesh_cap_v, ct = h->mesh_cap_t;
        h->mesh_pos = pos; h->mesh_nrm = nrm; h->mesh_tri = tri;
        h->mesh_cap_v = h->next_cap_v; h->mesh_cap_t = h->next_cap_t;
        h->next_pos = p0; h->next_nrm = n0; h->next_tri = t0b;
        h->next_cap_v = cv; h->next_cap_t = ct;
    }
    h->mesh_nv = NV;
    h->mesh_nt = NT;
    h->ms[3] = (omp_get_wtime() - t0) * 1e3;
done:
    if (r == HBK_ERR_CANCELLED) return hbk_fail(&h->msg, r, "surface: cancelled");
    if (r == HBK_ERR_OUT_OF_MEMORY && !h->msg.text[0])
        return hbk_fail(&h->msg, r, "surface: out of memory");
    return r;
}

hbk_result_t hbk_fluid_mesh_counts(hbk_fluid_t *h, int32_t *vertices, int32_t *triangles)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    if (vertices) *vertices = h->mesh_nv;
    if (triangles) *triangles = h->mesh_nt;
    return HBK_OK;
}

hbk_result_t hbk_fluid_get_mesh(hbk_fluid_t *h, float *pos, float *normal, int32_t *tris,
                                float *uvw_a, float *uvw_b, float *blend, float *features)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    const int32_t nv = h->mesh_nv, K = h->K, F = HBK_FLUID_FEATURE_COUNT;
    if (nv == 0) return HBK_OK; /* no mesh yet: its buffers may be NULL, and memcpy's must not */
    if (pos) memcpy(pos, h->mesh_pos, 3 * (size_t)nv * sizeof(float));
    if (normal) memcpy(normal, h->mesh_nrm, 3 * (size_t)nv * sizeof(float));
    if (tris) memcpy(tris, h->mesh_tri, 3 * (size_t)h->mesh_nt * sizeof(int32_t));
    if (!uvw_a && !uvw_b && !blend && !features) return HBK_OK;
    const int threads = HBK_OMP_THREADS(h);
    size_t off[8];
    hbk_fluid_corners(h, off);
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t v = 0; v < nv; ++v) {
        hbk_fluid_lerp_t l;
        hbk_fluid_lerp_at_mesh(h, v, &l);
        float *uvw[2] = {uvw_a ? uvw_a + 3 * (size_t)v : NULL, uvw_b ? uvw_b + 3 * (size_t)v : NULL};
        for (int f = 0; f < 2; ++f) {
            if (!uvw[f]) continue;
            hbk_fluid_sample_wrapped3(h, h->v.uvw[f], h->v.wrap[f], &l, uvw[f]);
            for (int c = 0; c < 3; ++c) { /* unwrapped near the rest mapping (see the header) */
                const float rest = (h->mesh_pos[3 * (size_t)v + (size_t)c] - h->p.box_min[c]) / h->p.uvw_tile;
                uvw[f][c] = hbk_fluid_unwrap(uvw[f][c], rest);
            }
        }
        if (blend) {
            /* Blend of the 8 corners, each already normalised, then trilinear. */
            float c[8][HBK_FLUID_MAX_TEXTURES], *o = blend + (size_t)K * (size_t)v, s = 0.0f;
            for (int q = 0; q < 8; ++q) hbk_fluid_blend_at(h, h->v.base, h->v.paint, h->v.life, l.base + off[q], c[q]);
            for (int k = 0; k < K; ++k) {
                const float ck[8] = {c[0][k], c[1][k], c[2][k], c[3][k], c[4][k], c[5][k], c[6][k], c[7][k]};
                o[k] = hbk_fluid_tri(ck, l.t);
                s += o[k];
            }
            if (s > 0.0f) for (int k = 0; k < K; ++k) o[k] /= s;
        }
        if (features) {
            float *o = features + (size_t)F * (size_t)v, vm[3];
            hbk_fluid_sample_field(h, h->features, F, &l, o);
            hbk_fluid_sample_field(h, h->motion, 3, &l, vm);
            const float *n = h->mesh_nrm + 3 * (size_t)v;
            const float vv = sqrtf(vm[0] * vm[0] + vm[1] * vm[1] + vm[2] * vm[2]);
            float ang = (float)(0.5 * M_PI);
            if (vv > 0.0f) {
                float cs = (vm[0] * n[0] + vm[1] * n[1] + vm[2] * n[2]) / vv;
                cs = cs > 1.0f ? 1.0f : cs < -1.0f ? -1.0f : cs;
                if (n[0] != 0.0f || n[1] != 0.0f || n[2] != 0.0f) ang = hbk_fluid_acos(cs);
            }
            o[HBK_FLUID_FEATURE_FLOW_ANGLE] = ang;
        }
    }
    return HBK_OK;
}
