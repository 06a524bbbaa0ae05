/* EXR reader: one OpenEXRCore read context per hbk_exr_reader_t. A channel is decoded chunk by
 * chunk into a scratch block in its stored type, then converted to float and copied, bottom row
 * first, into the caller's buffer. */
#include "internal_exr.h"
#include <stdlib.h>
#include <string.h>

/* Byte line strides handed to OpenEXRCore are int32_t. */
#define MAX_SIZE (INT32_MAX / (int32_t)sizeof(float))

struct hbk_exr_reader {
    exr_context_t ctx;
    const exr_attr_chlist_t *chlist; /* owned by ctx, immutable while reading */
    int32_t width, height;           /* of the data window */
    int32_t min_y;                   /* data window origin (files may not start at 0) */
    int32_t lines;                   /* scanlines per chunk */
    hbk_exr_detail_t detail;         /* last message from OpenEXRCore's error handler */
    hbk_message_t message;           /* detail of the last failed hbk_ call */
};

/* Read contexts take no lock in exr_get_user_data, so the handler finds its reader there. */
static void on_exr_error(exr_const_context_t ctxt, exr_result_t code, const char *text)
{
    (void)code;
    void *ud = NULL;
    if (ctxt && exr_get_user_data(ctxt, &ud) == EXR_ERR_SUCCESS && ud)
        hbk_exr_detail_set(&((hbk_exr_reader_t *)ud)->detail, text);
}

static const char *file_name(const hbk_exr_reader_t *r)
{
    const char *name = NULL;
    if (r->ctx && exr_get_file_name(r->ctx, &name) == EXR_ERR_SUCCESS && name) return name;
    return "?";
}

/* Takes the header of a freshly opened file, or says why it is not a file we read. */
static hbk_result_t take_header(hbk_exr_reader_t *r, const char *path, hbk_message_t *msg)
{
    int parts = 0;
    exr_storage_t storage = EXR_STORAGE_LAST_TYPE;
    exr_attr_box2i_t dw;
    exr_result_t rv;
    if ((rv = exr_get_count(r->ctx, &parts)) != EXR_ERR_SUCCESS ||
        (rv = exr_get_storage(r->ctx, 0, &storage)) != EXR_ERR_SUCCESS ||
        (rv = exr_get_data_window(r->ctx, 0, &dw)) != EXR_ERR_SUCCESS ||
        (rv = exr_get_scanlines_per_chunk(r->ctx, 0, &r->lines)) != EXR_ERR_SUCCESS ||
        (rv = exr_get_channels(r->ctx, 0, &r->chlist)) != EXR_ERR_SUCCESS)
        return hbk_fail(msg, HBK_ERR_FORMAT, "\"%s\": bad header: %s", path,
                        hbk_exr_detail_text(&r->detail, rv));
    if (parts != 1)
        return hbk_fail(msg, HBK_ERR_FORMAT, "\"%s\": has %d parts: only single-part files are "
                        "supported", path, parts);
    if (storage != EXR_STORAGE_SCANLINE)
        return hbk_fail(msg, HBK_ERR_FORMAT, "\"%s\": is a %s image: only flat scanline images "
                        "are supported", path, storage == EXR_STORAGE_TILED ? "tiled"
                        : storage == EXR_STORAGE_DEEP_SCANLINE ? "deep scanline" : "deep tiled");
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1, h = (int64_t)dw.max.y - dw.min.y + 1;
    if (w < 1 || w > MAX_SIZE || h < 1 || h > MAX_SIZE || r->lines < 1 || !r->chlist)
        return hbk_fail(msg, HBK_ERR_FORMAT, "\"%s\": data window (%d, %d)-(%d, %d): size must "
                        "be in [1, %d]", path, dw.min.x, dw.min.y, dw.max.x, dw.max.y, MAX_SIZE);
    r->width = (int32_t)w;
    r->height = (int32_t)h;
    r->min_y = dw.min.y;
    return HBK_OK;
}

