/* Blend weights: the base blend (advected, rewritten by the feature rules) under local paint
 * (advected, fading). The blend a vertex shows is base * (1 - a f) + paint * f, with a the
 * paint coverage (sum of its weights) and f its fade, so it sums to one whenever base does. */
#include "internal_lanes16.h"
#include <float.h>
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

void hbk_fluid_rules_compile(const hbk_fluid_t *h, hbk_fluid_rules_t *r)
{
    r->n = 0;
    r->lanes = hbk_fluid_lanes16_ok();
    for (int q = 0; q < 16 * h->K; ++q) {
        r->vtx16[q] = q / h->K;
        r->chan16[q] = q % h->K;
    }
    for (int t = 0; t < h->K; ++t) {
        if (!h->rule_on[t]) continue;
        const float *lo = h->rule_lo[t], *hi = h->rule_hi[t];
        for (int q = 0; q < 8 * HBK_FLUID_FEATURE_COUNT; ++q) {
            r->lo8[r->n][q] = lo[q % HBK_FLUID_FEATURE_COUNT];
            r->hi8[r->n][q] = hi[q % HBK_FLUID_FEATURE_COUNT];
        }
        r->r[r->n++] = (hbk_fluid_rule4_t){t,
                                           {lo[0], lo[1], lo[2], lo[3]},
                                           {hi[0], hi[1], hi[2], hi[3]},
                                           {lo[4], lo[5], lo[4], lo[5]},
                                           {hi[4], hi[5], hi[4], hi[5]}};
    }
}

/* The texture of the last rule (in texture order) whose every range holds features f, or -1.
 * Without branches per feature: which one fails is unpredictable. */
static inline int rule_match(const hbk_fluid_rules_t *r, const float *f)
{
    hbk_v4f a;
    memcpy(&a, f, sizeof a);
    const hbk_v4f b = {f[4], f[5], f[4], f[5]};
    int match = -1;
    for (int q = 0; q < r->n; ++q) {
        const hbk_fluid_rule4_t *p = &r->r[q];
        const hbk_v4i in = (a >= p->lo0) & (a <= p->hi0) & (b >= p->lo1) & (b <= p->hi1);
        match = __builtin_ia32_movmskps((hbk_v4f)in) == 15 ? p->t : match;
    }
    return match;
}

/* Makes b (K weights) one-hot at t; 1 if a bit changed (-0 is not +0). */
static inline int set_one_hot(float *b, int K, int t)
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

/* rule_match of the eight vertices whose features are at f (AVX-512), into tex[0 .. 8): their
 * 48 features are three vectors, each compared with the rule's bounds repeated, and a vertex
 * matches where its six bits are set. */
HBK_L16 static inline void match8(const hbk_fluid_rules_t *rl, const float *feat, uint8_t *tex)
{
    const __m512 f[3] = {_mm512_loadu_ps(feat), _mm512_loadu_ps(feat + 16),
                         _mm512_loadu_ps(feat + 32)};
    __m128i t = _mm_set1_epi8(-1);
    for (int q = 0; q < rl->n; ++q) { /* the last rule wins */
        __mmask16 mz[3];
        for (int z = 0; z < 3; ++z)
            mz[z] = _mm512_mask_cmp_ps_mask(
                _mm512_cmp_ps_mask(f[z], _mm512_loadu_ps(rl->lo8[q] + 16 * z), _CMP_GE_OQ), f[z],
                _mm512_loadu_ps(rl->hi8[q] + 16 * z), _CMP_LE_OQ);
        const uint64_t m = (uint64_t)mz[0] | (uint64_t)mz[1] << 16 | (uint64_t)mz[2] << 32;
        const uint64_t all = m & m >> 1 & m >> 2 & m >> 3 & m >> 4 & m >> 5;
        const __mmask16 hit = (__mmask16)_pext_u64(all, 0x041041041041ull); /* bit 6 v */
        t = _mm_mask_mov_epi8(t, hit, _mm_set1_epi8((char)rl->r[q].t));
    }
    _mm_storel_epi64((__m128i *)tex, t);
}

/* rule_match of vertices [i0, nx) of a row into tex (0xff: none). */
static void match_span(const hbk_fluid_rules_t *rl, const float *features, uint8_t *tex,
                       int32_t i0, int32_t nx)
{
    for (int32_t i = i0; i < nx; ++i)
        tex[i] = (uint8_t)rule_match(rl, features + HBK_FLUID_FEATURE_COUNT * (size_t)i);
}

HBK_L16 static void match_row8(const hbk_fluid_rules_t *rl, const float *features, uint8_t *tex,
                               int32_t nx)
{
    int32_t i = 0;
    for (; i + 8 <= nx; i += 8) match8(rl, features + HBK_FLUID_FEATURE_COUNT * (size_t)i, tex + i);
    match_span(rl, features, tex, i, nx);
}

