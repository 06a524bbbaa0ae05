/* The outflow (hbk_fluid_set_outflow): refused by name with the handle unchanged; it takes
 * exactly the particles that enter its shape (a box, a sphere, a mesh's inside, not its
 * field's corners), the others keeping their order; count = before + poured - drained at every
 * step; a tap into a drain pours for good, never reaching max_particles; a cancelled step
 * gives the drained particles back; the same bytes at any thread count. */
#include "test.h"
#include <stdlib.h>

/* Two rows of 8 lone particles (10 cm apart, beyond each other's reach of 4 cm: no force
 * acts, they coast) along x from 0.15 to 0.85 at z = 0.5, y = y0 and y = y1, moving at
 * 0.5 m/s along x: a frame takes each 2.08 cm further. */
enum { ROW = 8 };
static hbk_fluid_t *coasting(float y0, float y1)
{
    hbk_fluid_params_t p = fluid_still_box(100);
    hbk_fluid_t *h = fluid_make(&p);
    float x[2 * ROW * 3], v[2 * ROW * 3];
    for (int r = 0; r < 2; ++r)
        for (int i = 0; i < ROW; ++i) {
            float *q = x + 3 * (r * ROW + i), *u = v + 3 * (r * ROW + i);
            q[0] = 0.15f + 0.1f * (float)i, q[1] = r ? y1 : y0, q[2] = 0.5f;
            u[0] = 0.5f, u[1] = u[2] = 0.0f;
        }
    if (h && hbk_fluid_set_particles(h, x, v, 2 * ROW) != HBK_OK) {
        hbk_fluid_destroy(h);
        return NULL;
    }
    return h;
}

/* One frame of the coasting rows through `shape`: exactly the particles starting at x = 0.55
 * and 0.65 of the row at y0 go (they end within 0.03 and 0.07 m of x = 0.6, the others 0.13
 * or more away), the rest in their order, each where coasting takes it. */
static void drains_its_inside(const hbk_fluid_obstacle_t *shape, const int32_t *dims,
                              const float *field, float y0, float y1)
{
    hbk_fluid_t *h = coasting(y0, y1);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_outflow(h, shape, dims, field));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_outflow_removed(h) == 2);
    const int32_t n = hbk_fluid_particle_count(h);
    CHECK(n == 2 * ROW - 2);
    float x[2 * ROW * 3], v[2 * ROW * 3];
    CHECK_OK(hbk_fluid_get_particles(h, x, v, n));
    int k = 0;
    const float moved = 0.5f / 24.0f;
    for (int r = 0; r < 2; ++r)
        for (int i = 0; i < ROW; ++i) {
            if (r == 0 && (i == 4 || i == 5)) continue;
            if (k >= n) break;
            const float *q = x + 3 * k, *u = v + 3 * k;
            CHECK(fabsf(q[0] - (0.15f + 0.1f * (float)i + moved)) < 1e-5f);
            CHECK(q[1] == (r ? y1 : y0) && q[2] == 0.5f);
            CHECK(u[0] == 0.5f && u[1] == 0.0f && u[2] == 0.0f);
            ++k;
        }
    CHECK(k == n);
    hbk_fluid_destroy(h);
}

void test_fluid_outflow_drains_its_inside(void)
{
    /* an axis-aligned box over x in (0.5, 0.7) around the row at y = 0.5 */
    const hbk_fluid_obstacle_t box = {1, {0.6f, 0.5f, 0.5f}, {0.1f, 0.1f, 0.1f}, {1, 0, 0, 0}};
    drains_its_inside(&box, NULL, NULL, 0.5f, 0.2f);
    const hbk_fluid_obstacle_t ball = {0, {0.6f, 0.3f, 0.5f}, {0.08f, 0, 0}, {0}};
    drains_its_inside(&ball, NULL, NULL, 0.3f, 0.6f);
    /* a mesh: a sphere of 8 cm in a field box of 10 cm half-sizes, turned 90 degrees about
     * z; the row 9 cm off its centre crosses the box but not the sphere */
    const float e[3] = {0.1f, 0.1f, 0.1f}, c = 0.70710678f;
    const int32_t dims[3] = {33, 33, 33};
    float *f = fluid_sdf_field(SDF_SPHERE, e, 33, 0.08, 0, 0);
    CHECK(f);
    const hbk_fluid_obstacle_t mesh = {3, {0.6f, 0.5f, 0.5f}, {0.1f, 0.1f, 0.1f}, {c, 0, 0, c}};
    drains_its_inside(&mesh, dims, f, 0.5f, 0.59f);
    free(f);
}

