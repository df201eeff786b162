/*
 * db_read.c - what a database answers: its count, its ids page by page,
 * one entry whole, and the k entries nearest a query.
 *
 * count, list and get read the file itself, one statement each (one
 * snapshot), so that they see every commit at once. A query scans the
 * packed copy (db_scan.c), refreshed first when the file changed
 * (db_load.c); with verified matching the scan only shortlists, and
 * db_rerank.c, reading the shortlisted entries back through
 * phks__db_get_signature, decides.
 */
#include "db/db.h"

#include <stdio.h>
#include <string.h>

phks_status phks_db_count(phks_db *db, size_t *count)
{
    if (count)
        *count = 0;
    if (!db || !count)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_count: NULL argument");
    int64_t n = 0;
    pthread_mutex_lock(&db->lock);
    sqlite3_stmt *stmt;
    /* One statement, one snapshot; each subquery is a single b-tree
     * operation (count, and the first rowid). */
    phks_status st = phks__db_prepare(db,
                                      "SELECT (SELECT count(*) FROM entries),"
                                      " (SELECT min(id) FROM entries)",
                                      &stmt);
    if (st == PHKS_OK) {
        int rc = sqlite3_step(stmt);
        if (rc != SQLITE_ROW)
            st = phks__db_sql_fail(db, rc == SQLITE_DONE ? SQLITE_CORRUPT : rc,
                                   "phks_db_count");
        else if (sqlite3_column_type(stmt, 1) != SQLITE_NULL &&
                 sqlite3_column_int64(stmt, 1) < 1)
            st = phks__db_id_below_one(db, sqlite3_column_int64(stmt, 1));
        else
            n = sqlite3_column_int64(stmt, 0);
        sqlite3_finalize(stmt);
    }
    pthread_mutex_unlock(&db->lock);
    if (st == PHKS_OK)
        *count = (size_t)n;
    return st;
}

/* Steps stmt for up to capacity ids above after_id into ids (*n of
 * them). A damaged b-tree can return rowids out of order; a caller
 * paging from the last id would then loop for ever. */
static phks_status collect_ids(phks_db *db, sqlite3_stmt *stmt,
                               int64_t after_id, int64_t *ids,
                               size_t capacity, size_t *n)
{
    phks_status st = PHKS_OK;
    int rc = SQLITE_DONE;
    while (st == PHKS_OK && *n < capacity &&
           (rc = sqlite3_step(stmt)) == SQLITE_ROW) {
        int64_t id = sqlite3_column_int64(stmt, 0);
        if (id < 1)
            st = phks__db_id_below_one(db, id);
        else if (id <= (*n ? ids[*n - 1] : after_id))
            st = phks__fail(PHKS_ERROR_CORRUPT,
                            "phks_db_list: ids out of order, the file is "
                            "damaged");
        else
            ids[(*n)++] = id;
    }
    if (st == PHKS_OK && *n < capacity && rc != SQLITE_DONE)
        st = phks__db_sql_fail(db, rc, "phks_db_list");
    return st;
}

phks_status phks_db_list(phks_db *db, int64_t after_id, int64_t *ids,
                         size_t capacity, size_t *count)
{
    if (count)
        *count = 0;
    if (!db || !count || (!ids && capacity))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_list: NULL argument");
    if (capacity == 0)
        return PHKS_OK;
    pthread_mutex_lock(&db->lock);
    sqlite3_stmt *stmt;
    size_t n = 0;
    /* A first page (after_id below 1) starts at the very first row, so
     * that it meets any id below 1. */
    phks_status st = phks__db_prepare(
        db,
        after_id < 1 ? "SELECT id FROM entries ORDER BY id LIMIT ?2"
                     : "SELECT id FROM entries WHERE id > ?1 "
                       "ORDER BY id LIMIT ?2",
        &stmt);
    if (st == PHKS_OK) {
        sqlite3_bind_int64(stmt, 1, after_id);
        sqlite3_bind_int64(stmt, 2,
                           capacity > INT64_MAX ? INT64_MAX : (int64_t)capacity);
        st = collect_ids(db, stmt, after_id, ids, capacity, &n);
        sqlite3_finalize(stmt);
    }
    pthread_mutex_unlock(&db->lock);
    if (st == PHKS_OK)
        *count = n;
    return st;
}

/* ---- one entry */

/* A text column asked for: the caller's buffer (NULL: not asked) and
 * the column's text. */
typedef struct text_out {
    char *buf;
    size_t capacity;
    const char *text; /* NULL when SQLite ran out of memory */
    size_t len;
} text_out;

/* Column i as text ("" for NULL) and its length. */
static void column_text(sqlite3_stmt *stmt, int i, text_out *t)
{
    if (sqlite3_column_type(stmt, i) == SQLITE_NULL) {
        t->len = 0;
        t->text = "";
        return;
    }
    t->text = (const char *)sqlite3_column_text(stmt, i);
    t->len = (size_t)sqlite3_column_bytes(stmt, i);
}

static phks_status room_for(const char *what, const text_out *t)
{
    if (!t->buf || t->len < t->capacity)
        return PHKS_OK;
    return phks__fail(PHKS_ERROR_BUFFER_TOO_SMALL,
                      "phks_db_get: the %s needs %zu bytes, room for %zu",
                      what, t->len + 1, t->capacity);
}

static void copy_out(const text_out *t)
{
    if (t->buf) {
        memcpy(t->buf, t->text, t->len);
        t->buf[t->len] = '\0';
    }
}

