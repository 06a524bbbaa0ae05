/* The maps (paper §5): metaballs summed into row bands, the threshold and the compression
 * passes applied to each band while it is in cache; and the wetness map.
 *
 * Every drop becomes one or more balls (its sub-metaballs). Balls are binned by the bands of
 * BAND rows they reach, in ball order, and each band is filled by one thread: a texel
 * therefore sums the same balls in the same order whatever the thread count, and the bytes
 * never depend on it. The kernel 1 / (1 + t^2), t = (h / R)^2, is evaluated directly, four
 * texels at a time: a lookup table would not vectorise nor match the paper's formula exactly.
 * (Summing a drop's sub-metaballs as one fraction, one division per texel instead of four,
 * measured slower: the division is not the bottleneck.) */
#include "internal_rain.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define BAND 32
/* Floats per ball: centre (texels), 1 / R^2 along x and y, weight, support^2 in (h / R)^2,
 * and its box of texels (x0, x1, y0, y1; integers stored as floats, exact below 2^24). */
enum { B_CX, B_CY, B_IRX2, B_IRY2, B_W, B_S2, B_X0, B_X1, B_Y0, B_Y1, B_N };

/* Texels (rows or columns) a ball reaches along one axis: centres c - 0.5 +- reach, clipped
 * to [0, n - 1]; empty if *lo > *hi. */
static inline void ball_span(float c, float reach, int32_t n, int32_t *lo, int32_t *hi)
{
    const float a = c - 0.5f - reach, b = c - 0.5f + reach;
    int32_t l = a < -1.0f ? 0 : ifloor(a), u = b > (float)n ? n - 1 : ifloor(b);
    if ((float)l < a) ++l; /* ceil */
    *lo = l < 0 ? 0 : l;
    *hi = u > n - 1 ? n - 1 : u;
}

/* Appends a ball of radius r cells at (x, y) cells, unless it misses the map. */
static float *add_ball(float *b, const hbk_rain_t *h, float x, float y, float r, float w,
                       float s2)
{
    const float sx = (float)h->p.map_width / (float)h->p.width;
    const float sy = (float)h->p.map_height / (float)h->p.height;
    const float rx = r * sx, ry = r * sy;
    if (!(rx > 0.0f && ry > 0.0f)) return b;
    b[B_CX] = x * sx;
    b[B_CY] = y * sy;
    b[B_IRX2] = 1.0f / (rx * rx);
    b[B_IRY2] = 1.0f / (ry * ry);
    b[B_W] = w;
    b[B_S2] = s2;
    int32_t x0, x1, y0, y1;
    const float reach = sqrtf(s2);
    ball_span(b[B_CX], rx * reach, h->p.map_width, &x0, &x1);
    ball_span(b[B_CY], ry * reach, h->p.map_height, &y0, &y1);
    if (x0 > x1 || y0 > y1) return b;
    b[B_X0] = (float)x0;
    b[B_X1] = (float)x1;
    b[B_Y0] = (float)y0;
    b[B_Y1] = (float)y1;
    return b + B_N;
}

/* Fills h->balls; `disc`: one ball per drop, out to radius_scale * r (wetness). Returns the
 * ball count, or -1 when out of memory. */
static int64_t build_balls(hbk_rain_t *h, int disc)
{
    const hbk_rain_params_t *p = &h->p;
    const int32_t n = disc ? 1 : p->sub_count;
    int64_t most = h->particle_count;
    for (int64_t i = 0; i < h->drop_count; ++i)
        most += (h->drops[i].flags & DROP_TRAIL) ? 1 : n;
    if (most > h->ball_cap) {
        float *b = realloc(h->balls, (size_t)(most > 0 ? most : 1) * B_N * sizeof *b);
        if (!b) return -1;
        h->balls = b;
        h->ball_cap = most;
    }
    const float s2 = disc ? 1.0f : p->kernel_support * p->kernel_support;
    float *b = h->balls;
    for (int64_t i = 0; i < h->drop_count; ++i) {
        const rain_drop_t *d = &h->drops[i];
        if (d->flags & DROP_DEAD) continue;
        const float r = rain_radius_cells(h, d->mass) * p->radius_scale;
        if ((d->flags & DROP_TRAIL) || n == 1) {
            b = add_ball(b, h, d->x, d->y, r, 1.0f, s2);
            continue;
        }
        /* Sub-metaballs of weight 1/n: all on the centre they are exactly one drop. */
        const float w = 1.0f / (float)n;
        for (int32_t k = 0; k < n; ++k) {
            const float f = k == 0 ? 1.0f : 0.8f + 0.2f * (float)d->scale[k] / 255.0f;
            b = add_ball(b, h, d->x + d->off[k][0] * r, d->y + d->off[k][1] * r, r * f, w, s2);
        }
    }
    for (int64_t i = 0; i < h->particle_count; ++i) {
        const rain_particle_t *q = &h->particles[i];
        b = add_ball(b, h, q->x, q->y, rain_radius_cells(h, q->mass) * p->radius_scale, 1.0f, s2);
    }
    return (int64_t)(b - h->balls) / B_N;
}

