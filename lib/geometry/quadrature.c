/*
 * quadrature.c - PHKS_QUADRATURE_TRIANGLES: where the operator takes its
 * sum over the surface when triangles are long (docs/method.md section 13).
 *
 * The operator of section 3 is a quadrature of the continuum kernel
 * operator at the vertices, each weighted by a third of its triangles'
 * area. That is accurate only while neighbouring quadrature points lie
 * within the kernel's width w = sqrt(4h) of each other: a CAD part's flat
 * face, two triangles a unit-box length long, has its only points at the
 * corners, the kernel between them is exp(-1 / 4h) = 0, and heat never
 * crosses the face. So every triangle whose longest edge (its base)
 * exceeds w is covered by a triangular lattice of side at most w: the base
 * cut into n = ceil(L / w) parts, the height into r rows at most
 * w sqrt(3) / 2 apart, each row's points a part apart and staggered by
 * half a part against the rows beside it, and the row's ends on the
 * triangle's two other sides. That is the coarsest mesh the vertex
 * quadrature accepts (every edge at most w), so a long triangle is summed
 * as accurately as a mesh the option leaves alone, with the points a
 * triangle of its area needs whatever its shape: a CAD sliver a unit long
 * and a kernel width wide gets two rows, not the (L / w)^2 / 2 points of a
 * subdivision into congruent triangles. Between two rows the points are
 * zipped into sub-triangles, each giving a third of its area to its
 * corners (the vertices' own lumping).
 *
 * The points are the mesh's vertices first (point v is vertex v, with its
 * input position), then the others: points on an edge are shared by the
 * triangles on both sides when they cut it into as many parts (their
 * position then computed once, from the edge's lower vertex), the rest
 * belong to one triangle. Each non-vertex point remembers the triangle
 * corners it interpolates and its barycentric weights (Lambda of section
 * 13), so that masses can be handed back to the vertices.
 */
#include "geometry/geometry.h"

#include <math.h>
#include <string.h>

/* Lengths this close are equal (relative): the lattices on the two
 * longest sides of an isosceles triangle are each other's mirror image,
 * and a segment an exact multiple of the width long has that many parts,
 * so that no choice depends on rounding; else a rotated copy of a
 * symmetric mesh would get other points (and another signature) than the
 * original. */
#define TIE 1e-9

/* Parts of at most `width` for a segment `length` long, 1 if it is no
 * longer; beyond any mesh the unit box holds at a tau options allow (the
 * count check of phks__quadrature_build refuses it). */
static uint32_t parts(double length, double width)
{
    double s = ceil(length / width - TIE);
    if (!(s > 1))
        return 1;
    return s < 1e6 ? (uint32_t)s : 1000000u;
}

/* The length of mesh edge (lo, hi) in the unit box, from its lower
 * vertex, so that both triangles at an edge get the same bits. */
static double edge_length(const phks_mesh *mesh, double scale, uint32_t u,
                          uint32_t v)
{
    const double *a = mesh->xyz + 3 * (size_t)(u < v ? u : v);
    const double *b = mesh->xyz + 3 * (size_t)(u < v ? v : u);
    double d2 = 0;
    for (int d = 0; d < 3; d++)
        d2 += (b[d] - a[d]) * (b[d] - a[d]);
    return sqrt(d2) * scale;
}

/* A long triangle's lattice (docs/method.md section 13): base a b, apex
 * p, the base cut into n parts and the height into r rows; xi is where p's
 * foot falls on the base line, as a fraction of the base. rows == 0 marks
 * a triangle no longer than the width (the vertex quadrature). */
typedef struct {
    uint32_t base;
    uint32_t parts;
    uint32_t rows;
    double xi;
} lattice;

/* Edge slot e of triangle c (e and e + 1) as a pair of vertex ids, lower
 * first: the tie-break between the sides of an equilateral triangle. */
static uint64_t edge_key(const uint32_t *c, uint32_t e)
{
    uint32_t u = c[e], v = c[(e + 1) % 3];
    return u < v ? (uint64_t)u << 32 | v : (uint64_t)v << 32 | u;
}

/* The base: the side whose length no other side shares, the longest if
 * none does. Any side would do (rows parallel to it are no longer than
 * it), but the lattice is symmetric about the base's perpendicular
 * bisector only: an isosceles triangle takes its odd side, so that its
 * lattice, and the lattice of a mirror-image twin, are mirror images
 * whatever the vertex order; an equilateral one gets the congruent
 * subdivision's lattice from every side. */
