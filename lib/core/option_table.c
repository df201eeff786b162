/*
 * option_table.c - the one table of phks_options' fields: their names and
 * their enum values in every binding's spelling, their types, and which of
 * them shape a signature's numbers. The tool, the Python module and the
 * PostgreSQL extension parse and print their users' words from it, and the
 * library's own "options differ" messages come from it, so a name is
 * spelled once.
 */
#include "core/core.h"

#include <errno.h>
#include <locale.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SPELLINGS 2 /* PHKS_SPELLING_C, PHKS_SPELLING_CLI */

typedef enum { FIELD_DOUBLE, FIELD_INT32, FIELD_UINT32, FIELD_SCALES } field_type;

/* An enum's value names, by value, in each spelling; NULL-terminated. */
typedef const char *const value_names[SPELLINGS][5];

static value_names operator_values = {{"literal", "random_walk", NULL},
                                      {"literal", "random-walk", NULL}};
static value_names box_values = {{"principal", "axis_aligned", NULL},
                                 {"principal", "axis-aligned", NULL}};
static value_names scaling_values = {{"none", "mean", "local_area", NULL},
                                     {"none", "mean", "local-area", NULL}};
static value_names quadrature_values = {{"vertices", "triangles", NULL},
                                        {"vertices", "triangles", NULL}};
static value_names matching_values = {{"nearest", "verified", NULL},
                                      {"nearest", "verified", NULL}};
static value_names local_descriptor_values = {{"heat", "spin", NULL},
                                              {"heat", "spin", NULL}};
static value_names global_descriptor_values = {{"none", "d2", NULL},
                                               {"none", "d2", NULL}};
static value_names solver_values = {
    {"auto", "lanczos", "arpack", "dense", NULL},
    {"auto", "lanczos", "arpack", "dense", NULL}};

/* The order is the public index (phks.h): append only, and it is the
 * order a mismatch is looked for. 0.2.0's rows that shape a signature's
 * numbers come first, then those that do not, then later versions' rows
 * whatever they are; `spectrum` marks the rows a spectrum's eigenpairs
 * depend on. Not shaping: the solver, the tolerance and threads change how
 * the numbers are computed (or their last bits), not what they mean, and
 * the HKS-simp switch keeps a large mesh comparable with small ones.
 * `verified_only` rows shape a signature only when its matching is
 * VERIFIED (NEAREST ignores them): matching's row comes before them, so
 * two sets whose matching differs are told apart by it first, and a
 * verified-only row is compared only between two VERIFIED sets. */
