/* The paper's sticking chances (§3.2.2, §4.1.1-4.1.6) and stamps (§3.3.1, §4.1.7-4.1.8). */
#include "internal_snow.h"
#include <math.h>

static const hbk_snow_params_t *or_paper(const hbk_snow_params_t *p)
{
    return p ? p : snow_params_paper();
}

static float lerp_at(float x, float x0, float x1, float y0, float y1)
{
    return y0 + (y1 - y0) * ((x - x0) / (x1 - x0));
}

float hbk_snow_water_content(const hbk_snow_params_t *p, float temp_c)
{
    p = or_paper(p);
    if (!(temp_c >= p->wet_temperature)) return 0.0f; /* dry snow holds no liquid water */
    float w = lerp_at(temp_c, p->water_temperature[0], p->water_temperature[1],
                      p->water_content[0], p->water_content[1]);
    return fminf(fmaxf(w, 0.0f), 100.0f);
}

float hbk_snow_tension_chance(const hbk_snow_params_t *p, float water_content)
{
    p = or_paper(p);
    const float *w = p->tension_water, *c = p->tension_chance;
    float pc;
    if (!(water_content > 0.0f)) pc = 0.0f;
    else if (water_content < w[0]) pc = c[0] * (water_content / w[0]); /* rises from 0 at 0 % */
    else if (water_content <= w[1]) pc = lerp_at(water_content, w[0], w[1], c[0], c[1]);
    else if (water_content <= w[2]) pc = lerp_at(water_content, w[1], w[2], c[1], c[2]);
    else pc = 0.0f; /* too wet: the paper lets almost nothing stick */
    return fminf(fmaxf(pc * 0.01f, 0.0f), 1.0f);
}

float hbk_snow_sinter_chance(const hbk_snow_params_t *p, float temp_c)
{
    p = or_paper(p);
    const float *t = p->sinter_temperature, *c = p->sinter_chance;
    float pc = temp_c <= t[0] ? c[0] : temp_c >= t[1] ? c[1] : lerp_at(temp_c, t[0], t[1], c[0], c[1]);
    return fminf(fmaxf(pc * 0.01f, 0.0f), 1.0f);
}

float hbk_snow_stick_chance(const hbk_snow_params_t *p, float temp_c)
{
    p = or_paper(p);
    if (temp_c >= p->wet_temperature)
        return hbk_snow_tension_chance(p, hbk_snow_water_content(p, temp_c));
    return hbk_snow_sinter_chance(p, temp_c);
}

float hbk_snow_hit_chance(const hbk_snow_params_t *p, float temp_c, float catch_chance)
{
    float c = fminf(fmaxf(catch_chance, 0.0f), 1.0f); /* also maps NaN to 0 */
    return 1.0f - (1.0f - hbk_snow_stick_chance(p, temp_c)) * (1.0f - c);
}

float hbk_snow_bleed(const hbk_snow_params_t *p, float water_content)
{
    p = or_paper(p);
    const float *w = p->bleed_water, *b = p->bleed;
    if (water_content <= w[0]) return b[0];
    if (water_content >= w[1]) return b[1];
    return lerp_at(water_content, w[0], w[1], b[0], b[1]);
}

float snow_cell_alpha(const hbk_snow_params_t *p, int wet, float bleed, int kind, float r)
{
    float a;
    if (wet) {
        const float *s = p->wet_stamp + 3 * kind;
        a = s[0] + s[1] * r + s[2] * bleed;
    } else {
        const float *s = p->dry_stamp + 2 * kind;
        a = s[0] + s[1] * r;
    }
    return a > 0.0f ? a : 0.0f;
}

static int cell_kind(int dx, int dy) { return (dx != 0) + (dy != 0); }

void hbk_snow_stamp_alpha(const hbk_snow_params_t *p, float temp_c, float r, float alpha[9])
{
    if (!alpha) return;
    p = or_paper(p);
    const int wet = temp_c >= p->wet_temperature;
    const float d = hbk_snow_bleed(p, hbk_snow_water_content(p, temp_c));
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
            alpha[(dy + 1) * 3 + dx + 1] = snow_cell_alpha(p, wet, d, cell_kind(dx, dy), r);
}

/* Texel ranges [lo[k], hi[k]) of the three stamp cells along one axis, clipped to
 * [clip0, clip1), and the alpha weight of that axis. A cell of s >= 1 texels takes the texels
 * whose centres lie in it; a smaller one takes the texel hit and its neighbours, weighted by
 * s so that the snow per area is the same at any resolution. */
static float cells_1d(float c, float s, int32_t clip0, int32_t clip1, int32_t lo[3],
                      int32_t hi[3])
{
    float w = 1.0f;
    /* Clamp before converting so that far-off hits cannot overflow int32. */
    const float lim0 = (float)clip0 - 2.0f * s - 2.0f, lim1 = (float)clip1 + 2.0f * s + 2.0f;
    c = fminf(fmaxf(c, lim0), lim1);
    if (s < 1.0f) {
        w = s;
        int32_t i = (int32_t)floorf(c);
        for (int k = 0; k < 3; ++k) {
            lo[k] = i - 1 + k;
            hi[k] = lo[k] + 1;
        }
    } else {
        for (int k = 0; k < 3; ++k) {
            lo[k] = (int32_t)ceilf(c + s * ((float)k - 1.5f) - 0.5f);
            hi[k] = (int32_t)ceilf(c + s * ((float)k - 0.5f) - 0.5f);
        }
    }
    for (int k = 0; k < 3; ++k) {
        if (lo[k] < clip0) lo[k] = clip0;
        if (hi[k] > clip1) hi[k] = clip1;
    }
    return w;
}

void snow_stamp(hbk_snow_t *h, const snow_event_t *e)
{
    const hbk_snow_params_t *p = &h->p;
    int32_t rect[4]; /* x0, y0, x1, y1 (exclusive) */
    if (p->contact_mode == HBK_SNOW_CONTACT_BOX) {
        snow_box_tile(h, e->prim / 6, e->prim % 6, rect);
    } else {
        rect[0] = 0; rect[1] = 0; rect[2] = h->tex_w; rect[3] = h->tex_h;
    }
    int32_t xlo[3], xhi[3], ylo[3], yhi[3];
    const float wx = cells_1d(e->tx, e->sx, rect[0], rect[2], xlo, xhi);
    const float wy = cells_1d(e->ty, e->sy, rect[1], rect[3], ylo, yhi);
    const int wet = p->temperature >= p->wet_temperature;
    const float bleed = hbk_snow_bleed(p, hbk_snow_water_content(p, p->temperature));
    const float dpf = p->depth_per_flake * (1.0f / 255.0f);
    const size_t stride = (size_t)h->tex_w;
    for (int ky = 0; ky < 3; ++ky)
        for (int kx = 0; kx < 3; ++kx) {
            float a = snow_cell_alpha(p, wet, bleed, cell_kind(kx - 1, ky - 1), e->r);
            if (wx != 1.0f || wy != 1.0f) a *= wx * wy; /* keeps the s >= 1 case exact */
            if (a <= 0.0f) continue;
            const float dd = dpf * a;
            for (int32_t y = ylo[ky]; y < yhi[ky]; ++y) {
                float *cov = h->coverage + (size_t)y * stride, *dep = h->depth + (size_t)y * stride;
                for (int32_t x = xlo[kx]; x < xhi[kx]; ++x) {
                    const float c = cov[x] + a;
                    cov[x] = c < 255.0f ? c : 255.0f;
                    dep[x] += dd;
                }
            }
        }
}
