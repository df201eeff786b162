/* test_db.c - shape databases: round trips in memory and on disk, queries
 * against a brute-force phks_score oracle (bit for bit, ties by id), the
 * file's schema read back with SQLite itself, refusals (options, newer
 * formats, foreign and damaged files, read-only handles), two handles on
 * one file, a writer killed mid-stream, concurrent queries, allocation
 * failures and bad arguments. Signatures are synthetic (random vectors
 * with valid options) except in one end-to-end case, so the suite is fast. */
#include "soup.h"
#include "shapes.h"
#include "test_db_util.h"
#include "db/db.h"

#include <dirent.h>
#include <fcntl.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

/* ---- helpers */

static void write_file(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    ck_assert_ptr_nonnull(f);
    ck_assert_uint_eq(fwrite(data, 1, size, f), size);
    ck_assert_int_eq(fclose(f), 0);
}

/* The oracle: phks_score against every entry, sorted by score then id. */
typedef struct ranked {
    double score;
    int64_t id;
} ranked;

static int by_score_then_id(const void *a, const void *b)
{
    const ranked *x = a, *y = b;
    if (x->score != y->score)
        return x->score < y->score ? -1 : 1;
    return (x->id > y->id) - (x->id < y->id);
}

/* Checks phks_db_query(db, q, k) against phks_score over sigs[i] (ids[i],
 * names[i]; entries with ids[i] = 0 are absent). */
static void query_matches_oracle(phks_db *db, const phks_signature *q,
                                 size_t k, phks_signature **sigs,
                                 const int64_t *ids, char (*names)[32],
                                 size_t n)
{
    ranked *want = malloc(n * sizeof *want);
    phks_hit *hits = malloc(k * sizeof *hits);
    size_t live = 0, count = 12345;
    for (size_t i = 0; i < n; i++) {
        if (!ids[i])
            continue;
        ck_assert_int_eq(phks_score(q, sigs[i], &want[live].score), PHKS_OK);
        want[live++].id = ids[i];
    }
    qsort(want, live, sizeof *want, by_score_then_id);
    phks_status st = phks_db_query(db, q, k, hits, &count);
    ck_assert_msg(st == PHKS_OK, "%s", phks_last_error_message());
    ck_assert_uint_eq(count, k < live ? k : live);
    for (size_t h = 0; h < count; h++) {
        REQUIRE_MSG(hits[h].id == want[h].id,
                    "k %zu hit %zu: id %lld, oracle %lld (scores %.17g %.17g)",
                    k, h, (long long)hits[h].id, (long long)want[h].id,
                    hits[h].score, want[h].score);
        /* Bit for bit, not within a tolerance. */
        REQUIRE(memcmp(&hits[h].score, &want[h].score, sizeof(double)) == 0);
        size_t i = 0;
        while (ids[i] != hits[h].id)
            i++;
        REQUIRE(strcmp(hits[h].name, names[i]) == 0);
        REQUIRE(strcmp(hits[h].label, i % 3 ? "odd" : "") == 0);
    }
    free(want);
    free(hits);
}

/* ---- round trips */

/* add, get, count, list, remove; on disk also after reopening, read-write
 * and read-only. Ids are never reused, not even the highest after its
 * removal, not even across reopening. */
START_TEST(round_trip)
{
    bool on_disk = _i == 1;
    char *dir = on_disk ? temp_dir() : NULL;
    char *path = on_disk ? in_dir(dir, "shapes.phksdb") : strdup(":memory:");
    uint64_t seed = 1;
    phks_signature *sig[4] = {synthetic(15, &seed, false),
                              synthetic(7, &seed, false),
                              synthetic(1, &seed, false),
                              synthetic(20, &seed, false)};
    const char *names[4] = {"bunny.ply", "r\xc3\xa9sum\xc3\xa9 \xe2\x82\xac.off",
                            "a", "dragon"};
    const char *labels[4] = {"animal", NULL, "", "monster"};
    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_CREATE, &db), PHKS_OK);
    size_t count = 99;
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
    ck_assert_uint_eq(count, 0);
    int64_t ids[4];
    for (int i = 0; i < 3; i++)
        ck_assert_int_eq(phks_db_add(db, names[i], labels[i], sig[i], &ids[i]),
                         PHKS_OK);
    ck_assert_int_gt(ids[0], 0);
    ck_assert_int_gt(ids[1], ids[0]);
    ck_assert_int_gt(ids[2], ids[1]);
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
    ck_assert_uint_eq(count, 3);

    for (int reopen = 0; reopen < (on_disk ? 3 : 1); reopen++) {
        if (reopen) { /* 1: read-write, 2: read-only */
            phks_db_close(db);
            ck_assert_int_eq(phks_db_open(path, reopen == 2 ? PHKS_DB_READONLY
                                                             : 0,
                                          &db),
                             PHKS_OK);
        }
        for (int i = 0; i < 3; i++) {
            phks_signature *back;
            char name[64], label[64];
            ck_assert_int_eq(phks_db_get(db, ids[i], &back, name, sizeof name,
                                         label, sizeof label),
                             PHKS_OK);
            same_signature(back, sig[i]);
            ck_assert_str_eq(name, names[i]);
            ck_assert_str_eq(label, labels[i] ? labels[i] : "");
            phks_signature_free(back);
        }
        /* Paging: two, then one, then none. */
        int64_t page[2];
        ck_assert_int_eq(phks_db_list(db, 0, page, 2, &count), PHKS_OK);
        ck_assert_uint_eq(count, 2);
        ck_assert_int_eq(page[0], ids[0]);
        ck_assert_int_eq(page[1], ids[1]);
        ck_assert_int_eq(phks_db_list(db, page[1], page, 2, &count), PHKS_OK);
        ck_assert_uint_eq(count, 1);
        ck_assert_int_eq(page[0], ids[2]);
        ck_assert_int_eq(phks_db_list(db, ids[2], page, 2, &count), PHKS_OK);
        ck_assert_uint_eq(count, 0);
    }
    if (on_disk) {
        phks_db_close(db);
        ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
    }

    /* Remove the middle and the highest entries. */
    ck_assert_int_eq(phks_db_remove(db, ids[1]), PHKS_OK);
    ck_assert_int_eq(phks_db_remove(db, ids[2]), PHKS_OK);
    ck_assert_int_eq(phks_db_remove(db, ids[2]), PHKS_ERROR_INVALID_ARGUMENT);
    phks_signature *gone = (phks_signature *)1;
    ck_assert_int_eq(phks_db_get(db, ids[1], &gone, NULL, 0, NULL, 0),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_ptr_null(gone);
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert_int_eq(phks_db_add(db, names[3], labels[3], sig[3], &ids[3]),
                     PHKS_OK);
    ck_assert_int_gt(ids[3], ids[2]);
    if (on_disk) {
        phks_db_close(db);
        ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
        ck_assert_int_eq(phks_db_remove(db, ids[3]), PHKS_OK);
        phks_db_close(db);
        ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
        int64_t again;
        ck_assert_int_eq(phks_db_add(db, "again", NULL, sig[3], &again),
                         PHKS_OK);
        ck_assert_int_gt(again, ids[3]);
        ids[3] = again;
    }
    int64_t all[8];
    ck_assert_int_eq(phks_db_list(db, 0, all, 8, &count), PHKS_OK);
    ck_assert_uint_eq(count, 2);
    ck_assert_int_eq(all[0], ids[0]);
    ck_assert_int_eq(all[1], ids[3]);
    phks_db_close(db);
    for (int i = 0; i < 4; i++)
        phks_signature_free(sig[i]);
    free(path);
    if (dir)
        remove_dir(dir);
}
END_TEST

/* What docs/formats.md promises, read back with SQLite itself: the
 * application_id and user_version, WAL, the meta keys, the tables. An
 * existing empty file gets the schema without PHKS_DB_CREATE. */
START_TEST(file_layout_is_as_documented)
{
    char *dir = temp_dir(), *path = in_dir(dir, "empty.db");
    write_file(path, "", 0);
    uint64_t seed = 2;
    phks_signature *sig = synthetic(5, &seed, false);
    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
    sql_is(path, "SELECT count(*) FROM meta WHERE key = 'options'", "0");
    int64_t id;
    ck_assert_int_eq(phks_db_add(db, "five", "label", sig, &id), PHKS_OK);
    phks_db_close(db);
    sql_is(path, "PRAGMA application_id", "1346915155"); /* "PHKS" */
    sql_is(path, "PRAGMA user_version", "2");
    sql_is(path, "PRAGMA journal_mode", "wal");
    sql_is(path, "PRAGMA page_size", "65536");
    sql_is(path, "SELECT value FROM meta WHERE key = 'format'", "2");
    sql_is(path, "SELECT value FROM meta WHERE key = 'library_version'",
           phks_version_string());
    sql_is(path, "SELECT name || '/' || label FROM entries", "five/label");
    sql_is(path, "SELECT length(signature) = 0 FROM entries", "0");
    sql_is(path,
           "SELECT group_concat(name) FROM (SELECT name FROM sqlite_master "
           "WHERE type = 'table' ORDER BY name)",
           "entries,meta,pack_state,packs,sqlite_sequence");
    sql_is(path,
           "SELECT group_concat(name) FROM (SELECT name FROM sqlite_master "
           "WHERE type = 'trigger' ORDER BY name)",
           "entries_delete,entries_insert,entries_update");
    /* One chunk holds the entry; pack_state says it covers the rows. */
    sql_is(path, "SELECT rows || ' ' || changes || ' ' || pack_changes "
                 "FROM pack_state", "1 1 1");
    sql_is(path, "SELECT start || ' ' || entries || ' ' || vectors || ' ' || "
                 "text || ' ' || hex(substr(data, 1, 8)) FROM packs",
           "1 1 120 11 50484B5001000000");

    /* The stored blob is phks_signature_encode's; the options value is a
     * blob the codec decodes to the options of the first signature. */
    sqlite3 *raw;
    ck_assert_int_eq(sqlite3_open_v2(path, &raw, SQLITE_OPEN_READONLY, NULL),
                     SQLITE_OK);
    sqlite3_stmt *st;
    ck_assert_int_eq(sqlite3_prepare_v2(raw,
                                        "SELECT (SELECT signature FROM entries),"
                                        " (SELECT value FROM meta WHERE key ="
                                        " 'options')",
                                        -1, &st, NULL),
                     SQLITE_OK);
    ck_assert_int_eq(sqlite3_step(st), SQLITE_ROW);
    size_t size = phks_signature_encoded_size(sig);
    unsigned char *blob = malloc(size);
    ck_assert_int_eq(phks_signature_encode(sig, blob, size, &size), PHKS_OK);
    ck_assert_int_eq(sqlite3_column_bytes(st, 0), (int)size);
    ck_assert_mem_eq(sqlite3_column_blob(st, 0), blob, size);
    phks_signature *opts;
    ck_assert_int_eq(phks_signature_decode(sqlite3_column_blob(st, 1),
                                           (size_t)sqlite3_column_bytes(st, 1),
                                           &opts),
                     PHKS_OK);
    ck_assert(phks__options_comparable(&opts->options, &sig->options));
    phks_signature_free(opts);
    sqlite3_finalize(st);
    sqlite3_close(raw);
    free(blob);
    phks_signature_free(sig);
    free(path);
    remove_dir(dir);
}
END_TEST

