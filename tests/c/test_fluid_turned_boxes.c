/* Turned boxes: a quarter turn is the axis-aligned box with its sides swapped; a particle on a
 * tilted board slides down it at g sin(theta) and stays half a spacing off it; a paddle turning
 * about its end carries what it meets at omega times the arm; a dam break with a turning paddle
 * bakes the same bytes at any thread count; a fill leaves the inside out; and a state of the
 * version before rotations (28-byte obstacles) still loads. */
#include "test.h"
#include "fluid/internal_fluid.h"
#include <stdlib.h>

/* A turn of `angle` about unit axis (x, y, z) as (w, x, y, z). */
static void about(float q[4], float x, float y, float z, double angle)
{
    const double s = sin(0.5 * angle);
    q[0] = (float)cos(0.5 * angle);
    q[1] = (float)(x * s), q[2] = (float)(y * s), q[3] = (float)(z * s);
}

/* Where one step leaves a particle started at x with velocity v, near obstacle ob. */
static void one_step(const hbk_fluid_obstacle_t *ob, const float x0[3], const float v0[3],
                     float x[3], float v[3])
{
    hbk_fluid_t *h = fluid_lone(0.0f, 8, 0);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_obstacles(h, ob, 1));
    CHECK_OK(hbk_fluid_set_particles(h, x0, v0, 1));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK_OK(hbk_fluid_get_particles(h, x, v, 1));
    hbk_fluid_destroy(h);
}

void test_fluid_turned_box_quarter(void)
{
    hbk_fluid_obstacle_t turned = {2, {0.5f, 0.5f, 0.5f}, {0.2f, 0.05f, 0.1f}, {1, 0, 0, 0}};
    about(turned.rotation, 0, 0, 1, M_PI / 2);
    const hbk_fluid_obstacle_t plain = {1, {0.5f, 0.5f, 0.5f}, {0.05f, 0.2f, 0.1f}, {0}};
    /* inside near each face, outside, and moving into the box */
    const float starts[5][3] = {{0.53f, 0.6f, 0.5f},
                                {0.5f, 0.31f, 0.55f},
                                {0.45f, 0.5f, 0.58f},
                                {0.6f, 0.5f, 0.5f},
                                {0.56f, 0.3f, 0.5f}};
    const float vel[3] = {-0.5f, 0.3f, 0.1f};
    for (int i = 0; i < 5; ++i) {
        float xa[3], va[3], xb[3], vb[3];
        one_step(&turned, starts[i], vel, xa, va);
        one_step(&plain, starts[i], vel, xb, vb);
        for (int k = 0; k < 3; ++k) {
            CHECK_NEAR(xa[k], xb[k], 2e-6);
            CHECK_NEAR(va[k], vb[k], 2e-5);
        }
    }
}

void test_fluid_turned_box_ramp(void)
{
    const double th = 30.0 * M_PI / 180.0, m = 0.01;
    hbk_fluid_obstacle_t board = {2, {0.5f, 0.5f, 0.4f}, {0.4f, 0.3f, 0.02f}, {1, 0, 0, 0}};
    about(board.rotation, 0, 1, 0, th);
    /* its top face's normal (sin, 0, cos) and its downhill direction (cos, 0, -sin) */
    const double n[3] = {sin(th), 0.0, cos(th)}, d[3] = {cos(th), 0.0, -sin(th)};
    float x[3], v[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) x[k] = (float)(board.center[k] - 0.3 * d[k] + (0.02 + m) * n[k]);
    hbk_fluid_t *h = fluid_lone(-9.81f, 8, 0);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_obstacles(h, &board, 1));
    CHECK_OK(hbk_fluid_set_particles(h, x, v, 1));
    const int frames = 6;
    for (int f = 0; f < frames; ++f) CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK_OK(hbk_fluid_get_particles(h, x, v, 1));
    double vn = 0.0, vd = 0.0, height = 0.0, along = 0.0;
    for (int k = 0; k < 3; ++k) {
        vn += v[k] * n[k];
        vd += v[k] * d[k];
        height += (x[k] - board.center[k]) * n[k];
        along += (x[k] - board.center[k]) * d[k];
    }
    const double t = frames / 24.0;
    CHECK_NEAR(vn, 0.0, 1e-4);                  /* it slides, neither in nor off */
    CHECK_NEAR(height, 0.02 + m, 1e-5);         /* half a spacing above the face */
    CHECK_NEAR(vd, 9.81 * sin(th) * t, 1e-3);   /* free slip: g sin(theta) downhill */
    CHECK(along > -0.3 + 0.4 * 9.81 * sin(th) * t * t && along < -0.3 + 0.6 * 9.81 * sin(th) * t * t);
    CHECK(fabsf(v[1]) == 0.0f);
    hbk_fluid_destroy(h);
}

