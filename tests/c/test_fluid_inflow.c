/* The inflow (hbk_fluid_set_inflow): refused by name with the handle unchanged; it pours
 * k x k lattice points' worth of water at v (k^2 v dt / spacing a frame), each particle
 * starting at the velocity inside the shape, none nearer than a spacing to the water there,
 * none inside an obstacle, never past max_particles; a cancelled step takes its particles
 * back; the same bytes at any thread count. */
#include "test.h"
#include <stdlib.h>

/* Positions and velocities (malloc'd, 3 floats each per particle; count in *n). */
static float *particles(hbk_fluid_t *h, int32_t *n, float **vel)
{
    *n = hbk_fluid_particle_count(h);
    const size_t bytes = 3 * (size_t)(*n > 0 ? *n : 1) * sizeof(float);
    float *p = malloc(bytes), *v = malloc(bytes);
    if (!p || !v || hbk_fluid_get_particles(h, p, v, *n) != HBK_OK) {
        free(p);
        free(v);
        return NULL;
    }
    if (vel) *vel = v;
    else free(v);
    return p;
}

/* A tap across the flow along x: one lattice point thick in x (at 0.195), k = 4 points a
 * side in y and z (0.465 .. 0.525): the bounds are half a spacing off the lattice, so
 * rounding cannot add or drop a row. */
static const hbk_fluid_obstacle_t TAP = {1, {0.2f, 0.5f, 0.5f}, {0.015f, 0.045f, 0.045f}, {0}};
enum { TAP_POINTS = 16 };

void test_fluid_inflow_refused(void)
{
    hbk_fluid_params_t p = fluid_still_box(100);
    p.source = HBK_FLUID_PARTICLES;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float v[3] = {1, 0, 0};
    CHECK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, v, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "inflow: source = 1: only the simulation"));
    hbk_fluid_destroy(h);
    CHECK(hbk_fluid_set_inflow(NULL, &TAP, NULL, NULL, v, 0.0f) == HBK_ERR_INVALID_ARGUMENT);

    /* A good tap first: every refusal after it must leave it (and the state) as it was. */
    p = fluid_still_box(100);
    h = fluid_make(&p);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, v, 0.0f));
    CHECK(hbk_fluid_inflow_points(h) == TAP_POINTS && hbk_fluid_inflow_points(NULL) == 0);
    size_t s0, s1;
    unsigned char *before = fluid_state_of(h, &s0);
    CHECK(before);
    hbk_fluid_obstacle_t ob = TAP;
    ob.type = 5;
    CHECK(hbk_fluid_set_inflow(h, &ob, NULL, NULL, v, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "shape.type = 5: must be 0 (sphere)"));
    ob.type = 2, ob.rotation[0] = 2.0f;
    CHECK(hbk_fluid_set_inflow(h, &ob, NULL, NULL, v, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "shape.rotation: length 2, must be a unit quaternion"));
    ob.type = 3, ob.rotation[0] = 1.0f;
    CHECK(hbk_fluid_set_inflow(h, &ob, NULL, NULL, v, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "dims: must not be NULL"));
    const int32_t dims[3] = {2, 2, 2};
    CHECK(hbk_fluid_set_inflow(h, &ob, dims, NULL, v, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "distance: must not be NULL"));
    CHECK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, NULL, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "velocity: must not be NULL"));
    const float nan_v[3] = {1, NAN, 0}, fast[3] = {2000, 0, 0};
    CHECK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, nan_v, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "velocity[1] = nan: must be a finite number"));
    CHECK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, fast, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "velocity[0] = 2000: must be a finite number in "
                                       "[-1000, 1000] m/s"));
    CHECK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, v, 0.7f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "jitter = 0.7: must be in [0, 0.5]"));
    /* 5 x 5 x 5 lattice points, more than max_particles = 100 at once */
    const hbk_fluid_obstacle_t big = {1, {0.5f, 0.5f, 0.5f}, {0.055f, 0.055f, 0.055f}, {0}};
    CHECK(hbk_fluid_set_inflow(h, &big, NULL, NULL, v, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "inflow: the shape holds 125 particles at once: must "
                                       "hold at most max_particles = 100"));
    unsigned char *after = fluid_state_of(h, &s1);
    CHECK(after && s0 == s1 && !memcmp(before, after, s0));
    free(before);
    free(after);
    /* still the first tap: at 1 m/s whole rows of its 16 points (see the rate) */
    CHECK_OK(hbk_fluid_step(h, NULL));
    int32_t capped = -1;
    const int32_t poured = hbk_fluid_inflow_added(h, &capped);
    CHECK(poured >= 2 * TAP_POINTS && poured % TAP_POINTS == 0 && capped == 0);
    CHECK(hbk_fluid_particle_count(h) == poured);
    /* NULL stops it: the next step adds none */
    CHECK_OK(hbk_fluid_set_inflow(h, NULL, NULL, NULL, NULL, 0.0f));
    CHECK(hbk_fluid_inflow_points(h) == 0);
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_inflow_added(h, &capped) == 0 && capped == 0);
    CHECK(hbk_fluid_particle_count(h) == poured);
    /* a shape out of the box, or thinner than the lattice: taken, pouring nothing */
    const hbk_fluid_obstacle_t out = {0, {1.5f, 0.5f, 0.5f}, {0.1f, 0, 0}, {0}},
                               thin = {0, {0.5f, 0.5f, 0.5f}, {0.004f, 0, 0}, {0}};
    CHECK_OK(hbk_fluid_set_inflow(h, &out, NULL, NULL, v, 0.0f));
    CHECK(hbk_fluid_inflow_points(h) == 0);
    CHECK_OK(hbk_fluid_set_inflow(h, &thin, NULL, NULL, v, 0.0f));
    CHECK(hbk_fluid_inflow_points(h) == 0);
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_inflow_added(h, &capped) == 0 && capped == 0);
    CHECK(hbk_fluid_inflow_added(NULL, &capped) == 0 && capped == 0);
    hbk_fluid_destroy(h);
}

