/*
 * phks_pg.h - what the extension's files share: errors raised with the
 * library's message, blobs decoded into handles, hex text, and the query
 * signature kept between the calls of one expression.
 */
#ifndef PHKS_PG_H
#define PHKS_PG_H

#include "postgres.h"

#include "fmgr.h"

#include "phks.h"

/* The library's message for the last failure, copied into palloc'd memory
 * (call it before freeing handles: a later failing call replaces it). */
char *phks_pg_last_message(phks_status st);

/* Raises the error of status st, "what: msg" (msg alone when it starts
 * with "what:"), with the SQLSTATE of st. Call it only once every library
 * handle is freed. */
void phks_pg_error(phks_status st, const char *what, char *msg)
    pg_attribute_noreturn();

/* Decodes a blob into a new library handle, or raises the decode error
 * (nothing to free then: decode leaves its output NULL on failure). */
phks_signature *phks_pg_decode(const void *data, size_t size,
                               const char *what);

/* A palloc'd varlena holding the encoded blob of sig; frees sig, also
 * when encoding fails, before raising the error (which what names). */
bytea *phks_pg_encode_and_free(phks_signature *sig, const char *what);

/* The bytes of hex text (an optional \x prefix is accepted, as for
 * bytea), palloc'd, into *size; a syntax error names type. */
char *phks_pg_hex_decode(const char *text, const char *type, size_t *size);
/* The hex text of size bytes, palloc'd. */
char *phks_pg_hex_encode(const void *data, size_t size);

/* Defines the settings phks.max_vertices and phks.max_mesh_size
 * (phks_pg_mesh.c), at load. */
void phks_pg_define_mesh_limits(void);

typedef struct phks_pg_key phks_pg_key;

/* The query signature, the second argument, decoded once per expression
 * (the constant side of ORDER BY sig <~> $1) in fn_extra: keyed by its
 * bytes, or for good where the argument is a constant or a parameter of
 * the statement; the handle is freed with the expression's memory
 * context. */
typedef struct query_cache {
    bool stable; /* the second argument is the same for every call */
    size_t size;
    char *blob;          /* in fn_mcxt */
    phks_signature *sig; /* library handle, freed by the reset callback */
    phks_pg_key *key;    /* its key (phks_pg_key.c), made on first use */
    MemoryContextCallback cb;
} query_cache;

query_cache *phks_pg_cached_query(FunctionCallInfo fcinfo, bytea *blob,
                                  const char *name);

#endif
