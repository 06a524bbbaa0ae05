/* Private helpers shared by the EXR writer and reader (OpenEXRCore, the C API of OpenEXR 3.1). */
#ifndef HBK_INTERNAL_EXR_H
#define HBK_INTERNAL_EXR_H
#include "hbk_exr.h"
#include "../base/internal_base.h"
#include <openexr.h> /* OpenEXRCore; the include folder comes from pkg-config */
#include <stdio.h>
#include <stdlib.h>

/* Keeps the last message OpenEXRCore reported through a context's error handler, so that a
 * failing call can quote it: "exr_write_header: Unable to write 1234 bytes ...". */
typedef struct hbk_exr_detail {
    char text[HBK_MESSAGE_SIZE];
} hbk_exr_detail_t;

static inline void hbk_exr_detail_set(hbk_exr_detail_t *d, const char *text)
{
    if (d) snprintf(d->text, sizeof d->text, "%s", text ? text : "");
}

/* The handler's message if there is one, else OpenEXRCore's built-in text for `rv`. */
static inline const char *hbk_exr_detail_text(const hbk_exr_detail_t *d, exr_result_t rv)
{
    if (d && d->text[0]) return d->text;
    const char *s = exr_get_default_error_message(rv);
    return s ? s : "unknown OpenEXRCore error";
}

/* OpenEXRCore's allocations (the contexts' alloc_fn). OpenEXRCore 3.1 does not always pass an
 * allocation failure on: a header attribute it cannot allocate is skipped, and exr_start_read
 * then succeeds with a default in its place (a 64 x 64 data window, another compression) or
 * fails with "'channels' attribute not found". So failures are counted here, per thread
 * (OpenEXRCore allocates on the calling thread), and a call that saw one reports
 * HBK_ERR_OUT_OF_MEMORY rather than trusting what it got. One counter per source file. */
static _Thread_local unsigned long hbk_exr_failed_allocs;

static inline void *hbk_exr_alloc(size_t bytes)
{
    void *p = malloc(bytes);
    if (!p) ++hbk_exr_failed_allocs;
    return p;
}

#endif
