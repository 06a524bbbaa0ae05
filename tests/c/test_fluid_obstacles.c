/* Moving obstacles: a wall or a growing sphere carries the particles it meets at the speed of
 * its surface along the normal and leaves their slip along it; a move is refused by name when
 * it does not fit the obstacles, is made only by a completed step, and bakes the same bytes at
 * any thread count and across a checkpoint. */
#include "test.h"
#include "fluid/internal_fluid.h"
#include <stdlib.h>

static void particle(hbk_fluid_t *h, float x[3], float v[3])
{
    hbk_fluid_get_particles(h, x, v, 1);
}

void test_fluid_obstacles_move_refused(void)
{
    hbk_fluid_t *h = fluid_lone(0.0f, 8, 1);
    CHECK(h);
    const hbk_fluid_obstacle_t box = {1, {0.2f, 0.5f, 0.5f}, {0.1f, 0.1f, 0.1f}};
    CHECK(hbk_fluid_move_obstacles(h, &box, 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "count = 1: must be the obstacle count 0"));
    CHECK_OK(hbk_fluid_set_obstacles(h, &box, 1));
    const hbk_fluid_obstacle_t ball = {0, {0.2f, 0.5f, 0.5f}, {0.1f, 0, 0}};
    CHECK(hbk_fluid_move_obstacles(h, &ball, 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "to[0].type = 0: must be obstacle 0's type 1"));
    hbk_fluid_obstacle_t bad = box;
    bad.center[1] = NAN;
    CHECK(hbk_fluid_move_obstacles(h, &bad, 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "to[0].center[1] = nan: must be a finite number"));
    bad = box;
    bad.extent[2] = -1.0f;
    CHECK(hbk_fluid_move_obstacles(h, &bad, 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "to[0].extent[2] = -1: must be in [0, 1e6] m"));
    CHECK(hbk_fluid_move_obstacles(h, NULL, 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "to: must not be NULL"));
    CHECK(hbk_fluid_move_obstacles(NULL, &box, 1) == HBK_ERR_INVALID_ARGUMENT);
    hbk_fluid_destroy(h);
}

/* A box face sweeping along +x at u reaches a particle drifting along y: from then on the
 * particle rides the face (half a spacing in front of it) at exactly u, its drift untouched. */
void test_fluid_obstacles_moving_wall(void)
{
    hbk_fluid_t *h = fluid_lone(0.0f, 8, 1);
    CHECK(h);
    const float dt = 1.0f / 24.0f, u = 1.2f, m = 0.01f; /* m: half the particle spacing */
    hbk_fluid_obstacle_t box = {1, {0.2f, 0.5f, 0.5f}, {0.1f, 0.1f, 0.1f}};
    CHECK_OK(hbk_fluid_set_obstacles(h, &box, 1));
    float x[3] = {0.45f, 0.5f, 0.5f}, v[3] = {0.0f, 0.2f, 0.0f};
    CHECK_OK(hbk_fluid_set_particles(h, x, v, 1));
    for (int f = 1; f <= 6; ++f) {
        box.center[0] = 0.2f + u * dt * (float)f;
        CHECK_OK(hbk_fluid_move_obstacles(h, &box, 1));
        CHECK_OK(hbk_fluid_step(h, NULL));
        particle(h, x, v);
        const float face = box.center[0] + box.extent[0];
        if (f <= 2) { /* not reached yet: it keeps its own motion */
            CHECK(x[0] == 0.45f && v[0] == 0.0f);
        } else {
            CHECK_NEAR(x[0], face + m, 1e-5);
            CHECK_NEAR(v[0], u, 1e-4);
        }
        CHECK(v[1] == 0.2f && v[2] == 0.0f); /* free slip along the face */
        CHECK_NEAR(x[1], 0.5 + 0.2 * dt * f, 1e-5);
    }
    /* The wall stops: set where it is, the particle moving on at u is not held back (it
     * leaves the face), and a wall coming back at it stops it dead, as a still one does. */
    CHECK_OK(hbk_fluid_move_obstacles(h, &box, 1));
    CHECK_OK(hbk_fluid_step(h, NULL));
    particle(h, x, v);
    CHECK_NEAR(v[0], u, 1e-4);
    CHECK(x[0] > box.center[0] + box.extent[0] + m + 0.5f * u * dt);
    hbk_fluid_destroy(h);
}

/* A sphere growing from 0.05 to 0.15 m over one frame around a particle 0.1 m from its centre
 * leaves it on the new surface, moving outward at the radius's rate. */
