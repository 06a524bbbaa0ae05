/* hbk_exr_write: checks the arguments, encodes the channels through OpenEXRCore into a temporary
 * file beside `path`, and renames it over `path` once every chunk is written. */
#include "internal_exr.h"
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <omp.h>
#include <unistd.h>

#define MAX_SIZE 65536
#define MAX_CHANNELS 64
#define MAX_NAME 255
#define SHORT_NAME 31 /* longer names need OpenEXR's "long names" flag (readers >= 1.7) */

/* Routing OpenEXRCore's detail message. OpenEXRCore calls the error handler with the write
 * context's lock held, and exr_get_user_data() takes that same lock (a deadlock with 3.1.5), so
 * unlike the reader the handler cannot reach the call's state through user_data. The handler
 * runs on the thread that made the failing call, so hbk_exr_write points this thread-local at
 * its own buffer for the duration of the call: nothing is shared between threads. */
static _Thread_local hbk_exr_detail_t *t_detail;

static void on_exr_error(exr_const_context_t ctxt, exr_result_t code, const char *text)
{
    (void)ctxt;
    (void)code;
    hbk_exr_detail_set(t_detail, text);
}

/* The one piece of shared mutable state: makes temporary names unique between threads. */
static atomic_uint_fast64_t s_temp_counter;

static hbk_result_t check_channel(const hbk_exr_channel_t *c, int32_t i, int32_t width,
                                  int32_t height, hbk_message_t *msg)
{
    if (!c->name)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "channels[%d].name: must not be NULL", i);
    size_t len = strnlen(c->name, MAX_NAME + 1);
    if (len < 1 || len > MAX_NAME)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "channels[%d].name = \"%.32s%s\": length must be in [1, %d] bytes", i,
                        c->name, len > 32 ? "..." : "", MAX_NAME);
    if (!c->data)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "channels[%d].data: must not be NULL", i);
    if (c->half != 0 && c->half != 1)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "channels[%d].half = %d: must be 0 (float) or 1 (half)", i, c->half);
    if (c->pixel_stride < 1)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "channels[%d].pixel_stride = %zu: must be >= 1", i, c->pixel_stride);
    size_t row, last;
    if (__builtin_mul_overflow(c->pixel_stride, (size_t)width, &row))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "channels[%d].pixel_stride = %zu: width * pixel_stride overflows", i,
                        c->pixel_stride);
    if (c->row_stride < row)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "channels[%d].row_stride = %zu: must be >= width * pixel_stride = %zu",
                        i, c->row_stride, row);
    /* Index of the last float read; it and its byte offset must be representable. */
    if (__builtin_mul_overflow(c->row_stride, (size_t)(height - 1), &last) ||
        __builtin_add_overflow(last, row - c->pixel_stride, &last) ||
        last > SIZE_MAX / sizeof(float) - 1)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "channels[%d].row_stride = %zu: the buffer would span more than "
                        "SIZE_MAX bytes", i, c->row_stride);
    return HBK_OK;
}

static hbk_result_t check_args(const char *path, int32_t width, int32_t height,
                               const hbk_exr_channel_t *channels, int32_t count,
                               int32_t compression, hbk_message_t *msg)
{
    if (!path) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "path: must not be NULL");
    size_t plen = strlen(path);
    if (plen == 0) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "path = \"\": must not be empty");
    if (path[plen - 1] == '/')
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "path = \"%s\": must name a file, not a folder", path);
    if (width < 1 || width > MAX_SIZE)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "width = %d: must be in [1, %d]", width,
                        MAX_SIZE);
    if (height < 1 || height > MAX_SIZE)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "height = %d: must be in [1, %d]", height,
                        MAX_SIZE);
    if (count < 1 || count > MAX_CHANNELS)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "count = %d: must be in [1, %d]", count,
                        MAX_CHANNELS);
    if (!channels) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "channels: must not be NULL");
    if (compression < HBK_EXR_NONE || compression > HBK_EXR_ZIPS)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "compression = %d: must be 0 (none), 1 (zip) or 2 (zips)", compression);
    for (int32_t i = 0; i < count; ++i) {
        hbk_result_t r = check_channel(&channels[i], i, width, height, msg);
        if (r) return r;
        for (int32_t j = 0; j < i; ++j)
            if (!strcmp(channels[i].name, channels[j].name))
                return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                                "channels[%d].name = \"%s\": duplicate channel name (also "
                                "channels[%d])", i, channels[i].name, j);
    }
    return HBK_OK;
}

