/*
 * signature.c - phks.Signature, the persistent heat signature: feature
 * points and their HKS vectors as numpy arrays, the options it was made
 * with, its blob (encode, decode, pickling), and phks.signature(mesh,
 * **options), which computes one.
 */
#include "phks_python.h"

#include <string.h>

PyObject *signature_wrap(phks_signature *sig, const phks_mesh *mesh)
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

PyTypeObject SignatureType = {
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

int signature_arg(PyObject *obj, void *out)
{
    if (!PyObject_TypeCheck(obj, &SignatureType)) {
        PyErr_Format(PyExc_TypeError, "expected a phks.Signature, not %.100s",
                     Py_TYPE(obj)->tp_name);
        return 0;
    }
    *(const phks_signature **)out = ((SignatureObject *)obj)->sig;
    return 1;
}

typedef struct compute_args {
    const phks_mesh *mesh;
    phks_signature *sig;
} compute_args;

static phks_status compute(const phks_options *options, void *args)
{
    compute_args *a = args;
    return phks_signature_compute(a->mesh, options, &a->sig);
}

static PyObject *py_signature(PyObject *self, PyObject *args,
                              PyObject *kwargs)
{
    MeshObject *mesh;
    if (!PyArg_ParseTuple(args, "O!:signature", &MeshType, &mesh))
        return NULL;
    phks_options o;
    compute_args call = {mesh->mesh, NULL};
    if (run_long_call_with_kwargs(kwargs, &o, compute, &call) < 0) {
        phks_signature_free(call.sig);
        return NULL;
    }
    return signature_wrap(call.sig, mesh->mesh);
}

static PyMethodDef signature_functions[] = {
    {"signature", (PyCFunction)(void (*)(void))py_signature,
     METH_VARARGS | METH_KEYWORDS,
     "signature(mesh, progress=None, **options) -> Signature"},
    {"decode", (PyCFunction)(void (*)(void))py_decode,
     METH_VARARGS | METH_KEYWORDS,
     "decode(data, mesh=None) -> Signature (as Signature.decode)."},
    {NULL, NULL, 0, NULL}};

int signature_add_to_module(PyObject *module)
{
    if (add_type(module, "Signature", &SignatureType) < 0)
        return -1;
    return PyModule_AddFunctions(module, signature_functions);
}
