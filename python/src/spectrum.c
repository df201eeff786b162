/*
 * spectrum.c - phks.Spectrum, the smallest eigenpairs of the
 * mesh-Laplacian as numpy arrays, with the HKS at any time and the
 * signature from them, and phks.spectrum(mesh, **options), which computes
 * one.
 */
#include "phks_python.h"

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

/* The arguments and result of this file's two long calls (run_long_call):
 * phks.spectrum's and Spectrum.signature's. */
typedef struct spectrum_args {
    const phks_mesh *mesh;
    const phks_spectrum *spectrum; /* Spectrum.signature's */
    phks_spectrum *spectrum_out;   /* phks.spectrum's */
    phks_signature *sig;           /* Spectrum.signature's */
} spectrum_args;

static phks_status compute_spectrum(const phks_options *options, void *args)
{
    spectrum_args *a = args;
    return phks_spectrum_compute(a->mesh, options, &a->spectrum_out);
}

static phks_status signature_from_spectrum(const phks_options *options,
                                           void *args)
{
    spectrum_args *a = args;
    return phks_signature_from_spectrum(a->mesh, a->spectrum, options,
                                        &a->sig);
}

static PyObject *py_spectrum(PyObject *module, PyObject *args,
                             PyObject *kwargs)
{
    MeshObject *mesh;
    if (!PyArg_ParseTuple(args, "O!:spectrum", &MeshType, &mesh))
        return NULL;
    phks_options o;
    spectrum_args call = {.mesh = mesh->mesh};
    if (run_long_call_with_kwargs(kwargs, &o, compute_spectrum, &call) < 0) {
        phks_spectrum_free(call.spectrum_out);
        return NULL;
    }
    SpectrumObject *self = PyObject_New(SpectrumObject, &SpectrumType);
    if (!self) {
        phks_spectrum_free(call.spectrum_out);
        return NULL;
    }
    self->spectrum = call.spectrum_out;
    Py_INCREF(mesh);
    self->mesh = mesh;
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
    PyObject *progress_obj = Py_None, *progress = NULL;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "|O:signature", keywords,
                                     &progress_obj) ||
        parse_progress(progress_obj, &progress) < 0)
        return NULL;
    spectrum_args call = {.mesh = self->mesh->mesh,
                          .spectrum = self->spectrum};
    if (run_long_call(self->options, progress, signature_from_spectrum,
                      &call) < 0) {
        phks_signature_free(call.sig);
        return NULL;
    }
    return signature_wrap(call.sig, self->mesh->mesh);
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

static PyMethodDef spectrum_functions[] = {
    {"spectrum", (PyCFunction)(void (*)(void))py_spectrum,
     METH_VARARGS | METH_KEYWORDS,
     "spectrum(mesh, progress=None, **options) -> Spectrum"},
    {NULL, NULL, 0, NULL}};

int spectrum_add_to_module(PyObject *module)
{
    if (add_type(module, "Spectrum", &SpectrumType) < 0)
        return -1;
    return PyModule_AddFunctions(module, spectrum_functions);
}
