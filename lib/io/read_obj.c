/*
 * read_obj.c - Wavefront OBJ: only 'v' (x y z, then an optional w or
 * colour that we ignore) and 'f' lines matter; every other statement
 * (vt, vn, g, o, s, usemtl, mtllib, l, p, curves) is skipped. Face corners
 * are i, i/t, i//n or i/t/n with indices from 1, or negative ones counting
 * back from the latest vertex. Polygons are fan-triangulated. A backslash
 * at a line end continues the statement on the next line.
 */
#include "io/text_scan.h"

#include <string.h>

typedef struct obj_state {
    phks__scan s;
    double *xyz;
    size_t vertex_count;
    size_t vertex_capacity;
    phks__tri_list tri;
    size_t face_count;
    /* The file may name a vertex before defining it, so the largest
     * positive index is checked once all vertices are known; where it
     * appeared is kept for the message. */
    int64_t max_index;
    size_t max_index_line;
    size_t max_index_face;
} obj_state;

static phks_status read_vertex(obj_state *o)
{
    if (o->vertex_count == o->vertex_capacity) {
        if (o->vertex_count >= PHKS__MAX_COUNT)
            return phks__fail(PHKS_ERROR_TOO_LARGE,
                             "line %zu: more than %llu vertices", o->s.line,
                             (unsigned long long)PHKS__MAX_COUNT);
        size_t cap = o->vertex_capacity < 1024 ? 1024 : 2 * o->vertex_capacity;
        double *xyz = phks__realloc_array(o->xyz, cap, 3 * sizeof *xyz);
        if (!xyz)
            return phks__fail_oom("OBJ vertices");
        o->xyz = xyz;
        o->vertex_capacity = cap;
    }
    double *p = o->xyz + 3 * o->vertex_count;
    for (int k = 0; k < 3; k++) {
        phks__scan_result r = phks__scan_double(&o->s, p + k);
        if (r != PHKS__SCAN_OK)
            return phks__scan_fail(&o->s, r, "vertex %zu, coordinate %c",
                                  o->vertex_count + 1, "xyz"[k]);
    }
    o->vertex_count++;
    return PHKS_OK;
}

static bool ends_corner(const phks__scan *s, const char *q)
{
    return q == s->end || phks__scan_is_blank(*q) || *q == '\n' || *q == '#' ||
           *q == '\\';
}

/* An optional texture or normal index after a slash: syntax only. */
static bool skip_optional_index(const char **q, const char *end)
{
    if (*q == end || **q == '/' || phks__scan_is_blank(**q) || **q == '\n')
        return true;
    int64_t unused;
    return phks__parse_int(*q, end, &unused, q) == PHKS__SCAN_OK;
}

/* One corner "i[/[t][/[n]]]" into a vertex index from 0. */
static phks_status read_corner(obj_state *o, size_t corner, uint32_t *index)
{
    phks__scan *s = &o->s;
    const char *q = s->p;
    int64_t v = 0;
    phks__scan_result r = phks__parse_int(s->p, s->end, &v, &q);
    bool ok = r == PHKS__SCAN_OK;
    for (int slash = 0; ok && slash < 2 && q < s->end && *q == '/'; slash++) {
        q++;
        ok = skip_optional_index(&q, s->end);
    }
    if (r == PHKS__SCAN_RANGE && !ends_corner(s, q))
        r = PHKS__SCAN_BAD;
    if (!ok || !ends_corner(s, q))
        return phks__scan_fail(s, r == PHKS__SCAN_RANGE ? r : PHKS__SCAN_BAD,
                              "face %zu, corner %zu", o->face_count + 1,
                              corner + 1);
    if (v == 0)
        return phks__fail(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                         "line %zu: face %zu: vertex index 0 (OBJ indices "
                         "start at 1)",
                         s->line, o->face_count + 1);
    if (v < 0) {
        if ((uint64_t)-(v + 1) >= o->vertex_count)
            return phks__fail(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                             "line %zu: face %zu: relative vertex index %lld, "
                             "but only %zu vertices precede it",
                             s->line, o->face_count + 1, (long long)v,
                             o->vertex_count);
        v += (int64_t)o->vertex_count + 1;
    }
    if ((uint64_t)v > PHKS__MAX_COUNT)
        return phks__fail(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                         "line %zu: face %zu: vertex index %lld is too large",
                         s->line, o->face_count + 1, (long long)v);
    if (v > o->max_index) {
        o->max_index = v;
        o->max_index_line = s->line;
        o->max_index_face = o->face_count + 1;
    }
    s->p = q;
    *index = (uint32_t)(v - 1);
    return PHKS_OK;
}

static phks_status read_face(obj_state *o)
{
    size_t line = o->s.line, n = 0;
    uint32_t first = 0, prev = 0;
    while (!phks__scan_eol(&o->s)) {
        uint32_t v = 0;
        phks_status st = read_corner(o, n, &v);
        if (st != PHKS_OK)
            return st;
        if (n == 0)
            first = v;
        else if (n >= 2) {
            st = phks__tri_list_push(&o->tri, first, prev, v);
            if (st != PHKS_OK)
                return st;
        }
        prev = v;
        n++;
    }
    if (n < 3)
        return phks__fail(PHKS_ERROR_PARSE,
                         "line %zu: face %zu has %zu vertices; at least 3 are "
                         "needed",
                         line, o->face_count + 1, n);
    o->face_count++;
    return PHKS_OK;
}

static phks_status read_statements(obj_state *o)
{
    while (o->s.p < o->s.end) {
        const char *t;
        size_t n = phks__scan_token(&o->s, &t);
        phks_status st = PHKS_OK;
        if (n == 1 && t[0] == 'v')
            st = read_vertex(o);
        else if (n == 1 && t[0] == 'f')
            st = read_face(o);
        if (st != PHKS_OK)
            return st;
        phks__scan_next_line(&o->s);
    }
    if (o->tri.count == 0)
        return phks__fail(PHKS_ERROR_NO_TRIANGLES,
                         "line %zu: the file has %zu vertices but no faces",
                         o->s.line, o->vertex_count);
    if ((uint64_t)o->max_index > o->vertex_count)
        return phks__fail(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                         "line %zu: face %zu: vertex index %lld, but the file "
                         "has %zu vertices",
                         o->max_index_line, o->max_index_face,
                         (long long)o->max_index, o->vertex_count);
    return PHKS_OK;
}

phks_status phks__read_obj(const char *data, size_t size, phks__raw_mesh *raw)
{
    memset(raw, 0, sizeof *raw);
    obj_state o = {0};
    phks__scan_init(&o.s, data, size);
    o.s.comment = '#';
    o.s.continuation = true;

    phks_status st = read_statements(&o);
    if (st != PHKS_OK) {
        phks__free(o.xyz);
        phks__free(o.tri.v);
        return st;
    }
    raw->xyz = o.xyz;
    raw->vertex_count = o.vertex_count;
    raw->triangles = o.tri.v;
    raw->triangle_count = o.tri.count;
    return PHKS_OK;
}
