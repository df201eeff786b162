/*
 * quadrature.c - PHKS_QUADRATURE_TRIANGLES: where the operator takes its
 * sum over the surface when triangles are long (docs/method.md section 13).
 *
 * The operator of section 3 is a quadrature of the continuum kernel
 * operator at the vertices, each weighted by a third of its triangles'
 * area. That is accurate only while neighbouring quadrature points lie
 * within the kernel's width sqrt(4h) of each other: a CAD part's flat face,
 * two triangles a unit-box length long, has its only points at the corners,
 * the kernel between them is exp(-1 / 4h) = 0, and heat never crosses the
 * face. So every triangle whose longest edge exceeds w = sqrt(4h) is cut
 * into s x s congruent sub-triangles, s = ceil(longest edge / w), and the
 * sub-grid's points (s + 1)(s + 2) / 2 per triangle, spacing at most w
 * along the edges) become quadrature points, each weighted by a third of
 * the area of the sub-triangles around it (the same lumping as the
 * vertices', so that s = 1 gives back exactly the vertex quadrature). A
 * Gaussian of width w summed over a lattice of spacing at most w differs
 * from its integral by about exp(-pi^2) = 5e-5 relative (Poisson
 * summation), and the error of the vertex quadrature elsewhere is left
 * alone.
 *
 * The points are the mesh's vertices first (point v is vertex v, with its
 * input position), then the others: points on an edge are shared by the
 * triangles on both sides when they cut it into as many parts (their
 * position then computed once, from the edge's lower vertex), the rest
 * belong to one triangle. Each non-vertex point remembers the triangle
 * corners it interpolates and its barycentric weights (Lambda of section
 * 13), so that masses can be handed back to the vertices.
 */
#include "operator/operator.h"

#include <math.h>
#include <string.h>

/* The number of parts the edges of a triangle are cut into. */
static uint32_t divisions(const phks_mesh *mesh, double scale, double width,
                          size_t t)
{
    const uint32_t *c = mesh->triangles + 3 * t;
    double longest = 0;
    for (int k = 0; k < 3; k++) {
        const double *a = mesh->xyz + 3 * (size_t)c[k];
        const double *b = mesh->xyz + 3 * (size_t)c[(k + 1) % 3];
        double d2 = 0;
        for (int d = 0; d < 3; d++)
            d2 += (b[d] - a[d]) * (b[d] - a[d]);
        longest = fmax(longest, sqrt(d2) * scale);
    }
    if (!(longest > width))
        return 1;
    double s = ceil(longest / width);
    /* beyond any mesh the unit box holds at a tau options allow: the
     * count check below refuses it */
    return s < 1e6 ? (uint32_t)s : 1000000u;
}

/* Walks every long triangle's points in a fixed order: counts the points
 * (q->xyz NULL) or fills them. edge_s / edge_base record the first long
 * triangle to cut an edge, zeroed by the caller before each walk. */
typedef struct {
    const phks_mesh *mesh;
    const uint32_t *s;        /* per triangle */
    uint32_t *edge_s;         /* per edge: parts of its shared points, 0 */
    size_t *edge_base;        /* per edge: its first shared point        */
    size_t next;              /* next free point                         */
} layout_ctx;

/* The index of the shared point with weight m / s on the second corner of
 * edge slot e (0: corners 0-1, 1: 1-2, 2: 2-0) of triangle t, 0 < m < s:
 * the edge's points are numbered by their parts k from its lower vertex. */
static size_t shared_edge_point(const layout_ctx *l, size_t t, int e,
                                uint32_t m)
{
    const phks_mesh *mesh = l->mesh;
    const uint32_t s = l->s[t];
    const uint32_t *c = mesh->triangles + 3 * t;
    uint32_t edge = mesh->triangle_edges[3 * t + e];
    uint32_t hi = mesh->edge_vertices[2 * (size_t)edge + 1];
    uint32_t k = c[(e + 1) % 3] == hi ? m : s - m;
    return l->edge_base[edge] + (k - 1);
}

/* Adds weight a to point i (when filling). */
static void add_weight(phks__quadrature *q, size_t i, double a)
{
    if (q->area)
        q->area[i] += a;
}

/* Stores point i (when filling, and unless it is a vertex): its corners,
 * its barycentric weights on them, and the position they give. */
