/* testutil.h - helpers shared by the test suites. */
#ifndef PHKS_TESTUTIL_H
#define PHKS_TESTUTIL_H

#include "internal.h"

#include <check.h>
#include <stddef.h>

/* Runs a suite, returns the process exit status (0 when all passed). */
int run_suite(Suite *suite);

/* Path of a file under the shared meshes folder (../shared/data/meshes),
 * or NULL when that folder is absent; the caller frees with free(). */
char *shared_mesh_path(const char *relative);

/* Uniform random double in [0,1) from a 64-bit state (splitmix64). */
double test_random(uint64_t *state);

#endif