static uint32_t base_of(const uint32_t *c, const double length[3])
{
    for (uint32_t e = 0; e < 3; e++) {
        double x = length[(e + 1) % 3], y = length[(e + 2) % 3];
        if (fabs(x - y) <= TIE * fmax(x, y) &&
            fabs(length[e] - x) > TIE * fmax(length[e], x))
            return e;
    }
    uint32_t base = 3;
    for (uint32_t e = 0; e < 3; e++)
        if (length[e] >= fmax(length[0], fmax(length[1], length[2])) * (1 - TIE) &&
            (base == 3 || edge_key(c, e) < edge_key(c, base)))
            base = e;
    return base;
}

static lattice lattice_of(const phks_mesh *mesh, double scale, double width,
                          size_t t)
{
    const uint32_t *c = mesh->triangles + 3 * t;
    lattice g = {0, 1, 0, 0};
    double length[3], longest = 0;
    for (uint32_t e = 0; e < 3; e++) {
        length[e] = edge_length(mesh, scale, c[e], c[(e + 1) % 3]);
        longest = fmax(longest, length[e]);
    }
    if (parts(longest, width) == 1)
        return g;
    g.base = base_of(c, length);
    const double *a = mesh->xyz + 3 * (size_t)c[g.base];
    const double *b = mesh->xyz + 3 * (size_t)c[(g.base + 1) % 3];
    const double *p = mesh->xyz + 3 * (size_t)c[(g.base + 2) % 3];
    double dot = 0, bb = 0;
    for (int d = 0; d < 3; d++) {
        dot += (p[d] - a[d]) * (b[d] - a[d]);
        bb += (b[d] - a[d]) * (b[d] - a[d]);
    }
    double area = phks__triangle_area(a, b, p) * scale * scale;
    g.parts = parts(length[g.base], width);
    g.rows = parts(2 * area / length[g.base], width * (sqrt(3) / 2));
    g.xi = dot / bb;
    return g;
}

/* Row j (0 < j < r) runs from side a p to side b p, from `start` to `end`
 * along the base (fractions of it); its lattice points are at
 * (k + (j odd) / 2) / n, staggered against the rows beside it, from k =
 * *first to *last (none if *first > *last). One closer than a quarter of a
 * part to an end is left out for the side's own point. */
static void row_span(const lattice *g, uint32_t j, double *start, double *end,
                     int64_t *first, int64_t *last)
{
    double up = (double)j / g->rows, odd = (double)(j & 1) / 2;
    *start = up * g->xi;
    *end = 1 - up * (1 - g->xi);
    /* (an exact tie, as on a symmetric triangle, must not be left to
     * rounding either) */
    *first = (int64_t)ceil(g->parts * *start + 0.25 - odd - TIE);
    *last = (int64_t)floor(g->parts * *end - 0.25 - odd + TIE);
}

static uint32_t inner_count(const lattice *g, uint32_t j)
{
    double start, end;
    int64_t first, last;
    row_span(g, j, &start, &end, &first, &last);
    return last >= first ? (uint32_t)(last - first + 1) : 0;
}

/* Walks every long triangle's points in a fixed order: counts the points
 * (q->xyz NULL) or fills them. edge_parts / edge_base record the first
 * long triangle to cut an edge, zeroed by the caller before each walk. */
typedef struct {
    const phks_mesh *mesh;
    const lattice *lattices;  /* per triangle */
    uint32_t *edge_parts;     /* per edge: parts of its shared points, 0 */
    size_t *edge_base;        /* per edge: its first shared point        */
    size_t next;              /* next free point                         */
} layout_ctx;

/* A long triangle's edges: the first point index of each slot's points
 * and its parts (1: no points). */
typedef struct {
    uint32_t parts[3];
    size_t first[3];
} triangle_edges;

/* Claims edge slot e of triangle t, cut into k parts: the edge's shared
 * points when it is unclaimed or cut alike, else k - 1 of its own. */
