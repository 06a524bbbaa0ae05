/* Fluid texturing parameters: defaults, the table, and the checks the table cannot express. */
#include "internal_fluid.h"
#include <stddef.h>

void hbk_fluid_params_default(hbk_fluid_params_t *p)
{
    if (!p) return;
    *p = (hbk_fluid_params_t){0};
    p->size = sizeof *p;
    p->source = HBK_FLUID_SIMULATE;
    for (int a = 0; a < 3; ++a) {
        p->resolution[a] = 32; /* the paper's volumes */
        p->box_min[a] = 0.0f;
        p->box_max[a] = 1.0f;
    }
    p->dt = 1.0f / 24.0f;
    p->substeps = 40;
    p->max_particles = 100000;
    p->particle_spacing = 0.02f;
    p->smoothing_length = 0.04f;
    p->rest_density = 1000.0f;
    p->stiffness = 200.0f;  /* sound speed 14 m/s: ~10x the flow of a 1 m drop */
    p->viscosity = 1.0f;
    p->damping = 0.0f;
    p->gravity[2] = -9.81f;
    p->metaball_radius = 0.04f;
    p->surface_threshold = 0.5f;
    p->max_flow = 2.0f;
    p->textures = 3;        /* the paper's figures use three samples */
    p->default_texture = 0;
    p->uvw_tile = 0.25f;
    p->reset_period = 2.0f;
    p->stretch_fade = 0.0f; /* the schedule alone */
    p->paint_duration = 2.0f;
    p->paint_fade = 0.5f;
    for (int t = 0; t < HBK_FLUID_MAX_TEXTURES; ++t) {
        p->texture_scale[t] = 1.0f;
        p->texture_feature[t] = HBK_FLUID_FEATURE_COUNT;
    }
    p->seed = 0;
    p->threads = 0;
}

