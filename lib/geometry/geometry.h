/*
 * geometry.h - the cleaned mesh and what is measured on it: the unit box,
 * vertex and local areas, the quadrature points inside long triangles,
 * distances to the boundary, and the spatial grid the operator and
 * HKS-simp find neighbours with.
 */
#ifndef PHKS_GEOMETRY_H
#define PHKS_GEOMETRY_H

#include "io/io.h"

/* ---- mesh (mesh.c) */
struct phks_mesh {
    size_t vertex_count;
    size_t triangle_count;
    double *xyz;             /* 3 per vertex, input coordinates          */
    uint32_t *triangles;     /* 3 per triangle                           */
    uint32_t *vertex_origin; /* input index of each vertex               */
    double area;             /* total area                               */

    /* Edges: unique unordered vertex pairs, sorted by (lower, higher). */
    size_t edge_count;
    uint32_t *edge_vertices;      /* 2 per edge                          */
    uint32_t *edge_tri_offset;    /* edge_count + 1 offsets into edge_tris */
    uint32_t *edge_tris;          /* triangles incident to each edge,
                                     ascending                            */
    uint32_t *triangle_edges;     /* 3 per triangle: edge of corners
                                     (0,1), (1,2), (2,0)                  */

    size_t boundary_edge_count;
    uint32_t *boundary_edges;     /* 2 per boundary edge                 */
    size_t component_count;
    uint32_t *vertex_component;
};

/* Area of the triangle with corners a, b, c (3 doubles each). */
double phks__triangle_area(const double *a, const double *b, const double *c);

/* Builds a mesh from arrays the caller keeps ownership of. vertex_origin
 * may be NULL (identity). Cleans as phks_mesh_create documents. */
phks_status phks__mesh_build(const double *xyz, size_t vertex_count,
                            const uint32_t *triangles, size_t triangle_count,
                            const uint32_t *vertex_origin, phks_mesh **out);

/* ---- the unit box and areas (unit_box.c, local_area.c, sym3_eigen.c) */
/* PHKS_BOX_PRINCIPAL with the surface's second moments integrated
 * exactly over each triangle rather than taken at its centroid: the axes
 * of a box do not then depend on how its faces were triangulated. What
 * PHKS_QUADRATURE_TRIANGLES uses for PHKS_BOX_PRINCIPAL (docs/method.md
 * section 13); never a value of phks_options.box. */
#define PHKS__BOX_PRINCIPAL_EXACT ((phks_box)-1)
/* Scale factor s such that s * positions fit the unit box of `box`.
 * Progress through `at` every 2^18 triangles or vertices; returns
 * PHKS_ERROR_CANCELLED when the callback asks. */
phks_status phks__unit_box_scale(const phks_mesh *mesh, phks_box box,
                                 phks__span at, double *scale);
/* Per-vertex area: a third of the area of the incident triangles, for
 * positions scaled by `scale`. mass has vertex_count entries. Progress as
 * phks__unit_box_scale's. */
phks_status phks__vertex_areas(const phks_mesh *mesh, double scale,
                               phks__span at, double *mass);

/* A mesh as the pipeline sees it: positions times `scale` fit the unit box,
 * and `area` (vertex_count, owned) holds the vertex areas at that scale.
 * Computed once, at the top of a computation, and handed down with the
 * input coordinates: every layer multiplies by the same scale as the
 * operator always did, so a pre-scaled copy (which would round
 * differently) is never made. */
typedef struct phks__unit_mesh {
    const phks_mesh *mesh;
    double scale;
    double *area;
} phks__unit_mesh;

/* Squared straight-line distance of vertices v and w in the unit box. */
static inline double phks__unit_distance2(const phks__unit_mesh *um, size_t v,
                                          size_t w)
{
    const double *p = um->mesh->xyz + 3 * v, *q = um->mesh->xyz + 3 * w;
    double d2 = 0;
    for (int k = 0; k < 3; k++)
        d2 += (p[k] - q[k]) * (p[k] - q[k]);
    return d2 * um->scale * um->scale;
}

/* The box's scale in the first two thirds of `at`, the areas in the last
 * third. On failure nothing is left to release. */
phks_status phks__unit_mesh_init(const phks_mesh *mesh, phks_box box,
                                 phks__span at, phks__unit_mesh *out);
void phks__unit_mesh_release(phks__unit_mesh *u);
/* Whether a triangle's longest edge, times scale, exceeds width. */
bool phks__long_triangles(const phks_mesh *mesh, double scale, double width);
/* phks__unit_mesh_init with opt's box; with PHKS_QUADRATURE_TRIANGLES,
 * PHKS_BOX_PRINCIPAL and a triangle longer than sqrt(4 tau) in that box,
 * the box again with PHKS__BOX_PRINCIPAL_EXACT (so that a mesh without
 * long triangles keeps every bit). */
