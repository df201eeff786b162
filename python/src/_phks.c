/*
 * _phks.c - phks._phks, the CPython extension module under the phks
 * package: libphks's public API (include/phks.h, nothing else) with numpy
 * arrays in and out. docs/python.md is the tour; phks/__init__.py re-exports
 * everything here.
 *
 * Ownership rules kept throughout:
 * - every Python object wraps exactly one phks handle and frees it in its
 *   dealloc; a handle is never shared between two Python objects;
 * - every error path frees what it made (handles, PyObjects, PyMem buffers)
 *   before returning NULL;
 * - the GIL is released around every call that may take long; the objects
 *   such a call reads are kept alive by the caller's argument references,
 *   and a Database counts its running calls so that close() cannot free the
 *   handle under them.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>

#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "phks.h"
/* The assimp adapter the tool also links (tools/assimp). */
#include "assimp_reader.h"

/* ---------------------------------------------------------------------
 * Errors and enumerations
 * --------------------------------------------------------------------- */

static PyObject *Error;      /* phks.Error, a RuntimeError               */
static PyObject *StatusEnum; /* phks.Status, an IntEnum of phks_status   */
static PyObject *StageEnum;  /* phks.Stage, an IntEnum of phks_stage     */

/* Indexed by the enum values, which phks.h freezes. */
static const char *const status_names[] = {
    "OK", "INVALID_ARGUMENT", "OUT_OF_MEMORY", "IO", "UNKNOWN_FORMAT",
    "PARSE", "TRUNCATED", "NON_FINITE", "INDEX_OUT_OF_RANGE", "NO_TRIANGLES",
    "ZERO_AREA", "TOO_LARGE", "CANCELLED", "NO_CONVERGENCE", "INCOMPATIBLE",
    "CORRUPT", "UNSUPPORTED_VERSION", "BUFFER_TOO_SMALL", "SOLVER", NULL};
static const char *const stage_names[] = {"OPERATOR", "EIGEN", "HKS",
                                          "PERSISTENCE", NULL};

/* The option enums as keyword strings, indexed by value. */
static const char *const operator_names[] = {"literal", "random_walk", NULL};
static const char *const box_names[] = {"principal", "axis_aligned", NULL};
static const char *const solver_names[] = {"auto", "lanczos", "arpack",
                                           "dense", NULL};
static const char *const scaling_names[] = {"none", "mean", "local_area",
                                            NULL};
static const char *const quadrature_names[] = {"vertices", "triangles",
                                               NULL};
static const char *const matching_names[] = {"nearest", "verified", NULL};
static const char *const format_names[] = {"auto", "off", "obj", "ply", "stl",
                                           NULL};

/* enum.IntEnum(name, [(member, value), ...], module='phks'). */
static PyObject *make_int_enum(const char *name, const char *const *names)
{
    PyObject *enum_module = NULL, *int_enum = NULL, *members = NULL;
    PyObject *args = NULL, *kwargs = NULL, *result = NULL;
    Py_ssize_t n = 0;
    while (names[n])
        n++;
    enum_module = PyImport_ImportModule("enum");
    if (!enum_module)
        goto done;
    int_enum = PyObject_GetAttrString(enum_module, "IntEnum");
    if (!int_enum)
        goto done;
    members = PyList_New(n);
    if (!members)
        goto done;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *pair = Py_BuildValue("(sn)", names[i], i);
        if (!pair)
            goto done;
        PyList_SET_ITEM(members, i, pair);
    }
    args = Py_BuildValue("(sO)", name, members);
    kwargs = Py_BuildValue("{s:s}", "module", "phks");
    if (args && kwargs)
        result = PyObject_Call(int_enum, args, kwargs);
done:
    Py_XDECREF(enum_module);
    Py_XDECREF(int_enum);
    Py_XDECREF(members);
    Py_XDECREF(args);
    Py_XDECREF(kwargs);
    return result;
}

/* The enum member for value, or a plain int for a value this module does
 * not know (a newer library may append statuses and stages). */
static PyObject *enum_member(PyObject *enum_type, int value)
{
    PyObject *member = PyObject_CallFunction(enum_type, "i", value);
    if (!member && PyErr_ExceptionMatches(PyExc_ValueError)) {
        PyErr_Clear();
        member = PyLong_FromLong(value);
    }
    return member;
}

/* Raises phks.Error(status, detail): str() is "<status string>: <detail>",
 * .status the Status member, .message the detail alone. Always NULL. */
static PyObject *raise_status_detail(phks_status status, const char *detail)
{
    PyObject *status_obj = NULL, *message = NULL, *text = NULL, *exc = NULL;
    status_obj = enum_member(StatusEnum, (int)status);
    if (!status_obj)
        goto done;
    /* File names in the detail need not be UTF-8. */
    message = PyUnicode_DecodeUTF8(detail, (Py_ssize_t)strlen(detail),
                                   "replace");
    if (!message)
        goto done;
    if (detail[0])
        text = PyUnicode_FromFormat("%s: %U", phks_status_string(status),
                                    message);
    else
        text = PyUnicode_FromString(phks_status_string(status));
    if (!text)
        goto done;
    exc = PyObject_CallFunctionObjArgs(Error, text, NULL);
    if (!exc)
        goto done;
    if (PyObject_SetAttrString(exc, "status", status_obj) < 0 ||
        PyObject_SetAttrString(exc, "message", message) < 0)
        goto done;
    PyErr_SetObject(Error, exc);
done:
    Py_XDECREF(status_obj);
    Py_XDECREF(message);
    Py_XDECREF(text);
    Py_XDECREF(exc);
    return NULL;
}

/* Raises phks.Error for a status a library call just returned, with the
 * calling thread's message (valid until its next failing call, so this is
 * called before any other phks function). */
static PyObject *raise_status(phks_status status)
{
    return raise_status_detail(status, phks_last_error_message());
}

/* Raises phks.Error for a problem this module finds itself before calling
 * the library, where the library would report the same status. */
static PyObject *raise_status_format(phks_status status, const char *format,
                                     ...)
{
    char buffer[256];
    va_list ap;
    va_start(ap, format);
    PyOS_vsnprintf(buffer, sizeof buffer, format, ap);
    va_end(ap);
    return raise_status_detail(status, buffer);
}

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
        PyObject *stage_obj = enum_member(StageEnum, (int)stage);
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

/* ---------------------------------------------------------------------
 * Options as keyword arguments
 * --------------------------------------------------------------------- */
typedef enum field_kind { FIELD_U32, FIELD_DOUBLE, FIELD_ENUM } field_kind;

typedef struct option_field {
    const char *name; /* the phks_options field and the keyword */
    field_kind kind;
    size_t offset;
    const char *const *names; /* FIELD_ENUM: the strings, by value */
} option_field;

#define FIELD(name, kind, names) {#name, kind, offsetof(phks_options, name), names}
static const option_field option_fields[] = {
    FIELD(eigen_count, FIELD_U32, NULL),
    FIELD(tau, FIELD_DOUBLE, NULL),
    FIELD(cutoff, FIELD_DOUBLE, NULL),
    FIELD(feature_count, FIELD_U32, NULL),
    FIELD(scale_count, FIELD_U32, NULL),
    FIELD(feature_scale, FIELD_DOUBLE, NULL),
    FIELD(operator_kind, FIELD_ENUM, operator_names),
    FIELD(box, FIELD_ENUM, box_names),
    FIELD(solver, FIELD_ENUM, solver_names),
    FIELD(threads, FIELD_U32, NULL),
    FIELD(tolerance, FIELD_DOUBLE, NULL),
    FIELD(boundary_margin, FIELD_DOUBLE, NULL),
    FIELD(hks_scaling, FIELD_ENUM, scaling_names),
    FIELD(quadrature, FIELD_ENUM, quadrature_names),
    FIELD(simplify_above, FIELD_U32, NULL),
    FIELD(simplify_target, FIELD_U32, NULL),
    FIELD(matching, FIELD_ENUM, matching_names),
};
#undef FIELD
#define OPTION_FIELD_COUNT (sizeof option_fields / sizeof option_fields[0])

/* An enum given as one of names (exact) or as an int, into *out. The
 * library checks an int's range, and names the field when it refuses. */
static int parse_enum(PyObject *value, const char *what,
                      const char *const *names, int32_t *out)
{
    if (PyUnicode_Check(value)) {
        const char *s = PyUnicode_AsUTF8(value);
        if (!s)
            return -1;
        for (int32_t i = 0; names[i]; i++)
            if (strcmp(s, names[i]) == 0) {
                *out = i;
                return 0;
            }
        PyErr_Format(PyExc_ValueError, "%s: unknown value '%s'", what, s);
        return -1;
    }
    long v = PyLong_AsLong(value);
    if (v == -1 && PyErr_Occurred())
        return -1;
    if (v < INT32_MIN || v > INT32_MAX) {
        PyErr_Format(PyExc_ValueError, "%s: %ld out of range", what, v);
        return -1;
    }
    *out = (int32_t)v;
    return 0;
}

static int parse_u32(PyObject *value, const char *what, uint32_t *out)
{
    if (PyFloat_Check(value)) { /* 1.5 would silently become 1 */
        PyErr_Format(PyExc_TypeError, "%s must be an integer", what);
        return -1;
    }
    PyObject *index = PyNumber_Index(value);
    if (!index)
        return -1;
    int overflow = 0;
    long long v = PyLong_AsLongLongAndOverflow(index, &overflow);
    Py_DECREF(index);
    if (v == -1 && PyErr_Occurred())
        return -1;
    if (overflow || v < 0 || v > (long long)UINT32_MAX) {
        PyErr_Format(PyExc_ValueError, "%s must be in 0..%lu", what,
                     (unsigned long)UINT32_MAX);
        return -1;
    }
    *out = (uint32_t)v;
    return 0;
}

/* scales: a sequence of 1..PHKS_MAX_SCALES numbers; sets scale_count. */
static int parse_scales(PyObject *value, phks_options *o)
{
    PyObject *seq = PySequence_Fast(value, "scales must be a sequence");
    if (!seq)
        return -1;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
    if (n < 1 || n > PHKS_MAX_SCALES) {
        PyErr_Format(PyExc_ValueError, "scales: %zd values, not 1..%d", n,
                     PHKS_MAX_SCALES);
        Py_DECREF(seq);
        return -1;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        double d = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
        if (d == -1 && PyErr_Occurred()) {
            Py_DECREF(seq);
            return -1;
        }
        o->scales[i] = d;
    }
    o->scale_count = (uint32_t)n;
    Py_DECREF(seq);
    return 0;
}

/* Fills *o from phks_options_init and the keyword arguments: one keyword
 * per field of phks_options (scales as a sequence), and progress, a
 * callable or None, into *progress (a new reference or NULL). Unknown
 * keywords are a TypeError, as for any Python function. Values are checked
 * by the library, whose message names the field. */
