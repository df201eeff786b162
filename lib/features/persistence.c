/*
 * persistence.c - persistent maxima of a vertex function and the induced
 * segmentation, by region merging (paper section 3.2 and appendix A,
 * docs/method.md section 7).
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
 * (the merged region's p is at least the target's, as its pair edge is not
 * later than the target's). Merging goes on while the least region has
 * p <= threshold or more than max_count regions remain (and it is paired).
 * There the segmentation is taken. Each surviving central triangle's true
 * persistence is the p it would have when popped if merging went on, or
 * infinity. (With non-manifold edges all this is the 0-dimensional
 * persistence of the dual graph in which such an edge joins all its
 * triangles, not the Z/2 homology of the complex.)
 *
 * Implementation, for T triangles:
 * - f is replaced by the dense ranks of its distinct values (a radix sort
 *   of the vertices), so orders compare integers and p = 0 exactly when
 *   the two ranks are equal.
 * - A union-find over triangles in which a popped region's root is linked
 *   under its target's: the root of a region is always its central
 *   triangle. Each root holds its region's boundary edges in a pairing
 *   max-heap whose nodes are the corner edges of the triangles (node 4t+k
 *   is edge triangle_edges[3t+k] seen from triangle t), keyed by (edge
 *   rank, edge), so merging two regions is one meld. Edges that became
 *   interior stay in the heaps and are dropped when they reach the top
 *   (lazy deletion): an edge never leaves the interior of a region. A
 *   triangle's heap and rank and its three nodes share one 64-byte cache
 *   line.
 * - Zero-persistence regions, the vast majority, always merge first and in
 *   triangle order, and p never decreases: so they are found by one sweep
 *   over the triangles in triangle order (a counting sort by rank) merging
 *   each region whose p is 0 when its central triangle comes up. A merge
 *   only grows a region whose central triangle comes later.
 * - The remaining regions (about one per maximum of f) get fresh heaps of
 *   their boundary edges alone, each region's nodes side by side (the old
 *   heaps are mostly interior edges by then), and go into an indexed
 *   binary min-heap keyed by (p, triangle order). A merge only raises the
 *   target's key, so no stale entries arise.
 * - Once the segmentation is taken, going on merging until the end is
 *   region merging on the quotient graph (survivors as nodes, their
 *   boundary edges as edges), whose pairs are those of the dual sweep
 *   (docs/method.md section 7): the survivors' persistences come from sorting
 *   their boundary edges and one union-find sweep over them, instead of
 *   draining heaps that by then hold nearly every edge.
 * Time O(T log T): pairing heaps and the union-find (path halving, the
 * popped root linked under the target's) are O(log T) amortised per
 * operation; the sorts are linear. Memory: 74 bytes per triangle, plus 16
 * per boundary-edge side after the sweep (few for smooth functions, at
 * most 48 per triangle). On a large mesh that is long enough to need
 * progress, longer for a function with many maxima (timings in
 * docs/benchmarks.md). So the signature
 * path (phks__persistence_run) reports progress inside every phase, every
 * so many steps, and stops at the next report when cancelled; the steps
 * and the results are the same with or without a callback.
 */
#include "features/features.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NIL UINT32_MAX

/* Boundary-edge heap node: key = edge rank << 32 | edge index. */
typedef struct heap_node {
    uint64_t key;
    uint32_t child;
    uint32_t sibling;
} heap_node;

/* What the merging reads about one triangle, in one cache line. */
typedef struct tri_state {
    heap_node node[3]; /* its edges (corners 0-1, 1-2, 2-0)             */
    uint32_t heap;     /* at a root: root node of its heap, or NIL      */
    uint32_t rank;     /* rank of hbar                                  */
    uint32_t slot;     /* at a surviving central triangle: its number,
                          else NIL                                      */
    uint32_t unused;
} tri_state;

_Static_assert(sizeof(tri_state) == 64, "tri_state is one cache line");

