/*
 * bench_stages.c - time of every stage of the pipeline, and peak memory,
 * per mesh. Stage boundaries come from the progress callback, so this
 * measures exactly what an application sees through the public API.
 *
 *   bench-stages [--solver auto|lanczos|arpack|dense] [--cutoff C]
 *                [--tolerance T] [--threads N] [--simplify-above N] [--simplify-target N]
 *                [--decimate N] [--trace S] [--cancel-at T1,T2,...] MESH...
 *
 * Each mesh runs in its own child process so that the peak resident
 * memory it reports (getrusage at its end) is its own. "gap" is the
 * longest time between two progress reports (the call and the return
 * count as reports, so a silent start or end shows): how long a cancellation
 * may wait. --trace S also lists every gap longer than S seconds with the
 * reports around it (stage and fraction), to find the silent code. The
 * "cpu" columns are the processor time (user + system, all threads, the
 * BLAS's included) of the operator and eigen stages and of the whole
 * computation: on a shared machine they vary far less than wall times.
 *
 * --cancel-at T1,T2,... measures cancellation instead: for each T, a
 * child runs the signature again and asks to cancel T seconds after the
 * call began (the callback returns non-zero from its first report at or
 * after T), and prints the stage that honoured it and the latency from
 * the request to the return of phks_signature_compute. T may also be
 * STAGE+S (operator, eigen, hks or persist): S seconds after that stage's
 * first report. The worst latency over all T is about the longest gap
 * plus the time to free everything.
 *
 * --decimate N first reduces each mesh to about N vertices by quadric
 * decimation (meshoptimizer's meshopt_simplify; only when the benchmark
 * was built with it): a way to time sizes that no file in ../shared has,
 * such as 500k vertices from the 1.6M-vertex armadillo. The decimation is
 * not timed; the peak memory is then the high-water mark from after it
 * (reset through /proc/self/clear_refs; marked * where that fails, when
 * it includes the decimation of the larger mesh).
 */
#include "phks.h"

#ifdef HAVE_MESHOPTIMIZER
#include <meshoptimizer.h>
#endif

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

#define MAX_TRACE 64

/* One silent stretch: from a report (stage, fraction) to the next. */
typedef struct {
    double seconds;
    int from_stage, to_stage; /* -1: the call, -2: the return */
    double from_fraction, to_fraction;
} silence;

/* Processor time of the whole process (every thread), in seconds. */
static double cpu_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

typedef struct {
    double start[PHKS_STAGE_COUNT], end[PHKS_STAGE_COUNT];
    double cpu_start[PHKS_STAGE_COUNT];
    double last, gap; /* the longest time between two reports: how long a
                         cancellation can wait */
    int last_stage;
    double last_fraction;
    double trace;     /* record silences longer than this (0: none)     */
    silence silences[MAX_TRACE];
    int silence_count;
    double cancel_at; /* cancel from the first report at or after this
                         time (0: never)                                 */
    int cancel_stage; /* or, when >= 0, cancel_delay seconds after the
                         first report of this stage                      */
    double cancel_delay;
    int cancelled_in; /* stage that returned non-zero, or -1            */
} stage_times;

static void note_gap(stage_times *t, double x, int stage, double fraction)
{
    if (t->last > 0) {
        double g = x - t->last;
        if (g > t->gap)
            t->gap = g;
        if (t->trace > 0 && g > t->trace && t->silence_count < MAX_TRACE)
            t->silences[t->silence_count++] =
                (silence){g, t->last_stage, stage, t->last_fraction, fraction};
    }
    t->last = x;
    t->last_stage = stage;
    t->last_fraction = fraction;
}

static int on_progress(void *user, phks_stage stage, double fraction)
{
    stage_times *t = user;
    double x = now();
    if (t->start[stage] == 0) {
        t->start[stage] = x;
        t->cpu_start[stage] = cpu_now();
    }
    t->end[stage] = x;
    note_gap(t, x, (int)stage, fraction);
    if (t->cancel_stage >= 0 && t->start[t->cancel_stage] > 0 && t->cancel_at == 0)
        t->cancel_at = t->start[t->cancel_stage] + t->cancel_delay;
    if (t->cancel_at > 0 && x >= t->cancel_at) {
        t->cancelled_in = (int)stage;
        return 1;
    }
    return 0;
}

static const char *const stage_names[] = {"operator", "eigen", "hks", "persist"};

static const char *stage_name(int stage)
{
    const char *const *names = stage_names;
    return stage >= 0 && stage < PHKS_STAGE_COUNT ? names[stage]
           : stage == -1                          ? "call"
                                                  : "return";
}

/* The quadric decimation of mesh to about `target` vertices (NULL when
 * meshoptimizer is missing or fails). */
