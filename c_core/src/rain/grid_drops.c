/* The grid model (paper §4.1, after Kaneda et al.): drops that sit until they overcome static
 * friction, then run cell by cell along the force, choosing among three neighbours by the
 * glass's affinity; merging, trail drops and the film they leave; rain arrivals. */
#include "internal_rain.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The 8 neighbours, counter-clockwise from +x. */
static const int8_t k_dir[8][2] = {{1, 0}, {1, 1}, {0, 1}, {-1, 1},
                                   {-1, 0}, {-1, -1}, {0, -1}, {1, -1}};

static inline int32_t cell_of(float v) { return (int32_t)floorf(v); }

int rain_is_glass(const hbk_rain_t *h, int32_t cx, int32_t cy)
{
    if (cx < 0 || cy < 0 || cx >= h->p.width || cy >= h->p.height) return 0;
    return !h->mask || h->mask[(size_t)cy * (size_t)h->p.width + (size_t)cx] >= 0.5f;
}

void rain_accel_at(const hbk_rain_t *h, int32_t cx, int32_t cy, float *ax, float *ay)
{
    float g[2] = {h->p.gravity_dir[0], h->p.gravity_dir[1]};
    float b[2] = {h->p.airflow_dir[0], h->p.airflow_dir[1]};
    if (h->field) {
        const float *f = h->field + ((size_t)cy * (size_t)h->p.width + (size_t)cx) *
                                        (size_t)h->field_channels;
        g[0] = f[0];
        g[1] = f[1];
        if (h->field_channels == 4) {
            b[0] = f[2];
            b[1] = f[3];
        }
    }
    const float push = h->p.airflow * h->car_speed * h->car_speed + h->car_accel;
    *ax = h->p.gravity * g[0] + h->wind[0] + push * b[0];
    *ay = h->p.gravity * g[1] + h->wind[1] + push * b[1];
}

/* Logs the old value of a cell for cancellation; 0 if the log cannot grow. */
static int journal(hbk_rain_t *h, uint32_t field, size_t i, double old)
{
    if (h->journaling) {
        if (h->undo_count == h->undo_cap) {
            size_t cap = h->undo_cap ? 2 * h->undo_cap : 4096;
            rain_undo_t *u = realloc(h->undo, cap * sizeof *u);
            if (!u) {
                h->alloc_failed = 1;
                return 0; /* the step is rolled back; this write must not happen unlogged */
            }
            h->undo = u;
            h->undo_cap = cap;
        }
        h->undo[h->undo_count++] = (rain_undo_t){(uint32_t)i, field, old};
    }
    return 1;
}

void rain_set_affinity(hbk_rain_t *h, size_t i, float v)
{
    if (journal(h, 0, i, h->affinity[i])) h->affinity[i] = v;
}

void rain_set_film(hbk_rain_t *h, size_t i, double v)
{
    if (journal(h, 1, i, h->film[i])) h->film[i] = v;
}

void rain_mark_wet(hbk_rain_t *h, float x, float y, float r)
{
    if (h->mark_count == h->mark_cap) {
        size_t cap = h->mark_cap ? 2 * h->mark_cap : 1024;
        rain_wet_mark_t *m = realloc(h->marks, cap * sizeof *m);
        if (!m) {
            h->alloc_failed = 1;
            return;
        }
        h->marks = m;
        h->mark_cap = cap;
    }
    h->marks[h->mark_count++] = (rain_wet_mark_t){x, y, r};
}

void rain_commit_marks(hbk_rain_t *h)
{
    const int32_t W = h->p.width, H = h->p.height;
    const float now = (float)h->time;
    for (size_t k = 0; k < h->mark_count; ++k) {
        const rain_wet_mark_t *m = &h->marks[k];
        const float r = m->r > 0.5f ? m->r : 0.5f; /* at least the cell it is in */
        const int32_t y0 = cell_of(m->y - r), y1 = cell_of(m->y + r);
        const int32_t x0 = cell_of(m->x - r), x1 = cell_of(m->x + r);
        for (int32_t y = y0 < 0 ? 0 : y0; y <= y1 && y < H; ++y) {
            const float dy = (float)y + 0.5f - m->y;
            for (int32_t x = x0 < 0 ? 0 : x0; x <= x1 && x < W; ++x) {
                const float dx = (float)x + 0.5f - m->x;
                if (dx * dx + dy * dy <= r * r)
                    h->wet_time[(size_t)y * (size_t)W + (size_t)x] = now;
            }
        }
    }
    h->mark_count = 0;
}