/* "<dir>/.<basename>.tmp-<pid>-<counter>": same folder, so rename() is atomic; hidden. The
 * basename is cut to 200 bytes to stay under NAME_MAX; pid and counter keep it unique. */
static char *temp_path_for(const char *path)
{
    const char *slash = strrchr(path, '/');
    size_t dir_len = slash ? (size_t)(slash - path) + 1 : 0, len = strlen(path);
    uint64_t n = (uint64_t)atomic_fetch_add_explicit(&s_temp_counter, 1, memory_order_relaxed);
    size_t cap = len + 64;
    char *t = malloc(cap);
    if (!t) return NULL;
    memcpy(t, path, dir_len);
    snprintf(t + dir_len, cap - dir_len, ".%.200s.tmp-%ld-%" PRIu64, path + dir_len,
             (long)getpid(), n);
    return t;
}

static hbk_result_t code_for(exr_result_t rv)
{
    switch (rv) {
    case EXR_ERR_OUT_OF_MEMORY: return HBK_ERR_OUT_OF_MEMORY;
    case EXR_ERR_FILE_ACCESS:
    case EXR_ERR_READ_IO:
    case EXR_ERR_WRITE_IO: return HBK_ERR_IO;
    case EXR_ERR_INVALID_ARGUMENT:
    case EXR_ERR_ARGUMENT_OUT_OF_RANGE:
    case EXR_ERR_NAME_TOO_LONG:
    case EXR_ERR_INVALID_ATTR: return HBK_ERR_INVALID_ARGUMENT;
    default: return HBK_ERR_INTERNAL;
    }
}

static hbk_result_t fail_exr(hbk_message_t *msg, const hbk_exr_detail_t *d, exr_result_t rv,
                             const char *path, const char *what)
{
    return hbk_fail(msg, code_for(rv), "\"%s\": %s: %s", path, what, hbk_exr_detail_text(d, rv));
}

/* OpenEXRCore up to 3.4.7 (Debian 12 has 3.1.5) keeps a zlib stream exactly as long as the
 * packed chunk, but a chunk whose stored size equals its unpacked size is raw to every reader,
 * so the chunk read back as noise (openexr#2306; a snow depth map showed it). Stored raw
 * instead, as the fixed library does. The library's own compressor runs first. */
typedef struct {
    exr_result_t (*compress)(exr_encode_pipeline_t *);
} zip_guard_t;

static exr_result_t compress_never_ambiguous(exr_encode_pipeline_t *enc)
{
    const zip_guard_t *g = enc->encoding_user_data;
    exr_result_t rv = g->compress(enc);
    if (rv == EXR_ERR_SUCCESS && enc->compressed_bytes == enc->packed_bytes &&
        enc->compressed_buffer != enc->packed_buffer)
        memcpy(enc->compressed_buffer, enc->packed_buffer, enc->packed_bytes);
    return rv;
}

/* Copies rows [y0, y0 + n) of the file (row 0 = top) from the caller's buffer (row 0 = bottom)
 * into a planar scratch block of n rows of `width` floats. */
static void gather_rows(float *dst, const hbk_exr_channel_t *c, int32_t width, int32_t height,
                        int32_t y0, int32_t n)
{
    for (int32_t k = 0; k < n; ++k) {
        const float *src = c->data + (size_t)(height - 1 - (y0 + k)) * c->row_stride;
        float *row = dst + (size_t)k * (size_t)width;
        if (c->pixel_stride == 1) {
            memcpy(row, src, (size_t)width * sizeof(float));
        } else {
            for (int32_t x = 0; x < width; ++x) row[x] = src[(size_t)x * c->pixel_stride];
        }
    }
}

/* One chunk compressed by a worker, held until the writer's turn comes. */
typedef struct {
    exr_chunk_info_t ci;
    void *data;
    size_t bytes;
    exr_result_t rv;          /* the worker's error, if any */
    hbk_exr_detail_t detail;  /* and OpenEXRCore's message for it */
} chunk_slot_t;

/* A worker thread's encode pipeline and its block of gathered rows. */
typedef struct {
    zip_guard_t guard; /* first: compress_never_ambiguous reads the pipeline's user data as it */
    exr_encode_pipeline_t enc;
    int ready;
    float *rows;
    chunk_slot_t *slot; /* the chunk being encoded */
} worker_t;

