/* The particle model near wipers (paper §4.2): equal-sized particles that push each other
 * apart and are pushed by the blades. */
#include "internal_rain.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

rain_particle_t *rain_new_particle(hbk_rain_t *h, float x, float y, double mass)
{
    if (h->particle_count == h->particle_cap) {
        int64_t cap = h->particle_cap ? 2 * h->particle_cap : 1024;
        rain_particle_t *q = realloc(h->particles, (size_t)cap * sizeof *q);
        if (!q) {
            h->alloc_failed = 1;
            return NULL;
        }
        h->particles = q;
        h->particle_cap = cap;
    }
    rain_particle_t *q = &h->particles[h->particle_count++];
    *q = (rain_particle_t){mass, x, y};
    return q;
}

/* Pushes particle q out of the blades it touches (to the leading edge, or the nearer edge of
 * a blade at rest). */
static void collide_one(rain_particle_t *q, const rain_blade_t *b, const int *lead, int nb,
                        float pr)
{
    for (int i = 0; i < nb; ++i) {
        const float rx = q->x - b[i].ox, ry = q->y - b[i].oy;
        const float u = rx * b[i].ax + ry * b[i].ay;
        if (u < 0.0f || u > b[i].len) continue; /* past the blade's ends */
        const float d = rx * b[i].nx + ry * b[i].ny;
        int s = lead[i];
        if (s == 0) {
            if (fabsf(d) >= b[i].half_w + pr) continue;
            s = d >= 0.0f ? 1 : -1;
        } else {
            /* Closer than its radius to the leading edge, or inside the blade. */
            const float dl = d * (float)s;
            if (!(dl > -b[i].half_w && dl < b[i].half_w + pr)) continue;
        }
        const float move = (float)s * (b[i].half_w + pr) - d;
        q->x += move * b[i].nx;
        q->y += move * b[i].ny;
    }
}

void rain_particles_collide(hbk_rain_t *h, const rain_blade_t *b, const int *lead, int nb,
                            const int64_t *cand, int64_t ncand, int64_t first_new)
{
    const float pr = h->p.particle_radius / h->p.cell_size;
    for (int64_t k = 0; k < ncand; ++k)
        if (h->particles[cand[k]].mass >= 0.0) collide_one(&h->particles[cand[k]], b, lead, nb, pr);
    for (int64_t k = first_new; k < h->particle_count; ++k)
        if (h->particles[k].mass >= 0.0) collide_one(&h->particles[k], b, lead, nb, pr);
}

static inline uint32_t hash_cell(int32_t bx, int32_t by, uint32_t mask)
{
    return (((uint32_t)bx * 73856093u) ^ ((uint32_t)by * 19349663u)) & mask;
}

