/*
 * test_eigen.c - phks_spectrum_compute against a dense solve of the
 * generalised problem done here.
 *
 * Oracle: S and M built by brute force over all vertex pairs (docs/method.md
 * sections 3-4; positions scaled by 1 / longest side of the axis-aligned box,
 * A = a third of the incident triangle areas, W cut at cutoff * sqrt(4h),
 * S = (diag(K 1) - K) / (4 pi h^2), M = diag(A) or diag(A D)), then
 * S phi = lambda M phi solved by LAPACKE_dsygvd, which works from S and M
 * directly (Cholesky of M), not from the library's B = M^-1/2 S M^-1/2.
 *
 * For each solver (DENSE, ARPACK, LANCZOS, AUTO) the library's result must
 * match: eigenvalues to 1e-8 relative (near-zero ones to 1e-8 of the
 * largest computed eigenvalue), phi_i^T M phi_j = delta_ij to 1e-10 with
 * the library's M and with the oracle's, the documented sign convention,
 * HKS at t = 5, 100, 1000 tau to 1e-8 relative (eigen_count is chosen at a
 * wide gap of the oracle's spectrum, so that the cut never splits a
 * cluster and HKS is defined by complete eigenspaces), and the eigenvectors
 * of well-isolated eigenvalues themselves. Also: one zero eigenvalue per
 * cluster of vertices joined by the kernel, eigen_count above the vertex
 * count, bit-identical repeated runs (and thread counts), cancellation
 * from inside each solver; a tolerance that forces the fallbacks; the
 * Ritz vectors' packed product against cblas_dgemm.
 */
#include "eigen/lanczos.h"
#include "soup.h"

#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Tolerances of the comparison with the oracle. */
#define EIG_TOL 1e-8     /* eigenvalues, relative                     */
#define ORTHO_TOL 1e-10  /* |Phi^T M Phi - I|                        */
#define HKS_TOL 1e-8     /* HKS, relative per vertex                 */
#define VEC_TOL 1e-6     /* isolated eigenvectors, relative to max   */

static const int solvers[] = {PHKS_SOLVER_DENSE, PHKS_SOLVER_ARPACK,
                              PHKS_SOLVER_LANCZOS, PHKS_SOLVER_AUTO};
static const char *const solver_names[] = {"auto", "lanczos", "arpack", "dense"};

/* =====================================================================
 * The oracle
 * ===================================================================== */

typedef struct {
    size_t n;
    double tau;
    double *mass;     /* M                                          */
    double *lambda;   /* all n eigenvalues, ascending              */
    double *phi;      /* n x n column-major, M-orthonormal columns */
    size_t clusters;  /* clusters of vertices joined by W           */
    size_t zeros;     /* eigenvalues below ZERO_REL * lambda_max   */
    double seconds;   /* dsygvd time                                */
} reference;

/* An eigenvalue below this fraction of the largest is a zero. */
#define ZERO_REL 1e-8

static size_t find_root(size_t *parent, size_t v)
{
    while (parent[v] != v)
        v = parent[v] = parent[parent[v]];
    return v;
}

static void reference_free(reference *r)
{
    free(r->mass);
    free(r->lambda);
    free(r->phi);
    memset(r, 0, sizeof *r);
}

