/* Private: the rain handle, its drops and particles, and the parts of one step. */
#ifndef HBK_INTERNAL_RAIN_H
#define HBK_INTERNAL_RAIN_H
#include "hbk_rain.h"
#include "hbk_rng.h"
#include "../base/internal_base.h"

/* RNG streams: one per purpose, so no two uses ever share a block. */
enum {
    RAIN_STREAM_AFFINITY = 0x52a1, /* counter: cell / 4 */
    RAIN_STREAM_RAIN_COUNT,        /* counter: step */
    RAIN_STREAM_RAIN_DROP,         /* counter: step << 24 | k */
    RAIN_STREAM_SHAPE,             /* counter: drop id << 2 | block */
    RAIN_STREAM_MOVE,              /* counter: drop id << 24 | move */
    RAIN_STREAM_SPLIT              /* counter: drop id << 24 | particle */
};

#define RAIN_MAX_SUBS 8
#define RAIN_AFFINITY_MAX 2.0f
#define RAIN_TAIL_RELAX 0.25 /* s, time constant of the sub-metaballs' return */
#define RAIN_BLOCK 16         /* cells per side of the blocks that bound drop radii */
#define RAIN_MAX_MOVES 4096  /* cells one drop may move in one step (a guard, never reached
                                at sane speeds) */

enum { DROP_TRAIL = 1u, DROP_DEAD = 2u };

/* A grid drop. No padding (it is saved byte for byte). */
typedef struct rain_drop {
    double mass;                        /* mg */
    uint64_t id;
    float x, y;                         /* cells, continuous */
    float speed;                        /* m/s, 0 at rest */
    float travel;                       /* m run towards the next cell */
    float age;                          /* s, trail drops: since they were left */
    float mass0;                        /* mg, trail drops: mass when left */
    uint32_t moves;                     /* cells moved (the RNG counter of its choices) */
    uint32_t flags;                     /* DROP_* */
    float off[RAIN_MAX_SUBS][2];        /* sub-metaball offsets now, in radii */
    int8_t rest[RAIN_MAX_SUBS][2];      /* rest offsets, radii * 127 */
    uint8_t scale[RAIN_MAX_SUBS];       /* radius factor, 0.8 + 0.2 * scale / 255 */
} rain_drop_t;
_Static_assert(sizeof(rain_drop_t) == 136, "rain_drop_t must have no padding");

typedef struct rain_particle {
    double mass; /* mg */
    float x, y;  /* cells */
} rain_particle_t;
_Static_assert(sizeof(rain_particle_t) == 16, "rain_particle_t must have no padding");

/* Undo journal entry for a cell value changed during a step (for cancellation). */
typedef struct rain_undo {
    uint32_t index;
    uint32_t field; /* 0 affinity, 1 film */
    double old;
} rain_undo_t;

/* A wet mark made during a step, applied when the step commits. */
typedef struct rain_wet_mark {
    float x, y, r; /* cells */
} rain_wet_mark_t;

/* A blade at one instant, in cells: centre line from o along a for len; n = a turned +90 deg. */
typedef struct rain_blade {
    float ox, oy, ax, ay, nx, ny, len, half_w;
} rain_blade_t;

struct hbk_rain {
    hbk_rain_params_t p;
    hbk_message_t msg;
    size_t n; /* cells */
    /* State (saved by hbk_rain_save_state). */
    uint64_t steps, next_id;
    double time;                        /* s */
    double rain_in, wiped, run_off;     /* mg */
    float car_speed, car_accel, wind[2];
    float wiper_value[2];               /* deg (PIVOT) / m (TRANSLATE) now */
    float wiper_target[2];
    int32_t wiper_external;             /* 1: wiper_target drives the next steps */
    rain_drop_t *drops;
    int64_t drop_count, drop_cap;
    int64_t dead;                       /* drops flagged DROP_DEAD, not yet compacted away */
    rain_particle_t *particles;
    int64_t particle_count, particle_cap;
    float *affinity;                    /* per cell */
    double *film;                       /* mg per cell (double: the books must balance) */
    float *wet_time;                    /* s, last time a drop ran through; -1e30: never */
    float *field;                       /* per cell: g (2) and b (2), or NULL */
    int32_t field_channels;             /* 2 or 4 when `field` is set */
    float *mask;                        /* per cell, or NULL */
    /* Derived, rebuilt on load. */
    int32_t *occ;                       /* per cell: index of its drop, or -1 */
    uint64_t *occ_bits;                 /* per cell: holds a drop that is not a trail drop (the
                                           ones contact merges and hold-back look for), so
                                           their scans skip everything else 64 cells at once */
    size_t occ_words;                   /* 64-bit words per row of occ_bits */
    /* Radius bounds (derived: rebuilt at each step and on load; only grow in between). */
    float r_max;                        /* cells, an upper bound of every drop's radius */
    float *blk_r;                       /* per RAIN_BLOCK^2 block: bound of its drops' radii */
    int32_t blk_w, blk_h;
    /* Step scratch. */
    int journaling;
    rain_undo_t *undo;
    size_t undo_count, undo_cap;
    rain_wet_mark_t *marks;
    size_t mark_count, mark_cap;
    rain_drop_t *backup_drops;
    int64_t backup_drop_cap;
    rain_particle_t *backup_particles;
    int64_t backup_particle_cap;
    int alloc_failed;                   /* an allocation inside the step failed */
    /* Particle scratch (hash grid and displacements). */
    uint32_t *hash_start, *hash_items, *hash_key;
    int32_t *hash_bin;                  /* 2 per particle: its hash cell */
    int64_t hash_cap;
    uint32_t hash_size;
    float *disp;
    int64_t disp_cap;
    /* Map scratch. */
    float *balls;                       /* 5 floats per ball: cx, cy, inv_r2, w, reach */
    int64_t ball_cap;
    uint32_t *band_items, *band_start;
    int64_t band_item_cap;
    int32_t band_cap;
    float *band_buf;                    /* per thread: BAND rows of the map, padded */
    size_t band_buf_size;
};

