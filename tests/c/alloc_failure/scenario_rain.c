/* Rain: a small curved glass (a gravity field) with rain, one wiper and a mask, stepped, read
 * out, saved and loaded into a second handle that steps on. */
#include <math.h>
#include "alloc_failure.h"

typedef struct {
    hbk_rain_t *a, *b;
} rain_state_t;

static hbk_rain_params_t params(void)
{
    hbk_rain_params_t p;
    hbk_rain_params_default(&p);
    p.width = p.map_width = 96;
    p.height = p.map_height = 64;
    p.cell_size = 0.002f;
    p.rain_rate = 3000.0f;
    p.wiper_count = 1;
    p.wiper_pivot[0] = 0.096f;
    p.wiper_pivot[1] = -0.01f;
    p.wiper_period = 0.3f;
    p.threads = af_threads();
    p.seed = 7;
    return p;
}

static void outputs(af_ctx_t *c, hbk_rain_t *h)
{
    const hbk_rain_params_t p = params();
    const size_t n = (size_t)p.map_width * (size_t)p.map_height;
    float *map = af_buffer(c, n * sizeof *map), *wet = af_buffer(c, n * sizeof *wet);
    hbk_image_t hm = {map, p.map_width, p.map_height, 1, (size_t)p.map_width};
    hbk_image_t wm = {wet, p.map_width, p.map_height, 1, (size_t)p.map_width};
    AF_CALL(c, hbk_rain_heightmap(h, &hm), hbk_rain_message(h));
    AF_CALL(c, hbk_rain_wetness(h, &wm), hbk_rain_message(h));
    af_hash(c, map, n * sizeof *map);
    af_hash(c, wet, n * sizeof *wet);
    const int64_t cap = hbk_rain_drop_count(h);
    int64_t got = 0;
    hbk_rain_drop_t *d = af_buffer(c, (size_t)(cap + 1) * sizeof *d);
    AF_CALL(c, hbk_rain_drops(h, d, cap, &got), hbk_rain_message(h));
    af_hash(c, d, (size_t)got * sizeof *d);
}

static void run(af_ctx_t *c, void *state)
{
    rain_state_t *s = state;
    const hbk_rain_params_t p = params();
    hbk_message_t m;
    AF_CREATE(c, hbk_rain_create(&s->a, &p, &m), s->a, m);
    float *mask = af_buffer(c, (size_t)p.width * (size_t)p.height * sizeof *mask);
    for (int32_t y = 0; y < p.height; ++y)
        for (int32_t x = 0; x < p.width; ++x) mask[y * p.width + x] = x < 88 ? 1.0f : 0.0f;
    const hbk_image_t mi = {mask, p.width, p.height, 1, (size_t)p.width};
    /* Curved glass: down leans towards +u across the glass (a field the state carries). */
    float *down = af_buffer(c, 2 * (size_t)p.width * (size_t)p.height * sizeof *down);
    for (int32_t q = 0; q < p.width * p.height; ++q) {
        const float u = 0.5f * (float)(q % p.width) / (float)p.width;
        down[2 * q] = u;
        down[2 * q + 1] = -sqrtf(1.0f - u * u);
    }
    const hbk_image_t gi = {down, p.width, p.height, 2, 2 * (size_t)p.width};
    AF_CALL(c, hbk_rain_set_tangents(s->a, &gi, &mi), hbk_rain_message(s->a));
    AF_CALL(c, hbk_rain_add_drop(s->a, 0.05f, 0.1f, 40.0f), hbk_rain_message(s->a));
    for (int f = 0; f < 3; ++f) AF_CALL(c, hbk_rain_step(s->a, 0.05f, NULL), hbk_rain_message(s->a));
    outputs(c, s->a);
    if (af_failed(c)) return;
    const size_t size = hbk_rain_state_size(s->a);
    void *buf = af_buffer(c, size);
    AF_CALL(c, hbk_rain_save_state(s->a, buf, size), hbk_rain_message(s->a));
    AF_CREATE(c, hbk_rain_create(&s->b, &p, &m), s->b, m);
    AF_CALL(c, hbk_rain_load_state(s->b, buf, size), hbk_rain_message(s->b));
    AF_CALL(c, hbk_rain_step(s->b, 0.05f, NULL), hbk_rain_message(s->b));
    outputs(c, s->b);
}

static void done(void *state)
{
    rain_state_t *s = state;
    hbk_rain_destroy(s->a);
    hbk_rain_destroy(s->b);
}

const af_scenario_t af_scenario_rain = {"rain", sizeof(rain_state_t), run, done};