static int parse_options(PyObject *kwargs, phks_options *o,
                         PyObject **progress)
{
    *progress = NULL;
    phks_options_init(o);
    if (!kwargs)
        return 0;
    PyObject *scales = PyDict_GetItemString(kwargs, "scales");
    if (scales && parse_scales(scales, o) < 0)
        return -1;
    PyObject *key, *value;
    Py_ssize_t pos = 0;
    while (PyDict_Next(kwargs, &pos, &key, &value)) {
        const char *name = PyUnicode_AsUTF8(key);
        if (!name)
            goto fail;
        if (strcmp(name, "scales") == 0)
            continue;
        if (strcmp(name, "progress") == 0) {
            if (value == Py_None)
                continue;
            if (!PyCallable_Check(value)) {
                PyErr_SetString(PyExc_TypeError,
                                "progress must be callable or None");
                goto fail;
            }
            Py_INCREF(value);
            Py_XSETREF(*progress, value);
            continue;
        }
        const option_field *f = NULL;
        for (size_t i = 0; i < OPTION_FIELD_COUNT; i++)
            if (strcmp(name, option_fields[i].name) == 0)
                f = &option_fields[i];
        if (!f) {
            PyErr_Format(PyExc_TypeError, "unknown option '%s'", name);
            goto fail;
        }
        char *field = (char *)o + f->offset;
        if (f->kind == FIELD_DOUBLE) {
            double d = PyFloat_AsDouble(value);
            if (d == -1 && PyErr_Occurred())
                goto fail;
            memcpy(field, &d, sizeof d);
        } else if (f->kind == FIELD_U32) {
            uint32_t u;
            if (parse_u32(value, name, &u) < 0)
                goto fail;
            if (scales && strcmp(name, "scale_count") == 0 &&
                u != o->scale_count) {
                PyErr_SetString(PyExc_ValueError,
                                "scale_count differs from len(scales)");
                goto fail;
            }
            memcpy(field, &u, sizeof u);
        } else {
            int32_t e;
            if (parse_enum(value, name, f->names, &e) < 0)
                goto fail;
            memcpy(field, &e, sizeof e);
        }
    }
    return 0;
fail:
    Py_CLEAR(*progress);
    return -1;
}

/* The options as a dict of keyword arguments (enums as strings), which
 * phks.signature(mesh, **d) accepts back. */
static PyObject *options_to_dict(const phks_options *o)
{
    PyObject *d = PyDict_New();
    if (!d)
        return NULL;
    for (size_t i = 0; i < OPTION_FIELD_COUNT; i++) {
        const option_field *f = &option_fields[i];
        const char *field = (const char *)o + f->offset;
        PyObject *v;
        if (f->kind == FIELD_DOUBLE) {
            double x;
            memcpy(&x, field, sizeof x);
            v = PyFloat_FromDouble(x);
        } else if (f->kind == FIELD_U32) {
            uint32_t u;
            memcpy(&u, field, sizeof u);
            v = PyLong_FromUnsignedLong(u);
        } else {
            int32_t e, n = 0;
            memcpy(&e, field, sizeof e);
            while (f->names[n])
                n++;
            v = e >= 0 && e < n ? PyUnicode_FromString(f->names[e])
                                : PyLong_FromLong(e);
        }
        if (!v || PyDict_SetItemString(d, f->name, v) < 0) {
            Py_XDECREF(v);
            Py_DECREF(d);
            return NULL;
        }
        Py_DECREF(v);
    }
    uint32_t n = o->scale_count <= PHKS_MAX_SCALES ? o->scale_count : 0;
    PyObject *scales = PyTuple_New(n);
    if (!scales) {
        Py_DECREF(d);
        return NULL;
    }
    for (uint32_t i = 0; i < n; i++) {
        PyObject *x = PyFloat_FromDouble(o->scales[i]);
        if (!x) {
            Py_DECREF(scales);
            Py_DECREF(d);
            return NULL;
        }
        PyTuple_SET_ITEM(scales, i, x);
    }
    int rc = PyDict_SetItemString(d, "scales", scales);
    Py_DECREF(scales);
    if (rc < 0) {
        Py_DECREF(d);
        return NULL;
    }
    return d;
}

static PyObject *py_default_options(PyObject *self, PyObject *unused)
{
    phks_options o;
    phks_options_init(&o);
    return options_to_dict(&o);
}

/* ---------------------------------------------------------------------
 * numpy helpers
 * --------------------------------------------------------------------- */

/* A read-only array over memory owned by a handle, kept alive by owner
 * (the Python object holding the handle). NULL data (a count of 0) gives
 * an empty array. */
static PyObject *view_array(PyObject *owner, const void *data, int nd,
                            npy_intp *dims, int type)
{
    if (!data) { /* the library gives NULL arrays for a count of 0 */
        dims[0] = 0;
        return PyArray_ZEROS(nd, dims, type, 0);
    }
    PyObject *arr = PyArray_New(&PyArray_Type, nd, dims, type, NULL,
                                (void *)data, 0,
                                NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED,
                                NULL);
    if (!arr)
        return NULL;
    Py_INCREF(owner);
    if (PyArray_SetBaseObject((PyArrayObject *)arr, owner) < 0) {
        Py_DECREF(arr); /* SetBaseObject released owner */
        return NULL;
    }
    return arr;
}

/* ---------------------------------------------------------------------
 * Mesh
 * --------------------------------------------------------------------- */
typedef struct MeshObject {
    PyObject_HEAD
    phks_mesh *mesh;
} MeshObject;

static PyTypeObject MeshType;

/* Wraps a new handle; frees it if the wrapper cannot be made. */
static PyObject *mesh_wrap(phks_mesh *mesh)
{
    MeshObject *self = PyObject_New(MeshObject, &MeshType);
    if (!self) {
        phks_mesh_free(mesh);
        return NULL;
    }
    self->mesh = mesh;
    return (PyObject *)self;
}

static void Mesh_dealloc(MeshObject *self)
{
    phks_mesh_free(self->mesh);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* faces: any integer array of shape (m, 3), into uint32 indices checked
 * here for what uint32 cannot hold (negative, above 2^32 - 1); the library
 * checks them against the vertex count. */
static int convert_faces(PyObject *faces, uint32_t **out, size_t *count)
{
    *out = NULL;
    *count = 0;
    PyArrayObject *arr = (PyArrayObject *)PyArray_FROM_O(faces);
    if (!arr)
        return -1;
    if (PyArray_NDIM(arr) != 2 || PyArray_DIM(arr, 1) != 3) {
        PyErr_SetString(PyExc_ValueError, "faces must have shape (m, 3)");
        Py_DECREF(arr);
        return -1;
    }
    int type = PyArray_TYPE(arr);
    /* An empty list makes a float64 array: nothing to lose there. */
    if (PyArray_SIZE(arr) > 0 && !PyTypeNum_ISINTEGER(type)) {
        PyErr_SetString(PyExc_TypeError,
                        "faces must be an array of integers");
        Py_DECREF(arr);
        return -1;
    }
    /* Signed and unsigned inputs go through the 64-bit type of their
     * signedness, so that no value wraps before it is checked. */
    int wide = PyTypeNum_ISUNSIGNED(type) ? NPY_UINT64 : NPY_INT64;
    PyArrayObject *w = (PyArrayObject *)PyArray_FROMANY(
        (PyObject *)arr, wide, 2, 2,
        NPY_ARRAY_IN_ARRAY | NPY_ARRAY_FORCECAST);
    Py_DECREF(arr);
    if (!w)
        return -1;
    size_t m = (size_t)PyArray_DIM(w, 0);
    uint32_t *idx = PyMem_Malloc(m ? 3 * m * sizeof *idx : 1);
    if (!idx) {
        Py_DECREF(w);
        PyErr_NoMemory();
        return -1;
    }
    for (size_t i = 0; i < 3 * m; i++) {
        long long v;
        int bad;
        if (wide == NPY_UINT64) {
            uint64_t u = ((const uint64_t *)PyArray_DATA(w))[i];
            bad = u > UINT32_MAX;
            v = bad ? -1 : (long long)u;
        } else {
            v = ((const int64_t *)PyArray_DATA(w))[i];
            bad = v < 0 || v > (long long)UINT32_MAX;
        }
        if (bad) {
            if (wide == NPY_UINT64)
                raise_status_format(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                                    "faces[%zu, %zu]: index %llu too large",
                                    i / 3, i % 3,
                                    (unsigned long long)((
                                        const uint64_t *)PyArray_DATA(w))[i]);
            else
                raise_status_format(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                                    "faces[%zu, %zu]: index %lld out of range",
                                    i / 3, i % 3, v);
            PyMem_Free(idx);
            Py_DECREF(w);
            return -1;
        }
        idx[i] = (uint32_t)v;
    }
    Py_DECREF(w);
    *out = idx;
    *count = m;
    return 0;
}

static PyObject *Mesh_new(PyTypeObject *type, PyObject *args,
                          PyObject *kwargs)
{
    static char *keywords[] = {"vertices", "faces", NULL};
    PyObject *vertices_obj, *faces_obj;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OO:Mesh", keywords,
                                     &vertices_obj, &faces_obj))
        return NULL;
    /* float64 (n, 3); numpy refuses unsafe casts (complex, strings). */
    PyArrayObject *v = (PyArrayObject *)PyArray_FROMANY(
        vertices_obj, NPY_DOUBLE, 2, 2, NPY_ARRAY_IN_ARRAY);
    if (!v)
        return NULL;
    if (PyArray_DIM(v, 1) != 3) {
        PyErr_SetString(PyExc_ValueError, "vertices must have shape (n, 3)");
        Py_DECREF(v);
        return NULL;
    }
    uint32_t *tri;
    size_t tri_count;
    if (convert_faces(faces_obj, &tri, &tri_count) < 0) {
        Py_DECREF(v);
        return NULL;
    }
    const double *xyz = PyArray_DATA(v);
    size_t n = (size_t)PyArray_DIM(v, 0);
    phks_mesh *mesh = NULL;
    phks_status st;
    Py_BEGIN_ALLOW_THREADS
    st = phks_mesh_create(xyz, n, tri, tri_count, &mesh);
    Py_END_ALLOW_THREADS
    PyMem_Free(tri);
    Py_DECREF(v);
    if (st != PHKS_OK)
        return raise_status(st);
    MeshObject *self = (MeshObject *)type->tp_alloc(type, 0);
    if (!self) {
        phks_mesh_free(mesh);
        return NULL;
    }
    self->mesh = mesh;
    return (PyObject *)self;
}

static PyObject *Mesh_get_vertex_count(MeshObject *self, void *c)
{
    return PyLong_FromSize_t(phks_mesh_vertex_count(self->mesh));
}

