/*
 * match.c - score two mesh files and list their feature correspondences.
 * Public API only.
 *
 *   phks-match A B
 */
#include "phks.h"

#include <stdio.h>
#include <stdlib.h>

static phks_signature *signature_of(const char *path)
{
    phks_mesh *mesh;
    phks_signature *sig = NULL;
    phks_status st = phks_mesh_load(path, &mesh);
    if (st == PHKS_OK) {
        st = phks_signature_compute(mesh, NULL, &sig);
        phks_mesh_free(mesh);
    }
    if (st != PHKS_OK)
        fprintf(stderr, "phks-match: %s: %s\n", phks_status_string(st),
                phks_last_error_message());
    return sig;
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: phks-match A B\n");
        return 2;
    }
    phks_signature *a = signature_of(argv[1]), *b = a ? signature_of(argv[2]) : NULL;
    if (!a || !b) {
        phks_signature_free(a);
        return 1;
    }
    size_t count;
    double score;
    phks_match(a, b, NULL, 0, &count, &score);
    phks_correspondence *c = malloc(count * sizeof *c);
    if (!c || phks_match(a, b, c, count, &count, &score) != PHKS_OK) {
        fprintf(stderr, "phks-match: %s\n", phks_last_error_message());
        return 1;
    }
    printf("score %.6g\n", score);
    printf("%-6s %-6s %12s  %-30s %-30s\n", "a", "b", "L1", "position in A",
           "position in B");
    for (size_t i = 0; i < count; i++) {
        double pa[3], pb[3];
        phks_signature_feature_position(a, c[i].feature_a, pa);
        phks_signature_feature_position(b, c[i].feature_b, pb);
        printf("%-6u %-6u %12.6g  (%8.4f %8.4f %8.4f)  (%8.4f %8.4f %8.4f)%s\n",
               c[i].feature_a, c[i].feature_b, c[i].distance, pa[0], pa[1],
               pa[2], pb[0], pb[1], pb[2], c[i].from_a ? "" : "  <- from B");
    }
    free(c);
    phks_signature_free(a);
    phks_signature_free(b);
    return 0;
}