hbk_result_t hbk_exr_open(hbk_exr_reader_t **out, const char *path, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!out) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out: must not be NULL");
    *out = NULL;
    if (!path) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "path: must not be NULL");
    if (!path[0]) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "path = \"\": must not be empty");

    hbk_exr_reader_t *r = calloc(1, sizeof *r);
    if (!r) return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "cannot allocate the reader");

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = on_exr_error;
    init.user_data = r;
    init.alloc_fn = hbk_exr_alloc;
    init.free_fn = free;
    hbk_result_t res;
    const unsigned long failed0 = hbk_exr_failed_allocs;
    exr_result_t rv = exr_start_read(&r->ctx, path, &init);
    if (hbk_exr_failed_allocs != failed0) { /* even on success: the header may lack parts */
        res = hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "\"%s\": out of memory reading the header: %s",
                       path, hbk_exr_detail_text(&r->detail, EXR_ERR_OUT_OF_MEMORY));
    } else if (rv == EXR_ERR_SUCCESS) {
        res = take_header(r, path, msg);
    } else {
        const char *text = hbk_exr_detail_text(&r->detail, rv);
        if (rv == EXR_ERR_FILE_ACCESS)
            res = hbk_fail(msg, HBK_ERR_IO, "\"%s\": cannot open: %s", path, text);
        else if (rv == EXR_ERR_OUT_OF_MEMORY)
            res = hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "\"%s\": %s", path, text);
        else
            res = hbk_fail(msg, HBK_ERR_FORMAT, "\"%s\": not a readable EXR file: %s", path, text);
    }
    if (res != HBK_OK) {
        hbk_exr_close(r);
        return res;
    }
    *out = r;
    return HBK_OK;
}

void hbk_exr_size(const hbk_exr_reader_t *r, int32_t *width, int32_t *height)
{
    if (width) *width = r ? r->width : 0;
    if (height) *height = r ? r->height : 0;
}

int32_t hbk_exr_channel_count(const hbk_exr_reader_t *r)
{
    return r ? r->chlist->num_channels : 0;
}

const char *hbk_exr_channel_name(const hbk_exr_reader_t *r, int32_t i)
{
    if (!r || i < 0 || i >= r->chlist->num_channels) return NULL;
    return r->chlist->entries[i].name.str;
}

int32_t hbk_exr_channel_is_half(const hbk_exr_reader_t *r, int32_t i)
{
    if (!r || i < 0 || i >= r->chlist->num_channels) return -1;
    return r->chlist->entries[i].pixel_type == EXR_PIXEL_HALF;
}

const char *hbk_exr_message(const hbk_exr_reader_t *r) { return r ? r->message.text : ""; }

void hbk_exr_close(hbk_exr_reader_t *r)
{
    if (!r) return;
    if (r->ctx) exr_finish(&r->ctx);
    free(r);
}

/* "name = "Z": no such channel; the file has: A, B, G, R" (cut with "..." when too long). */
static hbk_result_t no_such_channel(hbk_exr_reader_t *r, const char *name)
{
    char list[HBK_MESSAGE_SIZE];
    size_t used = 0;
    list[0] = '\0';
    for (int i = 0; i < r->chlist->num_channels; ++i) {
        const char *n = r->chlist->entries[i].name.str;
        size_t need = strlen(n) + (i ? 2 : 0);
        if (used + need + 4 >= sizeof list) {
            snprintf(list + used, sizeof list - used, "%s...", i ? ", " : "");
            break;
        }
        used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", i ? ", " : "", n);
    }
    return hbk_fail(&r->message, HBK_ERR_INVALID_ARGUMENT,
                    "name = \"%.64s\": no such channel; the file has: %s", name,
                    r->chlist->num_channels ? list : "(none)");
}

