/*
 * db_pack.c - the packed copy's persisted form: a chunk of the packs table
 * (docs/formats.md, "Packed chunks") holds a run of entries exactly as the
 * cache lays them out (ids, feature counts, the padded vector blocks, the
 * cut names and labels), little-endian, with a checksum. Loading a chunk
 * is a read into place and a pass over it, not a decode of signatures.
 *
 * Checksum: two 64-bit sums (modulo 2^64) over the chunk's little-endian
 * 64-bit words, a = 1 + sum of the words and b = sum of the successive
 * values of a (Fletcher's construction): one addition chain per word,
 * so it runs at memory speed, and it catches flipped bits, zeroed or
 * swapped words. It guards against damage, not against a writer that
 * means harm.
 */
#include "db/db.h"

#include <string.h>

#define HEADER 32
#define TRAILER 16
#define PACK_VERSION 1

#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__)
#define HOST_LE (__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__)
#else
static bool host_le(void)
{
    const uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}
#define HOST_LE host_le()
#endif

static uint64_t get_le(const unsigned char *p, int bytes)
{
    uint64_t v = 0;
    for (int i = bytes - 1; i >= 0; i--)
        v = v << 8 | p[i];
    return v;
}

static void put_le(unsigned char *p, uint64_t v, int bytes)
{
    for (int i = 0; i < bytes; i++, v >>= 8)
        p[i] = (unsigned char)v;
}

static uint64_t bswap64(uint64_t v)
{
    uint64_t r = 0;
    for (int i = 0; i < 8; i++, v >>= 8)
        r = r << 8 | (v & 0xff);
    return r;
}

/* ---- checksum */

typedef struct sum {
    uint64_t a, b;
    unsigned char carry[8];
    size_t carried;
} sum;

static void sum_init(sum *s)
{
    s->a = 1;
    s->b = 0;
    s->carried = 0;
}

static void sum_words(sum *s, const unsigned char *p, size_t words)
{
    uint64_t a = s->a, b = s->b;
    if (HOST_LE) {
        for (size_t i = 0; i < words; i++) {
            uint64_t w;
            memcpy(&w, p + 8 * i, 8);
            a += w;
            b += a;
        }
    } else {
        for (size_t i = 0; i < words; i++) {
            a += get_le(p + 8 * i, 8);
            b += a;
        }
    }
    s->a = a;
    s->b = b;
}

/* Any run of bytes; the words span the runs. */
static void sum_bytes(sum *s, const void *data, size_t n)
{
    const unsigned char *p = data;
    if (s->carried) {
        size_t take = 8 - s->carried < n ? 8 - s->carried : n;
        memcpy(s->carry + s->carried, p, take);
        s->carried += take;
        p += take;
        n -= take;
        if (s->carried < 8)
            return;
        sum_words(s, s->carry, 1);
        s->carried = 0;
    }
    sum_words(s, p, n / 8);
    p += n / 8 * 8;
    s->carried = n % 8;
    memcpy(s->carry, p, s->carried);
}

/* ---- layout */

static size_t pad8(size_t n)
{
    return (n + 7) / 8 * 8;
}

/* Bytes of a chunk of n entries, or 0 on overflow. */
static size_t chunk_size(size_t n, size_t doubles, size_t text)
{
    if (n > SIZE_MAX / 16 || doubles > SIZE_MAX / 8 / 2 ||
        text > SIZE_MAX / 4)
        return 0;
    size_t head = HEADER + 8 * n + pad8(4 * n) + pad8(text) + TRAILER;
    if (8 * doubles > SIZE_MAX - head)
        return 0;
    return head + 8 * doubles;
}

size_t phks__db_pack_bytes(const phks__db_cache *c)
{
    return chunk_size(c->count, c->vectors_used, c->text_used);
}

/* The bytes "name\0label\0" of slot e take. */
static size_t text_of(const phks__db_cache *c, size_t e)
{
    const char *t = c->text + c->text_at[e];
    size_t n = strlen(t) + 1;
    return n + strlen(t + n) + 1;
}