/* A region in the queue: its p and its central triangle (rank, index). */
typedef struct region_entry {
    double p;
    uint32_t rank;
    uint32_t t;
} region_entry;

typedef struct merger {
    const phks_mesh *mesh;
    const uint32_t *edge_start; /* mesh edge_tri_offset */
    const uint32_t *edge_tris;
    uint32_t *parent;       /* union-find over triangles; a root is the
                               central triangle of its region. Apart
                               from tri: finds touch many neighbours,
                               and 16 links share a cache line          */
    void *tri_block;        /* allocation holding tri                    */
    tri_state *tri;         /* per triangle, 64-byte aligned             */
    double *value;          /* distinct values of f, ascending           */
    uint32_t *vertex_rank;  /* index of f[v] in value                    */
    uint32_t *order;        /* triangles in triangle order; then, indexed
                               by central triangle, positions in queue   */
    heap_node *nodes;       /* after the sweep: the boundary edges' nodes,
                               each region's together; NULL before, when
                               node 4t+k is tri[t].node[k]               */
    region_entry *queue;
    size_t queue_size;
    /* Progress through `at`; the current phase covers [from, from +
     * width) of it. */
    phks__span at;
    double from, width;
    size_t pops;            /* heap nodes popped so far: the merging
                               loops count them as steps                */
} merger;

static void merger_release(merger *m)
{
    phks__free(m->parent);
    phks__free(m->tri_block);
    phks__free(m->value);
    phks__free(m->vertex_rank);
    phks__free(m->order);
    phks__free(m->queue);
    phks__free(m->nodes);
}

/* ---- progress: each phase has a share of the stage's span (its share
 * of the time measured on a large mesh and a smooth f) and reports at its
 * start and every so many steps inside: 2^16 for the steps that merge or
 * build heaps (in the merging loops a heap pop is a step too), 2^18 for
 * plain passes over triangles or edges, which are far cheaper per step,
 * so that the interval between reports, and the wait for a cancellation
 * to be noticed, stays short and about the same whatever the mesh size
 * (the step costs and intervals measured are in docs/benchmarks.md).
 * The number of reports depends on the mesh and f alone, never
 * on timing. */

enum { PHASE_RANKS, PHASE_INIT, PHASE_SWEEP, PHASE_HEAPS, PHASE_QUEUE,
       PHASE_SURVIVORS, PHASE_COUNT };
static const double phase_start[PHASE_COUNT + 1] = {0,    0.06, 0.28, 0.8,
                                                    0.92, 0.94, 1};

#define HEAVY 16 /* log2 of the steps between reports */
#define LIGHT 18

/* Whether a loop at step i is due to report: every 2^shift, not at 0. */
static int due(size_t i, unsigned shift)
{
    return (i & (((size_t)1 << shift) - 1)) == 0 && i > 0;
}

/* The same for the merging loops, whose steps are their iterations plus
 * the heap pops they cause (a merge late in the queue can pop thousands
 * of interior edges): due when steps reach *next, which then moves on. */
static int due_steps(size_t steps, size_t *next)
{
    if (steps < *next)
        return 0;
    *next = steps + ((size_t)1 << HEAVY);
    return 1;
}

/* Reports the fraction i / n of the current phase. */
static phks_status report(const merger *m, size_t i, size_t n)
{
    if (!m->at.opt || !m->at.opt->progress)
        return PHKS_OK;
    double x = m->from + m->width * (n > 0 && i < n ? (double)i / (double)n : 1);
    return phks__span_report(m->at, x);
}

/* Starts the part [from, to) (fractions of it) of phase p, with a
 * report. */
static phks_status phase(merger *m, int p, double from, double to)
{
    double width = phase_start[p + 1] - phase_start[p];
    m->from = phase_start[p] + from * width;
    m->width = (to - from) * width;
    return report(m, 0, 1);
}

/* ---- sorting and ranks */