static void put_point(phks__quadrature *q, const phks_mesh *mesh, size_t i,
                      const uint32_t corner[3], const double bary[3])
{
    if (!q->xyz || i < q->vertex_count)
        return;
    size_t j = i - q->vertex_count;
    for (int d = 0; d < 3; d++) {
        double x = 0;
        for (int k = 0; k < 3; k++)
            x += bary[k] * mesh->xyz[3 * (size_t)corner[k] + d];
        q->xyz[3 * i + d] = x;
    }
    for (int k = 0; k < 3; k++) {
        q->corner[3 * j + k] = corner[k];
        q->bary[3 * j + k] = bary[k];
    }
}

/* One long triangle: claims its edges, numbers its points, and (filling)
 * stores them and adds a third of every sub-triangle's area to its
 * corners. Grid point (i, j), i + j <= s, has barycentric weights
 * ((s - i - j) / s, i / s, j / s) on the corners c0, c1, c2. */
static void layout_triangle(layout_ctx *l, phks__quadrature *q, size_t t,
                            double scale, size_t *grid)
{
    const phks_mesh *mesh = l->mesh;
    const uint32_t s = l->s[t];
    const uint32_t *c = mesh->triangles + 3 * t;
    /* edges: shared points when the edge is unclaimed or cut alike */
    size_t own_edge[3];
    bool shared[3];
    for (int e = 0; e < 3; e++) {
        uint32_t edge = mesh->triangle_edges[3 * t + e];
        if (l->edge_s[edge] == 0) {
            l->edge_s[edge] = s;
            l->edge_base[edge] = l->next;
            l->next += s - 1;
        }
        shared[e] = l->edge_s[edge] == s;
        own_edge[e] = 0;
        if (!shared[e]) {
            own_edge[e] = l->next;
            l->next += s - 1;
        }
    }
    size_t interior = l->next;
    if (s >= 3)
        l->next += (size_t)(s - 1) * (s - 2) / 2;
    if (!grid)
        return;

    /* the index of every grid point, row by row (i + j <= s) */
    size_t at = 0, inner = 0;
    for (uint32_t j = 0; j <= s; j++)
        for (uint32_t i = 0; i + j <= s; i++, at++) {
            size_t index;
            int e = -1;
            uint32_t m = 0; /* weight m / s on the edge's second corner */
            if (i == 0 && j == 0)
                index = c[0];
            else if (j == 0 && i == s)
                index = c[1];
            else if (i == 0 && j == s)
                index = c[2];
            else if (j == 0)
                e = 0, m = i;             /* c0 -> c1, weight i/s on c1 */
            else if (i + j == s)
                e = 1, m = j;             /* c1 -> c2, weight j/s on c2 */
            else if (i == 0)
                e = 2, m = s - j;         /* c2 -> c0, weight (s-j)/s on c0 */
            else
                index = interior + inner++;
            if (e >= 0) {
                index = shared[e] ? shared_edge_point(l, t, e, m)
                                  : own_edge[e] + (m - 1);
            }
            grid[at] = index;
            if (!q->xyz || index < q->vertex_count)
                continue;
            double bary[3] = {(double)(s - i - j) / s, (double)i / s,
                              (double)j / s};
            uint32_t corner[3] = {c[0], c[1], c[2]};
            if (e >= 0 && shared[e]) {
                /* computed from the edge's lower vertex, so that both
                 * triangles give the same bits */
                uint32_t edge = mesh->triangle_edges[3 * t + e];
                uint32_t lo = mesh->edge_vertices[2 * (size_t)edge];
                uint32_t hi = mesh->edge_vertices[2 * (size_t)edge + 1];
                uint32_t to = c[(e + 1) % 3];
                uint32_t k = to == hi ? m : s - m;
                corner[0] = lo;
                corner[1] = hi;
                corner[2] = hi;
                bary[0] = (double)(s - k) / s;
                bary[1] = (double)k / s;
                bary[2] = 0;
            }
            put_point(q, mesh, index, corner, bary);
        }
    if (!q->area)
        return;
    /* sub-triangles: up (i,j) (i+1,j) (i,j+1) and down (i+1,j) (i+1,j+1)
     * (i,j+1), all of area T / s^2 */
    double tri = phks__triangle_area(mesh->xyz + 3 * (size_t)c[0],
                                     mesh->xyz + 3 * (size_t)c[1],
                                     mesh->xyz + 3 * (size_t)c[2]) *
                 scale * scale;
    double third = tri / ((double)s * s) / 3;
    size_t row = 0; /* index in grid of (0, j) */
    for (uint32_t j = 0; j < s; j++) {
        size_t next_row = row + (s - j + 1);
        for (uint32_t i = 0; i + j < s; i++) {
            size_t a = grid[row + i], b = grid[row + i + 1],
                   d = grid[next_row + i];
            add_weight(q, a, third);
            add_weight(q, b, third);
            add_weight(q, d, third);
            if (i + j + 1 < s) {
                size_t e2 = grid[next_row + i + 1];
                add_weight(q, b, third);
                add_weight(q, e2, third);
                add_weight(q, d, third);
            }
        }
        row = next_row;
    }
}

