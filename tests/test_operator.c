/*
 * test_operator.c - the mesh-Laplacian (lib/operator/laplacian.c) against
 * a brute force build of docs/method.md section 3.
 *
 * Oracle: over all vertex pairs (O(n^2), no spatial grid), with positions
 * scaled by s = 1 / (longest side of the axis-aligned bounding box),
 * A_p = a third of the area of the triangles at p, h = tau,
 * r = cutoff * sqrt(4h) and W(w,p) = exp(-|w-p|^2 / 4h) for |w-p| < r:
 *     K_wp = A_w A_p W(w,p) (w != p),  S = (diag(K 1) - K) / (4 pi h^2),
 *     M = diag(A)                        (literal operator),
 *     M = diag(A) D, D_w = 1/(4 pi h) sum_k A_k W(w,k), k = w included
 *                                        (random-walk operator),
 * and the library's symmetric matrix must be B = M^-1/2 S M^-1/2.
 * Checked entry-wise (relative 1e-12) with the CSR densified, op->mass
 * against M, the CSR's structure, symmetry, zero row sums of
 * S = M^1/2 B M^1/2, positive semi-definiteness (LAPACKE_dsyev), the
 * Gershgorin bound, and phks__operator_apply on blocks of k = 1, 3, 8
 * vectors against a dense product, bit-identical for 1, 2 and 3 threads.
 *
 * Meshes: perturbed ellipsoids (closed, 42 to 642 vertices), a torus, an
 * open height field, two components (far apart and within the cut-off), a
 * triangle soup with duplicated vertices, a non-manifold mesh.
 *
 * The principal box: its 3 x 3 eigen-solver (Jacobi) against LAPACK's
 * dsyev on random and degenerate matrices, and its scale at any size of
 * the mesh and any number of BLAS threads.
 */
#include "soup.h"

#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The operator of a mesh as the library builds it: the unit box and the
 * vertex areas, then the matrix. */
static phks_status mesh_operator(const phks_mesh *mesh, const phks_options *opt,
                                 phks__operator_matrix *op)
{
    phks__unit_mesh um;
    phks_status st = phks__unit_mesh_init(mesh, (phks_box)opt->box,
                                          PHKS__SPAN_NONE, &um);
    if (st != PHKS_OK)
        return st;
    st = phks__operator_build(&um, opt, PHKS__SPAN_NONE, op);
    phks__unit_mesh_release(&um);
    return st;
}

/* =====================================================================
 * Meshes
 * ===================================================================== */

/* An open height field over [0, size]^2 with nx * ny cells, jittered in
 * the plane, z a gentle bump. Returns the index of its first vertex. */
static uint32_t add_patch(soup *s, size_t nx, size_t ny, double size,
                          double jitter, uint64_t *rng)
{
    uint32_t first = (uint32_t)s->nv;
    for (size_t j = 0; j <= ny; j++)
        for (size_t i = 0; i <= nx; i++) {
            double x = (i + jitter * (test_random(rng) - 0.5)) * size / nx;
            double y = (j + jitter * (test_random(rng) - 0.5)) * size / ny;
            soup_vertex(s, x, y, 0.15 * size * sin(3 * x / size) * cos(2 * y / size));
        }
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            uint32_t a = first + (uint32_t)(j * (nx + 1) + i), b = a + 1;
            uint32_t d = a + (uint32_t)(nx + 1), c = d + 1;
            soup_triangle(s, a, b, c);
            soup_triangle(s, a, c, d);
        }
    return first;
}

/* Every triangle gets its own three vertices: a triangle soup in which
 * each vertex position is repeated by all its triangles. */
static void explode(soup *s)
{
    soup out = {0};
    for (size_t t = 0; t < s->nt; t++) {
        uint32_t v[3];
        for (int k = 0; k < 3; k++) {
            const double *p = s->xyz + 3 * s->tri[3 * t + k];
            v[k] = soup_vertex(&out, p[0], p[1], p[2]);
        }
        soup_triangle(&out, v[0], v[1], v[2]);
    }
    soup_free(s);
    *s = out;
}

/* Uniform random rotation (Shoemake), row-major. */
static void random_rotation(uint64_t *rng, double r[9])
{
    double u1 = test_random(rng), u2 = test_random(rng), u3 = test_random(rng);
    double a = sqrt(1 - u1), b = sqrt(u1);
    double w = a * sin(2 * PI * u2), x = a * cos(2 * PI * u2),
           y = b * sin(2 * PI * u3), z = b * cos(2 * PI * u3);
    double m[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),
                   2 * (x * z + w * y),     2 * (x * y + w * z),
                   1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y),     2 * (y * z + w * x),
                   1 - 2 * (x * x + y * y)};
    memcpy(r, m, sizeof m);
}

static void rotate(soup *s, const double r[9], const double shift[3])
{
    for (size_t v = 0; v < s->nv; v++) {
        double *p = s->xyz + 3 * v, q[3];
        for (int i = 0; i < 3; i++)
            q[i] = r[3 * i] * p[0] + r[3 * i + 1] * p[1] + r[3 * i + 2] * p[2] +
                   shift[i];
        memcpy(p, q, sizeof q);
    }
}

/* =====================================================================
 * The brute-force oracle
 * ===================================================================== */

