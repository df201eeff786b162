/*
 * persistence.c - persistent maxima of a vertex function and the induced
 * segmentation, by region merging (paper section 3.2 and appendix A,
 * NOTES.md section 4).
 *
 * Definitions (they fix every tie, so results never vary between runs):
 * - f has one finite value per vertex. Vertex order: (f, vertex index).
 * - hbar(simplex) = the largest f over its vertices.
 * - Triangle order: (hbar, triangle index). Edge order: (hbar, edge index),
 *   where edges are numbered as the mesh's edge table numbers them: the
 *   unique unordered vertex pairs sorted by (lower vertex, higher vertex).
 * - The highest vertex of a triangle is its vertex latest in vertex order.
 * - A region is a set of triangles with a central triangle: the one latest
 *   in triangle order. A boundary edge of a region has incident triangles
 *   both inside and outside it; an edge with a single incident triangle
 *   (mesh boundary) is never a boundary edge, which equals sealing each
 *   boundary loop with a virtual vertex below everything; a non-manifold
 *   edge (3+ triangles) stays a boundary edge until all its triangles are in
 *   one region. The pair edge of a region is its boundary edge latest in
 *   edge order, and its persistence p = hbar(central) - hbar(pair edge) >= 0.
 *   A region without boundary edges is unpaired: p = +infinity.
 *
 * Merging: every triangle starts as its own region. The region least in
 * (p, central triangle order) is merged into the region across its pair
 * edge whose central triangle is latest (one region for a manifold edge;
 * the eldest of several for a non-manifold one), which keeps its central
 * triangle. By Prop. 2 the popped region's (central, pair edge) is a true
 * persistence pair of the filtration, and the popped keys strictly increase
 * (the merged region's key is at least the target's). Merging goes on while
 * the least region has p <= threshold or more than max_count regions
 * remain (and it is paired). There the segmentation is taken; merging then
 * continues until only unpaired regions are left, so that each surviving
 * central triangle gets its true persistence: the p it had when popped, or
 * infinity. (With non-manifold edges this is the 0-dimensional persistence
 * of the dual graph in which such an edge joins all its triangles.)
 *
 * Data structures, for T triangles: a union-find over triangles (union by
 * rank, path halving) whose roots carry the region's central triangle and
 * its boundary edges as a pairing max-heap; the heap nodes are the 3T
 * corner-edge slots (node 3t+k is edge triangle_edges[3t+k] seen from
 * triangle t), so merging two regions is one meld. Edges that became
 * interior stay in the heaps and are dropped when they reach the top (lazy
 * deletion): an edge never leaves the interior of a region. The regions
 * wait in an indexed binary min-heap keyed by central triangle; a merge
 * only raises the key of the target, so no stale entries arise. Time
 * O(T log T) amortised, memory about 75 bytes per triangle.
 */
#include "internal.h"

#include <math.h>
#include <stdlib.h>

#define NIL UINT32_MAX

typedef struct merger {
    /* the mesh and f (read only) */
    const double *f;
    const uint32_t *triangles;
    const uint32_t *slot_edge;  /* triangle_edges: edge of each node    */
    const uint32_t *edge_start; /* edge_tri_offset                      */
    const uint32_t *edge_tris;
    /* keys */
    double *tri_h;   /* hbar per triangle                                 */
    double *edge_h;  /* hbar per edge                                     */
    double *pers;    /* p of the region a triangle is central to; after the
                        triangle is popped, its true persistence          */
    /* union-find over triangles; region data lives at the root */
    uint32_t *parent;
    uint8_t *rank;
    uint32_t *central;  /* central triangle of the region (at roots)      */
    uint32_t *heap;     /* root node of its boundary-edge heap, or NIL    */
    /* pairing heap nodes, 3 per triangle */
    uint32_t *child;
    uint32_t *sibling;
    /* regions by (p, central triangle order): min-heap of central
     * triangles and each one's position in it */
    uint32_t *queue;
    uint32_t *pos;
    size_t queue_size;
} merger;

