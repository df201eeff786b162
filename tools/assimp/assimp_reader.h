/*
 * assimp_reader.h - meshes from the formats of the Open Asset Import Library
 * (assimp: glTF/GLB, FBX, COLLADA, 3DS, X3D, ...), read into arrays and
 * handed to phks_mesh_create. The library itself reads OFF, OBJ, PLY and
 * STL and stays free of assimp (and of C++); this adapter is linked into the
 * `phks` tool and into the Python module (tools/assimp/meson.build), and
 * depends on the public header only. Built with -DPHKS_WITH_ASSIMP when meson finds
 * assimp; without it, the formats are recognised by their extension and
 * refused with "built without assimp: cannot read .EXT". A gzip'd scene
 * ("shape.glb.gz") is inflated here (to 2 GiB at most) and read under its
 * name without ".gz", the files it refers to found beside it.
 *
 * Vertex numbering: the vertices of the scene's meshes concatenated, in
 * scene order (the node tree depth first, parents before children, each
 * node's meshes in its order; a mesh that several nodes use comes once per
 * node), after assimp's triangulation and joining of identical vertices,
 * with each node's transform (and its parents') applied. Meshes of points
 * or lines only are skipped.
 */
#ifndef PHKS_ASSIMP_READER_H
#define PHKS_ASSIMP_READER_H

#include <stddef.h>

#include "phks.h"

/* 1 when the build has assimp. */
int assimp_reader_available(void);
/* 1 when path is for assimp: its extension is none of the library's own
 * (.off, .obj, .ply, .stl, each optionally followed by .gz) and names,
 * before a final .gz if any, a format that assimp reads (without assimp:
 * assimp_reader_common, so that the refusal can say why). Other names stay
 * with phks_mesh_load, which recognises the content. */
int assimp_reader_handles(const char *path);
/* 1 when path ends in the extension of one of assimp's common formats
 * (.gltf, .glb, .fbx, .dae, .3ds, .x3d, .blend, ...: the list in
 * assimp_reader.c), optionally followed by .gz, whether or not the build
 * has assimp. */
int assimp_reader_common(const char *path);
/* Reads the scene at path into *mesh: all its meshes merged into one shape,
 * or, with `object`, those of the nodes named so (and of their children)
 * and the meshes named so. Thread-safe. On success PHKS_OK; `note` (when
 * not NULL) gets "N meshes (a, b, ...) merged into one shape" when several
 * were merged without `object`, else "". On failure a status (PHKS_ERROR_IO,
 * PHKS_ERROR_UNKNOWN_FORMAT without assimp, PHKS_ERROR_PARSE for assimp's
 * and zlib's refusals, PHKS_ERROR_TRUNCATED for a gzip'd file cut short,
 * PHKS_ERROR_TOO_LARGE for one that inflates past 2 GiB,
 * PHKS_ERROR_INVALID_ARGUMENT for an unknown `object`,
 * PHKS_ERROR_NO_TRIANGLES, or phks_mesh_create's) and the reason, without
 * the file's name, in err. */
phks_status assimp_reader_load(const char *path, const char *object,
                            phks_mesh **mesh, char *note, size_t note_size,
                            char *err, size_t err_size);

#endif
