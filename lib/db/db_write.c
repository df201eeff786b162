/*
 * db_write.c - adding and removing entries. Each call is one write
 * transaction: the rows, the options the first entry sets, and the
 * packed chunks (db_pack_table.c) commit together or not at all, and a batch
 * of a thousand entries costs one fsync, not a thousand.
 *
 * Entries are checked whole before the transaction starts, so a bad one
 * leaves the file as it was. After the commit this handle's cache takes
 * the change in place; other handles notice it by data_version
 * (db_load.c).
 */
#include "db/db.h"

#include <limits.h>
#include <stdio.h>
#include <string.h>

/* ---- checks */

/* Strict UTF-8: no overlong forms, surrogates or values above U+10FFFF. */
static bool valid_utf8(const char *s)
{
    const unsigned char *p = (const unsigned char *)s;
    while (*p) {
        uint32_t c = *p, min;
        size_t more;
        if (c < 0x80) {
            p++;
            continue;
        } else if ((c & 0xE0) == 0xC0) {
            more = 1, min = 0x80, c &= 0x1F;
        } else if ((c & 0xF0) == 0xE0) {
            more = 2, min = 0x800, c &= 0x0F;
        } else if ((c & 0xF8) == 0xF0) {
            more = 3, min = 0x10000, c &= 0x07;
        } else {
            return false;
        }
        for (size_t i = 1; i <= more; i++) {
            if ((p[i] & 0xC0) != 0x80) /* also stops at the NUL */
                return false;
            c = c << 6 | (p[i] & 0x3Fu);
        }
        if (c < min || c > 0x10FFFF || (c >= 0xD800 && c <= 0xDFFF))
            return false;
        p += more + 1;
    }
    return true;
}

static phks_status check_entry(const char *where, const phks_db_entry *e)
{
    if (!e->name || !e->signature)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: NULL %s", where,
                          e->name ? "signature" : "name");
    if (!valid_utf8(e->name))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "%s: the name is not valid UTF-8", where);
    if (e->label && !valid_utf8(e->label))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "%s: the label is not valid UTF-8", where);
    if (e->signature->count == 0)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "%s: the signature has no features", where);
    return PHKS_OK;
}

/* Where entry i of a call of fn is, for messages. */
static void where_of(char *where, size_t size, const char *fn, bool batch,
                     size_t i)
{
    if (batch)
        snprintf(where, size, "%s: entry %zu", fn, i);
    else
        snprintf(where, size, "%s", fn);
}

/* Each entry well formed, and all made with entry 0's options. */
static phks_status check_entries(const char *fn, bool batch,
                                 const phks_db_entry *entries, size_t count)
{
    char where[64], detail[128];
    for (size_t i = 0; i < count; i++) {
        where_of(where, sizeof where, fn, batch, i);
        phks_status st = check_entry(where, &entries[i]);
        if (st != PHKS_OK)
            return st;
        if (phks__options_difference(&entries[i].signature->options,
                                     &entries[0].signature->options, false,
                                     detail, sizeof detail))
            return phks__fail(PHKS_ERROR_INCOMPATIBLE,
                              "%s: made with other options than entry 0 (%s)",
                              where, detail);
    }
    return PHKS_OK;
}

/* ---- adding */

/* sig encoded into *blob (grown to *room bytes when short) as *size
 * bytes. */
static phks_status encode(const char *fn, const phks_signature *sig,
                          unsigned char **blob, size_t *room, size_t *size)
{
    *size = phks_signature_encoded_size(sig);
    if (*size > *room) {
        phks__free(*blob);
        *room = *size;
        if (!(*blob = phks__malloc(*room)))
            return phks__fail_oom("database entry");
    }
    phks_status st = phks_signature_encode(sig, *blob, *room, size);
    if (st == PHKS_OK && *size > INT_MAX)
        return phks__fail(PHKS_ERROR_TOO_LARGE, "%s: signature of %zu bytes",
                          fn, *size);
    return st;
}

/* Runs the insert statement for e, its signature encoded in blob; an
 * empty label is stored as NULL. */
static int insert_row(sqlite3_stmt *stmt, const phks_db_entry *e,
                      const unsigned char *blob, size_t size)
{
    bool no_label = !e->label || !*e->label;
    int rc = sqlite3_bind_text(stmt, 1, e->name, -1, SQLITE_STATIC);
    if (rc == SQLITE_OK)
        rc = no_label ? sqlite3_bind_null(stmt, 2)
                      : sqlite3_bind_text(stmt, 2, e->label, -1, SQLITE_STATIC);
    if (rc == SQLITE_OK)
        rc = sqlite3_bind_blob(stmt, 3, blob, (int)size, SQLITE_STATIC);
    if (rc == SQLITE_OK)
        rc = sqlite3_step(stmt);
    return rc;
}

/* Inserts the entries inside the open write transaction. */
static phks_status insert_all(phks_db *db, const char *fn, bool batch,
                              const phks_db_entry *entries, size_t count,
                              int64_t *ids)
{
    sqlite3_stmt *stmt;
    phks_status st = phks__db_prepare(db,
                                      "INSERT INTO entries (name, label,"
                                      " signature) VALUES (?1, ?2, ?3)",
                                      &stmt);
    unsigned char *blob = NULL;
    size_t room = 0, size;
    for (size_t i = 0; st == PHKS_OK && i < count; i++) {
        if ((st = encode(fn, entries[i].signature, &blob, &room, &size)) !=
            PHKS_OK)
            break;
        int rc = insert_row(stmt, &entries[i], blob, size);
        if (rc != SQLITE_DONE) {
            char where[64];
            where_of(where, sizeof where, fn, batch, i);
            st = phks__db_sql_fail(db, rc, where);
            break;
        }
        ids[i] = sqlite3_last_insert_rowid(db->conn);
        sqlite3_reset(stmt);
        sqlite3_clear_bindings(stmt);
    }
    sqlite3_finalize(stmt);
    phks__free(blob);
    return st;
}

