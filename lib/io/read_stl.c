/*
 * read_stl.c - stereolithography files: ascii ("solid ... facet normal ...
 * outer loop vertex x y z ... endloop endfacet ... endsolid") and binary
 * (an 80-byte header, a little-endian uint32 facet count, then 50 bytes per
 * facet: normal, three corners as float32, a uint16 attribute).
 *
 * STL stores each facet's corners separately, so coincident corners are
 * welded into shared vertices by exact equality of their coordinates
 * (-0 and +0 are equal). Each vertex's origin is the file position of the
 * first corner that made it: 3 * facet + corner for triangles.
 *
 * Many binary files begin their free-form header with "solid", so a file
 * whose size is exactly 84 + 50 * count is binary whatever its first bytes.
 */
#include "io/text_scan.h"

#include <math.h>
#include <string.h>

#define EMPTY UINT32_MAX

/* Welded vertices and the open-addressing hash table that finds them. */
typedef struct welder {
    double *xyz;
    uint32_t *origin;
    size_t count;
    size_t capacity;
    uint32_t *table; /* vertex index or EMPTY; a power of two long */
    size_t mask;
} welder;

static uint64_t bits(double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    return u;
}

static size_t hash3(const double *p)
{
    uint64_t h = bits(p[0]) * 0x9E3779B97F4A7C15ull;
    h ^= bits(p[1]) * 0xC2B2AE3D27D4EB4Full;
    h ^= bits(p[2]) * 0x165667B19E3779F9ull;
    h ^= h >> 31;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 29;
    return (size_t)h;
}

static void welder_release(welder *w)
{
    phks__free(w->xyz);
    phks__free(w->origin);
    phks__free(w->table);
}

/* Doubles the table, keeping it at most half full so probes stay short. */
static phks_status rehash(welder *w)
{
    size_t size = w->table ? 2 * (w->mask + 1) : 4096;
    uint32_t *table = phks__malloc_array(size, sizeof *table);
    if (!table)
        return phks__fail_oom("STL vertex welding");
    for (size_t i = 0; i < size; i++)
        table[i] = EMPTY;
    for (size_t v = 0; v < w->count; v++) {
        size_t h = hash3(w->xyz + 3 * v) & (size - 1);
        while (table[h] != EMPTY)
            h = (h + 1) & (size - 1);
        table[h] = (uint32_t)v;
    }
    phks__free(w->table);
    w->table = table;
    w->mask = size - 1;
    return PHKS_OK;
}

static phks_status add_vertex(welder *w, const double *p, uint32_t corner)
{
    if (w->count == w->capacity) {
        size_t cap = w->capacity < 1024 ? 1024 : 2 * w->capacity;
        double *xyz = phks__realloc_array(w->xyz, cap, 3 * sizeof *xyz);
        if (xyz)
            w->xyz = xyz;
        uint32_t *origin = phks__realloc_array(w->origin, cap, sizeof *origin);
        if (origin)
            w->origin = origin;
        if (!xyz || !origin)
            return phks__fail_oom("STL vertices");
        w->capacity = cap;
    }
    memcpy(w->xyz + 3 * w->count, p, 3 * sizeof *p);
    w->origin[w->count] = corner;
    w->count++;
    return PHKS_OK;
}

/* The vertex at p, made if new. corner is the corner's file position. */
static phks_status weld(welder *w, const double *in, uint32_t corner,
                        uint32_t *index)
{
    double p[3];
    for (int k = 0; k < 3; k++)
        p[k] = in[k] == 0 ? 0.0 : in[k];
    if (!w->table || w->count >= (w->mask + 1) / 2) {
        phks_status st = rehash(w);
        if (st != PHKS_OK)
            return st;
    }
    size_t h = hash3(p) & w->mask;
    for (; w->table[h] != EMPTY; h = (h + 1) & w->mask) {
        const double *q = w->xyz + 3 * w->table[h];
        if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) {
            *index = w->table[h];
            return PHKS_OK;
        }
    }
    phks_status st = add_vertex(w, p, corner);
    if (st != PHKS_OK)
        return st;
    w->table[h] = (uint32_t)(w->count - 1);
    *index = w->table[h];
    return PHKS_OK;
}

