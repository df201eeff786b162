/*
 * match.c - comparing two signatures: phks.score, phks.score_nearest,
 * phks.similarity (what a score means) and phks.match, the score with its
 * correspondences.
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

static PyObject *py_similarity(PyObject *module, PyObject *args)
{
    const phks_signature *a, *b;
    if (!PyArg_ParseTuple(args, "O&O&:similarity", signature_arg, &a,
                          signature_arg, &b))
        return NULL;
    double similarity;
    size_t verified;
    phks_status st = phks_similarity(a, b, &similarity, &verified);
    if (st != PHKS_OK)
        return raise_status(st);
    return Py_BuildValue("(dn)", similarity, (Py_ssize_t)verified);
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
    {"similarity", "phks.similarity(a, b)[0]: in [0, 1], 1 for a "
                   "signature against itself (attribute only)"},
    {"verified_count", "how many of a's features are verified, of "
                       "len(a.features): phks.similarity(a, b)[1] "
                       "(attribute only)"},
    {NULL, NULL}};
static PyStructSequence_Desc match_desc = {
    "phks.Match",
    "The score and its pairs: one per feature of a (its verified partner, "
    "or its nearest feature of b), then one per feature of b (its nearest "
    "feature of a). similarity and verified_count are attributes, not items: "
    "a Match unpacks to its six items as before 0.3.0.",
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
    double similarity = 0;
    size_t verified = 0;
    if (st == PHKS_OK)
        st = phks_similarity(a, b, &similarity, &verified);
    if (st != PHKS_OK) {
        PyMem_Free(c);
        return raise_status(st);
    }
    /* score, one array per column of the correspondences, then the two
     * attributes. */
    enum { COLUMNS = 5, ITEMS = 1 + COLUMNS + 2 };
    static const int types[COLUMNS] = {NPY_UINT32, NPY_UINT32, NPY_DOUBLE,
                                       NPY_BOOL, NPY_BOOL};
    PyObject *items[ITEMS] = {PyFloat_FromDouble(score)};
    items[1 + COLUMNS] = PyFloat_FromDouble(similarity);
    items[2 + COLUMNS] = PyLong_FromSize_t(verified);
    npy_intp dims[1] = {(npy_intp)got};
    int ok = items[0] && items[1 + COLUMNS] && items[2 + COLUMNS];
    for (int j = 0; ok && j < COLUMNS; j++)
        ok = (items[1 + j] = PyArray_SimpleNew(1, dims, types[j])) != NULL;
    PyObject *result = ok ? PyStructSequence_New(&MatchType) : NULL;
    if (!result) {
        for (int j = 0; j < ITEMS; j++)
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
    for (int j = 0; j < ITEMS; j++)
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
    {"similarity", py_similarity, METH_VARARGS,
     "similarity(query, entry) -> (float, int): a similarity in [0, 1] (1 "
     "for a signature against itself; with matching 'verified' the share of "
     "the query the verified set explains, 1 - score / score_nearest) and "
     "how many of the query's features are verified (0 with 'nearest'). "
     "docs/method.md, 'What a score means'."},
    {"match", py_match, METH_VARARGS,
     "match(a, b) -> Match(score, feature_a, feature_b, distance, from_a, "
     "verified), with the attributes similarity and verified_count."},
    {NULL, NULL, 0, NULL}};

int match_add_to_module(PyObject *module)
{
    if (add_struct_sequence(module, "Match", &MatchType, &match_desc) < 0)
        return -1;
    return PyModule_AddFunctions(module, match_functions);
}
