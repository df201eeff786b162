/*
 * cli_mesh.c - loading meshes for the `phks` tool: OBJ files with several
 * objects or groups (`o` and `g` statements) are either merged into one
 * shape, with a note on stderr, or cut down to the one named by the global
 * option --object NAME. The cut keeps every line but the faces of other
 * objects, so the vertex numbering stays the file's, and goes through
 * phks_mesh_load_memory. Other formats than the library's own (glTF, FBX,
 * COLLADA, ...) go through assimp (tools/assimp/assimp_reader.c), with the same merging,
 * note and --object.
 */
#include "common/cli_common.h"
#include "assimp_reader.h"

#include <ctype.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>

typedef struct span {
    const char *p;
    size_t n;
} span;

static int span_is(span s, const char *text)
{
    return s.p && strlen(text) == s.n && memcmp(s.p, text, s.n) == 0;
}

/* The statement's argument, trimmed. */
static span argument(const char *p, const char *end)
{
    while (p < end && (*p == ' ' || *p == '\t'))
        p++;
    while (end > p && isspace((unsigned char)end[-1]))
        end--;
    return (span){p, (size_t)(end - p)};
}

typedef struct names {
    span *v;
    size_t n, cap;
} names;

static void names_add(names *a, span s)
{
    for (size_t i = 0; i < a->n; i++)
        if (a->v[i].n == s.n && memcmp(a->v[i].p, s.p, s.n) == 0)
            return;
    if (a->n == a->cap) {
        size_t cap = a->cap ? 2 * a->cap : 8;
        span *v = realloc(a->v, cap * sizeof *v);
        if (!v)
            return;
        a->v = v;
        a->cap = cap;
    }
    a->v[a->n++] = s;
}

/* "a, b, c" (the first few) into buf. */
static void names_list(const names *a, char *buf, size_t size)
{
    size_t at = 0;
    buf[0] = '\0';
    for (size_t i = 0; i < a->n && at + 1 < size; i++) {
        int w = snprintf(buf + at, size - at, "%s%.*s", i ? ", " : "",
                         (int)a->v[i].n, a->v[i].p);
        if (w < 0)
            break;
        at += (size_t)w;
        if (i == 7 && a->n > 8) {
            snprintf(buf + (at < size ? at : size - 1), size - at, ", ...");
            break;
        }
    }
}

/* Scans the OBJ text: the names that own faces into *owners; with `want`,
 * writes the text without the faces of other objects into *kept. */
static size_t scan(const char *text, size_t size, const char *want,
                   names *owners, char *kept)
{
    span o = {0}, g = {0}, last = {0};
    const char *p = text, *end = text + size;
    size_t out = 0, selected = 0;
    while (p < end) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        const char *next = eol ? eol + 1 : end;
        const char *q = p;
        while (q < next && (*q == ' ' || *q == '\t'))
            q++;
        int keep = 1;
        if (next - q > 1 && (q[0] == 'o' || q[0] == 'g') &&
            (q[1] == ' ' || q[1] == '\t')) {
            span name = argument(q + 2, eol ? eol : end);
            if (q[0] == 'o')
                o = name;
            else
                g = name;
            last = name;
        } else if (next - q > 1 && q[0] == 'f' && (q[1] == ' ' || q[1] == '\t')) {
            names_add(owners, last.p ? last : (span){"(unnamed)", 9});
            keep = !want || span_is(o, want) || span_is(g, want);
            selected += keep && want;
        }
        if (kept && keep) {
            memcpy(kept + out, p, (size_t)(next - p));
            out += (size_t)(next - p);
        }
        p = next;
    }
    if (kept)
        kept[out] = '\0';
    return kept ? out : selected;
}

int cli_load_mesh(const char *path, phks_mesh **mesh)
{
    *mesh = NULL;
    if (assimp_reader_handles(path)) {
        char note[640], err[1024];
        phks_status st = assimp_reader_load(path, cli_object, mesh, note,
                                         sizeof note, err, sizeof err);
        if (st != PHKS_OK) {
            cli_say(stderr, "phks: %s: %s\n", path, err);
            return 1;
        }
        if (note[0])
            cli_say(stderr, "phks: %s: note: %s; --object NAME reads one\n",
                    path, note);
        return 0;
    }
    int is_obj = cli_has_suffix(path, ".obj");
    if (!is_obj && cli_object) {
        cli_say(stderr, "phks: %s: --object applies to uncompressed OBJ "
                "files and to the formats read through assimp only\n", path);
        return 1;
    }
    if (!is_obj) {
        phks_status st = phks_mesh_load(path, mesh);
        if (st != PHKS_OK)
            cli_say_fail(path, st);
        return st != PHKS_OK;
    }
    unsigned char *data;
    size_t size;
    if (cli_read_file(path, &data, &size) != 0) {
        cli_say(stderr, "phks: %s: %s\n", path, strerror(errno));
        return 1;
    }
    names owners = {0};
    char list[512];
    size_t selected = scan((const char *)data, size, cli_object, &owners, NULL);
    names_list(&owners, list, sizeof list);
    int rc = 0;
    phks_status st = PHKS_OK;
    if (cli_object && !selected) {
        cli_say(stderr, "phks: %s: no object or group named %s (it has: %s)\n",
                path, cli_object, owners.n ? list : "no faces");
        rc = 1;
    } else if (cli_object) {
        char *kept = malloc(size + 1);
        if (!kept)
            st = PHKS_ERROR_OUT_OF_MEMORY;
        else {
            size_t n = scan((const char *)data, size, cli_object, &owners,
                            kept);
            st = phks_mesh_load_memory(kept, n, PHKS_FORMAT_OBJ, mesh);
        }
        free(kept);
    } else {
        if (owners.n > 1)
            cli_say(stderr, "phks: %s: note: %zu objects or groups (%s) "
                    "merged into one shape; --object NAME reads one\n", path,
                    owners.n, list);
        st = phks_mesh_load(path, mesh);
    }
    if (st != PHKS_OK) {
        cli_say_fail(path, st);
        rc = 1;
    }
    free(owners.v);
    free(data);
    return rc;
}
