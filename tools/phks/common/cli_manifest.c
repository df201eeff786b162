/*
 * cli_manifest.c - the TSV manifests of `phks db add --manifest` and
 * `phks bench` (its lists too): a header line naming the columns, then one
 * file per line with its class, and optionally its name, kind and source.
 */
#include "common/cli_common.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#define MAX_COLUMNS 64

static char *dup_string(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    return d ? memcpy(d, s, n) : NULL;
}

/* Splits line in place at tabs; returns the number of fields. */
static size_t split(char *line, char **fields)
{
    size_t n = 0;
    fields[n++] = line;
    for (char *p = line; n < MAX_COLUMNS && (p = strchr(p, '\t')) != NULL;) {
        *p++ = '\0';
        fields[n++] = p;
    }
    return n;
}

/* The header's columns; -1 for an optional one it does not name. */
typedef struct columns {
    int file, cls, name, kind, source;
} columns;

static int column(char **fields, size_t n, const char *name)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(fields[i], name) == 0)
            return (int)i;
    return -1;
}

/* A header without the columns is a mistake, not a default: taking the
 * first two columns for file and class would read a header-less file's
 * first row as its header and drop it. */
static int read_header(const char *path, char **fields, size_t n,
                       columns *c)
{
    *c = (columns){column(fields, n, "file"), column(fields, n, "class"),
                   column(fields, n, "name"), column(fields, n, "kind"),
                   column(fields, n, "source")};
    if (c->file >= 0 && c->cls >= 0)
        return 0;
    cli_error_at(path, 1, "the header names no column \"%s\" (it needs "
                 "\"file\" and \"class\", separated by tabs)",
                 c->file < 0 ? "file" : "class");
    return -1;
}

static char *join(const char *manifest, const char *name)
{
    const char *slash = strrchr(manifest, '/');
    size_t dir = name[0] == '/' || !slash ? 0 : (size_t)(slash - manifest) + 1;
    char *path = malloc(dir + strlen(name) + 1);
    if (path) {
        memcpy(path, manifest, dir);
        strcpy(path + dir, name);
    }
    return path;
}

/* Next line of text (NUL-terminated in place, "\r" dropped), or NULL. */
static char *next_line(char **cursor, char *end)
{
    char *line = *cursor;
    if (line >= end)
        return NULL;
    char *nl = memchr(line, '\n', (size_t)(end - line));
    char *stop = nl ? nl : end;
    *cursor = stop + 1;
    *stop = '\0';
    if (stop > line && stop[-1] == '\r')
        stop[-1] = '\0';
    return line;
}

/* The field of an optional column, or NULL when the row leaves it out
 * or empty. */
static const char *optional(char **fields, size_t n, int col)
{
    return col >= 0 && (size_t)col < n && *fields[col] ? fields[col] : NULL;
}

static int add_row(cli_row **rows, size_t *count, const char *path,
                   char **f, size_t n, const columns *c, int line)
{
    cli_row *r = realloc(*rows, (*count + 1) * sizeof *r);
    if (!r)
        return -1;
    *rows = r;
    const char *file = f[c->file], *name = optional(f, n, c->name);
    const char *kind = optional(f, n, c->kind);
    const char *source = optional(f, n, c->source);
    cli_row *row = &r[(*count)++];
    *row = (cli_row){dup_string(file), join(path, file), dup_string(f[c->cls]),
                     dup_string(name ? name : file),
                     kind ? dup_string(kind) : NULL,
                     source ? dup_string(source) : NULL, line};
    return row->file && row->path && row->cls && row->name &&
                   (!kind || row->kind) && (!source || row->source)
               ? 0 : -1;
}

static int parse(const char *path, char *text, size_t size, cli_row **rows,
                 size_t *count)
{
    char *cursor = text, *end = text + size, *line, *f[MAX_COLUMNS];
    columns c;
    if ((line = next_line(&cursor, end)) == NULL) {
        cli_error_at(path, 1, "empty: no header line");
        return -1;
    }
    if (read_header(path, f, split(line, f), &c) != 0)
        return -1;
    for (int lineno = 2; (line = next_line(&cursor, end)) != NULL; lineno++) {
        size_t n = split(line, f);
        if (line[0] == '\0' || line[0] == '#')
            continue;
        if ((size_t)c.file >= n || (size_t)c.cls >= n || !*f[c.file]) {
            cli_error_at(path, lineno, "expected a file and a class "
                         "separated by a tab");
            return -1;
        }
        if (add_row(rows, count, path, f, n, &c, lineno) != 0) {
            cli_error(path, "out of memory");
            return -1;
        }
    }
    return 0;
}

int cli_manifest_read(const char *path, cli_row **rows, size_t *count)
{
    unsigned char *text;
    size_t size;
    *rows = NULL;
    *count = 0;
    if (cli_read_file(path, &text, &size) != 0) {
        cli_error(path, strerror(errno));
        return -1;
    }
    int rc = parse(path, (char *)text, size, rows, count);
    free(text);
    if (rc != 0) {
        cli_manifest_free(*rows, *count);
        *rows = NULL;
        *count = 0;
    }
    return rc;
}

void cli_manifest_free(cli_row *rows, size_t count)
{
    for (size_t i = 0; i < count; i++) {
        free(rows[i].file);
        free(rows[i].path);
        free(rows[i].cls);
        free(rows[i].name);
        free(rows[i].kind);
        free(rows[i].source);
    }
    free(rows);
}
