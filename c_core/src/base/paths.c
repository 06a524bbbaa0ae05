/* Which code paths the kernels may take: the environment variable HBK_PATHS = "scalar" keeps
 * every hand-dispatched kernel on its plain path, "sse" allows 4-lane vector code but not
 * AVX2 or AVX-512, "avx2" not AVX-512; unset, they take the widest the CPU has. The vector paths give the same
 * bytes as the plain ones; the tests check that by running both, and a user who suspects one
 * can rule it out without a rebuild. (Loops the compiler vectorises itself, with AVX2 clones
 * picked at load, are not switched: they have no separate plain code.) */
#include "internal_base.h"
#include <stdlib.h>
#include <string.h>

int hbk_paths(void)
{
    const char *e = getenv("HBK_PATHS");
    if (e && !strcmp(e, "scalar")) return HBK_PATHS_SCALAR;
    if (e && !strcmp(e, "sse")) return HBK_PATHS_SSE;
    if (e && !strcmp(e, "avx2") && __builtin_cpu_supports("avx2")) return HBK_PATHS_AVX2;
    if (__builtin_cpu_supports("avx512f")) return HBK_PATHS_AVX512;
    return __builtin_cpu_supports("avx2") ? HBK_PATHS_AVX2 : HBK_PATHS_SSE;
}
