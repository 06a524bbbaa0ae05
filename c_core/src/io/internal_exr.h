/* Private helpers shared by the EXR writer and reader (OpenEXRCore, the C API of OpenEXR 3.1). */
#ifndef HBK_INTERNAL_EXR_H
#define HBK_INTERNAL_EXR_H
#include "hbk_exr.h"
#include "../base/internal_base.h"
#include <openexr.h> /* OpenEXRCore; the include folder comes from pkg-config */
#include <stdio.h>

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

#endif
