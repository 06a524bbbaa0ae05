/* Inflows added (hbk_fluid_add_inflow): two taps, or a tap and a sprinkler, pour together
 * exactly what each pours alone, at the sum of their rates; set_inflow replaces them all; a
 * bad one is refused by name with the inflows left as they were. */
#include "test.h"
#include <stdlib.h>
#include <string.h>

static const hbk_fluid_obstacle_t TAP_A = {1, {0.2f, 0.5f, 0.5f}, {0.015f, 0.045f, 0.045f}, {0}};
static const hbk_fluid_obstacle_t TAP_B = {1, {0.7f, 0.3f, 0.6f}, {0.045f, 0.045f, 0.015f}, {0}};
static const hbk_fluid_obstacle_t BALL = {0, {0.5f, 0.7f, 0.3f}, {0.06f, 0, 0}, {0}};
static const float VEL_A[3] = {1.0f, 0.0f, 0.0f}, VEL_B[3] = {0.0f, 0.5f, -1.0f};

/* An empty still box after one step of `which` inflows (bit 0: tap A, 1: tap B at its
 * velocity, 2: the ball spraying 1 m/s), added in that order: its particles (malloc'd,
 * positions then velocities, 6 n floats), count in *n, the rate and points before the step. */
static float *after_one_step(int which, int32_t *n, double *rate, int32_t *points)
{
    hbk_fluid_params_t p = fluid_still_box(4000);
    p.dt = 1e-3f;
    p.substeps = 1;
    hbk_fluid_t *h = fluid_make(&p);
    if (!h) return NULL;
    const float zero[3] = {0, 0, 0};
    int ok = 1;
    if (which & 1) ok &= hbk_fluid_add_inflow(h, &TAP_A, NULL, NULL, VEL_A, 0.0f) == HBK_OK;
    if (which & 2) ok &= hbk_fluid_add_inflow(h, &TAP_B, NULL, NULL, VEL_B, 0.0f) == HBK_OK;
    if (which & 4) ok &= hbk_fluid_add_inflow(h, &BALL, NULL, NULL, zero, 1.0f) == HBK_OK;
    *rate = hbk_fluid_inflow_rate(h);
    *points = hbk_fluid_inflow_points(h);
    float *out = NULL;
    if (ok && hbk_fluid_step(h, NULL) == HBK_OK) {
        *n = hbk_fluid_particle_count(h);
        out = malloc(6 * (size_t)(*n > 0 ? *n : 1) * sizeof *out);
        if (out && hbk_fluid_get_particles(h, out, out + 3 * (size_t)*n, *n) != HBK_OK) {
            free(out);
            out = NULL;
        }
    }
    hbk_fluid_destroy(h);
    return out;
}

/* Whether the particles of `all` are those of `parts` (k of them) in turn, to the byte. */
static int concatenated(const float *all, int32_t n, float *const *parts, const int32_t *m,
                        int k)
{
    int32_t sum = 0;
    for (int i = 0; i < k; ++i) sum += m[i];
    if (sum != n || n == 0) return 0;
    int32_t at = 0;
    for (int i = 0; i < k; ++i) {
        const size_t b = 3 * (size_t)m[i] * sizeof(float);
        if (memcmp(all + 3 * (size_t)at, parts[i], b) ||
            memcmp(all + 3 * ((size_t)n + at), parts[i] + 3 * (size_t)m[i], b))
            return 0;
        at += m[i];
    }
    return 1;
}

void test_fluid_inflows_added(void)
{
    int32_t n[8] = {0}, pts[8] = {0};
    double rate[8] = {0};
    float *got[8] = {NULL};
    const int cases[] = {1, 2, 4, 3, 7};
    for (size_t c = 0; c < sizeof cases / sizeof *cases; ++c) {
        const int w = cases[c];
        got[w] = after_one_step(w, &n[w], &rate[w], &pts[w]);
        CHECK(got[w] && n[w] > 0 && n[w] == pts[w]); /* (each point pours once, at once) */
    }
    fprintf(stderr, "inflows: tap A %d points, %.0f/s; B %d, %.0f/s; ball %d, %.0f/s; all %d, "
            "%.0f/s\n", pts[1], rate[1], pts[2], rate[2], pts[4], rate[4], pts[7], rate[7]);
    /* the two taps: A's particles then B's, each as it pours alone; the rates add */
    float *ab[2] = {got[1], got[2]};
    CHECK(concatenated(got[3], n[3], ab, (int32_t[]){n[1], n[2]}, 2));
    CHECK(fabs(rate[3] - (rate[1] + rate[2])) < 1e-9 * rate[3]);
    /* and a sprinkler with them: its points each at their own velocity */
    float *abc[3] = {got[1], got[2], got[4]};
    CHECK(concatenated(got[7], n[7], abc, (int32_t[]){n[1], n[2], n[4]}, 3));
    CHECK(fabs(rate[7] - (rate[1] + rate[2] + rate[4])) < 1e-9 * rate[7]);
    for (int w = 0; w < 8; ++w) free(got[w]);
}