static void reference_solve(const phks_mesh *mesh, double tau, double cutoff,
                            int kind, reference *ref)
{
    size_t n = phks_mesh_vertex_count(mesh), nt = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    double scale = axis_aligned_scale(mesh), r2 = cutoff * cutoff * 4 * tau,
           c = 1 / (4 * PI * tau * tau);
    double *pos = malloc(3 * n * sizeof *pos), *area = calloc(n, sizeof *area),
           *density = calloc(n, sizeof *density), *S = calloc(n * n, sizeof *S),
           *Md = calloc(n * n, sizeof *Md);
    size_t *parent = malloc(n * sizeof *parent);
    ref->n = n;
    ref->tau = tau;
    ref->mass = malloc(n * sizeof(double));
    ref->lambda = malloc(n * sizeof(double));
    REQUIRE(pos && area && density && S && Md && parent && ref->mass && ref->lambda);
    for (size_t i = 0; i < 3 * n; i++)
        pos[i] = xyz[i] * scale;
    for (size_t t = 0; t < nt; t++) {
        const double *a = pos + 3 * tri[3 * t], *b = pos + 3 * tri[3 * t + 1],
                     *q = pos + 3 * tri[3 * t + 2];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double v[3] = {q[0] - a[0], q[1] - a[1], q[2] - a[2]};
        double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2],
               z = u[0] * v[1] - u[1] * v[0];
        for (int k = 0; k < 3; k++)
            area[tri[3 * t + k]] += sqrt(x * x + y * y + z * z) / 6;
    }
    for (size_t v = 0; v < n; v++)
        parent[v] = v;
    for (size_t w = 0; w < n; w++) {
        density[w] += area[w];
        for (size_t p = w + 1; p < n; p++) {
            double d2 = 0;
            for (int k = 0; k < 3; k++)
                d2 += (pos[3 * w + k] - pos[3 * p + k]) * (pos[3 * w + k] - pos[3 * p + k]);
            if (!(d2 < r2))
                continue;
            double W = exp(-d2 / (4 * tau)), K = c * area[w] * area[p] * W;
            S[w * n + p] -= K;
            S[p * n + w] -= K;
            S[w * n + w] += K;
            S[p * n + p] += K;
            density[w] += area[p] * W;
            density[p] += area[w] * W;
            size_t a = find_root(parent, w), b = find_root(parent, p);
            if (a != b)
                parent[a] = b;
        }
    }
    ref->clusters = 0;
    for (size_t v = 0; v < n; v++) {
        ref->clusters += find_root(parent, v) == v;
        ref->mass[v] = kind == PHKS_OPERATOR_RANDOM_WALK
                           ? area[v] * density[v] / (4 * PI * tau)
                           : area[v];
        Md[v * n + v] = ref->mass[v];
    }
    double t0 = now();
    lapack_int info = LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'V', 'U', (lapack_int)n,
                                     S, (lapack_int)n, Md, (lapack_int)n,
                                     ref->lambda);
    ref->seconds = now() - t0;
    REQUIRE_MSG(info == 0, "dsygvd: info %d", (int)info);
    ref->phi = S; /* column i: eigenvector i, phi^T M phi = I */
    ref->zeros = 0;
    for (size_t i = 0; i < n; i++)
        ref->zeros += ref->lambda[i] < ZERO_REL * ref->lambda[n - 1];
    free(pos);
    free(area);
    free(density);
    free(Md);
    free(parent);
}

/* The eigen_count in [lo, hi] (< n) at which the oracle's spectrum has the
 * widest relative gap between the last pair kept and the first dropped. */
static size_t pick_count(const reference *ref, size_t lo, size_t hi)
{
    size_t best = lo;
    double best_gap = -1;
    for (size_t k = lo; k <= hi && k < ref->n; k++) {
        double gap = (ref->lambda[k] - ref->lambda[k - 1]) / ref->lambda[k];
        if (gap > best_gap) {
            best_gap = gap;
            best = k;
        }
    }
    REQUIRE_MSG(best_gap > 1e-6, "no gap in the spectrum between %zu and %zu", lo, hi);
    return best;
}

/* =====================================================================
 * Comparison
 * ===================================================================== */

typedef struct {
    double eig;       /* max relative eigenvalue error (non-zero ones)     */
    double eig_zero;  /* max |lambda| of zeros / largest computed lambda   */
    double ortho;     /* max |Phi^T M Phi - I|, library's and oracle's M   */
    double hks;       /* max relative HKS error over t and vertices        */
    double vec;       /* max error of isolated eigenvectors               */
    double seconds;
} accuracy;

static phks_options eigen_options(int solver, int kind, double tau, size_t count,
                                  unsigned threads)
{
    phks_options opt;
    phks_options_init(&opt);
    /* The oracle is the vertices' operator (the quadrature's own is
     * tested in test_quadrature.c). */
    opt.quadrature = PHKS_QUADRATURE_VERTICES;
    opt.box = PHKS_BOX_AXIS_ALIGNED;
    opt.solver = solver;
    opt.operator_kind = kind;
    opt.tau = tau;
    opt.eigen_count = (uint32_t)count;
    opt.threads = threads;
    return opt;
}

