/* The benchmarks' command-line arguments. A bad one is named with its allowed range and the
 * program stops before timing anything: atoi read "--help" as 0 frames and printed NaNs. */
#ifndef HBK_BENCH_ARGS_H
#define HBK_BENCH_ARGS_H
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Exits 0 after the usage line for -h or --help anywhere, 2 if there are more than max_args. */
static void bench_check_args(int argc, char **argv, int max_args, const char *usage)
{
    for (int i = 1; i < argc; ++i)
        if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
            printf("usage: %s\n", usage);
            exit(0);
        }
    if (argc - 1 > max_args) {
        fprintf(stderr, "%s: at most %d argument%s, got %d\nusage: %s\n", argv[0], max_args,
                max_args == 1 ? "" : "s", argc - 1, usage);
        exit(2);
    }
}

/* argv[i] as an integer in [lo, hi], or def when it is not given. */
static int bench_int_arg(int argc, char **argv, int i, const char *name, int def, int lo, int hi,
                         const char *usage)
{
    if (i >= argc) return def;
    char *end;
    errno = 0;
    const long v = strtol(argv[i], &end, 10);
    if (end == argv[i] || *end || errno || v < lo || v > hi) {
        fprintf(stderr, "%s: %s must be an integer in [%d, %d], got \"%s\"\nusage: %s\n", argv[0],
                name, lo, hi, argv[i], usage);
        exit(2);
    }
    return (int)v;
}
#endif
