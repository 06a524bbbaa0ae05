/* Rain handle: life cycle, setters, the step (with its rollback), getters, checkpoints. */
#include "internal_rain.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define RAIN_NEVER (-1e30f) /* wet_time of a cell no drop has run through */

hbk_result_t hbk_rain_create(hbk_rain_t **out, const hbk_rain_params_t *p, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!out) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out: must not be NULL");
    *out = NULL;
    hbk_result_t r = hbk_rain_params_check(p, msg);
    if (r) return r;
    hbk_rain_t *h = calloc(1, sizeof *h);
    if (!h) return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "rain handle: out of memory");
    h->p = *p;
    h->n = (size_t)p->width * (size_t)p->height;
    h->next_id = 1;
    h->car_speed = p->car_speed;
    h->car_accel = p->car_accel;
    h->wind[0] = p->wind[0];
    h->wind[1] = p->wind[1];
    h->affinity = malloc(h->n * sizeof *h->affinity);
    h->film = calloc(h->n, sizeof *h->film);
    h->wet_time = malloc(h->n * sizeof *h->wet_time);
    h->occ = malloc(h->n * sizeof *h->occ);
    h->occ_words = ((size_t)p->width + 63) / 64;
    h->occ_bits = calloc((size_t)p->height * h->occ_words, sizeof *h->occ_bits);
    h->blk_w = (p->width + RAIN_BLOCK - 1) / RAIN_BLOCK;
    h->blk_h = (p->height + RAIN_BLOCK - 1) / RAIN_BLOCK;
    h->blk_r = calloc((size_t)h->blk_w * (size_t)h->blk_h, sizeof *h->blk_r);
    if (!h->affinity || !h->film || !h->wet_time || !h->occ || !h->occ_bits || !h->blk_r) {
        hbk_rain_destroy(h);
        return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "rain grid %d x %d: out of memory",
                        p->width, p->height);
    }
    /* Affinity of cell c from the block for c / 4, word c % 4: the glass is the same for any
     * thread count. */
    const int threads = hbk_threads(p->threads);
    const int64_t n = (int64_t)h->n;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int64_t b = 0; b < (n + 3) / 4; ++b) {
        uint32_t w[4];
        hbk_philox(p->seed, RAIN_STREAM_AFFINITY, (uint64_t)b, w);
        for (int64_t k = 0; k < 4 && 4 * b + k < n; ++k) {
            const size_t c = (size_t)(4 * b + k);
            h->affinity[c] = 1.0f - p->affinity_random * hbk_u32_to_unit(w[k]);
            h->wet_time[c] = RAIN_NEVER;
            h->occ[c] = -1;
        }
    }
    for (int i = 0; i < p->wiper_count; ++i) h->wiper_value[i] = rain_wiper_value_at(h, i, 0.0);
    *out = h;
    return HBK_OK;
}

void hbk_rain_destroy(hbk_rain_t *h)
{
    if (!h) return;
    free(h->drops);
    free(h->particles);
    free(h->affinity);
    free(h->film);
    free(h->wet_time);
    free(h->field);
    free(h->mask);
    free(h->occ);
    free(h->occ_bits);
    free(h->blk_r);
    free(h->undo);
    free(h->marks);
    free(h->backup_drops);
    free(h->backup_particles);
    free(h->hash_start);
    free(h->hash_items);
    free(h->hash_key);
    free(h->hash_bin);
    free(h->disp);
    free(h->balls);
    free(h->band_items);
    free(h->band_start);
    free(h->band_buf);
    free(h);
}

const char *hbk_rain_message(const hbk_rain_t *h) { return h ? h->msg.text : "handle is NULL"; }

#define RAIN_ENTER(h)                                                                   \
    do {                                                                                \
        if (!(h)) return HBK_ERR_INVALID_ARGUMENT;                                      \
        hbk_message_clear(&(h)->msg);                                                   \
    } while (0)

/* Checks a per-cell image: width x height, one of the allowed channel counts, values finite
 * and each pixel's first two (and, with 4 channels, last two) channels a vector of length at
 * most `max_len`, or values in [0, 1] when max_len is 0. */
