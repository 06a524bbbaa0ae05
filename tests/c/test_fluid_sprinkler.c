/* The sprinkler (hbk_fluid_set_inflow_normal): its points lie on the shape's surface, half a
 * spacing in and at least a spacing apart; each pours along its outward normal (plus the
 * velocity), and those whose velocity would enter the shape pour nothing; it pours its rate;
 * a bad normal is refused by name with the handle unchanged. */
#include "test.h"
#include <stdlib.h>

static const hbk_fluid_obstacle_t BALL = {0, {0.5f, 0.5f, 0.5f}, {0.1f, 0, 0}, {0}};

/* One step of 1e-5 s, so short that the forces leave the poured particles' velocities as
 * they were poured: the points are then x - 2 v dt (poured a substep's travel along, then
 * moved one). Returns the particles' points and velocities (malloc'd), count in *n. */
static float *poured_points(const hbk_fluid_obstacle_t *shape, const float vel[3], float normal,
                            int32_t *n, float **v, double *rate)
{
    hbk_fluid_params_t p = fluid_still_box(4000);
    p.dt = 1e-5f;
    p.substeps = 1;
    hbk_fluid_t *h = fluid_make(&p);
    if (!h) return NULL;
    float *x = NULL;
    if (hbk_fluid_set_inflow_normal(h, shape, NULL, NULL, vel, normal, 0.0f) == HBK_OK &&
        hbk_fluid_step(h, NULL) == HBK_OK) {
        *n = hbk_fluid_particle_count(h);
        *rate = hbk_fluid_inflow_rate(h);
        const size_t bytes = 3 * (size_t)(*n > 0 ? *n : 1) * sizeof(float);
        x = malloc(bytes);
        *v = malloc(bytes);
        if (x && *v && hbk_fluid_get_particles(h, x, *v, *n) == HBK_OK)
            for (int32_t i = 0; i < 3 * *n; ++i) x[i] -= 2.0f * (*v)[i] * p.dt;
        if (hbk_fluid_inflow_points(h) != *n) *n = -1; /* (every point pours once) */
    }
    hbk_fluid_destroy(h);
    return x;
}

static float nearest_other(const float *y, int32_t n, int32_t i)
{
    float best = INFINITY;
    for (int32_t j = 0; j < n; ++j) {
        if (j == i) continue;
        const float a = y[3 * i] - y[3 * j], b = y[3 * i + 1] - y[3 * j + 1],
                    c = y[3 * i + 2] - y[3 * j + 2];
        const float d = sqrtf(a * a + b * b + c * c);
        best = d < best ? d : best;
    }
    return best;
}

void test_fluid_sprinkler_points(void)
{
    const float s = 0.02f, zero[3] = {0, 0, 0};
    int32_t n = 0;
    float *v = NULL;
    double rate = 0.0, mean[3] = {0, 0, 0};
    /* a ball spraying at 1 m/s: the points on the sphere r - s / 2, radially out at 1 m/s */
    float *y = poured_points(&BALL, zero, 1.0f, &n, &v, &rate);
    CHECK(y && v);
    const float r = BALL.extent[0] - 0.5f * s, area = 4.0f * 3.14159265f * r * r / (s * s);
    fprintf(stderr, "sprinkler: a ball r = 0.1 m: %d points, its surface %.0f spacing squares\n",
            n, area);
    CHECK(n > 0.6f * area && n < area);
    for (int32_t i = 0; y && v && i < n; ++i) {
        const float q[3] = {y[3 * i] - 0.5f, y[3 * i + 1] - 0.5f, y[3 * i + 2] - 0.5f};
        const float d = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        CHECK(fabsf(d - r) < 1e-4f);
        for (int a = 0; a < 3; ++a) {
            CHECK(fabsf(v[3 * i + a] - q[a] / d) < 1e-4f);
            mean[a] += q[a] / n;
        }
        CHECK(nearest_other(y, n, i) >= s * (1.0f - 1e-3f));
    }
    for (int a = 0; a < 3; ++a) CHECK(fabs(mean[a]) < 0.1 * r); /* all round */
    CHECK(fabs(rate - n / s) < 1e-6 * rate); /* each a column at 1 m/s, no gravity */
    free(y);
    free(v);

    /* a box: on its faces half a spacing in, along the face's normal at 2 m/s */
    const hbk_fluid_obstacle_t box = {1, {0.5f, 0.5f, 0.5f}, {0.1f, 0.06f, 0.05f}, {0}};
    y = poured_points(&box, zero, 2.0f, &n, &v, &rate);
    CHECK(y && v && n > 100);
    for (int32_t i = 0; y && v && i < n; ++i) {
        int m = 0;
        float q[3];
        for (int a = 0; a < 3; ++a) q[a] = y[3 * i + a] - box.center[a];
        for (int a = 1; a < 3; ++a)
            m = fabsf(q[a]) - box.extent[a] > fabsf(q[m]) - box.extent[m] ? a : m;
        CHECK(fabsf(fabsf(q[m]) - (box.extent[m] - 0.5f * s)) < 1e-5f);
        for (int a = 0; a < 3; ++a)
            CHECK(fabsf(v[3 * i + a] - (a == m ? (q[m] < 0.0f ? -2.0f : 2.0f) : 0.0f)) < 1e-4f);
        CHECK(nearest_other(y, n, i) >= s * (1.0f - 1e-3f));
    }
    free(y);
    free(v);

    /* with a velocity down at 2 m/s and 1 along the normal: only where -2 n_z + 1 > 0 (below
     * 30 degrees over the equator), at the sum */
    const float down[3] = {0, 0, -2.0f};
    int32_t all = n;
    y = poured_points(&BALL, zero, 1.0f, &all, &v, &rate);
    free(y);
    free(v);
    y = poured_points(&BALL, down, 1.0f, &n, &v, &rate);
    CHECK(y && v && n > 0.5 * all && n < 0.85 * all);
    int low = 0;
    for (int32_t i = 0; y && v && i < n; ++i) {
        const float q[3] = {y[3 * i] - 0.5f, y[3 * i + 1] - 0.5f, y[3 * i + 2] - 0.5f};
        const float d = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        CHECK(q[2] / d < 0.5f);
        low += q[2] / d < -0.9f;
        for (int a = 0; a < 3; ++a) CHECK(fabsf(v[3 * i + a] - (down[a] + q[a] / d)) < 1e-4f);
    }
    CHECK(low > 0); /* the bottom pours */
    free(y);
    free(v);
}

