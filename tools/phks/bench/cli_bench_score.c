/*
 * cli_bench_score.c - one seed of `phks bench`: its database in memory, its
 * queries, and the markdown tables of the counts.
 */
#include "bench/cli_bench_parts.h"

#include <stdlib.h>
#include <string.h>

static const size_t top_k[3] = {1, 3, 5};

size_t bench_item_of(const bench_plan *plan, size_t model, int kind,
                     unsigned seed)
{
    const bench_model *m = &plan->models[model];
    if (kind == KIND_COMPLETE)
        return m->first_item;
    if (!m->all_versions)
        return m->first_item + seed - 1;
    return m->first_item + 1 + 2 * (size_t)(seed - 1) + (kind - KIND_PARTIAL);
}

/* The database of seed: every database model's one version, in order. */
static phks_status fill_db(const bench_plan *p, unsigned seed, phks_db *db,
                           bench_evd_db *evd, bench_tally *t)
{
    phks_db_entry *e = malloc((p->model_count + 1) * sizeof *e);
    if (!e)
        return PHKS_ERROR_OUT_OF_MEMORY;
    size_t n = 0;
    for (size_t m = 0; m < p->model_count; m++) {
        const bench_model *model = &p->models[m];
        if (model->is_query)
            continue;
        const bench_item *it = &p->items[bench_item_of(p, m, model->db_kind,
                                                       seed)];
        if (!it->sig) {
            t->db_failed[model->db_kind]++;
            continue;
        }
        t->db_entries[model->db_kind]++;
        e[n++] = (phks_db_entry){model->row->file, model->row->cls, it->sig};
        bench_evd_add(evd, it, model->row->file, model->row->cls);
    }
    phks_status st = n ? phks_db_add_batch(db, e, n, NULL) : PHKS_OK;
    free(e);
    return st;
}

size_t bench_class_rank(const phks_hit *hits, size_t count, const char *cls)
{
    for (size_t r = 0; r < count; r++)
        if (strcmp(hits[r].label, cls) == 0)
            return r + 1;
    return 0;
}

void bench_tally_rank(bench_tally *t, int kind, size_t rank)
{
    t->queries[kind]++;
    for (int k = 0; k < 3; k++)
        t->top[kind][k] += rank && rank <= top_k[k];
}

/* The best hit's score, similarity and verified share as the last four
 * columns of a --queries-out line: what docs/retrieval.md's "What a score
 * means" reads. Empty with --descriptor evd (no signatures compared) or
 * no hit. */
static void write_top1(const bench_plan *p, phks_db *db,
                       const bench_item *it, const phks_hit *hits,
                       size_t count, FILE *out)
{
    phks_signature *entry = NULL;
    double similarity;
    size_t verified;
    if (count && !p->evd &&
        phks_db_get(db, hits[0].id, &entry, NULL, 0, NULL, 0) == PHKS_OK &&
        phks_similarity(it->sig, entry, &similarity, &verified) == PHKS_OK)
        fprintf(out, "\t%.9g\t%.6f\t%zu\t%zu\n", hits[0].score, similarity,
                verified, phks_signature_feature_count(it->sig));
    else
        fputs("\t\t\t\t\n", out);
    phks_signature_free(entry);
}

