/* Caustics: a small wavy pool with a shoreline rendered without a workspace, then three times
 * through one workspace (the second render dispersive, periodic and bigger, so it grows the
 * workspace; the third small again), the view refraction and the lit ground; maps and stats
 * are compared. */
#include "alloc_failure.h"
#include <math.h>

enum { W = 12, H = 10 };

typedef struct {
    hbk_caustics_workspace_t *ws;
} caustics_state_t;

/* m.text is cleared first, so a stale message cannot stand in for a missing one. */
#define CALL(c, m, expr)          \
    do {                          \
        (m).text[0] = '\0';       \
        AF_CALL(c, expr, (m).text); \
    } while (0)

static hbk_image_t image(af_ctx_t *c, int32_t w, int32_t h, int32_t channels)
{
    float *v = af_buffer(c, (size_t)w * (size_t)h * (size_t)channels * sizeof *v);
    return (hbk_image_t){v, w, h, channels, (size_t)w * (size_t)channels};
}

static void hash_image(af_ctx_t *c, const hbk_image_t *img)
{
    af_hash(c, img->data, (size_t)img->height * img->row_stride * sizeof *img->data);
}

static void run(af_ctx_t *c, void *state)
{
    caustics_state_t *s = state;
    hbk_message_t m;
    /* Ground rising to the right above the water there: a shoreline crosses the pool. */
    hbk_image_t water = image(c, W, H, 1), ground = image(c, W, H, 1);
    for (int32_t y = 0; y < H; ++y)
        for (int32_t x = 0; x < W; ++x) {
            ground.data[y * W + x] = 0.04f * (float)x - 0.2f;
            water.data[y * W + x] = 0.1f + 0.01f * sinf(1.7f * (float)x + 0.9f * (float)y);
        }
    hbk_caustics_params_t p;
    hbk_caustics_params_default(&p);
    p.light_direction[0] = 0.3f;
    p.light_direction[1] = -0.2f;
    p.absorption[0] = 0.35f;
    p.threads = af_threads();
    hbk_caustics_stats_t st;
    hbk_image_t map = image(c, 16, 16, 4);
    CALL(c, m, hbk_caustics_render(&p, &water, &ground, 0.05f, &map, &st, NULL, &m));
    hash_image(c, &map);
    af_hash(c, &st, sizeof st);

    AF_CREATE(c, hbk_caustics_workspace_create(&s->ws, &m), s->ws, m);
    CALL(c, m, hbk_caustics_render_with(s->ws, &p, &water, &ground, 0.05f, &map, &st, NULL, &m));
    hash_image(c, &map);
    af_hash(c, &st, sizeof st);
    hbk_caustics_params_t q = p;
    q.ior[0] = 1.331f;
    q.ior[2] = 1.337f;
    q.fresnel = 1;
    q.periodic = 1;
    hbk_image_t big = image(c, 40, 36, 3);
    CALL(c, m, hbk_caustics_render_with(s->ws, &q, &water, &ground, 0.05f, &big, &st, NULL, &m));
    hash_image(c, &big);
    af_hash(c, &st, sizeof st);
    /* Smaller again: served from slots a failed growth above may have left behind. */
    CALL(c, m, hbk_caustics_render_with(s->ws, &p, &water, &ground, 0.05f, &map, &st, NULL, &m));
    hash_image(c, &map);
    af_hash(c, &st, sizeof st);

    const float camera[3] = {0.2f, -0.3f, 1.5f};
    hbk_image_t uv = image(c, W, H, 4), refl = image(c, W, H, 3);
    CALL(c, m, hbk_caustics_view(&p, &water, &ground, 0.05f, camera, &uv, &refl, &m));
    hash_image(c, &uv);
    hash_image(c, &refl);

    hbk_image_t tex = image(c, 20, 20, 4), lit = image(c, 20, 20, 4);
    for (size_t i = 0; i < 20 * 20 * 4; ++i) tex.data[i] = (float)(i % 7) / 7.0f;
    CALL(c, m, hbk_caustics_lit_ground(&tex, &map, HBK_EDGE_CLAMP, &lit, &m));
    hash_image(c, &lit);
}

static void done(void *state)
{
    caustics_state_t *s = state;
    hbk_caustics_workspace_destroy(s->ws);
}

const af_scenario_t af_scenario_caustics = {"caustics", sizeof(caustics_state_t), run, done};
