/*
 * mesh.c - the immutable cleaned mesh: validation, dropping of degenerate
 * triangles and unreferenced vertices, the edge table that persistence
 * walks, boundary edges and connected components.
 */
#include "geometry/geometry.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Triangle count limit: the edge table indexes 3 corners per triangle with
 * uint32_t. */
#define MAX_TRIANGLES ((size_t)1 << 30)
#define MAX_VERTICES ((size_t)UINT32_MAX - 1)

/* A triangle whose area is below this fraction of the squared bounding-box
 * diagonal carries no mass worth keeping and would only add noise to the
 * edge structure. */
#define DEGENERATE_AREA 1e-12

/* Edges longer than 2^240 or shorter than 2^-240 would overflow or
 * underflow the fourth powers below (an area of infinity at coordinates
 * of 1e100, of 0 at 1e-100): they are scaled by a power of two first,
 * which is exact. In between, the arithmetic is the plain formula's. */
double phks__triangle_area(const double *a, const double *b, const double *c)
{
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double m = 0;
    for (int k = 0; k < 3; k++)
        m = fmax(m, fmax(fabs(u[k]), fabs(v[k])));
    if (!isfinite(m))
        return m > 0 ? INFINITY : NAN; /* an edge beyond DBL_MAX, or NaN */
    int e = 0;
    if (m > 0x1p240 || (m > 0 && m < 0x1p-240)) {
        e = ilogb(m);
        for (int k = 0; k < 3; k++) {
            u[k] = ldexp(u[k], -e);
            v[k] = ldexp(v[k], -e);
        }
    }
    double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                   u[0] * v[1] - u[1] * v[0]};
    double area = 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    return e ? ldexp(area, 2 * e) : area;
}

void phks_mesh_free(phks_mesh *mesh)
{
    if (!mesh)
        return;
    phks__free(mesh->xyz);
    phks__free(mesh->triangles);
    phks__free(mesh->vertex_origin);
    phks__free(mesh->edge_vertices);
    phks__free(mesh->edge_tri_offset);
    phks__free(mesh->edge_tris);
    phks__free(mesh->triangle_edges);
    phks__free(mesh->boundary_edges);
    phks__free(mesh->vertex_component);
    phks__free(mesh);
}

static phks_status check_input(const double *xyz, size_t vertex_count,
                               const uint32_t *triangles, size_t triangle_count)
{
    if (triangle_count == 0)
        return phks__fail(PHKS_ERROR_NO_TRIANGLES, "the mesh has no triangles");
    if (vertex_count > MAX_VERTICES)
        return phks__fail(PHKS_ERROR_TOO_LARGE, "%zu vertices, more than %zu",
                         vertex_count, MAX_VERTICES);
    if (triangle_count > MAX_TRIANGLES)
        return phks__fail(PHKS_ERROR_TOO_LARGE, "%zu triangles, more than %zu",
                         triangle_count, MAX_TRIANGLES);
    for (size_t i = 0; i < 3 * vertex_count; i++)
        if (!isfinite(xyz[i]))
            return phks__fail(PHKS_ERROR_NON_FINITE,
                             "vertex %zu: coordinate %c is not finite", i / 3,
                             "xyz"[i % 3]);
    for (size_t i = 0; i < 3 * triangle_count; i++)
        if (triangles[i] >= vertex_count)
            return phks__fail(PHKS_ERROR_INDEX_OUT_OF_RANGE,
                             "triangle %zu: vertex index %u, but there are "
                             "%zu vertices",
                             i / 3, triangles[i], vertex_count);
    return PHKS_OK;
}

/* The bounding-box diagonal d and its square d2, which overflows for
 * extents above about 1e154 and underflows below 1e-154 (d does not). */
static void bbox_diagonal(const double *xyz, size_t n, double *d, double *d2)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], xyz[3 * i + k]);
            hi[k] = fmax(hi[k], xyz[3 * i + k]);
        }
    double s = 0, m = 0;
    for (int k = 0; k < 3; k++) {
        s += (hi[k] - lo[k]) * (hi[k] - lo[k]);
        m = fmax(m, hi[k] - lo[k]);
    }
    *d2 = s;
    *d = 0;
    if (m > 0 && isfinite(m)) {
        double r = 0;
        for (int k = 0; k < 3; k++)
            r += ((hi[k] - lo[k]) / m) * ((hi[k] - lo[k]) / m);
        *d = m * sqrt(r);
    } else if (m > 0)
        *d = INFINITY;
}