static PyObject *Mesh_get_triangle_count(MeshObject *self, void *c)
{
    return PyLong_FromSize_t(phks_mesh_triangle_count(self->mesh));
}

static PyObject *Mesh_get_vertices(MeshObject *self, void *c)
{
    npy_intp dims[2] = {(npy_intp)phks_mesh_vertex_count(self->mesh), 3};
    return view_array((PyObject *)self, phks_mesh_vertices(self->mesh), 2,
                      dims, NPY_DOUBLE);
}

static PyObject *Mesh_get_triangles(MeshObject *self, void *c)
{
    npy_intp dims[2] = {(npy_intp)phks_mesh_triangle_count(self->mesh), 3};
    return view_array((PyObject *)self, phks_mesh_triangles(self->mesh), 2,
                      dims, NPY_UINT32);
}

static PyObject *Mesh_get_vertex_origin(MeshObject *self, void *c)
{
    npy_intp dims[1] = {(npy_intp)phks_mesh_vertex_count(self->mesh)};
    return view_array((PyObject *)self, phks_mesh_vertex_origin(self->mesh),
                      1, dims, NPY_UINT32);
}

static PyObject *Mesh_get_boundary_edges(MeshObject *self, void *c)
{
    npy_intp dims[2] = {
        (npy_intp)phks_mesh_boundary_edge_count(self->mesh), 2};
    return view_array((PyObject *)self, phks_mesh_boundary_edges(self->mesh),
                      2, dims, NPY_UINT32);
}

static PyObject *Mesh_get_component_count(MeshObject *self, void *c)
{
    return PyLong_FromSize_t(phks_mesh_component_count(self->mesh));
}

static PyObject *Mesh_get_vertex_components(MeshObject *self, void *c)
{
    npy_intp dims[1] = {(npy_intp)phks_mesh_vertex_count(self->mesh)};
    return view_array((PyObject *)self,
                      phks_mesh_vertex_components(self->mesh), 1, dims,
                      NPY_UINT32);
}

static PyObject *Mesh_get_area(MeshObject *self, void *c)
{
    return PyFloat_FromDouble(phks_mesh_area(self->mesh));
}

static PyObject *Mesh_repr(MeshObject *self)
{
    return PyUnicode_FromFormat("<phks.Mesh: %zu vertices, %zu triangles>",
                                phks_mesh_vertex_count(self->mesh),
                                phks_mesh_triangle_count(self->mesh));
}

static PyGetSetDef Mesh_getset[] = {
    {"vertex_count", (getter)Mesh_get_vertex_count, NULL,
     "Vertices kept (unused ones are dropped).", NULL},
    {"triangle_count", (getter)Mesh_get_triangle_count, NULL,
     "Triangles kept (degenerate ones are dropped).", NULL},
    {"vertices", (getter)Mesh_get_vertices, NULL,
     "(vertex_count, 3) float64, read-only: the kept vertices, as given.",
     NULL},
    {"triangles", (getter)Mesh_get_triangles, NULL,
     "(triangle_count, 3) uint32, read-only: indices into vertices.", NULL},
    {"vertex_origin", (getter)Mesh_get_vertex_origin, NULL,
     "(vertex_count,) uint32, read-only: each vertex's index in the caller's "
     "arrays or the file.",
     NULL},
    {"boundary_edges", (getter)Mesh_get_boundary_edges, NULL,
     "(k, 2) uint32, read-only: edges with one triangle, lower index first.",
     NULL},
    {"component_count", (getter)Mesh_get_component_count, NULL,
     "Connected components (triangles sharing a vertex are connected).",
     NULL},
    {"vertex_components", (getter)Mesh_get_vertex_components, NULL,
     "(vertex_count,) uint32, read-only: each vertex's component.", NULL},
    {"area", (getter)Mesh_get_area, NULL,
     "Total surface area, in input units squared.", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

static PyTypeObject MeshType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "phks.Mesh",
    .tp_basicsize = sizeof(MeshObject),
    .tp_dealloc = (destructor)Mesh_dealloc,
    .tp_repr = (reprfunc)Mesh_repr,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Mesh(vertices, faces)\n\n"
              "An immutable, cleaned triangle mesh. vertices: float64 "
              "(n, 3); faces: integers (m, 3) indexing vertices. Degenerate "
              "triangles and unused vertices are dropped; vertex_origin maps "
              "the kept vertices back to the caller's numbering.",
    .tp_getset = Mesh_getset,
    .tp_new = Mesh_new,
};

static PyObject *py_has_assimp(PyObject *self, PyObject *unused)
{
    return PyBool_FromLong(assimp_reader_available());
}

static PyObject *py_load(PyObject *self, PyObject *args)
{
    PyObject *path;
    if (!PyArg_ParseTuple(args, "O&:load", PyUnicode_FSConverter, &path))
        return NULL;
    phks_mesh *mesh = NULL;
    phks_status st;
    const char *p = PyBytes_AS_STRING(path);
    if (assimp_reader_handles(p)) {
        /* glTF, FBX, COLLADA, ...: through assimp, all meshes merged (the
         * adapter, tools/assimp/assimp_reader.c). */
        char err[1024];
        Py_BEGIN_ALLOW_THREADS
        st = assimp_reader_load(p, NULL, &mesh, NULL, 0, err, sizeof err);
        Py_END_ALLOW_THREADS
        if (st != PHKS_OK) {
            char detail[1400];
            snprintf(detail, sizeof detail, "%s: %s", p, err);
            Py_DECREF(path);
            return raise_status_detail(st, detail);
        }
        Py_DECREF(path);
        return mesh_wrap(mesh);
    }
    Py_BEGIN_ALLOW_THREADS
    st = phks_mesh_load(p, &mesh);
    Py_END_ALLOW_THREADS
    Py_DECREF(path);
    if (st != PHKS_OK)
        return raise_status(st);
    return mesh_wrap(mesh);
}

static PyObject *py_load_memory(PyObject *self, PyObject *args,
                                PyObject *kwargs)
{
    static char *keywords[] = {"data", "format", NULL};
    Py_buffer data;
    PyObject *format_obj = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "y*|O:load_memory",
                                     keywords, &data, &format_obj))
        return NULL;
    int32_t format = PHKS_FORMAT_AUTO;
    if (format_obj &&
        parse_enum(format_obj, "format", format_names, &format) < 0) {
        PyBuffer_Release(&data);
        return NULL;
    }
    phks_mesh *mesh = NULL;
    phks_status st;
    /* The buffer stays exported (locked) while the GIL is released. */
    Py_BEGIN_ALLOW_THREADS
    st = phks_mesh_load_memory(data.buf, (size_t)data.len,
                               (phks_format)format, &mesh);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&data);
    if (st != PHKS_OK)
        return raise_status(st);
    return mesh_wrap(mesh);
}

/* ---------------------------------------------------------------------
 * Signature
 * --------------------------------------------------------------------- */
typedef struct SignatureObject {
    PyObject_HEAD
    phks_signature *sig;
    /* Feature vertices in the caller's numbering (uint32 array), or NULL
     * when unknown: a decoded signature knows only the cleaned mesh's. */
    PyObject *caller_vertices;
} SignatureObject;

static PyTypeObject SignatureType;

/* Wraps a new handle; with mesh, maps its feature vertices back through
 * the mesh's vertex_origin. Frees sig if anything fails. */
static PyObject *signature_wrap(phks_signature *sig, const phks_mesh *mesh)
{
    SignatureObject *self = PyObject_New(SignatureObject, &SignatureType);
    if (!self) {
        phks_signature_free(sig);
        return NULL;
    }
    self->sig = sig;
    self->caller_vertices = NULL;
    if (!mesh)
        return (PyObject *)self;
    size_t k = phks_signature_feature_count(sig);
    size_t n = phks_mesh_vertex_count(mesh);
    const uint32_t *origin = phks_mesh_vertex_origin(mesh);
    npy_intp dims[1] = {(npy_intp)k};
    PyObject *arr = PyArray_SimpleNew(1, dims, NPY_UINT32);
    if (!arr) {
        Py_DECREF(self);
        return NULL;
    }
    uint32_t *out = PyArray_DATA((PyArrayObject *)arr);
    for (size_t i = 0; i < k; i++) {
        uint32_t v = phks_signature_feature_vertex(sig, i);
        if (v >= n) {
            Py_DECREF(arr);
            Py_DECREF(self);
            PyErr_Format(PyExc_ValueError,
                         "feature %zu: vertex %lu is not a vertex of the "
                         "mesh (%zu vertices)",
                         i, (unsigned long)v, n);
            return NULL;
        }
        out[i] = origin[v];
    }
    PyArray_CLEARFLAGS((PyArrayObject *)arr, NPY_ARRAY_WRITEABLE);
    self->caller_vertices = arr;
    return (PyObject *)self;
}