/* Exact: every half is a float. NaN payloads are kept. */
static float half_to_float(uint16_t h)
{
    uint32_t sign = (uint32_t)(h & 0x8000u) << 16, e = (h >> 10) & 0x1fu, m = h & 0x3ffu, bits;
    if (e == 0x1f) {
        bits = sign | 0x7f800000u | (m << 13); /* inf, NaN */
    } else if (e) {
        bits = sign | ((e + 112) << 23) | (m << 13); /* normal: rebias 15 -> 127 */
    } else {
        float f = (float)m * 0x1p-24f; /* zero or denormal, m * 2^-24 exactly */
        return sign ? -f : f;
    }
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

/* One decoded row (native byte order, stored type) to floats at `out` with `pixel_stride`. */
static void convert_row(float *out, size_t pixel_stride, const uint8_t *src,
                        exr_pixel_type_t type, int32_t width)
{
    for (int32_t x = 0; x < width; ++x) {
        float v;
        if (type == EXR_PIXEL_HALF) {
            uint16_t h;
            memcpy(&h, src + 2 * (size_t)x, 2);
            v = half_to_float(h);
        } else if (type == EXR_PIXEL_UINT) {
            uint32_t u;
            memcpy(&u, src + 4 * (size_t)x, 4);
            v = (float)u;
        } else {
            memcpy(&v, src + 4 * (size_t)x, 4);
        }
        out[(size_t)x * pixel_stride] = v;
    }
}

/* Out of memory whenever an OpenEXRCore allocation failed since the read began (`failed0` is
 * the count then), whatever rv says: it may report a corrupt chunk instead. */
static hbk_result_t decode_fail(hbk_exr_reader_t *r, exr_result_t rv, unsigned long failed0,
                                const char *name, int32_t y)
{
    const int oom = hbk_exr_failed_allocs != failed0;
    hbk_result_t code = oom || rv == EXR_ERR_OUT_OF_MEMORY ? HBK_ERR_OUT_OF_MEMORY
                        : (rv == EXR_ERR_READ_IO || rv == EXR_ERR_FILE_ACCESS) ? HBK_ERR_IO
                                                                                 : HBK_ERR_FORMAT;
    return hbk_fail(&r->message, code, "\"%s\": channel \"%s\", chunk at y = %d: %s",
                    file_name(r), name, y, hbk_exr_detail_text(&r->detail, rv));
}

hbk_result_t hbk_exr_read_channel(hbk_exr_reader_t *r, const char *name, float *dst,
                                  size_t pixel_stride, size_t row_stride)
{
    if (!r) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_t *msg = &r->message;
    hbk_message_clear(msg);
    if (!name) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "name: must not be NULL");
    if (!dst) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "dst: must not be NULL");
    if (pixel_stride < 1)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "pixel_stride = %zu: must be >= 1",
                        pixel_stride);
    const int32_t width = r->width, height = r->height;
    size_t row, last;
    if (__builtin_mul_overflow(pixel_stride, (size_t)width, &row))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "pixel_stride = %zu: width * pixel_stride overflows", pixel_stride);
    if (row_stride < row)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "row_stride = %zu: must be >= width * pixel_stride = %zu", row_stride, row);
    if (__builtin_mul_overflow(row_stride, (size_t)(height - 1), &last) ||
        __builtin_add_overflow(last, row - pixel_stride, &last) ||
        last > SIZE_MAX / sizeof(float) - 1)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "row_stride = %zu: the buffer would span more than SIZE_MAX bytes",
                        row_stride);

    int32_t index = -1;
    for (int32_t i = 0; i < r->chlist->num_channels; ++i)
        if (!strcmp(r->chlist->entries[i].name.str, name)) index = i;
    if (index < 0) return no_such_channel(r, name);
    const exr_attr_chlist_entry_t *e = &r->chlist->entries[index];
    if (e->x_sampling != 1 || e->y_sampling != 1)
        return hbk_fail(msg, HBK_ERR_FORMAT, "\"%s\": channel \"%s\" is subsampled (%d x %d): "
                        "not supported", file_name(r), name, e->x_sampling, e->y_sampling);

    /* one chunk of the channel, in its stored type */
    const size_t elem = e->pixel_type == EXR_PIXEL_HALF ? 2 : 4;
    uint8_t *scratch = malloc((size_t)r->lines * (size_t)width * elem);
    if (!scratch)
        return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "cannot allocate %zu bytes for one chunk",
                        (size_t)r->lines * (size_t)width * elem);

    hbk_result_t res = HBK_OK;
    const unsigned long failed0 = hbk_exr_failed_allocs;
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int have_dec = 0;
    exr_result_t rv;
    for (int64_t y = r->min_y; y < (int64_t)r->min_y + height; y += r->lines) {
        exr_chunk_info_t ci;
        r->detail.text[0] = '\0';
        rv = exr_read_scanline_chunk_info(r->ctx, 0, (int)y, &ci);
        if (rv != EXR_ERR_SUCCESS) {
            res = decode_fail(r, rv, failed0, name, (int32_t)y);
            break;
        }
        const int64_t first = (int64_t)ci.start_y - r->min_y; /* file row, 0 = top */
        if (ci.start_y != y || ci.height < 1 || ci.height > r->lines || ci.width != width ||
            first + ci.height > height) {
            res = hbk_fail(msg, HBK_ERR_FORMAT, "\"%s\": chunk at y = %d has an unexpected "
                           "extent (y %d, %d x %d)", file_name(r), (int32_t)y, ci.start_y,
                           ci.width, ci.height);
            break;
        }
        if (!have_dec) {
            rv = exr_decoding_initialize(r->ctx, 0, &ci, &dec);
            if (rv != EXR_ERR_SUCCESS) {
                res = decode_fail(r, rv, failed0, name, (int32_t)y);
                break;
            }
            have_dec = 1;
            if (dec.channel_count != r->chlist->num_channels) {
                res = hbk_fail(msg, HBK_ERR_INTERNAL, "decoder has %d channels, header %d",
                               dec.channel_count, r->chlist->num_channels);
                break;
            }
            /* Only the requested channel gets a pointer; the others are skipped. It is decoded
             * in its stored type and converted here: OpenEXRCore 3.1's choice of a type-changing
             * unpacker ignores skipped channels (a half channel of a 3- or 4-channel file, read
             * alone as float, gets the all-channels routine and a NULL write). */
            exr_coding_channel_info_t *cc = &dec.channels[index];
            cc->user_data_type = cc->data_type;
            cc->user_bytes_per_element = cc->bytes_per_element;
            cc->user_pixel_stride = cc->bytes_per_element;
            cc->user_line_stride = width * cc->bytes_per_element;
            cc->decode_to_ptr = scratch;
            rv = exr_decoding_choose_default_routines(r->ctx, 0, &dec);
        } else {
            rv = exr_decoding_update(r->ctx, 0, &ci, &dec);
        }
        if (rv == EXR_ERR_SUCCESS) rv = exr_decoding_run(r->ctx, 0, &dec);
        if (rv != EXR_ERR_SUCCESS) {
            res = decode_fail(r, rv, failed0, name, (int32_t)y);
            break;
        }
        for (int32_t k = 0; k < ci.height; ++k)
            convert_row(dst + (size_t)(height - 1 - (first + k)) * row_stride, pixel_stride,
                        scratch + (size_t)k * (size_t)width * elem, e->pixel_type, width);
    }
    if (have_dec) exr_decoding_destroy(r->ctx, &dec);
    free(scratch);
    if (res == HBK_OK && hbk_exr_failed_allocs != failed0) /* a decode that "succeeded" anyway */
        res = hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "\"%s\": channel \"%s\": out of memory "
                       "decoding it", file_name(r), name);
    return res;
}
