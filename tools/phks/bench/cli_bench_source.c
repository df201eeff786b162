/*
 * cli_bench_source.c - the source part of `phks bench` (docs/cli.md): each
 * model's partial scan and incomplete version looks for its own source in
 * a database of the complete versions, and its feature points are matched
 * to the source's, checked against the points they came from.
 */
#include "bench/cli_bench_parts.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- computing --------------------------------------------------------- */
typedef struct source_ctx {
    bench_plan *plan;
    phks_db *db;
    bench_evd_db evd;  /* --descriptor evd */
} source_ctx;

/* Distances along the source mesh from its complete signature's feature
 * points, made when first needed: the graph is undirected, so the field
 * of a matched feature gives its distance from every true point, and one
 * field serves every version and seed of the model. */
typedef struct fields {
    const phks_mesh *mesh;
    const phks_signature *sig;
    const phks_options *options;
    double **of;  /* per feature and sample of sig, NULL until needed */
} fields;

static const double *field(fields *g, size_t feature)
{
    if (g->of[feature])
        return g->of[feature];
    double *d = malloc(phks_mesh_vertex_count(g->mesh) * sizeof *d);
    uint32_t v = phks_signature_feature_vertex(g->sig, feature);
    if (d && phks_mesh_geodesic_distances(g->mesh, g->options, v, d) !=
                 PHKS_OK) {
        free(d);
        d = NULL;
    }
    return g->of[feature] = d;
}

static phks_status fill_db(const bench_plan *p, phks_db *db, bench_evd_db *evd)
{
    phks_db_entry *e = malloc((p->model_count + 1) * sizeof *e);
    size_t n = 0;
    if (!e)
        return PHKS_ERROR_OUT_OF_MEMORY;
    for (size_t m = 0; m < p->model_count; m++) {
        const cli_row *row = p->models[m].row;
        const bench_item *it = &p->items[bench_item_of(p, m, KIND_COMPLETE,
                                                       1)];
        if (it->sig)
            e[n++] = (phks_db_entry){row->file, row->cls, it->sig};
        bench_evd_add(evd, it, row->file, row->cls);
    }
    phks_status st = n ? phks_db_add_batch(db, e, n, NULL) : PHKS_OK;
    free(e);
    return st;
}

/* Rank (1..) of model m's own entry among the hits, 0 when absent; a model
 * of a one-character class owns every entry of its class. */
static long own_rank(const source_ctx *c, size_t m, const bench_item *query)
{
    const bench_model *model = &c->plan->models[m];
    phks_hit hits[BENCH_QUERY_DEPTH];
    size_t count;
    phks_status st = bench_query(c->plan, c->db, &c->evd, query,
                                 BENCH_QUERY_DEPTH, hits, &count);
    if (st != PHKS_OK) {
        cli_say_fail(model->row->path, st);
        return -1;
    }
    for (size_t r = 0; r < count; r++)
        if (model->one_character ? strcmp(hits[r].label, model->row->cls) == 0
                                 : strcmp(hits[r].name, model->row->file) == 0)
            return (long)r + 1;
    return 0;
}

/* Where a version's feature stands in the descriptor recall: a point
 * of the source's signature among the 3 its description proposes lies
 * within BENCH_CORRECT_RADIUS of its true point, or none does though one
 * of the signature's points lies that near, or none lies that near. */
enum recall_of { RECALL_MISS, RECALL_HIT, RECALL_NO_POINT };
#define RECALL_DEPTH 3

/* The distance along the source from its signature's point p to vertex
 * t, in units of unit; INFINITY without memory for the field. */
static double from_point(fields *g, size_t p, uint32_t t, double unit)
{
    const double *d = field(g, p);
    return d ? d[t] / unit : INFINITY;
}

static phks_status recall_of(fields *g, double unit, const bench_item *v,
                             size_t f, unsigned char *out)
{
    size_t points = phks_signature_feature_count(g->sig) +
                    phks_signature_sample_count(g->sig);
    uint32_t t = v->truth[f];
    double nearest = INFINITY;
    for (size_t p = 0; p < points; p++)
        nearest = fmin(nearest, from_point(g, p, t, unit));
    *out = RECALL_NO_POINT;
    if (!(nearest <= BENCH_CORRECT_RADIUS))
        return PHKS_OK;
    phks_candidate c[RECALL_DEPTH];
    size_t count;
    phks_status st = phks_candidates(v->sig, f, g->sig, RECALL_DEPTH, c,
                                     &count);
    *out = RECALL_MISS;
    for (size_t r = 0; st == PHKS_OK && r < count; r++)
        if (from_point(g, c[r].point, t, unit) <= BENCH_CORRECT_RADIUS)
            *out = RECALL_HIT;
    return st;
}