static hbk_result_t check_cells(hbk_rain_t *h, const hbk_image_t *img, const char *name,
                                int32_t ch_a, int32_t ch_b, float max_len)
{
    hbk_result_t r = hbk_image_check(img, name, &h->msg);
    if (r) return r;
    if (img->width != h->p.width || img->height != h->p.height)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s size = %d x %d: must equal the "
                        "grid, %d x %d", name, img->width, img->height, h->p.width, h->p.height);
    if (img->channels != ch_a && img->channels != ch_b)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s.channels = %d: must be %d%s%.0d",
                        name, img->channels, ch_a, ch_a != ch_b ? " or " : "",
                        ch_a != ch_b ? ch_b : 0);
    const int32_t nc = img->channels;
    for (int32_t y = 0; y < img->height; ++y)
        for (int32_t x = 0; x < img->width; ++x) {
            const float *v = img->data + (size_t)y * img->row_stride + (size_t)x * (size_t)nc;
            int ok = 1;
            for (int32_t c = 0; c < nc; ++c) ok &= isfinite(v[c]);
            if (ok && max_len > 0.0f) {
                ok = hypotf(v[0], v[1]) <= max_len;
                if (nc == 4) ok &= hypotf(v[2], v[3]) <= max_len;
            } else if (ok) {
                ok = v[0] >= 0.0f && v[0] <= 1.0f;
            }
            if (!ok)
                return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s at pixel (%d, %d) = %g: "
                                "%s", name, x, y, (double)v[0],
                                max_len > 0.0f ? "must be finite, vectors of length <= 1"
                                               : "must be in [0, 1]");
        }
    return HBK_OK;
}

hbk_result_t hbk_rain_set_tangents(hbk_rain_t *h, const hbk_image_t *gravity_dir,
                                   const hbk_image_t *mask)
{
    RAIN_ENTER(h);
    hbk_result_t r;
    if (gravity_dir && (r = check_cells(h, gravity_dir, "gravity_dir", 2, 4, 1.001f))) return r;
    if (mask && (r = check_cells(h, mask, "mask", 1, 1, 0.0f))) return r;
    float *field = NULL, *m = NULL;
    const int32_t W = h->p.width;
    if (gravity_dir) {
        const size_t row = (size_t)W * (size_t)gravity_dir->channels;
        if (!(field = malloc(h->n * (size_t)gravity_dir->channels * sizeof *field)))
            return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "gravity_dir: out of memory");
        for (int32_t y = 0; y < h->p.height; ++y)
            memcpy(field + (size_t)y * row, gravity_dir->data + (size_t)y * gravity_dir->row_stride,
                   row * sizeof *field);
    }
    if (mask) {
        if (!(m = malloc(h->n * sizeof *m))) {
            free(field);
            return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "mask: out of memory");
        }
        for (int32_t y = 0; y < h->p.height; ++y)
            memcpy(m + (size_t)y * (size_t)W, mask->data + (size_t)y * mask->row_stride,
                   (size_t)W * sizeof *m);
    }
    free(h->field);
    h->field = field;
    h->field_channels = gravity_dir ? gravity_dir->channels : 0;
    free(h->mask);
    h->mask = m;
    if (!m) return HBK_OK;
    /* What now lies off the glass has run off. */
    for (int64_t i = 0; i < h->drop_count; ++i) {
        const rain_drop_t *d = &h->drops[i];
        if (d->flags & DROP_DEAD) continue; /* merged away: its water is in another drop */
        if (!rain_is_glass(h, (int32_t)floorf(d->x), (int32_t)floorf(d->y))) {
            h->run_off += d->mass;
            rain_kill_drop(h, i);
        }
    }
    for (int64_t i = 0; i < h->particle_count; ++i) {
        rain_particle_t *q = &h->particles[i];
        if (!rain_is_glass(h, (int32_t)floorf(q->x), (int32_t)floorf(q->y))) {
            h->run_off += q->mass;
            q->mass = -1.0;
        }
    }
    for (size_t c = 0; c < h->n; ++c)
        if (m[c] < 0.5f && h->film[c] != 0.0) {
            h->run_off += h->film[c];
            h->film[c] = 0.0;
        }
    rain_compact(h);
    return HBK_OK;
}

