/* Falling flakes (§3.1, §4.1.9-4.1.10): motion, contact, sticking decisions. Flakes move in
 * parallel; the flakes that stick are stamped afterwards, serially, in (substep, flake) order,
 * so the textures do not depend on the thread count or schedule. */
#include "internal_snow.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define BLOCK 2048       /* flakes per work item */
#define CANCEL_EVERY 16  /* flakes between polls of progress->cancel */
#define ROUND 256        /* substeps per flake between polls at most */
#define TWO_PI 6.28318530717958647692f

typedef struct {
    const hbk_snow_t *h;
    uint64_t seed;
    float dt, relax, amp, radius2;
    float wind[3], lo[3], hi[3], len[3];
    float eps;           /* how far a bounced flake is set off the surface */
    float rot[2 * SNOW_FLUTTER_CLASSES][2];
    int box_mode;
    float root_lo[3], root_hi[3];
    int has_mesh;
} ctx_t;

static void air_velocity(const ctx_t *c, const snow_flake_t *f, float a[3])
{
    a[0] = c->wind[0] + c->amp * f->fc;
    a[1] = c->wind[1] + c->amp * f->fs;
    a[2] = c->wind[2] - f->fall;
}

enum { SPAWN_TOP, SPAWN_INIT, SPAWN_SHELTER };

/* A new flake for `id` at substep `step`: anywhere in the volume (init), else at the top. */
static void spawn(const ctx_t *c, uint32_t id, uint64_t step, int kind, snow_flake_t *f)
{
    static const uint32_t k_purpose[3][2] = {{SNOW_RNG_SPAWN_A, SNOW_RNG_SPAWN_B},
                                             {SNOW_RNG_INIT_A, SNOW_RNG_INIT_B},
                                             {SNOW_RNG_SHELTER_A, SNOW_RNG_SHELTER_B}};
    const int init = kind == SPAWN_INIT;
    uint32_t a[4], b[4];
    hbk_philox(c->seed, id, snow_rng_counter(step, k_purpose[kind][0]), a);
    hbk_philox(c->seed, id, snow_rng_counter(step, k_purpose[kind][1]), b);
    const hbk_snow_params_t *p = &c->h->p;
    f->fall = p->fall_speed * (0.8f + 0.4f * hbk_u32_to_unit(b[0]));
    f->cls = b[1] & (2 * SNOW_FLUTTER_CLASSES - 1);
    const float phase = TWO_PI * hbk_u32_to_unit(a[3]);
    f->fc = cosf(phase);
    f->fs = sinf(phase);
    f->p[0] = c->lo[0] + c->len[0] * hbk_u32_to_unit(a[0]);
    f->p[1] = c->lo[1] + c->len[1] * hbk_u32_to_unit(a[1]);
    if (init) {
        f->p[2] = c->lo[2] + c->len[2] * hbk_u32_to_unit(a[2]);
    } else {
        /* Spread over one substep's fall so that the flux leaving the top is even. */
        const float drop = fminf(f->fall * c->dt, c->len[2]);
        f->p[2] = c->hi[2] - drop * hbk_u32_to_unit(a[2]);
    }
    float v[3];
    air_velocity(c, f, v);
    memcpy(f->v, v, sizeof v);
}

