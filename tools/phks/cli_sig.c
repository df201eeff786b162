/*
 * cli_sig.c - `phks signature` (one mesh to a summary and a .sig blob) and
 * `phks match` (score and correspondences of two meshes or blobs).
 */
#include "cli.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

static void print_features(const phks_signature *sig)
{
    printf("%7s %8s %12s %12s %12s %12s\n", "feature", "vertex", "x", "y", "z",
           "persistence");
    for (size_t i = 0; i < phks_signature_feature_count(sig); i++) {
        double p[3];
        phks_signature_feature_position(sig, i, p);
        printf("%7zu %8u %12.6g %12.6g %12.6g %12.6g\n", i,
               phks_signature_feature_vertex(sig, i), p[0], p[1], p[2],
               phks_signature_feature_persistence(sig, i));
    }
}

static int write_blob(const char *path, const phks_signature *sig)
{
    unsigned char *blob;
    size_t size;
    phks_status st = cli_encode(sig, &blob, &size);
    if (st != PHKS_OK)
        return cli_fail(path, st);
    int rc = cli_write_file_atomic(path, blob, size);
    free(blob);
    if (rc != 0)
        return cli_error(path, strerror(errno));
    printf("wrote %s (%zu bytes)\n", path, size);
    return 0;
}

/* A mesh file gets its counts printed before its signature is computed. */
static phks_signature *summarise(const char *path, const phks_options *o)
{
    if (cli_is_blob(path))
        return cli_signature_of(path, o);
    phks_mesh *mesh;
    phks_signature *sig = NULL;
    phks_status st = phks_mesh_load(path, &mesh);
    if (st == PHKS_OK) {
        printf("%s: %zu vertices, %zu triangles\n", path,
               phks_mesh_vertex_count(mesh), phks_mesh_triangle_count(mesh));
        st = phks_signature_compute(mesh, o, &sig);
        phks_mesh_free(mesh);
    }
    if (st != PHKS_OK)
        cli_fail(path, st);
    return sig;
}

int cli_signature(int argc, char **argv, const phks_options *options)
{
    const char *out = NULL;
    const cli_opt opts[] = {{"-o", &out, NULL}};
    int n;
    if (cli_parse(argc, argv, 1, opts, 1, &n) != 0 || n != 1)
        return cli_usage("signature MESH [-o SIG]");
    phks_signature *sig = summarise(argv[1], options);
    if (!sig)
        return 1;
    printf("signature: %zu features x %zu scales\n",
           phks_signature_feature_count(sig),
           phks_signature_vector_length(sig));
    print_features(sig);
    int rc = out ? write_blob(out, sig) : 0;
    phks_signature_free(sig);
    return rc;
}

static int print_match(const phks_signature *a, const phks_signature *b,
                       const char *what)
{
    size_t count;
    double score;
    phks_status st = phks_match(a, b, NULL, 0, &count, &score);
    phks_correspondence *c = st == PHKS_OK ? malloc(count * sizeof *c) : NULL;
    if (st == PHKS_OK && !c)
        st = PHKS_ERROR_OUT_OF_MEMORY;
    if (st == PHKS_OK)
        st = phks_match(a, b, c, count, &count, &score);
    if (st != PHKS_OK) {
        free(c);
        return cli_fail(what, st);
    }
    printf("score %.6g\n", score);
    printf("%-6s %-6s %12s  %-32s %-32s\n", "a", "b", "L1", "position in A",
           "position in B");
    for (size_t i = 0; i < count; i++) {
        double pa[3], pb[3];
        phks_signature_feature_position(a, c[i].feature_a, pa);
        phks_signature_feature_position(b, c[i].feature_b, pb);
        printf("%-6u %-6u %12.6g  (%9.4g %9.4g %9.4g)  (%9.4g %9.4g %9.4g)%s\n",
               c[i].feature_a, c[i].feature_b, c[i].distance, pa[0], pa[1],
               pa[2], pb[0], pb[1], pb[2], c[i].from_a ? "" : "  <- from B");
    }
    free(c);
    return 0;
}

int cli_match(int argc, char **argv, const phks_options *options)
{
    int n;
    if (cli_parse(argc, argv, 1, NULL, 0, &n) != 0 || n != 2)
        return cli_usage("match A B");
    phks_signature *a = cli_signature_of(argv[1], options);
    phks_signature *b = a ? cli_signature_of(argv[2], options) : NULL;
    int rc = 1;
    char *what = malloc(strlen(argv[1]) + strlen(argv[2]) + 6);
    if (a && b && what) {
        sprintf(what, "%s and %s", argv[1], argv[2]);
        rc = print_match(a, b, what);
    }
    free(what);
    phks_signature_free(a);
    phks_signature_free(b);
    return rc;
}
