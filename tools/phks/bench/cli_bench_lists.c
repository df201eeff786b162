/*
 * cli_bench_lists.c - `phks bench --db LIST --queries LIST` and `phks bench
 * --leave-one-out LIST` (docs/cli.md, "bench on lists of your own"): the
 * protocol's retrieval tables for a catalogue split as its user chooses,
 * each entry as the list gives it (no generated versions), with the
 * protocol's signatures, cache, work pool and tables.
 */
#include "bench/cli_bench_parts.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Under verified matching phks_db_query ranks a shortlist of the max(k,
 * 32) entries of the least nearest score (phks.h); under nearest matching
 * it takes the k of the least score. Asked for one place more, a
 * leave-one-out query's own entry (its score 0, the least) takes the
 * extra place, and the others are shortlisted and ranked as in a database
 * without it (unless more than 32 entries equal it). */
#define LEAVE_ONE_OUT_DEPTH (32 + 1)

typedef struct lists_args {
    const char *db, *queries, *leave_one_out, *cache;
    unsigned long workers;
    int json;
} lists_args;

typedef struct list {
    const char *path;
    cli_row *rows;
    size_t count;
} list;

/* What the lists say of a model beyond its row, and what its query
 * found. */
typedef struct entry {
    int kind;          /* the kind column, KIND_*                         */
    size_t source;     /* the model its source column names; SIZE_MAX:
                          none (always in leave-one-out)                  */
    int64_t id;        /* database entries: the id; 0: not entered        */
    long rank;         /* queries: the first hit of its class, 1..20; 0:
                          none of the 20; -1: failed                      */
    long source_rank;  /* ... of its source's entry, the same way; -1 also
                          without a source                                */
    int has_best;      /* ... best is its best hit                        */
    phks_hit best;
} entry;

typedef struct lists {
    list db, queries;      /* leave-one-out: db alone, queries empty      */
    int leave_one_out;
    size_t first_query;    /* models first_query.. are the queries        */
    entry *entries;        /* per model                                   */
    bench_plan plan;       /* models: db's rows, then the queries' (not in
                              leave-one-out: each model is both)          */
    bench_tally results;   /* by the queries' kind column                 */
    bench_tally source;    /* the same, a hit being the source's entry    */
    size_t named_sources;  /* queries with a source column                */
} lists;

static int parse_args(int argc, char **argv, lists_args *a)
{
    const char *jobs = NULL;
    const cli_opt opts[] = {
        {"--db", &a->db, NULL},
        {"--queries", &a->queries, NULL},
        {"--leave-one-out", &a->leave_one_out, NULL},
        {"--cache", &a->cache, NULL},
        {"-j", &jobs, NULL},
        {"--json", NULL, &a->json},
    };
    int n;
    a->workers = cli_cpu_count();
    if (cli_parse(argc, argv, 1, opts, sizeof opts / sizeof opts[0], &n) ||
        (jobs && cli_option_count("-j", jobs, 1, 1024, &a->workers)))
        return -1;
    if (n != 0) {
        fprintf(stderr, "phks: bench: no MANIFEST with --db, --queries or "
                        "--leave-one-out\n");
        return -1;
    }
    if (a->leave_one_out ? a->db || a->queries : !a->db || !a->queries) {
        fprintf(stderr, "phks: bench: either --db LIST and --queries LIST, "
                        "or --leave-one-out LIST\n");
        return -1;
    }
    return 0;
}

/* ---- reading and checking the lists --------------------------------------- */
static int read_list(const char *path, list *l)
{
    l->path = path;
    if (cli_manifest_read(path, &l->rows, &l->count) != 0)
        return -1;
    if (l->count == 0) {
        cli_error(path, "no entries");
        return -1;
    }
    return 0;
}

/* The row's kind column as KIND_* (complete when empty), and its file
 * there to be read: a list's mistake is named before the hours of
 * signatures, not counted as a failed signature after them. */
