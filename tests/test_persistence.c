/*
 * test_persistence.c - phks_persistent_maxima against independent oracles.
 *
 * Oracle 1 (docs/method.md section 7, the dual view): triangles are nodes
 * valued hbar; edges, rebuilt here from the triangle list alone, are swept by
 * decreasing (hbar, edge index) with a plain union-find. When an edge joins
 * components, all but the one whose maximum triangle is latest in triangle
 * order die, with persistence hbar(their maximum) - hbar(edge). This gives
 * every triangle's persistence (INFINITY: unpaired). The expected result of
 * a call is then: sort the triangles by (persistence, triangle order),
 * merge while the least has persistence <= threshold or more than
 * max_count remain (and it is paired); the rest are the survivors.
 *
 * Oracle 2 (small meshes): the region merging of paper 3.2 done naively,
 * recomputing every region's boundary from scratch at each step. Its pops
 * must equal oracle 1's sorted deaths, and replaying its first merges gives
 * the exact expected segmentation.
 *
 * Orders, as the library documents them: vertex (f, index); triangle
 * (hbar, index); edge (hbar, index) with edges numbered as the unique
 * vertex pairs sorted by (lower vertex, higher vertex).
 */
#include "soup.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define NIL UINT32_MAX

/* =====================================================================
 * Meshes
 * ===================================================================== */

/* A planar grid of nx * ny cells at height z, offset by (ox, oy); keep
 * (row-major, NULL = all) says which cells get their two triangles. The
 * diagonal alternates so that vertices have different valences. */
static void add_grid(soup *s, size_t nx, size_t ny, double ox, double oy,
                     double z, const unsigned char *keep)
{
    uint32_t base = (uint32_t)s->nv;
    for (size_t j = 0; j <= ny; j++)
        for (size_t i = 0; i <= nx; i++)
            soup_vertex(s, ox + (double)i, oy + (double)j, z);
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            if (keep && !keep[j * nx + i])
                continue;
            uint32_t a = base + (uint32_t)(j * (nx + 1) + i), b = a + 1;
            uint32_t d = a + (uint32_t)(nx + 1), c = d + 1;
            if ((i + j) % 2) {
                soup_triangle(s, a, b, c);
                soup_triangle(s, a, c, d);
            } else {
                soup_triangle(s, a, b, d);
                soup_triangle(s, b, c, d);
            }
        }
}

/* A closed torus of nu * nv quads, radii 3 and 1 (genus 1, no boundary). */
static void add_exact_torus(soup *s, size_t nu, size_t nv)
{
    uint64_t unused = 0; /* no jitter, so the random numbers do not count */
    add_torus(s, nu, nv, 3, 1, 0, &unused);
}

/* A closed sphere: the octahedron with each triangle split in four
 * `levels` times, vertices pushed to the unit sphere. */