/* phks__radix_sort on all 64 bits, reporting through the current phase. */
static phks_status radix_sort(const merger *m, phks__keyed *a, phks__keyed *tmp,
                              size_t n, phks__keyed **sorted)
{
    phks__span phase = phks__span_part(m->at, m->from, m->from + m->width);
    return phks__radix_sort(a, tmp, n, 64, phase, sorted);
}

/* A key whose unsigned order is the order of the doubles (-0 as +0). */
static uint64_t double_key(double x)
{
    x += 0.0;
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    return u >> 63 ? ~u : u | (uint64_t)1 << 63;
}

/* m->vertex_rank[v] = index of f[v] among the distinct values of f, which
 * go to m->value in ascending order. */
static phks_status rank_values(merger *m, const double *f, size_t n)
{
    m->vertex_rank = phks__malloc_array(n, sizeof *m->vertex_rank);
    m->value = phks__malloc_array(n, sizeof *m->value);
    phks__keyed *a = phks__malloc_array(n, sizeof *a);
    phks__keyed *tmp = phks__malloc_array(n, sizeof *tmp);
    if (!m->vertex_rank || !m->value || !a || !tmp) {
        phks__free(a);
        phks__free(tmp);
        return phks__fail_oom("persistence ranks");
    }
    for (size_t v = 0; v < n; v++)
        a[v] = (phks__keyed){double_key(f[v]), (uint32_t)v};
    phks__keyed *s = NULL;
    phks_status st = radix_sort(m, a, tmp, n, &s);
    uint32_t r = 0;
    for (size_t i = 0; st == PHKS_OK && i < n; i++) {
        double x = f[s[i].id];
        if (i > 0 && x != m->value[r])
            r++;
        m->value[r] = x;
        m->vertex_rank[s[i].id] = r;
    }
    phks__free(a);
    phks__free(tmp);
    return st;
}

static uint32_t edge_rank(const merger *m, uint32_t e)
{
    uint32_t a = m->vertex_rank[m->mesh->edge_vertices[2 * (size_t)e]];
    uint32_t b = m->vertex_rank[m->mesh->edge_vertices[2 * (size_t)e + 1]];
    return a > b ? a : b;
}

/* ---- union-find: path halving; roots are central triangles */

static uint32_t find(merger *m, uint32_t t)
{
    return phks__find_root(m->parent, t);
}

/* Triangle a later than b in triangle order. */
static int tri_later(const merger *m, uint32_t a, uint32_t b)
{
    uint32_t ra = m->tri[a].rank, rb = m->tri[b].rank;
    return ra > rb || (ra == rb && a > b);
}

/* ---- pairing max-heap of boundary edges */

static heap_node *node_at(const merger *m, uint32_t id)
{
    return m->nodes ? &m->nodes[id] : &m->tri[id >> 2].node[id & 3];
}

static uint32_t meld(merger *m, uint32_t a, uint32_t b)
{
    if (a == NIL)
        return b;
    if (b == NIL)
        return a;
    heap_node *na = node_at(m, a), *nb = node_at(m, b);
    if (na->key < nb->key) {
        heap_node *s = na;
        na = nb;
        nb = s;
        uint32_t t = a;
        a = b;
        b = t;
    }
    nb->sibling = na->child;
    na->child = b;
    return a;
}

