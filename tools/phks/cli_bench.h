/*
 * cli_bench.h - the parts of `phks bench` (docs/cli.md, "bench"): the plan
 * of models and signatures to compute (cli_bench.c), computing one
 * signature (cli_bench_item.c), and scoring and reporting
 * (cli_bench_score.c).
 */
#ifndef PHKS_CLI_BENCH_H
#define PHKS_CLI_BENCH_H

#include "cli.h"

enum { KIND_COMPLETE, KIND_PARTIAL, KIND_INCOMPLETE, KIND_COUNT };
extern const char *const bench_kind_name[KIND_COUNT];

/* Queries rank the database up to this depth (for --queries-out); Top-k
 * rates use the first 5. */
#define BENCH_QUERY_DEPTH 20
/* "Next to the cut": within this fraction of the longest side of the
 * source mesh's axis-aligned bounding box from a cut vertex. */
#define BENCH_CUT_RADIUS 0.05

typedef struct bench_model {
    const cli_row *row;
    int is_query;      /* index in its class % 4 == 3                     */
    int db_kind;       /* database models: their one version             */
    size_t first_item; /* its versions' items, see bench_item_of          */
} bench_model;

typedef struct bench_item {
    size_t model;
    int kind;
    unsigned seed;           /* seed base; 0 for the complete version      */
    phks_signature *sig;     /* NULL: failed                               */
    int cached;              /* read from the cache, not computed          */
    size_t features;         /* partial and incomplete queries: features */
    size_t near_cut;         /* ... and those next to a cut vertex        */
    size_t vertices;         /* the piece's vertices                      */
    size_t vertices_near_cut;/* ... and those next to a cut vertex        */
} bench_item;

typedef struct bench_plan {
    bench_model *models;
    size_t model_count;
    bench_item *items;
    size_t item_count;
    unsigned seeds;          /* seed bases 1..seeds                        */
    phks_options options;    /* threads = 1 per worker                     */
    const char *cache_dir;   /* NULL: no cache                             */
} bench_plan;

/* Per-seed or pooled counts. */
typedef struct bench_tally {
    size_t queries[KIND_COUNT];   /* answered                     */
    size_t failed[KIND_COUNT];    /* no signature, or query error */
    size_t top[KIND_COUNT][3];    /* Top-1, Top-3, Top-5 hits     */
    size_t cut_queries[KIND_COUNT], features[KIND_COUNT],
        near_cut[KIND_COUNT], vertices[KIND_COUNT],
        vertices_near_cut[KIND_COUNT];
    size_t db_entries[KIND_COUNT], db_failed[KIND_COUNT];
} bench_tally;

/* Index of the item of model's version kind for seed base `seed`. */
size_t bench_item_of(const bench_plan *plan, size_t model, int kind,
                     unsigned seed);
/* The generator seed of a version: mix64 hash of seed base, name, kind. */
uint64_t bench_seed(unsigned seed_base, const char *name, int kind);

/* Pool task: computes plan->items[index] (ctx is the plan). */
void bench_compute(void *ctx, size_t index);

/* Builds seed's database, runs its queries, adds to *tally and writes one
 * line per query to queries_out (may be NULL). Returns 0, or 1 when the
 * database itself fails. */
int bench_score_seed(const bench_plan *plan, unsigned seed, bench_tally *tally,
                     FILE *queries_out);
void bench_tally_add(bench_tally *sum, const bench_tally *t);
/* The retrieval table and the features-at-the-cut table, markdown. */
void bench_print_tally(const bench_tally *t, const char *title);
/* The same as a JSON object on stdout (docs/cli.md). */
void bench_json_tally(const bench_tally *t);

#endif