static void add_sphere(soup *s, int levels, double ox)
{
    soup t = {0};
    const double p[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0},
                            {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    const uint32_t f[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                              {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    for (int i = 0; i < 6; i++)
        soup_vertex(&t, p[i][0], p[i][1], p[i][2]);
    for (int i = 0; i < 8; i++)
        soup_triangle(&t, f[i][0], f[i][1], f[i][2]);
    for (int level = 0; level < levels; level++) {
        size_t nt = t.nt, ne = 0;
        uint32_t *old = t.tri;
        uint32_t(*mid)[3] = malloc(3 * nt * sizeof *mid); /* lo, hi, vertex */
        REQUIRE(mid);
        t.tri = NULL;
        t.nt = t.cap_t = 0;
        for (size_t k = 0; k < nt; k++) {
            uint32_t c[3], m[3];
            memcpy(c, old + 3 * k, sizeof c);
            for (int i = 0; i < 3; i++) {
                uint32_t a = c[i], b = c[(i + 1) % 3];
                uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
                size_t e = 0;
                while (e < ne && !(mid[e][0] == lo && mid[e][1] == hi))
                    e++;
                if (e == ne) {
                    double q[3];
                    for (int d = 0; d < 3; d++)
                        q[d] = t.xyz[3 * lo + d] + t.xyz[3 * hi + d];
                    double r = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
                    mid[ne][0] = lo;
                    mid[ne][1] = hi;
                    mid[ne][2] = soup_vertex(&t, q[0] / r, q[1] / r, q[2] / r);
                    ne++;
                }
                m[i] = mid[e][2];
            }
            soup_triangle(&t, c[0], m[0], m[2]);
            soup_triangle(&t, m[0], c[1], m[1]);
            soup_triangle(&t, m[2], m[1], c[2]);
            soup_triangle(&t, m[0], m[1], m[2]);
        }
        free(mid);
        free(old);
    }
    uint32_t base = (uint32_t)s->nv;
    for (size_t i = 0; i < t.nv; i++)
        soup_vertex(s, ox + t.xyz[3 * i], t.xyz[3 * i + 1], t.xyz[3 * i + 2]);
    for (size_t i = 0; i < t.nt; i++)
        soup_triangle(s, base + t.tri[3 * i], base + t.tri[3 * i + 1],
                      base + t.tri[3 * i + 2]);
    free(t.xyz);
    free(t.tri);
}

/* `pages` strips of nx * ny cells hinged on one line (the z axis): the
 * ny spine edges are non-manifold, each shared by `pages` triangles. With
 * nx = ny = 1 and one triangle per page this is the "book" below. */
static void add_strip_book(soup *s, size_t pages, size_t nx, size_t ny)
{
    uint32_t spine = (uint32_t)s->nv;
    for (size_t j = 0; j <= ny; j++)
        soup_vertex(s, 0, 0, (double)j);
    for (size_t k = 0; k < pages; k++) {
        double a = 2 * PI * (double)k / (double)pages + 0.3;
        uint32_t base = (uint32_t)s->nv;
        for (size_t j = 0; j <= ny; j++)
            for (size_t i = 1; i <= nx; i++)
                soup_vertex(s, (double)i * cos(a), (double)i * sin(a), (double)j);
        for (size_t j = 0; j < ny; j++)
            for (size_t i = 0; i < nx; i++) {
                uint32_t a0 = i == 0 ? spine + (uint32_t)j
                                     : base + (uint32_t)(j * nx + i - 1);
                uint32_t d0 = i == 0 ? spine + (uint32_t)(j + 1)
                                     : base + (uint32_t)((j + 1) * nx + i - 1);
                uint32_t b0 = base + (uint32_t)(j * nx + i);
                uint32_t c0 = base + (uint32_t)((j + 1) * nx + i);
                soup_triangle(s, a0, b0, c0);
                soup_triangle(s, a0, c0, d0);
            }
    }
}

/* One triangle per page around the spine edge (0,0,0)-(0,0,1). */
static void add_book(soup *s, size_t pages)
{
    uint32_t a = soup_vertex(s, 0, 0, 0), b = soup_vertex(s, 0, 0, 1);
    for (size_t k = 0; k < pages; k++) {
        double t = 2 * PI * (double)k / (double)pages + 0.1;
        soup_triangle(s, a, b, soup_vertex(s, cos(t), sin(t), 0.5));
    }
}

/* =====================================================================
 * Orders and the oracles
 * ===================================================================== */

typedef struct {
    size_t nv, nt, ne;
    const uint32_t *tri;
    const double *f;
    double *th;          /* hbar per triangle                       */
    uint32_t *ev;        /* 2 per edge: lower, higher vertex        */
    double *eh;          /* hbar per edge                           */
    uint32_t *eoff;      /* ne + 1 offsets into etri                */
    uint32_t *etri;      /* triangles of each edge                  */
    double *pers;        /* per triangle; INFINITY when unpaired    */
    uint32_t *sorted;    /* triangles by (pers, triangle order)     */
    size_t deaths;       /* finite entries of pers                  */
    /* naive region merging (NULL for big meshes) */
    uint32_t *merged;    /* central triangle popped at each step    */
    uint32_t *into;      /* central of the region it merged into    */
} oracle;

static int tri_later(const oracle *o, uint32_t a, uint32_t b)
{
    return o->th[a] > o->th[b] || (o->th[a] == o->th[b] && a > b);
}

static int edge_later(const oracle *o, uint32_t a, uint32_t b)
{
    return o->eh[a] > o->eh[b] || (o->eh[a] == o->eh[b] && a > b);
}

static uint32_t highest_vertex(const oracle *o, uint32_t t)
{
    const uint32_t *c = o->tri + 3 * (size_t)t;
    uint32_t best = c[0];
    for (int k = 1; k < 3; k++)
        if (o->f[c[k]] > o->f[best] || (o->f[c[k]] == o->f[best] && c[k] > best))
            best = c[k];
    return best;
}

static const oracle *sort_ctx; /* qsort has no context argument */

typedef struct {
    uint32_t lo, hi, tri;
} corner;

static int corner_cmp(const void *pa, const void *pb)
{
    const corner *a = pa, *b = pb;
    if (a->lo != b->lo)
        return a->lo < b->lo ? -1 : 1;
    if (a->hi != b->hi)
        return a->hi < b->hi ? -1 : 1;
    return (a->tri > b->tri) - (a->tri < b->tri);
}

static int edge_desc_cmp(const void *pa, const void *pb)
{
    uint32_t a = *(const uint32_t *)pa, b = *(const uint32_t *)pb;
    return edge_later(sort_ctx, a, b) ? -1 : edge_later(sort_ctx, b, a);
}

static int death_cmp(const void *pa, const void *pb)
{
    uint32_t a = *(const uint32_t *)pa, b = *(const uint32_t *)pb;
    double x = sort_ctx->pers[a], y = sort_ctx->pers[b];
    if (x != y)
        return x < y ? -1 : 1;
    return tri_later(sort_ctx, a, b) - tri_later(sort_ctx, b, a);
}

static uint32_t uf_find(uint32_t *parent, uint32_t x)
{
    while (parent[x] != x)
        x = parent[x] = parent[parent[x]];
    return x;
}

/* Distinct values of `in` (n entries) into `out`; returns their number. */
static size_t distinct(const uint32_t *in, size_t n, uint32_t *out)
{
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        size_t j = 0;
        while (j < k && out[j] != in[i])
            j++;
        if (j == k)
            out[k++] = in[i];
    }
    return k;
}

/* Oracle 1. */
static void dual_sweep(oracle *o)
{
    uint32_t *parent = malloc(o->nt * sizeof *parent);
    uint32_t *top = malloc(o->nt * sizeof *top); /* maximum of a component */
    uint32_t *order = malloc(o->ne * sizeof *order);
    uint32_t *roots = malloc(o->nt * sizeof *roots);
    uint32_t *found = malloc(o->nt * sizeof *found);
    REQUIRE(parent && top && order && roots && found);
    for (uint32_t t = 0; t < o->nt; t++) {
        parent[t] = top[t] = t;
        o->pers[t] = INFINITY;
    }
    for (uint32_t e = 0; e < o->ne; e++)
        order[e] = e;
    sort_ctx = o;
    qsort(order, o->ne, sizeof *order, edge_desc_cmp);
    for (size_t i = 0; i < o->ne; i++) {
        uint32_t e = order[i];
        size_t deg = o->eoff[e + 1] - o->eoff[e];
        for (size_t k = 0; k < deg; k++)
            roots[k] = uf_find(parent, o->etri[o->eoff[e] + k]);
        size_t n = distinct(roots, deg, found);
        if (n < 2)
            continue;
        uint32_t eldest = found[0];
        for (size_t k = 1; k < n; k++)
            if (tri_later(o, top[found[k]], top[eldest]))
                eldest = found[k];
        for (size_t k = 0; k < n; k++) {
            uint32_t q = found[k];
            if (q == eldest)
                continue;
            o->pers[top[q]] = o->th[top[q]] - o->eh[e];
            parent[q] = eldest;
        }
    }
    o->deaths = 0;
    for (uint32_t t = 0; t < o->nt; t++) {
        o->sorted[t] = t;
        o->deaths += isfinite(o->pers[t]) != 0;
    }
    qsort(o->sorted, o->nt, sizeof *o->sorted, death_cmp);
    free(parent);
    free(top);
    free(order);
    free(roots);
    free(found);
}

/* Oracle 2: regions as labels (the central triangle of each triangle's
 * region), every boundary recomputed from scratch at every step. */
static void naive_merging(oracle *o)
{
    uint32_t *label = malloc(o->nt * sizeof *label);
    uint32_t *best = malloc(o->nt * sizeof *best);
    uint32_t *regs = malloc(o->nt * sizeof *regs);
    uint32_t *found = malloc(o->nt * sizeof *found);
    o->merged = malloc(o->nt * sizeof *o->merged);
    o->into = malloc(o->nt * sizeof *o->into);
    REQUIRE(label && best && regs && found && o->merged && o->into);
    for (uint32_t t = 0; t < o->nt; t++)
        label[t] = t;
    size_t steps = 0;
    for (;;) {
        for (uint32_t t = 0; t < o->nt; t++)
            best[t] = NIL;
        for (uint32_t e = 0; e < o->ne; e++) {
            size_t deg = o->eoff[e + 1] - o->eoff[e];
            for (size_t k = 0; k < deg; k++)
                regs[k] = label[o->etri[o->eoff[e] + k]];
            size_t n = distinct(regs, deg, found);
            if (n < 2)
                continue;
            for (size_t k = 0; k < n; k++)
                if (best[found[k]] == NIL || edge_later(o, e, best[found[k]]))
                    best[found[k]] = e;
        }
        uint32_t least = NIL;
        double least_p = INFINITY;
        for (uint32_t c = 0; c < o->nt; c++) {
            if (best[c] == NIL)
                continue;
            double p = o->th[c] - o->eh[best[c]];
            if (least == NIL || p < least_p ||
                (p == least_p && tri_later(o, least, c))) {
                least = c;
                least_p = p;
            }
        }
        if (least == NIL)
            break;
        uint32_t e = best[least], target = NIL;
        for (uint32_t i = o->eoff[e]; i < o->eoff[e + 1]; i++) {
            uint32_t q = label[o->etri[i]];
            if (q != least && (target == NIL || tri_later(o, q, target)))
                target = q;
        }
        REQUIRE(tri_later(o, target, least));
        /* Its pop is oracle 1's next death, in the same order. */
        REQUIRE((steps) < (o->deaths));
        REQUIRE((least) == (o->sorted[steps]));
        REQUIRE(least_p == o->pers[least]);
        o->merged[steps] = least;
        o->into[steps] = target;
        steps++;
        for (uint32_t t = 0; t < o->nt; t++)
            if (label[t] == least)
                label[t] = target;
    }
    REQUIRE((steps) == (o->deaths));
    free(label);
    free(best);
    free(regs);
    free(found);
}

/* Builds both oracles for f on mesh, from the triangle list alone. */
static void oracle_build(oracle *o, const phks_mesh *mesh, const double *f,
                         int naive)
{
    *o = (oracle){0};
    o->nv = phks_mesh_vertex_count(mesh);
    o->nt = phks_mesh_triangle_count(mesh);
    o->tri = phks_mesh_triangles(mesh);
    o->f = f;
    size_t nc = 3 * o->nt;
    corner *c = malloc(nc * sizeof *c);
    o->th = malloc(o->nt * sizeof *o->th);
    o->pers = malloc(o->nt * sizeof *o->pers);
    o->sorted = malloc(o->nt * sizeof *o->sorted);
    o->ev = malloc(nc * 2 * sizeof *o->ev);
    o->eh = malloc(nc * sizeof *o->eh);
    o->eoff = malloc((nc + 1) * sizeof *o->eoff);
    o->etri = malloc(nc * sizeof *o->etri);
    REQUIRE(c && o->th && o->pers && o->sorted && o->ev && o->eh &&
              o->eoff && o->etri);
    for (uint32_t t = 0; t < o->nt; t++) {
        const uint32_t *v = o->tri + 3 * (size_t)t;
        o->th[t] = fmax(f[v[0]], fmax(f[v[1]], f[v[2]]));
        for (int k = 0; k < 3; k++) {
            uint32_t a = v[k], b = v[(k + 1) % 3];
            c[3 * t + k] = (corner){a < b ? a : b, a < b ? b : a, t};
        }
    }
    qsort(c, nc, sizeof *c, corner_cmp);
    o->ne = 0;
    for (size_t i = 0; i < nc; i++) {
        if (i == 0 || c[i].lo != c[i - 1].lo || c[i].hi != c[i - 1].hi) {
            o->ev[2 * o->ne] = c[i].lo;
            o->ev[2 * o->ne + 1] = c[i].hi;
            o->eh[o->ne] = fmax(f[c[i].lo], f[c[i].hi]);
            o->eoff[o->ne++] = (uint32_t)i;
        }
        o->etri[i] = c[i].tri;
    }
    o->eoff[o->ne] = (uint32_t)nc;
    free(c);
    dual_sweep(o);
    if (naive)
        naive_merging(o);
}

static void oracle_free(oracle *o)
{
    free(o->th);
    free(o->pers);
    free(o->sorted);
    free(o->ev);
    free(o->eh);
    free(o->eoff);
    free(o->etri);
    free(o->merged);
    free(o->into);
}

/* Number of merges before the stop rule holds. */
static size_t expected_merges(const oracle *o, size_t max_count,
                              double threshold)
{
    size_t k = 0;
    while (k < o->deaths && (o->pers[o->sorted[k]] <= threshold ||
                             o->nt - k > max_count))
        k++;
    return k;
}

/* =====================================================================
 * The check of one call
 * ===================================================================== */

static size_t checked_calls;

static void check_call(const oracle *o, const phks_mesh *mesh, size_t max_count,
                       double threshold, const char *what)
{
    size_t room = max_count < o->nt ? max_count : o->nt;
    phks_maximum *out = malloc(room * sizeof *out); /* exact: ASan checks */
    phks_maximum *again = malloc(room * sizeof *again);
    uint32_t *label = malloc(o->nt * sizeof *label);
    REQUIRE(out && again && label);
    size_t count = 12345, count2 = 12345;
    phks_status st = phks_persistent_maxima(mesh, o->f, max_count, threshold,
                                            out, &count, label);
    REQUIRE_MSG(st == PHKS_OK, "%s: %s", what, phks_last_error_message());
    checked_calls++;

    /* The maxima. */
    size_t k = expected_merges(o, max_count, threshold);
    size_t regions = o->nt - k;
    size_t want = regions < max_count ? regions : max_count;
    REQUIRE_MSG(count == want, "%s max_count %zu threshold %.17g: %zu maxima, "
                  "expected %zu", what, max_count, threshold, count, want);
    for (size_t i = 0; i < count; i++) {
        uint32_t t = o->sorted[o->nt - 1 - i];
        uint32_t v = highest_vertex(o, t);
        REQUIRE_MSG(out[i].triangle == t && out[i].vertex == v &&
                          out[i].value == o->f[v] &&
                          out[i].persistence == o->pers[t],
                      "%s max_count %zu threshold %.17g: maximum %zu is "
                      "(t %u v %u %.17g p %.17g), expected (t %u v %u %.17g "
                      "p %.17g)",
                      what, max_count, threshold, i, out[i].triangle,
                      out[i].vertex, out[i].value, out[i].persistence, t, v,
                      o->f[v], o->pers[t]);
    }

    /* The segmentation, by its properties. */
    for (size_t i = 0; i < count; i++)
        REQUIRE((label[out[i].triangle]) == (i));
    for (uint32_t t = 0; t < o->nt; t++) {
        if (label[t] == NIL) {
            REQUIRE(regions > max_count); /* an unreported component */
            continue;
        }
        REQUIRE((label[t]) < (count));
        uint32_t c = out[label[t]].triangle;
        REQUIRE(t == c || tri_later(o, c, t));
    }
    /* Each region is connected across its interior edges. */
    uint32_t *parent = malloc(o->nt * sizeof *parent);
    size_t *members = calloc(count + 1, sizeof *members);
    REQUIRE(parent && members);
    for (uint32_t t = 0; t < o->nt; t++)
        parent[t] = t;
    for (uint32_t e = 0; e < o->ne; e++)
        for (uint32_t i = o->eoff[e]; i < o->eoff[e + 1]; i++)
            for (uint32_t j = i + 1; j < o->eoff[e + 1]; j++) {
                uint32_t a = o->etri[i], b = o->etri[j];
                if (label[a] == label[b])
                    parent[uf_find(parent, a)] = uf_find(parent, b);
            }
    for (uint32_t t = 0; t < o->nt; t++)
        if (label[t] != NIL && uf_find(parent, t) == t)
            members[label[t]]++;
    for (size_t i = 0; i < count; i++)
        REQUIRE_MSG(members[i] == 1, "%s: region %zu is not connected", what, i);

    /* The segmentation, exactly: replay the naive merging's first k steps.
     * Linking a popped region's root under its target's keeps every root
     * the central triangle of its region. */
    if (o->merged) {
        for (uint32_t t = 0; t < o->nt; t++)
            parent[t] = t;
        for (size_t s = 0; s < k; s++)
            parent[uf_find(parent, o->merged[s])] = uf_find(parent, o->into[s]);
        for (uint32_t t = 0; t < o->nt; t++) {
            uint32_t c = uf_find(parent, t);
            uint32_t got = label[t] == NIL ? NIL : out[label[t]].triangle;
            if (label[t] == NIL)
                for (size_t i = 0; i < count; i++)
                    REQUIRE((out[i].triangle) != (c));
            else
                REQUIRE_MSG(got == c, "%s max_count %zu threshold %.17g: "
                              "triangle %u in the region of %u, expected %u",
                              what, max_count, threshold, t, got, c);
        }
    }

    /* Without labels: the same maxima. */
    st = phks_persistent_maxima(mesh, o->f, max_count, threshold, again,
                                &count2, NULL);
    REQUIRE(st == PHKS_OK);
    REQUIRE((count2) == (count));
    REQUIRE(memcmp(out, again, count * sizeof *out) == 0);

    free(parent);
    free(members);
    free(out);
    free(again);
    free(label);
}

/* Kappa mode (threshold 0, max_count 1..20), threshold mode (max_count >=
 * triangle count, thresholds at and between the persistences) and a few
 * mixtures. */
static void check_all_modes(const oracle *o, const phks_mesh *mesh,
                            const char *what)
{
    for (size_t kappa = 1; kappa <= 20; kappa++)
        check_call(o, mesh, kappa, 0, what);
    double th[12] = {0, INFINITY, 1e-300};
    size_t n = 3;
    if (o->deaths > 0) {
        for (size_t q = 1; q <= 4; q++) {
            double p = o->pers[o->sorted[(o->deaths - 1) * q / 4]];
            th[n++] = p;                        /* equal: merged */
            th[n++] = p > 0 ? nextafter(p, 0) : p; /* just below: kept */
        }
    }
    for (size_t i = 0; i < n; i++) {
        check_call(o, mesh, o->nt, th[i], what);
        check_call(o, mesh, o->nt + 7, th[i], what);
        check_call(o, mesh, 3, th[i], what);
    }
}

/* =====================================================================
 * Functions
 * ===================================================================== */

enum { F_UNIFORM, F_TIED3, F_EQUAL, F_SMOOTH, F_TIED10, F_ULP, F_ZEROS,
       F_SCALES, F_KINDS };

static double *make_function(const phks_mesh *mesh, int kind, uint64_t seed)
{
    size_t n = phks_mesh_vertex_count(mesh);
    const double *x = phks_mesh_vertices(mesh);
    double *f = malloc(n * sizeof *f);
    REQUIRE(f);
    uint64_t s = seed * 7919 + 17;
    for (size_t v = 0; v < n; v++) {
        double r = test_random(&s);
        switch (kind) {
        case F_UNIFORM: f[v] = r; break;
        case F_TIED3: f[v] = floor(3 * r); break;
        case F_EQUAL: f[v] = 0.5; break;
        case F_SMOOTH:
            f[v] = sin(1.3 * x[3 * v]) + cos(0.9 * x[3 * v + 1]) +
                   0.5 * x[3 * v + 2] + 0.01 * r;
            break;
        case F_TIED10: f[v] = floor(10 * r) - 4; break;
        case F_ULP: f[v] = 1 + floor(6 * r) * 0x1p-52; break;
        case F_ZEROS: { /* -0 == +0: a tie, whatever the bits */
            const double z[4] = {-0.0, 0.0, -1, 1};
            f[v] = z[(int)(4 * r)];
            break;
        }
        default: /* mixed signs and magnitudes: inexact differences */
            f[v] = (r - 0.5) * pow(10, floor(7 * test_random(&s)) - 3);
            break;
        }
    }
    return f;
}

static void check_function(const phks_mesh *mesh, int kind, uint64_t seed,
                           int naive, const char *name)
{
    char what[128];
    snprintf(what, sizeof what, "%s f%d seed %llu", name, kind,
             (unsigned long long)seed);
    double *f = make_function(mesh, kind, seed);
    oracle o;
    oracle_build(&o, mesh, f, naive);
    check_all_modes(&o, mesh, what);
    oracle_free(&o);
    free(f);
}

/* =====================================================================
 * Tests
 * ===================================================================== */

START_TEST(test_arguments)
{
    soup s = {0};
    add_grid(&s, 2, 2, 0, 0, 0, NULL);
    phks_mesh *mesh = soup_mesh_take(&s);
    double f[9] = {0, 1, 2, 3, 4, 5, 6, 7, 8};
    phks_maximum out[8];
    size_t count = 99;
    uint32_t label[8];
    ck_assert_int_eq(phks_persistent_maxima(NULL, f, 4, 0, out, &count, label),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_uint_eq(count, 0);
    ck_assert_int_eq(phks_persistent_maxima(mesh, NULL, 4, 0, out, &count, label),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 4, 0, NULL, &count, label),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 4, 0, out, NULL, label),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 0, 0, out, &count, label),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "max_count"));
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 4, -1, out, &count, label),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 4, NAN, out, &count, label),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "threshold"));
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 4, -INFINITY, out, &count,
                                            label),
                     PHKS_ERROR_INVALID_ARGUMENT);
    const double bad[3] = {NAN, INFINITY, -INFINITY};
    for (int i = 0; i < 3; i++) {
        f[7] = bad[i];
        count = 99;
        ck_assert_int_eq(phks_persistent_maxima(mesh, f, 4, 0, out, &count,
                                                label),
                         PHKS_ERROR_NON_FINITE);
        ck_assert_uint_eq(count, 0);
        ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "vertex 7"));
    }
    f[7] = 7;
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 4, INFINITY, out, &count,
                                            label),
                     PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert(isinf(out[0].persistence));
    phks_mesh_free(mesh);
}
END_TEST