/* Removes the root; returns the new root. Two-pass pairing, iterative. */
static uint32_t heap_pop(merger *m, uint32_t root)
{
    uint32_t c = node_at(m, root)->child, pairs = NIL;
    while (c != NIL) {
        uint32_t a = c, b = node_at(m, a)->sibling;
        if (b == NIL) {
            c = NIL;
        } else {
            c = node_at(m, b)->sibling;
            a = meld(m, a, b);
        }
        node_at(m, a)->sibling = pairs; /* stack of the melded pairs */
        pairs = a;
    }
    uint32_t r = NIL;
    while (pairs != NIL) {
        uint32_t next = node_at(m, pairs)->sibling;
        node_at(m, pairs)->sibling = NIL;
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

/* Drops interior edges from the top of the region's heap; returns the
 * pair-edge node, or NIL when the region is unpaired. */
static uint32_t settle(merger *m, uint32_t root)
{
    uint32_t h = m->tri[root].heap;
    while (h != NIL && edge_interior(m, (uint32_t)node_at(m, h)->key, root)) {
        h = heap_pop(m, h);
        m->pops++;
    }
    m->tri[root].heap = h;
    return h;
}

/* p of a settled region. */
static double region_p(const merger *m, uint32_t root)
{
    uint32_t h = m->tri[root].heap;
    if (h == NIL)
        return INFINITY;
    return m->value[m->tri[root].rank] - m->value[node_at(m, h)->key >> 32];
}

/* Merges the settled, paired region at root into the region across its
 * pair edge whose central triangle is latest. Returns the target root. */
static uint32_t merge_across(merger *m, uint32_t root)
{
    uint32_t e = (uint32_t)node_at(m, m->tri[root].heap)->key, target = NIL;
    for (uint32_t i = m->edge_start[e]; i < m->edge_start[e + 1]; i++) {
        uint32_t q = find(m, m->edge_tris[i]);
        if (q != root && (target == NIL || tri_later(m, q, target)))
            target = q;
    }
    m->tri[target].heap = meld(m, m->tri[root].heap, m->tri[target].heap);
    m->tri[root].heap = NIL;
    m->parent[root] = target;
    return target;
}

/* ---- indexed min-heap of regions by (p, triangle order) */

static int entry_before(const region_entry *a, const region_entry *b)
{
    if (a->p != b->p)
        return a->p < b->p;
    if (a->rank != b->rank)
        return a->rank < b->rank;
    return a->t < b->t;
}

static void queue_down(merger *m, size_t i)
{
    region_entry *q = m->queue, x = q[i];
    uint32_t *pos = m->order;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= m->queue_size)
            break;
        if (c + 1 < m->queue_size && entry_before(&q[c + 1], &q[c]))
            c++;
        if (!entry_before(&q[c], &x))
            break;
        q[i] = q[c];
        pos[q[i].t] = (uint32_t)i;
        i = c;
    }
    q[i] = x;
    pos[x.t] = (uint32_t)i;
}

static void queue_up(merger *m, size_t i)
{
    region_entry *q = m->queue, x = q[i];
    uint32_t *pos = m->order;
    while (i > 0) {
        size_t up = (i - 1) / 2;
        if (!entry_before(&x, &q[up]))
            break;
        q[i] = q[up];
        pos[q[i].t] = (uint32_t)i;
        i = up;
    }
    q[i] = x;
    pos[x.t] = (uint32_t)i;
}

static void queue_pop(merger *m)
{
    m->queue_size--;
    if (m->queue_size > 0) {
        m->queue[0] = m->queue[m->queue_size];
        queue_down(m, 0);
    }
}

static int least_is_paired(const merger *m)
{
    return m->queue_size > 0 && isfinite(m->queue[0].p);
}

/* Pops the least region (paired) and merges it. */
static void queue_merge_least(merger *m)
{
    uint32_t t = m->queue[0].t;
    queue_pop(m);
    uint32_t target = merge_across(m, t);
    settle(m, target);
    size_t i = m->order[target];
    m->queue[i].p = region_p(m, target);
    /* The key only grows; sifting both ways costs nothing more. */
    queue_up(m, i);
    queue_down(m, m->order[target]);
}

/* ---- the phases */

/* Ranks, per-triangle state and triangle order, for a merger whose
 * progress fields are set and the rest zero. Releases m on failure. */