/* Keeps the non-degenerate triangles and the vertices they reference,
 * renumbered in input order. */
static phks_status compact(phks_mesh *m, const double *xyz, size_t vertex_count,
                           const uint32_t *triangles, size_t triangle_count,
                           const uint32_t *origin)
{
    double diag, diag2;
    bbox_diagonal(xyz, vertex_count, &diag, &diag2);
    if (!isfinite(diag))
        return phks__fail(PHKS_ERROR_TOO_LARGE,
                         "the coordinates span more than a double can hold");
    /* Where diag2 overflows or underflows, the same test on a / diag. */
    bool scaled = !(isfinite(diag2) && diag2 >= DBL_MIN) && diag > 0;
    double min_area = DEGENERATE_AREA * diag2;
    uint32_t *new_index = phks__malloc_array(vertex_count, sizeof *new_index);
    m->triangles = phks__malloc_array(triangle_count, 3 * sizeof(uint32_t));
    if (!new_index || !m->triangles) {
        phks__free(new_index);
        return phks__fail_oom("mesh triangles");
    }
    for (size_t v = 0; v < vertex_count; v++)
        new_index[v] = UINT32_MAX;

    size_t kept = 0;
    double area = 0;
    for (size_t t = 0; t < triangle_count; t++) {
        const uint32_t *c = triangles + 3 * t;
        if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2])
            continue;
        double a = phks__triangle_area(xyz + 3 * c[0], xyz + 3 * c[1], xyz + 3 * c[2]);
        if (scaled ? !(a / diag > DEGENERATE_AREA * diag) : !(a > min_area))
            continue;
        area += a;
        memcpy(m->triangles + 3 * kept, c, 3 * sizeof *c);
        for (int k = 0; k < 3; k++)
            new_index[c[k]] = 0;
        kept++;
    }
    if (kept == 0) {
        phks__free(new_index);
        return phks__fail(PHKS_ERROR_ZERO_AREA,
                         "all %zu triangles are degenerate (zero area or a "
                         "repeated vertex)",
                         triangle_count);
    }
    if (!isfinite(area)) {
        phks__free(new_index);
        return phks__fail(PHKS_ERROR_TOO_LARGE,
                         "the total area is beyond the range of a double: "
                         "the coordinates are too large");
    }

    size_t n = 0;
    for (size_t v = 0; v < vertex_count; v++)
        if (new_index[v] == 0)
            new_index[v] = (uint32_t)n++;
    m->xyz = phks__malloc_array(n, 3 * sizeof(double));
    m->vertex_origin = phks__malloc_array(n, sizeof(uint32_t));
    if (!m->xyz || !m->vertex_origin) {
        phks__free(new_index);
        return phks__fail_oom("mesh vertices");
    }
    for (size_t v = 0; v < vertex_count; v++) {
        uint32_t w = new_index[v];
        if (w == UINT32_MAX)
            continue;
        memcpy(m->xyz + 3 * w, xyz + 3 * v, 3 * sizeof(double));
        m->vertex_origin[w] = origin ? origin[v] : (uint32_t)v;
    }
    for (size_t i = 0; i < 3 * kept; i++)
        m->triangles[i] = new_index[m->triangles[i]];
    phks__free(new_index);

    uint32_t *shrunk = phks__realloc_array(m->triangles, kept, 3 * sizeof(uint32_t));
    if (shrunk)
        m->triangles = shrunk;
    m->vertex_count = n;
    m->triangle_count = kept;
    m->area = area;
    return PHKS_OK;
}

/* One corner-edge of a triangle, bucketed by its lower vertex. */
typedef struct {
    uint32_t hi;
    uint32_t tri;
    uint32_t slot; /* 3 * tri + which edge of the triangle */
} half_edge;

static int half_edge_cmp(const void *a, const void *b)
{
    const half_edge *x = a, *y = b;
    if (x->hi != y->hi)
        return x->hi < y->hi ? -1 : 1;
    return x->tri < y->tri ? -1 : x->tri > y->tri;
}