static void Signature_dealloc(SignatureObject *self)
{
    phks_signature_free(self->sig);
    Py_XDECREF(self->caller_vertices);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static Py_ssize_t Signature_len(SignatureObject *self)
{
    return (Py_ssize_t)phks_signature_feature_count(self->sig);
}

static PyObject *Signature_get_vertices(SignatureObject *self, void *c)
{
    if (!self->caller_vertices)
        Py_RETURN_NONE;
    Py_INCREF(self->caller_vertices);
    return self->caller_vertices;
}

/* The mesh vertices of points [first, first + k): features, then
 * samples. */
static PyObject *vertices_of(const phks_signature *sig, size_t first,
                             size_t k)
{
    npy_intp dims[1] = {(npy_intp)k};
    PyObject *arr = PyArray_SimpleNew(1, dims, NPY_UINT32);
    if (!arr)
        return NULL;
    uint32_t *out = PyArray_DATA((PyArrayObject *)arr);
    for (size_t i = 0; i < k; i++)
        out[i] = phks_signature_feature_vertex(sig, first + i);
    return arr;
}

static PyObject *Signature_get_mesh_vertices(SignatureObject *self, void *c)
{
    return vertices_of(self->sig, 0, phks_signature_feature_count(self->sig));
}

static PyObject *Signature_get_positions(SignatureObject *self, void *c)
{
    size_t k = phks_signature_feature_count(self->sig);
    npy_intp dims[2] = {(npy_intp)k, 3};
    PyObject *arr = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (!arr)
        return NULL;
    double *out = PyArray_DATA((PyArrayObject *)arr);
    for (size_t i = 0; i < k; i++) {
        phks_status st = phks_signature_feature_position(self->sig, i,
                                                         out + 3 * i);
        if (st != PHKS_OK) {
            Py_DECREF(arr);
            return raise_status(st);
        }
    }
    return arr;
}

static PyObject *Signature_get_persistence(SignatureObject *self, void *c)
{
    size_t k = phks_signature_feature_count(self->sig);
    npy_intp dims[1] = {(npy_intp)k};
    PyObject *arr = PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    if (!arr)
        return NULL;
    double *out = PyArray_DATA((PyArrayObject *)arr);
    for (size_t i = 0; i < k; i++)
        out[i] = phks_signature_feature_persistence(self->sig, i);
    return arr;
}

/* The vectors of points [first, first + k): features, then samples. */
static PyObject *vectors_of(const phks_signature *sig, size_t first, size_t k)
{
    size_t len = phks_signature_vector_length(sig);
    npy_intp dims[2] = {(npy_intp)k, (npy_intp)len};
    PyObject *arr = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (!arr)
        return NULL;
    double *out = PyArray_DATA((PyArrayObject *)arr);
    for (size_t i = 0; i < k; i++)
        memcpy(out + i * len, phks_signature_feature_vector(sig, first + i),
               len * sizeof *out);
    return arr;
}

static PyObject *Signature_get_vectors(SignatureObject *self, void *c)
{
    return vectors_of(self->sig, 0, phks_signature_feature_count(self->sig));
}

static PyObject *Signature_get_sample_vectors(SignatureObject *self, void *c)
{
    return vectors_of(self->sig, phks_signature_feature_count(self->sig),
                      phks_signature_sample_count(self->sig));
}

static PyObject *Signature_get_sample_mesh_vertices(SignatureObject *self,
                                                    void *c)
{
    return vertices_of(self->sig, phks_signature_feature_count(self->sig),
                       phks_signature_sample_count(self->sig));
}

static PyObject *Signature_get_vector_length(SignatureObject *self, void *c)
{
    return PyLong_FromSize_t(phks_signature_vector_length(self->sig));
}

static PyObject *Signature_get_options(SignatureObject *self, void *c)
{
    phks_options o;
    phks_status st = phks_signature_options(self->sig, &o);
    if (st != PHKS_OK)
        return raise_status(st);
    return options_to_dict(&o);
}

static PyObject *Signature_encode(SignatureObject *self, PyObject *unused)
{
    size_t size = phks_signature_encoded_size(self->sig);
    if (size > PY_SSIZE_T_MAX)
        return PyErr_NoMemory();
    PyObject *bytes = PyBytes_FromStringAndSize(NULL, (Py_ssize_t)size);
    if (!bytes)
        return NULL;
    size_t written = 0;
    phks_status st = phks_signature_encode(
        self->sig, PyBytes_AS_STRING(bytes), size, &written);
    if (st != PHKS_OK) {
        Py_DECREF(bytes);
        return raise_status(st);
    }
    if (written != size) { /* phks.h: encoded_size is exact */
        Py_DECREF(bytes);
        PyErr_SetString(PyExc_SystemError,
                        "phks_signature_encode wrote another size than "
                        "phks_signature_encoded_size gave");
        return NULL;
    }
    return bytes;
}

static PyObject *signature_decode(PyObject *args, PyObject *kwargs,
                                  const char *format)
{
    static char *keywords[] = {"data", "mesh", NULL};
    Py_buffer data;
    PyObject *mesh_obj = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, format, keywords, &data,
                                     &mesh_obj))
        return NULL;
    if (mesh_obj != Py_None && !PyObject_TypeCheck(mesh_obj, &MeshType)) {
        PyBuffer_Release(&data);
        PyErr_SetString(PyExc_TypeError, "mesh must be a phks.Mesh or None");
        return NULL;
    }
    phks_signature *sig = NULL;
    phks_status st = phks_signature_decode(data.buf, (size_t)data.len, &sig);
    PyBuffer_Release(&data);
    if (st != PHKS_OK)
        return raise_status(st);
    return signature_wrap(sig, mesh_obj == Py_None
                                   ? NULL
                                   : ((MeshObject *)mesh_obj)->mesh);
}

static PyObject *Signature_decode(PyObject *cls, PyObject *args,
                                  PyObject *kwargs)
{
    return signature_decode(args, kwargs, "y*|O:decode");
}

static PyObject *py_decode(PyObject *self, PyObject *args, PyObject *kwargs)
{
    return signature_decode(args, kwargs, "y*|O:decode");
}

/* Pickling (multiprocessing pools, caches): the blob, and the caller's
 * numbering, which the blob does not hold. */
static PyObject *Signature_reduce(SignatureObject *self, PyObject *unused)
{
    PyObject *restore = NULL, *blob = NULL, *result = NULL;
    restore = PyObject_GetAttrString((PyObject *)Py_TYPE(self), "_restore");
    if (restore)
        blob = Signature_encode(self, NULL);
    if (blob)
        result = Py_BuildValue("(O(OO))", restore, blob,
                               self->caller_vertices ? self->caller_vertices
                                                     : Py_None);
    Py_XDECREF(restore);
    Py_XDECREF(blob);
    return result;
}

static PyObject *Signature_restore(PyObject *cls, PyObject *args)
{
    Py_buffer data;
    PyObject *vertices;
    if (!PyArg_ParseTuple(args, "y*O:_restore", &data, &vertices))
        return NULL;
    phks_signature *sig = NULL;
    phks_status st = phks_signature_decode(data.buf, (size_t)data.len, &sig);
    PyBuffer_Release(&data);
    if (st != PHKS_OK)
        return raise_status(st);
    SignatureObject *self = (SignatureObject *)signature_wrap(sig, NULL);
    if (!self || vertices == Py_None)
        return (PyObject *)self;
    /* A private copy, read-only like the one signature_wrap makes. */
    PyArrayObject *arr = (PyArrayObject *)PyArray_FROMANY(
        vertices, NPY_UINT32, 1, 1, NPY_ARRAY_IN_ARRAY | NPY_ARRAY_ENSURECOPY);
    if (!arr) {
        Py_DECREF(self);
        return NULL;
    }
    if ((size_t)PyArray_DIM(arr, 0) != phks_signature_feature_count(self->sig)) {
        PyErr_SetString(PyExc_ValueError,
                        "_restore: one vertex per feature expected");
        Py_DECREF(arr);
        Py_DECREF(self);
        return NULL;
    }
    PyArray_CLEARFLAGS(arr, NPY_ARRAY_WRITEABLE);
    self->caller_vertices = (PyObject *)arr;
    return (PyObject *)self;
}

static PyObject *Signature_repr(SignatureObject *self)
{
    return PyUnicode_FromFormat(
        "<phks.Signature: %zu features x %zu scales>",
        phks_signature_feature_count(self->sig),
        phks_signature_vector_length(self->sig));
}

static PyMethodDef Signature_methods[] = {
    {"encode", (PyCFunction)Signature_encode, METH_NOARGS,
     "encode() -> bytes: the versioned, CRC-checked blob "
     "(docs/formats.md)."},
    {"decode", (PyCFunction)(void (*)(void))Signature_decode,
     METH_VARARGS | METH_KEYWORDS | METH_CLASS,
     "Signature.decode(data, mesh=None): a signature from a blob. With the "
     "mesh it was computed on, .vertices is in the caller's numbering; "
     "without, it is None (see .mesh_vertices)."},
    {"__reduce__", (PyCFunction)Signature_reduce, METH_NOARGS,
     "Pickles as the encoded blob and the caller's vertex numbering."},
    {"_restore", (PyCFunction)Signature_restore, METH_VARARGS | METH_CLASS,
     "Unpickles (see __reduce__)."},
    {NULL, NULL, 0, NULL}};