/* A paddle (long along its own x) turning about z around its centre at omega meets a particle
 * ahead of it; from then on the particle rides its face at omega times its distance along the
 * paddle, measured where it ends. */
void test_fluid_turned_box_paddle(void)
{
    const double omega = 3.0, dt = 1.0 / 24.0, m = 0.01;
    hbk_fluid_obstacle_t paddle = {2, {0.5f, 0.5f, 0.5f}, {0.3f, 0.02f, 0.1f}, {1, 0, 0, 0}};
    hbk_fluid_t *h = fluid_lone(0.0f, 8, 0);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_obstacles(h, &paddle, 1));
    const double a0 = 0.35; /* ahead of the face, 0.2 m out */
    float x[3] = {(float)(0.5 + 0.2 * cos(a0)), (float)(0.5 + 0.2 * sin(a0)), 0.5f};
    float v[3] = {0, 0, 0};
    CHECK_OK(hbk_fluid_set_particles(h, x, v, 1));
    const int frames = 4; /* 0.5 rad: it is reached in the second frame */
    for (int f = 1; f <= frames; ++f) {
        about(paddle.rotation, 0, 0, 1, omega * dt * f);
        CHECK_OK(hbk_fluid_move_obstacles(h, &paddle, 1));
        CHECK_OK(hbk_fluid_step(h, NULL));
    }
    CHECK_OK(hbk_fluid_get_particles(h, x, v, 1));
    const double phi = omega * dt * frames;
    const double ax[3] = {cos(phi), sin(phi), 0}, n[3] = {-sin(phi), cos(phi), 0};
    double lx = 0.0, ly = 0.0, vn = 0.0;
    for (int k = 0; k < 3; ++k) {
        lx += (x[k] - 0.5) * ax[k];
        ly += (x[k] - 0.5) * n[k];
        vn += v[k] * n[k];
    }
    CHECK_NEAR(ly, 0.02 + m, 1e-5); /* on the face it was met by */
    CHECK(lx > 0.19 && lx < 0.3);
    CHECK_NEAR(vn, omega * lx, 2e-3);
    CHECK(x[2] == 0.5f && v[2] == 0.0f);
    /* the turn is the shorter way: a quaternion given as its negative turns no differently */
    hbk_fluid_t *g = fluid_lone(0.0f, 8, 0);
    CHECK(g);
    hbk_fluid_obstacle_t flipped = paddle;
    about(flipped.rotation, 0, 0, 1, omega * dt * frames);
    CHECK_OK(hbk_fluid_set_obstacles(g, &flipped, 1));
    CHECK_OK(hbk_fluid_set_particles(g, x, v, 1));
    CHECK_OK(hbk_fluid_set_obstacles(h, &flipped, 1));
    about(flipped.rotation, 0, 0, 1, omega * dt * (frames + 1));
    hbk_fluid_obstacle_t neg = flipped;
    for (int k = 0; k < 4; ++k) neg.rotation[k] = -neg.rotation[k];
    CHECK_OK(hbk_fluid_move_obstacles(h, &flipped, 1));
    CHECK_OK(hbk_fluid_move_obstacles(g, &neg, 1));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK_OK(hbk_fluid_step(g, NULL));
    float xh[3], vh[3], xg[3], vg[3];
    CHECK_OK(hbk_fluid_get_particles(h, xh, vh, 1));
    CHECK_OK(hbk_fluid_get_particles(g, xg, vg, 1));
    for (int k = 0; k < 3; ++k) {
        CHECK_NEAR(xh[k], xg[k], 1e-6);
        CHECK_NEAR(vh[k], vg[k], 1e-4);
    }
    CHECK_NEAR(vh[0] * -sin(phi + omega * dt) + vh[1] * cos(phi + omega * dt), omega * 0.2, 0.1);
    hbk_fluid_destroy(g);
    hbk_fluid_destroy(h);
}