/* Rest offsets and radius factors of a drop's sub-metaballs, from its id. */
static void init_shape(const hbk_rain_t *h, rain_drop_t *d)
{
    memset(d->off, 0, sizeof d->off);
    memset(d->rest, 0, sizeof d->rest);
    memset(d->scale, 255, sizeof d->scale);
    uint32_t r[4];
    for (int32_t k = 1; k < h->p.sub_count; ++k) {
        /* One Philox block per sub-metaball: radius, angle, size. */
        hbk_philox(h->p.seed, RAIN_STREAM_SHAPE, (d->id << 3) | (uint64_t)k, r);
        const float rho = h->p.sub_spread * sqrtf(hbk_u32_to_unit(r[0]));
        const float phi = 2.0f * (float)M_PI * hbk_u32_to_unit(r[1]);
        d->rest[k][0] = (int8_t)lrintf(127.0f * rho * cosf(phi));
        d->rest[k][1] = (int8_t)lrintf(127.0f * rho * sinf(phi));
        d->scale[k] = (uint8_t)(r[2] >> 24);
        d->off[k][0] = d->rest[k][0] / 127.0f;
        d->off[k][1] = d->rest[k][1] / 127.0f;
    }
}

static rain_drop_t *push_drop(hbk_rain_t *h)
{
    if (h->drop_count == h->drop_cap) {
        int64_t cap = h->drop_cap ? 2 * h->drop_cap : 1024;
        rain_drop_t *d = realloc(h->drops, (size_t)cap * sizeof *d);
        if (!d) {
            h->alloc_failed = 1;
            return NULL;
        }
        h->drops = d;
        h->drop_cap = cap;
    }
    rain_drop_t *d = &h->drops[h->drop_count++];
    memset(d, 0, sizeof *d);
    d->id = h->next_id++;
    return d;
}

rain_drop_t *rain_new_drop(hbk_rain_t *h, float x, float y, double mass)
{
    rain_drop_t *d = push_drop(h);
    if (!d) return NULL;
    d->x = x;
    d->y = y;
    d->mass = mass;
    init_shape(h, d);
    rain_note_radius(h, x, y, rain_radius_cells(h, mass));
    return d;
}

void rain_kill_drop(hbk_rain_t *h, int64_t i)
{
    rain_drop_t *d = &h->drops[i];
    if (!(d->flags & DROP_DEAD)) h->dead++;
    d->flags |= DROP_DEAD;
    const int32_t cx = cell_of(d->x), cy = cell_of(d->y);
    if (h->occ[(size_t)cy * (size_t)h->p.width + (size_t)cx] == (int32_t)i)
        rain_occ_put(h, cx, cy, -1);
}

/* Drop s takes drop a's water; a is gone. A trail drop that takes a real drop becomes one. */
static void absorb(hbk_rain_t *h, int64_t s, int64_t a)
{
    rain_drop_t *ds = &h->drops[s], *da = &h->drops[a];
    const double m = ds->mass + da->mass;
    ds->speed = (float)((ds->mass * ds->speed + da->mass * da->speed) / m);
    ds->mass = m;
    if ((ds->flags & DROP_TRAIL) && !(da->flags & DROP_TRAIL)) {
        ds->flags &= ~DROP_TRAIL;
        init_shape(h, ds);
        rain_occ_put(h, cell_of(ds->x), cell_of(ds->y), (int32_t)s);
    }
    rain_kill_drop(h, a);
    ds = &h->drops[s];
    rain_note_radius(h, ds->x, ds->y, rain_radius_cells(h, m));
}

/* The film of drop i's cell joins the drop. */
static void take_film(hbk_rain_t *h, int64_t i)
{
    rain_drop_t *d = &h->drops[i];
    const size_t c = (size_t)cell_of(d->y) * (size_t)h->p.width + (size_t)cell_of(d->x);
    if (h->film[c] > 0.0) {
        d->mass += h->film[c];
        rain_set_film(h, c, 0.0);
        rain_note_radius(h, d->x, d->y, rain_radius_cells(h, d->mass));
    }
}

