/* Water: a small pool on sloped ground with rain, a source, an acceleration field and a
 * footprint, stepped and read out, saved and loaded into a second handle that steps on. */
#include "alloc_failure.h"

enum { W = 24, H = 16 };

typedef struct {
    hbk_water_t *a, *b;
} water_state_t;

static hbk_water_params_t params(void)
{
    hbk_water_params_t p;
    hbk_water_params_default(&p);
    p.width = W;
    p.height = H;
    p.substeps = 2;
    p.damping = 0.5f;
    p.rain_rate = 400.0f;
    p.rain_radius = 0.06f;
    p.seed = 11;
    p.threads = af_threads();
    return p;
}

/* A W x H view of `channels` channels on a scenario buffer filled by f(x, y, c). */
static hbk_image_t field(af_ctx_t *c, int32_t channels, float (*f)(int32_t, int32_t, int32_t))
{
    float *v = af_buffer(c, (size_t)W * H * (size_t)channels * sizeof *v);
    for (int32_t y = 0; y < H; ++y)
        for (int32_t x = 0; x < W; ++x)
            for (int32_t k = 0; k < channels; ++k) v[(y * W + x) * channels + k] = f(x, y, k);
    return (hbk_image_t){v, W, H, channels, (size_t)W * (size_t)channels};
}

static float ground(int32_t x, int32_t y, int32_t k) { return 0.01f * (float)x - 0.003f * (float)y; }
static float source(int32_t x, int32_t y, int32_t k) { return x == 3 && y == 4 ? 0.2f : x == 20 && y == 12 ? -0.1f : 0.0f; }
static float accel(int32_t x, int32_t y, int32_t k) { return k ? 0.1f * (float)(y % 3) : 0.2f; }
static float foot(int32_t x, int32_t y, int32_t k) { return x >= 10 && x < 14 && y >= 6 && y < 10 ? 0.02f : 0.0f; }

static void outputs(af_ctx_t *c, hbk_water_t *h)
{
    float *s = af_buffer(c, (size_t)W * H * sizeof *s), *d = af_buffer(c, (size_t)W * H * sizeof *d);
    float *v = af_buffer(c, (size_t)W * H * 2 * sizeof *v);
    hbk_image_t si = {s, W, H, 1, W}, di = {d, W, H, 1, W}, vi = {v, W, H, 2, 2 * W};
    AF_CALL(c, hbk_water_get_surface(h, &si), hbk_water_message(h));
    AF_CALL(c, hbk_water_get_depth(h, &di), hbk_water_message(h));
    AF_CALL(c, hbk_water_get_velocity(h, &vi), hbk_water_message(h));
    af_hash(c, s, (size_t)W * H * sizeof *s);
    af_hash(c, d, (size_t)W * H * sizeof *d);
    af_hash(c, v, (size_t)W * H * 2 * sizeof *v);
    const uint64_t steps = hbk_water_step_count(h);
    af_hash(c, &steps, sizeof steps);
}

static void run(af_ctx_t *c, void *state)
{
    water_state_t *s = state;
    const hbk_water_params_t p = params();
    hbk_message_t m;
    AF_CREATE(c, hbk_water_create(&s->a, &p, &m), s->a, m);
    const hbk_image_t g = field(c, 1, ground), src = field(c, 1, source);
    const hbk_image_t acc = field(c, 2, accel), fp = field(c, 1, foot);
    AF_CALL(c, hbk_water_set_ground(s->a, &g), hbk_water_message(s->a));
    AF_CALL(c, hbk_water_set_level(s->a, 0.15f), hbk_water_message(s->a));
    AF_CALL(c, hbk_water_set_sources(s->a, &src), hbk_water_message(s->a));
    AF_CALL(c, hbk_water_set_acceleration(s->a, &acc), hbk_water_message(s->a));
    AF_CALL(c, hbk_water_set_footprint(s->a, &fp), hbk_water_message(s->a));
    for (int f = 0; f < 3; ++f) AF_CALL(c, hbk_water_step(s->a, NULL), hbk_water_message(s->a));
    outputs(c, s->a);
    if (af_failed(c)) return;
    const size_t size = hbk_water_state_size(s->a);
    void *buf = af_buffer(c, size);
    AF_CALL(c, hbk_water_save_state(s->a, buf, size), hbk_water_message(s->a));
    af_hash(c, buf, size);
    AF_CREATE(c, hbk_water_create(&s->b, &p, &m), s->b, m);
    AF_CALL(c, hbk_water_load_state(s->b, buf, size), hbk_water_message(s->b));
    AF_CALL(c, hbk_water_step(s->b, NULL), hbk_water_message(s->b));
    outputs(c, s->b);
}

static void done(void *state)
{
    water_state_t *s = state;
    hbk_water_destroy(s->a);
    hbk_water_destroy(s->b);
}

const af_scenario_t af_scenario_water = {"water", sizeof(water_state_t), run, done};
