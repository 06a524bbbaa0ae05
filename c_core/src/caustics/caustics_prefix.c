/* The caustic map's pixels from a band's accumulator: a prefix sum along each row (the
 * accumulator holds per-pixel differences), scaled to the irradiance, and the accumulator
 * cleared for the next band. */
#include "internal_raster.h"

static inline void store4(float *q, v4d v) /* v to floats, rounded as (float) does */
{
    const v4f f = __builtin_convertvector(v, v4f);
    memcpy(q, &f, sizeof f);
}

/* Pixels [x, MW) of a mono row from its sum s so far; clears the accumulator. */
static void prefix_mono_tail(double *a, float *px, int32_t x, int32_t MW, int nc, double s,
                             const double e[3])
{
    for (; x < MW; ++x) {
        s += a[x];
        a[x] = 0.0;
        const double v = s > 0.0 ? s : 0.0; /* below 0 only by rounding */
        float *q = px + (size_t)x * (size_t)nc;
        for (int k = 0; k < 3; ++k) q[k] = (float)(v * e[k]);
        if (nc == 4) q[3] = 1.0f;
    }
}

/* Row R's next four pixels from its running sum sR. */
#define PREFIX_MONO4(R)                                                                      \
    do {                                                                                     \
        double *const p_ = a[R] + x;                                                         \
        const double v0 = (s##R += p_[0]) > 0.0 ? s##R : 0.0; /* < 0 only by rounding */    \
        const double v1 = (s##R += p_[1]) > 0.0 ? s##R : 0.0;                                \
        const double v2 = (s##R += p_[2]) > 0.0 ? s##R : 0.0;                                \
        const double v3 = (s##R += p_[3]) > 0.0 ? s##R : 0.0;                                \
        memset(p_, 0, 4 * sizeof(double));                                                  \
        float *const q = px[R] + (size_t)x * (size_t)nc;                                     \
        if (nc == 3) {                                                                       \
            store4(q, (v4d){v0, v0, v0, v1} * e3a);                                          \
            store4(q + 4, (v4d){v1, v1, v2, v2} * e3b);                                      \
            store4(q + 8, (v4d){v2, v3, v3, v3} * e3c);                                      \
        } else {                                                                             \
            store4(q, (v4d){v0, v0, v0, 1.0} * e4);                                          \
            store4(q + 4, (v4d){v1, v1, v1, 1.0} * e4);                                      \
            store4(q + 8, (v4d){v2, v2, v2, 1.0} * e4);                                      \
            store4(q + 12, (v4d){v3, v3, v3, 1.0} * e4);                                     \
        }                                                                                    \
    } while (0)

/* Four mono rows of an RGB or RGBA map side by side, so four chains of additions overlap
 * (each row still adds in x order: the bytes of prefix_mono_tail), four pixels at a time, so
 * the pixels leave in 16-byte stores: three (RGB) or four (RGBA) per four pixels instead of
 * twelve or sixteen. */
static void prefix_mono4(double *const a[4], float *const px[4], int32_t MW, int nc,
                         const double e[3])
{
    const v4d e3a = {e[0], e[1], e[2], e[0]}, e3b = {e[1], e[2], e[0], e[1]},
              e3c = {e[2], e[0], e[1], e[2]}, e4 = {e[0], e[1], e[2], 1.0};
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int32_t x = 0;
    for (; x + 4 <= MW; x += 4) {
        PREFIX_MONO4(0);
        PREFIX_MONO4(1);
        PREFIX_MONO4(2);
        PREFIX_MONO4(3);
    }
    prefix_mono_tail(a[0], px[0], x, MW, nc, s0, e);
    prefix_mono_tail(a[1], px[1], x, MW, nc, s1, e);
    prefix_mono_tail(a[2], px[2], x, MW, nc, s2, e);
    prefix_mono_tail(a[3], px[3], x, MW, nc, s3, e);
}
#undef PREFIX_MONO4

/* Writes rows [y, y + n) of the map (n <= 4) from the band's accumulator by prefix sums along
 * each row, and clears the accumulator for the next band. */
void hbk_cr_prefix_rows(const hbk_caustics_ctx_t *c, const band_t *b, int32_t y, int32_t n,
                        hbk_image_t *out)
{
    const int nc = out->channels;
    double *a[4];
    float *px[4];
    for (int r = 0; r < 4; ++r) {
        const int32_t yy = y + (r < n ? r : n - 1);
        a[r] = b->buf + (size_t)(yy - b->B0) * b->rowlen;
        px[r] = out->data + (size_t)yy * out->row_stride;
    }
    if (c->ps == 1 && n == 4 && (nc == 3 || nc == 4)) {
        prefix_mono4(a, px, c->MW, nc, c->escale);
    } else if (c->ps == 1) {
        for (int32_t r = 0; r < n; ++r) prefix_mono_tail(a[r], px[r], 0, c->MW, nc, 0.0, c->escale);
    } else {
        for (int32_t r = 0; r < n; ++r) {
            double s0 = 0.0, s1 = 0.0, s2 = 0.0, *q = a[r];
            float *o = px[r];
            for (int32_t x = 0; x < c->MW; ++x, q += 3, o += nc) {
                s0 += q[0];
                s1 += q[1];
                s2 += q[2];
                q[0] = q[1] = q[2] = 0.0;
                o[0] = s0 > 0.0 ? (float)s0 : 0.0f;
                o[1] = s1 > 0.0 ? (float)s1 : 0.0f;
                o[2] = s2 > 0.0 ? (float)s2 : 0.0f;
                if (nc == 4) o[3] = 1.0f;
            }
        }
    }
    /* The pixels past the edge take writes that affect no pixel: clear them too. */
    for (int32_t r = 0; r < n; ++r)
        memset(b->buf + (size_t)(y + r - b->B0) * b->rowlen + (size_t)c->ps * (size_t)c->MW, 0,
               (size_t)c->ps * HBK_PAD * sizeof(double));
}
