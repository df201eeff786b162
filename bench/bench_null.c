/*
 * bench_null.c - the eigen solve on meshes whose kernel has many
 * components (that many zero eigenvalues): soups of separate triangles
 * and of small separate spheres, generated here. Median wall time of
 * phks_spectrum_compute over the runs, and the pairs it kept, their
 * zeros and the sum of the others (to compare builds and solvers).
 *
 *   bench-null [--runs R] [--solver auto|lanczos|arpack|dense] CASE...
 *
 * CASE is triangles:N:K or spheres:N:K (N pieces, K = eigen_count;
 * :TAU may follow). The pieces sit on a cubic lattice whose spacing in
 * the unit box is beyond the kernel's cut-off, so each is a component.
 * (The box is the axis-aligned one.) The spectrum keeps a zero cluster that reaches K without a solve, so K
 * must exceed N for the solver to run.
 */
#include "phks.h"

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define PI 3.14159265358979323846

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

typedef struct {
    double *xyz;
    uint32_t *tri;
    size_t nv, nt;
} soup;

static double uniform(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) / 9007199254740992.0;
}

static uint32_t vertex(soup *s, double x, double y, double z)
{
    s->xyz[3 * s->nv] = x;
    s->xyz[3 * s->nv + 1] = y;
    s->xyz[3 * s->nv + 2] = z;
    return (uint32_t)s->nv++;
}

static void triangle(soup *s, uint32_t a, uint32_t b, uint32_t c)
{
    s->tri[3 * s->nt] = a;
    s->tri[3 * s->nt + 1] = b;
    s->tri[3 * s->nt + 2] = c;
    s->nt++;
}

/* A triangle of random shape, sides about 0.05 of the lattice spacing. */
static void add_triangle(soup *s, const double c[3], double spacing, uint64_t *rng)
{
    uint32_t v[3];
    for (int i = 0; i < 3; i++) {
        double a = 2 * PI * (i + 0.6 * uniform(rng)) / 3;
        double r = spacing * (0.03 + 0.02 * uniform(rng));
        v[i] = vertex(s, c[0] + r * cos(a), c[1] + r * sin(a),
                      c[2] + 0.01 * spacing * uniform(rng));
    }
    triangle(s, v[0], v[1], v[2]);
}

/* A UV sphere of 8 x 4 rings and two poles (34 vertices), radius about
 * 0.1 of the lattice spacing. */
#define AROUND 8
#define RINGS 4
static void add_sphere(soup *s, const double c[3], double spacing, uint64_t *rng)
{
    double r = spacing * (0.08 + 0.04 * uniform(rng));
    uint32_t south = vertex(s, c[0], c[1], c[2] - r);
    uint32_t first = (uint32_t)s->nv;
    for (int i = 1; i <= RINGS; i++) {
        double t = PI * i / (RINGS + 1);
        for (int j = 0; j < AROUND; j++) {
            double a = 2 * PI * j / AROUND;
            vertex(s, c[0] + r * sin(t) * cos(a), c[1] + r * sin(t) * sin(a),
                   c[2] - r * cos(t));
        }
    }
    uint32_t north = vertex(s, c[0], c[1], c[2] + r);
    for (uint32_t j = 0; j < AROUND; j++) {
        uint32_t k = (j + 1) % AROUND;
        triangle(s, south, first + k, first + j);
        uint32_t top = first + (RINGS - 1) * AROUND;
        triangle(s, north, top + j, top + k);
        for (uint32_t i = 0; i + 1 < RINGS; i++) {
            uint32_t a = first + i * AROUND;
            triangle(s, a + j, a + k, a + AROUND + k);
            triangle(s, a + j, a + AROUND + k, a + AROUND + j);
        }
    }
}