/* ---- queries */

#define N_SMALL 120

/* Top-k against the oracle for k = 1, 10, all and more than all, with
 * feature counts from 1 to 24 (one, two and three lane blocks), exact
 * duplicates (equal scores, ties by id), a query equal to an entry; then
 * after removing more than half (the copy compacts) and adding more. */
START_TEST(query_equals_brute_force)
{
    uint64_t seed = 3;
    enum { N = N_SMALL };
    phks_signature *sigs[N + 20];
    int64_t ids[N + 20] = {0};
    char names[N + 20][32];
    phks_db_entry entries[N];
    for (size_t i = 0; i < N + 20; i++) {
        sigs[i] = i % 10 == 9 ? NULL : synthetic(1 + i % 24, &seed, false);
        snprintf(names[i], sizeof names[i], "shape %zu", i);
    }
    for (size_t i = 9; i < N + 20; i += 10) { /* duplicates */
        ck_assert_int_eq(phks__signature_alloc(sigs[i - 4]->count, 0, 15, &sigs[i]),
                         PHKS_OK);
        sigs[i]->options = sigs[i - 4]->options;
        memcpy(sigs[i]->vertex, sigs[i - 4]->vertex,
               sigs[i]->count * sizeof(uint32_t));
        memcpy(sigs[i]->position, sigs[i - 4]->position,
               3 * sigs[i]->count * sizeof(double));
        memcpy(sigs[i]->persistence, sigs[i - 4]->persistence,
               sigs[i]->count * sizeof(double));
        memcpy(sigs[i]->vectors, sigs[i - 4]->vectors,
               15 * sigs[i]->count * sizeof(double));
    }
    for (size_t i = 0; i < N; i++)
        entries[i] = (phks_db_entry){names[i], i % 3 ? "odd" : NULL, sigs[i]};
    phks_db *db;
    ck_assert_int_eq(phks_db_open(":memory:", PHKS_DB_CREATE, &db), PHKS_OK);
    ck_assert_int_eq(phks_db_add_batch(db, entries, N, ids), PHKS_OK);

    phks_signature *queries[6];
    for (int q = 0; q < 5; q++)
        queries[q] = synthetic((size_t)(1 + 5 * q), &seed, false);
    queries[5] = sigs[17]; /* scores 0 against itself */
    const size_t ks[] = {1, 10, N, N + 7};
    for (int q = 0; q < 6; q++)
        for (size_t k = 0; k < sizeof ks / sizeof *ks; k++)
            query_matches_oracle(db, queries[q], ks[k], sigs, ids, names, N);

    /* Remove 70 (the copy compacts past half), add 20 more. */
    for (size_t i = 0; i < N; i++)
        if (i % 12 < 7) {
            ck_assert_int_eq(phks_db_remove(db, ids[i]), PHKS_OK);
            ids[i] = 0;
        }
    for (size_t i = N; i < N + 20; i++)
        ck_assert_int_eq(phks_db_add(db, names[i], i % 3 ? "odd" : "", sigs[i],
                                     &ids[i]),
                         PHKS_OK);
    for (int q = 0; q < 6; q++)
        for (size_t k = 0; k < sizeof ks / sizeof *ks; k++)
            query_matches_oracle(db, queries[q], ks[k], sigs, ids, names,
                                 N + 20);
    phks_db_close(db);
    for (int q = 0; q < 5; q++)
        phks_signature_free(queries[q]);
    for (size_t i = 0; i < N + 20; i++)
        phks_signature_free(sigs[i]);
}
END_TEST

/* Enough entries for the threaded scan (several parts, each with its own
 * pruned top-k list): still the oracle's answer, duplicates included. */
START_TEST(parallel_scan_equals_brute_force)
{
    enum { N = 6000 };
    uint64_t seed = 4;
    phks_signature **sigs = malloc(N * sizeof *sigs);
    int64_t *ids = malloc(N * sizeof *ids);
    char (*names)[32] = malloc(N * sizeof *names);
    phks_db_entry *entries = malloc(N * sizeof *entries);
    for (size_t i = 0; i < N; i++) {
        /* Every 100th entry repeats an earlier one in another part. */
        size_t from = i >= 3100 && i % 100 == 99 ? i - 3001 : i;
        sigs[i] = synthetic(1 + from % 4, &(uint64_t){seed + from}, false);
        snprintf(names[i], sizeof names[i], "s%zu", i);
        entries[i] = (phks_db_entry){names[i], i % 3 ? "odd" : "", sigs[i]};
    }
    phks_db *db;
    ck_assert_int_eq(phks_db_open(":memory:", PHKS_DB_CREATE, &db), PHKS_OK);
    ck_assert_int_eq(phks_db_add_batch(db, entries, N, ids), PHKS_OK);
    for (int q = 0; q < 3; q++) {
        phks_signature *query = q == 2 ? sigs[1198] : synthetic(3, &seed, false);
        query_matches_oracle(db, query, 10, sigs, ids, names, N);
        query_matches_oracle(db, query, 200, sigs, ids, names, N);
        if (q != 2)
            phks_signature_free(query);
    }
    phks_db_close(db);
    for (size_t i = 0; i < N; i++)
        phks_signature_free(sigs[i]);
    free(sigs);
    free(ids);
    free(names);
    free(entries);
}
END_TEST

/* Real signatures of generated creatures (few eigenpairs and the
 * vertices' quadrature, for speed under valgrind: the default's points
 * inside the creatures' long triangles would be thousands to solve): the
 * query's hits are phks_score's, and an entry finds itself first. */
START_TEST(creatures_end_to_end)
{
    phks_options o;
    phks_options_init(&o);
    o.eigen_count = 40;
    o.quadrature = PHKS_QUADRATURE_VERTICES;
    phks_signature *sigs[4];
    int64_t ids[4];
    char names[4][32];
    phks_db *db;
    ck_assert_int_eq(phks_db_open(":memory:", PHKS_DB_CREATE, &db), PHKS_OK);
    for (unsigned i = 0; i < 4; i++) {
        unsigned kind = i < 2 ? SHAPE_HAND : SHAPE_PLIER;
        phks_mesh *m = creature_mesh(kind, i % 2 + 1);
        ck_assert_int_eq(phks_signature_compute(m, &o, &sigs[i]), PHKS_OK);
        phks_mesh_free(m);
        snprintf(names[i], sizeof names[i], "%s %u", shape_creature_name(kind),
                 i);
        ck_assert_int_eq(phks_db_add(db, names[i], i % 3 ? "odd" : NULL,
                                     sigs[i], &ids[i]),
                         PHKS_OK);
    }
    for (int q = 0; q < 4; q++) {
        query_matches_oracle(db, sigs[q], 4, sigs, ids, names, 4);
        phks_hit hit;
        size_t count;
        ck_assert_int_eq(phks_db_query(db, sigs[q], 1, &hit, &count), PHKS_OK);
        ck_assert_int_eq(hit.id, ids[q]);
        /* The stored copy scores as the signature itself does (0 unless a
         * symmetry of the shape offers a set about as consistent). */
        double self;
        ck_assert_int_eq(phks_score(sigs[q], sigs[q], &self), PHKS_OK);
        ck_assert_double_eq(hit.score, self);
        ck_assert_double_lt(self, 1e-3);
    }
    phks_db_close(db);
    for (int i = 0; i < 4; i++)
        phks_signature_free(sigs[i]);
}
END_TEST