static phks_status merger_init(merger *m, const phks_mesh *mesh, const double *f)
{
    size_t n_v = mesh->vertex_count, n_t = mesh->triangle_count;
    m->mesh = mesh;
    m->edge_start = mesh->edge_tri_offset;
    m->edge_tris = mesh->edge_tris;
    phks_status st = phase(m, PHASE_RANKS, 0, 1);
    if (st == PHKS_OK)
        st = rank_values(m, f, n_v);
    if (st == PHKS_OK)
        st = phase(m, PHASE_INIT, 0, 1);
    if (st != PHKS_OK) {
        merger_release(m);
        return st;
    }
    /* One spare element leaves room to align to 64 bytes. */
    m->tri_block = phks__malloc_array(n_t + 1, sizeof(tri_state));
    m->order = phks__malloc_array(n_t, sizeof *m->order);
    m->parent = phks__malloc_array(n_t, sizeof *m->parent);
    uint32_t *start = phks__calloc(n_v + 1, sizeof *start);
    if (!m->tri_block || !m->order || !m->parent || !start) {
        phks__free(start);
        merger_release(m);
        return phks__fail_oom("persistence work arrays");
    }
    m->tri = (tri_state *)(((uintptr_t)m->tri_block + 63) & ~(uintptr_t)63);

    const uint32_t *corner = mesh->triangles;
    for (uint32_t t = 0; t < n_t; t++) {
        if (due(t, HEAVY) && (st = report(m, t, n_t)) != PHKS_OK) {
            phks__free(start);
            merger_release(m);
            return st;
        }
        const uint32_t *c = corner + 3 * (size_t)t;
        const uint32_t r[3] = {m->vertex_rank[c[0]], m->vertex_rank[c[1]],
                               m->vertex_rank[c[2]]};
        tri_state *s = &m->tri[t];
        uint32_t top = r[0] > r[1] ? r[0] : r[1];
        s->rank = top > r[2] ? top : r[2];
        s->slot = NIL;
        s->unused = 0;
        m->parent[t] = t;
        start[s->rank + 1]++;
        uint32_t h = NIL;
        for (uint32_t k = 0; k < 3; k++) {
            uint32_t e = mesh->triangle_edges[3 * (size_t)t + k];
            uint32_t er = r[k] > r[(k + 1) % 3] ? r[k] : r[(k + 1) % 3];
            s->node[k] = (heap_node){(uint64_t)er << 32 | e, NIL, NIL};
            if (m->edge_start[e + 1] - m->edge_start[e] >= 2)
                h = meld(m, h, 4 * t + k);
        }
        s->heap = h;
    }
    /* Counting sort by rank, stable: triangle order. */
    for (size_t r = 0; r < n_v; r++)
        start[r + 1] += start[r];
    for (uint32_t t = 0; t < n_t; t++)
        m->order[start[m->tri[t].rank]++] = t;
    phks__free(start);
    return PHKS_OK;
}

/* Merges every zero-persistence region, in triangle order; leaves the
 * others (settled) in m->order[0 .. *kept) and counts the merges into
 * *merges. */
static phks_status merge_zero_persistence(merger *m, size_t n_t, size_t *kept,
                                          size_t *merges)
{
    size_t k = 0, start = m->pops, next = (size_t)1 << HEAVY;
    *merges = 0;
    phks_status st = phase(m, PHASE_SWEEP, 0, 1);
    for (size_t i = 0; st == PHKS_OK && i < n_t; i++) {
        if (due_steps(i + m->pops - start, &next) &&
            (st = report(m, i, n_t)) != PHKS_OK)
            break;
        uint32_t t = m->order[i]; /* a root: not merged yet */
        uint32_t h = settle(m, t);
        if (h != NIL && node_at(m, h)->key >> 32 == m->tri[t].rank) {
            merge_across(m, t);
            ++*merges;
        } else {
            m->order[k++] = t;
        }
    }
    *kept = k;
    return st;
}

/* Whether edge e has a triangle outside the region of triangle t, for a
 * flattened union-find. */
static int leaves_region(const merger *m, uint32_t e, uint32_t t)
{
    const uint32_t *p = m->parent;
    for (uint32_t i = m->edge_start[e]; i < m->edge_start[e + 1]; i++)
        if (p[m->edge_tris[i]] != p[t])
            return 1;
    return 0;
}

