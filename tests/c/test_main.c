#include <stdlib.h>
#include "test.h"

int hbk_test_failed;

typedef struct {
    const char *name;
    void (*fn)(void);
} test_entry_t;

#define HBK_ENTRY(g, n) {#g "." #n, test_##g##_##n},
static const test_entry_t k_tests[] = {HBK_TEST_LIST(HBK_ENTRY)};
#undef HBK_ENTRY

const char *hbk_test_tmpdir(void)
{
    const char *d = getenv("HBK_TEST_TMP");
    return d && *d ? d : "/tmp";
}

/* Usage: hbk_tests [--list] [substring]  — runs every test whose name contains substring. */
int main(int argc, char **argv)
{
    const char *filter = NULL;
    int list = 0;
    for (int i = 1; i < argc; ++i) {
        if (!strcmp(argv[i], "--list")) list = 1;
        else filter = argv[i];
    }
    int run = 0, failed = 0, exact = 0;
    for (size_t i = 0; filter && i < sizeof k_tests / sizeof k_tests[0]; ++i)
        exact |= !strcmp(k_tests[i].name, filter);
    for (size_t i = 0; i < sizeof k_tests / sizeof k_tests[0]; ++i) {
        if (filter && (exact ? strcmp(k_tests[i].name, filter) : !strstr(k_tests[i].name, filter)))
            continue;
        if (list) { puts(k_tests[i].name); continue; }
        hbk_test_failed = 0;
        k_tests[i].fn();
        printf("%s %s\n", hbk_test_failed ? "FAIL" : "ok  ", k_tests[i].name);
        failed += hbk_test_failed;
        ++run;
    }
    if (!list) printf("%d passed, %d failed\n", run - failed, failed);
    if (!list && run == 0) { fprintf(stderr, "no test matches '%s'\n", filter ? filter : ""); return 2; }
    return failed ? 1 : 0;
}