/* The rate: the tap's 16 points poured along x at v, no gravity: a row leaves every s / v
 * seconds, k^2 v dt / s particles a frame (33.3 at 1 m/s, 66.7 at 2). A point
 * pours at a substep's start once the particle before has gone a spacing, the new one as
 * far along as it would be had it left then, so the rows stay a spacing apart whatever the
 * substep: over 7 frames the count is the formula give or take the one row a frame's end can
 * cut (16 / 7 a frame). (Before that placement a row left every whole number of substeps:
 * 32 a frame at 1 m/s, 250 at 10.) Each new particle is where the tap is, moved along x no
 * more than a frame and a substep of travel, and every particle still moves at v within
 * 0.1% (one velocity: no viscosity; the rows a spacing apart are a lattice at rest density
 * in the jet's middle, whose rounding leaves a pressure of a few 1e-4 m/s by frame 8). */
void test_fluid_inflow_rate(void)
{
    const float vs[2] = {1.0f, 2.0f}, s = 0.02f, dt = 1.0f / 24.0f;
    for (int c = 0; c < 2; ++c) {
        const float v = vs[c], vel[3] = {v, 0, 0};
        hbk_fluid_params_t p = fluid_still_box(4000);
        hbk_fluid_t *h = fluid_make(&p);
        CHECK(h);
        CHECK_OK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, vel, 0.0f));
        int32_t first = 0, n = 0, substeps = 0;
        for (int f = 1; f <= 8; ++f) {
            const int32_t before = hbk_fluid_particle_count(h);
            CHECK_OK(hbk_fluid_step(h, NULL));
            int32_t capped = -1;
            CHECK(hbk_fluid_inflow_added(h, &capped) == hbk_fluid_particle_count(h) - before);
            CHECK(capped == 0);
            if (f == 1) first = hbk_fluid_particle_count(h);
            if (f == 1) substeps = hbk_fluid_substeps_taken(h); /* equal substeps throughout */
            CHECK(hbk_fluid_substeps_taken(h) == substeps);
            float *vv = NULL, *x = particles(h, &n, &vv);
            CHECK(x && n > before);
            for (int32_t i = before; i < n; ++i) { /* this frame's: where the tap is */
                const float *q = x + 3 * i;
                CHECK(q[0] >= 0.195f - 1e-6f &&
                      q[0] <= 0.195f + v * dt * (1.0f + 1.0f / (float)substeps) + 1e-5f);
                for (int a = 1; a < 3; ++a) {
                    const float row = (q[a] - 0.465f) / s; /* 0..3: on a row of the tap */
                    CHECK(fabsf(row - roundf(row)) < 1e-3f && row > -0.5f && row < 3.5f);
                }
            }
            for (int32_t i = 0; i < n; ++i)
                CHECK(fabsf(vv[3 * i] - v) < 1e-3f * v && fabsf(vv[3 * i + 1]) < 1e-3f * v &&
                      fabsf(vv[3 * i + 2]) < 1e-3f * v);
            free(x);
            free(vv);
        }
        const double got = (double)(n - first) / 7.0, want = TAP_POINTS * v * dt / s;
        fprintf(stderr, "inflow at %g m/s: %.2f particles a frame (%d substeps), formula "
                "%.2f\n", v, got, substeps, want);
        CHECK(fabs(got - want) <= TAP_POINTS / 7.0 + 1e-9);
        /* the forecast's rate is the formula's, a second */
        CHECK(fabs(hbk_fluid_inflow_rate(h) - TAP_POINTS * v / s) < 1e-6 * TAP_POINTS * v / s);
        hbk_fluid_destroy(h);
    }
}