typedef struct {
    size_t n;
    double h, r2, c;
    double *pos;      /* scaled positions, 3n       */
    double *area;     /* A                          */
    double *density;  /* D                          */
    double *mass;     /* M                          */
    double *S;        /* n x n                      */
    double *B;        /* M^-1/2 S M^-1/2, n x n     */
    size_t near_cut;  /* pairs within 1e-9 relative of the cut-off */
} dense_op;

static void dense_free(dense_op *d)
{
    free(d->pos);
    free(d->area);
    free(d->density);
    free(d->mass);
    free(d->S);
    free(d->B);
    memset(d, 0, sizeof *d);
}

static void dense_build(const phks_mesh *mesh, double scale, double tau,
                        double cutoff, int kind, dense_op *d)
{
    size_t n = phks_mesh_vertex_count(mesh), nt = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    d->n = n;
    d->h = tau;
    d->r2 = cutoff * cutoff * 4 * tau;
    d->c = 1 / (4 * PI * tau * tau);
    d->pos = malloc(3 * n * sizeof(double));
    d->area = calloc(n, sizeof(double));
    d->density = calloc(n, sizeof(double));
    d->mass = malloc(n * sizeof(double));
    d->S = calloc(n * n, sizeof(double));
    d->B = malloc(n * n * sizeof(double));
    REQUIRE(d->pos && d->area && d->density && d->mass && d->S && d->B);
    for (size_t i = 0; i < 3 * n; i++)
        d->pos[i] = xyz[i] * scale;
    for (size_t t = 0; t < nt; t++) {
        const double *a = d->pos + 3 * tri[3 * t], *b = d->pos + 3 * tri[3 * t + 1],
                     *c = d->pos + 3 * tri[3 * t + 2];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2],
               z = u[0] * v[1] - u[1] * v[0];
        double third = sqrt(x * x + y * y + z * z) / 6;
        for (int k = 0; k < 3; k++)
            d->area[tri[3 * t + k]] += third;
    }
    d->near_cut = 0;
    for (size_t w = 0; w < n; w++) {
        d->density[w] += d->area[w]; /* k = w: W = 1 */
        for (size_t p = w + 1; p < n; p++) {
            double d2 = 0;
            for (int k = 0; k < 3; k++) {
                double x = d->pos[3 * w + k] - d->pos[3 * p + k];
                d2 += x * x;
            }
            if (fabs(d2 - d->r2) < 1e-9 * d->r2)
                d->near_cut++;
            if (!(d2 < d->r2))
                continue;
            double W = exp(-d2 / (4 * tau));
            double K = d->area[w] * d->area[p] * W;
            d->S[w * n + p] -= d->c * K;
            d->S[p * n + w] -= d->c * K;
            d->S[w * n + w] += d->c * K;
            d->S[p * n + p] += d->c * K;
            d->density[w] += d->area[p] * W;
            d->density[p] += d->area[w] * W;
        }
    }
    for (size_t w = 0; w < n; w++) {
        d->density[w] /= 4 * PI * tau;
        d->mass[w] = kind == PHKS_OPERATOR_RANDOM_WALK ? d->area[w] * d->density[w]
                                                       : d->area[w];
    }
    for (size_t w = 0; w < n; w++)
        for (size_t p = 0; p < n; p++)
            d->B[w * n + p] = d->S[w * n + p] / sqrt(d->mass[w] * d->mass[p]);
}

/* =====================================================================
 * Comparison
 * ===================================================================== */

typedef struct {
    double entry, mass, symmetry, rowsum, apply, min_eig; /* worst seen */
} op_errors;
static op_errors worst_all;

static double *densify(const phks__operator_matrix *op)
{
    size_t n = op->n;
    double *b = calloc(n * n, sizeof *b);
    size_t *seen = calloc(n, sizeof *seen); /* row + 1 where column seen */
    REQUIRE(b && seen);
    REQUIRE(op->row_start[0] == 0);
    for (size_t w = 0; w < n; w++) {
        REQUIRE(op->row_start[w + 1] >= op->row_start[w]);
        size_t diagonal = 0;
        for (size_t i = op->row_start[w]; i < op->row_start[w + 1]; i++) {
            uint32_t p = op->col[i];
            REQUIRE_MSG(p < n, "row %zu: column %u out of range", w, p);
            REQUIRE_MSG(seen[p] != w + 1, "row %zu: column %u stored twice", w, p);
            seen[p] = w + 1;
            REQUIRE(isfinite(op->val[i]));
            b[w * n + p] = op->val[i];
            diagonal += p == w;
        }
        REQUIRE_MSG(diagonal == 1, "row %zu: diagonal stored %zu times", w,
                    diagonal);
    }
    free(seen);
    return b;
}

