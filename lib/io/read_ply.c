/*
 * read_ply.c - the Stanford polygon format, version 1.0, in its three
 * encodings (ascii, binary_little_endian, binary_big_endian). The text
 * header declares elements, each with a count and a list of scalar or
 * list properties; the data then holds the elements in header order. We
 * keep x, y, z of "vertex" and the index list (vertex_indices or
 * vertex_index) of "face", and step over everything else, whatever its
 * types, so any layout written by any tool reads the same.
 */
#include "io/text_scan.h"

#include <math.h>
#include <string.h>

typedef enum ply_type {
    PLY_NONE, PLY_I8, PLY_U8, PLY_I16, PLY_U16, PLY_I32, PLY_U32, PLY_F32,
    PLY_F64
} ply_type;

static const unsigned type_size[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};

static const struct {
    const char *name;
    ply_type type;
} type_names[] = {
    {"char", PLY_I8},    {"int8", PLY_I8},     {"uchar", PLY_U8},
    {"uint8", PLY_U8},   {"short", PLY_I16},   {"int16", PLY_I16},
    {"ushort", PLY_U16}, {"uint16", PLY_U16},  {"int", PLY_I32},
    {"int32", PLY_I32},  {"uint", PLY_U32},    {"uint32", PLY_U32},
    {"float", PLY_F32},  {"float32", PLY_F32}, {"double", PLY_F64},
    {"float64", PLY_F64},
};

typedef enum ply_role { ROLE_SKIP, ROLE_X, ROLE_Y, ROLE_Z, ROLE_INDICES } ply_role;
typedef enum ply_kind { KIND_OTHER, KIND_VERTEX, KIND_FACE } ply_kind;
typedef enum ply_format { FORMAT_NONE, FORMAT_ASCII, FORMAT_LE, FORMAT_BE } ply_format;

typedef struct ply_property {
    ply_type type;       /* of the scalar, or of a list's items          */
    ply_type count_type; /* PLY_NONE for a scalar                        */
    ply_role role;
} ply_property;

typedef struct ply_element {
    const char *name; /* points into the header, for messages            */
    int name_len;
    ply_kind kind;
    uint64_t count;
    size_t first;     /* its properties are props[first .. first + n)   */
    size_t n;
    size_t line;      /* where it was declared                           */
} ply_element;

typedef struct ply_file {
    const char *data;
    size_t size;
    size_t data_start; /* offset of the first byte after the header     */
    size_t data_line;
    ply_format format;
    ply_element *elements;
    size_t element_count, element_capacity;
    ply_property *props;
    size_t prop_count, prop_capacity;
    uint64_t vertex_count;
    double *xyz;
    phks__tri_list tri;
} ply_file;

/* ------------------------------------------------------------------ header */

static phks_status grow(void **array, size_t *capacity, size_t count,
                        size_t item)
{
    if (count < *capacity)
        return PHKS_OK;
    size_t cap = *capacity < 8 ? 8 : 2 * *capacity;
    void *p = phks__realloc_array(*array, cap, item);
    if (!p)
        return phks__fail_oom("PLY header");
    *array = p;
    *capacity = cap;
    return PHKS_OK;
}

static phks_status header_error(const phks__scan *s, const char *what,
                                const char *t, size_t n)
{
    char q[40];
    phks__token_quote(t, n, q, sizeof q);
    return phks__fail(PHKS_ERROR_PARSE, "line %zu: %s '%s'", s->line, what, q);
}

static ply_type parse_type(const char *t, size_t n)
{
    for (size_t i = 0; i < sizeof type_names / sizeof *type_names; i++)
        if (phks__token_is(t, n, type_names[i].name))
            return type_names[i].type;
    return PLY_NONE;
}

static bool is_integer(ply_type t)
{
    return t != PLY_NONE && t != PLY_F32 && t != PLY_F64;
}

static phks_status read_format(ply_file *f, phks__scan *s)
{
    const char *t;
    size_t n = phks__scan_token(s, &t);
    if (phks__token_is(t, n, "ascii"))
        f->format = FORMAT_ASCII;
    else if (phks__token_is(t, n, "binary_little_endian"))
        f->format = FORMAT_LE;
    else if (phks__token_is(t, n, "binary_big_endian"))
        f->format = FORMAT_BE;
    else
        return header_error(s, "unknown PLY format", t, n);
    n = phks__scan_token(s, &t);
    if (!phks__token_is(t, n, "1.0") && !phks__token_is(t, n, "1"))
        return header_error(s, "unsupported PLY version", t, n);
    return PHKS_OK;
}

