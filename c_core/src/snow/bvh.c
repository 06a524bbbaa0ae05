/* Triangle BVH: binned SAH build, first-hit query for a segment. */
#include "internal_snow.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BINS 12
#define LEAF_MAX 4      /* leaves a split cannot improve may still hold up to this many */
#define FORCE_MEDIAN 64 /* past this depth split by count, so the stack below always fits */
#define STACK 128

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
    free(b->tris);
    memset(b, 0, sizeof *b);
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

int snow_bvh_hit(const bvh_t *b, const float o[3], const float d[3], bvh_hit_t *hit)
{
    if (b->tri_count <= 0) return 0;
    float inv[3];
    for (int k = 0; k < 3; ++k) /* a tiny stand-in for 0 keeps the slabs free of NaN */
        inv[k] = 1.0f / (d[k] != 0.0f ? d[k] : copysignf(1e-30f, d[k]));
    float tmax = 1.0f;
    int found = 0;
    if (slab(&b->nodes[0], o, inv, tmax) == INFINITY) return 0;
    int32_t stack[STACK], sp = 0, ni = 0;
    for (;;) {
        const bvh_node_t *n = &b->nodes[ni];
        if (n->count > 0) {
            for (int32_t i = n->first; i < n->first + n->count; ++i) {
                float tt, u, v;
                if (snow_ray_tri(&b->tris[i], o, d, &tt, &u, &v) && tt <= tmax) {
                    tmax = tt;
                    hit->t = tt; hit->b1 = u; hit->b2 = v; hit->tri = i;
                    found = 1;
                }
            }
        } else {
            const int32_t l = n->first, r = n->first + 1;
            const float tl = slab(&b->nodes[l], o, inv, tmax), tr = slab(&b->nodes[r], o, inv, tmax);
            if (tl != INFINITY && tr != INFINITY) {
                /* Nearer child first: its hit shortens the segment for the other. */
                if (tl <= tr) { stack[sp++] = r; ni = l; }
                else { stack[sp++] = l; ni = r; }
                continue;
            }
            if (tl != INFINITY) { ni = l; continue; }
            if (tr != INFINITY) { ni = r; continue; }
        }
        /* Pop, skipping nodes that now lie beyond the nearest hit. */
        for (;;) {
            if (sp == 0) return found;
            ni = stack[--sp];
            if (slab(&b->nodes[ni], o, inv, tmax) != INFINITY) break;
        }
    }
}