void test_fluid_inflows_replaced_and_refused(void)
{
    hbk_fluid_params_t p = fluid_still_box(4000);
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    if (!h) return;
    const float zero[3] = {0, 0, 0}, bad[3] = {0, 2000.0f, 0};
    CHECK_OK(hbk_fluid_add_inflow(h, &TAP_A, NULL, NULL, VEL_A, 0.0f));
    const int32_t a = hbk_fluid_inflow_points(h);
    const double ra = hbk_fluid_inflow_rate(h);
    CHECK_OK(hbk_fluid_add_inflow(h, &TAP_B, NULL, NULL, VEL_B, 0.0f));
    const int32_t ab = hbk_fluid_inflow_points(h);
    const double rab = hbk_fluid_inflow_rate(h);
    CHECK(ab > a && rab > ra);
    /* refused by name, the two left as they were */
    CHECK(hbk_fluid_add_inflow(h, NULL, NULL, NULL, VEL_A, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strcmp(hbk_fluid_message(h), "shape: must not be NULL") == 0);
    CHECK(hbk_fluid_add_inflow(h, &BALL, NULL, NULL, zero, -1.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strcmp(hbk_fluid_message(h), "normal = -1: must be in [0, 1000] m/s") == 0);
    CHECK(hbk_fluid_add_inflow(h, &BALL, NULL, NULL, bad, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strcmp(hbk_fluid_message(h), "velocity[1] = 2000: must be a finite number in [-1000, 1000] m/s") == 0);
    CHECK(hbk_fluid_inflow_points(h) == ab && hbk_fluid_inflow_rate(h) == rab);
    /* more points together than max_particles: refused, the two kept */
    hbk_fluid_params_t q = fluid_still_box(ab + 10);
    hbk_fluid_t *small = fluid_make(&q);
    CHECK(small);
    if (small) {
        CHECK_OK(hbk_fluid_add_inflow(small, &TAP_A, NULL, NULL, VEL_A, 0.0f));
        CHECK_OK(hbk_fluid_add_inflow(small, &TAP_B, NULL, NULL, VEL_B, 0.0f));
        CHECK(hbk_fluid_add_inflow(small, &TAP_A, NULL, NULL, VEL_A, 0.0f) ==
              HBK_ERR_INVALID_ARGUMENT);
        CHECK(strstr(hbk_fluid_message(small), "inflow: the shapes hold ") != NULL);
        CHECK(strstr(hbk_fluid_message(small), "must hold at most max_particles = ") != NULL);
        CHECK(hbk_fluid_inflow_points(small) == ab);
        hbk_fluid_destroy(small);
    }
    /* set_inflow replaces them all; after set_inflow(NULL) an added one is alone */
    CHECK_OK(hbk_fluid_set_inflow(h, &TAP_B, NULL, NULL, VEL_B, 0.0f));
    CHECK(hbk_fluid_inflow_points(h) == ab - a && hbk_fluid_inflow_rate(h) == rab - ra);
    CHECK_OK(hbk_fluid_set_inflow(h, NULL, NULL, NULL, NULL, 0.0f));
    CHECK(hbk_fluid_inflow_points(h) == 0 && hbk_fluid_inflow_rate(h) == 0.0);
    CHECK_OK(hbk_fluid_add_inflow(h, &TAP_A, NULL, NULL, VEL_A, 0.0f));
    CHECK(hbk_fluid_inflow_points(h) == a && hbk_fluid_inflow_rate(h) == ra);
    /* another source pours none */
    hbk_fluid_params_t g = fluid_still_box(4000);
    g.source = HBK_FLUID_PARTICLES;
    hbk_fluid_t *other = fluid_make(&g);
    CHECK(other);
    if (other) {
        CHECK(hbk_fluid_add_inflow(other, &TAP_A, NULL, NULL, VEL_A, 0.0f) ==
              HBK_ERR_INVALID_ARGUMENT);
        CHECK(strcmp(hbk_fluid_message(other), "inflow: source = 1: only the simulation (0) pours an inflow") == 0);
        hbk_fluid_destroy(other);
    }
    hbk_fluid_destroy(h);
}
