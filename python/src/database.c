/*
 * database.c - phks.Database, a shape database in one SQLite file: opening
 * and closing it (a context manager), and its entries added, queried,
 * listed, read and removed.
 */
#include "phks_python.h"

#include <stddef.h>
#include <string.h>
#include <structmember.h>

static PyTypeObject HitType, EntryType;

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
    {"similarity", "phks.similarity(query, entry)[0], in [0, 1] "
                   "(attribute only)"},
    {"verified", "how many of the query's features are verified in the "
                 "entry: phks.similarity(query, entry)[1] (attribute only)"},
    {NULL, NULL}};
static PyStructSequence_Desc hit_desc = {
    "phks.Hit",
    "A query hit: (id, name, label, score), with the attributes similarity "
    "and verified.",
    hit_fields, 4};

/* What a reader weighs a hit's score by (phks_similarity). */
typedef struct hit_weight {
    double similarity;
    size_t verified;
} hit_weight;

/* The weights of count hits of query: each entry read back and compared
 * once more (as many verifications again as the query's re-ranking). */
static phks_status weigh_hits(phks_db *db, const phks_signature *query,
                              const phks_hit *hits, size_t count,
                              hit_weight *w)
{
    phks_status st = PHKS_OK;
    for (size_t i = 0; st == PHKS_OK && i < count; i++)
        st = phks_db_similarity(db, query, hits[i].id, &w[i].similarity,
                                &w[i].verified);
    return st;
}

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

/* The handle and the entry id arg names, or NULL with the exception. */
static phks_db *db_and_id(DatabaseObject *self, PyObject *arg, int64_t *id)
{
    long long v = PyLong_AsLongLong(arg);
    if (v == -1 && PyErr_Occurred())
        return NULL;
    *id = (int64_t)v;
    return db_open_handle(self);
}

/* A name or label the library gives, as str: they need not be UTF-8. */
static PyObject *text_of(const char *s)
{
    return PyUnicode_DecodeUTF8(s, (Py_ssize_t)strlen(s), "replace");
}

/* A Hit or an Entry of the four fields (references stolen, also on
 * failure); NULL when a field is (its exception is set). */
static PyObject *record_of(PyTypeObject *type, PyObject *fields[4])
{
    PyObject *record = NULL;
    if (fields[0] && fields[1] && fields[2] && fields[3])
        record = PyStructSequence_New(type);
    for (Py_ssize_t i = 0; i < 4; i++) {
        if (record)
            PyStructSequence_SET_ITEM(record, i, fields[i]);
        else
            Py_XDECREF(fields[i]);
    }
    return record;
}

/* phks_db_open's failure, its message in Python's terms: the library
 * names its C flag ("cannot open (missing? PHKS_DB_CREATE makes it)"),
 * Python's users know the keywords. */
static PyObject *raise_open_error(phks_status status, int readonly)
{
    static const char flag[] = "PHKS_DB_CREATE";
    const char *keyword = readonly ? "create=True without readonly=True"
                                   : "create=True";
    const char *msg = phks_last_error_message();
    const char *at = msg ? strstr(msg, flag) : NULL;
    if (!at)
        return raise_status(status);
    size_t size = strlen(msg) + strlen(keyword) + 1;
    char *reworded = PyMem_Malloc(size);
    if (!reworded)
        return PyErr_NoMemory();
    snprintf(reworded, size, "%.*s%s%s", (int)(at - msg), msg, keyword,
             at + strlen(flag));
    raise_status_detail(status, reworded);
    PyMem_Free(reworded);
    return NULL;
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
        raise_open_error(st, readonly);
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
    hit_weight *w = hits ? PyMem_Malloc(room * sizeof *w) : NULL;
    if (!w) {
        PyMem_Free(hits);
        return PyErr_NoMemory();
    }
    size_t count = 0;
    self->busy++;
    Py_BEGIN_ALLOW_THREADS
    st = phks_db_query(db, sig, room, hits, &count);
    if (st == PHKS_OK)
        st = weigh_hits(db, sig, hits, count, w);
    Py_END_ALLOW_THREADS
    self->busy--;
    if (st != PHKS_OK) {
        PyMem_Free(w);
        PyMem_Free(hits);
        return raise_status(st);
    }
    PyObject *list = PyList_New((Py_ssize_t)count);
    for (size_t i = 0; list && i < count; i++) {
        PyObject *fields[4] = {PyLong_FromLongLong(hits[i].id),
                               text_of(hits[i].name), text_of(hits[i].label),
                               PyFloat_FromDouble(hits[i].score)};
        PyObject *hit = record_of(&HitType, fields);
        PyObject *similarity = hit ? PyFloat_FromDouble(w[i].similarity)
                                   : NULL;
        PyObject *verified = similarity ? PyLong_FromSize_t(w[i].verified)
                                        : NULL;
        if (!verified) {
            Py_XDECREF(similarity);
            Py_XDECREF(hit);
            Py_CLEAR(list);
            break;
        }
        PyStructSequence_SET_ITEM(hit, 4, similarity);
        PyStructSequence_SET_ITEM(hit, 5, verified);
        PyList_SET_ITEM(list, (Py_ssize_t)i, hit);
    }
    PyMem_Free(w);
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
    int64_t id;
    phks_db *db = db_and_id(self, arg, &id);
    if (!db)
        return NULL;
    /* Names are not limited in length: grow the buffers until they fit. */
    size_t capacity = PHKS_DB_TEXT_MAX + 1;
    for (;;) {
        char *name = PyMem_Malloc(capacity), *label = PyMem_Malloc(capacity);
        phks_signature *sig = NULL;
        phks_status st = PHKS_ERROR_OUT_OF_MEMORY;
        if (name && label)
            st = phks_db_get(db, id, &sig, name, capacity, label,
                             capacity);
        if (st == PHKS_OK) {
            PyObject *fields[4] = {PyLong_FromLongLong(id), text_of(name),
                                   text_of(label),
                                   /* frees sig on failure */
                                   signature_wrap(sig, NULL)};
            PyMem_Free(name);
            PyMem_Free(label);
            return record_of(&EntryType, fields);
        }
        int no_memory = !name || !label;
        PyMem_Free(name);
        PyMem_Free(label);
        if (no_memory)
            return PyErr_NoMemory();
        if (st != PHKS_ERROR_BUFFER_TOO_SMALL || capacity >= ((size_t)1 << 30))
            return raise_status(st);
        capacity *= 4;
    }
}

static PyObject *Database_remove(DatabaseObject *self, PyObject *arg)
{
    int64_t id;
    phks_db *db = db_and_id(self, arg, &id);
    if (!db)
        return NULL;
    phks_status st;
    self->busy++;
    Py_BEGIN_ALLOW_THREADS
    st = phks_db_remove(db, id);
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
     "max(k, 32) entries of lowest score_nearest. Each Hit also has the "
     "attributes similarity and verified (phks.similarity)."},
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

int database_add_to_module(PyObject *module)
{
    if (add_struct_sequence(module, "Hit", &HitType, &hit_desc) < 0 ||
        add_struct_sequence(module, "Entry", &EntryType, &entry_desc) < 0)
        return -1;
    return add_type(module, "Database", &DatabaseType);
}