static phks_status read_element(ply_file *f, phks__scan *s)
{
    const char *t;
    size_t n = phks__scan_token(s, &t);
    if (n == 0)
        return phks__fail(PHKS_ERROR_PARSE, "line %zu: element without a name",
                         s->line);
    int64_t count;
    phks__scan_result r = phks__scan_int(s, &count);
    if (r == PHKS__SCAN_RANGE)
        count = INT64_MAX; /* refused below as too large */
    else if (r != PHKS__SCAN_OK)
        return phks__scan_fail(s, r, "element %.*s, count", (int)(n < 40 ? n : 40), t);
    if (count < 0)
        return phks__fail(PHKS_ERROR_PARSE, "line %zu: element %.*s: negative "
                         "count %lld", s->line, (int)(n < 40 ? n : 40), t,
                         (long long)count);
    if ((uint64_t)count > PHKS__MAX_COUNT)
        return phks__fail(PHKS_ERROR_TOO_LARGE, "line %zu: element %.*s: count "
                         "%lld is more than %llu", s->line,
                         (int)(n < 40 ? n : 40), t, (long long)count,
                         (unsigned long long)PHKS__MAX_COUNT);
    ply_kind kind = phks__token_is(t, n, "vertex") ? KIND_VERTEX
                    : phks__token_is(t, n, "face") ? KIND_FACE
                                                  : KIND_OTHER;
    for (size_t i = 0; kind != KIND_OTHER && i < f->element_count; i++)
        if (f->elements[i].kind == kind)
            return header_error(s, "a second element", t, n);
    phks_status st = grow((void **)&f->elements, &f->element_capacity,
                          f->element_count, sizeof *f->elements);
    if (st != PHKS_OK)
        return st;
    f->elements[f->element_count++] = (ply_element){
        t, (int)(n < 40 ? n : 40), kind, (uint64_t)count, f->prop_count, 0,
        s->line};
    if (kind == KIND_VERTEX)
        f->vertex_count = (uint64_t)count;
    return PHKS_OK;
}

static ply_role property_role(const ply_element *e, const char *t, size_t n)
{
    if (e->kind == KIND_VERTEX && n == 1 && (t[0] == 'x' || t[0] == 'y' || t[0] == 'z'))
        return (ply_role)(ROLE_X + (t[0] - 'x'));
    if (e->kind == KIND_FACE && (phks__token_is(t, n, "vertex_indices") ||
                                 phks__token_is(t, n, "vertex_index")))
        return ROLE_INDICES;
    return ROLE_SKIP;
}

static phks_status read_property(ply_file *f, phks__scan *s)
{
    if (f->element_count == 0)
        return phks__fail(PHKS_ERROR_PARSE,
                         "line %zu: a property before any element", s->line);
    ply_element *e = &f->elements[f->element_count - 1];
    ply_property p = {PLY_NONE, PLY_NONE, ROLE_SKIP};
    const char *t;
    size_t n = phks__scan_token(s, &t);
    if (phks__token_is(t, n, "list")) {
        n = phks__scan_token(s, &t);
        p.count_type = parse_type(t, n);
        if (!is_integer(p.count_type))
            return header_error(s, "a list length needs an integer type, not", t, n);
        n = phks__scan_token(s, &t);
    }
    p.type = parse_type(t, n);
    if (p.type == PLY_NONE)
        return header_error(s, "unknown property type", t, n);
    n = phks__scan_token(s, &t);
    if (n == 0)
        return phks__fail(PHKS_ERROR_PARSE, "line %zu: a property without a name",
                         s->line);
    p.role = property_role(e, t, n);
    bool list = p.count_type != PLY_NONE;
    if (p.role >= ROLE_X && p.role <= ROLE_Z && list)
        return header_error(s, "a list cannot be the coordinate", t, n);
    if (p.role == ROLE_INDICES && (!list || !is_integer(p.type)))
        return header_error(s, "the face index list needs integer items:", t, n);
    for (size_t i = e->first; p.role != ROLE_SKIP && i < f->prop_count; i++)
        if (f->props[i].role == p.role) {
            if (p.role != ROLE_INDICES)
                return header_error(s, "a second property", t, n);
            p.role = ROLE_SKIP; /* the first index list wins */
        }
    phks_status st = grow((void **)&f->props, &f->prop_capacity, f->prop_count,
                          sizeof *f->props);
    if (st != PHKS_OK)
        return st;
    f->props[f->prop_count++] = p;
    e->n++;
    return PHKS_OK;
}

