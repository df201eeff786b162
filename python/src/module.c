/*
 * module.c - phks._phks, the CPython extension module under the phks
 * package: libphks's public API (include/phks.h, nothing else) with numpy
 * arrays in and out; phks/__init__.py re-exports everything here. This
 * file makes the module from the other files' parts, and holds what they
 * all raise: phks.Error, phks.Status and phks.Stage.
 */
#define PHKS_PYTHON_IMPORTS_NUMPY
#include "phks_python.h"

#include <limits.h>
#include <string.h>

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

PyObject *raise_status_detail(phks_status status, const char *detail)
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

PyObject *raise_status(phks_status status)
{
    return raise_status_detail(status, phks_last_error_message());
}

PyObject *raise_status_format(phks_status status, const char *format, ...)
{
    char buffer[256];
    va_list ap;
    va_start(ap, format);
    PyOS_vsnprintf(buffer, sizeof buffer, format, ap);
    va_end(ap);
    return raise_status_detail(status, buffer);
}

PyObject *stage_member(phks_stage stage)
{
    return enum_member(StageEnum, (int)stage);
}

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

int add_object(PyObject *module, const char *name, PyObject *obj)
{
    Py_INCREF(obj);
    if (PyModule_AddObject(module, name, obj) < 0) {
        Py_DECREF(obj);
        return -1;
    }
    return 0;
}

int add_type(PyObject *module, const char *name, PyTypeObject *type)
{
    if (PyType_Ready(type) < 0)
        return -1;
    return add_object(module, name, (PyObject *)type);
}

int add_struct_sequence(PyObject *module, const char *name,
                        PyTypeObject *type, PyStructSequence_Desc *desc)
{
    /* Static types live as long as the process: a second init (a
     * re-import after deletion from sys.modules) reuses them. */
    if (!type->tp_name && PyStructSequence_InitType2(type, desc) < 0)
        return -1;
    return add_object(module, name, (PyObject *)type);
}

/* The exception and the enums live as long as the process: a second init
 * (a re-import after deletion from sys.modules) reuses them. */
static int make_errors_and_enums(void)
{
    if (!Error) {
        Error = PyErr_NewExceptionWithDoc(
            "phks.Error",
            "A libphks failure: .status (a phks.Status) and .message (the "
            "library's detail).",
            PyExc_RuntimeError, NULL);
        if (!Error)
            return -1;
    }
    if (!StatusEnum && !(StatusEnum = make_int_enum("Status", status_names)))
        return -1;
    if (!StageEnum && !(StageEnum = make_int_enum("Stage", stage_names)))
        return -1;
    return 0;
}

/* Each file adds its own types and functions. */
static int add_parts(PyObject *m)
{
    return mesh_add_to_module(m) < 0 || signature_add_to_module(m) < 0 ||
                   spectrum_add_to_module(m) < 0 ||
                   surface_add_to_module(m) < 0 ||
                   match_add_to_module(m) < 0 ||
                   database_add_to_module(m) < 0 ||
                   options_add_to_module(m) < 0
               ? -1
               : 0;
}

PyMODINIT_FUNC PyInit__phks(void);

PyMODINIT_FUNC PyInit__phks(void)
{
    import_array();
    if (make_errors_and_enums() < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module_def);
    if (!m)
        return NULL;
    if (add_parts(m) < 0 || add_object(m, "Error", Error) < 0 ||
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