/* Every feature of the version v (its rows of phks_match against the
 * source), verified or not: the distance of its match from its true
 * point, in units of unit. */
static phks_status match(fields *g, double unit, bench_item *v)
{
    size_t na = phks_signature_feature_count(v->sig);
    size_t cap = na + phks_signature_feature_count(g->sig), count;
    phks_correspondence *rows = malloc((cap + 1) * sizeof *rows);
    double score;
    v->error = malloc((na + 1) * sizeof *v->error);
    /* Recall needs the proposals, which only verified matching makes. */
    int proposals = g->options->matching == PHKS_MATCHING_VERIFIED;
    v->verified = malloc(na + 1);
    v->recall = proposals ? malloc(na + 1) : NULL;
    phks_status st = rows && v->error && v->verified &&
                     (v->recall || !proposals)
        ? phks_match(v->sig, g->sig, rows, cap, &count, &score)
        : PHKS_ERROR_OUT_OF_MEMORY;
    for (size_t r = 0; st == PHKS_OK && r < count; r++) {
        const double *d = rows[r].from_a ? field(g, rows[r].feature_b) : NULL;
        if (rows[r].from_a && !d)
            st = PHKS_ERROR_OUT_OF_MEMORY;
        else if (d) {
            v->error[rows[r].feature_a] = d[v->truth[rows[r].feature_a]] / unit;
            v->verified[rows[r].feature_a] = (unsigned char)rows[r].verified;
        }
    }
    for (size_t f = 0; st == PHKS_OK && v->recall && f < na; f++)
        st = recall_of(g, unit, v, f, &v->recall[f]);
    v->matched = st == PHKS_OK;
    free(rows);
    return st;
}

/* Pool task: model index's partial and incomplete versions of every seed. */
static void source_task(void *ctx, size_t index)
{
    source_ctx *c = ctx;
    bench_plan *p = c->plan;
    const bench_model *model = &p->models[index];
    const bench_item *whole = &p->items[bench_item_of(p, index, KIND_COMPLETE,
                                                      1)];
    phks_mesh *mesh = NULL;
    const char *reason = NULL;
    /* Verified partners may be samples, after the features. */
    size_t nf = phks_signature_feature_count(whole->sig) +
                phks_signature_sample_count(whole->sig);
    fields g = {NULL, whole->sig, &p->options, calloc(nf + 1, sizeof *g.of)};
    phks_status st = !whole->sig ? PHKS_ERROR_INVALID_ARGUMENT
                     : g.of ? bench_load(model, &mesh, &reason)
                            : PHKS_ERROR_OUT_OF_MEMORY;
    double unit = st == PHKS_OK ? sqrt(phks_mesh_area(mesh)) : 0;
    g.mesh = mesh;
    for (unsigned s = 1; s <= p->seeds; s++)
        for (int k = KIND_PARTIAL; k < KIND_COUNT; k++) {
            bench_item *v = &p->items[bench_item_of(p, index, k, s)];
            v->source_rank = v->sig && whole->sig
                ? own_rank(c, index, v) : -1;
            if (st == PHKS_OK && v->sig && v->truth &&
                (st = match(&g, unit, v)) != PHKS_OK)
                reason = cli_reason(model->row->path, st);
        }
    if (whole->sig && st != PHKS_OK)
        cli_say(stderr, "phks: %s: correspondences: %s\n", model->row->path,
                reason ? reason : cli_reason(model->row->path, st));
    for (size_t f = 0; g.of && f < nf; f++)
        free(g.of[f]);
    free(g.of);
    phks_mesh_free(mesh);
    cli_progress_step();
}

int bench_source_run(bench_plan *plan, unsigned workers)
{
    source_ctx c = {plan, NULL, {NULL, 0}};
    phks_status st = phks_db_open(":memory:", PHKS_DB_CREATE, &c.db);
    if (st == PHKS_OK && plan->evd &&
        !(c.evd.entries = malloc((plan->model_count + 1) *
                                 sizeof *c.evd.entries)))
        st = PHKS_ERROR_OUT_OF_MEMORY;
    if (st == PHKS_OK)
        st = fill_db(plan, c.db, &c.evd);
    if (st != PHKS_OK) {
        cli_say_fail(":memory:", st);
        phks_db_close(c.db);
        free(c.evd.entries);
        return 1;
    }
    cli_progress_start(plan->model_count, "sources");
    cli_pool_run(plan->model_count, workers, source_task, &c);
    cli_progress_end();
    phks_db_close(c.db);
    free(c.evd.entries);
    return 0;
}

