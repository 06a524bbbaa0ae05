/* Blend weights: the base blend (advected, rewritten by the feature rules) under local paint
 * (advected, fading). The blend a vertex shows is base * (1 - a f) + paint * f, with a the
 * paint coverage (sum of its weights) and f its fade, so it sums to one whenever base does. */
#include "internal_fluid.h"
#include <float.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

static inline float fade(const hbk_fluid_params_t *p, float life)
{
    if (life <= 0.0f) return 0.0f;
    if (p->paint_fade <= 0.0f || life >= p->paint_fade) return 1.0f;
    return life / p->paint_fade;
}

void hbk_fluid_blend_at(const hbk_fluid_t *h, const float *base, const float *paint,
                        const float *life, size_t i, float *out)
{
    const int K = h->K;
    const float *b = base + (size_t)K * i;
    float f = 0.0f, cov = 0.0f;
    if (h->paint_active) {
        f = fade(&h->p, life[i]);
        for (int t = 0; t < K; ++t) cov += paint[(size_t)K * i + (size_t)t];
    }
    float s = 0.0f;
    for (int t = 0; t < K; ++t) {
        out[t] = b[t] * (1.0f - cov * f) + (f > 0.0f ? paint[(size_t)K * i + (size_t)t] * f : 0.0f);
        s += out[t];
    }
    if (s > 0.0f) for (int t = 0; t < K; ++t) out[t] /= s;
}

/* The rules, four features to a vector: features 0-3, then 4-5 twice. */
typedef struct {
    int t;
    hbk_v4f lo0, hi0, lo1, hi1;
} rule4_t;
_Static_assert(HBK_FLUID_FEATURE_COUNT == 6, "rule4_t holds six features");

static int rules_compile(const hbk_fluid_t *h, rule4_t *r)
{
    int n = 0;
    for (int t = 0; t < h->K; ++t) {
        if (!h->rule_on[t]) continue;
        const float *lo = h->rule_lo[t], *hi = h->rule_hi[t];
        r[n++] = (rule4_t){t, {lo[0], lo[1], lo[2], lo[3]}, {hi[0], hi[1], hi[2], hi[3]},
                           {lo[4], lo[5], lo[4], lo[5]}, {hi[4], hi[5], hi[4], hi[5]}};
    }
    return n;
}

/* The texture of the last rule (in texture order) whose every range holds features f, or -1.
 * Without branches per feature: which one fails is unpredictable. */
static inline int rule_match(const rule4_t *r, int n, const float *f)
{
    hbk_v4f a;
    memcpy(&a, f, sizeof a);
    const hbk_v4f b = {f[4], f[5], f[4], f[5]};
    int match = -1;
    for (int q = 0; q < n; ++q) {
        const hbk_v4i in = (a >= r[q].lo0) & (a <= r[q].hi0) & (b >= r[q].lo1) & (b <= r[q].hi1);
        match = __builtin_ia32_movmskps((hbk_v4f)in) == 15 ? r[q].t : match;
    }
    return match;
}

/* Makes b (K weights) one-hot at t; 1 if a bit changed (-0 is not +0). */
static int set_one_hot(float *b, int K, int t)
{
    uint32_t diff = 0; /* inline: memcmp is a call per vertex */
    for (int q = 0; q < K; ++q) {
        uint32_t x;
        memcpy(&x, b + q, sizeof x);
        diff |= x ^ (q == t ? 0x3f800000u : 0u); /* the bits of 1.0f and +0.0f */
    }
    if (!diff) return 0;
    for (int q = 0; q < K; ++q) b[q] = q == t ? 1.0f : 0.0f;
    return 1;
}

