/* Surface extraction: marching cubes on the six Kuhn tetrahedra of every cube (all sharing the
 * cube's main diagonal). The split is the same in neighbouring cubes, so the tetrahedra tile
 * space and there are no ambiguous faces: the mesh is closed by construction. The grid is
 * padded with one layer of empty vertices all round, so blobs touching the box are capped.
 *
 * Three passes, each parallel over z layers and each writing only its own slots, so the mesh
 * is the same bytes for any thread count: (1) mark crossing edges per padded vertex (7 edge
 * directions: 3 axes, 3 face diagonals, 1 body diagonal), (2) number and place the edge
 * vertices, (3) count, number and write the triangles. */
#include "internal_fluid.h"
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* Edge direction d (1..7) is the offset (d & 1, d >> 1 & 1, d >> 2 & 1); bit d-1 of a mask. */
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
static void crossing_f(const mc_t *m, int32_t i, int32_t j, int32_t k, int d, float f0, float f1,
                       float out[3], float *t_out)
{
    const int32_t i1 = i + (d & 1), j1 = j + (d >> 1 & 1), k1 = k + (d >> 2 & 1);
    float t = (m->iso - f0) / (f1 - f0);
    t = t < 0.0f ? 0.0f : t > 1.0f ? 1.0f : t;
    const int32_t a[3] = {i, j, k}, b[3] = {i1, j1, k1};
    for (int c = 0; c < 3; ++c)
        out[c] = m->h->p.box_min[c] +
                 ((float)(a[c] - 1) + t * (float)(b[c] - a[c])) * m->h->cell[c];
    *t_out = t;
}

/* The six tetrahedra: path 0 -> e_a -> e_a + e_b -> (1,1,1) for each permutation (a, b, c). */
static const int k_perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

/* Corner offsets (as bit masks) of tetrahedron t. */
static inline void tet(int t, int c[4])
{
    c[0] = 0;
    c[1] = 1 << k_perm[t][0];
    c[2] = c[1] | 1 << k_perm[t][1];
    c[3] = 7;
}

static inline int tet_tris(int in)
{
    const int n = (in & 1) + (in >> 1 & 1) + (in >> 2 & 1) + (in >> 3 & 1);
    return n == 1 || n == 3 ? 1 : n == 2 ? 2 : 0;
}

/* Every cube's triangles by its corners' inside bits, in the order of its tetrahedra: each
 * vertex is the edge from corner `corner` (bits) in direction `dir` (1..7), and `dirv` is the
 * tetrahedron's reference direction (from its inside corners' mean to its outside ones', in
 * metres), which decides the winding. */
typedef struct mc_tri {
    uint8_t corner[3], dir[3], tet;
} mc_tri_t;
typedef struct mc_table {
    int16_t first[257];     /* triangles of cube config b: tri[first[b] .. first[b + 1]) */
    uint8_t rank[256][8];   /* edges of mask m before direction d: pop8(m & (bit d-1 - 1)) */
    mc_tri_t tri[256 * 12];
    float dirv[256][6][3];
} mc_table_t;

