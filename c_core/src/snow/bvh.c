/* Triangle BVH: binned SAH build, collapsed to four children a node; first-hit query for a
 * segment. */
#include "internal_snow.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#define BINS 12
#define LEAF_MAX 4      /* leaves a split cannot improve may still hold up to this many */
#define FORCE_MEDIAN 64 /* past this depth split by count, so the stack below always fits */
#define STACK 384 /* the walk's stack: three children of each of <= 128 levels */

typedef struct {
    float lo[3], hi[3];
} aabb_t;

static void box_empty(aabb_t *b)
{
    for (int k = 0; k < 3; ++k) { b->lo[k] = FLT_MAX; b->hi[k] = -FLT_MAX; }
}
static void box_grow(aabb_t *b, const aabb_t *o)
{
    for (int k = 0; k < 3; ++k) {
        b->lo[k] = snow_min(b->lo[k], o->lo[k]);
        b->hi[k] = snow_max(b->hi[k], o->hi[k]);
    }
}
static float box_area(const aabb_t *b)
{
    float x = b->hi[0] - b->lo[0], y = b->hi[1] - b->lo[1], z = b->hi[2] - b->lo[2];
    if (x < 0 || y < 0 || z < 0) return 0.0f;
    return x * y + y * z + z * x;
}

typedef struct {
    int32_t node, start, end, depth;
} build_item_t;

void snow_bvh_free(bvh_t *b)
{
    if (!b) return;
    free(b->nodes);
    free(b->wide);
    free(b->tris);
    memset(b, 0, sizeof *b);
}

static void wide_child(bvh_wide_t *w, int c, const bvh_node_t *nd, int32_t first, int32_t count)
{
    for (int k = 0; k < 3; ++k) {
        w->lo[k][c] = nd->lo[k];
        w->hi[k][c] = nd->hi[k];
    }
    w->first[c] = first;
    w->count[c] = count;
}

/* The binary tree as one of up to four children a node: each wide node takes the children of
 * a binary node and, while it has room, opens the inner one with the largest box. The walk
 * then tests four boxes at once and takes about half the steps down. */
static hbk_result_t collapse(bvh_t *b)
{
    const int32_t cap = b->node_count / 2 + 1; /* one wide node per binary inner node at most */
    b->wide = aligned_alloc(64, sizeof *b->wide * (size_t)cap);
    int32_t *pending = malloc(sizeof *pending * 2 * (size_t)cap);
    if (!b->wide || !pending) {
        free(pending);
        return HBK_ERR_OUT_OF_MEMORY;
    }
    memset(b->wide, 0, sizeof *b->wide * (size_t)cap);
    int32_t wide_count = 1, np = 0;
    const bvh_node_t *nodes = b->nodes;
    for (int c = 0; c < 4; ++c) b->wide[0].count[c] = -1;
    if (nodes[0].count > 0) /* one leaf: the root node holds it */
        wide_child(&b->wide[0], 0, &nodes[0], nodes[0].first, nodes[0].count);
    else
        pending[np++] = 0, pending[np++] = 0;
    while (np > 0) {
        const int32_t wi = pending[--np], bn = pending[--np];
        int32_t cand[4] = {nodes[bn].first, nodes[bn].first + 1}, nc = 2;
        while (nc < 4) {
            int best = -1;
            float area = -1.0f;
            for (int c = 0; c < nc; ++c) {
                const bvh_node_t *nd = &nodes[cand[c]];
                const aabb_t box = {{nd->lo[0], nd->lo[1], nd->lo[2]},
                                    {nd->hi[0], nd->hi[1], nd->hi[2]}};
                if (nd->count == 0 && box_area(&box) > area) {
                    area = box_area(&box);
                    best = c;
                }
            }
            if (best < 0) break;
            const int32_t inner = cand[best];
            cand[best] = nodes[inner].first;
            cand[nc++] = nodes[inner].first + 1;
        }
        bvh_wide_t *w = &b->wide[wi];
        for (int c = 0; c < 4; ++c) {
            if (c >= nc) {
                w->count[c] = -1;
                continue;
            }
            const bvh_node_t *nd = &nodes[cand[c]];
            if (nd->count > 0) {
                wide_child(w, c, nd, nd->first, nd->count);
            } else {
                wide_child(w, c, nd, wide_count, 0);
                pending[np++] = cand[c];
                pending[np++] = wide_count++;
            }
        }
    }
    b->wide_count = wide_count;
    free(pending);
    return HBK_OK;
}