static void claim_edge(layout_ctx *l, size_t t, uint32_t e, uint32_t k,
                       triangle_edges *te)
{
    uint32_t edge = l->mesh->triangle_edges[3 * t + e];
    te->parts[e] = k;
    if (k == 1)
        return;
    if (l->edge_parts[edge] == 0) {
        l->edge_parts[edge] = k;
        l->edge_base[edge] = l->next;
        l->next += k - 1;
    }
    if (l->edge_parts[edge] == k) {
        te->first[e] = l->edge_base[edge];
    } else {
        te->first[e] = l->next;
        l->next += k - 1;
    }
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

/* The point on edge slot e of triangle t with weight m / parts on corner
 * `toward`, 0 < m < parts: numbered, placed and weighted from the edge's
 * lower vertex. */
static size_t edge_point(const layout_ctx *l, phks__quadrature *q, size_t t,
                         const triangle_edges *te, uint32_t e,
                         uint32_t toward, uint32_t m)
{
    const phks_mesh *mesh = l->mesh;
    uint32_t edge = mesh->triangle_edges[3 * t + e];
    uint32_t lo = mesh->edge_vertices[2 * (size_t)edge];
    uint32_t hi = mesh->edge_vertices[2 * (size_t)edge + 1];
    uint32_t k = toward == hi ? m : te->parts[e] - m;
    size_t index = te->first[e] + (k - 1);
    uint32_t corner[3] = {lo, hi, hi};
    double bary[3] = {(double)(te->parts[e] - k) / te->parts[e],
                      (double)k / te->parts[e], 0};
    put_point(q, mesh, index, corner, bary);
    return index;
}

/* One row of a triangle's points, in order along the base: their indices
 * and their places x along the base line, as fractions of the base. */
typedef struct {
    size_t *index;
    double *x;
    uint32_t count;
} row_points;

/* Row j of triangle t: a, the base's points and b (j = 0); p (j = r);
 * else the point on side a p, the lattice points, the point on side b p.
 * A point at x along the base on row j (y = j / r of the height) is
 * a + (x - y xi)(b - a) + y (p - a). */
static void row_of(const layout_ctx *l, phks__quadrature *q, size_t t,
                   const triangle_edges *te, uint32_t j, size_t *interior,
                   row_points *row)
{
    const lattice *g = &l->lattices[t];
    const uint32_t *c = l->mesh->triangles + 3 * t;
    const uint32_t e = g->base, n = g->parts, r = g->rows;
    const uint32_t a = c[e], b = c[(e + 1) % 3], p = c[(e + 2) % 3];
    uint32_t count = 0;
    if (j == r) {
        row->index[0] = p;
        row->x[0] = g->xi;
        row->count = 1;
        return;
    }
    if (j == 0) {
        row->index[count] = a;
        row->x[count++] = 0;
        for (uint32_t i = 1; i < n; i++) {
            row->index[count] = edge_point(l, q, t, te, e, b, i);
            row->x[count++] = (double)i / n;
        }
        row->index[count] = b;
        row->x[count++] = 1;
        row->count = count;
        return;
    }
    double start, end, y = (double)j / r, odd = (double)(j & 1) / 2;
    int64_t first, last;
    row_span(g, j, &start, &end, &first, &last);
    row->index[count] = edge_point(l, q, t, te, (e + 2) % 3, p, j);
    row->x[count++] = start;
    for (int64_t k = first; k <= last; k++) {
        double x = ((double)k + odd) / n, along = x - y * g->xi;
        size_t index = (*interior)++;
        uint32_t corner[3] = {a, b, p};
        double bary[3] = {1 - along - y, along, y};
        put_point(q, l->mesh, index, corner, bary);
        row->index[count] = index;
        row->x[count++] = x;
    }
    row->index[count] = edge_point(l, q, t, te, (e + 1) % 3, p, j);
    row->x[count++] = end;
    row->count = count;
}

/* Adds a third of `area` to each corner of a sub-triangle (when filling). */
static void add_thirds(phks__quadrature *q, size_t x, size_t y, size_t z,
                       double area)
{
    if (!q->area)
        return;
    q->area[x] += area / 3;
    q->area[y] += area / 3;
    q->area[z] += area / 3;
}

/* One long triangle (area `tri` in the unit box): claims its edges,
 * numbers its points and (filling) stores them and lumps its sub-triangles
 * onto them. The strip between rows j and j + 1 is zipped along the base:
 * each sub-triangle has one side on a row, so its area is that side's
 * fraction of the base times T / r (they sum to T). `row` and `above` hold
 * two rows, parts + 1 points long. */
static void layout_triangle(layout_ctx *l, phks__quadrature *q, size_t t,
                            double tri, row_points *row, row_points *above)
{
    const lattice *g = &l->lattices[t];
    const uint32_t e = g->base, r = g->rows;
    triangle_edges te;
    claim_edge(l, t, e, g->parts, &te);
    claim_edge(l, t, (e + 1) % 3, r, &te);
    claim_edge(l, t, (e + 2) % 3, r, &te);
    size_t interior = l->next;
    /* (counting stops where the points are already too many) */
    for (uint32_t j = 1; j < r && l->next < UINT32_MAX; j++)
        l->next += inner_count(g, j);
    if (!row)
        return;
    row_of(l, q, t, &te, 0, &interior, row);
    for (uint32_t j = 0; j < r; j++) {
        row_of(l, q, t, &te, j + 1, &interior, above);
        const size_t *lo = row->index, *hi = above->index;
        const double *xl = row->x, *xh = above->x;
        uint32_t i = 0, k = 0, n = row->count - 1, m = above->count - 1;
        while (i < n || k < m) {
            if (k == m || (i < n && xl[i + 1] <= xh[k + 1])) {
                add_thirds(q, lo[i], lo[i + 1], hi[k], (xl[i + 1] - xl[i]) * tri / r);
                i++;
            } else {
                add_thirds(q, lo[i], hi[k + 1], hi[k], (xh[k + 1] - xh[k]) * tri / r);
                k++;
            }
        }
        row_points *swap = row;
        row = above, above = swap;
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
    lattice *lattices = phks__malloc_array(nt ? nt : 1, sizeof *lattices);
    if (!lattices)
        return phks__fail_oom("quadrature");
    uint32_t widest = 0; /* the most parts of a base: a row has at most
                            that many points, plus 2 */
    for (size_t t = 0; t < nt; t++) {
        lattices[t] = lattice_of(mesh, um->scale, width, t);
        if (lattices[t].rows && lattices[t].parts > widest)
            widest = lattices[t].parts;
    }
    if (widest == 0) {
        /* no long triangle: the vertices are the quadrature */
        phks__free(lattices);
        return PHKS_OK;
    }
    phks_status st = PHKS_OK;
    size_t ne = mesh->edge_count;
    layout_ctx l = {mesh, lattices,
                    phks__calloc(ne ? ne : 1, sizeof *l.edge_parts),
                    phks__calloc(ne ? ne : 1, sizeof *l.edge_base), n};
    size_t *index = NULL; /* two rows' points */
    double *place = NULL;
    row_points row[2];
    if (!l.edge_parts || !l.edge_base) {
        st = phks__fail_oom("quadrature");
        goto done;
    }
    /* count */
    for (size_t t = 0; t < nt && l.next < UINT32_MAX; t++)
        if (lattices[t].rows)
            layout_triangle(&l, q, t, 0, NULL, NULL);
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
    size_t span = (size_t)widest + 2;
    index = phks__malloc_array(span, 2 * sizeof *index);
    place = phks__malloc_array(span, 2 * sizeof *place);
    q->xyz = phks__malloc_array(q->count, 3 * sizeof *q->xyz);
    q->area = phks__calloc(q->count, sizeof *q->area);
    q->corner = phks__malloc_array(extra, 3 * sizeof *q->corner);
    q->bary = phks__malloc_array(extra, 3 * sizeof *q->bary);
    if (!index || !place || !q->xyz || !q->area || !q->corner || !q->bary) {
        st = phks__fail_oom("quadrature");
        goto done;
    }
    memcpy(q->xyz, mesh->xyz, n * 3 * sizeof *q->xyz);
    for (int k = 0; k < 2; k++)
        row[k] = (row_points){index + k * span, place + k * span, 0};
    memset(l.edge_parts, 0, ne * sizeof *l.edge_parts);
    l.next = n;
    /* every triangle in order: short ones give their corners a third of
     * their area as the vertex areas do (the same formula, in the same
     * order), long ones through their sub-triangles */
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *c = mesh->triangles + 3 * t;
        double a = phks__triangle_area(mesh->xyz + 3 * c[0], mesh->xyz + 3 * c[1],
                                       mesh->xyz + 3 * c[2]) *
                   um->scale * um->scale;
        if (lattices[t].rows)
            layout_triangle(&l, q, t, a, &row[0], &row[1]);
        else
            add_thirds(q, c[0], c[1], c[2], a);
    }
done:
    phks__free(lattices);
    phks__free(l.edge_parts);
    phks__free(l.edge_base);
    phks__free(index);
    phks__free(place);
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
