/*
 * call.c - the one way the module makes a library call that may take long:
 * options with the progress trampoline in them, the GIL released around
 * the call, the caller's progress callback run under the GIL, and what
 * cancelled the call (an exception the callback raised, Ctrl-C) raised in
 * place of PHKS_ERROR_CANCELLED.
 */
#include "phks_python.h"

/* ---------------------------------------------------------------------
 * Progress, cancellation and Ctrl-C
 * ---------------------------------------------------------------------
 * Long calls run without the GIL and are given progress_trampoline as the
 * library's callback whether or not the caller passed progress=, so that
 * Ctrl-C (a pending SIGINT seen by PyErr_CheckSignals) cancels them. The
 * library calls back on the calling thread, which gave up the GIL: the
 * trampoline takes it back with PyGILState_Ensure for the Python work. */
typedef struct progress_ctx {
    PyObject *callable; /* the caller's progress(stage, fraction), or NULL */
    int stopped;        /* cancelled: Python is not called again           */
    PyObject *exc_type, *exc_value, *exc_tb; /* what cancelled, if raised  */
} progress_ctx;

static int progress_trampoline(void *user, phks_stage stage, double fraction)
{
    progress_ctx *ctx = user;
    if (ctx->stopped)
        return 1;
    PyGILState_STATE gil = PyGILState_Ensure();
    int cancel = 0;
    if (PyErr_CheckSignals() < 0) {
        cancel = 1;
    } else if (ctx->callable) {
        PyObject *stage_obj = stage_member(stage);
        PyObject *result = NULL;
        if (stage_obj)
            result = PyObject_CallFunction(ctx->callable, "Od", stage_obj,
                                           fraction);
        Py_XDECREF(stage_obj);
        if (!result) {
            cancel = 1;
        } else {
            /* None (no return statement) continues; False or another false
             * value cancels. */
            if (result != Py_None) {
                int truth = PyObject_IsTrue(result);
                if (truth <= 0)
                    cancel = 1;
            }
            Py_DECREF(result);
        }
    }
    if (cancel) {
        ctx->stopped = 1;
        /* Kept until the call returns, then raised in place of
         * PHKS_ERROR_CANCELLED: a KeyboardInterrupt stays one. */
        if (PyErr_Occurred())
            PyErr_Fetch(&ctx->exc_type, &ctx->exc_value, &ctx->exc_tb);
    }
    PyGILState_Release(gil);
    return cancel;
}

/* After the call, with the GIL: raises what cancelled it, or phks.Error for
 * a failure; 0 on success. Releases the context's references. */
static int progress_finish(progress_ctx *ctx, phks_status status)
{
    Py_CLEAR(ctx->callable);
    if (ctx->exc_type) {
        PyErr_Restore(ctx->exc_type, ctx->exc_value, ctx->exc_tb);
        ctx->exc_type = ctx->exc_value = ctx->exc_tb = NULL;
        return -1;
    }
    if (status != PHKS_OK) {
        raise_status(status);
        return -1;
    }
    return 0;
}

int run_long_call(phks_options options, PyObject *progress, long_call call,
                  void *args)
{
    progress_ctx ctx = {.callable = progress};
    options.progress = progress_trampoline;
    options.progress_user = &ctx;
    phks_status st;
    Py_BEGIN_ALLOW_THREADS
    st = call(&options, args);
    Py_END_ALLOW_THREADS
    return progress_finish(&ctx, st);
}

int run_long_call_with_kwargs(PyObject *kwargs, phks_options *options,
                              long_call call, void *args)
{
    PyObject *progress;
    if (parse_options(kwargs, options, &progress) < 0)
        return -1;
    return run_long_call(*options, progress, call, args);
}
