/* Mesh obstacles whose shape changes (hbk_fluid_move_obstacle_field): refused by name; a
 * growing ball's field pushes a particle out at the speed its surface grows, where a field
 * taken at once leaves it at rest; the change is pending until a step completes, dropped by
 * set_obstacle_field, set_obstacles and load_state, taken at once with other dims, and counted
 * in the stable step; the same bytes at one and two threads and from a checkpoint. */
#include "test.h"
#include "fluid/internal_fluid.h"
#include <stdlib.h>

#define N 48 /* points a side of the fields */

static const hbk_fluid_obstacle_t BALL = {3, {0.5f, 0.5f, 0.5f}, {0.2f, 0.2f, 0.2f}, {1, 0, 0, 0}};
static const int32_t DIMS[3] = {N, N, N};

/* Sets `field` (a ball of radius r's, over BALL's box) through `how`. */
static hbk_result_t ball_field(hbk_fluid_t *h, double r,
                               hbk_result_t (*how)(hbk_fluid_t *, int32_t, const int32_t *,
                                                   const float *))
{
    float *f = fluid_sdf_field(SDF_SPHERE, BALL.extent, N, r, r, r);
    hbk_result_t res = f ? how(h, 0, DIMS, f) : HBK_ERR_OUT_OF_MEMORY;
    free(f);
    return res;
}

void test_fluid_deforming_refused(void)
{
    hbk_fluid_t *h = fluid_lone(0.0f, 8, 0);
    CHECK(h);
    const hbk_fluid_obstacle_t obs[2] = {BALL, {1, {0.2f, 0.2f, 0.2f}, {0.1f, 0.1f, 0.1f}, {0}}};
    CHECK_OK(hbk_fluid_set_obstacles(h, obs, 2));
    float f[8] = {1, 1, 1, 1, 1, 1, 1, 1};
    const int32_t two[3] = {2, 2, 2}, bad[3] = {2, 1, 2};
    CHECK(hbk_fluid_move_obstacle_field(h, 2, two, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "index = 2: must be in [0, 2)"));
    CHECK(hbk_fluid_move_obstacle_field(h, 1, two, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "obstacle 1 is of type 1, must be 3 (mesh)"));
    CHECK(hbk_fluid_move_obstacle_field(h, 0, bad, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "dims[1] = 1: must be in [2, 128]"));
    CHECK(hbk_fluid_move_obstacle_field(h, 0, NULL, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "dims: must not be NULL"));
    f[5] = NAN;
    CHECK(hbk_fluid_move_obstacle_field(h, 0, two, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "distance[5] = nan"));
    CHECK(hbk_fluid_move_obstacle_field(NULL, 0, two, f) == HBK_ERR_INVALID_ARGUMENT);
    hbk_fluid_destroy(h);
}

/* A ball's field grows from 5 to 15 cm over one frame: a particle at rest 10 cm from its
 * centre rides its surface out, half a spacing off it, at the 0.1 m / dt it grows. Taken at
 * once (set_obstacle_field), the field throws the particle out with no speed at all. */
void test_fluid_deforming_growing_ball(void)
{
    const float dt = 1.0f / 24.0f, m = 0.01f;
    for (int at_once = 0; at_once < 2; ++at_once) {
        hbk_fluid_t *h = fluid_lone(0.0f, 8, 1);
        CHECK(h);
        CHECK_OK(hbk_fluid_set_obstacles(h, &BALL, 1));
        CHECK_OK(ball_field(h, 0.05, hbk_fluid_set_obstacle_field));
        const float x0[3] = {0.5f, 0.6f, 0.5f}, v0[3] = {0, 0, 0};
        CHECK_OK(hbk_fluid_set_particles(h, x0, v0, 1));
        CHECK_OK(ball_field(h, 0.15, at_once ? hbk_fluid_set_obstacle_field
                                             : hbk_fluid_move_obstacle_field));
        CHECK_OK(hbk_fluid_step(h, NULL));
        float x[3], v[3];
        CHECK_OK(hbk_fluid_get_particles(h, x, v, 1));
        CHECK_NEAR(x[0], 0.5, 1e-4);
        CHECK_NEAR(x[2], 0.5, 1e-4);
        CHECK_NEAR(x[1], 0.5 + 0.15 + m, 1e-3);
        CHECK_NEAR(v[1], at_once ? 0.0 : 0.1 / dt, at_once ? 1e-6 : 0.03 * 0.1 / dt);
        hbk_fluid_destroy(h);
    }
}

/* Pending until a step completes: the saved state holds the field it has, a cancelled step
 * keeps the change, a completed one makes it the field. Other dims: taken at once. Dropped by
 * set_obstacle_field, set_obstacles and load_state. A fast change takes more SPH steps. */
