/*
 * db_load.c - keeping a handle's packed copy (db_scan.c) the file's:
 * loading it, from the packed chunks when they are current (db_pack_table.c)
 * else from the rows, and noticing when another connection changed the
 * file.
 *
 * Refresh: PRAGMA data_version changes when another connection (this
 * process or another) commits. Each query compares it with the value read
 * when the cache was loaded (one prepared statement, no work per entry)
 * and reloads on a change. This handle's own writes leave data_version as
 * it is and update the cache in place (db_write.c).
 */
#include "db/db.h"

#include <stdatomic.h>
#include <stdio.h>

/* Loads that read the chunks, and loads that decoded the rows. */
static atomic_ulong loads_from_pack, loads_from_rows;

void phks__db_load_counts(unsigned long *from_pack, unsigned long *from_rows)
{
    *from_pack = atomic_load(&loads_from_pack);
    *from_rows = atomic_load(&loads_from_rows);
}

static phks_status data_version(phks_db *db, int64_t *version)
{
    int rc = sqlite3_step(db->version);
    if (rc == SQLITE_ROW)
        *version = sqlite3_column_int64(db->version, 0);
    phks_status st = rc == SQLITE_ROW
                         ? PHKS_OK
                         : phks__db_sql_fail(db, rc, "cannot read data_version");
    sqlite3_reset(db->version);
    return st;
}

void phks__db_drop_cache(phks_db *db)
{
    phks__db_cache_release(&db->cache);
    db->cache_loaded = false;
}

/* Appends the row of entry id (its signature decoded) to the cache; what
 * names the entry in messages. */
static phks_status append_row(phks_db *db, int64_t id, const char *what,
                              const char *name, const char *label,
                              const phks_signature *sig)
{
    phks_status st;
    if (!db->has_options ||
        !phks__options_comparable(&sig->options, &db->options))
        st = phks__fail(PHKS_ERROR_CORRUPT,
                        "%s: %s was made with other options than the "
                        "database's",
                        db->path, what);
    else if (!name && sqlite3_errcode(db->conn) == SQLITE_NOMEM)
        st = phks__fail_oom("database cache");
    else
        st = phks__db_cache_append(&db->cache, id, name ? name : "", label,
                                   sig);
    if (st == PHKS_ERROR_OUT_OF_MEMORY)
        return phks__fail_oom("database cache");
    if (st == PHKS_ERROR_INVALID_ARGUMENT)
        return id < 1 ? phks__db_id_below_one(db, id)
                      : phks__fail(PHKS_ERROR_CORRUPT,
                                   "%s: %s is out of place", db->path, what);
    return st;
}

/* Inside a read transaction, into the empty cache: every row, decoded. */
static phks_status load_rows(phks_db *db)
{
    sqlite3_stmt *stmt;
    phks_status st = phks__db_prepare(db,
                                      "SELECT id, name, label, signature"
                                      " FROM entries ORDER BY id",
                                      &stmt);
    if (st != PHKS_OK)
        return st;
    while (st == PHKS_OK) {
        int rc = sqlite3_step(stmt);
        if (rc == SQLITE_DONE)
            break;
        if (rc != SQLITE_ROW) {
            st = phks__db_sql_fail(db, rc, "cannot read the entries");
            break;
        }
        int64_t id = sqlite3_column_int64(stmt, 0);
        char what[64];
        snprintf(what, sizeof what, "entry %lld", (long long)id);
        phks_signature *sig;
        st = phks__db_decode_stored(db, sqlite3_column_blob(stmt, 3),
                                    sqlite3_column_bytes(stmt, 3), what, &sig);
        if (st != PHKS_OK)
            break;
        const char *name = (const char *)sqlite3_column_text(stmt, 1);
        const char *label = (const char *)sqlite3_column_text(stmt, 2);
        st = append_row(db, id, what, name, label, sig);
        phks_signature_free(sig);
    }
    sqlite3_finalize(stmt);
    return st;
}

/* Inside a read transaction, into the empty cache: from the chunks when
 * they are current, else from the rows. *ps: pack_state as read;
 * *from_rows tells which. */
static phks_status load(phks_db *db, phks__db_pack_state *ps, bool *from_rows)
{
    phks_status st = db->has_options ? PHKS_OK : phks__db_read_options(db);
    *from_rows = true;
    if (st == PHKS_OK && db->use_pack)
        st = phks__db_pack_state_read(db, ps);
    if (st == PHKS_OK && db->use_pack && phks__db_pack_current(ps)) {
        st = phks__db_pack_load(db, ps);
        *from_rows = st == PHKS_ERROR_CORRUPT;
        if (*from_rows) {
            phks__db_drop_cache(db);
            st = PHKS_OK;
        }
    }
    return st == PHKS_OK && *from_rows ? load_rows(db) : st;
}

/* Reads every entry into a new cache in one read transaction. Called
 * with lock held; takes cache_lock. */
static phks_status reload(phks_db *db)
{
    pthread_rwlock_wrlock(&db->cache_lock);
    phks__db_drop_cache(db);
    int64_t version = 0;
    phks__db_pack_state ps = {0};
    bool from_rows = true;
    phks_status st = phks__db_begin(db, false);
    if (st == PHKS_OK)
        st = load(db, &ps, &from_rows);
    /* Read inside the transaction: the version of the state just read. */
    if (st == PHKS_OK)
        st = data_version(db, &version);
    st = phks__db_end(db, st);
    if (st == PHKS_OK) {
        db->cache_loaded = true;
        db->cache_version = version;
        atomic_fetch_add(from_rows ? &loads_from_rows : &loads_from_pack, 1);
    } else {
        phks__db_drop_cache(db);
    }
    pthread_rwlock_unlock(&db->cache_lock);
    /* No writer can change the cache while lock is held: it is read
     * without cache_lock, and queries may scan it meanwhile. */
    if (st == PHKS_OK && from_rows && db->use_pack && !db->readonly)
        phks__db_pack_persist(db, ps.changes);
    return st;
}

phks_status phks__db_refresh(phks_db *db)
{
    int64_t version = 0;
    phks_status st = data_version(db, &version);
    if (st != PHKS_OK || (db->cache_loaded && version == db->cache_version))
        return st;
    return reload(db);
}