static void merger_release(merger *m)
{
    phks_free(m->tri_h);
    phks_free(m->edge_h);
    phks_free(m->pers);
    phks_free(m->parent);
    phks_free(m->rank);
    phks_free(m->central);
    phks_free(m->heap);
    phks_free(m->child);
    phks_free(m->sibling);
    phks_free(m->queue);
    phks_free(m->pos);
}

/* ---- union-find */

static uint32_t find(merger *m, uint32_t t)
{
    uint32_t *p = m->parent;
    while (p[t] != t) {
        p[t] = p[p[t]];
        t = p[t];
    }
    return t;
}

static uint32_t unite(merger *m, uint32_t a, uint32_t b)
{
    if (m->rank[a] < m->rank[b]) {
        m->parent[a] = b;
        return b;
    }
    if (m->rank[a] == m->rank[b])
        m->rank[a]++;
    m->parent[b] = a;
    return a;
}

/* ---- orders */

/* Triangle a later than b in triangle order. */
static int tri_later(const merger *m, uint32_t a, uint32_t b)
{
    double ha = m->tri_h[a], hb = m->tri_h[b];
    return ha > hb || (ha == hb && a > b);
}

/* Node a below node b in edge order (of their edges). */
static int node_below(const merger *m, uint32_t a, uint32_t b)
{
    uint32_t ea = m->slot_edge[a], eb = m->slot_edge[b];
    double ha = m->edge_h[ea], hb = m->edge_h[eb];
    return ha < hb || (ha == hb && ea < eb);
}

/* Region of central triangle a before that of b: (p, triangle order). */
static int region_before(const merger *m, uint32_t a, uint32_t b)
{
    double pa = m->pers[a], pb = m->pers[b];
    if (pa != pb)
        return pa < pb;
    return tri_later(m, b, a);
}

/* ---- pairing max-heap of boundary edges */

static uint32_t meld(merger *m, uint32_t a, uint32_t b)
{
    if (a == NIL)
        return b;
    if (b == NIL)
        return a;
    if (node_below(m, a, b)) {
        uint32_t s = a;
        a = b;
        b = s;
    }
    m->sibling[b] = m->child[a];
    m->child[a] = b;
    return a;
}

/* Removes the root; returns the new root. Two-pass pairing, iterative. */
static uint32_t heap_pop(merger *m, uint32_t root)
{
    uint32_t c = m->child[root], pairs = NIL;
    while (c != NIL) {
        uint32_t a = c, b = m->sibling[a];
        if (b == NIL) {
            c = NIL;
        } else {
            c = m->sibling[b];
            a = meld(m, a, b);
        }
        m->sibling[a] = pairs; /* stack of the melded pairs */
        pairs = a;
    }
    uint32_t r = NIL;
    while (pairs != NIL) {
        uint32_t next = m->sibling[pairs];
        m->sibling[pairs] = NIL;
        r = meld(m, r, pairs);
        pairs = next;
    }
    return r;
}

/* Whether all triangles of edge e lie in the region rooted at root. */
static int edge_interior(merger *m, uint32_t e, uint32_t root)
{
    for (uint32_t i = m->edge_start[e]; i < m->edge_start[e + 1]; i++)
        if (find(m, m->edge_tris[i]) != root)
            return 0;
    return 1;
}

/* Drops interior edges from the top of the region's heap and sets the
 * persistence of its central triangle. */
static void settle_region(merger *m, uint32_t root)
{
    uint32_t h = m->heap[root];
    while (h != NIL && edge_interior(m, m->slot_edge[h], root))
        h = heap_pop(m, h);
    m->heap[root] = h;
    uint32_t t = m->central[root];
    m->pers[t] = h == NIL ? INFINITY : m->tri_h[t] - m->edge_h[m->slot_edge[h]];
}

/* ---- indexed min-heap of regions (by central triangle) */

static void queue_place(merger *m, size_t i, uint32_t t)
{
    m->queue[i] = t;
    m->pos[t] = (uint32_t)i;
}

static void queue_down(merger *m, size_t i)
{
    uint32_t t = m->queue[i];
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= m->queue_size)
            break;
        if (c + 1 < m->queue_size && region_before(m, m->queue[c + 1], m->queue[c]))
            c++;
        if (!region_before(m, m->queue[c], t))
            break;
        queue_place(m, i, m->queue[c]);
        i = c;
    }
    queue_place(m, i, t);
}

