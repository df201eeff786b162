/*
 * phks_pg_key.c - the type phks_key: the part of a signature that the
 * first stage of a query reads (docs/postgres.md, "Large tables").
 *
 * A verified signature takes 6.5 KB, and decoding one (its checksum, its
 * layout) costs more than scoring it: a scan that shortlists a million
 * rows by sig <#> q reads and decodes 6.5 GB. A key keeps the feature
 * vectors as plain doubles beside the options that shape them, about
 * 1.9 KB with the defaults, so that four fit in a page and a row is
 * scored where it lies, with phks_score_nearest_vectors: the same number
 * as sig <#> q, bit for bit.
 *
 * A key is made by phks_key(sig) and checked whenever it comes in as
 * text or binary; its bytes are the server's own (native byte order),
 * like a float8's in a page. Keys and queries made with different options
 * refuse to be compared, naming the option.
 *
 * The local descriptor (0.3.0) sits in what was the header's padding
 * before the options, which 0.2.0's keys hold as zero (palloc0): HEAT,
 * what their signatures were made with, so that their bytes, size and
 * version stay valid keys and compare as they did. A key records it only
 * for VERIFIED signatures (0 with NEAREST, which ignores it), as
 * phks_options_compare compares it only there.
 *
 * The global descriptor (0.3.0) is not recorded: the header has no
 * padding left, and a field would move the options and turn every stored
 * key into one of another version. It changes none of the vectors a key
 * holds, so key <#> q scores keys of either, and the second stage,
 * sig <~> q on the shortlist's signatures, refuses a mixed pair with the
 * library's message (docs/postgres.md, "Large tables").
 */
#include "phks_pg.h"

#include <math.h>
#include <string.h>

#include "libpq/pqformat.h"
#include "utils/memutils.h"

#define KEY_MAGIC 0x4b4b4850u /* "PHKK" */
#define KEY_VERSION 1

/* The options a signature's numbers depend on (those phks_options(sig)
 * lists), the scales as a hash of their bits. */
typedef struct key_options {
    uint64 scales_hash;
    double tau, cutoff, feature_scale, boundary_margin;
    uint32 eigen_count, feature_count, scale_count;
    int32 operator_kind, box, hks_scaling, quadrature, matching;
} key_options;

struct phks_pg_key {
    int32 vl_len_;
    uint32 magic;
    uint32 version;
    uint32 count, length; /* count vectors of length doubles */
    int32 local_descriptor; /* VERIFIED: phks_local_descriptor; else 0 */
    key_options options;
    double vectors[FLEXIBLE_ARRAY_MEMBER];
};

/* The local descriptor took the padding before the options: the layout
 * of 0.2.0's keys, which stored tables hold, is unchanged. */
StaticAssertDecl(offsetof(phks_pg_key, local_descriptor) == 20 &&
                     offsetof(phks_pg_key, options) == 24,
                 "phks_key's layout moved");

#define FIELD(name, member) \
    {name, offsetof(key_options, member), sizeof(((key_options *)0)->member)}

static const struct key_field {
    const char *name;
    size_t offset, size;
} key_fields[] = {
    FIELD("tau", tau),
    FIELD("cutoff", cutoff),
    FIELD("eigen_count", eigen_count),
    FIELD("feature_count", feature_count),
    FIELD("scales", scale_count),
    FIELD("scales", scales_hash),
    FIELD("feature_scale", feature_scale),
    FIELD("operator_kind", operator_kind),
    FIELD("box", box),
    FIELD("boundary_margin", boundary_margin),
    FIELD("hks_scaling", hks_scaling),
    FIELD("quadrature", quadrature),
    FIELD("matching", matching),
};

static size_t key_size(size_t count, size_t length)
{
    return offsetof(phks_pg_key, vectors) + count * length * sizeof(double);
}

/* FNV-1a over the scales' bits: equal scales, equal hashes. */
static uint64 scales_hash(const double *scales, uint32 count)
{
    uint64 h = UINT64CONST(14695981039346656037);
    const unsigned char *p = (const unsigned char *)scales;
    for (size_t i = 0; i < count * sizeof *scales; i++)
        h = (h ^ p[i]) * UINT64CONST(1099511628211);
    return h;
}