static PyGetSetDef Signature_getset[] = {
    {"vertices", (getter)Signature_get_vertices, NULL,
     "(k,) uint32: each feature's vertex in the caller's numbering (the "
     "input arrays or file), or None for a signature decoded without its "
     "mesh.",
     NULL},
    {"mesh_vertices", (getter)Signature_get_mesh_vertices, NULL,
     "(k,) uint32: each feature's vertex in the cleaned mesh "
     "(Mesh.vertices).",
     NULL},
    {"positions", (getter)Signature_get_positions, NULL,
     "(k, 3) float64: feature positions in input coordinates.", NULL},
    {"persistence", (getter)Signature_get_persistence, NULL,
     "(k,) float64: feature persistence (inf if never merged), most "
     "persistent first.",
     NULL},
    {"vectors", (getter)Signature_get_vectors, NULL,
     "(k, vector_length) float64: HKS at each time scale.", NULL},
    {"sample_vectors", (getter)Signature_get_sample_vectors, NULL,
     "(s, vector_length) float64: the vectors of the samples a verified "
     "signature spreads after its features (s = 0 with matching "
     "'nearest'); a match's feature_b from len(b) on is sample "
     "feature_b - len(b).",
     NULL},
    {"sample_mesh_vertices", (getter)Signature_get_sample_mesh_vertices,
     NULL, "(s,) uint32: each sample's vertex in the cleaned mesh.", NULL},
    {"vector_length", (getter)Signature_get_vector_length, NULL,
     "Entries of each vector (the options' scale count).", NULL},
    {"options", (getter)Signature_get_options, NULL,
     "The options it was made with, as keyword arguments.", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

static PySequenceMethods Signature_as_sequence = {
    .sq_length = (lenfunc)Signature_len,
};

static PyTypeObject SignatureType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "phks.Signature",
    .tp_basicsize = sizeof(SignatureObject),
    .tp_dealloc = (destructor)Signature_dealloc,
    .tp_repr = (reprfunc)Signature_repr,
    .tp_as_sequence = &Signature_as_sequence,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "A persistent heat signature: feature points and their HKS "
              "vectors. Made by phks.signature() or Signature.decode(); "
              "len() is the feature count.",
    .tp_methods = Signature_methods,
    .tp_getset = Signature_getset,
};

static int signature_arg(PyObject *obj, void *out)
{
    if (!PyObject_TypeCheck(obj, &SignatureType)) {
        PyErr_Format(PyExc_TypeError, "expected a phks.Signature, not %.100s",
                     Py_TYPE(obj)->tp_name);
        return 0;
    }
    *(const phks_signature **)out = ((SignatureObject *)obj)->sig;
    return 1;
}

static PyObject *py_signature(PyObject *self, PyObject *args,
                              PyObject *kwargs)
{
    MeshObject *mesh;
    if (!PyArg_ParseTuple(args, "O!:signature", &MeshType, &mesh))
        return NULL;
    phks_options o;
    progress_ctx ctx = {0};
    if (parse_options(kwargs, &o, &ctx.callable) < 0)
        return NULL;
    o.progress = progress_trampoline;
    o.progress_user = &ctx;
    phks_signature *sig = NULL;
    phks_status st;
    Py_BEGIN_ALLOW_THREADS
    st = phks_signature_compute(mesh->mesh, &o, &sig);
    Py_END_ALLOW_THREADS
    if (progress_finish(&ctx, st) < 0) {
        phks_signature_free(sig);
        return NULL;
    }
    return signature_wrap(sig, mesh->mesh);
}

/* ---------------------------------------------------------------------
 * Spectrum
 * --------------------------------------------------------------------- */
typedef struct SpectrumObject {
    PyObject_HEAD
    phks_spectrum *spectrum;
    MeshObject *mesh;    /* the mesh it was computed on                 */
    phks_options options; /* those it was computed with (progress NULL) */
} SpectrumObject;

static PyTypeObject SpectrumType;

static void Spectrum_dealloc(SpectrumObject *self)
{
    phks_spectrum_free(self->spectrum);
    Py_XDECREF(self->mesh);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *py_spectrum(PyObject *module, PyObject *args,
                             PyObject *kwargs)
{
    MeshObject *mesh;
    if (!PyArg_ParseTuple(args, "O!:spectrum", &MeshType, &mesh))
        return NULL;
    phks_options o;
    progress_ctx ctx = {0};
    if (parse_options(kwargs, &o, &ctx.callable) < 0)
        return NULL;
    o.progress = progress_trampoline;
    o.progress_user = &ctx;
    phks_spectrum *spectrum = NULL;
    phks_status st;
    Py_BEGIN_ALLOW_THREADS
    st = phks_spectrum_compute(mesh->mesh, &o, &spectrum);
    Py_END_ALLOW_THREADS
    if (progress_finish(&ctx, st) < 0) {
        phks_spectrum_free(spectrum);
        return NULL;
    }
    SpectrumObject *self = PyObject_New(SpectrumObject, &SpectrumType);
    if (!self) {
        phks_spectrum_free(spectrum);
        return NULL;
    }
    self->spectrum = spectrum;
    Py_INCREF(mesh);
    self->mesh = mesh;
    o.progress = NULL;
    o.progress_user = NULL;
    self->options = o;
    return (PyObject *)self;
}

static Py_ssize_t Spectrum_len(SpectrumObject *self)
{
    return (Py_ssize_t)phks_spectrum_count(self->spectrum);
}

static PyObject *Spectrum_get_eigenvalues(SpectrumObject *self, void *c)
{
    npy_intp dims[1] = {(npy_intp)phks_spectrum_count(self->spectrum)};
    return view_array((PyObject *)self,
                      phks_spectrum_eigenvalues(self->spectrum), 1, dims,
                      NPY_DOUBLE);
}

/* (sample_count, count): column i is eigenvector i, as numpy.linalg.eigh
 * returns them. A copy: the API gives one pointer per eigenvector. */
static PyObject *Spectrum_get_eigenvectors(SpectrumObject *self, void *c)
{
    size_t k = phks_spectrum_count(self->spectrum);
    size_t n = phks_spectrum_sample_count(self->spectrum);
    npy_intp dims[2] = {(npy_intp)n, (npy_intp)k};
    PyObject *arr = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (!arr)
        return NULL;
    double *out = PyArray_DATA((PyArrayObject *)arr);
    for (size_t j = 0; j < k; j++) {
        const double *phi = phks_spectrum_eigenvector(self->spectrum, j);
        for (size_t i = 0; i < n; i++)
            out[i * k + j] = phi[i];
    }
    return arr;
}

static PyObject *Spectrum_get_mass(SpectrumObject *self, void *c)
{
    npy_intp dims[1] = {(npy_intp)phks_spectrum_sample_count(self->spectrum)};
    return view_array((PyObject *)self, phks_spectrum_mass(self->spectrum), 1,
                      dims, NPY_DOUBLE);
}

static PyObject *Spectrum_get_sample_vertices(SpectrumObject *self, void *c)
{
    const uint32_t *v = phks_spectrum_sample_vertices(self->spectrum);
    if (!v)
        Py_RETURN_NONE;
    npy_intp dims[1] = {(npy_intp)phks_spectrum_sample_count(self->spectrum)};
    return view_array((PyObject *)self, v, 1, dims, NPY_UINT32);
}

static PyObject *Spectrum_get_vertex_count(SpectrumObject *self, void *c)
{
    return PyLong_FromSize_t(phks_spectrum_vertex_count(self->spectrum));
}

static PyObject *Spectrum_get_sample_count(SpectrumObject *self, void *c)
{
    return PyLong_FromSize_t(phks_spectrum_sample_count(self->spectrum));
}

static PyObject *Spectrum_get_mesh(SpectrumObject *self, void *c)
{
    Py_INCREF(self->mesh);
    return (PyObject *)self->mesh;
}

static PyObject *Spectrum_get_options(SpectrumObject *self, void *c)
{
    return options_to_dict(&self->options);
}

static PyObject *Spectrum_hks(SpectrumObject *self, PyObject *arg)
{
    double t = PyFloat_AsDouble(arg);
    if (t == -1 && PyErr_Occurred())
        return NULL;
    npy_intp dims[1] = {(npy_intp)phks_spectrum_vertex_count(self->spectrum)};
    PyObject *arr = PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    if (!arr)
        return NULL;
    double *out = PyArray_DATA((PyArrayObject *)arr);
    phks_status st;
    /* Seconds with HKS-simp on large meshes; arr is not shared yet. */
    Py_BEGIN_ALLOW_THREADS
    st = phks_spectrum_hks(self->spectrum, t, out);
    Py_END_ALLOW_THREADS
    if (st != PHKS_OK) {
        Py_DECREF(arr);
        return raise_status(st);
    }
    return arr;
}

static PyObject *Spectrum_signature(SpectrumObject *self, PyObject *args,
                                    PyObject *kwargs)
{
    static char *keywords[] = {"progress", NULL};
    PyObject *progress = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "|O:signature", keywords,
                                     &progress))
        return NULL;
    if (progress != Py_None && !PyCallable_Check(progress)) {
        PyErr_SetString(PyExc_TypeError, "progress must be callable or None");
        return NULL;
    }
    progress_ctx ctx = {0};
    if (progress != Py_None) {
        Py_INCREF(progress);
        ctx.callable = progress;
    }
    phks_options o = self->options;
    o.progress = progress_trampoline;
    o.progress_user = &ctx;
    phks_signature *sig = NULL;
    phks_status st;
    Py_BEGIN_ALLOW_THREADS
    st = phks_signature_from_spectrum(self->mesh->mesh, self->spectrum, &o,
                                      &sig);
    Py_END_ALLOW_THREADS
    if (progress_finish(&ctx, st) < 0) {
        phks_signature_free(sig);
        return NULL;
    }
    return signature_wrap(sig, self->mesh->mesh);
}

static PyObject *Spectrum_repr(SpectrumObject *self)
{
    return PyUnicode_FromFormat(
        "<phks.Spectrum: %zu eigenpairs, %zu vertices, %zu samples>",
        phks_spectrum_count(self->spectrum),
        phks_spectrum_vertex_count(self->spectrum),
        phks_spectrum_sample_count(self->spectrum));
}

static PyMethodDef Spectrum_methods[] = {
    {"hks", (PyCFunction)Spectrum_hks, METH_O,
     "hks(t) -> (vertex_count,) float64: HKS_t at every vertex, t in "
     "absolute time on the unit box (5 tau = 0.001 by default)."},
    {"signature", (PyCFunction)(void (*)(void))Spectrum_signature,
     METH_VARARGS | METH_KEYWORDS,
     "signature(progress=None): the signature of the mesh from this "
     "spectrum, with the options it was computed with."},
    {NULL, NULL, 0, NULL}};

static PyGetSetDef Spectrum_getset[] = {
    {"eigenvalues", (getter)Spectrum_get_eigenvalues, NULL,
     "(count,) float64, read-only, ascending, in 1 / (unit-box length)^2.",
     NULL},
    {"eigenvectors", (getter)Spectrum_get_eigenvectors, NULL,
     "(sample_count, count) float64: column i is eigenvector i, "
     "M-orthonormal.",
     NULL},
    {"mass", (getter)Spectrum_get_mass, NULL,
     "(sample_count,) float64, read-only: the diagonal of M.", NULL},
    {"sample_vertices", (getter)Spectrum_get_sample_vertices, NULL,
     "(sample_count,) uint32 mesh vertices of an HKS-simp spectrum's "
     "entries; None for an exact one.",
     NULL},
    {"vertex_count", (getter)Spectrum_get_vertex_count, NULL,
     "The mesh's vertex count.", NULL},
    {"sample_count", (getter)Spectrum_get_sample_count, NULL,
     "Entries of each eigenvector.", NULL},
    {"mesh", (getter)Spectrum_get_mesh, NULL, "The mesh.", NULL},
    {"options", (getter)Spectrum_get_options, NULL,
     "The options it was computed with.", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

static PySequenceMethods Spectrum_as_sequence = {
    .sq_length = (lenfunc)Spectrum_len,
};

static PyTypeObject SpectrumType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "phks.Spectrum",
    .tp_basicsize = sizeof(SpectrumObject),
    .tp_dealloc = (destructor)Spectrum_dealloc,
    .tp_repr = (reprfunc)Spectrum_repr,
    .tp_as_sequence = &Spectrum_as_sequence,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The smallest eigenpairs of the mesh-Laplacian, from "
              "phks.spectrum(mesh, **options). len() is the eigenpair count.",
    .tp_methods = Spectrum_methods,
    .tp_getset = Spectrum_getset,
};

/* ---------------------------------------------------------------------
 * Persistent maxima, scores, correspondences
 * --------------------------------------------------------------------- */
static PyTypeObject MaximaType, MatchType, HitType, EntryType;

static PyStructSequence_Field maxima_fields[] = {
    {"vertices", "(r,) uint32: vertex of each maximum (cleaned mesh)"},
    {"triangles", "(r,) uint32: central triangle of each region"},
    {"values", "(r,) float64: f at the vertex"},
    {"persistence", "(r,) float64: persistence, inf if never merged"},
    {"labels", "(triangle_count,) uint32: region of each triangle, "
               "0xFFFFFFFF for none"},
    {NULL, NULL}};
static PyStructSequence_Desc maxima_desc = {
    "phks.Maxima", "Persistent maxima and the segmentation.", maxima_fields,
    5};

static PyObject *py_persistent_maxima(PyObject *module, PyObject *args,
                                      PyObject *kwargs)
{
    static char *keywords[] = {"mesh", "f", "max_count", "threshold", NULL};
    MeshObject *mesh;
    PyObject *f_obj;
    Py_ssize_t max_count = 15;
    double threshold = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "O!O|nd:persistent_maxima",
                                     keywords, &MeshType, &mesh, &f_obj,
                                     &max_count, &threshold))
        return NULL;
    if (max_count < 1) {
        PyErr_SetString(PyExc_ValueError, "max_count must be at least 1");
        return NULL;
    }
    size_t n = phks_mesh_vertex_count(mesh->mesh);
    size_t m = phks_mesh_triangle_count(mesh->mesh);
    PyArrayObject *f = (PyArrayObject *)PyArray_FROMANY(
        f_obj, NPY_DOUBLE, 1, 1, NPY_ARRAY_IN_ARRAY);
    if (!f)
        return NULL;
    if ((size_t)PyArray_DIM(f, 0) != n) {
        PyErr_Format(PyExc_ValueError,
                     "f has %zd values, the mesh %zu vertices",
                     PyArray_DIM(f, 0), n);
        Py_DECREF(f);
        return NULL;
    }
    size_t room = (size_t)max_count < m ? (size_t)max_count : m;
    npy_intp label_dims[1] = {(npy_intp)m};
    PyObject *labels = PyArray_SimpleNew(1, label_dims, NPY_UINT32);
    phks_maximum *out = PyMem_Malloc((room ? room : 1) * sizeof *out);
    PyObject *result = NULL, *vertices = NULL, *triangles = NULL;
    PyObject *values = NULL, *persistence = NULL;
    if (!labels || !out) {
        if (labels)
            PyErr_NoMemory();
        goto done;
    }
    const double *fv = PyArray_DATA(f);
    uint32_t *lv = PyArray_DATA((PyArrayObject *)labels);
    size_t count = 0;
    phks_status st;
    Py_BEGIN_ALLOW_THREADS
    st = phks_persistent_maxima(mesh->mesh, fv, (size_t)max_count, threshold,
                                out, &count, lv);
    Py_END_ALLOW_THREADS
    if (st != PHKS_OK) {
        raise_status(st);
        goto done;
    }
    npy_intp dims[1] = {(npy_intp)count};
    vertices = PyArray_SimpleNew(1, dims, NPY_UINT32);
    triangles = PyArray_SimpleNew(1, dims, NPY_UINT32);
    values = PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    persistence = PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    if (!vertices || !triangles || !values || !persistence)
        goto done;
    for (size_t i = 0; i < count; i++) {
        ((uint32_t *)PyArray_DATA((PyArrayObject *)vertices))[i] =
            out[i].vertex;
        ((uint32_t *)PyArray_DATA((PyArrayObject *)triangles))[i] =
            out[i].triangle;
        ((double *)PyArray_DATA((PyArrayObject *)values))[i] = out[i].value;
        ((double *)PyArray_DATA((PyArrayObject *)persistence))[i] =
            out[i].persistence;
    }
    result = PyStructSequence_New(&MaximaType);
    if (!result)
        goto done;
    /* SET_ITEM steals: the arrays now belong to result. */
    PyStructSequence_SET_ITEM(result, 0, vertices);
    PyStructSequence_SET_ITEM(result, 1, triangles);
    PyStructSequence_SET_ITEM(result, 2, values);
    PyStructSequence_SET_ITEM(result, 3, persistence);
    PyStructSequence_SET_ITEM(result, 4, labels);
    vertices = triangles = values = persistence = labels = NULL;
