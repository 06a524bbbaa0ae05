/* Height-field water (Tokuyama, Yamamoto, Takai §2; Kass & Miller 1990).
 *
 * A grid of width x height cells, each `cell_size` metres square. Cell (i, j) has its centre at
 * world ((i + 0.5) * cell_size, (j + 0.5) * cell_size); x grows with i, y with j, z is up
 * (Blender's axes; the paper puts the field in its XZ plane with Y up). Every buffer crossing
 * this API is an hbk_image_t of exactly width x height pixels, row 0 = j = 0 = v 0 (the bottom,
 * see hbk_image.h).
 *
 * Per cell the handle keeps the ground b, the depth d >= 0 (the water surface is h = b + d) and
 * the velocities u, v on the faces between cells ("between grid points", as the paper has it).
 * One frame, hbk_water_step, advances `dt` seconds in `substeps` equal steps; each step solves
 * the paper's tridiagonal system A (Thomas algorithm, cyclic with Sherman-Morrison when
 * periodic) once per row along x and then once per column along y, alternating the order every
 * step. The solve is written in flux form, so:
 *  - volume is conserved to double rounding when no source adds or removes water (rain,
 *    wind and object footprints move water, they never create it);
 *  - the depth never goes negative: a cell never gives away more water than it holds;
 *  - water runs onto dry ground lower than its surface and off it again;
 *  - it stays stable at any time step (the gravity term is implicit; `implicitness` 1 is Kass &
 *    Miller's fully implicit scheme, 0.5 keeps short ripples alive longer).
 * Rain uses the counter-based RNG keyed by (seed, stream, step counter), so a run is the same
 * bytes for any thread count and can be checkpointed and resumed bit for bit.
 *
 * Threads: one handle must not be used from two threads at once; different handles are
 * independent. The handle owns everything it allocates; setters copy the caller's buffers. */
#ifndef HBK_WATER_H
#define HBK_WATER_H
#include "hbk_base.h"
#include "hbk_image.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef struct hbk_water_params {
    uint32_t size;        /* sizeof(hbk_water_params_t), set by hbk_water_params_default */
    int32_t width;        /* cells along x, 4..16384 (paper: 16..256, 128 shown) */
    int32_t height;       /* cells along y, 4..16384; width x height <= 4096^2 */
    float cell_size;      /* m, edge of one cell; 0.005..1 for pools and ponds */
    float gravity;        /* m/s^2, 9.81 */
    float dt;             /* s, time advanced by one hbk_water_step (one frame), e.g. 1/24 */
    int32_t substeps;     /* solver steps per frame, 1..1000; more = less numerical damping */
    float implicitness;   /* theta in 0.5..1: 1 = Kass & Miller (damps short waves), 0.5 = none */
    float damping;        /* 1/s, velocity decay rate (bottom friction), 0..100; 0 = paper */
    int32_t periodic;     /* 1: the grid wraps in x and y (tileable); 0: closed walls */
    uint64_t seed;        /* random seed for rain */
    int32_t threads;      /* OpenMP threads, 0 = all; results never depend on it */
    float rain_rate;      /* drops per m^2 per s, 0..1e5; 0 = no rain */
    float rain_radius;    /* m, radius of one drop's dent, at most 256 cells */
    float rain_depth;     /* m, depth of one drop's dent, 0..10 (a ring around it rises) */
    float wind[2];        /* m/s^2, horizontal acceleration on all water (x, y), |.| <= 100 */
} hbk_water_params_t;

/* Fills every field with the defaults (the paper's model; a 128 x 128 pool). Never fails. */
HBK_EXPORT void hbk_water_params_default(hbk_water_params_t *p);

/* The parameter table (every field but `size`); *count receives its length. Never fails. */
HBK_EXPORT const hbk_param_info_t *hbk_water_params_info(size_t *count);

/* Range checks of the table plus the cross-field rules (periodic wind needs damping > 0,
 * rain_radius <= 256 cells). HBK_ERR_INVALID_ARGUMENT / HBK_ERR_VERSION. */
HBK_EXPORT hbk_result_t hbk_water_params_check(const hbk_water_params_t *p, hbk_message_t *msg);

typedef struct hbk_water hbk_water_t;

/* A new simulation: flat ground at z = 0, no water, no sources. The params are copied.
 * Returns HBK_ERR_INVALID_ARGUMENT, HBK_ERR_VERSION, HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_water_create(hbk_water_t **out, const hbk_water_params_t *p,
                                         hbk_message_t *msg);
/* NULL is allowed. */
HBK_EXPORT void hbk_water_destroy(hbk_water_t *h);
/* Detail of the handle's last failure ("" after a success); never NULL. */
HBK_EXPORT const char *hbk_water_message(const hbk_water_t *h);