phks_status phks__db_pack_encode(const phks__db_cache *c, size_t begin,
                                size_t end, unsigned char **blob,
                                size_t *size, size_t *entries)
{
    *blob = NULL;
    *size = 0;
    *entries = 0;
    size_t n = 0, doubles = 0, text = 0;
    for (size_t e = begin; e < end; e++)
        if (c->features[e]) {
            n++;
            doubles += phks__db_padded(c->features[e]) * c->length;
            text += text_of(c, e);
        }
    size_t bytes = chunk_size(n, doubles, text);
    if (n == 0 || bytes == 0 || n > UINT32_MAX || c->length > UINT32_MAX)
        return PHKS_ERROR_INVALID_ARGUMENT;
    unsigned char *out = phks__calloc(1, bytes), *p = out;
    if (!out)
        return PHKS_ERROR_OUT_OF_MEMORY;
    memcpy(p, "PHKP", 4);
    put_le(p + 4, PACK_VERSION, 2);
    put_le(p + 6, 0, 2);
    put_le(p + 8, n, 4);
    put_le(p + 12, c->length, 4);
    put_le(p + 16, doubles, 8);
    put_le(p + 24, text, 8);
    p += HEADER;
    unsigned char *ids = p, *features = ids + 8 * n,
                  *vectors = features + pad8(4 * n),
                  *texts = vectors + 8 * doubles;
    for (size_t e = begin; e < end; e++) {
        if (!c->features[e])
            continue;
        put_le(ids, (uint64_t)c->ids[e], 8);
        put_le(features, c->features[e], 4);
        ids += 8;
        features += 4;
        size_t block = phks__db_padded(c->features[e]) * c->length;
        const double *v = c->vectors + c->vector_at[e];
        if (HOST_LE) {
            memcpy(vectors, v, 8 * block);
        } else {
            for (size_t i = 0; i < block; i++) {
                uint64_t w;
                memcpy(&w, &v[i], 8);
                put_le(vectors + 8 * i, w, 8);
            }
        }
        vectors += 8 * block;
        size_t t = text_of(c, e);
        memcpy(texts, c->text + c->text_at[e], t);
        texts += t;
    }
    sum s;
    sum_init(&s);
    sum_bytes(&s, out, bytes - TRAILER);
    put_le(out + bytes - TRAILER, s.a, 8);
    put_le(out + bytes - 8, s.b, 8);
    *blob = out;
    *size = bytes;
    *entries = n;
    return PHKS_OK;
}

static size_t cut_len(const char *t, size_t room)
{
    size_t n = strnlen(t, room);
    return n < room && n <= PHKS_DB_TEXT_MAX ? n : SIZE_MAX;
}

