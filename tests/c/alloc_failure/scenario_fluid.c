/* Fluid, one scenario per source: the built-in SPH (obstacles with a mesh, an inflow, an
 * outflow with a mesh's field, paint, feature rules, a capture), particles set every frame,
 * and a velocity grid. Each steps, builds the surface, reads every volume and the mesh, then
 * saves and loads into a second handle that steps on. */
#include <float.h>
#include <math.h>
#include "alloc_failure.h"

typedef struct {
    hbk_fluid_t *a, *b;
} fluid_state_t;

static hbk_fluid_params_t params(int32_t source)
{
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    p.source = source;
    for (int a = 0; a < 3; ++a) p.resolution[a] = 12;
    p.max_particles = 400;
    p.particle_spacing = 0.05f;
    p.smoothing_length = 0.1f;
    p.metaball_radius = 0.1f;
    p.textures = 3;
    p.reset_period = 0.1f;
    p.stretch_fade = 1.0f;
    p.dt = 0.01f; /* a few SPH substeps a frame, to keep the many runs short */
    p.substeps = 2;
    p.threads = af_threads();
    p.seed = 3;
    return p;
}

/* Every volume, the mesh and its weights into the hash. */
static void outputs(af_ctx_t *c, hbk_fluid_t *h)
{
    AF_CALL(c, hbk_fluid_update_surface(h, NULL), hbk_fluid_message(h));
    for (int32_t v = 0; v < HBK_FLUID_VOL_COUNT; ++v) {
        const size_t n = hbk_fluid_volume_size(h, v);
        float *out = af_buffer(c, n * sizeof *out);
        AF_CALL(c, hbk_fluid_get_volume(h, v, out, n), hbk_fluid_message(h));
        af_hash(c, out, n * sizeof *out);
    }
    int32_t nv = 0, nt = 0;
    AF_CALL(c, hbk_fluid_mesh_counts(h, &nv, &nt), hbk_fluid_message(h));
    if (nt == 0 && !af_skipped(c)) { /* a skipped surface update leaves none */
        af_fail(c, __LINE__, "no surface: the scenario must make one");
        return;
    }
    const size_t v3 = 3 * (size_t)nv * sizeof(float);
    float *pos = af_buffer(c, v3), *nrm = af_buffer(c, v3), *ua = af_buffer(c, v3),
          *ub = af_buffer(c, v3), *w = af_buffer(c, (size_t)nv * sizeof(float)),
          *bl = af_buffer(c, 3 * (size_t)nv * sizeof(float)),
          *ft = af_buffer(c, HBK_FLUID_FEATURE_COUNT * (size_t)nv * sizeof(float));
    int32_t *tri = af_buffer(c, 3 * (size_t)nt * sizeof *tri);
    AF_CALL(c, hbk_fluid_get_mesh(h, pos, nrm, tri, ua, ub, bl, ft), hbk_fluid_message(h));
    AF_CALL(c, hbk_fluid_get_mesh_weight(h, w), hbk_fluid_message(h));
    af_hash(c, pos, v3);
    af_hash(c, nrm, v3);
    af_hash(c, tri, 3 * (size_t)nt * sizeof *tri);
    af_hash(c, ft, HBK_FLUID_FEATURE_COUNT * (size_t)nv * sizeof(float));
    af_hash(c, w, (size_t)nv * sizeof(float));
}

/* The inputs of a frame for the external sources: a ball of particles, or a swirl with the
 * ball as its surface field, moving with the frame number f. */
static void inputs(af_ctx_t *c, hbk_fluid_t *h, int32_t source, int f)
{
    if (source == HBK_FLUID_PARTICLES) {
        enum { N = 216 };
        float *pos = af_buffer(c, 3 * N * sizeof *pos), *vel = af_buffer(c, 3 * N * sizeof *vel);
        for (int q = 0; q < N; ++q) {
            const int ijk[3] = {q % 6, q / 6 % 6, q / 36};
            for (int a = 0; a < 3; ++a) {
                pos[3 * q + a] = 0.3f + 0.05f * (float)ijk[a] + 0.01f * (float)f;
                vel[3 * q + a] = a == 0 ? 0.24f : 0.0f;
            }
        }
        AF_CALL(c, hbk_fluid_set_particles(h, pos, vel, N), hbk_fluid_message(h));
        return;
    }
    int32_t nv[3];
    const size_t n = hbk_fluid_grid_vertices(h, nv);
    float *vel = af_buffer(c, 3 * n * sizeof *vel), *surf = af_buffer(c, n * sizeof *surf);
    for (int32_t k = 0; k < nv[2]; ++k)
        for (int32_t j = 0; j < nv[1]; ++j)
            for (int32_t i = 0; i < nv[0]; ++i) {
                const size_t v = (size_t)i + (size_t)nv[0] * ((size_t)j + (size_t)nv[1] * (size_t)k);
                const float x = (float)i / 12.0f - 0.5f, y = (float)j / 12.0f - 0.5f,
                            z = (float)k / 12.0f - 0.4f - 0.02f * (float)f;
                vel[3 * v] = -y;
                vel[3 * v + 1] = x;
                vel[3 * v + 2] = 0.1f;
                surf[v] = 1.0f - (x * x + y * y + z * z) / 0.09f;
            }
    AF_CALL(c, hbk_fluid_set_velocity_grid(h, vel, surf), hbk_fluid_message(h));
}

