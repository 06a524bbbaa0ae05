/* Helpers the test files share. */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"

grid_t grid_new(int32_t w, int32_t h, int32_t channels)
{
    grid_t g;
    g.v = calloc((size_t)w * (size_t)h * (size_t)channels, sizeof *g.v);
    g.img = (hbk_image_t){g.v, w, h, channels, (size_t)w * (size_t)channels};
    return g;
}

int hbk_test_break_param(void *params, const hbk_param_info_t *p, int side)
{
    if (p->type == HBK_PARAM_U64) return 0;
    unsigned char *at = (unsigned char *)params + p->offset + 4 * (p->count - 1);
    if (p->type == HBK_PARAM_F32) {
        float v = side == 0 ? (float)(p->min - 1.0 - fabs(p->min))
                : side == 1 ? (float)(p->max + 1.0 + fabs(p->max)) : NAN;
        memcpy(at, &v, 4);
        return 1;
    }
    if (side == 2) return 0;
    int32_t v = side == 0 ? (int32_t)p->min - 1 : (int32_t)p->max + 1;
    memcpy(at, &v, 4);
    return 1;
}

hbk_fluid_t *fluid_make(const hbk_fluid_params_t *p)
{
    hbk_fluid_t *h = NULL;
    hbk_message_t m;
    if (hbk_fluid_create(&h, p, &m) != HBK_OK) {
        fprintf(stderr, "create: %s\n", m.text);
        return NULL;
    }
    return h;
}

hbk_fluid_t *fluid_lone(float gz, int32_t max_particles, int32_t threads)
{
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    for (int a = 0; a < 3; ++a) p.resolution[a] = 16;
    p.gravity[2] = gz;
    p.max_particles = max_particles;
    if (threads) p.threads = threads; /* else the default */
    hbk_fluid_t *h = NULL;
    hbk_message_t m;
    if (hbk_fluid_create(&h, &p, &m) != HBK_OK) return NULL;
    return h;
}

hbk_fluid_params_t fluid_still_box(int32_t max_particles)
{
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    for (int a = 0; a < 3; ++a) p.resolution[a] = 16;
    p.gravity[2] = 0.0f;
    p.viscosity = 0.01f;
    p.max_particles = max_particles;
    p.threads = 1;
    return p;
}

typedef struct {
    hbk_progress_t *pr;
    volatile int stop;
} watcher_t;

static void *cancel_after_a_substep(void *arg)
{
    watcher_t *w = arg;
    while (!w->stop)
        if (w->pr->fraction > 0.0f) {
            w->pr->cancel = 1;
            break;
        }
    return NULL;
}

hbk_result_t fluid_step_cancelled(hbk_fluid_t *h, int *midway)
{
    hbk_progress_t pr = {0, 0.0f};
    watcher_t w = {&pr, 0};
    pthread_t th;
    *midway = 0;
    if (pthread_create(&th, NULL, cancel_after_a_substep, &w) != 0) return HBK_ERR_IO;
    const hbk_result_t r = hbk_fluid_step(h, &pr);
    w.stop = 1;
    pthread_join(th, NULL);
    *midway = r == HBK_ERR_CANCELLED && pr.fraction > 0.0f;
    return r;
}

unsigned char *fluid_state_of(hbk_fluid_t *h, size_t *size)
{
    *size = hbk_fluid_state_size(h);
    unsigned char *b = malloc(*size);
    if (b && hbk_fluid_save_state(h, b, *size) != HBK_OK) {
        free(b);
        return NULL;
    }
    return b;
}

int fluid_same_state(hbk_fluid_t *a, hbk_fluid_t *b)
{
    size_t sa, sb;
    unsigned char *xa = fluid_state_of(a, &sa), *xb = fluid_state_of(b, &sb);
    const int same = xa && xb && sa == sb && !memcmp(xa, xb, sa);
    free(xa);
    free(xb);
    return same;
}

/* Signed distance at p (own axes) to a sphere of radius a, a box of half-sizes (a, b, c), or
 * a torus about z of radii a (ring) and b (tube). */
float fluid_sdf(int shape, const double p[3], double a, double b, double c)
{
    if (shape == SDF_SPHERE) return (float)(sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - a);
    if (shape == SDF_TORUS) {
        const double ring = sqrt(p[0] * p[0] + p[1] * p[1]) - a;
        return (float)(sqrt(ring * ring + p[2] * p[2]) - b);
    }
    const double q[3] = {fabs(p[0]) - a, fabs(p[1]) - b, fabs(p[2]) - c};
    double out = 0.0, in = fmax(q[0], fmax(q[1], q[2]));
    for (int k = 0; k < 3; ++k) out += q[k] > 0.0 ? q[k] * q[k] : 0.0;
    return (float)(sqrt(out) + (in < 0.0 ? in : 0.0));
}

/* The field of a shape over the box of half-sizes e at n points a side. */
float *fluid_sdf_field(int shape, const float e[3], int n, double a, double b, double c)
{
    float *f = malloc((size_t)n * n * n * sizeof *f);
    if (!f) return NULL;
    for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const double p[3] = {-e[0] + 2.0 * e[0] * i / (n - 1),
                                     -e[1] + 2.0 * e[1] * j / (n - 1),
                                     -e[2] + 2.0 * e[2] * k / (n - 1)};
                f[(size_t)i + (size_t)n * ((size_t)j + (size_t)n * k)] =
                    fluid_sdf(shape, p, a, b, c);
            }
    return f;
}