/* The vertex element needs x, y and z; the face element an index list. */
static phks_status check_roles(const ply_file *f)
{
    for (size_t i = 0; i < f->element_count; i++) {
        const ply_element *e = &f->elements[i];
        unsigned seen = 0;
        for (size_t j = e->first; j < e->first + e->n; j++)
            seen |= 1u << f->props[j].role;
        const char *missing = NULL;
        if (e->kind == KIND_VERTEX)
            missing = !(seen & 1u << ROLE_X)   ? "x"
                      : !(seen & 1u << ROLE_Y) ? "y"
                      : !(seen & 1u << ROLE_Z) ? "z"
                                               : NULL;
        if (e->kind == KIND_FACE && !(seen & 1u << ROLE_INDICES))
            missing = "vertex_indices";
        if (missing)
            return phks__fail(PHKS_ERROR_PARSE,
                             "line %zu: element %.*s has no property %s",
                             e->line, e->name_len, e->name, missing);
    }
    return PHKS_OK;
}

static phks_status read_header(ply_file *f)
{
    phks__scan s;
    phks__scan_init(&s, f->data, f->size);
    const char *t;
    size_t n = phks__scan_token(&s, &t);
    if (!phks__token_is(t, n, "ply") || !phks__scan_eol(&s))
        return phks__fail(PHKS_ERROR_PARSE, "line 1: not a PLY file");
    phks__scan_next_line(&s);
    for (;;) {
        if (s.p == s.end)
            return phks__fail(PHKS_ERROR_TRUNCATED,
                             "line %zu: the data ends before end_header", s.line);
        n = phks__scan_token(&s, &t);
        phks_status st = PHKS_OK;
        if (phks__token_is(t, n, "format"))
            st = read_format(f, &s);
        else if (phks__token_is(t, n, "element"))
            st = read_element(f, &s);
        else if (phks__token_is(t, n, "property"))
            st = read_property(f, &s);
        else if (phks__token_is(t, n, "end_header"))
            break;
        else if (n != 0 && !phks__token_is(t, n, "comment") &&
                 !phks__token_is(t, n, "obj_info"))
            st = header_error(&s, "unknown header keyword", t, n);
        if (st != PHKS_OK)
            return st;
        phks__scan_next_line(&s);
    }
    if (f->format == FORMAT_NONE)
        return phks__fail(PHKS_ERROR_PARSE, "line %zu: no format line before "
                         "end_header", s.line);
    if (!phks__scan_eol(&s))
        return phks__fail(PHKS_ERROR_PARSE, "line %zu: text after end_header",
                         s.line);
    phks__scan_next_line(&s);
    f->data_start = (size_t)(s.p - f->data);
    f->data_line = s.line;
    return check_roles(f);
}

/* The fewest bytes a record of e can take: in binary, its scalars and list
 * lengths; in ascii, one character and a separator per number. A face's
 * index list holds at least 3 indices. */
static uint64_t min_record_size(const ply_file *f, const ply_element *e)
{
    uint64_t size = 0;
    for (size_t j = e->first; j < e->first + e->n; j++) {
        const ply_property *p = &f->props[j];
        unsigned items = p->role == ROLE_INDICES ? 3 : 0;
        if (f->format == FORMAT_ASCII)
            size += 2 * (1 + items);
        else if (p->count_type != PLY_NONE)
            size += type_size[p->count_type] + items * type_size[p->type];
        else
            size += type_size[p->type];
    }
    return size;
}