static phks_spectrum *compute_with(const phks_mesh *mesh, const phks_options *opt,
                                   double *seconds)
{
    phks_spectrum *spec = NULL;
    double t0 = now();
    phks_status st = phks_spectrum_compute(mesh, opt, &spec);
    if (seconds)
        *seconds = now() - t0;
    REQUIRE_MSG(st == PHKS_OK, "solver %d, eigen_count %u: %s (%s)", (int)opt->solver,
                (unsigned)opt->eigen_count, phks_status_string(st),
                phks_last_error_message());
    return spec;
}

static phks_spectrum *compute(const phks_mesh *mesh, int solver, int kind,
                              double tau, size_t count, unsigned threads,
                              double *seconds)
{
    phks_options opt = eigen_options(solver, kind, tau, count, threads);
    return compute_with(mesh, &opt, seconds);
}

/* max |Phi^T diag(m) Phi - I| */
static double m_orthonormality(const phks_spectrum *spec, const double *m)
{
    size_t n = phks_spectrum_vertex_count(spec), k = phks_spectrum_count(spec);
    double *y = malloc(n * k * sizeof *y), *g = malloc(k * k * sizeof *g);
    REQUIRE(y && g);
    for (size_t i = 0; i < k; i++) {
        const double *phi = phks_spectrum_eigenvector(spec, i);
        for (size_t v = 0; v < n; v++)
            y[i * n + v] = phi[v] * sqrt(m[v]);
    }
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)k, (int)k, (int)n,
                1.0, y, (int)n, y, (int)n, 0.0, g, (int)k);
    double worst = 0;
    for (size_t i = 0; i < k; i++)
        for (size_t j = 0; j < k; j++)
            worst = fmax(worst, fabs(g[j * k + i] - (i == j)));
    free(y);
    free(g);
    return worst;
}