void test_fluid_obstacles_growing_sphere(void)
{
    hbk_fluid_t *h = fluid_lone(0.0f, 8, 1);
    CHECK(h);
    const float dt = 1.0f / 24.0f, m = 0.01f;
    hbk_fluid_obstacle_t ball = {0, {0.5f, 0.5f, 0.5f}, {0.05f, 0, 0}};
    CHECK_OK(hbk_fluid_set_obstacles(h, &ball, 1));
    float x[3] = {0.5f, 0.6f, 0.5f}, v[3] = {0.0f, 0.0f, 0.0f};
    CHECK_OK(hbk_fluid_set_particles(h, x, v, 1));
    ball.extent[0] = 0.15f;
    CHECK_OK(hbk_fluid_move_obstacles(h, &ball, 1));
    CHECK_OK(hbk_fluid_step(h, NULL));
    particle(h, x, v);
    CHECK(x[0] == 0.5f && x[2] == 0.5f && v[0] == 0.0f && v[2] == 0.0f);
    CHECK_NEAR(x[1], 0.5 + 0.15 + m, 1e-5);
    CHECK_NEAR(v[1], 0.1 / dt, 1e-3);
    hbk_fluid_destroy(h);
}

/* The dam break with its sphere and box: the box is carried into the fluid frame by frame. */
static hbk_fluid_t *pushed(int threads)
{
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    for (int a = 0; a < 3; ++a) p.resolution[a] = 24;
    p.threads = threads;
    p.max_particles = 4000;
    p.substeps = 10;
    p.seed = 1234;
    hbk_fluid_t *h = NULL;
    hbk_message_t msg;
    if (hbk_fluid_create(&h, &p, &msg) != HBK_OK) return NULL;
    const float lo[3] = {0.0f, 0.0f, 0.0f}, hi[3] = {0.3f, 0.3f, 0.3f};
    const hbk_fluid_obstacle_t obs[2] = {{0, {0.5f, 0.5f, 0.1f}, {0.1f, 0, 0}},
                                         {1, {0.7f, 0.15f, 0.1f}, {0.1f, 0.05f, 0.1f}}};
    if (hbk_fluid_fill_box(h, lo, hi, 0.2f) || hbk_fluid_set_obstacles(h, obs, 2)) {
        hbk_fluid_destroy(h);
        return NULL;
    }
    return h;
}

static hbk_result_t push_frame(hbk_fluid_t *h, int f, hbk_progress_t *pr)
{
    const hbk_fluid_obstacle_t obs[2] = {{0, {0.5f, 0.5f, 0.1f}, {0.1f, 0, 0}},
                                         {1, {0.7f - 0.06f * (float)f, 0.15f, 0.1f},
                                          {0.1f, 0.05f, 0.1f + 0.01f * (float)f}}};
    hbk_result_t r = hbk_fluid_move_obstacles(h, obs, 2);
    return r ? r : hbk_fluid_step(h, pr);
}

void test_fluid_obstacles_move_deterministic(void)
{
    hbk_fluid_t *a = pushed(1), *b = pushed(2), *still = pushed(2);
    CHECK(a && b && still);
    for (int f = 1; f <= 5; ++f) {
        CHECK_OK(push_frame(a, f, NULL));
        CHECK_OK(push_frame(b, f, NULL));
        CHECK_OK(hbk_fluid_step(still, NULL));
    }
    CHECK(fluid_same_state(a, b));
    CHECK(!fluid_same_state(a, still)); /* the box did push */
    /* No particle is left inside the box where the last step put it. */
    const int32_t n = hbk_fluid_particle_count(a);
    float *pos = malloc(3 * (size_t)n * sizeof *pos);
    CHECK(pos && hbk_fluid_get_particles(a, pos, NULL, n) == HBK_OK);
    const float c[3] = {0.7f - 0.3f, 0.15f, 0.1f}, e[3] = {0.1f, 0.05f, 0.15f};
    int inside = 0, near = 0;
    for (int32_t i = 0; i < n; ++i) {
        int in = 1, close = 1;
        for (int k = 0; k < 3; ++k) {
            const float d = fabsf(pos[3 * i + k] - c[k]);
            in &= d < e[k] + 0.0099f;
            close &= d < e[k] + 0.03f;
        }
        inside += in;
        near += close;
    }
    free(pos);
    CHECK(inside == 0 && near > 0);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
    hbk_fluid_destroy(still);
}

/* A cancelled step keeps the obstacles and the move pending; a checkpoint taken between moves
 * continues to the same bytes; set_obstacles drops a pending move. */