START_TEST(test_single_triangle)
{
    const double xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t tri[3] = {0, 1, 2};
    phks_mesh *mesh = NULL;
    ck_assert_int_eq(phks_mesh_create(xyz, 3, tri, 1, &mesh), PHKS_OK);
    const double f[3] = {2, 5, 5}; /* tie: the larger index is highest */
    phks_maximum out[1];
    size_t count = 0;
    uint32_t label[1] = {7};
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 15, 0, out, &count, label),
                     PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert_uint_eq(out[0].triangle, 0);
    ck_assert_uint_eq(out[0].vertex, 2);
    ck_assert(out[0].value == 5);
    ck_assert(isinf(out[0].persistence) && out[0].persistence > 0);
    ck_assert_uint_eq(label[0], 0);
    phks_mesh_free(mesh);
}
END_TEST

/* Three pages on spine (0,1): f(spine) = 0, 1; pages 5, 4, 3. Pages 1 and
 * 2 die at the spine edge (hbar 1) with 3 and 2; page 0 is unpaired. */
START_TEST(test_book_by_hand)
{
    soup s = {0};
    add_book(&s, 3);
    phks_mesh *mesh = soup_mesh_take(&s);
    const double f[5] = {0, 1, 5, 4, 3};
    phks_maximum out[3];
    uint32_t label[3];
    size_t count = 0;
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 3, 0, out, &count, label),
                     PHKS_OK);
    ck_assert_uint_eq(count, 3);
    const uint32_t tri[3] = {0, 1, 2}, vert[3] = {2, 3, 4};
    const double p[3] = {INFINITY, 3, 2};
    for (int i = 0; i < 3; i++) {
        ck_assert_uint_eq(out[i].triangle, tri[i]);
        ck_assert_uint_eq(out[i].vertex, vert[i]);
        ck_assert(out[i].value == f[vert[i]]);
        ck_assert(out[i].persistence == p[i]);
        ck_assert_uint_eq(label[i], i);
    }
    /* Threshold 2.5: page 2 merges, into the eldest region (page 0). */
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 3, 2.5, out, &count, label),
                     PHKS_OK);
    ck_assert_uint_eq(count, 2);
    ck_assert_uint_eq(out[0].triangle, 0);
    ck_assert_uint_eq(out[1].triangle, 1);
    ck_assert(out[1].persistence == 3);
    ck_assert_uint_eq(label[0], 0);
    ck_assert_uint_eq(label[1], 1);
    ck_assert_uint_eq(label[2], 0);
    /* kappa 1 */
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 1, 0, out, &count, label),
                     PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert_uint_eq(out[0].triangle, 0);
    for (int i = 0; i < 3; i++)
        ck_assert_uint_eq(label[i], 0);
    phks_mesh_free(mesh);
}
END_TEST

