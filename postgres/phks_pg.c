/*
 * phks_pg.c - the PostgreSQL extension `phks` (docs/postgres.md): the type
 * phks_signature (the library's encoded blob), scoring, the operator <~>,
 * accessors; signatures computed from mesh bytes are in phks_pg_mesh.c.
 *
 * Public API only (include/phks.h). Every library handle is freed before
 * any ereport(ERROR) can leave the function: the library allocates with
 * malloc, which PostgreSQL's memory contexts do not clean up.
 */
#include "postgres.h"

#include <dlfcn.h>
#include <string.h>

#include "catalog/pg_type.h"
#include "common/shortest_dec.h"
#include "fmgr.h"
#include "lib/stringinfo.h"
#include "libpq/pqformat.h"
#include "mb/pg_wchar.h"
#include "miscadmin.h"
#include "utils/array.h"
#include "utils/builtins.h"
#include "utils/memutils.h"

#include "phks_pg.h"

PG_MODULE_MAGIC;

void _PG_init(void);

/* OpenBLAS threads have no place in a backend: computations run on the
 * backend's own thread (options.threads = 1) and BLAS on one thread too.
 * (The server's environment should also have OPENBLAS_NUM_THREADS=1, so
 * that OpenBLAS does not even start its pool: docs/postgres.md.) The
 * settings phks.* are defined here too. */
void _PG_init(void)
{
    phks_pg_define_mesh_limits();
    void (*set_threads)(int) = NULL;
    void *sym = dlsym(RTLD_DEFAULT, "openblas_set_num_threads");
    if (sym)
        memcpy(&set_threads, &sym, sizeof set_threads);
    if (set_threads)
        set_threads(1);
}

/* The SQLSTATE for a library status. */
static int pg_errcode_of(phks_status st)
{
    switch (st) {
    case PHKS_ERROR_OUT_OF_MEMORY:
        return ERRCODE_OUT_OF_MEMORY;
    case PHKS_ERROR_INCOMPATIBLE:
        return ERRCODE_INVALID_PARAMETER_VALUE;
    case PHKS_ERROR_CORRUPT:
    case PHKS_ERROR_TRUNCATED:
    case PHKS_ERROR_UNSUPPORTED_VERSION:
        return ERRCODE_INVALID_BINARY_REPRESENTATION;
    case PHKS_ERROR_UNKNOWN_FORMAT:
    case PHKS_ERROR_PARSE:
    case PHKS_ERROR_NON_FINITE:
    case PHKS_ERROR_INDEX_OUT_OF_RANGE:
    case PHKS_ERROR_NO_TRIANGLES:
    case PHKS_ERROR_ZERO_AREA:
    case PHKS_ERROR_TOO_LARGE:
        return ERRCODE_DATA_EXCEPTION;
    case PHKS_ERROR_CANCELLED:
        return ERRCODE_QUERY_CANCELED;
    case PHKS_ERROR_INVALID_ARGUMENT:
        return ERRCODE_INVALID_PARAMETER_VALUE;
    default:
        return ERRCODE_EXTERNAL_ROUTINE_EXCEPTION;
    }
}

char *phks_pg_last_message(phks_status st)
{
    const char *msg = phks_last_error_message();
    if (!msg || !*msg)
        msg = phks_status_string(st);
    return pstrdup(msg);
}

/* The library's messages start with the function that failed; where that
 * is the SQL function's own name, it is not said twice. */
void phks_pg_error(phks_status st, const char *what, char *msg)
{
    size_t n = strlen(what);
    bool named = strncmp(msg, what, n) == 0 && msg[n] == ':';
    ereport(ERROR, (errcode(pg_errcode_of(st)),
                    named ? errmsg("%s", msg) : errmsg("%s: %s", what, msg)));
    pg_unreachable();
}