static void compare(const char *name, const phks_spectrum *spec,
                    const reference *ref, size_t k, accuracy *acc)
{
    size_t n = ref->n;
    REQUIRE_MSG(phks_spectrum_count(spec) == k, "%s: %zu pairs, %zu expected", name,
                phks_spectrum_count(spec), k);
    REQUIRE(phks_spectrum_vertex_count(spec) == n);
    const double *lambda = phks_spectrum_eigenvalues(spec);
    const double *mass = phks_spectrum_mass(spec);
    double top = ref->lambda[k - 1], lambda_max = ref->lambda[n - 1];

    for (size_t v = 0; v < n; v++)
        REQUIRE_MSG(fabs(mass[v] - ref->mass[v]) <= 1e-12 * ref->mass[v],
                    "%s: mass[%zu] %.17g, expected %.17g", name, v, mass[v],
                    ref->mass[v]);

    for (size_t i = 0; i < k; i++) {
        double err = fabs(lambda[i] - ref->lambda[i]);
        REQUIRE_MSG(i == 0 || lambda[i] >= lambda[i - 1], "%s: eigenvalues not ascending at %zu",
                    name, i);
        if (ref->lambda[i] < ZERO_REL * lambda_max) {
            REQUIRE_MSG(err <= EIG_TOL * top,
                        "%s: zero eigenvalue %zu is %.3g (largest computed %.6g)",
                        name, i, lambda[i], top);
            acc->eig_zero = fmax(acc->eig_zero, err / top);
        } else {
            REQUIRE_MSG(err <= EIG_TOL * ref->lambda[i],
                        "%s: eigenvalue %zu is %.17g, dsygvd %.17g (relative %.3g)",
                        name, i, lambda[i], ref->lambda[i], err / ref->lambda[i]);
            acc->eig = fmax(acc->eig, err / ref->lambda[i]);
        }
    }

    double o1 = m_orthonormality(spec, mass), o2 = m_orthonormality(spec, ref->mass);
    REQUIRE_MSG(o1 <= ORTHO_TOL && o2 <= ORTHO_TOL,
                "%s: M-orthonormality %.3g (library M), %.3g (oracle M)", name, o1, o2);
    acc->ortho = fmax(acc->ortho, fmax(o1, o2));

    /* The entry of largest magnitude (the first such) is positive. */
    for (size_t i = 0; i < k; i++) {
        const double *phi = phks_spectrum_eigenvector(spec, i);
        size_t big = 0;
        for (size_t v = 1; v < n; v++)
            if (fabs(phi[v]) > fabs(phi[big]))
                big = v;
        REQUIRE_MSG(phi[big] > 0, "%s: eigenvector %zu: largest entry %zu is %.3g",
                    name, i, big, phi[big]);
    }

    /* HKS over complete eigenspaces (k sits at a gap of the spectrum). */
    const double times[] = {5, 100, 1000};
    double *hks = malloc(n * sizeof *hks), *expect = calloc(n, sizeof *expect);
    REQUIRE(hks && expect);
    for (int ti = 0; ti < 3; ti++) {
        double t = times[ti] * ref->tau;
        REQUIRE(phks_spectrum_hks(spec, t, hks) == PHKS_OK);
        memset(expect, 0, n * sizeof *expect);
        for (size_t i = 0; i < k; i++) {
            double decay = exp(-t * ref->lambda[i]);
            const double *phi = ref->phi + i * n;
            for (size_t v = 0; v < n; v++)
                expect[v] += decay * phi[v] * phi[v];
        }
        for (size_t v = 0; v < n; v++) {
            double err = fabs(hks[v] - expect[v]) / expect[v];
            REQUIRE_MSG(err <= HKS_TOL, "%s: HKS(t = %g tau) at vertex %zu: %.17g, "
                        "expected %.17g (relative %.3g)",
                        name, times[ti], v, hks[v], expect[v], err);
            acc->hks = fmax(acc->hks, err);
        }
    }
    free(hks);
    free(expect);

    /* Eigenvectors of eigenvalues apart from both neighbours by 1e-3. */
    for (size_t i = 0; i < k; i++) {
        double l = ref->lambda[i];
        if (l < ZERO_REL * lambda_max)
            continue;
        if ((i > 0 && l - ref->lambda[i - 1] < 1e-3 * l) ||
            (i + 1 < n && ref->lambda[i + 1] - l < 1e-3 * l))
            continue;
        const double *phi = phks_spectrum_eigenvector(spec, i),
                     *exact = ref->phi + i * n;
        double dot = 0, size = 0;
        for (size_t v = 0; v < n; v++) {
            dot += phi[v] * ref->mass[v] * exact[v];
            size = fmax(size, fabs(exact[v]));
        }
        double sign = dot < 0 ? -1 : 1, err = 0;
        for (size_t v = 0; v < n; v++)
            err = fmax(err, fabs(phi[v] - sign * exact[v]) / size);
        REQUIRE_MSG(err <= VEC_TOL, "%s: eigenvector %zu differs by %.3g", name, i,
                    err);
        acc->vec = fmax(acc->vec, err);
    }
}

/* Every solver against the oracle on one mesh, eigen_count chosen at a
 * gap within [lo, hi]. */
static void check_all_solvers(const char *mesh_name, const phks_mesh *mesh,
                              const reference *ref, int kind, size_t lo,
                              size_t hi)
{
    size_t k = pick_count(ref, lo, hi);
    for (size_t s = 0; s < sizeof solvers / sizeof *solvers; s++) {
        char name[160];
        snprintf(name, sizeof name, "%s/%s/%s/k=%zu", mesh_name,
                 kind == PHKS_OPERATOR_LITERAL ? "literal" : "random-walk",
                 solver_names[solvers[s]], k);
        accuracy acc = {0};
        phks_spectrum *spec = compute(mesh, solvers[s], kind, ref->tau, k, 0,
                                      &acc.seconds);
        compare(name, spec, ref, k, &acc);
        /* One zero eigenvalue per kernel cluster. */
        const double *lambda = phks_spectrum_eigenvalues(spec);
        size_t zeros = 0;
        for (size_t i = 0; i < k; i++)
            zeros += lambda[i] < ZERO_REL * ref->lambda[ref->n - 1];
        REQUIRE_MSG(zeros == ref->clusters, "%s: %zu zero eigenvalues, %zu clusters",
                    name, zeros, ref->clusters);
        printf("%-40s n %4zu  %6.2f s  eig %.1e  zero %.1e  ortho %.1e  "
               "hks %.1e  vec %.1e\n",
               name, ref->n, acc.seconds, acc.eig, acc.eig_zero, acc.ortho,
               acc.hks, acc.vec);
        fflush(stdout);
        phks_spectrum_free(spec);
    }
}

