/*
 * cli_bench.c - `phks bench MANIFEST`: the retrieval protocol of the
 * paper's section 5 (docs/cli.md states it in full). This file chooses the
 * models, lays out the signatures to compute, runs them on the work pool
 * and prints the report; cli_bench_item.c computes one signature,
 * cli_bench_score.c scores one seed, cli_bench_source.c the source
 * part, and cli_bench_features.c makes the comparison rows' features and
 * descriptor. `phks bench --db LIST --queries LIST` and `--leave-one-out
 * LIST` go to cli_bench_lists.c.
 */
#include "cli.h"
#include "bench/cli_bench_parts.h"

#include <errno.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>

static const char usage[] =
    "bench MANIFEST [--prefix P] [--classes A,B] [--max-per-class M]\n"
    "                  [--seeds N] [--cache DIR] [--queries-out TSV] [-j N]\n"
    "                  [--json] [--no-source] [--one-character A,B]\n"
    "                  [--feature-function hks|agd|gc] [--descriptor hks|evd]\n"
    "                  [--group NAME=A,B]\n"
    "       phks bench --db LIST --queries LIST [--cache DIR] [-j N] [--json]\n"
    "       phks bench --leave-one-out LIST [--cache DIR] [-j N] [--json]\n"
    "  --prefix P          rows whose file starts with P (psb/)\n"
    "  --classes A,B       only these classes (all)\n"
    "  --max-per-class M   the first M models of each class (all)\n"
    "  --seeds N           seed bases 1..N, 1..1000000 (1)\n"
    "  --cache DIR         read and write signatures there (no cache)\n"
    "  --queries-out TSV   one line per query (none)\n"
    "  -j N                worker threads, 1..1024 (the online CPUs)\n"
    "  --json              the report as JSON (markdown)\n"
    "  --no-source         skip source retrieval and correspondences\n"
    "  --one-character A,B classes whose models are poses of one character\n"
    "                      (Armadillo)\n"
    "  --feature-function F  feature points at the persistent maxima of HKS,\n"
    "                      the average geodesic distance or Gaussian\n"
    "                      curvature (hks)\n"
    "  --descriptor D      rank by the signatures, or by the first 50\n"
    "                      nonzero eigenvalues (hks)\n"
    "  --group NAME=A,B    a row NAME of the by-class table pooling these\n"
    "                      classes (none)\n"
    "  --db LIST           the database: a TSV naming the columns file and\n"
    "                      class, and optionally name (the file) and kind\n"
    "                      (complete, partial or incomplete; complete)\n"
    "  --queries LIST      the queries: a TSV as --db's, and optionally\n"
    "                      source (the name of the database entry the query\n"
    "                      was made from; none)\n"
    "  --leave-one-out LIST  each entry against a database of all the\n"
    "                      others";

typedef struct bench_args {
    const char *manifest, *prefix, *classes, *cache, *queries_out;
    const char *one_character, *feature_function, *descriptor, *group;
    unsigned long max_per_class, seeds, workers;
    int json, no_source;
} bench_args;

/* --feature-function and --descriptor into the plan's fields; the
 * eigenvalue descriptor has no feature points to choose. */
static int parse_comparison(const bench_args *a, int *features, int *evd)
{
    *features = -1;
    for (int f = 0; f < BENCH_FEATURES_COUNT; f++)
        if (strcmp(a->feature_function, bench_feature_name[f]) == 0)
            *features = f;
    *evd = strcmp(a->descriptor, "evd") == 0;
    if (*features < 0 || (!*evd && strcmp(a->descriptor, "hks") != 0))
        return -1;
    if (*evd && *features != BENCH_FEATURES_HKS) {
        fprintf(stderr, "phks: bench: --descriptor evd ranks by eigenvalues, "
                        "without feature points: no --feature-function\n");
        return -1;
    }
    return 0;
}