phks_signature *phks_pg_decode(const void *data, size_t size,
                                       const char *what)
{
    phks_signature *sig = NULL;
    phks_status st = phks_signature_decode(data, size, &sig);
    if (st != PHKS_OK) {
        char *msg = phks_pg_last_message(st);
        phks_pg_error(st, what, msg);
    }
    return sig;
}

bytea *phks_pg_encode_and_free(phks_signature *sig, const char *what)
{
    size_t size = phks_signature_encoded_size(sig);
    bytea *out = (bytea *)palloc(VARHDRSZ + size);
    size_t written = 0;
    phks_status st = phks_signature_encode(sig, VARDATA(out), size, &written);
    if (st != PHKS_OK || written != size) {
        char *msg = st != PHKS_OK ? phks_pg_last_message(st)
                                  : pstrdup("encoded size changed");
        phks_signature_free(sig);
        phks_pg_error(st != PHKS_OK ? st : PHKS_ERROR_CORRUPT, what, msg);
    }
    phks_signature_free(sig);
    SET_VARSIZE(out, VARHDRSZ + size);
    return out;
}

/* The canonical blob of raw bytes: decoded (refused if damaged) and
 * encoded again, so that one signature has one stored form whatever wrote
 * it (an older format is stored as the current one) and equality can
 * compare bytes (phks_pg_equal.c). A current blob comes back unchanged. */
static bytea *canonical_copy(const char *data, size_t size, const char *what)
{
    return phks_pg_encode_and_free(phks_pg_decode(data, size, what), what);
}

/* ---------------------------------------------------------------------
 * Type I/O: text is the hex of the blob (an optional \x prefix is
 * accepted on input, as for bytea); binary is the blob itself.
 * ------------------------------------------------------------------- */
char *phks_pg_hex_decode(const char *text, const char *type, size_t *size)
{
    if (text[0] == '\\' && (text[1] == 'x' || text[1] == 'X'))
        text += 2;
    size_t len = strlen(text);
    if (len % 2 != 0)
        ereport(ERROR, (errcode(ERRCODE_INVALID_TEXT_REPRESENTATION),
                        errmsg("invalid input syntax for type %s: "
                               "odd number of hex digits", type)));
    char *raw = palloc(len / 2 + 1);
    for (size_t i = 0; i < len / 2; i++) {
        int v = 0;
        for (int h = 0; h < 2; h++) {
            const char *at = text + 2 * i + h;
            char c = *at;
            int d;
            if (c >= '0' && c <= '9')
                d = c - '0';
            else if (c >= 'a' && c <= 'f')
                d = c - 'a' + 10;
            else if (c >= 'A' && c <= 'F')
                d = c - 'A' + 10;
            else
                /* The whole character: its first byte alone would make
                 * the message invalid in a multibyte encoding. */
                ereport(ERROR,
                        (errcode(ERRCODE_INVALID_TEXT_REPRESENTATION),
                         errmsg("invalid input syntax for type %s: \"%.*s\" "
                                "is not a hex digit", type, pg_mblen(at), at)));
            v = v * 16 + d;
        }
        raw[i] = (char)v;
    }
    *size = len / 2;
    return raw;
}

char *phks_pg_hex_encode(const void *data, size_t size)
{
    const unsigned char *p = data;
    static const char digits[] = "0123456789abcdef";
    char *out = palloc(2 * size + 1);
    for (size_t i = 0; i < size; i++) {
        out[2 * i] = digits[p[i] >> 4];
        out[2 * i + 1] = digits[p[i] & 15];
    }
    out[2 * size] = '\0';
    return out;
}

PG_FUNCTION_INFO_V1(phks_signature_in);
Datum phks_signature_in(PG_FUNCTION_ARGS)
{
    size_t size;
    char *raw =
        phks_pg_hex_decode(PG_GETARG_CSTRING(0), "phks_signature", &size);
    bytea *out = canonical_copy(raw, size, "phks_signature");
    pfree(raw);
    PG_RETURN_BYTEA_P(out);
}

