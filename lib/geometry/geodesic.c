/*
 * geodesic.c - distances along the surface: Dijkstra over the mesh's
 * edges, with the pieces of a mesh in several pieces joined where they
 * come within the operator's reach of each other (an unwelded CAD seam,
 * a soup of triangles), so that every two points of a shape the heat
 * kernel sees as one have a finite distance. Edge paths overestimate the
 * true geodesic by a few percent on a regular mesh; what the distances
 * serve (telling whether two sets of points are laid out alike, see
 * features/verify.c) needs them unchanged by pose, not exact.
 */
#include "geometry/geometry.h"

#include <math.h>
#include <string.h>

/* The nearest vertex of another piece within reach of each vertex:
 * bridge[v] = that vertex, or UINT32_MAX. */
static phks_status find_bridges(const phks__unit_mesh *um, double reach,
                                uint32_t *bridge, double *bridge_length)
{
    const phks_mesh *m = um->mesh;
    phks__grid grid;
    phks_status st = phks__grid_build(m->xyz, m->vertex_count, um->scale,
                                      reach, &grid);
    if (st != PHKS_OK)
        return st;
    for (size_t v = 0; v < m->vertex_count; v++) {
        double p[3], best = reach * reach;
        for (int d = 0; d < 3; d++)
            p[d] = m->xyz[3 * v + d] * um->scale;
        size_t c[3], range[9][2];
        phks__grid_cell(&grid, p, c);
        size_t rows = phks__grid_neighbourhood(&grid, c, range);
        bridge[v] = UINT32_MAX;
        for (size_t r = 0; r < rows; r++)
            for (size_t k = range[r][0]; k < range[r][1]; k++) {
                uint32_t w = grid.points[k];
                if (m->vertex_component[w] == m->vertex_component[v])
                    continue;
                double d2 = 0;
                for (int d = 0; d < 3; d++) {
                    double e = m->xyz[3 * (size_t)w + d] * um->scale - p[d];
                    d2 += e * e;
                }
                if (d2 < best) {
                    best = d2;
                    bridge[v] = w;
                }
            }
        bridge_length[v] = sqrt(best);
    }
    phks__grid_release(&grid);
    return PHKS_OK;
}

/* Appends the arc a -> b between the nodes of vertices a and b, counting
 * when `next` is NULL; none inside a node. */
static void add_arc(phks__geodesic_graph *g, size_t *fill, uint32_t a,
                    uint32_t b, double length)
{
    if (g->node_of) {
        a = g->node_of[a];
        b = g->node_of[b];
        if (a == b)
            return;
    }
    if (!g->next) {
        g->offset[a + 1]++;
        return;
    }
    size_t at = g->offset[a] + fill[a]++;
    g->next[at] = b;
    g->length[at] = length;
}

/* The length of the arc between the nodes of vertices a and b: the
 * distance of the vertices, or of the nodes' centres. */
static double arc_length(const phks__unit_mesh *um,
                         const phks__geodesic_graph *g, uint32_t a, uint32_t b)
{
    if (!g->node_of)
        return sqrt(phks__unit_distance2(um, a, b));
    const double *p = g->centre + 3 * (size_t)g->node_of[a];
    const double *q = g->centre + 3 * (size_t)g->node_of[b];
    double d2 = 0;
    for (int d = 0; d < 3; d++)
        d2 += (p[d] - q[d]) * (p[d] - q[d]);
    return sqrt(d2);
}

static void add_arcs(const phks__unit_mesh *um, const uint32_t *bridge,
                     const double *bridge_length, phks__geodesic_graph *g,
                     size_t *fill)
{
    const phks_mesh *m = um->mesh;
    for (size_t e = 0; e < m->edge_count; e++) {
        uint32_t a = m->edge_vertices[2 * e], b = m->edge_vertices[2 * e + 1];
        double len = g->next ? arc_length(um, g, a, b) : 0;
        add_arc(g, fill, a, b, len);
        add_arc(g, fill, b, a, len);
    }
    for (size_t v = 0; bridge && v < m->vertex_count; v++)
        if (bridge[v] != UINT32_MAX) {
            add_arc(g, fill, (uint32_t)v, bridge[v], bridge_length[v]);
            add_arc(g, fill, bridge[v], (uint32_t)v, bridge_length[v]);
        }
}

