/*
 * db_pack_table.c - the packs table of format 2 (docs/formats.md): the
 * packed copy kept inside the file, so that a fresh handle loads it by
 * reading chunks (laid out by db_pack.c) instead of decoding every
 * signature.
 *
 * The table holds the cache's entries in chunks, each covering the ids
 * from its start up to the next chunk's start. pack_state counts the
 * rows and every change made to them (by triggers, whoever writes), and
 * records in pack_changes the count of changes the chunks cover: they
 * are used only when it equals changes and every chunk's checksum and
 * layout hold, else the cache is rebuilt from the rows and, on a
 * writable handle, the chunks rewritten from it. Each write of this
 * library updates the chunks in its own transaction.
 */
#include "db/db.h"

#include <limits.h>
#include <string.h>

/* A chunk closes at this many bytes: an add rewrites at most one chunk
 * below it, a removal one chunk. */
#define PACK_CHUNK_BYTES (512 * 1024)

/* ---- pack_state */

phks_status phks__db_pack_state_read(phks_db *db, phks__db_pack_state *ps)
{
    memset(ps, 0, sizeof *ps);
    sqlite3_stmt *stmt;
    phks_status st = phks__db_prepare(
        db, "SELECT rows, changes, pack_changes FROM pack_state WHERE id = 1",
        &stmt);
    if (st != PHKS_OK)
        return st;
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW) {
        ps->present = true;
        ps->rows = sqlite3_column_int64(stmt, 0);
        ps->changes = sqlite3_column_int64(stmt, 1);
        ps->pack_changes = sqlite3_column_int64(stmt, 2);
    } else if (rc != SQLITE_DONE) {
        st = phks__db_sql_fail(db, rc, "cannot read pack_state");
    }
    sqlite3_finalize(stmt);
    return st;
}

bool phks__db_pack_current(const phks__db_pack_state *ps)
{
    return ps->present && ps->pack_changes == ps->changes && ps->rows >= 0;
}

/* Inside a write transaction, after the chunks were brought up to date:
 * they now cover every change counted (and, with set_rows, rows rows). */
static phks_status mark_current(phks_db *db, int64_t rows, bool set_rows)
{
    return phks__db_exec_id(
        db,
        set_rows ? "INSERT OR REPLACE INTO pack_state (id, rows, changes,"
                   " pack_changes) SELECT 1, ?1, coalesce(max(changes), 0),"
                   " coalesce(max(changes), 0) FROM pack_state"
                 : "UPDATE pack_state SET pack_changes = changes",
        rows, "cannot write pack_state");
}

/* ---- writing chunks */

/* The vector values and text bytes of the live entries of slots
 * [begin, end) of c: the columns vectors and text of their chunk. */
static void chunk_totals(const phks__db_cache *c, size_t begin, size_t end,
                         size_t *vectors, size_t *text)
{
    *vectors = *text = 0;
    for (size_t e = begin; e < end; e++)
        if (c->features[e]) {
            *vectors += phks__db_padded(c->features[e]) * c->length;
            const char *t = c->text + c->text_at[e];
            size_t n = strlen(t) + 1;
            *text += n + strlen(t + n) + 1;
        }
}

/* Writes the live entries of slots [begin, end) of c as the chunk that
 * starts at id start (replacing one that did). */