PG_FUNCTION_INFO_V1(phks_signature_out);
Datum phks_signature_out(PG_FUNCTION_ARGS)
{
    bytea *blob = PG_GETARG_BYTEA_PP(0);
    PG_RETURN_CSTRING(
        phks_pg_hex_encode(VARDATA_ANY(blob), VARSIZE_ANY_EXHDR(blob)));
}

PG_FUNCTION_INFO_V1(phks_signature_recv);
Datum phks_signature_recv(PG_FUNCTION_ARGS)
{
    StringInfo buf = (StringInfo)PG_GETARG_POINTER(0);
    int size = buf->len - buf->cursor;
    const char *data = pq_getmsgbytes(buf, size);
    PG_RETURN_BYTEA_P(canonical_copy(data, (size_t)size, "phks_signature"));
}

PG_FUNCTION_INFO_V1(phks_signature_send);
Datum phks_signature_send(PG_FUNCTION_ARGS)
{
    bytea *blob = PG_GETARG_BYTEA_P_COPY(0);
    PG_RETURN_BYTEA_P(blob);
}

/* bytea -> phks_signature, validated. */
PG_FUNCTION_INFO_V1(phks_signature_from_bytea);
Datum phks_signature_from_bytea(PG_FUNCTION_ARGS)
{
    bytea *blob = PG_GETARG_BYTEA_PP(0);
    PG_RETURN_BYTEA_P(canonical_copy(VARDATA_ANY(blob),
                                     VARSIZE_ANY_EXHDR(blob),
                                     "phks_signature"));
}

/* ---------------------------------------------------------------------
 * Scoring. The decoded signature of the second argument (the query, in
 * ORDER BY sig <~> $1) is kept between calls of the same expression,
 * keyed by its bytes, and freed with the expression's memory context.
 * ------------------------------------------------------------------- */
static void query_cache_free(void *arg)
{
    query_cache *cache = (query_cache *)arg;
    phks_signature_free(cache->sig);
    cache->sig = NULL;
}

query_cache *phks_pg_cached_query(FunctionCallInfo fcinfo, bytea *blob,
                          const char *name)
{
    query_cache *cache = (query_cache *)fcinfo->flinfo->fn_extra;
    const char *data = VARDATA_ANY(blob);
    size_t size = VARSIZE_ANY_EXHDR(blob);
    /* A constant or a parameter of the statement cannot change between
     * rows: its bytes need no comparing. */
    if (cache && cache->sig &&
        (cache->stable ||
         (cache->size == size && memcmp(cache->blob, data, size) == 0)))
        return cache;
    if (!cache) {
        cache = MemoryContextAllocZero(fcinfo->flinfo->fn_mcxt,
                                       sizeof *cache);
        cache->cb.func = query_cache_free;
        cache->cb.arg = cache;
        MemoryContextRegisterResetCallback(fcinfo->flinfo->fn_mcxt,
                                           &cache->cb);
        fcinfo->flinfo->fn_extra = cache;
        cache->stable = get_fn_expr_arg_stable(fcinfo->flinfo, 1);
    }
    phks_signature_free(cache->sig);
    cache->sig = NULL;
    if (cache->blob)
        pfree(cache->blob);
    cache->blob = NULL;
    if (cache->key)
        pfree(cache->key);
    cache->key = NULL;
    phks_signature *sig = phks_pg_decode(data, size, name);
    cache->blob = MemoryContextAlloc(fcinfo->flinfo->fn_mcxt, size ? size : 1);
    memcpy(cache->blob, data, size);
    cache->size = size;
    cache->sig = sig;
    return cache;
}

typedef phks_status (*score_fn)(const phks_signature *,
                                const phks_signature *, double *);

/* fn(first, second), or fn(second, first) with query_first, with second's
 * handle cached; the other argument decoded here and freed before any
 * error, which name names. */