/* The dam break with a paddle turning through it about y. */
static hbk_fluid_t *stirred(int threads)
{
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    for (int a = 0; a < 3; ++a) p.resolution[a] = 24;
    p.threads = threads;
    p.max_particles = 6000;
    p.substeps = 10;
    p.seed = 99;
    hbk_fluid_t *h = NULL;
    hbk_message_t msg;
    if (hbk_fluid_create(&h, &p, &msg) != HBK_OK) return NULL;
    const float lo[3] = {0.0f, 0.0f, 0.0f}, hi[3] = {0.4f, 0.3f, 0.3f};
    hbk_fluid_obstacle_t ob = {2, {0.2f, 0.15f, 0.15f}, {0.12f, 0.1f, 0.015f}, {1, 0, 0, 0}};
    if (hbk_fluid_set_obstacles(h, &ob, 1) || hbk_fluid_fill_box(h, lo, hi, 0.2f)) {
        hbk_fluid_destroy(h);
        return NULL;
    }
    return h;
}

static hbk_fluid_obstacle_t stir_at(int f)
{
    hbk_fluid_obstacle_t ob = {2, {0.2f, 0.15f, 0.15f}, {0.12f, 0.1f, 0.015f}, {1, 0, 0, 0}};
    about(ob.rotation, 0, 1, 0, 0.25 * f);
    return ob;
}

static int in_box(const hbk_fluid_obstacle_t *ob, const float *x, float margin)
{
    float ax[9];
    const float *q = ob->rotation;
    const float w = q[0], a = q[1], b = q[2], c = q[3];
    const float m[9] = {1 - 2 * (b * b + c * c), 2 * (a * b + w * c), 2 * (a * c - w * b),
                        2 * (a * b - w * c), 1 - 2 * (a * a + c * c), 2 * (b * c + w * a),
                        2 * (a * c + w * b), 2 * (b * c - w * a), 1 - 2 * (a * a + b * b)};
    memcpy(ax, m, sizeof ax);
    for (int k = 0; k < 3; ++k) {
        const float l = ax[3 * k] * (x[0] - ob->center[0]) + ax[3 * k + 1] * (x[1] - ob->center[1]) +
                        ax[3 * k + 2] * (x[2] - ob->center[2]);
        if (!(fabsf(l) < ob->extent[k] + margin)) return 0;
    }
    return 1;
}

void test_fluid_turned_box_stirred(void)
{
    hbk_fluid_t *a = stirred(1), *b = stirred(2);
    CHECK(a && b);
    /* the fill left the paddle's inside out (and half a spacing around it) */
    int32_t n = hbk_fluid_particle_count(a);
    float *pos = malloc(3 * (size_t)n * sizeof *pos);
    CHECK(pos && hbk_fluid_get_particles(a, pos, NULL, n) == HBK_OK);
    const hbk_fluid_obstacle_t first = stir_at(0);
    int inside = 0;
    for (int32_t i = 0; i < n; ++i) inside += in_box(&first, pos + 3 * i, 0.0099f);
    CHECK(inside == 0 && n < 20 * 15 * 15 - 150);
    for (int f = 1; f <= 5; ++f) {
        const hbk_fluid_obstacle_t ob = stir_at(f);
        CHECK_OK(hbk_fluid_move_obstacles(a, &ob, 1));
        CHECK_OK(hbk_fluid_move_obstacles(b, &ob, 1));
        CHECK_OK(hbk_fluid_step(a, NULL));
        CHECK_OK(hbk_fluid_step(b, NULL));
    }
    size_t sa, sb;
    unsigned char *xa = fluid_state_of(a, &sa), *xb = fluid_state_of(b, &sb);
    CHECK(xa && xb && sa == sb && !memcmp(xa, xb, sa));
    free(xa);
    free(xb);
    const hbk_fluid_obstacle_t last = stir_at(5);
    CHECK(hbk_fluid_get_particles(a, pos, NULL, n) == HBK_OK);
    int near = 0;
    for (int32_t i = 0; i < n; ++i) {
        inside += in_box(&last, pos + 3 * i, 0.0099f);
        near += in_box(&last, pos + 3 * i, 0.03f);
    }
    CHECK(inside == 0 && near > 50);
    free(pos);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
}

