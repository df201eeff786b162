/*
 * test_threads.c - eight threads at once, each computing signatures of
 * different meshes and querying one shared database handle, give bit for
 * bit the answers one thread gave before: the same encoded signatures and
 * the same hits (ids, scores, names, labels).
 *
 * The meshes differ in shape and in the path they take: the dense solver,
 * block Lanczos with two operator threads of its own, ARPACK (serialised
 * inside the library) and HKS-simp with two threads. The database holds
 * their signatures and enough synthetic ones that every query scans on
 * several threads (db_scan.c's PARALLEL_MIN); half the threads also add
 * and remove an entry while the others query, whose scores are far worse
 * than any other so it never enters the hits compared.
 *
 * The library's worker team, which carries the loops of one computation,
 * keeps each loop's chunks and survives a loop started from inside one.
 *
 * CI runs this file under ThreadSanitizer too (README: build-tsan), with
 * OPENBLAS_NUM_THREADS=1 as in every test (OpenBLAS and LAPACK are not
 * instrumented).
 */
#include "testutil.h"
#include "soup.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define THREADS 8
#define MESHES 8
#define ROUNDS 2
#define K 12          /* hits compared per query */
#define SYNTHETIC 4200 /* above PARALLEL_MIN (4096): parallel scans */

/* ---- the meshes and their options */

typedef struct blob {
    unsigned char *p;
    size_t n;
} blob;

static phks_mesh *make_mesh(int i)
{
    uint64_t rng = 100 + (uint64_t)i;
    soup s = {0};
    if (i % 4 == 1) {
        add_torus(&s, 24 + (size_t)i, 17, 1, 0.35 + 0.02 * i, 0.3, &rng);
    } else {
        const double center[3] = {0, 0, 0};
        const double axes[3] = {1, 0.9 - 0.05 * i, 0.5 + 0.04 * i};
        add_icosphere(&s, 3, center, axes, 0.04, &rng); /* 642 vertices */
    }
    return soup_mesh_take(&s);
}

/* Options that differ between the meshes only in what signatures do not
 * record (solver, threads, HKS-simp), so that all go into one database. */
static phks_options mesh_options(int i)
{
    phks_options o;
    phks_options_init(&o);
    o.eigen_count = 30;
    o.tau = 0.001;
    o.threads = 1;
    switch (i % 4) {
    case 0: o.solver = PHKS_SOLVER_DENSE; break;
    case 1: o.solver = PHKS_SOLVER_LANCZOS; o.threads = 2; break;
    case 2: o.solver = PHKS_SOLVER_ARPACK; break;
    case 3:
        o.simplify_above = 300;
        o.simplify_target = 200;
        o.threads = 2;
        break;
    }
    return o;
}

static blob encode(const phks_signature *sig)
{
    blob b = {NULL, phks_signature_encoded_size(sig)};
    b.p = malloc(b.n);
    size_t size = 0;
    if (b.p && phks_signature_encode(sig, b.p, b.n, &size) != PHKS_OK) {
        free(b.p);
        b.p = NULL;
    }
    return b;
}

/* A signature with the options of like, count features of random vectors
 * in [0, scale). */
static phks_signature *synthetic(const phks_signature *like, size_t count,
                                 double scale, uint64_t *rng)
{
    phks_signature *sig;
    ck_assert_int_eq(phks__signature_alloc(count, 0, like->length, &sig), PHKS_OK);
    sig->options = like->options;
    if (like->geodesic) {
        ck_assert_int_eq(phks__signature_alloc_layout(sig), PHKS_OK);
        for (size_t k = 0; k < phks__pair_count(count); k++)
            sig->geodesic[k] = (float)test_random(rng);
    }
    for (size_t i = 0; i < count; i++) {
        if (sig->boundary)
            sig->boundary[i] = INFINITY;
        sig->vertex[i] = (uint32_t)i;
        for (int d = 0; d < 3; d++)
            sig->position[3 * i + d] = test_random(rng);
        sig->persistence[i] = i == 0 ? INFINITY : test_random(rng);
        for (size_t s = 0; s < like->length; s++)
            sig->vectors[i * like->length + s] = scale * test_random(rng);
    }
    return sig;
}

