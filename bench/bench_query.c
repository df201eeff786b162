/*
 * bench_query.c - top-k query time of a shape database against its size,
 * on synthetic signatures of the default options (15 features and 20
 * samples x 15 scales, uniform random HKS values, spin images of random
 * bytes: every entry is about as far as every other, so the scan can
 * skip little; real catalogues with classes are easier).
 *
 *   bench-query [--runs R] [--k K] [--file PATH] [SIZE...]
 *   bench-query --reopen --file PATH [--keep] [--runs R] [--k K] [SIZE...]
 *
 * Default sizes 300 and 1000000, R = 9 queries per size, K = 10, the
 * database in memory (--file PATH: a new file, deleted afterwards). For
 * each size it prints the time to add the entries, the first query (which
 * loads the packed copy), the median and fastest of R further queries, the
 * median CPU time of a query (all threads: on a busy machine this, divided
 * by the CPU count, is what the wall time would be on an idle one) and the
 * peak resident memory so far. Threads: all online CPUs.
 *
 * --reopen times the start of a fresh handle instead: it fills the file
 * with phks_db_add_batch (batches of 10,000) and closes it, then R times
 * opens a new handle, runs one query (which loads the packed copy) and
 * closes it, and prints the median and fastest of open + first query,
 * the median CPU time of open + first query (all threads), the median
 * of a second query on the same handle, and the medians of 9 single
 * phks_db_add and phks_db_remove calls (each its own transaction) on a
 * handle that has not queried; the file ends as it began. With --keep the file is left in
 * place, and a later --reopen --keep on a file that already holds SIZE
 * entries skips the filling (the "add s" column then reads 0).
 */
#include "features/features.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#define FEATURES 15
#define SCALES 15
#define BATCH 10000

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double uniform(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}

static phks_signature *synthetic(uint64_t *state)
{
    phks_signature *sig;
    if (phks__signature_alloc(FEATURES, PHKS__SAMPLES, SCALES, &sig) != PHKS_OK)
        return NULL;
    phks_options_init(&sig->options);
    if (phks__signature_alloc_layout(sig) != PHKS_OK) {
        phks_signature_free(sig);
        return NULL;
    }
    for (size_t k = 0; k < phks__pair_count(FEATURES + PHKS__SAMPLES); k++)
        sig->geodesic[k] = (float)uniform(state);
    for (size_t i = 0; i < FEATURES + PHKS__SAMPLES; i++) {
        sig->boundary[i] = INFINITY;
        sig->vertex[i] = (uint32_t)i;
        for (int d = 0; d < 3; d++)
            sig->position[3 * i + d] = uniform(state);
        sig->persistence[i] = uniform(state);
        for (size_t s = 0; s < SCALES; s++)
            sig->vectors[i * SCALES + s] = uniform(state);
    }
    /* Random images, not the zeros alloc_layout leaves (on which every
     * proposal would tie), and a unit scale, with which the verifier
     * compares straight-line distances too, as on real signatures. */
    sig->unit_scale = 1;
    for (size_t k = 0; sig->spin && k < (FEATURES + PHKS__SAMPLES) *
                                          (size_t)PHKS__SPIN_BYTES; k++)
        sig->spin[k] = (uint8_t)(256 * uniform(state));
    return sig;
}

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double cpu_seconds(void)
{
    struct rusage use;
    getrusage(RUSAGE_SELF, &use);
    return (double)use.ru_utime.tv_sec + 1e-6 * (double)use.ru_utime.tv_usec +
           (double)use.ru_stime.tv_sec + 1e-6 * (double)use.ru_stime.tv_usec;
}

static double peak_mb(void)
{
    struct rusage use;
    getrusage(RUSAGE_SELF, &use);
    return (double)use.ru_maxrss / 1024;
}

static int fail(const char *what)
{
    fprintf(stderr, "bench-query: %s: %s\n", what, phks_last_error_message());
    return 1;
}

static bool reopen, keep;

/* --reopen: R fresh handles on file, each timed from open through its
 * first query; then a second query on the same handle. */
