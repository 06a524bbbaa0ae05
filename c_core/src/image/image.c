#include "hbk_image.h"
#include "../base/internal_base.h"
#include <math.h>

hbk_result_t hbk_image_check(const hbk_image_t *img, const char *name, hbk_message_t *msg)
{
    if (!img) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s: must not be NULL", name);
    if (!img->data) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s.data: must not be NULL", name);
    if (img->width < 1 || img->width > 65536)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s.width = %d: must be in [1, 65536]",
                        name, img->width);
    if (img->height < 1 || img->height > 65536)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s.height = %d: must be in [1, 65536]",
                        name, img->height);
    if (img->channels < 1 || img->channels > 4)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s.channels = %d: must be in [1, 4]",
                        name, img->channels);
    size_t need = (size_t)img->width * (size_t)img->channels;
    if (img->row_stride < need)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "%s.row_stride = %zu: must be >= width * channels = %zu", name,
                        img->row_stride, need);
    return HBK_OK;
}

hbk_result_t hbk_image_check_values(const hbk_image_t *img, const char *name, double lo,
                                    double hi, const char *unit, hbk_message_t *msg)
{
    const size_t w = (size_t)img->width * (size_t)img->channels;
    for (int32_t y = 0; y < img->height; ++y) {
        const float *row = img->data + (size_t)y * img->row_stride;
        for (size_t x = 0; x < w; ++x)
            if (!(row[x] >= lo && row[x] <= hi))
                return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                                "%s at pixel (%zu, %d) = %g: must be a finite number in "
                                "[%g, %g]%s%s", name, x / (size_t)img->channels, y,
                                (double)row[x], lo, hi, *unit ? " " : "", unit);
    }
    return HBK_OK;
}

static inline int32_t edge_index(int32_t i, int32_t n, int32_t edge)
{
    if (i >= 0 && i < n) return i;
    switch (edge) {
    case HBK_EDGE_WRAP: i %= n; return i < 0 ? i + n : i;
    case HBK_EDGE_MIRROR: {
        int32_t period = 2 * n;
        i %= period;
        if (i < 0) i += period;
        return i < n ? i : period - 1 - i;
    }
    default: return i < 0 ? 0 : n - 1;
    }
}

static inline float texel(const hbk_image_t *img, int32_t x, int32_t y, int32_t c, int32_t edge)
{
    x = edge_index(x, img->width, edge);
    y = edge_index(y, img->height, edge);
    return img->data[(size_t)y * img->row_stride + (size_t)x * (size_t)img->channels + (size_t)c];
}

float hbk_image_sample(const hbk_image_t *img, float x, float y, int32_t c, int32_t edge)
{
    /* Held within the floats that convert to int32 (NaN too, which then gives NaN): a texel
     * index past them would be undefined. No coordinate that converted before changes. */
    float fx = fminf(fmaxf(floorf(x), -2147483648.0f), 2147483520.0f);
    float fy = fminf(fmaxf(floorf(y), -2147483648.0f), 2147483520.0f);
    int32_t x0 = (int32_t)fx, y0 = (int32_t)fy;
    float tx = x - fx, ty = y - fy;
    float a = texel(img, x0, y0, c, edge), b = texel(img, x0 + 1, y0, c, edge);
    float d = texel(img, x0, y0 + 1, c, edge), e = texel(img, x0 + 1, y0 + 1, c, edge);
    return (a + (b - a) * tx) * (1.0f - ty) + (d + (e - d) * tx) * ty;
}

/* One row's interior (x in [1, w - 2]): direct indexing, no edge rules, the same arithmetic as
 * the edge path, so the same bytes. Blocks of HBK_NB texels: first the three components into
 * small arrays (a loop the compiler vectorises, sqrtf included thanks to -fno-math-errno), then
 * the interleaved stores, specialised for the common 3- and 4-channel layouts. */
enum { HBK_NB = 64 };