phks_status phks__quadrature_build(const phks__unit_mesh *um,
                                   const phks_options *opt,
                                   phks__quadrature *q)
{
    const phks_mesh *mesh = um->mesh;
    const size_t n = mesh->vertex_count, nt = mesh->triangle_count;
    memset(q, 0, sizeof *q);
    q->vertex_count = n;
    q->count = n;
    const double width = sqrt(4 * opt->tau);
    uint32_t *s = phks__malloc_array(nt ? nt : 1, sizeof *s);
    if (!s)
        return phks__fail_oom("quadrature");
    uint32_t smax = 1;
    for (size_t t = 0; t < nt; t++) {
        s[t] = divisions(mesh, um->scale, width, t);
        smax = s[t] > smax ? s[t] : smax;
    }
    if (smax == 1) {
        /* no long triangle: the vertices are the quadrature */
        phks__free(s);
        return PHKS_OK;
    }
    phks_status st = PHKS_OK;
    size_t ne = mesh->edge_count;
    layout_ctx l = {mesh, s, phks__calloc(ne ? ne : 1, sizeof *l.edge_s),
                    phks__calloc(ne ? ne : 1, sizeof *l.edge_base), n};
    size_t *grid = NULL;
    if (!l.edge_s || !l.edge_base) {
        st = phks__fail_oom("quadrature");
        goto done;
    }
    /* count */
    for (size_t t = 0; t < nt; t++)
        if (s[t] > 1)
            layout_triangle(&l, q, t, um->scale, NULL);
    /* a point is a row of the operator: 2^32 of them are far beyond what
     * it can hold, and their indices are 32-bit */
    if (l.next >= UINT32_MAX) {
        st = phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                        "quadrature: %zu points; tau %g is too small for "
                        "this mesh's long triangles",
                        l.next, opt->tau);
        goto done;
    }
    q->count = l.next;
    size_t extra = q->count - n;
    /* the point indices of one triangle's grid, row by row */
    grid = phks__malloc_array((size_t)(smax + 1) * (smax + 2) / 2, sizeof *grid);
    q->xyz = phks__malloc_array(q->count, 3 * sizeof *q->xyz);
    q->area = phks__calloc(q->count, sizeof *q->area);
    q->corner = phks__malloc_array(extra, 3 * sizeof *q->corner);
    q->bary = phks__malloc_array(extra, 3 * sizeof *q->bary);
    if (!grid || !q->xyz || !q->area || !q->corner || !q->bary) {
        st = phks__fail_oom("quadrature");
        goto done;
    }
    memcpy(q->xyz, mesh->xyz, n * 3 * sizeof *q->xyz);
    /* the vertices' own triangles give their thirds as the vertex areas
     * do (the same formula, in the same order), long ones through their
     * corner sub-triangles below */
    for (size_t t = 0; t < nt; t++) {
        if (s[t] > 1)
            continue;
        const uint32_t *c = mesh->triangles + 3 * t;
        double a = phks__triangle_area(mesh->xyz + 3 * c[0], mesh->xyz + 3 * c[1],
                                       mesh->xyz + 3 * c[2]) *
                   um->scale * um->scale / 3;
        q->area[c[0]] += a;
        q->area[c[1]] += a;
        q->area[c[2]] += a;
    }
    memset(l.edge_s, 0, ne * sizeof *l.edge_s);
    l.next = n;
    for (size_t t = 0; t < nt; t++)
        if (s[t] > 1)
            layout_triangle(&l, q, t, um->scale, grid);
done:
    phks__free(s);
    phks__free(l.edge_s);
    phks__free(l.edge_base);
    phks__free(grid);
    if (st != PHKS_OK)
        phks__quadrature_release(q);
    return st;
}

void phks__quadrature_release(phks__quadrature *q)
{
    phks__free(q->xyz);
    phks__free(q->area);
    phks__free(q->corner);
    phks__free(q->bary);
    memset(q, 0, sizeof *q);
}

void phks__quadrature_lump(const phks__quadrature *q, const double *point,
                           double *vertex)
{
    memcpy(vertex, point, q->vertex_count * sizeof *vertex);
    for (size_t i = q->vertex_count; i < q->count; i++) {
        size_t j = i - q->vertex_count;
        for (int k = 0; k < 3; k++)
            vertex[q->corner[3 * j + k]] += q->bary[3 * j + k] * point[i];
    }
}
