/* Raindrops on a windshield (Gotou, Tanaka, Sagawa, "フロントガラスを流れる雨滴の CG 表現"):
 * drops that meander down the glass and leave trails, wipers that gather them, baked into a
 * height map (2D metaballs, compressed), normals, a wetness map and a cheap refraction preview.
 *
 * The glass. A grid of width x height cells, each cell_size metres square; cell (i, j) spans
 * x in [i, i+1), y in [j, j+1) in cell units, i.e. metres / cell_size. Positions in this API
 * are in metres from the glass's lower left corner: x along u, y along v (row 0 = bottom, as
 * in hbk_image.h). Masses are in mg (1 mg = 1 mm^3 of water). Curved glass is simulated in
 * the UV space of its mesh (hbk_rain_set_tangents): each cell is treated as cell_size square
 * and the forces act along that cell's own u and v tangents.
 *
 * Drops (paper §4.1, the grid model). A drop has a mass and sits in one cell. The in-plane
 * acceleration on it is
 *     A = gravity * g + wind + (airflow * car_speed^2 + car_accel) * b
 * where g is the cell's in-plane gravity direction (gravity_dir, or the tangent image) and b
 * the car's backward axis projected into the cell's frame (airflow_dir, or the tangent
 * image): driving makes air push drops backward (up a windshield), accelerating adds the
 * inertial force the same way, braking the opposite. A drop at rest starts to run when
 * mass * |A| > static_mass * gravity (static friction). A running drop's speed s (m/s) follows
 *     ds/dt = |A| - static_mass * gravity / mass - drag * s      (implicit in drag),
 * and it stops when s reaches 0. It moves one cell at a time: each time it has travelled a
 * cell's length it draws the next cell among the neighbour (of the 8) nearest the direction
 * of A and that neighbour's two side neighbours, with weights affinity(cell) * (c + m): c
 * splits A between the two neighbours that bracket it (A = c1 d1 + c2 d2, so the mean move
 * points exactly along A and a drop pulled straight at a cell runs straight), m is
 * affinity_random shared between the two side neighbours so that their sideways parts
 * cancel (meandering on uneven glass, without bias). Each cell's affinity starts at
 * 1 - affinity_random * U[0,1) and rises by affinity_gain (up to 2) every time a drop leaves
 * it, so later drops follow earlier paths.
 * Trails: leaving a cell, a running drop leaves a trail drop of trail_mass there with chance
 * (length of the move) / trail_spacing, if it keeps at least twice that. Trail drops keep
 * their size for half of trail_lifetime, then shrink linearly and vanish at trail_lifetime;
 * the water they lose stays on the glass as an invisible film in their cell, which the next
 * drop to enter or land in the cell takes up.
 * Merging: a drop that moves into, or lands in, a cell merges with the drop there (the
 * paper's rule), and with every other drop (not trail drops) whose centre is closer than
 * merge_distance * (r1 + r2); masses add; the mover keeps its place and shape, or else the
 * heavier drop, the one already there on a tie. A drop's contact radius r is that of a
 * hemisphere of its volume, r = cbrt(3 V / (2 pi)).
 * Rain arrives as new drops at uniformly random places, rain_rate per m^2 per s, with masses
 * uniform in drop_mass * [1 - drop_mass_spread, 1 + drop_mass_spread]. A drop that moves off
 * the glass (out of the grid, or onto a cell whose mask is < 0.5) has run off.
 *
 * Wipers and particles (§4.2-4.6). A blade is a rectangle of blade_length x blade_width.
 * PIVOT: the blade lies along the arm at angle theta from the pivot, from blade_offset to
 * blade_offset + blade_length; theta = wiper_rest[i] + sweep_angle * (1 - cos(2 pi (t /
 * wiper_period + wiper_phase))) / 2. TRANSLATE (the paper's): the blade's centre is
 * wiper_pivot[i] + s * (cos rest, sin rest), the blade perpendicular to that travel
 * direction, s = sweep_distance * (1 - cos(...)) / 2. hbk_rain_set_wiper_angles can drive
 * theta (degrees) or s (metres) from animation instead.
 * Each step moves the blades in substeps of at most 0.9 blade_width, so nothing slips
 * through a blade. In every substep, a drop touched by a blade (its circle reaches the blade,
 * on the blade's leading side) becomes n = max(1, round(mass / particle_mass)) particles of
 * mass mass / n, jittered around it within its radius; and a particle closer than
 * particle_radius to a blade's leading long edge (or inside the blade) is moved to touch
 * that edge. Once per step, particles within switch_margin of a blade push each other apart:
 * overlapping ones move along the line of centres by half the overlap each plus that times
 * `repulsion` (particle_iterations Jacobi passes, at most a radius per particle and pass,
 * each followed by the blades again); the others rest where they were left. A particle that
 * leaves the glass has been wiped off. At the end of a step, a particle farther than
 * switch_margin from every blade becomes a drop again in its cell, in particle order, unless
 * `holdback` is on and a drop of at least holdback_mass sits in the square of (2 R + 1)^2
 * cells around that cell, R the larger of holdback_radius and that drop's merge reach (so
 * the search is always wider than merging, as §4.6 asks); then it waits.
 *
 * Height map (§5). Every drop is drawn as sub_count sub-metaballs of weight 1 / sub_count
 * (trail drops and particles as one of weight 1): sub k at offset o_k * R from the drop's
 * centre with radius R_k = R * f_k, R = radius_scale * r, f_0 = 1, o_0 = 0, the others
 * random per drop (|o_k| <= sub_spread, f_k in [0.8, 1]). A running drop drags its
 * sub-metaballs behind it (up to tail_length radii) and they relax back to their rest
 * offsets (time constant 0.25 s), which draws tails. The field S = sum w N(h / R_k) with
 * N(q) = 1 / (1 + q^4), h the distance from the texel centre to the ball's centre, summed
 * over h <= kernel_support * R_k. Then V = S - threshold where S > threshold, else 0, and
 * compress_passes passes of
 *     V > V0_p:  V = compress_k (V - V0_p) + V0_p,   V0_p = compress_v0 + p * compress_step.
 * We read the paper as applying the passes to the part above the threshold: a single drop,
 * whose V peaks at 0.5, keeps its exact profile and only stacked drops are flattened. The map
 * holds V * height_scale metres. Normals: hbk_normal_map with texel size width * cell_size /
 * map_width by height * cell_size / map_height.
 *
 * Water. rain_in = on_glass + wiped + run_off holds after every call, to double rounding.
 *
 * Determinism. Every random number comes from the counter-based RNG keyed by the seed and
 * (cell) for affinities, (step, k) for rain, (drop id, move) for choices and trails, (drop id)
 * for shapes and particle jitter. The step runs in a fixed order; the maps are split into
 * row bands whose texels sum their balls in one fixed order. Same seed, params and calls give
 * the same bytes for any `threads` (and with or without the AVX2 path the maps take where the
 * CPU has it).
 *
 * Threads: one handle must not be used from two threads at once; different handles are
 * independent. The handle owns everything it allocates; setters copy the caller's data. */
