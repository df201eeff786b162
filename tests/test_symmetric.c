/*
 * test_symmetric.c - exactly symmetric and numerically hostile meshes,
 * generated here with exact coordinates: every solver must give the same
 * spectrum, whole clusters of equal eigenvalues, and the known null space.
 *
 * Symmetry gives eigenvalues of exact multiplicity (2l + 1 on a sphere,
 * pairs on anything with an n-fold axis, a doubled spectrum for two
 * identical parts), which MRRR, the convergence checks and ARPACK's
 * single-vector Lanczos each handle differently; hostile meshes add many
 * zero eigenvalues (separate triangles), points the kernel isolates (cap
 * centres of fans), coincident vertices and slivers.
 *
 * Expectations: for each mesh, PHKS_SOLVER_AUTO, LANCZOS and ARPACK (and
 * DENSE where the mesh is small) return the same number of pairs and
 * eigenvalues within 1e-8 relative, with an absolute floor of 1e-8 * 2/tau
 * near zero; as many zero eigenvalues as the kernel has components,
 * counted here from the geometry; the count ends at a cluster boundary
 * (the next eigenvalue, from a dense solve of more pairs, is apart).
 * The geodesic sphere also against the continuum limit (Funk-Hecke, as in
 * test_sphere), and its signatures from each solver and from a rotated
 * copy must score within 1e-6 of each other.
 */
#include "funk_hecke.h"
#include "soup.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TAU 0.0002
#define AGREE 1e-8
#define FLOOR (1e-8 * 2 / TAU)
/* the library's documented tolerance for equal eigenvalues (phks.h) */
#define CLUSTER 1e-6
/* dense solves are compared on meshes up to this size */
#define DENSE_MAX 2000

/* =====================================================================
 * Generators (exact coordinates)
 * ===================================================================== */

/* Merges vertices closer than 1e-9 (the generators' rounding) into the
 * first, renumbering the triangles. O(n^2): the meshes are small. */
static void weld(soup *s)
{
    uint32_t *map = malloc(s->nv * sizeof *map);
    size_t kept = 0;
    REQUIRE(map);
    for (size_t i = 0; i < s->nv; i++) {
        size_t j;
        for (j = 0; j < kept; j++) {
            const double *a = s->xyz + 3 * i, *b = s->xyz + 3 * j;
            if (fabs(a[0] - b[0]) < 1e-9 && fabs(a[1] - b[1]) < 1e-9 &&
                fabs(a[2] - b[2]) < 1e-9)
                break;
        }
        if (j == kept) {
            memmove(s->xyz + 3 * kept, s->xyz + 3 * i, 3 * sizeof(double));
            kept++;
        }
        map[i] = (uint32_t)j;
    }
    for (size_t t = 0; t < 3 * s->nt; t++)
        s->tri[t] = map[s->tri[t]];
    s->nv = kept;
    free(map);
}

static double round12(double x) { return round(x * 1e12) / 1e12; }