phks_status phks__unit_mesh_for(const phks_mesh *mesh, const phks_options *opt,
                                phks__span at, phks__unit_mesh *out);

/* A surface sampled by weighted points: n positions (3 each, times scale
 * in the unit box) and the area each stands for (a mesh's vertices with
 * their vertex areas, or the operator's quadrature points). */
typedef struct phks__surface {
    const double *xyz;
    const double *area;
    size_t n;
    double scale;
} phks__surface;

/* area[s] = the area (the points' areas summed) of the points within
 * straight-line distance sqrt(radius2[s]) of point `point`, in the unit
 * box: what PHKS_HKS_SCALING_LOCAL_AREA multiplies HKS by
 * (local_area.c). The radii in any order. */
void phks__local_areas(const phks__surface *surface, size_t point,
                       const double *radius2, size_t count, double *area);
/* Eigen-decomposition of the symmetric 3 x 3 matrix (row-major; its upper
 * triangle is read) by cyclic Jacobi, in the layout of LAPACK's row-major
 * dsyev: values ascending, vectors[3 * i + j] component i of the unit
 * eigenvector j, the columns orthonormal. Each vector's entry of largest
 * magnitude (the first of equals) is positive. A diagonal matrix gives
 * the unit vectors, in the order of its sorted diagonal. The same bits on
 * every run, whatever the BLAS threads; finite input assumed. */
void phks__sym3_eigen(const double matrix[9], double values[3],
                     double vectors[9]);
/* ---- quadrature inside long triangles (quadrature.c) */
/* PHKS_QUADRATURE_TRIANGLES' points (docs/method.md section 13): the
 * mesh's vertices first (point v is vertex v), then points inside every
 * triangle whose longest edge exceeds sqrt(4 tau) in the unit box, each
 * weighted by its share of the surface. */
typedef struct phks__quadrature {
    size_t count;          /* points; count == vertex_count: no long
                              triangle, and nothing is allocated        */
    size_t vertex_count;
    double *xyz;           /* 3 per point, input coordinates            */
    double *area;          /* the weight a_q of every point (unit box)  */
    uint32_t *corner;      /* 3 per point past the vertices: the mesh
                              vertices it interpolates                  */
    double *bary;          /* 3 per point past the vertices: its
                              barycentric weights on them (Lambda)      */
} phks__quadrature;

phks_status phks__quadrature_build(const phks__unit_mesh *um,
                                   const phks_options *opt,
                                   phks__quadrature *q);
void phks__quadrature_release(phks__quadrature *q);
/* vertex[v] = sum_q Lambda_qv point[q]: what a mass on the points is on
 * the vertices (the sums agree). */
void phks__quadrature_lump(const phks__quadrature *q, const double *point,
                           double *vertex);

/* ---- spatial grid (grid.c) */
typedef struct phks__grid {
    double origin[3];
    double cell;           /* cell edge length */
    size_t dims[3];
    size_t *cell_start;    /* dims product + 1 offsets into points    */
    uint32_t *points;      /* point indices sorted by cell           */
} phks__grid;

/* Buckets n points (xyz, scaled by `scale`) into cells of size `cell`. */
phks_status phks__grid_build(const double *xyz, size_t n, double scale,
                            double cell, phks__grid *grid);
void phks__grid_release(phks__grid *grid);
/* The cell of the (scaled) point p, clamped to the grid. */
void phks__grid_cell(const phks__grid *grid, const double p[3], size_t c[3]);
/* The index of cell (x, y, z) in cell_start. */
static inline size_t phks__grid_cell_index(const phks__grid *grid, size_t x,
                                           size_t y, size_t z)
{
    return (z * grid->dims[1] + y) * grid->dims[0] + x;
}
/* The points of cell c and the 26 around it as ranges [first, last) of
 * grid->points, in a fixed order (z, then y; x ascending within each):
 * returns how many ranges (at most 9, fewer at the grid's faces). */
size_t phks__grid_neighbourhood(const phks__grid *grid, const size_t c[3],
                               size_t range[9][2]);