hbk_result_t hbk_rain_set_wiper_angles(hbk_rain_t *h, const float *angles, int32_t count)
{
    RAIN_ENTER(h);
    if (count == 0) {
        h->wiper_external = 0;
        return HBK_OK;
    }
    if (count != h->p.wiper_count)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "count = %d: must be 0 or "
                        "wiper_count = %d", count, h->p.wiper_count);
    if (!angles) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "angles: must not be NULL");
    for (int32_t i = 0; i < count; ++i)
        if (!(fabsf(angles[i]) <= 1e6f))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "angles[%d] = %g: must be a "
                            "finite number within +-1e6", i, (double)angles[i]);
    for (int32_t i = 0; i < count; ++i) h->wiper_target[i] = angles[i];
    h->wiper_external = 1;
    return HBK_OK;
}

hbk_result_t hbk_rain_set_car(hbk_rain_t *h, float speed, float accel, const float wind[2])
{
    RAIN_ENTER(h);
    if (!(speed >= 0.0f && speed <= 100.0f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "speed = %g: must be in [0, 100] m/s",
                        (double)speed);
    if (!(accel >= -50.0f && accel <= 50.0f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "accel = %g: must be in [-50, 50] "
                        "m/s^2", (double)accel);
    for (int k = 0; wind && k < 2; ++k)
        if (!(wind[k] >= -100.0f && wind[k] <= 100.0f))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "wind[%d] = %g: must be in "
                            "[-100, 100] m/s^2", k, (double)wind[k]);
    h->car_speed = speed;
    h->car_accel = accel;
    if (wind) {
        h->wind[0] = wind[0];
        h->wind[1] = wind[1];
    }
    return HBK_OK;
}

hbk_result_t hbk_rain_add_drop(hbk_rain_t *h, float x, float y, float mass)
{
    RAIN_ENTER(h);
    if (!isfinite(x) || !isfinite(y))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "(x, y) = (%g, %g): must be finite",
                        (double)x, (double)y);
    if (!(mass > 0.0f && mass <= 1e6f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "mass = %g: must be in (0, 1e6] mg",
                        (double)mass);
    const float cx = x / h->p.cell_size, cy = y / h->p.cell_size;
    if (!(fabsf(cx) < 1e9f && fabsf(cy) < 1e9f) ||
        !rain_is_glass(h, (int32_t)floorf(cx), (int32_t)floorf(cy)))
        return HBK_OK;
    /* Room for the one drop it may make, so that landing cannot fail half way. */
    if (h->drop_count == h->drop_cap) {
        const int64_t cap = h->drop_cap ? 2 * h->drop_cap : 1024;
        rain_drop_t *d = realloc(h->drops, (size_t)cap * sizeof *d);
        if (!d) return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "drops: out of memory");
        h->drops = d;
        h->drop_cap = cap;
    }
    rain_land(h, cx, cy, (double)mass); /* r_max is kept an upper bound as drops grow */
    h->rain_in += (double)mass;
    if (2 * h->dead > h->drop_count) rain_compact(h); /* merged drops: now and then */
    return HBK_OK;
}

/* ---- The step ---------------------------------------------------------------------- */

typedef struct {
    uint64_t steps, next_id;
    double time, rain_in, wiped, run_off;
    float wiper_value[2];
    int64_t drop_count, particle_count, dead;
} scalars_t;

static void get_scalars(const hbk_rain_t *h, scalars_t *s)
{
    *s = (scalars_t){h->steps, h->next_id, h->time, h->rain_in, h->wiped, h->run_off,
                     {h->wiper_value[0], h->wiper_value[1]}, h->drop_count, h->particle_count,
                     h->dead};
}