#ifndef HBK_RAIN_H
#define HBK_RAIN_H
#include "hbk_base.h"
#include "hbk_image.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef enum hbk_rain_wiper_mode {
    HBK_RAIN_WIPER_TRANSLATE = 0, /* the paper's straight blade moving sideways */
    HBK_RAIN_WIPER_PIVOT = 1      /* a car's blade on an arm sweeping an arc */
} hbk_rain_wiper_mode_t;

typedef struct hbk_rain_params {
    uint32_t size;            /* sizeof(hbk_rain_params_t), set by hbk_rain_params_default */
    /* The glass and its maps. */
    int32_t width;            /* cells along x (u), 8..16384; default 1024 */
    int32_t height;           /* cells along y (v), 8..16384; 512; width x height <= 4096^2 */
    float cell_size;          /* m, 1e-4..0.05, edge of one cell, about a small drop; 0.001 */
    int32_t map_width;        /* height map texels along x, 8..16384; default 2048 */
    int32_t map_height;       /* texels along y, 8..16384; 1024; product <= 8192^2 */
    /* Forces. */
    float gravity;            /* m/s^2, 0..100; 9.81 */
    float gravity_dir[2];     /* in-plane part of the unit down vector, |.| <= 1 (a pane
                                 tilted back by a has length cos a); (0, -1): upright pane */
    float wind[2];            /* m/s^2, -100..100, in-plane push along the cells' u, v; 0 */
    float car_speed;          /* m/s, 0..100; airflow pushes drops along airflow_dir; 0 */
    float car_accel;          /* m/s^2, -50..50; > 0 pushes drops along airflow_dir; 0 */
    float airflow;            /* 1/m, 0..10: airflow acceleration per (m/s)^2 of car speed;
                                 0.04 lifts drops on an upright pane at about 16 m/s */
    float airflow_dir[2];     /* car's backward axis in the glass plane, |.| <= 1; (0, 1) */
    /* Drops (grid model). */
    float static_mass;        /* mg, 0.01..1e4: a drop heavier than this runs under full
                                 gravity (static friction); 15 */
    float drag;               /* 1/s, 0.01..1e4: speed relaxation of running drops; 40 */
    float affinity_random;    /* 0..1: spread of the cells' affinities; 0.6 */
    float affinity_gain;      /* 0..1: affinity added each time a drop leaves a cell; 0.1 */
    float merge_distance;     /* 0..2: merge drops closer than this times r1 + r2 (0: only in
                                 the same cell, the paper's rule); 1 (touching drops) */
    float trail_mass;         /* mg, 0..100: mass of one trail drop; 0.3 */
    float trail_spacing;      /* m, 1e-4..1: mean distance between trail drops; 0.003 */
    float trail_lifetime;     /* s, 0.01..1000: trail drops vanish after this; 4 */
    float wet_lifetime;       /* s, 0.01..1000: wetness fades to 0 over this; 6 */
    float rain_rate;          /* drops per m^2 per s, 0..1e6; 300 (steady rain) */
    float drop_mass;          /* mg, 0.01..1000: mean mass of a raindrop; 3 */
    float drop_mass_spread;   /* 0..0.99: masses uniform in mean * (1 -+ spread); 0.6 */
    int32_t sub_count;        /* 1..8 sub-metaballs per drop; 4 */
    float sub_spread;         /* 0..1: rest offsets of the sub-metaballs, in radii; 0.35 */
    float tail_length;        /* 0..8: how far (radii) sub-metaballs trail a running drop; 1.5 */
    /* Particles (near wipers). */
    float particle_mass;      /* mg, 0.01..1000: target mass of one particle; 3 */
    float particle_radius;    /* m, 1e-5..0.05: collision radius, a little under the contact
                                 radius of particle_mass so packed water merges; 0.001 */
    float repulsion;          /* 0..2: extra push apart, times the overlap / 2; 0.2 */
    int32_t particle_iterations; /* 1..16 repulsion passes per step; 2 */
    float switch_margin;      /* m, 0..1: particle region around each blade; 0.02 */
    int32_t holdback;         /* bool: the paper's hold-back rule (§4.6); 1 */
    float holdback_mass;      /* mg, 0..1e5: drops this big hold back conversions; 30 */
    int32_t holdback_radius;  /* cells, 0..64: half size of the searched square (at least;
                                 it grows to the merge reach of big drops); 5 */
    /* Height map (§5). */
    float radius_scale;       /* 0.1..10: metaball R / contact radius; 1 */
    float threshold;          /* 0.01..0.99: iso value of the drop outline; 0.5 */
    float kernel_support;     /* 1..16: balls are summed out to this many R; 3 */
    float compress_v0;        /* 0..10: first reference height V0; 0.5 */
    float compress_k;         /* 0..1: compression factor k; 0.3 */
    float compress_step;      /* 0..10: V0 rises by this each pass; 0.1 */
    int32_t compress_passes;  /* 0..64 passes; 5 */
    float height_scale;       /* m, 1e-6..1: height of one unit of V (a drop peaks at 0.5);
                                 0.004 */
    /* Wipers. */
    int32_t wiper_count;      /* 0..2; 0 */
    int32_t wiper_mode;       /* hbk_rain_wiper_mode_t; PIVOT */
    float blade_length;       /* m, 0.001..10; 0.45 */
    float blade_width;        /* m, 0.0005..0.5; 0.01 */
    float blade_offset;       /* m, 0..10: pivot to the blade's inner end (PIVOT); 0.05 */
    float wiper_pivot[4];     /* m, -100..100: pivot (PIVOT) or blade centre at rest
                                 (TRANSLATE) of wiper 0 (x, y) and 1 (x, y);
                                 (0.15, -0.02, 0.6, -0.02) */
    float wiper_rest[2];      /* deg, -360..360: blade angle at rest (PIVOT), travel
                                 direction (TRANSLATE); 0, 0 */
    float sweep_angle;        /* deg, -360..360: PIVOT sweep, > 0 counter-clockwise; 110 */
    float sweep_distance;     /* m, 0..100: TRANSLATE travel; 0.8 */
    float wiper_period;       /* s, 0.05..1000: one sweep out and back; 1.2 */
    float wiper_phase;        /* 0..1: fraction of a period at t = 0 (0: at rest); 0 */
    uint64_t seed;            /* random seed */
    int32_t threads;          /* OpenMP threads for the maps and particle repulsion, 0 = all;
                                 results never depend on it */
} hbk_rain_params_t;

