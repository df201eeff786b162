/*
 * cli_db_add.c - `phks db add`: signatures of many files (meshes, .sig
 * blobs, or the mesh and blob files under directories) computed on worker
 * threads and added to a database one by one in the order given, so a crash
 * loses only the files in flight and the ids are the same whatever -j. A
 * signature whose encoded blob equals an entry's is skipped unless
 * --allow-duplicates.
 */
#include "cli.h"
#include "common/cli_common.h"
#include "assimp_reader.h"

#include <dirent.h>
#include <errno.h>
#include <inttypes.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

static const char usage[] =
    "db add DB FILES|DIRS... [--label L] [-j N] [--allow-duplicates]\n"
    "       phks db add DB --manifest TSV [-j N] [--allow-duplicates]\n"
    "  FILES               meshes (OFF, OBJ, PLY, STL, optionally .gz) or .sig\n"
    "                      blobs; a directory adds its mesh and .sig files,\n"
    "                      recursively, sorted by name\n"
    "  --label L           label of every entry (none)\n"
    "  --manifest TSV      files and labels from the TSV's file and class\n"
    "                      columns\n"
    "  -j N                worker threads, 1..1024 (the online CPUs)\n"
    "  --allow-duplicates  add a signature equal to an entry's (skipped)\n"
    "  the database is created if missing; a non-empty one computes with its\n"
    "  own options";

/* Hashes of the entries' encoded blobs (open addressing), and their ids. */
typedef struct seen {
    uint64_t *hash;
    int64_t *id;
    size_t cap, count;
} seen;

/* A file computed, waiting for its turn to be added. */
typedef struct slot {
    phks_signature *sig;        /* NULL: it failed (and said so) */
    unsigned char *blob;
    size_t size;
    bool ready;
} slot;

typedef struct add_job {
    phks_db *db;
    phks_options options;       /* threads = 1: the workers share the CPUs */
    size_t count;
    char **names, **paths;
    const char **labels;
    char **owned;               /* strings made here, or NULL */
    size_t owned_count;
    int allow_duplicates;
    pthread_mutex_t lock;       /* seen, the window, and the adds */
    seen seen;
    /* The reorder window: file i waits in slot i % window_size until files
     * 0..i-1 are added, so ids follow the input, not the workers' finishing
     * order. A worker takes file i only once i < next + window_size, which
     * bounds the signatures held; the pool hands files out in order, so the
     * file at next is always being computed and the window always drains. */
    slot *window;
    size_t window_size, next;
    pthread_cond_t turn;        /* next moved */
    atomic_size_t added, failed, skipped;
} add_job;

static int seen_put(seen *s, uint64_t h, int64_t id)
{
    if (2 * (s->count + 1) > s->cap) {
        seen bigger = {calloc(s->cap ? 2 * s->cap : 256, 8),
                       calloc(s->cap ? 2 * s->cap : 256, 8),
                       s->cap ? 2 * s->cap : 256, 0};
        if (!bigger.hash || !bigger.id) {
            free(bigger.hash);
            free(bigger.id);
            return -1;
        }
        for (size_t i = 0; i < s->cap; i++)
            if (s->id[i])
                seen_put(&bigger, s->hash[i], s->id[i]);
        free(s->hash);
        free(s->id);
        *s = bigger;
    }
    size_t i = (size_t)(h % s->cap);
    while (s->id[i])
        i = (i + 1) % s->cap;
    s->hash[i] = h;
    s->id[i] = id;
    s->count++;
    return 0;
}

/* The encoding of entry id, to confirm a hash match byte for byte. */
static int same_blob(phks_db *db, int64_t id, const unsigned char *blob,
                     size_t size)
{
    phks_signature *sig;
    unsigned char *other = NULL;
    size_t n;
    if (phks_db_get(db, id, &sig, NULL, 0, NULL, 0) != PHKS_OK)
        return 0;
    int same = cli_encode(sig, &other, &n) == PHKS_OK && n == size &&
               memcmp(other, blob, n) == 0;
    free(other);
    phks_signature_free(sig);
    return same;
}

/* An entry with this very blob, or 0. */
static int64_t seen_find(add_job *job, const unsigned char *blob, size_t size)
{
    seen *s = &job->seen;
    uint64_t h = cli_hash_bytes(0, blob, size);
    for (size_t i = s->cap ? (size_t)(h % s->cap) : 0; s->cap && s->id[i];
         i = (i + 1) % s->cap)
        if (s->hash[i] == h && same_blob(job->db, s->id[i], blob, size))
            return s->id[i];
    return 0;
}