static phks_status write_chunk(phks_db *db, int64_t start,
                               const phks__db_cache *c, size_t begin,
                               size_t end)
{
    unsigned char *blob;
    size_t size, entries, vectors, text;
    phks_status st = phks__db_pack_encode(c, begin, end, &blob, &size, &entries);
    if (st == PHKS_ERROR_OUT_OF_MEMORY)
        return phks__fail_oom("database pack");
    if (st != PHKS_OK) /* no live entry: no chunk */
        return PHKS_OK;
    if (size > INT_MAX) {
        phks__free(blob);
        return phks__fail(PHKS_ERROR_TOO_LARGE, "%s: a pack chunk of %zu bytes",
                          db->path, size);
    }
    chunk_totals(c, begin, end, &vectors, &text);
    sqlite3_stmt *stmt;
    st = phks__db_prepare(db,
                          "INSERT OR REPLACE INTO packs (start, entries,"
                          " vectors, text, data) VALUES (?1, ?2, ?3, ?4, ?5)",
                          &stmt);
    if (st == PHKS_OK) {
        sqlite3_bind_int64(stmt, 1, start);
        sqlite3_bind_int64(stmt, 2, (int64_t)entries);
        sqlite3_bind_int64(stmt, 3, (int64_t)vectors);
        sqlite3_bind_int64(stmt, 4, (int64_t)text);
        int rc = sqlite3_bind_blob(stmt, 5, blob, (int)size, SQLITE_STATIC);
        if (rc == SQLITE_OK)
            rc = sqlite3_step(stmt);
        if (rc != SQLITE_DONE)
            st = phks__db_sql_fail(db, rc, "cannot write a pack chunk");
        sqlite3_finalize(stmt);
    }
    phks__free(blob);
    return st;
}

/* Every live entry of c as chunks of about PACK_CHUNK_BYTES, replacing
 * all chunks. */
static phks_status write_all_chunks(phks_db *db, const phks__db_cache *c)
{
    phks_status st =
        phks__db_exec(db, "DELETE FROM packs", "cannot clear the packs");
    size_t begin = 0, bytes = 0;
    for (size_t e = 0; e <= c->count && st == PHKS_OK; e++) {
        if (e < c->count && !c->features[e])
            continue;
        if (e < c->count)
            bytes += 12 + 8 * phks__db_padded(c->features[e]) * c->length + 32;
        if (bytes && (bytes >= PACK_CHUNK_BYTES || e == c->count)) {
            size_t end = e < c->count ? e + 1 : e;
            while (!c->features[begin]) /* a live slot lies below end */
                begin++;
            st = write_chunk(db, c->ids[begin], c, begin, end);
            begin = end;
            bytes = 0;
        }
    }
    return st;
}

void phks__db_pack_persist(phks_db *db, int64_t changes)
{
    if (phks__db_begin(db, true) != PHKS_OK)
        return;
    phks__db_pack_state ps;
    phks_status st = phks__db_pack_state_read(db, &ps);
    if (st == PHKS_OK && ps.changes == changes)
        st = write_all_chunks(db, &db->cache);
    else
        st = PHKS_ERROR_IO;
    if (st == PHKS_OK)
        st = mark_current(db, (int64_t)(db->cache.count - db->cache.dead),
                          true);
    (void)phks__db_end(db, st);
}

/* ---- the chunk a write changes */

static phks_status read_memory(void *ctx, void *dst, size_t n, size_t offset)
{
    memcpy(dst, (const unsigned char *)ctx + offset, n);
    return PHKS_OK;
}

/* The chunk holding id (the one with the highest start at most id) into
 * the empty cache t. *found false when there is none; PHKS_ERROR_CORRUPT
 * without a message when it is damaged. */
static phks_status read_chunk(phks_db *db, int64_t id, phks__db_cache *t,
                              int64_t *start, bool *found)
{
    *found = false;
    sqlite3_stmt *stmt;
    phks_status st = phks__db_prepare(db,
                                      "SELECT start, data FROM packs WHERE"
                                      " start <= ?1 ORDER BY start DESC LIMIT 1",
                                      &stmt);
    if (st != PHKS_OK)
        return st;
    sqlite3_bind_int64(stmt, 1, id);
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW) {
        *found = true;
        *start = sqlite3_column_int64(stmt, 0);
        const void *blob = sqlite3_column_blob(stmt, 1);
        int size = sqlite3_column_bytes(stmt, 1);
        if (!blob && sqlite3_errcode(db->conn) == SQLITE_NOMEM)
            st = phks__fail_oom("database pack");
        else if (!blob || size <= 0)
            st = PHKS_ERROR_CORRUPT;
        else
            st = phks__db_pack_decode(t, *start, (size_t)size, read_memory,
                                      (void *)blob);
        if (st == PHKS_ERROR_OUT_OF_MEMORY)
            st = phks__fail_oom("database pack");
    } else if (rc != SQLITE_DONE) {
        st = phks__db_sql_fail(db, rc, "cannot read a pack chunk");
    }
    sqlite3_finalize(stmt);
    return st;
}

