/* Helpers the test files share. */
#include <stdlib.h>
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
