/*
 * demo.c - the main job on built-in data, no files needed: generated
 * creatures of five kinds in several poses go into a shape database, each
 * pose as one version (complete, a partial scan or an incomplete model, made
 * by the generator of partial.h and randomly rotated); then another pose of
 * each kind, in all three versions, queries the database. Prints each
 * query's best matches and the hit table. Public API only.
 *
 *   phks-demo [--resolution R] [--db PATH]
 *
 * PATH defaults to ":memory:"; with a file, the database stays for
 * `phks db list` and `phks db query`.
 */
#include "partial.h"
#include "phks.h"
#include "shapes.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DB_POSES 3      /* poses 1..3 go into the database             */
#define QUERY_POSE 4    /* another pose queries it                      */
#define VERSIONS 3
#define TOP 5

static const char *const version_name[VERSIONS] = {"complete", "partial",
                                                   "incomplete"};

static int fail(const char *what, phks_status st)
{
    fprintf(stderr, "phks-demo: %s: %s (%s)\n", what, phks_status_string(st),
            phks_last_error_message());
    return 1;
}

/* The creature `kind` in pose `pose` as version `version`, rotated. */
static phks_status make_mesh(unsigned kind, unsigned pose, unsigned version,
                             unsigned res, phks_mesh **mesh)
{
    double angles[SHAPE_MAX_JOINTS], rotation[9];
    shape_mesh shape;
    shape_creature_pose(kind, pose, angles);
    if (shape_creature(kind, angles, res, &shape) != 0)
        return PHKS_ERROR_OUT_OF_MEMORY;
    uint64_t seed = 1000u * kind + 10u * pose + version;
    shape_random_rotation(seed, rotation);
    shape_transform(&shape, rotation, 1, NULL);
    piece p = {0};
    int cut = 0;
    if (version == 1)
        cut = piece_partial_scan(shape.xyz, shape.vertex_count, shape.triangles,
                                 shape.triangle_count, seed, &p);
    else if (version == 2)
        cut = piece_incomplete(shape.xyz, shape.vertex_count, shape.triangles,
                               shape.triangle_count, seed, &p);
    phks_status st;
    if (cut != 0)
        st = PHKS_ERROR_NO_TRIANGLES;
    else if (version == 0)
        st = phks_mesh_create(shape.xyz, shape.vertex_count, shape.triangles,
                              shape.triangle_count, mesh);
    else
        st = phks_mesh_create(p.xyz, p.vertex_count, p.triangles,
                              p.triangle_count, mesh);
    piece_free(&p);
    shape_mesh_free(&shape);
    return st;
}

static phks_status signature_of(unsigned kind, unsigned pose, unsigned version,
                                unsigned res, phks_signature **sig)
{
    phks_mesh *mesh;
    phks_status st = make_mesh(kind, pose, version, res, &mesh);
    if (st == PHKS_OK)
        st = phks_signature_compute(mesh, NULL, sig);
    phks_mesh_free(mesh);
    return st;
}

static int fill_database(phks_db *db, unsigned res)
{
    printf("database:");
    for (unsigned kind = 0; kind < SHAPE_KIND_COUNT; kind++)
        for (unsigned pose = 1; pose <= DB_POSES; pose++) {
            unsigned version = (pose - 1) % VERSIONS;
            char name[64];
            snprintf(name, sizeof name, "%s-pose%u-%s",
                     shape_creature_name(kind), pose, version_name[version]);
            phks_signature *sig;
            phks_status st = signature_of(kind, pose, version, res, &sig);
            if (st == PHKS_OK)
                st = phks_db_add(db, name, shape_creature_name(kind), sig, NULL);
            phks_signature_free(sig);
            if (st != PHKS_OK)
                return fail(name, st);
            printf(" %s", name);
            fflush(stdout);
        }
    printf("\n\n");
    return 0;
}

/* Rank (1-based) of the first hit of the query's kind, 0 if none. */
static int run_query(phks_db *db, unsigned kind, unsigned version, unsigned res,
                     int *rank)
{
    phks_signature *sig;
    phks_status st = signature_of(kind, QUERY_POSE, version, res, &sig);
    phks_hit hits[TOP];
    size_t n = 0;
    if (st == PHKS_OK)
        st = phks_db_query(db, sig, TOP, hits, &n);
    phks_signature_free(sig);
    if (st != PHKS_OK)
        return fail("query", st);
    *rank = 0;
    printf("  %-10s %-10s ->", shape_creature_name(kind), version_name[version]);
    for (size_t i = 0; i < n; i++) {
        if (*rank == 0 && strcmp(hits[i].label, shape_creature_name(kind)) == 0)
            *rank = (int)i + 1;
        if (i < 3)
            printf(" %s (%.3g)", hits[i].name, hits[i].score);
    }
    printf("\n");
    return 0;
}

int main(int argc, char **argv)
{
    unsigned res = SHAPE_DEFAULT_RESOLUTION;
    const char *path = ":memory:";
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--resolution") == 0 && i + 1 < argc)
            res = (unsigned)atoi(argv[++i]);
        else if (strcmp(argv[i], "--db") == 0 && i + 1 < argc)
            path = argv[++i];
        else {
            fprintf(stderr, "usage: phks-demo [--resolution R] [--db PATH]\n");
            return 2;
        }
    }
    printf("libphks %s demo: %d creature kinds; poses 1-%d in the database "
           "(complete, partial scan, incomplete), pose %d queries\n\n",
           phks_version_string(), SHAPE_KIND_COUNT, DB_POSES, QUERY_POSE);
    phks_db *db;
    phks_status st = phks_db_open(path, PHKS_DB_CREATE, &db);
    if (st != PHKS_OK)
        return fail(path, st);
    int hits[VERSIONS][TOP + 1] = {{0}};
    int status = fill_database(db, res);
    if (status == 0)
        printf("queries (best three matches, score):\n");
    for (unsigned kind = 0; status == 0 && kind < SHAPE_KIND_COUNT; kind++)
        for (unsigned version = 0; status == 0 && version < VERSIONS; version++) {
            int rank;
            status = run_query(db, kind, version, res, &rank);
            hits[version][rank]++;
        }
    phks_db_close(db);
    if (status != 0)
        return status;

    printf("\n| queries | n | Top-1 | Top-3 | Top-5 |\n|---|---|---|---|---|\n");
    for (unsigned v = 0; v < VERSIONS; v++) {
        int top[TOP + 1] = {0};
        for (int r = 1; r <= TOP; r++)
            top[r] = top[r - 1] + hits[v][r];
        printf("| %s | %d | %d | %d | %d |\n", version_name[v],
               SHAPE_KIND_COUNT, top[1], top[3], top[5]);
    }
    return 0;
}
