/*
 * cli_bench_parts.h - the parts of `phks bench` (docs/cli.md, "bench"):
 * the plan of models and signatures to compute (../cli_bench.c), computing
 * one signature (cli_bench_item.c), scoring and reporting the protocol
 * (cli_bench_score.c), the source part: retrieving each version's own
 * source and checking its correspondences (cli_bench_source.c), the
 * comparison rows: other feature functions and the eigenvalue descriptor
 * (cli_bench_features.c), and the mode on lists of the user's own
 * (cli_bench_lists.c).
 */
#ifndef PHKS_CLI_BENCH_PARTS_H
#define PHKS_CLI_BENCH_PARTS_H

#include "common/cli_common.h"

enum { KIND_COMPLETE, KIND_PARTIAL, KIND_INCOMPLETE, KIND_COUNT };
extern const char *const bench_kind_name[KIND_COUNT];

/* --feature-function: the function whose persistent maxima are the
 * feature points. */
enum { BENCH_FEATURES_HKS, BENCH_FEATURES_AGD, BENCH_FEATURES_GC,
       BENCH_FEATURES_COUNT };
extern const char *const bench_feature_name[BENCH_FEATURES_COUNT];
/* AGD: sources of the mean distance. */
#define BENCH_AGD_SOURCES 64
/* --descriptor evd: the nonzero eigenvalues compared. */
#define BENCH_EVD_COUNT 50

/* Queries rank the database up to this depth (for --queries-out); Top-k
 * rates use the first 5. */
#define BENCH_QUERY_DEPTH 20
/* "Next to the cut": within this fraction of the longest side of the
 * source mesh's axis-aligned bounding box from a cut vertex. */
#define BENCH_CUT_RADIUS 0.05
/* A correspondence is correct within this fraction of sqrt(area) of the
 * source mesh, along its surface, from the true point. */
#define BENCH_CORRECT_RADIUS 0.1

typedef struct bench_model {
    const cli_row *row;
    int is_query;      /* index in its class % 4 == 3 (lists: a query)    */
    int db_kind;       /* database models: their one version             */
    int all_versions;  /* items of every kind: query models, and every
                          model with the source part                      */
    int one_character; /* its class's models are poses of one character  */
    size_t first_item; /* its versions' items, see bench_item_of          */
    size_t cls;        /* index in the plan's classes                     */
} bench_model;

/* A class of the selected models, in the order of their first model. */
typedef struct bench_class {
    const char *name;
    int in_group;      /* one of --group's classes                        */
} bench_class;

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
    /* The source part, partial and incomplete versions: */
    uint32_t *truth;         /* per feature: the vertex of the source mesh
                                it came from                              */
    long source_rank;        /* of its source among the first
                                BENCH_QUERY_DEPTH; 0 beyond; -1 failed    */
    int matched;             /* error and verified are set                */
    double *error;           /* per feature: its match's distance from the
                                true point, in sqrt(source area)          */
    unsigned char *verified; /* per feature: its match is verified        */
    unsigned char *recall;   /* per feature: a recall_of value            */
    double *evd;             /* --descriptor evd: BENCH_EVD_COUNT
                                eigenvalues; NULL otherwise or failed     */
} bench_item;

typedef struct bench_plan {
    bench_model *models;
    size_t model_count;
    bench_item *items;
    size_t item_count;
    unsigned seeds;          /* seed bases 1..seeds                        */
    phks_options options;    /* threads = 1 per worker                     */
    const char *cache_dir;   /* NULL: no cache                             */
    int source;              /* with the source part                       */
    int features;            /* BENCH_FEATURES_*                           */
    int evd;                 /* rank by the eigenvalue descriptor          */
    bench_class *classes;
    size_t class_count;
    struct bench_tally *by_class; /* per class: its queries' counts, pooled
                                     over the seeds                        */
    char *group_name;        /* --group NAME=A,B: NAME; NULL: none         */
    const char *group_classes; /* ... and A,B                              */
} bench_plan;

/* The sets of queries the tables report: name and one bit per kind. */
typedef struct bench_set {
    const char *name;
    unsigned kinds;
} bench_set;
/* complete, partial, incomplete, partial+incomplete, all. */
#define BENCH_SET_COUNT 5
extern const bench_set bench_sets[BENCH_SET_COUNT];

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

/* Loads the model's mesh file. On failure *reason may be set. */
phks_status bench_load(const bench_model *model, phks_mesh **mesh,
                       const char **reason);
/* What one spectrum of a version gives: the signature of each feature
 * function, and the eigenvalue descriptor. */