/* Runs one query and counts it into t, a tally of its own. */
static void run_query(const bench_plan *p, phks_db *db,
                      const bench_evd_db *evd, size_t m, int kind,
                      unsigned seed, bench_tally *t, FILE *out)
{
    const cli_row *row = p->models[m].row;
    const bench_item *it = &p->items[bench_item_of(p, m, kind, seed)];
    phks_hit hits[BENCH_QUERY_DEPTH];
    size_t count = 0;
    phks_status st = bench_query(p, db, evd, it, BENCH_QUERY_DEPTH, hits,
                                   &count);
    if (it->sig && st != PHKS_OK)
        cli_say_fail(row->path, st);
    if (st != PHKS_OK) {
        t->failed[kind]++;
        if (out)
            fprintf(out, "%s\t%s\t%u\t%s\t-1\t\t\t\t\t\n", row->file,
                    bench_kind_name[kind], seed, row->cls);
        return;
    }
    size_t rank = bench_class_rank(hits, count, row->cls);
    bench_tally_rank(t, kind, rank);
    if (kind != KIND_COMPLETE) {
        t->cut_queries[kind]++;
        t->features[kind] += it->features;
        t->near_cut[kind] += it->near_cut;
        t->vertices[kind] += it->vertices;
        t->vertices_near_cut[kind] += it->vertices_near_cut;
    }
    if (out) {
        fprintf(out, "%s\t%s\t%u\t%s\t%zu\t%s", row->file,
                bench_kind_name[kind], seed, row->cls, rank,
                count ? hits[0].label : "");
        write_top1(p, db, it, hits, count, out);
    }
}

int bench_score_seed(const bench_plan *plan, unsigned seed, bench_tally *tally,
                     bench_tally *by_class, FILE *queries_out)
{
    phks_db *db;
    bench_evd_db evd = {NULL, 0};
    phks_status st = phks_db_open(":memory:", PHKS_DB_CREATE, &db);
    if (st == PHKS_OK && plan->evd &&
        !(evd.entries = malloc((plan->model_count + 1) * sizeof *evd.entries)))
        st = PHKS_ERROR_OUT_OF_MEMORY;
    if (st == PHKS_OK)
        st = fill_db(plan, seed, db, &evd, tally);
    if (st != PHKS_OK) {
        cli_say_fail(":memory:", st);
        phks_db_close(db);
        free(evd.entries);
        return 1;
    }
    for (size_t m = 0; m < plan->model_count; m++)
        for (int k = 0; plan->models[m].is_query && k < KIND_COUNT; k++) {
            bench_tally q = {0};
            run_query(plan, db, &evd, m, k, seed, &q, queries_out);
            bench_tally_add(tally, &q);
            bench_tally_add(&by_class[plan->models[m].cls], &q);
        }
    phks_db_close(db);
    free(evd.entries);
    return 0;
}

void bench_tally_add(bench_tally *sum, const bench_tally *t)
{
    for (int k = 0; k < KIND_COUNT; k++) {
        sum->queries[k] += t->queries[k];
        sum->failed[k] += t->failed[k];
        for (int j = 0; j < 3; j++)
            sum->top[k][j] += t->top[k][j];
        sum->cut_queries[k] += t->cut_queries[k];
        sum->features[k] += t->features[k];
        sum->near_cut[k] += t->near_cut[k];
        sum->vertices[k] += t->vertices[k];
        sum->vertices_near_cut[k] += t->vertices_near_cut[k];
        sum->db_entries[k] += t->db_entries[k];
        sum->db_failed[k] += t->db_failed[k];
    }
}

/* ---- tables ---------------------------------------------------------------- */
const bench_set bench_sets[BENCH_SET_COUNT] = {
    {"complete", 1}, {"partial", 2}, {"incomplete", 4},
    {"partial+incomplete", 6}, {"all", 7}};

static size_t sum(const size_t *per_kind, unsigned kinds)
{
    size_t s = 0;
    for (int k = 0; k < KIND_COUNT; k++)
        s += kinds >> k & 1 ? per_kind[k] : 0;
    return s;
}

/* Top-k hits (k: index in top_k) of the queries of kinds. */
static size_t set_hits(const bench_tally *t, unsigned kinds, int k)
{
    size_t hits = 0;
    for (int kind = 0; kind < KIND_COUNT; kind++)
        hits += kinds >> kind & 1 ? t->top[kind][k] : 0;
    return hits;
}

void bench_print_percent(size_t part, size_t whole)
{
    if (whole)
        printf(" %.1f |", 100.0 * (double)part / (double)whole);
    else
        printf(" - |");
}