hbk_result_t snow_bvh_build(bvh_t *out, const float *pos, const int32_t *tri, int32_t n)
{
    bvh_t b = {0};
    if (n <= 0) { *out = b; return HBK_OK; }
    aabb_t *tb = malloc(sizeof *tb * (size_t)n);
    float *cen = malloc(sizeof *cen * 3 * (size_t)n);
    int32_t *idx = malloc(sizeof *idx * (size_t)n);
    build_item_t *stack = malloc(sizeof *stack * (size_t)(FORCE_MEDIAN + 64));
    b.nodes = malloc(sizeof *b.nodes * (size_t)(2 * n));
    b.tris = malloc(sizeof *b.tris * (size_t)n);
    if (!tb || !cen || !idx || !stack || !b.nodes || !b.tris) {
        free(tb); free(cen); free(idx); free(stack); snow_bvh_free(&b);
        return HBK_ERR_OUT_OF_MEMORY;
    }
    for (int32_t i = 0; i < n; ++i) {
        box_empty(&tb[i]);
        for (int c = 0; c < 3; ++c) {
            const float *v = pos + 3 * (size_t)tri[3 * (size_t)i + c];
            for (int k = 0; k < 3; ++k) {
                tb[i].lo[k] = snow_min(tb[i].lo[k], v[k]);
                tb[i].hi[k] = snow_max(tb[i].hi[k], v[k]);
            }
        }
        for (int k = 0; k < 3; ++k) cen[3 * (size_t)i + k] = 0.5f * (tb[i].lo[k] + tb[i].hi[k]);
        idx[i] = i;
    }

    int32_t sp = 0, node_count = 1;
    stack[sp++] = (build_item_t){0, 0, n, 0};
    while (sp > 0) {
        build_item_t it = stack[--sp];
        const int32_t cnt = it.end - it.start;
        aabb_t bb, cb;
        box_empty(&bb);
        box_empty(&cb);
        for (int32_t i = it.start; i < it.end; ++i) {
            box_grow(&bb, &tb[idx[i]]);
            const float *c = cen + 3 * (size_t)idx[i];
            aabb_t pt = {{c[0], c[1], c[2]}, {c[0], c[1], c[2]}};
            box_grow(&cb, &pt);
        }
        bvh_node_t *nd = &b.nodes[it.node];
        memcpy(nd->lo, bb.lo, sizeof nd->lo);
        memcpy(nd->hi, bb.hi, sizeof nd->hi);

        int32_t mid = -1;
        if (cnt > 1) {
            /* Binned SAH on all three axes (cost: traversal 1, triangle 1). */
            float best = FLT_MAX, parent = box_area(&bb);
            int best_axis = -1, best_bin = 0;
            for (int ax = 0; ax < 3 && parent > 0.0f; ++ax) {
                const float ext = cb.hi[ax] - cb.lo[ax];
                if (!(ext > 0.0f)) continue;
                const float scale = (float)BINS / ext;
                aabb_t bin[BINS];
                int32_t bc[BINS] = {0};
                for (int k = 0; k < BINS; ++k) box_empty(&bin[k]);
                for (int32_t i = it.start; i < it.end; ++i) {
                    int k = (int)((cen[3 * (size_t)idx[i] + ax] - cb.lo[ax]) * scale);
                    if (k >= BINS) k = BINS - 1;
                    if (k < 0) k = 0;
                    box_grow(&bin[k], &tb[idx[i]]);
                    bc[k]++;
                }
                float right_area[BINS];
                int32_t right_cnt[BINS];
                aabb_t acc;
                box_empty(&acc);
                int32_t c = 0;
                for (int k = BINS - 1; k > 0; --k) {
                    box_grow(&acc, &bin[k]);
                    c += bc[k];
                    right_area[k] = box_area(&acc);
                    right_cnt[k] = c;
                }
                box_empty(&acc);
                c = 0;
                for (int k = 0; k < BINS - 1; ++k) {
                    box_grow(&acc, &bin[k]);
                    c += bc[k];
                    if (c == 0 || right_cnt[k + 1] == 0) continue;
                    float cost = 1.0f + (box_area(&acc) * (float)c +
                                         right_area[k + 1] * (float)right_cnt[k + 1]) / parent;
                    if (cost < best) { best = cost; best_axis = ax; best_bin = k; }
                }
            }
            /* Split when it pays, or when the leaf would be too big anyway. */
            if (best_axis >= 0 && it.depth < FORCE_MEDIAN && (best < (float)cnt || cnt > LEAF_MAX)) {
                const float ext = cb.hi[best_axis] - cb.lo[best_axis];
                const float scale = (float)BINS / ext;
                int32_t i = it.start, j = it.end - 1;
                while (i <= j) {
                    int k = (int)((cen[3 * (size_t)idx[i] + best_axis] - cb.lo[best_axis]) * scale);
                    if (k >= BINS) k = BINS - 1;
                    if (k <= best_bin) ++i;
                    else { int32_t t = idx[i]; idx[i] = idx[j]; idx[j] = t; --j; }
                }
                mid = i;
                if (mid == it.start || mid == it.end) mid = -1;
            }
            /* No split pays but the leaf is big (or the tree is deep): halve by count. */
            if (mid < 0 && (cnt > LEAF_MAX || (it.depth >= FORCE_MEDIAN && cnt > 1)))
                mid = it.start + cnt / 2;
        }
        if (mid < 0) {
            nd->first = it.start;
            nd->count = cnt;
            continue;
        }
        nd->first = node_count;
        nd->count = 0;
        stack[sp++] = (build_item_t){node_count, it.start, mid, it.depth + 1};
        stack[sp++] = (build_item_t){node_count + 1, mid, it.end, it.depth + 1};
        node_count += 2;
    }
    for (int32_t i = 0; i < n; ++i) {
        const int32_t *t = tri + 3 * (size_t)idx[i];
        const float *a = pos + 3 * (size_t)t[0], *bb = pos + 3 * (size_t)t[1],
                    *c = pos + 3 * (size_t)t[2];
        bvh_tri_t *o = &b.tris[i];
        for (int k = 0; k < 3; ++k) {
            o->v0[k] = a[k];
            o->e1[k] = bb[k] - a[k];
            o->e2[k] = c[k] - a[k];
        }
        o->id = idx[i];
    }
    b.node_count = node_count;
    b.tri_count = n;
    free(tb); free(cen); free(idx); free(stack);
    b.plain = hbk_paths() == HBK_PATHS_SCALAR;
    if (collapse(&b)) {
        snow_bvh_free(&b);
        return HBK_ERR_OUT_OF_MEMORY;
    }
    *out = b;
    return HBK_OK;
}

