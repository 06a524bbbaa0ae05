/* Water handle: life cycle, setters, getters, checkpoints. The solver is in water_step.c. */
#include "internal_water.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

hbk_result_t hbk_water_create(hbk_water_t **out, const hbk_water_params_t *p, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!out) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out: must not be NULL");
    *out = NULL;
    hbk_result_t r = hbk_water_params_check(p, msg);
    if (r) return r;
    hbk_water_t *h = calloc(1, sizeof *h);
    if (!h) return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "water handle: out of memory");
    h->p = *p;
    h->n = (size_t)p->width * (size_t)p->height;
    h->ground = calloc(h->n, sizeof *h->ground);
    h->depth = calloc(h->n, sizeof *h->depth);
    h->vel_x = calloc(h->n, sizeof *h->vel_x);
    h->vel_y = calloc(h->n, sizeof *h->vel_y);
    h->backup = malloc(3 * h->n * sizeof *h->backup);
    if (!h->ground || !h->depth || !h->vel_x || !h->vel_y || !h->backup) {
        hbk_water_destroy(h);
        return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "water grid %d x %d: out of memory",
                        p->width, p->height);
    }
    *out = h;
    return HBK_OK;
}

void hbk_water_destroy(hbk_water_t *h)
{
    if (!h) return;
    free(h->ground);
    free(h->depth);
    free(h->vel_x);
    free(h->vel_y);
    free(h->sources);
    free(h->accel);
    free(h->footprint);
    free(h->backup);
    free(h->scratch);
    free(h);
}

const char *hbk_water_message(const hbk_water_t *h) { return h ? h->msg.text : "handle is NULL"; }

/* Checks that `img` is a width x height view with `channels` channels. */
static hbk_result_t check_view(hbk_water_t *h, const hbk_image_t *img, const char *name,
                               int32_t channels)
{
    hbk_result_t r = hbk_image_check(img, name, &h->msg);
    if (r) return r;
    if (img->width != h->p.width || img->height != h->p.height)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "%s size = %d x %d: must equal the grid, %d x %d", name, img->width,
                        img->height, h->p.width, h->p.height);
    if (img->channels != channels)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s.channels = %d: must be %d", name,
                        img->channels, channels);
    return HBK_OK;
}

/* Every value of `img` finite and in [lo, hi]; names the first bad pixel. */
static hbk_result_t check_values(hbk_water_t *h, const hbk_image_t *img, const char *name,
                                 double lo, double hi, const char *unit)
{
    return hbk_image_check_values(img, name, lo, hi, unit, &h->msg);
}

/* Copies an optional per-cell field into *dst (allocated on first use, freed for NULL). */
static hbk_result_t set_field(hbk_water_t *h, float **dst, const hbk_image_t *img,
                              const char *name, int32_t channels, double lo, double hi,
                              const char *unit)
{
    if (!img) {
        free(*dst);
        *dst = NULL;
        return HBK_OK;
    }
    hbk_result_t r = check_view(h, img, name, channels);
    if (r || (r = check_values(h, img, name, lo, hi, unit))) return r;
    if (!*dst && !(*dst = malloc(h->n * (size_t)channels * sizeof **dst)))
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "%s: out of memory", name);
    const size_t w = (size_t)h->p.width * (size_t)channels;
    for (int32_t y = 0; y < h->p.height; ++y)
        memcpy(*dst + (size_t)y * w, img->data + (size_t)y * img->row_stride, w * sizeof **dst);
    return HBK_OK;
}

#define HBK_WATER_ENTER(h)                                                              \
    do {                                                                                \
        if (!(h)) return HBK_ERR_INVALID_ARGUMENT;                                      \
        hbk_message_clear(&(h)->msg);                                                   \
    } while (0)

hbk_result_t hbk_water_set_ground(hbk_water_t *h, const hbk_image_t *ground)
{
    HBK_WATER_ENTER(h);
    if (!ground) {
        memset(h->ground, 0, h->n * sizeof *h->ground);
        return HBK_OK;
    }
    hbk_result_t r = check_view(h, ground, "ground", 1);
    if (r || (r = check_values(h, ground, "ground", -1e6, 1e6, "m"))) return r;
    for (int32_t y = 0; y < h->p.height; ++y)
        memcpy(h->ground + (size_t)y * (size_t)h->p.width, ground->data + (size_t)y * ground->row_stride,
               (size_t)h->p.width * sizeof *h->ground);
    return HBK_OK;
}