void test_fluid_obstacles_move_cancel_resume(void)
{
    hbk_fluid_t *a = pushed(2), *b = pushed(2), *c = pushed(2);
    CHECK(a && b && c);
    for (int f = 1; f <= 2; ++f) {
        CHECK_OK(push_frame(a, f, NULL));
        CHECK_OK(push_frame(b, f, NULL));
    }
    size_t s0, s1;
    unsigned char *x0 = fluid_state_of(b, &s0);
    CHECK(x0);
    hbk_progress_t pr = {1, 0.0f};
    CHECK(push_frame(b, 3, &pr) == HBK_ERR_CANCELLED);
    unsigned char *x1 = fluid_state_of(b, &s1);
    CHECK(x1 && s0 == s1 && !memcmp(x0, x1, s0)); /* obstacles where they were */
    CHECK_OK(hbk_fluid_step(b, NULL));             /* the pending move */
    CHECK_OK(hbk_fluid_load_state(c, x0, s0));
    for (int f = 3; f <= 4; ++f) {
        CHECK_OK(push_frame(a, f, NULL));
        if (f > 3) CHECK_OK(push_frame(b, f, NULL));
        CHECK_OK(push_frame(c, f, NULL));
    }
    CHECK(fluid_same_state(a, b) && fluid_same_state(a, c));
    /* Dropped by set_obstacles: a step after it is a still one. */
    hbk_fluid_t *d = pushed(2), *e = pushed(2);
    CHECK(d && e);
    const hbk_fluid_obstacle_t obs[2] = {{0, {0.5f, 0.5f, 0.1f}, {0.1f, 0, 0}},
                                         {1, {0.7f, 0.15f, 0.1f}, {0.1f, 0.05f, 0.1f}}};
    CHECK_OK(hbk_fluid_move_obstacles(d, (const hbk_fluid_obstacle_t[2]){obs[0], {1, {0.4f, 0.15f, 0.1f}, {0.1f, 0.05f, 0.1f}}}, 2));
    CHECK_OK(hbk_fluid_set_obstacles(d, obs, 2));
    CHECK_OK(hbk_fluid_step(d, NULL));
    CHECK_OK(hbk_fluid_step(e, NULL));
    CHECK(fluid_same_state(d, e));
    free(x0);
    free(x1);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
    hbk_fluid_destroy(c);
    hbk_fluid_destroy(d);
    hbk_fluid_destroy(e);
}

/* A fill leaves out the lattice points inside an obstacle (where the first step would throw
 * them out), and the others are where a fill without it puts them. */
void test_fluid_obstacles_fill_around(void)
{
    hbk_fluid_t *a = NULL, *b = NULL;
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    p.max_particles = 20000;
    hbk_message_t msg;
    CHECK_OK(hbk_fluid_create(&a, &p, &msg));
    CHECK_OK(hbk_fluid_create(&b, &p, &msg));
    const float lo[3] = {0.0f, 0.0f, 0.0f}, hi[3] = {0.4f, 0.4f, 0.2f};
    const hbk_fluid_obstacle_t obs[2] = {{0, {0.2f, 0.2f, 0.1f}, {0.06f, 0, 0}},
                                         {1, {0.35f, 0.05f, 0.1f}, {0.03f, 0.03f, 0.5f}}};
    CHECK_OK(hbk_fluid_set_obstacles(b, obs, 2));
    CHECK_OK(hbk_fluid_fill_box(a, lo, hi, 0.3f));
    CHECK_OK(hbk_fluid_fill_box(b, lo, hi, 0.3f));
    const int32_t na = hbk_fluid_particle_count(a), nb = hbk_fluid_particle_count(b);
    fprintf(stderr, "filled %d, around the obstacles %d\n", na, nb);
    CHECK(na >= 19 * 19 * 9 && nb < na - 250); /* about 180 in the ball, 160 in the post */
    float *pa = malloc(3 * (size_t)na * sizeof *pa), *pb = malloc(3 * (size_t)nb * sizeof *pb);
    CHECK(pa && pb);
    CHECK_OK(hbk_fluid_get_particles(a, pa, NULL, na));
    CHECK_OK(hbk_fluid_get_particles(b, pb, NULL, nb));
    int32_t k = 0, kept = 0;
    for (int32_t i = 0; i < na; ++i) {
        const float *x = pa + 3 * i;
        const float ds = hypotf(hypotf(x[0] - 0.2f, x[1] - 0.2f), x[2] - 0.1f);
        const int in = ds < 0.07f || (fabsf(x[0] - 0.35f) < 0.04f && fabsf(x[1] - 0.05f) < 0.04f);
        if (in) continue;
        CHECK(k < nb && !memcmp(x, pb + 3 * k, 3 * sizeof *x)); /* the same, in order */
        ++k;
        ++kept;
    }
    CHECK(k == nb && kept == nb);
    free(pa);
    free(pb);
    /* The count that must fit is of the points kept. */
    hbk_fluid_destroy(a);
    p.max_particles = nb;
    CHECK_OK(hbk_fluid_create(&a, &p, &msg));
    CHECK_OK(hbk_fluid_set_obstacles(a, obs, 2));
    CHECK_OK(hbk_fluid_fill_box(a, lo, hi, 0.3f));
    CHECK(hbk_fluid_particle_count(a) == nb);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
}