/* Fills every field with the defaults above. Never fails. */
HBK_EXPORT void hbk_rain_params_default(hbk_rain_params_t *p);

/* The parameter table (every field but `size`); *count receives its length. Never fails. */
HBK_EXPORT const hbk_param_info_t *hbk_rain_params_info(size_t *count);

/* Range checks of the table plus the rules it cannot express (gravity_dir and airflow_dir at
 * most 1 long; the map no coarser than 1/64 of the grid and no finer than 64 x; blades and
 * particles at most a quarter of the glass's short side). HBK_ERR_INVALID_ARGUMENT naming the
 * field, HBK_ERR_VERSION. */
HBK_EXPORT hbk_result_t hbk_rain_params_check(const hbk_rain_params_t *p, hbk_message_t *msg);

/* The formulas, for tests and user interfaces; none of them fails.
 * N(q) = 1 / (1 + q^4), q = h / R (any sign). */
HBK_EXPORT float hbk_rain_kernel(float q);
/* The compression passes applied to one value V (the part above the threshold), as the map
 * applies them. p NULL: the defaults. */
HBK_EXPORT float hbk_rain_compress(const hbk_rain_params_t *p, float v);
/* Contact radius in m of a drop of `mass` mg: cbrt(3 mass / (2 pi)) mm. */
HBK_EXPORT float hbk_rain_drop_radius(float mass);

