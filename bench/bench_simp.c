/*
 * bench_simp.c - accuracy of HKS-simp against the exact computation, in the
 * form of the paper's Table 1 (section 4.1): for each mesh, the HKS at
 * t = 5, 40 and 100 tau from
 *   - the exact spectrum of the whole mesh (the ground truth),
 *   - HKS-simp reduced to about --target samples (default 3000), extended
 *     to every vertex,
 *   - quadric decimation (meshoptimizer's meshopt_simplify, when the
 *     library was found at build time) to about as many vertices, with the
 *     exact spectrum of the decimated mesh,
 * and for each approximation the mean L1 error and the correlation against
 * the ground truth.
 *
 * The error, as the paper's "averaged L1-norm distance": the mean over
 * vertices of |HKS_approx(v) - HKS_exact(v)|, in the library's units (mesh
 * scaled to the unit box, eigenvectors M-orthonormal, so HKS is in
 * 1 / (unit-box length)^2, as the paper's). Also the same divided by the
 * mean of HKS_exact ("rel", which does not depend on the box). Correlation
 * is Pearson's over vertices. HKS-simp is measured over every vertex of
 * the mesh; decimation only over the vertices it keeps (they are vertices
 * of the input: meshopt_simplify collapses edges onto existing vertices),
 * which spares it any extension error.
 *
 *   bench-simp [--target N] [--box principal|axis] [--operator literal|rw]
 *              MESH...
 *
 * With --match, the matching test at full size instead: the
 * signatures (default options: HKS-simp above 25k vertices) of LARGE, of
 * SMALL (a smaller version of the same shape) and of every OTHER mesh, and
 * where SMALL ranks among LARGE's matches and LARGE among SMALL's:
 *
 *   bench-simp --match LARGE SMALL OTHER...
 */
#include "phks.h"

#ifdef HAVE_MESHOPTIMIZER
#include <meshoptimizer.h>
#endif

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define SCALES 3
static const double scales[SCALES] = {5, 40, 100};

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

typedef struct {
    double l1, rel, corr;
} accuracy;

/* Over the vertices listed in at (count of them; NULL: 0..count-1), the
 * approximation a[i] against exact[at[i]]. */
static accuracy compare(const double *exact, const double *a,
                        const uint32_t *at, size_t count)
{
    double se = 0, sa = 0, l1 = 0;
    for (size_t i = 0; i < count; i++) {
        double e = exact[at ? at[i] : i];
        se += e;
        sa += a[i];
        l1 += fabs(a[i] - e);
    }
    double me = se / (double)count, ma = sa / (double)count;
    double cov = 0, ve = 0, va = 0;
    for (size_t i = 0; i < count; i++) {
        double e = exact[at ? at[i] : i] - me, d = a[i] - ma;
        cov += e * d;
        ve += e * e;
        va += d * d;
    }
    accuracy r = {l1 / (double)count, l1 / (double)count / me,
                  cov / sqrt(ve * va)};
    return r;
}

static int fail(const char *what)
{
    fprintf(stderr, "bench-simp: %s: %s\n", what, phks_last_error_message());
    return 1;
}

/* HKS at the three scales for all vertices of mesh under opt: 3 x n. */
static double *hks3(const phks_mesh *mesh, const phks_options *opt,
                    phks_spectrum **keep, double *seconds)
{
    double t0 = now();
    phks_spectrum *spec;
    if (phks_spectrum_compute(mesh, opt, &spec) != PHKS_OK)
        return NULL;
    size_t n = phks_mesh_vertex_count(mesh);
    double *h = malloc(SCALES * n * sizeof *h);
    for (int s = 0; h && s < SCALES; s++)
        if (phks_spectrum_hks(spec, scales[s] * opt->tau, h + s * n) != PHKS_OK) {
            free(h);
            h = NULL;
        }
    *seconds = now() - t0;
    if (keep)
        *keep = spec;
    else
        phks_spectrum_free(spec);
    return h;
}

