/* Drains added (hbk_fluid_add_outflow): two drains take exactly the particles entering either
 * (each what it takes alone), the others keeping their order; set_outflow replaces them all;
 * a bad one is refused by name with the drains left as they were. */
#include "test.h"
#include <stdlib.h>
#include <string.h>

/* A row of 8 lone particles along x from 0.15 to 0.85 (10 cm apart: no force acts) at y 0.5,
 * z 0.5, coasting at 0.5 m/s along x. */
enum { ROW = 8 };
static hbk_fluid_t *row(void)
{
    hbk_fluid_params_t p = fluid_still_box(100);
    hbk_fluid_t *h = fluid_make(&p);
    float x[ROW * 3], v[ROW * 3];
    for (int i = 0; i < ROW; ++i) {
        x[3 * i] = 0.15f + 0.1f * (float)i, x[3 * i + 1] = x[3 * i + 2] = 0.5f;
        v[3 * i] = 0.5f, v[3 * i + 1] = v[3 * i + 2] = 0.0f;
    }
    if (h && hbk_fluid_set_particles(h, x, v, ROW) != HBK_OK) {
        hbk_fluid_destroy(h);
        return NULL;
    }
    return h;
}

/* Boxes around the particles from x 0.25 (i = 1) and 0.65 (i = 5) after a frame's 2 cm. */
static const hbk_fluid_obstacle_t LEFT = {1, {0.27f, 0.5f, 0.5f}, {0.03f, 0.05f, 0.05f}, {0}};
static const hbk_fluid_obstacle_t BALL = {0, {0.67f, 0.5f, 0.5f}, {0.03f, 0, 0}, {0}};

/* The x of the particles left after a frame with the drains `which` (bit 0: LEFT, 1: BALL);
 * their count in *n. */
static int32_t left_after(int which, float *xs)
{
    hbk_fluid_t *h = row();
    int32_t n = -1;
    if (!h) return n;
    int ok = 1;
    if (which & 1) ok &= hbk_fluid_add_outflow(h, &LEFT, NULL, NULL) == HBK_OK;
    if (which & 2) ok &= hbk_fluid_add_outflow(h, &BALL, NULL, NULL) == HBK_OK;
    float x[ROW * 3], v[ROW * 3];
    if (ok && hbk_fluid_step(h, NULL) == HBK_OK) {
        n = hbk_fluid_particle_count(h);
        if (hbk_fluid_get_particles(h, x, v, n) == HBK_OK)
            for (int32_t i = 0; i < n; ++i) xs[i] = x[3 * i];
        if (hbk_fluid_outflow_removed(h) != ROW - n) n = -2;
    }
    hbk_fluid_destroy(h);
    return n;
}

void test_fluid_outflows_added(void)
{
    float a[ROW], b[ROW], ab[ROW];
    CHECK(left_after(1, a) == ROW - 1); /* each takes its one particle */
    CHECK(left_after(2, b) == ROW - 1);
    CHECK(left_after(3, ab) == ROW - 2); /* both take both */
    const float moved = 0.5f / 24.0f;
    int k = 0;
    for (int i = 0; i < ROW; ++i) {
        if (i == 1 || i == 5) continue;
        CHECK(k < ROW - 2 && fabsf(ab[k] - (0.15f + 0.1f * (float)i + moved)) < 1e-5f);
        ++k;
    }
    CHECK(fabsf(a[0] - (0.15f + moved)) < 1e-5f && fabsf(a[1] - (0.35f + moved)) < 1e-5f);
    CHECK(fabsf(b[4] - (0.55f + moved)) < 1e-5f && fabsf(b[5] - (0.75f + moved)) < 1e-5f);
}

void test_fluid_outflows_replaced_and_refused(void)
{
    hbk_fluid_t *h = row();
    CHECK(h);
    if (!h) return;
    CHECK_OK(hbk_fluid_add_outflow(h, &LEFT, NULL, NULL));
    CHECK_OK(hbk_fluid_add_outflow(h, &BALL, NULL, NULL));
    const hbk_fluid_obstacle_t bad = {0, {0.5f, 0.5f, 0.5f}, {-1.0f, 0, 0}, {0}};
    CHECK(hbk_fluid_add_outflow(h, NULL, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strcmp(hbk_fluid_message(h), "shape: must not be NULL") == 0);
    CHECK(hbk_fluid_add_outflow(h, &bad, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "shape.") == hbk_fluid_message(h));
    CHECK(hbk_fluid_set_outflow(h, &bad, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
    /* the two kept through the refusals: a frame takes both particles */
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_outflow_removed(h) == 2);
    hbk_fluid_destroy(h);
    /* set_outflow replaces them: only the ball's particle goes */
    h = row();
    CHECK(h);
    if (!h) return;
    CHECK_OK(hbk_fluid_add_outflow(h, &LEFT, NULL, NULL));
    CHECK_OK(hbk_fluid_set_outflow(h, &BALL, NULL, NULL));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_outflow_removed(h) == 1 && hbk_fluid_particle_count(h) == ROW - 1);
    /* and set_outflow(NULL) stops them all */
    CHECK_OK(hbk_fluid_add_outflow(h, &LEFT, NULL, NULL));
    CHECK_OK(hbk_fluid_set_outflow(h, NULL, NULL, NULL));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_outflow_removed(h) == 0);
    hbk_fluid_destroy(h);
    hbk_fluid_params_t g = fluid_still_box(100);
    g.source = HBK_FLUID_PARTICLES;
    hbk_fluid_t *other = fluid_make(&g);
    CHECK(other);
    if (other) {
        CHECK(hbk_fluid_add_outflow(other, &LEFT, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
        CHECK(strcmp(hbk_fluid_message(other),
                     "outflow: source = 1: only the simulation (0) drains an outflow") == 0);
        hbk_fluid_destroy(other);
    }
}
