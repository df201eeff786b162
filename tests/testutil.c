/* testutil.c - helpers shared by the test suites. */
#include "testutil.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int run_suite(Suite *suite)
{
    SRunner *runner = srunner_create(suite);
    srunner_run_all(runner, CK_NORMAL);
    int failed = srunner_ntests_failed(runner);
    srunner_free(runner);
    return failed == 0 ? 0 : 1;
}

static char *join(const char *dir, const char *relative)
{
    size_t n = strlen(dir) + strlen(relative) + 2;
    char *path = malloc(n);
    if (path)
        snprintf(path, n, "%s/%s", dir, relative);
    return path;
}

char *shared_mesh_path(const char *relative)
{
    const char *dir = getenv("PHKS_SHARED_MESHES");
    struct stat st;
    if (!dir || stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
        return NULL;
    return join(dir, relative);
}

double test_random(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}