__attribute__((target_clones("avx2", "default"))) static void interior_normals(const hbk_image_t *height, int32_t y, int32_t w, float sx, float sy,
                             int32_t encode, float *row, int32_t nc)
{
    const float *c = height->data + (size_t)y * height->row_stride;
    const float *up = c + height->row_stride, *dn = c - height->row_stride;
    for (int32_t x0 = 1; x0 < w - 1; x0 += HBK_NB) {
        const int32_t n = w - 1 - x0 < HBK_NB ? w - 1 - x0 : HBK_NB;
        float n0[HBK_NB], n1[HBK_NB], n2[HBK_NB];
        const float *cc = c + x0, *uu = up + x0, *dd = dn + x0;
        for (int32_t k = 0; k < n; ++k) {
            const float dx = (cc[k + 1] - cc[k - 1]) * sx;
            const float dy = (uu[k] - dd[k]) * sy;
            const float inv = 1.0f / sqrtf(dx * dx + dy * dy + 1.0f);
            n0[k] = -dx * inv;
            n1[k] = -dy * inv;
            n2[k] = inv;
        }
        if (encode)
            for (int32_t k = 0; k < n; ++k) {
                n0[k] = n0[k] * 0.5f + 0.5f;
                n1[k] = n1[k] * 0.5f + 0.5f;
                n2[k] = n2[k] * 0.5f + 0.5f;
            }
        float *px = row + (size_t)x0 * (size_t)nc;
        if (nc == 3) {
            for (int32_t k = 0; k < n; ++k) {
                px[3 * k] = n0[k];
                px[3 * k + 1] = n1[k];
                px[3 * k + 2] = n2[k];
            }
        } else {
            for (int32_t k = 0; k < n; ++k) {
                px[4 * k] = n0[k];
                px[4 * k + 1] = n1[k];
                px[4 * k + 2] = n2[k];
                px[4 * k + 3] = 1.0f;
            }
        }
    }
}

hbk_result_t hbk_normal_map(const hbk_image_t *height, float texel_size_x, float texel_size_y,
                            float strength, int32_t edge, int32_t encode, hbk_image_t *out,
                            hbk_message_t *msg)
{
    hbk_message_clear(msg);
    hbk_result_t r = hbk_image_check(height, "height", msg);
    if (r) return r;
    if ((r = hbk_image_check(out, "out", msg))) return r;
    if (height->channels != 1)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "height.channels = %d: must be 1",
                        height->channels);
    if (out->channels < 3)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out.channels = %d: must be 3 or 4",
                        out->channels);
    if (out->width != height->width || out->height != height->height)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "out size = %dx%d: must equal height size %dx%d", out->width,
                        out->height, height->width, height->height);
    /* An infinite height makes NaN normals around it; past 1e6 m the slopes overflow too. */
    if ((r = hbk_image_check_values(height, "height", -1e6, 1e6, "", msg))) return r;
    if (!(texel_size_x > 0.0f) || !(texel_size_y > 0.0f) || !isfinite(texel_size_x) ||
        !isfinite(texel_size_y))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "texel_size = (%g, %g): must be finite and > 0", (double)texel_size_x,
                        (double)texel_size_y);
    if (!isfinite(strength) || strength < 0.0f || strength > 1000.0f)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "strength = %g: must be in [0, 1000]",
                        (double)strength);
    if (edge < HBK_EDGE_CLAMP || edge > HBK_EDGE_MIRROR)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "edge = %d: must be 0 (clamp), 1 (wrap) "
                        "or 2 (mirror)", edge);

    const int32_t w = height->width, h = height->height, nc = out->channels;
    const float sx = strength / (2.0f * texel_size_x), sy = strength / (2.0f * texel_size_y);
    if (!isfinite(sx) || !isfinite(sy)) /* else a flat field gives 0 * inf = NaN normals */
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "texel_size = (%g, %g): too small for strength = %g (strength / (2 "
                        "texel_size) must be a finite float)", (double)texel_size_x,
                        (double)texel_size_y, (double)strength);
#pragma omp parallel for schedule(static)
    for (int32_t y = 0; y < h; ++y) {
        float *row = out->data + (size_t)y * out->row_stride;
        const int interior_row = y > 0 && y < h - 1;
        for (int32_t x = 0; x < w; ++x) {
            if (interior_row && x == 1 && w > 2) {
                interior_normals(height, y, w, sx, sy, encode, row, nc);
                x = w - 2;
                continue;
            }
            float dx = (texel(height, x + 1, y, 0, edge) - texel(height, x - 1, y, 0, edge)) * sx;
            float dy = (texel(height, x, y + 1, 0, edge) - texel(height, x, y - 1, 0, edge)) * sy;
            float inv = 1.0f / sqrtf(dx * dx + dy * dy + 1.0f);
            float n[3] = {-dx * inv, -dy * inv, inv};
            float *px = row + (size_t)x * (size_t)nc;
            for (int k = 0; k < 3; ++k) px[k] = encode ? n[k] * 0.5f + 0.5f : n[k];
            if (nc == 4) px[3] = 1.0f;
        }
    }
    return HBK_OK;
}
