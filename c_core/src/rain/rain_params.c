/* Rain parameters: defaults, the table, the cross-field checks, and the paper's formulas. */
#include "internal_rain.h"
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define RAIN_MAX_CELLS (4096 * 4096)
#define RAIN_MAX_TEXELS (8192 * 8192)

void hbk_rain_params_default(hbk_rain_params_t *p)
{
    if (!p) return;
    *p = (hbk_rain_params_t){0};
    p->size = sizeof *p;
    p->width = 1024; /* a 1.02 x 0.51 m pane in 1 mm cells */
    p->height = 512;
    p->cell_size = 0.001f;
    p->map_width = 2048; /* 0.5 mm texels: a 3 mg drop is 2.3 texels across its radius */
    p->map_height = 1024;
    p->gravity = 9.81f;
    p->gravity_dir[0] = 0.0f;
    p->gravity_dir[1] = -1.0f;
    p->airflow = 0.04f;
    p->airflow_dir[0] = 0.0f;
    p->airflow_dir[1] = 1.0f;
    p->static_mass = 15.0f; /* ~15 uL: drops on vertical glass start to run at 10..30 uL */
    p->drag = 40.0f;
    p->affinity_random = 0.6f;
    p->affinity_gain = 0.1f;
    p->merge_distance = 1.0f; /* drops whose outlines touch coalesce */
    p->trail_mass = 0.3f;
    p->trail_spacing = 0.003f;
    p->trail_lifetime = 4.0f;
    p->wet_lifetime = 6.0f;
    p->rain_rate = 300.0f;
    p->drop_mass = 3.0f;
    p->drop_mass_spread = 0.6f;
    p->sub_count = 4;
    p->sub_spread = 0.35f;
    p->tail_length = 1.5f;
    p->particle_mass = 3.0f;
    p->particle_radius = 0.001f; /* a little under a 3 mg drop's 1.13 mm: packed water touches */
    p->repulsion = 0.2f;
    p->particle_iterations = 2;
    p->switch_margin = 0.02f;
    p->holdback = 1;
    p->holdback_mass = 30.0f; /* above static_mass, as the paper advises: the cause clears */
    p->holdback_radius = 5;
    p->radius_scale = 1.0f;
    p->threshold = 0.5f; /* the paper's */
    p->kernel_support = 3.0f;
    p->compress_v0 = 0.5f; /* the paper's V0, k, step and passes */
    p->compress_k = 0.3f;
    p->compress_step = 0.1f;
    p->compress_passes = 5;
    p->height_scale = 0.004f;
    p->wiper_count = 0;
    p->wiper_mode = HBK_RAIN_WIPER_PIVOT;
    p->blade_length = 0.45f;
    p->blade_width = 0.01f;
    p->blade_offset = 0.05f;
    p->wiper_pivot[0] = 0.15f;
    p->wiper_pivot[1] = -0.02f;
    p->wiper_pivot[2] = 0.6f;
    p->wiper_pivot[3] = -0.02f;
    p->sweep_angle = 110.0f;
    p->sweep_distance = 0.8f;
    p->wiper_period = 1.2f;
}

