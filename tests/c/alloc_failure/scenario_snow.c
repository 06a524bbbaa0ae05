/* Snow: a box of 12 triangles (three material slots, one melting) in a small volume of fast
 * flakes, so that enough stick to grow the event lists; TRIANGLES mode stepped, the mesh set
 * again (moved), read out, saved and loaded into a second handle that steps on; then a BOX
 * mode handle with three slots (one texture block each), stepped and read out. */
#include "alloc_failure.h"

typedef struct {
    hbk_snow_t *a, *b, *box;
} snow_state_t;

static hbk_snow_params_t params(int box)
{
    hbk_snow_params_t p;
    hbk_snow_params_default(&p);
    p.flake_count = 1500;
    p.flake_radius = 0.02f;
    p.fall_speed = 5.0f;
    p.wind[0] = 0.5f;
    p.wind[1] = -0.3f;
    p.volume_min[0] = p.volume_min[1] = -0.6f;
    p.volume_max[0] = p.volume_max[1] = 0.6f;
    p.volume_max[2] = 1.2f;
    p.texture_width = 18;
    p.texture_height = 16;
    p.contact_mode = box ? HBK_SNOW_CONTACT_BOX : HBK_SNOW_CONTACT_TRIANGLES;
    p.threads = af_threads();
    p.seed = 11;
    return p;
}

typedef struct {
    float pos[24 * 3], uv[12 * 6];
    int32_t tri[12 * 3], mat[12];
} box_mesh_t;

/* Axis-aligned box [lo, lo + size]: face f (0 +X, 1 -X, 2 +Y, 3 -Y, 4 +Z, 5 -Z) on its own
 * tile of a 3 x 2 UV atlas; the top in slot 0, the bottom (melting) in slot 2, sides in 1. */
static void box_mesh(box_mesh_t *m, float dz)
{
    const float lo[3] = {-0.45f, -0.4f, 0.2f + dz}, hi[3] = {0.45f, 0.4f, 0.9f + dz};
    const float q[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    const int c[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int f = 0; f < 6; ++f) {
        const int ax = f / 2, a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
        for (int i = 0; i < 4; ++i) {
            float *v = m->pos + 3 * (4 * f + i);
            v[ax] = (f & 1) ? lo[ax] : hi[ax];
            v[a1] = q[i][0] ? hi[a1] : lo[a1];
            v[a2] = q[i][1] ? hi[a2] : lo[a2];
        }
        for (int t = 0; t < 2; ++t) {
            const int tt = 2 * f + t;
            for (int k = 0; k < 3; ++k) {
                const int v = c[t][k];
                m->tri[3 * tt + k] = 4 * f + v;
                m->uv[6 * tt + 2 * k] = ((float)(f % 3) + 0.9f * q[v][0]) / 3.0f;
                m->uv[6 * tt + 2 * k + 1] = ((float)(f / 3) + 0.9f * q[v][1]) / 2.0f;
            }
            m->mat[tt] = f == 4 ? 0 : f == 5 ? 2 : 1;
        }
    }
}

static void setup(af_ctx_t *c, hbk_snow_t *h, float dz)
{
    static const hbk_snow_material_t mats[3] = {{0.5f, 0, 0}, {0.2f, 0, 0}, {0.0f, 1, 0}};
    box_mesh_t *m = af_buffer(c, sizeof *m);
    box_mesh(m, dz);
    AF_CALL(c, hbk_snow_set_materials(h, mats, 3), hbk_snow_message(h));
    AF_CALL(c, hbk_snow_set_mesh(h, m->pos, 24, m->tri, m->uv, m->mat, 12), hbk_snow_message(h));
}

static void outputs(af_ctx_t *c, hbk_snow_t *h)
{
    int32_t w, ht, count = 0;
    hbk_snow_texture_size(h, &w, &ht);
    af_hash(c, &w, sizeof w);
    af_hash(c, &ht, sizeof ht);
    const size_t n = (size_t)w * (size_t)ht;
    float *rgba = af_buffer(c, 4 * n * sizeof *rgba), *dep = af_buffer(c, n * sizeof *dep);
    hbk_image_t ci = {rgba, w, ht, 4, 4 * (size_t)w}, di = {dep, w, ht, 1, (size_t)w};
    AF_CALL(c, hbk_snow_coverage(h, &ci), hbk_snow_message(h));
    AF_CALL(c, hbk_snow_depth(h, &di), hbk_snow_message(h));
    af_hash(c, rgba, 4 * n * sizeof *rgba);
    af_hash(c, dep, n * sizeof *dep);
    const int32_t cap = params(0).flake_count;
    float *xyz = af_buffer(c, 3 * (size_t)cap * sizeof *xyz);
    AF_CALL(c, hbk_snow_flakes(h, xyz, cap, &count), hbk_snow_message(h));
    af_hash(c, xyz, 3 * (size_t)count * sizeof *xyz);
    hbk_snow_stats_t st;
    hbk_snow_stats(h, &st);
    af_hash(c, &st, sizeof st);
}

static void run(af_ctx_t *c, void *state)
{
    snow_state_t *s = state;
    const hbk_snow_params_t p = params(0), pb = params(1);
    hbk_message_t m;
    AF_CREATE(c, hbk_snow_create(&s->a, &p, &m), s->a, m);
    setup(c, s->a, 0.0f);
    if (af_failed(c)) return;
    AF_CALL(c, hbk_snow_step(s->a, 10, NULL), hbk_snow_message(s->a));
    setup(c, s->a, 0.05f); /* moved: the old mesh is replaced, flakes it now shelters move */
    if (af_failed(c)) return;
    AF_CALL(c, hbk_snow_step(s->a, 10, NULL), hbk_snow_message(s->a));
    outputs(c, s->a);
    if (af_failed(c)) return;
    const size_t size = hbk_snow_state_size(s->a);
    void *buf = af_buffer(c, size);
    AF_CALL(c, hbk_snow_save_state(s->a, buf, size), hbk_snow_message(s->a));
    AF_CREATE(c, hbk_snow_create(&s->b, &p, &m), s->b, m);
    setup(c, s->b, 0.05f);
    if (af_failed(c)) return;
    AF_CALL(c, hbk_snow_load_state(s->b, buf, size), hbk_snow_message(s->b));
    AF_CALL(c, hbk_snow_step(s->b, 2, NULL), hbk_snow_message(s->b));
    outputs(c, s->b);
    if (af_failed(c)) return;
    AF_CREATE(c, hbk_snow_create(&s->box, &pb, &m), s->box, m);
    setup(c, s->box, 0.0f); /* three slots: the textures grow to three blocks */
    if (af_failed(c)) return;
    AF_CALL(c, hbk_snow_step(s->box, 3, NULL), hbk_snow_message(s->box));
    outputs(c, s->box);
}

static void done(void *state)
{
    snow_state_t *s = state;
    hbk_snow_destroy(s->a);
    hbk_snow_destroy(s->b);
    hbk_snow_destroy(s->box);
}

const af_scenario_t af_scenario_snow = {"snow", sizeof(snow_state_t), run, done};
