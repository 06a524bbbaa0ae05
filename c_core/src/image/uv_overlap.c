/* hbk_uv_overlap: how much of a UV layout is covered twice. Snow and rain bake into the
 * object's own UVs; where two faces share texels, snow or drops of one show on the other. */
#include "hbk_image.h"
#include "../base/internal_base.h"
#include <math.h>
#include <stdlib.h>

/* UVs are snapped to 1/256 of a texel so the edge functions are exact integers: a texel centre
 * on an edge two triangles share is then counted once, by the top-left rule, never twice. */
#define SUB 256

static int64_t edge_fn(int64_t ax, int64_t ay, int64_t bx, int64_t by, int64_t px, int64_t py)
{
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

/* Top-left rule for a counter-clockwise triangle: a centre exactly on an edge belongs to the
 * triangle only for a top edge (horizontal, pointing left) or a left edge (pointing down). */
static int64_t bias(int64_t ax, int64_t ay, int64_t bx, int64_t by)
{
    const int top_left = (ay == by && bx < ax) || by < ay;
    return top_left ? 0 : -1;
}

static void draw(uint8_t *count, int32_t res, const float *t)
{
    int64_t x[3], y[3];
    for (int k = 0; k < 3; ++k) {
        /* Outside 0..1 (or not finite): the caller's business; kept within reach of int64. */
        const double u = fmin(fmax((double)t[2 * k], -4.0), 5.0);
        const double v = fmin(fmax((double)t[2 * k + 1], -4.0), 5.0);
        x[k] = (int64_t)llround((u == u ? u : 0.0) * res * SUB);
        y[k] = (int64_t)llround((v == v ? v : 0.0) * res * SUB);
    }
    int64_t area = edge_fn(x[0], y[0], x[1], y[1], x[2], y[2]);
    if (area == 0) return; /* degenerate: covers nothing */
    if (area < 0) {        /* mirrored UVs: make it counter-clockwise */
        int64_t sx = x[1], sy = y[1];
        x[1] = x[2], y[1] = y[2], x[2] = sx, y[2] = sy;
    }
    int64_t lo_x = x[0], hi_x = x[0], lo_y = y[0], hi_y = y[0];
    for (int k = 1; k < 3; ++k) {
        lo_x = x[k] < lo_x ? x[k] : lo_x, hi_x = x[k] > hi_x ? x[k] : hi_x;
        lo_y = y[k] < lo_y ? y[k] : lo_y, hi_y = y[k] > hi_y ? y[k] : hi_y;
    }
    /* Texel i's centre is at (i + 1/2) * SUB. */
    int64_t i0 = (lo_x - SUB / 2 + SUB - 1) / SUB, i1 = (hi_x - SUB / 2) / SUB;
    int64_t j0 = (lo_y - SUB / 2 + SUB - 1) / SUB, j1 = (hi_y - SUB / 2) / SUB;
    if (lo_x < SUB / 2) i0 = 0;
    if (lo_y < SUB / 2) j0 = 0;
    if (hi_x < SUB / 2 || hi_y < SUB / 2) return;
    i1 = i1 < res - 1 ? i1 : res - 1;
    j1 = j1 < res - 1 ? j1 : res - 1;
    const int64_t b0 = bias(x[1], y[1], x[2], y[2]), b1 = bias(x[2], y[2], x[0], y[0]);
    const int64_t b2 = bias(x[0], y[0], x[1], y[1]);
    for (int64_t j = j0; j <= j1; ++j) {
        const int64_t py = j * SUB + SUB / 2;
        for (int64_t i = i0; i <= i1; ++i) {
            const int64_t px = i * SUB + SUB / 2;
            if (edge_fn(x[1], y[1], x[2], y[2], px, py) + b0 >= 0 &&
                edge_fn(x[2], y[2], x[0], y[0], px, py) + b1 >= 0 &&
                edge_fn(x[0], y[0], x[1], y[1], px, py) + b2 >= 0) {
                uint8_t *c = count + (size_t)j * (size_t)res + (size_t)i;
                *c += *c < 2;
            }
        }
    }
}

hbk_result_t hbk_uv_overlap(const float *uvs, int32_t triangles, int32_t resolution,
                            float *overlap, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!uvs && triangles > 0)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "uvs: must not be NULL");
    if (!overlap) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "overlap: must not be NULL");
    if (triangles < 0)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "triangles = %d: must be >= 0",
                        triangles);
    if (resolution < 1 || resolution > 4096)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "resolution = %d: must be in [1, 4096]",
                        resolution);
    uint8_t *count = calloc((size_t)resolution * (size_t)resolution, 1);
    if (!count)
        return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "cannot allocate a %dx%d coverage grid",
                        resolution, resolution);
    for (int32_t t = 0; t < triangles; ++t) draw(count, resolution, uvs + (size_t)t * 6);
    size_t once = 0, twice = 0;
    for (size_t i = 0; i < (size_t)resolution * (size_t)resolution; ++i) {
        once += count[i] > 0;
        twice += count[i] > 1;
    }
    free(count);
    *overlap = once ? (float)((double)twice / (double)once) : 0.0f;
    return HBK_OK;
}