/* Everything about one operator against the oracle. */
static void compare_operator(const char *name, const phks_mesh *mesh,
                             const phks_options *opt, double scale)
{
    dense_op d = {0};
    dense_build(mesh, scale, opt->tau, opt->cutoff, opt->operator_kind, &d);
    REQUIRE_MSG(d.near_cut == 0,
                "%s: %zu vertex pairs lie at the cut-off radius; the test mesh "
                "is ambiguous",
                name, d.near_cut);
    size_t n = d.n;
    phks__operator_matrix op;
    phks_status st = mesh_operator(mesh, opt, &op);
    REQUIRE_MSG(st == PHKS_OK, "%s: %s", name, phks_last_error_message());
    REQUIRE(op.n == n);

    /* Structure: exactly the pairs within the cut-off, plus the diagonal. */
    size_t expected_nnz = 0;
    for (size_t w = 0; w < n; w++)
        for (size_t p = 0; p < n; p++)
            expected_nnz += p == w || d.S[w * n + p] != 0;
    double *b = densify(&op);
    REQUIRE_MSG(op.row_start[n] == expected_nnz, "%s: %zu stored entries, %zu expected",
                name, op.row_start[n], expected_nnz);

    op_errors e = {0};
    for (size_t w = 0; w < n; w++) {
        REQUIRE_MSG(fabs(op.mass[w] - d.mass[w]) <= 1e-12 * d.mass[w],
                    "%s: mass[%zu] %.17g, expected %.17g", name, w, op.mass[w],
                    d.mass[w]);
        e.mass = fmax(e.mass, fabs(op.mass[w] - d.mass[w]) / d.mass[w]);
        for (size_t p = 0; p < n; p++) {
            double x = b[w * n + p], y = d.B[w * n + p];
            REQUIRE_MSG(fabs(x - y) <= 1e-12 * fabs(y),
                        "%s: B[%zu][%zu] = %.17g, expected %.17g", name, w, p, x, y);
            if (y != 0)
                e.entry = fmax(e.entry, fabs(x - y) / fabs(y));
            double t = b[p * n + w];
            REQUIRE_MSG(fabs(x - t) <= 1e-14 * fabs(x),
                        "%s: B not symmetric at (%zu, %zu): %.17g, %.17g", name,
                        w, p, x, t);
            if (x != 0)
                e.symmetry = fmax(e.symmetry, fabs(x - t) / fabs(x));
        }
    }

    /* Rows of S = M^1/2 B M^1/2 sum to zero; Gershgorin bound. */
    double gershgorin = 0;
    for (size_t w = 0; w < n; w++) {
        double sum = 0, abs_sum = 0, row_abs = 0;
        for (size_t p = 0; p < n; p++) {
            double s = sqrt(op.mass[w]) * b[w * n + p] * sqrt(op.mass[p]);
            sum += s;
            abs_sum += fabs(s);
            row_abs += fabs(b[w * n + p]);
        }
        REQUIRE_MSG(fabs(sum) <= 1e-13 * abs_sum + 1e-300,
                    "%s: row %zu of S sums to %.3g (|S| row %.3g)", name, w, sum,
                    abs_sum);
        if (abs_sum > 0)
            e.rowsum = fmax(e.rowsum, fabs(sum) / abs_sum);
        gershgorin = fmax(gershgorin, row_abs);
    }
    REQUIRE_MSG(fabs(op.norm_bound - gershgorin) <= 1e-12 * gershgorin,
                "%s: norm_bound %.17g, Gershgorin %.17g", name, op.norm_bound,
                gershgorin);

    /* Positive semi-definite, and |B| within the bound. */
    double *a = malloc(n * n * sizeof *a), *ev = malloc(n * sizeof *ev);
    REQUIRE(a && ev);
    memcpy(a, b, n * n * sizeof *a);
    REQUIRE(LAPACKE_dsyev(LAPACK_ROW_MAJOR, 'N', 'U', (lapack_int)n, a,
                          (lapack_int)n, ev) == 0);
    double top = ev[n - 1];
    REQUIRE_MSG(ev[0] > -1e-9 * top, "%s: smallest eigenvalue of B %.3g, |B| %.3g",
                name, ev[0], top);
    e.min_eig = ev[0] / top;
    REQUIRE_MSG(top <= op.norm_bound * (1 + 1e-12), "%s: |B| %.17g above bound %.17g",
                name, top, op.norm_bound);
    free(a);
    free(ev);

    /* Y = B X for blocks of k vectors, 1, 2 and 3 threads. */
    uint64_t rng = 99;
    const size_t ks[] = {1, 3, 8};
    for (size_t ki = 0; ki < 3; ki++) {
        size_t k = ks[ki];
        double *x = malloc(n * k * sizeof *x), *y1 = malloc(n * k * sizeof *y1),
               *yt = malloc(n * k * sizeof *yt);
        REQUIRE(x && y1 && yt);
        for (size_t i = 0; i < n * k; i++)
            x[i] = 2 * test_random(&rng) - 1;
        phks__operator_apply(&op, x, y1, k, 1);
        for (size_t w = 0; w < n; w++)
            for (size_t j = 0; j < k; j++) {
                double exact = 0, size = 0;
                for (size_t p = 0; p < n; p++) {
                    exact += d.B[w * n + p] * x[p * k + j];
                    size += fabs(d.B[w * n + p] * x[p * k + j]);
                }
                double err = fabs(y1[w * k + j] - exact);
                REQUIRE_MSG(err <= 1e-12 * size + 1e-300,
                            "%s: (B X)[%zu][%zu] (k = %zu) %.17g, expected %.17g",
                            name, w, j, k, y1[w * k + j], exact);
                if (size > 0)
                    e.apply = fmax(e.apply, err / size);
            }
        for (unsigned threads = 2; threads <= 3; threads++) {
            memset(yt, 0xff, n * k * sizeof *yt);
            phks__operator_apply(&op, x, yt, k, threads);
            REQUIRE_MSG(memcmp(y1, yt, n * k * sizeof *yt) == 0,
                        "%s: apply with %u threads differs from 1 thread (k = %zu)",
                        name, threads, k);
        }
        free(x);
        free(y1);
        free(yt);
    }

    /* The build itself does not depend on the thread count. */
    for (unsigned threads = 1; threads <= 2; threads++) {
        phks_options o = *opt;
        o.threads = threads;
        phks__operator_matrix op2;
        REQUIRE(mesh_operator(mesh, &o, &op2) == PHKS_OK);
        REQUIRE(op2.n == n && op2.row_start[n] == op.row_start[n]);
        REQUIRE(memcmp(op2.row_start, op.row_start, (n + 1) * sizeof *op.row_start) == 0);
        REQUIRE(memcmp(op2.col, op.col, op.row_start[n] * sizeof *op.col) == 0);
        REQUIRE(memcmp(op2.val, op.val, op.row_start[n] * sizeof *op.val) == 0);
        REQUIRE(memcmp(op2.mass, op.mass, n * sizeof *op.mass) == 0);
        REQUIRE(op2.norm_bound == op.norm_bound);
        phks__operator_release(&op2);
    }

    printf("%-22s %-11s n %4zu nnz/row %6.1f  entry %.1e mass %.1e sym %.1e "
           "rowsum %.1e apply %.1e min eig/|B| %+.1e\n",
           name, opt->operator_kind == PHKS_OPERATOR_LITERAL ? "literal" : "random-walk",
           n, (double)op.row_start[n] / (double)n, e.entry, e.mass, e.symmetry,
           e.rowsum, e.apply, e.min_eig);
    fflush(stdout);
    worst_all.entry = fmax(worst_all.entry, e.entry);
    worst_all.mass = fmax(worst_all.mass, e.mass);
    worst_all.apply = fmax(worst_all.apply, e.apply);
    free(b);
    phks__operator_release(&op);
    dense_free(&d);
}