/* The pipeline's last stage: keeps the compressed chunk for the writer instead of writing it.
 * Chunks of a file in increasing-y order must reach it one after another. */
static exr_result_t keep_chunk(exr_encode_pipeline_t *enc)
{
    worker_t *w = enc->encoding_user_data;
    w->slot->data = malloc(enc->compressed_bytes ? enc->compressed_bytes : 1);
    if (!w->slot->data) return EXR_ERR_OUT_OF_MEMORY;
    memcpy(w->slot->data, enc->compressed_buffer, enc->compressed_bytes);
    w->slot->bytes = enc->compressed_bytes;
    return EXR_ERR_SUCCESS;
}

typedef struct {
    exr_context_t ctx;
    int part;
    int32_t width, height, count, lines;
    int compressed; /* else each chunk's packing (under OpenEXRCore's lock) is all the work */
    const hbk_exr_channel_t *channels;
    const int32_t *source; /* file channel order -> channels[] index */
} file_t;

/* Packs and compresses one chunk on this thread's pipeline into its slot. */
static exr_result_t encode_chunk(const file_t *f, worker_t *w, chunk_slot_t *slot)
{
    const size_t plane = (size_t)f->lines * (size_t)f->width;
    exr_result_t rv;
    w->slot = slot;
    for (int32_t k = 0; k < f->count; ++k)
        gather_rows(w->rows + (size_t)k * plane, &f->channels[f->source[k]], f->width, f->height,
                    slot->ci.start_y, slot->ci.height);
    if (!w->ready) {
        rv = exr_encoding_initialize(f->ctx, f->part, &slot->ci, &w->enc);
        if (rv != EXR_ERR_SUCCESS) return rv;
        w->ready = 1;
        if (w->enc.channel_count != f->count) return EXR_ERR_INVALID_ARGUMENT;
        for (int32_t k = 0; k < f->count; ++k) {
            exr_coding_channel_info_t *cc = &w->enc.channels[k];
            cc->user_data_type = EXR_PIXEL_FLOAT;
            cc->user_bytes_per_element = (int16_t)sizeof(float);
            cc->user_pixel_stride = (int32_t)sizeof(float);
            cc->user_line_stride = f->width * (int32_t)sizeof(float);
            cc->encode_from_ptr = (const uint8_t *)(w->rows + (size_t)k * plane);
        }
        rv = exr_encoding_choose_default_routines(f->ctx, f->part, &w->enc);
        if (rv != EXR_ERR_SUCCESS) return rv;
        if (w->enc.compress_fn) {
            w->guard.compress = w->enc.compress_fn;
            w->enc.compress_fn = compress_never_ambiguous;
        }
        w->enc.encoding_user_data = w;
        w->enc.yield_until_ready_fn = NULL; /* the writer below keeps the order */
        w->enc.write_fn = keep_chunk;
    } else {
        rv = exr_encoding_update(f->ctx, f->part, &slot->ci, &w->enc);
        if (rv != EXR_ERR_SUCCESS) return rv;
    }
    return exr_encoding_run(f->ctx, f->part, &w->enc);
}

/* Every chunk, compressed on all cores a batch at a time (compression is nearly all of a
 * write: 1.5 s of a 2048^2 two-channel ZIP file, against 0.07 s stored raw) and written in
 * order on this thread, so the file's bytes are those of one thread. Returns the chunks
 * written; on failure sets *r. */