static const struct option_row {
    const char *name[SPELLINGS];
    size_t offset;
    field_type type;
    value_names *values; /* FIELD_INT32 enums; NULL otherwise */
    bool shaping, spectrum, verified_only;
} rows[] = {
#define ROW(c, cli, field, type, values, shaping, spectrum)                 \
    {{c, cli}, offsetof(phks_options, field), type, values, shaping, spectrum, \
     false}
#define VERIFIED_ROW(c, cli, field, values)                                  \
    {{c, cli}, offsetof(phks_options, field), FIELD_INT32, values, true, false, \
     true}
    ROW("tau", "tau", tau, FIELD_DOUBLE, NULL, true, true),
    ROW("cutoff", "cutoff", cutoff, FIELD_DOUBLE, NULL, true, true),
    ROW("eigen_count", "eigen-count", eigen_count, FIELD_UINT32, NULL, true,
        true),
    ROW("operator_kind", "operator", operator_kind, FIELD_INT32,
        &operator_values, true, true),
    ROW("box", "box", box, FIELD_INT32, &box_values, true, true),
    ROW("quadrature", "quadrature", quadrature, FIELD_INT32,
        &quadrature_values, true, true),
    ROW("feature_count", "feature-count", feature_count, FIELD_UINT32, NULL,
        true, false),
    ROW("scale_count", "scale-count", scale_count, FIELD_UINT32, NULL, true,
        false),
    ROW("feature_scale", "feature-scale", feature_scale, FIELD_DOUBLE, NULL,
        true, false),
    ROW("boundary_margin", "boundary-margin", boundary_margin, FIELD_DOUBLE,
        NULL, true, false),
    ROW("hks_scaling", "hks-scaling", hks_scaling, FIELD_INT32,
        &scaling_values, true, false),
    ROW("matching", "matching", matching, FIELD_INT32, &matching_values, true,
        false),
    ROW("scales", "scales", scales, FIELD_SCALES, NULL, true, false),
    ROW("solver", "solver", solver, FIELD_INT32, &solver_values, false,
        false),
    ROW("threads", "threads", threads, FIELD_UINT32, NULL, false, false),
    ROW("tolerance", "tolerance", tolerance, FIELD_DOUBLE, NULL, false,
        false),
    ROW("simplify_above", "simplify-above", simplify_above, FIELD_UINT32,
        NULL, false, false),
    ROW("simplify_target", "simplify-target", simplify_target, FIELD_UINT32,
        NULL, false, false),
    /* Since 0.3.0: the spin images sit beside VERIFIED signatures' layout;
     * NEAREST signatures have none and score alike under either value. */
    VERIFIED_ROW("local_descriptor", "local-descriptor", local_descriptor,
                 &local_descriptor_values),
    /* Since 0.3.0: the shape distribution sits beside VERIFIED
     * signatures' layout and only the verified score reads it. */
    VERIFIED_ROW("global_descriptor", "global-descriptor", global_descriptor,
                 &global_descriptor_values),
#undef VERIFIED_ROW
#undef ROW
};
#define ROW_COUNT (sizeof rows / sizeof rows[0])

static bool known_spelling(phks_spelling spelling)
{
    return (unsigned)spelling < SPELLINGS;
}

static const struct option_row *row_of(uint32_t index, phks_spelling spelling)
{
    return known_spelling(spelling) && index < ROW_COUNT ? &rows[index] : NULL;
}

const char *phks_option_name(uint32_t index, phks_spelling spelling)
{
    const struct option_row *row = row_of(index, spelling);
    return row ? row->name[spelling] : NULL;
}

phks_status phks_option_type_of(uint32_t index, phks_option_type *type)
{
    if (!type || index >= ROW_COUNT)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_option_type_of: type is NULL or option %u "
                         "unknown", (unsigned)index);
    switch (rows[index].type) {
    case FIELD_DOUBLE: *type = PHKS_OPTION_REAL; break;
    case FIELD_UINT32: *type = PHKS_OPTION_COUNT; break;
    case FIELD_INT32: *type = PHKS_OPTION_ENUM; break;
    case FIELD_SCALES:
    default: *type = PHKS_OPTION_REALS; break;
    }
    return PHKS_OK;
}

phks_status phks_option_find(const char *name, phks_spelling spelling,
                             uint32_t *index)
{
    if (!name || !index)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_option_find: name or index is NULL");
    if (!known_spelling(spelling))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_option_find: unknown spelling %d",
                         (int)spelling);
    for (uint32_t i = 0; i < ROW_COUNT; i++)
        if (strcmp(rows[i].name[spelling], name) == 0) {
            *index = i;
            return PHKS_OK;
        }
    return phks__fail(PHKS_ERROR_INVALID_ARGUMENT, "unknown option '%s'",
                     name);
}

const char *phks_option_value_name(uint32_t index, int32_t value,
                                   phks_spelling spelling)
{
    const struct option_row *row = row_of(index, spelling);
    if (!row || !row->values || value < 0)
        return NULL;
    const char *const *names = (*row->values)[spelling];
    for (int32_t v = 0; names[v]; v++)
        if (v == value)
            return names[v];
    return NULL;
}

static void *field_of(phks_options *o, const struct option_row *row)
{
    return (char *)o + row->offset;
}

static const void *const_field_of(const phks_options *o,
                                  const struct option_row *row)
{
    return (const char *)o + row->offset;
}