/* Entry parameter of the segment into a box within [0, tmax], or +inf if it misses. */
static inline float slab(const bvh_node_t *n, const float o[3], const float inv[3], float tmax)
{
    float t0 = (n->lo[0] - o[0]) * inv[0], t1 = (n->hi[0] - o[0]) * inv[0];
    float tn = snow_min(t0, t1), tf = snow_max(t0, t1);
    t0 = (n->lo[1] - o[1]) * inv[1]; t1 = (n->hi[1] - o[1]) * inv[1];
    tn = snow_max(tn, snow_min(t0, t1)); tf = snow_min(tf, snow_max(t0, t1));
    t0 = (n->lo[2] - o[2]) * inv[2]; t1 = (n->hi[2] - o[2]) * inv[2];
    tn = snow_max(tn, snow_min(t0, t1)); tf = snow_min(tf, snow_max(t0, t1));
    tn = snow_max(tn, 0.0f);
    tf = snow_min(tf, tmax);
    return tn <= tf ? tn : INFINITY;
}

#if defined(__SSE2__)
/* The four children at once: per axis (lo - o) * inv and (hi - o) * inv, as slab() has them. */
static inline void wide_slab4(const bvh_wide_t *w, const float o[3], const float inv[3],
                              float tmax, float t[4])
{
    __m128 tn = _mm_setzero_ps(), tf = _mm_setzero_ps();
    for (int k = 0; k < 3; ++k) {
        const __m128 ok = _mm_set1_ps(o[k]), ik = _mm_set1_ps(inv[k]);
        const __m128 t0 = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(w->lo[k]), ok), ik);
        const __m128 t1 = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(w->hi[k]), ok), ik);
        const __m128 near = _mm_min_ps(t0, t1), far = _mm_max_ps(t0, t1);
        tn = k ? _mm_max_ps(tn, near) : near;
        tf = k ? _mm_min_ps(tf, far) : far;
    }
    tn = _mm_max_ps(tn, _mm_setzero_ps());
    tf = _mm_min_ps(tf, _mm_set1_ps(tmax));
    const __m128 in = _mm_cmple_ps(tn, tf);
    _mm_storeu_ps(t, _mm_or_ps(_mm_and_ps(in, tn), _mm_andnot_ps(in, _mm_set1_ps(INFINITY))));
}
#endif