static Datum score_args(FunctionCallInfo fcinfo, int query_first,
                        score_fn fn, const char *name)
{
    bytea *a_blob = PG_GETARG_BYTEA_PP(0);
    bytea *b_blob = PG_GETARG_BYTEA_PP(1);
    /* Without an flinfo (a direct call from C) there is nowhere to keep
     * the query: it is decoded here and freed with the other one. */
    phks_signature *own = NULL;
    const phks_signature *q;
    if (fcinfo->flinfo)
        q = phks_pg_cached_query(fcinfo, b_blob, name)->sig;
    else
        q = own = phks_pg_decode(VARDATA_ANY(b_blob),
                                  VARSIZE_ANY_EXHDR(b_blob), name);
    phks_signature *e = NULL;
    phks_status st = phks_signature_decode(VARDATA_ANY(a_blob),
                                           VARSIZE_ANY_EXHDR(a_blob), &e);
    double score = 0.0;
    if (st == PHKS_OK)
        st = query_first ? fn(q, e, &score) : fn(e, q, &score);
    if (st != PHKS_OK) {
        char *msg = phks_pg_last_message(st);
        phks_signature_free(e);
        phks_signature_free(own);
        phks_pg_error(st, name, msg);
    }
    phks_signature_free(e);
    phks_signature_free(own);
    PG_RETURN_FLOAT8(score);
}

/* phks_score(query, entry): the library's phks_score(query, entry). */
PG_FUNCTION_INFO_V1(phks_pg_score);
Datum phks_pg_score(PG_FUNCTION_ARGS)
{
    return score_args(fcinfo, 0, phks_score, "phks_score");
}

/* entry <~> query: the library's phks_score(query, entry), the very number
 * phks_db_query reports; the entry comes first so that the query, the
 * constant of an ORDER BY, is the argument cached. */
PG_FUNCTION_INFO_V1(phks_pg_distance);
Datum phks_pg_distance(PG_FUNCTION_ARGS)
{
    return score_args(fcinfo, 1, phks_score, "phks_score");
}

/* phks_score_nearest(a, b): the library's phks_score_nearest(a, b). */
PG_FUNCTION_INFO_V1(phks_pg_score_nearest);
Datum phks_pg_score_nearest(PG_FUNCTION_ARGS)
{
    return score_args(fcinfo, 0, phks_score_nearest, "phks_score_nearest");
}

/* entry <#> query: phks_score_nearest(query, entry), the number
 * phks_db_query's first stage ranks by (the two sums are added in that
 * order, so swapped arguments may differ in the last bit). */
PG_FUNCTION_INFO_V1(phks_pg_nearest_distance);
Datum phks_pg_nearest_distance(PG_FUNCTION_ARGS)
{
    return score_args(fcinfo, 1, phks_score_nearest, "phks_score_nearest");
}

/* ---------------------------------------------------------------------
 * Accessors
 * ------------------------------------------------------------------- */
static phks_signature *arg_signature(FunctionCallInfo fcinfo, int n,
                                     const char *what)
{
    bytea *blob = PG_GETARG_BYTEA_PP(n);
    return phks_pg_decode(VARDATA_ANY(blob), VARSIZE_ANY_EXHDR(blob), what);
}

PG_FUNCTION_INFO_V1(phks_pg_feature_count);
Datum phks_pg_feature_count(PG_FUNCTION_ARGS)
{
    phks_signature *sig = arg_signature(fcinfo, 0, "phks_feature_count");
    size_t n = phks_signature_feature_count(sig);
    phks_signature_free(sig);
    PG_RETURN_INT32((int32)n);
}

