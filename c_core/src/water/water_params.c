/* Water parameters: defaults, the table, and the checks the table cannot express. */
#include "internal_water.h"
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define WATER_MAX_CELLS (4096 * 4096)

void hbk_water_params_default(hbk_water_params_t *p)
{
    if (!p) return;
    *p = (hbk_water_params_t){0};
    p->size = sizeof *p;
    p->width = 128; /* the paper's figures */
    p->height = 128;
    p->cell_size = 0.05f;
    p->gravity = 9.81f;
    p->dt = 1.0f / 24.0f;
    p->substeps = 2;
    p->implicitness = 1.0f; /* Kass & Miller */
    p->damping = 0.0f;      /* the paper's equations have no friction */
    p->periodic = 0;
    p->seed = 0;
    p->threads = 0;
    p->rain_rate = 0.0f;
    p->rain_radius = 0.1f;
    p->rain_depth = 0.01f;
}

#define F(name, n, lo, hi, unit, desc) \
    {#name, HBK_PARAM_F32, offsetof(hbk_water_params_t, name), n, lo, hi, unit, NULL, desc}
#define I(name, lo, hi, unit, desc) \
    {#name, HBK_PARAM_I32, offsetof(hbk_water_params_t, name), 1, lo, hi, unit, NULL, desc}
static const hbk_param_info_t k_info[] = {
    I(width, 4, 16384, "cells", "Grid cells along x; 64..512 for a pool."),
    I(height, 4, 16384, "cells", "Grid cells along y; 64..512 for a pool."),
    F(cell_size, 1, 1e-4, 1e3, "m", "Edge length of one cell; 0.01..0.1 for a pool."),
    F(gravity, 1, 0.01, 100, "m/s^2", "Gravitational acceleration; 9.81 on Earth."),
    F(dt, 1, 1e-5, 10, "s", "Time advanced by one step call (one frame), e.g. 1/24."),
    I(substeps, 1, 1000, "1", "Solver steps per frame; 1..8, more keeps short ripples alive."),
    F(implicitness, 1, 0.5, 1, "1", "Theta of the implicit solve: 1 = Kass & Miller (damps "
                                    "short waves), 0.5 = energy-conserving."),
    F(damping, 1, 0, 100, "1/s", "Velocity decay rate, like bottom friction; 0..1."),
    {"periodic", HBK_PARAM_BOOL, offsetof(hbk_water_params_t, periodic), 1, 0, 1, "1", NULL,
     "Wrap the grid in x and y so the result tiles; otherwise the borders are walls."},
    {"seed", HBK_PARAM_U64, offsetof(hbk_water_params_t, seed), 1, 0, 18446744073709551615.0,
     "1", NULL, "Random seed of the rain."},
    I(threads, 0, 1024, "1", "Threads to use, 0 = all; the result never depends on it."),
    F(rain_rate, 1, 0, 1e5, "1/(m^2 s)", "Raindrops per square metre per second; 0..200."),
    F(rain_radius, 1, 1e-4, 100, "m", "Radius of the dent one drop makes; 0.02..0.2."),
    F(rain_depth, 1, 0, 10, "m", "Depth of one drop's dent (a ring rises around it); "
                                 "0.002..0.02."),
    F(wind, 2, -100, 100, "m/s^2", "Horizontal acceleration on all water (x, y); wind drag, "
                                    "0..0.5."),
};
#undef F
#undef I

const hbk_param_info_t *hbk_water_params_info(size_t *count)
{
    if (count) *count = sizeof k_info / sizeof k_info[0];
    return k_info;
}

hbk_result_t hbk_water_params_check(const hbk_water_params_t *p, hbk_message_t *msg)
{
    hbk_result_t r = hbk_params_validate(p, sizeof *p, k_info, sizeof k_info / sizeof k_info[0],
                                         msg);
    if (r) return r;
    /* About 400 bytes a cell by the time a frame's caustic map is written (4 texels a cell):
     * past 4096 x 4096 a bake needs more memory than a workstation has, and the system kills
     * the process rather than let an allocation fail. */
    if ((int64_t)p->width * p->height > WATER_MAX_CELLS)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "width x height = %d x %d: must be at most %d cells (4096 x 4096)",
                        p->width, p->height, WATER_MAX_CELLS);
    if (p->rain_radius > 256.0f * p->cell_size)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "rain_radius = %g: must be at most 256 cells (%g m)",
                        (double)p->rain_radius, 256.0 * p->cell_size);
    /* Without friction a uniform push on a basin without walls accelerates it for ever. */
    if (p->periodic && (p->wind[0] != 0.0f || p->wind[1] != 0.0f) && p->damping == 0.0f)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "wind = (%g, %g) with periodic = 1: needs damping > 0 (got 0), or the "
                        "water speeds up without bound", (double)p->wind[0], (double)p->wind[1]);
    return HBK_OK;
}
