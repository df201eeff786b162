/*
 * text_scan.c - scanning of text mesh files held in memory. The buffers are
 * not NUL-terminated, so every step is bounded by the end pointer; lines
 * are counted as they are passed so messages can point at them.
 *
 * Numbers are parsed by hand rather than with strtod on the raw text:
 * strtod needs a NUL, reads the locale's decimal point ("1,5" in a German
 * locale) and is slow. The common case (at most 19 significant digits that
 * fit a double's mantissa, a power of ten up to 22) is exact by Clinger's
 * fast path; anything else goes through strtod with the digits rewritten
 * as an integer and an exponent, a form no locale changes.
 */
#include "io/text_scan.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Significant digits kept for strtod: correct rounding of a double never
 * needs more than 767, provided a dropped non-zero tail is remembered. */
#define MAX_DIGITS 780
/* Beyond 10^±100000 every double is 0 or infinite. */
#define MAX_EXPONENT 100000

void phks__scan_init(phks__scan *s, const char *data, size_t size)
{
    /* Windows editors start UTF-8 files with a byte order mark, which
     * would otherwise hide the first keyword ("v", "OFF"). */
    if (size >= 3 && memcmp(data, "\xEF\xBB\xBF", 3) == 0) {
        data += 3;
        size -= 3;
    }
    s->p = data;
    s->end = data + size;
    s->line = 1;
    s->comment = 0;
    s->continuation = false;
}

/* At a backslash: past it and the line break it escapes, if it does. */
static bool skip_continuation(phks__scan *s)
{
    const char *q = s->p + 1;
    while (q < s->end && *q == '\r')
        q++;
    if (q < s->end && *q != '\n')
        return false;
    if (q < s->end) {
        q++;
        s->line++;
    }
    s->p = q;
    return true;
}

void phks__scan_blanks(phks__scan *s)
{
    while (s->p < s->end) {
        char c = *s->p;
        if (phks__scan_is_blank(c))
            s->p++;
        else if (c == '\\' && s->continuation) {
            if (!skip_continuation(s))
                return;
        } else
            return;
    }
}

void phks__scan_next_line(phks__scan *s)
{
    for (;;) {
        const char *start = s->p;
        const char *nl = memchr(start, '\n', (size_t)(s->end - start));
        if (!nl) {
            s->p = s->end;
            return;
        }
        const char *q = nl;
        while (q > start && q[-1] == '\r')
            q--;
        s->p = nl + 1;
        s->line++;
        if (!(s->continuation && q > start && q[-1] == '\\'))
            return;
    }
}

void phks__scan_space(phks__scan *s)
{
    while (s->p < s->end) {
        char c = *s->p;
        if (c == '\n') {
            s->p++;
            s->line++;
        } else if (s->comment && c == s->comment)
            phks__scan_next_line(s);
        else if (phks__scan_is_blank(c))
            s->p++;
        else if (c == '\\' && s->continuation) {
            if (!skip_continuation(s))
                return;
        } else
            return;
    }
}

bool phks__scan_eol(phks__scan *s)
{
    phks__scan_blanks(s);
    return s->p == s->end || *s->p == '\n' ||
           (s->comment && *s->p == s->comment);
}

static bool ends_token(const phks__scan *s, const char *q)
{
    return q == s->end || phks__scan_is_blank(*q) || *q == '\n' ||
           (s->comment && *q == s->comment);
}

size_t phks__scan_token(phks__scan *s, const char **token)
{
    phks__scan_blanks(s);
    const char *start = s->p;
    while (!ends_token(s, s->p))
        s->p++;
    *token = start;
    return (size_t)(s->p - start);
}

bool phks__token_is(const char *token, size_t len, const char *word)
{
    return strlen(word) == len && memcmp(token, word, len) == 0;
}

static char lower(char c)
{
    return c >= 'A' && c <= 'Z' ? (char)(c - 'A' + 'a') : c;
}

bool phks__token_is_nocase(const char *token, size_t len, const char *word)
{
    if (strlen(word) != len)
        return false;
    for (size_t i = 0; i < len; i++)
        if (lower(token[i]) != word[i])
            return false;
    return true;
}

static bool is_digit(char c)
{
    return c >= '0' && c <= '9';
}

static bool is_alpha(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}

/* Case-insensitive prefix match of a lower-case word at [p, end). */
static bool starts_with(const char *p, const char *end, const char *word)
{
    size_t n = strlen(word);
    if ((size_t)(end - p) < n)
        return false;
    for (size_t i = 0; i < n; i++)
        if (lower(p[i]) != word[i])
            return false;
    return true;
}