/* pack_append's work: *kept false when the last chunk is damaged or the
 * entries do not fit in (out of order, another length). */
static phks_status append_entries(phks_db *db, const phks_db_entry *entries,
                                  const int64_t *ids, size_t count, bool *kept)
{
    phks__db_cache t;
    phks__db_cache_init(&t);
    int64_t start = 0;
    bool found;
    phks_status st = read_chunk(db, INT64_MAX, &t, &start, &found);
    *kept = st != PHKS_ERROR_CORRUPT;
    if (st != PHKS_OK) {
        phks__db_cache_release(&t);
        return *kept ? st : PHKS_OK;
    }
    if (!found || phks__db_pack_bytes(&t) >= PACK_CHUNK_BYTES) {
        phks__db_cache_release(&t);
        start = ids[0];
    }
    for (size_t i = 0; i < count && st == PHKS_OK; i++) {
        if (t.count && phks__db_pack_bytes(&t) >= PACK_CHUNK_BYTES) {
            st = write_chunk(db, start, &t, 0, t.count);
            phks__db_cache_release(&t);
            start = ids[i];
        }
        if (st != PHKS_OK)
            break;
        st = phks__db_cache_append(&t, ids[i], entries[i].name,
                                   entries[i].label, entries[i].signature);
        if (st == PHKS_ERROR_OUT_OF_MEMORY)
            st = phks__fail_oom("database pack");
        else if (st != PHKS_OK) { /* out of order or another length */
            *kept = false;
            st = PHKS_OK;
            break;
        }
    }
    if (st == PHKS_OK && *kept && t.count)
        st = write_chunk(db, start, &t, 0, t.count);
    phks__db_cache_release(&t);
    return st;
}

phks_status phks__db_pack_append(phks_db *db, const phks_db_entry *entries,
                                 const int64_t *ids, size_t count)
{
    bool kept;
    phks_status st = append_entries(db, entries, ids, count, &kept);
    return st == PHKS_OK && kept ? mark_current(db, 0, false) : st;
}

phks_status phks__db_pack_remove(phks_db *db, int64_t id)
{
    phks__db_cache t;
    phks__db_cache_init(&t);
    int64_t start = 0;
    bool found;
    phks_status st = read_chunk(db, id, &t, &start, &found);
    bool kept = st == PHKS_OK && found && phks__db_cache_find(&t, id) < t.count;
    if (st == PHKS_ERROR_CORRUPT)
        st = PHKS_OK;
    if (st == PHKS_OK && kept) {
        phks__db_cache_remove(&t, id);
        st = t.count > t.dead
                 ? write_chunk(db, start, &t, 0, t.count)
                 : phks__db_exec_id(db, "DELETE FROM packs WHERE start = ?1",
                                    start, "cannot remove a pack chunk");
    }
    phks__db_cache_release(&t);
    return st == PHKS_OK && kept ? mark_current(db, 0, false) : st;
}

/* ---- loading */

typedef struct blob_reader {
    phks_db *db;
    sqlite3_blob *blob;
} blob_reader;

static phks_status read_blob(void *ctx, void *dst, size_t n, size_t offset)
{
    blob_reader *r = ctx;
    if (n == 0)
        return PHKS_OK;
    if (n > INT_MAX || offset > INT_MAX)
        return PHKS_ERROR_CORRUPT;
    int rc = sqlite3_blob_read(r->blob, dst, (int)n, (int)offset);
    return rc == SQLITE_OK
               ? PHKS_OK
               : phks__db_sql_fail(r->db, rc, "cannot read a pack chunk");
}

/* The chunks' totals, against the rows ps counts; they also size the
 * cache. *max_id: the highest row's id. */