/* Hits cut long names at a character boundary; get returns them whole. */
START_TEST(hit_text_is_cut_at_a_character)
{
    /* "ab" + 150 x U+00E9 (2 bytes): byte 255 is inside a character, so
     * the hit keeps "ab" + 126 of them = 254 bytes. "x" + 100 x U+20AC
     * (3 bytes): 1 + 84 * 3 = 253 bytes. 255 ASCII bytes fit exactly. */
    char two[2 + 300 + 1], three[1 + 300 + 1], ascii[256];
    strcpy(two, "ab");
    for (int i = 0; i < 150; i++)
        memcpy(two + 2 + 2 * i, "\xc3\xa9", 3);
    strcpy(three, "x");
    for (int i = 0; i < 100; i++)
        memcpy(three + 1 + 3 * i, "\xe2\x82\xac", 4);
    memset(ascii, 'q', 255);
    ascii[255] = '\0';
    uint64_t seed = 5;
    phks_signature *sig = synthetic(4, &seed, false);
    phks_db *db;
    ck_assert_int_eq(phks_db_open(":memory:", 0, &db), PHKS_OK);
    int64_t id;
    ck_assert_int_eq(phks_db_add(db, two, three, sig, &id), PHKS_OK);
    phks_hit hit;
    size_t count;
    ck_assert_int_eq(phks_db_query(db, sig, 3, &hit, &count), PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert_uint_eq(strlen(hit.name), 254);
    ck_assert_mem_eq(hit.name, two, 254);
    ck_assert_uint_eq(strlen(hit.label), 253);
    ck_assert_mem_eq(hit.label, three, 253);
    char name[400], label[400];
    ck_assert_int_eq(phks_db_get(db, id, NULL, name, sizeof name, label,
                                 sizeof label),
                     PHKS_OK);
    ck_assert_str_eq(name, two);
    ck_assert_str_eq(label, three);
    ck_assert_int_eq(phks_db_add(db, ascii, ascii, sig, &id), PHKS_OK);
    phks_hit hits[2];
    ck_assert_int_eq(phks_db_query(db, sig, 2, hits, &count), PHKS_OK);
    ck_assert_uint_eq(count, 2);
    ck_assert_str_eq(hits[1].name, ascii);
    ck_assert_str_eq(hits[1].label, ascii);
    phks_db_close(db);
    phks_signature_free(sig);
}
END_TEST

/* ---- refusals */

START_TEST(other_options_are_refused)
{
    uint64_t seed = 6;
    phks_signature *mine = synthetic(6, &seed, false),
                   *other = synthetic(6, &seed, true);
    phks_db *db;
    ck_assert_int_eq(phks_db_open(":memory:", 0, &db), PHKS_OK);
    /* An empty database takes the first signature's options. */
    phks_hit hits[2];
    size_t count = 7;
    ck_assert_int_eq(phks_db_query(db, other, 2, hits, &count), PHKS_OK);
    ck_assert_uint_eq(count, 0);
    ck_assert_int_eq(phks_db_add(db, "mine", NULL, mine, NULL), PHKS_OK);
    ck_assert_int_eq(phks_db_add(db, "other", NULL, other, NULL),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_int_eq(phks_db_query(db, other, 2, hits, &count),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_uint_eq(count, 0);
    phks_db_entry batch[3] = {{"a", NULL, mine}, {"b", NULL, mine},
                              {"c", NULL, other}};
    ck_assert_int_eq(phks_db_add_batch(db, batch, 3, NULL),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "entry 2"));
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
    ck_assert_uint_eq(count, 1);
    /* Removing every entry does not forget the options. */
    ck_assert_int_eq(phks_db_remove(db, 1), PHKS_OK);
    ck_assert_int_eq(phks_db_add(db, "other", NULL, other, NULL),
                     PHKS_ERROR_INCOMPATIBLE);
    phks_db_close(db);
    phks_signature_free(mine);
    phks_signature_free(other);
}
END_TEST

/* A VERIFIED synthetic signature with its layout (no samples: the
 * features are the points), of the local descriptor given; spin images
 * of bytes that differ from point to point. */
static phks_signature *verified_synthetic(size_t count, uint64_t *seed,
                                          int32_t descriptor)
{
    phks_signature *sig = synthetic(count, seed, false);
    sig->options.matching = PHKS_MATCHING_VERIFIED;
    sig->options.local_descriptor = descriptor;
    ck_assert_int_eq(phks__signature_alloc_layout(sig), PHKS_OK);
    for (size_t i = 0; i < count; i++)
        sig->boundary[i] = INFINITY;
    for (size_t k = 0; k < phks__pair_count(count); k++)
        sig->geodesic[k] = (float)(0.1 + test_random(seed));
    for (size_t b = 0; sig->spin && b < count * PHKS__SPIN_BYTES; b++)
        sig->spin[b] = (uint8_t)(b * 13 + 1);
    sig->unit_scale = 0.5;
    return sig;
}

/* A file of `mine` refuses `other` as an entry and, read by a fresh
 * handle, as a query, the message saying `says`; returns mine as the file
 * gives it back, for the option's own checks. */
static phks_signature *kept_and_refused(const char *path,
                                        const phks_signature *mine,
                                        const phks_signature *other,
                                        const char *says)
{
    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_CREATE, &db), PHKS_OK);
    ck_assert_int_eq(phks_db_add(db, "mine", NULL, mine, NULL), PHKS_OK);
    ck_assert_int_eq(phks_db_add(db, "other", NULL, other, NULL),
                     PHKS_ERROR_INCOMPATIBLE);
    phks_db_close(db);
    /* A fresh handle reads the options back from the file. */
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_READONLY, &db), PHKS_OK);
    phks_hit hits[2];
    size_t count = 0;
    ck_assert_int_eq(phks_db_query(db, mine, 2, hits, &count), PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert_str_eq(hits[0].name, "mine");
    ck_assert_int_eq(phks_db_query(db, other, 2, hits + 1, &count),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_msg(strstr(phks_last_error_message(), says), "%s",
                  phks_last_error_message());
    phks_signature *back;
    ck_assert_int_eq(phks_db_get(db, hits[0].id, &back, NULL, 0, NULL, 0),
                     PHKS_OK);
    phks_db_close(db);
    return back;
}

/* The local descriptor is one of a database's options, between VERIFIED
 * signatures: a file of HEAT signatures (0.2.0's: format-4 blobs, the
 * bytes test_codec.c pins) opens, answers HEAT queries and refuses SPIN
 * ones, naming the option; a file of SPIN signatures keeps their images
 * and answers SPIN queries. */
START_TEST(local_descriptor_is_the_databases)
{
    uint64_t seed = 21;
    char *dir = temp_dir();
    const int32_t descriptors[2] = {PHKS_LOCAL_DESCRIPTOR_HEAT,
                                    PHKS_LOCAL_DESCRIPTOR_SPIN};
    for (int d = 0; d < 2; d++) {
        char path[256];
        snprintf(path, sizeof path, "%s/%d.db", dir, d);
        phks_signature *mine = verified_synthetic(6, &seed, descriptors[d]);
        phks_signature *other =
            verified_synthetic(6, &seed, descriptors[1 - d]);
        char says[64];
        snprintf(says, sizeof says, "local_descriptor %s against %s",
                 d ? "heat" : "spin", d ? "spin" : "heat");
        phks_signature *back = kept_and_refused(path, mine, other, says);
        ck_assert_int_eq(back->options.local_descriptor, descriptors[d]);
        ck_assert_int_eq(back->spin != NULL, d == 1);
        if (back->spin)
            ck_assert_mem_eq(back->spin, mine->spin, 6 * PHKS__SPIN_BYTES);
        phks_signature_free(back);
        phks_signature_free(mine);
        phks_signature_free(other);
    }
    remove_dir(dir);
}
END_TEST

/* verified_synthetic's HEAT signature, made with the global descriptor
 * given; with D2 a shape distribution of bytes that differ from bin to
 * bin, set here as the computation would. */
static phks_signature *global_synthetic(uint64_t *seed, int32_t descriptor)
{
    phks_signature *sig =
        verified_synthetic(6, seed, PHKS_LOCAL_DESCRIPTOR_HEAT);
    sig->options.global_descriptor = descriptor;
    sig->has_shape = descriptor == PHKS_GLOBAL_DESCRIPTOR_D2;
    for (size_t b = 0; sig->has_shape && b < PHKS__SHAPE_BINS; b++)
        sig->shape[b] = (uint8_t)(7 * b + 3);
    return sig;
}

/* The global descriptor is one of a database's options too: a file of
 * NONE signatures (0.2.0's bytes) refuses a D2 entry and a D2 query,
 * naming the option and both values; a file of D2 signatures (its
 * options blob format 6) keeps their distributions and refuses NONE. */
START_TEST(global_descriptor_is_the_databases)
{
    uint64_t seed = 31;
    char *dir = temp_dir();
    const int32_t descriptors[2] = {PHKS_GLOBAL_DESCRIPTOR_NONE,
                                    PHKS_GLOBAL_DESCRIPTOR_D2};
    for (int d = 0; d < 2; d++) {
        char path[256];
        snprintf(path, sizeof path, "%s/%d.db", dir, d);
        phks_signature *mine = global_synthetic(&seed, descriptors[d]);
        phks_signature *other = global_synthetic(&seed, descriptors[1 - d]);
        char says[64];
        snprintf(says, sizeof says, "global_descriptor %s against %s",
                 d ? "none" : "d2", d ? "d2" : "none");
        phks_signature *back = kept_and_refused(path, mine, other, says);
        ck_assert_int_eq(back->options.global_descriptor, descriptors[d]);
        ck_assert_int_eq(back->has_shape, d == 1);
        ck_assert_mem_eq(back->shape, mine->shape, PHKS__SHAPE_BINS);
        phks_signature_free(back);
        phks_signature_free(mine);
        phks_signature_free(other);
    }
    remove_dir(dir);
}
END_TEST

/* Two handles on one new file: the second learns the options the first
 * committed, inside its own write transaction. */
START_TEST(options_set_by_another_handle_are_refused)
{
    char *dir = temp_dir(), *path = in_dir(dir, "two.db");
    uint64_t seed = 7;
    phks_signature *mine = synthetic(6, &seed, false),
                   *other = synthetic(6, &seed, true);
    phks_db *a, *b;
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_CREATE, &a), PHKS_OK);
    ck_assert_int_eq(phks_db_open(path, 0, &b), PHKS_OK);
    ck_assert_int_eq(phks_db_add(a, "mine", NULL, mine, NULL), PHKS_OK);
    ck_assert_int_eq(phks_db_add(b, "other", NULL, other, NULL),
                     PHKS_ERROR_INCOMPATIBLE);
    ck_assert_int_eq(phks_db_add(b, "mine too", NULL, mine, NULL), PHKS_OK);
    phks_db_close(a);
    phks_db_close(b);
    phks_signature_free(mine);
    phks_signature_free(other);
    free(path);
    remove_dir(dir);
}
END_TEST