/* An inflow (SIMULATE) clear of the fill and the obstacles: 2 x 2 x 2 lattice points poured
 * down at 3 m/s, so every step grows the particle count (8, 3, 2: the SPH's lists with it). */
static hbk_result_t inflow(hbk_fluid_t *h)
{
    const hbk_fluid_obstacle_t tap = {1, {0.7f, 0.3f, 0.6f}, {0.06f, 0.06f, 0.06f}, {0}};
    const float vel[3] = {1.0f, 0.0f, -3.0f};
    return hbk_fluid_set_inflow(h, &tap, NULL, NULL, vel, 0.2f);
}

/* A sprinkler (the second handle's inflow): a ball spraying along its normal and down, its
 * points on its surface (more than the first buffer holds: it grows), and a tap added beside
 * it (the two inflows' points merged). */
static hbk_result_t sprinkler(hbk_fluid_t *h)
{
    const hbk_fluid_obstacle_t head = {0, {0.7f, 0.6f, 0.6f}, {0.2f, 0.0f, 0.0f}, {0}};
    const hbk_fluid_obstacle_t tap = {1, {0.2f, 0.7f, 0.8f}, {0.03f, 0.03f, 0.03f}, {0}};
    const float vel[3] = {0.0f, 0.0f, -0.5f};
    hbk_result_t r = hbk_fluid_set_inflow_normal(h, &head, NULL, NULL, vel, 1.0f, 0.0f);
    return r ? r : hbk_fluid_add_inflow(h, &tap, NULL, NULL, vel, 0.0f);
}