static void ctx_init(ctx_t *c, const hbk_snow_t *h)
{
    const hbk_snow_params_t *p = &h->p;
    memset(c, 0, sizeof *c);
    c->h = h;
    c->seed = p->seed;
    c->dt = p->time_step;
    /* A flake at terminal speed relaxes to the air speed in tau = v_t / g. */
    c->relax = 1.0f - expf(-p->time_step * 9.81f / p->fall_speed);
    c->amp = p->flutter_amplitude;
    c->radius2 = 2.0f * p->flake_radius;
    float scale = 1.0f;
    for (int k = 0; k < 3; ++k) {
        c->wind[k] = p->wind[k];
        c->lo[k] = p->volume_min[k];
        c->hi[k] = p->volume_max[k];
        c->len[k] = p->volume_max[k] - p->volume_min[k];
        scale = fmaxf(scale, fmaxf(fabsf(p->volume_min[k]), fabsf(p->volume_max[k])));
    }
    /* Well above float resolution at the scene's scale, well below a flake. */
    c->eps = fmaxf(1e-4f, scale * 4e-6f);
    for (int k = 0; k < 2 * SNOW_FLUTTER_CLASSES; ++k) {
        const int cls = k & (SNOW_FLUTTER_CLASSES - 1);
        const double f = p->flutter_frequency * (0.7 + 0.6 * cls / (SNOW_FLUTTER_CLASSES - 1));
        const double ang = (k >= SNOW_FLUTTER_CLASSES ? -1.0 : 1.0) * 2.0 * M_PI * f * p->time_step;
        c->rot[k][0] = (float)cos(ang);
        c->rot[k][1] = (float)sin(ang);
    }
    c->box_mode = p->contact_mode == HBK_SNOW_CONTACT_BOX;
    const snow_mesh_t *m = &h->mesh;
    if (c->box_mode) {
        for (int k = 0; k < 3; ++k) { c->root_lo[k] = INFINITY; c->root_hi[k] = -INFINITY; }
        for (int32_t b = 0; b < m->box_count; ++b)
            if (m->boxes[b].valid) {
                c->has_mesh = 1;
                for (int k = 0; k < 3; ++k) {
                    c->root_lo[k] = fminf(c->root_lo[k], m->boxes[b].lo[k]);
                    c->root_hi[k] = fmaxf(c->root_hi[k], m->boxes[b].hi[k]);
                }
            }
    } else if (m->bvh.tri_count > 0) {
        c->has_mesh = 1;
        memcpy(c->root_lo, m->bvh.nodes[0].lo, sizeof c->root_lo);
        memcpy(c->root_hi, m->bvh.nodes[0].hi, sizeof c->root_hi);
    }
}

void snow_flakes_init(hbk_snow_t *h)
{
    ctx_t c;
    ctx_init(&c, h);
    const int32_t n = h->p.flake_count;
    const int nt = hbk_threads(h->p.threads);
#pragma omp parallel for schedule(static) num_threads(nt)
    for (int32_t i = 0; i < n; ++i) spawn(&c, (uint32_t)i, 0, SPAWN_INIT, &h->flakes[i]);
    snow_flakes_by_id(h);
}

void snow_flakes_by_id(hbk_snow_t *h)
{
    for (int32_t i = 0; i < h->p.flake_count; ++i) h->ids[i] = (uint32_t)i;
}

#define PLACE_AXIS 32 /* cells a side of the grid that orders the slots */

/* Bits 0-4 of v to every third bit. */
static uint32_t spread3(uint32_t v)
{
    v &= 31;
    v = (v | v << 8) & 0x0300f00f;
    v = (v | v << 4) & 0x030c30c3;
    v = (v | v << 2) & 0x09249249;
    return v;
}

/* Puts the flakes in slots by place: cell by cell of a 32^3 grid over the volume, the cells in
 * Morton order, in their slots' order within a cell (a counting sort). Flakes stepped one
 * after another then walk the same BVH nodes to the same triangles, which stay in cache; in
 * slots by id each step's walk went to a part of the tree at random. Nothing else depends on
 * the slots: each flake steps alone under its id, the events are sorted, and the state and
 * the flakes' positions are given by id. Left as they are if out of memory. */