static void sort_bucket(half_edge *h, size_t n)
{
    if (n > 16) {
        qsort(h, n, sizeof *h, half_edge_cmp);
        return;
    }
    for (size_t i = 1; i < n; i++) {
        half_edge x = h[i];
        size_t j = i;
        while (j > 0 && half_edge_cmp(&h[j - 1], &x) > 0) {
            h[j] = h[j - 1];
            j--;
        }
        h[j] = x;
    }
}

/* Counting sort of the 3T corner edges by lower vertex, then by higher
 * vertex within each bucket: linear in practice, and the edge numbering
 * depends only on vertex numbers, never on triangle order. */
static phks_status build_edges(phks_mesh *m)
{
    size_t n = m->vertex_count, t_count = m->triangle_count, h_count = 3 * t_count;
    size_t *bucket = phks__calloc(n + 1, sizeof *bucket);
    half_edge *h = phks__malloc_array(h_count, sizeof *h);
    m->triangle_edges = phks__malloc_array(h_count, sizeof(uint32_t));
    m->edge_tris = phks__malloc_array(h_count, sizeof(uint32_t));
    m->edge_tri_offset = phks__malloc_array(h_count + 1, sizeof(uint32_t));
    m->edge_vertices = phks__malloc_array(h_count, 2 * sizeof(uint32_t));
    phks_status st = PHKS_OK;
    if (!bucket || !h || !m->triangle_edges || !m->edge_tris ||
        !m->edge_tri_offset || !m->edge_vertices) {
        st = phks__fail_oom("mesh edges");
        goto done;
    }
    for (size_t s = 0; s < h_count; s++) {
        uint32_t a = m->triangles[s], b = m->triangles[s - s % 3 + (s % 3 + 1) % 3];
        bucket[(a < b ? a : b) + 1]++;
    }
    for (size_t v = 0; v < n; v++)
        bucket[v + 1] += bucket[v];
    for (size_t s = 0; s < h_count; s++) {
        uint32_t a = m->triangles[s], b = m->triangles[s - s % 3 + (s % 3 + 1) % 3];
        uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
        h[bucket[lo]++] = (half_edge){hi, (uint32_t)(s / 3), (uint32_t)s};
    }
    /* bucket[v] is now the end of v's run; shift back to starts. */
    memmove(bucket + 1, bucket, n * sizeof *bucket);
    bucket[0] = 0;

    size_t e = 0;
    for (size_t v = 0; v < n; v++) {
        half_edge *run = h + bucket[v];
        size_t len = bucket[v + 1] - bucket[v];
        sort_bucket(run, len);
        for (size_t i = 0; i < len; i++) {
            if (i == 0 || run[i].hi != run[i - 1].hi) {
                m->edge_vertices[2 * e] = (uint32_t)v;
                m->edge_vertices[2 * e + 1] = run[i].hi;
                m->edge_tri_offset[e] = (uint32_t)(bucket[v] + i);
                e++;
            }
            m->edge_tris[bucket[v] + i] = run[i].tri;
            m->triangle_edges[run[i].slot] = (uint32_t)(e - 1);
        }
    }
    m->edge_tri_offset[e] = (uint32_t)h_count;
    m->edge_count = e;

    size_t boundary = 0;
    for (size_t i = 0; i < e; i++)
        boundary += m->edge_tri_offset[i + 1] - m->edge_tri_offset[i] == 1;
    m->boundary_edges = phks__malloc_array(boundary ? boundary : 1, 2 * sizeof(uint32_t));
    if (!m->boundary_edges) {
        st = phks__fail_oom("mesh boundary");
        goto done;
    }
    m->boundary_edge_count = 0;
    for (size_t i = 0; i < e; i++)
        if (m->edge_tri_offset[i + 1] - m->edge_tri_offset[i] == 1) {
            memcpy(m->boundary_edges + 2 * m->boundary_edge_count,
                   m->edge_vertices + 2 * i, 2 * sizeof(uint32_t));
            m->boundary_edge_count++;
        }
done:
    phks__free(bucket);
    phks__free(h);
    return st;
}

