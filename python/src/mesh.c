/*
 * mesh.c - phks.Mesh, an immutable cleaned triangle mesh from numpy arrays,
 * and the functions that read one from a file or from bytes: the library's
 * own formats, and others through the assimp adapter the tool also links
 * (tools/assimp).
 */
#include "phks_python.h"

#include <stdio.h>
#include <string.h>

/* The assimp adapter the tool also links (tools/assimp). */
#include "assimp_reader.h"

/* load_memory's format argument, indexed by phks_format. */
static const char *const format_names[] = {"auto", "off", "obj", "ply", "stl",
                                           NULL};

PyObject *view_array(PyObject *owner, const void *data, int nd,
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

PyObject *mesh_wrap(phks_mesh *mesh)
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

/* Mesh's argument `what` ("vertices") as an array of shape (k, 3), or NULL
 * after an error that names the argument, what it must be (`expected`:
 * "an (n, 3) array of numbers") and what it got: a TypeError for what is
 * no array at all (None, a number), a ValueError for another shape or
 * rows numpy cannot stack. numpy's own messages name no argument. */
static PyArrayObject *rows_of_three(PyObject *obj, const char *what,
                                    const char *expected)
{
    PyArrayObject *arr = obj == Py_None ? NULL
                                        : (PyArrayObject *)PyArray_FROM_O(obj);
    if (obj != Py_None && !arr) {
        PyObject *type, *value, *trace;
        PyErr_Fetch(&type, &value, &trace);
        PyErr_Format(PyExc_ValueError, "Mesh: %s must be %s, got a %s "
                     "numpy cannot make an array of (%S)", what, expected,
                     Py_TYPE(obj)->tp_name, value ? value : Py_None);
        Py_XDECREF(type);
        Py_XDECREF(value);
        Py_XDECREF(trace);
        return NULL;
    }
    if (!arr || PyArray_NDIM(arr) == 0) {
        PyErr_Format(PyExc_TypeError, "Mesh: %s must be %s, got %s", what,
                     expected, obj == Py_None ? "None"
                                              : Py_TYPE(obj)->tp_name);
        Py_XDECREF(arr);
        return NULL;
    }
    if (PyArray_NDIM(arr) != 2 || PyArray_DIM(arr, 1) != 3) {
        PyObject *shape = PyArray_IntTupleFromIntp(PyArray_NDIM(arr),
                                                   PyArray_DIMS(arr));
        if (shape)
            PyErr_Format(PyExc_ValueError, "Mesh: %s must be %s, got shape "
                         "%S", what, expected, shape);
        Py_XDECREF(shape);
        Py_DECREF(arr);
        return NULL;
    }
    return arr;
}

/* Says that arr (Mesh's argument `what`) holds other things than it must
 * ("an array of complex128"): a TypeError; returns NULL. */
static PyArrayObject *wrong_type(PyArrayObject *arr, const char *what,
                                 const char *expected)
{
    PyErr_Format(PyExc_TypeError, "Mesh: %s must be %s, got an array of %S",
                 what, expected, (PyObject *)PyArray_DESCR(arr));
    Py_DECREF(arr);
    return NULL;
}

/* vertices: any real numbers of shape (n, 3), as float64. */
static PyArrayObject *convert_vertices(PyObject *vertices)
{
    static const char expected[] = "an (n, 3) array of numbers";
    PyArrayObject *arr = rows_of_three(vertices, "vertices", expected);
    if (!arr)
        return NULL;
    int type = PyArray_TYPE(arr);
    if (!PyTypeNum_ISINTEGER(type) && !PyTypeNum_ISFLOAT(type))
        return wrong_type(arr, "vertices", expected);
    PyArrayObject *v = (PyArrayObject *)PyArray_FROMANY(
        (PyObject *)arr, NPY_DOUBLE, 2, 2,
        NPY_ARRAY_IN_ARRAY | NPY_ARRAY_FORCECAST);
    Py_DECREF(arr);
    return v;
}

/* faces: any integer array of shape (m, 3), into uint32 indices checked
 * here for what uint32 cannot hold (negative, above 2^32 - 1); the library
 * checks them against the vertex count. */
static int convert_faces(PyObject *faces, uint32_t **out, size_t *count)
{
    static const char expected[] = "an (m, 3) array of integers";
    *out = NULL;
    *count = 0;
    PyArrayObject *arr = rows_of_three(faces, "faces", expected);
    if (!arr)
        return -1;
    int type = PyArray_TYPE(arr);
    /* An empty list makes a float64 array: nothing to lose there. */
    if (PyArray_SIZE(arr) > 0 && !PyTypeNum_ISINTEGER(type)) {
        wrong_type(arr, "faces", expected);
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
    PyArrayObject *v = convert_vertices(vertices_obj);
    if (!v)
        return NULL;
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

PyTypeObject MeshType = {
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
    static char *keywords[] = {"data", "format", "max_bytes", "max_vertices",
                               NULL};
    Py_buffer data;
    PyObject *format_obj = NULL;
    Py_ssize_t max_bytes = 0, max_vertices = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "y*|O$nn:load_memory",
                                     keywords, &data, &format_obj, &max_bytes,
                                     &max_vertices))
        return NULL;
    if (max_bytes < 0 || max_vertices < 0) {
        PyBuffer_Release(&data);
        PyErr_SetString(PyExc_ValueError, "load_memory: max_bytes and "
                                          "max_vertices must be 0 (no "
                                          "limit) or more");
        return NULL;
    }
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
    st = phks_mesh_load_memory_limited(data.buf, (size_t)data.len,
                                       (phks_format)format, (size_t)max_bytes,
                                       (size_t)max_vertices, &mesh);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&data);
    if (st != PHKS_OK)
        return raise_status(st);
    return mesh_wrap(mesh);
}

static PyMethodDef mesh_functions[] = {
    {"load", py_load, METH_VARARGS,
     "load(path) -> Mesh: OFF, OBJ, PLY or STL, optionally gzipped; other "
     "formats (glTF/GLB, FBX, COLLADA, ...) through assimp when built with "
     "it, all meshes merged."},
    {"_has_assimp", py_has_assimp, METH_NOARGS,
     "_has_assimp() -> bool: whether load() reads formats through assimp."},
    {"load_memory", (PyCFunction)(void (*)(void))py_load_memory,
     METH_VARARGS | METH_KEYWORDS,
     "load_memory(data, format='auto', *, max_bytes=0, max_vertices=0) -> "
     "Mesh: a mesh file's bytes; format 'auto', 'off', 'obj', 'ply' or "
     "'stl'. A service taking meshes from others sets max_bytes (after "
     "gzip inflation) and max_vertices (0: no limit): above them, Error "
     "TOO_LARGE before the memory is taken."},
    {NULL, NULL, 0, NULL}};

int mesh_add_to_module(PyObject *module)
{
    if (add_type(module, "Mesh", &MeshType) < 0)
        return -1;
    return PyModule_AddFunctions(module, mesh_functions);
}