/* ---- numbers in the C locale's words
 *
 * strtod and printf follow the host's LC_NUMERIC: under a decimal-comma
 * locale "2.5" would not parse and 2.5 would print "2,5", which the
 * scales' commas then split in two. A user's text means the same
 * whatever locale the host chose, so numbers are read and written with
 * the C locale's, on the calling thread only (uselocale), never changing
 * the process's setting. */
static locale_t c_numeric;
static pthread_once_t c_numeric_once = PTHREAD_ONCE_INIT;

static void make_c_numeric(void)
{
    c_numeric = newlocale(LC_NUMERIC_MASK, "C", (locale_t)0);
}

/* Switches the calling thread to the C locale's numbers; the locale to
 * give back to restore_numeric ((locale_t)0: nothing was switched). */
static locale_t use_c_numeric(void)
{
    pthread_once(&c_numeric_once, make_c_numeric);
    return c_numeric ? uselocale(c_numeric) : (locale_t)0;
}

static void restore_numeric(locale_t previous)
{
    if (previous)
        uselocale(previous);
}

/* ---- parsing a user's text */

/* A finite double filling all of text. */
static bool parse_real(const char *text, double *out)
{
    char *end;
    errno = 0;
    locale_t previous = use_c_numeric();
    double x = strtod(text, &end);
    restore_numeric(previous);
    if (end == text || *end || !isfinite(x))
        return false;
    *out = x;
    return true;
}

/* Decimal digits only (no sign, no space), at most max. */
static bool parse_count(const char *text, uint64_t max, uint64_t *out)
{
    uint64_t v = 0;
    if (!*text)
        return false;
    for (const char *p = text; *p; p++) {
        if (*p < '0' || *p > '9')
            return false;
        v = v * 10 + (uint64_t)(*p - '0');
        if (v > max)
            return false;
    }
    *out = v;
    return true;
}

static bool parse_enum(const char *text, const struct option_row *row,
                       phks_spelling spelling, int32_t *out)
{
    const char *const *names = (*row->values)[spelling];
    for (int32_t v = 0; names[v]; v++)
        if (strcmp(text, names[v]) == 0) {
            *out = v;
            return true;
        }
    uint64_t v;
    if (!parse_count(text, INT32_MAX, &v))
        return false;
    *out = (int32_t)v;
    return true;
}

/* Numbers separated by commas, 1..PHKS_MAX_SCALES of them. */
static bool parse_scales(const char *text, phks_options *o)
{
    char item[64];
    uint32_t n = 0;
    const char *p = text;
    for (;;) {
        size_t len = strcspn(p, ",");
        if (n == PHKS_MAX_SCALES || len == 0 || len >= sizeof item)
            return false;
        memcpy(item, p, len);
        item[len] = '\0';
        if (!parse_real(item, &o->scales[n++]))
            return false;
        if (!p[len])
            break;
        p += len + 1;
    }
    o->scale_count = n;
    return true;
}

static bool parse_value(const char *text, const struct option_row *row,
                        phks_spelling spelling, phks_options *o)
{
    void *field = field_of(o, row);
    uint64_t count;
    double real;
    int32_t value;
    switch (row->type) {
    case FIELD_DOUBLE:
        if (!parse_real(text, &real))
            return false;
        memcpy(field, &real, sizeof real);
        return true;
    case FIELD_UINT32:
        if (!parse_count(text, UINT32_MAX, &count))
            return false;
        uint32_t u = (uint32_t)count;
        memcpy(field, &u, sizeof u);
        return true;
    case FIELD_INT32:
        if (!parse_enum(text, row, spelling, &value))
            return false;
        memcpy(field, &value, sizeof value);
        return true;
    case FIELD_SCALES:
    default:
        return parse_scales(text, o);
    }
}

/* Appends printf-style text at out + *used (out has size bytes), cut to
 * fit; *used counts what the whole text needs, as snprintf's result does. */
static void append(char *out, size_t size, size_t *used, const char *fmt,
                   ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(out + (*used < size ? *used : size),
                      *used < size ? size - *used : 0, fmt, ap);
    va_end(ap);
    if (n > 0)
        *used += (size_t)n;
}