/* After the sweep the heaps hold mostly interior edges, each to be popped
 * when it surfaces, scattered over all triangles. Rebuilds them from the
 * boundary edges alone, into m->nodes where each region's nodes are
 * contiguous (the kept regions are m->order[0 .. kept)). Flattens the
 * union-find on the way. */
static phks_status rebuild_heaps(merger *m, size_t n_t, size_t kept)
{
    uint32_t *p = m->parent;
    phks_status st = phase(m, PHASE_HEAPS, 0, 1);
    if (st != PHKS_OK)
        return st;
    uint32_t *start = phks__calloc(kept + 1, sizeof *start);
    if (!start)
        return phks__fail_oom("persistence heaps");
    for (uint32_t i = 0; i < kept; i++) {
        m->tri[m->order[i]].slot = i; /* region number, for now */
        m->tri[m->order[i]].heap = NIL;
    }
    /* Three passes over the triangles: a third of the phase each. */
    for (uint32_t t = 0; t < n_t; t++) {
        if (due(t, LIGHT) && (st = report(m, t, 3 * n_t)) != PHKS_OK)
            goto fail;
        p[t] = find(m, t);
    }
    /* The old nodes are dead: their child field notes boundary edges. */
    for (uint32_t t = 0; t < n_t; t++) {
        if (due(t, LIGHT) && (st = report(m, n_t + t, 3 * n_t)) != PHKS_OK)
            goto fail;
        for (uint32_t k = 0; k < 3; k++) {
            heap_node *old = &m->tri[t].node[k];
            old->child = (uint32_t)leaves_region(m, (uint32_t)old->key, t);
            start[m->tri[p[t]].slot + 1] += old->child;
        }
    }
    for (size_t i = 0; i < kept; i++)
        start[i + 1] += start[i];
    m->nodes = phks__malloc_array(start[kept] ? start[kept] : 1, sizeof *m->nodes);
    if (!m->nodes) {
        st = phks__fail_oom("persistence heaps");
        goto fail;
    }
    for (uint32_t t = 0; t < n_t; t++) {
        if (due(t, LIGHT) && (st = report(m, 2 * n_t + t, 3 * n_t)) != PHKS_OK)
            goto fail;
        for (uint32_t k = 0; k < 3; k++) {
            uint64_t key = m->tri[t].node[k].key;
            if (!m->tri[t].node[k].child)
                continue;
            tri_state *root = &m->tri[p[t]];
            uint32_t id = start[root->slot]++;
            m->nodes[id] = (heap_node){key, NIL, NIL};
            root->heap = meld(m, root->heap, id);
        }
    }
    for (uint32_t i = 0; i < kept; i++)
        m->tri[m->order[i]].slot = NIL;
fail:
    phks__free(start);
    return st;
}

/* Fills the queue with the regions left by the sweep. m->order becomes
 * the queue positions, indexed by central triangle. */
static phks_status queue_build(merger *m, size_t kept)
{
    phks_status st = phase(m, PHASE_QUEUE, 0, 1);
    if (st != PHKS_OK)
        return st;
    m->queue = phks__malloc_array(kept ? kept : 1, sizeof *m->queue);
    if (!m->queue)
        return phks__fail_oom("persistence queue");
    for (size_t i = 0; i < kept; i++) {
        uint32_t t = m->order[i];
        m->queue[i] = (region_entry){region_p(m, t), m->tri[t].rank, t};
    }
    for (size_t i = 0; i < kept; i++)
        m->order[m->queue[i].t] = (uint32_t)i;
    m->queue_size = kept;
    for (size_t i = kept / 2; i-- > 0;)
        queue_down(m, i);
    return PHKS_OK;
}