static void print_reference(const char *name, const reference *ref)
{
    printf("%s: n %zu, dsygvd %.2f s, clusters %zu, zeros %zu, lambda_1 %.6g, "
           "lambda_max %.6g\n",
           name, ref->n, ref->seconds, ref->clusters, ref->zeros,
           ref->lambda[ref->clusters], ref->lambda[ref->n - 1]);
    fflush(stdout);
    /* The oracle agrees with itself: one zero per cluster, and the first
     * non-zero eigenvalue far from zero. */
    REQUIRE_MSG(ref->zeros == ref->clusters, "%s: oracle has %zu zeros, %zu clusters",
                name, ref->zeros, ref->clusters);
    REQUIRE(ref->lambda[ref->clusters] > 1e-5 * ref->lambda[ref->n - 1]);
}

/* =====================================================================
 * Tests
 * ===================================================================== */

START_TEST(test_ellipsoid)
{
    uint64_t rng = 21;
    const double c[3] = {1, 2, 3}, ax[3] = {1.0, 0.8, 0.6};
    soup s = {0};
    add_icosphere(&s, 3, c, ax, 0.02, &rng); /* 642 */
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    for (int kind = 0; kind < 2; kind++) {
        reference ref;
        reference_solve(mesh, 0.001, 3.5, kind, &ref);
        print_reference(kind ? "ellipsoid-642 random-walk" : "ellipsoid-642 literal",
                        &ref);
        REQUIRE(ref.clusters == 1);
        check_all_solvers("ellipsoid-642", mesh, &ref, kind, 90, 110);
        reference_free(&ref);
    }
    phks_mesh_free(mesh);
}
END_TEST

/* A partial model with a boundary, ~2000 vertices, default tau; one run
 * with eigen_count 300. */
START_TEST(test_open)
{
    uint64_t rng = 22;
    const double c[3] = {0, 0, 0}, ax[3] = {1.0, 0.9, 0.75};
    soup s = {0};
    add_icosphere(&s, 4, c, ax, 0.01, &rng); /* 2562 */
    crop_z(&s, -0.42);
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    REQUIRE(phks_mesh_boundary_edge_count(mesh) > 0);
    reference ref;
    reference_solve(mesh, 0.0002, 3.5, PHKS_OPERATOR_LITERAL, &ref);
    print_reference("open", &ref);
    REQUIRE(ref.clusters == 1);
    check_all_solvers("open", mesh, &ref, PHKS_OPERATOR_LITERAL, 140, 160);
    check_all_solvers("open", mesh, &ref, PHKS_OPERATOR_LITERAL, 295, 315);
    reference_free(&ref);
    phks_mesh_free(mesh);
}
END_TEST

/* Two components farther apart than the cut-off: two zeros. */
START_TEST(test_two_components)
{
    uint64_t rng = 23;
    const double c1[3] = {0, 0, 0}, c2[3] = {3.4, 0.3, 0}, ax[3] = {1, 0.8, 0.7};
    soup s = {0};
    add_icosphere(&s, 3, c1, ax, 0.02, &rng);
    add_icosphere(&s, 3, c2, ax, 0.02, &rng); /* 1284 */
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    REQUIRE(phks_mesh_component_count(mesh) == 2);
    reference ref;
    reference_solve(mesh, 0.0005, 3.5, PHKS_OPERATOR_LITERAL, &ref);
    print_reference("two-components", &ref);
    REQUIRE(ref.clusters == 2);
    check_all_solvers("two-components", mesh, &ref, PHKS_OPERATOR_LITERAL, 70, 90);
    reference_free(&ref);
    phks_mesh_free(mesh);
}
END_TEST