/* "a, b, c" for an enum's message. */
static void list_values(const struct option_row *row, phks_spelling spelling,
                        char *out, size_t size)
{
    const char *const *names = (*row->values)[spelling];
    size_t used = 0;
    out[0] = '\0';
    for (int v = 0; names[v]; v++)
        append(out, size, &used, "%s%s", v ? ", " : "", names[v]);
}

phks_status phks_option_set(phks_options *options, uint32_t index,
                            const char *text, phks_spelling spelling)
{
    if (!options || !text)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_option_set: options or text is NULL");
    const struct option_row *row = row_of(index, spelling);
    if (!row)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_option_set: unknown option %u or spelling %d",
                         (unsigned)index, (int)spelling);
    phks_options changed = *options, checked;
    if (!parse_value(text, row, spelling, &changed)) {
        if (row->values) {
            char names[128];
            list_values(row, spelling, names, sizeof names);
            return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                             "%s: '%s' is not one of %s",
                             row->name[spelling], text, names);
        }
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: '%s' is not %s", row->name[spelling], text,
                         row->type == FIELD_UINT32 ? "a count"
                         : row->type == FIELD_SCALES
                             ? "a list of numbers separated by commas"
                             : "a finite number");
    }
    phks_status st = phks__options_resolve(&changed, &checked);
    if (st != PHKS_OK)
        return st;
    *options = changed;
    return PHKS_OK;
}

/* ---- printing */

/* The fewest digits that read back to x. */
static int format_real(double x, char *text, size_t size)
{
    char buf[32];
    locale_t previous = use_c_numeric();
    for (int digits = 15; digits <= 17; digits++) {
        snprintf(buf, sizeof buf, "%.*g", digits, x);
        if (strtod(buf, NULL) == x)
            break;
    }
    restore_numeric(previous);
    return snprintf(text, size, "%s", buf);
}

/* Writes the value into text; the length it needs, or -1 for an enum value
 * without a name. */
static int format_value(const phks_options *o, const struct option_row *row,
                        phks_spelling spelling, char *text, size_t size)
{
    const void *field = const_field_of(o, row);
    double real;
    uint32_t count;
    int32_t value;
    switch (row->type) {
    case FIELD_DOUBLE:
        memcpy(&real, field, sizeof real);
        return format_real(real, text, size);
    case FIELD_UINT32:
        memcpy(&count, field, sizeof count);
        return snprintf(text, size, "%u", (unsigned)count);
    case FIELD_INT32: {
        memcpy(&value, field, sizeof value);
        const char *name = phks_option_value_name(
            (uint32_t)(row - rows), value, spelling);
        return name ? snprintf(text, size, "%s", name) : -1;
    }
    case FIELD_SCALES:
    default: {
        size_t used = 0;
        uint32_t n = o->scale_count < PHKS_MAX_SCALES ? o->scale_count
                                                      : PHKS_MAX_SCALES;
        if (size)
            text[0] = '\0';
        for (uint32_t s = 0; s < n; s++) {
            char digits[32];
            format_real(o->scales[s], digits, sizeof digits);
            append(text, size, &used, "%s%s", s ? "," : "", digits);
        }
        return (int)used;
    }
    }
}

phks_status phks_option_format(const phks_options *options, uint32_t index,
                               phks_spelling spelling, char *text,
                               size_t size)
{
    if (!options || !text || size == 0)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_option_format: options or text is NULL, or "
                         "size is 0");
    const struct option_row *row = row_of(index, spelling);
    if (!row)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_option_format: unknown option %u or spelling "
                         "%d", (unsigned)index, (int)spelling);
    int n = format_value(options, row, spelling, text, size);
    if (n < 0)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "%s: value has no name", row->name[spelling]);
    if ((size_t)n >= size)
        return phks__fail(PHKS_ERROR_BUFFER_TOO_SMALL,
                         "phks_option_format: %s needs %d bytes, not %zu",
                         row->name[spelling], n + 1, size);
    return PHKS_OK;
}

