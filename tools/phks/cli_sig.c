/*
 * cli_sig.c - `phks signature` (one mesh to a summary and a .sig blob) and
 * `phks match` (score and correspondences of two meshes or blobs). Vertex
 * ids are the input file's (phks_mesh_vertex_origin); a blob has no file
 * numbering, so its ids are the cleaned mesh's.
 */
#include "cli.h"
#include "common/cli_common.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

static const char signature_usage[] =
    "signature MESH|SIG [-o SIG] [--json]\n"
    "  -o SIG    write the encoded signature blob to SIG (none)\n"
    "  --json    print the signature as JSON (text)\n"
    "  global options: see `phks --help`";

static const char match_usage[] =
    "match A B [--json]   (A and B: meshes or .sig blobs)\n"
    "  --json    print the score and correspondences as JSON (text)\n"
    "  global options: see `phks --help`";

static void print_features(const phks_signature *sig, const phks_mesh *mesh)
{
    printf("%7s %8s %12s %12s %12s %12s\n", "feature", "vertex", "x", "y", "z",
           "persistence");
    for (size_t i = 0; i < phks_signature_feature_count(sig); i++) {
        double p[3];
        phks_signature_feature_position(sig, i, p);
        printf("%7zu %8u %12.6g %12.6g %12.6g %12.6g\n", i,
               cli_file_vertex(mesh, phks_signature_feature_vertex(sig, i)),
               p[0], p[1], p[2], phks_signature_feature_persistence(sig, i));
    }
}

static void json_features(const phks_signature *sig, const phks_mesh *mesh)
{
    size_t len = phks_signature_vector_length(sig);
    fputs("[", stdout);
    for (size_t i = 0; i < phks_signature_feature_count(sig); i++) {
        double p[3];
        phks_signature_feature_position(sig, i, p);
        printf("%s\n    {\"index\": %zu, \"vertex\": %u, \"position\": ",
               i ? "," : "", i,
               cli_file_vertex(mesh, phks_signature_feature_vertex(sig, i)));
        cli_json_vec(p, 3);
        fputs(", \"persistence\": ", stdout);
        cli_json_number(phks_signature_feature_persistence(sig, i));
        fputs(", \"vector\": ", stdout);
        cli_json_vec(phks_signature_feature_vector(sig, i), len);
        fputs("}", stdout);
    }
    fputs("\n  ]", stdout);
}

static void json_signature(const char *path, const phks_signature *sig,
                           const phks_mesh *mesh, const char *out,
                           size_t bytes)
{
    phks_options o;
    phks_signature_options(sig, &o);
    fputs("{\"file\": ", stdout);
    cli_json_string(path);
    printf(", \"source\": \"%s\", \"vertex_ids\": \"%s\"",
           mesh ? "mesh" : "signature", mesh ? "file" : "cleaned");
    if (mesh)
        printf(", \"vertices\": %zu, \"triangles\": %zu",
               phks_mesh_vertex_count(mesh), phks_mesh_triangle_count(mesh));
    printf(",\n  \"feature_count\": %zu, \"vector_length\": %zu,\n"
           "  \"options\": ", phks_signature_feature_count(sig),
           phks_signature_vector_length(sig));
    cli_json_options(&o);
    fputs(",\n  \"output\": ", stdout);
    if (out) {
        cli_json_string(out);
        printf(", \"output_bytes\": %zu", bytes);
    } else
        fputs("null", stdout);
    fputs(",\n  \"features\": ", stdout);
    json_features(sig, mesh);
    fputs("\n}\n", stdout);
}

static int write_blob(const char *path, const phks_signature *sig,
                      size_t *size)
{
    unsigned char *blob;
    phks_status st = cli_encode(sig, &blob, size);
    if (st != PHKS_OK)
        return cli_fail(path, st);
    int rc = cli_write_file_atomic(path, blob, *size);
    free(blob);
    if (rc != 0)
        return cli_error(path, strerror(errno));
    return 0;
}

