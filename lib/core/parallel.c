/*
 * parallel.c - a minimal parallel-for over POSIX threads. The library does
 * not link OpenMP so that nothing beyond the C library's threads is pulled
 * into a host application. Work is split into contiguous equal chunks, one
 * per thread, so which thread computes what never depends on timing and
 * results are bit-identical from run to run.
 *
 * A team keeps worker threads for the length of one long computation
 * (phks__team_enter .. phks__team_leave): an eigen-solve runs hundreds
 * of parallel loops, and creating and joining threads for each cost
 * time (docs/benchmarks.md). While a team is entered on a thread, the loops
 * that thread starts go to the team's threads in small runs of units that
 * each thread takes as it becomes free (of a loop's n units, about
 * n / (8 threads) per run): on a shared machine one thread is often
 * slower than the other, and with equal halves the faster one waited for
 * it. Every caller computes each unit alone (a row, a column, a
 * stretch with its own slot for partial sums), so which thread takes which
 * run does not change the results. A loop started while the team is busy
 * (a chunk that itself runs a parallel loop) creates threads as before.
 */
#include "core/core.h"

#include <pthread.h>
#include <stdatomic.h>
#include <unistd.h>

#define MAX_THREADS 64

/* How long a team's thread polls before it sleeps on a condition
 * variable: well beyond the gap between two loops (docs/benchmarks.md
 * has the time it takes). The eigen-solver's loops follow each other
 * within microseconds, and a futex wake-up per loop (two per loop, one each
 * way) cost more than the shorter loops themselves on a virtual machine,
 * where each wake-up is an interrupt between processors. */
#define SPIN_ROUNDS 4096

static void cpu_relax(void)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#elif defined(__aarch64__)
    __asm__ __volatile__("yield");
#endif
}

typedef struct {
    phks__range_fn fn;
    void *ctx;
    size_t begin, end;
} chunk;

typedef struct {
    phks__team *team;
    unsigned index;
} seat;

/* A loop is published by writing its function and size and bumping
 * generation (release); every worker, taking part or not, answers by
 * lowering pending (release), so no worker can fall a loop behind. Both sides poll
 * first and sleep only after SPIN_ROUNDS; a sleeper is counted under the
 * lock, and the other side signals only where one is counted. */
struct phks__team {
    pthread_mutex_t lock;
    pthread_cond_t wake, done;
    unsigned workers;               /* started, numbered 1 .. workers */
    atomic_ulong generation;        /* bumped for each loop */
    atomic_uint pending;            /* workers not done with this loop */
    atomic_bool stopping;
    unsigned used;                  /* workers 1..used - 1 take part */
    phks__range_fn fn;               /* the loop: units [0, n), in runs of grain */
    void *ctx;
    size_t n, grain;
    atomic_size_t next;             /* the first unit no thread has taken */
    unsigned sleepers;              /* workers asleep on wake (under lock) */
    bool waiting;                   /* the caller asleep on done (under lock) */
    bool busy;                      /* a loop is running (caller's thread only) */
    seat seats[MAX_THREADS];
    pthread_t ids[MAX_THREADS];
};

/* The team entered on this thread, if any. */
static _Thread_local phks__team *current_team;

static void *run_chunk(void *arg)
{
    chunk *c = arg;
    c->fn(c->ctx, c->begin, c->end);
    return NULL;
}

/* The next generation after `seen`, or `seen` when the team stops. */
static unsigned long next_generation(phks__team *tm, unsigned long seen)
{
    unsigned long g = seen;
    for (int i = 0; i < SPIN_ROUNDS; i++) {
        g = atomic_load_explicit(&tm->generation, memory_order_acquire);
        if (g != seen || atomic_load(&tm->stopping))
            return g;
        cpu_relax();
    }
    pthread_mutex_lock(&tm->lock);
    tm->sleepers++;
    while ((g = atomic_load_explicit(&tm->generation, memory_order_acquire)) == seen &&
           !atomic_load(&tm->stopping))
        pthread_cond_wait(&tm->wake, &tm->lock);
    tm->sleepers--;
    pthread_mutex_unlock(&tm->lock);
    return g;
}

/* Takes runs of the current loop until none is left. */
static void take_runs(phks__team *tm)
{
    for (;;) {
        size_t begin = atomic_fetch_add_explicit(&tm->next, tm->grain,
                                                 memory_order_relaxed);
        if (begin >= tm->n)
            return;
        size_t end = tm->n - begin > tm->grain ? begin + tm->grain : tm->n;
        tm->fn(tm->ctx, begin, end);
    }
}

static void *team_worker(void *arg)
{
    const seat *s = arg;
    phks__team *tm = s->team;
    unsigned long seen = 0;
    for (;;) {
        seen = next_generation(tm, seen);
        if (atomic_load(&tm->stopping))
            break;
        if (s->index < tm->used)
            take_runs(tm);
        if (atomic_fetch_sub_explicit(&tm->pending, 1, memory_order_acq_rel) == 1) {
            pthread_mutex_lock(&tm->lock);
            if (tm->waiting)
                pthread_cond_signal(&tm->done);
            pthread_mutex_unlock(&tm->lock);
        }
    }
    return NULL;
}