typedef struct bench_outputs {
    phks_signature *sig[BENCH_FEATURES_COUNT];
    double *evd;  /* NULL: fewer than BENCH_EVD_COUNT nonzero eigenvalues */
} bench_outputs;
/* Fills out (zeroed) with the signatures of the feature functions whose
 * bits are set in `features` and, when evd, the descriptor, from one
 * eigen-solve; on failure nothing is left in it. */
phks_status bench_outputs_compute(const bench_plan *plan, const phks_mesh *mesh,
                                  unsigned features, int evd,
                                  bench_outputs *out);
void bench_outputs_free(bench_outputs *out);
/* A database of eigenvalue descriptors: entries has room for every
 * model. */
typedef struct bench_evd_entry {
    const double *values;
    const char *name, *label;
} bench_evd_entry;
typedef struct bench_evd_db {
    bench_evd_entry *entries;
    size_t count;
} bench_evd_db;
/* Appends it (when it has its eigenvalues) to db. */
void bench_evd_add(bench_evd_db *db, const bench_item *it, const char *name,
                   const char *label);
/* The depth best entries for it, best first (hits has room for depth):
 * of db by phks_db_query, or with --descriptor evd of evd. */
phks_status bench_query(const bench_plan *plan, phks_db *db,
                        const bench_evd_db *evd, const bench_item *it,
                        size_t depth, phks_hit *hits, size_t *count);

/* Pool task: computes plan->items[index] (ctx is the plan). */
void bench_compute(void *ctx, size_t index);
/* Creates the --cache folder when missing (dir NULL: no cache). 0, or 1
 * after "phks: dir: reason". */
int bench_make_cache(const char *dir);
/* Computes every item of the plan on the work pool, with the progress
 * bar; BLAS on one thread per worker. */
void bench_compute_all(bench_plan *plan, unsigned workers);
/* The signatures computed, read from the cache and failed, and the wall
 * time: the report's last line (markdown), or its last fields and the
 * closing brace (JSON). */
void bench_print_footer(const bench_plan *plan, double seconds, int json);

/* Builds seed's database, runs its queries, adds to *tally and to
 * by_class[the query's class] (class_count tallies) and writes one line per
 * query to queries_out (may be NULL). Returns 0, or 1 when the database
 * itself fails. */
int bench_score_seed(const bench_plan *plan, unsigned seed, bench_tally *tally,
                     bench_tally *by_class, FILE *queries_out);
void bench_tally_add(bench_tally *sum, const bench_tally *t);
/* Rank (1..) of the first hit labelled cls, 0 when none. */
size_t bench_class_rank(const phks_hit *hits, size_t count, const char *cls);
/* Counts an answered query of kind into t: its hit at rank (1..; 0: none
 * among the hits) is a Top-k hit for k >= rank. */
void bench_tally_rank(bench_tally *t, int kind, size_t rank);
/* The retrieval table and the features-at-the-cut table, markdown. */
void bench_print_tally(const bench_tally *t, const char *title);
/* The same as a JSON object on stdout (docs/cli.md). */
void bench_json_tally(const bench_tally *t);
/* Without the cut: "## title", the database's line and the retrieval
 * table (markdown); the retrieval table alone. */
void bench_print_results(const bench_tally *t, const char *title);
void bench_print_retrieval(const bench_tally *t);
/* Without the cut: the results object's "database" and "retrieval",
 * left open for the caller's fields and closing brace; the "retrieval"
 * array alone. */
void bench_json_results(const bench_tally *t);
void bench_json_retrieval(const bench_tally *t);
/* The plan's by_class: the by-class table with --group's row (markdown),
 * or the JSON report's fields "by_class" and "group"; the table alone,
 * without its sentence. */
void bench_print_by_class(const bench_plan *plan);
void bench_json_by_class(const bench_plan *plan);
void bench_print_class_table(const bench_plan *plan);
/* " 12.5 |" (markdown) or 12.5 (JSON): percent of part in whole, "-" or
 * null when whole is 0. */
void bench_print_percent(size_t part, size_t whole);
void bench_json_percent(size_t part, size_t whole);

/* The source part: retrieves every version's source from a database of
 * the complete versions and matches the version to it, filling the items'
 * source fields. Returns 0, or 1 when the database itself fails. */
int bench_source_run(bench_plan *plan, unsigned workers);
/* Its tables (markdown) or its JSON object, per seed and pooled. */
void bench_source_print(const bench_plan *plan, const char *one_character);
void bench_source_json(const bench_plan *plan, const char *one_character);

/* `phks bench --db LIST --queries LIST` and `--leave-one-out LIST`
 * (cli_bench_lists.c): parses argv (argv[0] "bench"), reads and checks the
 * lists, computes, scores and prints the report. Returns the exit status;
 * a usage error prints usage (cli_usage). */
int bench_lists(int argc, char **argv, const phks_options *options,
                const char *usage);

#endif
