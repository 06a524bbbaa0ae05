/* EXR files through OpenEXRCore: multi-channel scanline images, float or half, ZIP.
 *
 * Buffers follow hbk_image.h: row 0 is the bottom row (v = 0). Files store the top row first,
 * as every EXR reader expects, so the writer and reader flip rows.
 * Writing is atomic: the file is written to a temporary name in the same folder and renamed
 * over `path` only when every chunk was written; on any failure the temporary is removed and an
 * existing file at `path` is untouched. Functions are safe to call from several threads on
 * different files. */
#ifndef HBK_EXR_H
#define HBK_EXR_H
#include "hbk_base.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef enum hbk_exr_compression {
    HBK_EXR_NONE = 0,
    HBK_EXR_ZIP = 1, /* 16-line zlib blocks: lossless, the default for bakes */
    HBK_EXR_ZIPS = 2 /* 1-line zlib blocks */
} hbk_exr_compression_t;

typedef struct hbk_exr_channel {
    const char *name;    /* e.g. "R", "G", "B", "A", "height"; 1..255 bytes, unique */
    const float *data;   /* value of pixel (0, 0), the bottom-left pixel */
    size_t pixel_stride; /* floats from one pixel to the next (1 for a planar channel) */
    size_t row_stride;   /* floats from one row to the next */
    int32_t half;        /* 1: stored as 16-bit half, 0: stored as 32-bit float */
} hbk_exr_channel_t;

/* Writes `count` channels (1..64) of width x height (1..65536) pixels to `path`.
 * Returns HBK_ERR_INVALID_ARGUMENT (bad size, name, stride, compression), HBK_ERR_IO
 * (cannot create, write or rename; also when OpenEXRCore dropped chunks, which its
 * exr_finish does not report), HBK_ERR_OUT_OF_MEMORY, HBK_ERR_INTERNAL (OpenEXRCore reported
 * something unexpected; the message has its words). A compressed file's chunks are
 * compressed on every core OpenMP allows (OMP_NUM_THREADS) and written in order: the bytes do
 * not depend on the thread count. Memory: per thread one 16-row block of all channels as
 * float (1 MB for 4096-wide RGBA), and the compressed chunks of one batch (4 per thread).
 * POSIX rename semantics. */
HBK_EXPORT hbk_result_t hbk_exr_write(const char *path, int32_t width, int32_t height,
                                      const hbk_exr_channel_t *channels, int32_t count,
                                      int32_t compression, hbk_message_t *msg);

/* Reading: open, ask the size and channels, read channels into caller buffers, close. */
typedef struct hbk_exr_reader hbk_exr_reader_t;

/* HBK_ERR_IO (cannot open), HBK_ERR_FORMAT (not a single-part scanline EXR, subsampled
 * channels), HBK_ERR_INVALID_ARGUMENT (NULL out or path), HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_exr_open(hbk_exr_reader_t **out, const char *path,
                                     hbk_message_t *msg);
/* Never fails. */
HBK_EXPORT void hbk_exr_size(const hbk_exr_reader_t *r, int32_t *width, int32_t *height);
HBK_EXPORT int32_t hbk_exr_channel_count(const hbk_exr_reader_t *r);
/* Name of channel i (alphabetical order, as stored), or NULL if i is out of range. */
HBK_EXPORT const char *hbk_exr_channel_name(const hbk_exr_reader_t *r, int32_t i);
/* 1 if channel i is stored as half, 0 if float (or other), -1 if out of range. */
HBK_EXPORT int32_t hbk_exr_channel_is_half(const hbk_exr_reader_t *r, int32_t i);
/* Reads channel `name` as float into dst (pixel (0,0) bottom-left), with the given strides;
 * half and unsigned-int channels are converted exactly. HBK_ERR_INVALID_ARGUMENT (no such
 * channel, bad stride), HBK_ERR_FORMAT (corrupt data), HBK_ERR_IO (read error),
 * HBK_ERR_OUT_OF_MEMORY. The reader's message is cleared at the start of each read. */
HBK_EXPORT hbk_result_t hbk_exr_read_channel(hbk_exr_reader_t *r, const char *name, float *dst,
                                             size_t pixel_stride, size_t row_stride);
/* Detail message of the reader's last failure ("" if none). Never NULL. */
HBK_EXPORT const char *hbk_exr_message(const hbk_exr_reader_t *r);
/* Closes the file and frees the reader; NULL is allowed. */
HBK_EXPORT void hbk_exr_close(hbk_exr_reader_t *r);

#ifdef __cplusplus
}
#endif
#endif