int cli_signature(int argc, char **argv, const phks_options *options)
{
    const char *out = NULL;
    int json = 0, n;
    const cli_opt opts[] = {{"-o", &out, NULL}, {"--json", NULL, &json}};
    if (cli_help(argc, argv, signature_usage))
        return 0;
    if (cli_parse(argc, argv, 1, opts, 2, &n) != 0 || n != 1)
        return cli_usage(signature_usage);
    phks_mesh *mesh;
    phks_signature *sig = cli_signature_mesh(argv[1], options, &mesh, !json);
    if (!sig)
        return 1;
    size_t bytes = 0;
    int rc = out ? write_blob(out, sig, &bytes) : 0;
    if (rc == 0 && json)
        json_signature(argv[1], sig, mesh, out, bytes);
    else if (rc == 0) {
        printf("signature: %zu features x %zu scales%s\n",
               phks_signature_feature_count(sig),
               phks_signature_vector_length(sig),
               mesh ? "" : " (vertex ids of the cleaned mesh)");
        print_features(sig, mesh);
        if (out)
            printf("wrote %s (%zu bytes)\n", out, bytes);
    }
    phks_signature_free(sig);
    phks_mesh_free(mesh);
    return rc;
}

typedef struct side {
    const char *path;
    phks_signature *sig;
    phks_mesh *mesh;
} side;

/* The score and what a reader weighs it by (phks_similarity). */
typedef struct verdict {
    double score, similarity;
    size_t verified, features; /* of A's features, the verified */
} verdict;

static void json_match(const side *a, const side *b,
                       const phks_correspondence *c, size_t count,
                       const verdict *v)
{
    fputs("{\"a\": ", stdout);
    cli_json_string(a->path);
    fputs(", \"b\": ", stdout);
    cli_json_string(b->path);
    printf(", \"vertex_ids_a\": \"%s\", \"vertex_ids_b\": \"%s\",\n"
           "  \"score\": ", a->mesh ? "file" : "cleaned",
           b->mesh ? "file" : "cleaned");
    cli_json_number(v->score);
    fputs(", \"similarity\": ", stdout);
    cli_json_number(v->similarity);
    printf(", \"verified\": %zu, \"features\": %zu", v->verified,
           v->features);
    fputs(",\n  \"correspondences\": [", stdout);
    for (size_t i = 0; i < count; i++) {
        double pa[3], pb[3];
        phks_signature_feature_position(a->sig, c[i].feature_a, pa);
        phks_signature_feature_position(b->sig, c[i].feature_b, pb);
        printf("%s\n    {\"feature_a\": %u, \"feature_b\": %u, "
               "\"vertex_a\": %u, \"vertex_b\": %u, \"position_a\": ",
               i ? "," : "", c[i].feature_a, c[i].feature_b,
               cli_file_vertex(a->mesh, phks_signature_feature_vertex(
                                            a->sig, c[i].feature_a)),
               cli_file_vertex(b->mesh, phks_signature_feature_vertex(
                                            b->sig, c[i].feature_b)));
        cli_json_vec(pa, 3);
        fputs(", \"position_b\": ", stdout);
        cli_json_vec(pb, 3);
        fputs(", \"distance\": ", stdout);
        cli_json_number(c[i].distance);
        printf(", \"direction\": \"%s\", \"verified\": %s}",
               c[i].from_a ? "a_to_b" : "b_to_a",
               c[i].verified ? "true" : "false");
    }
    fputs("\n  ]\n}\n", stdout);
}