static phks_mesh *decimate(const phks_mesh *mesh, size_t target)
{
#ifdef HAVE_MESHOPTIMIZER
    size_t n = phks_mesh_vertex_count(mesh), nt = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    float *pos = malloc(3 * n * sizeof *pos);
    unsigned *out = malloc(3 * nt * sizeof *out);
    phks_mesh *dec = NULL;
    if (pos && out) {
        for (size_t i = 0; i < 3 * n; i++)
            pos[i] = (float)xyz[i];
        /* About two triangles per vertex; no error bound. */
        size_t got = meshopt_simplify(out, tri, 3 * nt, pos, n, 3 * sizeof(float),
                                      6 * target, 1.0f, 0, NULL);
        phks_mesh_create(xyz, n, out, got / 3, &dec);
    }
    free(pos);
    free(out);
    return dec;
#else
    (void)mesh;
    (void)target;
    fprintf(stderr, "bench-stages: built without meshoptimizer, no --decimate\n");
    return NULL;
#endif
}

/* Resets the peak resident memory (Linux); false where it cannot. */
static bool reset_peak(void)
{
    FILE *f = fopen("/proc/self/clear_refs", "w");
    if (!f)
        return false;
    bool ok = fputs("5", f) >= 0;
    return fclose(f) == 0 && ok;
}

/* Peak resident memory in MB: VmHWM, or getrusage's maximum. */
static double peak_mb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    while (f && fgets(line, sizeof line, f))
        if (strncmp(line, "VmHWM:", 6) == 0) {
            fclose(f);
            return atof(line + 6) / 1024;
        }
    if (f)
        fclose(f);
    struct rusage use;
    getrusage(RUSAGE_SELF, &use);
    return (double)use.ru_maxrss / 1024;
}

/* When to cancel: after seconds from the call (stage -1) or from the
 * first report of a stage; seconds 0: never. */
typedef struct {
    int stage;
    double seconds;
} cancel_request;

/* Child: prints one table row (or, with a cancellation, one line on it)
 * and exits. */
static int run(const char *path, const phks_options *base, size_t decimate_to,
               double trace, cancel_request cancel)
{
    phks_options opt = *base;
    stage_times t;
    memset(&t, 0, sizeof t);
    t.last_stage = -1;
    t.trace = trace;
    t.cancelled_in = -1;
    t.cancel_stage = -1;
    opt.progress = on_progress;
    opt.progress_user = &t;
    double t0 = now();
    phks_mesh *mesh;
    phks_status st = phks_mesh_load(path, &mesh);
    double t1 = now(), c1 = cpu_now();
    bool clean_peak = true;
    double load = t1 - t0;
    if (st == PHKS_OK && decimate_to) {
        phks_mesh *dec = decimate(mesh, decimate_to);
        phks_mesh_free(mesh);
        if (!dec) {
            printf("%-34s decimation failed\n", path);
            return 1;
        }
        mesh = dec;
        clean_peak = reset_peak();
        t1 = now();
    }
    const char *name = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    phks_signature *sig = NULL;
    if (st == PHKS_OK) {
        t1 = t.last = now();
        c1 = cpu_now();
        if (cancel.seconds > 0 && cancel.stage < 0)
            t.cancel_at = t1 + cancel.seconds;
        else if (cancel.seconds > 0) {
            t.cancel_stage = cancel.stage;
            t.cancel_delay = cancel.seconds;
        }
        st = phks_signature_compute(mesh, &opt, &sig);
    }
    double t2 = now(), c2 = cpu_now();
    if (cancel.seconds > 0) {
        char when[32];
        snprintf(when, sizeof when, "%s%s%.2f",
                 cancel.stage < 0 ? "" : stage_name(cancel.stage),
                 cancel.stage < 0 ? "" : "+", cancel.seconds);
        if (st == PHKS_ERROR_CANCELLED)
            printf("%-28s %8zu %14s %9s %9.3f\n", name,
                   phks_mesh_vertex_count(mesh), when,
                   stage_name(t.cancelled_in), t2 - t.cancel_at);
        else
            printf("%-28s %8zu %14s %9s (done after %.2f s: %s)\n", name,
                   phks_mesh_vertex_count(mesh), when, "-", t2 - t1,
                   phks_status_string(st));
        fflush(stdout);
        phks_signature_free(sig);
        phks_mesh_free(mesh);
        return st == PHKS_ERROR_CANCELLED || st == PHKS_OK ? 0 : 1;
    }
    if (st != PHKS_OK) {
        printf("%-34s error: %s\n", path, phks_last_error_message());
        return 1;
    }
    note_gap(&t, t2, -2, 1);
    printf("%-28s %8zu %7.2f", name, phks_mesh_vertex_count(mesh), load);
    /* A stage lasts from its first report to the next stage's first. */
    for (int s = 0; s < PHKS_STAGE_COUNT; s++) {
        double end = s + 1 < PHKS_STAGE_COUNT ? t.start[s + 1] : t2;
        printf(" %8.3f", end - t.start[s]);
    }
    printf(" %8.3f %6.2f %8.0f%s", t2 - t1, t.gap, peak_mb(),
           clean_peak ? "" : "*");
    /* processor time of the operator and eigen stages, and in all */
    printf(" %7.3f %7.3f %7.3f\n",
           t.cpu_start[PHKS_STAGE_EIGEN] - t.cpu_start[PHKS_STAGE_OPERATOR],
           t.cpu_start[PHKS_STAGE_HKS] - t.cpu_start[PHKS_STAGE_EIGEN], c2 - c1);
    for (int i = 0; i < t.silence_count; i++) {
        const silence *g = &t.silences[i];
        printf("    silent %6.2f s from %s %.4f to %s %.4f\n", g->seconds,
               stage_name(g->from_stage), g->from_fraction,
               stage_name(g->to_stage), g->to_fraction);
    }
    fflush(stdout);
    phks_signature_free(sig);
    phks_mesh_free(mesh);
    return 0;
}