/* Both operator kinds on one mesh, AXIS_ALIGNED box with the scale
 * computed here. */
static void check_mesh(const char *name, const soup *s, double tau,
                       double cutoff)
{
    phks_mesh *mesh = soup_mesh(s);
    double scale = axis_aligned_scale(mesh), lib_scale = 0;
    REQUIRE(phks__unit_box_scale(mesh, PHKS_BOX_AXIS_ALIGNED, PHKS__SPAN_NONE, &lib_scale) == PHKS_OK);
    REQUIRE_MSG(fabs(lib_scale - scale) <= 1e-15 * scale,
                "%s: axis-aligned scale %.17g, expected %.17g", name, lib_scale,
                scale);
    for (int kind = 0; kind < 2; kind++) {
        phks_options opt;
        phks_options_init(&opt);
        opt.quadrature = PHKS_QUADRATURE_VERTICES; /* the oracle's */
        opt.box = PHKS_BOX_AXIS_ALIGNED;
        opt.tau = tau;
        opt.cutoff = cutoff;
        opt.operator_kind = kind;
        opt.threads = 2;
        compare_operator(name, mesh, &opt, scale);
    }
    phks_mesh_free(mesh);
}

/* =====================================================================
 * Tests
 * ===================================================================== */

START_TEST(test_closed)
{
    uint64_t rng = 11;
    const double c[3] = {0.3, -2, 5}, ax[3] = {1.0, 0.8, 0.55};
    soup s = {0};
    add_icosphere(&s, 1, c, ax, 0.05, &rng); /* 42 vertices */
    check_mesh("ellipsoid-42", &s, 0.01, 3.5);
    soup_free(&s);
    add_icosphere(&s, 2, c, ax, 0.03, &rng); /* 162 */
    check_mesh("ellipsoid-162", &s, 0.002, 3.5);
    soup_free(&s);
    add_icosphere(&s, 2, c, ax, 0.03, &rng);
    check_mesh("ellipsoid-162-cut2", &s, 0.002, 2.0);
    soup_free(&s);
    add_icosphere(&s, 3, c, ax, 0.02, &rng); /* 642, default tau */
    check_mesh("ellipsoid-642", &s, 0.0002, 3.5);
    soup_free(&s);
    add_torus(&s, 24, 12, 1.0, 0.35, 0.3, &rng); /* 288 */
    check_mesh("torus-288", &s, 0.001, 5.0);
    soup_free(&s);
}
END_TEST

START_TEST(test_open)
{
    uint64_t rng = 12;
    soup s = {0};
    add_patch(&s, 25, 20, 2.0, 0.4, &rng); /* 546 */
    check_mesh("patch-546", &s, 0.0005, 3.5);
    soup_free(&s);
    /* Half an ellipsoid: the triangles above a plane. */
    const double c[3] = {0, 0, 0}, ax[3] = {1, 1, 0.7};
    add_icosphere(&s, 3, c, ax, 0.01, &rng);
    crop_z(&s, 0.1);
    check_mesh("cap-open", &s, 0.0005, 3.5);
    soup_free(&s);
}
END_TEST

START_TEST(test_two_components)
{
    uint64_t rng = 13;
    const double ax[3] = {0.5, 0.4, 0.45};
    /* Far apart: the spatial grid spans mostly empty space. */
    soup s = {0};
    const double c1[3] = {0, 0, 0}, c2[3] = {12, 3, -4};
    add_icosphere(&s, 2, c1, ax, 0.03, &rng);
    add_icosphere(&s, 2, c2, ax, 0.03, &rng);
    check_mesh("two-far", &s, 0.00005, 3.5);
    soup_free(&s);
    /* Two closed components closer than the cut-off radius. */
    const double c3[3] = {1.02, 0, 0};
    add_icosphere(&s, 2, c1, ax, 0.03, &rng);
    add_icosphere(&s, 2, c3, ax, 0.03, &rng);
    check_mesh("two-near", &s, 0.001, 3.5);
    soup_free(&s);
}
END_TEST

