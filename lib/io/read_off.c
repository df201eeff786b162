/*
 * read_off.c - Geomview's Object File Format: a header keyword, the vertex
 * and face counts, one vertex per line, then one face per line as a vertex
 * count followed by indices from 0. Faces are fan-triangulated.
 *
 * The header keyword's optional prefixes (ST, C, N: texture coordinates,
 * colours, normals) only add values after x y z on a vertex line, and a
 * face line may end in a colour; both are ignored, so every line is read
 * for its leading numbers and the rest skipped. 4OFF and nOFF (other than
 * three dimensions) and binary OFF are refused.
 */
#include "io/text_scan.h"

#include <string.h>

/* The fewest bytes a vertex line ("0 0 0\n") and a face line
 * ("3 0 0 0\n") can take: the counts are checked against the bytes left
 * before anything is allocated, so a lying header cannot make us reserve
 * gigabytes for a small file. */
#define MIN_VERTEX_BYTES 6
#define MIN_FACE_BYTES 8

/* Reads the header keyword; refuses the variants we cannot read. */
static phks_status read_keyword(phks__scan *s)
{
    phks__scan_space(s);
    const char *t;
    size_t n = phks__scan_token(s, &t);
    if (n == 0)
        return phks__fail(PHKS_ERROR_TRUNCATED,
                         "line %zu: the data ends before the OFF header",
                         s->line);
    bool ok = n >= 3 && memcmp(t + n - 3, "OFF", 3) == 0;
    for (size_t i = 0; ok && i + 3 < n; i++)
        ok = t[i] != '\0' && strchr("STCN4n", t[i]) != NULL;
    if (!ok) {
        char q[40];
        phks__token_quote(t, n, q, sizeof q);
        return phks__fail(PHKS_ERROR_PARSE,
                         "line %zu: expected the OFF header, found '%s'",
                         s->line, q);
    }
    if (memchr(t, '4', n) || memchr(t, 'n', n))
        return phks__fail(PHKS_ERROR_PARSE,
                         "line %zu: only three-dimensional OFF is supported, "
                         "not %.*s",
                         s->line, (int)n, t);
    n = phks__scan_token(s, &t);
    if (phks__token_is(t, n, "BINARY"))
        return phks__fail(PHKS_ERROR_PARSE,
                         "line %zu: binary OFF is not supported", s->line);
    s->p = t; /* the counts may follow on the same line */
    return PHKS_OK;
}

static phks_status read_count(phks__scan *s, const char *what, uint64_t *out)
{
    int64_t v = 0;
    phks__scan_space(s);
    phks__scan_result r = phks__scan_int(s, &v);
    if (r == PHKS__SCAN_RANGE)
        return phks__fail(PHKS_ERROR_TOO_LARGE, "line %zu: %s count beyond "
                         "%llu", s->line, what,
                         (unsigned long long)PHKS__MAX_COUNT);
    if (r != PHKS__SCAN_OK)
        return phks__scan_fail(s, r, "%s count", what);
    if (v < 0)
        return phks__fail(PHKS_ERROR_PARSE, "line %zu: negative %s count %lld",
                         s->line, what, (long long)v);
    if ((uint64_t)v > PHKS__MAX_COUNT)
        return phks__fail(PHKS_ERROR_TOO_LARGE,
                         "line %zu: %s count %lld is more than %llu",
                         s->line, what, (long long)v,
                         (unsigned long long)PHKS__MAX_COUNT);
    *out = (uint64_t)v;
    return PHKS_OK;
}