/* Copies drops and particles aside; 0 if out of memory (nothing changed). */
static int backup(hbk_rain_t *h)
{
    if (h->drop_count > h->backup_drop_cap) {
        rain_drop_t *d = realloc(h->backup_drops, (size_t)h->drop_cap * sizeof *d);
        if (!d) return 0;
        h->backup_drops = d;
        h->backup_drop_cap = h->drop_cap;
    }
    if (h->particle_count > h->backup_particle_cap) {
        rain_particle_t *q = realloc(h->backup_particles, (size_t)h->particle_cap * sizeof *q);
        if (!q) return 0;
        h->backup_particles = q;
        h->backup_particle_cap = h->particle_cap;
    }
    if (h->drop_count)
        memcpy(h->backup_drops, h->drops, (size_t)h->drop_count * sizeof *h->drops);
    if (h->particle_count)
        memcpy(h->backup_particles, h->particles, (size_t)h->particle_count * sizeof *h->particles);
    return 1;
}

static void restore(hbk_rain_t *h, const scalars_t *s)
{
    const size_t W = (size_t)h->p.width;
    for (int64_t i = 0; i < h->drop_count; ++i) {
        const rain_drop_t *d = &h->drops[i];
        if (d->flags & DROP_DEAD) continue;
        const size_t c = (size_t)floorf(d->y) * W + (size_t)floorf(d->x);
        if (h->occ[c] == (int32_t)i)
            rain_occ_put(h, (int32_t)floorf(d->x), (int32_t)floorf(d->y), -1);
    }
    for (size_t k = h->undo_count; k > 0; --k) {
        const rain_undo_t *u = &h->undo[k - 1];
        if (u->field == 0) h->affinity[u->index] = (float)u->old;
        else h->film[u->index] = u->old;
    }
    h->undo_count = 0;
    h->mark_count = 0;
    h->steps = s->steps;
    h->next_id = s->next_id;
    h->time = s->time;
    h->rain_in = s->rain_in;
    h->wiped = s->wiped;
    h->run_off = s->run_off;
    h->wiper_value[0] = s->wiper_value[0];
    h->wiper_value[1] = s->wiper_value[1];
    h->drop_count = s->drop_count;
    h->particle_count = s->particle_count;
    h->dead = s->dead;
    /* The arrays may have grown (moved) during the step, never shrunk. */
    if (s->drop_count)
        memcpy(h->drops, h->backup_drops, (size_t)s->drop_count * sizeof *h->drops);
    if (s->particle_count)
        memcpy(h->particles, h->backup_particles, (size_t)s->particle_count * sizeof *h->particles);
    for (int64_t i = 0; i < h->drop_count; ++i) {
        const rain_drop_t *d = &h->drops[i];
        if (!(d->flags & DROP_DEAD))
            rain_occ_put(h, (int32_t)floorf(d->x), (int32_t)floorf(d->y), (int32_t)i);
    }
    rain_update_bounds(h);
}

hbk_result_t hbk_rain_step(hbk_rain_t *h, float dt, hbk_progress_t *progress)
{
    RAIN_ENTER(h);
    if (!(dt >= 1e-5f && dt <= 10.0f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "dt = %g: must be in [1e-05, 10] s",
                        (double)dt);
    if (hbk_cancelled(progress))
        return hbk_fail(&h->msg, HBK_ERR_CANCELLED, "step cancelled; the rain is as before the "
                        "call");
    if (!backup(h))
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "step: out of memory for the backup");
    scalars_t s0;
    get_scalars(h, &s0);
    h->journaling = 1;
    h->undo_count = h->mark_count = 0;
    h->alloc_failed = 0;
    rain_update_bounds(h);
    const double t = dt;
    hbk_result_t r = HBK_OK;
    rain_rain(h, t);
    if (h->alloc_failed) r = HBK_ERR_OUT_OF_MEMORY;
    hbk_report(progress, 0.1f);
    if (!r && hbk_cancelled(progress)) r = HBK_ERR_CANCELLED;
    if (!r) r = rain_move_drops(h, t, progress);
    hbk_report(progress, 0.4f);
    if (!r && hbk_cancelled(progress)) r = HBK_ERR_CANCELLED;
    if (!r) r = rain_wipers(h, t, progress);
    hbk_report(progress, 0.8f);
    if (!r && hbk_cancelled(progress)) r = HBK_ERR_CANCELLED;
    if (!r && !rain_to_drops(h)) r = HBK_ERR_OUT_OF_MEMORY;
    if (!r) rain_age_drops(h, t);
    if (!r && h->alloc_failed) r = HBK_ERR_OUT_OF_MEMORY;
    if (!r && hbk_cancelled(progress)) r = HBK_ERR_CANCELLED;
    h->journaling = 0;
    if (r) {
        restore(h, &s0);
        return r == HBK_ERR_CANCELLED
                   ? hbk_fail(&h->msg, r, "step cancelled; the rain is as before the call")
                   : hbk_fail(&h->msg, r, "step: out of memory; the rain is as before the call");
    }
    /* Commit: nothing below can fail or be cancelled. */
    h->time += t;
    h->steps++;
    rain_commit_marks(h);
    /* Dead drops are skipped everywhere: compact now and then, not every step (it moves the
     * whole array). Particles were compacted by the switch back to drops. */
    if (8 * h->dead > h->drop_count) rain_compact_drops(h);
    h->undo_count = 0;
    hbk_report(progress, 1.0f);
    return HBK_OK;
}