/* ------------------------------------------------------------------ binary */

#define HEADER_BYTES 84
#define FACET_BYTES 50

static uint32_t load_u32le(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}

static float load_f32le(const unsigned char *p)
{
    uint32_t u = load_u32le(p);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static phks_status read_binary(const unsigned char *data, size_t size,
                               welder *w, phks__tri_list *tri)
{
    uint32_t facets = load_u32le(data + 80);
    if ((uint64_t)facets * 3 > PHKS__MAX_COUNT)
        return phks__fail(PHKS_ERROR_TOO_LARGE,
                         "byte offset 80: %lu facets, more than %llu",
                         (unsigned long)facets,
                         (unsigned long long)(PHKS__MAX_COUNT / 3));
    uint64_t need = HEADER_BYTES + (uint64_t)facets * FACET_BYTES;
    if (need > size)
        return phks__fail(PHKS_ERROR_TOO_LARGE,
                         "byte offset 80: %lu facets need %llu bytes, but the "
                         "data has %zu",
                         (unsigned long)facets, (unsigned long long)need, size);
    if (facets == 0)
        return phks__fail(PHKS_ERROR_NO_TRIANGLES,
                         "byte offset 80: the file declares no facets");
    phks_status st = phks__tri_list_reserve(tri, facets);
    for (uint32_t f = 0; st == PHKS_OK && f < facets; f++) {
        const unsigned char *facet = data + HEADER_BYTES + (size_t)f * FACET_BYTES;
        uint32_t v[3];
        for (int k = 0; st == PHKS_OK && k < 3; k++) {
            double p[3];
            for (int d = 0; d < 3; d++) {
                p[d] = load_f32le(facet + 12 + 12 * k + 4 * d);
                if (!isfinite(p[d]))
                    return phks__fail(PHKS_ERROR_NON_FINITE,
                                     "byte offset %zu: facet %lu, corner %d: "
                                     "coordinate %c is not finite",
                                     (size_t)(facet + 12 + 12 * k + 4 * d - data),
                                     (unsigned long)f, k, "xyz"[d]);
            }
            st = weld(w, p, 3 * f + (uint32_t)k, &v[k]);
        }
        if (st == PHKS_OK)
            st = phks__tri_list_push(tri, v[0], v[1], v[2]);
    }
    return st;
}

/* ------------------------------------------------------------------- ascii */

/* Keywords are matched without case: some writers shout. */
static phks_status expect(phks__scan *s, const char *word)
{
    phks__scan_space(s);
    const char *t;
    size_t n = phks__scan_token(s, &t);
    if (phks__token_is_nocase(t, n, word))
        return PHKS_OK;
    if (n == 0)
        return phks__fail(PHKS_ERROR_TRUNCATED,
                         "line %zu: the data ends before '%s'", s->line, word);
    char q[40];
    phks__token_quote(t, n, q, sizeof q);
    return phks__fail(PHKS_ERROR_PARSE, "line %zu: expected '%s', found '%s'",
                     s->line, word, q);
}

/* One "facet ... endfacet" after its keyword; loops of more than three
 * corners are fan-triangulated. */
static phks_status read_facet(phks__scan *s, size_t facet, uint64_t *corners,
                              welder *w, phks__tri_list *tri)
{
    phks__scan_next_line(s); /* the normal: recomputed, never trusted */
    phks_status st = expect(s, "outer");
    if (st == PHKS_OK)
        st = expect(s, "loop");
    uint32_t first = 0, prev = 0;
    size_t n = 0;
    for (; st == PHKS_OK; n++) {
        phks__scan_space(s);
        const char *t;
        size_t len = phks__scan_token(s, &t);
        if (phks__token_is_nocase(t, len, "endloop"))
            break;
        if (!phks__token_is_nocase(t, len, "vertex")) {
            s->p = t;
            return expect(s, n < 3 ? "vertex" : "endloop");
        }
        double p[3];
        for (int d = 0; d < 3; d++) {
            phks__scan_result r = phks__scan_double(s, p + d);
            if (r != PHKS__SCAN_OK)
                return phks__scan_fail(s, r, "facet %zu, corner %zu, coordinate %c",
                                      facet, n, "xyz"[d]);
        }
        if (*corners >= PHKS__MAX_COUNT)
            return phks__fail(PHKS_ERROR_TOO_LARGE, "line %zu: more than %llu "
                             "corners", s->line, (unsigned long long)PHKS__MAX_COUNT);
        uint32_t v = 0;
        st = weld(w, p, (uint32_t)(*corners)++, &v);
        if (st == PHKS_OK && n == 0)
            first = v;
        else if (st == PHKS_OK && n >= 2)
            st = phks__tri_list_push(tri, first, prev, v);
        prev = v;
    }
    if (st == PHKS_OK && n < 3)
        return phks__fail(PHKS_ERROR_PARSE,
                         "line %zu: facet %zu has %zu corners; at least 3 are "
                         "needed",
                         s->line, facet, n);
    return st == PHKS_OK ? expect(s, "endfacet") : st;
}

static phks_status read_ascii(const char *data, size_t size, welder *w,
                              phks__tri_list *tri)
{
    phks__scan s;
    phks__scan_init(&s, data, size);
    phks_status st = expect(&s, "solid");
    size_t facets = 0;
    uint64_t corners = 0;
    while (st == PHKS_OK) {
        phks__scan_next_line(&s); /* the rest of a solid or endsolid line */
        phks__scan_space(&s);
        if (s.p == s.end)
            break; /* a missing final endsolid is forgiven */
        const char *t;
        size_t n = phks__scan_token(&s, &t);
        if (phks__token_is_nocase(t, n, "facet"))
            st = read_facet(&s, facets++, &corners, w, tri);
        else if (!phks__token_is_nocase(t, n, "endsolid") &&
                 !phks__token_is_nocase(t, n, "solid")) {
            s.p = t;
            st = expect(&s, "facet");
        }
    }
    if (st == PHKS_OK && tri->count == 0)
        return phks__fail(PHKS_ERROR_NO_TRIANGLES, "line %zu: no facets", s.line);
    return st;
}

/* ascii when it starts with "solid" and is not exactly binary-sized. */
static bool is_ascii(const char *data, size_t size)
{
    if (size >= HEADER_BYTES) {
        uint32_t facets = load_u32le((const unsigned char *)data + 80);
        if (HEADER_BYTES + (uint64_t)facets * FACET_BYTES == size)
            return false;
    }
    phks__scan s;
    phks__scan_init(&s, data, size);
    phks__scan_space(&s);
    const char *t;
    size_t n = phks__scan_token(&s, &t);
    return phks__token_is_nocase(t, n, "solid");
}

phks_status phks__read_stl(const char *data, size_t size, phks__raw_mesh *raw)
{
    memset(raw, 0, sizeof *raw);
    welder w = {0};
    phks__tri_list tri = {0};
    phks_status st;
    if (is_ascii(data, size))
        st = read_ascii(data, size, &w, &tri);
    else if (size < HEADER_BYTES)
        st = phks__fail(PHKS_ERROR_TRUNCATED,
                       "byte offset %zu: a binary STL needs an 84-byte header",
                       size);
    else
        st = read_binary((const unsigned char *)data, size, &w, &tri);
    phks__free(w.table);
    w.table = NULL;
    if (st != PHKS_OK) {
        welder_release(&w);
        phks__free(tri.v);
        return st;
    }
    raw->xyz = w.xyz;
    raw->vertex_origin = w.origin;
    raw->vertex_count = w.count;
    raw->triangles = tri.v;
    raw->triangle_count = tri.count;
    return PHKS_OK;
}