/* ---- counting ---------------------------------------------------------- */
typedef struct source_counts {
    size_t queries, failed, top1, top5;  /* retrieval                      */
    size_t versions, unmatched;          /* correspondences: versions ...  */
    size_t features, correct, verified, verified_correct;  /* ... features */
    size_t recalled, no_point;           /* descriptor recall               */
    double median, verified_median;      /* NAN: no feature                */
} source_counts;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *x, size_t n)
{
    if (!n)
        return NAN;
    qsort(x, n, sizeof *x, cmp_double);
    return 0.5 * (x[(n - 1) / 2] + x[n / 2]);
}

static void count_item(const bench_item *v, source_counts *c, double *all,
                       double *ver)
{
    size_t nf = phks_signature_feature_count(v->sig);
    c->queries += v->source_rank >= 0;
    c->failed += v->source_rank < 0;
    c->top1 += v->source_rank == 1;
    c->top5 += v->source_rank >= 1 && v->source_rank <= 5;
    c->versions += v->matched;
    c->unmatched += !v->matched;
    for (size_t f = 0; v->matched && f < nf; f++) {
        int correct = v->error[f] <= BENCH_CORRECT_RADIUS;
        all[c->features++] = v->error[f];
        c->correct += (size_t)correct;
        c->recalled += v->recall && v->recall[f] == RECALL_HIT;
        c->no_point += v->recall && v->recall[f] == RECALL_NO_POINT;
        if (v->verified[f]) {
            ver[c->verified++] = v->error[f];
            c->verified_correct += (size_t)correct;
        }
    }
}

/* The counts over seed bases lo..hi and the kinds of set. */
static void count_set(const bench_plan *p, unsigned lo, unsigned hi,
                      const bench_set *set, source_counts *c)
{
    size_t room = 1;
    for (size_t i = 0; i < p->item_count; i++)
        room += p->items[i].matched
                ? phks_signature_feature_count(p->items[i].sig) : 0;
    double *all = malloc(room * sizeof *all);
    double *ver = malloc(room * sizeof *ver);
    *c = (source_counts){0};
    for (size_t m = 0; all && ver && m < p->model_count; m++)
        for (unsigned s = lo; s <= hi; s++)
            for (int k = KIND_PARTIAL; k < KIND_COUNT; k++)
                if (set->kinds >> k & 1)
                    count_item(&p->items[bench_item_of(p, m, k, s)], c, all,
                               ver);
    c->median = median(all, c->features);
    c->verified_median = median(ver, c->verified);
    free(all);
    free(ver);
}

static size_t db_entries(const bench_plan *p)
{
    size_t n = 0;
    for (size_t m = 0; m < p->model_count; m++)
        n += p->items[bench_item_of(p, m, KIND_COMPLETE, 1)].sig != NULL;
    return n;
}

/* ---- markdown ---------------------------------------------------------- */
static void print_error(double x)
{
    if (isnan(x))
        printf(" - |");
    else
        printf(" %.3f |", x);
}