/* ---- Getters ----------------------------------------------------------------------- */

hbk_result_t hbk_rain_water(const hbk_rain_t *h, hbk_rain_water_t *out)
{
    if (!h || !out) return HBK_ERR_INVALID_ARGUMENT;
    hbk_rain_water_t w = {0};
    w.rain_in = h->rain_in;
    w.wiped = h->wiped;
    w.run_off = h->run_off;
    for (int64_t i = 0; i < h->drop_count; ++i) {
        if (h->drops[i].flags & DROP_DEAD) continue;
        w.in_drops += h->drops[i].mass;
        w.drops++;
        w.trails += (h->drops[i].flags & DROP_TRAIL) != 0;
    }
    for (int64_t i = 0; i < h->particle_count; ++i) {
        w.in_particles += h->particles[i].mass;
        w.particles++;
    }
    for (size_t c = 0; c < h->n; ++c) w.in_film += h->film[c];
    w.on_glass = w.in_drops + w.in_particles + w.in_film;
    *out = w;
    return HBK_OK;
}

int64_t hbk_rain_drop_count(const hbk_rain_t *h)
{
    return h ? h->drop_count - h->dead + h->particle_count : 0;
}

hbk_result_t hbk_rain_drops(const hbk_rain_t *h, hbk_rain_drop_t *out, int64_t capacity,
                            int64_t *count)
{
    if (!h || !count || capacity < 0 || (capacity > 0 && !out)) return HBK_ERR_INVALID_ARGUMENT;
    const float cs = h->p.cell_size;
    int64_t k = 0;
    for (int64_t i = 0; i < h->drop_count && k < capacity; ++i) {
        const rain_drop_t *d = &h->drops[i];
        if (d->flags & DROP_DEAD) continue;
        out[k++] = (hbk_rain_drop_t){d->x * cs, d->y * cs, (float)d->mass,
                                     hbk_rain_drop_radius((float)d->mass), d->speed,
                                     (d->flags & DROP_TRAIL) ? HBK_RAIN_TRAIL : HBK_RAIN_DROP,
                                     d->id};
    }
    for (int64_t i = 0; i < h->particle_count && k < capacity; ++i) {
        const rain_particle_t *q = &h->particles[i];
        out[k++] = (hbk_rain_drop_t){q->x * cs, q->y * cs, (float)q->mass,
                                     hbk_rain_drop_radius((float)q->mass), 0.0f,
                                     HBK_RAIN_PARTICLE, 0};
    }
    *count = k;
    return HBK_OK;
}

int32_t hbk_rain_blades(const hbk_rain_t *h, hbk_rain_blade_t *out, int32_t count)
{
    if (!h || !out || count <= 0) return 0;
    const int32_t n = count < h->p.wiper_count ? count : h->p.wiper_count;
    const float cs = h->p.cell_size;
    for (int32_t i = 0; i < n; ++i) {
        rain_blade_t b;
        rain_blade_at(h, i, h->wiper_value[i], &b);
        out[i] = (hbk_rain_blade_t){b.ox * cs, b.oy * cs, (b.ox + b.ax * b.len) * cs,
                                    (b.oy + b.ay * b.len) * cs, h->p.blade_width,
                                    h->wiper_value[i]};
    }
    return n;
}