/* ---- comparing two option sets */

/* One value of row as a message shows it: its name in spelling, or its
 * number when it has none (a corrupt or future value). */
static void describe_value(const phks_options *o, const struct option_row *row,
                           phks_spelling spelling, char *text, size_t size)
{
    int n = format_value(o, row, spelling, text, size);
    if (n < 0) {
        int32_t value;
        memcpy(&value, const_field_of(o, row), sizeof value);
        snprintf(text, size, "%d", (int)value);
    }
}

static bool equal_values(const phks_options *a, const phks_options *b,
                         const struct option_row *row, uint32_t *scale)
{
    const void *x = const_field_of(a, row), *y = const_field_of(b, row);
    double p, q;
    switch (row->type) {
    case FIELD_DOUBLE:
        memcpy(&p, x, sizeof p);
        memcpy(&q, y, sizeof q);
        return p == q;
    case FIELD_UINT32:
    case FIELD_INT32:
        return memcmp(x, y, sizeof(uint32_t)) == 0;
    case FIELD_SCALES:
    default:
        /* scale_count is compared before scales. */
        for (uint32_t s = 0; s < a->scale_count && s < PHKS_MAX_SCALES; s++)
            if (a->scales[s] != b->scales[s]) {
                *scale = s;
                return false;
            }
        return true;
    }
}

/* Whether row takes part in comparing a with b: a shaping row, of the
 * spectrum's when only those are asked for, and a verified-only row only
 * when a's matching is VERIFIED (b's is then too, or matching's row,
 * looked at before, has already told them apart). */
static bool compared(const struct option_row *row, const phks_options *a,
                     bool spectrum_only)
{
    return row->shaping && (!spectrum_only || row->spectrum) &&
           (!row->verified_only || a->matching == PHKS_MATCHING_VERIFIED);
}

/* The first shaping option that differs between a and b, in spelling,
 * with "NAME A against B" in detail; NULL when none does. */
static const char *options_difference_in(const phks_options *a,
                                         const phks_options *b,
                                         bool spectrum_only,
                                         phks_spelling spelling, char *detail,
                                         size_t size)
{
    for (size_t i = 0; i < ROW_COUNT; i++) {
        const struct option_row *row = &rows[i];
        uint32_t scale = 0;
        if (!compared(row, a, spectrum_only) ||
            equal_values(a, b, row, &scale))
            continue;
        if (detail && size) {
            char x[64], y[64];
            if (row->type == FIELD_SCALES) {
                format_real(a->scales[scale], x, sizeof x);
                format_real(b->scales[scale], y, sizeof y);
                snprintf(detail, size, "%s[%u] %s against %s",
                         row->name[spelling], (unsigned)scale, x, y);
            } else {
                describe_value(a, row, spelling, x, sizeof x);
                describe_value(b, row, spelling, y, sizeof y);
                snprintf(detail, size, "%s %s against %s",
                         row->name[spelling], x, y);
            }
        }
        return row->name[spelling];
    }
    return NULL;
}

const char *phks__options_difference(const phks_options *a,
                                     const phks_options *b, bool spectrum_only,
                                     char *detail, size_t size)
{
    return options_difference_in(a, b, spectrum_only, PHKS_SPELLING_C, detail,
                                 size);
}

bool phks__options_comparable(const phks_options *a, const phks_options *b)
{
    return phks__options_difference(a, b, false, NULL, 0) == NULL;
}

phks_status phks_options_compare(const phks_options *a, const phks_options *b,
                                 phks_spelling spelling, char *detail,
                                 size_t size)
{
    if (!a || !b || (!detail && size))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_options_compare: a, b or detail is NULL");
    if (!known_spelling(spelling))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_options_compare: unknown spelling %d",
                         (int)spelling);
    char text[256];
    if (!options_difference_in(a, b, false, spelling, text, sizeof text))
        return PHKS_OK;
    if (size)
        snprintf(detail, size, "%s", text);
    return phks__fail(PHKS_ERROR_INCOMPATIBLE, "options differ: %s", text);
}