void bench_print_retrieval(const bench_tally *t)
{
    printf("| queries | n | failed | Top-1 | Top-3 | Top-5 |\n"
           "|---|---:|---:|---:|---:|---:|\n");
    for (size_t r = 0; r < BENCH_SET_COUNT; r++) {
        const bench_set *set = &bench_sets[r];
        size_t n = sum(t->queries, set->kinds);
        printf("| %s | %zu | %zu |", set->name, n, sum(t->failed, set->kinds));
        for (int k = 0; k < 3; k++)
            bench_print_percent(set_hits(t, set->kinds, k), n);
        printf("\n");
    }
}

static void print_cut(const bench_tally *t)
{
    printf("\nFeature points on or next to the cut (within %g of the longest "
           "side of the source's bounding box from a cut vertex), and for "
           "comparison the share of the pieces' vertices there:\n\n"
           "| queries | n | features | next to the cut | percent | "
           "vertices next to the cut, percent |\n"
           "|---|---:|---:|---:|---:|---:|\n", BENCH_CUT_RADIUS);
    for (size_t r = 1; r < 4; r++) {
        const bench_set *set = &bench_sets[r];
        size_t f = sum(t->features, set->kinds);
        size_t c = sum(t->near_cut, set->kinds);
        printf("| %s | %zu | %zu | %zu |", set->name,
               sum(t->cut_queries, set->kinds), f, c);
        bench_print_percent(c, f);
        bench_print_percent(sum(t->vertices_near_cut, set->kinds),
                            sum(t->vertices, set->kinds));
        printf("\n");
    }
}

void bench_print_results(const bench_tally *t, const char *title)
{
    printf("\n## %s\n\nDatabase: %zu entries (%zu complete, %zu partial, %zu "
           "incomplete), %zu failed.\n\n", title, sum(t->db_entries, 7),
           t->db_entries[0], t->db_entries[1], t->db_entries[2],
           sum(t->db_failed, 7));
    bench_print_retrieval(t);
}

void bench_print_tally(const bench_tally *t, const char *title)
{
    bench_print_results(t, title);
    print_cut(t);
}

void bench_json_percent(size_t part, size_t whole)
{
    if (whole)
        cli_json_number(100.0 * (double)part / (double)whole);
    else
        fputs("null", stdout);
}

/* A row of "retrieval": the queries of set. */
static void json_retrieval_row(const bench_tally *t, const bench_set *set)
{
    static const char *const top[] = {"top1", "top3", "top5"};
    size_t n = sum(t->queries, set->kinds);
    printf("{\"queries\": \"%s\", \"n\": %zu, \"failed\": %zu", set->name, n,
           sum(t->failed, set->kinds));
    for (int k = 0; k < 3; k++) {
        size_t hits = set_hits(t, set->kinds, k);
        printf(", \"%s_hits\": %zu, \"%s\": ", top[k], hits, top[k]);
        bench_json_percent(hits, n);
    }
    putchar('}');
}

void bench_json_retrieval(const bench_tally *t)
{
    putchar('[');
    for (size_t r = 0; r < BENCH_SET_COUNT; r++) {
        printf("%s\n        ", r ? "," : "");
        json_retrieval_row(t, &bench_sets[r]);
    }
    fputs("\n      ]", stdout);
}

void bench_json_results(const bench_tally *t)
{
    printf("{\"database\": {\"entries\": %zu, \"complete\": %zu, "
           "\"partial\": %zu, \"incomplete\": %zu, \"failed\": %zu},\n"
           "      \"retrieval\": ", sum(t->db_entries, 7), t->db_entries[0],
           t->db_entries[1], t->db_entries[2], sum(t->db_failed, 7));
    bench_json_retrieval(t);
}

