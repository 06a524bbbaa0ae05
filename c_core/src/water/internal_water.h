/* Private: the water handle and the solver entry points shared by the water sources. */
#ifndef HBK_INTERNAL_WATER_H
#define HBK_INTERNAL_WATER_H
#include "hbk_water.h"
#include "hbk_rng.h"
#include "../base/internal_base.h"

/* RNG streams of the rain: one block per step for the drop count, one per drop. */
enum { HBK_WATER_STREAM_RAIN_COUNT = 0x57a1, HBK_WATER_STREAM_RAIN_DROP = 0x57a2 };

struct hbk_water {
    hbk_water_params_t p;
    hbk_message_t msg;
    size_t n;            /* width * height */
    /* State (saved by hbk_water_save_state). Depth and velocities are double so that the flux
     * form conserves volume to ~1e-16 relative over long runs, not to float's 1e-7. */
    float *ground;       /* b, m */
    double *depth;       /* d >= 0, m */
    double *vel_x;       /* u on the face between cell i and i+1 (wrapping), m/s */
    double *vel_y;       /* v on the face between row j and j+1 (wrapping), m/s */
    float *sources;      /* Ha, m/s, or NULL */
    float *accel;        /* Ua, 2 per cell, m/s^2, or NULL */
    float *footprint;    /* object pressure head, m, or NULL */
    uint64_t steps;      /* solver steps taken: the rain RNG counter */
    /* Scratch, not state. */
    double *backup;      /* depth, vel_x, vel_y at the start of a frame, for cancellation */
    double *scratch;     /* per-thread line solver scratch */
    int32_t scratch_threads;
};

/* One solver step of length `dt` (sources, rain, x and y sweeps); returns HBK_ERR_CANCELLED
 * if progress asks between sweeps (the caller restores the backup). */
hbk_result_t hbk_water_substep(hbk_water_t *h, double dt, int threads, hbk_progress_t *progress);
/* Doubles of scratch one thread needs for a line of n cells. */
size_t hbk_water_line_scratch(int32_t n);

#endif