/* A closed octahedron with two maxima (poles 10 and 9) and an equator
 * 0, 1, 2, 3: the saddle is at 3, so the lower pole has persistence 6. */
START_TEST(test_octahedron_by_hand)
{
    soup s = {0};
    add_sphere(&s, 0, 0); /* vertices +x -x +y -y +z -z */
    phks_mesh *mesh = soup_mesh_take(&s);
    const double f[6] = {0, 2, 1, 3, 10, 9};
    phks_maximum out[8];
    uint32_t label[8];
    size_t count = 0;
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 8, 0, out, &count, label),
                     PHKS_OK);
    ck_assert_uint_eq(count, 2);
    ck_assert_uint_eq(out[0].vertex, 4);
    ck_assert(isinf(out[0].persistence));
    ck_assert_uint_eq(out[1].vertex, 5);
    ck_assert(out[1].persistence == 6);
    ck_assert(out[1].value == 9);
    for (uint32_t t = 0; t < 8; t++) /* upper faces 0-3, lower 4-7 */
        ck_assert_uint_eq(label[t], t < 4 ? 0 : 1);
    /* One maximum only: a single region of infinite persistence. */
    const double g[6] = {0, 2, 1, 3, 10, -1};
    ck_assert_int_eq(phks_persistent_maxima(mesh, g, 8, 0, out, &count, label),
                     PHKS_OK);
    ck_assert_uint_eq(count, 1);
    ck_assert_uint_eq(out[0].vertex, 4);
    phks_mesh_free(mesh);
}
END_TEST

