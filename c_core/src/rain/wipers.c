/* Wiper blades: where they are (period-driven or animated), and one step of their sweep in
 * substeps short enough that nothing slips through a blade. */
#include "internal_rain.h"
#include <math.h>
#include <stdlib.h>

float rain_wiper_value_at(const hbk_rain_t *h, int32_t i, double t)
{
    const hbk_rain_params_t *p = &h->p;
    /* Smooth out and back: at rest at phase 0, fully swept at half a period. */
    const double s = 0.5 * (1.0 - cos(2.0 * M_PI * (t / p->wiper_period + p->wiper_phase)));
    if (p->wiper_mode == HBK_RAIN_WIPER_PIVOT)
        return (float)(p->wiper_rest[i] + p->sweep_angle * s);
    return (float)(p->sweep_distance * s);
}

void rain_blade_at(const hbk_rain_t *h, int32_t i, float value, rain_blade_t *b)
{
    const hbk_rain_params_t *p = &h->p;
    const float inv = 1.0f / p->cell_size;
    const float px = p->wiper_pivot[2 * i] * inv, py = p->wiper_pivot[2 * i + 1] * inv;
    b->len = p->blade_length * inv;
    b->half_w = 0.5f * p->blade_width * inv;
    if (p->wiper_mode == HBK_RAIN_WIPER_PIVOT) {
        const float th = value * (float)(M_PI / 180.0);
        b->ax = cosf(th);
        b->ay = sinf(th);
        b->ox = px + b->ax * p->blade_offset * inv;
        b->oy = py + b->ay * p->blade_offset * inv;
    } else {
        /* The blade stands across its travel direction and is centred on the pivot at rest. */
        const float th = p->wiper_rest[i] * (float)(M_PI / 180.0);
        const float tx = cosf(th), ty = sinf(th);
        b->ax = -ty;
        b->ay = tx;
        b->ox = px + tx * value * inv - b->ax * 0.5f * b->len;
        b->oy = py + ty * value * inv - b->ay * 0.5f * b->len;
    }
    b->nx = -b->ay;
    b->ny = b->ax;
}

/* Bounding box of a blade, grown by `grow` cells, merged into box (x0, y0, x1, y1). */
static void grow_box(const rain_blade_t *b, float grow, float box[4])
{
    const float ex = b->ox + b->ax * b->len, ey = b->oy + b->ay * b->len;
    const float x0 = fminf(b->ox, ex) - grow, x1 = fmaxf(b->ox, ex) + grow;
    const float y0 = fminf(b->oy, ey) - grow, y1 = fmaxf(b->oy, ey) + grow;
    box[0] = fminf(box[0], x0);
    box[1] = fminf(box[1], y0);
    box[2] = fmaxf(box[2], x1);
    box[3] = fmaxf(box[3], y1);
}