/* The forecast's rate: the lattice columns the tap's points make along its velocity, speed /
 * s a second each, and what the tap then pours. The tap is 1 x 4 x 4 points (x, y, z): across
 * x 16 columns, across y or z 4; a ball of radius r is pi r^2 / s^2 columns whichever way it
 * pours (along an axis or a diagonal, its lattice laid along the flow: within 6%). Nothing
 * pours at zero velocity, without a shape, or for NULL. */
void test_fluid_inflow_forecast_rate(void)
{
    const float s = 0.02f;
    hbk_fluid_params_t p = fluid_still_box(4000);
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const struct { float v[3]; double cols; } taps[] = {
        {{1, 0, 0}, 16}, {{-3, 0, 0}, 16}, {{0, 2, 0}, 4}, {{0, 0, -0.5f}, 4}};
    for (size_t c = 0; c < sizeof taps / sizeof *taps; ++c) {
        CHECK_OK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, taps[c].v, 0.0f));
        const float *u = taps[c].v;
        const double want = taps[c].cols * sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) / s;
        CHECK(fabs(hbk_fluid_inflow_rate(h) - want) < 1e-6 * want);
    }
    const hbk_fluid_obstacle_t ball = {0, {0.5f, 0.5f, 0.5f}, {0.1f, 0, 0}, {0}};
    const float dirs[3][3] = {{0, 0, -1}, {0.6f, 0, 0.8f}, {1, 1, 1}};
    for (int c = 0; c < 3; ++c) {
        CHECK_OK(hbk_fluid_set_inflow(h, &ball, NULL, NULL, dirs[c], 0.0f));
        const float *u = dirs[c];
        const double speed = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]),
                     want = 3.14159265 * 0.01 / (s * s) * speed / s,
                     got = hbk_fluid_inflow_rate(h);
        fprintf(stderr, "inflow forecast: a ball along (%g, %g, %g): %.1f a second, pi r^2 v "
                "/ s^3 %.1f\n", u[0], u[1], u[2], got, want);
        CHECK(fabs(got - want) < 0.06 * want);
    }
    hbk_fluid_destroy(h);
    /* and it pours that, whichever way: a ball at 1 m/s along z, x-z and the diagonal, over 8
     * frames after the first, the rate's count within the one row of its columns a frame's end
     * can cut (on the world's lattice the diagonal poured about 40% of it) */
    const hbk_fluid_obstacle_t small = {0, {0.5f, 0.5f, 0.5f}, {0.06f, 0, 0}, {0}};
    const float dt = 1.0f / 24.0f;
    for (int c = 0; c < 3; ++c) {
        const float *u = dirs[c];
        const float l = sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]),
                    unit[3] = {u[0] / l, u[1] / l, u[2] / l};
        h = fluid_make(&p);
        CHECK(h);
        CHECK_OK(hbk_fluid_set_inflow(h, &small, NULL, NULL, unit, 0.0f));
        const double rate = hbk_fluid_inflow_rate(h), cols = rate * s;
        CHECK_OK(hbk_fluid_step(h, NULL));
        const int32_t first = hbk_fluid_particle_count(h);
        for (int f = 0; f < 8; ++f) CHECK_OK(hbk_fluid_step(h, NULL));
        const double got = hbk_fluid_particle_count(h) - first, want = rate * 8.0 * dt;
        fprintf(stderr, "inflow along (%g, %g, %g): %g columns, poured %.0f in 8 frames, rate "
                "x time %.1f\n", u[0], u[1], u[2], cols, got, want);
        CHECK(cols > 20 && fabs(got - want) <= cols + 1e-6);
        hbk_fluid_destroy(h);
    }
    /* With gravity g along the flow a column pours once the particle before has gone a
     * spacing, at t of v t + g t^2 / 2 = s: 4 columns down at 1 m/s, up at 1, and up at 0.5
     * (too slow to rise a spacing: none); a ball poured down at 1 m/s for 12 frames after the
     * first pours that within 8% (1% under it here; the jet's pressure and the substeps' grain
     * move it: a slower jet pours more, 15% over it at 0.5 m/s, not checked). */
    hbk_fluid_params_t pg = fluid_still_box(4000);
    pg.gravity[2] = -9.81f;
    h = fluid_make(&pg);
    CHECK(h);
    const struct { float vz; double want; } falls[] = {
        {-1.0f, 4.0 * (1.0 + sqrt(1.0 + 2.0 * 9.81 * s)) / (2.0 * s)},
        {1.0f, 4.0 * (1.0 + sqrt(1.0 - 2.0 * 9.81 * s)) / (2.0 * s)},
        {0.5f, 0.0}};
    for (int c = 0; c < 3; ++c) {
        const float u[3] = {0, 0, falls[c].vz};
        CHECK_OK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, u, 0.0f));
        CHECK(fabs(hbk_fluid_inflow_rate(h) - falls[c].want) <= 1e-4 * falls[c].want);
    }
    const float down[3] = {0, 0, -1};
    const hbk_fluid_obstacle_t high = {0, {0.5f, 0.5f, 0.85f}, {0.06f, 0, 0}, {0}};
    CHECK_OK(hbk_fluid_set_inflow(h, &high, NULL, NULL, down, 0.0f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    const int32_t before = hbk_fluid_particle_count(h);
    for (int f = 0; f < 12; ++f) CHECK_OK(hbk_fluid_step(h, NULL));
    const double fell = hbk_fluid_particle_count(h) - before,
                 forecast = hbk_fluid_inflow_rate(h) * 12.0 * dt;
    fprintf(stderr, "inflow down at 1 m/s under gravity: poured %.0f in 12 frames, rate x time "
            "%.1f\n", fell, forecast);
    CHECK(fabs(fell - forecast) < 0.08 * forecast);
    hbk_fluid_destroy(h);
    h = fluid_make(&p);
    CHECK(h);
    const float still[3] = {0, 0, 0};
    CHECK_OK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, still, 0.0f));
    CHECK(hbk_fluid_inflow_rate(h) == 0.0);
    CHECK_OK(hbk_fluid_set_inflow(h, NULL, NULL, NULL, NULL, 0.0f));
    CHECK(hbk_fluid_inflow_rate(h) == 0.0 && hbk_fluid_inflow_rate(NULL) == 0.0);
    hbk_fluid_destroy(h);
}