int rain_particles_repel(hbk_rain_t *h, const int64_t *act, int64_t np)
{
    if (np < 2) return 1;
    uint32_t size = 64;
    while ((int64_t)size < 2 * np) size <<= 1;
    if (np > h->hash_cap || size > h->hash_size) {
        const int64_t cap = np > h->hash_cap ? 2 * np : h->hash_cap;
        const uint32_t hs = size > h->hash_size ? size : h->hash_size;
        uint32_t *st = realloc(h->hash_start, ((size_t)hs + 1) * sizeof *st);
        if (st) h->hash_start = st;
        uint32_t *it = realloc(h->hash_items, (size_t)cap * sizeof *it);
        if (it) h->hash_items = it;
        uint32_t *ky = realloc(h->hash_key, (size_t)cap * sizeof *ky);
        if (ky) h->hash_key = ky;
        int32_t *bn = realloc(h->hash_bin, 2 * (size_t)cap * sizeof *bn);
        if (bn) h->hash_bin = bn;
        float *dp = realloc(h->disp, 4 * (size_t)cap * sizeof *dp);
        if (dp) h->disp = dp;
        if (!st || !it || !ky || !bn || !dp) {
            h->alloc_failed = 1;
            return 0;
        }
        h->hash_cap = cap;
        h->hash_size = hs;
    }
    const uint32_t mask = size - 1;
    const float pr = h->p.particle_radius / h->p.cell_size, reach = 2.0f * pr;
    const float inv = 1.0f / reach, push = 0.5f * (1.0f + h->p.repulsion);
    uint32_t *start = h->hash_start, *order = h->hash_items, *key = h->hash_key;
    int32_t *bin = h->hash_bin;        /* hash cell of sorted entry t */
    float *pos = h->disp, *disp = h->disp + 2 * np; /* sorted positions, displacements */
    /* Counting sort by bucket, stable in the order of `act`; the sorted copy keeps each
     * bucket's particles next to each other in memory. */
    memset(start, 0, ((size_t)size + 1) * sizeof *start);
    for (int64_t i = 0; i < np; ++i) {
        const rain_particle_t *q = &h->particles[act[i]];
        key[i] = hash_cell((int32_t)floorf(q->x * inv), (int32_t)floorf(q->y * inv), mask);
        start[key[i] + 1]++;
    }
    for (uint32_t k = 0; k < size; ++k) start[k + 1] += start[k];
    for (int64_t i = 0; i < np; ++i) {
        const uint32_t t = start[key[i]]++;
        const rain_particle_t *q = &h->particles[act[i]];
        order[t] = (uint32_t)i;
        pos[2 * t] = q->x;
        pos[2 * t + 1] = q->y;
        bin[2 * t] = (int32_t)floorf(q->x * inv);
        bin[2 * t + 1] = (int32_t)floorf(q->y * inv);
    }
    for (uint32_t k = size; k > 0; --k) start[k] = start[k - 1];
    start[0] = 0;
    /* Jacobi: every displacement from the positions at the start of the pass, so the result
     * does not depend on the order or the threads. */
    const int threads = hbk_threads(h->p.threads);
#pragma omp parallel for num_threads(threads) schedule(static) if (np > 4096)
    for (int64_t t = 0; t < np; ++t) {
        float sx = 0.0f, sy = 0.0f;
        const float x = pos[2 * t], y = pos[2 * t + 1];
        const int32_t bx = bin[2 * t], by = bin[2 * t + 1];
        for (int32_t oy = -1; oy <= 1; ++oy)
            for (int32_t ox = -1; ox <= 1; ++ox) {
                const uint32_t kk = hash_cell(bx + ox, by + oy, mask);
                for (uint32_t u = start[kk]; u < start[kk + 1]; ++u) {
                    if ((int64_t)u == t || bin[2 * u] != bx + ox || bin[2 * u + 1] != by + oy)
                        continue; /* itself, or another cell hashed to this bucket */
                    const float dx = x - pos[2 * u], dy = y - pos[2 * u + 1];
                    const float d2 = dx * dx + dy * dy;
                    if (!(d2 < reach * reach)) continue;
                    const float d = sqrtf(d2);
                    if (d < 1e-6f * reach) {
                        /* On top of each other: part them along x, the earlier one left. */
                        sx += (order[u] > order[t] ? -1.0f : 1.0f) * push * reach;
                        continue;
                    }
                    /* Half the overlap each, plus that times the repulsion coefficient. */
                    const float m = push * (reach - d) / d;
                    sx += dx * m;
                    sy += dy * m;
                }
            }
        /* At most one radius per pass: in a pile many overlaps push the same way, and the sum
         * would overshoot (Jacobi) - far enough to carry a particle through a blade. */
        const float len2 = sx * sx + sy * sy;
        if (len2 > pr * pr) {
            const float k = pr / sqrtf(len2);
            sx *= k;
            sy *= k;
        }
        disp[2 * t] = sx;
        disp[2 * t + 1] = sy;
    }
    for (int64_t t = 0; t < np; ++t) {
        rain_particle_t *q = &h->particles[act[order[t]]];
        q->x += disp[2 * t];
        q->y += disp[2 * t + 1];
    }
    return 1;
}

void rain_particles_leave_glass(hbk_rain_t *h, int64_t first)
{
    /* Removed particles keep their place (mass -1) until the step commits, so that indices
     * stay valid during the step. */
    for (int64_t i = first; i < h->particle_count; ++i) {
        rain_particle_t *q = &h->particles[i];
        if (q->mass >= 0.0 && !rain_is_glass(h, (int32_t)floorf(q->x), (int32_t)floorf(q->y))) {
            h->wiped += q->mass;
            q->mass = -1.0;
        }
    }
}