static void run_source(af_ctx_t *c, fluid_state_t *s, int32_t source)
{
    const hbk_fluid_params_t p = params(source);
    hbk_message_t m;
    AF_CREATE(c, hbk_fluid_create(&s->a, &p, &m), s->a, m);
    const float ctr[3] = {0.4f, 0.4f, 0.3f};
    float field[27];
    const int32_t dims[3] = {3, 3, 3};
    if (source == HBK_FLUID_SIMULATE) {
        const float lo[3] = {0.0f, 0.0f, 0.0f}, hi[3] = {0.35f, 0.35f, 0.35f};
        AF_CALL(c, hbk_fluid_fill_box(s->a, lo, hi, 0.2f), hbk_fluid_message(s->a));
        /* a ball, and a mesh (a ball's distance field, carried by the state) */
        const hbk_fluid_obstacle_t ob[2] = {{0, {0.7f, 0.5f, 0.1f}, {0.1f, 0.0f, 0.0f}, {0}},
                                            {3, {0.5f, 0.8f, 0.1f}, {0.1f, 0.1f, 0.1f},
                                             {1, 0, 0, 0}}};
        AF_CALL(c, hbk_fluid_set_obstacles(s->a, ob, 2), hbk_fluid_message(s->a));
        for (int i = 0; i < 27; ++i)
            field[i] = sqrtf((float)((i % 3 - 1) * (i % 3 - 1) + (i / 3 % 3 - 1) * (i / 3 % 3 - 1) +
                                     (i / 9 - 1) * (i / 9 - 1))) * 0.1f - 0.06f;
        AF_CALL(c, hbk_fluid_set_obstacle_field(s->a, 1, dims, field), hbk_fluid_message(s->a));
        AF_CALL(c, inflow(s->a), hbk_fluid_message(s->a));
        /* a drain in the fill's corner, the same ball's field: every step takes water */
        const hbk_fluid_obstacle_t drain = {3, {0.1f, 0.1f, 0.1f}, {0.1f, 0.1f, 0.1f},
                                            {1, 0, 0, 0}};
        AF_CALL(c, hbk_fluid_set_outflow(s->a, &drain, dims, field), hbk_fluid_message(s->a));
        /* and a second drain beside it (the drains' list grows) */
        const hbk_fluid_obstacle_t sump = {1, {0.3f, 0.05f, 0.05f}, {0.05f, 0.05f, 0.05f}, {0}};
        AF_CALL(c, hbk_fluid_add_outflow(s->a, &sump, NULL, NULL), hbk_fluid_message(s->a));
    } else {
        inputs(c, s->a, source, 0);
        if (af_failed(c)) return;
    }
    AF_CALL(c, hbk_fluid_update_fields(s->a), hbk_fluid_message(s->a));
    AF_CALL(c, hbk_fluid_paint_sphere(s->a, 1, ctr, 0.2f, 0.05f), hbk_fluid_message(s->a));
    const float pts[6] = {0.3f, 0.3f, 0.2f, 0.5f, 0.4f, 0.3f}, cov[2] = {1.0f, 0.5f};
    AF_CALL(c, hbk_fluid_paint_points(s->a, 0, 2, pts, cov, 0.1f, 0.05f),
            hbk_fluid_message(s->a));
    float lo[HBK_FLUID_FEATURE_COUNT], hi[HBK_FLUID_FEATURE_COUNT];
    for (int q = 0; q < HBK_FLUID_FEATURE_COUNT; ++q) lo[q] = -FLT_MAX, hi[q] = FLT_MAX;
    lo[HBK_FLUID_FEATURE_DENSITY] = 500.0f;
    AF_CALL(c, hbk_fluid_set_feature_rule(s->a, 2, lo, hi), hbk_fluid_message(s->a));
    const size_t n = hbk_fluid_grid_vertices(s->a, NULL);
    float *mask = af_buffer(c, n * sizeof *mask);
    for (size_t v = 0; v < n; v += 3) mask[v] = 1.0f;
    AF_CALL(c, hbk_fluid_capture_feature_rule(s->a, 0, mask), hbk_fluid_message(s->a));
    for (int f = 1; f <= 3; ++f) {
        if (source != HBK_FLUID_SIMULATE) inputs(c, s->a, source, f);
        if (af_failed(c)) return;
        if (source == HBK_FLUID_SIMULATE) { /* the mesh grows: a change of shape per step */
            for (int i = 0; i < 27; ++i) field[i] -= 0.01f;
            AF_CALL(c, hbk_fluid_move_obstacle_field(s->a, 1, dims, field),
                    hbk_fluid_message(s->a));
        }
        AF_CALL(c, hbk_fluid_step(s->a, NULL), hbk_fluid_message(s->a));
    }
    outputs(c, s->a);
    if (af_failed(c)) return;
    const size_t size = hbk_fluid_state_size(s->a);
    void *buf = af_buffer(c, size);
    AF_CALL(c, hbk_fluid_save_state(s->a, buf, size), hbk_fluid_message(s->a));
    AF_CREATE(c, hbk_fluid_create(&s->b, &p, &m), s->b, m);
    AF_CALL(c, hbk_fluid_load_state(s->b, buf, size), hbk_fluid_message(s->b));
    if (source == HBK_FLUID_SIMULATE) /* (not in the state: set again, as a sprinkler) */
        AF_CALL(c, sprinkler(s->b), hbk_fluid_message(s->b));
    if (source != HBK_FLUID_SIMULATE) inputs(c, s->b, source, 4);
    if (af_failed(c)) return;
    AF_CALL(c, hbk_fluid_step(s->b, NULL), hbk_fluid_message(s->b));
    outputs(c, s->b);
}

static void done(void *state)
{
    fluid_state_t *s = state;
    hbk_fluid_destroy(s->a);
    hbk_fluid_destroy(s->b);
}

#define FLUID_SCENARIO(name, source)                                                          \
    static void run_##name(af_ctx_t *c, void *s) { run_source(c, s, source); }                \
    const af_scenario_t af_scenario_##name = {#name, sizeof(fluid_state_t), run_##name, done};
FLUID_SCENARIO(fluid_simulate, HBK_FLUID_SIMULATE)
FLUID_SCENARIO(fluid_particles, HBK_FLUID_PARTICLES)
FLUID_SCENARIO(fluid_velocity_grid, HBK_FLUID_VELOCITY_GRID)