void hbk_fluid_apply_rules(hbk_fluid_t *h, float *base, const float *features, int threads)
{
    rule4_t rl[HBK_FLUID_MAX_TEXTURES];
    const int nr = rules_compile(h, rl);
    if (!nr) return;
    const int32_t nx = h->nv[0], rows = h->nv[1] * h->nv[2];
    const int K = h->K, F = HBK_FLUID_FEATURE_COUNT;
    /* By rows: a row whose base this changes no longer matches the other buffer's. A quiet row
     * (features.c) holds one set of features at every vertex: matched once, and its
     * features not read again. */
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t r = 0; r < rows; ++r) {
        const size_t v0 = (size_t)r * (size_t)nx;
        const int whole = h->quiet[r] ? rule_match(rl, nr, features + (size_t)F * v0) : -2;
        if (whole == -1) continue;
        int changed = 0;
        for (size_t i = v0; i < v0 + (size_t)nx; ++i) {
            const int match = whole >= 0 ? whole : rule_match(rl, nr, features + (size_t)F * i);
            if (match >= 0) changed |= set_one_hot(base + (size_t)K * i, K, match);
        }
        if (changed) h->same_rows[r] = 0;
    }
}

#define ENTER(h)                                      \
    do {                                              \
        if (!(h)) return HBK_ERR_INVALID_ARGUMENT;    \
        hbk_message_clear(&(h)->msg);                 \
    } while (0)

static hbk_result_t check_texture(hbk_fluid_t *h, int32_t texture)
{
    if (texture < 0 || texture >= h->K)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "texture = %d: must be in [0, %d] (textures = %d)", texture, h->K - 1, h->K);
    return HBK_OK;
}

/* Lays a stroke of coverage mask[i] (or the sphere's) over the paint. Old paint is first
 * baked to its current fade, so a refreshed life never revives faded paint. */
static hbk_result_t stroke(hbk_fluid_t *h, int32_t texture, const float *mask,
                           const float *center, float radius, float falloff)
{
    const int K = h->K;
    const size_t nv = h->n_vert;
    const float L = h->p.paint_duration + h->p.paint_fade;
    if (!h->paint_active) {
        memset(h->v.paint, 0, nv * (size_t)K * sizeof(float));
        memset(h->v.life, 0, nv * sizeof(float));
    }
    for (size_t i = 0; i < nv; ++i) {
        float m;
        if (mask) m = mask[i];
        else {
            const size_t ix = i % (size_t)h->nv[0], iy = (i / (size_t)h->nv[0]) % (size_t)h->nv[1],
                         iz = i / ((size_t)h->nv[0] * (size_t)h->nv[1]);
            const float dx = h->p.box_min[0] + (float)ix * h->cell[0] - center[0];
            const float dy = h->p.box_min[1] + (float)iy * h->cell[1] - center[1];
            const float dz = h->p.box_min[2] + (float)iz * h->cell[2] - center[2];
            const float d = sqrtf(dx * dx + dy * dy + dz * dz);
            m = d <= radius ? 1.0f : falloff > 0.0f && d < radius + falloff ? 1.0f - (d - radius) / falloff : 0.0f;
        }
        if (m <= 0.0f) continue;
        float *pw = h->v.paint + (size_t)K * i;
        const float f = fade(&h->p, h->v.life[i]);
        for (int t = 0; t < K; ++t) pw[t] = pw[t] * f * (1.0f - m);
        pw[texture] += m;
        h->v.life[i] = L;
    }
    h->paint_active = 1;
    hbk_fluid_vols_differ(h);
    return HBK_OK;
}

hbk_result_t hbk_fluid_paint_mask(hbk_fluid_t *h, int32_t texture, const float *mask)
{
    ENTER(h);
    hbk_result_t r = check_texture(h, texture);
    if (r) return r;
    if (!mask) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "mask: must not be NULL");
    for (size_t i = 0; i < h->n_vert; ++i)
        if (!(mask[i] >= 0.0f && mask[i] <= 1.0f))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "mask[%zu] = %g: must be a finite number in [0, 1]", i, (double)mask[i]);
    return stroke(h, texture, mask, NULL, 0, 0);
}