static void queue_up(merger *m, size_t i)
{
    uint32_t t = m->queue[i];
    while (i > 0) {
        size_t up = (i - 1) / 2;
        if (!region_before(m, t, m->queue[up]))
            break;
        queue_place(m, i, m->queue[up]);
        i = up;
    }
    queue_place(m, i, t);
}

static uint32_t queue_pop(merger *m)
{
    uint32_t t = m->queue[0];
    m->queue_size--;
    if (m->queue_size > 0) {
        queue_place(m, 0, m->queue[m->queue_size]);
        queue_down(m, 0);
    }
    return t;
}

/* ---- the algorithm */

static phks_status merger_init(merger *m, const phks_mesh *mesh, const double *f)
{
    size_t n_t = mesh->triangle_count, n_e = mesh->edge_count;
    *m = (merger){0};
    m->f = f;
    m->triangles = mesh->triangles;
    m->slot_edge = mesh->triangle_edges;
    m->edge_start = mesh->edge_tri_offset;
    m->edge_tris = mesh->edge_tris;
    m->tri_h = phks_malloc_array(n_t, sizeof *m->tri_h);
    m->edge_h = phks_malloc_array(n_e, sizeof *m->edge_h);
    m->pers = phks_malloc_array(n_t, sizeof *m->pers);
    m->parent = phks_malloc_array(n_t, sizeof *m->parent);
    m->rank = phks_calloc(n_t, sizeof *m->rank);
    m->central = phks_malloc_array(n_t, sizeof *m->central);
    m->heap = phks_malloc_array(n_t, sizeof *m->heap);
    m->child = phks_malloc_array(n_t, 3 * sizeof *m->child);
    m->sibling = phks_malloc_array(n_t, 3 * sizeof *m->sibling);
    m->queue = phks_malloc_array(n_t, sizeof *m->queue);
    m->pos = phks_malloc_array(n_t, sizeof *m->pos);
    if (!m->tri_h || !m->edge_h || !m->pers || !m->parent || !m->rank ||
        !m->central || !m->heap || !m->child || !m->sibling || !m->queue ||
        !m->pos) {
        merger_release(m);
        return phks_fail_oom("persistence work arrays");
    }

    for (size_t e = 0; e < n_e; e++)
        m->edge_h[e] = fmax(f[mesh->edge_vertices[2 * e]],
                            f[mesh->edge_vertices[2 * e + 1]]);
    for (uint32_t t = 0; t < n_t; t++) {
        const uint32_t *c = m->triangles + 3 * (size_t)t;
        m->tri_h[t] = fmax(f[c[0]], fmax(f[c[1]], f[c[2]]));
        m->parent[t] = t;
        m->central[t] = t;
        uint32_t h = NIL;
        for (uint32_t k = 0; k < 3; k++) {
            uint32_t node = 3 * t + k, e = m->slot_edge[node];
            m->child[node] = NIL;
            m->sibling[node] = NIL;
            if (m->edge_start[e + 1] - m->edge_start[e] >= 2)
                h = meld(m, h, node);
        }
        /* A single triangle has no interior edge: settling only sets p. */
        m->heap[t] = h;
        m->pers[t] = h == NIL ? INFINITY
                              : m->tri_h[t] - m->edge_h[m->slot_edge[h]];
        m->queue[t] = t;
        m->pos[t] = t;
    }
    m->queue_size = n_t;
    for (size_t i = n_t / 2; i-- > 0;)
        queue_down(m, i);
    return PHKS_OK;
}

/* Pops the least region (which must be paired) and merges it into the
 * region across its pair edge with the latest central triangle. */
static void merge_least(merger *m)
{
    uint32_t t = queue_pop(m);
    uint32_t r = find(m, t);
    uint32_t e = m->slot_edge[m->heap[r]];
    uint32_t target = NIL;
    for (uint32_t i = m->edge_start[e]; i < m->edge_start[e + 1]; i++) {
        uint32_t q = find(m, m->edge_tris[i]);
        if (q != r && (target == NIL ||
                       tri_later(m, m->central[q], m->central[target])))
            target = q;
    }
    uint32_t keep = m->central[target];
    uint32_t h = meld(m, m->heap[r], m->heap[target]);
    uint32_t root = unite(m, r, target);
    m->central[root] = keep;
    m->heap[root] = h;
    settle_region(m, root);
    /* The key of keep only grows; sifting both ways costs nothing more. */
    queue_up(m, m->pos[keep]);
    queue_down(m, m->pos[keep]);
}

