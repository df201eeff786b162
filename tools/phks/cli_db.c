/*
 * cli_db.c - `phks db query | list | remove` (and the dispatch to `db add`,
 * in cli_db_add.c): shape databases through the phks_db_* functions.
 */
#include "cli.h"
#include "common/cli_common.h"
#include "render/cli_pictures.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#define PAGE 256

static const char query_usage[] =
    "db query DB MESH|SIG [-k K] [--json] [--png OUT.png]\n"
    "  -k K           the K best entries, 1..1000000 (10)\n"
    "  --json         print the hits as JSON (text)\n"
    "  --png OUT.png  also draw a contact sheet of the query and its hits\n"
    "  the signature of a mesh is computed with the database's options";
static const char list_usage[] =
    "db list DB [--json]\n"
    "  --json    print the entries as JSON (text)";
static const char info_usage[] =
    "db info DB [--json]\n"
    "  --json    print the database's description as JSON (text)";
static const char remove_usage[] = "db remove DB ID...";
static const char db_usage[] =
    "db add|query|list|info|remove DB ...\n"
    "  phks db add DB FILES|DIRS... [--label L] [-j N] [--allow-duplicates]\n"
    "  phks db add DB --manifest TSV [-j N] [--allow-duplicates]\n"
    "  phks db query DB MESH|SIG [-k K (10)] [--json] [--png OUT.png]\n"
    "  phks db list DB [--json]\n"
    "  phks db info DB [--json]\n"
    "  phks db remove DB ID...\n"
    "  `phks db SUBCOMMAND --help` tells more";

/* What a reader weighs a hit's score by (phks_similarity of the query
 * against the hit's stored signature). */
typedef struct weight {
    double similarity;
    size_t verified;
} weight;

/* The weights of the count hits: one phks_db_similarity each, as many
 * verifications again as the query's re-ranking made. */
static phks_status weigh_hits(phks_db *db, const phks_signature *query,
                              const phks_hit *hits, size_t count, weight *w)
{
    phks_status st = PHKS_OK;
    for (size_t i = 0; st == PHKS_OK && i < count; i++)
        st = phks_db_similarity(db, query, hits[i].id, &w[i].similarity,
                                &w[i].verified);
    return st;
}

static void print_hits(const phks_hit *hits, const weight *w, size_t count,
                       size_t features, int json)
{
    if (!json) {
        printf("%4s %8s %14s %10s %8s  %-16s %s\n", "rank", "id", "score",
               "similarity", "verified", "label", "name");
        for (size_t i = 0; i < count; i++)
            printf("%4zu %8" PRId64 " %14.6g %10.3f %5zu/%-2zu  %-16s %s\n",
                   i + 1, hits[i].id, hits[i].score, w[i].similarity,
                   w[i].verified, features, hits[i].label, hits[i].name);
        return;
    }
    printf("[");
    for (size_t i = 0; i < count; i++) {
        printf("%s\n  {\"rank\": %zu, \"id\": %" PRId64 ", \"score\": %.17g, "
               "\"similarity\": %.17g, \"verified\": %zu, \"features\": %zu, "
               "\"label\": ", i ? "," : "", i + 1, hits[i].id, hits[i].score,
               w[i].similarity, w[i].verified, features);
        cli_json_string(hits[i].label);
        printf(", \"name\": ");
        cli_json_string(hits[i].name);
        printf("}");
    }
    printf("%s]\n", count ? "\n" : "");
}