/* Merges drop i with every non-trail drop whose centre is within merge_distance * (r_i + r_j),
 * visiting only the blocks whose radius bound can reach, in a fixed order. A mover survives
 * its merges; otherwise the heavier drop does, the one already there on a tie (then the scan
 * goes on around it). Returns the survivor. */
static int64_t merge_around(hbk_rain_t *h, int64_t i, int mover)
{
    const float md = h->p.merge_distance;
    const int32_t W = h->p.width, H = h->p.height, B = RAIN_BLOCK;
    for (int pass = 0; pass < 4 && md > 0.0f; ++pass) {
        if (h->drops[i].flags & DROP_TRAIL) return i;
        int merged = 0, moved = 0;
        float ri = rain_radius_cells(h, h->drops[i].mass);
        const float xi = h->drops[i].x, yi = h->drops[i].y;
        const float far = md * (ri + h->r_max);
        const int32_t bx0 = clampi(ifloor(xi - far), 0, W - 1) / B;
        const int32_t bx1 = clampi(ifloor(xi + far), 0, W - 1) / B;
        const int32_t by0 = clampi(ifloor(yi - far), 0, H - 1) / B;
        const int32_t by1 = clampi(ifloor(yi + far), 0, H - 1) / B;
        for (int32_t by = by0; by <= by1 && !moved; ++by)
            for (int32_t bx = bx0; bx <= bx1 && !moved; ++bx) {
                const float rb = h->blk_r[(size_t)by * (size_t)h->blk_w + (size_t)bx];
                if (!(rb > 0.0f)) continue;
                const float reach = md * (ri + rb);
                const int32_t x0 = clampi(ifloor(xi - reach), bx * B, W - 1);
                const int32_t x1 = clampi(ifloor(xi + reach), 0, mini(bx * B + B, W) - 1);
                const int32_t y0 = clampi(ifloor(yi - reach), by * B, H - 1);
                const int32_t y1 = clampi(ifloor(yi + reach), 0, mini(by * B + B, H) - 1);
                for (int32_t y = y0; y <= y1 && !moved; ++y)
                    for (int32_t x = rain_next_occ(h, y, x0, x1); x <= x1;
                         x = rain_next_occ(h, y, x + 1, x1)) {
                        /* The bitmap holds no trail drops: they only merge by cell. */
                        const int32_t j = h->occ[(size_t)y * (size_t)W + (size_t)x];
                        if (j == i) continue;
                        const rain_drop_t *e = &h->drops[j];
                        const float lim = md * (ri + rain_radius_cells(h, e->mass));
                        const float dx = e->x - xi, dy = e->y - yi;
                        if (dx * dx + dy * dy >= lim * lim) continue;
                        merged = 1;
                        if (mover || h->drops[i].mass > e->mass) {
                            absorb(h, i, j);
                            ri = rain_radius_cells(h, h->drops[i].mass);
                        } else {
                            absorb(h, j, i);
                            i = j;
                            moved = 1; /* rescan around the survivor */
                            break;
                        }
                    }
            }
        if (!merged) break;
    }
    return i;
}

int rain_land(hbk_rain_t *h, float x, float y, double mass)
{
    const int32_t cx = cell_of(x), cy = cell_of(y);
    const size_t c = (size_t)cy * (size_t)h->p.width + (size_t)cx;
    int64_t i = h->occ[c];
    if (i >= 0) {
        /* The paper's rule: two drops in one cell are one. */
        rain_drop_t *d = &h->drops[i];
        d->mass += mass;
        if (d->flags & DROP_TRAIL) {
            d->flags &= ~DROP_TRAIL;
            init_shape(h, d);
            rain_occ_put(h, cx, cy, (int32_t)i);
        }
        rain_note_radius(h, d->x, d->y, rain_radius_cells(h, d->mass));
    } else {
        if (!rain_new_drop(h, x, y, mass)) return 0;
        i = h->drop_count - 1;
        rain_occ_put(h, cx, cy, (int32_t)i);
    }
    take_film(h, i);
    merge_around(h, i, 0);
    return 1;
}