static phks_status read_header(phks__scan *s, uint64_t *vertices,
                               uint64_t *faces)
{
    phks_status st = read_keyword(s);
    if (st == PHKS_OK)
        st = read_count(s, "vertex", vertices);
    if (st == PHKS_OK)
        st = read_count(s, "face", faces);
    if (st != PHKS_OK)
        return st;
    /* The edge count is optional and unused; it can only be on this line,
     * as the next one is already the first vertex. */
    int64_t edges;
    if (!phks__scan_eol(s)) {
        phks__scan_result r = phks__scan_int(s, &edges);
        if (r != PHKS__SCAN_OK)
            return phks__scan_fail(s, r, "edge count");
    }
    size_t header_line = s->line;
    phks__scan_next_line(s);

    uint64_t need = *vertices * MIN_VERTEX_BYTES + *faces * MIN_FACE_BYTES;
    uint64_t left = (uint64_t)(s->end - s->p) + 1; /* last line may lack \n */
    if (need > left)
        return phks__fail(PHKS_ERROR_TOO_LARGE,
                         "line %zu: %llu vertices and %llu faces need at "
                         "least %llu bytes, but only %llu follow",
                         header_line, (unsigned long long)*vertices,
                         (unsigned long long)*faces, (unsigned long long)need,
                         (unsigned long long)(left - 1));
    if (*faces == 0)
        return phks__fail(PHKS_ERROR_NO_TRIANGLES,
                         "line %zu: the header declares no faces", header_line);
    return PHKS_OK;
}

static phks_status read_vertices(phks__scan *s, double *xyz, size_t count)
{
    for (size_t i = 0; i < count; i++) {
        phks__scan_space(s);
        for (int k = 0; k < 3; k++) {
            phks__scan_result r = phks__scan_double(s, xyz + 3 * i + k);
            if (r != PHKS__SCAN_OK)
                return phks__scan_fail(s, r, "vertex %zu, coordinate %c", i,
                                      "xyz"[k]);
        }
        phks__scan_next_line(s);
    }
    return PHKS_OK;
}

static phks_status read_faces(phks__scan *s, size_t faces, size_t vertices,
                              phks__tri_list *tri)
{
    for (size_t f = 0; f < faces; f++) {
        phks__scan_space(s);
        int64_t n;
        phks__scan_result r = phks__scan_int(s, &n);
        if (r != PHKS__SCAN_OK)
            return phks__scan_fail(s, r, "face %zu, vertex count", f);
        if (n < 3)
            return phks__fail(PHKS_ERROR_PARSE,
                             "line %zu: face %zu has %lld vertices; at least "
                             "3 are needed",
                             s->line, f, (long long)n);
        uint32_t first = 0, prev = 0;
        for (int64_t k = 0; k < n; k++) {
            int64_t v;
            r = phks__scan_int(s, &v);
            if (r != PHKS__SCAN_OK)
                return phks__scan_fail(s, r, "face %zu, vertex %lld of %lld", f,
                                      (long long)k, (long long)n);
            if (v < 0 || (uint64_t)v >= vertices)
                return phks__fail(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                                 "line %zu: face %zu: vertex index %lld, but "
                                 "there are %zu vertices",
                                 s->line, f, (long long)v, vertices);
            if (k == 0)
                first = (uint32_t)v;
            else if (k >= 2) {
                phks_status st = phks__tri_list_push(tri, first, prev, (uint32_t)v);
                if (st != PHKS_OK)
                    return st;
            }
            prev = (uint32_t)v;
        }
        phks__scan_next_line(s); /* an optional face colour */
    }
    return PHKS_OK;
}

phks_status phks__read_off(const char *data, size_t size, phks__raw_mesh *raw)
{
    memset(raw, 0, sizeof *raw);
    phks__scan s;
    phks__scan_init(&s, data, size);
    s.comment = '#';

    uint64_t vertices = 0, faces = 0;
    phks_status st = read_header(&s, &vertices, &faces);
    if (st != PHKS_OK)
        return st;

    phks__tri_list tri = {0};
    double *xyz = phks__malloc_array((size_t)vertices, 3 * sizeof *xyz);
    if (!xyz)
        return phks__fail_oom("OFF vertices");
    st = phks__tri_list_reserve(&tri, (size_t)faces);
    if (st == PHKS_OK)
        st = read_vertices(&s, xyz, (size_t)vertices);
    if (st == PHKS_OK)
        st = read_faces(&s, (size_t)faces, (size_t)vertices, &tri);
    if (st != PHKS_OK) {
        phks__free(xyz);
        phks__free(tri.v);
        return st;
    }
    raw->xyz = xyz;
    raw->vertex_count = (size_t)vertices;
    raw->triangles = tri.v;
    raw->triangle_count = tri.count;
    return PHKS_OK;
}