void bench_json_tally(const bench_tally *t)
{
    bench_json_results(t);
    printf(",\n      \"cut_radius\": %g, \"cut\": [", BENCH_CUT_RADIUS);
    for (size_t r = 1; r < 4; r++) {
        const bench_set *set = &bench_sets[r];
        size_t f = sum(t->features, set->kinds);
        size_t c = sum(t->near_cut, set->kinds);
        printf("%s\n        {\"queries\": \"%s\", \"n\": %zu, "
               "\"features\": %zu, \"near_cut\": %zu, \"percent\": ",
               r > 1 ? "," : "", set->name, sum(t->cut_queries, set->kinds),
               f, c);
        bench_json_percent(c, f);
        fputs(", \"vertices_near_cut_percent\": ", stdout);
        bench_json_percent(sum(t->vertices_near_cut, set->kinds),
                           sum(t->vertices, set->kinds));
        putchar('}');
    }
    fputs("\n      ]}", stdout);
}

/* ---- by class -------------------------------------------------------------- */
/* The query sets of the by-class rows: complete, partial+incomplete, all. */
static const size_t class_sets[3] = {0, 3, 4};

/* The counts of --group's classes together. */
static bench_tally group_tally(const bench_plan *p)
{
    bench_tally g = {0};
    for (size_t c = 0; c < p->class_count; c++)
        if (p->classes[c].in_group)
            bench_tally_add(&g, &p->by_class[c]);
    return g;
}

static void print_class_row(const char *name, const bench_tally *t)
{
    printf("| %s | %zu | %zu |", name, sum(t->queries, 7), sum(t->failed, 7));
    for (int s = 0; s < 3; s++) {
        unsigned kinds = bench_sets[class_sets[s]].kinds;
        for (int k = 0; k < 3; k++)
            bench_print_percent(set_hits(t, kinds, k), sum(t->queries, kinds));
    }
    printf("\n");
}

void bench_print_by_class(const bench_plan *p)
{
    printf("\nBy class, pooled over the seeds: answered and failed queries, "
           "and Top-k in percent of the class's answered queries of each "
           "set");
    if (p->group_name)
        printf("; the last row, %s, pools %s", p->group_name,
               p->group_classes);
    printf(":\n");
    bench_print_class_table(p);
}

void bench_print_class_table(const bench_plan *p)
{
    printf("\n| class | n | failed | complete Top-1 | Top-3 | Top-5 | "
           "partial+incomplete Top-1 | Top-3 | Top-5 | all Top-1 | Top-3 | "
           "Top-5 |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
           "---:|\n");
    for (size_t c = 0; c < p->class_count; c++)
        print_class_row(p->classes[c].name, &p->by_class[c]);
    if (p->group_name) {
        bench_tally g = group_tally(p);
        print_class_row(p->group_name, &g);
    }
}

/* The rest of a class's object, after its name. */
static void json_class(const bench_tally *t)
{
    printf(", \"queries\": %zu, \"failed\": %zu, \"retrieval\": [",
           sum(t->queries, 7), sum(t->failed, 7));
    for (int s = 0; s < 3; s++) {
        printf("%s\n      ", s ? "," : "");
        json_retrieval_row(t, &bench_sets[class_sets[s]]);
    }
    fputs("]}", stdout);
}

void bench_json_by_class(const bench_plan *p)
{
    fputs(",\n  \"by_class\": [", stdout);
    for (size_t c = 0; c < p->class_count; c++) {
        printf("%s\n    {\"class\": ", c ? "," : "");
        cli_json_string(p->classes[c].name);
        json_class(&p->by_class[c]);
    }
    fputs("\n  ],\n  \"group\": ", stdout);
    if (!p->group_name) {
        fputs("null", stdout);
        return;
    }
    bench_tally g = group_tally(p);
    fputs("{\"name\": ", stdout);
    cli_json_string(p->group_name);
    fputs(", \"classes\": ", stdout);
    cli_json_string(p->group_classes);
    json_class(&g);
}