static key_options options_of(const phks_options *o)
{
    key_options k;
    memset(&k, 0, sizeof k); /* padding too: keys compare by their bytes */
    k.scale_count = o->scale_count;
    k.scales_hash = scales_hash(o->scales, o->scale_count);
    k.tau = o->tau;
    k.cutoff = o->cutoff;
    k.feature_scale = o->feature_scale;
    k.boundary_margin = o->boundary_margin;
    k.eigen_count = o->eigen_count;
    k.feature_count = o->feature_count;
    k.operator_kind = (int32)o->operator_kind;
    k.box = (int32)o->box;
    k.hks_scaling = (int32)o->hks_scaling;
    k.quadrature = (int32)o->quadrature;
    k.matching = (int32)o->matching;
    return k;
}

/* The key of sig, palloc'd in the current memory context. */
static phks_status key_of(const phks_signature *sig, phks_pg_key **out)
{
    phks_options o;
    phks_status st = phks_signature_options(sig, &o);
    if (st != PHKS_OK)
        return st;
    size_t count = phks_signature_feature_count(sig);
    size_t length = phks_signature_vector_length(sig);
    size_t size = key_size(count, length);
    phks_pg_key *key = palloc0(size);
    SET_VARSIZE(key, size);
    key->magic = KEY_MAGIC;
    key->version = KEY_VERSION;
    key->count = (uint32)count;
    key->length = (uint32)length;
    key->options = options_of(&o);
    key->local_descriptor = o.matching == PHKS_MATCHING_VERIFIED
                                ? (int32)o.local_descriptor
                                : PHKS_LOCAL_DESCRIPTOR_HEAT;
    for (size_t i = 0; i < count; i++)
        memcpy(key->vectors + i * length, phks_signature_feature_vector(sig, i),
               length * sizeof(double));
    *out = key;
    return PHKS_OK;
}

/* Why the header of key does not describe size bytes, or NULL: in
 * constant time, the vectors unread. */
static const char *key_header_problem(const phks_pg_key *key, size_t size)
{
    size_t fixed = offsetof(phks_pg_key, vectors);
    if (size < fixed)
        return "shorter than its header";
    if (key->magic != KEY_MAGIC)
        return "not a phks_key";
    if (key->version != KEY_VERSION)
        return "a version this extension does not read";
    if (key->count == 0 || key->length == 0 ||
        key->length != key->options.scale_count ||
        key->length > PHKS_MAX_SCALES ||
        key->count > (MaxAllocSize - fixed) / (key->length * sizeof(double)) ||
        key_size(key->count, key->length) != size)
        return "its size does not match its vectors and options";
    if (key->local_descriptor != PHKS_LOCAL_DESCRIPTOR_HEAT &&
        (key->local_descriptor != PHKS_LOCAL_DESCRIPTOR_SPIN ||
         key->options.matching != PHKS_MATCHING_VERIFIED))
        return "an unknown local descriptor";
    return NULL;
}

/* Why the size bytes of key are not a whole key, or NULL. */
static const char *key_problem(const phks_pg_key *key, size_t size)
{
    const char *problem = key_header_problem(key, size);
    if (problem)
        return problem;
    for (size_t i = 0; i < (size_t)key->count * key->length; i++)
        if (!isfinite(key->vectors[i]))
            return "a vector entry is not finite";
    return NULL;
}

/* A key made of the n bytes at data (a key without its length word),
 * checked. */
static phks_pg_key *key_from_bytes(const char *data, size_t n)
{
    size_t size = VARHDRSZ + n;
    phks_pg_key *key = palloc0(Max(size, sizeof(phks_pg_key)));
    memcpy(VARDATA(key), data, n);
    SET_VARSIZE(key, size);
    const char *problem = key_problem(key, size);
    if (problem)
        ereport(ERROR, (errcode(ERRCODE_DATA_CORRUPTED),
                        errmsg("phks_key: %s", problem)));
    return key;
}

PG_FUNCTION_INFO_V1(phks_key_in);
Datum phks_key_in(PG_FUNCTION_ARGS)
{
    size_t n;
    char *raw = phks_pg_hex_decode(PG_GETARG_CSTRING(0), "phks_key", &n);
    phks_pg_key *key = key_from_bytes(raw, n);
    pfree(raw);
    PG_RETURN_POINTER(key);
}

PG_FUNCTION_INFO_V1(phks_key_out);
Datum phks_key_out(PG_FUNCTION_ARGS)
{
    phks_pg_key *key = (phks_pg_key *)PG_DETOAST_DATUM(PG_GETARG_DATUM(0));
    PG_RETURN_CSTRING(
        phks_pg_hex_encode(VARDATA(key), VARSIZE(key) - VARHDRSZ));
}

PG_FUNCTION_INFO_V1(phks_key_recv);
Datum phks_key_recv(PG_FUNCTION_ARGS)
{
    StringInfo buf = (StringInfo)PG_GETARG_POINTER(0);
    int n = buf->len - buf->cursor;
    PG_RETURN_POINTER(key_from_bytes(pq_getmsgbytes(buf, n), (size_t)n));
}