static void sort_by_place(hbk_snow_t *h, const ctx_t *c)
{
    enum { CELLS = PLACE_AXIS * PLACE_AXIS * PLACE_AXIS };
    const int32_t n = h->p.flake_count;
    const int nt = hbk_threads(h->p.threads);
    /* Per thread a histogram of its own run of slots, then each thread's start in each cell:
     * the same stable order as one thread's counting sort, whatever the thread count. */
    uint32_t *at = calloc((size_t)nt * CELLS, sizeof *at);
    uint16_t *key = malloc(sizeof *key * (size_t)n);
    if (!at || !key) {
        free(at); free(key);
        return;
    }
    float scale[3];
    for (int k = 0; k < 3; ++k) scale[k] = (float)PLACE_AXIS / c->len[k];
#pragma omp parallel num_threads(nt)
    {
        const int t = omp_get_thread_num(), team = omp_get_num_threads();
        const int32_t j0 = (int32_t)((int64_t)n * t / team);
        const int32_t j1 = (int32_t)((int64_t)n * (t + 1) / team);
        uint32_t *mine = at + (size_t)t * CELLS;
        for (int32_t j = j0; j < j1; ++j) {
            uint32_t code = 0;
            for (int k = 0; k < 3; ++k) {
                const float q = (h->flakes[j].p[k] - c->lo[k]) * scale[k];
                code |= spread3((uint32_t)snow_min(snow_max(q, 0.0f), PLACE_AXIS - 1)) << k;
            }
            key[j] = (uint16_t)code;
            mine[code]++;
        }
#pragma omp barrier
#pragma omp single
        {
            uint32_t sum = 0;
            for (int b = 0; b < CELLS; ++b)
                for (int u = 0; u < team; ++u) {
                    const uint32_t count = at[(size_t)u * CELLS + b];
                    at[(size_t)u * CELLS + b] = sum;
                    sum += count;
                }
        }
        for (int32_t j = j0; j < j1; ++j) {
            const uint32_t to = mine[key[j]]++;
            h->scratch[to] = h->flakes[j];
            h->ids_spare[to] = h->ids[j];
        }
    }
    snow_flake_t *f = h->flakes;
    h->flakes = h->scratch;
    h->scratch = f;
    uint32_t *i = h->ids;
    h->ids = h->ids_spare;
    h->ids_spare = i;
    free(at); free(key);
}

/* Whether geometry lies on the way the flake would have come from the top with the mean air
 * velocity (wind and fall), or, BOX, the flake is inside a box. */
static int sheltered(const ctx_t *c, const snow_flake_t *f)
{
    const hbk_snow_params_t *p = &c->h->p;
    const float up = c->hi[2] - f->p[2], vz = p->fall_speed - c->wind[2];
    if (!(up > 0.0f)) return 0;
    float d[3] = {0.0f, 0.0f, up};
    if (vz > 0.0f) { /* else an updraught: look straight up */
        d[0] = -c->wind[0] * up / vz;
        d[1] = -c->wind[1] * up / vz;
    }
    for (int k = 0; k < 3; ++k) {
        const float e = f->p[k] + d[k];
        if (snow_min(f->p[k], e) > c->root_hi[k] || snow_max(f->p[k], e) < c->root_lo[k]) return 0;
    }
    const snow_mesh_t *m = &c->h->mesh;
    if (c->box_mode) {
        for (int32_t b = 0; b < m->box_count; ++b) {
            const snow_box_t *bx = &m->boxes[b];
            if (bx->valid && f->p[0] >= bx->lo[0] && f->p[0] <= bx->hi[0] && f->p[1] >= bx->lo[1] &&
                f->p[1] <= bx->hi[1] && f->p[2] >= bx->lo[2] && f->p[2] <= bx->hi[2])
                return 1;
        }
        float t;
        int32_t box, face;
        return snow_box_hit(m, f->p, d, &t, &box, &face);
    }
    bvh_hit_t hit;
    return snow_bvh_hit(&m->bvh, f->p, d, &hit);
}

static int push_event(snow_events_t *ev, const snow_event_t *e)
{
    if (ev->n == ev->cap) {
        size_t cap = ev->cap ? ev->cap * 2 : 1024;
        snow_event_t *ne = realloc(ev->e, cap * sizeof *ne);
        if (!ne) return 0;
        ev->e = ne;
        ev->cap = cap;
    }
    ev->e[ev->n++] = *e;
    return 1;
}

typedef struct {
    int64_t stuck, bounced, melted, shed, fell;
} counts_t;

typedef struct {
    float t, n[3];
    int32_t prim, mat;
    bvh_hit_t bh;
} contact_t;

