/*
 * io.h - the reader layer: mesh files (OFF, OBJ, PLY, STL, each optionally
 * gzipped) to plain arrays. It knows nothing of the cleaned mesh that the
 * geometry layer builds from them.
 */
#ifndef PHKS_IO_H
#define PHKS_IO_H

#include "core/core.h"

/* ---- readers (read_*.c): parse a whole in-memory file into arrays.
 * On success *xyz and *tri are library allocations owned by the caller.
 * Errors carry a message with a line number (text) or byte offset
 * (binary), without the file name (the loader adds it). */
typedef struct phks__raw_mesh {
    double *xyz;
    size_t vertex_count;
    uint32_t *triangles;
    size_t triangle_count;
    uint32_t *vertex_origin; /* NULL for identity; set by welding readers */
} phks__raw_mesh;

void phks__raw_mesh_release(phks__raw_mesh *raw);
phks_status phks__read_off(const char *data, size_t size, phks__raw_mesh *raw);
phks_status phks__read_obj(const char *data, size_t size, phks__raw_mesh *raw);
phks_status phks__read_ply(const char *data, size_t size, phks__raw_mesh *raw);
phks_status phks__read_stl(const char *data, size_t size, phks__raw_mesh *raw);

/* The whole file at path, or the size bytes at data, read into *raw by
 * the reader its name or content picks (format: phks_format; AUTO sniffs
 * the content), gzip inflated first. Errors as the readers' (the caller
 * adds the file name). From memory, data of more than max_bytes (after
 * inflating; SIZE_MAX: no limit but gzip's built-in one) is refused with
 * PHKS_ERROR_TOO_LARGE before it is parsed. */
phks_status phks__raw_mesh_read_file(const char *path, phks__raw_mesh *raw);
phks_status phks__raw_mesh_read_memory(const void *data, size_t size,
                                      phks_format format, size_t max_bytes,
                                      phks__raw_mesh *raw);

#endif /* PHKS_IO_H */
