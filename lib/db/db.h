/*
 * db.h - the database layer's own declarations: the handle, the packed
 * copy of its entries that queries scan (db_scan.c), the chunks that
 * copy is kept in inside the file (db_pack.c) and the verified stage
 * (db_rerank.c). Private to the layer (and its tests).
 */
#ifndef PHKS_DB_H
#define PHKS_DB_H

#include "features/features.h"

#include <pthread.h>
#include <sqlite3.h>

/* ---- the packed copy (db_scan.c) */
/* The packed copy of a database's entries that queries scan. Entries stay
 * in ascending id order. Entry e's feature vectors form one block at
 * vectors + vector_at[e]: `length` rows (one per scale) of
 * phks__db_padded(features[e]) values (one per feature), the padding lanes
 * +infinity. text + text_at[e] holds "name\0label\0", each cut to
 * PHKS_DB_TEXT_MAX bytes. Removed entries keep their slot with features 0
 * until more than half the slots are dead. Not locked by itself: db.c
 * guards it with a read-write lock. */
typedef struct phks__db_cache {
    size_t count, dead, capacity; /* slots used, removed, allocated     */
    size_t length;                /* vector length; 0 until the first   */
    uint32_t max_features;        /* largest features[e] ever added     */
    int64_t *ids;
    uint32_t *features;
    size_t *vector_at, *text_at;
    double *vectors;
    size_t vectors_used, vectors_capacity; /* in doubles                */
    char *text;
    size_t text_used, text_capacity;
} phks__db_cache;

/* Feature count rounded up to the scan's lane count. */
size_t phks__db_padded(size_t features);
/* An empty cache; release frees it and leaves it empty. */
void phks__db_cache_init(phks__db_cache *cache);
void phks__db_cache_release(phks__db_cache *cache);
/* Appends an entry whose id is above every id held, with vectors of the
 * same length as the others. Returns PHKS_ERROR_OUT_OF_MEMORY (the cache
 * is left as it was) or PHKS_ERROR_INVALID_ARGUMENT (id below 1 or out of
 * order, other length, no features) without setting a message: the caller,
 * whose own call may still succeed, decides what to report. */
phks_status phks__db_cache_append(phks__db_cache *cache, int64_t id,
                                 const char *name, const char *label,
                                 const phks_signature *signature);
/* Marks entry id removed (no-op if absent); compacts in place. */
void phks__db_cache_remove(phks__db_cache *cache, int64_t id);
/* The k best entries for query, as phks_db_query documents; the query's
 * vector length must be the cache's. Safe from many threads at once. */
phks_status phks__db_cache_query(const phks__db_cache *cache,
                                const phks_signature *query, size_t k,
                                phks_hit *hits, size_t *count);

/* ---- the handle (db.c) */
/* Locking: `lock` serialises everything that touches the connection (one
 * SQLite connection cannot hold two transactions) and guards the options
 * and the cache's state; `cache_lock` lets many queries scan the cache at
 * once while a write or a reload changes it. Order: lock, then
 * cache_lock; a scan holds cache_lock alone. */
struct phks_db {
    sqlite3 *conn;
    char *path;          /* as given, for messages */
    bool readonly;
    int format;          /* the file's user_version: 1 (read-only) or 2 */
    bool use_pack;       /* format 2 and a file: keep the packs table    */
    pthread_mutex_t lock;
    pthread_rwlock_t cache_lock;
    bool lock_ready, cache_lock_ready;
    sqlite3_stmt *version; /* PRAGMA data_version */
    bool has_options;    /* the options are set once and never change */
    phks_options options;
    bool cache_loaded;
    int64_t cache_version;
    phks__db_cache cache;
};

/* ---- the verified stage (db_rerank.c) */
/* Entries the packed scan hands to the verified score: re-ranking 100
 * instead changes no answer of the benchmark (docs/retrieval.md), and
 * each costs a verification (docs/benchmarks.md). */
#define PHKS__DB_SHORTLIST 32
/* Scores shortlist's m entries (read from db) by the verified score of
 * query, and returns the k best as phks_db_query does; entries removed
 * since the scan are left out. shortlist is reordered. */
phks_status phks__db_rerank(phks_db *db, const phks_signature *query,
                            phks_hit *shortlist, size_t m, size_t k,
                            phks_hit *hits, size_t *count);

/* Makes room for `slots` more entries, `doubles` more vector values and
 * `text` more text bytes (PHKS_ERROR_OUT_OF_MEMORY; nothing is lost). */
phks_status phks__db_cache_reserve(phks__db_cache *cache, size_t slots,
                                  size_t doubles, size_t text);

/* ---- packed chunks (db_pack.c; docs/formats.md, "Packed chunks") */
/* The persisted form of a run of cache entries. */
/* Reads n bytes at offset of a chunk into dst; a status on failure. */
typedef phks_status (*phks__db_pack_read_fn)(void *ctx, void *dst, size_t n,
                                            size_t offset);
/* The chunk of the live entries of slots [begin, end) into a new *blob
 * (phks__free) of *size bytes holding *entries entries. Errors:
 * PHKS_ERROR_INVALID_ARGUMENT (no live entry), PHKS_ERROR_OUT_OF_MEMORY. */
phks_status phks__db_pack_encode(const phks__db_cache *cache, size_t begin,
                                size_t end, unsigned char **blob,
                                size_t *size, size_t *entries);
/* About the bytes the chunk of every slot of cache would take. */
size_t phks__db_pack_bytes(const phks__db_cache *cache);
/* Appends the entries of a chunk of `size` bytes, read through read, to
 * cache: their ids must be at least start and above every id held. On
 * PHKS_ERROR_CORRUPT (checksum, layout or order wrong; no message set),
 * PHKS_ERROR_OUT_OF_MEMORY (no message) or the reader's status, the
 * cache holds what it held. */
phks_status phks__db_pack_decode(phks__db_cache *cache, int64_t start,
                                size_t size, phks__db_pack_read_fn read,
                                void *ctx);

/* For the tests (db.c): how many loads of a handle's cache, since the
 * process started, read the packed chunks, and how many decoded the rows. */
void phks__db_load_counts(unsigned long *from_pack, unsigned long *from_rows);

#endif /* PHKS_DB_H */