/* Two mesh components closer than the cut-off radius: the kernel joins
 * them, so there is only one zero eigenvalue. */
START_TEST(test_components_joined_by_kernel)
{
    uint64_t rng = 24;
    const double c1[3] = {0, 0, 0}, c2[3] = {2.03, 0, 0}, ax[3] = {1, 0.8, 0.7};
    soup s = {0};
    add_icosphere(&s, 3, c1, ax, 0, &rng);
    add_icosphere(&s, 3, c2, ax, 0, &rng);
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    REQUIRE(phks_mesh_component_count(mesh) == 2);
    reference ref;
    reference_solve(mesh, 0.001, 3.5, PHKS_OPERATOR_LITERAL, &ref);
    print_reference("joined-by-kernel", &ref);
    REQUIRE(ref.clusters == 1);
    check_all_solvers("joined-by-kernel", mesh, &ref, PHKS_OPERATOR_LITERAL, 40, 60);
    reference_free(&ref);
    phks_mesh_free(mesh);
}
END_TEST

/* eigen_count above the vertex count: all vertex_count pairs. */
START_TEST(test_more_pairs_than_vertices)
{
    uint64_t rng = 25;
    const double c[3] = {0, 0, 0}, ax[3] = {1, 0.7, 0.5};
    soup s = {0};
    add_icosphere(&s, 1, c, ax, 0.05, &rng); /* 42 */
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    size_t n = phks_mesh_vertex_count(mesh);
    for (int kind = 0; kind < 2; kind++) {
        reference ref;
        reference_solve(mesh, 0.01, 3.5, kind, &ref);
        for (size_t i = 0; i < sizeof solvers / sizeof *solvers; i++) {
            accuracy acc = {0};
            phks_spectrum *spec = compute(mesh, solvers[i], kind, 0.01, 300, 0, NULL);
            REQUIRE(phks_spectrum_count(spec) == n);
            REQUIRE(phks_spectrum_eigenvector(spec, n) == NULL);
            REQUIRE(phks_spectrum_eigenvector(spec, n - 1) != NULL);
            compare("all-pairs", spec, &ref, n, &acc);
            phks_spectrum_free(spec);
        }
        reference_free(&ref);
    }
    phks_mesh_free(mesh);
}
END_TEST

/* phks__ritz_product against cblas_dgemm, at sizes that are not multiples
 * of its tiles (8 x 6) or stretches (64 rows), the same bits for 1, 2 and
 * 3 threads, with and without AVX2. */
START_TEST(test_ritz_product)
{
    const size_t sizes[][3] = {{1, 1, 1}, {7, 5, 3}, {203, 37, 13}, {640, 64, 12}};
    for (size_t c = 0; c < sizeof sizes / sizeof *sizes; c++) {
        size_t n = sizes[c][0], m = sizes[c][1], k = sizes[c][2];
        double *v = malloc(n * m * sizeof *v), *s = malloc(m * k * sizeof *s);
        double *ref = malloc(n * k * sizeof *ref), *x = malloc(n * k * sizeof *x);
        double *first = malloc(n * k * sizeof *first);
        REQUIRE(v && s && ref && x && first);
        phks__random_fill(v, n * m, 3 + c);
        phks__random_fill(s, m * k, 5 + c);
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)n, (int)k, (int)m,
                    1.0, v, (int)n, s, (int)m, 0.0, ref, (int)n);
        for (int avx2 = 0; avx2 < 2; avx2++)
            for (unsigned threads = 1; threads <= 3; threads++) {
                REQUIRE(phks__ritz_product(v, n, m, s, k, x, threads,
                                          avx2 && phks__cpu_avx2()) == PHKS_OK);
                double worst = 0, scale = 0;
                for (size_t i = 0; i < n * k; i++) {
                    worst = fmax(worst, fabs(x[i] - ref[i]));
                    scale = fmax(scale, fabs(ref[i]));
                }
                REQUIRE_MSG(worst <= 1e-14 * (double)m * fmax(scale, 1e-300),
                            "%zu x %zu x %zu, %u threads: off by %.3g", n, m, k,
                            threads, worst);
                if (threads == 1)
                    memcpy(first, x, n * k * sizeof *x);
                else
                    REQUIRE_MSG(memcmp(first, x, n * k * sizeof *x) == 0,
                                "%zu x %zu x %zu: %u threads differ from 1", n, m,
                                k, threads);
            }
        free(v);
        free(s);
        free(ref);
        free(x);
        free(first);
    }
}
END_TEST