void hbk_fluid_rules_match_row(const hbk_fluid_t *h, const hbk_fluid_rules_t *rl,
                               const float *features, size_t v0)
{
    uint8_t *tex = h->rule_tex + v0;
    if (rl->lanes)
        match_row8(rl, features, tex, h->nv[0]);
    else
        match_span(rl, features, tex, 0, h->nv[0]);
}

/* set_one_hot at tex[i] for vertices [i0, i1) of a row whose bases are at b (0xff: none). */
static int apply_span(float *b, int K, const uint8_t *tex, int32_t i0, int32_t i1)
{
    int changed = 0;
    for (int32_t i = i0; i < i1; ++i)
        if (tex[i] != 0xff) changed |= set_one_hot(b + (size_t)K * (size_t)i, K, tex[i]);
    return changed;
}

/* apply_span sixteen vertices at a time (AVX-512): their K * 16 weights are K vectors, each
 * float the vertex's texture test against its channel, without a branch per vertex (whether a
 * vertex matches, and whether it was one-hot already, are unpredictable). The weights are
 * written back whole: the same bits where nothing changes. */
HBK_L16 static int apply_row16(const hbk_fluid_rules_t *rl, float *b, int K, const uint8_t *tex,
                               int32_t nx)
{
    const __m512 one = _mm512_set1_ps(1.0f);
    __mmask16 changed = 0;
    int32_t i = 0;
    for (; i + 16 <= nx; i += 16) {
        const __m512i t = _mm512_cvtepu8_epi32(_mm_loadu_si128((const __m128i *)(tex + i)));
        if (_mm512_cmpneq_epi32_mask(t, _mm512_set1_epi32(0xff)) == 0) continue;
        float *p = b + (size_t)K * (size_t)i;
        for (int z = 0; z < K; ++z) {
            const __m512i tz =
                _mm512_permutexvar_epi32(_mm512_loadu_si512(rl->vtx16 + 16 * z), t);
            const __mmask16 set = _mm512_cmpneq_epi32_mask(tz, _mm512_set1_epi32(0xff));
            const __m512 old = _mm512_loadu_ps(p + 16 * z);
            const __m512i chan = _mm512_loadu_si512(rl->chan16 + 16 * z);
            const __m512 w = _mm512_maskz_mov_ps(_mm512_cmpeq_epi32_mask(tz, chan), one);
            changed |= _mm512_mask_cmpneq_epi32_mask(set, _mm512_castps_si512(old),
                                                     _mm512_castps_si512(w));
            _mm512_storeu_ps(p + 16 * z, _mm512_mask_mov_ps(old, set, w));
        }
    }
    return (changed != 0) | apply_span(b, K, tex, i, nx);
}

void hbk_fluid_rules_row(hbk_fluid_t *h, const hbk_fluid_rules_t *rl, float *base,
                         const float *features, size_t r)
{
    const int32_t nx = h->nv[0];
    const int K = h->K;
    const size_t v0 = r * (size_t)nx;
    int changed = 0;
    if (h->quiet[r]) {
        /* A quiet row (features.c) holds one set of features at every vertex: matched once. */
        const int whole = rule_match(rl, features + (size_t)HBK_FLUID_FEATURE_COUNT * v0);
        if (whole == -1) return;
        /* Far from the fluid the rows stay the same from frame to frame: a row the rule made
         * one-hot in both buffers is left alone (most of a box's rows, 129 compares each). A
         * quiet row is still, so the advection has just made it the same in both buffers, and
         * forgot rows_hot if it had to copy. */
        if (h->rows_hot[r] == whole) return;
        for (size_t i = v0; i < v0 + (size_t)nx; ++i)
            changed |= set_one_hot(base + (size_t)K * i, K, whole);
        if (!changed) h->rows_hot[r] = (uint8_t)whole;
    } else if (rl->lanes)
        changed = apply_row16(rl, base + (size_t)K * v0, K, h->rule_tex + v0, nx);
    else
        changed = apply_span(base + (size_t)K * v0, K, h->rule_tex + v0, 0, nx);
    if (changed) h->same_rows[r] = 0; /* no longer the other buffer's base */
}

static hbk_result_t check_texture(hbk_fluid_t *h, int32_t texture)
{
    if (texture < 0 || texture >= h->K)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "texture = %d: must be in [0, %d] (textures = %d)", texture, h->K - 1, h->K);
    return HBK_OK;
}

/* Coverage of a ball: 1 within radius, then linear to 0 over falloff. */
static inline float ball(float d, float radius, float falloff)
{
    if (d <= radius) return 1.0f;
    return falloff > 0.0f && d < radius + falloff ? 1.0f - (d - radius) / falloff : 0.0f;
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
            m = ball(sqrtf(dx * dx + dy * dy + dz * dz), radius, falloff);
        }
        if (m <= 0.0f) continue;
        float *pw = h->v.paint + (size_t)K * i;
        const float f = fade(&h->p, h->v.life[i]);
        for (int t = 0; t < K; ++t) pw[t] = pw[t] * f * (1.0f - m);
        pw[texture] += m;
        h->v.life[i] = L;
    }
    h->paint_active = 1;
    memset(h->v.unpainted, 0, h->n_rows); /* not known */
    hbk_fluid_vols_differ(h);
    return HBK_OK;
}