static void team_destroy(phks__team *tm)
{
    pthread_cond_destroy(&tm->done);
    pthread_cond_destroy(&tm->wake);
    pthread_mutex_destroy(&tm->lock);
    phks__free(tm);
}

phks__team *phks__team_enter(unsigned threads)
{
    if (threads > MAX_THREADS)
        threads = MAX_THREADS;
    if (current_team || threads <= 1)
        return NULL;
    phks__team *tm = phks__calloc(1, sizeof *tm);
    if (!tm)
        return NULL;
    atomic_init(&tm->generation, 0);
    atomic_init(&tm->pending, 0);
    atomic_init(&tm->stopping, false);
    atomic_init(&tm->next, 0);
    if (pthread_mutex_init(&tm->lock, NULL) != 0) {
        phks__free(tm);
        return NULL;
    }
    if (pthread_cond_init(&tm->wake, NULL) != 0) {
        pthread_mutex_destroy(&tm->lock);
        phks__free(tm);
        return NULL;
    }
    if (pthread_cond_init(&tm->done, NULL) != 0) {
        pthread_cond_destroy(&tm->wake);
        pthread_mutex_destroy(&tm->lock);
        phks__free(tm);
        return NULL;
    }
    for (unsigned t = 1; t < threads; t++) {
        tm->seats[t] = (seat){tm, t};
        if (pthread_create(&tm->ids[t], NULL, team_worker, &tm->seats[t]) != 0)
            break;
        tm->workers = t;
    }
    if (tm->workers == 0) {
        team_destroy(tm);
        return NULL;
    }
    current_team = tm;
    return tm;
}

void phks__team_leave(phks__team *tm)
{
    if (!tm)
        return;
    atomic_store(&tm->stopping, true);
    pthread_mutex_lock(&tm->lock);
    pthread_cond_broadcast(&tm->wake);
    pthread_mutex_unlock(&tm->lock);
    for (unsigned t = 1; t <= tm->workers; t++)
        pthread_join(tm->ids[t], NULL);
    current_team = NULL;
    team_destroy(tm);
}

/* The loop on the team: the calling thread and workers 1 .. used - 1
 * take runs of units until none is left. */
static void team_run(phks__team *tm, phks__range_fn fn, void *ctx, size_t n,
                     unsigned threads)
{
    unsigned used = threads < tm->workers + 1 ? threads : tm->workers + 1;
    tm->busy = true;
    tm->fn = fn;
    tm->ctx = ctx;
    tm->n = n;
    tm->grain = n / (8 * (size_t)used) > 1 ? n / (8 * (size_t)used) : 1;
    atomic_store_explicit(&tm->next, 0, memory_order_relaxed);
    tm->used = used;
    atomic_store_explicit(&tm->pending, tm->workers, memory_order_relaxed);
    atomic_fetch_add_explicit(&tm->generation, 1, memory_order_release);
    pthread_mutex_lock(&tm->lock);
    if (tm->sleepers)
        pthread_cond_broadcast(&tm->wake);
    pthread_mutex_unlock(&tm->lock);
    take_runs(tm);
    bool finished = false;
    for (int i = 0; i < SPIN_ROUNDS && !finished; i++) {
        finished = atomic_load_explicit(&tm->pending, memory_order_acquire) == 0;
        if (!finished)
            cpu_relax();
    }
    if (!finished) {
        pthread_mutex_lock(&tm->lock);
        tm->waiting = true;
        while (atomic_load_explicit(&tm->pending, memory_order_acquire) != 0)
            pthread_cond_wait(&tm->done, &tm->lock);
        tm->waiting = false;
        pthread_mutex_unlock(&tm->lock);
    }
    tm->busy = false;
}

unsigned phks__thread_count(const phks_options *opt)
{
    if (opt && opt->threads)
        return opt->threads;
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : n > MAX_THREADS ? MAX_THREADS : (unsigned)n;
}

void phks__parallel_for(size_t n, unsigned threads, phks__range_fn fn, void *ctx)
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
    phks__team *tm = current_team;
    if (tm && !tm->busy) {
        team_run(tm, fn, ctx, n, threads);
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
    phks__range_fn fn;
    void *ctx;
    size_t first;
} offset_ctx;

static void run_offset(void *ctx, size_t begin, size_t end)
{
    const offset_ctx *o = ctx;
    o->fn(o->ctx, o->first + begin, o->first + end);
}

phks_status phks__run_batched(size_t n, unsigned threads, phks__range_fn fn,
                              void *ctx, phks__span at, size_t batches)
{
    for (size_t b = 0; b < batches; b++) {
        phks_status st = phks__span_report(at, (double)b / (double)batches);
        if (st != PHKS_OK)
            return st;
        size_t lo = n * b / batches, hi = n * (b + 1) / batches;
        offset_ctx o = {fn, ctx, lo};
        phks__parallel_for(hi - lo, threads, run_offset, &o);
    }
    return PHKS_OK;
}