/* Two triangles sharing a vertex only, and an isolated third: three
 * unpaired regions; with max_count 2 the earliest in triangle order is
 * left out and its triangle labelled UINT32_MAX. */
START_TEST(test_more_components_than_max_count)
{
    const double xyz[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0,
                          5, 5, 0, 6, 5, 0, 5, 6, 0};
    const uint32_t tri[] = {0, 1, 2, 0, 3, 4, 5, 6, 7};
    phks_mesh *mesh = NULL;
    ck_assert_int_eq(phks_mesh_create(xyz, 8, tri, 3, &mesh), PHKS_OK);
    const double f[8] = {1, 2, 3, 3, 0, 3, 1, 1};
    phks_maximum out[2];
    uint32_t label[3];
    size_t count = 0;
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, 2, 0, out, &count, label),
                     PHKS_OK);
    ck_assert_uint_eq(count, 2);
    /* hbar 3 for all three: triangle order is the index. */
    ck_assert_uint_eq(out[0].triangle, 2);
    ck_assert_uint_eq(out[1].triangle, 1);
    ck_assert_uint_eq(out[0].vertex, 5);
    ck_assert_uint_eq(out[1].vertex, 3);
    ck_assert(isinf(out[0].persistence) && isinf(out[1].persistence));
    ck_assert_uint_eq(label[0], UINT32_MAX);
    ck_assert_uint_eq(label[1], 1);
    ck_assert_uint_eq(label[2], 0);
    phks_mesh_free(mesh);
}
END_TEST