/* Setters. Each returns HBK_ERR_INVALID_ARGUMENT (NULL handle, image not width x height with
 * the stated channels, non-finite or out-of-range value; the message names it) and then leaves
 * the handle unchanged. */

/* Ground height b in m (1 channel). The depth of every cell is kept, so the surface follows the
 * ground and no water appears or vanishes; velocities are kept. NULL: flat ground at 0. */
HBK_EXPORT hbk_result_t hbk_water_set_ground(hbk_water_t *h, const hbk_image_t *ground);
/* Fills to a flat surface: depth = max(0, level - b) everywhere; velocities to zero. */
HBK_EXPORT hbk_result_t hbk_water_set_level(hbk_water_t *h, float level);
/* Water surface height in m (1 channel): depth = max(0, surface - b); velocities to zero. */
HBK_EXPORT hbk_result_t hbk_water_set_surface(hbk_water_t *h, const hbk_image_t *surface);
/* Depth in m (1 channel, >= 0); velocities are kept. */
HBK_EXPORT hbk_result_t hbk_water_set_depth(hbk_water_t *h, const hbk_image_t *depth);
/* Ha: water added (> 0, poured) or removed (< 0, drained) per cell, in m of depth per second
 * (1 channel). A drain never takes more than the cell holds. NULL: no sources. */
HBK_EXPORT hbk_result_t hbk_water_set_sources(hbk_water_t *h, const hbk_image_t *ha);
/* Ua: horizontal acceleration in m/s^2 per cell (2 channels: x, y), added to `wind`; faces
 * take the mean of their two cells. NULL: none. */
HBK_EXPORT hbk_result_t hbk_water_set_acceleration(hbk_water_t *h, const hbk_image_t *ua);
/* An object in the water: per cell, how far in m (>= 0) it presses the surface down
 * (1 channel; 0 where there is no object). It acts as a pressure head, so water flows out from
 * under it and a moving footprint pushes a bow wave and leaves a wake; volume is conserved.
 * Update it before each step as the object moves. NULL: no object. */
HBK_EXPORT hbk_result_t hbk_water_set_footprint(hbk_water_t *h, const hbk_image_t *depth);

/* Advances one frame (`dt` s in `substeps` steps). Polls progress->cancel between steps and
 * sweeps; on HBK_ERR_CANCELLED the handle is as it was before the call. progress may be NULL.
 * Returns HBK_ERR_INVALID_ARGUMENT (NULL handle), HBK_ERR_OUT_OF_MEMORY (thread scratch; the
 * handle is then as before), HBK_ERR_CANCELLED. */
HBK_EXPORT hbk_result_t hbk_water_step(hbk_water_t *h, hbk_progress_t *progress);

/* Getters into caller images of width x height. HBK_ERR_INVALID_ARGUMENT on a wrong view (the
 * handle is not const only because it keeps that message). */
/* Surface height h = b + d in m (1 channel); on dry cells it equals the ground. */
HBK_EXPORT hbk_result_t hbk_water_get_surface(hbk_water_t *h, hbk_image_t *out);
/* Depth d >= 0 in m (1 channel). */
HBK_EXPORT hbk_result_t hbk_water_get_depth(hbk_water_t *h, hbk_image_t *out);
/* Velocity at cell centres in m/s (2 channels: x, y), the mean of the cell's two faces. */
HBK_EXPORT hbk_result_t hbk_water_get_velocity(hbk_water_t *h, hbk_image_t *out);

/* Total water volume in m^3 (sum of depth x cell area, in a fixed order). 0 for NULL. */
HBK_EXPORT double hbk_water_volume(const hbk_water_t *h);
/* Number of solver steps taken since creation (the rain's RNG counter). 0 for NULL. */
HBK_EXPORT uint64_t hbk_water_step_count(const hbk_water_t *h);

/* Checkpoints. The state is everything the handle holds except its params: ground, depth,
 * velocities, sources, acceleration, footprint and the step counter. Loading it into a handle
 * with the same params continues bit for bit as the saved one would have.
 * hbk_water_state_size: bytes needed (0 for NULL). save: HBK_ERR_INVALID_ARGUMENT if `size` is
 * smaller. load: HBK_ERR_FORMAT (not a water state, other version, invalid numbers),
 * HBK_ERR_INVALID_ARGUMENT (other grid size, buffer too small); the handle is unchanged on
 * failure. The layout is native-endian: a checkpoint for the same machine, not an archive. */
HBK_EXPORT size_t hbk_water_state_size(const hbk_water_t *h);
HBK_EXPORT hbk_result_t hbk_water_save_state(hbk_water_t *h, void *buffer, size_t size);
HBK_EXPORT hbk_result_t hbk_water_load_state(hbk_water_t *h, const void *buffer, size_t size);

#ifdef __cplusplus
}
#endif
#endif