void rain_rain(hbk_rain_t *h, double dt)
{
    const hbk_rain_params_t *p = &h->p;
    if (!(p->rain_rate > 0.0f)) return;
    const double area = (double)p->width * p->height * (double)p->cell_size * p->cell_size;
    /* Rounding the expected count up or down at random keeps the mean exact. */
    double count = floor((double)p->rain_rate * area * dt +
                         (double)hbk_rng_uniform(p->seed, RAIN_STREAM_RAIN_COUNT, h->steps, 0));
    if (count > 16777215.0) count = 16777215.0;
    for (uint32_t k = 0; k < (uint32_t)count && !h->alloc_failed; ++k) {
        uint32_t r[4];
        hbk_philox(p->seed, RAIN_STREAM_RAIN_DROP, (h->steps << 24) | k, r);
        const float x = hbk_u32_to_unit(r[0]) * (float)p->width;
        const float y = hbk_u32_to_unit(r[1]) * (float)p->height;
        if (!rain_is_glass(h, cell_of(x), cell_of(y))) continue;
        const double m = (double)p->drop_mass *
                         (1.0 + (double)p->drop_mass_spread * (2.0 * hbk_u32_to_unit(r[2]) - 1.0));
        if (rain_land(h, x, y, m)) h->rain_in += m;
    }
}

/* Moves drop i by one cell in direction k (it has already left its old cell). Returns 0 when
 * the drop ran off the glass. */
static int enter_cell(hbk_rain_t *h, int64_t i, int k)
{
    rain_drop_t *d = &h->drops[i];
    const int32_t nx = cell_of(d->x) + k_dir[k][0], ny = cell_of(d->y) + k_dir[k][1];
    if (!rain_is_glass(h, nx, ny)) {
        h->run_off += d->mass;
        d->flags |= DROP_DEAD; /* its old cell is already cleared */
        h->dead++;
        return 0;
    }
    /* Sub-metaballs lag behind the move, the later ones more: tails. */
    const int32_t n = h->p.sub_count;
    if (n > 1) {
        const float r = rain_radius_cells(h, d->mass);
        const float ux = (float)k_dir[k][0] / r, uy = (float)k_dir[k][1] / r;
        const float lim = h->p.tail_length + h->p.sub_spread;
        for (int32_t s = 1; s < n; ++s) {
            const float lag = (float)s / (float)(n - 1);
            float ox = d->off[s][0] - ux * lag, oy = d->off[s][1] - uy * lag;
            const float len = sqrtf(ox * ox + oy * oy);
            if (len > lim) {
                ox *= lim / len;
                oy *= lim / len;
            }
            d->off[s][0] = ox;
            d->off[s][1] = oy;
        }
    }
    d->x = (float)nx + 0.5f;
    d->y = (float)ny + 0.5f;
    const int32_t j = h->occ[(size_t)ny * (size_t)h->p.width + (size_t)nx];
    if (j >= 0) absorb(h, i, j); /* two drops in one cell merge */
    rain_occ_put(h, nx, ny, (int32_t)i);
    take_film(h, i);
    merge_around(h, i, 1);
    d = &h->drops[i];
    const float r = rain_radius_cells(h, d->mass);
    rain_note_radius(h, d->x, d->y, r);
    /* Discs r/2 apart still wet a band of width > 1.9 r: no need to mark every cell. */
    const uint32_t every = r >= 4.0f ? (uint32_t)(0.5f * r) : 1u;
    if (d->moves % every == 0) rain_mark_wet(h, d->x, d->y, r);
    return 1;
}