typedef struct hbk_rain hbk_rain_t;

/* A new simulation: dry glass with random affinities, flat glass (gravity_dir, airflow_dir),
 * no mask, wipers at their t = 0 position. The params are copied.
 * HBK_ERR_INVALID_ARGUMENT, HBK_ERR_VERSION, HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_rain_create(hbk_rain_t **out, const hbk_rain_params_t *p,
                                        hbk_message_t *msg);
/* NULL is allowed. */
HBK_EXPORT void hbk_rain_destroy(hbk_rain_t *h);
/* Detail of the handle's last failure ("" after a success); never NULL. */
HBK_EXPORT const char *hbk_rain_message(const hbk_rain_t *h);

/* Curved glass: per cell, from the mesh (width x height images, row 0 = v 0).
 * gravity_dir: 2 or 4 channels. 0-1: the unit down vector's components along the cell's u and
 * v tangents (|.| <= 1); 2-3 (optional): the car's backward axis likewise (else airflow_dir).
 * mask: 1 channel, the glass where >= 0.5; drops now off the glass run off at once.
 * Either may be NULL to return to the params' uniform values / all glass.
 * HBK_ERR_INVALID_ARGUMENT (wrong size or channels, a value out of range: the message names
 * the pixel), HBK_ERR_OUT_OF_MEMORY; on failure nothing changes. */