static phks_status build_components(phks_mesh *m)
{
    size_t n = m->vertex_count;
    uint32_t *parent = phks__malloc_array(n, sizeof *parent);
    m->vertex_component = phks__malloc_array(n, sizeof(uint32_t));
    if (!parent || !m->vertex_component) {
        phks__free(parent);
        return phks__fail_oom("mesh components");
    }
    for (size_t v = 0; v < n; v++)
        parent[v] = (uint32_t)v;
    for (size_t e = 0; e < m->edge_count; e++) {
        uint32_t a = phks__find_root(parent, m->edge_vertices[2 * e]);
        uint32_t b = phks__find_root(parent, m->edge_vertices[2 * e + 1]);
        if (a != b)
            parent[a > b ? a : b] = a < b ? a : b; /* root = lowest vertex */
    }
    size_t count = 0;
    for (size_t v = 0; v < n; v++) {
        uint32_t r = phks__find_root(parent, (uint32_t)v);
        m->vertex_component[v] = r == v ? (uint32_t)count++ : m->vertex_component[r];
    }
    m->component_count = count;
    phks__free(parent);
    return PHKS_OK;
}

phks_status phks__mesh_build(const double *xyz, size_t vertex_count,
                            const uint32_t *triangles, size_t triangle_count,
                            const uint32_t *vertex_origin, phks_mesh **out)
{
    phks_status st = check_input(xyz, vertex_count, triangles, triangle_count);
    if (st != PHKS_OK)
        return st;
    phks_mesh *m = phks__calloc(1, sizeof *m);
    if (!m)
        return phks__fail_oom("mesh");
    st = compact(m, xyz, vertex_count, triangles, triangle_count, vertex_origin);
    if (st == PHKS_OK)
        st = build_edges(m);
    if (st == PHKS_OK)
        st = build_components(m);
    if (st != PHKS_OK) {
        phks_mesh_free(m);
        return st;
    }
    *out = m;
    return PHKS_OK;
}

phks_status phks_mesh_create(const double *xyz, size_t vertex_count,
                             const uint32_t *triangles, size_t triangle_count,
                             phks_mesh **mesh)
{
    if (mesh)
        *mesh = NULL;
    if (!mesh || (!xyz && vertex_count) || (!triangles && triangle_count))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_mesh_create: NULL argument");
    return phks__mesh_build(xyz, vertex_count, triangles, triangle_count, NULL,
                           mesh);
}

phks_status phks_mesh_create_f(const float *xyz, size_t vertex_count,
                               const uint32_t *triangles, size_t triangle_count,
                               phks_mesh **mesh)
{
    if (mesh)
        *mesh = NULL;
    if (!mesh || (!xyz && vertex_count) || (!triangles && triangle_count))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_mesh_create_f: NULL argument");
    if (vertex_count > MAX_VERTICES)
        return phks__fail(PHKS_ERROR_TOO_LARGE, "%zu vertices, more than %zu",
                         vertex_count, MAX_VERTICES);
    double *wide = phks__malloc_array(vertex_count, 3 * sizeof *wide);
    if (!wide)
        return phks__fail_oom("mesh vertices");
    for (size_t i = 0; i < 3 * vertex_count; i++)
        wide[i] = xyz[i];
    phks_status st = phks__mesh_build(wide, vertex_count, triangles,
                                     triangle_count, NULL, mesh);
    phks__free(wide);
    return st;
}

size_t phks_mesh_vertex_count(const phks_mesh *m) { return m ? m->vertex_count : 0; }
size_t phks_mesh_triangle_count(const phks_mesh *m) { return m ? m->triangle_count : 0; }
const double *phks_mesh_vertices(const phks_mesh *m) { return m ? m->xyz : NULL; }
const uint32_t *phks_mesh_triangles(const phks_mesh *m) { return m ? m->triangles : NULL; }
const uint32_t *phks_mesh_vertex_origin(const phks_mesh *m) { return m ? m->vertex_origin : NULL; }
size_t phks_mesh_boundary_edge_count(const phks_mesh *m) { return m ? m->boundary_edge_count : 0; }
const uint32_t *phks_mesh_boundary_edges(const phks_mesh *m) { return m ? m->boundary_edges : NULL; }
size_t phks_mesh_component_count(const phks_mesh *m) { return m ? m->component_count : 0; }
const uint32_t *phks_mesh_vertex_components(const phks_mesh *m) { return m ? m->vertex_component : NULL; }
double phks_mesh_area(const phks_mesh *m) { return m ? m->area : 0; }