/* The row of entry id that stmt (prepared, id bound) gives: the texts
 * where asked, the signature decoded when signature is not NULL. Nothing
 * is written out unless all of it succeeds. */
static phks_status read_row(phks_db *db, sqlite3_stmt *stmt, int64_t id,
                            phks_signature **signature, text_out *name,
                            text_out *label)
{
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_DONE)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_get: no entry with id %lld", (long long)id);
    if (rc != SQLITE_ROW)
        return phks__db_sql_fail(db, rc, "phks_db_get");
    column_text(stmt, 0, name);
    column_text(stmt, 1, label);
    phks_status st = !name->text || !label->text
                         ? phks__fail_oom("phks_db_get")
                         : room_for("name", name);
    if (st == PHKS_OK)
        st = room_for("label", label);
    phks_signature *sig = NULL;
    if (st == PHKS_OK && signature) {
        char what[64];
        snprintf(what, sizeof what, "entry %lld", (long long)id);
        st = phks__db_decode_stored(db, sqlite3_column_blob(stmt, 2),
                                    sqlite3_column_bytes(stmt, 2), what, &sig);
    }
    if (st == PHKS_OK) {
        copy_out(name);
        copy_out(label);
        if (signature)
            *signature = sig;
    }
    return st;
}

/* Entry id, as phks_db_get reads it; takes lock. */
static phks_status get_entry(phks_db *db, int64_t id,
                             phks_signature **signature, text_out *name,
                             text_out *label)
{
    pthread_mutex_lock(&db->lock);
    sqlite3_stmt *stmt;
    phks_status st = phks__db_prepare(
        db, "SELECT name, label, signature FROM entries WHERE id = ?1", &stmt);
    if (st == PHKS_OK) {
        sqlite3_bind_int64(stmt, 1, id);
        st = read_row(db, stmt, id, signature, name, label);
        sqlite3_finalize(stmt);
    }
    pthread_mutex_unlock(&db->lock);
    return st;
}

phks_status phks_db_get(phks_db *db, int64_t id, phks_signature **signature,
                        char *name, size_t name_capacity, char *label,
                        size_t label_capacity)
{
    if (signature)
        *signature = NULL;
    if (!db || (!name && name_capacity) || (!label && label_capacity))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_get: NULL argument");
    text_out n = {name, name_capacity, NULL, 0};
    text_out l = {label, label_capacity, NULL, 0};
    return get_entry(db, id, signature, &n, &l);
}

phks_status phks_db_similarity(phks_db *db, const phks_signature *query,
                               int64_t id, double *similarity,
                               size_t *verified)
{
    if (!db || !query || !similarity)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_similarity: NULL argument");
    phks_signature *entry;
    phks_status st = phks__db_get_signature(db, id, &entry);
    if (st == PHKS_OK)
        st = phks_similarity(query, entry, similarity, verified);
    phks_signature_free(entry);
    return st;
}

phks_status phks__db_get_signature(phks_db *db, int64_t id,
                                   phks_signature **signature)
{
    text_out name = {NULL, 0, NULL, 0}, label = name;
    *signature = NULL;
    return get_entry(db, id, signature, &name, &label);
}

/* ---- queries */

/* Brings the cache up to date and checks that query compares with the
 * database; takes lock. */
static phks_status ready(phks_db *db, const phks_signature *query)
{
    pthread_mutex_lock(&db->lock);
    phks_status st = phks__db_refresh(db);
    if (st == PHKS_OK)
        st = phks__db_check_options(db, "phks_db_query", "query",
                                    &query->options);
    pthread_mutex_unlock(&db->lock);
    return st;
}

/* The scan's k best into hits, if the cache is loaded (*loaded); takes
 * cache_lock. */
static phks_status scan(phks_db *db, const phks_signature *query, size_t k,
                        phks_hit *hits, size_t *count, bool *loaded)
{
    phks_status st = PHKS_OK;
    pthread_rwlock_rdlock(&db->cache_lock);
    *loaded = db->cache_loaded;
    if (*loaded)
        st = phks__db_cache_query(&db->cache, query, k, hits, count);
    pthread_rwlock_unlock(&db->cache_lock);
    return st;
}

phks_status phks_db_query(phks_db *db, const phks_signature *query, size_t k,
                          phks_hit *hits, size_t *count)
{
    if (count)
        *count = 0;
    if (!db || !query || !hits || !count)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_query: NULL argument");
    if (k == 0)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "phks_db_query: k is 0");
    /* Verified matching: the scan shortlists, db_rerank.c decides. */
    bool verified = query->options.matching == PHKS_MATCHING_VERIFIED;
    size_t m = k > PHKS__DB_SHORTLIST ? k : PHKS__DB_SHORTLIST, listed = 0;
    phks_hit *shortlist = verified ? phks__malloc_array(m, sizeof *shortlist)
                                   : NULL;
    if (verified && !shortlist)
        return phks__fail_oom("phks_db_query");
    /* A writer that runs out of memory updating the cache drops it; the
     * scan then finds it unloaded and refreshes again. */
    phks_status st = PHKS_OK;
    bool loaded = false;
    while (!loaded && (st = ready(db, query)) == PHKS_OK)
        st = verified ? scan(db, query, m, shortlist, &listed, &loaded)
                      : scan(db, query, k, hits, count, &loaded);
    if (st == PHKS_OK && verified)
        st = phks__db_rerank(db, query, shortlist, listed, k, hits, count);
    phks__free(shortlist);
    return st;
}
