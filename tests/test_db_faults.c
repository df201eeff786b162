/* test_db_faults.c - the database under load and faults. Load: two
 * processes add while a third queries, for PHKS_DB_LOAD_SECONDS (20 s
 * unless set); no call fails (none reaches the 5 s busy wait's
 * PHKS_ERROR_IO) and every add that returned PHKS_OK is in the file with
 * its bytes. Full disk: a VFS that wraps SQLite's default one and fails
 * writes with SQLITE_FULL once a budget of bytes is spent; an add that
 * meets it fails with PHKS_ERROR_IO and a message, and leaves the last
 * committed state, which queries answer as before, to the same handle and
 * to a new one. The tool's full disk is test_db_full.sh's. */
#include "test_db_util.h"

#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* ---- entries anyone can remake: entry n of writer w */

enum { WRITERS = 2, QUERIES = 3, K = 5 };

static phks_signature *entry_signature(int writer, uint64_t n)
{
    uint64_t seed = (uint64_t)writer << 32 | n;
    return synthetic(8 + n % 8, &seed, false);
}

static void entry_name(char *name, size_t size, int writer, uint64_t n)
{
    snprintf(name, size, "writer %d entry %llu", writer, (unsigned long long)n);
}

static unsigned char *encoded(const phks_signature *sig, size_t *size)
{
    *size = phks_signature_encoded_size(sig);
    unsigned char *blob = malloc(*size);
    ck_assert_ptr_nonnull(blob);
    ck_assert_int_eq(phks_signature_encode(sig, blob, *size, size), PHKS_OK);
    return blob;
}

/* An entry added: its id, and which it is. */
typedef struct added {
    int64_t id;
    int writer;
    uint64_t n;
} added;

/* The entry with this id is entry n of writer w: name and bytes. */
static void entry_is(phks_db *db, const added *a)
{
    phks_signature *got, *want = entry_signature(a->writer, a->n);
    char name[64], want_name[64];
    entry_name(want_name, sizeof want_name, a->writer, a->n);
    phks_status st = phks_db_get(db, a->id, &got, name, sizeof name, NULL, 0);
    ck_assert_msg(st == PHKS_OK, "entry %lld (%s): %s", (long long)a->id,
                  want_name, phks_last_error_message());
    ck_assert_str_eq(name, want_name);
    size_t n_got, n_want;
    unsigned char *b_got = encoded(got, &n_got), *b_want = encoded(want, &n_want);
    ck_assert_uint_eq(n_got, n_want);
    ck_assert_mem_eq(b_got, b_want, n_got);
    free(b_got);
    free(b_want);
    phks_signature_free(got);
    phks_signature_free(want);
}

/* The file holds exactly these entries, each with its bytes. */
static void entries_are(phks_db *db, const added *book, size_t count)
{
    size_t n;
    ck_assert_int_eq(phks_db_count(db, &n), PHKS_OK);
    ck_assert_uint_eq(n, count);
    for (size_t i = 0; i < count; i++)
        entry_is(db, &book[i]);
}

static phks_db *open_db(const char *path, unsigned flags)
{
    phks_db *db;
    phks_status st = phks_db_open(path, flags, &db);
    ck_assert_msg(st == PHKS_OK, "%s", phks_last_error_message());
    return db;
}

static double clock_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* *slowest, or the time since start when longer. */
static void note_time(double *slowest, double start)
{
    double took = clock_now() - start;
    if (took > *slowest)
        *slowest = took;
}

/* ---- load */

static double load_seconds(void)
{
    const char *s = getenv("PHKS_DB_LOAD_SECONDS");
    double v = s ? atof(s) : 0;
    return v > 0 ? v : 20;
}

/* A child's end: its figures on stderr, its verdict as exit status (a
 * child never returns into Check). */
static void child_exit(const char *who, size_t calls, double slowest,
                       phks_status st)
{
    if (st != PHKS_OK)
        fprintf(stderr, "%s: status %d after %zu calls: %s\n", who, (int)st,
                calls, phks_last_error_message());
    else
        fprintf(stderr, "%s: %zu calls, slowest %.3f s\n", who, calls, slowest);
    _exit(st == PHKS_OK ? 0 : 1);
}