START_TEST(foreign_newer_and_damaged_files_are_refused)
{
    char *dir = temp_dir();
    char *good = in_dir(dir, "good.db"), *text = in_dir(dir, "text.db"),
         *other = in_dir(dir, "other.db"), *missing = in_dir(dir, "none.db");
    uint64_t seed = 8;
    phks_signature *sig = synthetic(5, &seed, false);
    phks_db *db = (phks_db *)1;

    /* Missing: IO without CREATE, read-only or not. */
    ck_assert_int_eq(phks_db_open(missing, 0, &db), PHKS_ERROR_IO);
    ck_assert_ptr_null(db);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "none.db"));
    ck_assert_int_eq(phks_db_open(missing, PHKS_DB_READONLY, &db),
                     PHKS_ERROR_IO);
    ck_assert_int_eq(access(missing, F_OK), -1); /* not created */

    /* Not SQLite at all. */
    char junk[4096];
    for (size_t i = 0; i < sizeof junk; i++)
        junk[i] = (char)('a' + i % 26);
    write_file(text, junk, sizeof junk);
    ck_assert_int_eq(phks_db_open(text, 0, &db), PHKS_ERROR_CORRUPT);
    ck_assert_int_eq(phks_db_open(text, PHKS_DB_READONLY, &db),
                     PHKS_ERROR_CORRUPT);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "text.db"));

    /* SQLite, but another application's: refused and left untouched. */
    free(sql(other, "CREATE TABLE t (x)"));
    ck_assert_int_eq(phks_db_open(other, 0, &db), PHKS_ERROR_CORRUPT);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "not a libphks"));
    sql_is(other, "PRAGMA journal_mode", "delete");
    free(sql(other, "PRAGMA application_id = 7"));
    ck_assert_int_eq(phks_db_open(other, 0, &db), PHKS_ERROR_CORRUPT);

    /* Ours, from a newer format. */
    ck_assert_int_eq(phks_db_open(good, PHKS_DB_CREATE, &db), PHKS_OK);
    int64_t id;
    ck_assert_int_eq(phks_db_add(db, "x", NULL, sig, &id), PHKS_OK);
    phks_db_close(db);
    free(sql(good, "PRAGMA user_version = 3"));
    ck_assert_int_eq(phks_db_open(good, 0, &db), PHKS_ERROR_UNSUPPORTED_VERSION);
    ck_assert_int_eq(phks_db_open(good, PHKS_DB_READONLY, &db),
                     PHKS_ERROR_UNSUPPORTED_VERSION);
    ck_assert_ptr_null(db);
    free(sql(good, "PRAGMA user_version = 2"));

    /* A damaged signature blob: get and query say CORRUPT, count works. */
    free(sql(good, "UPDATE entries SET signature = x'50484B5302000000'"));
    ck_assert_int_eq(phks_db_open(good, 0, &db), PHKS_OK);
    phks_signature *back = (phks_signature *)1;
    ck_assert_int_eq(phks_db_get(db, id, &back, NULL, 0, NULL, 0),
                     PHKS_ERROR_CORRUPT);
    ck_assert_ptr_null(back);
    phks_hit hit;
    size_t count;
    ck_assert_int_eq(phks_db_query(db, sig, 1, &hit, &count),
                     PHKS_ERROR_CORRUPT);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "entry 1"));
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert_int_eq(phks_db_remove(db, id), PHKS_OK); /* repairs it */
    ck_assert_int_eq(phks_db_query(db, sig, 1, &hit, &count), PHKS_OK);
    ck_assert_uint_eq(count, 0);
    phks_db_close(db);

    /* Our header without our tables. */
    free(sql(good, "DROP TABLE entries"));
    ck_assert_int_eq(phks_db_open(good, 0, &db), PHKS_ERROR_CORRUPT);

    phks_signature_free(sig);
    free(good);
    free(text);
    free(other);
    free(missing);
    remove_dir(dir);
}
END_TEST

/* What a handle answers: count, every id, and the top 10 of a query (each
 * CORRUPT or OK). */
typedef struct answers {
    phks_status count_st, list_st, query_st;
    size_t count, listed, hits;
    int64_t ids[64];
    phks_hit top[10];
} answers;

static void ask(phks_db *db, const phks_signature *q, answers *a)
{
    memset(a, 0, sizeof *a);
    a->count_st = phks_db_count(db, &a->count);
    a->list_st = phks_db_list(db, 0, a->ids, 64, &a->listed);
    a->query_st = phks_db_query(db, q, 10, a->top, &a->hits);
}

static void same_or_corrupt(phks_status st, bool same, const char *what,
                            size_t page)
{
    ck_assert_msg(st == PHKS_OK || st == PHKS_ERROR_CORRUPT,
                  "page %zu: %s gave %s", page, what, phks_status_string(st));
    ck_assert_msg(st != PHKS_OK || same, "page %zu: %s answered differently",
                  page, what);
    ck_assert_msg(st == PHKS_OK || phks_last_error_message()[0], "page %zu: %s "
                  "without a message", page, what);
}

/* Each page of a database file in turn overwritten with noise, as a bad
 * disk sector would: opening and every read either say CORRUPT or give
 * exactly the undamaged file's answers, never another answer, never a
 * crash. */
START_TEST(every_damaged_page_is_refused_or_harmless)
{
    char *dir = temp_dir();
    char *good = in_dir(dir, "good.db"), *bad = in_dir(dir, "bad.db");
    uint64_t seed = 77;
    phks_db *db;
    /* An empty file of 4 KB pages (the library keeps an existing file's
     * page size, and gives new files 64 KB), so that the entries span
     * many pages. */
    free(sql(good, "PRAGMA user_version = 0"));
    sql_is(good, "PRAGMA page_size", "4096");
    ck_assert_int_eq(phks_db_open(good, PHKS_DB_CREATE, &db), PHKS_OK);
    for (int i = 0; i < 60; i++) {
        phks_signature *sig = synthetic(15, &seed, false);
        char name[32];
        snprintf(name, sizeof name, "entry %d", i);
        ck_assert_int_eq(phks_db_add(db, name, "label", sig, NULL), PHKS_OK);
        phks_signature_free(sig);
    }
    phks_signature *q = synthetic(15, &seed, false);
    answers want;
    ask(db, q, &want);
    ck_assert_int_eq(want.query_st, PHKS_OK);
    ck_assert_uint_eq(want.listed, 60);
    phks_db_close(db); /* the last connection folds the WAL into the file */

    FILE *f = fopen(good, "rb");
    ck_assert_ptr_nonnull(f);
    unsigned char *file = malloc(1 << 20), *copy = malloc(1 << 20);
    size_t size = fread(file, 1, 1 << 20, f);
    fclose(f);
    size_t page = (size_t)file[16] << 8 | file[17];
    if (page == 1)
        page = 65536;
    ck_assert_uint_ge(size / page, 40); /* the entries span many pages */
    size_t refused = 0;
    for (size_t p = 0; p < size / page; p++) {
        memcpy(copy, file, size);
        for (size_t b = 0; b < page; b++)
            copy[p * page + b] = (unsigned char)(test_random(&seed) * 256);
        write_file(bad, copy, size);
        phks_status st = phks_db_open(bad, 0, &db);
        same_or_corrupt(st, true, "open", p + 1);
        if (st != PHKS_OK) {
            ck_assert_ptr_null(db);
            refused++;
            continue;
        }
        answers got;
        ask(db, q, &got);
        same_or_corrupt(got.count_st, got.count == want.count, "count", p + 1);
        same_or_corrupt(got.list_st,
                        got.listed == want.listed &&
                            !memcmp(got.ids, want.ids, sizeof want.ids),
                        "list", p + 1);
        same_or_corrupt(got.query_st,
                        got.hits == want.hits &&
                            !memcmp(got.top, want.top, sizeof want.top),
                        "query", p + 1);
        refused += got.count_st || got.list_st || got.query_st;
        phks_db_close(db);
    }
    /* Most pages hold entries, so most damage must be seen. */
    ck_assert_uint_ge(refused, size / page / 2);
    free(file);
    free(copy);
    phks_signature_free(q);
    free(good);
    free(bad);
    remove_dir(dir);
}
END_TEST

START_TEST(read_only_handles_refuse_writes)
{
    char *dir = temp_dir(), *path = in_dir(dir, "ro.db");
    uint64_t seed = 9;
    phks_signature *sig = synthetic(5, &seed, false);
    phks_db *db;
    int64_t id;
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_CREATE, &db), PHKS_OK);
    ck_assert_int_eq(phks_db_add(db, "x", NULL, sig, &id), PHKS_OK);
    phks_db_close(db);
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_READONLY, &db), PHKS_OK);
    ck_assert_int_eq(phks_db_add(db, "y", NULL, sig, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "read-only"));
    phks_db_entry e = {"y", NULL, sig};
    ck_assert_int_eq(phks_db_add_batch(db, &e, 1, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_db_remove(db, id), PHKS_ERROR_INVALID_ARGUMENT);
    size_t count;
    phks_hit hit;
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert_int_eq(phks_db_query(db, sig, 1, &hit, &count), PHKS_OK);
    ck_assert_int_eq(hit.id, id);
    phks_db_close(db);
    /* A read-only handle sees what a writer commits later. */
    phks_db *w;
    phks_hit hits[5];
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_READONLY, &db), PHKS_OK);
    ck_assert_int_eq(phks_db_open(path, 0, &w), PHKS_OK);
    ck_assert_int_eq(phks_db_query(db, sig, 5, hits, &count), PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert_int_eq(phks_db_add(w, "z", NULL, sig, NULL), PHKS_OK);
    ck_assert_int_eq(phks_db_query(db, sig, 5, hits, &count), PHKS_OK);
    ck_assert_uint_eq(count, 2);
    ck_assert_str_eq(hits[1].name, "z");
    phks_db_close(w);
    phks_db_close(db);
    phks_signature_free(sig);
    free(path);
    remove_dir(dir);
}
END_TEST

/* ---- several handles and processes */

