/*
 * db_options.c - a database's options: every signature of a file was
 * made with the same ones, so a query's scores compare. The first entry
 * ever added sets them (meta 'options'); they never change after, so a
 * handle keeps them once read.
 *
 * The meta value is a signature blob with one all-zero feature that
 * carries the options: the signature codec (versioned, checked) stores
 * and validates them, and no second format is needed.
 */
#include "db/db.h"

#include <string.h>

/* The meta 'options' value for options, in a new *blob (phks__free). */
static phks_status options_blob(const phks_options *options, void **blob,
                                size_t *size)
{
    phks_signature *sig;
    phks_status st = phks__signature_alloc(1, 0, options->scale_count, &sig);
    if (st != PHKS_OK)
        return st;
    sig->options = *options;
    if (options->matching == PHKS_MATCHING_VERIFIED) {
        st = phks__signature_alloc_layout(sig);
        if (st != PHKS_OK) {
            phks_signature_free(sig);
            return st;
        }
        sig->boundary[0] = 0;
        /* Its zero histogram stands for a D2 signature's, as the zero
         * spin images alloc_layout gives for a SPIN one's. */
        sig->has_shape =
            options->global_descriptor == PHKS_GLOBAL_DESCRIPTOR_D2;
    }
    sig->vertex[0] = 0;
    memset(sig->position, 0, 3 * sizeof *sig->position);
    sig->persistence[0] = 0;
    memset(sig->vectors, 0, sig->length * sizeof *sig->vectors);
    *size = phks_signature_encoded_size(sig);
    *blob = phks__malloc(*size);
    if (!*blob)
        st = phks__fail_oom("database options");
    else
        st = phks_signature_encode(sig, *blob, *size, size);
    phks_signature_free(sig);
    return st;
}

phks_status phks__db_read_options(phks_db *db)
{
    sqlite3_stmt *stmt;
    phks_status st = phks__db_prepare(
        db, "SELECT value FROM meta WHERE key = 'options'", &stmt);
    if (st != PHKS_OK)
        return st;
    int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW) {
        phks_signature *sig;
        st = phks__db_decode_stored(db, sqlite3_column_blob(stmt, 0),
                                    sqlite3_column_bytes(stmt, 0),
                                    "meta 'options'", &sig);
        if (st == PHKS_OK) {
            db->options = sig->options;
            db->has_options = true;
            phks_signature_free(sig);
        }
    } else if (rc != SQLITE_DONE) {
        st = phks__db_sql_fail(db, rc, "cannot read the meta table");
    }
    sqlite3_finalize(stmt);
    return st;
}

phks_status phks__db_check_options(const phks_db *db, const char *fn,
                                   const char *what,
                                   const phks_options *options)
{
    char detail[128];
    if (db->has_options &&
        phks__options_difference(options, &db->options, false, detail,
                                 sizeof detail))
        return phks__fail(PHKS_ERROR_INCOMPATIBLE,
                          "%s: the %s was made with other options than the "
                          "database's (%s)",
                          fn, what, detail);
    return PHKS_OK;
}

/* Inserts the meta 'options' row for mine. */
static phks_status record_options(phks_db *db, const phks_options *mine)
{
    void *blob;
    size_t size;
    phks_status st = options_blob(mine, &blob, &size);
    if (st != PHKS_OK)
        return st;
    sqlite3_stmt *stmt;
    st = phks__db_prepare(
        db, "INSERT INTO meta (key, value) VALUES ('options', ?1)", &stmt);
    if (st == PHKS_OK) {
        int rc = sqlite3_bind_blob(stmt, 1, blob, (int)size, SQLITE_STATIC);
        if (rc == SQLITE_OK)
            rc = sqlite3_step(stmt);
        if (rc != SQLITE_DONE)
            st = phks__db_sql_fail(db, rc, "cannot record the options");
        sqlite3_finalize(stmt);
    }
    phks__free(blob);
    return st;
}

phks_status phks__db_settle_options(phks_db *db, const char *fn,
                                    const phks_options *mine, bool *set)
{
    *set = false;
    phks_status st = db->has_options ? PHKS_OK : phks__db_read_options(db);
    if (st != PHKS_OK)
        return st;
    if (db->has_options)
        return phks__options_comparable(mine, &db->options)
                   ? PHKS_OK
                   : phks__fail(PHKS_ERROR_INCOMPATIBLE,
                                "%s: the signature was made with other "
                                "options than the database's",
                                fn);
    st = record_options(db, mine);
    *set = st == PHKS_OK;
    return st;
}
