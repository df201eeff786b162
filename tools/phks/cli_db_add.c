/*
 * cli_db_add.c - `phks db add`: signatures of many files computed on worker
 * threads and added to a database one by one as they complete, so a crash
 * loses only the files in flight.
 */
#include "cli.h"

#include <inttypes.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

typedef struct add_job {
    phks_db *db;
    phks_options options;       /* threads = 1: the workers share the CPUs */
    size_t count;
    char **names, **paths;
    const char **labels;
    char **owned;               /* names and paths made here, or NULL */
    atomic_size_t added, failed;
} add_job;

static void add_one(void *ctx, size_t i)
{
    add_job *job = ctx;
    phks_mesh *mesh;
    phks_signature *sig = NULL;
    int64_t id = 0;
    phks_status st = phks_mesh_load(job->paths[i], &mesh);
    if (st == PHKS_OK) {
        st = phks_signature_compute(mesh, &job->options, &sig);
        phks_mesh_free(mesh);
    }
    if (st == PHKS_OK)
        st = phks_db_add(job->db, job->names[i], job->labels[i], sig, &id);
    if (st == PHKS_OK) {
        cli_say(stdout, "added %" PRId64 " %s\n", id, job->names[i]);
        atomic_fetch_add(&job->added, 1);
    } else {
        cli_say_fail(job->paths[i], st);
        atomic_fetch_add(&job->failed, 1);
    }
    phks_signature_free(sig);
    cli_progress_step();
}

/* Work lists from the command line: every file under one label. */
static int from_files(add_job *job, char **files, size_t count,
                      const char *label)
{
    job->count = count;
    job->names = files;
    job->paths = files;
    job->labels = malloc((count ? count : 1) * sizeof *job->labels);
    if (!job->labels)
        return cli_error("db add", "out of memory");
    for (size_t i = 0; i < count; i++)
        job->labels[i] = label;
    return 0;
}

/* ... or from a manifest: name = the file column, path relative to the
 * manifest's directory, label = the class column. */
static int from_manifest(add_job *job, cli_row *rows, size_t count)
{
    job->count = count;
    job->owned = malloc(2 * (count ? count : 1) * sizeof *job->owned);
    job->labels = malloc((count ? count : 1) * sizeof *job->labels);
    if (!job->owned || !job->labels)
        return cli_error("db add", "out of memory");
    job->names = job->owned;
    job->paths = job->owned + count;
    for (size_t i = 0; i < count; i++) {
        job->names[i] = rows[i].name;
        job->paths[i] = rows[i].path;
        job->labels[i] = rows[i].cls;
    }
    return 0;
}

static int run(add_job *job, const char *db_path, unsigned workers)
{
    phks_status st = phks_db_open(db_path, PHKS_DB_CREATE, &job->db);
    if (st != PHKS_OK)
        return cli_fail(db_path, st);
    if (cli_db_options(job->db, db_path, &job->options) != 0) {
        phks_db_close(job->db);
        return 1;
    }
    cli_blas_one_thread();
    cli_progress_start(job->count, "files");
    cli_pool_run(job->count, workers, add_one, job);
    cli_progress_end();
    phks_db_close(job->db);
    size_t failed = atomic_load(&job->failed);
    printf("%s: %zu added, %zu failed\n", db_path, atomic_load(&job->added),
           failed);
    return failed ? 1 : 0;
}

int cli_db_add(int argc, char **argv, const phks_options *options)
{
    static const char usage[] =
        "db add DB FILES... [--label L] [-j N] | db add DB --manifest TSV [-j N]";
    const char *label = NULL, *manifest = NULL, *jobs = NULL;
    const cli_opt opts[] = {{"--label", &label, NULL},
                            {"--manifest", &manifest, NULL},
                            {"-j", &jobs, NULL}};
    int n;
    unsigned long workers = cli_cpu_count();
    if (cli_parse(argc, argv, 1, opts, 3, &n) != 0 || n < 1 ||
        (manifest ? n != 1 || label : n < 2) ||
        (jobs && cli_parse_count(jobs, 1, 1024, &workers) != 0))
        return cli_usage(usage);
    add_job job = {.options = *options};
    job.options.threads = 1;
    cli_row *rows = NULL;
    size_t nrows = 0;
    int rc = manifest ? cli_manifest_read(manifest, &rows, &nrows) != 0 ||
                            from_manifest(&job, rows, nrows)
                      : from_files(&job, argv + 2, (size_t)n - 1, label);
    if (rc == 0)
        rc = run(&job, argv[1], (unsigned)workers);
    else
        rc = 1;
    free(job.owned);
    free(job.labels);
    cli_manifest_free(rows, nrows);
    return rc;
}