static int db_query(int argc, char **argv, const phks_options *defaults)
{
    const char *k_text = "10", *png = NULL;
    int json = 0, n;
    const cli_opt opts[] = {{"-k", &k_text, NULL}, {"--json", NULL, &json},
                            {"--png", &png, NULL}};
    unsigned long k;
    if (cli_help(argc, argv, query_usage))
        return 0;
    if (cli_parse(argc, argv, 1, opts, 3, &n) != 0 || n != 2 ||
        cli_option_count("-k", k_text, 1, 1000000, &k) != 0)
        return cli_usage(query_usage);
    if (png && !cli_has_suffix(png, ".png"))  /* as render's -o */
        return cli_error(png, "--png writes PNG only: name the contact "
                              "sheet OUT.png");
    if (png && !cli_png_supported())
        return cli_png_write(png, NULL);  /* "built without PNG support" */
    phks_db *db;
    phks_status st = phks_db_open(argv[1], PHKS_DB_READONLY, &db);
    if (st != PHKS_OK)
        return cli_fail(argv[1], st);
    size_t entries = 0;
    if ((st = phks_db_count(db, &entries)) != PHKS_OK) {
        phks_db_close(db);
        return cli_fail(argv[1], st);
    }
    k = k < entries ? k : entries ? entries : 1;  /* room for what exists */
    phks_options options = *defaults;
    if (cli_db_options(db, argv[1], &options) != 0) {
        phks_db_close(db);
        return 1;
    }
    phks_signature *query = cli_signature_of(argv[2], &options);
    phks_hit *hits = query ? malloc(k * sizeof *hits) : NULL;
    weight *w = hits ? malloc(k * sizeof *w) : NULL;
    size_t count = 0;
    int rc = 1;
    if (query && (!hits || !w))
        cli_error(argv[1], "out of memory");
    else if (w && (st = phks_db_query(db, query, k, hits, &count)) != PHKS_OK) {
        /* A .sig made with other options: that file is the one to blame. */
        if (st == PHKS_ERROR_INCOMPATIBLE)
            cli_say_db_fail(db, argv[2], query, st);
        else
            cli_fail(argv[1], st);
    }
    else if (w && (st = weigh_hits(db, query, hits, count, w)) != PHKS_OK)
        cli_fail(argv[1], st);
    else if (w) {
        print_hits(hits, w, count, phks_signature_feature_count(query), json);
        rc = png ? cli_sheet_write(png, db, argv[2], query, hits, count) : 0;
    }
    free(w);
    free(hits);
    phks_signature_free(query);
    phks_db_close(db);
    return rc;
}

/* phks_db_get with buffers that grow until the name and label fit. */
static phks_status get_entry(phks_db *db, int64_t id, phks_signature **sig,
                             char **name, char **label, size_t *cap)
{
    for (;;) {
        phks_status st = phks_db_get(db, id, sig, *name, *cap, *label, *cap);
        if (st != PHKS_ERROR_BUFFER_TOO_SMALL || *cap >= ((size_t)1 << 26))
            return st;
        char *n = realloc(*name, *cap * 4), *l = n ? realloc(*label, *cap * 4) : NULL;
        if (n)
            *name = n;
        if (!n || !l)
            return PHKS_ERROR_OUT_OF_MEMORY;
        *label = l;
        *cap *= 4;
    }
}

static phks_status list_page(phks_db *db, const int64_t *ids, size_t count,
                             char **name, char **label, size_t *cap,
                             int json, size_t *listed)
{
    for (size_t i = 0; i < count; i++) {
        phks_signature *sig;
        phks_status st = get_entry(db, ids[i], &sig, name, label, cap);
        if (st != PHKS_OK)
            return st;
        if (json) {
            printf("%s\n  {\"id\": %" PRId64 ", \"label\": ",
                   (*listed)++ ? "," : "", ids[i]);
            cli_json_string(*label);
            printf(", \"features\": %zu, \"name\": ",
                   phks_signature_feature_count(sig));
            cli_json_string(*name);
            putchar('}');
        } else
            printf("%8" PRId64 "  %-16s %8zu  %s\n", ids[i], *label,
                   phks_signature_feature_count(sig), *name);
        phks_signature_free(sig);
    }
    return PHKS_OK;
}

static int db_list(int argc, char **argv)
{
    int n, json = 0;
    size_t listed = 0;
    const cli_opt opts[] = {{"--json", NULL, &json}};
    if (cli_help(argc, argv, list_usage))
        return 0;
    if (cli_parse(argc, argv, 1, opts, 1, &n) != 0 || n != 1)
        return cli_usage(list_usage);
    phks_db *db;
    phks_status st = phks_db_open(argv[1], PHKS_DB_READONLY, &db);
    if (st != PHKS_OK)
        return cli_fail(argv[1], st);
    size_t cap = 1024, count = PAGE;
    char *name = malloc(cap), *label = malloc(cap);
    int64_t ids[PAGE], after = 0;
    st = name && label ? PHKS_OK : PHKS_ERROR_OUT_OF_MEMORY;
    if (st == PHKS_OK && json)
        putchar('[');
    else if (st == PHKS_OK)
        printf("%8s  %-16s %8s  %s\n", "id", "label", "features", "name");
    while (st == PHKS_OK && count == PAGE &&
           (st = phks_db_list(db, after, ids, PAGE, &count)) == PHKS_OK &&
           count > 0) {
        st = list_page(db, ids, count, &name, &label, &cap, json, &listed);
        after = ids[count - 1];
    }
    if (st == PHKS_OK && json)
        printf("%s]\n", listed ? "\n" : "");
    free(name);
    free(label);
    phks_db_close(db);
    return st == PHKS_OK ? 0 : cli_fail(argv[1], st);
}