static phks_status load_existing(add_job *job)
{
    int64_t ids[256], after = 0;
    size_t count = 256;
    phks_status st = PHKS_OK;
    while (count == 256 &&
           (st = phks_db_list(job->db, after, ids, 256, &count)) == PHKS_OK) {
        for (size_t i = 0; i < count && st == PHKS_OK; i++) {
            phks_signature *sig = NULL;
            unsigned char *blob;
            size_t size;
            st = phks_db_get(job->db, ids[i], &sig, NULL, 0, NULL, 0);
            if (st == PHKS_OK && (st = cli_encode(sig, &blob, &size)) == PHKS_OK) {
                if (seen_put(&job->seen, cli_hash_bytes(0, blob, size),
                             ids[i]) != 0)
                    st = PHKS_ERROR_OUT_OF_MEMORY;
                free(blob);
            }
            phks_signature_free(sig);
        }
        if (count)
            after = ids[count - 1];
    }
    return st;
}

static phks_signature *signature_of(add_job *job, size_t i)
{
    const char *path = job->paths[i];
    if (cli_is_blob(path))
        return cli_signature_of(path, &job->options);
    phks_mesh *mesh;
    phks_signature *sig = NULL;
    if (cli_load_mesh(path, &mesh) != 0)
        return NULL;
    phks_status st = phks_signature_compute(mesh, &job->options, &sig);
    phks_mesh_free(mesh);
    if (st != PHKS_OK)
        cli_say_fail(path, st);
    return sig;
}

/* Adds the file at next from its slot, and moves next on; with lock
 * held. */
static void add_in_turn(add_job *job)
{
    size_t i = job->next++;
    slot *s = &job->window[i % job->window_size];
    int64_t id = 0, twin = 0;
    phks_status st = PHKS_OK;
    if (s->sig && !job->allow_duplicates)
        twin = seen_find(job, s->blob, s->size);
    if (s->sig && !twin)
        st = phks_db_add(job->db, job->names[i], job->labels[i], s->sig, &id);
    if (s->sig && !twin && st == PHKS_OK &&
        seen_put(&job->seen, cli_hash_bytes(0, s->blob, s->size), id) != 0)
        st = PHKS_ERROR_OUT_OF_MEMORY;
    if (s->sig && st != PHKS_OK)
        cli_say_db_fail(job->db, job->paths[i], s->sig, st);
    if (twin) {
        cli_say(stdout, "skipped %s: the same signature as entry %" PRId64
                "\n", job->names[i], twin);
        atomic_fetch_add(&job->skipped, 1);
    } else if (s->sig && st == PHKS_OK) {
        cli_say(stdout, "added %" PRId64 " %s\n", id, job->names[i]);
        atomic_fetch_add(&job->added, 1);
    } else
        atomic_fetch_add(&job->failed, 1);
    free(s->blob);
    phks_signature_free(s->sig);
    *s = (slot){0};
    cli_progress_step();
}

/* File i's signature and its encoding, or a slot with no signature. */
static slot computed(add_job *job, size_t i)
{
    slot s = {signature_of(job, i), NULL, 0, true};
    phks_status st = s.sig ? cli_encode(s.sig, &s.blob, &s.size) : PHKS_OK;
    if (st != PHKS_OK) {
        cli_say_fail(job->paths[i], st);
        phks_signature_free(s.sig);
        s.sig = NULL;
    }
    return s;
}

static void add_one(void *ctx, size_t i)
{
    add_job *job = ctx;
    pthread_mutex_lock(&job->lock);
    while (i >= job->next + job->window_size)
        pthread_cond_wait(&job->turn, &job->lock);
    pthread_mutex_unlock(&job->lock);
    slot s = computed(job, i);
    pthread_mutex_lock(&job->lock);
    job->window[i % job->window_size] = s;
    /* Whoever completes the run of ready files adds them. */
    while (job->window[job->next % job->window_size].ready)
        add_in_turn(job);
    pthread_cond_broadcast(&job->turn);
    pthread_mutex_unlock(&job->lock);
}

/* ---- the work list ---------------------------------------------------------- */
typedef struct list {
    char **v;
    size_t n, cap;
} list;

static int list_add(list *l, char *s)
{
    if (!s)
        return -1;
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 64;
        char **v = realloc(l->v, cap * sizeof *v);
        if (!v) {
            free(s);
            return -1;
        }
        l->v = v;
        l->cap = cap;
    }
    l->v[l->n++] = s;
    return 0;
}

static char *dup_string(const char *s)
{
    char *d = malloc(strlen(s) + 1);
    return d ? strcpy(d, s) : NULL;
}

