/*
 * match.c - comparing two signatures: phks.score, phks.score_nearest and
 * phks.match, the score with its correspondences.
 */
#include "phks_python.h"

static PyTypeObject MatchType;

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

static PyMethodDef match_functions[] = {
    {"score", py_score, METH_VARARGS,
     "score(query, entry) -> float: 0 or more, lower is more similar (no "
     "upper bound: include/phks.h); with matching 'verified' (the default) "
     "asymmetric."},
    {"score_nearest", py_score_nearest, METH_VARARGS,
     "score_nearest(a, b) -> float: the paper's symmetric sum of nearest L1 "
     "distances, whatever the matching (a query's fast first stage)."},
    {"match", py_match, METH_VARARGS,
     "match(a, b) -> Match(score, feature_a, feature_b, distance, from_a, "
     "verified)."},
    {NULL, NULL, 0, NULL}};

int match_add_to_module(PyObject *module)
{
    if (add_struct_sequence(module, "Match", &MatchType, &match_desc) < 0)
        return -1;
    return PyModule_AddFunctions(module, match_functions);
}
