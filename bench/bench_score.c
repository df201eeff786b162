/*
 * bench_score.c - processor time per call of what a host that scores
 * stored blobs pays per row: decoding a blob, the nearest-L1 score of two
 * signatures, the same score on plain arrays, and the full score.
 *
 *   bench-score [--calls N] QUERY.sig ENTRY.sig
 *
 * Times are processor time (CLOCK_PROCESS_CPUTIME_ID) over N calls
 * (default 20000; a tenth of that for phks_score), so that other jobs on
 * a shared machine inflate them little.
 */
#include "bench_files.h"

#include <phks.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double cpu_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

static phks_signature *load(const char *path, void **blob, size_t *size)
{
    phks_signature *sig = NULL;
    *blob = bench_read_file(path, size);
    if (!*blob || phks_signature_decode(*blob, *size, &sig) != PHKS_OK) {
        fprintf(stderr, "bench-score: %s: %s\n", path,
                *blob ? phks_last_error_message() : "cannot read");
        exit(1);
    }
    return sig;
}

/* The feature vectors of sig, one after the other. */
static double *vectors_of(const phks_signature *sig)
{
    size_t n = phks_signature_feature_count(sig);
    size_t length = phks_signature_vector_length(sig);
    double *v = malloc(n * length * sizeof *v);
    for (size_t i = 0; v && i < n; i++)
        memcpy(v + i * length, phks_signature_feature_vector(sig, i),
               length * sizeof *v);
    return v;
}

int main(int argc, char **argv)
{
    long calls = 20000;
    int a = 1;
    if (argc > 2 && strcmp(argv[1], "--calls") == 0) {
        calls = atol(argv[2]);
        a = 3;
    }
    if (argc - a != 2 || calls < 10) {
        fprintf(stderr, "usage: bench-score [--calls N] QUERY.sig ENTRY.sig\n");
        return 2;
    }
    void *qblob, *eblob;
    size_t qsize, esize;
    phks_signature *q = load(argv[a], &qblob, &qsize);
    phks_signature *e = load(argv[a + 1], &eblob, &esize);
    double *qv = vectors_of(q), *ev = vectors_of(e);
    size_t length = phks_signature_vector_length(q);
    double sink = 0, s = 0;

    double t0 = cpu_seconds();
    for (long i = 0; i < calls; i++) {
        phks_signature *d = NULL;
        phks_signature_decode(eblob, esize, &d);
        sink += (double)phks_signature_feature_count(d);
        phks_signature_free(d);
    }
    double t1 = cpu_seconds();
    for (long i = 0; i < calls; i++) {
        phks_score_nearest(q, e, &s);
        sink += s;
    }
    double t2 = cpu_seconds();
    for (long i = 0; i < calls; i++) {
        phks_score_nearest_vectors(qv, phks_signature_feature_count(q), ev,
                                   phks_signature_feature_count(e), length,
                                   &s);
        sink += s;
    }
    double t3 = cpu_seconds();
    for (long i = 0; i < calls / 10; i++) {
        phks_score(q, e, &s);
        sink += s;
    }
    double t4 = cpu_seconds();
    printf("entry blob %zu bytes, %zu x %zu features\n", esize,
           phks_signature_feature_count(q), phks_signature_feature_count(e));
    printf("decode                      %8.2f us\n", (t1 - t0) / calls * 1e6);
    printf("phks_score_nearest          %8.2f us\n", (t2 - t1) / calls * 1e6);
    printf("phks_score_nearest_vectors  %8.2f us\n", (t3 - t2) / calls * 1e6);
    printf("phks_score                  %8.2f us\n",
           (t4 - t3) / (calls / 10) * 1e6);
    fprintf(stderr, "(%g)\n", sink);
    free(qv);
    free(ev);
    phks_signature_free(q);
    phks_signature_free(e);
    free(qblob);
    free(eblob);
    return 0;
}