/* Adds entries 0, 1, ... of writer w until the deadline, one transaction
 * each; each that returned PHKS_OK goes to the log as an `added`. */
static void writer(const char *path, int w, double deadline, const char *log)
{
    phks_db *db;
    phks_status st = phks_db_open(path, 0, &db);
    FILE *f = fopen(log, "wb");
    double slowest = 0;
    uint64_t n = 0;
    for (; st == PHKS_OK && f && clock_now() < deadline; n++) {
        phks_signature *sig = entry_signature(w, n);
        char name[64];
        entry_name(name, sizeof name, w, n);
        added a = {0, w, n};
        double t = clock_now();
        st = phks_db_add(db, name, "load", sig, &a.id);
        note_time(&slowest, t);
        phks_signature_free(sig);
        if (st == PHKS_OK && fwrite(&a, sizeof a, 1, f) != 1)
            st = PHKS_ERROR_IO;
    }
    if (!f || fclose(f) != 0)
        st = PHKS_ERROR_IO;
    phks_db_close(db);
    child_exit(w == 1 ? "writer 1" : "writer 2", (size_t)n, slowest, st);
}

/* Queries until the deadline: every call answers, with K hits (the file
 * starts with K entries), and the count never goes back. */
static void querier(const char *path, double deadline)
{
    phks_db *db;
    phks_status st = phks_db_open(path, 0, &db);
    uint64_t seed = 99;
    size_t calls = 0, count = 0, last = 0;
    double slowest = 0;
    phks_hit hits[K];
    for (; st == PHKS_OK && clock_now() < deadline; calls++) {
        phks_signature *q = synthetic(10, &seed, false);
        size_t got = 0;
        double t = clock_now();
        st = phks_db_query(db, q, K, hits, &got);
        if (st == PHKS_OK)
            st = phks_db_count(db, &count);
        note_time(&slowest, t);
        phks_signature_free(q);
        if (st == PHKS_OK && (got != K || count < last))
            st = PHKS_ERROR_CORRUPT;
        last = count;
    }
    phks_db_close(db);
    child_exit("querier", calls, slowest, st);
}

/* The log of writer w, appended to book. */
static size_t read_log(const char *log, added *book, size_t count, size_t room)
{
    FILE *f = fopen(log, "rb");
    ck_assert_ptr_nonnull(f);
    size_t n;
    while ((n = fread(book + count, sizeof *book, room - count, f)) > 0)
        count += n;
    ck_assert(feof(f));
    fclose(f);
    return count;
}

START_TEST(two_writers_and_a_reader_lose_nothing)
{
    char *dir = temp_dir(), *path = in_dir(dir, "load.db");
    char *logs[WRITERS] = {in_dir(dir, "writer1.log"), in_dir(dir, "writer2.log")};
    size_t room = 1 << 20, count = 0;
    added *book = malloc(room * sizeof *book);
    ck_assert_ptr_nonnull(book);
    /* Writer 0's K entries, so every query has K hits. */
    phks_db *db = open_db(path, PHKS_DB_CREATE);
    for (uint64_t n = 0; n < K; n++) {
        phks_signature *sig = entry_signature(0, n);
        char name[64];
        entry_name(name, sizeof name, 0, n);
        book[count] = (added){0, 0, n};
        ck_assert_int_eq(phks_db_add(db, name, NULL, sig, &book[count++].id),
                         PHKS_OK);
        phks_signature_free(sig);
    }
    phks_db_close(db);

    double deadline = clock_now() + load_seconds();
    pid_t pids[WRITERS + 1];
    for (int c = 0; c <= WRITERS; c++) {
        pids[c] = fork();
        ck_assert_int_ge(pids[c], 0);
        if (pids[c] == 0 && c < WRITERS)
            writer(path, c + 1, deadline, logs[c]);
        if (pids[c] == 0)
            querier(path, deadline);
    }
    for (int c = 0; c <= WRITERS; c++) {
        int status;
        ck_assert_int_eq(waitpid(pids[c], &status, 0), pids[c]);
        ck_assert_msg(WIFEXITED(status) && WEXITSTATUS(status) == 0,
                      "child %d failed (its stderr says why)", c);
    }

    for (int w = 0; w < WRITERS; w++)
        count = read_log(logs[w], book, count, room);
    db = open_db(path, PHKS_DB_READONLY);
    entries_are(db, book, count);
    phks_db_close(db);
    sql_is(path, "PRAGMA integrity_check", "ok");
    fprintf(stderr, "load: %zu entries after %.0f s\n", count, load_seconds());
    for (int w = 0; w < WRITERS; w++)
        free(logs[w]);
    free(book);
    free(path);
    remove_dir(dir);
}
END_TEST

