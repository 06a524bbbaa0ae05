#include "internal_base.h"
#include <stdio.h>
#include <string.h>

static const char *const k_names[HBK_RESULT_COUNT] = {
    "success", "invalid argument", "out of memory", "input/output error", "bad file format",
    "cancelled", "params struct version mismatch", "invalid state", "internal error",
};

const char *hbk_result_string(hbk_result_t r)
{
    return (r >= 0 && r < HBK_RESULT_COUNT) ? k_names[r] : "unknown result code";
}

const char *hbk_version_string(void) { return "0.1.0"; }

void hbk_message_clear(hbk_message_t *msg)
{
    if (msg) msg->text[0] = '\0';
}

hbk_result_t hbk_fail(hbk_message_t *msg, hbk_result_t code, const char *fmt, ...)
{
    if (msg) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(msg->text, sizeof msg->text, fmt, ap);
        va_end(ap);
    }
    return code;
}