int main(int argc, char **argv)
{
    phks_options opt;
    phks_options_init(&opt);
    int first = 1;
    size_t decimate_to = 0;
    double trace = 0;
    const char *cancel_list = NULL;
    for (; first + 1 < argc && argv[first][0] == '-'; first += 2) {
        const char *v = argv[first + 1];
        if (strcmp(argv[first], "--solver") == 0)
            opt.solver = strcmp(v, "lanczos") == 0  ? PHKS_SOLVER_LANCZOS
                         : strcmp(v, "arpack") == 0 ? PHKS_SOLVER_ARPACK
                         : strcmp(v, "dense") == 0  ? PHKS_SOLVER_DENSE
                                                    : PHKS_SOLVER_AUTO;
        else if (strcmp(argv[first], "--cutoff") == 0)
            opt.cutoff = atof(v);
        else if (strcmp(argv[first], "--tolerance") == 0)
            opt.tolerance = atof(v);
        else if (strcmp(argv[first], "--threads") == 0)
            opt.threads = (uint32_t)strtoul(v, NULL, 10);
        else if (strcmp(argv[first], "--simplify-above") == 0)
            opt.simplify_above = (uint32_t)strtoul(v, NULL, 10);
        else if (strcmp(argv[first], "--simplify-target") == 0)
            opt.simplify_target = (uint32_t)strtoul(v, NULL, 10);
        else if (strcmp(argv[first], "--decimate") == 0)
            decimate_to = (size_t)strtoul(v, NULL, 10);
        else if (strcmp(argv[first], "--trace") == 0)
            trace = atof(v);
        else if (strcmp(argv[first], "--cancel-at") == 0)
            cancel_list = v;
    }
    if (first >= argc) {
        fprintf(stderr, "usage: bench-stages [--solver S] [--cutoff C] "
                        "[--tolerance T] [--threads N] [--simplify-above N] [--simplify-target N] "
                        "[--decimate N] [--trace S] [--cancel-at T1,T2,...] "
                        "MESH...\n");
        return 2;
    }
    printf("libphks %s, cutoff %.2f, HKS-simp above %u vertices (target %u), "
           "times in seconds\n",
           phks_version_string(), opt.cutoff, opt.simplify_above,
           opt.simplify_target);
    /* The cancellation requests, or one of 0 s (no cancellation). */
    cancel_request cancel_at[64] = {{-1, 0}};
    int cancel_count = 1;
    if (cancel_list) {
        cancel_count = 0;
        for (const char *c = cancel_list; *c && cancel_count < 64;) {
            cancel_request r = {-1, 0};
            for (int s = 0; s < PHKS_STAGE_COUNT; s++) {
                size_t len = strlen(stage_names[s]);
                if (strncmp(c, stage_names[s], len) == 0 && c[len] == '+') {
                    r.stage = s;
                    c += len + 1;
                }
            }
            char *end;
            r.seconds = strtod(c, &end);
            if (end == c || !(r.seconds > 0)) {
                fprintf(stderr, "bench-stages: --cancel-at wants positive "
                                "seconds (T or STAGE+T) separated by commas\n");
                return 2;
            }
            cancel_at[cancel_count++] = r;
            c = *end == ',' ? end + 1 : end;
        }
        printf("%-28s %8s %14s %9s %9s\n", "mesh", "vertices", "cancel at",
               "stage", "latency");
    } else {
        printf("%-28s %8s %7s %8s %8s %8s %8s %8s %6s %8s %7s %7s %7s\n",
               "mesh", "vertices", "load", "operator", "eigen", "hks",
               "persist", "total", "gap", "peak MB", "op cpu", "eig cpu",
               "cpu");
    }
    int failures = 0;
    for (int i = first; i < argc; i++)
        for (int c = 0; c < cancel_count; c++) {
            fflush(stdout);
            pid_t pid = fork();
            if (pid == 0)
                _exit(run(argv[i], &opt, decimate_to, trace, cancel_at[c]));
            int status = 0;
            if (pid < 0 || waitpid(pid, &status, 0) < 0) {
                perror("bench-stages");
                return 1;
            }
            failures += !WIFEXITED(status) || WEXITSTATUS(status) != 0;
        }
    return failures ? 1 : 0;
}