done:
    Py_XDECREF(vertices);
    Py_XDECREF(triangles);
    Py_XDECREF(values);
    Py_XDECREF(persistence);
    Py_XDECREF(labels);
    PyMem_Free(out);
    Py_DECREF(f);
    return result;
}

/* Distances along the surface from vertex source: options as for
 * signature() (box and tau decide which pieces are joined), bar progress,
 * which the library does not report for them. */
static PyObject *py_geodesic_distances(PyObject *module, PyObject *args,
                                       PyObject *kwargs)
{
    MeshObject *mesh;
    PyObject *source_obj;
    if (!PyArg_ParseTuple(args, "O!O:geodesic_distances", &MeshType, &mesh,
                          &source_obj))
        return NULL;
    uint32_t source;
    if (parse_u32(source_obj, "source", &source) < 0)
        return NULL;
    phks_options o;
    PyObject *progress;
    if (parse_options(kwargs, &o, &progress) < 0)
        return NULL;
    if (progress) {
        Py_DECREF(progress);
        PyErr_SetString(PyExc_TypeError,
                        "geodesic_distances takes no progress");
        return NULL;
    }
    npy_intp dims[1] = {(npy_intp)phks_mesh_vertex_count(mesh->mesh)};
    PyObject *out = PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    if (!out)
        return NULL;
    double *d = PyArray_DATA((PyArrayObject *)out);
    phks_status st;
    Py_BEGIN_ALLOW_THREADS
    st = phks_mesh_geodesic_distances(mesh->mesh, &o, source, d);
    Py_END_ALLOW_THREADS
    if (st != PHKS_OK) {
        Py_DECREF(out);
        return raise_status(st);
    }
    return out;
}

typedef phks_status (*score_fn)(const phks_signature *,
                                const phks_signature *, double *);

/* fn(a, b) of the two Signature arguments; format is PyArg's, ending in
 * the Python name its messages give. */
static PyObject *score_pair(PyObject *args, const char *format, score_fn fn)
{
    const phks_signature *a, *b;
    if (!PyArg_ParseTuple(args, format, signature_arg, &a, signature_arg,
                          &b))
        return NULL;
    double score;
    phks_status st = fn(a, b, &score);
    if (st != PHKS_OK)
        return raise_status(st);
    return PyFloat_FromDouble(score);
}

static PyObject *py_score(PyObject *module, PyObject *args)
{
    return score_pair(args, "O&O&:score", phks_score);
}

static PyObject *py_score_nearest(PyObject *module, PyObject *args)
{
    return score_pair(args, "O&O&:score_nearest", phks_score_nearest);
}

static PyStructSequence_Field match_fields[] = {
    {"score", "phks.score(a, b)"},
    {"feature_a", "(c,) uint32: index of a feature of a"},
    {"feature_b", "(c,) uint32: index of a feature of b"},
    {"distance", "(c,) float64: L1 distance of their vectors"},
    {"from_a", "(c,) bool: True for the rows of a's features, False for "
               "those of b's (feature_a nearest to feature_b)"},
    {"verified", "(c,) bool: True where the pair is one of the verified "
                 "set (matching 'verified'; all False with 'nearest')"},
    {NULL, NULL}};
static PyStructSequence_Desc match_desc = {
    "phks.Match",
    "The score and its pairs: one per feature of a (its verified partner, "
    "or its nearest feature of b), then one per feature of b (its nearest "
    "feature of a).",
    match_fields, 6};

static PyObject *py_match(PyObject *module, PyObject *args)
{
    const phks_signature *a, *b;
    if (!PyArg_ParseTuple(args, "O&O&:match", signature_arg, &a,
                          signature_arg, &b))
        return NULL;
    size_t count = 0;
    double score;
    phks_status st = phks_match(a, b, NULL, 0, &count, &score);
    if (st != PHKS_OK)
        return raise_status(st);
    phks_correspondence *c = PyMem_Malloc((count ? count : 1) * sizeof *c);
    if (!c)
        return PyErr_NoMemory();
    size_t got = 0;
    st = phks_match(a, b, c, count, &got, &score);
    if (st != PHKS_OK) {
        PyMem_Free(c);
        return raise_status(st);
    }
    /* score, then one array per column of the correspondences. */
    enum { COLUMNS = 5 };
    static const int types[COLUMNS] = {NPY_UINT32, NPY_UINT32, NPY_DOUBLE,
                                       NPY_BOOL, NPY_BOOL};
    PyObject *items[1 + COLUMNS] = {PyFloat_FromDouble(score)};
    npy_intp dims[1] = {(npy_intp)got};
    int ok = items[0] != NULL;
    for (int j = 0; ok && j < COLUMNS; j++)
        ok = (items[1 + j] = PyArray_SimpleNew(1, dims, types[j])) != NULL;
    PyObject *result = ok ? PyStructSequence_New(&MatchType) : NULL;
    if (!result) {
        for (int j = 0; j < 1 + COLUMNS; j++)
            Py_XDECREF(items[j]);
        PyMem_Free(c);
        return NULL;
    }
    void *col[COLUMNS];
    for (int j = 0; j < COLUMNS; j++)
        col[j] = PyArray_DATA((PyArrayObject *)items[1 + j]);
    for (size_t i = 0; i < got; i++) {
        ((uint32_t *)col[0])[i] = c[i].feature_a;
        ((uint32_t *)col[1])[i] = c[i].feature_b;
        ((double *)col[2])[i] = c[i].distance;
        ((npy_bool *)col[3])[i] = c[i].from_a != 0;
        ((npy_bool *)col[4])[i] = c[i].verified != 0;
    }
    PyMem_Free(c);
    /* SET_ITEM steals: the items now belong to result. */
    for (int j = 0; j < 1 + COLUMNS; j++)
        PyStructSequence_SET_ITEM(result, j, items[j]);
    return result;
}

/* ---------------------------------------------------------------------
 * Database
 * --------------------------------------------------------------------- */
typedef struct DatabaseObject {
    PyObject_HEAD
    phks_db *db;   /* NULL once closed                                   */
    int busy;      /* calls running without the GIL; close() waits for 0 */
    PyObject *path;
} DatabaseObject;

static PyStructSequence_Field hit_fields[] = {
    {"id", "entry id"},
    {"name", "name (cut at 255 bytes; Database.get has it whole)"},
    {"label", "class label, '' for none (cut at 255 bytes)"},
    {"score", "phks.score(query, entry)"},
    {NULL, NULL}};
static PyStructSequence_Desc hit_desc = {"phks.Hit", "A query hit.",
                                         hit_fields, 4};

static PyStructSequence_Field entry_fields[] = {
    {"id", "entry id"},
    {"name", "name"},
    {"label", "class label, '' for none"},
    {"signature", "the stored phks.Signature (vertices None: no mesh)"},
    {NULL, NULL}};
static PyStructSequence_Desc entry_desc = {"phks.Entry", "A database entry.",
                                           entry_fields, 4};

/* The open handle, or NULL with ValueError (as for a closed file). */
static phks_db *db_open_handle(DatabaseObject *self)
{
    if (!self->db)
        PyErr_SetString(PyExc_ValueError, "database is closed");
    return self->db;
}

static int Database_init(DatabaseObject *self, PyObject *args,
                         PyObject *kwargs)
{
    static char *keywords[] = {"path", "readonly", "create", NULL};
    PyObject *path;
    int readonly = 0, create = 1;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "O&|pp:Database", keywords,
                                     PyUnicode_FSConverter, &path, &readonly,
                                     &create))
        return -1;
    if (self->db || self->busy) {
        Py_DECREF(path);
        PyErr_SetString(PyExc_RuntimeError, "Database is already open");
        return -1;
    }
    unsigned flags = readonly ? PHKS_DB_READONLY
                              : (create ? PHKS_DB_CREATE : 0u);
    phks_db *db = NULL;
    phks_status st;
    const char *p = PyBytes_AS_STRING(path);
    Py_BEGIN_ALLOW_THREADS
    st = phks_db_open(p, flags, &db);
    Py_END_ALLOW_THREADS
    if (st != PHKS_OK) {
        Py_DECREF(path);
        raise_status(st);
        return -1;
    }
    self->db = db;
    Py_XSETREF(self->path, PyUnicode_DecodeFSDefault(p));
    Py_DECREF(path);
    if (!self->path) {
        phks_db_close(self->db);
        self->db = NULL;
        return -1;
    }
    return 0;
}

