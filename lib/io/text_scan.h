/*
 * text_scan.h - what the mesh readers share: a scanner over a text buffer
 * that is not NUL-terminated and counts lines for error messages, number
 * parsing that is independent of the locale, and the growing triangle list
 * every reader fills.
 */
#ifndef PHKS_TEXT_SCAN_H
#define PHKS_TEXT_SCAN_H

#include "io/io.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Counts up to this are accepted from files: a mesh indexes vertices and
 * triangles with uint32_t and keeps UINT32_MAX as "no vertex". */
#define PHKS__MAX_COUNT ((uint64_t)UINT32_MAX - 1)

typedef struct phks__scan {
    const char *p;      /* next unread byte                                */
    const char *end;    /* one past the last byte                          */
    size_t line;        /* line of p, from 1                               */
    char comment;       /* starts a comment up to the line end, or 0       */
    bool continuation;  /* a backslash before a line break joins the lines */
} phks__scan;

/* The outcome of reading one number. */
typedef enum phks__scan_result {
    PHKS__SCAN_OK,
    PHKS__SCAN_EOL,        /* the line (or a comment) ends first            */
    PHKS__SCAN_EOF,        /* the data ends first                           */
    PHKS__SCAN_BAD,        /* something that is not a number                */
    PHKS__SCAN_NON_FINITE, /* nan, inf, or beyond the range of a double     */
    PHKS__SCAN_RANGE       /* an integer beyond the range of int64_t        */
} phks__scan_result;

void phks__scan_init(phks__scan *s, const char *data, size_t size);

static inline bool phks__scan_is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/* Skips blanks on the current line. */
void phks__scan_blanks(phks__scan *s);
/* Skips blanks, line breaks and comments. */
void phks__scan_space(phks__scan *s);
/* Moves to the start of the next line. */
void phks__scan_next_line(phks__scan *s);
/* After blanks: true at a line break, a comment or the end of the data. */
bool phks__scan_eol(phks__scan *s);

/* The next run of non-blank bytes on the current line (stopping at a
 * comment), after blanks; length 0 at the line end. */
size_t phks__scan_token(phks__scan *s, const char **token);
/* Whole-token comparisons with a NUL-terminated word. */
bool phks__token_is(const char *token, size_t len, const char *word);
bool phks__token_is_nocase(const char *token, size_t len, const char *word);

/* Reads a number on the current line. It must end at a blank, a line
 * break, a comment or the end of the data. */
phks__scan_result phks__scan_double(phks__scan *s, double *out);
phks__scan_result phks__scan_int(phks__scan *s, int64_t *out);

/* Parses a number at the start of [p, end) and sets *stop past it. No
 * leading blanks. Decimal and exponent syntax as strtod, without hex
 * floats; "inf", "nan" and the MSVC "1.#INF" forms give
 * PHKS__SCAN_NON_FINITE. The result is correctly rounded and never depends
 * on the locale. */
phks__scan_result phks__parse_double(const char *p, const char *end,
                                   double *out, const char **stop);
phks__scan_result phks__parse_int(const char *p, const char *end, int64_t *out,
                                const char **stop);

/* Records the failure of a read of `what` (printf-style) at the scanner's
 * line, with the status that fits r, and returns that status:
 * EOL and BAD give PHKS_ERROR_PARSE, EOF PHKS_ERROR_TRUNCATED, NON_FINITE
 * PHKS_ERROR_NON_FINITE, RANGE PHKS_ERROR_PARSE. */
phks_status phks__scan_fail(const phks__scan *s, phks__scan_result r,
                           const char *what, ...) PHKS__PRINTF(3, 4);

/* Copies up to size - 1 bytes of a token into out for a message, with
 * unprintable bytes replaced so binary garbage cannot garble it. */
void phks__token_quote(const char *token, size_t len, char *out, size_t size);

/* Triangles a reader collects, 3 indices each. */
typedef struct phks__tri_list {
    uint32_t *v;
    size_t count;
    size_t capacity;
} phks__tri_list;

/* Makes room for at least `more` further triangles. */
phks_status phks__tri_list_reserve(phks__tri_list *t, size_t more);

static inline phks_status phks__tri_list_push(phks__tri_list *t, uint32_t a,
                                             uint32_t b, uint32_t c)
{
    if (t->count == t->capacity) {
        phks_status st = phks__tri_list_reserve(t, 1);
        if (st != PHKS_OK)
            return st;
    }
    uint32_t *v = t->v + 3 * t->count++;
    v[0] = a;
    v[1] = b;
    v[2] = c;
    return PHKS_OK;
}

#endif /* PHKS_TEXT_SCAN_H */
