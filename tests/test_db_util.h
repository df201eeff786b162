/* test_db_util.h - what the database suites share (test_db.c,
 * test_db_faults.c). */
#ifndef PHKS_TEST_DB_UTIL_H
#define PHKS_TEST_DB_UTIL_H

#include "testutil.h"

/* A signature of `count` features with random vectors (length 15) and
 * the default options (matching NEAREST), or tau changed when
 * other_options. */
phks_signature *synthetic(size_t count, uint64_t *seed, bool other_options);

/* Asserts that a and b are the same signature, field by field. */
void same_signature(const phks_signature *a, const phks_signature *b);

/* A new folder under /tmp (free with remove_dir), a path in it (free),
 * and the folder removed with its files. */
char *temp_dir(void);
char *in_dir(const char *dir, const char *name);
void remove_dir(char *dir);

/* Runs SQL on the file with SQLite directly; returns the first column of
 * the first row as text (malloc'ed, "" when no row); sql_is asserts it. */
char *sql(const char *path, const char *statement);
void sql_is(const char *path, const char *statement, const char *want);

#endif