START_TEST(two_handles_see_each_others_commits)
{
    char *dir = temp_dir(), *path = in_dir(dir, "shared.db");
    uint64_t seed = 10;
    enum { N = 12 };
    phks_signature *sigs[N];
    int64_t ids[N] = {0};
    char names[N][32];
    for (int i = 0; i < N; i++) {
        sigs[i] = synthetic(3 + (size_t)i, &seed, false);
        snprintf(names[i], sizeof names[i], "n%d", i);
    }
    phks_signature *q = synthetic(9, &seed, false);
    phks_db *a, *b;
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_CREATE, &a), PHKS_OK);
    ck_assert_int_eq(phks_db_open(path, 0, &b), PHKS_OK);
    for (int i = 0; i < 4; i++) /* a adds, b has loaded its copy already */
        ck_assert_int_eq(phks_db_add(a, names[i], i % 3 ? "odd" : NULL,
                                     sigs[i], &ids[i]),
                         PHKS_OK);
    query_matches_oracle(b, q, N, sigs, ids, names, N);
    query_matches_oracle(a, q, N, sigs, ids, names, N);
    for (int i = 4; i < 8; i++) /* now b adds */
        ck_assert_int_eq(phks_db_add(b, names[i], i % 3 ? "odd" : NULL,
                                     sigs[i], &ids[i]),
                         PHKS_OK);
    query_matches_oracle(a, q, N, sigs, ids, names, N);
    /* b removes one of a's, a adds more, both agree. */
    ck_assert_int_eq(phks_db_remove(b, ids[1]), PHKS_OK);
    ids[1] = 0;
    phks_db_entry batch[4];
    for (int i = 8; i < N; i++)
        batch[i - 8] = (phks_db_entry){names[i], i % 3 ? "odd" : "", sigs[i]};
    ck_assert_int_eq(phks_db_add_batch(a, batch, 4, ids + 8), PHKS_OK);
    query_matches_oracle(a, q, N, sigs, ids, names, N);
    query_matches_oracle(b, q, N, sigs, ids, names, N);
    size_t count;
    ck_assert_int_eq(phks_db_count(b, &count), PHKS_OK);
    ck_assert_uint_eq(count, N - 1);
    phks_db_close(a);
    phks_db_close(b);
    for (int i = 0; i < N; i++)
        phks_signature_free(sigs[i]);
    phks_signature_free(q);
    free(path);
    remove_dir(dir);
}
END_TEST

/* A child adds entries one transaction at a time and reports each commit
 * through a pipe; it is killed with SIGKILL mid-stream. Every entry it
 * reported is there and readable, and SQLite finds the file intact. */
START_TEST(killed_writer_loses_no_commit)
{
    char *dir = temp_dir(), *path = in_dir(dir, "killed.db");
    int fds[2];
    ck_assert_int_eq(pipe(fds), 0);
    pid_t child = fork();
    ck_assert_int_ge(child, 0);
    if (child == 0) {
        close(fds[0]);
        uint64_t seed = 11;
        phks_db *db;
        if (phks_db_open(path, PHKS_DB_CREATE, &db) != PHKS_OK)
            _exit(1);
        for (size_t n = 1; n < 100000; n++) {
            phks_signature *sig = synthetic(15, &seed, false);
            char name[32];
            snprintf(name, sizeof name, "entry %zu", n);
            if (phks_db_add(db, name, "killed", sig, NULL) != PHKS_OK)
                _exit(2);
            phks_signature_free(sig);
            if (write(fds[1], &n, sizeof n) != sizeof n)
                _exit(3);
        }
        _exit(4);
    }
    close(fds[1]);
    size_t reported = 0, n;
    while (reported < 25 && read(fds[0], &n, sizeof n) == sizeof n)
        reported = n;
    ck_assert_uint_eq(reported, 25);
    ck_assert_int_eq(kill(child, SIGKILL), 0);
    int status;
    ck_assert_int_eq(waitpid(child, &status, 0), child);
    ck_assert(WIFSIGNALED(status));
    while (read(fds[0], &n, sizeof n) == sizeof n)
        reported = n;
    close(fds[0]);

    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
    size_t count;
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
    ck_assert_uint_ge(count, reported);
    int64_t *ids = malloc(count * sizeof *ids);
    size_t listed;
    ck_assert_int_eq(phks_db_list(db, 0, ids, count, &listed), PHKS_OK);
    ck_assert_uint_eq(listed, count);
    phks_signature *first = NULL;
    for (size_t i = 0; i < count; i++) {
        phks_signature *sig;
        char name[32], want[32];
        ck_assert_int_eq(phks_db_get(db, ids[i], &sig, name, sizeof name, NULL,
                                     0),
                         PHKS_OK);
        snprintf(want, sizeof want, "entry %zu", i + 1);
        ck_assert_str_eq(name, want);
        ck_assert_uint_eq(sig->count, 15);
        if (i == 0)
            first = sig;
        else
            phks_signature_free(sig);
    }
    phks_hit hit;
    ck_assert_int_eq(phks_db_query(db, first, 1, &hit, &count), PHKS_OK);
    ck_assert_int_eq(hit.id, ids[0]);
    ck_assert_double_eq(hit.score, 0);
    phks_db_close(db);
    phks_signature_free(first);
    sql_is(path, "PRAGMA integrity_check", "ok");
    free(ids);
    free(path);
    remove_dir(dir);
}
END_TEST

/* ---- ids below 1 */

/* libphks numbers entries from 1 (AUTOINCREMENT never gives less), but
 * another program can write any id into the file. Count, list (whose
 * first page starts after id 0) and query would then disagree about the
 * entries; all three refuse the file as damaged instead, until the rows
 * are gone. get and remove still reach them by id. */
START_TEST(ids_below_one_are_refused)
{
    char *dir = temp_dir(), *path = in_dir(dir, "ids.db");
    uint64_t seed = 21;
    phks_signature *sig = synthetic(6, &seed, false);
    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_CREATE, &db), PHKS_OK);
    int64_t id;
    ck_assert_int_eq(phks_db_add(db, "one", NULL, sig, &id), PHKS_OK);
    ck_assert_int_eq(id, 1);
    phks_hit hits[4];
    size_t count;
    int64_t ids[4];
    ck_assert_int_eq(phks_db_query(db, sig, 4, hits, &count), PHKS_OK);
    static const char *bad[] = {"0", "-5", "-9223372036854775808"};
    for (size_t b = 0; b < sizeof bad / sizeof *bad; b++) {
        char insert[256], delete[96];
        snprintf(insert, sizeof insert,
                 "INSERT INTO entries (id, name, label, signature) "
                 "SELECT %s, 'other', NULL, signature FROM entries "
                 "WHERE id = 1",
                 bad[b]);
        snprintf(delete, sizeof delete, "DELETE FROM entries WHERE id = %s",
                 bad[b]);
        free(sql(path, insert));
        count = 99;
        ck_assert_int_eq(phks_db_count(db, &count), PHKS_ERROR_CORRUPT);
        ck_assert_uint_eq(count, 0);
        ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "ids.db"));
        ck_assert_int_eq(phks_db_list(db, 0, ids, 4, &count),
                         PHKS_ERROR_CORRUPT);
        ck_assert_int_eq(phks_db_list(db, -10, ids, 4, &count),
                         PHKS_ERROR_CORRUPT);
        ck_assert_int_eq(phks_db_query(db, sig, 4, hits, &count),
                         PHKS_ERROR_CORRUPT);
        /* a handle opened now sees the same */
        phks_db *other;
        ck_assert_int_eq(phks_db_open(path, PHKS_DB_READONLY, &other), PHKS_OK);
        ck_assert_int_eq(phks_db_count(other, &count), PHKS_ERROR_CORRUPT);
        ck_assert_int_eq(phks_db_query(other, sig, 4, hits, &count),
                         PHKS_ERROR_CORRUPT);
        phks_db_close(other);
        /* pages after a valid id are unaffected */
        ck_assert_int_eq(phks_db_list(db, 1, ids, 4, &count), PHKS_OK);
        ck_assert_uint_eq(count, 0);
        free(sql(path, delete));
        ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
        ck_assert_uint_eq(count, 1);
        ck_assert_int_eq(phks_db_list(db, 0, ids, 4, &count), PHKS_OK);
        ck_assert_uint_eq(count, 1);
        ck_assert_int_eq(ids[0], 1);
        ck_assert_int_eq(phks_db_query(db, sig, 4, hits, &count), PHKS_OK);
        ck_assert_uint_eq(count, 1);
        ck_assert_int_eq(hits[0].id, 1);
    }
    /* removed by id, the file is whole again */
    free(sql(path, "INSERT INTO entries (id, name, label, signature) "
                   "SELECT -3, 'other', NULL, signature FROM entries"));
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_ERROR_CORRUPT);
    ck_assert_int_eq(phks_db_remove(db, -3), PHKS_OK);
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
    ck_assert_uint_eq(count, 1);
    phks_db_close(db);
    phks_signature_free(sig);
    free(path);
    remove_dir(dir);
}
END_TEST

/* ---- threads */

#define QUERY_THREADS 4
#define QUERIES_EACH 6

typedef struct query_thread {
    phks_db *db;
    phks_signature **queries;
    phks_hit (*expected)[10];
    size_t *expected_count;
    int failures;
} query_thread;

static void *query_worker(void *arg)
{
    query_thread *t = arg;
    for (int round = 0; round < 3; round++)
        for (int q = 0; q < QUERIES_EACH; q++) {
            phks_hit hits[10];
            size_t count;
            if (phks_db_query(t->db, t->queries[q], 10, hits, &count) !=
                    PHKS_OK ||
                count != t->expected_count[q]) {
                t->failures++;
                continue;
            }
            for (size_t h = 0; h < count; h++) {
                const phks_hit *want = &t->expected[q][h];
                if (hits[h].id != want->id ||
                    memcmp(&hits[h].score, &want->score, sizeof(double)) ||
                    strcmp(hits[h].name, want->name) ||
                    strcmp(hits[h].label, want->label))
                    t->failures++;
            }
        }
    return NULL;
}