static void row(const char *name, const char *method, size_t kept,
                double seconds, const accuracy *acc)
{
    printf("%-22s %-10s %6zu %7.1f", name, method, kept, seconds);
    for (int s = 0; s < SCALES; s++)
        printf("   %6.3f %5.2f%% %.4f", acc[s].l1, 100 * acc[s].rel, acc[s].corr);
    printf("\n");
    fflush(stdout);
}

#ifdef HAVE_MESHOPTIMIZER
/* Quadric decimation to about `target` vertices: the decimated mesh, its
 * vertices being vertices of mesh (phks_mesh_vertex_origin maps them). */
static phks_mesh *decimate(const phks_mesh *mesh, size_t target)
{
    size_t n = phks_mesh_vertex_count(mesh), nt = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    float *pos = malloc(3 * n * sizeof *pos);
    unsigned *idx = malloc(3 * nt * sizeof *idx);
    unsigned *out = malloc(3 * nt * sizeof *out);
    phks_mesh *dec = NULL;
    if (!pos || !idx || !out)
        goto done;
    for (size_t i = 0; i < 3 * n; i++)
        pos[i] = (float)xyz[i];
    for (size_t i = 0; i < 3 * nt; i++)
        idx[i] = tri[i];
    /* A closed mesh has twice as many triangles as vertices; aim there
     * and let meshoptimizer stop at that count (no error bound). */
    size_t want = 3 * 2 * target, got = 0;
    got = meshopt_simplify(out, idx, 3 * nt, pos, n, 3 * sizeof(float), want,
                           1.0f, 0, NULL);
    phks_mesh_create(xyz, n, out, got / 3, &dec);
done:
    free(pos);
    free(idx);
    free(out);
    return dec;
}
#endif

static int run(const char *path, const phks_options *base, size_t target)
{
    phks_mesh *mesh;
    if (phks_mesh_load(path, &mesh) != PHKS_OK)
        return fail(path);
    const char *name = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    size_t n = phks_mesh_vertex_count(mesh);

    phks_options exact = *base;
    exact.simplify_above = 0;
    double t_exact, t_simp;
    double *truth = hks3(mesh, &exact, NULL, &t_exact);
    if (!truth)
        return fail(path);
    accuracy acc[SCALES];
    for (int s = 0; s < SCALES; s++)
        acc[s] = (accuracy){0, 0, 1};
    row(name, "exact", n, t_exact, acc);

    phks_options simp = *base;
    simp.simplify_above = (uint32_t)(target < n ? target : n - 1);
    simp.simplify_target = (uint32_t)target;
    phks_spectrum *spec = NULL;
    double *h = hks3(mesh, &simp, &spec, &t_simp);
    if (!h)
        return fail(path);
    for (int s = 0; s < SCALES; s++)
        acc[s] = compare(truth + s * n, h + s * n, NULL, n);
    row(name, "HKS-simp", phks_spectrum_sample_count(spec), t_simp, acc);
    free(h);
    phks_spectrum_free(spec);

#ifdef HAVE_MESHOPTIMIZER
    double t0 = now();
    phks_mesh *dec = decimate(mesh, target);
    if (!dec)
        return fail("decimation");
    double t_dec;
    size_t nd = phks_mesh_vertex_count(dec);
    double *hd = hks3(dec, &exact, NULL, &t_dec);
    if (!hd)
        return fail("decimated mesh");
    const uint32_t *origin = phks_mesh_vertex_origin(dec);
    for (int s = 0; s < SCALES; s++)
        acc[s] = compare(truth + s * n, hd + s * nd, origin, nd);
    row(name, "quadric", nd, now() - t0, acc);
    free(hd);
    phks_mesh_free(dec);
#endif
    free(truth);
    phks_mesh_free(mesh);
    return 0;
}

