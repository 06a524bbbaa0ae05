/* Hydrobake base: export macro, result codes, messages, progress/cancel, parameter tables.
 *
 * Conventions every kernel follows:
 *  - Every fallible call returns an hbk_result_t; HBK_OK == 0. Nothing aborts or exits.
 *  - A call that runs out of memory returns HBK_ERR_OUT_OF_MEMORY with a message and leaves its
 *    handle as it was (a create leaves no handle), so it may simply be tried again.
 *  - A handle keeps the detail message of its last failure (hbk_<x>_message(h)). Calls without
 *    a handle (create, stateless kernels) take an optional hbk_message_t* for the detail.
 *  - Output buffers are owned by the caller; sizes and row strides are passed in.
 *  - No global state: the random seed and the thread count come in through the params.
 *    Results never depend on the thread count; at most four threads per processor are
 *    started, whatever it asks (more only cost stacks, and OpenMP ends the process when it
 *    cannot make them).
 */
#ifndef HBK_BASE_H
#define HBK_BASE_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#  define HBK_EXPORT __declspec(dllexport)
#else
#  define HBK_EXPORT __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

#define HBK_VERSION_MAJOR 0
#define HBK_VERSION_MINOR 1
#define HBK_VERSION_PATCH 0

typedef int32_t hbk_result_t;

enum {
    HBK_OK = 0,
    HBK_ERR_INVALID_ARGUMENT = 1, /* a parameter is out of range; the message names it */
    HBK_ERR_OUT_OF_MEMORY = 2,
    HBK_ERR_IO = 3,               /* a file could not be opened, written or renamed */
    HBK_ERR_FORMAT = 4,           /* a file is not what was expected (missing channel, corrupt) */
    HBK_ERR_CANCELLED = 5,        /* the caller set hbk_progress_t.cancel */
    HBK_ERR_VERSION = 6,          /* a params struct's size field does not match this library */
    HBK_ERR_STATE = 7,            /* the call is not valid in the handle's current state */
    HBK_ERR_INTERNAL = 8
};
#define HBK_RESULT_COUNT 9

/* Built-in English name of a result code; never NULL, never fails. */
HBK_EXPORT const char *hbk_result_string(hbk_result_t r);

/* "major.minor.patch"; never fails. */
HBK_EXPORT const char *hbk_version_string(void);

/* Detail message of a call that has no handle to keep it on. Always NUL-terminated. */
#define HBK_MESSAGE_SIZE 256
typedef struct hbk_message {
    char text[HBK_MESSAGE_SIZE];
} hbk_message_t;

/* Progress and cancellation for long calls, owned by the caller and shared with one call at a
 * time. The caller may set `cancel` to non-zero from any thread; the call polls it at least
 * every few milliseconds and returns HBK_ERR_CANCELLED, leaving the handle as it was before the
 * call. The library writes `fraction` (0..1) as it goes. Plain int32/float loads and stores:
 * no callback ever runs on a library thread. */
typedef struct hbk_progress {
    volatile int32_t cancel;
    volatile float fraction;
} hbk_progress_t;

/* Parameter tables: every params struct is described field by field, so bindings can build
 * their mirror, user interfaces their widgets, and the library its range checks, all from
 * one place. `min`/`max` are inclusive. Arrays (count > 1) are checked element-wise. */
typedef enum hbk_param_type {
    HBK_PARAM_F32 = 1,
    HBK_PARAM_I32 = 2,
    HBK_PARAM_U64 = 3,
    HBK_PARAM_BOOL = 4, /* int32_t, 0 or 1 */
    HBK_PARAM_ENUM = 5  /* int32_t, index into `items` ("A|B|C") */
} hbk_param_type_t;

typedef struct hbk_param_info {
    const char *name;        /* C field name, also the binding's name */
    int32_t type;            /* hbk_param_type_t */
    uint32_t offset;         /* offsetof(struct, field) */
    uint32_t count;          /* 1, or the array length (vectors) */
    double min, max;         /* inclusive range */
    const char *unit;        /* "m", "s", "deg", "m/s", "1" (dimensionless), "%", ... */
    const char *items;       /* enum items separated by '|', else NULL */
    const char *description; /* one sentence: what it does, typical values */
} hbk_param_info_t;

/* Checks every field of `params` against `table`; on failure writes e.g.
 * "wind_speed = -3: must be in [0, 50] m/s" to `msg` and returns HBK_ERR_INVALID_ARGUMENT.
 * The first field of every params struct is `uint32_t size`, checked against `expected_size`. */
HBK_EXPORT hbk_result_t hbk_params_validate(const void *params, size_t expected_size,
                                            const hbk_param_info_t *table, size_t count,
                                            hbk_message_t *msg);

/* Copies a grid of nx x ny x nz points of `comps` floats, stored x fastest (element c of
 * point (x, y, z) at ((z ny + y) nx + x) comps + c, as the kernels' volumes are), into dst
 * stored z fastest (at ((x ny + y) nz + z) comps + c): the [x][y][z] order OpenVDB's dense
 * copies take. threads: 0 or 1 for one. dst must not overlap src. HBK_ERR_INVALID_ARGUMENT
 * (NULL, dst == src, a size outside [1, 65536], comps outside [1, 16]). */
HBK_EXPORT hbk_result_t hbk_grid_to_xyz(const float *src, float *dst, int32_t nx, int32_t ny,
                                        int32_t nz, int32_t comps, int32_t threads,
                                        hbk_message_t *msg);

/* Size (field NULL) or offset of a field of a public struct, by name, e.g.
 * hbk_layout("hbk_image_t", "row_stride", &off). Lets bindings check their mirrors of the
 * structs at load time. HBK_ERR_INVALID_ARGUMENT for an unknown struct or field. */
HBK_EXPORT hbk_result_t hbk_layout(const char *struct_name, const char *field, size_t *out);

#ifdef __cplusplus
}
#endif
#endif