START_TEST(test_soup_and_non_manifold)
{
    uint64_t rng = 14;
    /* Triangle soup: every vertex repeated by each of its triangles, so
     * coincident vertices (distance 0, W = 1) abound. */
    soup s = {0};
    const double c[3] = {0, 0, 0}, ax[3] = {1, 0.9, 0.8};
    add_icosphere(&s, 1, c, ax, 0.05, &rng);
    add_patch(&s, 8, 8, 1.5, 0.3, &rng);
    explode(&s); /* 80 * 3 + 128 * 3 = 624 vertices */
    check_mesh("soup-624", &s, 0.002, 3.5);
    soup_free(&s);

    /* Non-manifold: fins standing on interior edges of a patch (three
     * triangles per such edge), a bow-tie (two triangles sharing only a
     * vertex) and a book of four pages on one edge. */
    uint32_t first = add_patch(&s, 14, 12, 1.0, 0.3, &rng);
    for (size_t i = 2; i < 12; i += 2) {
        uint32_t a = first + (uint32_t)(6 * 15 + i), b = a + 1;
        uint32_t apex = soup_vertex(&s, (s.xyz[3 * a] + s.xyz[3 * b]) / 2,
                                    s.xyz[3 * a + 1] + 0.01, 0.2);
        soup_triangle(&s, a, b, apex);
    }
    uint32_t hub = soup_vertex(&s, 1.3, 0.5, 0.1);
    uint32_t t1 = soup_vertex(&s, 1.4, 0.55, 0.12), t2 = soup_vertex(&s, 1.38, 0.45, 0.05);
    uint32_t t3 = soup_vertex(&s, 1.2, 0.52, 0.13), t4 = soup_vertex(&s, 1.23, 0.41, 0.09);
    soup_triangle(&s, hub, t1, t2);
    soup_triangle(&s, hub, t3, t4);
    uint32_t e0 = soup_vertex(&s, 1.3, 0.1, 0.0), e1 = soup_vertex(&s, 1.3, 0.2, 0.0);
    for (int page = 0; page < 4; page++) {
        double ang = 2 * PI * page / 4 + 0.3;
        uint32_t tip = soup_vertex(&s, 1.3 + 0.08 * cos(ang), 0.15, 0.08 * sin(ang));
        soup_triangle(&s, e0, e1, tip);
    }
    check_mesh("non-manifold", &s, 0.0005, 3.5);
    soup_free(&s);
}
END_TEST

/* PHKS_BOX_PRINCIPAL: invariant to rotations; on a mesh symmetric about the
 * coordinate planes its axes are the coordinate axes; and the operator of
 * a rotated copy is that of the original. */
START_TEST(test_principal_box)
{
    uint64_t rng = 15;
    const double c[3] = {0.2, -0.5, 1.0}, ax[3] = {1.0, 0.6, 0.3};
    soup sym = {0};
    add_icosphere(&sym, 2, c, ax, 0, &rng);
    phks_mesh *mesh = soup_mesh(&sym);
    double principal, aligned;
    REQUIRE(phks__unit_box_scale(mesh, PHKS_BOX_PRINCIPAL, PHKS__SPAN_NONE, &principal) == PHKS_OK);
    REQUIRE(phks__unit_box_scale(mesh, PHKS_BOX_AXIS_ALIGNED, PHKS__SPAN_NONE, &aligned) == PHKS_OK);
    /* The icosphere is symmetric under each coordinate reflection, so its
     * principal axes are x, y, z and the box is 2 x 1.2 x 0.6. */
    REQUIRE_MSG(fabs(principal - 0.5) < 1e-12, "principal scale %.17g", principal);
    REQUIRE_MSG(fabs(aligned - axis_aligned_scale(mesh)) <= 1e-15 * aligned,
                "aligned scale %.17g", aligned);
    phks_mesh_free(mesh);
    soup_free(&sym);

    soup base = {0};
    add_icosphere(&base, 3, c, ax, 0.02, &rng);
    phks_mesh *original = soup_mesh(&base);
    double s0;
    REQUIRE(phks__unit_box_scale(original, PHKS_BOX_PRINCIPAL, PHKS__SPAN_NONE, &s0) == PHKS_OK);
    double worst = 0;
    for (int trial = 0; trial < 6; trial++) {
        soup r = {0};
        add_icosphere(&r, 3, c, ax, 0, &rng); /* same connectivity */
        memcpy(r.xyz, base.xyz, 3 * base.nv * sizeof *r.xyz);
        double rot[9], shift[3] = {5 * test_random(&rng), -3, 7 * test_random(&rng)};
        random_rotation(&rng, rot);
        rotate(&r, rot, shift);
        phks_mesh *rotated = soup_mesh(&r);
        double s1, a1;
        REQUIRE(phks__unit_box_scale(rotated, PHKS_BOX_PRINCIPAL, PHKS__SPAN_NONE, &s1) == PHKS_OK);
        REQUIRE_MSG(fabs(s1 - s0) <= 1e-12 * s0,
                    "rotation %d: principal scale %.17g, original %.17g", trial, s1, s0);
        worst = fmax(worst, fabs(s1 - s0) / s0);
        REQUIRE(phks__unit_box_scale(rotated, PHKS_BOX_AXIS_ALIGNED, PHKS__SPAN_NONE, &a1) == PHKS_OK);
        REQUIRE(fabs(a1 - axis_aligned_scale(rotated)) <= 1e-15 * a1);

        if (trial < 2)
            for (int kind = 0; kind < 2; kind++) {
                phks_options opt;
                phks_options_init(&opt);
                opt.quadrature = PHKS_QUADRATURE_VERTICES; /* the oracle's */
                opt.box = PHKS_BOX_PRINCIPAL;
                opt.operator_kind = kind;
                opt.tau = 0.001;
                /* The operator with the library's principal scale against
                 * the oracle at that scale... */
                compare_operator("principal-rotated", rotated, &opt, s1);
                /* ...and equal to the original's up to rounding. */
                phks__operator_matrix o0, o1;
                REQUIRE(mesh_operator(original, &opt, &o0) == PHKS_OK);
                REQUIRE(mesh_operator(rotated, &opt, &o1) == PHKS_OK);
                REQUIRE(o0.row_start[o0.n] == o1.row_start[o1.n]);
                double *d0 = densify(&o0), *d1 = densify(&o1);
                size_t n = o0.n;
                for (size_t i = 0; i < n * n; i++)
                    REQUIRE_MSG(fabs(d0[i] - d1[i]) <= 1e-9 * fabs(d0[i]),
                                "rotated operator entry %zu: %.17g vs %.17g", i,
                                d1[i], d0[i]);
                for (size_t i = 0; i < n; i++)
                    REQUIRE(fabs(o0.mass[i] - o1.mass[i]) <= 1e-10 * o0.mass[i]);
                free(d0);
                free(d1);
                phks__operator_release(&o0);
                phks__operator_release(&o1);
            }
        phks_mesh_free(rotated);
        soup_free(&r);
    }
    printf("principal box: max relative scale change under rotation %.2e\n", worst);
    phks_mesh_free(original);
    soup_free(&base);
}
END_TEST

