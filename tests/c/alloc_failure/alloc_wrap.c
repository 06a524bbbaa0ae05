/* The library's allocator calls, wrapped at link time (see CMakeLists.txt): counted, failed on
 * request, and the blocks still live tracked, so a test sees both a crash on an error path
 * and a leak. Atomic: the kernels allocate inside OpenMP regions too. */
#include <stdlib.h>
#include "alloc_failure.h"

void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t n);
void *__real_aligned_alloc(size_t align, size_t n);
void __real_free(void *p);

static long g_fail_at, g_count, g_injected, g_live;
static int g_persist;

void af_arm(long n, int persist)
{
    __atomic_store_n(&g_count, 0, __ATOMIC_SEQ_CST);
    __atomic_store_n(&g_injected, 0, __ATOMIC_SEQ_CST);
    g_persist = persist;
    __atomic_store_n(&g_fail_at, n, __ATOMIC_SEQ_CST);
}

long af_allocations(void) { return __atomic_load_n(&g_count, __ATOMIC_SEQ_CST); }
long af_injected(void) { return __atomic_load_n(&g_injected, __ATOMIC_SEQ_CST); }
long af_live(void) { return __atomic_load_n(&g_live, __ATOMIC_SEQ_CST); }

static int should_fail(void)
{
    const long k = __atomic_add_fetch(&g_count, 1, __ATOMIC_SEQ_CST);
    const long at = __atomic_load_n(&g_fail_at, __ATOMIC_SEQ_CST);
    if (at <= 0 || k < at || (k > at && !g_persist)) return 0;
    __atomic_add_fetch(&g_injected, 1, __ATOMIC_SEQ_CST);
    return 1;
}

static void *counted(void *p)
{
    if (p) __atomic_add_fetch(&g_live, 1, __ATOMIC_SEQ_CST);
    return p;
}

void *__wrap_malloc(size_t n) { return should_fail() ? NULL : counted(__real_malloc(n)); }

void *__wrap_calloc(size_t n, size_t size)
{
    return should_fail() ? NULL : counted(__real_calloc(n, size));
}

void *__wrap_aligned_alloc(size_t align, size_t n)
{
    return should_fail() ? NULL : counted(__real_aligned_alloc(align, n));
}

void *__wrap_realloc(void *p, size_t n)
{
    if (should_fail()) return NULL; /* p stays the caller's */
    void *q = __real_realloc(p, n);
    if (!p) return counted(q);
    if (!q && n == 0) __atomic_sub_fetch(&g_live, 1, __ATOMIC_SEQ_CST); /* freed p */
    return q;
}

void __wrap_free(void *p)
{
    if (p) __atomic_sub_fetch(&g_live, 1, __ATOMIC_SEQ_CST);
    __real_free(p);
}

/* The scenarios' own buffers, outside the count. */
void *af_raw_calloc(size_t bytes) { return __real_calloc(1, bytes ? bytes : 1); }
void af_raw_free(void *p) { __real_free(p); }