static void print_tables(const bench_plan *p, unsigned lo, unsigned hi)
{
    source_counts c[3];
    for (int r = 0; r < 3; r++)
        count_set(p, lo, hi, &bench_sets[r + 1], &c[r]);
    printf("| queries | n | failed | Top-1 | Top-5 |\n"
           "|---|---:|---:|---:|---:|\n");
    for (int r = 0; r < 3; r++) {
        printf("| %s | %zu | %zu |", bench_sets[r + 1].name, c[r].queries,
               c[r].failed);
        bench_print_percent(c[r].top1, c[r].queries);
        bench_print_percent(c[r].top5, c[r].queries);
        printf("\n");
    }
    printf("\n| versions | n | failed | features | correct, percent | "
           "verified | verified correct, percent | median error | "
           "median error, verified |\n"
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (int r = 0; r < 3; r++) {
        printf("| %s | %zu | %zu | %zu |", bench_sets[r + 1].name,
               c[r].versions, c[r].unmatched, c[r].features);
        bench_print_percent(c[r].correct, c[r].features);
        printf(" %zu |", c[r].verified);
        bench_print_percent(c[r].verified_correct, c[r].verified);
        print_error(c[r].median);
        print_error(c[r].verified_median);
        printf("\n");
    }
    if (p->options.matching != PHKS_MATCHING_VERIFIED)
        return;
    printf("\nDescriptor recall: for each feature, whether a point of the "
           "source's signature among the %d that phks_candidates proposes "
           "lies within %g sqrt(area) of the point it came from; features "
           "with no signature point that near count as misses.\n\n"
           "| versions | features | no point near | percent | recalled | "
           "percent | percent of those with a point near |\n"
           "|---|---:|---:|---:|---:|---:|---:|\n", RECALL_DEPTH,
           BENCH_CORRECT_RADIUS);
    for (int r = 0; r < 3; r++) {
        printf("| %s | %zu | %zu |", bench_sets[r + 1].name, c[r].features,
               c[r].no_point);
        bench_print_percent(c[r].no_point, c[r].features);
        printf(" %zu |", c[r].recalled);
        bench_print_percent(c[r].recalled, c[r].features);
        bench_print_percent(c[r].recalled, c[r].features - c[r].no_point);
        printf("\n");
    }
}

void bench_source_print(const bench_plan *plan, const char *one_character)
{
    printf("\n## Source retrieval and correspondences\n\nDatabase: the "
           "complete versions of the %zu models, %zu entries. Queries: each "
           "model's partial scan and incomplete version (the protocol's "
           "generator seeds); a hit is its own source among the k best (in "
           "the one-character classes \"%s\": any model of its class). "
           "Correspondences: every feature point of each version matched "
           "(phks_match) to its source's complete signature; correct when "
           "the match lies within %g sqrt(area) of the point it came from, "
           "along the source's surface (symmetric swaps count as wrong); "
           "errors in units of sqrt(area).\n", plan->model_count,
           db_entries(plan), one_character, BENCH_CORRECT_RADIUS);
    for (unsigned s = 1; plan->seeds > 1 && s <= plan->seeds; s++) {
        printf("\n### Seed %u\n\n", s);
        print_tables(plan, s, s);
    }
    printf(plan->seeds > 1 ? "\n### All seeds (pooled)\n\n" : "\n");
    print_tables(plan, 1, plan->seeds);
}

/* ---- JSON -------------------------------------------------------------- */
static void json_row(const bench_set *set, const source_counts *c)
{
    printf("\n          {\"versions\": \"%s\", \"n\": %zu, \"failed\": %zu, "
           "\"features\": %zu, \"correct\": %zu, \"percent\": ", set->name,
           c->versions, c->unmatched, c->features, c->correct);
    bench_json_percent(c->correct, c->features);
    printf(", \"verified\": %zu, \"verified_correct\": %zu, "
           "\"verified_percent\": ", c->verified, c->verified_correct);
    bench_json_percent(c->verified_correct, c->verified);
    fputs(", \"median_error\": ", stdout);
    cli_json_number(c->median);
    fputs(", \"verified_median_error\": ", stdout);
    cli_json_number(c->verified_median);
    printf(", \"no_point_near\": %zu, \"recalled\": %zu, "
           "\"recall_percent\": ", c->no_point, c->recalled);
    bench_json_percent(c->recalled, c->features);
    putchar('}');
}

static void json_results(const bench_plan *p, unsigned lo, unsigned hi)
{
    source_counts c[3];
    for (int r = 0; r < 3; r++)
        count_set(p, lo, hi, &bench_sets[r + 1], &c[r]);
    fputs("{\"retrieval\": [", stdout);
    for (int r = 0; r < 3; r++) {
        printf("%s\n          {\"queries\": \"%s\", \"n\": %zu, \"failed\": "
               "%zu, \"top1_hits\": %zu, \"top1\": ", r ? "," : "",
               bench_sets[r + 1].name, c[r].queries, c[r].failed, c[r].top1);
        bench_json_percent(c[r].top1, c[r].queries);
        printf(", \"top5_hits\": %zu, \"top5\": ", c[r].top5);
        bench_json_percent(c[r].top5, c[r].queries);
        putchar('}');
    }
    fputs("\n        ],\n        \"correspondences\": [", stdout);
    for (int r = 0; r < 3; r++) {
        fputs(r ? "," : "", stdout);
        json_row(&bench_sets[r + 1], &c[r]);
    }
    fputs("\n        ]}", stdout);
}

void bench_source_json(const bench_plan *plan, const char *one_character)
{
    fputs("{\"one_character\": ", stdout);
    cli_json_string(one_character);
    printf(", \"correct_radius\": %g, \"database\": {\"entries\": %zu, "
           "\"failed\": %zu},\n    \"seeds\": [", BENCH_CORRECT_RADIUS,
           db_entries(plan), plan->model_count - db_entries(plan));
    for (unsigned s = 1; s <= plan->seeds; s++) {
        printf("%s\n      {\"seed\": %u, \"results\": ", s > 1 ? "," : "", s);
        json_results(plan, s, s);
        putchar('}');
    }
    fputs("\n    ],\n    \"pooled\": ", stdout);
    json_results(plan, 1, plan->seeds);
    putchar('}');
}
