/*
 * cli_manifest.c - the TSV manifests of `phks db add --manifest` and
 * `phks bench`: a header line, then one file per line with its class.
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

static int column(char **fields, size_t n, const char *name, size_t fallback)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(fields[i], name) == 0)
            return (int)i;
    return (int)fallback;
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

static int add_row(cli_row **rows, size_t *count, const char *path,
                   const char *name, const char *cls)
{
    cli_row *r = realloc(*rows, (*count + 1) * sizeof *r);
    if (!r)
        return -1;
    *rows = r;
    r[*count] = (cli_row){dup_string(name), join(path, name), dup_string(cls)};
    (*count)++;
    return r[*count - 1].name && r[*count - 1].path && r[*count - 1].cls
               ? 0 : -1;
}

static int parse(const char *path, char *text, size_t size, cli_row **rows,
                 size_t *count)
{
    char *cursor = text, *end = text + size, *line, *f[MAX_COLUMNS];
    int file_col = 0, class_col = 1, lineno = 0;
    char where[64];
    while ((line = next_line(&cursor, end)) != NULL) {
        lineno++;
        size_t n = split(line, f);
        if (lineno == 1) {
            file_col = column(f, n, "file", 0);
            class_col = column(f, n, "class", 1);
            continue;
        }
        if (line[0] == '\0' || line[0] == '#')
            continue;
        if ((size_t)file_col >= n || (size_t)class_col >= n || !*f[file_col]) {
            snprintf(where, sizeof where, "line %d: expected a file and a "
                     "class separated by a tab", lineno);
            cli_error(path, where);
            return -1;
        }
        if (add_row(rows, count, path, f[file_col], f[class_col]) != 0) {
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
        free(rows[i].name);
        free(rows[i].path);
        free(rows[i].cls);
    }
    free(rows);
}