/* Four threads on one fresh handle (the first queries race to load the
 * copy) get what one thread got from another handle. */
START_TEST(concurrent_queries_agree)
{
    char *dir = temp_dir(), *path = in_dir(dir, "threads.db");
    enum { N = 300 };
    uint64_t seed = 12;
    phks_db_entry entries[N];
    phks_signature *sigs[N];
    char names[N][32];
    for (int i = 0; i < N; i++) {
        sigs[i] = synthetic(15, &seed, false);
        snprintf(names[i], sizeof names[i], "t%d", i);
        entries[i] = (phks_db_entry){names[i], "label", sigs[i]};
    }
    phks_db *one, *many;
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_CREATE, &one), PHKS_OK);
    ck_assert_int_eq(phks_db_add_batch(one, entries, N, NULL), PHKS_OK);
    phks_signature *queries[QUERIES_EACH];
    phks_hit expected[QUERIES_EACH][10];
    size_t expected_count[QUERIES_EACH];
    memset(expected, 0, sizeof expected);
    for (int q = 0; q < QUERIES_EACH; q++) {
        queries[q] = synthetic((size_t)(5 + q), &seed, false);
        ck_assert_int_eq(phks_db_query(one, queries[q], 10, expected[q],
                                       &expected_count[q]),
                         PHKS_OK);
        ck_assert_uint_eq(expected_count[q], 10);
    }
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_READONLY, &many), PHKS_OK);
    pthread_t ids[QUERY_THREADS];
    query_thread t[QUERY_THREADS];
    for (int i = 0; i < QUERY_THREADS; i++) {
        t[i] = (query_thread){many, queries, expected, expected_count, 0};
        ck_assert_int_eq(pthread_create(&ids[i], NULL, query_worker, &t[i]), 0);
    }
    for (int i = 0; i < QUERY_THREADS; i++) {
        pthread_join(ids[i], NULL);
        ck_assert_int_eq(t[i].failures, 0);
    }
    phks_db_close(many);
    phks_db_close(one);
    for (int q = 0; q < QUERIES_EACH; q++)
        phks_signature_free(queries[q]);
    for (int i = 0; i < N; i++)
        phks_signature_free(sigs[i]);
    free(path);
    remove_dir(dir);
}
END_TEST

/* ---- allocation failures */

/* Open, add, add_batch, query, get, remove, query, close on ":memory:"
 * with the i-th library allocation failing, for every i: each call either
 * works or returns a clean status; a handle stays usable; nothing leaks.
 * (SQLite's own allocations are outside the hook.) */
static int sequence(phks_signature **sigs, bool check_usable)
{
    phks_db *db = (phks_db *)1;
    phks_status st = phks_db_open(":memory:", 0, &db);
    if (st != PHKS_OK) {
        ck_assert_int_eq(st, PHKS_ERROR_OUT_OF_MEMORY);
        ck_assert_ptr_null(db);
        return 1;
    }
    int failures = 0;
    int64_t ids[3] = {0};
    phks_db_entry batch[2] = {{"b", "x", sigs[1]}, {"c", NULL, sigs[2]}};
    phks_hit hits[4];
    size_t count;
    phks_signature *back = NULL;
    phks_status sts[7];
    sts[0] = phks_db_add(db, "a", NULL, sigs[0], &ids[0]);
    sts[1] = phks_db_add_batch(db, batch, 2, ids + 1);
    sts[2] = phks_db_query(db, sigs[1], 3, hits, &count);
    sts[3] = phks_db_get(db, ids[0] ? ids[0] : 1, &back, NULL, 0, NULL, 0);
    phks_signature_free(back);
    sts[4] = phks_db_remove(db, ids[1] ? ids[1] : 2);
    sts[5] = phks_db_query(db, sigs[2], 3, hits, &count);
    sts[6] = phks_db_add(db, "d", NULL, sigs[0], NULL);
    for (int i = 0; i < 7; i++)
        if (sts[i] != PHKS_OK) {
            /* get and remove of an entry whose add failed: no such id */
            ck_assert_msg(sts[i] == PHKS_ERROR_OUT_OF_MEMORY ||
                              sts[i] == PHKS_ERROR_INVALID_ARGUMENT,
                          "call %d: %s", i, phks_status_string(sts[i]));
            failures++;
        }
    if (check_usable) { /* with memory back, the handle answers truly */
        long saved = alloc_fail_at;
        alloc_fail_at = -1;
        size_t entries;
        ck_assert_int_eq(phks_db_count(db, &entries), PHKS_OK);
        ck_assert_int_eq(phks_db_query(db, sigs[0], 4, hits, &count), PHKS_OK);
        ck_assert_uint_eq(count, entries);
        alloc_fail_at = saved;
    }
    phks_db_close(db);
    return failures;
}

START_TEST(allocation_failures_are_clean)
{
    phks_allocator counting = {count_malloc, count_realloc, count_free, NULL};
    ck_assert_int_eq(phks_set_allocator(&counting), PHKS_OK);
    alloc_fail_at = -1;
    alloc_calls = alloc_live = 0;
    uint64_t seed = 13;
    phks_signature *sigs[3] = {synthetic(15, &seed, false),
                               synthetic(9, &seed, false),
                               synthetic(2, &seed, false)};
    long baseline = alloc_live;
    alloc_calls = 0;
    ck_assert_int_eq(sequence(sigs, false), 0);
    long total = alloc_calls;
    ck_assert_int_gt(total, 10);
    ck_assert_int_eq(alloc_live, baseline);
    int failing = 0;
    for (alloc_fail_at = 0; alloc_fail_at < total; alloc_fail_at++) {
        alloc_calls = 0;
        failing += sequence(sigs, true) > 0;
        REQUIRE_MSG(alloc_live == baseline, "failing allocation %ld: %ld leaked",
                    alloc_fail_at, alloc_live - baseline);
    }
    /* Most failures show (a few hit only the cache, which reloads). */
    ck_assert_int_ge(failing, total / 2);
    alloc_fail_at = -1;
    for (int i = 0; i < 3; i++)
        phks_signature_free(sigs[i]);
    ck_assert_int_eq(alloc_live, 0);
    ck_assert_int_eq(phks_set_allocator(NULL), PHKS_OK);
}
END_TEST

/* ---- bad arguments */

START_TEST(bad_arguments_are_refused)
{
    const phks_status BAD = PHKS_ERROR_INVALID_ARGUMENT;
    uint64_t seed = 14;
    phks_signature *sig = synthetic(4, &seed, false);
    phks_signature *empty;
    ck_assert_int_eq(phks__signature_alloc(0, 0, 15, &empty), PHKS_OK);
    empty->options = sig->options;
    phks_db *db = (phks_db *)1;
    ck_assert_int_eq(phks_db_open(NULL, 0, &db), BAD);
    ck_assert_ptr_null(db);
    ck_assert_int_eq(phks_db_open(":memory:", 0, NULL), BAD);
    ck_assert_int_eq(phks_db_open(":memory:", 0x4, &db), BAD);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "flags"));
    ck_assert_int_eq(phks_db_open("/tmp/x.db", PHKS_DB_READONLY | PHKS_DB_CREATE,
                                  &db),
                     BAD);
    ck_assert_int_eq(phks_db_open("", PHKS_DB_CREATE, &db), BAD);
    ck_assert_int_eq(phks_db_open(":memory:", PHKS_DB_READONLY, &db), BAD);
    phks_db_close(NULL);

    ck_assert_int_eq(phks_db_open(":memory:", PHKS_DB_CREATE, &db), PHKS_OK);
    int64_t id = 77;
    ck_assert_int_eq(phks_db_add(NULL, "n", NULL, sig, &id), BAD);
    ck_assert_int_eq(phks_db_add(db, NULL, NULL, sig, &id), BAD);
    ck_assert_int_eq(phks_db_add(db, "n", NULL, NULL, &id), BAD);
    ck_assert_int_eq(phks_db_add(db, "n", NULL, empty, &id), BAD);
    ck_assert_int_eq(phks_db_add(db, "bad \xc3(", NULL, sig, &id), BAD);
    ck_assert_int_eq(phks_db_add(db, "n", "\xed\xa0\x80", sig, &id), BAD);
    ck_assert_int_eq(phks_db_add(db, "n", "\xc0\xaf", sig, &id), BAD);
    ck_assert_int_eq(phks_db_add(db, "n", "\xf4\x90\x80\x80", sig, &id), BAD);
    ck_assert_int_eq(id, 77);
    phks_db_entry batch[2] = {{"a", NULL, sig}, {NULL, NULL, sig}};
    ck_assert_int_eq(phks_db_add_batch(NULL, batch, 1, NULL), BAD);
    ck_assert_int_eq(phks_db_add_batch(db, NULL, 1, NULL), BAD);
    ck_assert_int_eq(phks_db_add_batch(db, batch, 2, NULL), BAD);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "entry 1"));
    ck_assert_int_eq(phks_db_add_batch(db, NULL, 0, NULL), PHKS_OK);
    size_t count = 5;
    ck_assert_int_eq(phks_db_count(db, &count), PHKS_OK);
    ck_assert_uint_eq(count, 0);

    ck_assert_int_eq(phks_db_add(db, "ok", NULL, sig, &id), PHKS_OK);
    ck_assert_int_eq(phks_db_remove(NULL, id), BAD);
    ck_assert_int_eq(phks_db_remove(db, id + 1), BAD);
    ck_assert_int_eq(phks_db_remove(db, -3), BAD);
    ck_assert_int_eq(phks_db_count(NULL, &count), BAD);
    ck_assert_int_eq(phks_db_count(db, NULL), BAD);

    int64_t ids[2];
    ck_assert_int_eq(phks_db_list(NULL, 0, ids, 2, &count), BAD);
    ck_assert_int_eq(phks_db_list(db, 0, ids, 2, NULL), BAD);
    ck_assert_int_eq(phks_db_list(db, 0, NULL, 2, &count), BAD);
    ck_assert_int_eq(phks_db_list(db, 0, NULL, 0, &count), PHKS_OK);
    ck_assert_uint_eq(count, 0);

    phks_signature *back = (phks_signature *)1;
    char name[3] = "zz", label[8];
    ck_assert_int_eq(phks_db_get(NULL, id, &back, NULL, 0, NULL, 0), BAD);
    ck_assert_ptr_null(back);
    ck_assert_int_eq(phks_db_get(db, id + 1, &back, NULL, 0, NULL, 0), BAD);
    ck_assert_int_eq(phks_db_get(db, id, &back, NULL, 5, NULL, 0), BAD);
    ck_assert_int_eq(phks_db_get(db, id, &back, NULL, 0, NULL, 5), BAD);
    /* "ok" needs 3 bytes: 2 is too small, and nothing is returned. */
    ck_assert_int_eq(phks_db_get(db, id, &back, name, 2, label, sizeof label),
                     PHKS_ERROR_BUFFER_TOO_SMALL);
    ck_assert_ptr_null(back);
    ck_assert_str_eq(name, "zz");
    ck_assert_int_eq(phks_db_get(db, id, &back, name, 3, label, 0),
                     PHKS_ERROR_BUFFER_TOO_SMALL);
    ck_assert_int_eq(phks_db_get(db, id, &back, name, 3, label, 1), PHKS_OK);
    ck_assert_str_eq(name, "ok");
    ck_assert_str_eq(label, "");
    same_signature(back, sig);
    phks_signature_free(back);
    ck_assert_int_eq(phks_db_get(db, id, NULL, NULL, 0, NULL, 0), PHKS_OK);

    phks_hit hits[2];
    count = 9;
    ck_assert_int_eq(phks_db_query(NULL, sig, 2, hits, &count), BAD);
    ck_assert_uint_eq(count, 0);
    ck_assert_int_eq(phks_db_query(db, NULL, 2, hits, &count), BAD);
    ck_assert_int_eq(phks_db_query(db, sig, 0, hits, &count), BAD);
    ck_assert_int_eq(phks_db_query(db, sig, 2, NULL, &count), BAD);
    ck_assert_int_eq(phks_db_query(db, sig, 2, hits, NULL), BAD);
    ck_assert_int_eq(phks_db_query(db, sig, 2, hits, &count), PHKS_OK);
    ck_assert_uint_eq(count, 1);
    phks_db_close(db);
    phks_signature_free(sig);
    phks_signature_free(empty);
}
END_TEST

