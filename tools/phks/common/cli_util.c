/*
 * cli_util.c - errors, argument parsing, files and signatures for the
 * `phks` tool.
 */
#include "common/cli_common.h"

#include <errno.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int cli_progress_mode = -1;
const char *cli_object;
unsigned cli_explicit;

int cli_error(const char *what, const char *reason)
{
    fprintf(stderr, "phks: %s: %s\n", what, reason);
    return 1;
}

/* The library's messages speak of its C API; the tool's users know its
 * options. Identifiers are replaced, and a mismatch of an option the tool
 * has gets its values in the tool's words appended. */
static const struct {
    const char *from, *to;
} rewording[] = {
    {"(missing? PHKS_DB_CREATE makes it)",
     "(missing? `phks db add` creates a database)"},
    {"PHKS_DB_READONLY", "read-only"},
    {"PHKS_DB_CREATE", "create"},
};

static const char *value_name(const char *field, double v)
{
    static _Thread_local char buf[32];
    if (strcmp(field, "operator_kind") == 0)
        return cli_operator_name((int32_t)v);
    if (strcmp(field, "hks_scaling") == 0)
        return cli_scaling_name((int32_t)v);
    if (strcmp(field, "quadrature") == 0)
        return cli_quadrature_name((int32_t)v);
    if (strcmp(field, "matching") == 0)
        return cli_matching_name((int32_t)v);
    if (strcmp(field, "box") == 0)
        return cli_box_name((int32_t)v);
    snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

static void reword(char *buf, size_t size)
{
    /* "phks_db_add: ..." names a C function: the command already says
     * what was done. */
    if (strncmp(buf, "phks_", 5) == 0) {
        size_t n = strspn(buf + 5, "abcdefghijklmnopqrstuvwxyz_") + 5;
        if (buf[n] == ':' && buf[n + 1] == ' ')
            memmove(buf, buf + n + 2, strlen(buf + n + 2) + 1);
    }
    for (size_t i = 0; i < sizeof rewording / sizeof rewording[0]; i++) {
        char *at = strstr(buf, rewording[i].from);
        if (!at)
            continue;
        size_t from = strlen(rewording[i].from), to = strlen(rewording[i].to);
        size_t tail = strlen(at + from);
        if ((size_t)(at - buf) + to + tail + 1 > size)
            continue;
        memmove(at + to, at + from, tail + 1);
        memcpy(at, rewording[i].to, to);
    }
    static const char *const fields[][2] = {
        {"operator_kind", "--operator"},
        {"hks_scaling", "--hks-scaling"},
        {"boundary_margin", "--boundary-margin"},
        {"quadrature", "--quadrature"},
        {"matching", "--matching"},
    };
    for (size_t i = 0; i < sizeof fields / sizeof fields[0]; i++) {
        char pattern[64];
        snprintf(pattern, sizeof pattern, "%s ", fields[i][0]);
        const char *at = strstr(buf, pattern);
        double x, y;
        if (!at || sscanf(at + strlen(pattern), "%lf against %lf", &x, &y) != 2)
            continue;
        char a[32], b[32], more[160];
        snprintf(a, sizeof a, "%s", value_name(fields[i][0], x));
        snprintf(b, sizeof b, "%s", value_name(fields[i][0], y));
        snprintf(more, sizeof more, "; phks option %s: %s against %s",
                 fields[i][1], a, b);
        if (strlen(buf) + strlen(more) + 1 <= size)
            strcat(buf, more);
        break;
    }
}

const char *cli_reason(const char *what, phks_status status)
{
    static _Thread_local char buf[1024];
    const char *msg = phks_last_error_message();
    size_t n = strlen(what);
    if (!msg || !*msg)
        return phks_status_string(status);
    /* Loader messages start with the file name, which is already said. */
    if (strncmp(msg, what, n) == 0 && msg[n] == ':' && msg[n + 1] == ' ')
        msg += n + 2;
    snprintf(buf, sizeof buf, "%s", msg);
    reword(buf, sizeof buf);
    return buf;
}

int cli_fail(const char *what, phks_status status)
{
    return cli_error(what, cli_reason(what, status));
}

int cli_usage(const char *line)
{
    fprintf(stderr, "usage: phks %s\n", line);
    return 2;
}

int cli_help(int argc, char **argv, const char *text)
{
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--") == 0)
            return 0;
        if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0) {
            printf("usage: phks %s\n", text);
            return 1;
        }
    }
    return 0;
}

static const cli_opt *find_opt(const cli_opt *opts, size_t nopts,
                               const char *name)
{
    for (size_t i = 0; i < nopts; i++)
        if (strcmp(opts[i].name, name) == 0)
            return &opts[i];
    return NULL;
}

int cli_parse(int argc, char **argv, int first, const cli_opt *opts,
              size_t nopts, int *npos)
{
    int n = 0, only_positional = 0;
    for (int i = first; i < argc; i++) {
        const char *a = argv[i];
        if (only_positional || a[0] != '-' || a[1] == '\0') {
            argv[first + n++] = argv[i];
            continue;
        }
        if (strcmp(a, "--") == 0) {
            only_positional = 1;
            continue;
        }
        const cli_opt *o = find_opt(opts, nopts, a);
        if (!o) {
            fprintf(stderr, "phks: unknown option %s\n", a);
            return -1;
        }
        if (o->flag)
            *o->flag = 1;
        if (o->value) {
            if (i + 1 >= argc) {
                fprintf(stderr, "phks: option %s needs a value\n", a);
                return -1;
            }
            *o->value = argv[++i];
        }
    }
    *npos = n;
    return 0;
}