static int check_row(const list *l, const cli_row *row, int *kind)
{
    *kind = row->kind ? KIND_COUNT : KIND_COMPLETE;
    for (int k = 0; row->kind && k < KIND_COUNT; k++)
        if (strcmp(row->kind, bench_kind_name[k]) == 0)
            *kind = k;
    if (*kind == KIND_COUNT)
        return cli_error_at(l->path, row->line, "unknown kind \"%s\" (one "
                            "of complete, partial, incomplete)", row->kind);
    if (access(row->path, R_OK) != 0)
        return cli_error_at(l->path, row->line, "%s: %s", row->path,
                            strerror(errno));
    return 0;
}

/* Rows by name, then line. */
static int by_name(const void *x, const void *y)
{
    const cli_row *a = *(const cli_row *const *)x;
    const cli_row *b = *(const cli_row *const *)y;
    int c = strcmp(a->name, b->name);
    return c ? c : (a->line > b->line) - (a->line < b->line);
}

/* The database list's rows sorted by name (free it), or NULL after saying
 * what is wrong: two entries of one name would make a source ambiguous. */
static const cli_row **index_names(const list *db)
{
    const cli_row **order = malloc(db->count * sizeof *order);
    if (!order) {
        cli_error(db->path, "out of memory");
        return NULL;
    }
    for (size_t i = 0; i < db->count; i++)
        order[i] = &db->rows[i];
    qsort(order, db->count, sizeof *order, by_name);
    for (size_t i = 1; i < db->count; i++)
        if (strcmp(order[i - 1]->name, order[i]->name) == 0) {
            cli_error_at(db->path, order[i]->line, "the name \"%s\" is line "
                         "%d's too (a name column tells entries of one file "
                         "apart)", order[i]->name, order[i - 1]->line);
            free(order);
            return NULL;
        }
    return order;
}