hbk_result_t rain_wipers(hbk_rain_t *h, double dt, hbk_progress_t *progress)
{
    const hbk_rain_params_t *p = &h->p;
    const int nb = p->wiper_count;
    if (nb == 0) return HBK_OK;
    float v0[2], v1[2];
    double most = 0.0; /* cells the fastest blade point moves this step */
    for (int i = 0; i < nb; ++i) {
        v0[i] = h->wiper_value[i];
        v1[i] = h->wiper_external ? h->wiper_target[i] : rain_wiper_value_at(h, i, h->time + dt);
        double move = fabs((double)v1[i] - v0[i]) / p->cell_size;
        if (p->wiper_mode == HBK_RAIN_WIPER_PIVOT)
            move *= (M_PI / 180.0) * ((double)p->blade_offset + p->blade_length);
        if (move > most) most = move;
    }
    /* A blade that moves at most 0.9 of its width per substep cannot jump over anything: what
     * was in front of it is at worst inside it afterwards, and is pushed out in front. */
    const double limit = 0.9 * (double)p->blade_width / p->cell_size;
    int64_t nsub = (int64_t)ceil(most / limit);
    if (nsub < 1) nsub = 1;
    if (nsub > 4096) nsub = 4096;

    /* Only drops near the swept area can be touched: collect them once. */
    float box[2][4];
    const float grow = 0.5f * p->blade_width / p->cell_size + h->r_max + 1.0f;
    for (int i = 0; i < nb; ++i) {
        box[i][0] = box[i][1] = INFINITY;
        box[i][2] = box[i][3] = -INFINITY;
        for (int64_t s = 0; s <= nsub; ++s) {
            rain_blade_t b;
            rain_blade_at(h, i, v0[i] + (v1[i] - v0[i]) * (float)((double)s / (double)nsub), &b);
            grow_box(&b, grow, box[i]);
        }
    }
    const float pr = p->particle_radius / p->cell_size;
    const float pgrow = 0.5f * p->blade_width / p->cell_size + pr + 1.0f;
    int64_t *cand = malloc((size_t)(h->drop_count + h->particle_count + 1) * sizeof *cand);
    if (!cand) return HBK_ERR_OUT_OF_MEMORY;
    int64_t ncand = 0;
    for (int64_t k = 0; k < h->drop_count; ++k) {
        const rain_drop_t *d = &h->drops[k];
        if (d->flags & DROP_DEAD) continue;
        for (int i = 0; i < nb; ++i)
            if (d->x >= box[i][0] && d->x <= box[i][2] && d->y >= box[i][1] && d->y <= box[i][3]) {
                cand[ncand++] = k;
                break;
            }
    }
    /* Particles the blades can reach (those made during the step are added as they come). */
    int64_t *pcand = cand + ncand, npcand = 0;
    const int64_t first_new = h->particle_count;
    for (int64_t k = 0; k < h->particle_count; ++k) {
        const rain_particle_t *q = &h->particles[k];
        if (!(q->mass >= 0.0)) continue;
        for (int i = 0; i < nb; ++i)
            if (q->x >= box[i][0] + grow - pgrow && q->x <= box[i][2] - grow + pgrow &&
                q->y >= box[i][1] + grow - pgrow && q->y <= box[i][3] - grow + pgrow) {
                pcand[npcand++] = k;
                break;
            }
    }

    rain_blade_t prev[2], b[2];
    int lead[2] = {0, 0};
    for (int i = 0; i < nb; ++i) rain_blade_at(h, i, v0[i], &prev[i]);
    hbk_result_t r = HBK_OK;
    for (int64_t s = 1; s <= nsub && r == HBK_OK; ++s) {
        if (hbk_cancelled(progress)) {
            r = HBK_ERR_CANCELLED;
            break;
        }
        for (int i = 0; i < nb; ++i) {
            rain_blade_at(h, i, v0[i] + (v1[i] - v0[i]) * (float)((double)s / (double)nsub), &b[i]);
            /* The leading side: where the blade's middle went. */
            const float hl = 0.5f * b[i].len, hp = 0.5f * prev[i].len;
            const float mx = (b[i].ox + b[i].ax * hl) - (prev[i].ox + prev[i].ax * hp);
            const float my = (b[i].oy + b[i].ay * hl) - (prev[i].oy + prev[i].ay * hp);
            const float along = mx * b[i].nx + my * b[i].ny;
            lead[i] = along > 1e-6f ? 1 : along < -1e-6f ? -1 : 0;
        }
        if (!rain_to_particles(h, b, lead, nb, cand, ncand)) r = HBK_ERR_OUT_OF_MEMORY;
        else rain_particles_collide(h, b, lead, nb, pcand, npcand, first_new);
        for (int i = 0; i < nb; ++i) prev[i] = b[i];
    }
    /* Repulsion once per step, among the particles in the blades' regions (the others rest
     * where they were left); every pass is followed by the blades again, so that none is
     * pushed into or through a blade. */
    if (r == HBK_OK && h->particle_count > 0) {
        const float margin = p->switch_margin / p->cell_size + 2.0f * pr;
        int64_t *act = malloc((size_t)h->particle_count * sizeof *act), nact = 0;
        if (!act) r = HBK_ERR_OUT_OF_MEMORY;
        for (int64_t k = 0; act && k < h->particle_count; ++k) {
            const rain_particle_t *q = &h->particles[k];
            if (!(q->mass >= 0.0)) continue;
            for (int i = 0; i < nb; ++i)
                if (rain_blade_distance(&b[i], q->x, q->y) <= margin) {
                    act[nact++] = k;
                    break;
                }
        }
        for (int32_t it = 0; act && it < p->particle_iterations && r == HBK_OK; ++it) {
            if (!rain_particles_repel(h, act, nact)) r = HBK_ERR_OUT_OF_MEMORY;
            else rain_particles_collide(h, b, lead, nb, act, nact, h->particle_count);
        }
        free(act);
        rain_particles_leave_glass(h, 0);
    }
    free(cand);
    if (r == HBK_OK)
        for (int i = 0; i < nb; ++i) h->wiper_value[i] = v1[i];
    return r;
}