void phks__geodesic_graph_release(phks__geodesic_graph *g)
{
    phks__free(g->node_of);
    phks__free(g->centre);
    phks__free(g->offset);
    phks__free(g->next);
    phks__free(g->length);
    memset(g, 0, sizeof *g);
}

/* One node per occupied cell of a grid of the given size, at the mean of
 * its vertices (unit box). */
static phks_status cluster(const phks__unit_mesh *um, double cell,
                           phks__geodesic_graph *g)
{
    const phks_mesh *m = um->mesh;
    phks__grid grid;
    phks_status st = phks__grid_build(m->xyz, m->vertex_count, um->scale,
                                      cell, &grid);
    if (st != PHKS_OK)
        return st;
    size_t cells = grid.dims[0] * grid.dims[1] * grid.dims[2];
    g->node_of = phks__malloc_array(m->vertex_count, sizeof *g->node_of);
    g->centre = phks__calloc(m->vertex_count, 3 * sizeof *g->centre);
    if (!g->node_of || !g->centre) {
        phks__grid_release(&grid);
        return phks__fail_oom("geodesic graph");
    }
    g->n = 0;
    for (size_t c = 0; c < cells; c++) {
        size_t first = grid.cell_start[c], last = grid.cell_start[c + 1];
        if (first == last)
            continue;
        double *centre = g->centre + 3 * g->n;
        for (size_t k = first; k < last; k++) {
            uint32_t v = grid.points[k];
            g->node_of[v] = (uint32_t)g->n;
            for (int d = 0; d < 3; d++)
                centre[d] += m->xyz[3 * (size_t)v + d] * um->scale /
                             (double)(last - first);
        }
        g->n++;
    }
    phks__grid_release(&grid);
    return PHKS_OK;
}

phks_status phks__geodesic_graph_build(const phks__unit_mesh *um, double reach,
                                       double cell, phks__geodesic_graph *g)
{
    const phks_mesh *m = um->mesh;
    memset(g, 0, sizeof *g);
    g->n = m->vertex_count;
    phks_status st = cell > 0 ? cluster(um, cell, g) : PHKS_OK;
    if (st != PHKS_OK) {
        phks__geodesic_graph_release(g);
        return st;
    }
    size_t n = g->n, nv = m->vertex_count;
    uint32_t *bridge = NULL;
    double *bridge_length = NULL;
    size_t *fill = NULL;
    if (m->component_count > 1 && reach > 0) {
        bridge = phks__malloc_array(nv, sizeof *bridge);
        bridge_length = phks__malloc_array(nv, sizeof *bridge_length);
        st = bridge && bridge_length
                 ? find_bridges(um, reach, bridge, bridge_length)
                 : phks__fail_oom("geodesic bridges");
    }
    g->offset = st == PHKS_OK ? phks__calloc(n + 1, sizeof *g->offset) : NULL;
    fill = st == PHKS_OK ? phks__calloc(n, sizeof *fill) : NULL;
    if (st == PHKS_OK && (!g->offset || !fill))
        st = phks__fail_oom("geodesic graph");
    if (st == PHKS_OK) {
        add_arcs(um, bridge, bridge_length, g, fill);
        for (size_t v = 0; v < n; v++)
            g->offset[v + 1] += g->offset[v];
        g->next = phks__malloc_array(g->offset[n] + 1, sizeof *g->next);
        g->length = phks__malloc_array(g->offset[n] + 1, sizeof *g->length);
        if (!g->next || !g->length)
            st = phks__fail_oom("geodesic graph");
        else
            add_arcs(um, bridge, bridge_length, g, fill);
    }
    phks__free(bridge);
    phks__free(bridge_length);
    phks__free(fill);
    if (st != PHKS_OK)
        phks__geodesic_graph_release(g);
    return st;
}