/* ---- the packed chunks (format 2) */

static unsigned long loads(bool from_rows)
{
    unsigned long pack, rows;
    phks__db_load_counts(&pack, &rows);
    return from_rows ? rows : pack;
}

/* A database of n entries of 1 + i % 37 features, named "e<i>", labelled
 * as query_matches_oracle expects, added in batches and one by one. */
typedef struct packed_db {
    size_t n;
    phks_signature **sigs;
    int64_t *ids;
    char (*names)[32];
    phks_signature *queries[4];
} packed_db;

static void packed_db_make(packed_db *p, const char *path, size_t n)
{
    uint64_t seed = 77;
    p->n = n;
    p->sigs = calloc(n, sizeof *p->sigs);
    p->ids = calloc(n, sizeof *p->ids);
    p->names = calloc(n, sizeof *p->names);
    for (int q = 0; q < 4; q++)
        p->queries[q] = synthetic(3 + 5 * (size_t)q, &seed, false);
    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_CREATE, &db), PHKS_OK);
    phks_db_entry *e = calloc(n, sizeof *e);
    for (size_t i = 0; i < n; i++) {
        p->sigs[i] = synthetic(1 + i % 37, &seed, false);
        snprintf(p->names[i], sizeof p->names[i], "e%zu", i);
        e[i] = (phks_db_entry){p->names[i], i % 3 ? "odd" : NULL, p->sigs[i]};
    }
    size_t done = 0;
    for (; done < 5 && done < n; done++)
        ck_assert_int_eq(phks_db_add(db, e[done].name, e[done].label,
                                     e[done].signature, &p->ids[done]),
                         PHKS_OK);
    while (done < n) {
        size_t take = n - done < 250 ? n - done : 250;
        ck_assert_int_eq(phks_db_add_batch(db, e + done, take, p->ids + done),
                         PHKS_OK);
        done += take;
    }
    free(e);
    phks_db_close(db);
}

static void packed_db_free(packed_db *p)
{
    for (size_t i = 0; i < p->n; i++)
        phks_signature_free(p->sigs[i]);
    for (int q = 0; q < 4; q++)
        phks_signature_free(p->queries[q]);
    free(p->sigs);
    free(p->ids);
    free(p->names);
}

typedef struct top10 {
    size_t count;
    phks_hit hits[10];
} top10;

/* The answers of a fresh handle to the four queries, checked against the
 * oracle; from_rows says how its cache must have been loaded. */
static void fresh_answers(const packed_db *p, const char *path, unsigned flags,
                          bool from_rows, top10 out[4])
{
    unsigned long pack0 = loads(false), rows0 = loads(true);
    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, flags, &db), PHKS_OK);
    for (int q = 0; q < 4; q++) {
        memset(&out[q], 0, sizeof out[q]);
        phks_status st =
            phks_db_query(db, p->queries[q], 10, out[q].hits, &out[q].count);
        ck_assert_msg(st == PHKS_OK, "%s", phks_last_error_message());
        query_matches_oracle(db, p->queries[q], 10, p->sigs, p->ids, p->names,
                             p->n);
    }
    phks_db_close(db);
    ck_assert_uint_eq(loads(false) - pack0, from_rows ? 0 : 1);
    ck_assert_uint_eq(loads(true) - rows0, from_rows ? 1 : 0);
}

static void same_answers(const top10 a[4], const top10 b[4])
{
    for (int q = 0; q < 4; q++) {
        ck_assert_uint_eq(a[q].count, b[q].count);
        ck_assert_mem_eq(a[q].hits, b[q].hits, a[q].count * sizeof(phks_hit));
    }
}

/* pack_state covers the rows, and counts them right. */
static void pack_is_current(const char *path, bool current)
{
    sql_is(path,
           "SELECT pack_changes = changes AND rows = (SELECT count(*) FROM "
           "entries) FROM pack_state",
           current ? "1" : "0");
}

/* Flips one byte of the chunk with the lowest (first) or highest start,
 * at offset (from the end when negative). */