/* Where a particle starts: a frame of 10 us (one substep, 10 um of travel) pours each point of
 * a turned box once, a substep's travel along (nothing was before it: the first of a stream,
 * as if it left a substep ago), moving at exactly the tap's velocity (a lattice: nothing
 * pushes them). Its points, for a flow at an angle: a lattice of the spacing laid along the
 * velocity (each point's nearest neighbour a spacing away, their places along the flow whole
 * spacings apart) and centred on the box (their mean its centre: the 2 v dt they were poured
 * along shows), inside it, as many as its volume holds within 15%. With jitter 0.3:
 * each within 0.3 spacings of its point along each axis (some further than 0.2: it is
 * applied), so inside the box's bounds widened by that; moving at the velocity within 0.05
 * m/s (neighbours the jitter brought as close as 0.4 s push each other: up to 0.015 m/s in 10
 * us over seeds 0..29). */
void test_fluid_inflow_starts_in_the_shape(void)
{
    hbk_fluid_params_t p = fluid_still_box(4000);
    p.dt = 1e-5f;
    p.substeps = 1;
    p.seed = 7;
    const float c = cosf(0.3f), sn = sinf(0.3f); /* turned 0.6 rad about z */
    const hbk_fluid_obstacle_t tb = {2, {0.4f, 0.5f, 0.5f}, {0.05f, 0.08f, 0.03f}, {c, 0, 0, sn}};
    const float vel[3] = {0.8f, -0.5f, 0.25f}, jit = 0.3f, s = 0.02f;
    hbk_fluid_t *h = fluid_make(&p), *k = fluid_make(&p);
    CHECK(h && k);
    CHECK_OK(hbk_fluid_set_inflow(h, &tb, NULL, NULL, vel, 0.0f));
    CHECK_OK(hbk_fluid_set_inflow(k, &tb, NULL, NULL, vel, jit));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK_OK(hbk_fluid_step(k, NULL));
    CHECK(hbk_fluid_substeps_taken(h) == 1 && hbk_fluid_substeps_taken(k) == 1);
    int32_t m, n, nk;
    float *hv = NULL, *kv = NULL, *x = particles(h, &n, &hv), *xk = particles(k, &nk, &kv);
    m = n;
    float *y = malloc(3 * (size_t)(n > 0 ? n : 1) * sizeof *y);
    CHECK(y && x && xk && n > 50 && nk == n);
    CHECK(hbk_fluid_inflow_added(h, NULL) == n && hbk_fluid_inflow_added(k, NULL) == n);
    const float vol = 8.0f * tb.extent[0] * tb.extent[1] * tb.extent[2] / (s * s * s);
    CHECK(fabsf((float)n - vol) < 0.15f * vol);
    double mean[3] = {0, 0, 0};
    for (int32_t i = 0; i < n; ++i) /* y: the points, each poured 2 v dt along */
        for (int a = 0; a < 3; ++a) {
            y[3 * i + a] = x[3 * i + a] - 2.0f * vel[a] * p.dt;
            mean[a] += y[3 * i + a] / n;
        }
    for (int a = 0; a < 3; ++a) CHECK_NEAR(mean[a], tb.center[a], 2e-6);
    const float speed = sqrtf(vel[0] * vel[0] + vel[1] * vel[1] + vel[2] * vel[2]);
    for (int32_t i = 0; i < m; ++i) {
        const float *q = y + 3 * i;
        float along = 0.0f, nearest = INFINITY;
        for (int a = 0; a < 3; ++a) along += (q[a] - y[a]) * vel[a] / speed;
        CHECK(fabsf(along / s - roundf(along / s)) < 1e-3f);
        for (int32_t j = 0; j < m; ++j) {
            if (j == i) continue;
            const float d0 = q[0] - y[3 * j], d1 = q[1] - y[3 * j + 1], d2 = q[2] - y[3 * j + 2];
            const float d = sqrtf(d0 * d0 + d1 * d1 + d2 * d2);
            nearest = d < nearest ? d : nearest;
        }
        CHECK(fabsf(nearest - s) < 1e-4f * s + 1e-6f);
    }
    /* the turned box's axes in the world: x' = (c2, s2, 0), y' = (-s2, c2, 0) */
    const float c2 = cosf(0.6f), s2 = sinf(0.6f);
    double most = 0.0;
    for (int32_t i = 0; i < n; ++i) {
        float q[3];
        for (int a = 0; a < 3; ++a) {
            const float v = vel[a], *at = x + 3 * i, *atk = xk + 3 * i;
            CHECK(fabsf(hv[3 * i + a] - v) < 1e-6f);
            const double moved = fabs(atk[a] - 2.0f * v * p.dt - y[3 * i + a]);
            CHECK(moved <= jit * s + 1e-5);
            most = moved > most ? moved : most;
            CHECK(fabsf(kv[3 * i + a] - v) < 0.05f);
            q[a] = atk[a] - 2.0f * v * p.dt - tb.center[a];
        }
        const float l[3] = {c2 * q[0] + s2 * q[1], -s2 * q[0] + c2 * q[1], q[2]};
        for (int a = 0; a < 3; ++a) /* (0.3 s along both world axes: up to 0.3 s sqrt 2) */
            CHECK(fabsf(l[a]) <= tb.extent[a] + jit * s * sqrtf(2.0f) + 1e-5f);
        const float *o = y + 3 * i, r[3] = {o[0] - tb.center[0], o[1] - tb.center[1],
                                            o[2] - tb.center[2]};
        const float lo[3] = {c2 * r[0] + s2 * r[1], -s2 * r[0] + c2 * r[1], r[2]};
        for (int a = 0; a < 3; ++a) CHECK(fabsf(lo[a]) <= tb.extent[a] + 1e-5f);
    }
    CHECK(most > 0.2 * s);
    free(y);
    free(x);
    free(xk);
    free(hv);
    free(kv);
    hbk_fluid_destroy(h);
    hbk_fluid_destroy(k);
}