/* The coasting rows over three frames through a box (x in (0.5, 0.7)): the frame each
 * particle enters is the one it goes (2, then 0, then the one from 0.45, at 0.5125 by then);
 * stopped (NULL), nothing more goes. */
void test_fluid_outflow_frame_by_frame(void)
{
    const hbk_fluid_obstacle_t box = {1, {0.6f, 0.5f, 0.5f}, {0.1f, 0.1f, 0.1f}, {1, 0, 0, 0}};
    hbk_fluid_t *h = coasting(0.5f, 0.2f);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_outflow(h, &box, NULL, NULL));
    const int32_t want[3] = {2, 0, 1};
    for (int f = 0; f < 3; ++f) {
        const int32_t before = hbk_fluid_particle_count(h);
        CHECK_OK(hbk_fluid_step(h, NULL));
        CHECK(hbk_fluid_outflow_removed(h) == want[f]);
        CHECK(hbk_fluid_particle_count(h) == before - want[f]);
    }
    CHECK_OK(hbk_fluid_set_outflow(h, NULL, NULL, NULL));
    for (int f = 0; f < 3; ++f) { /* 0.35 would reach it by the sixth frame */
        CHECK_OK(hbk_fluid_step(h, NULL));
        CHECK(hbk_fluid_outflow_removed(h) == 0);
    }
    CHECK(hbk_fluid_particle_count(h) == 2 * ROW - 3);
    hbk_fluid_destroy(h);
}