/* The hand-made meshes of the random tests. */
enum { M_GRID, M_HOLE, M_OCTAHEDRON, M_SPHERE, M_TORUS, M_TWO, M_BOOK3,
       M_BOOK4, M_STRIPS, M_PUNCHED, M_KINDS };

static phks_mesh *make_mesh(int kind, uint64_t seed, const char **name)
{
    soup s = {0};
    unsigned char keep[64];
    switch (kind) {
    case M_GRID:
        *name = "grid";
        add_grid(&s, 7, 6, 0, 0, 0, NULL);
        break;
    case M_HOLE:
        *name = "grid with hole";
        memset(keep, 1, sizeof keep);
        keep[2 * 7 + 3] = keep[3 * 7 + 3] = keep[3 * 7 + 2] = 0;
        keep[2 * 7 + 2] = 0;
        add_grid(&s, 7, 6, 0, 0, 0, keep);
        break;
    case M_OCTAHEDRON:
        *name = "octahedron";
        add_sphere(&s, 0, 0);
        break;
    case M_SPHERE:
        *name = "sphere";
        add_sphere(&s, 2, 0);
        break;
    case M_TORUS:
        *name = "torus";
        add_exact_torus(&s, 8, 5);
        break;
    case M_TWO:
        *name = "two components";
        add_grid(&s, 4, 4, 0, 0, 0, NULL);
        add_sphere(&s, 1, 10);
        break;
    case M_BOOK3:
        *name = "book of 3";
        add_book(&s, 3);
        break;
    case M_BOOK4:
        *name = "book of 4";
        add_book(&s, 4);
        break;
    case M_STRIPS:
        *name = "strips on a spine";
        add_strip_book(&s, 3, 3, 4);
        break;
    default: {
        *name = "punched grid";
        uint64_t r = seed;
        for (size_t i = 0; i < 64; i++)
            keep[i] = test_random(&r) < 0.7;
        keep[0] = 1;
        add_grid(&s, 8, 8, 0, 0, 0, keep);
        break;
    }
    }
    return soup_mesh_take(&s);
}

