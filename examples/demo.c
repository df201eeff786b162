/*
 * demo.c - the main job on built-in data: generated creatures of several
 * kinds, each in two poses, to signatures and a score matrix. Needs no
 * files. Public API only.
 *
 *   phks-demo [--resolution R]
 */
#include "phks.h"
#include "shapes.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define POSES 2

static int fail(const char *what, phks_status st)
{
    fprintf(stderr, "phks-demo: %s: %s (%s)\n", what, phks_status_string(st),
            phks_last_error_message());
    return 1;
}

static phks_status signature_of(unsigned kind, unsigned pose, unsigned res,
                                phks_signature **sig)
{
    double angles[SHAPE_MAX_JOINTS];
    shape_mesh shape;
    shape_creature_pose(kind, pose, angles);
    if (shape_creature(kind, angles, res, &shape) != 0)
        return PHKS_ERROR_OUT_OF_MEMORY;
    phks_mesh *mesh;
    phks_status st = phks_mesh_create(shape.xyz, shape.vertex_count,
                                      shape.triangles, shape.triangle_count,
                                      &mesh);
    shape_mesh_free(&shape);
    if (st != PHKS_OK)
        return st;
    st = phks_signature_compute(mesh, NULL, sig);
    phks_mesh_free(mesh);
    return st;
}

int main(int argc, char **argv)
{
    unsigned res = SHAPE_DEFAULT_RESOLUTION;
    if (argc == 3 && strcmp(argv[1], "--resolution") == 0)
        res = (unsigned)atoi(argv[2]);
    else if (argc != 1) {
        fprintf(stderr, "usage: phks-demo [--resolution R]\n");
        return 2;
    }
    enum { N = SHAPE_KIND_COUNT * POSES };
    phks_signature *sig[N] = {0};
    printf("libphks %s demo: %d generated shapes (%d kinds x %d poses)\n",
           phks_version_string(), N, SHAPE_KIND_COUNT, POSES);
    for (unsigned i = 0; i < N; i++) {
        unsigned kind = i / POSES, pose = 1 + i % POSES;
        phks_status st = signature_of(kind, pose, res, &sig[i]);
        if (st != PHKS_OK)
            return fail(shape_creature_name(kind), st);
        printf("  %-10s pose %u: %zu vertices, %zu features\n",
               shape_creature_name(kind), pose,
               shape_creature_vertex_count(kind, res),
               phks_signature_feature_count(sig[i]));
    }

    printf("\nscore matrix (lower = more similar)\n%14s", "");
    for (unsigned j = 0; j < N; j++)
        printf(" %7.7s%u", shape_creature_name(j / POSES), 1 + j % POSES);
    printf("\n");
    unsigned hits = 0;
    for (unsigned i = 0; i < N; i++) {
        printf("%12.12s%u ", shape_creature_name(i / POSES), 1 + i % POSES);
        unsigned best = i;
        double best_score = 0;
        for (unsigned j = 0; j < N; j++) {
            double s;
            phks_status st = phks_score(sig[i], sig[j], &s);
            if (st != PHKS_OK)
                return fail("score", st);
            printf(" %8.1f", s);
            if (j != i && (best == i || s < best_score)) {
                best = j;
                best_score = s;
            }
        }
        hits += best / POSES == i / POSES;
        printf("\n");
    }
    printf("\nnearest other shape is the same kind in another pose: %u of %d\n",
           hits, N);
    for (unsigned i = 0; i < N; i++)
        phks_signature_free(sig[i]);
    return 0;
}