static int parse_args(int argc, char **argv, bench_args *a)
{
    const char *max = NULL, *seeds = "1", *jobs = NULL;
    const cli_opt opts[] = {
        {"--prefix", &a->prefix, NULL},   {"--classes", &a->classes, NULL},
        {"--max-per-class", &max, NULL},  {"--seeds", &seeds, NULL},
        {"--cache", &a->cache, NULL},     {"--queries-out", &a->queries_out, NULL},
        {"-j", &jobs, NULL},              {"--json", NULL, &a->json},
        {"--no-source", NULL, &a->no_source},
        {"--one-character", &a->one_character, NULL},
        {"--feature-function", &a->feature_function, NULL},
        {"--descriptor", &a->descriptor, NULL},
        {"--group", &a->group, NULL},
    };
    int n;
    a->prefix = "psb/";
    a->one_character = "Armadillo";
    a->feature_function = "hks";
    a->descriptor = "hks";
    a->max_per_class = (unsigned long)-1;
    a->workers = cli_cpu_count();
    if (cli_parse(argc, argv, 1, opts, sizeof opts / sizeof opts[0], &n) ||
        n != 1 || (max && cli_option_count("--max-per-class", max, 1,
                                           ULONG_MAX, &a->max_per_class)) ||
        cli_option_count("--seeds", seeds, 1, 1000000, &a->seeds) ||
        (jobs && cli_option_count("-j", jobs, 1, 1024, &a->workers)))
        return -1;
    const char *eq = a->group ? strchr(a->group, '=') : NULL;
    if (a->group && (!eq || eq == a->group || !eq[1])) {
        fprintf(stderr, "phks: bench: --group takes NAME=A,B\n");
        return -1;
    }
    a->manifest = argv[1];
    return 0;
}

/* The name after the next comma of a comma-separated list, or NULL. */
static const char *next_name(const char *p)
{
    const char *comma = strchr(p, ',');
    return comma ? comma + 1 : NULL;
}

/* Is the name at p, up to a comma or the end, cls? */
static int names(const char *p, const char *cls)
{
    size_t n = strlen(cls);
    return strncmp(p, cls, n) == 0 && (p[n] == ',' || p[n] == '\0');
}

/* Is cls one of the comma-separated names in list (NULL: all)? */
static int listed(const char *list, const char *cls)
{
    for (const char *p = list; p; p = next_name(p))
        if (names(p, cls))
            return 1;
    return !list;
}

static int wanted(const bench_args *a, const cli_row *row)
{
    return strncmp(row->file, a->prefix, strlen(a->prefix)) == 0 &&
           listed(a->classes, row->cls);
}

/* Every name of --classes has a row under the prefix. */
static int check_classes(const bench_args *a, const cli_row *rows, size_t n)
{
    for (const char *p = a->classes; p; p = next_name(p)) {
        size_t len = strcspn(p, ",");
        size_t r = 0;
        while (r < n && !(wanted(a, &rows[r]) &&
                          strlen(rows[r].cls) == len &&
                          strncmp(rows[r].cls, p, len) == 0))
            r++;
        if (r == n) {
            fprintf(stderr, "phks: %s: no class %.*s under %s\n", a->manifest,
                    (int)len, p, a->prefix);
            return -1;
        }
    }
    return 0;
}

/* A class's models in manifest order: query when i % 4 == 3, else the j-th
 * database model, entered as version j % 3. */
static void add_class(const bench_args *a, const cli_row *rows, size_t n,
                      size_t first, bench_plan *p)
{
    size_t i = 0, j = 0;
    p->classes[p->class_count].name = rows[first].cls;
    for (size_t r = first; r < n && i < a->max_per_class; r++) {
        if (!wanted(a, &rows[r]) || strcmp(rows[r].cls, rows[first].cls) != 0)
            continue;
        bench_model *m = &p->models[p->model_count++];
        m->row = &rows[r];
        m->is_query = i++ % 4 == 3;
        m->db_kind = m->is_query ? KIND_COMPLETE : (int)(j++ % 3);
        m->all_versions = m->is_query || p->source;
        m->one_character = listed(a->one_character, m->row->cls);
        m->cls = p->class_count;
    }
    p->class_count++;
}

static int select_models(const bench_args *a, const cli_row *rows, size_t n,
                         bench_plan *p)
{
    p->models = calloc(n ? n : 1, sizeof *p->models);
    p->classes = calloc(n ? n : 1, sizeof *p->classes);
    p->by_class = calloc(n ? n : 1, sizeof *p->by_class);
    if (!p->models || !p->classes || !p->by_class)
        return cli_error(a->manifest, "out of memory");
    for (size_t r = 0; r < n; r++) {
        size_t s = 0;
        while (s < r && !(wanted(a, &rows[s]) &&
                          strcmp(rows[s].cls, rows[r].cls) == 0))
            s++;
        if (wanted(a, &rows[r]) && s == r)  /* first of its class */
            add_class(a, rows, n, r, p);
    }
    if (!p->model_count)
        return cli_error(a->manifest, "no model matches the prefix and classes");
    return 0;
}

/* --group NAME=A,B into the plan: every name one of the selected
 * classes. */