START_TEST(test_random_against_oracles)
{
    /* Each (mesh, function kind) with several seeds: 500 functions. */
    for (int m = 0; m < M_KINDS; m++) {
        const char *name = NULL;
        phks_mesh *mesh = make_mesh(m, 1, &name);
        for (int kind = 0; kind < F_KINDS; kind++) {
            int seeds = kind == F_EQUAL ? 1 : 7;
            for (int seed = 0; seed < seeds; seed++) {
                if (m == M_PUNCHED && seed > 0) {
                    phks_mesh_free(mesh);
                    mesh = make_mesh(m, (uint64_t)(seed * 31 + kind), &name);
                }
                check_function(mesh, kind, (uint64_t)(100 * m + seed), 1, name);
            }
        }
        phks_mesh_free(mesh);
    }
    ck_assert_uint_gt(checked_calls, 10000);
}
END_TEST

START_TEST(test_larger_meshes)
{
    /* Beyond the naive oracle: maxima exact, segmentation by properties. */
    const char *names[3] = {"grid 50x40", "torus 60x40", "strips 5x(10x30)"};
    for (int i = 0; i < 3; i++) {
        soup s = {0};
        if (i == 0)
            add_grid(&s, 50, 40, 0, 0, 0, NULL);
        else if (i == 1)
            add_exact_torus(&s, 60, 40);
        else
            add_strip_book(&s, 5, 10, 30);
        phks_mesh *mesh = soup_mesh_take(&s);
        const int kinds[3] = {F_SMOOTH, F_TIED3, F_UNIFORM};
        for (int k = 0; k < 3; k++)
            check_function(mesh, kinds[k], (uint64_t)(7 + i), 0, names[i]);
        phks_mesh_free(mesh);
    }
}
END_TEST

START_TEST(test_deterministic)
{
    soup s = {0};
    add_exact_torus(&s, 12, 9);
    phks_mesh *mesh = soup_mesh_take(&s);
    size_t nt = phks_mesh_triangle_count(mesh);
    for (int kind = 0; kind < F_KINDS; kind++) {
        double *f = make_function(mesh, kind, 5);
        phks_maximum a[20], b[20];
        uint32_t *la = malloc(nt * sizeof *la), *lb = malloc(nt * sizeof *lb);
        ck_assert(la && lb);
        size_t ca = 0, cb = 0;
        memset(a, 0, sizeof a);
        memset(b, 0xff, sizeof b);
        ck_assert_int_eq(phks_persistent_maxima(mesh, f, 20, 0, a, &ca, la),
                         PHKS_OK);
        ck_assert_int_eq(phks_persistent_maxima(mesh, f, 20, 0, b, &cb, lb),
                         PHKS_OK);
        ck_assert_uint_eq(ca, cb);
        ck_assert(memcmp(a, b, ca * sizeof *a) == 0);
        ck_assert(memcmp(la, lb, nt * sizeof *la) == 0);
        free(la);
        free(lb);
        free(f);
    }
    phks_mesh_free(mesh);
}
END_TEST

/* The counting allocator (testutil.h) fails request n = 0, 1, ... in turn:
 * out of memory and nothing leaked, until the call succeeds. */
START_TEST(test_out_of_memory)
{
    const phks_allocator counting = {count_malloc, count_realloc, count_free,
                                     NULL};
    ck_assert_int_eq(phks_set_allocator(&counting), PHKS_OK);
    soup s = {0};
    add_grid(&s, 6, 5, 0, 0, 0, NULL);
    phks_mesh *mesh = soup_mesh_take(&s);
    double *f = make_function(mesh, F_UNIFORM, 3);
    phks_maximum out[5];
    uint32_t label[60];
    size_t count = 0;
    long failures = 0;
    for (long n = 0;; n++) {
        long live = alloc_live;
        alloc_calls = 0;
        alloc_fail_at = n;
        count = 99;
        phks_status st = phks_persistent_maxima(mesh, f, 5, 0, out, &count, label);
        alloc_fail_at = -1;
        ck_assert_int_eq(alloc_live, live);
        if (st == PHKS_OK)
            break;
        ck_assert_int_eq(st, PHKS_ERROR_OUT_OF_MEMORY);
        ck_assert_uint_eq(count, 0);
        failures++;
    }
    ck_assert_int_gt(failures, 0);
    ck_assert_uint_gt(count, 0);
    free(f);
    phks_mesh_free(mesh);
    ck_assert_int_eq(alloc_live, 0);
    phks_set_allocator(NULL);
}
END_TEST

