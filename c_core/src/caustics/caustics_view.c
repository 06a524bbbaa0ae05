/* View refraction (paper §3.2) and the lit ground (§3.1's texture x light pattern). */
#include "internal_caustics.h"
#include <math.h>
#include <omp.h>
#include <string.h>

hbk_result_t hbk_caustics_view(const hbk_caustics_params_t *p, const hbk_image_t *water_height,
                               const hbk_image_t *ground_height, float cell_size,
                               const float camera[3], hbk_image_t *out_uv,
                               hbk_image_t *out_reflect, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    hbk_result_t r = hbk_caustics_check_inputs(p, water_height, ground_height, cell_size, msg);
    if (r || (r = hbk_image_check(out_uv, "out_uv", msg))) return r;
    const int32_t W = water_height->width, H = water_height->height;
    if (out_uv->width != W || out_uv->height != H || out_uv->channels < 2)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "out_uv = %d x %d x %d channels: must be %d x %d with 2 to 4 channels",
                        out_uv->width, out_uv->height, out_uv->channels, W, H);
    if (out_reflect) {
        if ((r = hbk_image_check(out_reflect, "out_reflect", msg))) return r;
        if (out_reflect->width != W || out_reflect->height != H || out_reflect->channels != 3)
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                            "out_reflect = %d x %d x %d channels: must be %d x %d x 3",
                            out_reflect->width, out_reflect->height, out_reflect->channels, W, H);
    }
    if (!camera) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "camera: must not be NULL");
    float top = -INFINITY;
    for (int32_t y = 0; y < H; ++y)
        for (int32_t x = 0; x < W; ++x)
            top = fmaxf(top, water_height->data[(size_t)y * water_height->row_stride + (size_t)x]);
    for (int k = 0; k < 3; ++k)
        if (!(camera[k] >= -1e6f && camera[k] <= 1e6f))
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                            "camera[%d] = %g: must be a finite number in [-1e6, 1e6] m", k,
                            (double)camera[k]);
    if (!(camera[2] > top))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "camera[2] = %g: the camera must be above the water (highest surface "
                        "%g m)", (double)camera[2], (double)top);
    hbk_caustics_workspace_t ws = {0};
    hbk_caustics_ctx_t c;
    hbk_caustics_init(&c, &ws, p, water_height, ground_height, cell_size);
    if ((r = hbk_caustics_setup_ground(&c))) {
        hbk_cs_release(&ws);
        return hbk_fail(msg, r, "view: out of memory");
    }
    double ex0 = 0.0, ey0 = 0.0, ex1 = W * c.dx, ey1 = H * c.dx;
    if (!p->auto_extent) {
        ex0 = p->extent[0];
        ey0 = p->extent[1];
        ex1 = p->extent[2];
        ey1 = p->extent[3];
    }
    const double ior = p->ior[1];
#pragma omp parallel for num_threads(c.threads) schedule(dynamic, 4)
    for (int32_t j = 0; j < H; ++j)
        for (int32_t i = 0; i < W; ++i) {
            const double s[3] = {(i + 0.5) * c.dx, (j + 0.5) * c.dx,
                                 water_height->data[(size_t)j * water_height->row_stride + (size_t)i]};
            double v[3], len = 0.0, n[3] = {0.0, 0.0, 1.0}, hit[3] = {s[0], s[1], s[2]};
            for (int k = 0; k < 3; ++k) len += (camera[k] - s[k]) * (camera[k] - s[k]);
            len = sqrt(len);
            for (int k = 0; k < 3; ++k) v[k] = (camera[k] - s[k]) / len; /* towards the eye */
            double path = 0.0, refl = 0.0;
            if (hbk_caustics_wet(&c, i, j)) {
                double rd[3];
                hbk_caustics_normal(&c, i, j, n);
                hbk_caustics_refract(v, n, 1.0 / ior, rd);
                path = hbk_caustics_march(&c, s, rd);
                for (int k = 0; k < 3; ++k) hit[k] = s[k] + path * rd[k];
                const double cos_i = n[0] * v[0] + n[1] * v[1] + n[2] * v[2];
                refl = 1.0 - hbk_caustics_fresnel_t(cos_i, ior);
            }
            float *o = out_uv->data + (size_t)j * out_uv->row_stride + (size_t)i * (size_t)out_uv->channels;
            o[0] = (float)((hit[0] - ex0) / (ex1 - ex0));
            o[1] = (float)((hit[1] - ey0) / (ey1 - ey0));
            if (out_uv->channels > 2) o[2] = (float)path;
            if (out_uv->channels > 3) o[3] = (float)refl;
            if (out_reflect) {
                const double d = 2.0 * (n[0] * v[0] + n[1] * v[1] + n[2] * v[2]);
                float *q = out_reflect->data + (size_t)j * out_reflect->row_stride + 3 * (size_t)i;
                for (int k = 0; k < 3; ++k) q[k] = (float)(d * n[k] - v[k]);
            }
        }
    hbk_cs_release(&ws);
    return HBK_OK;
}

hbk_result_t hbk_caustics_lit_ground(const hbk_image_t *texture, const hbk_image_t *caustics,
                                     int32_t edge, hbk_image_t *out, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    hbk_result_t r;
    if ((r = hbk_image_check(texture, "texture", msg)) ||
        (r = hbk_image_check(caustics, "caustics", msg)) || (r = hbk_image_check(out, "out", msg)))
        return r;
    const hbk_image_t *imgs[3] = {texture, caustics, out};
    static const char *const names[3] = {"texture", "caustics", "out"};
    for (int k = 0; k < 3; ++k)
        if (imgs[k]->channels < 3)
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s.channels = %d: must be 3 or 4",
                            names[k], imgs[k]->channels);
    if (out->width != texture->width || out->height != texture->height)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "out size = %d x %d: must equal the texture's, %d x %d", out->width,
                        out->height, texture->width, texture->height);
    if (edge < HBK_EDGE_CLAMP || edge > HBK_EDGE_MIRROR)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "edge = %d: must be 0 (clamp), 1 (wrap) or 2 (mirror)", edge);
    /* A NaN or infinite texel would come out as such in the lit ground. */
    if ((r = hbk_image_check_values(texture, "texture", -1e6, 1e6, "", msg)) ||
        (r = hbk_image_check_values(caustics, "caustics", -1e6, 1e6, "", msg)))
        return r;
    const double fx = (double)caustics->width / texture->width;
    const double fy = (double)caustics->height / texture->height;
#pragma omp parallel for schedule(static)
    for (int32_t y = 0; y < texture->height; ++y) {
        const float my = (float)((y + 0.5) * fy - 0.5);
        for (int32_t x = 0; x < texture->width; ++x) {
            const float mx = (float)((x + 0.5) * fx - 0.5);
            const float *t = texture->data + (size_t)y * texture->row_stride + (size_t)x * (size_t)texture->channels;
            float *o = out->data + (size_t)y * out->row_stride + (size_t)x * (size_t)out->channels;
            const float alpha = texture->channels == 4 ? t[3] : 1.0f;
            float v[3];
            for (int k = 0; k < 3; ++k) v[k] = t[k] * hbk_image_sample(caustics, mx, my, k, edge);
            for (int k = 0; k < 3; ++k) o[k] = v[k];
            if (out->channels == 4) o[3] = alpha;
        }
    }
    return HBK_OK;
}
