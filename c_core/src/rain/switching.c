/* Switching between the models (paper §4.3-4.6): drops touched by a blade become particles;
 * particles that have left the region around every blade become drops again, unless a big
 * drop nearby holds them back. */
#include "internal_rain.h"
#include <math.h>
#include <stdlib.h>

float rain_blade_distance(const rain_blade_t *b, float x, float y)
{
    const float rx = x - b->ox, ry = y - b->oy;
    float u = rx * b->ax + ry * b->ay;
    u = u < 0.0f ? 0.0f : u > b->len ? b->len : u;
    const float dx = rx - u * b->ax, dy = ry - u * b->ay;
    const float d = sqrtf(dx * dx + dy * dy) - b->half_w;
    return d > 0.0f ? d : 0.0f;
}

int rain_to_particles(hbk_rain_t *h, const rain_blade_t *b, const int *lead, int nb,
                      const int64_t *cand, int64_t ncand)
{
    const double pm = h->p.particle_mass;
    for (int64_t c = 0; c < ncand; ++c) {
        const int64_t i = cand[c];
        const rain_drop_t *d = &h->drops[i];
        if (d->flags & DROP_DEAD) continue;
        const float r = rain_radius_cells(h, d->mass);
        int touched = 0;
        for (int k = 0; k < nb && !touched; ++k) {
            if (!(rain_blade_distance(&b[k], d->x, d->y) < r)) continue;
            /* Touching the trailing side of a blade that moves away is not a touch. */
            const float side = ((d->x - b[k].ox) * b[k].nx + (d->y - b[k].oy) * b[k].ny) *
                               (float)lead[k];
            touched = lead[k] == 0 || side > -b[k].half_w;
        }
        if (!touched) continue;
        /* mass / particle_mass particles (the masses share the drop's exactly), jittered
         * around the drop within its radius. */
        double n = floor(d->mass / pm + 0.5);
        n = n < 1.0 ? 1.0 : n > 4096.0 ? 4096.0 : n;
        const int32_t count = (int32_t)n;
        const double each = d->mass / n;
        const float x = d->x, y = d->y;
        const uint64_t id = d->id;
        double left = d->mass;
        for (int32_t k = 0; k < count; ++k) {
            float px = x, py = y;
            if (count > 1) {
                uint32_t rr[4];
                hbk_philox(h->p.seed, RAIN_STREAM_SPLIT, (id << 24) | (uint64_t)k, rr);
                const float rho = r * sqrtf(hbk_u32_to_unit(rr[0]));
                const float phi = 2.0f * (float)M_PI * hbk_u32_to_unit(rr[1]);
                px += rho * cosf(phi);
                py += rho * sinf(phi);
            }
            const double m = k + 1 == count ? left : each;
            left -= m;
            if (!rain_new_particle(h, px, py, m)) return 0;
        }
        rain_kill_drop(h, i);
    }
    return 1;
}

/* Is a drop of at least holdback_mass in the square of half size R around cell (cx, cy), R
 * the larger of holdback_radius and that drop's merge reach with a particle of `mass`? The
 * square is then always wider than the merge limit, as the paper asks, however big the drop:
 * a conversion can never merge with a big drop the search did not see. Only blocks whose
 * radius bound allows a big drop within reach are visited. */
static int held_back(const hbk_rain_t *h, int32_t cx, int32_t cy, double mass)
{
    const int32_t W = h->p.width, H = h->p.height, B = RAIN_BLOCK;
    const float md = h->p.merge_distance, rp = rain_radius_cells(h, mass);
    const float r_big = rain_radius_cells(h, h->p.holdback_mass);
    const double big = h->p.holdback_mass;
    const float hr = (float)h->p.holdback_radius;
    const float far_m = ceilf(md * (rp + h->r_max)), far = far_m > hr ? far_m : hr;
    const int32_t f = (int32_t)far;
    const int32_t bx0 = clampi(cx - f, 0, W - 1) / B, bx1 = clampi(cx + f, 0, W - 1) / B;
    const int32_t by0 = clampi(cy - f, 0, H - 1) / B, by1 = clampi(cy + f, 0, H - 1) / B;
    for (int32_t by = by0; by <= by1; ++by)
        for (int32_t bx = bx0; bx <= bx1; ++bx) {
            const float rb = h->blk_r[(size_t)by * (size_t)h->blk_w + (size_t)bx];
            if (rb < r_big) continue; /* no drop of holdback_mass in this block */
            const float rr = ceilf(md * (rp + rb));
            const int32_t reach = rr > hr ? (int32_t)rr : (int32_t)hr;
            const int32_t x0 = clampi(cx - reach, bx * B, W - 1);
            const int32_t x1 = clampi(cx + reach, 0, mini(bx * B + B, W) - 1);
            const int32_t y0 = clampi(cy - reach, by * B, H - 1);
            const int32_t y1 = clampi(cy + reach, 0, mini(by * B + B, H) - 1);
            for (int32_t y = y0; y <= y1; ++y)
                for (int32_t x = rain_next_occ(h, y, x0, x1); x <= x1;
                     x = rain_next_occ(h, y, x + 1, x1)) {
                    const int32_t j = h->occ[(size_t)y * (size_t)W + (size_t)x];
                    if (h->drops[j].mass < big) continue;
                    const float rm = ceilf(md * (rp + rain_radius_cells(h, h->drops[j].mass)));
                    const int32_t rj = rm > hr ? (int32_t)rm : (int32_t)hr;
                    if (abs(x - cx) <= rj && abs(y - cy) <= rj) return 1;
                }
        }
    return 0;
}

int rain_to_drops(hbk_rain_t *h)
{
    const int nb = h->p.wiper_count;
    if (h->particle_count == 0) return 1;
    rain_blade_t b[2];
    for (int i = 0; i < nb; ++i) rain_blade_at(h, i, h->wiper_value[i], &b[i]);
    const float margin = h->p.switch_margin / h->p.cell_size;
    const float pr = h->p.particle_radius / h->p.cell_size;
    int64_t j = 0;
    for (int64_t k = 0; k < h->particle_count; ++k) {
        const rain_particle_t q = h->particles[k];
        if (!(q.mass >= 0.0)) continue; /* wiped off this step */
        int near = 0;
        for (int i = 0; i < nb && !near; ++i) near = rain_blade_distance(&b[i], q.x, q.y) <= margin;
        const int32_t cx = (int32_t)floorf(q.x), cy = (int32_t)floorf(q.y);
        if (!near && !(h->p.holdback && held_back(h, cx, cy, q.mass))) {
            if (!rain_land(h, q.x, q.y, q.mass)) return 0;
            continue;
        }
        rain_mark_wet(h, q.x, q.y, pr);
        h->particles[j++] = q;
    }
    h->particle_count = j;
    return 1;
}