static phks_mesh *make(bool spheres, size_t count)
{
    size_t side = 1;
    while (side * side * side < count)
        side++;
    size_t per = spheres ? 2 + AROUND * RINGS : 3;
    size_t faces = spheres ? 2 * AROUND * RINGS : 1;
    soup s = {malloc(count * per * 3 * sizeof(double)),
              malloc(count * faces * 3 * sizeof(uint32_t)), 0, 0};
    if (!s.xyz || !s.tri)
        return NULL;
    uint64_t rng = 1;
    for (size_t p = 0; p < count; p++) {
        double c[3] = {(double)(p % side), (double)(p / side % side),
                       (double)(p / side / side)};
        if (spheres)
            add_sphere(&s, c, 1, &rng);
        else
            add_triangle(&s, c, 1, &rng);
    }
    phks_mesh *mesh = NULL;
    phks_status st = phks_mesh_create(s.xyz, s.nv, s.tri, s.nt, &mesh);
    free(s.xyz);
    free(s.tri);
    return st == PHKS_OK ? mesh : NULL;
}

static int compare(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int run_case(const char *spec, int solver, int runs)
{
    char kind[16];
    size_t count;
    unsigned k;
    double tau = 0.0002;
    if (sscanf(spec, "%15[a-z]:%zu:%u:%lf", kind, &count, &k, &tau) < 3 ||
        (strcmp(kind, "triangles") && strcmp(kind, "spheres"))) {
        fprintf(stderr, "bench-null: bad case %s\n", spec);
        return 1;
    }
    phks_mesh *mesh = make(!strcmp(kind, "spheres"), count);
    if (!mesh) {
        fprintf(stderr, "bench-null: %s: %s\n", spec, phks_last_error_message());
        return 1;
    }
    phks_options opt;
    phks_options_init(&opt);
    opt.solver = solver;
    opt.eigen_count = k;
    opt.tau = tau;
    /* the lattice's principal frame is arbitrary, and along a diagonal
     * its spacing would fall below the cut-off */
    opt.box = PHKS_BOX_AXIS_ALIGNED;
    double *times = malloc((size_t)runs * sizeof *times);
    size_t pairs = 0, zeros = 0;
    double sum = 0;
    for (int r = 0; r < runs && times; r++) {
        phks_spectrum *sp = NULL;
        double t0 = now();
        phks_status st = phks_spectrum_compute(mesh, &opt, &sp);
        times[r] = now() - t0;
        if (st != PHKS_OK) {
            fprintf(stderr, "bench-null: %s: %s\n", spec, phks_last_error_message());
            free(times);
            phks_mesh_free(mesh);
            return 1;
        }
        const double *v = phks_spectrum_eigenvalues(sp);
        pairs = phks_spectrum_count(sp);
        zeros = 0;
        sum = 0;
        for (size_t i = 0; i < pairs; i++) {
            zeros += fabs(v[i]) <= 1e-8 * 2 / tau;
            sum += fabs(v[i]) <= 1e-8 * 2 / tau ? 0 : v[i];
        }
        phks_spectrum_free(sp);
    }
    bool ok = times != NULL;
    if (ok) {
        qsort(times, (size_t)runs, sizeof *times, compare);
        printf("%-24s %6zu vertices  %5zu pairs  %5zu zeros  sum %.12e  "
               "median %.3f s  (min %.3f, max %.3f, %d runs)\n",
               spec, phks_mesh_vertex_count(mesh), pairs, zeros, sum,
               times[runs / 2], times[0], times[runs - 1], runs);
        fflush(stdout);
    }
    free(times);
    phks_mesh_free(mesh);
    return ok ? 0 : 1;
}

int main(int argc, char **argv)
{
    int runs = 3, solver = PHKS_SOLVER_AUTO, status = 0;
    static const char *const names[] = {"auto", "lanczos", "arpack", "dense"};
    static const int solvers[] = {PHKS_SOLVER_AUTO, PHKS_SOLVER_LANCZOS,
                                  PHKS_SOLVER_ARPACK, PHKS_SOLVER_DENSE};
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc) {
            runs = atoi(argv[++i]);
            if (runs < 1)
                runs = 1;
        } else if (!strcmp(argv[i], "--solver") && i + 1 < argc) {
            const char *name = argv[++i];
            for (int s = 0; s < 4; s++)
                if (!strcmp(name, names[s]))
                    solver = solvers[s];
        } else {
            status |= run_case(argv[i], solver, runs);
        }
    }
    return status;
}