static int run_reopen(size_t size, int runs, size_t k, const char *file,
                      double t_add, uint64_t state)
{
    phks_hit *hits = calloc(k, sizeof *hits);
    double *first = calloc((size_t)runs, sizeof *first);
    double *second = calloc((size_t)runs, sizeof *second);
    double *cpu = calloc((size_t)runs, sizeof *cpu);
    size_t count;
    for (int r = 0; r < runs; r++) {
        phks_signature *q = synthetic(&state);
        phks_db *db;
        double c0 = cpu_seconds(), t0 = now();
        if (phks_db_open(file, 0, &db) != PHKS_OK)
            return fail("open");
        if (phks_db_query(db, q, k, hits, &count) != PHKS_OK)
            return fail("query");
        first[r] = now() - t0;
        cpu[r] = cpu_seconds() - c0;
        t0 = now();
        if (phks_db_query(db, q, k, hits, &count) != PHKS_OK)
            return fail("query");
        second[r] = now() - t0;
        phks_db_close(db);
        phks_signature_free(q);
    }
    /* One add and one removal at a time on a handle that has not
     * queried: each is its own transaction (and fsync). */
    double adds[9], removes[9];
    phks_db *db;
    if (phks_db_open(file, 0, &db) != PHKS_OK)
        return fail("open");
    for (int r = 0; r < 9; r++) {
        phks_signature *sig = synthetic(&state);
        int64_t id;
        double t0 = now();
        if (phks_db_add(db, "single", "odd", sig, &id) != PHKS_OK)
            return fail("add");
        adds[r] = now() - t0;
        t0 = now();
        if (phks_db_remove(db, id) != PHKS_OK)
            return fail("remove");
        removes[r] = now() - t0;
        phks_signature_free(sig);
    }
    phks_db_close(db);
    qsort(first, (size_t)runs, sizeof *first, by_value);
    qsort(second, (size_t)runs, sizeof *second, by_value);
    qsort(cpu, (size_t)runs, sizeof *cpu, by_value);
    qsort(adds, 9, sizeof *adds, by_value);
    qsort(removes, 9, sizeof *removes, by_value);
    printf("%10zu %9.2f %11.1f %11.1f %11.1f %11.2f %9.0f %9.2f %9.2f  "
           "best %s %.4g\n",
           size, t_add, first[runs / 2] * 1e3, first[0] * 1e3,
           cpu[runs / 2] * 1e3, second[runs / 2] * 1e3, peak_mb(),
           adds[4] * 1e3, removes[4] * 1e3, hits[0].name, hits[0].score);
    fflush(stdout);
    if (!keep)
        unlink(file);
    free(first);
    free(second);
    free(cpu);
    free(hits);
    return 0;
}