double hbk_rain_time(const hbk_rain_t *h) { return h ? h->time : 0.0; }
uint64_t hbk_rain_step_count(const hbk_rain_t *h) { return h ? h->steps : 0; }

/* ---- Checkpoints --------------------------------------------------------------------
 * Layout: a 160-byte header (magic, version, grid, counts, scalars), then the drops and
 * particles byte for byte, affinity (float), film (double), wet_time (float) per cell, the
 * tangent field (field_channels floats per cell) and the mask (float per cell) if set. */
static const char k_magic[8] = {'H', 'B', 'K', 'R', 'A', 'I', 'N', '1'};
enum { STATE_VERSION = 1, STATE_HEADER = 160 };

typedef struct {
    char magic[8];
    uint32_t version;
    int32_t width, height, field_channels, has_mask, wiper_external;
    int64_t drop_count, particle_count;
    uint64_t steps, next_id;
    double time, rain_in, wiped, run_off;
    float car_speed, car_accel, wind[2], wiper_value[2], wiper_target[2];
} state_header_t;
_Static_assert(sizeof(state_header_t) <= STATE_HEADER, "state header too large");

static size_t state_size(const hbk_rain_t *h, int64_t drops, int64_t particles, int32_t fc,
                         int32_t has_mask)
{
    return STATE_HEADER + (size_t)drops * sizeof(rain_drop_t) +
           (size_t)particles * sizeof(rain_particle_t) +
           h->n * (sizeof(float) * (2 + (size_t)fc + (has_mask ? 1 : 0)) + sizeof(double));
}

size_t hbk_rain_state_size(const hbk_rain_t *h)
{
    return h ? state_size(h, h->drop_count - h->dead, h->particle_count,
                          h->field ? h->field_channels : 0, h->mask != NULL)
             : 0;
}

hbk_result_t hbk_rain_save_state(hbk_rain_t *h, void *buffer, size_t size)
{
    RAIN_ENTER(h);
    if (h->dead) rain_compact(h); /* keeps the order, so it changes nothing that follows */
    const size_t need = hbk_rain_state_size(h);
    if (!buffer) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "buffer: must not be NULL");
    if (size < need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "size = %zu: must be >= hbk_rain_state_size() = %zu", size, need);
    state_header_t hd;
    memset(&hd, 0, sizeof hd); /* no stray padding bytes in the file */
    memcpy(hd.magic, k_magic, 8);
    hd.version = STATE_VERSION;
    hd.width = h->p.width;
    hd.height = h->p.height;
    hd.field_channels = h->field ? h->field_channels : 0;
    hd.has_mask = h->mask != NULL;
    hd.wiper_external = h->wiper_external;
    hd.drop_count = h->drop_count;
    hd.particle_count = h->particle_count;
    hd.steps = h->steps;
    hd.next_id = h->next_id;
    hd.time = h->time;
    hd.rain_in = h->rain_in;
    hd.wiped = h->wiped;
    hd.run_off = h->run_off;
    hd.car_speed = h->car_speed;
    hd.car_accel = h->car_accel;
    for (int k = 0; k < 2; ++k) {
        hd.wind[k] = h->wind[k];
        hd.wiper_value[k] = h->wiper_value[k];
        hd.wiper_target[k] = h->wiper_target[k];
    }
    unsigned char *at = buffer;
    memset(at, 0, STATE_HEADER);
    memcpy(at, &hd, sizeof hd);
    at += STATE_HEADER;
#define PUT(src, bytes) (memcpy(at, (src), (bytes)), at += (bytes))
    if (h->drop_count) PUT(h->drops, (size_t)h->drop_count * sizeof(rain_drop_t));
    if (h->particle_count) PUT(h->particles, (size_t)h->particle_count * sizeof(rain_particle_t));
    PUT(h->affinity, h->n * sizeof(float));
    PUT(h->film, h->n * sizeof(double));
    PUT(h->wet_time, h->n * sizeof(float));
    if (hd.field_channels) PUT(h->field, h->n * (size_t)hd.field_channels * sizeof(float));
    if (hd.has_mask) PUT(h->mask, h->n * sizeof(float));
