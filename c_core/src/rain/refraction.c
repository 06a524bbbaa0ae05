/* The paper's cheap refraction (§5.4): the background looked up at a place shifted by the
 * normal's in-plane part, mirrored where that leaves the image. A preview, not optics. */
#include "hbk_rain.h"
#include "../base/internal_base.h"
#include <math.h>

hbk_result_t hbk_rain_refraction(const hbk_image_t *normals, const hbk_image_t *background,
                                 float strength, hbk_image_t *out, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    hbk_result_t r = hbk_image_check(normals, "normals", msg);
    if (r || (r = hbk_image_check(background, "background", msg)) ||
        (r = hbk_image_check(out, "out", msg)))
        return r;
    if (normals->channels < 3)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "normals.channels = %d: must be 3 or 4",
                        normals->channels);
    if (out->width != normals->width || out->height != normals->height)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out size = %d x %d: must equal the "
                        "normals' size, %d x %d", out->width, out->height, normals->width,
                        normals->height);
    if (out->channels != background->channels)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out.channels = %d: must equal "
                        "background.channels = %d", out->channels, background->channels);
    if (!(strength >= 0.0f && strength <= 10.0f))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "strength = %g: must be in [0, 10]",
                        (double)strength);
    /* A NaN or infinite texel would spread to every pixel that looks it up. */
    if ((r = hbk_image_check_values(background, "background", -1e6, 1e6, "", msg))) return r;
    const int32_t W = out->width, H = out->height, nc = out->channels;
    const int32_t nn = normals->channels;
    /* Unit normals (a little rounding allowed): anything else would shift the lookup by
     * NaN or past any image. */
    for (int32_t y = 0; y < H; ++y)
        for (int32_t x = 0; x < W; ++x) {
            const float *n =
                normals->data + (size_t)y * normals->row_stride + (size_t)x * (size_t)nn;
            if (!(fabsf(n[0]) <= 1.001f && fabsf(n[1]) <= 1.001f))
                return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "normals at pixel (%d, %d) = "
                                "(%g, %g): must be finite unit normals, x and y in [-1, 1]", x,
                                y, (double)n[0], (double)n[1]);
        }
    const float bw = (float)background->width, bh = (float)background->height;
    const float fx = bw / (float)W, fy = bh / (float)H;
#pragma omp parallel for schedule(static)
    for (int32_t y = 0; y < H; ++y) {
        const float *nrow = normals->data + (size_t)y * normals->row_stride;
        float *orow = out->data + (size_t)y * out->row_stride;
        for (int32_t x = 0; x < W; ++x) {
            const float *n = nrow + (size_t)x * (size_t)nn;
            /* Pixel centres at integers in hbk_image_sample. */
            const float sx = ((float)x + 0.5f) * fx - 0.5f - strength * n[0] * bw;
            const float sy = ((float)y + 0.5f) * fy - 0.5f - strength * n[1] * bh;
            for (int32_t c = 0; c < nc; ++c)
                orow[(size_t)x * (size_t)nc + (size_t)c] =
                    hbk_image_sample(background, sx, sy, c, HBK_EDGE_MIRROR);
        }
    }
    return HBK_OK;
}
