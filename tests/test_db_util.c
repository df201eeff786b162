/* test_db_util.c - what the database suites share (test_db.c,
 * test_db_faults.c): synthetic signatures and scratch folders. */
#include "test_db_util.h"

#include <dirent.h>
#include <math.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

phks_signature *synthetic(size_t count, uint64_t *seed, bool other_options)
{
    phks_signature *sig;
    ck_assert_int_eq(phks__signature_alloc(count, 0, 15, &sig), PHKS_OK);
    ck_assert_int_eq(phks__options_resolve(NULL, &sig->options), PHKS_OK);
    /* The scan's own score, which the brute force here recomputes; the
     * verified stage is tested in test_verify.c. */
    sig->options.matching = PHKS_MATCHING_NEAREST;
    if (other_options)
        sig->options.tau *= 1.5;
    for (size_t i = 0; i < count; i++) {
        sig->vertex[i] = (uint32_t)(3 * i + 1);
        for (int d = 0; d < 3; d++)
            sig->position[3 * i + d] = test_random(seed) - 0.5;
        sig->persistence[i] = i == 0 ? INFINITY : test_random(seed);
        for (size_t s = 0; s < 15; s++)
            sig->vectors[i * 15 + s] = 10 * test_random(seed);
    }
    return sig;
}

void same_signature(const phks_signature *a, const phks_signature *b)
{
    ck_assert_uint_eq(a->count, b->count);
    ck_assert_uint_eq(a->length, b->length);
    ck_assert_mem_eq(a->vertex, b->vertex, a->count * sizeof *a->vertex);
    ck_assert_mem_eq(a->position, b->position, 3 * a->count * sizeof(double));
    ck_assert_mem_eq(a->persistence, b->persistence, a->count * sizeof(double));
    ck_assert_mem_eq(a->vectors, b->vectors,
                     a->count * a->length * sizeof(double));
    ck_assert(phks__options_comparable(&a->options, &b->options));
}

char *temp_dir(void)
{
    char *dir = strdup("/tmp/phks-test-db-XXXXXX");
    ck_assert_ptr_nonnull(dir);
    ck_assert_ptr_nonnull(mkdtemp(dir));
    return dir;
}

char *in_dir(const char *dir, const char *name)
{
    size_t n = strlen(dir) + strlen(name) + 2;
    char *path = malloc(n);
    ck_assert_ptr_nonnull(path);
    snprintf(path, n, "%s/%s", dir, name);
    return path;
}

void remove_dir(char *dir)
{
    DIR *d = opendir(dir);
    ck_assert_ptr_nonnull(d);
    struct dirent *e;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) {
            char *p = in_dir(dir, e->d_name);
            unlink(p);
            free(p);
        }
    closedir(d);
    ck_assert_int_eq(rmdir(dir), 0);
    free(dir);
}

/* Runs SQL on the file with SQLite directly; returns the first column of
 * the first row as text (malloc'ed, "" when no row). */
char *sql(const char *path, const char *statement)
{
    sqlite3 *db;
    ck_assert_int_eq(sqlite3_open_v2(path, &db,
                                     SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE,
                                     NULL),
                     SQLITE_OK);
    sqlite3_busy_timeout(db, 5000);
    sqlite3_stmt *st;
    ck_assert_msg(sqlite3_prepare_v2(db, statement, -1, &st, NULL) == SQLITE_OK,
                  "%s: %s", statement, sqlite3_errmsg(db));
    int rc = sqlite3_step(st);
    ck_assert_msg(rc == SQLITE_ROW || rc == SQLITE_DONE, "%s: %s", statement,
                  sqlite3_errmsg(db));
    const char *text =
        rc == SQLITE_ROW ? (const char *)sqlite3_column_text(st, 0) : NULL;
    char *out = strdup(text ? text : "");
    sqlite3_finalize(st);
    ck_assert_int_eq(sqlite3_close(db), SQLITE_OK);
    return out;
}

void sql_is(const char *path, const char *statement, const char *want)
{
    char *got = sql(path, statement);
    ck_assert_str_eq(got, want);
    free(got);
}