/* A binary min-heap of (distance, vertex) with stale entries left in
 * place and skipped when popped: simpler than decrease-key, and the heap
 * holds at most one entry per arc. */
typedef struct heap_entry {
    double d;
    uint32_t v;
} heap_entry;

static void heap_push(heap_entry *h, size_t *n, double d, uint32_t v)
{
    size_t i = (*n)++;
    while (i && h[(i - 1) / 2].d > d) {
        h[i] = h[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    h[i] = (heap_entry){d, v};
}

static heap_entry heap_pop(heap_entry *h, size_t *n)
{
    heap_entry top = h[0], last = h[--*n];
    size_t i = 0;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= *n)
            break;
        if (c + 1 < *n && h[c + 1].d < h[c].d)
            c++;
        if (h[c].d >= last.d)
            break;
        h[i] = h[c];
        i = c;
    }
    if (*n)
        h[i] = last;
    return top;
}

uint32_t phks__geodesic_node(const phks__geodesic_graph *g, uint32_t vertex)
{
    return g->node_of ? g->node_of[vertex] : vertex;
}

phks_status phks__geodesic_run(const phks__geodesic_graph *g, uint32_t source,
                               const uint32_t *targets, size_t target_count,
                               double *distance)
{
    source = phks__geodesic_node(g, source);
    size_t n = g->n;
    heap_entry *heap = phks__malloc_array(g->offset[n] + 1, sizeof *heap);
    unsigned char *done = phks__calloc(n, 1);
    unsigned char *wanted = targets ? phks__calloc(n, 1) : NULL;
    if (!heap || !done || (targets && !wanted)) {
        phks__free(heap);
        phks__free(done);
        phks__free(wanted);
        return phks__fail_oom("geodesic distances");
    }
    size_t left = n;
    if (targets) {
        left = 0;
        for (size_t i = 0; i < target_count; i++) {
            uint32_t t = phks__geodesic_node(g, targets[i]);
            if (!wanted[t]) {
                wanted[t] = 1;
                left++;
            }
        }
    }
    for (size_t v = 0; v < n; v++)
        distance[v] = INFINITY;
    size_t size = 0;
    distance[source] = 0;
    heap_push(heap, &size, 0, source);
    while (size && left) {
        heap_entry top = heap_pop(heap, &size);
        if (done[top.v])
            continue;
        done[top.v] = 1;
        if (!targets || wanted[top.v])
            left--;
        for (size_t k = g->offset[top.v]; k < g->offset[top.v + 1]; k++) {
            uint32_t w = g->next[k];
            double d = top.d + g->length[k];
            if (d < distance[w]) {
                distance[w] = d;
                heap_push(heap, &size, d, w);
            }
        }
    }
    phks__free(heap);
    phks__free(done);
    phks__free(wanted);
    return PHKS_OK;
}

phks_status phks_mesh_geodesic_distances(const phks_mesh *mesh,
                                         const phks_options *options,
                                         uint32_t source, double *distance)
{
    if (!mesh || !distance)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_mesh_geodesic_distances: NULL argument");
    if (source >= mesh->vertex_count)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_mesh_geodesic_distances: vertex %u of %zu",
                         (unsigned)source, mesh->vertex_count);
    phks_options opt;
    phks_status st = phks__options_resolve(options, &opt);
    if (st != PHKS_OK)
        return st;
    phks__unit_mesh um;
    st = phks__unit_mesh_init(mesh, (phks_box)opt.box, PHKS__SPAN_NONE, &um);
    if (st != PHKS_OK)
        return st;
    phks__geodesic_graph graph;
    st = phks__geodesic_graph_build(&um, opt.cutoff * sqrt(4 * opt.tau), 0,
                                    &graph);
    if (st == PHKS_OK)
        st = phks__geodesic_run(&graph, source, NULL, 0, distance);
    for (size_t v = 0; st == PHKS_OK && v < mesh->vertex_count; v++)
        distance[v] /= um.scale;
    phks__geodesic_graph_release(&graph);
    phks__unit_mesh_release(&um);
    return st;
}
