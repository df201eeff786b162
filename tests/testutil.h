/* testutil.h - helpers shared by the test suites. */
#ifndef PHKS_TESTUTIL_H
#define PHKS_TESTUTIL_H

#include "features/features.h"

#include <check.h>
#include <stdbool.h>
#include <stddef.h>

#define PI 3.14159265358979323846

/* Assertions for hot loops: ck_assert reports to Check's parent process
 * through a pipe (a system call per check), these only when they fail. */
#define REQUIRE(c)                                                            \
    do {                                                                      \
        if (!(c))                                                             \
            ck_abort_msg("line %d: %s", __LINE__, #c);                        \
    } while (0)
#define REQUIRE_MSG(c, ...)                                                   \
    do {                                                                      \
        if (!(c))                                                             \
            ck_abort_msg(__VA_ARGS__);                                        \
    } while (0)

/* Runs a suite, returns the process exit status (0 when all passed). */
int run_suite(Suite *suite);

/* Path of a file under the shared meshes folder (../shared/data/meshes),
 * or NULL when that folder is absent; the caller frees with free(). */
char *shared_mesh_path(const char *relative);

/* Uniform random double in [0,1) from a 64-bit state (splitmix64). */
double test_random(uint64_t *state);

/* A growing byte buffer (plain malloc, outside the library's allocator
 * hook), for files the tests build and results they compare. */
typedef struct bytes {
    unsigned char *p;
    size_t n, cap;
} bytes;
/* Appends n bytes of data to b. */
void put(bytes *b, const void *data, size_t n);

/* Seconds on the monotonic clock, for timing. */
double now(void);

/* 1 / longest side of the axis-aligned box of the mesh's vertices. */
double axis_aligned_scale(const phks_mesh *mesh);

/* The feature of s nearest to vector v (s's vector length) by L1
 * distance, the lower index on ties, and that distance into *distance
 * (INFINITY when s has no feature). */
size_t nearest_vector(const phks_signature *s, const double *v,
                       double *distance);

/* A counting allocator for phks_set_allocator: {count_malloc,
 * count_realloc, count_free, NULL}. alloc_live counts the blocks held;
 * alloc_calls numbers the malloc and realloc requests from 0. Request
 * alloc_fail_at fails (-1: none), and with alloc_fail_rest so does every
 * later one. */
extern long alloc_live, alloc_calls, alloc_fail_at;
extern bool alloc_fail_rest;
void *count_malloc(void *user, size_t size);
void *count_realloc(void *user, void *ptr, size_t size);
void count_free(void *user, void *ptr);

#endif