/* ---- cancellation, with the counting allocator (testutil.h) */
typedef struct {
    long calls, cancel_at, after_cancel;
    int cancelled;
    int last_stage;
    double last_fraction;
    int bad_order;
} progress_log;

static int progress_cb(void *user, phks_stage stage, double fraction)
{
    progress_log *log = user;
    if (log->cancelled)
        log->after_cancel++;
    if ((int)stage < log->last_stage ||
        ((int)stage == log->last_stage && fraction < log->last_fraction) ||
        !(fraction >= 0 && fraction <= 1))
        log->bad_order++;
    log->last_stage = (int)stage;
    log->last_fraction = fraction;
    if (stage != PHKS_STAGE_OPERATOR)
        return 0;
    if (++log->calls == log->cancel_at) {
        log->cancelled = 1;
        return 1;
    }
    return 0;
}

START_TEST(test_cancel_operator)
{
    const phks_allocator counting = {count_malloc, count_realloc, count_free, NULL};
    REQUIRE(phks_set_allocator(&counting) == PHKS_OK);
    uint64_t rng = 16;
    soup s = {0};
    const double c[3] = {0, 0, 0}, ax[3] = {1, 0.7, 0.5};
    add_icosphere(&s, 3, c, ax, 0.02, &rng);
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    phks_options opt;
    phks_options_init(&opt);
    /* A dense solve of the vertices alone: the quadrature's points would
     * make it one of thousands. */
    opt.quadrature = PHKS_QUADRATURE_VERTICES;
    opt.eigen_count = 10;
    opt.solver = PHKS_SOLVER_DENSE;
    opt.progress = progress_cb;
    for (unsigned threads = 1; threads <= 2; threads++) {
        opt.threads = threads;
        /* Count the operator-stage reports of a full run. */
        progress_log log = {0, -1, 0, 0, -1, 0, 0};
        opt.progress_user = &log;
        phks_spectrum *spec = NULL;
        long live = alloc_live;
        REQUIRE(phks_spectrum_compute(mesh, &opt, &spec) == PHKS_OK);
        REQUIRE(log.bad_order == 0);
        long reports = log.calls;
        REQUIRE(reports >= 2);
        phks_spectrum_free(spec);
        REQUIRE(alloc_live == live);
        /* Cancel at each of them. */
        for (long at = 1; at <= reports; at++) {
            progress_log l2 = {0, at, 0, 0, -1, 0, 0};
            opt.progress_user = &l2;
            spec = (phks_spectrum *)&l2; /* must be reset to NULL */
            phks_status st = phks_spectrum_compute(mesh, &opt, &spec);
            REQUIRE_MSG(st == PHKS_ERROR_CANCELLED, "cancel at report %ld: status %d",
                        at, (int)st);
            REQUIRE(spec == NULL);
            REQUIRE_MSG(alloc_live == live, "cancel at report %ld: %ld blocks leaked",
                        at, alloc_live - live);
            REQUIRE_MSG(l2.after_cancel == 0,
                        "cancel at report %ld: %ld reports after cancelling", at,
                        l2.after_cancel);
            REQUIRE(strlen(phks_last_error_message()) > 0);
        }
    }
    phks_mesh_free(mesh);
    REQUIRE(alloc_live == 0);
    phks_set_allocator(NULL);
}
END_TEST

