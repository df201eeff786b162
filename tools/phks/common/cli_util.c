/*
 * cli_util.c - errors (the library's messages in the tool's words),
 * usage, argument parsing, files and the global settings of the `phks`
 * tool.
 */
#include "common/cli_common.h"

#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

int cli_progress_mode = -1;
const char *cli_object;
unsigned cli_explicit;

int cli_error(const char *what, const char *reason)
{
    fprintf(stderr, "phks: %s: %s\n", what, reason);
    return 1;
}

int cli_error_at(const char *path, int line, const char *format, ...)
{
    va_list ap;
    va_start(ap, format);
    fprintf(stderr, "phks: %s:%d: ", path, line);
    vfprintf(stderr, format, ap);
    fputc('\n', stderr);
    va_end(ap);
    return 1;
}

/* The library's messages speak of its C API; the tool's users know its
 * commands and options. */
static const struct {
    const char *from, *to;
} rewording[] = {
    {"(missing? PHKS_DB_CREATE makes it)",
     "(missing? `phks db add` creates a database)"},
    {"PHKS_DB_READONLY", "read-only"},
    {"PHKS_DB_CREATE", "create"},
};

static void reword(char *buf, size_t size)
{
    /* "phks_db_add: ..." names a C function, "options: ..." the
     * library's check of them: the tool's message already says what was
     * done or given. */
    if (strncmp(buf, "phks_", 5) == 0) {
        size_t n = strspn(buf + 5, "abcdefghijklmnopqrstuvwxyz_") + 5;
        if (buf[n] == ':' && buf[n + 1] == ' ')
            memmove(buf, buf + n + 2, strlen(buf + n + 2) + 1);
    } else if (strncmp(buf, "options: ", 9) == 0)
        memmove(buf, buf + 9, strlen(buf + 9) + 1);
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
    cli_options_reword(buf);
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

int cli_option_count(const char *option, const char *text, unsigned long min,
                     unsigned long max, unsigned long *out)
{
    if (cli_parse_count(text, min, max, out) == 0)
        return 0;
    if (max == ULONG_MAX)
        fprintf(stderr, "phks: %s: '%s' is not a whole number of %lu or "
                        "more\n", option, text, min);
    else
        fprintf(stderr, "phks: %s: '%s' is not a whole number from %lu to "
                        "%lu\n", option, text, min, max);
    return -1;
}

int cli_option_time(const char *option, const char *text, double *out)
{
    char *end;
    double t = strtod(text, &end);
    if (end != text && !*end && t > 0 && t <= 1e9) {
        *out = t;
        return 0;
    }
    fprintf(stderr, "phks: %s: '%s' is not a time above 0 and at most 1e9 "
                    "(in units of tau)\n", option, text);
    return -1;
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

double cli_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

unsigned cli_cpu_count(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : n > 1024 ? 1024 : (unsigned)n;
}

int cli_has_suffix(const char *path, const char *suffix)
{
    size_t n = strlen(path), m = strlen(suffix);
    return n >= m && strcasecmp(path + n - m, suffix) == 0;
}