/* It pours its rate: a ball spraying at 1 m/s with no gravity, over 6 frames after the first,
 * within 10% of rate x time (its streams part: measured 96%). */
void test_fluid_sprinkler_pours_its_rate(void)
{
    hbk_fluid_params_t p = fluid_still_box(30000);
    p.threads = 2;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float zero[3] = {0, 0, 0};
    CHECK_OK(hbk_fluid_set_inflow_normal(h, &BALL, NULL, NULL, zero, 1.0f, 0.0f));
    const double rate = hbk_fluid_inflow_rate(h);
    CHECK_OK(hbk_fluid_step(h, NULL));
    const int32_t first = hbk_fluid_particle_count(h);
    for (int f = 0; f < 6; ++f) CHECK_OK(hbk_fluid_step(h, NULL));
    const double n = hbk_fluid_particle_count(h) - first, want = rate * 6.0 * p.dt;
    fprintf(stderr, "sprinkler: poured %.0f over 6 frames, rate x time %.0f\n", n, want);
    CHECK(n > 0.9 * want && n < 1.05 * want);
    hbk_fluid_destroy(h);
}

void test_fluid_sprinkler_refused(void)
{
    hbk_fluid_params_t p = fluid_still_box(4000);
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float zero[3] = {0, 0, 0};
    CHECK_OK(hbk_fluid_set_inflow_normal(h, &BALL, NULL, NULL, zero, 1.0f, 0.0f));
    const int32_t pts = hbk_fluid_inflow_points(h);
    const double rate = hbk_fluid_inflow_rate(h);
    const float bad[] = {-1.0f, 1001.0f, NAN};
    for (int i = 0; i < 3; ++i) {
        CHECK(hbk_fluid_set_inflow_normal(h, &BALL, NULL, NULL, zero, bad[i], 0.0f) ==
              HBK_ERR_INVALID_ARGUMENT);
        CHECK(strstr(hbk_fluid_message(h), "normal = ") &&
              strstr(hbk_fluid_message(h), ": must be in [0, 1000] m/s"));
        CHECK(hbk_fluid_inflow_points(h) == pts && hbk_fluid_inflow_rate(h) == rate);
    }
    /* normal = 0 is set_inflow: the volume's lattice */
    CHECK_OK(hbk_fluid_set_inflow_normal(h, &BALL, NULL, NULL, zero, 0.0f, 0.0f));
    const int32_t vol = hbk_fluid_inflow_points(h);
    CHECK_OK(hbk_fluid_set_inflow(h, &BALL, NULL, NULL, zero, 0.0f));
    CHECK(hbk_fluid_inflow_points(h) == vol && vol > 2 * pts);
    hbk_fluid_destroy(h);
}
