/*
 * core.h - what every layer shares: allocation, errors, options and
 * progress, threads, the start vectors' generator and the checksum. The
 * bottom layer: it includes only the public header. Nothing here is
 * exported; tests reach it through the build's internal dependency.
 */
#ifndef PHKS_CORE_H
#define PHKS_CORE_H

#include "phks.h"

#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__) || defined(__clang__)
#define PHKS__PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define PHKS__PRINTF(f, a)
#endif

#define PHKS__PI 3.14159265358979323846

/* ---- allocation (alloc.c): every library allocation goes through here */
void *phks__malloc(size_t size);
void *phks__calloc(size_t count, size_t size); /* zeroed, overflow-checked */
void *phks__realloc(void *ptr, size_t size);
void phks__free(void *ptr);
/* count * size bytes, NULL on overflow or failure. */
void *phks__malloc_array(size_t count, size_t size);
void *phks__realloc_array(void *ptr, size_t count, size_t size);

/* ---- errors (error.c) */
/* Records a printf-style detail for phks_last_error_message() in the
 * calling thread and returns status, so a failure is one line:
 *     return phks__fail(PHKS_ERROR_PARSE, "line %zu: ...", line); */
phks_status phks__fail(phks_status status, const char *fmt, ...)
    PHKS__PRINTF(2, 3);
/* The common case of a failed allocation. */
phks_status phks__fail_oom(const char *what);
/* Prefixes the current thread's message with "prefix: " (used to add a
 * file name to a reader's message). */
void phks__error_prefix(const char *prefix);

/* ---- options (options.c) */
/* Validates user options (NULL means defaults) into *out. Returns
 * PHKS_ERROR_INVALID_ARGUMENT with a message naming the bad field. */
phks_status phks__options_resolve(const phks_options *user, phks_options *out);
/* Reports progress; returns PHKS_ERROR_CANCELLED when the callback asks. */
phks_status phks__progress(const phks_options *opt, phks_stage stage,
                          double fraction);

/* The first field that shapes a signature's numbers (option_table.c lists
 * them) and differs between a and b, or NULL when none does; with
 * spectrum_only, only the fields a spectrum's eigenpairs depend on. When
 * detail is not NULL it receives "NAME A against B" (cut to size), an
 * enum's values by name: "hks_scaling local_area against none". */
const char *phks__options_difference(const phks_options *a,
                                     const phks_options *b, bool spectrum_only,
                                     char *detail, size_t size);
/* True when two option sets give comparable signatures. */
bool phks__options_comparable(const phks_options *a, const phks_options *b);

/* Where a long step reports: the fractions done .. done + span of `stage`,
 * through opt's callback (opt NULL: nowhere). A caller hands a step its
 * part of its own span, so nested steps report one rising sequence. */
typedef struct phks__span {
    const phks_options *opt;
    phks_stage stage;
    double done, span;
} phks__span;

/* The span reporting nowhere. */
#define PHKS__SPAN_NONE ((phks__span){NULL, PHKS_STAGE_OPERATOR, 0, 0})
/* Reports done + span * fraction (fraction in [0, 1]); returns
 * PHKS_ERROR_CANCELLED when the callback asks, PHKS_OK without one. */
phks_status phks__span_report(phks__span s, double fraction);
/* The part of s from fraction `from` to fraction `to` of it. */
phks__span phks__span_part(phks__span s, double from, double to);

/* ---- threads (parallel.c) */
/* Calls fn(ctx, begin, end) over [0, n) split into `threads` contiguous
 * chunks on worker threads (falls back to the calling thread alone). */
typedef void (*phks__range_fn)(void *ctx, size_t begin, size_t end);
void phks__parallel_for(size_t n, unsigned threads, phks__range_fn fn, void *ctx);
/* Keeps threads - 1 workers for the loops this thread starts until
 * phks__team_leave (parallel.c says why). NULL, which leave accepts, when a
 * team is entered on this thread already, threads <= 1, or nothing could
 * be started: the loops then create their threads as they go. */
typedef struct phks__team phks__team;
phks__team *phks__team_enter(unsigned threads);
void phks__team_leave(phks__team *team);
/* threads option resolved: 0 means the number of online CPUs. */
unsigned phks__thread_count(const phks_options *opt);
/* Runs fn(ctx, begin, end) over [0, n) in `batches` consecutive batches,
 * each split over `threads` workers by phks__parallel_for (so the outputs
 * never depend on the thread count when fn writes disjoint entries), and
 * reports progress through `at` before each batch: a cancellation is
 * noticed within one batch. */
phks_status phks__run_batched(size_t n, unsigned threads, phks__range_fn fn,
                              void *ctx, phks__span at, size_t batches);

/* ---- sorting and union-find */
/* A 64-bit sort key with a 32-bit payload. */
typedef struct phks__keyed {
    uint64_t key;
    uint32_t id;
} phks__keyed;

/* Stable LSD radix sort of a[0, n) on the low `bits` bits of the keys, 11
 * bits a pass, through the scratch tmp (n entries): *sorted is a or tmp,
 * whichever holds the result. Reports through `at` between passes over
 * 2^18 items or more; returns PHKS_ERROR_CANCELLED when the callback
 * asks. */
phks_status phks__radix_sort(phks__keyed *a, phks__keyed *tmp, size_t n,
                             unsigned bits, phks__span at, phks__keyed **sorted);

/* The root of x in the union-find forest `parent` (a root is its own
 * parent), halving the path on the way: nearly constant amortised time. */
static inline uint32_t phks__find_root(uint32_t *parent, uint32_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* ---- deterministic start vectors (random.c) */
/* Fills v with n numbers in [-0.5, 0.5) from a fixed generator started at
 * `state`: the solvers start from the same vectors on every run, so
 * results never depend on what ran before. */
void phks__random_fill(double *v, size_t n, uint64_t state);

/* ---- checksum (crc32.c via zlib) */
uint32_t phks__crc32(const void *data, size_t size);

#endif /* PHKS_CORE_H */