static bool same_hits(const phks_hit *a, size_t na, const phks_hit *b,
                      size_t nb)
{
    if (na != nb)
        return false;
    for (size_t i = 0; i < na; i++)
        if (a[i].id != b[i].id ||
            memcmp(&a[i].score, &b[i].score, sizeof a[i].score) != 0 ||
            strcmp(a[i].name, b[i].name) != 0 ||
            strcmp(a[i].label, b[i].label) != 0)
            return false;
    return true;
}

/* ---- the threads */

typedef struct shared {
    phks_mesh *meshes[MESHES];
    phks_options options[MESHES];
    blob want_blob[MESHES];          /* one thread's encoded signatures   */
    phks_signature *queries[MESHES]; /* one thread's signatures           */
    phks_hit want_hits[MESHES][K];   /* one thread's hits for each query  */
    size_t want_count[MESHES];
    phks_signature *far;             /* added and removed while querying  */
    phks_db *db;                     /* the handle all threads share      */
    pthread_barrier_t start;
} shared;

typedef struct worker {
    shared *sh;
    int index;
    int failures;
    char first_failure[256];
} worker;

static void failed(worker *w, const char *fmt, ...) PHKS__PRINTF(2, 3);
static void failed(worker *w, const char *fmt, ...)
{
    if (w->failures++ == 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(w->first_failure, sizeof w->first_failure, fmt, ap);
        va_end(ap);
    }
}

static void query_all(worker *w, const char *when)
{
    shared *sh = w->sh;
    for (int q = 0; q < MESHES; q++) {
        int m = (w->index + q) % MESHES;
        phks_hit hits[K];
        size_t count = 0;
        phks_status st = phks_db_query(sh->db, sh->queries[m], K, hits, &count);
        if (st != PHKS_OK)
            failed(w, "thread %d: query %d %s: %s", w->index, m, when,
                   phks_last_error_message());
        else if (!same_hits(hits, count, sh->want_hits[m], sh->want_count[m]))
            failed(w, "thread %d: query %d %s: other hits", w->index, m, when);
    }
}

static void *work(void *arg)
{
    worker *w = arg;
    shared *sh = w->sh;
    pthread_barrier_wait(&sh->start);
    for (int round = 0; round < ROUNDS; round++) {
        int m = (w->index + 3 * round) % MESHES;
        phks_signature *sig = NULL;
        phks_status st =
            phks_signature_compute(sh->meshes[m], &sh->options[m], &sig);
        if (st != PHKS_OK) {
            failed(w, "thread %d: mesh %d: %s", w->index, m,
                   phks_last_error_message());
            continue;
        }
        blob b = encode(sig);
        if (!b.p || b.n != sh->want_blob[m].n ||
            memcmp(b.p, sh->want_blob[m].p, b.n) != 0)
            failed(w, "thread %d: mesh %d: another signature", w->index, m);
        free(b.p);
        phks_signature_free(sig);
        query_all(w, "while computing");
        if (w->index % 2 == 0) {
            char name[32];
            snprintf(name, sizeof name, "far %d.%d", w->index, round);
            int64_t id = 0;
            if (phks_db_add(sh->db, name, "far", sh->far, &id) != PHKS_OK)
                failed(w, "thread %d: add: %s", w->index,
                       phks_last_error_message());
            query_all(w, "after an add");
            if (id && phks_db_remove(sh->db, id) != PHKS_OK)
                failed(w, "thread %d: remove: %s", w->index,
                       phks_last_error_message());
        }
    }
    return NULL;
}