/* Lists the balls of every band in ball order (band_start / band_items). */
static int bin_balls(hbk_rain_t *h, int64_t nballs, int32_t H)
{
    const int32_t nbands = (H + BAND - 1) / BAND;
    if (nbands + 1 > h->band_cap) {
        uint32_t *s = realloc(h->band_start, (size_t)(nbands + 1) * sizeof *s);
        if (!s) return 0;
        h->band_start = s;
        h->band_cap = nbands + 1;
    }
    uint32_t *start = h->band_start;
    memset(start, 0, (size_t)(nbands + 1) * sizeof *start);
    int64_t total = 0;
    for (int64_t i = 0; i < nballs; ++i) {
        const float *ball = h->balls + i * B_N;
        const int32_t y0 = (int32_t)ball[B_Y0], y1 = (int32_t)ball[B_Y1];
        for (int32_t b = y0 / BAND; b <= y1 / BAND; ++b) start[b + 1]++, ++total;
    }
    if (total > UINT32_MAX) return 0;
    if (total > h->band_item_cap) {
        uint32_t *it = realloc(h->band_items, (size_t)total * sizeof *it);
        if (!it) return 0;
        h->band_items = it;
        h->band_item_cap = total;
    }
    for (int32_t b = 0; b < nbands; ++b) start[b + 1] += start[b];
    for (int64_t i = 0; i < nballs; ++i) {
        const float *ball = h->balls + i * B_N;
        const int32_t y0 = (int32_t)ball[B_Y0], y1 = (int32_t)ball[B_Y1];
        for (int32_t b = y0 / BAND; b <= y1 / BAND; ++b) h->band_items[start[b]++] = (uint32_t)i;
    }
    for (int32_t b = nbands; b > 0; --b) start[b] = start[b - 1];
    start[0] = 0;
    return 1;
}

typedef float v4f __attribute__((vector_size(16)));
typedef int32_t v4i __attribute__((vector_size(16)));
typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));

/* Adds (or, for discs, sets to 1 inside) one ball into a band buffer holding rows [r0, r1]
 * with `stride` floats per row (room for 15 more than the map width): over the ball's bounding
 * box, L texels at a time (vector types VF / VI), each lane masked to 0 outside the ball's
 * support (h > support * R) or past the box. A per-row span would need a square root and two
 * roundings per row, and a scalar remainder loop; at the ~16 x 16 texels a drop covers those
 * cost more than the masked lanes. Every lane does the scalar formula's correctly rounded
 * operations in the same order, so any L gives the same bytes. */
#define SPLAT_BODY(VF, VI, L)                                                                  \
    const int32_t x0 = (int32_t)b[B_X0], x1 = (int32_t)b[B_X1];                                \
    const int32_t y0 = (int32_t)b[B_Y0] > r0 ? (int32_t)b[B_Y0] : r0;                          \
    const int32_t y1 = (int32_t)b[B_Y1] < r1 ? (int32_t)b[B_Y1] : r1;                          \
    const float cx = b[B_CX], cy = b[B_CY], irx2 = b[B_IRX2], iry2 = b[B_IRY2], w = b[B_W];    \
    const float s2 = b[B_S2];                                                                  \
    VF half, one;                                                                              \
    VI lane;                                                                                   \
    for (int k = 0; k < L; ++k) half[k] = (float)k + 0.5f, one[k] = 1.0f, lane[k] = k;         \
    for (int32_t y = y0; y <= y1; ++y) {                                                       \
        const float dy = (float)y + 0.5f - cy, ty = dy * dy * iry2;                            \
        float *row = band + (size_t)(y - r0) * stride;                                         \
        for (int32_t x = x0; x <= x1; x += L) {                                                \
            /* (x + k + 0.5) - cx, rounded as the scalar formula rounds it. */                 \
            const VF dx = ((float)x + half) - cx;                                              \
            const VF t = dx * dx * irx2 + ty;                                                  \
            const VI keep = (t <= s2) & ((x + lane) <= x1);                                    \
            VF acc;                                                                            \
            memcpy(&acc, row + x, sizeof acc);                                                 \
            if (disc) { /* s2 is 1: inside the contact circle */                               \
                acc = (VF)(((VI)one & keep) | ((VI)acc & ~keep));                              \
            } else {                                                                           \
                const VF v = w / (1.0f + t * t);                                               \
                acc += (VF)((VI)v & keep);                                                     \
            }                                                                                  \
            memcpy(row + x, &acc, sizeof acc);                                                 \
        }                                                                                      \
    }

