/*
 * compare.c - the smallest useful libphks program: the signatures of two
 * mesh files and their score.
 *
 *   compare A.off B.ply
 *
 * prints, for example,
 *
 *   A.off: 266 vertices, 12 features
 *   B.ply: 1020 vertices, 15 features
 *   score: 3.14159
 *
 * Lower scores mean more similar shapes; 0 means identical signatures.
 * Files may be OFF, OBJ, PLY or STL, each optionally gzip-compressed.
 *
 * Build against an installed libphks:
 *   cc compare.c $(pkg-config --cflags --libs phks) -o compare
 */
#include <phks.h>

#include <stdio.h>

/* Prints what failed and why, and returns the exit status for a failure.
 * phks_last_error_message() has the detail (file, line, what was wrong). */
static int fail(const char *what, phks_status status)
{
    fprintf(stderr, "compare: %s: %s (%s)\n", what,
            phks_status_string(status), phks_last_error_message());
    return 1;
}

/* Loads the mesh in path and computes its signature with the default
 * options (options NULL). On success the caller frees *signature. */
static int signature_of(const char *path, phks_signature **signature)
{
    phks_mesh *mesh = NULL;
    phks_status status = phks_mesh_load(path, &mesh);
    if (status != PHKS_OK)
        return fail(path, status);

    status = phks_signature_compute(mesh, NULL, signature);
    size_t vertices = phks_mesh_vertex_count(mesh);
    phks_mesh_free(mesh); /* the signature does not need the mesh */
    if (status != PHKS_OK)
        return fail(path, status);

    printf("%s: %zu vertices, %zu features\n", path, vertices,
           phks_signature_feature_count(*signature));
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: compare MESH_A MESH_B\n");
        return 2;
    }

    phks_signature *a = NULL, *b = NULL;
    int rc = signature_of(argv[1], &a);
    if (rc == 0)
        rc = signature_of(argv[2], &b);

    if (rc == 0) {
        double score;
        phks_status status = phks_score(a, b, &score);
        if (status == PHKS_OK)
            printf("score: %g\n", score);
        else
            rc = fail("score", status);
    }

    /* phks_signature_free(NULL) does nothing, so this is safe on any path. */
    phks_signature_free(a);
    phks_signature_free(b);
    return rc;
}