#define F(name, n, lo, hi, unit, desc) \
    {#name, HBK_PARAM_F32, offsetof(hbk_rain_params_t, name), n, lo, hi, unit, NULL, desc}
#define I(name, lo, hi, unit, desc) \
    {#name, HBK_PARAM_I32, offsetof(hbk_rain_params_t, name), 1, lo, hi, unit, NULL, desc}
static const hbk_param_info_t k_info[] = {
    I(width, 8, 16384, "cells", "Simulation cells across the glass (u); 512..2048."),
    I(height, 8, 16384, "cells", "Simulation cells up the glass (v); 256..2048."),
    F(cell_size, 1, 1e-4, 0.05, "m", "Edge of one cell, about a small drop: 0.0005..0.002."),
    I(map_width, 8, 16384, "texels", "Height map width; 1..4 texels per cell."),
    I(map_height, 8, 16384, "texels", "Height map height; 1..4 texels per cell."),
    F(gravity, 1, 0, 100, "m/s^2", "Gravitational acceleration; 9.81 on Earth."),
    F(gravity_dir, 2, -1, 1, "1", "In-plane part of the unit down vector (u, v); (0, -1) for "
                                  "an upright pane, shorter for a tilted one."),
    F(wind, 2, -100, 100, "m/s^2", "In-plane push on the drops along u and v; 0..5."),
    F(car_speed, 1, 0, 100, "m/s", "Car speed: its airflow pushes drops along airflow_dir."),
    F(car_accel, 1, -50, 50, "m/s^2", "Car acceleration: > 0 pushes drops along airflow_dir, "
                                      "braking the other way."),
    F(airflow, 1, 0, 10, "1/m", "Airflow push per (m/s)^2 of car speed; 0.04 lifts drops on "
                                "an upright pane at about 16 m/s."),
    F(airflow_dir, 2, -1, 1, "1", "The car's backward axis in the glass plane (u, v); (0, 1) "
                                  "for a windshield."),
    F(static_mass, 1, 0.01, 1e4, "mg", "Drops heavier than this run under full gravity (static "
                                       "friction); 10..50."),
    F(drag, 1, 0.01, 1e4, "1/s", "Speed relaxation of running drops; 20..80."),
    F(affinity_random, 1, 0, 1, "1", "Spread of the glass's random affinities: how much drops "
                                     "meander; 0.3..0.8."),
    F(affinity_gain, 1, 0, 1, "1", "Affinity added where a drop passed, so later drops "
                                   "follow; 0.05..0.3."),
    F(merge_distance, 1, 0, 2, "1", "Drops merge closer than this times the sum of their "
                                    "radii; 0 = only in one cell (the paper); 0.5..1."),
    F(trail_mass, 1, 0, 100, "mg", "Mass of one trail drop a running drop leaves; 0.1..1."),
    F(trail_spacing, 1, 1e-4, 1, "m", "Mean distance between the trail drops a running drop "
                                      "leaves; 0.002..0.01."),
    F(trail_lifetime, 1, 0.01, 1000, "s", "Trail drops shrink after half of this and vanish "
                                          "at its end; 2..10."),
    F(wet_lifetime, 1, 0.01, 1000, "s", "Wet paths fade out over this time; 3..20."),
    F(rain_rate, 1, 0, 1e6, "1/(m^2 s)", "Raindrops landing per square metre per second; "
                                         "50..2000."),
    F(drop_mass, 1, 0.01, 1000, "mg", "Mean mass of a raindrop; 1..10."),
    F(drop_mass_spread, 1, 0, 0.99, "1", "Raindrop masses are uniform in mean * (1 -+ this)."),
    I(sub_count, 1, RAIN_MAX_SUBS, "1", "Sub-metaballs per drop, for irregular shapes; 3..6."),
    F(sub_spread, 1, 0, 1, "1", "How far sub-metaballs sit from the centre, in radii; "
                                "0.2..0.5."),
    F(tail_length, 1, 0, 8, "1", "How far sub-metaballs trail a running drop, in radii; 1..3."),
    F(particle_mass, 1, 0.01, 1000, "mg", "Target mass of a particle near a wiper; about "
                                          "drop_mass."),
    F(particle_radius, 1, 1e-5, 0.05, "m", "Collision radius of a particle; about its contact "
                                           "radius, 0.001..0.002."),
    F(repulsion, 1, 0, 2, "1", "Extra push between overlapping particles, times half the "
                               "overlap; 0..0.5."),
    I(particle_iterations, 1, 16, "1", "Repulsion passes per step near the wipers; 1..4."),
    F(switch_margin, 1, 0, 1, "m", "Width of the particle region around each blade; "
                                   "0.01..0.05."),
    {"holdback", HBK_PARAM_BOOL, offsetof(hbk_rain_params_t, holdback), 1, 0, 1, "1", NULL,
     "Hold back particles from becoming drops next to a big drop (paper 4.6)."},
    F(holdback_mass, 1, 0, 1e5, "mg", "Drops this heavy hold back conversions; above "
                                      "static_mass."),
    I(holdback_radius, 0, 64, "cells", "Half size of the square searched for big drops; more "
                                       "than the merge reach."),
    F(radius_scale, 1, 0.1, 10, "1", "Metaball radius R per contact radius; 1."),
    F(threshold, 1, 0.01, 0.99, "1", "Iso value of the drop outline; 0.5 (paper)."),
    F(kernel_support, 1, 1, 16, "1", "Metaballs are summed out to this many R; 3..4."),
    F(compress_v0, 1, 0, 10, "1", "First reference height V0 of the compression; 0.5."),
    F(compress_k, 1, 0, 1, "1", "Compression factor k; 0.3."),
    F(compress_step, 1, 0, 10, "1", "V0 rises by this each pass; 0.1."),
    I(compress_passes, 0, 64, "1", "Compression passes; 5."),
    F(height_scale, 1, 1e-6, 1, "m", "Height of one unit of the compressed field (a drop "
                                     "peaks at 0.5 units); 0.002..0.006."),
    I(wiper_count, 0, 2, "1", "Number of wiper blades; 0..2."),
    {"wiper_mode", HBK_PARAM_ENUM, offsetof(hbk_rain_params_t, wiper_mode), 1, 0, 1, "1",
     "TRANSLATE|PIVOT", "Blades sliding sideways (the paper) or sweeping an arc (cars)."},
    F(blade_length, 1, 0.001, 10, "m", "Length of a blade; 0.3..0.7 on cars."),
    F(blade_width, 1, 0.0005, 0.5, "m", "Width of a blade's rubber; 0.005..0.02."),
    F(blade_offset, 1, 0, 10, "m", "Pivot to the blade's inner end (PIVOT); 0.03..0.1."),
    F(wiper_pivot, 4, -100, 100, "m", "Pivot (PIVOT) or blade centre at rest (TRANSLATE) of "
                                      "wipers 0 and 1: x0, y0, x1, y1."),
    F(wiper_rest, 2, -360, 360, "deg", "Blade angle at rest (PIVOT) or travel direction "
                                       "(TRANSLATE) of each wiper."),
    F(sweep_angle, 1, -360, 360, "deg", "Sweep of a PIVOT blade, > 0 counter-clockwise; "
                                        "90..120."),
    F(sweep_distance, 1, 0, 100, "m", "Travel of a TRANSLATE blade."),
    F(wiper_period, 1, 0.05, 1000, "s", "One sweep out and back; 0.8..2."),
    F(wiper_phase, 1, 0, 1, "1", "Fraction of a period at time 0; 0 = at rest."),
    {"seed", HBK_PARAM_U64, offsetof(hbk_rain_params_t, seed), 1, 0, 18446744073709551615.0,
     "1", NULL, "Random seed: glass, rain, meandering, shapes."},
    I(threads, 0, 1024, "1", "Threads for the maps and particles, 0 = all; the result never "
                             "depends on it."),
};
#undef F
#undef I

const hbk_param_info_t *hbk_rain_params_info(size_t *count)
{
    if (count) *count = sizeof k_info / sizeof k_info[0];
    return k_info;
}

hbk_result_t hbk_rain_params_check(const hbk_rain_params_t *p, hbk_message_t *msg)
{
    hbk_result_t r = hbk_params_validate(p, sizeof *p, k_info, sizeof k_info / sizeof k_info[0],
                                         msg);
    if (r) return r;
    /* Vectors the table checks element-wise only. */
    if (hypotf(p->gravity_dir[0], p->gravity_dir[1]) > 1.0001f)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "gravity_dir = (%g, %g): its length must "
                        "be at most 1", (double)p->gravity_dir[0], (double)p->gravity_dir[1]);
    if (hypotf(p->airflow_dir[0], p->airflow_dir[1]) > 1.0001f)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "airflow_dir = (%g, %g): its length must "
                        "be at most 1", (double)p->airflow_dir[0], (double)p->airflow_dir[1]);
    /* Past these a bake needs more memory than a workstation has (about 15 bytes a cell and
     * 30 a texel), and the system kills the process rather than let an allocation fail. */
    if ((int64_t)p->width * p->height > RAIN_MAX_CELLS)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "width x height = %d x %d: must be at most %d cells (4096 x 4096)",
                        p->width, p->height, RAIN_MAX_CELLS);
    if ((int64_t)p->map_width * p->map_height > RAIN_MAX_TEXELS)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "map_width x map_height = %d x %d: must be at most %d texels "
                        "(8192 x 8192)", p->map_width, p->map_height, RAIN_MAX_TEXELS);
    /* Metaballs are splatted per texel and drops move per cell: keep the two scales within
     * reach of each other so neither degenerates. */
    if ((double)p->map_width > 64.0 * p->width || 64.0 * p->map_width < (double)p->width)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "map_width = %d: must be within 1/64 and "
                        "64 times width = %d", p->map_width, p->width);
    if ((double)p->map_height > 64.0 * p->height || 64.0 * p->map_height < (double)p->height)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "map_height = %d: must be within 1/64 "
                        "and 64 times height = %d", p->map_height, p->height);
    /* The particle hash and the blade substeps assume objects much smaller than the glass. */
    const double short_side = (p->width < p->height ? p->width : p->height) * (double)p->cell_size;
    if (p->particle_radius > 0.25 * short_side)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "particle_radius = %g: must be at most a "
                        "quarter of the glass's short side (%g m)", (double)p->particle_radius,
                        0.25 * short_side);
    if (p->wiper_count > 0 && p->blade_width > 0.25 * short_side)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "blade_width = %g: must be at most a "
                        "quarter of the glass's short side (%g m)", (double)p->blade_width,
                        0.25 * short_side);
    return HBK_OK;
}

float hbk_rain_kernel(float q)
{
    const float q2 = q * q;
    return 1.0f / (1.0f + q2 * q2);
}

float hbk_rain_compress(const hbk_rain_params_t *p, float v)
{
    hbk_rain_params_t d;
    if (!p) {
        hbk_rain_params_default(&d);
        p = &d;
    }
    return rain_compress_value(p, v);
}

float hbk_rain_drop_radius(float mass)
{
    if (!(mass > 0.0f)) return 0.0f;
    return 1e-3f * cbrtf(3.0f * mass / (2.0f * (float)M_PI));
}

float rain_radius_cells(const hbk_rain_t *h, double mass)
{
    return hbk_rain_drop_radius((float)mass) / h->p.cell_size;
}