/* Refuses counts the data could not hold, before anything is allocated. */
static phks_status check_counts(const ply_file *f)
{
    uint64_t left = f->size - f->data_start + (f->format == FORMAT_ASCII);
    uint64_t need = 0;
    for (size_t i = 0; i < f->element_count; i++) {
        const ply_element *e = &f->elements[i];
        uint64_t record = min_record_size(f, e);
        if (record && e->count > (left - need) / record)
            return phks__fail(PHKS_ERROR_TOO_LARGE,
                             "line %zu: element %.*s: %llu records of at least "
                             "%llu bytes do not fit in the %llu bytes of data",
                             e->line, e->name_len, e->name,
                             (unsigned long long)e->count,
                             (unsigned long long)record,
                             (unsigned long long)(f->size - f->data_start));
        need += e->count * record;
    }
    return PHKS_OK;
}

/* ------------------------------------------------------------ binary data */

typedef struct bin_cursor {
    const unsigned char *data;
    size_t size;
    size_t pos;
    bool big;
} bin_cursor;

static uint64_t load_bits(const unsigned char *p, unsigned size, bool big)
{
    uint64_t v = 0;
    for (unsigned i = 0; i < size; i++)
        v |= (uint64_t)p[big ? size - 1 - i : i] << (8 * i);
    return v;
}

/* Every type as a double: exact for all the integer types. */
static double load_value(const unsigned char *p, ply_type t, bool big)
{
    uint64_t b = load_bits(p, type_size[t], big);
    switch (t) {
    case PLY_I8: return (int8_t)b;
    case PLY_U8: return (uint8_t)b;
    case PLY_I16: return (int16_t)b;
    case PLY_U16: return (uint16_t)b;
    case PLY_I32: return (int32_t)b;
    case PLY_U32: return (uint32_t)b;
    case PLY_F32: {
        uint32_t u = (uint32_t)b;
        float x;
        memcpy(&x, &u, sizeof x);
        return x;
    }
    case PLY_F64: {
        double x;
        memcpy(&x, &b, sizeof x);
        return x;
    }
    case PLY_NONE: break;
    }
    return 0;
}

static phks_status bin_truncated(const bin_cursor *c, const ply_element *e,
                                 uint64_t record)
{
    return phks__fail(PHKS_ERROR_TRUNCATED,
                     "byte offset %zu: element %.*s, record %llu: the data "
                     "ends early",
                     c->pos, e->name_len, e->name, (unsigned long long)record);
}

/* Reads a list length and checks its items are there. */
static phks_status bin_list_length(bin_cursor *c, const ply_element *e,
                                   uint64_t record, const ply_property *p,
                                   uint64_t *length)
{
    unsigned cs = type_size[p->count_type], is = type_size[p->type];
    if (c->size - c->pos < cs)
        return bin_truncated(c, e, record);
    double v = load_value(c->data + c->pos, p->count_type, c->big);
    if (v < 0)
        return phks__fail(PHKS_ERROR_PARSE,
                         "byte offset %zu: element %.*s, record %llu: negative "
                         "list length %.0f",
                         c->pos, e->name_len, e->name, (unsigned long long)record, v);
    c->pos += cs;
    if ((uint64_t)v > (c->size - c->pos) / is)
        return bin_truncated(c, e, record);
    *length = (uint64_t)v;
    return PHKS_OK;
}

static phks_status bin_face_list(ply_file *f, bin_cursor *c,
                                 const ply_element *e, uint64_t record,
                                 const ply_property *p)
{
    uint64_t n;
    size_t at = c->pos;
    phks_status st = bin_list_length(c, e, record, p, &n);
    if (st != PHKS_OK)
        return st;
    if (n < 3)
        return phks__fail(PHKS_ERROR_PARSE,
                         "byte offset %zu: face %llu has %llu vertices; at "
                         "least 3 are needed",
                         at, (unsigned long long)record, (unsigned long long)n);
    unsigned is = type_size[p->type];
    uint32_t first = 0, prev = 0;
    for (uint64_t k = 0; k < n; k++, c->pos += is) {
        double v = load_value(c->data + c->pos, p->type, c->big);
        if (v < 0 || v >= (double)f->vertex_count)
            return phks__fail(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                             "byte offset %zu: face %llu: vertex index %.0f, "
                             "but there are %llu vertices",
                             c->pos, (unsigned long long)record, v,
                             (unsigned long long)f->vertex_count);
        uint32_t i = (uint32_t)v;
        if (k == 0)
            first = i;
        else if (k >= 2 && (st = phks__tri_list_push(&f->tri, first, prev, i)) != PHKS_OK)
            return st;
        prev = i;
    }
    return PHKS_OK;
}