static phks_status check_totals(phks_db *db, const phks__db_pack_state *ps,
                                int64_t *max_id)
{
    sqlite3_stmt *stmt;
    phks_status st = phks__db_prepare(db,
                                      "SELECT count(*), total(entries),"
                                      " total(vectors), total(text),"
                                      " (SELECT max(id) FROM entries)"
                                      " FROM packs",
                                      &stmt);
    if (st != PHKS_OK)
        return st;
    int rc = sqlite3_step(stmt);
    double entries = 0, vectors = 0, text = 0;
    *max_id = 0;
    if (rc == SQLITE_ROW) {
        entries = sqlite3_column_double(stmt, 1);
        vectors = sqlite3_column_double(stmt, 2);
        text = sqlite3_column_double(stmt, 3);
        *max_id = sqlite3_column_int64(stmt, 4);
    } else {
        st = phks__db_sql_fail(db, rc == SQLITE_DONE ? SQLITE_CORRUPT : rc,
                               "cannot read the packs");
    }
    sqlite3_finalize(stmt);
    if (st != PHKS_OK)
        return st;
    /* The totals only size the cache (the chunks are checked one by one):
     * when that much memory is not there, the chunks' reads find out
     * whether it was needed. */
    if (entries != (double)ps->rows || (ps->rows && !db->has_options))
        return PHKS_ERROR_CORRUPT;
    if (vectors >= 0 && text >= 0 && vectors < 1e15 && text < 1e15)
        (void)phks__db_cache_reserve(&db->cache, (size_t)entries,
                                     (size_t)vectors, (size_t)text);
    return PHKS_OK;
}

/* Appends the chunk that starts at start, of `entries` entries, to the
 * cache, through r (its blob opened on the first chunk). */
static phks_status load_chunk(phks_db *db, blob_reader *r, int64_t start,
                              int64_t entries)
{
    size_t before = db->cache.count;
    int rc = r->blob ? sqlite3_blob_reopen(r->blob, start)
                     : sqlite3_blob_open(db->conn, "main", "packs", "data",
                                         start, 0, &r->blob);
    if (rc != SQLITE_OK)
        return phks__db_sql_status(rc) == PHKS_ERROR_CORRUPT
                   ? PHKS_ERROR_CORRUPT
                   : phks__db_sql_fail(db, rc, "cannot open a pack chunk");
    phks_status st = phks__db_pack_decode(&db->cache, start,
                                          (size_t)sqlite3_blob_bytes(r->blob),
                                          read_blob, r);
    if (st == PHKS_ERROR_OUT_OF_MEMORY)
        return phks__fail_oom("database cache");
    if (st == PHKS_OK && (db->cache.count - before != (size_t)entries ||
                          db->cache.length != (size_t)db->options.scale_count))
        return PHKS_ERROR_CORRUPT;
    return st;
}

phks_status phks__db_pack_load(phks_db *db, const phks__db_pack_state *ps)
{
    int64_t max_id;
    sqlite3_stmt *stmt;
    phks_status st = check_totals(db, ps, &max_id);
    if (st != PHKS_OK ||
        (st = phks__db_prepare(db,
                               "SELECT start, entries FROM packs ORDER BY start",
                               &stmt)) != PHKS_OK)
        return st;
    blob_reader r = {db, NULL};
    int rc = SQLITE_DONE;
    while (st == PHKS_OK && (rc = sqlite3_step(stmt)) == SQLITE_ROW)
        st = load_chunk(db, &r, sqlite3_column_int64(stmt, 0),
                        sqlite3_column_int64(stmt, 1));
    if (st == PHKS_OK && rc != SQLITE_DONE)
        st = phks__db_sql_status(rc) == PHKS_ERROR_CORRUPT
                 ? PHKS_ERROR_CORRUPT
                 : phks__db_sql_fail(db, rc, "cannot read the packs");
    sqlite3_blob_close(r.blob);
    sqlite3_finalize(stmt);
    /* Every row, and no other: as many entries as rows counted, and the
     * last id the highest row's. */
    if (st == PHKS_OK &&
        (db->cache.count != (size_t)ps->rows ||
         (db->cache.count ? db->cache.ids[db->cache.count - 1] : 0) != max_id))
        st = PHKS_ERROR_CORRUPT;
    return st;
}
