/*
 * fuzz_common.h - what every fuzz target checks. Each target is one
 * LLVMFuzzerTestOneInput; the same source is built with libFuzzer (fuzz/,
 * clang) and with the replay driver tests/fuzz_replay.c (the test suite,
 * any compiler), which runs the committed corpora as regression tests.
 *
 * A failed check prints what failed and aborts, which libFuzzer reports as
 * a crash with the input that caused it and the replay test as a failure.
 * Checks never use assert(): release builds define NDEBUG.
 */
#ifndef PHKS_FUZZ_COMMON_H
#define PHKS_FUZZ_COMMON_H

#include "features/features.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define FUZZ_CHECK(c)                                                         \
    do {                                                                      \
        if (!(c)) {                                                           \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__,  \
                    #c);                                                      \
            abort();                                                          \
        }                                                                     \
    } while (0)

/* Empties the thread's error message, so that a failure can be checked
 * for leaving one of its own. */
static inline void fuzz_clear_message(void)
{
    (void)phks__fail(PHKS_OK, "%s", "");
}

/* A failing call returns a known status and says why. */
static inline void fuzz_check_failure(phks_status st)
{
    if (st <= PHKS_OK || st > PHKS_ERROR_SOLVER)
        fprintf(stderr, "status %d\n", (int)st);
    FUZZ_CHECK(st > PHKS_OK && st <= PHKS_ERROR_SOLVER);
    FUZZ_CHECK(phks_last_error_message()[0] != '\0');
}

/* A heap copy of exactly size bytes, so that the sanitizers see any read
 * past the end (libFuzzer's own buffer is exact too; the replay driver's
 * is not necessarily). */
static inline char *fuzz_copy(const uint8_t *data, size_t size)
{
    char *copy = malloc(size ? size : 1);
    FUZZ_CHECK(copy != NULL);
    if (size)
        memcpy(copy, data, size);
    return copy;
}

/* What a reader returns on success: at least one triangle, indices in
 * range, finite coordinates, and origins (when the reader welds) strictly
 * increasing. On failure every pointer is NULL. */
static inline void fuzz_check_raw(phks_status st, const phks__raw_mesh *raw)
{
    if (st != PHKS_OK) {
        fuzz_check_failure(st);
        FUZZ_CHECK(raw->xyz == NULL && raw->triangles == NULL &&
                   raw->vertex_origin == NULL);
        return;
    }
    FUZZ_CHECK(raw->triangle_count > 0 && raw->triangles != NULL);
    FUZZ_CHECK(raw->vertex_count <= (size_t)UINT32_MAX - 1);
    FUZZ_CHECK(raw->vertex_count == 0 || raw->xyz != NULL);
    for (size_t i = 0; i < 3 * raw->vertex_count; i++)
        FUZZ_CHECK(isfinite(raw->xyz[i]));
    for (size_t i = 0; i < 3 * raw->triangle_count; i++)
        FUZZ_CHECK(raw->triangles[i] < raw->vertex_count);
    if (raw->vertex_origin)
        for (size_t v = 1; v < raw->vertex_count; v++)
            FUZZ_CHECK(raw->vertex_origin[v - 1] < raw->vertex_origin[v]);
}

/* The index in raw of the vertex whose origin is `origin`. */
static inline size_t fuzz_raw_index(const phks__raw_mesh *raw, uint32_t origin)
{
    if (!raw->vertex_origin) {
        FUZZ_CHECK(origin < raw->vertex_count);
        return origin;
    }
    size_t lo = 0, hi = raw->vertex_count; /* origins ascend */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (raw->vertex_origin[mid] < origin)
            lo = mid + 1;
        else
            hi = mid;
    }
    FUZZ_CHECK(lo < raw->vertex_count && raw->vertex_origin[lo] == origin);
    return lo;
}

/* A cleaned mesh: consistent counts, every index in range, no triangle
 * with a repeated corner, every vertex used, finite coordinates, origins
 * ascending, a positive finite area, boundary edges and components in
 * range. With raw (the reader's output it was built from, or NULL), each
 * vertex must also be the raw vertex its origin names. */