static phks_status bin_record(ply_file *f, bin_cursor *c, const ply_element *e,
                              uint64_t record)
{
    for (size_t j = e->first; j < e->first + e->n; j++) {
        const ply_property *p = &f->props[j];
        phks_status st;
        if (p->role == ROLE_INDICES) {
            if ((st = bin_face_list(f, c, e, record, p)) != PHKS_OK)
                return st;
        } else if (p->count_type != PLY_NONE) {
            uint64_t n;
            if ((st = bin_list_length(c, e, record, p, &n)) != PHKS_OK)
                return st;
            c->pos += (size_t)n * type_size[p->type];
        } else {
            unsigned size = type_size[p->type];
            if (c->size - c->pos < size)
                return bin_truncated(c, e, record);
            if (p->role != ROLE_SKIP) {
                double v = load_value(c->data + c->pos, p->type, c->big);
                if (!isfinite(v))
                    return phks__fail(PHKS_ERROR_NON_FINITE,
                                     "byte offset %zu: vertex %llu: "
                                     "coordinate %c is not finite",
                                     c->pos, (unsigned long long)record,
                                     "xyz"[p->role - ROLE_X]);
                f->xyz[3 * record + (p->role - ROLE_X)] = v;
            }
            c->pos += size;
        }
    }
    return PHKS_OK;
}

static phks_status read_binary(ply_file *f)
{
    bin_cursor c = {(const unsigned char *)f->data, f->size, f->data_start,
                    f->format == FORMAT_BE};
    for (size_t i = 0; i < f->element_count; i++) {
        const ply_element *e = &f->elements[i];
        bool fixed = e->kind == KIND_OTHER;
        for (size_t j = e->first; fixed && j < e->first + e->n; j++)
            fixed = f->props[j].count_type == PLY_NONE;
        if (fixed) { /* all scalars we skip: one step over the lot */
            uint64_t bytes = e->count * min_record_size(f, e);
            if (bytes > c.size - c.pos)
                return bin_truncated(&c, e, (c.size - c.pos) / min_record_size(f, e));
            c.pos += (size_t)bytes;
            continue;
        }
        for (uint64_t r = 0; r < e->count; r++) {
            phks_status st = bin_record(f, &c, e, r);
            if (st != PHKS_OK)
                return st;
        }
    }
    return PHKS_OK;
}

/* ------------------------------------------------------------- ascii data */

static phks_status ascii_skip(phks__scan *s, const ply_element *e, uint64_t record)
{
    phks__scan_space(s);
    if (s->p == s->end)
        return phks__fail(PHKS_ERROR_TRUNCATED,
                         "line %zu: element %.*s, record %llu: the data ends "
                         "early",
                         s->line, e->name_len, e->name, (unsigned long long)record);
    const char *t;
    phks__scan_token(s, &t);
    return PHKS_OK;
}

static phks_status ascii_list_length(phks__scan *s, const ply_element *e,
                                     uint64_t record, int64_t *n)
{
    phks__scan_space(s);
    phks__scan_result r = phks__scan_int(s, n);
    if (r != PHKS__SCAN_OK)
        return phks__scan_fail(s, r, "element %.*s, record %llu, list length",
                              e->name_len, e->name, (unsigned long long)record);
    if (*n < 0)
        return phks__fail(PHKS_ERROR_PARSE,
                         "line %zu: element %.*s, record %llu: negative list "
                         "length %lld",
                         s->line, e->name_len, e->name,
                         (unsigned long long)record, (long long)*n);
    return PHKS_OK;
}