static void Database_dealloc(DatabaseObject *self)
{
    /* No call can be running: each holds a reference to self. */
    phks_db_close(self->db);
    Py_XDECREF(self->path);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *Database_close(DatabaseObject *self, PyObject *unused)
{
    if (self->busy) {
        PyErr_SetString(PyExc_RuntimeError,
                        "database is in use by another thread");
        return NULL;
    }
    phks_db *db = self->db;
    self->db = NULL;
    Py_BEGIN_ALLOW_THREADS
    phks_db_close(db);
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

static PyObject *Database_enter(DatabaseObject *self, PyObject *unused)
{
    if (!db_open_handle(self))
        return NULL;
    Py_INCREF(self);
    return (PyObject *)self;
}

static PyObject *Database_exit(DatabaseObject *self, PyObject *args)
{
    PyObject *r = Database_close(self, NULL);
    if (!r)
        return NULL;
    Py_DECREF(r);
    Py_RETURN_FALSE; /* exceptions propagate */
}

/* A str as UTF-8 without NUL bytes (the library takes C strings), or NULL
 * for None when allowed. Returns 0 on success. */
static int utf8_arg(PyObject *obj, const char *what, int none_ok,
                    const char **out)
{
    *out = NULL;
    if (obj == Py_None && none_ok)
        return 0;
    if (!PyUnicode_Check(obj)) {
        PyErr_Format(PyExc_TypeError, "%s must be a str", what);
        return -1;
    }
    Py_ssize_t size;
    const char *s = PyUnicode_AsUTF8AndSize(obj, &size);
    if (!s)
        return -1;
    if ((size_t)size != strlen(s)) {
        PyErr_Format(PyExc_ValueError, "%s contains a NUL character", what);
        return -1;
    }
    *out = s;
    return 0;
}

static PyObject *Database_add(DatabaseObject *self, PyObject *args,
                              PyObject *kwargs)
{
    static char *keywords[] = {"name", "signature", "label", NULL};
    PyObject *name_obj, *label_obj = Py_None;
    const phks_signature *sig;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "OO&|O:add", keywords,
                                     &name_obj, signature_arg, &sig,
                                     &label_obj))
        return NULL;
    const char *name, *label;
    if (utf8_arg(name_obj, "name", 0, &name) < 0 ||
        utf8_arg(label_obj, "label", 1, &label) < 0)
        return NULL;
    phks_db *db = db_open_handle(self);
    if (!db)
        return NULL;
    int64_t id = 0;
    phks_status st;
    self->busy++;
    Py_BEGIN_ALLOW_THREADS /* one fsync per add */
    st = phks_db_add(db, name, label, sig, &id);
    Py_END_ALLOW_THREADS
    self->busy--;
    if (st != PHKS_OK)
        return raise_status(st);
    return PyLong_FromLongLong(id);
}

static PyObject *Database_add_batch(DatabaseObject *self, PyObject *arg)
{
    /* Each entry becomes a tuple held in items, so that the strings and
     * signatures the C array points into outlive the call. */
    PyObject *seq = PySequence_Fast(
        arg, "add_batch takes an iterable of (name, signature[, label])");
    if (!seq)
        return NULL;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
    PyObject *items = PyList_New(n);
    phks_db_entry *entries = PyMem_Malloc((n ? (size_t)n : 1) *
                                          sizeof *entries);
    int64_t *ids = PyMem_Malloc((n ? (size_t)n : 1) * sizeof *ids);
    PyObject *result = NULL;
    if (!items || !entries || !ids) {
        if (items)
            PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *t = PySequence_Tuple(PySequence_Fast_GET_ITEM(seq, i));
        if (!t)
            goto done;
        PyList_SET_ITEM(items, i, t);
        Py_ssize_t len = PyTuple_GET_SIZE(t);
        if (len != 2 && len != 3) {
            PyErr_Format(PyExc_ValueError,
                         "entry %zd: expected (name, signature[, label])", i);
            goto done;
        }
        const phks_signature *sig;
        if (!signature_arg(PyTuple_GET_ITEM(t, 1), &sig))
            goto done;
        if (utf8_arg(PyTuple_GET_ITEM(t, 0), "name", 0, &entries[i].name) <
                0 ||
            utf8_arg(len == 3 ? PyTuple_GET_ITEM(t, 2) : Py_None, "label", 1,
                     &entries[i].label) < 0)
            goto done;
        entries[i].signature = sig;
    }
    phks_db *db = db_open_handle(self);
    if (!db)
        goto done;
    if (n == 0) {
        result = PyList_New(0);
        goto done;
    }
    phks_status st;
    self->busy++;
    Py_BEGIN_ALLOW_THREADS
    st = phks_db_add_batch(db, entries, (size_t)n, ids);
    Py_END_ALLOW_THREADS
    self->busy--;
    if (st != PHKS_OK) {
        raise_status(st);
        goto done;
    }
    result = PyList_New(n);
    if (!result)
        goto done;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *id = PyLong_FromLongLong(ids[i]);
        if (!id) {
            Py_CLEAR(result);
            goto done;
        }
        PyList_SET_ITEM(result, i, id);
    }
done:
    PyMem_Free(entries);
    PyMem_Free(ids);
    Py_XDECREF(items);
    Py_DECREF(seq);
    return result;
}

static PyObject *Database_query(DatabaseObject *self, PyObject *args,
                                PyObject *kwargs)
{
    static char *keywords[] = {"signature", "k", NULL};
    const phks_signature *sig;
    Py_ssize_t k = 10;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "O&|n:query", keywords,
                                     signature_arg, &sig, &k))
        return NULL;
    if (k < 1) {
        PyErr_SetString(PyExc_ValueError, "k must be at least 1");
        return NULL;
    }
    phks_db *db = db_open_handle(self);
    if (!db)
        return NULL;
    /* Room for no more hits than entries: k may be huge. */
    size_t entries = 0;
    phks_status st = phks_db_count(db, &entries);
    if (st != PHKS_OK)
        return raise_status(st);
    if (entries == 0)
        return PyList_New(0);
    size_t room = (size_t)k < entries ? (size_t)k : entries;
    phks_hit *hits = PyMem_Malloc(room * sizeof *hits);
    if (!hits)
        return PyErr_NoMemory();
    size_t count = 0;
    self->busy++;
    Py_BEGIN_ALLOW_THREADS
    st = phks_db_query(db, sig, room, hits, &count);
    Py_END_ALLOW_THREADS
    self->busy--;
    if (st != PHKS_OK) {
        PyMem_Free(hits);
        return raise_status(st);
    }
    PyObject *list = PyList_New((Py_ssize_t)count);
    for (size_t i = 0; list && i < count; i++) {
        PyObject *hit = PyStructSequence_New(&HitType);
        PyObject *id = PyLong_FromLongLong(hits[i].id);
        PyObject *name = PyUnicode_DecodeUTF8(
            hits[i].name, (Py_ssize_t)strlen(hits[i].name), "replace");
        PyObject *label = PyUnicode_DecodeUTF8(
            hits[i].label, (Py_ssize_t)strlen(hits[i].label), "replace");
        PyObject *score = PyFloat_FromDouble(hits[i].score);
        if (!hit || !id || !name || !label || !score) {
            Py_XDECREF(hit);
            Py_XDECREF(id);
            Py_XDECREF(name);
            Py_XDECREF(label);
            Py_XDECREF(score);
            Py_CLEAR(list);
            break;
        }
        PyStructSequence_SET_ITEM(hit, 0, id);
        PyStructSequence_SET_ITEM(hit, 1, name);
        PyStructSequence_SET_ITEM(hit, 2, label);
        PyStructSequence_SET_ITEM(hit, 3, score);
        PyList_SET_ITEM(list, (Py_ssize_t)i, hit);
    }
    PyMem_Free(hits);
    return list;
}

static PyObject *Database_list(DatabaseObject *self, PyObject *unused)
{
    phks_db *db = db_open_handle(self);
    if (!db)
        return NULL;
    PyObject *list = PyList_New(0);
    if (!list)
        return NULL;
    int64_t page[1024], after = 0;
    for (;;) {
        size_t count = 0;
        phks_status st = phks_db_list(db, after, page,
                                      sizeof page / sizeof page[0], &count);
        if (st != PHKS_OK) {
            Py_DECREF(list);
            return raise_status(st);
        }
        for (size_t i = 0; i < count; i++) {
            PyObject *id = PyLong_FromLongLong(page[i]);
            if (!id || PyList_Append(list, id) < 0) {
                Py_XDECREF(id);
                Py_DECREF(list);
                return NULL;
            }
            Py_DECREF(id);
        }
        if (count < sizeof page / sizeof page[0])
            return list;
        after = page[count - 1];
    }
}

static PyObject *Database_get(DatabaseObject *self, PyObject *arg)
{
    long long id = PyLong_AsLongLong(arg);
    if (id == -1 && PyErr_Occurred())
        return NULL;
    phks_db *db = db_open_handle(self);
    if (!db)
        return NULL;
    /* Names are not limited in length: grow the buffers until they fit. */
    size_t capacity = PHKS_DB_TEXT_MAX + 1;
    for (;;) {
        char *name = PyMem_Malloc(capacity), *label = PyMem_Malloc(capacity);
        phks_signature *sig = NULL;
        phks_status st = PHKS_ERROR_OUT_OF_MEMORY;
        if (name && label)
            st = phks_db_get(db, (int64_t)id, &sig, name, capacity, label,
                             capacity);
        if (st == PHKS_ERROR_BUFFER_TOO_SMALL && capacity < ((size_t)1 << 30)) {
            PyMem_Free(name);
            PyMem_Free(label);
            capacity *= 4;
            continue;
        }
        if (!name || !label) {
            PyMem_Free(name);
            PyMem_Free(label);
            return PyErr_NoMemory();
        }
        if (st != PHKS_OK) {
            PyMem_Free(name);
            PyMem_Free(label);
            return raise_status(st);
        }
        PyObject *entry = PyStructSequence_New(&EntryType);
        PyObject *id_obj = PyLong_FromLongLong(id);
        PyObject *name_obj = PyUnicode_DecodeUTF8(name, (Py_ssize_t)strlen(name),
                                                  "replace");
        PyObject *label_obj = PyUnicode_DecodeUTF8(
            label, (Py_ssize_t)strlen(label), "replace");
        PyObject *sig_obj = signature_wrap(sig, NULL); /* frees on failure */
        PyMem_Free(name);
        PyMem_Free(label);
        if (!entry || !id_obj || !name_obj || !label_obj || !sig_obj) {
            Py_XDECREF(entry);
            Py_XDECREF(id_obj);
            Py_XDECREF(name_obj);
            Py_XDECREF(label_obj);
            Py_XDECREF(sig_obj);
            return NULL;
        }
        PyStructSequence_SET_ITEM(entry, 0, id_obj);
        PyStructSequence_SET_ITEM(entry, 1, name_obj);
        PyStructSequence_SET_ITEM(entry, 2, label_obj);
        PyStructSequence_SET_ITEM(entry, 3, sig_obj);
        return entry;
    }
}