static inline int32_t ifloor(float v)
{
    const int32_t i = (int32_t)v;
    return (float)i > v ? i - 1 : i;
}
static inline int32_t clampi(int32_t v, int32_t lo, int32_t hi)
{
    return v < lo ? lo : v > hi ? hi : v;
}
static inline int32_t mini(int32_t a, int32_t b) { return a < b ? a : b; }

/* rain_params.c */
float rain_radius_cells(const hbk_rain_t *h, double mass);

/* The paper's compression passes (eq. 2) on V, the part of the field above the threshold. */
static inline float rain_compress_value(const hbk_rain_params_t *p, float v)
{
    for (int32_t k = 0; k < p->compress_passes; ++k) {
        const float v0 = p->compress_v0 + (float)k * p->compress_step;
        if (v > v0) v = p->compress_k * (v - v0) + v0;
    }
    return v;
}

/* grid_drops.c */
int rain_is_glass(const hbk_rain_t *h, int32_t cx, int32_t cy);
void rain_accel_at(const hbk_rain_t *h, int32_t cx, int32_t cy, float *ax, float *ay);
rain_drop_t *rain_new_drop(hbk_rain_t *h, float x, float y, double mass);
/* Lands `mass` at (x, y) cells: merges with the drop there or within reach, else a new drop.
 * Returns 0 on allocation failure (h->alloc_failed is set). */
int rain_land(hbk_rain_t *h, float x, float y, double mass);
void rain_kill_drop(hbk_rain_t *h, int64_t i);
void rain_rain(hbk_rain_t *h, double dt);
hbk_result_t rain_move_drops(hbk_rain_t *h, double dt, hbk_progress_t *progress);
void rain_age_drops(hbk_rain_t *h, double dt);
void rain_compact(hbk_rain_t *h);
void rain_compact_drops(hbk_rain_t *h);
void rain_commit_marks(hbk_rain_t *h);
void rain_set_affinity(hbk_rain_t *h, size_t i, float v);
void rain_set_film(hbk_rain_t *h, size_t i, double v);
void rain_mark_wet(hbk_rain_t *h, float x, float y, float r);
void rain_rebuild_occ(hbk_rain_t *h);
void rain_update_bounds(hbk_rain_t *h);

/* Puts drop i (or -1: none) in cell (x, y), keeping the bitmap in step: call it again when
 * a trail drop becomes a real one. */
static inline void rain_occ_put(hbk_rain_t *h, int32_t x, int32_t y, int32_t i)
{
    h->occ[(size_t)y * (size_t)h->p.width + (size_t)x] = i;
    uint64_t *w = h->occ_bits + (size_t)y * h->occ_words + ((size_t)x >> 6);
    const uint64_t bit = (uint64_t)1 << (x & 63);
    *w = i >= 0 && !(h->drops[i].flags & DROP_TRAIL) ? *w | bit : *w & ~bit;
}

/* The first occupied cell x' >= x of row y, or x1 + 1 if none is <= x1. */
static inline int32_t rain_next_occ(const hbk_rain_t *h, int32_t y, int32_t x, int32_t x1)
{
    const uint64_t *row = h->occ_bits + (size_t)y * h->occ_words;
    while (x <= x1) {
        const uint64_t w = row[x >> 6] >> (x & 63);
        if (w) {
            x += __builtin_ctzll(w);
            return x <= x1 ? x : x1 + 1;
        }
        x = (x | 63) + 1;
    }
    return x1 + 1;
}

/* Notes a drop of radius r (cells) at (x, y) cells in the radius bounds. */
static inline void rain_note_radius(hbk_rain_t *h, float x, float y, float r)
{
    if (r > h->r_max) h->r_max = r;
    const size_t b = (size_t)((int32_t)y / RAIN_BLOCK) * (size_t)h->blk_w +
                     (size_t)((int32_t)x / RAIN_BLOCK);
    if (r > h->blk_r[b]) h->blk_r[b] = r;
}

/* wipers.c */
float rain_wiper_value_at(const hbk_rain_t *h, int32_t i, double t);
void rain_blade_at(const hbk_rain_t *h, int32_t i, float value, rain_blade_t *b);
hbk_result_t rain_wipers(hbk_rain_t *h, double dt, hbk_progress_t *progress);

/* particles.c */
rain_particle_t *rain_new_particle(hbk_rain_t *h, float x, float y, double mass);
/* Particles cand[0..ncand) and every particle from index `first_new` on. */
void rain_particles_collide(hbk_rain_t *h, const rain_blade_t *b, const int *lead, int nb,
                            const int64_t *cand, int64_t ncand, int64_t first_new);
int rain_particles_repel(hbk_rain_t *h, const int64_t *act, int64_t nact);
void rain_particles_leave_glass(hbk_rain_t *h, int64_t first);

/* switching.c */
int rain_to_particles(hbk_rain_t *h, const rain_blade_t *b, const int *lead, int nb,
                      const int64_t *cand, int64_t ncand);
int rain_to_drops(hbk_rain_t *h);
float rain_blade_distance(const rain_blade_t *b, float x, float y);

#endif