static void text_match(const side *a, const side *b,
                       const phks_correspondence *c, size_t count,
                       const verdict *v)
{
    printf("score %.6g  similarity %.3f  verified %zu of %zu\n", v->score,
           v->similarity, v->verified, v->features);
    printf("%-6s %-6s %8s %8s %12s  %-32s %-32s\n", "a", "b", "vertex A",
           "vertex B", "L1", "position in A", "position in B");
    /* "verified": the pair is one of the set the score verified. */
    for (size_t i = 0; i < count; i++) {
        double pa[3], pb[3];
        phks_signature_feature_position(a->sig, c[i].feature_a, pa);
        phks_signature_feature_position(b->sig, c[i].feature_b, pb);
        printf("%-6u %-6u %8u %8u %12.6g  (%9.4g %9.4g %9.4g)  "
               "(%9.4g %9.4g %9.4g)%s\n", c[i].feature_a, c[i].feature_b,
               cli_file_vertex(a->mesh, phks_signature_feature_vertex(
                                            a->sig, c[i].feature_a)),
               cli_file_vertex(b->mesh, phks_signature_feature_vertex(
                                            b->sig, c[i].feature_b)),
               c[i].distance, pa[0], pa[1], pa[2], pb[0], pb[1], pb[2],
               c[i].from_a ? (c[i].verified ? "  verified" : "")
                           : (c[i].verified ? "  <- from B, verified"
                                            : "  <- from B"));
    }
}

/* The library names the option that differs in C ("quadrature triangles
 * against vertices" of its fields); the tool's users know "--quadrature". */
static int incompatible(const side *a, const side *b, const char *what,
                        phks_status st)
{
    phks_options oa, ob;
    char detail[256];
    phks_signature_options(a->sig, &oa);
    phks_signature_options(b->sig, &ob);
    if (!cli_options_differ(&oa, &ob, detail, sizeof detail))
        return cli_fail(what, st);
    fprintf(stderr, "phks: %s: made with different options: %s\n", what,
            detail);
    return 1;
}

static int print_match(const side *a, const side *b, const char *what,
                       int json)
{
    size_t count;
    verdict v = {0, 0, 0, phks_signature_feature_count(a->sig)};
    phks_status st = phks_match(a->sig, b->sig, NULL, 0, &count, &v.score);
    phks_correspondence *c = st == PHKS_OK ? malloc(count * sizeof *c) : NULL;
    if (st == PHKS_OK && !c)
        st = PHKS_ERROR_OUT_OF_MEMORY;
    if (st == PHKS_OK)
        st = phks_match(a->sig, b->sig, c, count, &count, &v.score);
    if (st == PHKS_OK)
        st = phks_similarity(a->sig, b->sig, &v.similarity, &v.verified);
    if (st != PHKS_OK) {
        free(c);
        return st == PHKS_ERROR_INCOMPATIBLE ? incompatible(a, b, what, st)
                                             : cli_fail(what, st);
    }
    if (json)
        json_match(a, b, c, count, &v);
    else
        text_match(a, b, c, count, &v);
    free(c);
    return 0;
}

int cli_match(int argc, char **argv, const phks_options *options)
{
    int json = 0, n;
    const cli_opt opts[] = {{"--json", NULL, &json}};
    if (cli_help(argc, argv, match_usage))
        return 0;
    if (cli_parse(argc, argv, 1, opts, 1, &n) != 0 || n != 2)
        return cli_usage(match_usage);
    side a = {argv[1], NULL, NULL}, b = {argv[2], NULL, NULL};
    a.sig = cli_signature_mesh(a.path, options, &a.mesh, 0);
    b.sig = a.sig ? cli_signature_mesh(b.path, options, &b.mesh, 0) : NULL;
    int rc = 1;
    char *what = malloc(strlen(argv[1]) + strlen(argv[2]) + 6);
    if (a.sig && b.sig && what) {
        sprintf(what, "%s and %s", argv[1], argv[2]);
        rc = print_match(&a, &b, what, json);
    }
    free(what);
    phks_signature_free(a.sig);
    phks_signature_free(b.sig);
    phks_mesh_free(a.mesh);
    phks_mesh_free(b.mesh);
    return rc;
}