/* Runs drop i for dt seconds; it may leave trail drops (which can move the drops array). */
static void run_drop(hbk_rain_t *h, int64_t i, double dt)
{
    const hbk_rain_params_t *p = &h->p;
    rain_drop_t *d = &h->drops[i];
    const float friction = p->static_mass * p->gravity; /* mg m/s^2 */
    float ax, ay;
    rain_accel_at(h, cell_of(d->x), cell_of(d->y), &ax, &ay);
    float a = sqrtf(ax * ax + ay * ay);
    if (d->speed == 0.0f && !((float)d->mass * a > friction)) return;
    const float fdt = (float)dt;
    float s = (d->speed + fdt * (a - friction / (float)d->mass)) / (1.0f + p->drag * fdt);
    if (!(s > 0.0f)) {
        d->speed = 0.0f;
        d->travel = 0.0f;
        return;
    }
    d->speed = s;
    d->travel += s * (float)dt;
    for (int n = 0; n < RAIN_MAX_MOVES; ++n) {
        d = &h->drops[i];
        const int32_t cx = cell_of(d->x), cy = cell_of(d->y);
        rain_accel_at(h, cx, cy, &ax, &ay);
        a = sqrtf(ax * ax + ay * ay);
        if (!(a > 0.0f)) break;
        /* The neighbour nearest the force's direction and its two side neighbours (the
         * paper's choice), weighted by their cells' affinity times
         *  - the force split between the two neighbours that bracket it (A = a d_k + b d_k+1,
         *    a, b >= 0): alone, these make the mean move point exactly along A, and a drop
         *    pulled straight at a cell runs straight;
         *  - plus affinity_random times weights on the two side neighbours whose sideways
         *    parts cancel: meandering on uneven glass that does not bias the mean. */
        const float ux = ax / a, uy = ay / a;
        const float f = atan2f(uy, ux) / (float)(M_PI / 4.0);
        const int kf = (int)floorf(f), k0 = ((int)lrintf(f) + 8) & 7;
        const float th = (f - (float)kf) * (float)(M_PI / 4.0);
        /* Unit-direction split, then per move vector (diagonals are sqrt 2 long). */
        float bary[2] = {sinf((float)(M_PI / 4.0) - th) * (float)M_SQRT2,
                         sinf(th) * (float)M_SQRT2};
        const int kb[2] = {(kf + 8) & 7, (kf + 9) & 7};
        for (int c = 0; c < 2; ++c)
            if (kb[c] & 1) bary[c] *= (float)M_SQRT1_2;
        float w[3];
        int ks[3];
        float side[2];
        for (int c = 0; c < 3; ++c) {
            ks[c] = (k0 + c + 7) & 7;
            w[c] = ks[c] == kb[0] ? bary[0] : ks[c] == kb[1] ? bary[1] : 0.0f;
        }
        for (int c = 0; c < 2; ++c) { /* sideways arm of each side neighbour */
            const int k = ks[2 * c];
            side[c] = fabsf((float)k_dir[k][0] * uy - (float)k_dir[k][1] * ux);
        }
        const float arms = side[0] + side[1];
        if (arms > 0.0f) {
            w[0] += p->affinity_random * side[1] / arms;
            w[2] += p->affinity_random * side[0] / arms;
        }
        float sum = 0.0f;
        for (int c = 0; c < 3; ++c) {
            const int32_t tx = cx + k_dir[ks[c]][0], ty = cy + k_dir[ks[c]][1];
            w[c] *= rain_is_glass(h, tx, ty)
                        ? h->affinity[(size_t)ty * (size_t)p->width + (size_t)tx]
                        : 1.0f;
            sum += w[c];
        }
        if (!(sum > 0.0f)) break;
        uint32_t r[4];
        hbk_philox(p->seed, RAIN_STREAM_MOVE, (d->id << 24) | (d->moves & 0xffffffu), r);
        const float pick = hbk_u32_to_unit(r[0]) * sum;
        const int c = pick < w[0] ? 0 : pick < w[0] + w[1] ? 1 : 2;
        const int k = ks[c];
        const float len = p->cell_size * ((k & 1) ? (float)M_SQRT2 : 1.0f);
        if (d->travel < len) break; /* the same choice is drawn again next time */
        d->travel -= len;
        d->moves++;
        /* Leave the cell: raise its affinity, maybe leave a trail drop there. */
        const size_t oc = (size_t)cy * (size_t)p->width + (size_t)cx;
        rain_occ_put(h, cx, cy, -1);
        if (p->affinity_gain > 0.0f) {
            float na = h->affinity[oc] + p->affinity_gain;
            rain_set_affinity(h, oc, na < RAIN_AFFINITY_MAX ? na : RAIN_AFFINITY_MAX);
        }
        if (p->trail_mass > 0.0f && hbk_u32_to_unit(r[1]) * p->trail_spacing < len &&
            d->mass >= 2.0 * (double)p->trail_mass) {
            const float ox = d->x, oy = d->y;
            d->mass -= (double)p->trail_mass;
            rain_drop_t *t = push_drop(h);
            if (!t) return;
            t->x = ox;
            t->y = oy;
            t->mass = (double)p->trail_mass;
            t->mass0 = p->trail_mass;
            t->flags = DROP_TRAIL;
            rain_note_radius(h, ox, oy, rain_radius_cells(h, t->mass));
            rain_occ_put(h, cx, cy, (int32_t)(h->drop_count - 1));
        }
        if (!enter_cell(h, i, k)) return;
    }
}

