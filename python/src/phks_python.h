/*
 * phks_python.h - what the files of phks._phks share: the Python objects
 * that wrap a handle, the errors, the options from keyword arguments, the
 * one way a long library call is made (call.c), and each file's part of
 * the module. Internal to the module; docs/python.md is the tour.
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
#ifndef PHKS_PYTHON_H
#define PHKS_PYTHON_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

/* numpy's C API is one table of pointers, filled by import_array() in
 * module.c and shared by name with the other files. */
#define PY_ARRAY_UNIQUE_SYMBOL phks_python_numpy_api
#ifndef PHKS_PYTHON_IMPORTS_NUMPY
#define NO_IMPORT_ARRAY
#endif
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <stdint.h>

#include "phks.h"

/* ---- The wrapped handles */

typedef struct MeshObject {
    PyObject_HEAD
    phks_mesh *mesh;
} MeshObject;

typedef struct SignatureObject {
    PyObject_HEAD
    phks_signature *sig;
    /* Feature vertices in the caller's numbering (uint32 array), or NULL
     * when unknown: a decoded signature knows only the cleaned mesh's. */
    PyObject *caller_vertices;
} SignatureObject;

extern PyTypeObject MeshType, SignatureType;

/* Wraps a new handle; frees it if the wrapper cannot be made. */
PyObject *mesh_wrap(phks_mesh *mesh);

/* Wraps a new handle; with mesh, maps its feature vertices back through
 * the mesh's vertex_origin. Frees sig if anything fails. */
PyObject *signature_wrap(phks_signature *sig, const phks_mesh *mesh);

/* A PyArg "O&" converter: a phks.Signature argument to its handle. */
int signature_arg(PyObject *obj, void *out);

/* A read-only array over memory owned by a handle, kept alive by owner
 * (the Python object holding the handle). NULL data (a count of 0) gives
 * an empty array. */
PyObject *view_array(PyObject *owner, const void *data, int nd,
                     npy_intp *dims, int type);

/* ---- Errors and enumerations (module.c) */

/* Raises phks.Error(status, detail): str() is "<status string>: <detail>",
 * .status the Status member, .message the detail alone. Always NULL. */
PyObject *raise_status_detail(phks_status status, const char *detail);

/* Raises phks.Error for a status a library call just returned, with the
 * calling thread's message (valid until its next failing call, so this is
 * called before any other phks function). */
PyObject *raise_status(phks_status status);

/* Raises phks.Error for a problem this module finds itself before calling
 * the library, where the library would report the same status. */
PyObject *raise_status_format(phks_status status, const char *format, ...);

/* The phks.Stage member for stage, or a plain int for one a newer library
 * appended. */
PyObject *stage_member(phks_stage stage);

/* ---- Options as keyword arguments (options.c) */

/* A count (an int, never a float: 1.5 would silently become 1) in
 * 0..UINT32_MAX; what names the argument in messages. */
int parse_u32(PyObject *value, const char *what, uint32_t *out);

/* An enum given as one of names (exact, NULL-terminated) or as an int. */
int parse_enum(PyObject *value, const char *what, const char *const *names,
               int32_t *out);

/* progress: a callable or None, into *progress (a new reference; left as
 * it was for None). */
int parse_progress(PyObject *value, PyObject **progress);

/* Fills *o from phks_options_init and the keyword arguments, each named as
 * in the library's option table (PHKS_SPELLING_C), and progress, a callable
 * or None, into *progress (a new reference or NULL). Unknown keywords are
 * a TypeError, as for any Python function. */
int parse_options(PyObject *kwargs, phks_options *o, PyObject **progress);

/* The options as a dict of keyword arguments (enums by name), which
 * phks.signature(mesh, **d) accepts back. */
PyObject *options_to_dict(const phks_options *o);

/* ---- The binding sequence (call.c) */

/* A library call that may take long, made without the GIL: it reads the
 * options (with the module's progress callback in them) and its own
 * arguments and results through args. */
typedef phks_status (*long_call)(const phks_options *options, void *args);

/* Runs call(options, args) without the GIL, with progress (a callable or
 * NULL; the reference is taken) called back under the GIL and Ctrl-C
 * cancelling it. Returns 0, or -1 with what cancelled it (an exception the
 * callback raised, KeyboardInterrupt) or phks.Error raised. */
int run_long_call(phks_options options, PyObject *progress, long_call call,
                  void *args);

/* parse_options, then run_long_call: the keyword arguments' options are
 * left in *options (without the progress callback). */
int run_long_call_with_kwargs(PyObject *kwargs, phks_options *options,
                              long_call call, void *args);

/* ---- Each file's part of the module: its types and functions */

int mesh_add_to_module(PyObject *module);
int signature_add_to_module(PyObject *module);
int spectrum_add_to_module(PyObject *module);
int surface_add_to_module(PyObject *module);
int match_add_to_module(PyObject *module);
int database_add_to_module(PyObject *module);
int options_add_to_module(PyObject *module);

/* Adds obj to module as name (a new reference the module keeps). */
int add_object(PyObject *module, const char *name, PyObject *obj);

/* Readies a static type and adds it as name. */
int add_type(PyObject *module, const char *name, PyTypeObject *type);

/* Makes a struct sequence type from desc, once, and adds it as name. */
int add_struct_sequence(PyObject *module, const char *name,
                        PyTypeObject *type, PyStructSequence_Desc *desc);

#endif