/* =====================================================================
 * The principal box's 3 x 3 eigen-solver
 * ===================================================================== */

/* Q diag(d) Q^T for a rotation Q, row-major. */
static void from_spectrum(const double q[9], const double d[3], double a[9])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double x = 0;
            for (int k = 0; k < 3; k++)
                x += q[3 * i + k] * d[k] * q[3 * j + k];
            a[3 * i + j] = x;
        }
    for (int i = 0; i < 3; i++) /* exactly symmetric */
        for (int j = 0; j < i; j++)
            a[3 * i + j] = a[3 * j + i];
}

/* phks__sym3_eigen(a) against dsyev: values, residuals, orthonormality,
 * the sign convention, and the eigenspaces (a vector for a simple
 * eigenvalue, the projector for a repeated one). */
static void check_sym3(const double a[9], const char *what, int index)
{
    double w[3], v[9], lw[3], lv[9];
    phks__sym3_eigen(a, w, v);
    memcpy(lv, a, sizeof lv);
    REQUIRE(LAPACKE_dsyev(LAPACK_ROW_MAJOR, 'V', 'U', 3, lv, 3, lw) == 0);
    double norm = fmax(fabs(lw[0]), fabs(lw[2]));
    double tiny = 1e-300; /* the zero matrix */
    for (int j = 0; j < 3; j++) {
        REQUIRE_MSG(fabs(w[j] - lw[j]) <= 4e-15 * norm + tiny,
                    "%s %d: value %d %.17g, dsyev %.17g", what, index, j, w[j], lw[j]);
        if (j > 0)
            REQUIRE(w[j - 1] <= w[j]);
        double res = 0, big = 0;
        for (int i = 0; i < 3; i++) {
            double r = -w[j] * v[3 * i + j];
            for (int k = 0; k < 3; k++)
                r += a[3 * i + k] * v[3 * k + j];
            res = fmax(res, fabs(r));
            if (fabs(v[3 * i + j]) > fabs(big))
                big = v[3 * i + j];
        }
        REQUIRE_MSG(res <= 4e-15 * norm + tiny, "%s %d: residual %d %g of %g",
                    what, index, j, res, norm);
        REQUIRE_MSG(big > 0, "%s %d: vector %d has its largest entry negative",
                    what, index, j);
        for (int l = 0; l < 3; l++) {
            double dot = 0;
            for (int i = 0; i < 3; i++)
                dot += v[3 * i + j] * v[3 * i + l];
            REQUIRE_MSG(fabs(dot - (j == l)) <= 1e-15, "%s %d: columns %d, %d: %g",
                        what, index, j, l, dot);
        }
    }
    /* Eigenspaces: group the values that are equal within 1e-8 |A|. */
    for (int j = 0; j < 3;) {
        int end = j + 1;
        while (end < 3 && lw[end] - lw[end - 1] <= 1e-8 * norm)
            end++;
        double gap = INFINITY; /* to the other eigenvalues */
        if (j > 0)
            gap = lw[j] - lw[j - 1];
        if (end < 3)
            gap = fmin(gap, lw[end] - lw[end - 1]);
        if (end - j < 3) {
            /* projectors onto the space of w[j .. end) */
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++) {
                    double pj = 0, pl = 0;
                    for (int k = j; k < end; k++) {
                        pj += v[3 * r + k] * v[3 * c + k];
                        pl += lv[3 * r + k] * lv[3 * c + k];
                    }
                    REQUIRE_MSG(fabs(pj - pl) <= 1e-14 * norm / gap + 1e-15,
                                "%s %d: eigenspace of %d..%d differs by %g (gap %g)",
                                what, index, j, end - 1, fabs(pj - pl), gap / norm);
                }
        }
        j = end;
    }
}