static phks_status ascii_face_list(ply_file *f, phks__scan *s,
                                   const ply_element *e, uint64_t record)
{
    int64_t n;
    phks_status st = ascii_list_length(s, e, record, &n);
    if (st != PHKS_OK)
        return st;
    if (n < 3)
        return phks__fail(PHKS_ERROR_PARSE,
                         "line %zu: face %llu has %lld vertices; at least 3 "
                         "are needed",
                         s->line, (unsigned long long)record, (long long)n);
    uint32_t first = 0, prev = 0;
    for (int64_t k = 0; k < n; k++) {
        int64_t v;
        phks__scan_space(s);
        phks__scan_result r = phks__scan_int(s, &v);
        if (r != PHKS__SCAN_OK)
            return phks__scan_fail(s, r, "face %llu, vertex %lld",
                                  (unsigned long long)record, (long long)k);
        if (v < 0 || (uint64_t)v >= f->vertex_count)
            return phks__fail(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                             "line %zu: face %llu: vertex index %lld, but there "
                             "are %llu vertices",
                             s->line, (unsigned long long)record, (long long)v,
                             (unsigned long long)f->vertex_count);
        if (k == 0)
            first = (uint32_t)v;
        else if (k >= 2 &&
                 (st = phks__tri_list_push(&f->tri, first, prev, (uint32_t)v)) != PHKS_OK)
            return st;
        prev = (uint32_t)v;
    }
    return PHKS_OK;
}

static phks_status ascii_record(ply_file *f, phks__scan *s, const ply_element *e,
                                uint64_t record)
{
    for (size_t j = e->first; j < e->first + e->n; j++) {
        const ply_property *p = &f->props[j];
        phks_status st = PHKS_OK;
        if (p->role == ROLE_INDICES)
            st = ascii_face_list(f, s, e, record);
        else if (p->count_type != PLY_NONE) {
            int64_t n;
            st = ascii_list_length(s, e, record, &n);
            for (int64_t k = 0; st == PHKS_OK && k < n; k++)
                st = ascii_skip(s, e, record);
        } else if (p->role != ROLE_SKIP) {
            int axis = p->role - ROLE_X;
            phks__scan_space(s);
            phks__scan_result r = phks__scan_double(s, f->xyz + 3 * record + axis);
            if (r != PHKS__SCAN_OK)
                return phks__scan_fail(s, r, "vertex %llu, coordinate %c",
                                      (unsigned long long)record, "xyz"[axis]);
        } else
            st = ascii_skip(s, e, record);
        if (st != PHKS_OK)
            return st;
    }
    return PHKS_OK;
}

static phks_status read_ascii(ply_file *f)
{
    phks__scan s;
    phks__scan_init(&s, f->data + f->data_start, f->size - f->data_start);
    s.line = f->data_line;
    for (size_t i = 0; i < f->element_count; i++) {
        const ply_element *e = &f->elements[i];
        for (uint64_t r = 0; e->n && r < e->count; r++) {
            phks_status st = ascii_record(f, &s, e, r);
            if (st != PHKS_OK)
                return st;
        }
    }
    return PHKS_OK;
}

/* ------------------------------------------------------------------- read */

static phks_status read_body(ply_file *f)
{
    phks_status st = read_header(f);
    if (st == PHKS_OK)
        st = check_counts(f);
    if (st != PHKS_OK)
        return st;
    uint64_t faces = 0;
    for (size_t i = 0; i < f->element_count; i++)
        if (f->elements[i].kind == KIND_FACE)
            faces = f->elements[i].count;
    if (faces == 0)
        return phks__fail(PHKS_ERROR_NO_TRIANGLES, "the file has no faces");
    f->xyz = phks__malloc_array((size_t)f->vertex_count, 3 * sizeof *f->xyz);
    if (!f->xyz)
        return phks__fail_oom("PLY vertices");
    if ((st = phks__tri_list_reserve(&f->tri, (size_t)faces)) != PHKS_OK)
        return st;
    return f->format == FORMAT_ASCII ? read_ascii(f) : read_binary(f);
}

phks_status phks__read_ply(const char *data, size_t size, phks__raw_mesh *raw)
{
    memset(raw, 0, sizeof *raw);
    ply_file f = {0};
    f.data = data;
    f.size = size;
    phks_status st = read_body(&f);
    phks__free(f.elements);
    phks__free(f.props);
    if (st != PHKS_OK) {
        phks__free(f.xyz);
        phks__free(f.tri.v);
        return st;
    }
    raw->xyz = f.xyz;
    raw->vertex_count = (size_t)f.vertex_count;
    raw->triangles = f.tri.v;
    raw->triangle_count = f.tri.count;
    return PHKS_OK;
}