/* The first contact of segment p + t d, t in [0, 1], with the mesh. */
static int find_contact(const ctx_t *c, const float p[3], const float d[3], contact_t *ct)
{
    const snow_mesh_t *m = &c->h->mesh;
    /* The cheap test first: most flakes are nowhere near the geometry. */
    float e[3];
    for (int k = 0; k < 3; ++k) {
        e[k] = p[k] + d[k];
        if (snow_min(p[k], e[k]) > c->root_hi[k] || snow_max(p[k], e[k]) < c->root_lo[k])
            return 0;
    }
    if (c->box_mode) {
        int32_t box, face;
        if (!snow_box_hit(m, p, d, &ct->t, &box, &face)) return 0;
        ct->prim = box * 6 + face;
        ct->mat = box;
        snow_box_normal(face, ct->n);
        return 1;
    }
    /* Then the occupancy grid: most steps inside the bounds touch no surface. */
    if (!snow_grid_maybe(&m->grid, p, e) || !snow_bvh_hit(&m->bvh, p, d, &ct->bh)) return 0;
    ct->t = ct->bh.t;
    ct->prim = m->bvh.tris[ct->bh.tri].id;
    const snow_tri_info_t *ti = &m->info[ct->prim];
    ct->mat = ti->material;
    memcpy(ct->n, ti->n, sizeof ct->n);
    return 1;
}

/* One flake through `substeps` substeps. Returns 0 if an event could not be stored. */
static int advance(const ctx_t *c, uint32_t id, uint64_t step0, int32_t substeps, int place,
                   snow_flake_t *f, snow_events_t *ev, counts_t *n)
{
    const hbk_snow_t *h = c->h;
    const snow_mesh_t *m = &h->mesh;
    /* The first placement spread flakes through the volume without the mesh, and a moving
     * mesh moves onto flakes: one inside an object or under a roof could not have got there. */
    if (place && sheltered(c, f)) spawn(c, id, step0, SPAWN_SHELTER, f);
    for (int32_t s = 0; s < substeps; ++s) {
        const uint64_t step = step0 + (uint64_t)s;
        float a[3], d[3];
        air_velocity(c, f, a);
        for (int k = 0; k < 3; ++k) {
            f->v[k] += (a[k] - f->v[k]) * c->relax;
            d[k] = f->v[k] * c->dt;
        }
        /* Turn the flutter now: its direction only affects the next substep's air. */
        {
            const float *r = c->rot[f->cls & (2 * SNOW_FLUTTER_CLASSES - 1)];
            const float fc = f->fc * r[0] - f->fs * r[1], fs = f->fs * r[0] + f->fc * r[1];
            f->fc = fc;
            f->fs = fs;
        }
        contact_t ct;
        int hit = c->has_mesh && find_contact(c, f->p, d, &ct);
        if (!hit && c->has_mesh) {
            /* A step across a side continues on the opposite side: test it there as well, so
             * geometry at the edge of the volume is hit from both sides. */
            float q[3] = {f->p[0], f->p[1], f->p[2]};
            int wraps = 0;
            for (int k = 0; k < 2; ++k) {
                const float e = q[k] + d[k];
                if (e < c->lo[k] || e >= c->hi[k]) {
                    q[k] -= floorf((e - c->lo[k]) / c->len[k]) * c->len[k];
                    wraps = 1;
                }
            }
            if (wraps && find_contact(c, q, d, &ct)) {
                hit = 1;
                memcpy(f->p, q, sizeof q);
            }
        }
        if (hit) {
            const float t = ct.t;
            float nrm[3] = {ct.n[0], ct.n[1], ct.n[2]};
            const int32_t prim = ct.prim, mat = ct.mat;
            const bvh_hit_t bh = ct.bh;
            const hbk_snow_material_t *mt = &h->materials[mat];
            int gone = 1;
            if (mt->melts) {
                n->melted++;
            } else if (mt->sheds) {
                n->shed++;
            } else {
                uint32_t w[4];
                hbk_philox(c->seed, id, snow_rng_counter(step, SNOW_RNG_CONTACT), w);
                float x[3];
                for (int k = 0; k < 3; ++k) x[k] = f->p[k] + t * d[k];
                if (hbk_u32_to_unit(w[0]) < h->chance[mat]) {
                    snow_event_t e = {.step = step, .flake = id, .prim = prim,
                                      .r = hbk_u32_to_unit(w[1])};
                    if (c->box_mode) {
                        snow_box_face_texel(h, prim / 6, prim % 6, x, &e.tx, &e.ty, &e.sx, &e.sy);
                    } else {
                        const snow_tri_info_t *ti = &m->info[prim];
                        const float b0 = 1.0f - bh.b1 - bh.b2;
                        e.tx = b0 * ti->uv[0] + bh.b1 * ti->uv[2] + bh.b2 * ti->uv[4];
                        e.ty = b0 * ti->uv[1] + bh.b1 * ti->uv[3] + bh.b2 * ti->uv[5];
                        e.sx = fminf(c->radius2 * ti->dens[0], (float)h->tex_w);
                        e.sy = fminf(c->radius2 * ti->dens[1], (float)h->tex_h);
                    }
                    if (!push_event(ev, &e)) return 0;
                    n->stuck++;
                } else {
                    /* Bounce: mirror the normal part of the velocity, fly on from the contact. */
                    n->bounced++;
                    float vn = f->v[0] * nrm[0] + f->v[1] * nrm[1] + f->v[2] * nrm[2];
                    if (vn > 0.0f) { /* face the side the flake came from */
                        for (int k = 0; k < 3; ++k) nrm[k] = -nrm[k];
                        vn = -vn;
                    }
                    for (int k = 0; k < 3; ++k) {
                        f->v[k] -= (1.0f + SNOW_RESTITUTION) * vn * nrm[k];
                        f->p[k] = x[k] + c->eps * nrm[k];
                    }
                    gone = 0;
                }
            }
            if (gone) {
                spawn(c, id, step, SPAWN_TOP, f);
                continue;
            }
        } else {
            for (int k = 0; k < 3; ++k) f->p[k] += d[k];
        }
        if (f->p[2] < c->lo[2] || f->p[2] > c->hi[2]) {
            n->fell++;
            spawn(c, id, step, SPAWN_TOP, f);
            continue;
        }
        for (int k = 0; k < 2; ++k) /* the four sides wrap around */
            if (f->p[k] < c->lo[k] || f->p[k] >= c->hi[k]) {
                f->p[k] -= floorf((f->p[k] - c->lo[k]) / c->len[k]) * c->len[k];
                if (f->p[k] < c->lo[k] || f->p[k] >= c->hi[k]) f->p[k] = c->lo[k];
            }
    }
    return 1;
}