static void flip_chunk_byte(const char *path, bool first, long offset)
{
    sqlite3 *raw;
    ck_assert_int_eq(sqlite3_open(path, &raw), SQLITE_OK);
    sqlite3_stmt *st;
    ck_assert_int_eq(
        sqlite3_prepare_v2(raw,
                           first ? "SELECT start, data FROM packs ORDER BY "
                                   "start LIMIT 1"
                                 : "SELECT start, data FROM packs ORDER BY "
                                   "start DESC LIMIT 1",
                           -1, &st, NULL),
        SQLITE_OK);
    ck_assert_int_eq(sqlite3_step(st), SQLITE_ROW);
    int64_t start = sqlite3_column_int64(st, 0);
    int size = sqlite3_column_bytes(st, 1);
    unsigned char *data = malloc((size_t)size);
    memcpy(data, sqlite3_column_blob(st, 1), (size_t)size);
    sqlite3_finalize(st);
    long at = offset < 0 ? size + offset : offset;
    ck_assert(at >= 0 && at < size);
    data[at] ^= 0x10;
    ck_assert_int_eq(sqlite3_prepare_v2(raw,
                                        "UPDATE packs SET data = ?1 WHERE "
                                        "start = ?2",
                                        -1, &st, NULL),
                     SQLITE_OK);
    sqlite3_bind_blob(st, 1, data, size, SQLITE_TRANSIENT);
    sqlite3_bind_int64(st, 2, start);
    ck_assert_int_eq(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
    ck_assert_int_eq(sqlite3_close(raw), SQLITE_OK);
    free(data);
}

/* A fresh handle answers from the chunks exactly what it answers from the
 * rows (forced by marking the chunks stale), read-only or not; a
 * writable handle's rebuild makes them current again. */
START_TEST(pack_answers_as_the_rows)
{
    char *dir = temp_dir(), *path = in_dir(dir, "pack.db");
    packed_db p;
    packed_db_make(&p, path, 700);
    sql_is(path, "SELECT count(*) > 2 FROM packs", "1");
    pack_is_current(path, true);
    /* Removed entries leave their chunks, and the answers. */
    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
    for (size_t i = 0; i < p.n; i += 7) {
        ck_assert_int_eq(phks_db_remove(db, p.ids[i]), PHKS_OK);
        p.ids[i] = 0;
    }
    phks_db_close(db);
    pack_is_current(path, true);

    top10 from_pack[4], from_rows[4], again[4];
    fresh_answers(&p, path, 0, false, from_pack);
    fresh_answers(&p, path, PHKS_DB_READONLY, false, again);
    same_answers(from_pack, again);

    free(sql(path, "UPDATE pack_state SET pack_changes = -1"));
    fresh_answers(&p, path, PHKS_DB_READONLY, true, from_rows);
    same_answers(from_pack, from_rows);
    pack_is_current(path, false); /* read-only: not rewritten */
    fresh_answers(&p, path, 0, true, again);
    same_answers(from_pack, again);
    pack_is_current(path, true); /* rebuilt */
    fresh_answers(&p, path, PHKS_DB_READONLY, false, again);
    same_answers(from_pack, again);

    packed_db_free(&p);
    free(path);
    remove_dir(dir);
}
END_TEST

/* Chunks that disagree with the rows are never used: each kind of damage
 * or staleness makes a fresh handle decode the rows (and answer as
 * before), a writable one rewrite the chunks. */
#define PACK_DAMAGES 10
START_TEST(stale_or_damaged_pack_is_rebuilt)
{
    char *dir = temp_dir(), *path = in_dir(dir, "pack.db");
    packed_db p;
    packed_db_make(&p, path, 400);
    top10 want[4], got[4];
    fresh_answers(&p, path, 0, false, want);
    switch (_i) {
    case 0: /* a row count that is not the rows' */
        free(sql(path, "UPDATE pack_state SET rows = rows + 1"));
        break;
    case 1: /* chunks that cover other changes */
        free(sql(path, "UPDATE pack_state SET pack_changes = changes - 1"));
        break;
    case 2: /* a vector value (checksum) */
        flip_chunk_byte(path, true, 2000);
        break;
    case 3: /* the entry count of a header */
        flip_chunk_byte(path, false, 8);
        break;
    case 4: /* the checksum itself */
        flip_chunk_byte(path, false, -3);
        break;
    case 5: /* a chunk's entry count column */
        free(sql(path, "UPDATE packs SET entries = entries + 1 WHERE start = "
                       "(SELECT max(start) FROM packs)"));
        break;
    case 6: /* a chunk lost */
        free(sql(path, "DELETE FROM packs WHERE start = "
                       "(SELECT max(start) FROM packs)"));
        break;
    case 7: /* a chunk whose start is above its ids */
        free(sql(path, "UPDATE packs SET start = start + 1 WHERE start = "
                       "(SELECT min(start) FROM packs)"));
        break;
    case 8: /* rows removed by another program: the triggers count them */
        free(sql(path, "DELETE FROM entries WHERE id IN (3, 200)"));
        p.ids[2] = p.ids[199] = 0;
        break;
    default: /* the pack_state row gone */
        free(sql(path, "DELETE FROM pack_state"));
        break;
    }
    fresh_answers(&p, path, PHKS_DB_READONLY, true, got);
    if (_i != 8)
        same_answers(want, got);
    memcpy(want, got, sizeof want);
    fresh_answers(&p, path, 0, true, got);
    same_answers(want, got);
    pack_is_current(path, true);
    fresh_answers(&p, path, 0, false, got);
    same_answers(want, got);
    packed_db_free(&p);
    free(path);
    remove_dir(dir);
}
END_TEST

/* A format 1 file (made here by taking format 2's additions away, which
 * leaves format 1's schema exactly) is read as it is by a read-only
 * handle, and upgraded by a writable one: same answers throughout. */
START_TEST(format_1_file_upgrades)
{
    char *dir = temp_dir(), *path = in_dir(dir, "old.db");
    packed_db p;
    packed_db_make(&p, path, 300);
    top10 want[4], got[4];
    fresh_answers(&p, path, 0, false, want);
    static const char *const downgrade[] = {
        "DROP TRIGGER entries_insert", "DROP TRIGGER entries_delete", "DROP TRIGGER entries_update",
        "DROP TABLE packs", "DROP TABLE pack_state",
        "UPDATE meta SET value = 1 WHERE key = 'format'",
        "PRAGMA user_version = 1"};
    for (size_t i = 0; i < sizeof downgrade / sizeof *downgrade; i++)
        free(sql(path, downgrade[i]));
    sql_is(path,
           "SELECT group_concat(name) FROM (SELECT name FROM sqlite_master "
           "ORDER BY name)",
           "entries,meta,sqlite_autoindex_meta_1,sqlite_sequence");

    fresh_answers(&p, path, PHKS_DB_READONLY, true, got);
    same_answers(want, got);
    sql_is(path, "PRAGMA user_version", "1");

    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
    sql_is(path, "PRAGMA user_version", "2");
    sql_is(path, "SELECT value FROM meta WHERE key = 'format'", "2");
    sql_is(path, "SELECT rows || ' ' || pack_changes FROM pack_state",
           "300 -1");
    phks_db_close(db);
    fresh_answers(&p, path, 0, true, got); /* fills the chunks */
    same_answers(want, got);
    pack_is_current(path, true);
    fresh_answers(&p, path, PHKS_DB_READONLY, false, got);
    same_answers(want, got);

    /* Writes after the upgrade keep the chunks current. */
    ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
    ck_assert_int_eq(phks_db_remove(db, p.ids[10]), PHKS_OK);
    p.ids[10] = 0;
    phks_db_close(db);
    pack_is_current(path, true);
    fresh_answers(&p, path, 0, false, got);
    packed_db_free(&p);
    free(path);
    remove_dir(dir);
}
END_TEST

/* Adds (one, a batch, across chunk boundaries) and removals (first,
 * last, middle entries, a whole chunk) keep the chunks current; a fresh
 * handle then loads them and answers as the oracle. Stale chunks stay
 * stale through writes, as do chunks whose tail is damaged. */
START_TEST(writes_keep_the_pack_current)
{
    char *dir = temp_dir(), *path = in_dir(dir, "pack.db");
    packed_db p;
    packed_db_make(&p, path, 600);
    size_t live = 300; /* the first 300 stay in the file */
    phks_db *db;
    ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
    for (size_t i = live; i < p.n; i++) {
        ck_assert_int_eq(phks_db_remove(db, p.ids[i]), PHKS_OK);
        p.ids[i] = 0;
    }
    pack_is_current(path, true);
    top10 got[4];
    fresh_answers(&p, path, 0, false, got);

    /* Removals: the first id, the last, one in the middle, then every
     * entry of the first chunk. */
    char *text = sql(path, "SELECT coalesce((SELECT min(start) FROM packs "
                           "WHERE start > 1), 1000000)");
    int64_t first_chunk_end = strtoll(text, NULL, 10);
    free(text);
    int64_t rm[] = {p.ids[0], p.ids[live - 1], p.ids[live / 2]};
    for (size_t r = 0; r < 3; r++) {
        ck_assert_int_eq(phks_db_remove(db, rm[r]), PHKS_OK);
        for (size_t i = 0; i < p.n; i++)
            if (p.ids[i] == rm[r])
                p.ids[i] = 0;
        pack_is_current(path, true);
        fresh_answers(&p, path, 0, false, got);
    }
    for (size_t i = 0; i < p.n; i++)
        if (p.ids[i] && p.ids[i] < first_chunk_end) {
            ck_assert_int_eq(phks_db_remove(db, p.ids[i]), PHKS_OK);
            p.ids[i] = 0;
        }
    pack_is_current(path, true);
    sql_is(path, "SELECT count(*) FROM packs WHERE start = 1", "0");
    fresh_answers(&p, path, 0, false, got);

    /* Adds: one, then a batch spanning chunks, with this handle's cache
     * loaded. */
    query_matches_oracle(db, p.queries[0], 10, p.sigs, p.ids, p.names, p.n);
    phks_db_entry e[300];
    for (size_t i = 300; i < 600; i++)
        e[i - 300] = (phks_db_entry){p.names[i], i % 3 ? "odd" : NULL,
                                     p.sigs[i]};
    ck_assert_int_eq(phks_db_add(db, e[0].name, e[0].label, e[0].signature,
                                 &p.ids[300]),
                     PHKS_OK);
    pack_is_current(path, true);
    fresh_answers(&p, path, 0, false, got);
    ck_assert_int_eq(phks_db_add_batch(db, e + 1, 299, p.ids + 301), PHKS_OK);
    pack_is_current(path, true);
    fresh_answers(&p, path, 0, false, got);
    query_matches_oracle(db, p.queries[1], 10, p.sigs, p.ids, p.names, p.n);
    phks_db_close(db);

    /* Stale chunks stay stale through writes. */
    free(sql(path, "UPDATE pack_state SET pack_changes = -1"));
    ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
    ck_assert_int_eq(phks_db_remove(db, p.ids[599]), PHKS_OK);
    p.ids[599] = 0;
    phks_db_close(db);
    pack_is_current(path, false);
    fresh_answers(&p, path, 0, true, got);
    pack_is_current(path, true);

    /* A damaged last chunk: an add leaves the chunks stale. */
    flip_chunk_byte(path, false, 100);
    ck_assert_int_eq(phks_db_open(path, 0, &db), PHKS_OK);
    ck_assert_int_eq(phks_db_remove(db, p.ids[598]), PHKS_OK);
    p.ids[598] = 0;
    phks_db_close(db);
    pack_is_current(path, false);
    fresh_answers(&p, path, PHKS_DB_READONLY, true, got);
    fresh_answers(&p, path, 0, true, got);
    fresh_answers(&p, path, 0, false, got);

    packed_db_free(&p);
    free(path);
    remove_dir(dir);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("db");
    TCase *c = tcase_create("db");
    tcase_set_timeout(c, 120);
    tcase_add_loop_test(c, round_trip, 0, 2);
    tcase_add_test(c, file_layout_is_as_documented);
    tcase_add_test(c, local_descriptor_is_the_databases);
    tcase_add_test(c, global_descriptor_is_the_databases);
    tcase_add_test(c, query_equals_brute_force);
    tcase_add_test(c, parallel_scan_equals_brute_force);
    tcase_add_test(c, creatures_end_to_end);
    tcase_add_test(c, hit_text_is_cut_at_a_character);
    tcase_add_test(c, other_options_are_refused);
    tcase_add_test(c, options_set_by_another_handle_are_refused);
    tcase_add_test(c, foreign_newer_and_damaged_files_are_refused);
    tcase_add_test(c, every_damaged_page_is_refused_or_harmless);
    tcase_add_test(c, read_only_handles_refuse_writes);
    tcase_add_test(c, two_handles_see_each_others_commits);
    tcase_add_test(c, killed_writer_loses_no_commit);
    tcase_add_test(c, ids_below_one_are_refused);
    tcase_add_test(c, concurrent_queries_agree);
    tcase_add_test(c, allocation_failures_are_clean);
    tcase_add_test(c, bad_arguments_are_refused);
    tcase_add_test(c, pack_answers_as_the_rows);
    tcase_add_loop_test(c, stale_or_damaged_pack_is_rebuilt, 0, PACK_DAMAGES);
    tcase_add_test(c, format_1_file_upgrades);
    tcase_add_test(c, writes_keep_the_pack_current);
    suite_add_tcase(s, c);
    return run_suite(s);
}
