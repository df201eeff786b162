/*
 * bench_quadrature.c - what PHKS_QUADRATURE_TRIANGLES costs (docs/method.md
 * section 13, docs/benchmarks.md): for each mesh, its vertices, its long
 * triangles (longest edge above sqrt(4 tau) in the unit box), the
 * quadrature points, and the wall time of a signature (default options)
 * with the vertices' quadrature and with the triangles', the best of
 * --repeat runs each, alternating: processor time (all threads; on a
 * shared machine it varies far less than wall time) and wall time.
 *
 *   bench-quadrature [--repeat R (3)] [--threads T (0)] MESH...
 */
#include "features/features.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static double cpu(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* Processor seconds of one signature; its wall seconds into *wall. */
static double signature_time(const phks_mesh *mesh, const phks_options *opt,
                             size_t *features, double *wall)
{
    phks_signature *sig = NULL;
    double t0 = cpu(), w0 = now();
    phks_status st = phks_signature_compute(mesh, opt, &sig);
    double t = cpu() - t0;
    *wall = now() - w0;
    if (st != PHKS_OK) {
        fprintf(stderr, "signature: %s\n", phks_last_error_message());
        exit(1);
    }
    *features = phks_signature_feature_count(sig);
    phks_signature_free(sig);
    return t;
}

int main(int argc, char **argv)
{
    int repeat = 3, first = 1;
    unsigned threads = 0;
    while (first < argc && strncmp(argv[first], "--", 2) == 0) {
        if (strcmp(argv[first], "--repeat") == 0 && first + 1 < argc)
            repeat = atoi(argv[first + 1]);
        else if (strcmp(argv[first], "--threads") == 0 && first + 1 < argc)
            threads = (unsigned)atoi(argv[first + 1]);
        else {
            fprintf(stderr, "usage: bench-quadrature [--repeat R] "
                            "[--threads T] MESH...\n");
            return 2;
        }
        first += 2;
    }
    printf("mesh\tvertices\ttriangles\tlong\tpoints\tcpu_vertices_s\t"
           "cpu_triangles_s\tratio\twall_vertices_s\twall_triangles_s\t"
           "features_v\tfeatures_t\n");
    for (int a = first; a < argc; a++) {
        phks_mesh *mesh = NULL;
        if (phks_mesh_load(argv[a], &mesh) != PHKS_OK) {
            fprintf(stderr, "%s: %s\n", argv[a], phks_last_error_message());
            return 1;
        }
        phks_options opt;
        phks_options_init(&opt);
        opt.threads = threads;
        phks__unit_mesh um;
        phks__quadrature q;
        size_t longest = 0;
        if (phks__unit_mesh_for(mesh, &opt, PHKS__SPAN_NONE, &um) != PHKS_OK ||
            phks__quadrature_build(&um, &opt, &q) != PHKS_OK) {
            fprintf(stderr, "%s: %s\n", argv[a], phks_last_error_message());
            return 1;
        }
        double w = sqrt(4 * opt.tau);
        for (size_t t = 0; t < mesh->triangle_count; t++) {
            const uint32_t *c = mesh->triangles + 3 * t;
            double l = 0;
            for (int k = 0; k < 3; k++) {
                const double *x = mesh->xyz + 3 * (size_t)c[k],
                             *y = mesh->xyz + 3 * (size_t)c[(k + 1) % 3];
                l = fmax(l, um.scale * sqrt((x[0] - y[0]) * (x[0] - y[0]) +
                                            (x[1] - y[1]) * (x[1] - y[1]) +
                                            (x[2] - y[2]) * (x[2] - y[2])));
            }
            longest += l > w;
        }
        size_t points = q.count;
        phks__quadrature_release(&q);
        phks__unit_mesh_release(&um);
        double best[2] = {INFINITY, INFINITY}, wall[2] = {INFINITY, INFINITY};
        size_t features[2] = {0, 0};
        for (int r = 0; r < repeat; r++)
            for (int k = 0; k < 2; k++) {
                opt.quadrature = k ? PHKS_QUADRATURE_TRIANGLES
                                   : PHKS_QUADRATURE_VERTICES;
                double seconds;
                best[k] = fmin(best[k], signature_time(mesh, &opt, &features[k],
                                                       &seconds));
                wall[k] = fmin(wall[k], seconds);
            }
        const char *name = strrchr(argv[a], '/');
        printf("%s\t%zu\t%zu\t%zu\t%zu\t%.3f\t%.3f\t%.2f\t%.3f\t%.3f\t%zu\t%zu\n",
               name ? name + 1 : argv[a], mesh->vertex_count,
               mesh->triangle_count, longest, points, best[0], best[1],
               best[1] / best[0], wall[0], wall[1], features[0], features[1]);
        fflush(stdout);
        phks_mesh_free(mesh);
    }
    return 0;
}