static void splat4(const float *b, float *band, size_t stride, int32_t r0, int32_t r1, int disc)
{
    SPLAT_BODY(v4f, v4i, 4)
}

/* Eight lanes where the CPU has AVX2 (chosen at run time; without it GCC would lower the
 * 32-byte vectors to slow SSE code). AVX2 does not bring FMA here, so the bytes are the same. */
#if defined(__x86_64__) && defined(__GNUC__)
#define RAIN_HAVE_SPLAT8 1
__attribute__((target("avx2"))) static void splat8(const float *b, float *band, size_t stride,
                                                   int32_t r0, int32_t r1, int disc)
{
    SPLAT_BODY(v8f, v8i, 8)
}
/* Sixteen where AVX-512 is there: a drop's box (10 to 16 texels wide at 2048^2) in one go.
 * AVX-512 brings FMA, which GCC would fuse a * b + c into (one rounding, not two): not here,
 * so the bytes stay those of 4 or 8 lanes. */
typedef float v16f __attribute__((vector_size(64)));
typedef int32_t v16i __attribute__((vector_size(64)));
__attribute__((target("avx512f"), optimize("fp-contract=off"))) static void splat16(const float *b, float *band,
                                                      size_t stride, int32_t r0, int32_t r1,
                                                      int disc)
{
    SPLAT_BODY(v16f, v16i, 16)
}
#endif
#undef SPLAT_BODY

static hbk_result_t check_map(hbk_rain_t *h, const hbk_image_t *img, const char *name)
{
    hbk_result_t r = hbk_image_check(img, name, &h->msg);
    if (r) return r;
    if (img->width != h->p.map_width || img->height != h->p.map_height)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s size = %d x %d: must be the map "
                        "size, %d x %d", name, img->width, img->height, h->p.map_width,
                        h->p.map_height);
    if (img->channels != 1)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s.channels = %d: must be 1", name,
                        img->channels);
    return HBK_OK;
}

/* The threshold, compression passes and scale, with the constants hoisted. */
typedef struct {
    float thr, hs, k;
    int32_t passes;
    float v0[64];
} finalize_t;

static void finalize_init(finalize_t *f, const hbk_rain_params_t *p)
{
    f->thr = p->threshold;
    f->hs = p->height_scale;
    f->k = p->compress_k;
    f->passes = p->compress_passes;
    /* The same float expression rain_compress_value uses, so the values match bit for bit. */
    for (int32_t k = 0; k < p->compress_passes; ++k)
        f->v0[k] = p->compress_v0 + (float)k * p->compress_step;
}

/* Writes one row of the map from the band buffer's row `src` (W texels, padded to a multiple
 * of 16 by the stride) and clears `src` for the next band in the same pass. Dry stretches
 * (no texel above the threshold) are tested 16 texels at a time: drops are small and far
 * apart, so that branch is well predicted where a test per 4 texels is not. */
static void finalize_row(const finalize_t *f, float *src, float *dst, int32_t W)
{
    const v4f zero = {0.0f, 0.0f, 0.0f, 0.0f};
    for (int32_t x = 0; x < W; x += 16) {
        v4f s[4];
        memcpy(s, src + x, sizeof s);
        memset(src + x, 0, sizeof s);
        const int32_t n = W - x < 16 ? W - x : 16;
        const v4i any = (s[0] > f->thr) | (s[1] > f->thr) | (s[2] > f->thr) | (s[3] > f->thr);
        if (!(any[0] | any[1] | any[2] | any[3])) {
            memset(dst + x, 0, (size_t)n * sizeof *dst); /* most of the glass is dry */
            continue;
        }
        v4f out[4];
        for (int q = 0; q < 4; ++q) {
            v4f v = s[q] - f->thr;
            const v4i pos = v > zero;
            /* V0 only rises and a pass never lifts V above its V0: once no lane is above
             * this pass's V0, no later pass changes anything (single drops stop at once). */
            for (int32_t k = 0; k < f->passes; ++k) {
                const v4i m = v > f->v0[k];
                if (!(m[0] | m[1] | m[2] | m[3])) break;
                const v4f c = f->k * (v - f->v0[k]) + f->v0[k];
                v = (v4f)(((v4i)c & m) | ((v4i)v & ~m));
            }
            out[q] = (v4f)((v4i)(v * f->hs) & pos);
        }
        memcpy(dst + x, out, (size_t)n * sizeof *dst);
    }
}