#define F(name, n, lo, hi, unit, desc) \
    {#name, HBK_PARAM_F32, offsetof(hbk_fluid_params_t, name), n, lo, hi, unit, NULL, desc}
#define I(name, n, lo, hi, unit, desc) \
    {#name, HBK_PARAM_I32, offsetof(hbk_fluid_params_t, name), n, lo, hi, unit, NULL, desc}
static const hbk_param_info_t k_info[] = {
    {"source", HBK_PARAM_ENUM, offsetof(hbk_fluid_params_t, source), 1, 0, 2, "1",
     "SIMULATE|PARTICLES|VELOCITY_GRID",
     "Where the flow comes from: the built-in SPH, particles set per frame, or a velocity grid."},
    I(resolution, 3, 4, 256, "voxels", "Voxels per axis of the texturing volumes; 32..128."),
    F(box_min, 3, -1e4, 1e4, "m", "Lower corner of the simulation box."),
    F(box_max, 3, -1e4, 1e4, "m", "Upper corner of the simulation box."),
    F(dt, 1, 1e-5, 10, "s", "Time advanced by one step (one frame), e.g. 1/24."),
    I(substeps, 1, 1, 1000, "1", "Least SPH steps per frame; more are taken when stability needs them."),
    I(max_particles, 1, 0, 4000000, "1", "Particle capacity; 10k..100k."),
    F(particle_spacing, 1, 1e-4, 10, "m", "Rest spacing of the particles; sets their mass."),
    F(smoothing_length, 1, 1e-4, 40, "m", "SPH kernel radius h, 1.5..3 particle spacings; with particles, the box may hold at most 2^24 cells of h."),
    F(rest_density, 1, 1, 1e5, "kg/m^3", "Density of the fluid at rest; 1000 for water."),
    F(stiffness, 1, 1e-3, 1e7, "m^2/s^2", "Pressure constant k (sound speed squared); 100..2000."),
    F(viscosity, 1, 0, 100, "Pa s", "Viscosity; 0.5..5 for a lively liquid."),
    F(damping, 1, 0, 100, "1/s", "Velocity decay rate; 0 for real fluid, 1..10 to settle."),
    F(gravity, 3, -1000, 1000, "m/s^2", "Gravitational acceleration; (0, 0, -9.81)."),
    F(metaball_radius, 1, 1e-4, 40, "m", "Radius of one particle's metaball, 1..4 spacings."),
    F(surface_threshold, 1, 0.01, 10, "1", "Iso value of the metaball sum; 0.3..1."),
    F(max_flow, 1, 0.01, 64, "voxels/frame", "Faster flow is clamped to this for texturing; 1..4."),
    I(textures, 1, 1, HBK_FLUID_MAX_TEXTURES, "1", "Number of sample textures; 1..8."),
    I(default_texture, 1, 0, HBK_FLUID_MAX_TEXTURES - 1, "1", "Texture everywhere at the start."),
    F(uvw_tile, 1, 1e-4, 1e4, "m", "World size of one texture tile when uvw is reset."),
    F(reset_period, 1, 0, 1e4, "s", "Seconds between resets of one uvw field; 0 = never; 1..4."),
    F(stretch_fade, 1, 0, 100, "1",
      "Stretch at which a uvw field fades out early where it is stretched; 0 = off; 0.5..2."),
    F(paint_duration, 1, 0, 1e5, "s", "How long local paint lasts at full strength."),
    F(paint_fade, 1, 0, 1e5, "s", "How long local paint then takes to fade out."),
    F(texture_scale, HBK_FLUID_MAX_TEXTURES, 1e-4, 1e4, "1", "Per texture: tiles per uvw unit."),
    {"texture_feature", HBK_PARAM_ENUM, offsetof(hbk_fluid_params_t, texture_feature),
     HBK_FLUID_MAX_TEXTURES, 0, HBK_FLUID_FEATURE_COUNT, "1",
     "DENSITY|DENSITY_RATE|FLOW_ANGLE|ACCELERATION|DIVERGENCE|CURVATURE|ALL",
     "Per texture: the feature a selection captures for feature paint."},
    {"seed", HBK_PARAM_U64, offsetof(hbk_fluid_params_t, seed), 1, 0, 18446744073709551615.0,
     "1", NULL, "Random seed of the particle jitter."},
    I(threads, 1, 0, 1024, "1", "Threads to use, 0 = all; the result never depends on it."),
};
#undef F
#undef I

const hbk_param_info_t *hbk_fluid_params_info(size_t *count)
{
    if (count) *count = sizeof k_info / sizeof k_info[0];
    return k_info;
}

hbk_result_t hbk_fluid_params_check(const hbk_fluid_params_t *p, hbk_message_t *msg)
{
    hbk_result_t r = hbk_params_validate(p, sizeof *p, k_info, sizeof k_info / sizeof k_info[0],
                                         msg);
    if (r) return r;
    for (int a = 0; a < 3; ++a)
        if (!(p->box_max[a] > p->box_min[a]))
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                            "box_max[%d] = %g: must be greater than box_min[%d] = %g", a,
                            (double)p->box_max[a], a, (double)p->box_min[a]);
    const float s = p->particle_spacing;
    if (p->smoothing_length < s || p->smoothing_length > 4.0f * s)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "smoothing_length = %g: must be 1..4 particle_spacing (%g..%g m)",
                        (double)p->smoothing_length, (double)s, 4.0 * s);
    if (p->metaball_radius < s || p->metaball_radius > 4.0f * s)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "metaball_radius = %g: must be 1..4 particle_spacing (%g..%g m)",
                        (double)p->metaball_radius, (double)s, 4.0 * s);
    if (p->default_texture >= p->textures)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "default_texture = %d: must be below textures = %d", p->default_texture,
                        p->textures);
    /* The particle grid is dense, with cells of h for the SPH and of the splat's reach
     * max(h, R) for particles given each frame (as hbk_fluid_cells_build counts them): each
     * use clears and sums all of them, so too many would only waste memory and time, and
     * past 2^31 their index would overflow. A velocity grid has no particles. */
    if (p->source == HBK_FLUID_VELOCITY_GRID) return HBK_OK;
    for (int a = 0; a < 3; ++a) {
        double cells = (p->box_max[a] - p->box_min[a]) / (double)p->smoothing_length;
        if (cells > 4096.0)
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                            "smoothing_length = %g: the box is %g kernel radii along axis %d, "
                            "at most 4096 are allowed", (double)p->smoothing_length, cells, a);
    }
    const int by_r = p->source == HBK_FLUID_PARTICLES && p->metaball_radius > p->smoothing_length;
    const float size = by_r ? p->metaball_radius : p->smoothing_length;
    double total = 1.0;
    for (int a = 0; a < 3; ++a) {
        const float d = ceilf((p->box_max[a] - p->box_min[a]) / size);
        total *= d < 1.0f ? 1.0 : (double)d;
    }
    if (total > (double)HBK_FLUID_MAX_CELLS)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "%s = %g: the box holds %.0f cells of one kernel radius, at most %d are "
                        "allowed (a larger %s or a smaller box)",
                        by_r ? "metaball_radius" : "smoothing_length", (double)size, total,
                        HBK_FLUID_MAX_CELLS, by_r ? "metaball_radius" : "smoothing_length");
    return HBK_OK;
}

uint64_t hbk_fluid_period_frames(const hbk_fluid_params_t *p)
{
    if (p->reset_period <= 0.0f) return 0;
    /* Even, so that B's reset (at P/2) is exactly where A's weight is 1. */
    double f = 2.0 * floor((double)p->reset_period / (2.0 * (double)p->dt) + 0.5);
    return f < 2.0 ? 2 : (uint64_t)f;
}

/* Field A resets when frame % P == 0, B when frame % P == P/2; each fades in from weight 0 at
 * its reset to 1 at the other's, so the one being reset is never visible. */
float hbk_fluid_weight_at(const hbk_fluid_params_t *p, uint64_t frame)
{
    const uint64_t P = hbk_fluid_period_frames(p);
    if (!P) return 1.0f;
    const double phase = (double)(frame % P) / (double)P;
    return (float)(1.0 - fabs(1.0 - 2.0 * phase));
}
