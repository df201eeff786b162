/*
 * options.c - phks_options as Python keyword arguments and back, through
 * the library's one table of option names (phks.h, "Option names") in
 * PHKS_SPELLING_C, which is Python's: operator_kind="random_walk". The
 * module keeps no names of its own; it only turns Python values into the
 * text phks_option_set reads (enums as a name or an int, counts as ints,
 * reals as floats, scales as a sequence) and phks_option_format's text
 * back into Python values.
 */
#include "phks_python.h"

#include <string.h>

/* The type of a known option (index from phks_option_find or below
 * phks_option_name's first NULL, so the call cannot fail). */
static phks_option_type type_of(uint32_t index)
{
    phks_option_type type = PHKS_OPTION_REAL;
    phks_option_type_of(index, &type);
    return type;
}

/* Enough for PHKS_MAX_SCALES reals of 17 digits, signs and exponents. */
#define OPTION_TEXT_MAX (PHKS_MAX_SCALES * 32)

/* ---------------------------------------------------------------------
 * Python values to the table's text
 * --------------------------------------------------------------------- */

int parse_enum(PyObject *value, const char *what, const char *const *names,
               int32_t *out)
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

int parse_u32(PyObject *value, const char *what, uint32_t *out)
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

/* An enum option: its value names from the table, by value. */
static int enum_text(PyObject *value, uint32_t index, const char *name,
                     char *text, size_t size)
{
    const char *names[16];
    int32_t n = 0;
    while (n < 15 &&
           (names[n] = phks_option_value_name(index, n, PHKS_SPELLING_C)))
        n++;
    names[n] = NULL;
    int32_t e;
    if (parse_enum(value, name, names, &e) < 0)
        return -1;
    PyOS_snprintf(text, size, "%ld", (long)e);
    return 0;
}

/* A real as digits that read back to the same double. */
static int real_text(PyObject *value, char *text, size_t size)
{
    double d = PyFloat_AsDouble(value);
    if (d == -1 && PyErr_Occurred())
        return -1;
    /* repr's digits, with a '.' whatever the locale (PyOS_snprintf would
     * follow LC_NUMERIC, and a decimal comma splits the scales). */
    char *repr = PyOS_double_to_string(d, 'r', 0, 0, NULL);
    if (!repr)
        return -1;
    PyOS_snprintf(text, size, "%s", repr);
    PyMem_Free(repr);
    return 0;
}

/* scales: a sequence of 1..PHKS_MAX_SCALES numbers, separated by commas. */
static int scales_text(PyObject *value, char *text, size_t size)
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
    size_t used = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        if (i)
            text[used++] = ',';
        if (real_text(PySequence_Fast_GET_ITEM(seq, i), text + used,
                      size - used) < 0) {
            Py_DECREF(seq);
            return -1;
        }
        used += strlen(text + used);
    }
    Py_DECREF(seq);
    return 0;
}

/* The text phks_option_set reads for value, as the option's kind takes a
 * Python value. */
static int option_text(PyObject *value, uint32_t index, const char *name,
                       char *text, size_t size)
{
    uint32_t count;
    switch (type_of(index)) {
    case PHKS_OPTION_ENUM:
        return enum_text(value, index, name, text, size);
    case PHKS_OPTION_COUNT:
        if (parse_u32(value, name, &count) < 0)
            return -1;
        PyOS_snprintf(text, size, "%lu", (unsigned long)count);
        return 0;
    case PHKS_OPTION_REALS:
        return scales_text(value, text, size);
    case PHKS_OPTION_REAL:
    default:
        return real_text(value, text, size);
    }
}

/* Sets the option named by the keyword name; the library checks the value
 * and names the option when it refuses it (phks.Error). */
static int set_option(phks_options *o, const char *name, PyObject *value)
{
    uint32_t index;
    if (phks_option_find(name, PHKS_SPELLING_C, &index) != PHKS_OK) {
        PyErr_Format(PyExc_TypeError, "unknown option '%s'", name);
        return -1;
    }
    char text[OPTION_TEXT_MAX];
    if (option_text(value, index, name, text, sizeof text) < 0)
        return -1;
    phks_status st = phks_option_set(o, index, text, PHKS_SPELLING_C);
    if (st != PHKS_OK) {
        raise_status(st);
        return -1;
    }
    return 0;
}