static int run(size_t size, int runs, size_t k, const char *file)
{
    phks_db *db;
    uint64_t state = 12345;
    if (reopen && keep &&
        phks_db_open(file, PHKS_DB_READONLY, &db) == PHKS_OK) {
        size_t have = 0;
        phks_status st = phks_db_count(db, &have);
        phks_db_close(db);
        if (st == PHKS_OK && have == size) /* filled by an earlier run */
            return run_reopen(size, runs, k, file, 0, state + 1);
    }
    if (file)
        unlink(file);
    if (phks_db_open(file ? file : ":memory:", PHKS_DB_CREATE, &db) != PHKS_OK)
        return fail("open");
    phks_signature **sigs = calloc(BATCH, sizeof *sigs);
    phks_db_entry *entries = calloc(BATCH, sizeof *entries);
    char (*names)[32] = calloc(BATCH, sizeof *names);
    double t0 = now();
    for (size_t done = 0; done < size;) {
        size_t n = size - done < BATCH ? size - done : BATCH;
        for (size_t i = 0; i < n; i++) {
            sigs[i] = synthetic(&state);
            snprintf(names[i], sizeof names[i], "shape-%zu", done + i);
            entries[i] = (phks_db_entry){names[i], i % 2 ? "odd" : "even",
                                         sigs[i]};
        }
        phks_status st = phks_db_add_batch(db, entries, n, NULL);
        for (size_t i = 0; i < n; i++)
            phks_signature_free(sigs[i]);
        if (st != PHKS_OK)
            return fail("add");
        done += n;
    }
    double t_add = now() - t0;
    if (reopen) {
        phks_db_close(db);
        free(names);
        free(entries);
        free(sigs);
        return run_reopen(size, runs, k, file, t_add, state);
    }

    phks_hit *hits = calloc(k, sizeof *hits);
    double *times = calloc((size_t)runs, sizeof *times);
    double *cpu = calloc((size_t)runs, sizeof *cpu);
    size_t count;
    phks_signature *q = synthetic(&state);
    t0 = now();
    if (phks_db_query(db, q, k, hits, &count) != PHKS_OK)
        return fail("query");
    double t_first = now() - t0;
    phks_signature_free(q);
    for (int r = 0; r < runs; r++) {
        q = synthetic(&state);
        double c0 = cpu_seconds();
        t0 = now();
        if (phks_db_query(db, q, k, hits, &count) != PHKS_OK)
            return fail("query");
        times[r] = now() - t0;
        cpu[r] = cpu_seconds() - c0;
        phks_signature_free(q);
    }
    qsort(times, (size_t)runs, sizeof *times, by_value);
    qsort(cpu, (size_t)runs, sizeof *cpu, by_value);
    printf("%10zu %9.2f %11.4f %11.4f %11.4f %11.4f %9.0f  best %s %.4g\n",
           size, t_add, t_first * 1e3, times[runs / 2] * 1e3, times[0] * 1e3,
           cpu[runs / 2] * 1e3, peak_mb(), hits[0].name, hits[0].score);
    fflush(stdout);
    phks_db_close(db);
    if (file)
        unlink(file);
    free(times);
    free(cpu);
    free(hits);
    free(names);
    free(entries);
    free(sigs);
    return 0;
}

int main(int argc, char **argv)
{
    int runs = 9;
    size_t k = 10;
    const char *file = NULL;
    size_t sizes[16], nsizes = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--k") && i + 1 < argc)
            k = (size_t)strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--file") && i + 1 < argc)
            file = argv[++i];
        else if (!strcmp(argv[i], "--reopen"))
            reopen = true;
        else if (!strcmp(argv[i], "--keep"))
            keep = true;
        else if (argv[i][0] != '-' && nsizes < 16)
            sizes[nsizes++] = (size_t)strtoull(argv[i], NULL, 10);
        else {
            fprintf(stderr, "usage: %s [--runs R] [--k K] [--file PATH] "
                            "[--reopen [--keep]] [SIZE...]\n", argv[0]);
            return 2;
        }
    }
    if (runs < 1 || k < 1) {
        fprintf(stderr, "bench-query: runs and k must be positive\n");
        return 2;
    }
    if ((reopen || keep) && !file) {
        fprintf(stderr, "bench-query: --reopen and --keep need --file\n");
        return 2;
    }
    if (nsizes == 0) {
        sizes[nsizes++] = 300;
        sizes[nsizes++] = 1000000;
    }
    printf("top-%zu of %d x %d synthetic signatures, %ld CPUs, median of "
           "%d queries\n", k, FEATURES, SCALES, sysconf(_SC_NPROCESSORS_ONLN),
           runs);
    if (reopen)
        printf("%10s %9s %11s %11s %11s %11s %9s %9s %9s\n", "entries",
               "add s", "open+1st ms", "best ms", "cpu ms", "2nd ms",
               "peak MB", "add1 ms", "rm1 ms");
    else
        printf("%10s %9s %11s %11s %11s %11s %9s\n", "entries", "add s",
               "first ms", "median ms", "best ms", "cpu ms", "peak MB");
    for (size_t i = 0; i < nsizes; i++)
        if (run(sizes[i], runs, k, file) != 0)
            return 1;
    return 0;
}