static inline void fuzz_check_mesh(const phks_mesh *mesh,
                                   const phks__raw_mesh *raw)
{
    size_t n = phks_mesh_vertex_count(mesh), t = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    const uint32_t *origin = phks_mesh_vertex_origin(mesh);
    FUZZ_CHECK(n >= 3 && t >= 1 && n <= 3 * t);
    FUZZ_CHECK(xyz && tri && origin);
    if (raw) {
        FUZZ_CHECK(n <= raw->vertex_count);
        FUZZ_CHECK(t <= raw->triangle_count);
    }
    for (size_t i = 0; i < 3 * n; i++)
        FUZZ_CHECK(isfinite(xyz[i]));
    unsigned char *used = calloc(n, 1);
    FUZZ_CHECK(used != NULL);
    for (size_t i = 0; i < t; i++) {
        const uint32_t *c = tri + 3 * i;
        FUZZ_CHECK(c[0] < n && c[1] < n && c[2] < n);
        FUZZ_CHECK(c[0] != c[1] && c[1] != c[2] && c[0] != c[2]);
        used[c[0]] = used[c[1]] = used[c[2]] = 1;
    }
    for (size_t v = 0; v < n; v++) {
        FUZZ_CHECK(used[v]);
        FUZZ_CHECK(v == 0 || origin[v - 1] < origin[v]);
        if (raw) {
            size_t k = fuzz_raw_index(raw, origin[v]);
            FUZZ_CHECK(memcmp(xyz + 3 * v, raw->xyz + 3 * k,
                              3 * sizeof *xyz) == 0);
        }
    }
    free(used);
    double area = phks_mesh_area(mesh);
    FUZZ_CHECK(isfinite(area) && area > 0);

    size_t b = phks_mesh_boundary_edge_count(mesh);
    const uint32_t *edges = phks_mesh_boundary_edges(mesh);
    FUZZ_CHECK(b <= 3 * t);
    for (size_t e = 0; e < b; e++) {
        FUZZ_CHECK(edges[2 * e] < edges[2 * e + 1] && edges[2 * e + 1] < n);
        if (e > 0) /* sorted, lower index first */
            FUZZ_CHECK(edges[2 * e - 2] < edges[2 * e] ||
                       (edges[2 * e - 2] == edges[2 * e] &&
                        edges[2 * e - 1] < edges[2 * e + 1]));
    }
    size_t components = phks_mesh_component_count(mesh);
    const uint32_t *component = phks_mesh_vertex_components(mesh);
    FUZZ_CHECK(components >= 1 && components <= n / 3);
    uint32_t next = 0; /* numbered in order of lowest vertex */
    for (size_t v = 0; v < n; v++) {
        FUZZ_CHECK(component[v] <= next && component[v] < components);
        if (component[v] == next)
            next++;
    }
    FUZZ_CHECK(next == components);
}

/* Runs one reader on an exact copy of the input, checks what it returns,
 * and builds a mesh from it as the loader would. */
static inline void fuzz_reader(phks_status (*reader)(const char *, size_t,
                                                     phks__raw_mesh *),
                               const uint8_t *data, size_t size)
{
    char *copy = fuzz_copy(data, size);
    phks__raw_mesh raw;
    memset(&raw, 0xA5, sizeof raw); /* the reader must set every field */
    fuzz_clear_message();
    phks_status st = reader(copy, size, &raw);
    fuzz_check_raw(st, &raw);
    if (st == PHKS_OK) {
        phks_mesh *mesh = NULL;
        fuzz_clear_message();
        st = phks__mesh_build(raw.xyz, raw.vertex_count, raw.triangles,
                             raw.triangle_count, raw.vertex_origin, &mesh);
        if (st == PHKS_OK)
            fuzz_check_mesh(mesh, &raw);
        else
            fuzz_check_failure(st);
        phks_mesh_free(mesh);
    }
    phks__raw_mesh_release(&raw);
    free(copy);
}

/* The public loader on an exact copy: a mesh exactly when PHKS_OK. */
static inline void fuzz_load(const uint8_t *data, size_t size,
                             phks_format format)
{
    char *copy = fuzz_copy(data, size);
    phks_mesh *mesh = (phks_mesh *)&mesh; /* must be reset */
    fuzz_clear_message();
    phks_status st = phks_mesh_load_memory(copy, size, format, &mesh);
    if (st == PHKS_OK) {
        FUZZ_CHECK(mesh != NULL);
        fuzz_check_mesh(mesh, NULL);
    } else {
        fuzz_check_failure(st);
        FUZZ_CHECK(mesh == NULL);
    }
    phks_mesh_free(mesh);
    free(copy);
}

#endif /* PHKS_FUZZ_COMMON_H */