void test_fluid_outflow_refused(void)
{
    const hbk_fluid_obstacle_t box = {1, {0.6f, 0.5f, 0.5f}, {0.1f, 0.1f, 0.1f}, {1, 0, 0, 0}};
    hbk_fluid_params_t p = fluid_still_box(100);
    p.source = HBK_FLUID_PARTICLES;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    CHECK(hbk_fluid_set_outflow(h, &box, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "outflow: source = 1: only the simulation"));
    hbk_fluid_destroy(h);
    CHECK(hbk_fluid_set_outflow(NULL, &box, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(hbk_fluid_outflow_removed(NULL) == 0);

    /* A good drain first: every refusal after it must leave it (and the state) as it was. */
    h = coasting(0.5f, 0.2f);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_outflow(h, &box, NULL, NULL));
    size_t s0, s1;
    unsigned char *before = fluid_state_of(h, &s0);
    CHECK(before);
    hbk_fluid_obstacle_t ob = box;
    ob.type = 5;
    CHECK(hbk_fluid_set_outflow(h, &ob, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "shape.type = 5: must be 0 (sphere)"));
    ob.type = 2, ob.rotation[0] = 2.0f;
    CHECK(hbk_fluid_set_outflow(h, &ob, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "shape.rotation: length 2, must be a unit quaternion"));
    ob.type = 1, ob.rotation[0] = 1.0f, ob.extent[1] = -0.1f;
    CHECK(hbk_fluid_set_outflow(h, &ob, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "shape.extent[1] = -0.1"));
    ob.type = 3, ob.extent[1] = 0.1f;
    CHECK(hbk_fluid_set_outflow(h, &ob, NULL, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "dims: must not be NULL"));
    const int32_t dims[3] = {2, 2, 2}, bad[3] = {2, 1, 2};
    CHECK(hbk_fluid_set_outflow(h, &ob, dims, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "distance: must not be NULL"));
    float f[8] = {-1, -1, -1, -1, -1, -1, -1, NAN};
    CHECK(hbk_fluid_set_outflow(h, &ob, bad, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "dims[1] = 1: must be in [2, 128]"));
    CHECK(hbk_fluid_set_outflow(h, &ob, dims, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "distance[7] = nan: must be a finite number"));
    unsigned char *after = fluid_state_of(h, &s1);
    CHECK(after && s1 == s0 && !memcmp(before, after, s0));
    free(before);
    free(after);
    CHECK_OK(hbk_fluid_step(h, NULL)); /* still the first box's drain */
    CHECK(hbk_fluid_outflow_removed(h) == 2);
    hbk_fluid_destroy(h);
}

/* A tap (16 points at 1 m/s along x, 33 particles a frame) over a drain on the floor where
 * its stream lands: 60 frames pour about 2000 particles into a fluid of at most 600 and it
 * never stops pouring; at every frame count = before + poured - drained. The same bytes at
 * 1 and 2 threads. */
static const hbk_fluid_obstacle_t TAP = {1, {0.2f, 0.5f, 0.5f}, {0.015f, 0.045f, 0.045f}, {0}};
static const hbk_fluid_obstacle_t FLOOR_DRAIN = {1, {0.6f, 0.5f, 0.0f}, {0.3f, 0.5f, 0.15f},
                                                 {1, 0, 0, 0}};

static hbk_fluid_t *tap_and_drain(int32_t threads)
{
    hbk_fluid_params_t p = fluid_still_box(600);
    p.gravity[2] = -9.81f;
    p.threads = threads;
    hbk_fluid_t *h = fluid_make(&p);
    const float vel[3] = {1, 0, 0};
    if (!h || hbk_fluid_set_inflow(h, &TAP, NULL, NULL, vel, 0.2f) != HBK_OK ||
        hbk_fluid_set_outflow(h, &FLOOR_DRAIN, NULL, NULL) != HBK_OK) {
        hbk_fluid_destroy(h);
        return NULL;
    }
    return h;
}

void test_fluid_outflow_tap_and_drain(void)
{
    hbk_fluid_t *h = tap_and_drain(1), *twin = tap_and_drain(2);
    CHECK(h && twin);
    int32_t poured = 0, drained = 0, most = 0;
    for (int f = 0; f < 60; ++f) {
        const int32_t before = hbk_fluid_particle_count(h);
        CHECK_OK(hbk_fluid_step(h, NULL));
        CHECK_OK(hbk_fluid_step(twin, NULL));
        int32_t capped = -1;
        const int32_t added = hbk_fluid_inflow_added(h, &capped);
        const int32_t removed = hbk_fluid_outflow_removed(h);
        CHECK(capped == 0);
        CHECK(hbk_fluid_particle_count(h) == before + added - removed);
        poured += added, drained += removed;
        most = hbk_fluid_particle_count(h) > most ? hbk_fluid_particle_count(h) : most;
    }
    fprintf(stderr, "tap and drain: %d poured, %d drained, at most %d at once\n", poured,
            drained, most);
    CHECK(poured > 1500 && drained > poured - 600 && most < 600);
    CHECK(fluid_same_state(h, twin));
    hbk_fluid_destroy(h);
    hbk_fluid_destroy(twin);
}

/* Cancelled after a substep drained some of a pool standing in the drain: the particles come
 * back to the byte and the count drained is 0; the step done again is the twin's. */
static hbk_fluid_t *pool_in_the_drain(void)
{
    hbk_fluid_params_t p = fluid_still_box(4000);
    p.gravity[2] = -9.81f;
    hbk_fluid_t *h = fluid_make(&p);
    const float lo[3] = {0.2f, 0.3f, 0.0f}, hi[3] = {0.6f, 0.7f, 0.1f};
    if (!h || hbk_fluid_fill_box(h, lo, hi, 0.2f) != HBK_OK ||
        hbk_fluid_step(h, NULL) != HBK_OK || /* the pool moving */
        hbk_fluid_set_outflow(h, &FLOOR_DRAIN, NULL, NULL) != HBK_OK) {
        hbk_fluid_destroy(h);
        return NULL;
    }
    return h;
}

void test_fluid_outflow_cancel(void)
{
    int midway = 0;
    for (int attempt = 0; attempt < 20 && !midway; ++attempt) {
        hbk_fluid_t *h = pool_in_the_drain(), *twin = pool_in_the_drain();
        CHECK(h && twin);
        const int32_t n0 = hbk_fluid_particle_count(h);
        unsigned char *st0 = NULL, *st1 = NULL;
        size_t s0 = 0, s1 = 0;
        CHECK((st0 = fluid_state_of(h, &s0)) != NULL);
        const hbk_result_t r = fluid_step_cancelled(h, &midway); /* (a substep had drained) */
        if (r == HBK_ERR_CANCELLED) {
            CHECK(hbk_fluid_particle_count(h) == n0);
            CHECK((st1 = fluid_state_of(h, &s1)) != NULL);
            CHECK(s1 == s0 && !memcmp(st0, st1, s0));
            CHECK(hbk_fluid_outflow_removed(h) == 0);
            CHECK_OK(hbk_fluid_step(h, NULL));
            CHECK(hbk_fluid_outflow_removed(h) > 0);
            CHECK_OK(hbk_fluid_step(twin, NULL));
            CHECK(fluid_same_state(h, twin));
        } else {
            CHECK_OK(r); /* done before the watcher saw it: again */
        }
        free(st0);
        free(st1);
        hbk_fluid_destroy(h);
        hbk_fluid_destroy(twin);
    }
    CHECK(midway);
}