hbk_result_t hbk_fluid_paint_mask(hbk_fluid_t *h, int32_t texture, const float *mask)
{
    HBK_FLUID_ENTER(h);
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
    HBK_FLUID_ENTER(h);
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

hbk_result_t hbk_fluid_paint_points(hbk_fluid_t *h, int32_t texture, int32_t count,
                                    const float *pos, const float *coverage, float radius,
                                    float falloff)
{
    HBK_FLUID_ENTER(h);
    hbk_result_t r = check_texture(h, texture);
    if (r) return r;
    if (count < 0)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "count = %d: must be >= 0", count);
    if (count > 0 && !pos)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "pos: must not be NULL");
    float cmin = h->cell[0] < h->cell[1] ? h->cell[0] : h->cell[1];
    cmin = h->cell[2] < cmin ? h->cell[2] : cmin;
    const float reach = 16.0f * cmin;
    if (!(radius >= 0.0f && radius <= reach))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "radius = %g: must be in [0, %g] m (16 cells)", (double)radius, (double)reach);
    if (!(falloff >= 0.0f && radius + falloff <= reach))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "falloff = %g: must be in [0, %g] m (radius + falloff within 16 cells)",
                        (double)falloff, (double)(reach - radius));
    for (int32_t i = 0; i < count; ++i) {
        for (int a = 0; a < 3; ++a)
            if (!isfinite(pos[3 * (size_t)i + (size_t)a]))
                return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "pos[%d][%d] = %g: must be finite",
                                i, a, (double)pos[3 * (size_t)i + (size_t)a]);
        if (coverage && !(coverage[i] >= 0.0f && coverage[i] <= 1.0f))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "coverage[%d] = %g: must be in [0, 1]", i, (double)coverage[i]);
    }
    int32_t any = 0;
    for (int32_t i = 0; i < count && !any; ++i) any = !coverage || coverage[i] > 0.0f;
    if (!any) return HBK_OK; /* nothing to paint: the paint stays as it is, untouched */
    float *mask = calloc(h->n_vert, sizeof(float));
    if (!mask) return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "paint points: out of memory");
    const float R = radius + falloff;
    for (int32_t i = 0; i < count; ++i) {
        const float *x = pos + 3 * (size_t)i;
        const float c = coverage ? coverage[i] : 1.0f;
        if (c <= 0.0f) continue;
        int32_t lo[3], hi[3];
        for (int a = 0; a < 3; ++a) { /* the grid vertices the ball may reach, clamped */
            const double g0 = ((double)x[a] - R - h->p.box_min[a]) / h->cell[a];
            const double g1 = ((double)x[a] + R - h->p.box_min[a]) / h->cell[a];
            lo[a] = g0 < 0.0 ? 0 : g0 > h->nv[a] ? h->nv[a] : (int32_t)ceil(g0);
            hi[a] = g1 < 0.0 ? -1 : g1 >= h->nv[a] - 1 ? h->nv[a] - 1 : (int32_t)floor(g1);
        }
        for (int32_t k = lo[2]; k <= hi[2]; ++k)
            for (int32_t j = lo[1]; j <= hi[1]; ++j)
                for (int32_t q = lo[0]; q <= hi[0]; ++q) {
                    /* The vertex's position as the sphere stroke computes it. */
                    const float dx = h->p.box_min[0] + (float)q * h->cell[0] - x[0];
                    const float dy = h->p.box_min[1] + (float)j * h->cell[1] - x[1];
                    const float dz = h->p.box_min[2] + (float)k * h->cell[2] - x[2];
                    const float m = c * ball(sqrtf(dx * dx + dy * dy + dz * dz), radius, falloff);
                    float *v = mask + (size_t)q +
                               (size_t)h->nv[0] * ((size_t)j + (size_t)h->nv[1] * (size_t)k);
                    *v = m > *v ? m : *v;
                }
    }
    r = stroke(h, texture, mask, NULL, 0, 0);
    free(mask);
    return r;
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
    HBK_FLUID_ENTER(h);
    hbk_fluid_paint_off(h);
    return HBK_OK;
}

hbk_result_t hbk_fluid_set_feature_rule(hbk_fluid_t *h, int32_t texture,
                                        const float lo[HBK_FLUID_FEATURE_COUNT],
                                        const float hi[HBK_FLUID_FEATURE_COUNT])
{
    HBK_FLUID_ENTER(h);
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
    HBK_FLUID_ENTER(h);
    hbk_result_t r = check_texture(h, texture);
    if (r) return r;
    h->rule_on[texture] = 0;
    return HBK_OK;
}

hbk_result_t hbk_fluid_capture_feature_rule(hbk_fluid_t *h, int32_t texture, const float *mask)
{
    HBK_FLUID_ENTER(h);
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
