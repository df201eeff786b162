/*
 * phks_pg_equal.c - equality of signatures: the btree and hash operator
 * classes of phks_signature, so that =, DISTINCT, GROUP BY, UNION and
 * hash joins work (docs/postgres.md, "Equality").
 *
 * Two signatures are equal when their blobs are: the library's encoder
 * writes one blob for one signature (no padding, no free field), and every
 * input is decoded before it is stored, so equal bytes are equal
 * signatures and unequal bytes unequal ones. The order (<, <=, >, >=) is
 * the bytes' (memcmp, then the shorter first): meaningless as shape
 * similarity, it only lets sorts group equal values.
 */
#include "phks_pg.h"

#include "common/hashfn.h"
#include "utils/fmgrprotos.h"

static int compare_blobs(FunctionCallInfo fcinfo)
{
    bytea *a = PG_GETARG_BYTEA_PP(0);
    bytea *b = PG_GETARG_BYTEA_PP(1);
    size_t na = VARSIZE_ANY_EXHDR(a), nb = VARSIZE_ANY_EXHDR(b);
    int c = memcmp(VARDATA_ANY(a), VARDATA_ANY(b), Min(na, nb));
    if (c == 0)
        c = na < nb ? -1 : na > nb ? 1 : 0;
    PG_FREE_IF_COPY(a, 0);
    PG_FREE_IF_COPY(b, 1);
    return c;
}

PG_FUNCTION_INFO_V1(phks_pg_cmp);
Datum phks_pg_cmp(PG_FUNCTION_ARGS)
{
    int c = compare_blobs(fcinfo);
    PG_RETURN_INT32(c < 0 ? -1 : c > 0 ? 1 : 0);
}

PG_FUNCTION_INFO_V1(phks_pg_eq);
Datum phks_pg_eq(PG_FUNCTION_ARGS)
{
    PG_RETURN_BOOL(compare_blobs(fcinfo) == 0);
}

PG_FUNCTION_INFO_V1(phks_pg_ne);
Datum phks_pg_ne(PG_FUNCTION_ARGS)
{
    PG_RETURN_BOOL(compare_blobs(fcinfo) != 0);
}

PG_FUNCTION_INFO_V1(phks_pg_lt);
Datum phks_pg_lt(PG_FUNCTION_ARGS)
{
    PG_RETURN_BOOL(compare_blobs(fcinfo) < 0);
}

PG_FUNCTION_INFO_V1(phks_pg_le);
Datum phks_pg_le(PG_FUNCTION_ARGS)
{
    PG_RETURN_BOOL(compare_blobs(fcinfo) <= 0);
}

PG_FUNCTION_INFO_V1(phks_pg_gt);
Datum phks_pg_gt(PG_FUNCTION_ARGS)
{
    PG_RETURN_BOOL(compare_blobs(fcinfo) > 0);
}

PG_FUNCTION_INFO_V1(phks_pg_ge);
Datum phks_pg_ge(PG_FUNCTION_ARGS)
{
    PG_RETURN_BOOL(compare_blobs(fcinfo) >= 0);
}

/* The hash of the blob's bytes, as bytea's. */
PG_FUNCTION_INFO_V1(phks_pg_hash);
Datum phks_pg_hash(PG_FUNCTION_ARGS)
{
    bytea *blob = PG_GETARG_BYTEA_PP(0);
    Datum h = hash_any((const unsigned char *)VARDATA_ANY(blob),
                       (int)VARSIZE_ANY_EXHDR(blob));
    PG_FREE_IF_COPY(blob, 0);
    return h;
}

PG_FUNCTION_INFO_V1(phks_pg_hash_extended);
Datum phks_pg_hash_extended(PG_FUNCTION_ARGS)
{
    bytea *blob = PG_GETARG_BYTEA_PP(0);
    Datum h = hash_any_extended((const unsigned char *)VARDATA_ANY(blob),
                                (int)VARSIZE_ANY_EXHDR(blob),
                                PG_GETARG_INT64(1));
    PG_FREE_IF_COPY(blob, 0);
    return h;
}