int cli_parse_count(const char *text, unsigned long min, unsigned long max,
                    unsigned long *out)
{
    if (!text || *text < '0' || *text > '9')
        return -1;
    errno = 0;
    char *end;
    unsigned long v = strtoul(text, &end, 10);
    if (errno || *end || v < min || v > max)
        return -1;
    *out = v;
    return 0;
}

int cli_read_file(const char *path, unsigned char **data, size_t *size)
{
    *data = NULL;
    *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return -1;
    size_t cap = 1 << 16, n = 0;
    unsigned char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break;
        unsigned char *bigger = realloc(buf, cap *= 2);
        if (!bigger)
            free(buf);
        buf = bigger;
    }
    int bad = !buf || ferror(f);
    int err = buf ? EIO : ENOMEM;
    fclose(f);
    if (bad) {
        free(buf);
        errno = err;
        return -1;
    }
    *data = buf;
    *size = n;
    return 0;
}

int cli_write_file_atomic(const char *path, const void *data, size_t size)
{
    static atomic_ulong counter;
    char *tmp = malloc(strlen(path) + 64);
    if (!tmp)
        return -1;
    sprintf(tmp, "%s.tmp.%ld.%lu", path, (long)getpid(),
            atomic_fetch_add(&counter, 1));
    FILE *f = fopen(tmp, "wb");
    int ok = f && fwrite(data, 1, size, f) == size && fflush(f) == 0 &&
             fsync(fileno(f)) == 0;
    int err = errno;
    if (f && fclose(f) != 0 && ok) {
        ok = 0;
        err = errno;
    }
    if (ok && rename(tmp, path) != 0) {
        ok = 0;
        err = errno;
    }
    if (!ok && f)
        remove(tmp);
    free(tmp);
    errno = err;
    return ok ? 0 : -1;
}

phks_status cli_encode(const phks_signature *sig, unsigned char **blob,
                       size_t *size)
{
    size_t n = phks_signature_encoded_size(sig);
    *blob = malloc(n ? n : 1);
    if (!*blob)
        return PHKS_ERROR_OUT_OF_MEMORY;
    phks_status st = phks_signature_encode(sig, *blob, n, size);
    if (st != PHKS_OK) {
        free(*blob);
        *blob = NULL;
    }
    return st;
}

int cli_is_blob(const char *path)
{
    unsigned char magic[4] = {0};
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    size_t n = fread(magic, 1, 4, f);
    fclose(f);
    return n == 4 && memcmp(magic, "PHKS", 4) == 0;
}

static phks_signature *decode_file(const char *path)
{
    unsigned char *data;
    size_t size;
    phks_signature *sig = NULL;
    if (cli_read_file(path, &data, &size) != 0) {
        cli_error(path, strerror(errno));
        return NULL;
    }
    phks_status st = phks_signature_decode(data, size, &sig);
    free(data);
    if (st != PHKS_OK)
        cli_fail(path, st);
    return sig;
}

phks_signature *cli_signature_mesh(const char *path,
                                   const phks_options *options,
                                   phks_mesh **mesh, int verbose)
{
    *mesh = NULL;
    if (cli_is_blob(path))
        return decode_file(path);
    phks_signature *sig = NULL;
    if (cli_load_mesh(path, mesh) != 0)
        return NULL;
    if (verbose)
        printf("%s: %zu vertices, %zu triangles\n", path,
               phks_mesh_vertex_count(*mesh), phks_mesh_triangle_count(*mesh));
    phks_options o = *options;
    cli_stages stages;
    cli_stages_attach(&stages, path, &o);
    phks_status st = phks_signature_compute(*mesh, &o, &sig);
    cli_stages_end(&stages);
    if (st != PHKS_OK) {
        cli_fail(path, st);
        phks_mesh_free(*mesh);
        *mesh = NULL;
    }
    return sig;
}

phks_signature *cli_signature_of(const char *path, const phks_options *options)
{
    phks_mesh *mesh;
    phks_signature *sig = cli_signature_mesh(path, options, &mesh, 0);
    phks_mesh_free(mesh);
    return sig;
}

uint32_t cli_file_vertex(const phks_mesh *mesh, uint32_t v)
{
    const uint32_t *origin = phks_mesh_vertex_origin(mesh);
    return origin && v < phks_mesh_vertex_count(mesh) ? origin[v] : v;
}

unsigned cli_cpu_count(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : n > 1024 ? 1024 : (unsigned)n;
}

const char *cli_operator_name(int32_t operator_kind)
{
    return operator_kind == PHKS_OPERATOR_RANDOM_WALK ? "random-walk"
                                                      : "literal";
}

void cli_print_options(FILE *out, const char *prefix, const phks_options *o)
{
    fprintf(out, "%soperator %s, box %s, tau %g, cutoff %g, eigenpairs %u, "
            "features %u at %g tau, %u scales (%g..%g tau), boundary margin "
            "%g, HKS scaling %s, quadrature %s, matching %s, HKS-simp above %u vertices "
            "(target %u)\n",
            prefix, cli_operator_name(o->operator_kind),
            cli_box_name(o->box),
            o->tau, o->cutoff, o->eigen_count, o->feature_count,
            o->feature_scale, o->scale_count, o->scales[0],
            o->scales[o->scale_count ? o->scale_count - 1 : 0],
            o->boundary_margin,
            cli_scaling_name(o->hks_scaling),
            cli_quadrature_name(o->quadrature),
            cli_matching_name(o->matching),
            o->simplify_above, o->simplify_target);
}