static int wanted_name(const char *name)
{
    /* glTF, FBX, ...: the common ones of assimp, when the tool has it. */
    if (assimp_reader_available() && assimp_reader_common(name))
        return 1;
    static const char *const ext[] = {".off", ".obj", ".ply", ".stl", ".sig"};
    size_t n = strlen(name);
    if (n > 3 && strcasecmp(name + n - 3, ".gz") == 0)
        n -= 3;
    for (size_t i = 0; i < sizeof ext / sizeof ext[0]; i++)
        if (n > 4 && strncasecmp(name + n - 4, ext[i], 4) == 0 &&
            (ext[i][1] != 's' || ext[i][2] != 'i' || n == strlen(name)))
            return 1;
    return 0;
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The wanted files under dir, recursively, into l (unsorted). */
static int walk(const char *dir, list *l)
{
    DIR *d = opendir(dir);
    if (!d)
        return cli_error(dir, strerror(errno));
    struct dirent *e;
    int rc = 0;
    while (!rc && (e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        size_t len = strlen(dir);
        char *path = malloc(len + strlen(e->d_name) + 2);
        if (!path) {
            rc = cli_error(dir, "out of memory");
            break;
        }
        sprintf(path, "%s%s%s", dir, len && dir[len - 1] == '/' ? "" : "/",
                e->d_name);
        struct stat st;
        if (stat(path, &st) != 0)
            free(path);
        else if (S_ISDIR(st.st_mode)) {
            rc = walk(path, l);
            free(path);
        } else if (S_ISREG(st.st_mode) && wanted_name(e->d_name))
            rc = list_add(l, path) ? cli_error(dir, "out of memory") : 0;
        else
            free(path);
    }
    closedir(d);
    return rc;
}

/* Work lists from the command line: files as given, directories expanded,
 * every entry under one label. */
static int from_files(add_job *job, char **args, size_t nargs,
                      const char *label)
{
    list l = {0};
    int rc = 0;
    for (size_t i = 0; i < nargs && !rc; i++) {
        struct stat st;
        if (stat(args[i], &st) == 0 && S_ISDIR(st.st_mode)) {
            size_t first = l.n;
            rc = walk(args[i], &l);
            qsort(l.v + first, l.n - first, sizeof *l.v, by_name);
        } else if (list_add(&l, dup_string(args[i])) != 0)
            rc = cli_error("db add", "out of memory");
    }
    job->owned = l.v;
    job->owned_count = l.n;
    job->count = l.n;
    job->names = l.v;
    job->paths = l.v;
    job->labels = malloc((l.n ? l.n : 1) * sizeof *job->labels);
    if (!rc && !job->labels)
        rc = cli_error("db add", "out of memory");
    for (size_t i = 0; !rc && i < l.n; i++)
        job->labels[i] = label;
    return rc;
}

/* ... or from a manifest: name = the file column, path relative to the
 * manifest's directory, label = the class column. */
static int from_manifest(add_job *job, cli_row *rows, size_t count)
{
    job->count = count;
    job->names = malloc(2 * (count ? count : 1) * sizeof *job->names);
    job->labels = malloc((count ? count : 1) * sizeof *job->labels);
    if (!job->names || !job->labels)
        return cli_error("db add", "out of memory");
    job->paths = job->names + count;
    for (size_t i = 0; i < count; i++) {
        job->names[i] = rows[i].file;
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
    if (!job->allow_duplicates && (st = load_existing(job)) != PHKS_OK) {
        phks_db_close(job->db);
        return cli_fail(db_path, st);
    }
    /* Two slots a worker: one computing, one waiting for its turn. */
    job->window_size = 2 * (size_t)workers;
    job->window = calloc(job->window_size, sizeof *job->window);
    if (!job->window) {
        phks_db_close(job->db);
        return cli_error("db add", "out of memory");
    }
    cli_blas_one_thread();
    cli_progress_start(job->count, "files");
    cli_pool_run(job->count, workers, add_one, job);
    cli_progress_end();
    free(job->window);
    phks_db_close(job->db);
    size_t failed = atomic_load(&job->failed);
    size_t skipped = atomic_load(&job->skipped);
    printf("%s: %zu added, %zu failed", db_path, atomic_load(&job->added),
           failed);
    if (skipped)
        printf(", skipped %zu duplicate%s", skipped, skipped == 1 ? "" : "s");
    printf("\n");
    return failed ? 1 : 0;
}

int cli_db_add(int argc, char **argv, const phks_options *options)
{
    const char *label = NULL, *manifest = NULL, *jobs = NULL;
    int allow = 0;
    const cli_opt opts[] = {{"--label", &label, NULL},
                            {"--manifest", &manifest, NULL},
                            {"-j", &jobs, NULL},
                            {"--allow-duplicates", NULL, &allow}};
    int n;
    unsigned long workers = cli_cpu_count();
    if (cli_help(argc, argv, usage))
        return 0;
    if (cli_parse(argc, argv, 1, opts, 4, &n) != 0 || n < 1 ||
        (manifest ? n != 1 || label : n < 2) ||
        (jobs && cli_option_count("-j", jobs, 1, 1024, &workers) != 0))
        return cli_usage(usage);
    add_job job = {.options = *options, .allow_duplicates = allow};
    pthread_mutex_init(&job.lock, NULL);
    pthread_cond_init(&job.turn, NULL);
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
    for (size_t i = 0; i < job.owned_count; i++)
        free(job.owned[i]);
    free(job.owned);
    if (manifest)
        free(job.names);
    free(job.labels);
    free(job.seen.hash);
    free(job.seen.id);
    pthread_mutex_destroy(&job.lock);
    pthread_cond_destroy(&job.turn);
    cli_manifest_free(rows, nrows);
    return rc;
}