/* The index of the database row named name, or SIZE_MAX. */
static size_t find_name(const list *db, const cli_row **order,
                        const char *name)
{
    size_t lo = 0, hi = db->count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        int c = strcmp(order[mid]->name, name);
        if (c == 0)
            return (size_t)(order[mid] - db->rows);
        if (c < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return SIZE_MAX;
}

/* Every row's kind and file; with --queries every source a name of the
 * database list. A list's source column is not read in leave-one-out,
 * where it may be something else (the shared manifests' provenance). */
static int check_lists(lists *l)
{
    const cli_row **order = index_names(&l->db);
    int rc = !order;
    for (size_t m = 0; !rc && m < l->plan.model_count; m++) {
        const list *in = m < l->db.count ? &l->db : &l->queries;
        const cli_row *row = l->plan.models[m].row;
        entry *e = &l->entries[m];
        e->source = SIZE_MAX;
        rc = check_row(in, row, &e->kind);
        if (rc || in != &l->queries || !row->source)
            continue;
        e->source = find_name(&l->db, order, row->source);
        l->named_sources++;
        if (e->source == SIZE_MAX)
            rc = cli_error_at(in->path, row->line, "source \"%s\" is no "
                              "name of %s", row->source, l->db.path);
    }
    free(order);
    return rc;
}

/* ---- the plan --------------------------------------------------------------- */
/* The class's index in the plan, added when new. */
static size_t class_of(bench_plan *p, const char *cls)
{
    size_t c = 0;
    while (c < p->class_count && strcmp(p->classes[c].name, cls) != 0)
        c++;
    if (c == p->class_count)
        p->classes[p->class_count++].name = cls;
    return c;
}

/* Models by path, then index. */
static int by_path(const void *x, const void *y)
{
    const bench_model *a = *(const bench_model *const *)x;
    const bench_model *b = *(const bench_model *const *)y;
    int c = strcmp(a->row->path, b->row->path);
    return c ? c : (a > b) - (a < b);
}

/* One item (the file as it is) per file: the models of one path share
 * the first one's, so that a file in both lists (a query that is a
 * database entry's copy) is computed once. */
static int plan_items(bench_plan *p)
{
    size_t n = p->model_count;
    const bench_model **order = malloc(n * sizeof *order);
    size_t *first = malloc(n * sizeof *first);  /* of the model's path */
    p->items = calloc(n, sizeof *p->items);
    int rc = order && first && p->items ? 0
             : cli_error("bench", "out of memory");
    for (size_t m = 0; !rc && m < n; m++) {
        order[m] = &p->models[m];
        first[m] = m;
    }
    if (!rc)
        qsort(order, n, sizeof *order, by_path);
    for (size_t i = 1; !rc && i < n; i++)
        if (strcmp(order[i - 1]->row->path, order[i]->row->path) == 0)
            first[order[i] - p->models] = first[order[i - 1] - p->models];
    for (size_t m = 0; !rc && m < n; m++) {
        if (first[m] != m) {
            p->models[m].first_item = p->models[first[m]].first_item;
            continue;
        }
        p->models[m].first_item = p->item_count;
        p->items[p->item_count++] = (bench_item){.model = m,
                                                 .kind = KIND_COMPLETE};
    }
    free(order);
    free(first);
    return rc;
}

/* One model per row: the database's, then the queries'; the by-class
 * rows are the queries' classes in the order of their first query. */
static int plan_models(lists *l)
{
    bench_plan *p = &l->plan;
    size_t n = l->db.count + (l->leave_one_out ? 0 : l->queries.count);
    p->models = calloc(n, sizeof *p->models);
    p->classes = calloc(n, sizeof *p->classes);
    l->entries = calloc(n, sizeof *l->entries);
    if (!p->models || !p->classes || !l->entries)
        return cli_error("bench", "out of memory");
    p->model_count = n;
    l->first_query = l->leave_one_out ? 0 : l->db.count;
    for (size_t m = 0; m < n; m++) {
        bench_model *model = &p->models[m];
        model->row = m < l->db.count ? &l->db.rows[m]
                                     : &l->queries.rows[m - l->db.count];
        model->is_query = m >= l->first_query;
        model->db_kind = KIND_COMPLETE;
        if (model->is_query)
            model->cls = class_of(p, model->row->cls);
    }
    p->by_class = calloc(p->class_count, sizeof *p->by_class);
    if (!p->by_class)
        return cli_error("bench", "out of memory");
    return plan_items(p);
}

/* ---- scoring ------------------------------------------------------------------ */
/* Model m's item (its sig NULL when it failed). */
static const bench_item *item(const bench_plan *p, size_t m)
{
    return &p->items[p->models[m].first_item];
}

/* The database list's entries whose signature was made, in list order. */
static phks_status fill_db(lists *l, phks_db *db)
{
    const bench_plan *p = &l->plan;
    size_t n = 0, count = l->db.count;
    phks_db_entry *e = malloc(count * sizeof *e);
    int64_t *ids = malloc(count * sizeof *ids);
    size_t *model = malloc(count * sizeof *model);
    phks_status st = e && ids && model ? PHKS_OK : PHKS_ERROR_OUT_OF_MEMORY;
    for (size_t m = 0; st == PHKS_OK && m < count; m++) {
        const cli_row *row = p->models[m].row;
        int kind = l->entries[m].kind;
        const bench_item *it = item(p, m);
        if (!it->sig) {
            l->results.db_failed[kind]++;
            continue;
        }
        l->results.db_entries[kind]++;
        model[n] = m;
        e[n++] = (phks_db_entry){row->name, row->cls, it->sig};
    }
    if (st == PHKS_OK && n)
        st = phks_db_add_batch(db, e, n, ids);
    for (size_t i = 0; st == PHKS_OK && i < n; i++)
        l->entries[model[i]].id = ids[i];
    free(e);
    free(ids);
    free(model);
    return st;
}

/* Rank (1..) of the hit of id, 0 when none. */
static long rank_of(const phks_hit *hits, size_t count, int64_t id)
{
    for (size_t r = 0; r < count; r++)
        if (hits[r].id == id)
            return (long)r + 1;
    return 0;
}

/* The BENCH_QUERY_DEPTH best entries for model m, leaving its own entry
 * out (a query of --queries has none). */
static phks_status query(const lists *l, phks_db *db, size_t m, phks_hit *hits,
                         size_t *count)
{
    phks_hit all[LEAVE_ONE_OUT_DEPTH];
    size_t found;
    phks_status st = bench_query(&l->plan, db, NULL, item(&l->plan, m),
                                 l->leave_one_out ? LEAVE_ONE_OUT_DEPTH
                                                  : BENCH_QUERY_DEPTH,
                                 all, &found);
    *count = 0;
    for (size_t r = 0; st == PHKS_OK && r < found; r++)
        if (all[r].id != l->entries[m].id && *count < BENCH_QUERY_DEPTH)
            hits[(*count)++] = all[r];
    return st;
}

/* Runs model m's query and counts it into the results, its class's row
 * and, when it names a source, the source's tally. */
static void run_query(lists *l, phks_db *db, size_t m)
{
    const cli_row *row = l->plan.models[m].row;
    entry *e = &l->entries[m];
    phks_hit hits[BENCH_QUERY_DEPTH];
    size_t count;
    bench_tally q = {0};
    phks_status st = query(l, db, m, hits, &count);
    if (item(&l->plan, m)->sig && st != PHKS_OK)
        cli_say_fail(row->path, st);
    e->rank = e->source_rank = -1;
    if (st != PHKS_OK)
        q.failed[e->kind]++;
    else {
        e->rank = (long)bench_class_rank(hits, count, row->cls);
        bench_tally_rank(&q, e->kind, (size_t)e->rank);
        e->has_best = count > 0;
        if (count)
            e->best = hits[0];
    }
    bench_tally_add(&l->results, &q);
    bench_tally_add(&l->plan.by_class[l->plan.models[m].cls], &q);
    if (e->source == SIZE_MAX)
        return;
    int64_t source_id = l->entries[e->source].id;
    if (st != PHKS_OK || !source_id)
        l->source.failed[e->kind]++;
    else {
        e->source_rank = rank_of(hits, count, source_id);
        bench_tally_rank(&l->source, e->kind, (size_t)e->source_rank);
    }
}

/* 0, or 1 when the database itself fails. */
static int score(lists *l)
{
    phks_db *db;
    phks_status st = phks_db_open(":memory:", PHKS_DB_CREATE, &db);
    if (st == PHKS_OK)
        st = fill_db(l, db);
    if (st != PHKS_OK) {
        cli_say_fail(":memory:", st);
        phks_db_close(db);
        return 1;
    }
    for (size_t m = l->first_query; m < l->plan.model_count; m++)
        run_query(l, db, m);
    phks_db_close(db);
    return 0;
}

/* ---- markdown ------------------------------------------------------------------ */
static void print_header(const lists *l, unsigned workers)
{
    printf("# phks bench\n\nlibphks %s; ", phks_version_string());
    if (l->leave_one_out)
        printf("leave-one-out over %s (%zu entries)", l->db.path, l->db.count);
    else
        printf("database %s (%zu entries), queries %s (%zu queries)",
               l->db.path, l->db.count, l->queries.path, l->queries.count);
    printf("; %u workers.\n\n", workers);
    cli_print_options(stdout, "Options: ", &l->plan.options);
    if (l->leave_one_out)
        printf("\nLeave-one-out: each entry of the list, as the list gives "
               "it, against a database of all the others (phks_db_query, "
               "k = 20). Top-k: an entry of the query's class among the k "
               "best, Top-1 the nearest neighbour's; rates over the "
               "answered queries, by their kind column.\n");
    else
        printf("\nEach query of the queries list against a database of the "
               "database list's entries (phks_db_query, k = 20), each file "
               "as the list gives it. Top-k: an entry of the query's class "
               "among the k best; rates over the answered queries, by "
               "their kind column.\n");
}

static void print_report(const lists *l)
{
    bench_print_results(&l->results, "Results");
    printf("\nBy class: answered and failed queries, and Top-k in percent "
           "of the class's answered queries of each set:\n");
    bench_print_class_table(&l->plan);
    if (!l->named_sources)
        return;
    printf("\n## Source retrieval\n\nThe %zu queries that name their "
           "source: a hit is the source's own entry among the k best; a "
           "query fails when its signature or its source's failed.\n\n",
           l->named_sources);
    bench_print_retrieval(&l->source);
}

/* ---- JSON ------------------------------------------------------------------------ */
static void json_string_or_null(const char *s)
{
    if (s)
        cli_json_string(s);
    else
        fputs("null", stdout);
}

/* A rank, or null when failed. */
static void json_rank(long rank)
{
    if (rank >= 0)
        printf("%ld", rank);
    else
        fputs("null", stdout);
}

static void json_header(const lists *l, unsigned workers)
{
    printf("{\"library\": \"%s\", \"mode\": \"%s\", \"db_list\": ",
           phks_version_string(), l->leave_one_out ? "leave-one-out"
                                                   : "queries");
    cli_json_string(l->db.path);
    fputs(", \"queries_list\": ", stdout);
    json_string_or_null(l->leave_one_out ? NULL : l->queries.path);
    printf(", \"workers\": %u,\n  \"options\": ", workers);
    cli_json_options(&l->plan.options);
    printf(",\n  \"database_entries\": %zu, \"query_count\": %zu",
           l->db.count, l->plan.model_count - l->first_query);
}

static void json_query(const lists *l, size_t m)
{
    const cli_row *row = l->plan.models[m].row;
    const entry *e = &l->entries[m];
    fputs("{\"name\": ", stdout);
    cli_json_string(row->name);
    fputs(", \"file\": ", stdout);
    cli_json_string(row->file);
    fputs(", \"class\": ", stdout);
    cli_json_string(row->cls);
    printf(", \"kind\": \"%s\", \"rank\": ", bench_kind_name[e->kind]);
    json_rank(e->rank);
    fputs(", \"best\": ", stdout);
    json_string_or_null(e->has_best ? e->best.name : NULL);
    fputs(", \"best_class\": ", stdout);
    json_string_or_null(e->has_best ? e->best.label : NULL);
    fputs(", \"source\": ", stdout);
    json_string_or_null(e->source != SIZE_MAX ? row->source : NULL);
    fputs(", \"source_rank\": ", stdout);
    json_rank(e->source_rank);
    putchar('}');
}

static void json_report(const lists *l)
{
    fputs(",\n  \"results\": ", stdout);
    bench_json_results(&l->results);
    putchar('}');
    bench_json_by_class(&l->plan);
    fputs(",\n  \"source\": ", stdout);
    if (l->named_sources) {
        printf("{\"named\": %zu, \"retrieval\": ", l->named_sources);
        bench_json_retrieval(&l->source);
        putchar('}');
    } else
        fputs("null", stdout);
    fputs(",\n  \"queries\": [", stdout);
    for (size_t m = l->first_query; m < l->plan.model_count; m++) {
        fputs(m > l->first_query ? ",\n    " : "\n    ", stdout);
        json_query(l, m);
    }
    fputs("\n  ]", stdout);
}

/* ---- running -------------------------------------------------------------------- */
static int run(const lists_args *a, lists *l)
{
    if (bench_make_cache(a->cache) != 0)
        return 1;
    unsigned workers = (unsigned)a->workers;
    if (a->json)
        json_header(l, workers);
    else
        print_header(l, workers);
    fflush(stdout);
    double start = cli_seconds();
    bench_compute_all(&l->plan, workers);
    int rc = score(l);
    if (a->json)
        json_report(l);
    else
        print_report(l);
    bench_print_footer(&l->plan, cli_seconds() - start, a->json);
    return rc;
}

static void free_lists(lists *l)
{
    for (size_t i = 0; i < l->plan.item_count; i++)
        phks_signature_free(l->plan.items[i].sig);
    free(l->plan.items);
    free(l->plan.models);
    free(l->plan.classes);
    free(l->plan.by_class);
    free(l->entries);
    cli_manifest_free(l->db.rows, l->db.count);
    if (!l->leave_one_out)
        cli_manifest_free(l->queries.rows, l->queries.count);
}

int bench_lists(int argc, char **argv, const phks_options *options,
                const char *usage)
{
    lists_args a = {0};
    if (parse_args(argc, argv, &a) != 0)
        return cli_usage(usage);
    lists l = {.leave_one_out = a.leave_one_out != NULL};
    l.plan.options = *options;
    l.plan.options.threads = 1;
    l.plan.cache_dir = a.cache;
    l.plan.features = BENCH_FEATURES_HKS;
    int rc = read_list(l.leave_one_out ? a.leave_one_out : a.db, &l.db) ||
             (!l.leave_one_out && read_list(a.queries, &l.queries));
    if (!rc && l.leave_one_out && l.db.count < 2)
        rc = cli_error(l.db.path, "leave-one-out needs two entries at least");
    rc = rc || plan_models(&l) || check_lists(&l) || run(&a, &l);
    free_lists(&l);
    return rc ? 1 : 0;
}