START_TEST(eight_threads_agree_with_one)
{
    static shared sh;
    memset(&sh, 0, sizeof sh);
    double t0 = now();

    /* One thread: the signatures and the database. */
    phks_signature *sigs[MESHES];
    for (int i = 0; i < MESHES; i++) {
        sh.meshes[i] = make_mesh(i);
        sh.options[i] = mesh_options(i);
        ck_assert_int_eq(phks_signature_compute(sh.meshes[i], &sh.options[i],
                                                &sigs[i]),
                         PHKS_OK);
        ck_assert_uint_gt(phks_signature_feature_count(sigs[i]), 3);
        sh.want_blob[i] = encode(sigs[i]);
        ck_assert_ptr_nonnull(sh.want_blob[i].p);
        ck_assert_int_eq(phks_signature_decode(sh.want_blob[i].p,
                                               sh.want_blob[i].n,
                                               &sh.queries[i]),
                         PHKS_OK);
    }
    /* the four paths make different spectra: HKS-simp did simplify */
    phks_spectrum *spec;
    ck_assert_int_eq(phks_spectrum_compute(sh.meshes[3], &sh.options[3], &spec),
                     PHKS_OK);
    ck_assert_uint_lt(phks_spectrum_sample_count(spec),
                      phks_mesh_vertex_count(sh.meshes[3]));
    phks_spectrum_free(spec);
    double computed = now() - t0;

    char dir[] = "/tmp/phks-threads-XXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(dir));
    char path[64];
    snprintf(path, sizeof path, "%s/shapes.db", dir);
    phks_db *one;
    ck_assert_int_eq(phks_db_open(path, PHKS_DB_CREATE, &one), PHKS_OK);
    enum { N = MESHES + SYNTHETIC };
    phks_db_entry *entries = calloc(N, sizeof *entries);
    phks_signature **all = calloc(N, sizeof *all);
    char (*names)[32] = calloc(N, sizeof *names);
    ck_assert(entries && all && names);
    uint64_t rng = 7;
    for (int i = 0; i < N; i++) {
        /* synthetic vectors in the range of the real ones */
        all[i] = i < MESHES ? sigs[i]
                            : synthetic(sigs[0], 1 + (size_t)i % 15,
                                        2 * sigs[0]->vectors[0], &rng);
        snprintf(names[i], sizeof names[i], "%s %d",
                 i < MESHES ? "mesh" : "synthetic", i);
        entries[i] = (phks_db_entry){names[i], i % 3 ? "a" : NULL, all[i]};
    }
    ck_assert_int_eq(phks_db_add_batch(one, entries, N, NULL), PHKS_OK);
    for (int m = 0; m < MESHES; m++) {
        ck_assert_int_eq(phks_db_query(one, sh.queries[m], K, sh.want_hits[m],
                                       &sh.want_count[m]),
                         PHKS_OK);
        ck_assert_uint_eq(sh.want_count[m], K);
        /* a mesh finds itself first, at score 0 */
        ck_assert_str_eq(sh.want_hits[m][0].name, names[m]);
        ck_assert(sh.want_hits[m][0].score == 0);
    }
    /* worse than every entry for every query */
    sh.far = synthetic(sigs[0], 15, 1, &rng);
    for (size_t i = 0; i < 15 * sh.far->length; i++)
        sh.far->vectors[i] += 1e9;

    /* Eight threads on a fresh handle: the first queries race to fill its
     * packed copy. */
    ck_assert_int_eq(phks_db_open(path, 0, &sh.db), PHKS_OK);
    ck_assert_int_eq(pthread_barrier_init(&sh.start, NULL, THREADS), 0);
    pthread_t ids[THREADS];
    worker workers[THREADS];
    double t1 = now();
    for (int t = 0; t < THREADS; t++) {
        workers[t] = (worker){&sh, t, 0, ""};
        ck_assert_int_eq(pthread_create(&ids[t], NULL, work, &workers[t]), 0);
    }
    for (int t = 0; t < THREADS; t++)
        ck_assert_int_eq(pthread_join(ids[t], NULL), 0);
    double threaded = now() - t1;
    for (int t = 0; t < THREADS; t++)
        ck_assert_msg(workers[t].failures == 0, "%d failures, the first: %s",
                      workers[t].failures, workers[t].first_failure);
    size_t count;
    ck_assert_int_eq(phks_db_count(sh.db, &count), PHKS_OK);
    ck_assert_uint_eq(count, N);
    printf("8 signatures on one thread in %.1f s; %d signatures and %d "
           "queries on %d threads in %.1f s\n",
           computed, THREADS * ROUNDS,
           THREADS * ROUNDS * MESHES * 3 / 2, THREADS, threaded);

    pthread_barrier_destroy(&sh.start);
    phks_db_close(sh.db);
    phks_db_close(one);
    char file[96];
    static const char *suffixes[] = {"", "-wal", "-shm"};
    for (int i = 0; i < 3; i++) {
        snprintf(file, sizeof file, "%s%s", path, suffixes[i]);
        unlink(file);
    }
    ck_assert_int_eq(rmdir(dir), 0);
    for (int i = 0; i < N; i++)
        phks_signature_free(all[i]);
    free(all);
    free(entries);
    free(names);
    phks_signature_free(sh.far);
    for (int i = 0; i < MESHES; i++) {
        free(sh.want_blob[i].p);
        phks_signature_free(sh.queries[i]);
        phks_mesh_free(sh.meshes[i]);
    }
}
END_TEST