PG_FUNCTION_INFO_V1(phks_pg_vectors);
Datum phks_pg_vectors(PG_FUNCTION_ARGS)
{
    phks_signature *sig = arg_signature(fcinfo, 0, "phks_vectors");
    size_t count = phks_signature_feature_count(sig);
    size_t length = phks_signature_vector_length(sig);
    if (count == 0 || length == 0) {
        phks_signature_free(sig);
        PG_RETURN_ARRAYTYPE_P(construct_empty_array(FLOAT8OID));
    }
    Datum *values = palloc(sizeof(Datum) * count * length);
    for (size_t i = 0; i < count; i++) {
        const double *v = phks_signature_feature_vector(sig, i);
        for (size_t j = 0; j < length; j++)
            values[i * length + j] = Float8GetDatum(v ? v[j] : 0.0);
    }
    phks_signature_free(sig);
    int dims[2] = {(int)count, (int)length};
    int lbs[2] = {1, 1};
    PG_RETURN_ARRAYTYPE_P(construct_md_array(values, NULL, 2, dims, lbs,
                                             FLOAT8OID, sizeof(float8),
                                             FLOAT8PASSBYVAL,
                                             TYPALIGN_DOUBLE));
}

static void json_number(StringInfo out, const char *key, double v, int first)
{
    char buf[DOUBLE_SHORTEST_DECIMAL_LEN];
    double_to_shortest_decimal_buf(v, buf);
    appendStringInfo(out, "%s\"%s\": %s", first ? "" : ", ", key, buf);
}

/* An enum option as its number under its field's name and, beside it
 * under NAME_name, the value's name from the library's table (the C
 * spelling, as SQL identifiers are written: "local_area"), or null for a
 * value the table does not name. */
static void json_enum(StringInfo out, const char *key, int32_t value)
{
    uint32_t index;
    const char *name = NULL;
    if (phks_option_find(key, PHKS_SPELLING_C, &index) == PHKS_OK)
        name = phks_option_value_name(index, value, PHKS_SPELLING_C);
    appendStringInfo(out, ", \"%s\": %d, \"%s_name\": ", key, (int)value,
                     key);
    if (name)
        appendStringInfo(out, "\"%s\"", name);
    else
        appendStringInfoString(out, "null");
}

PG_FUNCTION_INFO_V1(phks_pg_options);
Datum phks_pg_options(PG_FUNCTION_ARGS)
{
    phks_signature *sig = arg_signature(fcinfo, 0, "phks_options");
    phks_options o;
    phks_status st = phks_signature_options(sig, &o);
    if (st != PHKS_OK) {
        char *msg = phks_pg_last_message(st);
        phks_signature_free(sig);
        phks_pg_error(st, "phks_options", msg);
    }
    phks_signature_free(sig);
    StringInfoData out;
    initStringInfo(&out);
    appendStringInfoChar(&out, '{');
    json_number(&out, "tau", o.tau, 1);
    json_number(&out, "cutoff", o.cutoff, 0);
    appendStringInfo(&out, ", \"eigen_count\": %u", (unsigned)o.eigen_count);
    appendStringInfo(&out, ", \"feature_count\": %u",
                     (unsigned)o.feature_count);
    appendStringInfoString(&out, ", \"scales\": [");
    for (uint32_t i = 0; i < o.scale_count && i < PHKS_MAX_SCALES; i++) {
        char buf[DOUBLE_SHORTEST_DECIMAL_LEN];
        double_to_shortest_decimal_buf(o.scales[i], buf);
        appendStringInfo(&out, "%s%s", i ? ", " : "", buf);
    }
    appendStringInfoChar(&out, ']');
    json_number(&out, "feature_scale", o.feature_scale, 0);
    json_enum(&out, "operator_kind", o.operator_kind);
    json_enum(&out, "box", o.box);
    json_number(&out, "boundary_margin", o.boundary_margin, 0);
    json_enum(&out, "hks_scaling", o.hks_scaling);
    json_enum(&out, "quadrature", o.quadrature);
    json_enum(&out, "matching", o.matching);
    json_enum(&out, "local_descriptor", o.local_descriptor);
    json_enum(&out, "global_descriptor", o.global_descriptor);
    appendStringInfoChar(&out, '}');
    /* json's representation is its text. */
    PG_RETURN_TEXT_P(cstring_to_text_with_len(out.data, out.len));
}