PG_FUNCTION_INFO_V1(phks_key_send);
Datum phks_key_send(PG_FUNCTION_ARGS)
{
    phks_pg_key *key = (phks_pg_key *)PG_DETOAST_DATUM(PG_GETARG_DATUM(0));
    size_t n = VARSIZE(key) - VARHDRSZ;
    bytea *out = palloc(VARHDRSZ + n);
    SET_VARSIZE(out, VARHDRSZ + n);
    memcpy(VARDATA(out), VARDATA(key), n);
    PG_RETURN_BYTEA_P(out);
}

/* The key of a signature, or the library's error (sig is freed first
 * when owned). */
static phks_pg_key *key_or_error(phks_signature *sig, bool owned,
                                 const char *what)
{
    phks_pg_key *key = NULL;
    phks_status st = key_of(sig, &key);
    if (st != PHKS_OK) {
        char *msg = phks_pg_last_message(st);
        if (owned)
            phks_signature_free(sig);
        phks_pg_error(st, what, msg);
    }
    if (owned)
        phks_signature_free(sig);
    return key;
}

/* phks_key(sig): the key of a signature. */
PG_FUNCTION_INFO_V1(phks_pg_key_of);
Datum phks_pg_key_of(PG_FUNCTION_ARGS)
{
    bytea *blob = PG_GETARG_BYTEA_PP(0);
    phks_signature *sig = phks_pg_decode(VARDATA_ANY(blob),
                                         VARSIZE_ANY_EXHDR(blob), "phks_key");
    PG_RETURN_POINTER(key_or_error(sig, true, "phks_key"));
}

/* Raises an error naming the first option in which keys a and b differ. */
static void check_options(const phks_pg_key *ka, const phks_pg_key *kb)
{
    const key_options *a = &ka->options, *b = &kb->options;
    bool same = memcmp(a, b, sizeof *a) == 0;
    if (same && ka->local_descriptor == kb->local_descriptor)
        return;
    /* After the options: a different matching is named first. */
    const char *name = same ? "local_descriptor" : "options";
    for (size_t i = 0; i < lengthof(key_fields); i++) {
        const char *pa = (const char *)a + key_fields[i].offset;
        const char *pb = (const char *)b + key_fields[i].offset;
        if (memcmp(pa, pb, key_fields[i].size) != 0) {
            name = key_fields[i].name;
            break;
        }
    }
    ereport(ERROR, (errcode(ERRCODE_INVALID_PARAMETER_VALUE),
                    errmsg("phks_score_nearest: the signatures were made with "
                           "different options (%s differs)", name)));
}

/* key <#> query: phks_score_nearest(query, signature of key), bit for bit
 * sig <#> query of the key's own signature. */
PG_FUNCTION_INFO_V1(phks_pg_key_distance);
Datum phks_pg_key_distance(PG_FUNCTION_ARGS)
{
    phks_pg_key *key = (phks_pg_key *)PG_DETOAST_DATUM(PG_GETARG_DATUM(0));
    /* Keys are checked on their way in, but a damaged page could still
     * hand over bytes whose count sends the score past their end. */
    const char *problem = key_header_problem(key, VARSIZE(key));
    if (problem)
        ereport(ERROR, (errcode(ERRCODE_DATA_CORRUPTED),
                        errmsg("phks_key: %s", problem)));
    bytea *blob = PG_GETARG_BYTEA_PP(1);
    phks_pg_key *qkey;
    if (fcinfo->flinfo) {
        query_cache *q = phks_pg_cached_query(fcinfo, blob,
                                              "phks_score_nearest");
        if (!q->key) {
            MemoryContext old = MemoryContextSwitchTo(fcinfo->flinfo->fn_mcxt);
            q->key = key_or_error(q->sig, false, "phks_score_nearest");
            MemoryContextSwitchTo(old);
        }
        qkey = q->key;
    } else {
        phks_signature *own = phks_pg_decode(
            VARDATA_ANY(blob), VARSIZE_ANY_EXHDR(blob), "phks_score_nearest");
        qkey = key_or_error(own, true, "phks_score_nearest");
    }
    check_options(qkey, key);
    double score;
    phks_status st = phks_score_nearest_vectors(
        qkey->vectors, qkey->count, key->vectors, key->count, key->length,
        &score);
    if (st != PHKS_OK)
        phks_pg_error(st, "phks_score_nearest", phks_pg_last_message(st));
    PG_RETURN_FLOAT8(score);
}