/* The write transaction of an add, with lock held: the options settled
 * (*set: the first entry set them), the rows inserted, their ids into
 * ids, and the chunks brought along. */
static phks_status write_entries(phks_db *db, const char *fn, bool batch,
                                 const phks_db_entry *entries, size_t count,
                                 int64_t *ids, bool *set)
{
    phks__db_pack_state ps = {0};
    phks_status st = phks__db_begin(db, true);
    if (st != PHKS_OK)
        return st;
    st = phks__db_settle_options(db, fn, &entries[0].signature->options, set);
    if (st == PHKS_OK && db->use_pack)
        st = phks__db_pack_state_read(db, &ps);
    if (st == PHKS_OK)
        st = insert_all(db, fn, batch, entries, count, ids);
    /* Chunks that were current before stay so; stale ones stay stale (the
     * triggers counted these rows). */
    if (st == PHKS_OK && db->use_pack && phks__db_pack_current(&ps))
        st = phks__db_pack_append(db, entries, ids, count);
    return phks__db_end(db, st);
}

/* After the commit, with lock held: the cache, if loaded, takes the new
 * entries; when memory runs out it is dropped, and the next query
 * reloads it. */
static void cache_add(phks_db *db, const phks_db_entry *entries,
                      const int64_t *ids, size_t count)
{
    if (!db->cache_loaded)
        return;
    pthread_rwlock_wrlock(&db->cache_lock);
    for (size_t i = 0; i < count && db->cache_loaded; i++)
        if (phks__db_cache_append(&db->cache, ids[i], entries[i].name,
                                  entries[i].label,
                                  entries[i].signature) != PHKS_OK)
            phks__db_drop_cache(db);
    pthread_rwlock_unlock(&db->cache_lock);
}

static phks_status writable(const phks_db *db, const char *fn)
{
    return db->readonly ? phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                                     "%s: %s is open read-only", fn, db->path)
                        : PHKS_OK;
}

static phks_status add_entries(phks_db *db, const char *fn, bool batch,
                               const phks_db_entry *entries, size_t count,
                               int64_t *ids)
{
    if (!db || (count && !entries))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "%s: NULL argument", fn);
    phks_status st = writable(db, fn);
    if (st == PHKS_OK)
        st = check_entries(fn, batch, entries, count);
    if (st != PHKS_OK || count == 0)
        return st;
    int64_t *new_ids = phks__malloc_array(count, sizeof *new_ids);
    if (!new_ids)
        return phks__fail_oom(fn);

    pthread_mutex_lock(&db->lock);
    const phks_options *mine = &entries[0].signature->options;
    bool set = false;
    st = phks__db_check_options(db, fn, "signature", mine);
    if (st == PHKS_OK)
        st = write_entries(db, fn, batch, entries, count, new_ids, &set);
    if (st == PHKS_OK) {
        if (set) {
            db->options = *mine;
            db->has_options = true;
        }
        cache_add(db, entries, new_ids, count);
        if (ids)
            memcpy(ids, new_ids, count * sizeof *ids);
    }
    pthread_mutex_unlock(&db->lock);
    phks__free(new_ids);
    return st;
}

phks_status phks_db_add(phks_db *db, const char *name, const char *label,
                        const phks_signature *signature, int64_t *id)
{
    phks_db_entry e = {name, label, signature};
    return add_entries(db, "phks_db_add", false, &e, 1, id);
}

phks_status phks_db_add_batch(phks_db *db, const phks_db_entry *entries,
                              size_t count, int64_t *ids)
{
    return add_entries(db, "phks_db_add_batch", true, entries, count, ids);
}

/* ---- removing */

/* The write transaction of a removal, with lock held: the row and its
 * chunk. */
static phks_status delete_entry(phks_db *db, int64_t id)
{
    phks__db_pack_state ps = {0};
    phks_status st = phks__db_begin(db, true);
    if (st == PHKS_OK && db->use_pack)
        st = phks__db_pack_state_read(db, &ps);
    if (st == PHKS_OK)
        st = phks__db_exec_id(db, "DELETE FROM entries WHERE id = ?1", id,
                              "phks_db_remove");
    if (st == PHKS_OK && sqlite3_changes(db->conn) == 0)
        st = phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                        "phks_db_remove: no entry with id %lld", (long long)id);
    if (st == PHKS_OK && db->use_pack && phks__db_pack_current(&ps))
        st = phks__db_pack_remove(db, id);
    return phks__db_end(db, st);
}

phks_status phks_db_remove(phks_db *db, int64_t id)
{
    if (!db)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                          "phks_db_remove: NULL database");
    phks_status st = writable(db, "phks_db_remove");
    if (st != PHKS_OK)
        return st;
    pthread_mutex_lock(&db->lock);
    st = delete_entry(db, id);
    if (st == PHKS_OK && db->cache_loaded) {
        pthread_rwlock_wrlock(&db->cache_lock);
        phks__db_cache_remove(&db->cache, id);
        pthread_rwlock_unlock(&db->cache_lock);
    }
    pthread_mutex_unlock(&db->lock);
    return st;
}