/* slab() for the four children of a wide node, lane by lane the same operations in the same
 * order (so the same bits either way): t[c], child c's entry parameter, or +inf if the
 * segment misses its box. */
static inline void wide_slab(const bvh_wide_t *w, const float o[3], const float inv[3],
                             float tmax, int plain, float t[4])
{
#if defined(__SSE2__)
    if (!plain) {
        wide_slab4(w, o, inv, tmax, t);
        return;
    }
#endif
    for (int c = 0; c < 4; ++c) {
        float tn = 0.0f, tf = 0.0f;
        for (int k = 0; k < 3; ++k) {
            const float t0 = (w->lo[k][c] - o[k]) * inv[k], t1 = (w->hi[k][c] - o[k]) * inv[k];
            tn = k ? snow_max(tn, snow_min(t0, t1)) : snow_min(t0, t1);
            tf = k ? snow_min(tf, snow_max(t0, t1)) : snow_max(t0, t1);
        }
        tn = snow_max(tn, 0.0f);
        tf = snow_min(tf, tmax);
        t[c] = tn <= tf ? tn : INFINITY;
    }
}

typedef struct {
    int32_t first, count; /* as in bvh_wide_t */
    float t;              /* where the segment enters its box */
} stacked_t;

int snow_bvh_hit(const bvh_t *b, const float o[3], const float d[3], bvh_hit_t *hit)
{
    if (b->tri_count <= 0) return 0;
    float inv[3];
    for (int k = 0; k < 3; ++k) /* a tiny stand-in for 0 keeps the slabs free of NaN */
        inv[k] = 1.0f / (d[k] != 0.0f ? d[k] : copysignf(1e-30f, d[k]));
    float tmax = 1.0f;
    int found = 0;
    if (slab(&b->nodes[0], o, inv, tmax) == INFINITY) return 0;
    stacked_t stack[STACK];
    int32_t sp = 0, first = 0, count = 0;
    for (;;) {
        if (count > 0) {
            /* The nearest hit; of equally near ones the first in leaf order, so the answer
             * does not depend on the order the walk meets them. */
            for (int32_t i = first; i < first + count; ++i) {
                float tt, u, v;
                if (snow_ray_tri(&b->tris[i], o, d, &tt, &u, &v) &&
                    (tt < tmax || (tt == tmax && (!found || i < hit->tri)))) {
                    tmax = tt;
                    hit->t = tt; hit->b1 = u; hit->b2 = v; hit->tri = i;
                    found = 1;
                }
            }
        } else {
            const bvh_wide_t *w = &b->wide[first];
            float t[4];
            wide_slab(w, o, inv, tmax, b->plain, t);
            int near[4], nh = 0;
            for (int c = 0; c < 4; ++c) { /* the children entered, nearest first */
                if (w->count[c] < 0 || t[c] == INFINITY) continue;
                int j = nh++;
                for (; j > 0 && t[near[j - 1]] > t[c]; --j) near[j] = near[j - 1];
                near[j] = c;
            }
            if (nh > 0) {
                /* The nearest now: its hit shortens the segment for the others. */
                for (int j = nh - 1; j > 0; --j)
                    stack[sp++] = (stacked_t){w->first[near[j]], w->count[near[j]], t[near[j]]};
                first = w->first[near[0]];
                count = w->count[near[0]];
                continue;
            }
        }
        /* Pop, skipping children that now lie beyond the nearest hit. */
        for (;;) {
            if (sp == 0) return found;
            --sp;
            if (stack[sp].t <= tmax) break;
        }
        first = stack[sp].first;
        count = stack[sp].count;
    }
}
