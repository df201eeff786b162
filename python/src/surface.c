/*
 * surface.c - functions of one mesh's surface: the persistent maxima of a
 * vertex function with the segmentation they make, and geodesic distances
 * from a vertex.
 */
#include "phks_python.h"

static PyTypeObject MaximaType;

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

typedef struct geodesic_args {
    const phks_mesh *mesh;
    uint32_t source;
    double *distances;
} geodesic_args;

static phks_status geodesic(const phks_options *options, void *args)
{
    geodesic_args *a = args;
    return phks_mesh_geodesic_distances(a->mesh, options, a->source,
                                        a->distances);
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
    geodesic_args call = {.mesh = mesh->mesh};
    if (parse_u32(source_obj, "source", &call.source) < 0)
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
    call.distances = PyArray_DATA((PyArrayObject *)out);
    if (run_long_call(o, NULL, geodesic, &call) < 0) {
        Py_DECREF(out);
        return NULL;
    }
    return out;
}

static PyMethodDef surface_functions[] = {
    {"persistent_maxima", (PyCFunction)(void (*)(void))py_persistent_maxima,
     METH_VARARGS | METH_KEYWORDS,
     "persistent_maxima(mesh, f, max_count=15, threshold=0.0) -> Maxima: "
     "region merging of the triangles for the vertex function f."},
    {"geodesic_distances", (PyCFunction)(void (*)(void))py_geodesic_distances,
     METH_VARARGS | METH_KEYWORDS,
     "geodesic_distances(mesh, source, **options) -> (vertex_count,) "
     "float64: distances along the mesh's edges from vertex source, in "
     "input units; inf where a piece stays out of reach."},
    {NULL, NULL, 0, NULL}};

int surface_add_to_module(PyObject *module)
{
    if (add_struct_sequence(module, "Maxima", &MaximaType, &maxima_desc) < 0)
        return -1;
    return PyModule_AddFunctions(module, surface_functions);
}