hbk_result_t hbk_fluid_paint_sphere(hbk_fluid_t *h, int32_t texture, const float center[3],
                                    float radius, float falloff)
{
    ENTER(h);
    hbk_result_t r = check_texture(h, texture);
    if (r) return r;
    if (!center) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "center: must not be NULL");
    for (int a = 0; a < 3; ++a)
        if (!isfinite(center[a]))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "center[%d] = %g: must be finite",
                            a, (double)center[a]);
    if (!(radius >= 0.0f && radius <= 1e4f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "radius = %g: must be in [0, 1e4] m",
                        (double)radius);
    if (!(falloff >= 0.0f && falloff <= 1e4f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "falloff = %g: must be in [0, 1e4] m",
                        (double)falloff);
    return stroke(h, texture, NULL, center, radius, falloff);
}

/* No paint: both buffers' paint and life are zero, so that a saved state never holds stale
 * paint from whichever buffer the last swap left (the advection skips them meanwhile). */
void hbk_fluid_paint_off(hbk_fluid_t *h)
{
    const size_t nv = h->n_vert, K = (size_t)h->K;
    h->paint_active = 0;
    memset(h->v.paint, 0, nv * K * sizeof(float));
    memset(h->v.life, 0, nv * sizeof(float));
    memset(h->scratch.paint, 0, nv * K * sizeof(float));
    memset(h->scratch.life, 0, nv * sizeof(float));
}

hbk_result_t hbk_fluid_clear_paint(hbk_fluid_t *h)
{
    ENTER(h);
    hbk_fluid_paint_off(h);
    return HBK_OK;
}

hbk_result_t hbk_fluid_set_feature_rule(hbk_fluid_t *h, int32_t texture,
                                        const float lo[HBK_FLUID_FEATURE_COUNT],
                                        const float hi[HBK_FLUID_FEATURE_COUNT])
{
    ENTER(h);
    hbk_result_t r = check_texture(h, texture);
    if (r) return r;
    if (!lo || !hi)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s: must not be NULL", lo ? "hi" : "lo");
    for (int c = 0; c < HBK_FLUID_FEATURE_COUNT; ++c)
        if (isnan(lo[c]) || isnan(hi[c]) || lo[c] > hi[c])
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "lo[%d] = %g, hi[%d] = %g: must be numbers with lo <= hi", c,
                            (double)lo[c], c, (double)hi[c]);
    memcpy(h->rule_lo[texture], lo, sizeof h->rule_lo[texture]);
    memcpy(h->rule_hi[texture], hi, sizeof h->rule_hi[texture]);
    h->rule_on[texture] = 1;
    return HBK_OK;
}

hbk_result_t hbk_fluid_clear_feature_rule(hbk_fluid_t *h, int32_t texture)
{
    ENTER(h);
    hbk_result_t r = check_texture(h, texture);
    if (r) return r;
    h->rule_on[texture] = 0;
    return HBK_OK;
}

hbk_result_t hbk_fluid_capture_feature_rule(hbk_fluid_t *h, int32_t texture, const float *mask)
{
    ENTER(h);
    hbk_result_t r = check_texture(h, texture);
    if (r) return r;
    if (!mask) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "mask: must not be NULL");
    const int F = HBK_FLUID_FEATURE_COUNT, which = h->p.texture_feature[texture];
    float lo[HBK_FLUID_FEATURE_COUNT], hi[HBK_FLUID_FEATURE_COUNT], slo[HBK_FLUID_FEATURE_COUNT],
        shi[HBK_FLUID_FEATURE_COUNT];
    for (int c = 0; c < F; ++c) { slo[c] = FLT_MAX; shi[c] = -FLT_MAX; }
    size_t n = 0;
    for (size_t i = 0; i < h->n_vert; ++i) {
        if (!(mask[i] >= 0.5f)) continue;
        ++n;
        for (int c = 0; c < F; ++c) {
            const float v = h->features[(size_t)F * i + (size_t)c];
            slo[c] = v < slo[c] ? v : slo[c];
            shi[c] = v > shi[c] ? v : shi[c];
        }
    }
    if (!n)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "mask: selects no vertex (none >= 0.5)");
    for (int c = 0; c < F; ++c) {
        const int use = which == F || which == c;
        lo[c] = use ? slo[c] : -FLT_MAX;
        hi[c] = use ? shi[c] : FLT_MAX;
    }
    return hbk_fluid_set_feature_rule(h, texture, lo, hi);
}
