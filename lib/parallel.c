/*
 * parallel.c - a minimal parallel-for over POSIX threads. The library does
 * not link OpenMP so that nothing beyond the C library's threads is pulled
 * into a host application. Work is split into contiguous equal chunks, one
 * per thread, so which thread computes what never depends on timing and
 * results are bit-identical from run to run.
 */
#include "internal.h"

#include <pthread.h>
#include <unistd.h>

#define MAX_THREADS 64

typedef struct {
    phks_range_fn fn;
    void *ctx;
    size_t begin, end;
} chunk;

static void *run_chunk(void *arg)
{
    chunk *c = arg;
    c->fn(c->ctx, c->begin, c->end);
    return NULL;
}

unsigned phks_thread_count(const phks_options *opt)
{
    if (opt && opt->threads)
        return opt->threads;
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : n > MAX_THREADS ? MAX_THREADS : (unsigned)n;
}

void phks_parallel_for(size_t n, unsigned threads, phks_range_fn fn, void *ctx)
{
    if (threads > MAX_THREADS)
        threads = MAX_THREADS;
    if (threads > n)
        threads = (unsigned)n;
    if (threads <= 1) {
        if (n)
            fn(ctx, 0, n);
        return;
    }
    chunk chunks[MAX_THREADS];
    pthread_t ids[MAX_THREADS];
    bool started[MAX_THREADS] = {false};
    for (unsigned t = 0; t < threads; t++)
        chunks[t] = (chunk){fn, ctx, n * t / threads, n * (t + 1) / threads};
    /* Chunk 0 runs on the calling thread; a chunk whose thread cannot be
     * created runs there too, so a failure to spawn costs only speed. */
    for (unsigned t = 1; t < threads; t++)
        started[t] = pthread_create(&ids[t], NULL, run_chunk, &chunks[t]) == 0;
    run_chunk(&chunks[0]);
    for (unsigned t = 1; t < threads; t++) {
        if (started[t])
            pthread_join(ids[t], NULL);
        else
            run_chunk(&chunks[t]);
    }
}

typedef struct {
    phks_range_fn fn;
    void *ctx;
    size_t first;
} offset_ctx;

static void run_offset(void *ctx, size_t begin, size_t end)
{
    const offset_ctx *o = ctx;
    o->fn(o->ctx, o->first + begin, o->first + end);
}

phks_status phks_run_batched(size_t n, unsigned threads, phks_range_fn fn,
                             void *ctx, const phks_options *opt,
                             phks_stage stage, double done, double span,
                             size_t batches)
{
    for (size_t b = 0; b < batches; b++) {
        if (opt) {
            phks_status st = phks_progress(opt, stage,
                                           done + span * (double)b / (double)batches);
            if (st != PHKS_OK)
                return st;
        }
        size_t lo = n * b / batches, hi = n * (b + 1) / batches;
        offset_ctx o = {fn, ctx, lo};
        phks_parallel_for(hi - lo, threads, run_offset, &o);
    }
    return PHKS_OK;
}