#undef PUT
    return HBK_OK;
}

/* Numbers a step could not survive (a NaN position or time, an infinite mass makes an
 * infinite radius): what no run of the library writes. Masses up to 1e12 mg (a tonne) and
 * shape offsets up to 64 radii are far past any real glass. NULL if all are sound, else what
 * is not. */
#define STATE_MAX_MASS 1e12
static const char *state_bad_number(const state_header_t *hd, const rain_drop_t *drops,
                                    const rain_particle_t *parts, const unsigned char *film,
                                    size_t n)
{
    if (!(fabs(hd->time) <= 1e12 && isfinite(hd->rain_in) && isfinite(hd->wiped) &&
          isfinite(hd->run_off)))
        return "time or water books";
    /* The ranges hbk_rain_set_car and hbk_rain_set_wiper_angles take (a blade a run moves
     * by its period stays within them too). */
    if (!(hd->car_speed >= 0.0f && hd->car_speed <= 100.0f && fabsf(hd->car_accel) <= 50.0f))
        return "car speed or acceleration";
    for (int k = 0; k < 2; ++k)
        if (!(fabsf(hd->wind[k]) <= 100.0f && fabsf(hd->wiper_value[k]) <= 1e6f &&
              fabsf(hd->wiper_target[k]) <= 1e6f))
            return "wind or wiper";
    for (int64_t i = 0; i < hd->drop_count; ++i) {
        const rain_drop_t *d = &drops[i];
        if (!(d->mass >= 0.0 && d->mass <= STATE_MAX_MASS && d->mass0 >= 0.0f &&
              d->mass0 <= STATE_MAX_MASS && isfinite(d->speed) && isfinite(d->travel) &&
              isfinite(d->age)))
            return "drop mass or motion";
        for (int k = 0; k < RAIN_MAX_SUBS; ++k)
            if (!(fabsf(d->off[k][0]) <= 64.0f && fabsf(d->off[k][1]) <= 64.0f))
                return "drop shape";
    }
    for (int64_t i = 0; i < hd->particle_count; ++i)
        if (!(parts[i].mass >= 0.0 && parts[i].mass <= STATE_MAX_MASS &&
              isfinite(parts[i].x) && isfinite(parts[i].y)))
            return "particle";
    for (size_t i = 0; i < n; ++i) {
        double f;
        memcpy(&f, film + i * sizeof f, sizeof f);
        if (!(fabs(f) <= STATE_MAX_MASS)) return "film";
    }
    return NULL;
}

hbk_result_t hbk_rain_load_state(hbk_rain_t *h, const void *buffer, size_t size)
{
    RAIN_ENTER(h);
    if (!buffer) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "buffer: must not be NULL");
    state_header_t hd;
    if (size < STATE_HEADER || memcmp(buffer, k_magic, 8))
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "buffer: not a rain state (bad header)");
    memcpy(&hd, buffer, sizeof hd);
    if (hd.version != STATE_VERSION)
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "state version = %u: this library reads %u",
                        hd.version, (unsigned)STATE_VERSION);
    if (hd.width != h->p.width || hd.height != h->p.height)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "state grid = %d x %d: must equal "
                        "the handle's, %d x %d", hd.width, hd.height, h->p.width, h->p.height);
    if (hd.drop_count < 0 || hd.particle_count < 0 || hd.drop_count > (int64_t)1 << 40 ||
        hd.particle_count > (int64_t)1 << 40 ||
        (hd.field_channels != 0 && hd.field_channels != 2 && hd.field_channels != 4) ||
        (hd.has_mask != 0 && hd.has_mask != 1))
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "state: inconsistent header");
    const size_t need = state_size(h, hd.drop_count, hd.particle_count, hd.field_channels,
                                   hd.has_mask);
    if (size < need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "size = %zu: this state needs %zu "
                        "bytes", size, need);
    /* Allocate everything first, so a failure changes nothing. */
    const int64_t dcap = hd.drop_count > 0 ? hd.drop_count : 1;
    const int64_t pcap = hd.particle_count > 0 ? hd.particle_count : 1;
    rain_drop_t *drops = malloc((size_t)dcap * sizeof *drops);
    rain_particle_t *parts = malloc((size_t)pcap * sizeof *parts);
    float *field = hd.field_channels ? malloc(h->n * (size_t)hd.field_channels * sizeof *field)
                                     : NULL;
    float *mask = hd.has_mask ? malloc(h->n * sizeof *mask) : NULL;
    if (!drops || !parts || (hd.field_channels && !field) || (hd.has_mask && !mask)) {
        free(drops);
        free(parts);
        free(field);
        free(mask);
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "state: out of memory");
    }
    const unsigned char *at = (const unsigned char *)buffer + STATE_HEADER;