static phks_signature *signature_of(const char *path, double *seconds,
                                     size_t *vertices)
{
    double t0 = now();
    phks_mesh *mesh;
    phks_signature *sig = NULL;
    if (phks_mesh_load(path, &mesh) != PHKS_OK)
        return NULL;
    *vertices = phks_mesh_vertex_count(mesh);
    if (phks_signature_compute(mesh, NULL, &sig) != PHKS_OK)
        sig = NULL;
    phks_mesh_free(mesh);
    *seconds = now() - t0;
    return sig;
}

/* Rank (1 = best) of entry `pair` among the scores of sig[from] against
 * every other signature. */
static int rank_of(phks_signature **sig, int count, int from, int pair,
                   double *pair_score, double *best_other)
{
    int rank = 1;
    phks_score(sig[from], sig[pair], pair_score);
    *best_other = INFINITY;
    for (int i = 0; i < count; i++) {
        if (i == from || i == pair)
            continue;
        double s;
        phks_score(sig[from], sig[i], &s);
        if (s < *best_other)
            *best_other = s;
        rank += s < *pair_score;
    }
    return rank;
}

static int match(int count, char **paths)
{
    phks_signature **sig = calloc((size_t)count, sizeof *sig);
    if (!sig)
        return 1;
    printf("%-44s %9s %8s\n", "mesh", "vertices", "seconds");
    for (int i = 0; i < count; i++) {
        double seconds;
        size_t n;
        sig[i] = signature_of(paths[i], &seconds, &n);
        if (!sig[i])
            return fail(paths[i]);
        printf("%-44s %9zu %8.1f\n", paths[i], n, seconds);
        fflush(stdout);
    }
    for (int a = 0; a < 2; a++) {
        double pair, other;
        int rank = rank_of(sig, count, a, 1 - a, &pair, &other);
        printf("%s: %s ranks %d of %d (score %.1f; best other %.1f)\n", paths[a],
               paths[1 - a], rank, count - 1, pair, other);
    }
    for (int i = 0; i < count; i++)
        phks_signature_free(sig[i]);
    free(sig);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 3 && strcmp(argv[1], "--match") == 0)
        return match(argc - 2, argv + 2);
    phks_options opt;
    phks_options_init(&opt);
    size_t target = 3000;
    int first = 1;
    for (; first + 1 < argc && argv[first][0] == '-'; first += 2) {
        const char *v = argv[first + 1];
        if (strcmp(argv[first], "--target") == 0)
            target = (size_t)atol(v);
        else if (strcmp(argv[first], "--box") == 0)
            opt.box = strcmp(v, "axis") == 0 ? PHKS_BOX_AXIS_ALIGNED
                                             : PHKS_BOX_PRINCIPAL;
        else if (strcmp(argv[first], "--operator") == 0)
            opt.operator_kind = strcmp(v, "literal") == 0
                                    ? PHKS_OPERATOR_LITERAL
                                    : PHKS_OPERATOR_RANDOM_WALK;
    }
    if (first >= argc || target < 16) {
        fprintf(stderr, "usage: bench-simp [--target N] [--box principal|axis] "
                        "[--operator literal|rw] MESH...\n"
                        "       bench-simp --match LARGE SMALL OTHER...\n");
        return 2;
    }
    printf("libphks %s, %s operator, %s box; HKS at t = 5, 40, 100 tau: mean "
           "L1 error, the same relative to the mean HKS, correlation\n",
           phks_version_string(),
           opt.operator_kind == PHKS_OPERATOR_LITERAL ? "literal" : "random-walk",
           opt.box == PHKS_BOX_AXIS_ALIGNED ? "axis-aligned" : "principal");
#ifndef HAVE_MESHOPTIMIZER
    printf("(built without meshoptimizer: no quadric decimation rows)\n");
#endif
    printf("%-22s %-10s %6s %7s   %-20s   %-20s   %-20s\n", "mesh", "method",
           "kept", "seconds", "5 tau: L1 rel corr", "40 tau", "100 tau");
    int failures = 0;
    for (int i = first; i < argc; i++)
        failures += run(argv[i], &opt, target);
    return failures ? 1 : 0;
}