START_TEST(test_sym3_eigen_against_dsyev)
{
    uint64_t rng = 2024;
    for (int i = 0; i < 3000; i++) {
        /* random symmetric, entries over 60 decades */
        double a[9], scale = pow(10, 60 * test_random(&rng) - 30);
        for (int k = 0; k < 9; k++)
            a[k] = (2 * test_random(&rng) - 1) * scale;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < r; c++)
                a[3 * r + c] = a[3 * c + r];
        check_sym3(a, "random", i);

        /* given spectra: repeated, triple, clustered, of mixed signs,
         * singular, rank one */
        double q[9], d[3];
        random_rotation(&rng, q);
        double x = 2 * test_random(&rng) - 1, y = 2 * test_random(&rng) - 1;
        switch (i % 6) {
        case 0: d[0] = x; d[1] = x; d[2] = y; break;
        case 1: d[0] = x; d[1] = y; d[2] = y; break;
        case 2: d[0] = x; d[1] = x; d[2] = x; break;
        case 3: d[0] = x; d[1] = x * (1 + 1e-9); d[2] = y; break;
        case 4: d[0] = 0; d[1] = x; d[2] = y; break;
        default: d[0] = 0; d[1] = 0; d[2] = x; break;
        }
        from_spectrum(q, d, a);
        check_sym3(a, "spectrum", i);
    }
    /* Diagonal matrices give the unit vectors exactly, sorted. */
    const double diag[4][3] = {{3, 1, 2}, {-1, -1, 5}, {0, 0, 0}, {7, 7, 7}};
    for (int i = 0; i < 4; i++) {
        double a[9] = {diag[i][0], 0, 0, 0, diag[i][1], 0, 0, 0, diag[i][2]};
        double w[3], v[9];
        phks__sym3_eigen(a, w, v);
        check_sym3(a, "diagonal", i);
        for (int j = 0; j < 3; j++) {
            int ones = 0;
            for (int r = 0; r < 3; r++) {
                REQUIRE(v[3 * r + j] == 0 || v[3 * r + j] == 1);
                ones += v[3 * r + j] == 1;
                if (v[3 * r + j] == 1)
                    REQUIRE(w[j] == diag[i][r]);
            }
            REQUIRE(ones == 1);
        }
    }
    /* The zero matrix: zero values, the identity. */
    double zero[9] = {0}, w[3], v[9];
    phks__sym3_eigen(zero, w, v);
    for (int k = 0; k < 9; k++)
        REQUIRE(v[k] == (k % 4 == 0));
    for (int j = 0; j < 3; j++)
        REQUIRE(w[j] == 0);
    /* Only the upper triangle is read; a power of two changes no vector
     * bit and scales the values exactly. */
    double a[9] = {2, -1, 0.5, 99, 3, 0.25, -99, 99, 1}, b[9], w2[3], v2[9];
    double full[9] = {2, -1, 0.5, -1, 3, 0.25, 0.5, 0.25, 1};
    phks__sym3_eigen(a, w, v);
    phks__sym3_eigen(full, w2, v2);
    REQUIRE(memcmp(v, v2, sizeof v) == 0 && memcmp(w, w2, sizeof w) == 0);
    for (int k = 0; k < 9; k++)
        b[k] = ldexp(full[k], -700);
    phks__sym3_eigen(b, w2, v2);
    REQUIRE(memcmp(v, v2, sizeof v) == 0);
    for (int j = 0; j < 3; j++)
        REQUIRE(w2[j] == ldexp(w[j], -700));
}
END_TEST

/* The principal box of a mesh at any size (1e-150 to 1e150, where the
 * covariance's fourth powers would overflow or underflow) is the same box:
 * exactly so for powers of two. And it is the same, bit for bit, with one
 * BLAS thread and with two. */
START_TEST(test_principal_box_any_size_and_blas_threads)
{
    uint64_t rng = 99;
    const double c[3] = {0.3, 0.1, -0.2}, ax[3] = {1.0, 0.7, 0.4};
    soup base = {0};
    add_icosphere(&base, 3, c, ax, 0.05, &rng);
    double rot[9], shift[3] = {0.5, 0.25, -1};
    random_rotation(&rng, rot);
    rotate(&base, rot, shift);
    phks_mesh *mesh = soup_mesh(&base);
    double s0;
    REQUIRE(phks__unit_box_scale(mesh, PHKS_BOX_PRINCIPAL, PHKS__SPAN_NONE, &s0) == PHKS_OK);
    phks_mesh_free(mesh);
    const double sizes[] = {0x1p-490, 0x1p-100, 0x1p100, 0x1p490,
                            1e-150,   1e-100,   1e-60,   1e60,
                            1e100,    1e150};
    for (size_t i = 0; i < sizeof sizes / sizeof *sizes; i++) {
        soup t = {0};
        add_icosphere(&t, 3, c, ax, 0, &rng); /* same connectivity */
        for (size_t k = 0; k < 3 * base.nv; k++)
            t.xyz[k] = base.xyz[k] * sizes[i];
        phks_mesh *m = soup_mesh(&t);
        double s;
        phks_status st = phks__unit_box_scale(m, PHKS_BOX_PRINCIPAL, PHKS__SPAN_NONE, &s);
        REQUIRE_MSG(st == PHKS_OK, "size %g: %s", sizes[i], phks_last_error_message());
        if (i < 4)
            REQUIRE_MSG(s * sizes[i] == s0, "size %g: %.17g, at 1: %.17g",
                        sizes[i], s * sizes[i], s0);
        else
            REQUIRE_MSG(fabs(s * sizes[i] - s0) <= 1e-14 * s0,
                        "size %g: %.17g, at 1: %.17g", sizes[i], s * sizes[i], s0);
        phks_mesh_free(m);
        soup_free(&t);
    }
    /* BLAS threads. */
    mesh = soup_mesh(&base);
    double by[2];
    int before = openblas_get_num_threads();
    for (int t = 0; t < 2; t++) {
        openblas_set_num_threads(t + 1);
        REQUIRE(phks__unit_box_scale(mesh, PHKS_BOX_PRINCIPAL, PHKS__SPAN_NONE, &by[t]) == PHKS_OK);
    }
    openblas_set_num_threads(before);
    REQUIRE(memcmp(&by[0], &by[1], sizeof by[0]) == 0);
    REQUIRE(by[0] == s0);
    phks_mesh_free(mesh);
    soup_free(&base);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("operator");
    TCase *tc = tcase_create("operator");
    tcase_set_timeout(tc, 600);
    tcase_add_test(tc, test_closed);
    tcase_add_test(tc, test_open);
    tcase_add_test(tc, test_two_components);
    tcase_add_test(tc, test_soup_and_non_manifold);
    tcase_add_test(tc, test_principal_box);
    tcase_add_test(tc, test_sym3_eigen_against_dsyev);
    tcase_add_test(tc, test_principal_box_any_size_and_blas_threads);
    tcase_add_test(tc, test_cancel_operator);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return run_suite(suite());
}