/* A tolerance below what the filtered Lanczos reaches: its residual bound
 * fails, Rayleigh-Ritz fails, plain Lanczos follows and then the dense
 * solver; whatever path answers, it must be as right as the others. */
START_TEST(test_strict_tolerance)
{
    uint64_t rng = 27;
    const double c[3] = {0, 0, 0}, ax[3] = {1.0, 0.8, 0.6};
    soup s = {0};
    add_icosphere(&s, 3, c, ax, 0.02, &rng); /* 642 */
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    reference ref;
    reference_solve(mesh, 0.001, 3.5, PHKS_OPERATOR_LITERAL, &ref);
    size_t k = pick_count(&ref, 90, 110);
    phks_options opt =
        eigen_options(PHKS_SOLVER_LANCZOS, PHKS_OPERATOR_LITERAL, 0.001, k, 0);
    opt.tolerance = 1e-15;
    phks_spectrum *spec = compute_with(mesh, &opt, NULL);
    accuracy acc = {0};
    compare("strict-tolerance", spec, &ref, k, &acc);
    printf("strict-tolerance/lanczos/k=%zu  eig %.1e  ortho %.1e  hks %.1e\n", k,
           acc.eig, acc.ortho, acc.hks);
    phks_spectrum_free(spec);
    reference_free(&ref);
    phks_mesh_free(mesh);
}
END_TEST

static void require_identical(const phks_spectrum *a, const phks_spectrum *b,
                              const char *what)
{
    size_t n = phks_spectrum_vertex_count(a), k = phks_spectrum_count(a);
    REQUIRE(phks_spectrum_vertex_count(b) == n && phks_spectrum_count(b) == k);
    REQUIRE_MSG(memcmp(phks_spectrum_eigenvalues(a), phks_spectrum_eigenvalues(b),
                       k * sizeof(double)) == 0,
                "%s: eigenvalues differ", what);
    REQUIRE_MSG(memcmp(phks_spectrum_mass(a), phks_spectrum_mass(b),
                       n * sizeof(double)) == 0,
                "%s: masses differ", what);
    for (size_t i = 0; i < k; i++)
        REQUIRE_MSG(memcmp(phks_spectrum_eigenvector(a, i),
                           phks_spectrum_eigenvector(b, i), n * sizeof(double)) == 0,
                    "%s: eigenvector %zu differs", what, i);
}

/* Two runs give the same bits; so do 1 and 2 worker threads (the operator
 * rows are independent, so the thread count must not show). */
START_TEST(test_repeatable)
{
    uint64_t rng = 26;
    const double c[3] = {0, 0, 0}, ax[3] = {1, 0.8, 0.6};
    soup s = {0};
    add_icosphere(&s, 3, c, ax, 0.02, &rng);
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    for (size_t i = 0; i < sizeof solvers / sizeof *solvers; i++) {
        char what[64];
        phks_spectrum *a = compute(mesh, solvers[i], 0, 0.001, 100, 2, NULL);
        phks_spectrum *b = compute(mesh, solvers[i], 0, 0.001, 100, 2, NULL);
        snprintf(what, sizeof what, "%s: two runs", solver_names[solvers[i]]);
        require_identical(a, b, what);
        phks_spectrum *c1 = compute(mesh, solvers[i], 0, 0.001, 100, 1, NULL);
        snprintf(what, sizeof what, "%s: 1 vs 2 threads", solver_names[solvers[i]]);
        require_identical(a, c1, what);
        phks_spectrum_free(a);
        phks_spectrum_free(b);
        phks_spectrum_free(c1);
    }
    phks_mesh_free(mesh);
}
END_TEST

/* ---- cancellation from inside the eigen-solve */
typedef struct {
    long eigen_calls, cancel_at, after_cancel;
    int cancelled;
} cancel_log;