static int event_order(const void *pa, const void *pb)
{
    const snow_event_t *a = pa, *b = pb;
    if (a->step != b->step) return a->step < b->step ? -1 : 1;
    return (a->flake > b->flake) - (a->flake < b->flake);
}

hbk_result_t snow_flakes_step(hbk_snow_t *h, int32_t substeps, hbk_progress_t *progress)
{
    ctx_t c;
    ctx_init(&c, h);
    const int32_t n = h->p.flake_count;
    const int nt = hbk_threads(h->p.threads);
    if (h->tev_count < nt) {
        snow_events_t *t = realloc(h->tev, sizeof *t * (size_t)nt);
        if (!t) return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "out of memory for events");
        memset(t + h->tev_count, 0, sizeof *t * (size_t)(nt - h->tev_count));
        h->tev = t;
        h->tev_count = nt;
    }
    for (int i = 0; i < h->tev_count; ++i) h->tev[i].n = 0;

    /* Rounds of at most ROUND substeps over all flakes keep the cancel polls frequent; the
     * first round reads the current flakes, every round writes the scratch copy, which
     * becomes the state only when the whole call succeeded. */
    const int32_t blocks = (n + BLOCK - 1) / BLOCK;
    const int32_t rounds = (substeps + ROUND - 1) / ROUND;
    const double work = (double)n * rounds;
    int64_t done = 0;
    int32_t stop = 0; /* 1 cancelled, 2 out of memory */
    const int place = h->shelter_check && c.has_mesh;
    counts_t total = {0};
    for (int32_t rd = 0; rd < rounds && !stop; ++rd) {
        const int32_t first = rd * ROUND;
        const int32_t count = substeps - first < ROUND ? substeps - first : ROUND;
        const snow_flake_t *src = rd == 0 ? h->flakes : h->scratch;
        const uint64_t step0 = h->step + (uint64_t)first;
#pragma omp parallel num_threads(nt)
        {
            counts_t cnt = {0};
            snow_events_t *ev = &h->tev[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 1)
            for (int32_t b = 0; b < blocks; ++b) {
                if (__atomic_load_n(&stop, __ATOMIC_RELAXED)) continue;
                const int32_t end = b * BLOCK + BLOCK < n ? b * BLOCK + BLOCK : n;
                for (int32_t i = b * BLOCK; i < end; ++i) { /* slot i */
                    if ((i % CANCEL_EVERY) == 0 && hbk_cancelled(progress)) {
                        __atomic_store_n(&stop, 1, __ATOMIC_RELAXED);
                        break;
                    }
                    snow_flake_t f = src[i];
                    if (!advance(&c, h->ids[i], step0, count, place && rd == 0, &f, ev, &cnt)) {
                        __atomic_store_n(&stop, 2, __ATOMIC_RELAXED);
                        break;
                    }
                    h->scratch[i] = f;
                }
                const int64_t d = __atomic_add_fetch(&done, end - b * BLOCK, __ATOMIC_RELAXED);
                if (omp_get_thread_num() == 0) hbk_report(progress, (float)(0.95 * (double)d / work));
            }
#pragma omp critical
            {
                total.stuck += cnt.stuck; total.bounced += cnt.bounced;
                total.melted += cnt.melted; total.shed += cnt.shed; total.fell += cnt.fell;
            }
        }
    }
    if (stop == 1) return hbk_fail(&h->msg, HBK_ERR_CANCELLED, "cancelled");
    if (stop == 2) return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "out of memory for events");

    size_t ne = 0;
    for (int i = 0; i < h->tev_count; ++i) ne += h->tev[i].n;
    if (ne > h->all.cap) {
        snow_event_t *e = realloc(h->all.e, ne * sizeof *e);
        if (!e) return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "out of memory for events");
        h->all.e = e;
        h->all.cap = ne;
    }
    h->all.n = 0;
    for (int i = 0; i < h->tev_count; ++i) {
        if (h->tev[i].n) memcpy(h->all.e + h->all.n, h->tev[i].e, h->tev[i].n * sizeof *h->all.e);
        h->all.n += h->tev[i].n;
    }
    /* Keys are unique (one contact per flake and substep): the order is total. With no
     * events the array may be NULL, which qsort must not be given. */
    if (h->all.n) qsort(h->all.e, h->all.n, sizeof *h->all.e, event_order);
    for (size_t i = 0; i < h->all.n; ++i) snow_stamp(h, &h->all.e[i]);

    snow_flake_t *t = h->flakes;
    h->flakes = h->scratch;
    h->scratch = t;
    /* Where flakes meet the mesh at all, the next call finds them in slots by place: even in
     * an open volume (a hit in 300 flake-steps) that saves more than the sort costs. */
    const int64_t hits = total.stuck + total.bounced + total.melted + total.shed;
    if (hits * SNOW_SORT_HITS >= (int64_t)substeps * n) sort_by_place(h, &c);
    h->step += (uint64_t)substeps;
    h->shelter_check = 0;
    hbk_snow_stats_t *st = &h->stats;
    st->substeps += substeps;
    st->flake_steps += (int64_t)substeps * n;
    st->stuck += total.stuck;
    st->bounced += total.bounced;
    st->melted += total.melted;
    st->shed += total.shed;
    st->fell += total.fell;
    st->hits += total.stuck + total.bounced + total.melted + total.shed;
    hbk_report(progress, 1.0f);
    return HBK_OK;
}