static int32_t encode_chunks(const file_t *f, const char *path, hbk_exr_detail_t *detail,
                             hbk_message_t *msg, hbk_result_t *r)
{
    const int nt = f->compressed ? hbk_threads(0) : 1;
    const int32_t batch = 4 * nt;
    worker_t *workers = calloc((size_t)nt, sizeof *workers);
    chunk_slot_t *slots = calloc((size_t)batch, sizeof *slots);
    const size_t block = (size_t)f->count * (size_t)f->lines * (size_t)f->width;
    int32_t written = 0;
    int ok = workers && slots;
    for (int i = 0; ok && i < nt; ++i) ok = (workers[i].rows = malloc(block * sizeof(float))) != 0;
    if (!ok) {
        *r = hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "\"%s\": cannot allocate %zu bytes for %d "
                      "chunks", path, block * sizeof(float), nt);
        goto done;
    }
    for (int32_t y0 = 0; y0 < f->height && *r == HBK_OK; y0 += batch * f->lines) {
        int32_t n = 0;
        for (int32_t y = y0; y < f->height && n < batch; y += f->lines, ++n) {
            chunk_slot_t *sl = &slots[n];
            exr_chunk_info_t *ci = &sl->ci;
            detail->text[0] = '\0';
            exr_result_t rv = exr_write_scanline_chunk_info(f->ctx, f->part, y, ci);
            if (rv != EXR_ERR_SUCCESS) {
                *r = fail_exr(msg, detail, rv, path, "exr_write_scanline_chunk_info");
                goto done;
            }
            if (ci->start_y != y || ci->height < 1 || ci->height > f->lines ||
                ci->width != f->width) {
                *r = hbk_fail(msg, HBK_ERR_INTERNAL, "\"%s\": unexpected chunk %d (y %d, %dx%d)",
                              path, ci->idx, ci->start_y, ci->width, ci->height);
                goto done;
            }
        }
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt) if (n > 1)
        for (int32_t i = 0; i < n; ++i) {
            hbk_exr_detail_t *outer = t_detail; /* this thread's messages go to the slot */
            t_detail = &slots[i].detail;
            slots[i].rv = encode_chunk(f, &workers[omp_get_thread_num()], &slots[i]);
            t_detail = outer;
        }
        for (int32_t i = 0; i < n && *r == HBK_OK; ++i) {
            chunk_slot_t *sl = &slots[i];
            if (sl->rv != EXR_ERR_SUCCESS) {
                *r = fail_exr(msg, &sl->detail, sl->rv, path, "exr_encoding_run");
                break;
            }
            detail->text[0] = '\0';
            exr_result_t rv = exr_write_scanline_chunk(f->ctx, f->part, sl->ci.start_y, sl->data,
                                                       sl->bytes);
            if (rv != EXR_ERR_SUCCESS)
                *r = fail_exr(msg, detail, rv, path, "exr_write_scanline_chunk");
            else
                ++written;
        }
        for (int32_t i = 0; i < n; ++i) {
            free(slots[i].data);
            slots[i] = (chunk_slot_t){0};
        }
    }
done:
    for (int i = 0; workers && i < nt; ++i) {
        if (workers[i].ready) exr_encoding_destroy(f->ctx, &workers[i].enc);
        free(workers[i].rows);
    }
    free(workers);
    free(slots);
    return written;
}

/* Everything between exr_start_write and exr_finish. On failure the caller removes `tmp`. */
static hbk_result_t encode_file(const char *path, const char *tmp, int32_t width, int32_t height,
                                const hbk_exr_channel_t *channels, int32_t count,
                                exr_compression_t ctype, hbk_exr_detail_t *detail,
                                hbk_message_t *msg)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = on_exr_error;
    init.alloc_fn = hbk_exr_alloc; /* the same malloc; see internal_exr.h */
    init.free_fn = free;
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_start_write(&ctx, tmp, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS) {
        hbk_result_t r = fail_exr(msg, detail, rv, path, "cannot create the temporary file "
                                  "beside it");
        if (ctx) exr_finish(&ctx); /* OpenEXRCore already returns NULL here; be safe */
        return r;
    }

    hbk_result_t r = HBK_OK;
    int part = 0, long_names = 0;
    int32_t lines = 0, chunk_count = 0, written = 0;
    int32_t source[MAX_CHANNELS]; /* file channel order (sorted by name) -> channels[] index */
    const exr_attr_chlist_t *chlist = NULL;

#define TRY(call, what)                                     \
    do {                                                    \
        detail->text[0] = '\0';                             \
        rv = (call);                                        \
        if (rv != EXR_ERR_SUCCESS) {                        \
            r = fail_exr(msg, detail, rv, path, what);      \
            goto done;                                      \
        }                                                   \
    } while (0)

    for (int32_t i = 0; i < count; ++i) long_names |= strlen(channels[i].name) > SHORT_NAME;
    if (long_names) TRY(exr_set_longname_support(ctx, 1), "exr_set_longname_support");
    TRY(exr_add_part(ctx, NULL, EXR_STORAGE_SCANLINE, &part), "exr_add_part");
    TRY(exr_initialize_required_attr_simple(ctx, part, width, height, ctype),
        "exr_initialize_required_attr_simple");
    for (int32_t i = 0; i < count; ++i)
        TRY(exr_add_channel(ctx, part, channels[i].name,
                            channels[i].half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                            EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1),
            "exr_add_channel");
    TRY(exr_write_header(ctx), "exr_write_header");
    TRY(exr_get_scanlines_per_chunk(ctx, part, &lines), "exr_get_scanlines_per_chunk");
    TRY(exr_get_chunk_count(ctx, part, &chunk_count), "exr_get_chunk_count");
    TRY(exr_get_channels(ctx, part, &chlist), "exr_get_channels");