int parse_progress(PyObject *value, PyObject **progress)
{
    if (value == Py_None)
        return 0;
    if (!PyCallable_Check(value)) {
        PyErr_SetString(PyExc_TypeError, "progress must be callable or None");
        return -1;
    }
    Py_INCREF(value);
    Py_XSETREF(*progress, value);
    return 0;
}

/* scale_count next to scales must agree with it: scales sets it. */
static int check_scale_count(const phks_options *o, PyObject *value)
{
    uint32_t count;
    if (parse_u32(value, "scale_count", &count) < 0)
        return -1;
    if (count != o->scale_count) {
        PyErr_SetString(PyExc_ValueError,
                        "scale_count differs from len(scales)");
        return -1;
    }
    return 0;
}

/* One keyword argument into *o or *progress. */
static int parse_keyword(const char *name, PyObject *value, int has_scales,
                         phks_options *o, PyObject **progress)
{
    if (strcmp(name, "scales") == 0) /* set first, by parse_options */
        return 0;
    if (strcmp(name, "progress") == 0)
        return parse_progress(value, progress);
    if (has_scales && strcmp(name, "scale_count") == 0)
        return check_scale_count(o, value);
    return set_option(o, name, value);
}

int parse_options(PyObject *kwargs, phks_options *o, PyObject **progress)
{
    *progress = NULL;
    phks_options_init(o);
    if (!kwargs)
        return 0;
    PyObject *scales = PyDict_GetItemString(kwargs, "scales");
    if (scales && set_option(o, "scales", scales) < 0)
        return -1;
    PyObject *key, *value;
    Py_ssize_t pos = 0;
    while (PyDict_Next(kwargs, &pos, &key, &value)) {
        const char *name = PyUnicode_AsUTF8(key);
        if (!name ||
            parse_keyword(name, value, scales != NULL, o, progress) < 0) {
            Py_CLEAR(*progress);
            return -1;
        }
    }
    return 0;
}

/* ---------------------------------------------------------------------
 * The table's text back to Python values
 * --------------------------------------------------------------------- */

/* scales' "a,b,c" as a tuple of floats. */
static PyObject *scales_value(const char *text)
{
    PyObject *list = PyList_New(0);
    for (const char *p = text; list && *p;) {
        char *end;
        double x = PyOS_string_to_double(p, &end, NULL);
        PyObject *item = x == -1 && PyErr_Occurred() ? NULL
                                                     : PyFloat_FromDouble(x);
        if (!item || PyList_Append(list, item) < 0)
            Py_CLEAR(list);
        Py_XDECREF(item);
        p = *end == ',' ? end + 1 : end;
    }
    if (!list)
        return NULL;
    PyObject *tuple = PyList_AsTuple(list);
    Py_DECREF(list);
    return tuple;
}

/* Option index of o as the value its keyword takes. */
static PyObject *option_value(const phks_options *o, uint32_t index)
{
    char text[OPTION_TEXT_MAX];
    phks_status st =
        phks_option_format(o, index, PHKS_SPELLING_C, text, sizeof text);
    if (st != PHKS_OK)
        return raise_status(st);
    switch (type_of(index)) {
    case PHKS_OPTION_ENUM:
        return PyUnicode_FromString(text);
    case PHKS_OPTION_COUNT:
        return PyLong_FromString(text, NULL, 10);
    case PHKS_OPTION_REALS:
        return scales_value(text);
    case PHKS_OPTION_REAL:
    default: {
        double x = PyOS_string_to_double(text, NULL, NULL);
        return x == -1 && PyErr_Occurred() ? NULL : PyFloat_FromDouble(x);
    }
    }
}

PyObject *options_to_dict(const phks_options *o)
{
    PyObject *d = PyDict_New();
    const char *name;
    for (uint32_t i = 0;
         d && (name = phks_option_name(i, PHKS_SPELLING_C)) != NULL; i++) {
        PyObject *v = option_value(o, i);
        if (!v || PyDict_SetItemString(d, name, v) < 0)
            Py_CLEAR(d);
        Py_XDECREF(v);
    }
    return d;
}

static PyObject *py_default_options(PyObject *self, PyObject *unused)
{
    phks_options o;
    phks_options_init(&o);
    return options_to_dict(&o);
}

static PyMethodDef options_functions[] = {
    {"default_options", py_default_options, METH_NOARGS,
     "default_options() -> dict: the library's defaults as keyword "
     "arguments."},
    {NULL, NULL, 0, NULL}};

int options_add_to_module(PyObject *module)
{
    return PyModule_AddFunctions(module, options_functions);
}