hbk_result_t hbk_water_set_level(hbk_water_t *h, float level)
{
    HBK_WATER_ENTER(h);
    if (!(level >= -1e6f && level <= 1e6f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "level = %g: must be a finite number in [-1e6, 1e6] m", (double)level);
    for (size_t i = 0; i < h->n; ++i) {
        double d = (double)level - (double)h->ground[i];
        h->depth[i] = d > 0.0 ? d : 0.0;
    }
    memset(h->vel_x, 0, h->n * sizeof *h->vel_x);
    memset(h->vel_y, 0, h->n * sizeof *h->vel_y);
    return HBK_OK;
}

hbk_result_t hbk_water_set_surface(hbk_water_t *h, const hbk_image_t *surface)
{
    HBK_WATER_ENTER(h);
    hbk_result_t r = check_view(h, surface, "surface", 1);
    if (r || (r = check_values(h, surface, "surface", -1e6, 1e6, "m"))) return r;
    const int32_t w = h->p.width;
    for (int32_t y = 0; y < h->p.height; ++y)
        for (int32_t x = 0; x < w; ++x) {
            size_t i = (size_t)y * (size_t)w + (size_t)x;
            double d = (double)surface->data[(size_t)y * surface->row_stride + (size_t)x] -
                       (double)h->ground[i];
            h->depth[i] = d > 0.0 ? d : 0.0;
        }
    memset(h->vel_x, 0, h->n * sizeof *h->vel_x);
    memset(h->vel_y, 0, h->n * sizeof *h->vel_y);
    return HBK_OK;
}

hbk_result_t hbk_water_set_depth(hbk_water_t *h, const hbk_image_t *depth)
{
    HBK_WATER_ENTER(h);
    hbk_result_t r = check_view(h, depth, "depth", 1);
    if (r || (r = check_values(h, depth, "depth", 0, 1e6, "m"))) return r;
    const int32_t w = h->p.width;
    for (int32_t y = 0; y < h->p.height; ++y)
        for (int32_t x = 0; x < w; ++x)
            h->depth[(size_t)y * (size_t)w + (size_t)x] =
                depth->data[(size_t)y * depth->row_stride + (size_t)x];
    return HBK_OK;
}

hbk_result_t hbk_water_set_sources(hbk_water_t *h, const hbk_image_t *ha)
{
    HBK_WATER_ENTER(h);
    return set_field(h, &h->sources, ha, "sources", 1, -1e3, 1e3, "m/s");
}

hbk_result_t hbk_water_set_acceleration(hbk_water_t *h, const hbk_image_t *ua)
{
    HBK_WATER_ENTER(h);
    return set_field(h, &h->accel, ua, "acceleration", 2, -1e3, 1e3, "m/s^2");
}

hbk_result_t hbk_water_set_footprint(hbk_water_t *h, const hbk_image_t *depth)
{
    HBK_WATER_ENTER(h);
    return set_field(h, &h->footprint, depth, "footprint", 1, 0, 1e3, "m");
}

hbk_result_t hbk_water_get_surface(hbk_water_t *h, hbk_image_t *out)
{
    HBK_WATER_ENTER(h);
    hbk_result_t r = check_view(h, out, "out", 1);
    if (r) return r;
    const int32_t w = h->p.width;
    for (int32_t y = 0; y < h->p.height; ++y)
        for (int32_t x = 0; x < w; ++x) {
            size_t i = (size_t)y * (size_t)w + (size_t)x;
            out->data[(size_t)y * out->row_stride + (size_t)x] =
                (float)((double)h->ground[i] + h->depth[i]);
        }
    return HBK_OK;
}

hbk_result_t hbk_water_get_depth(hbk_water_t *h, hbk_image_t *out)
{
    HBK_WATER_ENTER(h);
    hbk_result_t r = check_view(h, out, "out", 1);
    if (r) return r;
    const int32_t w = h->p.width;
    for (int32_t y = 0; y < h->p.height; ++y)
        for (int32_t x = 0; x < w; ++x)
            out->data[(size_t)y * out->row_stride + (size_t)x] =
                (float)h->depth[(size_t)y * (size_t)w + (size_t)x];
    return HBK_OK;
}

hbk_result_t hbk_water_get_velocity(hbk_water_t *h, hbk_image_t *out)
{
    HBK_WATER_ENTER(h);
    hbk_result_t r = check_view(h, out, "out", 2);
    if (r) return r;
    const int32_t w = h->p.width, ht = h->p.height;
    for (int32_t y = 0; y < ht; ++y)
        for (int32_t x = 0; x < w; ++x) {
            size_t i = (size_t)y * (size_t)w + (size_t)x;
            /* The face on the low side of the cell; at a wall it is the (zero) wall face. */
            double ul = x > 0 ? h->vel_x[i - 1] : h->p.periodic ? h->vel_x[i + (size_t)w - 1] : 0.0;
            double vl = y > 0 ? h->vel_y[i - (size_t)w]
                              : h->p.periodic ? h->vel_y[i + (size_t)(ht - 1) * (size_t)w] : 0.0;
            float *px = out->data + (size_t)y * out->row_stride + 2 * (size_t)x;
            px[0] = (float)(0.5 * (ul + h->vel_x[i]));
            px[1] = (float)(0.5 * (vl + h->vel_y[i]));
        }
    return HBK_OK;
}

double hbk_water_volume(const hbk_water_t *h)
{
    if (!h) return 0.0;
    double s = 0.0;
    for (size_t i = 0; i < h->n; ++i) s += h->depth[i];
    return s * (double)h->p.cell_size * (double)h->p.cell_size;
}

uint64_t hbk_water_step_count(const hbk_water_t *h) { return h ? h->steps : 0; }

/* Checkpoint layout: a 32-byte header, then ground (float), depth, vel_x, vel_y (double),
 * sources (float), accel (2 float), footprint (float), each n long; absent optional fields are
 * written as zeros and flagged absent in the header. */
static const char k_magic[8] = {'H', 'B', 'K', 'W', 'A', 'T', 'E', 'R'};
enum { STATE_VERSION = 1, STATE_HEADER = 32 };
enum { HAS_SOURCES = 1, HAS_ACCEL = 2, HAS_FOOTPRINT = 4 };

size_t hbk_water_state_size(const hbk_water_t *h)
{
    return h ? STATE_HEADER + h->n * (sizeof(float) * 5 + sizeof(double) * 3) : 0;
}

static unsigned char *put(unsigned char *at, const void *src, size_t bytes)
{
    if (src) memcpy(at, src, bytes);
    else memset(at, 0, bytes);
    return at + bytes;
}

hbk_result_t hbk_water_save_state(hbk_water_t *h, void *buffer, size_t size)
{
    HBK_WATER_ENTER(h);
    const size_t need = hbk_water_state_size(h);
    if (!buffer) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "buffer: must not be NULL");
    if (size < need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "size = %zu: must be >= hbk_water_state_size() = %zu", size, need);
    uint32_t version = STATE_VERSION, flags = (h->sources ? HAS_SOURCES : 0) |
                                              (h->accel ? HAS_ACCEL : 0) |
                                              (h->footprint ? HAS_FOOTPRINT : 0);
    unsigned char *at = buffer;
    at = put(at, k_magic, 8);
    at = put(at, &version, 4);
    at = put(at, &h->p.width, 4);
    at = put(at, &h->p.height, 4);
    at = put(at, &flags, 4);
    at = put(at, &h->steps, 8);
    const size_t n = h->n;
    at = put(at, h->ground, n * sizeof(float));
    at = put(at, h->depth, n * sizeof(double));
    at = put(at, h->vel_x, n * sizeof(double));
    at = put(at, h->vel_y, n * sizeof(double));
    at = put(at, h->sources, n * sizeof(float));
    at = put(at, h->accel, 2 * n * sizeof(float));
    put(at, h->footprint, n * sizeof(float));
    return HBK_OK;
}

