/*
 * cli_pool.c - a pool of worker threads over an index range, and output from
 * several threads that keeps a progress bar on stderr intact.
 */
#include "cli.h"

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
    size_t done, total;
    const char *unit;
} bar;

static void bar_draw(void)
{
    if (!bar.on)
        return;
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
    if (bar.on)
        fputs("\r\033[K", stderr);
}

void cli_progress_start(size_t total, const char *unit)
{
    pthread_mutex_lock(&out_lock);
    bar.on = isatty(STDERR_FILENO) && total > 0;
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
    if (bar.on)
        fputc('\n', stderr);
    bar.on = 0;
    pthread_mutex_unlock(&out_lock);
}

static void say_locked(FILE *out, const char *format, va_list ap)
{
    bar_clear();
    vfprintf(out, format, ap);
    fflush(out);
    bar_draw();
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