/* Builds the balls and the bands, then fills each band in a thread's band buffer and writes
 * it out: height (threshold, compression, scale) or wetness (fade, then discs). */
static hbk_result_t render(hbk_rain_t *h, hbk_image_t *img, int disc)
{
    const hbk_rain_params_t *p = &h->p;
    const int32_t W = img->width, H = img->height, nbands = (H + BAND - 1) / BAND;
    const int threads = hbk_threads(p->threads);
    /* Room for a last 16-lane group of the splat, and whole 16-texel groups for finalize_row. */
    const size_t stride = ((size_t)W + 15 + 15) & ~(size_t)15;
    const size_t per = stride * BAND;
    if ((size_t)threads * per > h->band_buf_size) {
        /* Kept zeroed between uses: each band is cleared as it is written out. */
        free(h->band_buf);
        h->band_buf_size = 0;
        if (!(h->band_buf = calloc((size_t)threads * per, sizeof *h->band_buf)))
            return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "map: out of memory");
        h->band_buf_size = (size_t)threads * per;
    }
    const int64_t nballs = build_balls(h, disc);
    if (nballs < 0 || !bin_balls(h, nballs, H))
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "map: out of memory for the metaballs");
    finalize_t fin;
    finalize_init(&fin, p);
#ifdef RAIN_HAVE_SPLAT8
    const int paths = hbk_paths();
    const int wide = paths >= HBK_PATHS_AVX2, wider = paths >= HBK_PATHS_AVX512;
#endif
    const float now = (float)h->time, life = p->wet_lifetime;
    const float cw = (float)p->width / (float)W, ch = (float)p->height / (float)H;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (int32_t band = 0; band < nbands; ++band) {
        float *buf = h->band_buf + per * (size_t)omp_get_thread_num();
        const int32_t r0 = band * BAND, r1 = r0 + BAND - 1 < H - 1 ? r0 + BAND - 1 : H - 1;
        for (int32_t y = r0; y <= r1; ++y) {
            float *row = buf + (size_t)(y - r0) * stride;
            if (!disc) continue; /* already zero */
            /* Wetness where drops ran: fades from 1 to 0 over wet_lifetime. */
            int32_t cy = (int32_t)(((float)y + 0.5f) * ch);
            cy = cy < p->height ? cy : p->height - 1;
            const float *wt = h->wet_time + (size_t)cy * (size_t)p->width;
            for (int32_t x = 0; x < W; ++x) {
                int32_t cx = (int32_t)(((float)x + 0.5f) * cw);
                cx = cx < p->width ? cx : p->width - 1;
                const float f = 1.0f - (now - wt[cx]) / life;
                row[x] = f > 1.0f ? 1.0f : f > 0.0f ? f : 0.0f;
            }
        }
        for (uint32_t k = h->band_start[band]; k < h->band_start[band + 1]; ++k) {
            const float *b = h->balls + (size_t)h->band_items[k] * B_N;
#ifdef RAIN_HAVE_SPLAT8
            if (wider) {
                splat16(b, buf, stride, r0, r1, disc);
                continue;
            }
            if (wide) {
                splat8(b, buf, stride, r0, r1, disc);
                continue;
            }
#endif
            splat4(b, buf, stride, r0, r1, disc);
        }
        for (int32_t y = r0; y <= r1; ++y) {
            float *src = buf + (size_t)(y - r0) * stride;
            float *dst = img->data + (size_t)y * img->row_stride;
            if (disc) {
                memcpy(dst, src, (size_t)W * sizeof *dst);
                memset(src, 0, (size_t)W * sizeof *src);
            } else {
                finalize_row(&fin, src, dst, W);
            }
        }
    }
    return HBK_OK;
}

hbk_result_t hbk_rain_heightmap(hbk_rain_t *h, hbk_image_t *height)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    hbk_result_t r = check_map(h, height, "height");
    return r ? r : render(h, height, 0);
}

hbk_result_t hbk_rain_wetness(hbk_rain_t *h, hbk_image_t *out)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    hbk_result_t r = check_map(h, out, "out");
    return r ? r : render(h, out, 1);
}
