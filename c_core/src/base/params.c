/* Range checks driven by the parameter tables (see hbk_param_info_t). */
#include "internal_base.h"
#include <float.h>
#include <math.h>
#include <string.h>

/* A float is compared with its bounds rounded to float: the documented bound, as a float
 * (what Blender's slider or a C caller stores), must be accepted. */
static float to_float(double d) /* past float's range is infinite, not undefined */
{
    return d > FLT_MAX ? INFINITY : d < -FLT_MAX ? -INFINITY : (float)d;
}

static int in_range(double v, const hbk_param_info_t *p)
{
    if (p->type == HBK_PARAM_F32)
        return (float)v >= to_float(p->min) && (float)v <= to_float(p->max);
    return v >= p->min && v <= p->max;
}

hbk_result_t hbk_params_validate(const void *params, size_t expected_size,
                                 const hbk_param_info_t *table, size_t count, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!params) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "params: must not be NULL");
    uint32_t size;
    memcpy(&size, params, sizeof size);
    if (size != expected_size)
        return hbk_fail(msg, HBK_ERR_VERSION,
                        "params.size = %u: this library expects %zu (use the *_params_default() "
                        "of the same version)", size, expected_size);
    const unsigned char *base = params;
    for (size_t i = 0; i < count; ++i) {
        const hbk_param_info_t *p = &table[i];
        for (uint32_t k = 0; k < p->count; ++k) {
            const unsigned char *at = base + p->offset;
            double v;
            switch (p->type) {
            case HBK_PARAM_F32: {
                float f;
                memcpy(&f, at + 4 * k, 4);
                if (!isfinite(f) && p->count > 1)
                    return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s[%u] = %g: must be a "
                                    "finite number in [%g, %g] %s", p->name, k, (double)f,
                                    p->min, p->max, p->unit);
                if (!isfinite(f))
                    return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s = %g: must be a finite "
                                    "number in [%g, %g] %s", p->name, (double)f, p->min, p->max,
                                    p->unit);
                v = f;
                break;
            }
            case HBK_PARAM_U64: {
                uint64_t u;
                memcpy(&u, at + 8 * k, 8);
                v = (double)u;
                break;
            }
            default: { /* I32, BOOL, ENUM */
                int32_t n;
                memcpy(&n, at + 4 * k, 4);
                v = n;
                break;
            }
            }
            if (!in_range(v, p)) {
                if (p->count > 1)
                    return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s[%u] = %g: must be in "
                                    "[%g, %g] %s", p->name, k, v, p->min, p->max, p->unit);
                return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s = %g: must be in [%g, %g] %s",
                                p->name, v, p->min, p->max, p->unit);
            }
        }
    }
    return HBK_OK;
}