/* Whether edge e is a boundary edge of the segmentation label. */
static int is_boundary(const merger *m, const uint32_t *label, uint32_t e)
{
    uint32_t i = m->edge_start[e], end = m->edge_start[e + 1];
    uint32_t first = label[m->edge_tris[i]];
    for (i++; i < end; i++)
        if (label[m->edge_tris[i]] != first)
            return 1;
    return 0;
}

/* The true persistence of the n regions left, queue[0 .. n), into
 * queue[i].p: the dual sweep over their boundary edges by decreasing edge
 * order; when an edge joins groups of regions, all but the one whose
 * central triangle is latest die with hbar(its central) - hbar(edge).
 * Also flattens the union-find (every parent is then the central) and
 * numbers the survivors: tri[queue[i].t].slot = i. */
static phks_status survivors_persistence(merger *m, size_t n)
{
    size_t n_t = m->mesh->triangle_count, n_e = m->mesh->edge_count, b = 0;
    phks_status st = phase(m, PHASE_SURVIVORS, 0, 0.5);
    if (st != PHKS_OK)
        return st;
    for (uint32_t i = 0; i < n; i++) {
        m->queue[i].p = INFINITY;
        m->tri[m->queue[i].t].slot = i;
    }
    uint32_t *label = m->order; /* the queue is done with */
    for (uint32_t t = 0; t < n_t; t++) {
        if (due(t, LIGHT) && (st = report(m, t, n_t + n_e)) != PHKS_OK)
            return st;
        m->parent[t] = find(m, t);
        label[t] = m->tri[m->parent[t]].slot;
    }
    for (uint32_t e = 0; e < n_e; e++) {
        if (due(e, LIGHT) && (st = report(m, n_t + e, n_t + n_e)) != PHKS_OK)
            return st;
        b += is_boundary(m, label, e) != 0;
    }
    if (b == 0)
        return PHKS_OK;
    phks__keyed *a = phks__malloc_array(b, sizeof *a);
    phks__keyed *tmp = phks__malloc_array(b, sizeof *tmp);
    uint32_t *up = phks__malloc_array(n, sizeof *up);
    uint32_t *top = phks__malloc_array(n, sizeof *top); /* latest central */
    if (!a || !tmp || !up || !top) {
        phks__free(a);
        phks__free(tmp);
        phks__free(up);
        phks__free(top);
        return phks__fail_oom("persistence boundary edges");
    }
    size_t k = 0;
    st = phase(m, PHASE_SURVIVORS, 0.5, 0.75);
    for (uint32_t e = 0; st == PHKS_OK && e < n_e; e++) {
        if (due(e, LIGHT) && (st = report(m, e, n_e)) != PHKS_OK)
            break;
        if (is_boundary(m, label, e))
            a[k++] = (phks__keyed){(uint64_t)edge_rank(m, e) << 32 | e, e};
    }
    phks__keyed *s = NULL;
    if (st == PHKS_OK)
        st = phase(m, PHASE_SURVIVORS, 0.75, 0.85);
    if (st == PHKS_OK)
        st = radix_sort(m, a, tmp, b, &s);
    if (st == PHKS_OK)
        st = phase(m, PHASE_SURVIVORS, 0.85, 1);
    for (uint32_t i = 0; i < n; i++)
        up[i] = top[i] = i;
    const region_entry *q = m->queue;
    for (size_t j = b; st == PHKS_OK && j-- > 0;) {
        if (due(b - j, HEAVY) && (st = report(m, b - j, b)) != PHKS_OK)
            break;
        uint32_t e = s[j].id, eldest = NIL;
        for (uint32_t i = m->edge_start[e]; i < m->edge_start[e + 1]; i++) {
            uint32_t g = phks__find_root(up, label[m->edge_tris[i]]);
            if (eldest == NIL || tri_later(m, q[top[g]].t, q[top[eldest]].t))
                eldest = g;
        }
        double h = m->value[s[j].key >> 32];
        for (uint32_t i = m->edge_start[e]; i < m->edge_start[e + 1]; i++) {
            uint32_t g = phks__find_root(up, label[m->edge_tris[i]]);
            if (g == eldest)
                continue;
            m->queue[top[g]].p = m->value[q[top[g]].rank] - h;
            up[g] = eldest;
        }
    }
    phks__free(a);
    phks__free(tmp);
    phks__free(up);
    phks__free(top);
    return st;
}

