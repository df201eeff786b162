/*
 * cli_pool.c - a pool of worker threads over an index range, and output from
 * several threads that keeps a progress bar on stderr intact.
 */
#include "common/cli_common.h"

#include <dlfcn.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define BAR_WIDTH 30

typedef struct pool {
    pthread_mutex_t lock;
    size_t next, count;
    cli_task_fn task;
    void *ctx;
} pool;

static void *work(void *arg)
{
    pool *p = arg;
    for (;;) {
        pthread_mutex_lock(&p->lock);
        size_t i = p->next < p->count ? p->next++ : p->count;
        pthread_mutex_unlock(&p->lock);
        if (i == p->count)
            return NULL;
        p->task(p->ctx, i);
    }
}

void cli_pool_run(size_t count, unsigned workers, cli_task_fn task, void *ctx)
{
    pool p = {PTHREAD_MUTEX_INITIALIZER, 0, count, task, ctx};
    if (workers > count)
        workers = (unsigned)count;
    pthread_t *ids = workers > 1 ? calloc(workers, sizeof *ids) : NULL;
    unsigned started = 0;
    /* The calling thread works too; threads that cannot start cost speed. */
    for (unsigned t = 1; ids && t < workers; t++)
        if (pthread_create(&ids[started], NULL, work, &p) == 0)
            started++;
    work(&p);
    for (unsigned t = 0; t < started; t++)
        pthread_join(ids[t], NULL);
    free(ids);
}

void cli_blas_one_thread(void)
{
    if (getenv("OPENBLAS_NUM_THREADS") || getenv("OMP_NUM_THREADS"))
        return;
    void *self = dlopen(NULL, RTLD_NOW);
    void *sym = self ? dlsym(self, "openblas_set_num_threads") : NULL;
    if (sym) {
        void (*set_threads)(int);
        memcpy(&set_threads, &sym, sizeof set_threads);
        set_threads(1);
    }
    if (self)
        dlclose(self);
}

/* ---- output --------------------------------------------------------------- */
static pthread_mutex_t out_lock = PTHREAD_MUTEX_INITIALIZER;
static struct {
    int on;          /* a bar is being drawn         */
    int tty;         /* ... in place; else as lines  */
    size_t done, total;
    const char *unit;
} bar;

static void bar_draw(void)
{
    if (!bar.on)
        return;
    if (!bar.tty) {
        fprintf(stderr, "phks: %zu/%zu %s\n", bar.done, bar.total, bar.unit);
        fflush(stderr);
        return;
    }
    size_t fill = bar.total ? bar.done * BAR_WIDTH / bar.total : BAR_WIDTH;
    char cells[BAR_WIDTH + 1];
    for (size_t i = 0; i < BAR_WIDTH; i++)
        cells[i] = i < fill ? '=' : i == fill ? '>' : ' ';
    cells[BAR_WIDTH] = '\0';
    fprintf(stderr, "\r[%s] %zu/%zu %s", cells, bar.done, bar.total, bar.unit);
    fflush(stderr);
}

static void bar_clear(void)
{
    if (bar.on && bar.tty)
        fputs("\r\033[K", stderr);
}

void cli_progress_start(size_t total, const char *unit)
{
    pthread_mutex_lock(&out_lock);
    bar.on = cli_progress_enabled() && total > 0;
    bar.tty = isatty(STDERR_FILENO);
    bar.done = 0;
    bar.total = total;
    bar.unit = unit;
    bar_draw();
    pthread_mutex_unlock(&out_lock);
}

void cli_progress_step(void)
{
    pthread_mutex_lock(&out_lock);
    bar.done++;
    bar_draw();
    pthread_mutex_unlock(&out_lock);
}

void cli_progress_end(void)
{
    pthread_mutex_lock(&out_lock);
    if (bar.on && bar.tty)
        fputc('\n', stderr);
    bar.on = 0;
    pthread_mutex_unlock(&out_lock);
}

static void say_locked(FILE *out, const char *format, va_list ap)
{
    bar_clear();
    vfprintf(out, format, ap);
    fflush(out);
    if (bar.tty)
        bar_draw();
}

int cli_progress_enabled(void)
{
    return cli_progress_mode >= 0 ? cli_progress_mode
                                  : isatty(STDERR_FILENO);
}

/* ---- stages of one computation --------------------------------------------- */
static const char *const stage_names[PHKS_STAGE_COUNT] = {
    "building the operator", "eigen-decomposition", "heat kernel signature",
    "feature points"};

static void stage_report(cli_stages *s, const char *name, int percent)
{
    pthread_mutex_lock(&out_lock);
    if (isatty(STDERR_FILENO))
        fprintf(stderr, "\rphks: %s: %s %d%%\033[K", s->what, name, percent);
    else
        fprintf(stderr, "phks: %s: %s\n", s->what, name);
    fflush(stderr);
    pthread_mutex_unlock(&out_lock);
}

static int on_stage(void *user, phks_stage stage, double fraction)
{
    cli_stages *s = user;
    int percent = (int)(fraction * 100);
    percent = percent < 0 ? 0 : percent > 100 ? 100 : percent;
    int changed = (int)stage != s->stage;
    if ((unsigned)stage >= PHKS_STAGE_COUNT)
        return 0;
    /* Lines only when the stage changes; the terminal's line per percent. */
    if (changed || (percent != s->percent && isatty(STDERR_FILENO)))
        stage_report(s, stage_names[stage], percent);
    s->stage = (int)stage;
    s->percent = percent;
    return 0;
}

void cli_stages_attach(cli_stages *s, const char *what, phks_options *o)
{
    s->what = what;
    s->stage = -1;
    s->percent = -1;
    s->on = cli_progress_enabled();
    if (s->on) {
        o->progress = on_stage;
        o->progress_user = s;
    }
}

void cli_stages_note(cli_stages *s, const char *stage)
{
    if (s->on) {
        s->stage = PHKS_STAGE_COUNT;
        stage_report(s, stage, 0);
    }
}

void cli_stages_end(cli_stages *s)
{
    if (!s->on)
        return;
    pthread_mutex_lock(&out_lock);
    fprintf(stderr, "%sphks: %s: done%s\n", isatty(STDERR_FILENO) ? "\r" : "",
            s->what, isatty(STDERR_FILENO) ? "\033[K" : "");
    fflush(stderr);
    pthread_mutex_unlock(&out_lock);
    s->on = 0;
}

void cli_say(FILE *out, const char *format, ...)
{
    va_list ap;
    va_start(ap, format);
    pthread_mutex_lock(&out_lock);
    say_locked(out, format, ap);
    pthread_mutex_unlock(&out_lock);
    va_end(ap);
}

void cli_say_fail(const char *what, phks_status status)
{
    /* The message is per thread: read here, before taking the lock. */
    cli_say(stderr, "phks: %s: %s\n", what, cli_reason(what, status));
}