static int plan_group(const bench_args *a, bench_plan *p)
{
    const char *eq = strchr(a->group, '=');
    p->group_classes = eq + 1;
    for (const char *q = p->group_classes; q; q = next_name(q)) {
        size_t c = 0;
        while (c < p->class_count && !names(q, p->classes[c].name))
            c++;
        if (c == p->class_count) {
            fprintf(stderr, "phks: %s: --group: no class %.*s among the "
                    "selected classes\n", a->manifest, (int)strcspn(q, ","),
                    q);
            return -1;
        }
    }
    for (size_t c = 0; c < p->class_count; c++)
        p->classes[c].in_group = listed(p->group_classes, p->classes[c].name);
    p->group_name = malloc((size_t)(eq - a->group) + 1);
    if (!p->group_name)
        return cli_error("bench", "out of memory");
    memcpy(p->group_name, a->group, (size_t)(eq - a->group));
    p->group_name[eq - a->group] = '\0';
    return 0;
}

/* Items: a query model's complete version, then per seed its partial and
 * incomplete ones; a database model's one version (once if complete, else
 * per seed), or with the source part all its versions as a query model's. */
static int plan_items(bench_plan *p)
{
    size_t count = 0;
    for (size_t m = 0; m < p->model_count; m++) {
        bench_model *model = &p->models[m];
        model->first_item = count;
        count += model->all_versions ? 1 + 2 * (size_t)p->seeds
                 : model->db_kind == KIND_COMPLETE ? 1 : p->seeds;
    }
    p->items = calloc(count, sizeof *p->items);
    if (!p->items)
        return -1;
    p->item_count = count;
    for (size_t m = 0; m < p->model_count; m++)
        for (int k = 0; k < KIND_COUNT; k++)
            for (unsigned s = 1; s <= p->seeds; s++) {
                const bench_model *model = &p->models[m];
                if ((!model->all_versions && k != model->db_kind) ||
                    (k == KIND_COMPLETE && s > 1))
                    continue;
                bench_item *it = &p->items[bench_item_of(p, m, k, s)];
                it->model = m;
                it->kind = k;
                it->seed = k == KIND_COMPLETE ? 0 : s;
            }
    return 0;
}

static void print_header(const bench_args *a, const bench_plan *p,
                         unsigned workers)
{
    size_t queries = 0;
    for (size_t m = 0; m < p->model_count; m++)
        queries += (size_t)p->models[m].is_query;
    char per_class[48] = "all models";
    if (a->max_per_class != (unsigned long)-1)
        snprintf(per_class, sizeof per_class, "the first %lu models",
                 a->max_per_class);
    printf("# phks bench\n\nlibphks %s; manifest %s, files under \"%s\", "
           "classes %s, %s of each; seed bases 1..%u; %u workers.\n\n",
           phks_version_string(), a->manifest, a->prefix,
           a->classes ? a->classes : "all", per_class, p->seeds, workers);
    cli_print_options(stdout, "Options: ", &p->options);
    printf("\nFeature function: %s; descriptor: %s.\n",
           bench_feature_name[p->features],
           p->evd ? "evd (the first 50 nonzero eigenvalues, L1)"
                  : "the signatures");
    printf("\nProtocol (paper section 5): per class, models i = 0, 1, ... in "
           "manifest order; queries: i %% 4 == 3; database: the others, each "
           "entered as one version by its position j among them: j %% 3 == 0 "
           "complete, 1 partial scan, 2 incomplete. Each query model is "
           "queried as complete, partial scan and incomplete. Generator seed "
           "= splitmix64 hash of (seed base, file, kind). Top-k: an entry of "
           "the query's class among the k best of the database; rates over "
           "the answered queries.\n\n%zu models: %zu query models (%zu queries "
           "per seed), %zu database models.\n", p->model_count, queries,
           3 * queries, p->model_count - queries);
}

static FILE *open_queries_out(const char *path)
{
    FILE *f = path ? fopen(path, "w") : NULL;
    if (path && !f)
        cli_error(path, strerror(errno));
    else if (f)
        fprintf(f, "file\tkind\tseed\tclass\trank\ttop1_label\ttop1_score\t"
                   "top1_similarity\ttop1_verified\tfeatures\n");
    return f;
}

static int score_all(const bench_plan *p, FILE *qout, int json)
{
    bench_tally pooled = {0};
    int rc = 0;
    if (json)
        fputs(",\n  \"seeds\": [", stdout);
    for (unsigned s = 1; s <= p->seeds; s++) {
        bench_tally t = {0};
        char title[64];
        rc |= bench_score_seed(p, s, &t, p->by_class, qout);
        bench_tally_add(&pooled, &t);
        snprintf(title, sizeof title, "Seed %u", s);
        if (json) {
            printf("%s\n    {\"seed\": %u, \"results\": ", s > 1 ? "," : "",
                   s);
            bench_json_tally(&t);
            putchar('}');
        } else if (p->seeds > 1)
            bench_print_tally(&t, title);
    }
    if (json) {
        fputs("\n  ],\n  \"pooled\": ", stdout);
        bench_json_tally(&pooled);
        bench_json_by_class(p);
    } else {
        bench_print_tally(&pooled,
                          p->seeds > 1 ? "All seeds (pooled)" : "Results");
        bench_print_by_class(p);
    }
    return rc;
}

