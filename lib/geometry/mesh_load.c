/*
 * mesh_load.c - phks_mesh_load and phks_mesh_load_memory(_limited): the
 * reader layer (io/) turns the bytes into arrays, mesh.c cleans them into
 * a mesh.
 */
#include "geometry/geometry.h"

static phks_status build(phks_status st, phks__raw_mesh *raw, phks_mesh **mesh)
{
    if (st == PHKS_OK)
        st = phks__mesh_build(raw->xyz, raw->vertex_count, raw->triangles,
                             raw->triangle_count, raw->vertex_origin, mesh);
    phks__raw_mesh_release(raw);
    return st;
}

phks_status phks_mesh_load(const char *path, phks_mesh **mesh)
{
    if (mesh)
        *mesh = NULL;
    if (!path || !mesh)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_mesh_load: NULL argument");
    phks__raw_mesh raw = {0};
    phks_status st = build(phks__raw_mesh_read_file(path, &raw), &raw, mesh);
    if (st != PHKS_OK)
        phks__error_prefix(path);
    return st;
}

phks_status phks_mesh_load_memory(const void *data, size_t size,
                                  phks_format format, phks_mesh **mesh)
{
    return phks_mesh_load_memory_limited(data, size, format, 0, 0, mesh);
}

/* The vertex limit is checked on the reader's arrays, before cleaning:
 * their size is bounded by the bytes, and cleaning (welding, edges) is the
 * first step whose memory grows faster. */
phks_status phks_mesh_load_memory_limited(const void *data, size_t size,
                                          phks_format format, size_t max_bytes,
                                          size_t max_vertices, phks_mesh **mesh)
{
    if (mesh)
        *mesh = NULL;
    if (!data || !mesh)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_mesh_load_memory: NULL argument");
    if (format < PHKS_FORMAT_AUTO || format > PHKS_FORMAT_STL)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_mesh_load_memory: unknown format %d",
                         (int)format);
    phks__raw_mesh raw = {0};
    phks_status st = phks__raw_mesh_read_memory(
        data, size, format, max_bytes ? max_bytes : SIZE_MAX, &raw);
    if (st == PHKS_OK && max_vertices && raw.vertex_count > max_vertices)
        st = phks__fail(PHKS_ERROR_TOO_LARGE,
                        "the mesh has %zu vertices, more than the limit of %zu",
                        raw.vertex_count, max_vertices);
    return build(st, &raw, mesh);
}