#undef TRY
    if (lines < 1 || !chlist || chlist->num_channels != count) {
        r = hbk_fail(msg, HBK_ERR_INTERNAL, "\"%s\": unexpected part layout from OpenEXRCore",
                     path);
        goto done;
    }
    for (int32_t k = 0; k < count; ++k) {
        source[k] = -1;
        for (int32_t i = 0; i < count; ++i)
            if (!strcmp(chlist->entries[k].name.str, channels[i].name)) source[k] = i;
        if (source[k] < 0) {
            r = hbk_fail(msg, HBK_ERR_INTERNAL, "\"%s\": channel \"%s\" not found after "
                         "exr_add_channel", path, chlist->entries[k].name.str);
            goto done;
        }
    }
    const file_t f = {ctx, part, width, height, count, lines, ctype != EXR_COMPRESSION_NONE,
                      channels, source};
    written = encode_chunks(&f, path, detail, msg, &r);

done:
    /* exr_finish writes the chunk offset table and closes the file. */
    detail->text[0] = '\0';
    rv = exr_finish(&ctx);
    if (r == HBK_OK && rv != EXR_ERR_SUCCESS)
        r = fail_exr(msg, detail, rv, path, "exr_finish");
    /* exr_finish succeeds even when chunks are missing: count them ourselves. */
    if (r == HBK_OK && written != chunk_count)
        r = hbk_fail(msg, HBK_ERR_IO, "\"%s\": only %d of %d chunks were written", path, written,
                     chunk_count);
    return r;
}

/* Flushes the folder holding `path`, so that its rename outlives a power cut (the file is
 * complete either way: a resume's checksum check would find a lost rename). Best effort. */
static void sync_folder(const char *path)
{
    const char *slash = strrchr(path, '/');
    char dir[4096];
    if (!slash) snprintf(dir, sizeof dir, ".");
    else if (slash == path) snprintf(dir, sizeof dir, "/");
    else if ((size_t)(slash - path) < sizeof dir)
        snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
    else return;
    const int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return;
    (void)fsync(fd);
    close(fd);
}

/* Flushes the finished temporary file to disk, then puts it in place. */
static hbk_result_t commit(const char *tmp, const char *path, hbk_message_t *msg)
{
    int fd = open(tmp, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return hbk_fail(msg, HBK_ERR_IO, "\"%s\": cannot reopen the temporary file: %s", path,
                        strerror(errno));
    int sync_err = fsync(fd) ? errno : 0;
    close(fd);
    if (sync_err && sync_err != EINVAL && sync_err != EROFS) /* EINVAL: fs without fsync */
        return hbk_fail(msg, HBK_ERR_IO, "\"%s\": cannot flush the temporary file: %s", path,
                        strerror(sync_err));
    if (rename(tmp, path))
        return hbk_fail(msg, HBK_ERR_IO, "\"%s\": cannot rename the temporary file over it: %s",
                        path, strerror(errno));
    sync_folder(path);
    return HBK_OK;
}

hbk_result_t hbk_exr_write(const char *path, int32_t width, int32_t height,
                           const hbk_exr_channel_t *channels, int32_t count, int32_t compression,
                           hbk_message_t *msg)
{
    hbk_message_clear(msg);
    hbk_result_t r = check_args(path, width, height, channels, count, compression, msg);
    if (r) return r;
    static const exr_compression_t k_ctype[] = {EXR_COMPRESSION_NONE, EXR_COMPRESSION_ZIP,
                                                EXR_COMPRESSION_ZIPS};

    char *tmp = temp_path_for(path);
    if (!tmp) return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "cannot allocate a temporary name");

    hbk_exr_detail_t detail = {{0}};
    hbk_exr_detail_t *outer = t_detail;
    t_detail = &detail;
    r = encode_file(path, tmp, width, height, channels, count, k_ctype[compression], &detail,
                    msg);
    t_detail = outer;
    if (r == HBK_OK) r = commit(tmp, path, msg);
    if (r != HBK_OK) unlink(tmp); /* may already be gone (OpenEXRCore removes failed files) */
    free(tmp);
    return r;
}