/* ---- a full disk */

/* SQLite's default VFS with xWrite wrapped: `room` bytes more are
 * written, then SQLITE_FULL (the write that crosses the line writes its
 * first bytes, as a real disk would); -1 for no limit. A file keeps the
 * real one's methods but xWrite: the unix VFS has a few sets of them (one
 * per kind of locking), each wrapped once. */
enum { METHOD_SETS = 8 };
static sqlite3_vfs full_vfs, *real_vfs;
static sqlite3_io_methods full_methods[METHOD_SETS];
static const sqlite3_io_methods *real_methods[METHOD_SETS];
static long long room = -1;

static int full_write(sqlite3_file *f, const void *data, int amount,
                      sqlite3_int64 offset)
{
    const sqlite3_io_methods *real =
        real_methods[f->pMethods - (const sqlite3_io_methods *)full_methods];
    if (room < 0 || amount <= room) {
        room -= room < 0 ? 0 : amount;
        return real->xWrite(f, data, amount, offset);
    }
    if (room > 0)
        real->xWrite(f, data, (int)room, offset);
    room = 0;
    return SQLITE_FULL;
}

/* The wrapped set of these real methods. */
static const sqlite3_io_methods *wrapped(const sqlite3_io_methods *real)
{
    int k = 0;
    while (k < METHOD_SETS && real_methods[k] && real_methods[k] != real)
        k++;
    REQUIRE(k < METHOD_SETS);
    if (!real_methods[k]) {
        real_methods[k] = real;
        full_methods[k] = *real;
        full_methods[k].xWrite = full_write;
    }
    return &full_methods[k];
}

static int full_open(sqlite3_vfs *vfs, const char *name, sqlite3_file *f,
                     int flags, int *out_flags)
{
    (void)vfs;
    int rc = real_vfs->xOpen(real_vfs, name, f, flags, out_flags);
    if (rc == SQLITE_OK && f->pMethods)
        f->pMethods = wrapped(f->pMethods);
    return rc;
}

static void full_vfs_register(void)
{
    real_vfs = sqlite3_vfs_find(NULL);
    ck_assert_ptr_nonnull(real_vfs);
    full_vfs = *real_vfs;
    full_vfs.zName = "phks-test-full";
    full_vfs.pNext = NULL;
    full_vfs.xOpen = full_open;
    ck_assert_int_eq(sqlite3_vfs_register(&full_vfs, 1), SQLITE_OK);
}

/* The answers to QUERIES fixed queries. */
typedef struct answers {
    phks_hit hits[QUERIES][K];
    size_t count[QUERIES];
} answers;

static void ask(phks_db *db, answers *a)
{
    uint64_t seed = 7;
    memset(a, 0, sizeof *a);
    for (int q = 0; q < QUERIES; q++) {
        phks_signature *sig = synthetic(10, &seed, false);
        phks_status st = phks_db_query(db, sig, K, a->hits[q], &a->count[q]);
        ck_assert_msg(st == PHKS_OK, "%s", phks_last_error_message());
        phks_signature_free(sig);
    }
}

static void same_answers(const answers *a, const answers *b)
{
    ck_assert_mem_eq(a->count, b->count, sizeof a->count);
    for (int q = 0; q < QUERIES; q++)
        for (size_t h = 0; h < a->count[q]; h++) {
            ck_assert_int_eq(a->hits[q][h].id, b->hits[q][h].id);
            ck_assert_double_eq(a->hits[q][h].score, b->hits[q][h].score);
        }
}

/* Adds the next entries of writer 1 to book: one, or a batch of three
 * when batch. */