static int least_is_paired(const merger *m)
{
    return m->queue_size > 0 && isfinite(m->pers[m->queue[0]]);
}

/* Highest vertex of triangle t: latest in (f, vertex index). */
static uint32_t highest_vertex(const merger *m, uint32_t t)
{
    const uint32_t *c = m->triangles + 3 * (size_t)t;
    uint32_t best = c[0];
    for (int k = 1; k < 3; k++) {
        double a = m->f[c[k]], b = m->f[best];
        if (a > b || (a == b && c[k] > best))
            best = c[k];
    }
    return best;
}

/* Most persistent first; ties: later central triangle first. value is
 * hbar of the central triangle, so (value, triangle) is triangle order. */
static int maximum_cmp(const void *pa, const void *pb)
{
    const phks_maximum *a = pa, *b = pb;
    if (a->persistence != b->persistence)
        return a->persistence > b->persistence ? -1 : 1;
    if (a->value != b->value)
        return a->value > b->value ? -1 : 1;
    return a->triangle > b->triangle ? -1 : a->triangle < b->triangle;
}

phks_status phks_persistent_maxima(const phks_mesh *mesh, const double *f,
                                   size_t max_count, double threshold,
                                   phks_maximum *out, size_t *count,
                                   uint32_t *region_of_triangle)
{
    if (count)
        *count = 0;
    if (!mesh || !f || !out || !count)
        return phks_fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_persistent_maxima: NULL argument");
    if (max_count == 0)
        return phks_fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_persistent_maxima: max_count is 0");
    if (!(threshold >= 0))
        return phks_fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_persistent_maxima: threshold %g is negative "
                         "or NaN",
                         threshold);
    for (size_t v = 0; v < mesh->vertex_count; v++)
        if (!isfinite(f[v]))
            return phks_fail(PHKS_ERROR_NON_FINITE,
                             "phks_persistent_maxima: vertex %zu: value %g "
                             "is not finite",
                             v, f[v]);

    merger m;
    phks_status st = merger_init(&m, mesh, f);
    if (st != PHKS_OK)
        return st;
    size_t n_t = mesh->triangle_count;

    while (least_is_paired(&m) && (m.pers[m.queue[0]] <= threshold ||
                                   m.queue_size > max_count))
        merge_least(&m);

    /* The segmentation, as central triangles for now. */
    if (region_of_triangle)
        for (uint32_t t = 0; t < n_t; t++)
            region_of_triangle[t] = m.central[find(&m, t)];
    /* More regions than max_count remain only when all are unpaired
     * (more components than max_count): the earliest in triangle order
     * are left out, and their triangles labelled UINT32_MAX. */
    while (m.queue_size > max_count)
        queue_pop(&m);
    size_t n = m.queue_size;
    for (size_t i = 0; i < n; i++)
        out[i].triangle = m.queue[i];

    /* Every later pop is a survivor's: record its true persistence. */
    while (least_is_paired(&m))
        merge_least(&m);

    for (size_t i = 0; i < n; i++) {
        uint32_t t = out[i].triangle;
        out[i].vertex = highest_vertex(&m, t);
        out[i].value = f[out[i].vertex];
        out[i].persistence = m.pers[t];
    }
    qsort(out, n, sizeof *out, maximum_cmp);

    if (region_of_triangle) {
        uint32_t *index_of = m.pos; /* the queue is done with */
        for (size_t t = 0; t < n_t; t++)
            index_of[t] = NIL;
        for (size_t i = 0; i < n; i++)
            index_of[out[i].triangle] = (uint32_t)i;
        for (size_t t = 0; t < n_t; t++)
            region_of_triangle[t] = index_of[region_of_triangle[t]];
    }
    *count = n;
    merger_release(&m);
    return PHKS_OK;
}