/* Not into water: a point with a particle nearer than a spacing gets none. A tap of 5 x 10 x
 * 10 points (x 0.21..0.29, y and z 0.41..0.59) half filled at rest on a lattice half a
 * spacing off its own in y (0.42..0.48: every tap point at y <= 0.49 has one within 0.01,
 * those at y >= 0.51 none within 0.03): the first step pours exactly the 250 of the clear
 * half, and again none when the fill is on the tap's own lattice. Velocity 0: a poured
 * particle stays on its point and blocks it, so one pour a step. */
void test_fluid_inflow_clear_of_water(void)
{
    const hbk_fluid_obstacle_t tap = {1, {0.25f, 0.5f, 0.5f}, {0.05f, 0.1f, 0.1f}, {0}};
    const float still[3] = {0, 0, 0}, s = 0.02f;
    hbk_fluid_params_t p = fluid_still_box(4000);
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float lo[3] = {0.2f, 0.41f, 0.4f}, hi[3] = {0.3f, 0.5f, 0.6f};
    CHECK_OK(hbk_fluid_fill_box(h, lo, hi, 0.0f));
    const int32_t filled = hbk_fluid_particle_count(h);
    CHECK(filled == 5 * 4 * 10);
    int32_t n0;
    float *old = particles(h, &n0, NULL);
    CHECK(old);
    CHECK_OK(hbk_fluid_set_inflow(h, &tap, NULL, NULL, still, 0.0f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_inflow_added(h, NULL) == 5 * 5 * 10);
    int32_t n;
    float *x = particles(h, &n, NULL);
    CHECK(x && n == filled + 250);
    /* each poured particle: at least a spacing from every particle there was */
    double nearest = 1e30;
    for (int32_t i = filled; i < n; ++i)
        for (int32_t j = 0; j < n0; ++j) {
            const double d0 = x[3 * i] - old[3 * j], d1 = x[3 * i + 1] - old[3 * j + 1],
                         d2 = x[3 * i + 2] - old[3 * j + 2];
            const double d = sqrt(d0 * d0 + d1 * d1 + d2 * d2);
            nearest = d < nearest ? d : nearest;
        }
    free(old);
    free(x);
    CHECK(nearest >= s * (1.0 - 1e-4));
    /* the next step: every point blocked by its own particle */
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_inflow_added(h, NULL) == 0);
    hbk_fluid_destroy(h);
    /* filled on the tap's own lattice: none at all */
    h = fluid_make(&p);
    CHECK(h);
    const float tlo[3] = {0.2f, 0.4f, 0.4f}, thi[3] = {0.3f, 0.6f, 0.6f};
    CHECK_OK(hbk_fluid_fill_box(h, tlo, thi, 0.0f));
    CHECK(hbk_fluid_particle_count(h) == 500);
    CHECK_OK(hbk_fluid_set_inflow(h, &tap, NULL, NULL, still, 0.0f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_inflow_added(h, NULL) == 0 && hbk_fluid_particle_count(h) == 500);
    hbk_fluid_destroy(h);
}

/* Obstacles: a box obstacle of half-size s centred on a tap point keeps the points within
 * 1.5 s of its centre (collide's half spacing added) out: 3 x 3 of the 6 x 6 tap's one
 * layer, the rest poured; a sphere over the tap's other corner likewise. */
void test_fluid_inflow_obstacles(void)
{
    /* x 0.195 (one layer), y and z 0.445 .. 0.545 */
    const hbk_fluid_obstacle_t tap = {1, {0.2f, 0.5f, 0.5f}, {0.015f, 0.065f, 0.065f}, {0}};
    const float still[3] = {0, 0, 0};
    hbk_fluid_params_t p = fluid_still_box(4000);
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    /* a box around (0.195, 0.485, 0.485): y and z 0.465, 0.485, 0.505 inside, 0.445 and
     * 0.525 0.04 away (outside 0.03); a sphere of radius 0.005 (0.015 with the half
     * spacing) at (0.195, 0.545, 0.545): that corner point alone, its neighbours 0.02 off */
    const hbk_fluid_obstacle_t obs[2] = {{1, {0.195f, 0.485f, 0.485f}, {0.02f, 0.02f, 0.02f}, {0}},
                                         {0, {0.195f, 0.545f, 0.545f}, {0.005f, 0, 0}, {0}}};
    CHECK_OK(hbk_fluid_set_obstacles(h, obs, 2));
    CHECK_OK(hbk_fluid_set_inflow(h, &tap, NULL, NULL, still, 0.0f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_inflow_added(h, NULL) == 36 - 9 - 1);
    int32_t n;
    float *x = particles(h, &n, NULL);
    CHECK(x && n == 26);
    for (int32_t i = 0; i < n; ++i) {
        const float *q = x + 3 * i;
        CHECK(!(fabsf(q[1] - 0.485f) < 0.03f && fabsf(q[2] - 0.485f) < 0.03f));
        CHECK(!(fabsf(q[1] - 0.545f) < 0.01f && fabsf(q[2] - 0.545f) < 0.01f));
    }
    free(x);
    hbk_fluid_destroy(h);
}

/* Capacity: a first frame's n0 into max_particles = n0 + 18: n0, then the 18 that fit
 * (capped), then none (capped: the tap still wants to pour); never over it. Capped also when
 * the room runs out within a step's last (here only) substep; not when the points are
 * blocked by water anyway. */
void test_fluid_inflow_capacity(void)
{
    hbk_fluid_params_t p = fluid_still_box(4000);
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float vel[3] = {1, 0, 0};
    CHECK_OK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, vel, 0.0f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    const int32_t n0 = hbk_fluid_particle_count(h), most = n0 + 18;
    CHECK(n0 >= TAP_POINTS);
    hbk_fluid_destroy(h);
    p.max_particles = most;
    h = fluid_make(&p);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, vel, 0.0f));
    const int32_t want[4][2] = {{n0, 0}, {18, 1}, {0, 1}, {0, 1}};
    for (int f = 0; f < 4; ++f) {
        int32_t capped = -1;
        CHECK_OK(hbk_fluid_step(h, NULL));
        CHECK(hbk_fluid_inflow_added(h, &capped) == want[f][0] && capped == want[f][1]);
        CHECK(hbk_fluid_particle_count(h) == (f ? most : n0));
    }
    /* stopped: nothing wanted, not capped */
    CHECK_OK(hbk_fluid_set_inflow(h, NULL, NULL, NULL, NULL, 0.0f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    int32_t capped = -1;
    CHECK(hbk_fluid_inflow_added(h, &capped) == 0 && capped == 0);
    /* a tap holding more points than max_particles at once is refused (16 > 10) */
    hbk_fluid_destroy(h);
    p.max_particles = 10;
    h = fluid_make(&p);
    CHECK(h);
    CHECK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, vel, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "the shape holds 16 particles at once"));
    p.max_particles = 16; /* exactly: taken */
    hbk_fluid_destroy(h);
    h = fluid_make(&p);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, vel, 0.0f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_inflow_added(h, &capped) == 16 && capped == 1);
    hbk_fluid_destroy(h);
    /* cut short within a step's one substep: 6 particles there, room for 10 of the 16 */
    p.dt = 1e-4f;
    p.substeps = 1;
    h = fluid_make(&p);
    CHECK(h);
    const float lo[3] = {0.6f, 0.5f, 0.5f}, hi[3] = {0.73f, 0.525f, 0.525f}; /* 6 x 1 x 1 */
    CHECK_OK(hbk_fluid_fill_box(h, lo, hi, 0.0f));
    CHECK(hbk_fluid_particle_count(h) == 6);
    CHECK_OK(hbk_fluid_set_inflow(h, &TAP, NULL, NULL, vel, 0.0f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_substeps_taken(h) == 1);
    CHECK(hbk_fluid_inflow_added(h, &capped) == 10 && capped == 1);
    CHECK(hbk_fluid_particle_count(h) == 16);
    hbk_fluid_destroy(h);
    /* full, but every point under water: nothing stopped short, so not capped */
    p = fluid_still_box(500);
    h = fluid_make(&p);
    CHECK(h);
    const float wlo[3] = {0.2f, 0.4f, 0.4f}, whi[3] = {0.3f, 0.6f, 0.6f}, still[3] = {0, 0, 0};
    const hbk_fluid_obstacle_t under = {1, {0.25f, 0.5f, 0.5f}, {0.05f, 0.1f, 0.1f}, {0}};
    CHECK_OK(hbk_fluid_fill_box(h, wlo, whi, 0.0f));
    CHECK(hbk_fluid_particle_count(h) == 500);
    CHECK_OK(hbk_fluid_set_inflow(h, &under, NULL, NULL, still, 0.0f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_inflow_added(h, &capped) == 0 && capped == 0);
    hbk_fluid_destroy(h);
}

/* Cancelled mid-step (a second thread sets cancel once the first substep, which pours the
 * whole empty tap, is done): count, positions and velocities as before the step, nothing
 * reported added; the step done again then gives what an uncancelled twin gives. */
static hbk_fluid_t *tapped_pool(void)
{
    hbk_fluid_params_t p = fluid_still_box(4000);
    p.gravity[2] = -9.81f;
    hbk_fluid_t *h = fluid_make(&p);
    const float lo[3] = {0.5f, 0.3f, 0.0f}, hi[3] = {0.7f, 0.7f, 0.1f}, vel[3] = {1, 0, -0.5f};
    if (!h || hbk_fluid_fill_box(h, lo, hi, 0.2f) != HBK_OK ||
        hbk_fluid_step(h, NULL) != HBK_OK || /* the pool moving */
        hbk_fluid_set_inflow(h, &TAP, NULL, NULL, vel, 0.2f) != HBK_OK) {
        hbk_fluid_destroy(h);
        return NULL;
    }
    return h;
}

void test_fluid_inflow_cancel(void)
{
    int midway = 0;
    for (int attempt = 0; attempt < 20 && !midway; ++attempt) {
        hbk_fluid_t *h = tapped_pool(), *twin = tapped_pool();
        CHECK(h && twin);
        int32_t n0, n1;
        float *v0 = NULL, *v1 = NULL, *x0 = particles(h, &n0, &v0);
        CHECK(x0);
        const hbk_result_t r = fluid_step_cancelled(h, &midway); /* (a substep had poured) */
        if (r == HBK_ERR_CANCELLED) {
            float *x1 = particles(h, &n1, &v1);
            CHECK(x1 && n1 == n0);
            CHECK(!memcmp(x0, x1, 3 * (size_t)n0 * sizeof(float)));
            CHECK(!memcmp(v0, v1, 3 * (size_t)n0 * sizeof(float)));
            CHECK(hbk_fluid_inflow_added(h, NULL) == 0);
            free(x1);
            free(v1);
            CHECK_OK(hbk_fluid_step(h, NULL));
            CHECK(hbk_fluid_inflow_added(h, NULL) >= TAP_POINTS);
            CHECK_OK(hbk_fluid_step(twin, NULL));
            CHECK(fluid_same_state(h, twin));
        } else {
            CHECK_OK(r); /* done before the watcher saw it: again */
        }
        free(x0);
        free(v0);
        hbk_fluid_destroy(h);
        hbk_fluid_destroy(twin);
    }
    CHECK(midway);
}

/* Determinism: a jittered tap pouring onto a pool, 3 frames: the same positions to the byte
 * (and the same state) at 1 and 2 threads and for the same seed; other positions for another
 * seed (the jitter is keyed by it; the pool's fill has none, so the difference is the tap's).
 * The same for a sprinkler (`normal` > 0: its points on the ball's surface). */
static float *poured(int32_t threads, uint64_t seed, float normal, int32_t *n,
                     unsigned char **state, size_t *size)
{
    hbk_fluid_params_t p = fluid_still_box(4000);
    p.gravity[2] = -9.81f;
    p.threads = threads;
    p.seed = seed;
    hbk_fluid_t *h = fluid_make(&p);
    const float lo[3] = {0.1f, 0.35f, 0.0f}, hi[3] = {0.4f, 0.65f, 0.1f}, vel[3] = {0.5f, 0, -1};
    const hbk_fluid_obstacle_t ball = {0, {0.2f, 0.5f, 0.3f}, {0.05f, 0, 0}, {0}};
    float *out = NULL;
    *state = NULL;
    if (h && hbk_fluid_fill_box(h, lo, hi, 0.0f) == HBK_OK &&
        hbk_fluid_set_inflow_normal(h, &ball, NULL, NULL, vel, normal, 0.4f) == HBK_OK) {
        int ok = 1;
        for (int f = 0; f < 3 && ok; ++f) ok = hbk_fluid_step(h, NULL) == HBK_OK;
        if (ok && hbk_fluid_particle_count(h) > 15 * 15 * 5 + 100) { /* it poured */
            out = particles(h, n, NULL);
            *state = fluid_state_of(h, size);
        }
    }
    hbk_fluid_destroy(h);
    return out;
}

static int deterministic(float normal)
{
    int32_t n[4];
    unsigned char *st[4];
    size_t sz[4];
    float *x[4] = {poured(1, 11, normal, &n[0], &st[0], &sz[0]),
                   poured(2, 11, normal, &n[1], &st[1], &sz[1]),
                   poured(2, 11, normal, &n[2], &st[2], &sz[2]),
                   poured(1, 12, normal, &n[3], &st[3], &sz[3])};
    int ok = 1;
    for (int k = 0; k < 4; ++k) ok &= x[k] && st[k];
    if (ok) {
        const size_t b = 3 * (size_t)n[0] * sizeof(float);
        ok &= n[1] == n[0] && !memcmp(x[0], x[1], b); /* threads */
        ok &= sz[1] == sz[0] && !memcmp(st[0], st[1], sz[0]);
        ok &= n[2] == n[0] && !memcmp(x[1], x[2], b); /* again */
        ok &= n[3] != n[0] || memcmp(x[0], x[3], b);  /* another seed */
    }
    for (int k = 0; k < 4; ++k) {
        free(x[k]);
        free(st[k]);
    }
    return ok;
}

void test_fluid_inflow_deterministic(void)
{
    CHECK(deterministic(0.0f));
    CHECK(deterministic(1.0f)); /* a sprinkler */
}