/* Highest vertex of a triangle: latest in (f, vertex index). */
static uint32_t highest_vertex(const uint32_t *c, const double *f)
{
    uint32_t best = c[0];
    for (int k = 1; k < 3; k++)
        if (f[c[k]] > f[best] || (f[c[k]] == f[best] && c[k] > best))
            best = c[k];
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
    return phks__persistence_run(mesh, f, max_count, threshold, PHKS__SPAN_NONE,
                                 out, count, region_of_triangle);
}

phks_status phks__persistence_run(const phks_mesh *mesh, const double *f,
                                  size_t max_count, double threshold,
                                  phks__span at, phks_maximum *out,
                                  size_t *count, uint32_t *region_of_triangle)
{
    if (count)
        *count = 0;
    if (!mesh || !f || !out || !count)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_persistent_maxima: NULL argument");
    if (max_count == 0)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_persistent_maxima: max_count is 0");
    if (!(threshold >= 0))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_persistent_maxima: threshold %g is negative "
                         "or NaN",
                         threshold);
    for (size_t v = 0; v < mesh->vertex_count; v++)
        if (!isfinite(f[v]))
            return phks__fail(PHKS_ERROR_NON_FINITE,
                             "phks_persistent_maxima: vertex %zu: value %g "
                             "is not finite",
                             v, f[v]);

    merger m = {0};
    m.at = at;
    phks_status st = merger_init(&m, mesh, f);
    if (st != PHKS_OK)
        return st;
    size_t n_t = mesh->triangle_count, kept, merges;
    /* p = 0 <= threshold: these merges happen whatever the stop rule. */
    st = merge_zero_persistence(&m, n_t, &kept, &merges);
    size_t regions = n_t - merges;
    if (st == PHKS_OK)
        st = rebuild_heaps(&m, n_t, kept);
    if (st == PHKS_OK)
        st = queue_build(&m, kept);
    /* At least kept - max_count merges follow (more with a threshold):
     * the phase's fraction is measured against that. */
    size_t queued = 0, expected = kept > max_count ? kept - max_count : 1;
    size_t start = m.pops, next = (size_t)1 << HEAVY;
    while (st == PHKS_OK && least_is_paired(&m) &&
           (m.queue[0].p <= threshold || regions > max_count)) {
        if (due_steps(queued + m.pops - start, &next) &&
            (st = report(&m, queued, expected)) != PHKS_OK)
            break;
        queue_merge_least(&m);
        queued++;
        regions--;
    }
    /* Here the segmentation is taken. More regions than max_count remain
     * only when all are unpaired (more components than max_count): the
     * earliest in triangle order are left out, and their triangles
     * labelled UINT32_MAX. */
    while (st == PHKS_OK && m.queue_size > max_count)
        queue_pop(&m);
    size_t n = m.queue_size;
    if (st == PHKS_OK)
        st = survivors_persistence(&m, n);
    if (st != PHKS_OK) {
        merger_release(&m);
        return st;
    }

    for (size_t i = 0; i < n; i++) {
        uint32_t t = m.queue[i].t;
        uint32_t v = highest_vertex(mesh->triangles + 3 * (size_t)t, f);
        out[i] = (phks_maximum){v, t, f[v], m.queue[i].p};
    }
    qsort(out, n, sizeof *out, maximum_cmp);
    if (region_of_triangle) {
        for (uint32_t i = 0; i < n; i++)
            m.tri[out[i].triangle].slot = i;
        for (uint32_t t = 0; t < n_t; t++)
            region_of_triangle[t] = m.tri[m.parent[t]].slot;
    }
    *count = n;
    merger_release(&m);
    return PHKS_OK;
}