/* "inf", "infinity", "nan", "nan(...)" after the sign. */
static phks__scan_result parse_special(const char *p, const char *end,
                                      const char **stop)
{
    if (starts_with(p, end, "infinity"))
        p += 8;
    else if (starts_with(p, end, "inf"))
        p += 3;
    else if (starts_with(p, end, "nan")) {
        p += 3;
        if (p < end && *p == '(') {
            const char *q = p + 1;
            while (q < end && (is_alpha(*q) || is_digit(*q) || *q == '_'))
                q++;
            if (q < end && *q == ')')
                p = q + 1;
        }
    } else
        return PHKS__SCAN_BAD;
    *stop = p;
    return PHKS__SCAN_NON_FINITE;
}

static const double exact_powers[23] = {
    1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/* The slow, exact path: the mantissa digits in [p, q) rewritten without
 * the decimal point as "DDDDe<exp>" for strtod. */
static double parse_slow(const char *p, const char *q, long exponent)
{
    char buf[MAX_DIGITS + 32];
    size_t n = 0;
    bool fraction = false, sticky = false;
    for (; p < q; p++) {
        if (*p == '.') {
            fraction = true;
            continue;
        }
        if (n == 0 && *p == '0') {
            exponent -= fraction;
            continue;
        }
        if (n < MAX_DIGITS) {
            buf[n++] = *p;
            exponent -= fraction;
        } else {
            exponent += !fraction;
            sticky |= *p != '0';
        }
    }
    if (sticky) { /* a non-zero tail lifts the value off the truncation */
        buf[n++] = '1';
        exponent--;
    }
    if (exponent > MAX_EXPONENT)
        exponent = MAX_EXPONENT;
    if (exponent < -MAX_EXPONENT)
        exponent = -MAX_EXPONENT;
    snprintf(buf + n, sizeof buf - n, "e%ld", exponent);
    return strtod(buf, NULL);
}

phks__scan_result phks__parse_double(const char *p, const char *end,
                                   double *out, const char **stop)
{
    const char *q = p;
    bool negative = false;
    if (q < end && (*q == '+' || *q == '-'))
        negative = *q++ == '-';
    if (q < end && !is_digit(*q) && *q != '.')
        return parse_special(q, end, stop);

    const char *digits = q;
    uint64_t m = 0;
    int significant = 0;
    long exponent = 0; /* value = m * 10^exponent while significant <= 19 */
    bool any = false, fraction = false;
    for (; q < end; q++) {
        if (*q == '.' && !fraction) {
            fraction = true;
            continue;
        }
        if (!is_digit(*q))
            break;
        any = true;
        if (significant == 0 && *q == '0') {
            exponent -= fraction;
            continue;
        }
        if (significant < 19)
            m = m * 10 + (uint64_t)(*q - '0');
        significant++;
        exponent -= fraction;
    }
    if (!any)
        return PHKS__SCAN_BAD;
    /* MSVC prints infinities and NaNs as 1.#INF, -1.#IND, 1.#QNAN. */
    if (q < end && *q == '#' && q[-1] == '.' &&
        (starts_with(q + 1, end, "inf") || starts_with(q + 1, end, "ind") ||
         starts_with(q + 1, end, "qnan") || starts_with(q + 1, end, "snan"))) {
        for (q++; q < end && is_alpha(*q);)
            q++;
        *stop = q;
        return PHKS__SCAN_NON_FINITE;
    }
    const char *mantissa_end = q;

    long e10 = 0;
    if (q < end && (*q == 'e' || *q == 'E')) {
        const char *r = q + 1;
        bool eneg = false;
        if (r < end && (*r == '+' || *r == '-'))
            eneg = *r++ == '-';
        if (r < end && is_digit(*r)) {
            for (; r < end && is_digit(*r); r++)
                if (e10 < MAX_EXPONENT)
                    e10 = e10 * 10 + (*r - '0');
            e10 = eneg ? -e10 : e10;
            q = r;
        }
    }
    *stop = q;

    if (significant == 0) {
        *out = negative ? -0.0 : 0.0;
        return PHKS__SCAN_OK;
    }
    long total = exponent + e10;
    double v;
    if (significant <= 19 && m <= ((uint64_t)1 << 53) && total >= -22 &&
        total <= 22)
        v = total < 0 ? (double)m / exact_powers[-total]
                      : (double)m * exact_powers[total];
    else
        v = parse_slow(digits, mantissa_end, e10);
    v = negative ? -v : v;
    if (!isfinite(v))
        return PHKS__SCAN_NON_FINITE;
    *out = v;
    return PHKS__SCAN_OK;
}

phks__scan_result phks__parse_int(const char *p, const char *end, int64_t *out,
                                const char **stop)
{
    const char *q = p;
    bool negative = false;
    if (q < end && (*q == '+' || *q == '-'))
        negative = *q++ == '-';
    if (q >= end || !is_digit(*q))
        return PHKS__SCAN_BAD;
    uint64_t v = 0;
    bool overflow = false;
    for (; q < end && is_digit(*q); q++) {
        if (v > (UINT64_MAX - 9) / 10)
            overflow = true;
        else
            v = v * 10 + (uint64_t)(*q - '0');
    }
    *stop = q;
    if (overflow || v > (uint64_t)INT64_MAX)
        return PHKS__SCAN_RANGE;
    *out = negative ? -(int64_t)v : (int64_t)v;
    return PHKS__SCAN_OK;
}

/* Common front of the two number readers. */
static phks__scan_result scan_start(phks__scan *s)
{
    phks__scan_blanks(s);
    if (s->p == s->end)
        return PHKS__SCAN_EOF;
    if (*s->p == '\n' || (s->comment && *s->p == s->comment))
        return PHKS__SCAN_EOL;
    return PHKS__SCAN_OK;
}

/* On success or a well-formed non-finite number, the number must be the
 * whole token. The scanner moves only on success, so a failure's message
 * can quote the token. */
static phks__scan_result scan_finish(phks__scan *s, phks__scan_result r,
                                    const char *stop)
{
    if ((r == PHKS__SCAN_OK || r == PHKS__SCAN_NON_FINITE ||
         r == PHKS__SCAN_RANGE) &&
        !ends_token(s, stop))
        return PHKS__SCAN_BAD;
    if (r == PHKS__SCAN_OK)
        s->p = stop;
    return r;
}

phks__scan_result phks__scan_double(phks__scan *s, double *out)
{
    phks__scan_result r = scan_start(s);
    if (r != PHKS__SCAN_OK)
        return r;
    const char *stop = s->p;
    r = phks__parse_double(s->p, s->end, out, &stop);
    return scan_finish(s, r, stop);
}

phks__scan_result phks__scan_int(phks__scan *s, int64_t *out)
{
    phks__scan_result r = scan_start(s);
    if (r != PHKS__SCAN_OK)
        return r;
    const char *stop = s->p;
    r = phks__parse_int(s->p, s->end, out, &stop);
    return scan_finish(s, r, stop);
}

void phks__token_quote(const char *token, size_t len, char *out, size_t size)
{
    size_t limit = size > 4 ? size - 4 : 0, n = 0;
    for (; n < len && n < limit; n++) {
        unsigned char c = (unsigned char)token[n];
        out[n] = c >= 0x20 && c < 0x7f ? (char)c : '?';
    }
    if (n < len && size >= 4) {
        memcpy(out + n, "...", 3);
        n += 3;
    }
    if (size)
        out[n < size ? n : size - 1] = '\0';
}

phks_status phks__scan_fail(const phks__scan *s, phks__scan_result r,
                           const char *what, ...)
{
    char subject[160], token[40];
    va_list ap;
    va_start(ap, what);
    vsnprintf(subject, sizeof subject, what, ap);
    va_end(ap);

    const char *q = s->p;
    while (q < s->end && !ends_token(s, q))
        q++;
    phks__token_quote(s->p, (size_t)(q - s->p), token, sizeof token);

    switch (r) {
    case PHKS__SCAN_EOF:
        return phks__fail(PHKS_ERROR_TRUNCATED,
                         "line %zu: %s: the data ends early", s->line, subject);
    case PHKS__SCAN_EOL:
        return phks__fail(PHKS_ERROR_PARSE, "line %zu: %s: missing", s->line,
                         subject);
    case PHKS__SCAN_NON_FINITE:
        return phks__fail(PHKS_ERROR_NON_FINITE, "line %zu: %s: '%s' is not finite",
                         s->line, subject, token);
    case PHKS__SCAN_RANGE:
        return phks__fail(PHKS_ERROR_PARSE, "line %zu: %s: '%s' is out of range",
                         s->line, subject, token);
    case PHKS__SCAN_OK:
    case PHKS__SCAN_BAD:
        break;
    }
    return phks__fail(PHKS_ERROR_PARSE, "line %zu: %s: expected a number, found '%s'",
                     s->line, subject, token);
}

phks_status phks__tri_list_reserve(phks__tri_list *t, size_t more)
{
    if (more > PHKS__MAX_COUNT - t->count)
        return phks__fail(PHKS_ERROR_TOO_LARGE, "more than %llu triangles",
                         (unsigned long long)PHKS__MAX_COUNT);
    size_t need = t->count + more;
    if (need <= t->capacity)
        return PHKS_OK;
    size_t cap = t->capacity < 64 ? 64 : t->capacity;
    while (cap < need)
        cap = cap > SIZE_MAX / 2 ? need : 2 * cap;
    uint32_t *v = phks__realloc_array(t->v, cap, 3 * sizeof *v);
    if (!v)
        return phks__fail_oom("triangles");
    t->v = v;
    t->capacity = cap;
    return PHKS_OK;
}