static void json_header(const bench_args *a, const bench_plan *p,
                        unsigned workers)
{
    size_t queries = 0;
    for (size_t m = 0; m < p->model_count; m++)
        queries += (size_t)p->models[m].is_query;
    printf("{\"library\": \"%s\", \"manifest\": ", phks_version_string());
    cli_json_string(a->manifest);
    fputs(", \"prefix\": ", stdout);
    cli_json_string(a->prefix);
    fputs(", \"classes\": ", stdout);
    if (a->classes)
        cli_json_string(a->classes);
    else
        fputs("null", stdout);
    fputs(", \"max_per_class\": ", stdout);
    if (a->max_per_class != (unsigned long)-1)
        printf("%lu", a->max_per_class);
    else
        fputs("null", stdout);
    printf(", \"seed_count\": %u, \"workers\": %u,\n  \"options\": ",
           p->seeds, workers);
    cli_json_options(&p->options);
    printf(",\n  \"feature_function\": \"%s\", \"descriptor\": \"%s\"",
           bench_feature_name[p->features], p->evd ? "evd" : "hks");
    printf(",\n  \"models\": %zu, \"query_models\": %zu, "
           "\"queries_per_seed\": %zu, \"database_models\": %zu",
           p->model_count, queries, 3 * queries, p->model_count - queries);
}

static int run(const bench_args *a, bench_plan *p, FILE *qout)
{
    if (bench_make_cache(a->cache) != 0)
        return 1;
    unsigned workers = (unsigned)a->workers;
    if (a->json)
        json_header(a, p, workers);
    else
        print_header(a, p, workers);
    fflush(stdout);
    double start = cli_seconds();
    bench_compute_all(p, workers);
    /* A source part whose database failed reports nothing (null). */
    int source = p->source && bench_source_run(p, workers) == 0;
    int rc = score_all(p, qout, a->json) | (p->source && !source);
    if (a->json) {
        fputs(",\n  \"source\": ", stdout);
        if (source)
            bench_source_json(p, a->one_character);
        else
            fputs("null", stdout);
    } else if (source)
        bench_source_print(p, a->one_character);
    bench_print_footer(p, cli_seconds() - start, a->json);
    return rc;
}

/* --db, --queries or --leave-one-out (before "--"): the mode on lists. */
static int on_lists(int argc, char **argv)
{
    for (int i = 1; i < argc && strcmp(argv[i], "--") != 0; i++)
        if (strcmp(argv[i], "--db") == 0 || strcmp(argv[i], "--queries") == 0 ||
            strcmp(argv[i], "--leave-one-out") == 0)
            return 1;
    return 0;
}

int cli_bench(int argc, char **argv, const phks_options *options)
{
    bench_args a = {0};
    if (cli_help(argc, argv, usage))
        return 0;
    if (on_lists(argc, argv))
        return bench_lists(argc, argv, options, usage);
    int features, evd;
    if (parse_args(argc, argv, &a) != 0 ||
        parse_comparison(&a, &features, &evd) != 0)
        return cli_usage(usage);
    cli_row *rows;
    size_t n;
    if (cli_manifest_read(a.manifest, &rows, &n) != 0)
        return 1;
    bench_plan p = {.seeds = (unsigned)a.seeds, .options = *options,
                    .cache_dir = a.cache, .source = !a.no_source,
                    .features = features, .evd = evd};
    p.options.threads = 1;
    FILE *qout = NULL;
    int rc = check_classes(&a, rows, n) || select_models(&a, rows, n, &p) ||
             (a.group && plan_group(&a, &p));
    if (!rc && plan_items(&p) != 0)
        rc = cli_error("bench", "out of memory");
    if (!rc && a.queries_out && !(qout = open_queries_out(a.queries_out)))
        rc = 1;
    if (!rc)
        rc = run(&a, &p, qout);
    if (qout && fclose(qout) != 0)
        rc = cli_error(a.queries_out, strerror(errno));
    for (size_t i = 0; i < p.item_count; i++) {
        phks_signature_free(p.items[i].sig);
        free(p.items[i].truth);
        free(p.items[i].error);
        free(p.items[i].verified);
        free(p.items[i].recall);
        free(p.items[i].evd);
    }
    free(p.items);
    free(p.models);
    free(p.classes);
    free(p.by_class);
    free(p.group_name);
    cli_manifest_free(rows, n);
    return rc ? 1 : 0;
}
