/*
 * bench_stages.c - time of every stage of the pipeline, and peak memory,
 * per mesh. Stage boundaries come from the progress callback, so this
 * measures exactly what an application sees through the public API.
 *
 *   bench-stages [--solver auto|lanczos|arpack|dense] [--cutoff C] MESH...
 *
 * Each mesh runs in its own child process so that the peak resident
 * memory it reports (getrusage at its end) is its own.
 */
#include "phks.h"

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

typedef struct {
    double start[PHKS_STAGE_COUNT], end[PHKS_STAGE_COUNT];
} stage_times;

static int on_progress(void *user, phks_stage stage, double fraction)
{
    stage_times *t = user;
    double x = now();
    if (t->start[stage] == 0)
        t->start[stage] = x;
    t->end[stage] = x;
    (void)fraction;
    return 0;
}

/* Child: prints one table row and exits. */
static int run(const char *path, const phks_options *base)
{
    phks_options opt = *base;
    stage_times t = {{0}, {0}};
    opt.progress = on_progress;
    opt.progress_user = &t;
    double t0 = now();
    phks_mesh *mesh;
    phks_status st = phks_mesh_load(path, &mesh);
    double t1 = now();
    phks_signature *sig = NULL;
    if (st == PHKS_OK)
        st = phks_signature_compute(mesh, &opt, &sig);
    double t2 = now();
    if (st != PHKS_OK) {
        printf("%-34s error: %s\n", path, phks_last_error_message());
        return 1;
    }
    const char *name = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    printf("%-28s %8zu %7.2f", name, phks_mesh_vertex_count(mesh), t1 - t0);
    /* A stage lasts from its first report to the next stage's first. */
    for (int s = 0; s < PHKS_STAGE_COUNT; s++) {
        double end = s + 1 < PHKS_STAGE_COUNT ? t.start[s + 1] : t2;
        printf(" %8.3f", end - t.start[s]);
    }
    struct rusage use;
    getrusage(RUSAGE_SELF, &use);
    printf(" %8.3f %8.0f\n", t2 - t1, (double)use.ru_maxrss / 1024);
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
    for (; first + 1 < argc && argv[first][0] == '-'; first += 2) {
        const char *v = argv[first + 1];
        if (strcmp(argv[first], "--solver") == 0)
            opt.solver = strcmp(v, "lanczos") == 0  ? PHKS_SOLVER_LANCZOS
                         : strcmp(v, "arpack") == 0 ? PHKS_SOLVER_ARPACK
                         : strcmp(v, "dense") == 0  ? PHKS_SOLVER_DENSE
                                                    : PHKS_SOLVER_AUTO;
        else if (strcmp(argv[first], "--cutoff") == 0)
            opt.cutoff = atof(v);
    }
    if (first >= argc) {
        fprintf(stderr, "usage: bench-stages [--solver S] [--cutoff C] MESH...\n");
        return 2;
    }
    printf("libphks %s, cutoff %.2f, times in seconds\n", phks_version_string(),
           opt.cutoff);
    printf("%-28s %8s %7s %8s %8s %8s %8s %8s %8s\n", "mesh", "vertices", "load",
           "operator", "eigen", "hks", "persist", "total", "peak MB");
    int failures = 0;
    for (int i = first; i < argc; i++) {
        fflush(stdout);
        pid_t pid = fork();
        if (pid == 0)
            _exit(run(argv[i], &opt));
        int status = 0;
        if (pid < 0 || waitpid(pid, &status, 0) < 0) {
            perror("bench-stages");
            return 1;
        }
        failures += !WIFEXITED(status) || WEXITSTATUS(status) != 0;
    }
    return failures ? 1 : 0;
}