/* ---- the library's worker team (parallel.c) */

#define TEAM_N 1000
#define TEAM_THREADS 4

typedef struct {
    int visits[TEAM_N];
    size_t run[TEAM_N]; /* run[begin] = its length */
    int nested[TEAM_N];
} team_log;

static void nested_range(void *ctx, size_t begin, size_t end)
{
    team_log *log = ctx;
    for (size_t i = begin; i < end; i++)
        log->nested[i]++;
}

/* Records its run; the first run also runs a loop of its own. */
static void logged_range(void *ctx, size_t begin, size_t end)
{
    team_log *log = ctx;
    for (size_t i = begin; i < end; i++)
        log->visits[i]++;
    log->run[begin] = end - begin;
    if (begin == 0)
        phks__parallel_for(TEAM_N, TEAM_THREADS, nested_range, log);
}

/* With a team entered, every loop covers each index exactly once, in runs
 * shorter than a thread's share (taken as threads come free), a loop run
 * from inside a run (the team busy) completes, and a second enter on the
 * same thread gives no team. */
START_TEST(team_loops_cover_each_index_once)
{
    phks__team *team = phks__team_enter(TEAM_THREADS);
    ck_assert_ptr_nonnull(team);
    ck_assert_ptr_null(phks__team_enter(TEAM_THREADS));
    for (int round = 0; round < 50; round++) {
        static team_log log;
        memset(&log, 0, sizeof log);
        phks__parallel_for(TEAM_N, TEAM_THREADS, logged_range, &log);
        for (size_t i = 0; i < TEAM_N; i++) {
            ck_assert_int_eq(log.visits[i], 1);
            ck_assert_int_eq(log.nested[i], 1);
        }
        size_t covered = 0, runs = 0;
        for (size_t i = 0; i < TEAM_N; i++)
            if (log.run[i]) {
                ck_assert_uint_lt(log.run[i], TEAM_N / TEAM_THREADS);
                covered += log.run[i];
                runs++;
            }
        ck_assert_uint_eq(covered, TEAM_N);
        ck_assert_uint_gt(runs, TEAM_THREADS);
        /* fewer chunks than workers, and a loop of one */
        memset(&log, 0, sizeof log);
        phks__parallel_for(2, TEAM_THREADS, nested_range, &log);
        phks__parallel_for(1, TEAM_THREADS, nested_range, &log);
        ck_assert_int_eq(log.nested[0], 2);
        ck_assert_int_eq(log.nested[1], 1);
    }
    phks__team_leave(team);
    /* and a new team after the first has left */
    team = phks__team_enter(2);
    ck_assert_ptr_nonnull(team);
    phks__team_leave(team);
    phks__team_leave(NULL);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("threads");
    TCase *c = tcase_create("threads");
    tcase_set_timeout(c, 600);
    tcase_add_test(c, eight_threads_agree_with_one);
    tcase_add_test(c, team_loops_cover_each_index_once);
    suite_add_tcase(s, c);
    return run_suite(s);
}