phks_status phks__db_pack_decode(phks__db_cache *c, int64_t start,
                                size_t size, phks__db_pack_read_fn read,
                                void *ctx)
{
    unsigned char head[HEADER], pad[16], trailer[TRAILER];
    if (size < HEADER + TRAILER)
        return PHKS_ERROR_CORRUPT;
    phks_status st = read(ctx, head, HEADER, 0);
    if (st != PHKS_OK)
        return st;
    size_t n = (size_t)get_le(head + 8, 4), L = (size_t)get_le(head + 12, 4);
    uint64_t doubles64 = get_le(head + 16, 8), text64 = get_le(head + 24, 8);
    if (memcmp(head, "PHKP", 4) || get_le(head + 4, 2) != PACK_VERSION ||
        get_le(head + 6, 2) != 0 || n == 0 || L == 0 ||
        (c->count && L != c->length) || doubles64 > SIZE_MAX ||
        text64 > SIZE_MAX)
        return PHKS_ERROR_CORRUPT;
    size_t doubles = (size_t)doubles64, text = (size_t)text64;
    if (chunk_size(n, doubles, text) != size)
        return PHKS_ERROR_CORRUPT;
    if (phks__db_cache_reserve(c, n, doubles, text) != PHKS_OK)
        return PHKS_ERROR_OUT_OF_MEMORY;

    size_t e0 = c->count;
    int64_t *ids = c->ids + e0;
    uint32_t *features = c->features + e0;
    double *vectors = c->vectors + c->vectors_used;
    char *texts = c->text + c->text_used;
    size_t at = HEADER, fpad = pad8(4 * n) - 4 * n, tpad = pad8(text) - text;
    memset(pad, 0, sizeof pad);
    if ((st = read(ctx, ids, 8 * n, at)) != PHKS_OK ||
        (st = read(ctx, features, 4 * n, at += 8 * n)) != PHKS_OK ||
        (st = read(ctx, pad, fpad, at += 4 * n)) != PHKS_OK ||
        (st = read(ctx, vectors, 8 * doubles, at += fpad)) != PHKS_OK ||
        (st = read(ctx, texts, text, at += 8 * doubles)) != PHKS_OK ||
        (st = read(ctx, pad + 8, tpad, at += text)) != PHKS_OK ||
        (st = read(ctx, trailer, TRAILER, at += tpad)) != PHKS_OK)
        return st;
    sum s;
    sum_init(&s);
    sum_bytes(&s, head, HEADER);
    sum_bytes(&s, ids, 8 * n);
    sum_bytes(&s, features, 4 * n);
    sum_bytes(&s, pad, fpad);
    sum_bytes(&s, vectors, 8 * doubles);
    sum_bytes(&s, texts, text);
    sum_bytes(&s, pad + 8, tpad);
    for (size_t i = 0; i < sizeof pad; i++)
        if (pad[i])
            return PHKS_ERROR_CORRUPT;
    if (s.a != get_le(trailer, 8) || s.b != get_le(trailer + 8, 8))
        return PHKS_ERROR_CORRUPT;
    if (!HOST_LE) {
        for (size_t e = 0; e < n; e++) {
            ids[e] = (int64_t)get_le((const unsigned char *)&ids[e], 8);
            features[e] =
                (uint32_t)get_le((const unsigned char *)&features[e], 4);
        }
        for (size_t i = 0; i < doubles; i++) {
            uint64_t w;
            memcpy(&w, &vectors[i], 8);
            w = bswap64(w);
            memcpy(&vectors[i], &w, 8);
        }
    }

    /* What the scan relies on: ids ascending from start, above those
     * held; feature counts that tile the vectors; two cut strings each. */
    int64_t last = e0 ? c->ids[e0 - 1] : 0;
    if (start > last)
        last = start - 1;
    size_t vec = 0, tx = 0;
    uint32_t max_features = c->max_features;
    for (size_t e = 0; e < n; e++) {
        if (ids[e] <= last || features[e] == 0)
            return PHKS_ERROR_CORRUPT;
        last = ids[e];
        size_t block = phks__db_padded(features[e]);
        if (block > (doubles - vec) / L)
            return PHKS_ERROR_CORRUPT;
        c->vector_at[e0 + e] = c->vectors_used + vec;
        vec += block * L;
        size_t a = cut_len(texts + tx, text - tx);
        if (a == SIZE_MAX)
            return PHKS_ERROR_CORRUPT;
        size_t b = cut_len(texts + tx + a + 1, text - tx - a - 1);
        if (b == SIZE_MAX)
            return PHKS_ERROR_CORRUPT;
        c->text_at[e0 + e] = c->text_used + tx;
        tx += a + b + 2;
        if (features[e] > max_features)
            max_features = features[e];
    }
    if (vec != doubles || tx != text)
        return PHKS_ERROR_CORRUPT;
    c->count += n;
    c->length = L;
    c->max_features = max_features;
    c->vectors_used += doubles;
    c->text_used += text;
    return PHKS_OK;
}