/* Restores an optional field: allocated in *fresh beforehand so that failure changes nothing. */
static void take(float **field, float **fresh, const unsigned char *at, size_t bytes, int present)
{
    if (present) {
        if (!*field) { *field = *fresh; *fresh = NULL; }
        memcpy(*field, at, bytes);
    } else {
        free(*field);
        *field = NULL;
    }
}

hbk_result_t hbk_water_load_state(hbk_water_t *h, const void *buffer, size_t size)
{
    HBK_WATER_ENTER(h);
    if (!buffer) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "buffer: must not be NULL");
    const unsigned char *at = buffer;
    if (size < STATE_HEADER || memcmp(at, k_magic, 8))
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "buffer: not a water state (bad header)");
    uint32_t version, flags;
    int32_t w, ht;
    uint64_t steps;
    memcpy(&version, at + 8, 4);
    memcpy(&w, at + 12, 4);
    memcpy(&ht, at + 16, 4);
    memcpy(&flags, at + 20, 4);
    memcpy(&steps, at + 24, 8);
    if (version != STATE_VERSION)
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "state version = %u: this library reads %u",
                        version, (unsigned)STATE_VERSION);
    if (w != h->p.width || ht != h->p.height)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "state grid = %d x %d: must equal the handle's, %d x %d", w, ht,
                        h->p.width, h->p.height);
    const size_t need = hbk_water_state_size(h), n = h->n;
    if (size < need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "size = %zu: a %d x %d state needs %zu bytes", size, w, ht, need);
    /* Values are checked before anything is changed: a corrupt buffer must not poison the
     * simulation (NaN spreads through the implicit solve to every cell). */
    const unsigned char *vals = at + STATE_HEADER;
    for (size_t i = 0; i < n; ++i) {
        float b;
        double d, u, v;
        memcpy(&b, vals + i * sizeof b, sizeof b);
        memcpy(&d, vals + n * sizeof(float) + i * sizeof d, sizeof d);
        memcpy(&u, vals + n * (sizeof(float) + sizeof(double)) + i * sizeof u, sizeof u);
        memcpy(&v, vals + n * (sizeof(float) + 2 * sizeof(double)) + i * sizeof v, sizeof v);
        /* The setters' ranges (ground), or what a run can reach with room to spare (depth,
         * velocity): a finite double past them still overflows the floats read out. */
        if (!(fabs(b) <= 1e6f) || !(d >= 0.0 && d < 1e9) || !(fabs(u) <= 1e9) ||
            !(fabs(v) <= 1e9))
            return hbk_fail(&h->msg, HBK_ERR_FORMAT,
                            "state cell %zu: ground (in [-1e6, 1e6] m), depth (in [0, 1e9) m) "
                            "or velocity (in [-1e9, 1e9] m/s) is not a valid number", i);
    }
    const int present[3] = {!!(flags & HAS_SOURCES), !!(flags & HAS_ACCEL),
                            !!(flags & HAS_FOOTPRINT)};
    /* The inputs too, where present: sources, accel (two per cell), footprint. */
    const unsigned char *in = vals + n * (sizeof(float) + 3 * sizeof(double));
    static const char *const names[3] = {"sources", "accel", "footprint"};
    static const float lo[3] = {-1e3f, -1e3f, 0.0f}, hi[3] = {1e3f, 1e3f, 1e3f}; /* the setters' */
    for (int k = 0; k < 3; ++k) {
        const size_t m = n * (k == 1 ? 2 : 1);
        for (size_t i = 0; present[k] && i < m; ++i) {
            float f;
            memcpy(&f, in + i * sizeof f, sizeof f);
            if (!(f >= lo[k] && f <= hi[k]))
                return hbk_fail(&h->msg, HBK_ERR_FORMAT,
                                "state %s %zu = %g: must be a finite number in [%g, %g]", names[k],
                                i, (double)f, (double)lo[k], (double)hi[k]);
        }
        in += m * sizeof(float);
    }
    float *fresh[3] = {NULL, NULL, NULL};
    float *const *have[3] = {&h->sources, &h->accel, &h->footprint};
    for (int k = 0; k < 3; ++k)
        if (present[k] && !*have[k] && !(fresh[k] = malloc(n * (k == 1 ? 2 : 1) * sizeof(float)))) {
            for (int j = 0; j < 3; ++j) free(fresh[j]);
            return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "state: out of memory");
        }
    at += STATE_HEADER;
    h->steps = steps;
    memcpy(h->ground, at, n * sizeof(float)), at += n * sizeof(float);
    memcpy(h->depth, at, n * sizeof(double)), at += n * sizeof(double);
    memcpy(h->vel_x, at, n * sizeof(double)), at += n * sizeof(double);
    memcpy(h->vel_y, at, n * sizeof(double)), at += n * sizeof(double);
    take(&h->sources, &fresh[0], at, n * sizeof(float), present[0]), at += n * sizeof(float);
    take(&h->accel, &fresh[1], at, 2 * n * sizeof(float), present[1]), at += 2 * n * sizeof(float);
    take(&h->footprint, &fresh[2], at, n * sizeof(float), present[2]);
    return HBK_OK;
}