static PyObject *Database_remove(DatabaseObject *self, PyObject *arg)
{
    long long id = PyLong_AsLongLong(arg);
    if (id == -1 && PyErr_Occurred())
        return NULL;
    phks_db *db = db_open_handle(self);
    if (!db)
        return NULL;
    phks_status st;
    self->busy++;
    Py_BEGIN_ALLOW_THREADS
    st = phks_db_remove(db, (int64_t)id);
    Py_END_ALLOW_THREADS
    self->busy--;
    if (st != PHKS_OK)
        return raise_status(st);
    Py_RETURN_NONE;
}

static Py_ssize_t Database_len(DatabaseObject *self)
{
    phks_db *db = db_open_handle(self);
    if (!db)
        return -1;
    size_t count = 0;
    phks_status st = phks_db_count(db, &count);
    if (st != PHKS_OK) {
        raise_status(st);
        return -1;
    }
    return (Py_ssize_t)count;
}

static PyObject *Database_get_closed(DatabaseObject *self, void *c)
{
    return PyBool_FromLong(self->db == NULL);
}

static PyObject *Database_repr(DatabaseObject *self)
{
    return PyUnicode_FromFormat("<phks.Database %R%s>",
                                self->path ? self->path : Py_None,
                                self->db ? "" : " (closed)");
}

static PyMethodDef Database_methods[] = {
    {"add", (PyCFunction)(void (*)(void))Database_add,
     METH_VARARGS | METH_KEYWORDS,
     "add(name, signature, label=None) -> id"},
    {"add_batch", (PyCFunction)Database_add_batch, METH_O,
     "add_batch(entries) -> [id, ...]: (name, signature[, label]) tuples in "
     "one transaction: all are added or none."},
    {"query", (PyCFunction)(void (*)(void))Database_query,
     METH_VARARGS | METH_KEYWORDS,
     "query(signature, k=10) -> [Hit, ...]: the k lowest scores, best "
     "first, ties to the lower id; with matching 'verified' among the "
     "max(k, 100) entries of lowest score_nearest."},
    {"list", (PyCFunction)Database_list, METH_NOARGS,
     "list() -> [id, ...], ascending."},
    {"get", (PyCFunction)Database_get, METH_O,
     "get(id) -> Entry(id, name, label, signature)."},
    {"remove", (PyCFunction)Database_remove, METH_O, "remove(id)"},
    {"close", (PyCFunction)Database_close, METH_NOARGS,
     "close(): closes the file; further calls raise ValueError."},
    {"__enter__", (PyCFunction)Database_enter, METH_NOARGS, NULL},
    {"__exit__", (PyCFunction)Database_exit, METH_VARARGS, NULL},
    {NULL, NULL, 0, NULL}};

static PyMemberDef Database_members[] = {
    {"path", T_OBJECT, offsetof(DatabaseObject, path), READONLY,
     "The path it was opened with."},
    {NULL, 0, 0, 0, NULL}};

static PyGetSetDef Database_getset[] = {
    {"closed", (getter)Database_get_closed, NULL, "True after close().",
     NULL},
    {NULL, NULL, NULL, NULL, NULL}};

static PySequenceMethods Database_as_sequence = {
    .sq_length = (lenfunc)Database_len,
};

static PyTypeObject DatabaseType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "phks.Database",
    .tp_basicsize = sizeof(DatabaseObject),
    .tp_dealloc = (destructor)Database_dealloc,
    .tp_repr = (reprfunc)Database_repr,
    .tp_as_sequence = &Database_as_sequence,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Database(path, readonly=False, create=True)\n\n"
              "A shape database in one SQLite file (':memory:' for a "
              "private one). A context manager: closes on exit. len() is "
              "the entry count.",
    .tp_methods = Database_methods,
    .tp_members = Database_members,
    .tp_getset = Database_getset,
    .tp_init = (initproc)Database_init,
    .tp_new = PyType_GenericNew,
};

/* ---------------------------------------------------------------------
 * The module
 * --------------------------------------------------------------------- */
static PyObject *py_status_string(PyObject *module, PyObject *arg)
{
    long v = PyLong_AsLong(arg);
    if (v == -1 && PyErr_Occurred())
        return NULL;
    if (v < INT_MIN || v > INT_MAX)
        v = -1;
    return PyUnicode_FromString(phks_status_string((phks_status)v));
}

static PyMethodDef module_methods[] = {
    {"load", py_load, METH_VARARGS,
     "load(path) -> Mesh: OFF, OBJ, PLY or STL, optionally gzipped; other "
     "formats (glTF/GLB, FBX, COLLADA, ...) through assimp when built with "
     "it, all meshes merged."},
    {"_has_assimp", py_has_assimp, METH_NOARGS,
     "_has_assimp() -> bool: whether load() reads formats through assimp."},
    {"load_memory", (PyCFunction)(void (*)(void))py_load_memory,
     METH_VARARGS | METH_KEYWORDS,
     "load_memory(data, format='auto') -> Mesh: a mesh file's bytes; format "
     "'auto', 'off', 'obj', 'ply' or 'stl'."},
    {"signature", (PyCFunction)(void (*)(void))py_signature,
     METH_VARARGS | METH_KEYWORDS,
     "signature(mesh, progress=None, **options) -> Signature"},
    {"spectrum", (PyCFunction)(void (*)(void))py_spectrum,
     METH_VARARGS | METH_KEYWORDS,
     "spectrum(mesh, progress=None, **options) -> Spectrum"},
    {"decode", (PyCFunction)(void (*)(void))py_decode,
     METH_VARARGS | METH_KEYWORDS,
     "decode(data, mesh=None) -> Signature (as Signature.decode)."},
    {"persistent_maxima", (PyCFunction)(void (*)(void))py_persistent_maxima,
     METH_VARARGS | METH_KEYWORDS,
     "persistent_maxima(mesh, f, max_count=15, threshold=0.0) -> Maxima: "
     "region merging of the triangles for the vertex function f."},
    {"geodesic_distances", (PyCFunction)(void (*)(void))py_geodesic_distances,
     METH_VARARGS | METH_KEYWORDS,
     "geodesic_distances(mesh, source, **options) -> (vertex_count,) "
     "float64: distances along the mesh's edges from vertex source, in "
     "input units; inf where a piece stays out of reach."},
    {"score", py_score, METH_VARARGS,
     "score(query, entry) -> float: lower is more similar; with matching "
     "'verified' (the default) asymmetric, in [0, 1]."},
    {"score_nearest", py_score_nearest, METH_VARARGS,
     "score_nearest(a, b) -> float: the paper's symmetric sum of nearest L1 "
     "distances, whatever the matching (a query's fast first stage)."},
    {"match", py_match, METH_VARARGS,
     "match(a, b) -> Match(score, feature_a, feature_b, distance, from_a, "
     "verified)."},
    {"default_options", py_default_options, METH_NOARGS,
     "default_options() -> dict: the library's defaults as keyword "
     "arguments."},
    {"status_string", py_status_string, METH_O,
     "status_string(status) -> str: the library's description."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module_def = {
    PyModuleDef_HEAD_INIT,
    .m_name = "phks._phks",
    .m_doc = "libphks bindings; use the phks package.",
    .m_size = -1,
    .m_methods = module_methods,
};

static int add_type(PyObject *module, const char *name, PyTypeObject *type)
{
    Py_INCREF(type);
    if (PyModule_AddObject(module, name, (PyObject *)type) < 0) {
        Py_DECREF(type);
        return -1;
    }
    return 0;
}

static int add_object(PyObject *module, const char *name, PyObject *obj)
{
    Py_INCREF(obj);
    if (PyModule_AddObject(module, name, obj) < 0) {
        Py_DECREF(obj);
        return -1;
    }
    return 0;
}

PyMODINIT_FUNC PyInit__phks(void);

PyMODINIT_FUNC PyInit__phks(void)
{
    import_array();
    if (PyType_Ready(&MeshType) < 0 || PyType_Ready(&SignatureType) < 0 ||
        PyType_Ready(&SpectrumType) < 0 || PyType_Ready(&DatabaseType) < 0)
        return NULL;
    /* Static types and exceptions live as long as the process: a second
     * init (a re-import after deletion from sys.modules) reuses them. */
    if (!MaximaType.tp_name &&
        (PyStructSequence_InitType2(&MaximaType, &maxima_desc) < 0 ||
         PyStructSequence_InitType2(&MatchType, &match_desc) < 0 ||
         PyStructSequence_InitType2(&HitType, &hit_desc) < 0 ||
         PyStructSequence_InitType2(&EntryType, &entry_desc) < 0))
        return NULL;
    if (!Error) {
        Error = PyErr_NewExceptionWithDoc(
            "phks.Error",
            "A libphks failure: .status (a phks.Status) and .message (the "
            "library's detail).",
            PyExc_RuntimeError, NULL);
        if (!Error)
            return NULL;
    }
    if (!StatusEnum && !(StatusEnum = make_int_enum("Status", status_names)))
        return NULL;
    if (!StageEnum && !(StageEnum = make_int_enum("Stage", stage_names)))
        return NULL;

    PyObject *m = PyModule_Create(&module_def);
    if (!m)
        return NULL;
    if (add_type(m, "Mesh", &MeshType) < 0 ||
        add_type(m, "Signature", &SignatureType) < 0 ||
        add_type(m, "Spectrum", &SpectrumType) < 0 ||
        add_type(m, "Database", &DatabaseType) < 0 ||
        add_type(m, "Maxima", &MaximaType) < 0 ||
        add_type(m, "Match", &MatchType) < 0 ||
        add_type(m, "Hit", &HitType) < 0 ||
        add_type(m, "Entry", &EntryType) < 0 ||
        add_object(m, "Error", Error) < 0 ||
        add_object(m, "Status", StatusEnum) < 0 ||
        add_object(m, "Stage", StageEnum) < 0 ||
        PyModule_AddStringConstant(m, "library_version",
                                   phks_version_string()) < 0 ||
        PyModule_AddIntConstant(m, "MAX_SCALES", PHKS_MAX_SCALES) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