static int cancel_cb(void *user, phks_stage stage, double fraction)
{
    (void)fraction;
    cancel_log *log = user;
    if (log->cancelled)
        log->after_cancel++;
    if (stage == PHKS_STAGE_EIGEN && ++log->eigen_calls == log->cancel_at) {
        log->cancelled = 1;
        return 1;
    }
    return 0;
}

START_TEST(test_cancel_eigen)
{
    const phks_allocator counting = {count_malloc, count_realloc, count_free, NULL};
    REQUIRE(phks_set_allocator(&counting) == PHKS_OK);
    uint64_t rng = 27;
    const double c[3] = {0, 0, 0}, ax[3] = {1, 0.8, 0.6};
    soup s = {0};
    add_icosphere(&s, 3, c, ax, 0.02, &rng);
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    for (size_t i = 0; i < sizeof solvers / sizeof *solvers; i++) {
        const char *name = solver_names[solvers[i]];
        phks_options opt;
        phks_options_init(&opt);
        opt.box = PHKS_BOX_AXIS_ALIGNED;
        opt.tau = 0.001;
        opt.eigen_count = 100;
        opt.solver = solvers[i];
        opt.progress = cancel_cb;
        long live = alloc_live;
        cancel_log full = {0, -1, 0, 0};
        opt.progress_user = &full;
        phks_spectrum *first = NULL;
        phks_status st = phks_spectrum_compute(mesh, &opt, &first);
        REQUIRE_MSG(st == PHKS_OK, "%s: %s", name, phks_last_error_message());
        long reports = full.eigen_calls, live_with_first = alloc_live;
        REQUIRE_MSG(reports >= 2, "%s: %ld eigen-stage reports", name, reports);
        long ats[] = {1, 2, (reports + 1) / 2, reports - 1, reports};
        for (size_t a = 0; a < sizeof ats / sizeof *ats; a++) {
            cancel_log log = {0, ats[a], 0, 0};
            opt.progress_user = &log;
            phks_spectrum *spec = (phks_spectrum *)&log;
            st = phks_spectrum_compute(mesh, &opt, &spec);
            REQUIRE_MSG(st == PHKS_ERROR_CANCELLED,
                        "%s: cancel at eigen report %ld of %ld: status %s", name,
                        ats[a], reports, phks_status_string(st));
            REQUIRE(spec == NULL);
            REQUIRE_MSG(log.after_cancel == 0, "%s: %ld reports after cancelling",
                        name, log.after_cancel);
            REQUIRE_MSG(alloc_live == live_with_first,
                        "%s: cancel at eigen report %ld: %ld blocks leaked", name,
                        ats[a], alloc_live - live_with_first);
        }
        /* A cancelled solve leaves nothing behind that changes the next. */
        cancel_log again = {0, -1, 0, 0};
        opt.progress_user = &again;
        phks_spectrum *second = NULL;
        REQUIRE(phks_spectrum_compute(mesh, &opt, &second) == PHKS_OK);
        require_identical(first, second, name);
        phks_spectrum_free(first);
        phks_spectrum_free(second);
        REQUIRE(alloc_live == live);
        printf("cancel %s: %ld eigen-stage reports, cancelled at 1, 2, %ld, %ld, %ld\n",
               name, reports, ats[2], ats[3], ats[4]);
    }
    phks_mesh_free(mesh);
    REQUIRE(alloc_live == 0);
    phks_set_allocator(NULL);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("eigen");
    TCase *tc = tcase_create("eigen");
    tcase_set_timeout(tc, 900);
    tcase_add_test(tc, test_ellipsoid);
    tcase_add_test(tc, test_open);
    tcase_add_test(tc, test_two_components);
    tcase_add_test(tc, test_components_joined_by_kernel);
    tcase_add_test(tc, test_more_pairs_than_vertices);
    tcase_add_test(tc, test_repeatable);
    tcase_add_test(tc, test_strict_tolerance);
    tcase_add_test(tc, test_ritz_product);
    tcase_add_test(tc, test_cancel_eigen);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return run_suite(suite());
}