#define GET(dst, bytes) (memcpy((dst), at, (bytes)), at += (bytes))
    if (hd.drop_count) GET(drops, (size_t)hd.drop_count * sizeof *drops);
    if (hd.particle_count) GET(parts, (size_t)hd.particle_count * sizeof *parts);
    /* Every drop must sit in a cell of the grid, or the occupancy would be written out of
     * bounds. */
    for (int64_t i = 0; i < hd.drop_count; ++i)
        if (!(drops[i].x >= 0.0f && drops[i].x < (float)h->p.width && drops[i].y >= 0.0f &&
              drops[i].y < (float)h->p.height)) {
            free(drops);
            free(parts);
            free(field);
            free(mask);
            return hbk_fail(&h->msg, HBK_ERR_FORMAT, "state: drop %lld lies off the grid",
                            (long long)i);
        }
    /* Particles too: a step leaves none off the grid (leave_glass), and one far off would
     * overflow the cell index it is looked up by. */
    for (int64_t i = 0; i < hd.particle_count; ++i)
        if (!(parts[i].x >= 0.0f && parts[i].x < (float)h->p.width && parts[i].y >= 0.0f &&
              parts[i].y < (float)h->p.height)) {
            free(drops);
            free(parts);
            free(field);
            free(mask);
            return hbk_fail(&h->msg, HBK_ERR_FORMAT, "state: particle %lld lies off the grid",
                            (long long)i);
        }
    const char *bad = state_bad_number(&hd, drops, parts, at + h->n * sizeof(float), h->n);
    if (bad) {
        free(drops);
        free(parts);
        free(field);
        free(mask);
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "state: %s: not a number a run can hold", bad);
    }
    GET(h->affinity, h->n * sizeof(float));
    GET(h->film, h->n * sizeof(double));
    GET(h->wet_time, h->n * sizeof(float));
    if (field) GET(field, h->n * (size_t)hd.field_channels * sizeof *field);
    if (mask) GET(mask, h->n * sizeof *mask);
#undef GET
    free(h->drops);
    free(h->particles);
    free(h->field);
    free(h->mask);
    h->drops = drops;
    h->drop_count = hd.drop_count;
    h->drop_cap = dcap;
    h->particles = parts;
    h->particle_count = hd.particle_count;
    h->particle_cap = pcap;
    h->field = field;
    h->field_channels = hd.field_channels;
    h->mask = mask;
    h->wiper_external = hd.wiper_external;
    h->steps = hd.steps;
    h->next_id = hd.next_id;
    h->time = hd.time;
    h->rain_in = hd.rain_in;
    h->wiped = hd.wiped;
    h->run_off = hd.run_off;
    h->car_speed = hd.car_speed;
    h->car_accel = hd.car_accel;
    for (int k = 0; k < 2; ++k) {
        h->wind[k] = hd.wind[k];
        h->wiper_value[k] = hd.wiper_value[k];
        h->wiper_target[k] = hd.wiper_target[k];
    }
    h->dead = 0;
    for (int64_t i = 0; i < h->drop_count; ++i) h->dead += (h->drops[i].flags & DROP_DEAD) != 0;
    rain_rebuild_occ(h);
    rain_update_bounds(h);
    return HBK_OK;
}