HBK_EXPORT hbk_result_t hbk_rain_set_tangents(hbk_rain_t *h, const hbk_image_t *gravity_dir,
                                              const hbk_image_t *mask);

/* Drives the blades from animation: `count` == wiper_count values, degrees (PIVOT) or metres
 * along the travel (TRANSLATE), reached at the end of the next step (the blades move there
 * linearly during it). count 0 (angles may be NULL) returns to the period-driven motion from
 * the blades' current place. HBK_ERR_INVALID_ARGUMENT (count, non-finite value). */
HBK_EXPORT hbk_result_t hbk_rain_set_wiper_angles(hbk_rain_t *h, const float *angles,
                                                  int32_t count);

/* Car motion for the next steps (animation), overriding car_speed / car_accel and wind.
 * wind may be NULL to keep it. HBK_ERR_INVALID_ARGUMENT (out of the params' ranges). */
HBK_EXPORT hbk_result_t hbk_rain_set_car(hbk_rain_t *h, float speed, float accel,
                                         const float wind[2]);

/* Puts a drop of `mass` mg at (x, y) m, counted as rain in; it merges like a landing raindrop.
 * Off the glass it is not added (returns HBK_OK, nothing counted). HBK_ERR_INVALID_ARGUMENT
 * (non-finite, mass not in (0, 1e6]), HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_rain_add_drop(hbk_rain_t *h, float x, float y, float mass);

/* Advances dt seconds (1e-5..10): rain, drop motion, wipers and particles, switching, trails.
 * Polls progress->cancel between phases (and every few thousand drops); on HBK_ERR_CANCELLED
 * the handle is as it was before the call. progress may be NULL.
 * HBK_ERR_INVALID_ARGUMENT (NULL handle, dt), HBK_ERR_OUT_OF_MEMORY (the handle is then as
 * before the call), HBK_ERR_CANCELLED. */
HBK_EXPORT hbk_result_t hbk_rain_step(hbk_rain_t *h, float dt, hbk_progress_t *progress);

/* Height map in m (1 channel, map_width x map_height): metaballs, threshold, compression, as
 * described above. HBK_ERR_INVALID_ARGUMENT (wrong view), HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_rain_heightmap(hbk_rain_t *h, hbk_image_t *height);

/* Wetness in [0, 1] (1 channel, map_width x map_height): 1 under drops and particles (within
 * radius_scale * r), elsewhere 1 - (time since a drop last ran through the texel's cell) /
 * wet_lifetime, at least 0; 0 where no drop has run. Same errors as hbk_rain_heightmap. */
HBK_EXPORT hbk_result_t hbk_rain_wetness(hbk_rain_t *h, hbk_image_t *out);

/* The paper's cheap refraction (§5.4, §5.5(4)): out(x, y) = background sampled bilinearly,
 * mirrored at its edges, at the texel's place minus strength * (n_x, n_y) * (background width,
 * height), so a drop shows the background flipped as a real one does. normals: 3 or 4
 * channels, unit normals as hbk_normal_map writes them with encode = 0; out: the normals'
 * size, the background's channel count; background: any size (stretched over out). strength:
 * 0..10, about 0.05. Stateless; threads as hbk_normal_map. HBK_ERR_INVALID_ARGUMENT (also a
 * normal whose x or y is not in [-1, 1], naming its pixel). */
HBK_EXPORT hbk_result_t hbk_rain_refraction(const hbk_image_t *normals,
                                            const hbk_image_t *background, float strength,
                                            hbk_image_t *out, hbk_message_t *msg);

