/*
 * progress.c - progress reports and cancellation: the signature of a mesh
 * file, printing each stage as it starts, cancelled after a time limit or
 * when the user presses Ctrl-C.
 *
 *   progress MESH [SECONDS]     (SECONDS defaults to 60; 0 cancels at once)
 *
 * Exit status: 0 done, 1 failed, 2 usage, 124 time limit reached,
 * 130 interrupted (SIGINT).
 *
 * The library calls options.progress from the computing thread, several
 * times a second, with the stage and the fraction of it done. Returning
 * non-zero cancels: the call then returns PHKS_ERROR_CANCELLED promptly,
 * having freed everything it made.
 */
#include <phks.h>

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

/* Set by the SIGINT handler; a signal handler may only write such a flag. */
static volatile sig_atomic_t interrupted = 0;

static void on_sigint(int sig)
{
    (void)sig;
    interrupted = 1;
}

/* What the callback needs, passed through options.progress_user. */
typedef struct progress_state {
    double deadline;   /* seconds, on the clock of now()            */
    int last_stage;    /* the stage printed last, -1 before any     */
    int timed_out;     /* set when the callback cancels for time    */
} progress_state;

static double now(void)
{
    struct timespec ts;
    timespec_get(&ts, TIME_UTC); /* C11 */
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static const char *stage_name(phks_stage stage)
{
    switch (stage) {
    case PHKS_STAGE_OPERATOR: return "operator (mesh-Laplacian)";
    case PHKS_STAGE_EIGEN: return "eigen (smallest eigenpairs)";
    case PHKS_STAGE_HKS: return "hks (heat kernel signature)";
    case PHKS_STAGE_PERSISTENCE: return "persistence (feature points)";
    default: return "unknown stage";
    }
}

/* The progress callback: 0 to go on, non-zero to cancel. Keep it cheap. */
static int on_progress(void *user, phks_stage stage, double fraction)
{
    progress_state *state = user;
    (void)fraction; /* 0..1 within the stage: a progress bar would use it */
    if ((int)stage != state->last_stage) {
        printf("stage %s\n", stage_name(stage));
        fflush(stdout);
        state->last_stage = (int)stage;
    }
    if (!interrupted && now() >= state->deadline)
        state->timed_out = 1;
    return interrupted || state->timed_out;
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: progress MESH [SECONDS]\n");
        return 2;
    }
    double limit = argc == 3 ? atof(argv[2]) : 60.0;
    signal(SIGINT, on_sigint);

    phks_mesh *mesh = NULL;
    phks_status status = phks_mesh_load(argv[1], &mesh);
    if (status != PHKS_OK) {
        fprintf(stderr, "progress: %s: %s (%s)\n", argv[1],
                phks_status_string(status), phks_last_error_message());
        return 1;
    }

    /* Start from the defaults, then set the callback and its data. */
    progress_state state = {now() + limit, -1, 0};
    phks_options options;
    status = phks_options_init(&options);
    if (status != PHKS_OK) {
        fprintf(stderr, "progress: options: %s\n", phks_last_error_message());
        phks_mesh_free(mesh);
        return 1;
    }
    options.progress = on_progress;
    options.progress_user = &state;

    phks_signature *sig = NULL;
    double start = now();
    status = phks_signature_compute(mesh, &options, &sig);
    phks_mesh_free(mesh);

    int rc = 0;
    if (status == PHKS_OK) {
        printf("done in %.2f s: %zu features\n", now() - start,
               phks_signature_feature_count(sig));
    } else if (status == PHKS_ERROR_CANCELLED) {
        printf("cancelled after %.2f s (%s)\n", now() - start,
               state.timed_out ? "time limit" : "interrupted");
        rc = state.timed_out ? 124 : 130;
    } else {
        fprintf(stderr, "progress: %s: %s (%s)\n", argv[1],
                phks_status_string(status), phks_last_error_message());
        rc = 1;
    }
    phks_signature_free(sig); /* NULL after a failure: does nothing */
    return rc;
}