void test_fluid_deforming_pending(void)
{
    hbk_fluid_t *h = fluid_lone(0.0f, 8, 1), *g = fluid_lone(0.0f, 8, 1);
    CHECK(h && g);
    const float x0[3] = {0.5f, 0.8f, 0.5f}, v0[3] = {0, 0, 0};
    hbk_fluid_t *both[2] = {h, g};
    for (int k = 0; k < 2; ++k) {
        CHECK_OK(hbk_fluid_set_obstacles(both[k], &BALL, 1));
        CHECK_OK(ball_field(both[k], 0.05, hbk_fluid_set_obstacle_field));
        CHECK_OK(hbk_fluid_set_particles(both[k], x0, v0, 1));
    }
    size_t s0, s1;
    unsigned char *before = fluid_state_of(h, &s0);
    CHECK_OK(ball_field(h, 0.15, hbk_fluid_move_obstacle_field));
    unsigned char *pending = fluid_state_of(h, &s1);
    CHECK(before && pending && s0 == s1 && !memcmp(before, pending, s0));
    CHECK(h->obs_field_to[0] != NULL);
    hbk_progress_t pr = {1, 0.0f};
    CHECK(hbk_fluid_step(h, &pr) == HBK_ERR_CANCELLED);
    CHECK(h->obs_field_to[0] != NULL);
    CHECK_OK(hbk_fluid_step(h, NULL));
    const int32_t taken = hbk_fluid_substeps_taken(h);
    CHECK(h->obs_field_to[0] == NULL);
    CHECK_OK(hbk_fluid_step(g, NULL)); /* still: the fewest steps */
    CHECK(taken > hbk_fluid_substeps_taken(g));
    /* the field after the step: the new one */
    float *want = fluid_sdf_field(SDF_SPHERE, BALL.extent, N, 0.15, 0.15, 0.15);
    CHECK(want && !memcmp(h->obs_field[0], want, sizeof(float) * N * N * N));
    free(want);
    /* other dims: at once */
    float f8[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
    const int32_t two[3] = {2, 2, 2};
    CHECK_OK(hbk_fluid_move_obstacle_field(h, 0, two, f8));
    CHECK(h->obs_field_to[0] == NULL && h->obs_dims[0][0] == 2 && h->obs_field[0][7] == -1.0f);
    /* dropped: by set_obstacle_field, set_obstacles and load_state */
    CHECK_OK(ball_field(g, 0.1, hbk_fluid_move_obstacle_field));
    CHECK_OK(ball_field(g, 0.05, hbk_fluid_set_obstacle_field));
    CHECK(g->obs_field_to[0] == NULL);
    CHECK_OK(ball_field(g, 0.1, hbk_fluid_move_obstacle_field));
    CHECK_OK(hbk_fluid_load_state(g, before, s0));
    CHECK(g->obs_field_to[0] == NULL && g->obs_field[0] != NULL);
    CHECK_OK(ball_field(g, 0.1, hbk_fluid_move_obstacle_field));
    CHECK_OK(hbk_fluid_set_obstacles(g, &BALL, 1));
    CHECK(g->obs_field_to[0] == NULL && g->obs_field[0] == NULL);
    free(before);
    free(pending);
    hbk_fluid_destroy(h);
    hbk_fluid_destroy(g);
}

/* A dam break around a ball that swells and shrinks, frame by frame. */
static hbk_fluid_t *swelling(int threads)
{
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    for (int a = 0; a < 3; ++a) p.resolution[a] = 24;
    p.threads = threads;
    p.max_particles = 8000;
    p.seed = 77;
    hbk_fluid_t *h = NULL;
    hbk_message_t msg;
    if (hbk_fluid_create(&h, &p, &msg) != HBK_OK) return NULL;
    const float lo[3] = {0.0f, 0.0f, 0.0f}, hi[3] = {0.4f, 0.4f, 0.3f};
    hbk_fluid_obstacle_t ob = BALL;
    ob.center[0] = 0.35f, ob.center[1] = 0.35f, ob.center[2] = 0.2f;
    if (hbk_fluid_set_obstacles(h, &ob, 1) || ball_field(h, 0.08, hbk_fluid_set_obstacle_field) ||
        hbk_fluid_fill_box(h, lo, hi, 0.2f)) {
        hbk_fluid_destroy(h);
        return NULL;
    }
    return h;
}

static hbk_result_t swell(hbk_fluid_t *h, int frame)
{
    hbk_result_t r = ball_field(h, 0.08 + 0.03 * sin(frame), hbk_fluid_move_obstacle_field);
    return r ? r : hbk_fluid_step(h, NULL);
}

void test_fluid_deforming_same_bytes(void)
{
    hbk_fluid_t *a = swelling(1), *b = swelling(2), *c = swelling(2);
    CHECK(a && b && c);
    for (int f = 1; f <= 2; ++f) {
        CHECK_OK(swell(a, f));
        CHECK_OK(swell(b, f));
    }
    size_t s;
    unsigned char *mid = fluid_state_of(b, &s);
    CHECK(mid);
    CHECK_OK(hbk_fluid_load_state(c, mid, s));
    for (int f = 3; f <= 4; ++f) {
        CHECK_OK(swell(a, f));
        CHECK_OK(swell(b, f));
        CHECK_OK(swell(c, f));
    }
    CHECK(fluid_same_state(a, b) && fluid_same_state(b, c));
    /* and no particle inside the ball as it is now */
    const int32_t n = hbk_fluid_particle_count(a);
    float *pos = malloc(3 * (size_t)n * sizeof *pos);
    CHECK(pos && hbk_fluid_get_particles(a, pos, NULL, n) == HBK_OK);
    const double r = 0.08 + 0.03 * sin(4.0);
    for (int32_t i = 0; i < n; ++i) {
        const double d = sqrt(pow(pos[3 * i] - 0.35, 2) + pow(pos[3 * i + 1] - 0.35, 2) +
                              pow(pos[3 * i + 2] - 0.2, 2));
        CHECK(d > r + 0.005);
    }
    free(pos);
    free(mid);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
    hbk_fluid_destroy(c);
}
