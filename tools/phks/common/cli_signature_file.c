/*
 * cli_signature_file.c - signatures of the files the `phks` tool is given:
 * computed from a mesh file (through cli_load_mesh, with --object and the
 * progress of its stages), or decoded from a .sig blob, recognised by its
 * magic "PHKS"; and the blobs it writes.
 */
#include "common/cli_common.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

phks_status cli_encode(const phks_signature *sig, unsigned char **blob,
                       size_t *size)
{
    size_t n = phks_signature_encoded_size(sig);
    *blob = malloc(n ? n : 1);
    if (!*blob)
        return PHKS_ERROR_OUT_OF_MEMORY;
    phks_status st = phks_signature_encode(sig, *blob, n, size);
    if (st != PHKS_OK) {
        free(*blob);
        *blob = NULL;
    }
    return st;
}

int cli_is_blob(const char *path)
{
    unsigned char magic[4] = {0};
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    size_t n = fread(magic, 1, 4, f);
    fclose(f);
    return n == 4 && memcmp(magic, "PHKS", 4) == 0;
}

static phks_signature *decode_file(const char *path)
{
    unsigned char *data;
    size_t size;
    phks_signature *sig = NULL;
    if (cli_read_file(path, &data, &size) != 0) {
        cli_error(path, strerror(errno));
        return NULL;
    }
    phks_status st = phks_signature_decode(data, size, &sig);
    free(data);
    if (st != PHKS_OK)
        cli_fail(path, st);
    return sig;
}

phks_signature *cli_signature_mesh(const char *path,
                                   const phks_options *options,
                                   phks_mesh **mesh, int verbose)
{
    *mesh = NULL;
    if (cli_is_blob(path))
        return decode_file(path);
    phks_signature *sig = NULL;
    if (cli_load_mesh(path, mesh) != 0)
        return NULL;
    if (verbose)
        printf("%s: %zu vertices, %zu triangles\n", path,
               phks_mesh_vertex_count(*mesh), phks_mesh_triangle_count(*mesh));
    phks_options o = *options;
    cli_stages stages;
    cli_stages_attach(&stages, path, &o);
    phks_status st = phks_signature_compute(*mesh, &o, &sig);
    cli_stages_end(&stages);
    if (st != PHKS_OK) {
        cli_fail(path, st);
        phks_mesh_free(*mesh);
        *mesh = NULL;
    }
    return sig;
}

phks_signature *cli_signature_of(const char *path, const phks_options *options)
{
    phks_mesh *mesh;
    phks_signature *sig = cli_signature_mesh(path, options, &mesh, 0);
    phks_mesh_free(mesh);
    return sig;
}

uint32_t cli_file_vertex(const phks_mesh *mesh, uint32_t v)
{
    const uint32_t *origin = phks_mesh_vertex_origin(mesh);
    return origin && v < phks_mesh_vertex_count(mesh) ? origin[v] : v;
}
