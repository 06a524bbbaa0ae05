/* Runs the allocation-failure scenarios (alloc_failure.h). Usage:
 * hbk_alloc_failure_tests [scenario ...]; no name runs them all. */
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "alloc_failure.h"

void *af_raw_calloc(size_t bytes);
void af_raw_free(void *p);

enum { MAX_BUFFERS = 256 };

struct af_ctx {
    uint64_t hash;
    int failed, mode, skipped; /* mode: AF_RETRY, AF_SKIP or AF_STOP */
    char why[512];
    const char *retried; /* the call retried after its injected failure */
    void *buffers[MAX_BUFFERS];
    int n_buffers;
};

static int g_threads = 1;
int af_threads(void) { return g_threads; }

void *af_buffer(af_ctx_t *c, size_t bytes)
{
    if (c->n_buffers == MAX_BUFFERS) abort(); /* a scenario bug, not the library's */
    void *p = af_raw_calloc(bytes);
    if (!p) abort();
    return c->buffers[c->n_buffers++] = p;
}

void af_hash(af_ctx_t *c, const void *data, size_t bytes)
{
    const unsigned char *b = data;
    for (size_t i = 0; i < bytes; ++i) c->hash = (c->hash ^ b[i]) * 0x100000001b3ull;
}

const char *af_tmpdir(void)
{
    const char *d = getenv("HBK_TEST_TMP");
    return d && *d ? d : "/tmp";
}

void af_fail(af_ctx_t *c, int line, const char *fmt, ...)
{
    if (c->failed) return;
    c->failed = 1;
    int n = line ? snprintf(c->why, sizeof c->why, "line %d: ", line) : 0; /* 0: the runner's */
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->why + n, sizeof c->why - (size_t)n, fmt, ap);
    va_end(ap);
}

int af_after_injection(af_ctx_t *c, const char *expr)
{
    c->retried = expr;
    c->skipped |= c->mode == AF_SKIP;
    return c->mode;
}

int af_skipped(const af_ctx_t *c) { return c->skipped; }
int af_failed(const af_ctx_t *c) { return c->failed; }

/* One run with allocation `at` failing (0: none; and every one after it in mode AF_STOP),
 * handled as `mode` says; returns the allocations the run made. */
static long run_once(const af_scenario_t *s, long at, int mode, af_ctx_t *c)
{
    memset(c, 0, sizeof *c);
    c->hash = 0xcbf29ce484222325ull;
    c->mode = mode;
    void *state = af_raw_calloc(s->state_size);
    const long live0 = af_live();
    af_arm(at, mode == AF_STOP);
    s->run(c, state);
    const long made = af_allocations();
    af_arm(0, 0);
    s->done(state);
    if (af_live() != live0)
        af_fail(c, 0, "%ld blocks the library allocated are not freed", af_live() - live0);
    af_raw_free(state);
    for (int i = 0; i < c->n_buffers; ++i) af_raw_free(c->buffers[i]);
    return made;
}

/* Every run of scenario s at the current thread count; `clean` is the 1-thread clean run's
 * hash (0: this is that run, which sets it). Returns the number of failed runs; *total_out
 * is the clean run's allocations. */
static int sweep(const af_scenario_t *s, uint64_t *clean, long *total_out)
{
    static const char *const how[] = {" alone, the call retried", " alone, the call skipped",
                                      " and every one after"};
    af_ctx_t c;
    const long total = *total_out = run_once(s, 0, AF_RETRY, &c);
    if (!c.failed && total == 0) af_fail(&c, 0, "the clean run allocated nothing");
    if (!c.failed && *clean && c.hash != *clean)
        af_fail(&c, 0, "the clean run's bytes differ from those at 1 thread");
    if (c.failed) {
        printf("  %s, %d threads, the clean run: %s\n", s->name, g_threads, c.why);
        return 1;
    }
    *clean = c.hash;
    int bad = 0;
    for (int mode = AF_RETRY; mode <= AF_STOP; ++mode)
        for (long at = 1; at <= total; ++at) {
            if (getenv("HBK_AF_VERBOSE")) /* which run, should one crash */
                fprintf(stderr, "%s, %d threads, allocation %ld%s\n", s->name, g_threads, at,
                        how[mode]);
            run_once(s, at, mode, &c);
            if (!c.failed && mode == AF_RETRY && c.hash != *clean)
                af_fail(&c, 0, "the outputs differ from the clean run's after %s failed and was "
                        "retried", c.retried ? c.retried : "no call");
            if (c.failed && bad++ < 20)
                printf("  %s, %d threads, allocation %ld of %ld failing%s: %s\n", s->name,
                       g_threads, at, total, how[mode], c.why);
        }
    return bad;
}

static int run_scenario(const af_scenario_t *s)
{
    uint64_t clean = 0;
    long total[2];
    int bad = 0;
    for (g_threads = 1; g_threads <= 2; ++g_threads) bad += sweep(s, &clean, &total[g_threads - 1]);
    printf("%s alloc_failure.%s (%ld allocations at 1 thread, %ld at 2; each failed alone, "
           "retried or skipped, and from there on)\n", bad ? "FAIL" : "ok  ", s->name, total[0],
           total[1]);
    return bad != 0;
}

#define HBK_AF_ENTRY(n) &af_scenario_##n,
static const af_scenario_t *const k_scenarios[] = {HBK_AF_SCENARIOS(HBK_AF_ENTRY)};
#undef HBK_AF_ENTRY

int main(int argc, char **argv)
{
    setvbuf(stdout, NULL, _IOLBF, 0); /* what was printed survives a crash */
    int failed = 0, run = 0;
    for (size_t i = 0; i < sizeof k_scenarios / sizeof k_scenarios[0]; ++i) {
        int wanted = argc < 2;
        for (int a = 1; a < argc; ++a) wanted |= !strcmp(argv[a], k_scenarios[i]->name);
        if (!wanted) continue;
        failed += run_scenario(k_scenarios[i]);
        ++run;
    }
    if (run == 0) {
        fprintf(stderr, "no scenario matches\n");
        return 2;
    }
    return failed ? 1 : 0;
}