hbk_result_t rain_move_drops(hbk_rain_t *h, double dt, hbk_progress_t *progress)
{
    const int64_t count = h->drop_count; /* drops left during this pass wait for the next */
    for (int64_t i = 0; i < count; ++i) {
        if ((i & 4095) == 4095 && hbk_cancelled(progress)) return HBK_ERR_CANCELLED;
        if (h->drops[i].flags & (DROP_DEAD | DROP_TRAIL)) continue;
        run_drop(h, i, dt);
        if (h->alloc_failed) return HBK_ERR_OUT_OF_MEMORY;
    }
    return HBK_OK;
}

void rain_age_drops(hbk_rain_t *h, double dt)
{
    const float life = h->p.trail_lifetime, half = 0.5f * life;
    const float relax = (float)(1.0 - exp(-dt / RAIN_TAIL_RELAX));
    const int32_t n = h->p.sub_count;
    for (int64_t i = 0; i < h->drop_count; ++i) {
        rain_drop_t *d = &h->drops[i];
        if (d->flags & DROP_DEAD) continue;
        if (!(d->flags & DROP_TRAIL)) {
            for (int32_t s = 1; s < n; ++s) {
                d->off[s][0] += (d->rest[s][0] / 127.0f - d->off[s][0]) * relax;
                d->off[s][1] += (d->rest[s][1] / 127.0f - d->off[s][1]) * relax;
            }
            continue;
        }
        /* Trail drops keep their size for half their life, then shrink to nothing; the
         * water they lose stays in their cell's film. */
        d->age += (float)dt;
        if (d->age <= half) continue;
        double target = d->age >= life ? 0.0 : d->mass0 * (double)((life - d->age) / half);
        if (target > d->mass) target = d->mass;
        const size_t c = (size_t)cell_of(d->y) * (size_t)h->p.width + (size_t)cell_of(d->x);
        rain_set_film(h, c, h->film[c] + (d->mass - target));
        d->mass = target;
        if (d->age >= life) rain_kill_drop(h, i);
    }
}

void rain_compact_drops(hbk_rain_t *h)
{
    int64_t j = 0;
    const size_t W = (size_t)h->p.width;
    for (int64_t i = 0; i < h->drop_count; ++i) {
        if (h->drops[i].flags & DROP_DEAD) continue;
        if (j != i) {
            h->drops[j] = h->drops[i];
            const rain_drop_t *d = &h->drops[j];
            h->occ[(size_t)cell_of(d->y) * W + (size_t)cell_of(d->x)] = (int32_t)j;
        }
        ++j;
    }
    h->drop_count = j;
    h->dead = 0;
}

void rain_compact(hbk_rain_t *h)
{
    rain_compact_drops(h);
    int64_t j = 0;
    for (int64_t i = 0; i < h->particle_count; ++i) {
        if (!(h->particles[i].mass >= 0.0)) continue; /* removed particles have mass -1 */
        h->particles[j++] = h->particles[i];
    }
    h->particle_count = j;
}

void rain_rebuild_occ(hbk_rain_t *h)
{
    for (size_t c = 0; c < h->n; ++c) h->occ[c] = -1;
    memset(h->occ_bits, 0, (size_t)h->p.height * h->occ_words * sizeof *h->occ_bits);
    for (int64_t i = 0; i < h->drop_count; ++i) {
        const rain_drop_t *d = &h->drops[i];
        if (!(d->flags & DROP_DEAD)) rain_occ_put(h, cell_of(d->x), cell_of(d->y), (int32_t)i);
    }
}

void rain_update_bounds(hbk_rain_t *h)
{
    memset(h->blk_r, 0, (size_t)h->blk_w * (size_t)h->blk_h * sizeof *h->blk_r);
    h->r_max = 0.0f;
    for (int64_t i = 0; i < h->drop_count; ++i) {
        const rain_drop_t *d = &h->drops[i];
        if (!(d->flags & DROP_DEAD)) rain_note_radius(h, d->x, d->y, rain_radius_cells(h, d->mass));
    }
}