/* A version 1 state (obstacles as 28-byte records, no rotation, no fields) loads: the same
 * handle as the state it was made from. Versions past 3 are refused by number. */
void test_fluid_turned_box_state_v1(void)
{
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    for (int a = 0; a < 3; ++a) p.resolution[a] = 16;
    p.max_particles = 2000;
    hbk_fluid_t *a = NULL, *b = NULL;
    hbk_message_t msg;
    CHECK_OK(hbk_fluid_create(&a, &p, &msg));
    CHECK_OK(hbk_fluid_create(&b, &p, &msg));
    const hbk_fluid_obstacle_t obs[2] = {{0, {0.5f, 0.5f, 0.2f}, {0.1f, 0, 0}, {1, 0, 0, 0}},
                                         {1, {0.2f, 0.3f, 0.1f}, {0.05f, 0.1f, 0.1f}, {1, 0, 0, 0}}};
    const float lo[3] = {0.0f, 0.0f, 0.0f}, hi[3] = {0.3f, 0.3f, 0.1f};
    CHECK_OK(hbk_fluid_set_obstacles(a, obs, 2));
    CHECK_OK(hbk_fluid_fill_box(a, lo, hi, 0.2f));
    CHECK_OK(hbk_fluid_step(a, NULL));
    size_t s2;
    unsigned char *v2 = fluid_state_of(a, &s2);
    CHECK(v2);
    const int32_t count = hbk_fluid_particle_count(a);
    const size_t at = 64 + 24 * (size_t)count; /* header, positions, velocities */
    const size_t rec = sizeof(hbk_fluid_obstacle_t), old = 28;
    CHECK(rec == 44);
    const size_t tail = 12 * HBK_FLUID_MAX_OBSTACLES; /* version 3's field dims, all 0 */
    const size_t s1 = s2 - HBK_FLUID_MAX_OBSTACLES * (rec - old) - tail;
    unsigned char *v1 = calloc(1, s1);
    CHECK(v1);
    memcpy(v1, v2, at);
    const uint32_t one = 1;
    memcpy(v1 + 8, &one, 4);
    for (int i = 0; i < HBK_FLUID_MAX_OBSTACLES; ++i)
        memcpy(v1 + at + old * i, v2 + at + rec * i, old);
    memcpy(v1 + at + old * HBK_FLUID_MAX_OBSTACLES, v2 + at + rec * HBK_FLUID_MAX_OBSTACLES,
           s2 - at - rec * HBK_FLUID_MAX_OBSTACLES - tail);
    CHECK_OK(hbk_fluid_load_state(b, v1, s1));
    size_t sb;
    unsigned char *back = fluid_state_of(b, &sb);
    CHECK(back && sb == s2 && !memcmp(back, v2, s2));
    /* a version 1 state is exactly its size: more is a later state under an old number */
    CHECK(hbk_fluid_load_state(b, v2, s2) == HBK_OK);
    unsigned char *longer = malloc(s2);
    CHECK(longer);
    memcpy(longer, v1, s1);
    CHECK(hbk_fluid_load_state(b, longer, s1 + 1) == HBK_ERR_FORMAT);
    CHECK(strstr(hbk_fluid_message(b), "a version 1 state of this header is exactly"));
    memcpy(v2 + 8, &one, 4); /* the current state under version 1: refused by its size */
    CHECK(hbk_fluid_load_state(b, v2, s2) == HBK_ERR_FORMAT);
    free(longer);
    /* an old record of a type it did not have is refused */
    const int32_t two = 2;
    memcpy(v1 + at, &two, 4);
    CHECK(hbk_fluid_load_state(b, v1, s1) == HBK_ERR_FORMAT);
    CHECK(strstr(hbk_fluid_message(b), "obstacles"));
    const uint32_t four = 4;
    memcpy(v2 + 8, &four, 4);
    CHECK(hbk_fluid_load_state(b, v2, s2) == HBK_ERR_FORMAT);
    CHECK(strstr(hbk_fluid_message(b), "state version = 4: this library reads 1 to 3"));
    free(v1);
    free(v2);
    free(back);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
}