static phks_status add_next(phks_db *db, added *book, size_t *count,
                            bool batch)
{
    size_t n = batch ? 3 : 1;
    phks_db_entry e[3];
    phks_signature *sigs[3];
    char names[3][64];
    int64_t ids[3];
    for (size_t i = 0; i < n; i++) {
        uint64_t which = *count + i;
        sigs[i] = entry_signature(1, which);
        entry_name(names[i], sizeof names[i], 1, which);
        e[i] = (phks_db_entry){names[i], "full", sigs[i]};
    }
    phks_status st = batch ? phks_db_add_batch(db, e, n, ids)
                           : phks_db_add(db, e[0].name, e[0].label, sigs[0],
                                         ids);
    for (size_t i = 0; i < n; i++) {
        if (st == PHKS_OK) {
            book[*count] = (added){ids[i], 1, *count};
            ++*count;
        }
        phks_signature_free(sigs[i]);
    }
    return st;
}

/* The failure a full disk gives. */
static void failed_full(phks_status st)
{
    ck_assert_msg(st == PHKS_ERROR_IO, "status %d: %s", (int)st,
                  phks_last_error_message());
    ck_assert_msg(strstr(phks_last_error_message(), "full"), "message: %s",
                  phks_last_error_message());
}

/* Bytes left when the disk fills: none, inside the WAL's header, inside a
 * frame, and after one to a few commits. */
static const long long budgets[] = {0,     1,     24,    32,    100,
                                    4096,  4128,  6000,  8300,  12000,
                                    16600, 20000, 30000, 45000, 70000};
enum { BUDGETS = sizeof budgets / sizeof budgets[0] };

START_TEST(full_disk_keeps_the_last_commit)
{
    full_vfs_register();
    char *dir = temp_dir(), *path = in_dir(dir, "full.db");
    added book[200];
    size_t count = 0;
    phks_db *db = open_db(path, PHKS_DB_CREATE);
    for (int i = 0; i < 4; i++)
        ck_assert_int_eq(add_next(db, book, &count, i % 2), PHKS_OK);
    answers before, after, fresh;
    ask(db, &before);
    size_t kept = count;

    room = budgets[_i];
    phks_status st = PHKS_OK;
    for (int i = 0; st == PHKS_OK; i++) {
        ck_assert_uint_lt(count, 190);
        st = add_next(db, book, &count, i % 2);
    }
    room = -1;
    failed_full(st);
    entries_are(db, book, count);
    ask(db, &after);
    phks_db *other = open_db(path, PHKS_DB_READONLY);
    entries_are(other, book, count);
    ask(other, &fresh);
    phks_db_close(other);
    same_answers(&after, &fresh);
    if (count == kept)
        same_answers(&after, &before);

    /* Space again: the handle adds; then it closes on a full disk (its
     * checkpoint fails), and the file keeps everything. */
    ck_assert_int_eq(add_next(db, book, &count, false), PHKS_OK);
    room = 0;
    phks_db_close(db);
    room = -1;
    db = open_db(path, 0);
    entries_are(db, book, count);
    phks_db_close(db);
    sql_is(path, "PRAGMA integrity_check", "ok");
    free(path);
    remove_dir(dir);
}
END_TEST

/* A disk that fills while a new file gets its schema: the open fails with
 * PHKS_ERROR_IO, and the file left opens once there is space, empty. */
START_TEST(full_disk_while_creating)
{
    full_vfs_register();
    char *dir = temp_dir(), *path = in_dir(dir, "new.db");
    phks_db *db;
    room = budgets[_i];
    phks_status st = phks_db_open(path, PHKS_DB_CREATE, &db);
    if (st == PHKS_OK)
        phks_db_close(db);
    room = -1;
    if (st != PHKS_OK)
        failed_full(st);
    db = open_db(path, 0);
    entries_are(db, NULL, 0);
    phks_db_close(db);
    free(path);
    remove_dir(dir);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("db_faults");
    TCase *load = tcase_create("load");
    tcase_set_timeout(load, 60 + 2 * load_seconds());
    tcase_add_test(load, two_writers_and_a_reader_lose_nothing);
    suite_add_tcase(s, load);
    TCase *full = tcase_create("full disk");
    tcase_set_timeout(full, 120);
    tcase_add_loop_test(full, full_disk_keeps_the_last_commit, 0, BUDGETS);
    tcase_add_loop_test(full, full_disk_while_creating, 0, BUDGETS);
    suite_add_tcase(s, full);
    return run_suite(s);
}
