/* Allocation-failure tests: every scenario runs once cleanly, then, for each of its
 * allocations, three times: with that allocation failing alone and the failed call retried,
 * with it failing alone and the failed call skipped, and with every allocation failing from
 * there on.
 *
 * The library's malloc, calloc, aligned_alloc and realloc are wrapped at link time
 * (-Wl,--wrap), so only the library's own calls are counted and failed; the scenarios allocate
 * through af_buffer, which the failures never reach. A call may only succeed or report
 * HBK_ERR_OUT_OF_MEMORY, with a message, and only when an allocation failed under it; a create
 * that fails leaves no handle. Retried, the call must succeed and the run end with the clean
 * run's bytes: the failure left the handle as it was. Skipped, the scenario goes on as a
 * caller that carries on would (later calls may then refuse); with every allocation failing,
 * it stops at the first failure. In every mode nothing may crash, and once the handles are
 * destroyed nothing the library allocated is left. Run in the sanitizer tree too, where a bad
 * access fails the test. */
#ifndef HBK_ALLOC_FAILURE_H
#define HBK_ALLOC_FAILURE_H
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "hydrobake.h"

/* Every scenario, one X(name) each: the runner and CMake read this list. */
#define HBK_AF_SCENARIOS(X) \
    X(rain)                 \
    X(fluid_simulate)       \
    X(fluid_particles)      \
    X(fluid_velocity_grid)  \
    X(snow)                 \
    X(water)                \
    X(caustics)             \
    X(io)

typedef struct af_ctx af_ctx_t;

/* The allocation counter (alloc_wrap.c). af_arm(n, persist): the n-th allocation from now
 * fails, and with persist every one after it too; n = 0 fails none. */
void af_arm(long n, int persist);
long af_allocations(void); /* since the last af_arm */
long af_injected(void);    /* failures made since the last af_arm */
long af_live(void);        /* blocks the library allocated and has not freed */

/* A zeroed scratch buffer for the scenario, freed after the run; never fails by injection. */
void *af_buffer(af_ctx_t *c, size_t bytes);
/* Adds bytes to the run's hash (the outputs a scenario compares with the clean run). */
void af_hash(af_ctx_t *c, const void *data, size_t bytes);
/* The thread count the scenario's params take: the runner runs every scenario at 1, then at
 * 2, whose clean run must give the same bytes (at 2 the failing allocation may be any of the
 * threads', so errors raised inside parallel loops are reached too). */
int af_threads(void);
/* The folder for files (HBK_TEST_TMP or /tmp). */
const char *af_tmpdir(void);
/* Records a failure of the run (at a scenario's `line`), printf-style; the scenario should
 * return after it. */
void af_fail(af_ctx_t *c, int line, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/* What to do after `expr` failed by injection: retry it (the call is named if the run's bytes
 * then differ), skip it and go on, or end the scenario (every allocation failing). */
enum { AF_RETRY, AF_SKIP, AF_STOP };
int af_after_injection(af_ctx_t *c, const char *expr);
/* Whether a failed call was skipped in this run: later calls may fail then. */
int af_skipped(const af_ctx_t *c);
/* Whether the run has failed (the macros return at once then). */
int af_failed(const af_ctx_t *c);

/* Runs a call that returns hbk_result_t. HBK_OK goes on. HBK_ERR_OUT_OF_MEMORY right after an
 * injected failure is handled as af_after_injection says (a retry must succeed). Anything
 * else fails the run, unless an earlier call was skipped. `msg` is the handle's message
 * expression, which must name the failure. */
#define AF_CALL(c, expr, msg)                                                                \
    do {                                                                                     \
        const long inj_ = af_injected();                                                     \
        hbk_result_t r_ = (expr);                                                            \
        if (r_ == HBK_OK) break;                                                             \
        if (r_ == HBK_ERR_OUT_OF_MEMORY && af_injected() > inj_) {                           \
            const char *m_ = (msg);                                                          \
            if (!m_ || !*m_) {                                                               \
                af_fail(c, __LINE__, "%s: out of memory without a message", #expr);          \
                return;                                                                      \
            }                                                                                \
            const int a_ = af_after_injection(c, #expr);                                     \
            if (a_ == AF_STOP) return;                                                       \
            if (a_ == AF_SKIP) break;                                                        \
            r_ = (expr);                                                                     \
            if (r_ == HBK_OK) break;                                                         \
        } else if (af_skipped(c)) {                                                          \
            break;                                                                           \
        }                                                                                    \
        af_fail(c, __LINE__, "%s returned %s (%s)", #expr, hbk_result_string(r_), (msg));    \
        return;                                                                              \
    } while (0)

/* AF_CALL for a create call, which must leave *out NULL when it fails; skipped, it ends the
 * scenario (there is no handle to go on with). */
#define AF_CREATE(c, expr, out, msgbuf)                                                      \
    do {                                                                                     \
        const long inj_ = af_injected();                                                     \
        (msgbuf).text[0] = '\0';                                                             \
        hbk_result_t r_ = (expr);                                                            \
        if (r_ == HBK_OK) break;                                                             \
        if ((out) != NULL) {                                                                 \
            af_fail(c, __LINE__, "%s failed but left a handle", #expr);                      \
            return;                                                                          \
        }                                                                                    \
        if (r_ == HBK_ERR_OUT_OF_MEMORY && af_injected() > inj_) {                           \
            if (!(msgbuf).text[0]) {                                                         \
                af_fail(c, __LINE__, "%s: out of memory without a message", #expr);          \
                return;                                                                      \
            }                                                                                \
            if (af_after_injection(c, #expr) != AF_RETRY) return;                            \
            r_ = (expr);                                                                     \
            if (r_ == HBK_OK) break;                                                         \
        } else if (af_skipped(c)) {                                                          \
            return;                                                                          \
        }                                                                                    \
        af_fail(c, __LINE__, "%s returned %s (%s)", #expr, hbk_result_string(r_),            \
                (msgbuf).text);                                                              \
        return;                                                                              \
    } while (0)

/* A scenario: `run` makes its handles in *state (zeroed before each run) and `done` destroys
 * whatever `run` made, whether it finished or returned early. */
typedef struct {
    const char *name;
    size_t state_size;
    void (*run)(af_ctx_t *c, void *state);
    void (*done)(void *state);
} af_scenario_t;

#define HBK_AF_DECLARE(n) extern const af_scenario_t af_scenario_##n;
HBK_AF_SCENARIOS(HBK_AF_DECLARE)
#undef HBK_AF_DECLARE

#endif