static void build_table(const hbk_fluid_t *h, mc_table_t *tb)
{
    int n = 0;
    for (int bits = 0; bits < 256; ++bits) {
        tb->first[bits] = (int16_t)n;
        for (int t = 0; t < 6; ++t) {
            int c[4], in = 0;
            tet(t, c);
            for (int q = 0; q < 4; ++q) in |= (bits >> c[q] & 1) << q;
            const int nt = tet_tris(in);
            if (!nt) continue;
            /* Inside corners first, then outside ones (tetrahedron-local numbers). */
            int ins[4], outs[4], ni = 0, no = 0;
            for (int q = 0; q < 4; ++q) {
                if (in >> q & 1) ins[ni++] = q;
                else outs[no++] = q;
            }
            /* Edge between corners qa and qb: from the lower corner (qa < qb along the path)
             * in direction c[qb] - c[qa] (always a 0/1 vector). */
            uint8_t ec[4][4], ed[4][4];
            for (int a = 0; a < ni; ++a)
                for (int b = 0; b < no; ++b) {
                    int qa = ins[a], qb = outs[b];
                    if (qa > qb) { int sw = qa; qa = qb; qb = sw; }
                    ec[a][b] = (uint8_t)c[qa];
                    ed[a][b] = (uint8_t)(c[qb] & ~c[qa]);
                }
            float *dv = tb->dirv[bits][t];
            dv[0] = dv[1] = dv[2] = 0.0f;
            for (int q = 0; q < 4; ++q) {
                const float sgn = (in >> q & 1) ? -1.0f / (float)ni : 1.0f / (float)no;
                dv[0] += sgn * (float)(c[q] & 1) * h->cell[0];
                dv[1] += sgn * (float)(c[q] >> 1 & 1) * h->cell[1];
                dv[2] += sgn * (float)(c[q] >> 2 & 1) * h->cell[2];
            }
            /* one triangle (ni 1 or 3), or the quad a0b0, a0b1, a1b1, a1b0 as two */
            static const int qa4[4] = {0, 0, 1, 1}, qb4[4] = {0, 1, 1, 0};
            static const int use[2][3] = {{0, 1, 2}, {0, 2, 3}};
            for (int sidx = 0; sidx < nt; ++sidx, ++n) {
                mc_tri_t *tr = &tb->tri[n];
                tr->tet = (uint8_t)t;
                for (int v = 0; v < 3; ++v) {
                    const int a = ni == 1 ? 0 : ni == 3 ? v : qa4[use[sidx][v]];
                    const int b = ni == 1 ? v : ni == 3 ? 0 : qb4[use[sidx][v]];
                    tr->corner[v] = ec[a][b];
                    tr->dir[v] = ed[a][b];
                }
            }
        }
    }
    tb->first[256] = (int16_t)n;
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
    float *pos = NULL, *nrm = NULL, *raw = NULL;
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
    if (!tb && !(tb = h->mc_table = malloc(sizeof *tb))) {
        r = HBK_ERR_OUT_OF_MEMORY;
        goto done;
    }
    build_table(h, tb); /* cheap; the cell size could change with a load_state */
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
                    v16u bits = c[0], b = {0};
                    for (int q = 1; q < 8; ++q) {
                        bits |= c[q] << q;
                        b |= (c[q] ^ c[0]) << (q - 1);
                    }
                    memcpy(mask + p, &b, sizeof b);
                    const v16u cf = bits & ~(v16u)(bits == 255); /* all inside: none */
                    memcpy(cfg + p, &cf, sizeof cf);
                    for (int l = 0; l < 16; ++l) {
                        nvr += pop8(b[l]);
                        ntr += tb->first[bits[l] + 1] - tb->first[bits[l]];
                    }
                }
            for (; i < ex; ++i) {
                const size_t p = pidx(&m, i, j, k);
                const int a = in_at[p];
                uint8_t b = 0;
                if (i + 1 < ex && j + 1 < ey && k + 1 < ez) {
                    int bits = a;
                    for (int c = 1; c < 8; ++c) {
                        const int q = in_at[p + step[c]];
                        b |= (uint8_t)((q != a) << (c - 1));
                        bits |= q << c;
                    }
                    ntr += tb->first[bits + 1] - tb->first[bits];
                    cfg[p] = (uint8_t)(bits == 255 ? 0 : bits);
                } else {
                    for (int d = 1; d < 8; ++d) {
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
    /* The next mesh goes to the spare buffers, grown (by a quarter more) when too small. */
    if ((size_t)NV + 1 > h->next_cap_v) {
        const size_t cap = (size_t)NV + 1 + ((size_t)NV + 1) / 4;
        float *p2 = realloc(h->next_pos, 3 * cap * sizeof *p2);
        if (p2) h->next_pos = p2;
        float *n2 = realloc(h->next_nrm, 3 * cap * sizeof *n2);
        if (n2) h->next_nrm = n2;
        if (!p2 || !n2) { r = HBK_ERR_OUT_OF_MEMORY; goto done; }
        h->next_cap_v = cap;
    }
    if ((size_t)NT + 1 > h->next_cap_t) {
        const size_t cap = (size_t)NT + 1 + ((size_t)NT + 1) / 4;
        int32_t *t2 = realloc(h->next_tri, 3 * cap * sizeof *t2);
        if (!t2) { r = HBK_ERR_OUT_OF_MEMORY; goto done; }
        h->next_tri = t2;
        h->next_cap_t = cap;
    }
    if ((size_t)NV + 1 > h->mc_cap_raw) {
        const size_t cap = (size_t)NV + 1 + ((size_t)NV + 1) / 4;
        float *r2 = realloc(h->mc_raw, 3 * cap * sizeof *r2);
        if (!r2) { r = HBK_ERR_OUT_OF_MEMORY; goto done; }
        h->mc_raw = r2;
        h->mc_cap_raw = cap;
    }
    raw = h->mc_raw;
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
            if (row_v[q + 1] == row_v[q]) continue; /* no vertex: nothing reads its `first` */
            int32_t id = (int32_t)row_v[q];
            /* Edges whose ends and their neighbours lie in the grid (padded 2 .. e - 4) read
             * the field directly. */
            const int yz_in = j >= 2 && j <= ey - 4 && k >= 2 && k <= ez - 4;
            for (int32_t i = 0; i < ex; ++i) {
                const size_t pi = pidx(&m, i, j, k);
                first[pi] = id;
                if (!mask[pi]) continue;
                const int in = yz_in && i >= 2 && i <= ex - 4;
                const float *f = in ? h->surface + ((size_t)(i - 1) + fs[1] * (size_t)(j - 1) +
                                                     fs[2] * (size_t)(k - 1))
                                    : NULL;
                for (int d = 1; d < 8; ++d) {
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
                    memcpy(raw + 3 * (size_t)id, x, sizeof x); /* unclamped, for pass (3) */
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
                    int32_t tv[3];
                    const float *tp[3];
                    for (int v = 0; v < 3; ++v) {
                        const size_t pc = p + step[tr->corner[v]];
                        tv[v] = first[pc] + tb->rank[mask[pc]][tr->dir[v]];
                        tp[v] = raw + 3 * (size_t)tv[v];
                    }
                    const float *dirv = tb->dirv[bits][tr->tet];
                    float e1[3], e2[3], cr[3];
                    for (int c = 0; c < 3; ++c) {
                        e1[c] = tp[1][c] - tp[0][c];
                        e2[c] = tp[2][c] - tp[0][c];
                    }
                    cr[0] = e1[1] * e2[2] - e1[2] * e2[1];
                    cr[1] = e1[2] * e2[0] - e1[0] * e2[2];
                    cr[2] = e1[0] * e2[1] - e1[1] * e2[0];
                    const int flip = cr[0] * dirv[0] + cr[1] * dirv[1] + cr[2] * dirv[2] < 0.0f;
                    tri[3 * out] = tv[0];
                    tri[3 * out + 1] = tv[flip ? 2 : 1];
                    tri[3 * out + 2] = tv[flip ? 1 : 2];
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
        if (uvw_a) hbk_fluid_sample_wrapped3(h, h->v.uvw[0], h->v.wrap[0], &l, uvw_a + 3 * (size_t)v);
        if (uvw_b) hbk_fluid_sample_wrapped3(h, h->v.uvw[1], h->v.wrap[1], &l, uvw_b + 3 * (size_t)v);
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