/* Water accounting in mg, summed in a fixed order. rain_in = on_glass + wiped + run_off. */
typedef struct hbk_rain_water {
    double rain_in;      /* every raindrop that landed on the glass, and hbk_rain_add_drop */
    double on_glass;     /* drops + particles + film */
    double wiped;        /* pushed off the glass by wipers */
    double run_off;      /* ran off the glass's edges (or onto masked cells) */
    double in_drops;     /* on_glass parts: drops (with trail drops), */
    double in_particles; /* particles, */
    double in_film;      /* and the film trail drops leave */
    int64_t drops;       /* counts: drops (with trails), */
    int64_t trails;      /* of which trail drops, */
    int64_t particles;   /* and particles */
} hbk_rain_water_t;

/* HBK_ERR_INVALID_ARGUMENT for NULL. */
HBK_EXPORT hbk_result_t hbk_rain_water(const hbk_rain_t *h, hbk_rain_water_t *out);

typedef enum hbk_rain_drop_kind {
    HBK_RAIN_DROP = 0,     /* a grid drop */
    HBK_RAIN_TRAIL = 1,    /* a trail drop */
    HBK_RAIN_PARTICLE = 2  /* a particle near a wiper */
} hbk_rain_drop_kind_t;

typedef struct hbk_rain_drop {
    float x, y;     /* m, centre on the glass */
    float mass;     /* mg */
    float radius;   /* m, contact radius */
    float speed;    /* m/s (0 at rest; 0 for particles) */
    int32_t kind;   /* hbk_rain_drop_kind_t */
    uint64_t id;    /* unique per grid / trail drop for its life; 0 for particles */
} hbk_rain_drop_t;

/* Number of drops + particles (0 for NULL). */
HBK_EXPORT int64_t hbk_rain_drop_count(const hbk_rain_t *h);
/* Copies up to `capacity` of them (drops in their fixed order, then particles) and sets
 * *count to how many were written. HBK_ERR_INVALID_ARGUMENT (NULL, capacity < 0). */
HBK_EXPORT hbk_result_t hbk_rain_drops(const hbk_rain_t *h, hbk_rain_drop_t *out,
                                       int64_t capacity, int64_t *count);

/* The blades now: per wiper, its centre line from (x0, y0) to (x1, y1) in m, its width in m
 * and its angle (deg, PIVOT) or travel (m, TRANSLATE). Writes min(count, wiper_count) and
 * returns that number (0 for NULL). */
typedef struct hbk_rain_blade {
    float x0, y0, x1, y1, width, value;
} hbk_rain_blade_t;
HBK_EXPORT int32_t hbk_rain_blades(const hbk_rain_t *h, hbk_rain_blade_t *out, int32_t count);

/* Simulated time in s and steps taken since creation (0 for NULL). */
HBK_EXPORT double hbk_rain_time(const hbk_rain_t *h);
HBK_EXPORT uint64_t hbk_rain_step_count(const hbk_rain_t *h);

/* Checkpoints: everything the handle holds but its params (drops, particles, affinities,
 * film, wetness, tangents, mask, wipers, car, counters). Loading into a handle with the same
 * params continues bit for bit. state_size: bytes now needed (0 for NULL). save:
 * HBK_ERR_INVALID_ARGUMENT if `size` is smaller. load: HBK_ERR_FORMAT (not a rain state, other
 * version, inconsistent, numbers no run holds: NaN, infinite or absurd masses, times, wipers),
 * HBK_ERR_INVALID_ARGUMENT (other grid, too small),
 * HBK_ERR_OUT_OF_MEMORY; the handle is unchanged on failure. */
HBK_EXPORT size_t hbk_rain_state_size(const hbk_rain_t *h);
HBK_EXPORT hbk_result_t hbk_rain_save_state(hbk_rain_t *h, void *buffer, size_t size);
HBK_EXPORT hbk_result_t hbk_rain_load_state(hbk_rain_t *h, const void *buffer, size_t size);

#ifdef __cplusplus
}
#endif
#endif