static int parse_id(const char *text, int64_t *id)
{
    char *end;
    if (*text < '0' || *text > '9')
        return -1;
    unsigned long long v = strtoull(text, &end, 10);
    *id = (int64_t)v;
    return *end || v == 0 || v > INT64_MAX ? -1 : 0;
}

static int db_remove(int argc, char **argv)
{
    int n, rc = 0;
    int64_t id;
    if (cli_help(argc, argv, remove_usage))
        return 0;
    if (cli_parse(argc, argv, 1, NULL, 0, &n) != 0 || n < 2)
        return cli_usage(remove_usage);
    for (int i = 2; i <= n; i++)
        if (parse_id(argv[i], &id) != 0)
            return cli_usage("db remove DB ID...  (ids are positive integers)");
    phks_db *db;
    phks_status st = phks_db_open(argv[1], 0, &db);
    if (st != PHKS_OK)
        return cli_fail(argv[1], st);
    for (int i = 2; i <= n; i++) {
        parse_id(argv[i], &id);
        if ((st = phks_db_remove(db, id)) != PHKS_OK)
            rc = cli_fail(argv[1], st);
        else
            printf("removed %" PRId64 "\n", id);
    }
    phks_db_close(db);
    return rc;
}

/* The database format: SQLite's user_version, 4 bytes big-endian at
 * offset 60 of the file's header (docs/formats.md); 0 if unreadable. */
static unsigned long db_format(const char *path)
{
    unsigned char h[64];
    FILE *f = fopen(path, "rb");
    size_t got = f ? fread(h, 1, sizeof h, f) : 0;
    if (f)
        fclose(f);
    if (got < 64 || memcmp(h, "SQLite format 3", 15) != 0)
        return 0;
    return (unsigned long)h[60] << 24 | (unsigned long)h[61] << 16 |
           (unsigned long)h[62] << 8 | h[63];
}

static int db_info(int argc, char **argv, const phks_options *defaults)
{
    int n, json = 0;
    const cli_opt opts[] = {{"--json", NULL, &json}};
    if (cli_help(argc, argv, info_usage))
        return 0;
    if (cli_parse(argc, argv, 1, opts, 1, &n) != 0 || n != 1)
        return cli_usage(info_usage);
    phks_db *db;
    phks_status st = phks_db_open(argv[1], PHKS_DB_READONLY, &db);
    if (st != PHKS_OK)
        return cli_fail(argv[1], st);
    size_t entries = 0;
    st = phks_db_count(db, &entries);
    phks_options o = *defaults;
    unsigned saved = cli_explicit;
    cli_explicit = 0;  /* describing, not adding: nothing to refuse */
    int rc = st != PHKS_OK ? cli_fail(argv[1], st)
                           : cli_db_options(db, argv[1], &o);
    cli_explicit = saved;
    phks_db_close(db);
    if (rc)
        return rc;
    unsigned long format = db_format(argv[1]);
    if (json) {
        fputs("{\"path\": ", stdout);
        cli_json_string(argv[1]);
        printf(", \"format\": %lu, \"entries\": %zu,\n  \"options\": ",
               format, entries);
        if (entries)
            cli_json_options(&o);
        else
            fputs("null", stdout);
        fputs("\n}\n", stdout);
        return 0;
    }
    printf("path      %s\nformat    %lu\nentries   %zu\n", argv[1], format,
           entries);
    if (entries)
        cli_print_options(stdout, "options   ", &o);
    else
        printf("options   none yet (the first signature added sets them)\n");
    return 0;
}

int cli_db(int argc, char **argv, const phks_options *options)
{
    const char *sub = argc > 1 ? argv[1] : "";
    if (strcmp(sub, "--help") == 0 || strcmp(sub, "-h") == 0) {
        printf("usage: phks %s\n", db_usage);
        return 0;
    }
    if (strcmp(sub, "info") == 0)
        return db_info(argc - 1, argv + 1, options);
    if (strcmp(sub, "add") == 0)
        return cli_db_add(argc - 1, argv + 1, options);
    if (strcmp(sub, "query") == 0)
        return db_query(argc - 1, argv + 1, options);
    if (strcmp(sub, "list") == 0)
        return db_list(argc - 1, argv + 1);
    if (strcmp(sub, "remove") == 0)
        return db_remove(argc - 1, argv + 1);
    if (*sub)
        fprintf(stderr, "phks: unknown db command %s\n", sub);
    return cli_usage(db_usage);
}
