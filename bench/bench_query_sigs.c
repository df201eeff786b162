/*
 * bench_query_sigs.c - top-k query time on real signatures: the .sig
 * blobs of a directory (`phks signature MESH -o X.sig` makes them), in
 * name order, the first SIZE of them a database in memory and the next
 * 1 + R the queries: one warm-up (it loads the packed copy), then R timed.
 *
 *   bench-query-sigs [--size N] [--runs R] [--k K] [--dump] DIR
 *
 * Defaults N = 300, R = 31, K = 10. It prints the median, fastest and
 * slowest query and the median CPU time of a query (all threads). With
 * --dump it also prints every timed query's hits (id and score to 17
 * digits), so that two builds' rankings can be compared with diff.
 * Threads: all online CPUs (the library's default).
 */
#include "bench_files.h"

#include <phks.h>

#include <dirent.h>
#include <inttypes.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double cpu_seconds(void)
{
    struct rusage use;
    getrusage(RUSAGE_SELF, &use);
    return (double)use.ru_utime.tv_sec + 1e-6 * (double)use.ru_utime.tv_usec +
           (double)use.ru_stime.tv_sec + 1e-6 * (double)use.ru_stime.tv_usec;
}

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static bool is_sig(const char *name)
{
    size_t n = strlen(name);
    return n > 4 && !strcmp(name + n - 4, ".sig");
}

/* The .sig files of dir in name order; NULL when it cannot be read. */
static char **list_sigs(const char *dir, size_t *count)
{
    DIR *d = opendir(dir);
    if (!d)
        return NULL;
    char **names = NULL;
    size_t n = 0, cap = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (!is_sig(e->d_name))
            continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 256;
            names = realloc(names, cap * sizeof *names);
        }
        names[n++] = strdup(e->d_name);
    }
    closedir(d);
    if (names)
        qsort(names, n, sizeof *names, by_name);
    *count = n;
    return names;
}

static phks_signature *load(const char *dir, const char *name)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    size_t size;
    void *buffer = bench_read_file(path, &size);
    phks_signature *sig = NULL;
    if (buffer && phks_signature_decode(buffer, size, &sig) != PHKS_OK)
        fprintf(stderr, "bench-query-sigs: %s: %s\n", path,
                phks_last_error_message());
    free(buffer);
    return sig;
}

static phks_db *fill(const char *dir, char **names, size_t size)
{
    phks_db *db;
    if (phks_db_open(":memory:", PHKS_DB_CREATE, &db) != PHKS_OK)
        return NULL;
    phks_signature **sigs = calloc(size, sizeof *sigs);
    phks_db_entry *entries = calloc(size, sizeof *entries);
    bool ok = true;
    for (size_t i = 0; i < size && ok; i++) {
        ok = (sigs[i] = load(dir, names[i])) != NULL;
        entries[i] = (phks_db_entry){names[i], NULL, sigs[i]};
    }
    if (ok && phks_db_add_batch(db, entries, size, NULL) != PHKS_OK) {
        fprintf(stderr, "bench-query-sigs: add: %s\n",
                phks_last_error_message());
        ok = false;
    }
    for (size_t i = 0; i < size; i++)
        phks_signature_free(sigs[i]);
    free(sigs);
    free(entries);
    if (!ok) {
        phks_db_close(db);
        return NULL;
    }
    return db;
}

/* One query; *seconds and *cpu its wall and CPU time. */
static bool query(phks_db *db, const phks_signature *q, size_t k,
                  phks_hit *hits, size_t *count, double *seconds, double *cpu)
{
    double c0 = cpu_seconds(), t0 = now();
    phks_status st = phks_db_query(db, q, k, hits, count);
    *seconds = now() - t0;
    *cpu = cpu_seconds() - c0;
    if (st != PHKS_OK)
        fprintf(stderr, "bench-query-sigs: query: %s\n",
                phks_last_error_message());
    return st == PHKS_OK;
}

int main(int argc, char **argv)
{
    size_t size = 300, k = 10;
    int runs = 31;
    bool dump = false;
    const char *dir = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc)
            size = (size_t)strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--k") && i + 1 < argc)
            k = (size_t)strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--dump"))
            dump = true;
        else if (argv[i][0] != '-' && !dir)
            dir = argv[i];
        else
            dir = NULL, i = argc;
    }
    if (!dir || runs < 1 || k < 1 || size < 1) {
        fprintf(stderr, "usage: %s [--size N] [--runs R] [--k K] [--dump] "
                        "DIR\n", argv[0]);
        return 2;
    }
    size_t found = 0;
    char **names = list_sigs(dir, &found);
    if (found < size + 1 + (size_t)runs) {
        fprintf(stderr, "bench-query-sigs: %s: %zu .sig files, %zu needed\n",
                dir, found, size + 1 + (size_t)runs);
        return 1;
    }
    phks_db *db = fill(dir, names, size);
    if (!db)
        return 1;
    phks_hit *hits = calloc(k, sizeof *hits);
    double *times = calloc((size_t)runs, sizeof *times);
    double *cpu = calloc((size_t)runs, sizeof *cpu);
    size_t count;
    int status = 0;
    for (int r = -1; r < runs && status == 0; r++) {
        phks_signature *q = load(dir, names[size + 1 + (size_t)r]);
        double t, c;
        if (!q || !query(db, q, k, hits, &count, &t, &c))
            status = 1;
        phks_signature_free(q);
        if (status || r < 0)
            continue;
        times[r] = t;
        cpu[r] = c;
        for (size_t h = 0; dump && h < count; h++)
            printf("%s %zu %" PRId64 " %.17g\n", names[size + 1 + (size_t)r],
                   h, hits[h].id, hits[h].score);
    }
    if (status == 0) {
        qsort(times, (size_t)runs, sizeof *times, by_value);
        qsort(cpu, (size_t)runs, sizeof *cpu, by_value);
        printf("top-%zu of %zu signatures (%s), %ld CPUs, %d queries: median "
               "%.2f ms, fastest %.2f, slowest %.2f, median CPU %.2f ms\n",
               k, size, dir, sysconf(_SC_NPROCESSORS_ONLN), runs,
               times[runs / 2] * 1e3, times[0] * 1e3, times[runs - 1] * 1e3,
               cpu[runs / 2] * 1e3);
    }
    phks_db_close(db);
    for (size_t i = 0; i < found; i++)
        free(names[i]);
    free(names);
    free(hits);
    free(times);
    free(cpu);
    return status;
}
