/* testutil.c - helpers shared by the test suites. */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

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

double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double axis_aligned_scale(const phks_mesh *mesh)
{
    size_t n = phks_mesh_vertex_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    double lo[3] = {INFINITY, INFINITY, INFINITY},
           hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < n; v++)
        for (int d = 0; d < 3; d++) {
            lo[d] = fmin(lo[d], xyz[3 * v + d]);
            hi[d] = fmax(hi[d], xyz[3 * v + d]);
        }
    return 1 / fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
}

long alloc_live, alloc_calls, alloc_fail_at = -1;
bool alloc_fail_rest;

static bool refuse(void)
{
    long request = alloc_calls++;
    return alloc_fail_at >= 0 &&
           (request == alloc_fail_at || (alloc_fail_rest && request > alloc_fail_at));
}

void *count_malloc(void *user, size_t size)
{
    (void)user;
    if (refuse())
        return NULL;
    void *p = malloc(size);
    alloc_live += p != NULL;
    return p;
}

void *count_realloc(void *user, void *ptr, size_t size)
{
    (void)user;
    if (refuse())
        return NULL;
    return realloc(ptr, size);
}

void count_free(void *user, void *ptr)
{
    (void)user;
    alloc_live -= ptr != NULL;
    free(ptr);
}

void put(bytes *b, const void *data, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = 2 * (b->n + n) + 64;
        b->p = realloc(b->p, b->cap);
        REQUIRE(b->p);
    }
    if (n)
        memcpy(b->p + b->n, data, n);
    b->n += n;
}

size_t nearest_vector(const phks_signature *s, const double *v,
                       double *distance)
{
    size_t best = 0, length = phks_signature_vector_length(s);
    *distance = INFINITY;
    for (size_t j = 0; j < phks_signature_feature_count(s); j++) {
        const double *w = phks_signature_feature_vector(s, j);
        double d = 0;
        for (size_t t = 0; t < length; t++)
            d += fabs(v[t] - w[t]);
        if (d < *distance) {
            *distance = d;
            best = j;
        }
    }
    return best;
}