/* ---- distances along the surface (geodesic.c) */
/* The mesh's edges as arcs both ways, lengths in the unit box, plus, on a
 * mesh of several pieces, an arc both ways from each vertex to the
 * nearest vertex of another piece within straight-line distance `reach`
 * (none when reach is 0). With cell > 0 the vertices are first merged
 * into one node per occupied cell of a grid of about that size (unit
 * box), at their mean, and an arc joins two nodes where an edge or a
 * bridge joins their vertices: a mesh of millions of vertices gets a
 * graph of about its area over cell^2 nodes, whose paths differ from the
 * mesh's by about a cell per step. */
typedef struct phks__geodesic_graph {
    size_t n;          /* nodes                                      */
    uint32_t *node_of; /* per vertex; NULL: nodes are the vertices   */
    double *centre;    /* 3 per node with node_of                    */
    size_t *offset;    /* n + 1 offsets into next and length         */
    uint32_t *next;
    double *length;
} phks__geodesic_graph;

phks_status phks__geodesic_graph_build(const phks__unit_mesh *um, double reach,
                                       double cell,
                                       phks__geodesic_graph *graph);
void phks__geodesic_graph_release(phks__geodesic_graph *graph);
/* The node of a vertex. */
uint32_t phks__geodesic_node(const phks__geodesic_graph *graph,
                             uint32_t vertex);
/* Shortest-path distances from the node of vertex `source` into distance
 * (one per node; INFINITY where unreachable). With targets (target_count
 * vertices) the search stops once their nodes are settled, and only
 * their distances are final; with targets NULL every node's is. */
phks_status phks__geodesic_run(const phks__geodesic_graph *graph,
                               uint32_t source, const uint32_t *targets,
                               size_t target_count, double *distance);

/* ---- spin images (spin_image.c) */
/* Each point's description of the surface around it (docs/method.md
 * section 15): for each of PHKS__SPIN_RADII radii r_k = PHKS__SPIN_RADIUS
 * 2^(k/2) in the unit box, the area of the surface within straight-line
 * distance r_k of the point, binned by its distance from the point's
 * normal line (PHKS__SPIN_ALPHA bins over [0, r_k)) and its height along
 * the normal (PHKS__SPIN_BETA bins over [-r_k, r_k), an odd count: a
 * flat surface, height 0, lies inside the middle bin rather than on the
 * edge between two, where rounding would pick one), each bin's share
 * of the ball's area stored as round(255 sqrt(share)): an image's bytes
 * over 255 are a unit vector, and the distance of two of them is
 * Hellinger's. */
#define PHKS__SPIN_RADII 5
#define PHKS__SPIN_RADIUS 0.04
#define PHKS__SPIN_ALPHA 4
#define PHKS__SPIN_BETA 5
#define PHKS__SPIN_IMAGE (PHKS__SPIN_ALPHA * PHKS__SPIN_BETA)
#define PHKS__SPIN_BYTES (PHKS__SPIN_RADII * PHKS__SPIN_IMAGE)
/* The images of `count` vertices of um->mesh into out (count x
 * PHKS__SPIN_BYTES), the radii in order, each image row-major by
 * distance from the normal line. Fails only for want of memory. */
phks_status phks__spin_images(const phks__unit_mesh *um,
                              const uint32_t *vertices, size_t count,
                              uint8_t *out);

/* ---- the shape distribution D2 (shape_distribution.c) */
/* The histogram of the straight-line distances between every pair of
 * PHKS__SHAPE_POINTS points spread over the surface by area
 * (docs/method.md section 16), in units of their mean, over
 * [0, PHKS__SHAPE_RANGE) in PHKS__SHAPE_BINS bins (longer ones in the
 * last), each bin's share of the pairs stored as round(255 sqrt(share)),
 * so that two histograms' distance is Hellinger's as the spin images'. */
#define PHKS__SHAPE_BINS 32
#define PHKS__SHAPE_RANGE 3.0
#define PHKS__SHAPE_POINTS 2048
/* um->mesh's distribution into out. Fails only for want of memory. */
phks_status phks__shape_distribution(const phks__unit_mesh *um,
                                     uint8_t out[PHKS__SHAPE_BINS]);

/* ---- boundary proximity (boundary.c) */
/* distance[v] = straight-line distance from vertex v to the nearest vertex
 * on a boundary edge, in the unit box of um, capped at cap (cap > 0; all
 * cap on a closed mesh). Runs on phks__thread_count(at.opt) threads (the
 * distances do not depend on it; at.opt NULL: one) and reports progress
 * through `at` between batches of vertices; returns PHKS_ERROR_CANCELLED
 * when the callback asks. */
phks_status phks__boundary_distance(const phks__unit_mesh *um, double cap,
                                    phks__span at, double *distance);

#endif /* PHKS_GEOMETRY_H */
