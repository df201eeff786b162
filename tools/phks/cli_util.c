/*
 * cli_util.c - errors, argument parsing, files and signatures for the
 * `phks` tool.
 */
#include "cli.h"

#include <errno.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int cli_error(const char *what, const char *reason)
{
    fprintf(stderr, "phks: %s: %s\n", what, reason);
    return 1;
}

const char *cli_reason(const char *what, phks_status status)
{
    const char *msg = phks_last_error_message();
    size_t n = strlen(what);
    if (!msg || !*msg)
        return phks_status_string(status);
    /* Loader messages start with the file name, which is already said. */
    if (strncmp(msg, what, n) == 0 && msg[n] == ':' && msg[n + 1] == ' ')
        return msg + n + 2;
    return msg;
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

phks_signature *cli_signature_of(const char *path, const phks_options *options)
{
    if (cli_is_blob(path))
        return decode_file(path);
    phks_mesh *mesh;
    phks_signature *sig = NULL;
    phks_status st = phks_mesh_load(path, &mesh);
    if (st == PHKS_OK) {
        st = phks_signature_compute(mesh, options, &sig);
        phks_mesh_free(mesh);
    }
    if (st != PHKS_OK)
        cli_fail(path, st);
    return sig;
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
            "%g, HKS scaling %s, HKS-simp above %u vertices (target %u)\n",
            prefix, cli_operator_name(o->operator_kind),
            o->box == PHKS_BOX_AXIS_ALIGNED ? "axis-aligned" : "principal",
            o->tau, o->cutoff, o->eigen_count, o->feature_count,
            o->feature_scale, o->scale_count, o->scales[0],
            o->scales[o->scale_count ? o->scale_count - 1 : 0],
            o->boundary_margin,
            o->hks_scaling == PHKS_HKS_SCALING_MEAN         ? "mean"
            : o->hks_scaling == PHKS_HKS_SCALING_LOCAL_AREA ? "local-area"
                                                            : "none",
            o->simplify_above, o->simplify_target);
}