static const int ico_faces[20][3] = {
    {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};

static void ico_vertex(int i, double p[3])
{
    const double g = (1 + sqrt(5.0)) / 2;
    static const double base[12][3] = {
        {-1, 1, 0}, {1, 1, 0},  {-1, -1, 0}, {1, -1, 0}, {0, -1, 1}, {0, 1, 1},
        {0, -1, -1}, {0, 1, -1}, {1, 0, -1}, {1, 0, 1},  {-1, 0, -1}, {-1, 0, 1}};
    /* (+-1, +-g, 0) and its cyclic permutations */
    for (int d = 0; d < 3; d++)
        p[d] = base[i][d];
    if (i < 4)
        p[1] *= g;
    else if (i < 8)
        p[2] *= g;
    else
        p[0] *= g;
}

/* The geodesic sphere of the issue: each icosahedron face split into f x f
 * triangles, points projected onto the sphere of radius r about c,
 * rounded to 1e-12, welded: 10 f^2 + 2 vertices. */
static void add_geodesic(soup *s, int f, const double c[3], double r)
{
    for (int face = 0; face < 20; face++) {
        double a[3], b[3], d[3];
        ico_vertex(ico_faces[face][0], a);
        ico_vertex(ico_faces[face][1], b);
        ico_vertex(ico_faces[face][2], d);
        uint32_t idx[64][64];
        REQUIRE(f < 63);
        for (int i = 0; i <= f; i++)
            for (int j = 0; j <= f - i; j++) {
                double p[3], len = 0;
                for (int e = 0; e < 3; e++) {
                    p[e] = (i * a[e] + j * b[e] + (f - i - j) * d[e]) / f;
                    len += p[e] * p[e];
                }
                len = sqrt(len);
                idx[i][j] = soup_vertex(s, c[0] + r * round12(p[0] / len),
                                        c[1] + r * round12(p[1] / len),
                                        c[2] + r * round12(p[2] / len));
            }
        for (int i = 0; i < f; i++)
            for (int j = 0; j < f - i; j++) {
                soup_triangle(s, idx[i][j], idx[i + 1][j], idx[i][j + 1]);
                if (j + 1 < f - i)
                    soup_triangle(s, idx[i + 1][j], idx[i + 1][j + 1],
                                  idx[i][j + 1]);
            }
    }
    weld(s);
}

/* A closed surface of revolution about z: rings of `around` points at the
 * profile points (radius[i], z[i]), i = 0 .. rings - 1; radius 0 at either
 * end is a single pole vertex joined by a fan. */
static void add_revolution(soup *s, size_t around, size_t rings,
                           const double *radius, const double *z)
{
    uint32_t row[64][128];
    REQUIRE(rings <= 64 && around <= 128);
    for (size_t i = 0; i < rings; i++) {
        if (radius[i] == 0) {
            uint32_t v = soup_vertex(s, 0, 0, z[i]);
            for (size_t j = 0; j < around; j++)
                row[i][j] = v;
            continue;
        }
        for (size_t j = 0; j < around; j++) {
            double a = 2 * PI * (double)j / (double)around;
            row[i][j] = soup_vertex(s, radius[i] * cos(a), radius[i] * sin(a), z[i]);
        }
    }
    for (size_t i = 0; i + 1 < rings; i++)
        for (size_t j = 0; j < around; j++) {
            size_t k = (j + 1) % around;
            if (radius[i] != 0)
                soup_triangle(s, row[i][j], row[i][k], row[i + 1][k]);
            if (radius[i + 1] != 0)
                soup_triangle(s, row[i][j], row[i + 1][k], row[i + 1][j]);
        }
}

/* A closed cylinder (top radius = bottom radius) or cone (top 0) of
 * `around` sides and `rings` side rings, caps fanned from a centre vertex. */
static void add_capped(soup *s, size_t around, size_t rings, double r0,
                       double r1, double height)
{
    double radius[66], z[66];
    REQUIRE(rings + 2 <= 66);
    size_t m = 0;
    radius[m] = 0;
    z[m++] = 0;
    for (size_t i = 0; i < rings; i++) {
        double t = (double)i / (double)(rings - 1);
        radius[m] = r0 + (r1 - r0) * t;
        z[m++] = height * t;
    }
    if (radius[m - 1] != 0) {
        radius[m] = 0;
        z[m++] = height;
    }
    add_revolution(s, around, m, radius, z);
}

/* A g x g grid of squares on each face of the cube [-1, 1]^3. */
static void add_cube(soup *s, int g)
{
    for (int axis = 0; axis < 3; axis++)
        for (int side = -1; side <= 1; side += 2) {
            uint32_t idx[33][33];
            REQUIRE(g <= 32);
            for (int i = 0; i <= g; i++)
                for (int j = 0; j <= g; j++) {
                    double p[3];
                    p[axis] = side;
                    p[(axis + 1) % 3] = -1 + 2.0 * i / g;
                    p[(axis + 2) % 3] = -1 + 2.0 * j / g;
                    idx[i][j] = soup_vertex(s, p[0], p[1], p[2]);
                }
            for (int i = 0; i < g; i++)
                for (int j = 0; j < g; j++) {
                    soup_triangle(s, idx[i][j], idx[i + 1][j], idx[i + 1][j + 1]);
                    soup_triangle(s, idx[i][j], idx[i + 1][j + 1], idx[i][j + 1]);
                }
        }
    weld(s);
}

/* A flat (g + 1)^2 grid in the plane z = 0, open. */
static void add_grid(soup *s, int g)
{
    uint32_t first = (uint32_t)s->nv;
    for (int i = 0; i <= g; i++)
        for (int j = 0; j <= g; j++)
            soup_vertex(s, (double)i / g, (double)j / g, 0);
    for (int i = 0; i < g; i++)
        for (int j = 0; j < g; j++) {
            uint32_t a = first + (uint32_t)(i * (g + 1) + j);
            soup_triangle(s, a, a + (uint32_t)(g + 1), a + (uint32_t)(g + 2));
            soup_triangle(s, a, a + (uint32_t)(g + 2), a + 1);
        }
}

/* count triangles at the points of a cubic lattice of spacing 0.2: in a
 * unit box far apart for the kernel (cut-off 3.5 sqrt(4 tau) = 0.099,
 * and the box's side at most sqrt(3) per_side / 5 whatever its frame),
 * each its own component. Equilateral of side 0.01, or with `varied`
 * scalene, sides 0.01 to 0.014, no two alike (shapes repeat every 385). */
static void add_separate_triangles(soup *s, int per_side, size_t count,
                                   bool varied)
{
    size_t made = 0;
    for (int i = 0; i < per_side && made < count; i++)
        for (int j = 0; j < per_side && made < count; j++)
            for (int k = 0; k < per_side && made < count; k++, made++) {
                double x = 0.2 * i, y = 0.2 * j, z = 0.2 * k, e = 0.01;
                double apex = 0.5, height = sqrt(3.0) / 2;
                if (varied) {
                    e *= 1 + 0.1 * (double)(made % 5);
                    apex = 0.2 + 0.1 * (double)(made % 7);
                    height = 0.5 + 0.05 * (double)(made % 11);
                }
                uint32_t a = soup_vertex(s, x, y, z);
                uint32_t b = soup_vertex(s, x + e, y, z);
                uint32_t c = soup_vertex(s, x + e * apex, y + e * height, z);
                soup_triangle(s, a, b, c);
            }
}

/* =====================================================================
 * Checks
 * ===================================================================== */

static const int solvers[] = {PHKS_SOLVER_AUTO, PHKS_SOLVER_LANCZOS,
                              PHKS_SOLVER_ARPACK, PHKS_SOLVER_DENSE};
static const char *const solver_names[] = {"auto", "lanczos", "arpack", "dense"};

static phks_spectrum *spectrum(const phks_mesh *mesh, int solver, int op,
                               uint32_t count, const char *name)
{
    phks_options opt;
    phks_options_init(&opt);
    /* The vertices' operator: the dense solver among the four would
     * otherwise solve the quadrature's thousands of points. */
    opt.quadrature = PHKS_QUADRATURE_VERTICES;
    opt.solver = solver;
    opt.operator_kind = op;
    opt.eigen_count = count;
    phks_spectrum *spec = NULL;
    phks_status st = phks_spectrum_compute(mesh, &opt, &spec);
    REQUIRE_MSG(st == PHKS_OK, "%s, solver %d: %s (status %d)", name, solver,
                phks_last_error_message(), (int)st);
    return spec;
}

/* Every solver on mesh with eigen_count `count` and operator `op`: the same
 * count and eigenvalues; `zeros` eigenvalues ~0 and then a clearly positive
 * one (zeros 0: not checked). Returns the dense spectrum (or Lanczos's
 * where the mesh is too large for the comparison); the caller frees. */
static phks_spectrum *check_solvers(const phks_mesh *mesh, int op,
                                    uint32_t count, size_t zeros,
                                    const char *name)
{
    size_t n = phks_mesh_vertex_count(mesh);
    size_t nsolvers = n <= DENSE_MAX ? 4 : 3;
    phks_spectrum *spec[4] = {NULL};
    for (size_t s = 0; s < nsolvers; s++)
        spec[s] = spectrum(mesh, solvers[s], op, count, name);
    size_t c = phks_spectrum_count(spec[0]);
    const double *ref = phks_spectrum_eigenvalues(spec[nsolvers - 1]);
    double worst = 0;
    for (size_t s = 0; s < nsolvers; s++) {
        REQUIRE_MSG(phks_spectrum_count(spec[s]) == c,
                    "%s, op %d: %s gives %zu pairs, auto %zu", name, op,
                    solver_names[s], phks_spectrum_count(spec[s]), c);
        const double *v = phks_spectrum_eigenvalues(spec[s]);
        for (size_t i = 0; i < c; i++) {
            double d = fabs(v[i] - ref[i]);
            worst = fmax(worst, d / fmax(fabs(ref[i]), FLOOR / AGREE));
            REQUIRE_MSG(d <= AGREE * fmax(fabs(ref[i]), FLOOR / AGREE),
                        "%s, op %d: eigenvalue %zu: %s %.17g, %s %.17g", name,
                        op, i, solver_names[s], v[i],
                        solver_names[nsolvers - 1], ref[i]);
        }
    }
    if (zeros) {
        REQUIRE_MSG(c >= zeros, "%s: %zu pairs, %zu zeros expected", name, c,
                    zeros);
        for (size_t i = 0; i < zeros; i++)
            REQUIRE_MSG(fabs(ref[i]) <= FLOOR, "%s: lambda_%zu = %g", name, i,
                        ref[i]);
        if (c > zeros)
            REQUIRE_MSG(ref[zeros] > 1e3 * FLOOR, "%s: lambda_%zu = %g, not > 0",
                        name, zeros, ref[zeros]);
    }
    printf("%-28s op %d: %5zu vertices, %4zu pairs (%u asked), eigenvalues "
           "agree to %.1e\n",
           name, op, n, c, count, worst);
    fflush(stdout);
    for (size_t s = 0; s + 1 < nsolvers; s++)
        phks_spectrum_free(spec[s]);
    return spec[nsolvers - 1];
}

/* The count ends a cluster: a dense solve of more pairs shows the next
 * eigenvalue apart from the last kept (by more than the library's
 * tolerance), and the count is below what was asked only by a cluster
 * the cut would have split. */
static void check_whole(const phks_mesh *mesh, int op, uint32_t count,
                        const phks_spectrum *spec, const char *name)
{
    size_t n = phks_mesh_vertex_count(mesh), c = phks_spectrum_count(spec);
    if (n > DENSE_MAX || c >= n)
        return;
    const double *v = phks_spectrum_eigenvalues(spec);
    if (c > count) { /* the zero cluster, beyond the request */
        for (size_t i = 0; i < c; i++)
            REQUIRE(fabs(v[i]) <= FLOOR);
        return;
    }
    uint32_t more = (uint32_t)(count + 80 < n ? count + 80 : n);
    phks_spectrum *wide = spectrum(mesh, PHKS_SOLVER_DENSE, op, more, name);
    const double *w = phks_spectrum_eigenvalues(wide);
    if (phks_spectrum_count(wide) == c) {
        /* cut back to c again: the cluster after c is longer than 80;
         * all of it up to `more` must be one cluster */
        phks_spectrum_free(wide);
        wide = spectrum(mesh, PHKS_SOLVER_DENSE, op, (uint32_t)n, name);
        w = phks_spectrum_eigenvalues(wide);
        REQUIRE(phks_spectrum_count(wide) == n);
        for (size_t i = c; i + 1 < more; i++)
            REQUIRE_MSG(w[i + 1] - w[i] <= CLUSTER * fmax(fabs(w[i + 1]), 1 / TAU),
                        "%s: %zu pairs, but %zu and %zu are apart", name, c,
                        i, i + 1);
    }
    double tol = CLUSTER * fmax(fabs(w[c]), 1 / TAU);
    REQUIRE_MSG(w[c] - v[c - 1] > tol,
                "%s: the count %zu splits a cluster (%.17g, %.17g)", name, c,
                v[c - 1], w[c]);
    /* everything between the count and what was asked is one cluster with
     * the first value dropped */
    for (size_t i = c; i < count; i++)
        REQUIRE_MSG(w[i + 1] - w[i] <= CLUSTER * fmax(fabs(w[i + 1]), 1 / TAU),
                    "%s: %zu pairs of %u asked, but %zu and %zu are apart",
                    name, c, count, i, i + 1);
    phks_spectrum_free(wide);
}

static void check_mesh(const phks_mesh *mesh, uint32_t count, size_t zeros,
                       const char *name)
{
    for (int op = 0; op < 2; op++) {
        phks_spectrum *spec = check_solvers(mesh, op, count, zeros, name);
        check_whole(mesh, op, count, spec, name);
        phks_spectrum_free(spec);
    }
}

/* =====================================================================
 * Tests
 * ===================================================================== */

/* With `turned`, the copy turned by 120 degrees about (1, 1, 1), which
 * maps the icosahedron (and the whole construction) onto itself, exactly:
 * (x, y, z) -> (z, x, y), and its vertices numbered backwards. A generic
 * rotation would change the sphere's box (its extent varies by 1e-3 with
 * the direction at f = 12), hence the scale and every eigenvalue. */
static phks_mesh *geodesic_mesh(int f, bool turned)
{
    soup s = {0};
    const double c[3] = {0, 0, 0};
    add_geodesic(&s, f, c, 1);
    REQUIRE(s.nv == (size_t)(10 * f * f + 2) && s.nt == (size_t)(20 * f * f));
    if (turned) {
        soup t = {0};
        for (size_t v = s.nv; v-- > 0;)
            soup_vertex(&t, s.xyz[3 * v + 2], s.xyz[3 * v], s.xyz[3 * v + 1]);
        for (size_t i = 0; i < s.nt; i++)
            soup_triangle(&t, (uint32_t)(s.nv - 1 - s.tri[3 * i]),
                          (uint32_t)(s.nv - 1 - s.tri[3 * i + 1]),
                          (uint32_t)(s.nv - 1 - s.tri[3 * i + 2]));
        soup_free(&s);
        s = t;
    }
    return soup_mesh_take(&s);
}

/* The mesh: every solver, both operators, the default count (the
 * l = 17 cluster straddles the 300th pair). */
START_TEST(test_geodesic_sphere)
{
    phks_mesh *mesh = geodesic_mesh(12, false);
    check_mesh(mesh, 300, 1, "geodesic sphere f=12");
    phks_mesh_free(mesh);
}
END_TEST

/* Against the continuum limit of the paper's (literal) operator, l <= 6,
 * multiplicity 2l + 1. At f = 12 the edges (0.046 in the unit box) are
 * longer than the kernel's width sqrt(4 tau) = 0.028 and lambda_1 is a
 * third below mu_1; f = 32 (10242 vertices, test_sphere's icosphere size)
 * is within 0.5%. The box is axis-aligned, so R = 1 / (its longest side)
 * is measured from the vertices. */
START_TEST(test_geodesic_funk_hecke)
{
    gauss_legendre_init();
    phks_mesh *mesh = geodesic_mesh(32, false);
    phks_options opt;
    phks_options_init(&opt);
    opt.quadrature = PHKS_QUADRATURE_VERTICES; /* as test_sphere's */
    opt.operator_kind = PHKS_OPERATOR_LITERAL;
    opt.box = PHKS_BOX_AXIS_ALIGNED;
    opt.eigen_count = 64;
    const double *xyz = phks_mesh_vertices(mesh);
    size_t n = phks_mesh_vertex_count(mesh);
    double side = 0;
    for (int d = 0; d < 3; d++) {
        double lo = INFINITY, hi = -INFINITY;
        for (size_t v = 0; v < n; v++) {
            lo = fmin(lo, xyz[3 * v + d]);
            hi = fmax(hi, xyz[3 * v + d]);
        }
        side = fmax(side, hi - lo);
    }
    double R = 1 / side;
    phks_spectrum *spec = NULL;
    REQUIRE(phks_spectrum_compute(mesh, &opt, &spec) == PHKS_OK);
    REQUIRE(phks_spectrum_count(spec) == 64);
    const double *lambda = phks_spectrum_eigenvalues(spec);
    double r = opt.cutoff * sqrt(4 * opt.tau);
    REQUIRE(fabs(lambda[0]) < 1e-8);
    for (int l = 1; l <= 6; l++) {
        double mu = funk_hecke(l, R, opt.tau, r);
        for (int i = l * l; i < (l + 1) * (l + 1); i++)
            REQUIRE_MSG(fabs(lambda[i] - mu) < 0.005 * mu,
                        "l = %d: lambda_%d = %.10g, mu_l = %.10g", l, i,
                        lambda[i], mu);
        printf("funk-hecke l = %d: mu_l %.8g, lambda %.8g .. %.8g\n", l, mu,
               lambda[l * l], lambda[(l + 1) * (l + 1) - 1]);
        /* the next cluster is clearly apart */
        REQUIRE(lambda[(l + 1) * (l + 1)] > lambda[(l + 1) * (l + 1) - 1] +
                                                0.5 * (funk_hecke(l + 1, R, opt.tau, r) - mu));
    }
    phks_spectrum_free(spec);
    phks_mesh_free(mesh);
}
END_TEST

/* Signatures of the sphere from each solver and from a rotated copy. */
START_TEST(test_geodesic_signatures)
{
    phks_mesh *mesh = geodesic_mesh(12, false);
    phks_mesh *turned = geodesic_mesh(12, true);
    phks_signature *sig[5] = {NULL};
    for (int s = 0; s < 5; s++) {
        phks_options opt;
        phks_options_init(&opt);
        opt.quadrature = PHKS_QUADRATURE_VERTICES; /* as spectrum()'s */
        opt.solver = s < 4 ? solvers[s] : PHKS_SOLVER_LANCZOS;
        opt.box = PHKS_BOX_AXIS_ALIGNED;
        phks_status st = phks_signature_compute(s < 4 ? mesh : turned, &opt, &sig[s]);
        REQUIRE_MSG(st == PHKS_OK, "signature %d: %s", s, phks_last_error_message());
    }
    for (int s = 1; s < 5; s++) {
        double score = -1;
        REQUIRE(phks_score(sig[0], sig[s], &score) == PHKS_OK);
        printf("geodesic sphere: score auto vs %s %.3e\n",
               s < 4 ? solver_names[s] : "rotated", score);
        REQUIRE_MSG(score < 1e-6, "score auto vs %d: %g", s, score);
    }
    for (int s = 0; s < 5; s++)
        phks_signature_free(sig[s]);
    phks_mesh_free(mesh);
    phks_mesh_free(turned);
}
END_TEST

START_TEST(test_uv_sphere_and_revolution)
{
    /* UV sphere: 24 around, 31 rings between the poles */
    double radius[33], z[33];
    for (int i = 0; i <= 32; i++) {
        double a = PI * i / 32;
        radius[i] = i == 0 || i == 32 ? 0 : sin(a);
        z[i] = -cos(a);
    }
    soup s = {0};
    add_revolution(&s, 24, 33, radius, z);
    phks_mesh *mesh = soup_mesh_take(&s);
    check_mesh(mesh, 120, 1, "uv sphere");
    phks_mesh_free(mesh);
    /* Not here: a UV sphere of 15 rings, 0.098 apart in the unit box, at
     * the kernel's cut-off, has hundreds of eigenvalues in [0, 0.25]
     * against |B| ~ 10^4; ARPACK's regular mode cannot tell them apart and
     * reports PHKS_ERROR_NO_CONVERGENCE (it used to return a spectrum with
     * values missing); Lanczos and dense agree on it. */
    /* a vase: r(z) = 0.4 + 0.15 sin(3 z), closed by poles */
    for (int i = 0; i <= 16; i++) {
        z[i] = 2.0 * i / 16;
        radius[i] = i == 0 || i == 16 ? 0 : 0.4 + 0.15 * sin(3 * z[i]);
    }
    add_revolution(&s, 32, 17, radius, z);
    mesh = soup_mesh_take(&s);
    check_mesh(mesh, 120, 0, "surface of revolution");
    phks_mesh_free(mesh);
}
END_TEST

START_TEST(test_cube_torus_prism)
{
    soup s = {0};
    add_cube(&s, 10); /* 602 vertices */
    phks_mesh *mesh = soup_mesh_take(&s);
    check_mesh(mesh, 150, 1, "cube");
    phks_mesh_free(mesh);
    uint64_t rng = 1;
    add_torus(&s, 36, 16, 1, 0.4, 0, &rng);
    mesh = soup_mesh_take(&s);
    check_mesh(mesh, 150, 1, "torus");
    phks_mesh_free(mesh);
    /* a regular 7-gon prism: 7 sides, 12 rings, fan caps (the radius 0.25
     * keeps the centres within the kernel's reach of the rim) */
    add_capped(&s, 7, 12, 0.25, 0.25, 1);
    mesh = soup_mesh_take(&s);
    check_mesh(mesh, 40, 0, "7-gon prism");
    phks_mesh_free(mesh);
}
END_TEST

/* Fan caps whose centres are beyond the kernel's cut-off from every other
 * vertex: each is a component of its own, whence one zero eigenvalue
 * more per cap (ARPACK used to find one zero only). */
START_TEST(test_fan_caps)
{
    soup s = {0};
    /* radius 1, height 1: in the unit box (longest side 2 -> 1) the
     * centres are 0.5 from the rim, 5 cut-offs */
    add_capped(&s, 48, 14, 1, 1, 1);
    phks_mesh *mesh = soup_mesh_take(&s);
    check_mesh(mesh, 120, 3, "cylinder, fan caps");
    phks_mesh_free(mesh);
    add_capped(&s, 48, 14, 1, 0, 1.5);
    mesh = soup_mesh_take(&s);
    check_mesh(mesh, 120, 2, "cone, fan cap");
    phks_mesh_free(mesh);
}
END_TEST

/* Two identical disjoint spheres: every eigenvalue twice. */
START_TEST(test_two_spheres)
{
    soup s = {0};
    const double c0[3] = {0, 0, 0}, c1[3] = {3, 0, 0};
    add_geodesic(&s, 7, c0, 1);
    add_geodesic(&s, 7, c1, 1);
    phks_mesh *mesh = soup_mesh_take(&s);
    for (int op = 0; op < 2; op++) {
        phks_spectrum *spec = check_solvers(mesh, op, 200, 2, "two spheres");
        check_whole(mesh, op, 200, spec, "two spheres");
        const double *v = phks_spectrum_eigenvalues(spec);
        size_t c = phks_spectrum_count(spec);
        REQUIRE(c % 2 == 0);
        for (size_t i = 0; i < c; i += 2)
            REQUIRE_MSG(fabs(v[i + 1] - v[i]) <= FLOOR + 1e-10 * v[i],
                        "two spheres: lambda_%zu %.17g, lambda_%zu %.17g", i,
                        v[i], i + 1, v[i + 1]);
        phks_spectrum_free(spec);
    }
    phks_mesh_free(mesh);
}
END_TEST

/* A flat grid, separate triangles, coincident vertices, slivers. */
START_TEST(test_hostile)
{
    soup s = {0};
    add_grid(&s, 24);
    phks_mesh *mesh = soup_mesh_take(&s);
    check_mesh(mesh, 150, 1, "flat grid");
    phks_mesh_free(mesh);

    /* 200 triangles: 200 zeros, then 400 equal values; 300 asked splits
     * those, so 200 pairs remain */
    add_separate_triangles(&s, 6, 200, false);
    mesh = soup_mesh_take(&s);
    check_mesh(mesh, 300, 200, "200 separate triangles");
    phks_mesh_free(mesh);
    /* 180 triangles of as many shapes: 180 zeros, many more than the
     * Lanczos solver's block (it deflates them), then distinct values;
     * 300 asked, more than the zeros, so the solvers run (Lanczos used to
     * miss zeros here and return positive values in their place) */
    add_separate_triangles(&s, 6, 180, true);
    mesh = soup_mesh_take(&s);
    check_mesh(mesh, 300, 180, "180 scalene triangles");
    phks_mesh_free(mesh);
    /* 512 triangles: the zero cluster fills the request and is kept whole */
    add_separate_triangles(&s, 8, 512, false);
    mesh = soup_mesh_take(&s);
    for (int op = 0; op < 2; op++) {
        phks_spectrum *spec = check_solvers(mesh, op, 300, 512, "512 triangles");
        REQUIRE(phks_spectrum_count(spec) == 512);
        phks_spectrum_free(spec);
    }
    phks_mesh_free(mesh);

    /* a lattice of 6^3 points 0.2 apart, joined into 6 mesh components
     * by triangles longer than the kernel's cut-off: whatever the frame
     * of the principal box, its side is at most sqrt(3), and 0.2 /
     * sqrt(3) > 0.099, so every point is a component of its own and B is
     * zero; 150 pairs asked, fewer than the 210 zeros (the corner (5, 5)
     * of each layer is in no triangle and dropped) */
    for (int k = 0; k < 6; k++)
        for (int j = 0; j < 6; j++)
            for (int i = 0; i < 6; i++)
                soup_vertex(&s, i / 5.0, j / 5.0, k / 5.0);
    for (uint32_t k = 0; k < 6; k++)
        for (uint32_t j = 0; j < 5; j++)
            for (uint32_t i = 0; i < 5; i++) {
                uint32_t a = 36 * k + 6 * j + i;
                soup_triangle(&s, a, a + 1, a + 6);
            }
    mesh = soup_mesh_take(&s);
    REQUIRE(phks_mesh_component_count(mesh) == 6 &&
            phks_mesh_vertex_count(mesh) == 210);
    for (int op = 0; op < 2; op++) {
        phks_spectrum *spec = check_solvers(mesh, op, 150, 210, "isolated points");
        REQUIRE(phks_spectrum_count(spec) == 210);
        phks_spectrum_free(spec);
    }
    phks_mesh_free(mesh);

    /* coincident duplicates: a cube grid whose every vertex is doubled,
     * the triangles alternating between the copies */
    add_cube(&s, 8);
    size_t nv = s.nv;
    for (size_t v = 0; v < nv; v++)
        soup_vertex(&s, s.xyz[3 * v], s.xyz[3 * v + 1], s.xyz[3 * v + 2]);
    for (size_t t = 0; t < s.nt; t += 2)
        for (int c = 0; c < 3; c++)
            s.tri[3 * t + c] += (uint32_t)nv;
    mesh = soup_mesh_take(&s);
    REQUIRE(phks_mesh_vertex_count(mesh) == 2 * nv);
    check_mesh(mesh, 150, 1, "cube, duplicated vertices");
    phks_mesh_free(mesh);

    /* slivers: a fan of 400 needles, each 1 long and 1/400 of a turn */
    uint32_t centre = soup_vertex(&s, 0, 0, 0), prev = 0;
    for (int i = 0; i <= 400; i++) {
        double a = 2 * PI * i / 400 * 0.25;
        uint32_t v = soup_vertex(&s, cos(a), sin(a), 0.1 * sin(3 * a));
        if (i > 0)
            soup_triangle(&s, centre, prev, v);
        prev = v;
    }
    mesh = soup_mesh_take(&s);
    check_mesh(mesh, 120, 0, "sliver fan");
    phks_mesh_free(mesh);
}
END_TEST

/* Meshes of 4 to 20 vertices: every pair, all solvers alike. */
START_TEST(test_tiny)
{
    soup s = {0};
    /* tetrahedron */
    uint32_t a = soup_vertex(&s, 1, 1, 1), b = soup_vertex(&s, 1, -1, -1),
             c = soup_vertex(&s, -1, 1, -1), d = soup_vertex(&s, -1, -1, 1);
    soup_triangle(&s, a, b, c);
    soup_triangle(&s, a, d, b);
    soup_triangle(&s, a, c, d);
    soup_triangle(&s, b, d, c);
    phks_mesh *mesh = soup_mesh_take(&s);
    check_mesh(mesh, 300, 0, "tetrahedron");
    phks_mesh_free(mesh);
    /* the 12-triangle box */
    add_cube(&s, 1);
    mesh = soup_mesh_take(&s);
    REQUIRE(phks_mesh_vertex_count(mesh) == 8 &&
            phks_mesh_triangle_count(mesh) == 12);
    check_mesh(mesh, 300, 0, "12-triangle box");
    phks_mesh_free(mesh);
    /* icosahedron (12), and a geodesic sphere of f = 1 is the same */
    const double o[3] = {0, 0, 0};
    add_geodesic(&s, 1, o, 1);
    mesh = soup_mesh_take(&s);
    REQUIRE(phks_mesh_vertex_count(mesh) == 12);
    check_mesh(mesh, 300, 0, "icosahedron");
    phks_mesh_free(mesh);
    /* a pentagonal bipyramid-capped prism of 5 sides, 2 rings: 12 vertices;
     * and a 9-gon prism of 20 vertices */
    add_capped(&s, 5, 2, 1, 1, 1);
    mesh = soup_mesh_take(&s);
    check_mesh(mesh, 300, 0, "pentagonal prism");
    phks_mesh_free(mesh);
    add_capped(&s, 9, 2, 1, 1, 0.5);
    mesh = soup_mesh_take(&s);
    REQUIRE(phks_mesh_vertex_count(mesh) == 20);
    check_mesh(mesh, 300, 0, "9-gon prism");
    phks_mesh_free(mesh);
}
END_TEST

static void add_case(Suite *s, const char *name, const TTest *test)
{
    TCase *tc = tcase_create(name);
    tcase_set_timeout(tc, 600);
    tcase_add_test(tc, test);
    suite_add_tcase(s, tc);
}

static Suite *symmetric_suite(void)
{
    Suite *s = suite_create("symmetric");
    add_case(s, "geodesic_sphere", test_geodesic_sphere);
    add_case(s, "geodesic_funk_hecke", test_geodesic_funk_hecke);
    add_case(s, "geodesic_signatures", test_geodesic_signatures);
    add_case(s, "uv_sphere_and_revolution", test_uv_sphere_and_revolution);
    add_case(s, "cube_torus_prism", test_cube_torus_prism);
    add_case(s, "fan_caps", test_fan_caps);
    add_case(s, "two_spheres", test_two_spheres);
    add_case(s, "hostile", test_hostile);
    add_case(s, "tiny", test_tiny);
    return s;
}

int main(void)
{
    return run_suite(symmetric_suite());
}