/* Progress of phks__persistence_run, reported in [0.25, 0.75]. */
typedef struct {
    int calls, stop_at; /* cancel at report stop_at (0: never)       */
    int bad;            /* other stage, out of range, or backwards    */
    double last;
} progress_log;

static int record(void *user, phks_stage stage, double fraction)
{
    progress_log *log = user;
    log->calls++;
    log->bad += stage != PHKS_STAGE_PERSISTENCE || !(fraction >= 0.25) ||
                !(fraction <= 0.75) || fraction < log->last;
    log->last = fraction;
    return log->stop_at > 0 && log->calls >= log->stop_at;
}

/* Runs the internal variant with progress and checks it gives what the
 * public function gives, bit for bit; returns the number of reports. */
static int reports_of(const phks_mesh *mesh, const double *f, size_t max_count)
{
    size_t nt = phks_mesh_triangle_count(mesh), ca = 0, cb = 0;
    phks_maximum *a = calloc(max_count, sizeof *a);
    phks_maximum *b = calloc(max_count, sizeof *b);
    uint32_t *la = malloc(nt * sizeof *la), *lb = malloc(nt * sizeof *lb);
    ck_assert(a && b && la && lb);
    phks_options o;
    phks_options_init(&o);
    progress_log log = {0, 0, 0, 0};
    o.progress = record;
    o.progress_user = &log;
    ck_assert_int_eq(phks_persistent_maxima(mesh, f, max_count, 0, a, &ca, la),
                     PHKS_OK);
    ck_assert_int_eq(phks__persistence_run(mesh, f, max_count, 0,
                                           (phks__span){&o, PHKS_STAGE_PERSISTENCE,
                                                        0.25, 0.5},
                                           b, &cb, lb),
                     PHKS_OK);
    ck_assert_uint_eq(ca, cb);
    ck_assert(memcmp(a, b, ca * sizeof *a) == 0);
    ck_assert(memcmp(la, lb, nt * sizeof *la) == 0);
    ck_assert_int_eq(log.bad, 0);
    free(a);
    free(b);
    free(la);
    free(lb);
    return log.calls;
}

static phks_mesh *grid_mesh(size_t side)
{
    soup s = {0};
    add_grid(&s, side, side, 0, 0, 0, NULL);
    return soup_mesh_take(&s);
}

/* The number of reports grows with the mesh (a report every so many
 * steps in each phase, whatever the time), and a cancellation at any
 * report returns PHKS_ERROR_CANCELLED at once, with *count 0 and nothing
 * leaked. Not timed: the benchmark measures the gaps. */
START_TEST(test_progress_grows_and_cancels)
{
    const size_t sides[3] = {40, 200, 400}; /* 3.2k, 80k, 320k triangles */
    int calls[3];
    for (int i = 0; i < 3; i++) {
        phks_mesh *mesh = grid_mesh(sides[i]);
        /* White noise: many maxima, so every phase has work. */
        double *f = make_function(mesh, F_UNIFORM, 11);
        calls[i] = reports_of(mesh, f, 15);
        if (i == 1) {
            double *g = make_function(mesh, F_SMOOTH, 11);
            ck_assert_int_gt(reports_of(mesh, g, 15), 5);
            free(g);
        }
        free(f);
        phks_mesh_free(mesh);
    }
    ck_assert_int_ge(calls[0], 6); /* at least one per phase */
    ck_assert_int_gt(calls[1], calls[0]);
    ck_assert_int_gt(calls[2], calls[1] + 8);

    const phks_allocator counting = {count_malloc, count_realloc, count_free,
                                     NULL};
    ck_assert_int_eq(phks_set_allocator(&counting), PHKS_OK);
    phks_mesh *mesh = grid_mesh(200);
    double *f = make_function(mesh, F_UNIFORM, 11);
    uint32_t *label = malloc(phks_mesh_triangle_count(mesh) * sizeof *label);
    ck_assert_ptr_nonnull(label);
    phks_options o;
    phks_options_init(&o);
    o.progress = record;
    for (int k = 1; k <= calls[1]; k++) {
        progress_log log = {0, k, 0, 0};
        o.progress_user = &log;
        phks_maximum out[15];
        size_t count = 99;
        long live = alloc_live;
        ck_assert_int_eq(phks__persistence_run(mesh, f, 15, 0,
                                               (phks__span){&o, PHKS_STAGE_PERSISTENCE,
                                                            0.25, 0.5},
                                               out, &count, label),
                         PHKS_ERROR_CANCELLED);
        ck_assert_int_eq(log.calls, k); /* nothing after the cancellation */
        ck_assert_uint_eq(count, 0);
        ck_assert_int_eq(alloc_live, live);
    }
    free(label);
    free(f);
    phks_mesh_free(mesh);
    ck_assert_int_eq(alloc_live, 0);
    phks_set_allocator(NULL);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("persistence");
    TCase *tc = tcase_create("persistence");
    tcase_add_test(tc, test_arguments);
    tcase_add_test(tc, test_single_triangle);
    tcase_add_test(tc, test_book_by_hand);
    tcase_add_test(tc, test_octahedron_by_hand);
    tcase_add_test(tc, test_more_components_than_max_count);
    tcase_add_test(tc, test_random_against_oracles);
    tcase_add_test(tc, test_larger_meshes);
    tcase_add_test(tc, test_deterministic);
    tcase_add_test(tc, test_out_of_memory);
    tcase_add_test(tc, test_progress_grows_and_cancels);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return run_suite(suite());
}
